"""Drive parameter sets of a cascade gains file, re-certified as exported, and read back (docs/drive_export.md).

:func:`export_drive` writes the target's parameter file (:mod:`.sinamics`, :mod:`.odrive`, :mod:`.linuxcnc_pid`,
:mod:`.ax8000`, :mod:`.yaskawa`),
reads the written text back into the law the target runs (its rates, its rounding, without what it cannot express),
certifies that law on the same FRFs as the file's own (:func:`feedtune.machines.certificate.certify`, the analysis
``feedtune analyze`` runs) and compares the two: max ``|dL|`` [dB, deg] of both loops up to the target's Nyquist
frequencies, ``dMs`` and the change of the first crossover. It refuses (DesignError, nothing returned to write) when
the target's law fails the limits. :func:`import_drive` reads a target's file into a cascade gains document.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ...errors import DataError, DesignError, UsageError
from . import ax8000, linuxcnc_pid, odrive, sinamics, yaskawa
from .common import DriveOptions, DriveText, TargetLaw, from_motor_frame

TARGETS = {sinamics.NAME: sinamics, odrive.NAME: odrive, linuxcnc_pid.NAME: linuxcnc_pid, ax8000.NAME: ax8000,
           yaskawa.NAME: yaskawa}
"""The drive targets by name."""
MOTOR_FRAME = (sinamics.NAME, odrive.NAME, ax8000.NAME, yaskawa.NAME)
"""Targets whose parameters are in the motor frame (rad, N m)."""


def target_module(name: str):
    """The module of target ``name`` (UsageError naming the known ones)."""
    if name not in TARGETS:
        raise UsageError(f"drive target {name!r}: expected one of {', '.join(TARGETS)}", parameter="target")
    return TARGETS[name]


def cascade_law_of(doc: Mapping, where: str):
    """``(law, plant)`` of a cascade gains document; a gains file of another kind refused in one line."""
    from ...io.cascade_gains import CASCADE_KIND
    from ...structures import controller_title

    kind = doc.get("kind") if isinstance(doc, Mapping) else None
    if kind != CASCADE_KIND:
        title = controller_title(doc.get("controller") if isinstance(doc, Mapping) else None)
        raise DataError(f"{where}: a {title} gains file (kind {kind!r}); drive parameter sets express the drive "
                        "cascade (feedtune tune cascade / design cascade); a one-encoder P-PI maps onto it exactly "
                        "only in continuous time (Kp = Kpv, Tn = Kpv/Kiv, Kv = Kpx): design that cascade and export it")
    from ...io.cascade_gains import cascade_from_document

    law, plant, _ = cascade_from_document(doc, where)
    return law, plant


# ------------------------------------------------------------------------------------------ the comparison
@dataclass(frozen=True)
class LoopChange:
    """How one loop changes from the file's law to the target's on one FRF.

    Attributes
    ----------
    loop : str
        ``speed`` or ``position``.
    frf : str
        The FRF (``model`` on the design model).
    up_to_hz : float
        The comparison's upper end: the lower of the two laws' Nyquist frequencies of this loop [Hz].
    dl_db, dl_deg : float
        Max ``|20 log10 |L_t / L||`` [dB] and ``|angle(L_t / L)|`` [deg] up to ``up_to_hz``.
    ms, ms_target : float
        Peak sensitivity of the file's and the target's loop [-].
    crossover_hz, crossover_target_hz : float or None
        First crossover of each [Hz].
    """

    loop: str
    frf: str
    up_to_hz: float
    dl_db: float
    dl_deg: float
    ms: float
    ms_target: float
    crossover_hz: float | None
    crossover_target_hz: float | None

    @property
    def dms(self) -> float:
        """``Ms_target - Ms``."""
        return self.ms_target - self.ms

    @property
    def dcrossover_hz(self) -> float | None:
        """Change of the first crossover [Hz] (None when one has none)."""
        if self.crossover_hz is None or self.crossover_target_hz is None:
            return None
        return self.crossover_target_hz - self.crossover_hz

    def to_dict(self) -> dict:
        """JSON-ready, units in the keys."""
        return {"loop": self.loop, "frf": self.frf, "up_to_hz": self.up_to_hz, "max_dl_db": self.dl_db,
                "max_dl_deg": self.dl_deg, "ms": self.ms, "ms_target": self.ms_target, "dms": self.dms,
                "first_crossover_hz": self.crossover_hz, "first_crossover_target_hz": self.crossover_target_hz,
                "dcrossover_hz": self.dcrossover_hz}

    def line(self) -> str:
        """One line of the comparison."""
        dc = "n/a" if self.dcrossover_hz is None else f"{self.dcrossover_hz:+.4g} Hz"
        return (f"{self.loop} loop on {self.frf}: max |dL| {self.dl_db:.3g} dB / {self.dl_deg:.3g} deg up to "
                f"{self.up_to_hz:.5g} Hz, dMs {self.dms:+.3g} (Ms {self.ms:.4g} -> {self.ms_target:.4g}), "
                f"d first crossover {dc}")


def _on_grid(case_from, case_to) -> np.ndarray:
    """``case_from.L`` on ``case_to.freq_hz`` (the same array when the grids agree; else real and imaginary parts
    interpolated in log frequency)."""
    f0, f1 = case_from.freq_hz, case_to.freq_hz
    if f0.shape == f1.shape and np.allclose(f0, f1, rtol=1e-12, atol=0):
        return case_from.L
    lf0, lf1 = np.log(f0), np.log(f1)
    return np.interp(lf1, lf0, case_from.L.real) + 1j * np.interp(lf1, lf0, case_from.L.imag)


def loop_change(loop: str, frf: str, case, case_target) -> LoopChange:
    """The :class:`LoopChange` between two analysed cases of the same loop (module docstring)."""
    top = min(case.freq_hz[-1], case_target.freq_hz[-1])
    keep = (case.freq_hz <= top) & (case.freq_hz >= case_target.freq_hz[0])
    lt = _on_grid(case_target, case)[keep]
    lo = case.L[keep]
    with np.errstate(divide="ignore", invalid="ignore"):
        r = lt / lo
    r = r[np.isfinite(r) & (r != 0)]
    db = float(np.max(np.abs(20 * np.log10(np.abs(r))))) if r.size else math.nan
    deg = float(np.max(np.abs(np.degrees(np.angle(r))))) if r.size else math.nan
    m, mt = case.metrics, case_target.metrics
    return LoopChange(loop, frf, float(top), db, deg, float(m.ms), float(mt.ms), m.first_crossover_hz,
                      mt.first_crossover_hz)


# ------------------------------------------------------------------------------------------ export
@dataclass(frozen=True)
class DriveExport:
    """A target's parameter file and its re-certification.

    Attributes
    ----------
    target : str
    written : DriveText
        The file's text, what it could not express, the parameters.
    target_doc : dict
        The law the target runs, rebuilt from the text, as a cascade gains document in the file's units.
    certificate, certificate_target : Certificate
        The file's law and the target's, on the same FRFs (or the design model).
    changes : tuple of LoopChange
        Per FRF and loop.
    notes : tuple of str
        What the target runs beside the certified law (ODrive's encoder PLL, with its lag).
    """

    target: str
    written: DriveText
    target_doc: dict = field(repr=False)
    certificate: object = field(repr=False)
    certificate_target: object = field(repr=False)
    changes: tuple[LoopChange, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """The target's law passes the limits on every FRF."""
        return self.certificate_target.ok

    def worst(self) -> dict:
        """The largest ``|dL|`` [dB, deg], ``|dMs|`` and ``|d first crossover|`` [Hz] over FRFs and loops."""
        def biggest(fn):
            vals = [abs(v) for v in map(fn, self.changes) if v is not None and math.isfinite(v)]
            return max(vals, default=None)
        return {"max_dl_db": biggest(lambda c: c.dl_db), "max_dl_deg": biggest(lambda c: c.dl_deg),
                "max_abs_dms": biggest(lambda c: c.dms), "max_abs_dcrossover_hz": biggest(lambda c: c.dcrossover_hz)}

    def to_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """JSON-ready."""
        return {"target": self.target, "ok": self.ok, "parameters": self.written.parameters,
                "dropped": list(self.written.dropped), "notes": list(self.notes),
                "changes": [c.to_dict() for c in self.changes], "worst": self.worst(),
                "violations": self.certificate_target.violations(names),
                "certificate_target": self.certificate_target.to_dict(names), "target_doc": self.target_doc}


def target_law(name: str, law, text: str, options: DriveOptions, where: str) -> TargetLaw:
    """The law target ``name`` runs from ``text``, in ``law``'s units (``law``: the file's, for what the text does
    not hold: the computational delay, the feedforward)."""
    mod = target_module(name)
    if name in MOTOR_FRAME:
        from .common import to_motor_frame

        base, _ = to_motor_frame(law, options, name)
        got = mod.read(text, where, options, base)
        back = from_motor_frame(got.law, law.command_unit, law.position_unit, options, name)
        return TargetLaw(back, got.notes, got.extras)
    return mod.read(text, where, options, law)


def export_drive(doc: Mapping, name: str, options: DriveOptions | None = None, frfs: Sequence = (), limits=None, *,
                 where: str = "gains file", as_json: bool = False) -> DriveExport:
    """Write ``doc``'s law for target ``name``, rebuild what the target runs from the text and certify it.

    Parameters
    ----------
    doc : Mapping
        A cascade gains document.
    name : str
        A key of :data:`TARGETS`.
    options : DriveOptions, optional
        Torque constant, lead, rates, output limit ... (what a conversion needs beyond the file).
    frfs : sequence of FrfSource or (str, Frf)
        The FRFs to certify both laws on; empty: the design model the file holds.
    limits : Limits, optional
        The policy (default ``textbook``).
    where : str
        The file's name in messages and in the written text.
    as_json : bool
        ODrive only: the backup-config JSON instead of odrivetool lines.

    Raises
    ------
    DesignError
        The target's law fails the limits (the line names what the target dropped and the first failed limit), or
        ODrive's encoder PLL differs from the PT2 the rebuilt law holds in its place by more than 1 deg at a
        crossover.
    """
    from ...io.cascade_gains import cascade_document
    from ...machines.certificate import certify

    options = options or DriveOptions()
    target_module(name)
    law, plant = cascade_law_of(doc, where)
    if not frfs and plant is None:
        raise DataError(f"{where}: the gains file holds no plant model ([model]); give the FRFs to certify on with "
                        "--frf")
    written = (odrive.write(law, options, where, as_json=as_json) if name == odrive.NAME
               else target_module(name).write(law, options, where))  # the options checked before any analysis
    sources = list(frfs) or [("model", None)]
    cert = certify(doc, where, sources, limits)
    notes: list[str] = []
    got = target_law(name, law, written.text, options, where)
    notes += got.notes
    design = {"structure": "cascade", "rests_on": f"the {name} parameters feedtune wrote from {where}, read back",
              "target": name, "dropped": list(written.dropped)}
    tdoc = cascade_document(got.law, plant, design)
    tcert = certify(tdoc, f"{where} as {name} runs it", sources, limits)
    changes = []
    for c, ct in zip(cert.frfs, tcert.frfs, strict=True):
        for prefix, loop in (("", "speed"), ("position_", "position")):
            case = c.analysis.cases.get(prefix + c.checked_case.removeprefix("position_"))
            case_t = ct.analysis.cases.get(prefix + ct.checked_case.removeprefix("position_"))
            if case is not None and case_t is not None:
                changes.append(loop_change(loop, c.name, case, case_t))
    if not tcert.ok:
        viol = tcert.violations()
        missing = ", ".join(d.partition(":")[0] for d in written.dropped)
        raise DesignError(f"{name}: {'without ' + missing + ', ' if missing else ''}the law the drive runs (speed "
                          f"loop at {got.law.fs:g} Hz, position loop at {got.law.fp:g} Hz) fails the limits: {viol[0]}"
                          f"{f' (and {len(viol) - 1} more)' if len(viol) > 1 else ''}; nothing written")
    if name == odrive.NAME:
        bw = got.extras["encoder_bandwidth"]
        cross = {"speed": _first(tcert, ""), "position": _first(tcert, "position_")}
        err = odrive.pll_model_error_deg(cross, bw, got.law.fs)
        notes.append(f"the encoder PLL differs from the rebuilt law's PT2 by at most {err:.3g} deg at the crossovers")
        if err > odrive.MAX_PLL_ERROR_DEG:
            raise DesignError(f"{name}: the encoder PLL (encoder.config.bandwidth {bw:g} rad/s) differs from the PT2 "
                              f"the certified law holds in its place by {err:.3g} deg at a crossover (more than "
                              f"{odrive.MAX_PLL_ERROR_DEG:g} deg): lower the loops' crossovers or raise "
                              "--encoder-bandwidth; nothing written", parameter="encoder_bandwidth")
    return DriveExport(name, written, tdoc, cert, tcert, tuple(changes), tuple(notes))


def _first(cert, prefix: str) -> float | None:
    """The first crossover [Hz] of a loop (``prefix``: its case names') in the first FRF's checked case."""
    c = cert.frfs[0]
    case = c.analysis.cases.get(prefix + c.checked_case.removeprefix("position_"))
    return None if case is None else case.metrics.first_crossover_hz


# ------------------------------------------------------------------------------------------ import
def import_drive(text: str, name: str, options: DriveOptions | None = None, *, where: str = "drive file",
                 plant=None) -> dict:
    """A cascade gains document of target ``name``'s file ``text``: in the motor frame (rad, N m) for the targets that
    take torques unless ``options`` give ``command_unit`` (A with the torque constant) or the lead (positions in m);
    LinuxCNC's in the pid's output unit per rad or m; with ``plant`` as its ``[model]`` when given."""
    from ...io.cascade_gains import cascade_document

    options = options or DriveOptions()
    mod = target_module(name)
    got = mod.read(text, where, options, None)
    law = got.law
    if name in MOTOR_FRAME and (options.command_unit or "N*m") != "N*m":
        law = from_motor_frame(law, options.command_unit, "rad" if options.lead_m is None else "m", options, name)
    elif name in MOTOR_FRAME and options.lead_m is not None:
        law = from_motor_frame(law, "N*m", "m", options, name)
    if plant is not None and (plant.command_unit != law.command_unit or plant.position_unit != law.position_unit):
        raise UsageError(f"the model is in {plant.position_unit} per {plant.command_unit}, the drive's law in "
                         f"{law.position_unit} per {law.command_unit}", parameter="model")
    design = {"structure": "cascade", "rests_on": f"the {name} parameter file {where}, read back",
              "target": name, "notes": list(got.notes), **{k: v for k, v in got.extras.items()}}
    return cascade_document(law, plant, design)


__all__ = ["TARGETS", "DriveExport", "DriveOptions", "LoopChange", "cascade_law_of", "export_drive",
           "import_drive", "loop_change", "target_law", "target_module"]
