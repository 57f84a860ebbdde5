"""The certificate of a gains file over several measured FRFs: the limits checked on each, and the worst case.

A tuned design is certified by the same analysis ``feedtune analyze GAINS --frf F`` runs, once per FRF
(:func:`feedtune.machines.analyze_gains` on the gains document as written, so the certificate checks what a target
loads, not the tuner's internal candidate): in the ``discrete`` case (zero-order hold, computational delay, the
controller at its sample rate, the FRF continued below its band with the model) every limit of the policy, and
Nyquist stability in every case. Per FRF it lists the crossovers, phase and gain margins, the disk margin, the peak
sensitivity and where, the bands where ``|S| < 1``, stability and the limit closest to binding; the worst case is the
minimum or maximum of each figure over the FRFs, with the FRF it occurs on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..analysis.limits import DEFAULT_LIMITS, LimitCheck, Limits, check_analysis


@dataclass(frozen=True)
class FrfCertificate:
    """The check of one design on one FRF.

    Attributes
    ----------
    name : str
        The FRF (its file name).
    checked_case : str
        ``discrete`` (the limits' case).
    check : LimitCheck
        Every limit in the checked case and stability in every case.
    metrics : object
        The checked case's :class:`~feedtune.analysis.loop.LoopMetrics` (or MIMO metrics).
    analysis : object
        The whole analysis on this FRF (for figures; not in :meth:`to_dict`).
    """

    name: str
    checked_case: str
    check: LimitCheck
    metrics: object
    analysis: object = None

    @property
    def ok(self) -> bool:
        """Every limit met and stable in every case."""
        return self.check.ok

    def to_dict(self) -> dict:
        """JSON-ready figures (units in the keys)."""
        m = self.metrics
        active = self.check.active()
        return {
            "frf": self.name, "checked_case": self.checked_case, "ok": self.ok, "stable": bool(m.stable),
            "crossovers_hz": [float(f) for f in m.crossovers_hz],
            "phase_margins": list(m.phase_margins), "gain_margins": list(m.gain_margins),
            "pm_deg": m.phase_margin_deg, "gm_db": m.gain_margin_db,
            "disk_margin": float(m.disk_margin), "disk_margin_freq_hz": m.disk_margin_freq_hz,
            "ms": float(m.ms), "ms_freq_hz": float(m.ms_freq_hz),
            "rejection_bands_hz": [list(map(float, b)) for b in m.rejection_bands_hz],
            "active_limit": None if active is None else active.to_dict(),
            "violations": self.check.violations,
        }


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

    def worst(self) -> dict:
        """The worst of each figure over the FRFs [Hz, -, deg, dB] and the FRF it occurs on.

        ``first_crossover_hz`` is the lowest first crossover (the bandwidth the design guarantees on every FRF);
        ``ms`` the highest peak sensitivity; ``pm_deg``, ``gm_db``, ``disk_margin`` the smallest (absolute) margins;
        ``active_limit`` the limit with the smallest slack over all FRFs (what stops a higher bandwidth).
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

        def gm(c):
            return None if c.metrics.gain_margin_db is None else abs(float(c.metrics.gain_margin_db))

        actives = [(c.check.active(), c.name) for c in self.frfs if c.check.active() is not None]
        active = min(actives, key=lambda t: t[0].slack) if actives else None
        return {"ok": self.ok, "stable": all(bool(c.metrics.stable) for c in self.frfs),
                **pick("first_crossover_hz", first, min), **pick("ms", lambda c: float(c.metrics.ms), max),
                **pick("pm_deg", pm, min), **pick("gm_db", gm, min),
                **pick("disk_margin", lambda c: float(c.metrics.disk_margin), min),
                "active_limit": None if active is None else {**active[0].to_dict(), "frf": active[1]}}

    def to_dict(self) -> dict:
        """``{"limits", "frfs": [...], "worst": {...}}``."""
        return {"limits": self.limits.to_dict(), "frfs": [c.to_dict() for c in self.frfs], "worst": self.worst()}


def certify(doc: Mapping, where: str, frfs: Sequence[tuple[str, object]], limits: Limits | None = None,
            known: Sequence[tuple[object, object]] = ()) -> Certificate:
    """Check a gains document on every FRF (module docstring).

    Parameters
    ----------
    doc : Mapping
        The gains document (any machine kind).
    where : str
        Its name in error messages.
    frfs : sequence of (str, Frf)
        The measured FRFs and their names; at least one.
    limits : Limits, optional
        The policy (default: ``textbook``).
    known : sequence of (Frf, analysis), optional
        Analyses of this same document already made by :func:`feedtune.machines.analyze_gains` (e.g. the report's
        analysis on the FRF of the design's position): used for the FRF that *is* (the same object) one of
        ``frfs`` instead of analysing it again.
    """
    from .registry import analyze_gains

    policy = limits or DEFAULT_LIMITS
    out = []
    for name, frf in frfs:
        analysis = next((a for f, a in known if frf is not None and f is frf), None)
        if analysis is None:
            analysis = analyze_gains(doc, where, frf).analysis
        check, case = check_analysis(analysis, policy)
        out.append(FrfCertificate(name, case, check, analysis.cases[case].metrics, analysis))
    return Certificate(policy, tuple(out))
