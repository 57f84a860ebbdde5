"""One delivery exit: from a design (or a tuner's result) and its FRFs to a gains document, its certificate on every
FRF and the verdict.

Every path from a controller to a gains file goes through :func:`deliver`: ``feedtune design``, ``feedtune tune``,
both demos and library users. It builds the gains document of the design's controller structure (the registry of
structures, :mod:`feedtune.structures`, names its gains format and that format's document builder), certifies the
document *as written* on every FRF given (:func:`feedtune.machines.certificate.certify`: the analysis ``feedtune
analyze GAINS --frf F`` runs, so the certificate checks what a target loads), or on the design model alone when there
is none, and, when it was certified on measured FRFs, stores the certificate with the digests of its FRFs and of the
gains it certifies in the document's ``[certificate]`` (:func:`~feedtune.machines.certificate.certificate_section`).
The same design on the same FRFs under the same limits writes the same certificate whichever command made it.

Examples
--------
>>> from feedtune import read_frf, fit_ballscrew, design_mcppc, THESIS_FILTER_PACK
>>> from feedtune.machines.certificate import FrfSource
>>> frf = read_frf("examples/ballscrew_frf.csv")
>>> design = design_mcppc(fit_ballscrew([frf]).model, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
>>> delivery = deliver(design, [FrfSource.from_file("examples/ballscrew_frf.csv", frf)])
>>> delivery.certified, delivery.document["certificate"]["frfs"][0]["identity"]
(True, 'file')
>>> delivery.write("mcppc.toml")  # doctest: +SKIP

Adding a controller structure is one entry in :data:`feedtune.structures.CONTROLLERS` (naming its design class).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..analysis.limits import DEFAULT_LIMITS, Limits
from ..errors import DesignError, UsageError
from ..structures import ControllerStructure, controller_of, controllers, gains_format, resolve


# ------------------------------------------------------------------------------------------ structures
def structure_of(design) -> ControllerStructure:
    """The controller structure of a design (:func:`feedtune.structures.controller_of`); UsageError naming the
    known ones otherwise."""
    entry = controller_of(design)
    if entry is None:
        raise UsageError(f"deliver: {type(design).__name__} is not a design feedtune delivers; known: "
                         f"{', '.join(c.design.rpartition(':')[2] for c in controllers())}", parameter="design")
    return entry


# ------------------------------------------------------------------------------------------ the delivery
@dataclass(frozen=True)
class Delivery:
    """A design's gains document, its certificate on every FRF and the verdict.

    Attributes
    ----------
    design : object
        The design delivered (with its friction feedforward, when one was given).
    structure : ControllerStructure
        Its controller structure (:mod:`feedtune.structures`).
    document : dict
        The gains document as it is written; with a ``[certificate]`` when certified on measured FRFs.
    certificate : Certificate
        The check of the document as written on every FRF (on the design model alone without FRFs).
    target_violations : tuple of str
        Design targets the document misses (a given crossover and phase margin), when asked to check them.
    """

    design: object = field(repr=False)
    structure: ControllerStructure = field(repr=False)
    document: dict = field(repr=False)
    certificate: object
    target_violations: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """Every limit met and stable in every case on every FRF (and every target met)."""
        return self.certificate.ok and not self.target_violations

    @property
    def certified(self) -> bool:
        """Certified on measured FRFs (the document then carries the certificate)."""
        return self.certificate.on_frfs

    @property
    def result(self) -> dict:
        """The ``feedtune analyze --json`` result of the document on the first FRF (the model without FRFs)."""
        return self.certificate.frfs[0].result

    @property
    def analysis(self):
        """The analysis of the document on the first FRF (the model without FRFs)."""
        return self.certificate.frfs[0].analysis

    def violations(self, names: Mapping[str, str] | None = None) -> list[str]:
        """One line per violated limit (prefixed by its FRF when certified on FRFs) and per missed target; each
        limit called by ``names[item]`` (a command-line option) when given."""
        return self.certificate.violations(names) + list(self.target_violations)

    def check_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """The verdict in the layout of ``--json``'s ``check`` (:meth:`Certificate.check_dict`), with the targets."""
        out = self.certificate.check_dict(names)
        return {**out, "ok": self.ok, "violations": self.violations(names)}

    def to_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """JSON-ready: structure, gains kind, verdict, violations, the certificate and the document."""
        return {"structure": self.structure.name, "gains_kind": self.structure.gains_kind, "ok": self.ok,
                "certified": self.certified, "violations": self.violations(names),
                "certificate": self.certificate.to_dict(names), "document": self.document}

    def texts(self, stem: str) -> dict[str, str]:
        """``{stem.toml: TOML text, stem.json: JSON twin}`` of the document (for pipelines that write many files
        at once, all or none)."""
        from ..io import dumps_json, dumps_toml

        return {f"{stem}.toml": dumps_toml(self.document), f"{stem}.json": dumps_json(self.document)}

    def write(self, path: str | os.PathLike[str], *, force: bool = False, allow_failed: bool = False) -> list[Path]:
        """Write the document (``.toml`` with its JSON twin, or ``.json``), all or nothing.

        Raises
        ------
        DesignError
            The design fails (a limit, stability or a target) and ``allow_failed`` is False: nothing is written.
        UsageError
            The file exists and ``force`` is False.
        """
        from ..io import write_document

        if not self.ok and not allow_failed:
            raise DesignError("; ".join(self.violations()) + "; no gains file written (pass allow_failed=True to "
                              "write it anyway)", parameter="allow_failed")
        return write_document(path, self.document, force=force)

    def __repr__(self) -> str:
        where = ", ".join(c.name for c in self.certificate.frfs)
        verdict = "ok" if self.ok else f"FAILS ({len(self.violations())} violations)"
        return f"Delivery({self.structure.name} -> {self.structure.gains_kind} gains, on {where}: {verdict})"


