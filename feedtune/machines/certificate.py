"""The certificate of a gains file over several measured FRFs: the limits checked on each, and the worst case.

A design is certified by the same analysis ``feedtune analyze GAINS --frf F`` runs, once per FRF
(:func:`feedtune.machines.analyze_gains` on the gains document as written, so the certificate checks what a target
loads, not the tuner's internal candidate): in the ``discrete`` case (zero-order hold, computational delay, the
controller at its sample rate, the FRF continued below its band with the model) every limit of the policy, and
Nyquist stability in every case. Per FRF it lists what identifies the FRF (:class:`FrfSource`: the SHA-256 of its
file's bytes, or of its arrays when it came from memory), every figure of the checked case's metrics (their
``to_dict()``: crossovers, phase and gain margins, the disk margin, the peak sensitivity and where, the bands where
``|S| < 1``, stability, and whatever the analysis adds), every limit item and the one closest to binding, and for a
conditionally stable loop the saturation headroom its gain-reduction margin implies
(:func:`feedtune.analysis.limits.saturation_overdrive`); the worst case is the minimum or maximum of each figure over
the FRFs, with the FRF it occurs on.

The certificate travels in the gains file (``[certificate]``, :mod:`feedtune.io.gains_certificate`) with the digest
of the gains it certifies. :func:`gains_verdict` is the one verdict ``feedtune analyze``, ``export c`` and the report
give a gains file: the certificate made anew on the FRFs given, else the file's own certificate while it holds for
its gains (its stored figures judged under the policy asked for, exactly as :meth:`Limits.check` judges live ones),
else the check on what is known (the design model), with what would certify it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..analysis.limits import (
    DEFAULT_LIMITS,
    LimitCheck,
    LimitItem,
    Limits,
    check_analysis,
    saturation_overdrive,
    split_gain_margins,
)

UNCERTIFIED_HINT = "tune or design with --frf, or pass --frf to {command}"
"""What would certify a gains file (``{command}``: the command that refused it)."""


# ------------------------------------------------------------------------------------------ the FRFs
@dataclass(frozen=True)
class FrfSource:
    """A measured FRF and what identifies it.

    Attributes
    ----------
    name : str
        Its name (the file name as given, or a name for an FRF made in memory).
    frf : Frf
    sha256 : str
        SHA-256 (hex) of the file's bytes (``identity = "file"``) or of the FRF's arrays (``"arrays"``,
        :func:`feedtune.io.gains_certificate.frf_arrays_sha256`).
    identity : str
        ``file`` or ``arrays``.
    arrays_sha256 : str
        SHA-256 of the FRF's arrays in every case: the same measurement in another file format, or written to a file
        after it was certified from memory, is recognised by it.
    """

    name: str
    frf: object = field(repr=False)
    sha256: str
    identity: str
    arrays_sha256: str = ""

    def __post_init__(self) -> None:
        if not self.arrays_sha256:
            from ..io.gains_certificate import frf_arrays_sha256

            object.__setattr__(self, "arrays_sha256", frf_arrays_sha256(self.frf))

    @classmethod
    def from_file(cls, path, frf, name: str | None = None) -> FrfSource:
        """The FRF read from ``path``, identified by the SHA-256 of the file's bytes (read once more here).

        An FRF argument that is not one plain file (pieces joined with ``+``, or ``FILE:OUT/IN,scale=...``: its
        arrays are not the file's) is identified by its arrays (:meth:`from_memory`), named as typed."""
        import os

        from ..io.gains_certificate import file_sha256

        label = str(path) if name is None else name
        if not os.path.isfile(path):
            return cls.from_memory(label, frf)
        return cls(label, frf, file_sha256(path), "file")

    @classmethod
    def from_memory(cls, name: str, frf) -> FrfSource:
        """An FRF that never was a file (a twin's measurement), identified by the SHA-256 of its arrays."""
        from ..io.gains_certificate import frf_arrays_sha256

        digest = frf_arrays_sha256(frf)
        return cls(str(name), frf, digest, "arrays", digest)

    def to_dict(self) -> dict:
        """``{"frf", "sha256", "identity", "arrays_sha256"}``."""
        return {"frf": self.name, "sha256": self.sha256, "identity": self.identity,
                "arrays_sha256": self.arrays_sha256}


def frf_sources(frfs: Sequence) -> tuple[FrfSource, ...]:
    """``FrfSource`` of each entry: an :class:`FrfSource` as given, a ``(name, Frf)`` pair identified by its arrays
    (give :meth:`FrfSource.from_file` for an FRF read from a file)."""
    out = []
    for item in frfs:
        if isinstance(item, FrfSource):
            out.append(item)
        else:
            name, frf = item
            out.append(FrfSource.from_memory(name, frf))
    return tuple(out)


class _Figures:
    """Attribute access to a stored FRF entry's figures (the keys of the metrics' ``to_dict()``), so that
    :meth:`Limits.check` judges stored figures exactly as it judges live metrics. TOML has no null: an absent figure
    reads None, an absent disk margin infinite (written as None when infinite)."""

    def __init__(self, entry: Mapping):
        self._entry = entry

    def __getattr__(self, name: str):
        v = self._entry.get(name)
        if v is None and name == "disk_margin":
            return float("inf")
        if v is None and name in ("phase_margins", "gain_margins", "crossovers_hz"):
            return []
        if v is None and name == "nyquist_reliable":
            return True
        return v

    def to_dict(self) -> dict:
        return dict(self._entry)


# ------------------------------------------------------------------------------------------ one FRF
VERDICT_KEYS = ("frf", "sha256", "identity", "arrays_sha256", "checked_case", "ok", "items", "active_limit",
                "violations", "gm_increase_db", "gm_reduction_db", "saturation", "pm_deg", "gm_db")
"""Keys of a certificate's FRF entry that are its verdict (the rest are the checked case's figures)."""


@dataclass(frozen=True)
class FrfCertificate:
    """The check of one design on one FRF.

    Attributes
    ----------
    name : str
        The FRF (its file name), ``model`` for the check on the design model alone.
    checked_case : str
        ``discrete`` (the limits' case; ``ideal_discrete`` on the model).
    check : LimitCheck
        Every limit in the checked case and stability in every case.
    metrics : object
        The checked case's :class:`~feedtune.analysis.loop.LoopMetrics` (or MIMO metrics); for a stored certificate
        a view of its stored figures.
    analysis : object
        The whole analysis on this FRF (for figures; not in :meth:`to_dict`); None for a stored certificate.
    source : FrfSource or dict or None
        What identifies the FRF (a stored certificate: its ``{"frf", "sha256", "identity", "arrays_sha256"}``);
        None on the model.
    result : dict or None
        The ``feedtune analyze --json`` result of the gains on this FRF (without the check).
    """

    name: str
    checked_case: str
    check: LimitCheck
    metrics: object
    analysis: object = None
    source: object = None
    result: dict | None = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """Every limit met and stable in every case."""
        return self.check.ok

    def saturation(self) -> dict | None:
        """For a conditionally stable loop (a gain-reduction margin): the margin [dB], where [Hz], and how far a
        saturating command may exceed its limit before the loop's effective gain falls that far (describing
        function); None without a gain-reduction margin."""
        down = split_gain_margins(self.metrics.gain_margins)[1]
        if down is None:
            return None
        a = saturation_overdrive(down[0])
        return {"gain_reduction_margin_db": down[0], "freq_hz": down[1], "overdrive_ratio": a,
                "text": f"stays stable while the command exceeds its limit by at most {a:.3g} x (describing function "
                        f"of a saturation against the {down[0]:.3g} dB gain-reduction margin at {down[1]:.4g} Hz)"}

    def to_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """JSON-ready: what identifies the FRF, the verdict (``ok``, ``violations``, every limit item, the active
        limit, the saturation headroom) and every figure of the checked case (its metrics' ``to_dict()``, units in
        the keys). ``names`` calls each limit in the violations by its option (the command line's)."""
        m = self.metrics
        figures = {k: v for k, v in m.to_dict().items() if k not in VERDICT_KEYS}
        src = self.source.to_dict() if isinstance(self.source, FrfSource) else dict(self.source or {})
        up, down = split_gain_margins(m.gain_margins)
        active = self.check.active()
        return {
            "frf": self.name, **{k: v for k, v in src.items() if k != "frf"},
            "checked_case": self.checked_case, "ok": self.ok, "violations": self.check.violations_named(names),
            "active_limit": None if active is None else active.to_dict(),
            "items": [i.to_dict() for i in self.check.items],
            "pm_deg": m.phase_margin_deg, "gm_db": m.gain_margin_db,
            "gm_increase_db": None if up is None else up[0], "gm_reduction_db": None if down is None else down[0],
            "saturation": self.saturation(),
            **figures,
        }


def _stored_item(d: Mapping) -> LimitItem:
    """A stability item of a stored certificate (TOML drops its null entries)."""
    return LimitItem(str(d["name"]), d.get("value"), d.get("limit"), bool(d["ok"]), str(d.get("case", "")),
                     d.get("freq_hz"))


def judge_entry(entry: Mapping, limits: Limits) -> LimitCheck:
    """The check of a stored FRF entry under ``limits``: the checked case's stored figures judged by
    :meth:`Limits.check` (as :func:`~feedtune.analysis.limits.check_cases` judges live metrics), the other cases'
    stability as stored, in the stored order."""
    checked = entry.get("checked_case")
    items: list[LimitItem] = []
    for d in entry.get("items") or []:
        if d.get("name") != "stable":
            continue
        if d.get("case") == checked:
            items += limits.check(_Figures(entry), checked)
        else:
            items.append(_stored_item(d))
    if not any(i.case == checked for i in items):
        items += limits.check(_Figures(entry), str(checked))
    return LimitCheck(limits, items)


# ------------------------------------------------------------------------------------------ every FRF
@dataclass(frozen=True)
class Certificate:
    """A design checked on every given FRF.

    Attributes
    ----------
    limits : Limits
    frfs : tuple of FrfCertificate
    """

    limits: Limits
    frfs: tuple[FrfCertificate, ...]

    @property
    def ok(self) -> bool:
        """The limits hold on every FRF."""
        return all(c.ok for c in self.frfs)

    @property
    def on_frfs(self) -> bool:
        """Checked on measured FRFs (not on the design model alone)."""
        return bool(self.frfs) and all(c.source is not None for c in self.frfs)

    @classmethod
    def from_section(cls, section: Mapping, limits: Limits | None = None) -> Certificate:
        """A stored ``[certificate]`` (:mod:`feedtune.io.gains_certificate`) judged under ``limits`` (default: the
        limits it was made under): each FRF's stored figures through :func:`judge_entry`."""
        policy = limits or Limits.from_dict(section.get("limits") or {})
        out = []
        for e in section.get("frfs") or []:
            src = {k: e[k] for k in ("frf", "sha256", "identity", "arrays_sha256") if k in e}
            out.append(FrfCertificate(str(e["frf"]), str(e.get("checked_case", "discrete")), judge_entry(e, policy),
                                      _Figures(e), None, src))
        return cls(policy, tuple(out))

    def violations(self, names: Mapping[str, str] | None = None) -> list[str]:
        """Every violated limit, each prefixed by its FRF (``a.csv: ...``; not on the design model), limits called
        by ``names``."""
        return [f"{c.name}: {v}" if c.source is not None else v for c in self.frfs
                for v in c.check.violations_named(names)]

    def worst(self) -> dict:
        """The worst of each figure over the FRFs [Hz, -, deg, dB] and the FRF it occurs on.

        ``first_crossover_hz`` is the lowest first crossover (the bandwidth the design guarantees on every FRF);
        ``ms`` the highest peak sensitivity; ``pm_deg``, ``disk_margin`` the smallest (absolute) margins; ``gm_db``
        the smallest gain-increase margin and ``gm_low_db`` the smallest gain-reduction margin (positive numbers);
        ``saturation_overdrive`` the smallest overdrive ratio a gain-reduction margin allows; ``active_limit`` the
        limit with the smallest slack over all FRFs (what stops a higher bandwidth).
        """
        def pick(key, fn, best):
            vals = [(fn(c), c.name) for c in self.frfs if fn(c) is not None]
            if not vals:
                return {key: None, f"{key}_frf": None}
            v, name = best(vals, key=lambda t: t[0])
            return {key: v, f"{key}_frf": name}

        def first(c):
            return float(c.metrics.crossovers_hz[0]) if c.metrics.crossovers_hz else None

        def pm(c):
            return None if c.metrics.phase_margin_deg is None else abs(float(c.metrics.phase_margin_deg))

        def margin(k):
            def get(c):
                m = split_gain_margins(c.metrics.gain_margins)[k]
                return None if m is None else m[0]
            return get

        def overdrive(c):
            s = c.saturation()
            return None if s is None else s["overdrive_ratio"]

        actives = [(c.check.active(), c.name) for c in self.frfs if c.check.active() is not None]
        active = min(actives, key=lambda t: t[0].slack) if actives else None
        return {"ok": self.ok, "stable": all(bool(c.metrics.stable) for c in self.frfs),
                **pick("first_crossover_hz", first, min), **pick("ms", lambda c: float(c.metrics.ms), max),
                **pick("pm_deg", pm, min), **pick("gm_db", margin(0), min), **pick("gm_low_db", margin(1), min),
                **pick("saturation_overdrive", overdrive, min),
                **pick("disk_margin", lambda c: float(c.metrics.disk_margin), min),
                "active_limit": None if active is None else {**active[0].to_dict(), "frf": active[1]}}

    def to_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """``{"ok", "limits", "frfs": [...], "worst": {...}}`` (``names``: see :meth:`FrfCertificate.to_dict`)."""
        return {"ok": self.ok, "limits": self.limits.to_dict(), "frfs": [c.to_dict(names) for c in self.frfs],
                "worst": self.worst()}

    def check_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """The verdict in the layout of a design's limit check (``--json``'s ``check``): ``violations`` and
        ``items`` of every FRF, each named by its FRF; ``active`` the limit closest to binding over all FRFs."""
        active = self.worst().get("active_limit")
        return {"checked_case": self.frfs[0].checked_case if self.frfs else None, "ok": self.ok,
                "limits": self.limits.to_dict(), "violations": self.violations(names),
                "items": [{**i.to_dict(), "frf": c.name} for c in self.frfs for i in c.check.items],
                "active": None if active is None else active["name"]}


def certify(doc: Mapping, where: str, frfs: Sequence, limits: Limits | None = None,
            known: Sequence[tuple[object, object]] = ()) -> Certificate:
    """Check a gains document on every FRF (module docstring).

    Parameters
    ----------
    doc : Mapping
        The gains document (any machine kind).
    where : str
        Its name in error messages.
    frfs : sequence of FrfSource or (str, Frf)
        The measured FRFs (a pair is identified by its arrays; ``("model", None)`` checks the design model alone);
        at least one.
    limits : Limits, optional
        The policy (default: ``textbook``).
    known : sequence of (Frf, analysis), optional
        Analyses of this same document already made by :func:`feedtune.machines.analyze_gains` (e.g. the report's
        analysis on the FRF of the design's position; ``None`` for the analysis on the model): used for the FRF that
        *is* (the same object) one of ``frfs`` instead of analysing it again.
    """
    from .gains import analyze_gains

    policy = limits or DEFAULT_LIMITS
    out = []
    for item in frfs:
        if not isinstance(item, FrfSource) and item[1] is None:
            name, frf, source = str(item[0]), None, None
        else:
            source = frf_sources([item])[0]
            name, frf = source.name, source.frf
        analysis = next((a for f, a in known if f is frf), None)
        result = None
        if analysis is None:
            done = analyze_gains(doc, where, frf)
            analysis, result = done.analysis, done.result
        check, case = check_analysis(analysis, policy)
        out.append(FrfCertificate(name, case, check, analysis.cases[case].metrics, analysis, source, result))
    return Certificate(policy, tuple(out))


def certificate_section(cert: Certificate, doc: Mapping, *, date: str | None = None) -> dict:
    """The ``[certificate]`` of a gains document certified on FRFs: the certificate, the digests of the gains it
    certifies (``doc`` without its certificate) and of each FRF, the date (UTC, ``YYYY-MM-DD``) and the version that
    made it (:mod:`feedtune.io.gains_certificate`)."""
    import datetime

    from .. import __version__
    from ..io.document import strip_none
    from ..io.gains_certificate import CERTIFICATE_FORMAT, gains_sha256, section_digests

    body = {k: v for k, v in doc.items() if k != "certificate"}
    day = date or datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    return strip_none({"format": CERTIFICATE_FORMAT, "made_by": f"feedtune {__version__}", "date": day,
                       "gains_sha256": gains_sha256(body), "sections_sha256": section_digests(body),
                       **cert.to_dict()})


# ------------------------------------------------------------------------------------------ the verdict of a file
@dataclass(frozen=True)
class GainsVerdict:
    """The verdict on a gains file: what it rests on, and the check.

    Attributes
    ----------
    basis : str
        ``frfs`` (a certificate made anew on the FRFs given), ``certificate`` (the file's own, still valid for its
        gains) or ``model`` (the design model alone: the file is not certified).
    certificate : Certificate
        The check (on the FRFs, the stored one re-judged, or on the model).
    stored : StoredCertificate
        The file's own certificate and whether it holds.
    notes : tuple of str
        What the user should know: an edited or undigested certificate ignored, how the FRFs given compare with the
        stored certificate's (by digest).
    """

    basis: str
    certificate: Certificate
    stored: object
    notes: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """The limits hold on what the verdict rests on."""
        return self.certificate.ok

    @property
    def certified(self) -> bool:
        """Resting on measured FRFs (given now, or the file's own certificate)."""
        return self.basis in ("frfs", "certificate")

    def basis_text(self) -> str:
        """One line: on what the verdict rests."""
        if self.basis == "certificate":
            return f"the file's certificate: {self.stored.basis()}"
        if self.basis == "frfs":
            names = ", ".join(f"{c.name} (sha256 {c.source.sha256[:12]})" for c in self.certificate.frfs)
            return f"a certificate made now on {names} under {self.certificate.limits.name} limits"
        return "the design model alone (not certified on a measured FRF)"

    def to_dict(self, names: Mapping[str, str] | None = None) -> dict:
        """``{"basis", "basis_text", "ok", "certificate", "stored_status", "notes"}``."""
        return {"basis": self.basis, "basis_text": self.basis_text(), "ok": self.ok,
                "certificate": self.certificate.to_dict(names), "stored_status": self.stored.status,
                "notes": list(self.notes)}


def compare_sources(stored, sources: Sequence[FrfSource]) -> list[str]:
    """How the FRFs given compare with those of a stored certificate, by digest (one line each): the same file, the
    same arrays (the measurement in another file or format), or not among them."""
    if stored.status == "absent":
        return []
    lines, matched = [], set()
    for s in sources:
        same = next((e for e in stored.frfs if e.get("sha256") == s.sha256), None)
        how = "file" if same is not None else "arrays"
        same = same or next((e for e in stored.frfs if s.arrays_sha256 and s.arrays_sha256 in
                             (e.get("arrays_sha256"), e.get("sha256"))), None)
        if same is None:
            lines.append(f"{s.name}: not among the FRFs of the file's certificate (sha256 {s.sha256[:12]})")
            continue
        matched.add(id(same))
        what = "the same file as" if how == "file" and same.get("identity") != "arrays" else "the same arrays as"
        lines.append(f"{s.name}: {what} the file's certificate's {same.get('frf')} (sha256 {s.sha256[:12]})")
    missing = [str(e.get("frf")) for e in stored.frfs if id(e) not in matched]
    if missing:
        lines.append("the file's certificate also covers " + ", ".join(missing) + " (not given now)")
    return lines


def gains_verdict(doc: Mapping, where: str, frfs: Sequence = (), limits: Limits | None = None, *,
                  known: Sequence[tuple[object, object]] = ()) -> GainsVerdict:
    """The one verdict on a gains document (module docstring).

    Parameters
    ----------
    doc : Mapping
        The gains document.
    where : str
        Its name in messages.
    frfs : sequence of FrfSource or (str, Frf)
        Measured FRFs to certify on now (the stored certificate is then only compared with them, by digest).
    limits : Limits, optional
        The policy (default ``textbook``); a stored certificate's figures are judged under it.
    known : sequence of (Frf or None, analysis)
        Analyses of the document already made (``None`` for the model analysis), used instead of analysing again.
    """
    from ..io.gains_certificate import read_certificate

    policy = limits or DEFAULT_LIMITS
    stored = read_certificate(doc, where)
    notes = [] if stored.status in ("valid", "absent") else [stored.problem()]
    if frfs:
        sources = frf_sources(frfs)
        cert = certify(doc, where, sources, policy, known=known)
        return GainsVerdict("frfs", cert, stored, tuple(notes + compare_sources(stored, sources)))
    if stored.valid:
        return GainsVerdict("certificate", Certificate.from_section(stored.section, policy), stored, tuple(notes))
    model = next((a for f, a in known if f is None), None)
    cert = certify(doc, where, [("model", None)], policy, known=[(None, model)] if model is not None else ())
    return GainsVerdict("model", cert, stored, tuple(notes))