def deliver(design, frfs: Sequence = (), limits: Limits | None = None, *, friction=None,
            friction_band: float | None = None, targets: tuple[float, float] | None = None,
            where: str = "design", date: str | None = None) -> Delivery:
    """The gains document of ``design``, certified on every FRF (module docstring).

    Parameters
    ----------
    design : object
        A design or a tuner's result of any controller structure (:data:`feedtune.structures.CONTROLLERS`).
    frfs : sequence of FrfSource or (str, Frf)
        The measured FRFs to certify on (:class:`~feedtune.machines.certificate.FrfSource` says what identifies
        each: the SHA-256 of its file, or of its arrays for a pair); a gantry FRF is checked at the table position
        it records. Empty: checked on the design model alone, and the document carries no certificate.
    limits : Limits, optional
        The policy (default ``textbook``).
    friction : StribeckFriction, optional
        Friction model to feed forward (its units are checked against the design's command unit).
    friction_band : float, optional
        Linear band of the friction feedforward around zero velocity (the friction model's velocity unit).
    targets : (float, float), optional
        The first crossover [Hz] and its phase margin [deg] the design was asked for, checked (1 Hz, 1 deg) in the
        design's own case (``design_dict()["checked_case"]``, else ``ideal_discrete``): a model case on the design
        model at the design position, a measured case on the first FRF.
    where : str
        Name of the document in messages.
    date : str, optional
        Date of the certificate (default: today, UTC, ``YYYY-MM-DD``).

    Returns
    -------
    Delivery
    """
    from ..machines.certificate import certificate_section, certify, frf_sources

    entry = structure_of(design)
    policy = limits or DEFAULT_LIMITS
    if friction is not None and hasattr(design, "with_friction"):
        design = design.with_friction(friction, v_band=friction_band)
    doc = resolve(gains_format(entry.gains_kind).document)(design)
    if friction is not None and not hasattr(design, "with_friction"):
        from ..io.gains import with_friction_feedforward

        doc = with_friction_feedforward(doc, friction, v_band=friction_band, where=where)
    sources = frf_sources(frfs)
    cert = certify(doc, where, sources or [("model", None)], policy)
    if sources:
        doc = {**doc, "certificate": certificate_section(cert, doc, date=date)}
    missed: tuple[str, ...] = ()
    if targets is not None:
        from ..analysis.gantry import target_violations
        from ..machines import analyze_gains

        design_record = design.design_dict() if hasattr(design, "design_dict") else {}
        case = design_record.get("checked_case") or "ideal_discrete"
        on_model = case.startswith("ideal") and sources  # the design model at the design position
        analysis = (analyze_gains(doc, where).result if on_model else cert.frfs[0].result)["analysis"]
        missed = tuple(target_violations(analysis.get(case), targets[0], targets[1], name=case))
    return Delivery(design, entry, doc, cert, missed)


__all__ = ["Delivery", "deliver", "structure_of"]
