"""One limits policy for every verdict: peak sensitivity, phase margin, gain margin, disk margin, stability.

The same :class:`Limits` value is used by ``design``, ``analyze``, ``report``, the demos and the tuners, so a design
that one of them accepts is accepted by all. Profiles:

* ``textbook`` (the default): ``Ms <= 2.5``, every phase margin ``>= 30 deg``, every gain margin ``>= 6 dB`` in both
  directions: the gain may rise 6 dB (``gm_min_db``) and, in a conditionally stable loop, fall 6 dB
  (``gm_low_min_db``) before the loop reaches -1. Skogestad and Postlethwaite (*Multivariable Feedback Control*, 2nd
  ed., 2005, section 2.4.3) give ``GM > 2`` (6 dB) and ``PM > 30 deg`` as typical requirements; the thesis (section
  4.4.2, citing its reference [32]) says ``Ms`` "in practice should not be much larger than 1.5-2.5".
* ``thesis``: the thesis' own acceptance for its ball-screw comparison (section 3.3): "both controllers have phase
  margins of PM = 30 deg and maximum sensitivity values ``S_max <= 3.25``"; no gain-margin limit in either direction
  (its Ms alone keeps ``|L|`` off ``1 - 1/3.25`` .. ``1 + 1/3.25`` at every phase crossover: a gain-increase margin of
  at least 3.2 dB and a gain-reduction margin of at least 2.3 dB, which the profile states and does not tighten).

Every limit is checked on every crossover or phase crossover (the worst one decides) of every case a design is
checked on, and a design must be stable (Nyquist) in each of them.

**Two gain margins.** At a phase crossover where ``|L| < 1`` the gain margin ``-20 log10 |L|`` is positive: how far
the loop gain may *rise* (a gain-increase margin, ``gm_min_db``). Where ``|L| > 1`` it is negative: how far the gain
may *fall* before the loop reaches -1 (a gain-reduction margin of a conditionally stable loop, ``gm_low_min_db``):
MC-PPC with its integral action is such a loop by nature (type 3: three integrators, the phase starts at -270 deg).
A saturating actuator lowers the loop's effective gain, so the gain-reduction margin is also how far the command may
exceed its limit: :func:`saturation_overdrive` turns it into that overdrive ratio by the describing function of a
saturation, ``N(a) = (2/pi) (asin(1/a) + sqrt(1 - 1/a^2)/a)`` for ``a = A/u_max > 1``: the loop is predicted to stay
stable while ``N(a)`` stays above the gain factor ``10^(-GM_low/20)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UsageError
from .margins import PROOF_SIGMAS

LIKE_GM_MIN = type("LikeGmMin", (), {"__repr__": lambda self: "LIKE_GM_MIN"})()
"""Default of :attr:`Limits.gm_low_min_db`: the same limit as ``gm_min_db``."""
LIMIT_KEYS = ("ms_max", "pm_min_deg", "gm_min_db", "gm_low_min_db", "disk_margin_min")
"""The limits of a policy (:class:`Limits` fields)."""


@dataclass(frozen=True)
class LimitItem:
    """One limit compared with its value in one case.

    Attributes
    ----------
    name : str
        ``ms``, ``pm_deg``, ``gm_db`` (gain-increase margin), ``gm_low_db`` (gain-reduction margin, the value its
        magnitude), ``disk_margin``, ``stable`` or ``band_top`` (the loop at the last line of a
        measured FRF, small enough that the limits hold above the band if it rolls off there).
    value : float or None
        The design's value (the worst over crossovers) [-, deg, dB]; None when the loop has none (no crossover).
    limit : float or None
        The limit [-, deg, dB].
    ok : bool
    case : str
        Analysis case it was read from.
    freq_hz : float or None
        Where the value occurs [Hz].
    uncertainty : float
        How far the value may lie from the plant's by the FRF's line scatter there (:data:`PROOF_SIGMAS` 1-sigma
        scatters; same unit as the value; 0 for a figure that rests on no measured line): the limit is met only
        when the value meets it by more than this.
    """

    name: str
    value: float | None
    limit: float | None
    ok: bool
    case: str
    freq_hz: float | None = None
    uncertainty: float = 0.0

    @property
    def slack(self) -> float | None:
        """How far the value is inside the limit beyond its uncertainty, relative to the limit [-] (negative:
        violated or not proven)."""
        if self.value is None or self.limit is None or self.limit == 0:
            return None
        if self.name in ("ms", "band_top"):
            return (self.limit - self.value - self.uncertainty) / self.limit
        return (abs(self.value) - self.uncertainty - self.limit) / self.limit

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {"name": self.name, "value": self.value, "limit": self.limit, "ok": self.ok, "case": self.case,
                "freq_hz": self.freq_hz, "uncertainty": self.uncertainty, "slack": self.slack}


@dataclass(frozen=True)
class Limits:
    """Stability and robustness limits (module docstring).

    Attributes
    ----------
    ms_max : float or None
        Largest peak sensitivity ``max |S|`` (``max sigma_max(S)`` for a 2x2 loop) [-].
    pm_min_deg : float or None
        Smallest ``|phase margin|`` at any crossover [deg].
    gm_min_db : float or None
        Smallest gain-increase margin (a positive gain margin: ``|L| < 1`` at the phase crossover) [dB].
    disk_margin_min : float or None
        Smallest balanced disk margin ``alpha`` [-] (:mod:`feedtune.analysis.margins`).
    name : str
        Profile name, with ``+`` and the overridden keys when overridden.
    gm_low_min_db : float or None
        Smallest gain-reduction margin (the magnitude of a negative gain margin: ``|L| > 1`` at the phase crossover of
        a conditionally stable loop) [dB]. Not given: the same as ``gm_min_db`` (one ``|GM|`` limit both ways, as
        before the two were told apart).
    """

    ms_max: float | None = 2.5
    pm_min_deg: float | None = 30.0
    gm_min_db: float | None = 6.0
    disk_margin_min: float | None = None
    name: str = "textbook"
    gm_low_min_db: float | None = LIKE_GM_MIN  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.gm_low_min_db is LIKE_GM_MIN:
            object.__setattr__(self, "gm_low_min_db", self.gm_min_db)
        for key, low in (("ms_max", 1.0), ("pm_min_deg", 0.0), ("gm_min_db", 0.0), ("disk_margin_min", 0.0),
                         ("gm_low_min_db", 0.0)):
            v = getattr(self, key)
            if v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise UsageError(f"limit {key} must be a finite number, got {v!r}")
            if key == "ms_max" and not v > low:
                raise UsageError(f"limit ms_max must be > 1, got {v:g}")
            if key == "pm_min_deg" and not 0 <= v < 180:
                raise UsageError(f"limit pm_min_deg must be in [0, 180) deg, got {v:g}")
            if key in ("gm_min_db", "gm_low_min_db", "disk_margin_min") and not v >= low:
                raise UsageError(f"limit {key} must be >= 0, got {v:g}")
            if key == "disk_margin_min" and not v < 2:
                raise UsageError(f"limit disk_margin_min must be < 2, got {v:g}")
            object.__setattr__(self, key, float(v))

    def override(self, **values: float | None) -> Limits:
        """A copy with the given limits replaced (keys of the dataclass). ``None`` keeps the profile's value; ``0``
        for ``pm_min_deg``, ``gm_min_db``, ``gm_low_min_db`` or ``disk_margin_min`` removes that limit. The two gain
        margins are set apart: overriding ``gm_min_db`` leaves ``gm_low_min_db`` at the profile's value."""
        given = {k: v for k, v in values.items() if v is not None}
        if not given:
            return self
        unknown = set(given) - set(LIMIT_KEYS)
        if unknown:
            raise UsageError(f"unknown limit(s) {', '.join(sorted(unknown))}")
        name = self.name.split(" + ")[0] + " + " + ", ".join(sorted(given))
        given = {k: (None if k != "ms_max" and v == 0 else v) for k, v in given.items()}
        return replace(self, name=name, **given)

    def check(self, metrics, case: str) -> list[LimitItem]:
        """Compare the figures of one case with the limits.

        Parameters
        ----------
        metrics : LoopMetrics or MimoMetrics
            Figures of the case (``stable``, ``ms``, ``phase_margin_deg``, ``gain_margin_db``, ``disk_margin``).
        case : str
            Name of the case (reported).
        """
        items = [_stability(metrics, case)]
        if self.ms_max is not None:
            items.append(LimitItem("ms", float(metrics.ms), self.ms_max, metrics.ms <= self.ms_max, case,
                                   float(metrics.ms_freq_hz)))
        if self.pm_min_deg is not None:
            pm = metrics.phase_margin_deg
            f = _freq_of(metrics.phase_margins, "pm_deg", pm)
            items.append(LimitItem("pm_deg", pm, self.pm_min_deg, pm is None or abs(pm) >= self.pm_min_deg, case, f))
        up, down = proven_gain_margins(metrics.gain_margins)
        for name, limit, found in (("gm_db", self.gm_min_db, up), ("gm_low_db", self.gm_low_min_db, down)):
            if limit is not None:
                gm, f, u = found or (None, None, 0.0)
                items.append(LimitItem(name, gm, limit, gm is None or gm - u >= limit, case, f, u))
        if self.disk_margin_min is not None:
            dm = metrics.disk_margin
            items.append(LimitItem("disk_margin", dm, self.disk_margin_min, dm >= self.disk_margin_min, case,
                                   metrics.disk_margin_freq_hz))
        top = getattr(metrics, "band_top_loop_gain", None)
        if top is not None:
            allowed = 1.0 if self.ms_max is None else 1.0 - 1.0 / self.ms_max
            items.append(LimitItem("band_top", float(top), allowed, top <= allowed, case, metrics.band_top_hz))
        return items

    def to_dict(self) -> dict:
        """JSON-ready dict (units in the keys)."""
        return {"profile": self.name, "ms_max": self.ms_max, "pm_min_deg": self.pm_min_deg,
                "gm_min_db": self.gm_min_db, "gm_low_min_db": self.gm_low_min_db,
                "disk_margin_min": self.disk_margin_min}

    @classmethod
    def from_dict(cls, d: Mapping) -> Limits:
        """The limits of a :meth:`to_dict` dictionary (a stored certificate's, a ``--json`` result's); a dictionary
        written before the gain-reduction margin had its own limit has none (one ``|GM|`` limit both ways)."""
        extra = {"gm_low_min_db": d["gm_low_min_db"]} if "gm_low_min_db" in d else {}
        return cls(d.get("ms_max"), d.get("pm_min_deg"), d.get("gm_min_db"), d.get("disk_margin_min"),
                   str(d.get("profile", "custom")), **extra)

    def describe(self) -> str:
        """One line: ``textbook: Ms <= 2.5, PM >= 30 deg, GM >= 6 dB, gain-reduction GM >= 6 dB``."""
        parts = []
        if self.ms_max is not None:
            parts.append(f"Ms <= {self.ms_max:g}")
        if self.pm_min_deg is not None:
            parts.append(f"PM >= {self.pm_min_deg:g} deg")
        if self.gm_min_db is not None:
            parts.append(f"GM >= {self.gm_min_db:g} dB")
        if self.gm_low_min_db is not None:
            parts.append(f"gain-reduction GM >= {self.gm_low_min_db:g} dB")
        if self.disk_margin_min is not None:
            parts.append(f"disk margin >= {self.disk_margin_min:g}")
        return f"{self.name}: " + (", ".join(parts) if parts else "stability only")


def split_gain_margins(gain_margins) -> tuple[tuple[float, float] | None, tuple[float, float] | None]:
    """The worst gain-increase and the worst gain-reduction margin of ``[{"freq_hz", "gm_db"}]``.

    Returns
    -------
    (increase, reduction) : each ``(margin_db, freq_hz)`` or None
        ``increase``: the smallest positive gain margin (``|L| < 1`` at the phase crossover) [dB, Hz];
        ``reduction``: the magnitude of the negative gain margin closest to 0 (``|L| > 1``) [dB, Hz]. A phase
        crossover exactly on ``|L| = 1`` (0 dB) counts as both.
    """
    up = [(float(e["gm_db"]), float(e["freq_hz"])) for e in gain_margins or [] if e["gm_db"] >= 0]
    down = [(-float(e["gm_db"]), float(e["freq_hz"])) for e in gain_margins or [] if e["gm_db"] <= 0]
    return (min(up) if up else None), (min(down) if down else None)


def proven_gain_margins(gain_margins) -> tuple[tuple[float, float, float] | None,
                                                tuple[float, float, float] | None]:
    """The gain-increase and gain-reduction margins of ``[{"freq_hz", "gm_db"[, "sigma_db"]}]`` that come closest to
    their limits once their line uncertainty (:data:`PROOF_SIGMAS` ``sigma_db``) is taken off.

    Returns
    -------
    (increase, reduction) : each ``(margin_db, freq_hz, uncertainty_db)`` or None
        As :func:`split_gain_margins`, the margin whose ``margin - uncertainty`` is smallest.
    """
    def worst(sign: float):
        found = [(sign * float(e["gm_db"]), float(e["freq_hz"]), PROOF_SIGMAS * float(e.get("sigma_db") or 0.0))
                 for e in gain_margins or [] if sign * e["gm_db"] >= 0]
        return min(found, key=lambda m: (m[0] - m[2], m[0])) if found else None

    return worst(1.0), worst(-1.0)


def describing_function_saturation(a) -> np.ndarray:
    """Describing function of a unit saturation driven at ``a`` times its limit [-]: 1 for ``a <= 1``, else
    ``(2/pi) (asin(1/a) + sqrt(1 - 1/a^2)/a)`` (Gelb and Vander Velde, *Multiple-Input Describing Functions*,
    1968, table 2.3-1)."""
    a = np.asarray(a, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = 1.0 / np.maximum(a, 1.0)
        n = (2.0 / np.pi) * (np.arcsin(r) + np.sqrt(1.0 - r * r) * r)
    return np.where(a <= 1.0, 1.0, n)


def saturation_overdrive(gain_reduction_margin_db: float) -> float:
    """The overdrive ratio ``a = A / u_max`` at which a saturation's describing function falls to the loop's
    gain-reduction margin (module docstring): the command may exceed its limit by at most ``a`` times before the
    effective loop gain reaches the margin [-]; ``inf`` for an infinite margin, 1 for a margin of 0 dB.

    Parameters
    ----------
    gain_reduction_margin_db : float
        The magnitude of the negative gain margin [dB], >= 0.
    """
    from scipy.optimize import brentq

    g = 10.0 ** (-float(gain_reduction_margin_db) / 20.0)
    if not g < 1.0:
        return 1.0
    if g <= 0.0:
        return math.inf
    hi = 2.0
    while describing_function_saturation(hi) > g:  # N(a) ~ 4/(pi a) for large a: the root is below 4/(pi g) + 1
        hi *= 2.0
    return float(brentq(lambda a: float(describing_function_saturation(a)) - g, 1.0, hi, xtol=1e-12, rtol=1e-14))


def _freq_of(entries, key: str, value) -> float | None:
    for e in entries or []:
        if value is not None and e[key] == value:
            return float(e["freq_hz"])
    return None


PROFILES = {
    "textbook": Limits(2.5, 30.0, 6.0, None, "textbook", gm_low_min_db=6.0),
    "thesis": Limits(3.25, 30.0, None, None, "thesis", gm_low_min_db=None),
}
"""Named limit profiles (module docstring)."""

DEFAULT_LIMITS = PROFILES["textbook"]


def limits_profile(name: str) -> Limits:
    """The named profile (``textbook`` or ``thesis``)."""
    try:
        return PROFILES[str(name).strip().lower()]
    except KeyError:
        raise UsageError(f"unknown limits profile {name!r}; expected {' or '.join(PROFILES)}", parameter="limits") \
            from None


@dataclass(frozen=True)
class LimitCheck:
    """Every limit in every checked case, and the verdict.

    Attributes
    ----------
    limits : Limits
    items : list of LimitItem
    """

    limits: Limits
    items: list

    @property
    def ok(self) -> bool:
        """Every item within its limit."""
        return all(i.ok for i in self.items)

    @property
    def violations(self) -> list[str]:
        """One line per violated item."""
        return self.violations_named()

    def violations_named(self, names: dict | None = None) -> list[str]:
        """One line per violated item, each limit called by ``names[item.name]`` (e.g. a command-line option)
        instead of "the limit"."""
        return [_violation(i, (names or {}).get(i.name, "the limit")) for i in self.items if not i.ok]

    def active(self) -> LimitItem | None:
        """The limit closest to binding (smallest slack) over the checked cases, or None."""
        scored = [i for i in self.items if i.slack is not None]
        return min(scored, key=lambda i: i.slack) if scored else None

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        act = self.active()
        return {"ok": self.ok, "limits": self.limits.to_dict(), "violations": self.violations,
                "items": [i.to_dict() for i in self.items], "active": None if act is None else act.name}


def _stability(metrics, case: str) -> LimitItem:
    """Stable by a Nyquist count that came out close to an integer (an unreliable count is not a verdict)."""
    reliable = bool(getattr(metrics, "nyquist_reliable", True))
    return LimitItem("stable", None if reliable else 0.0, None, bool(metrics.stable) and reliable, case)


def _violation(i: LimitItem, limit: str = "the limit") -> str:
    where = f" at {i.freq_hz:.4g} Hz" if i.freq_hz is not None else ""
    if i.name == "stable" and i.value is not None:
        return (f"the Nyquist count is unreliable in the {i.case} case (winding far from an integer: the loop is "
                "not resolved or not closed); no stability verdict")
    if i.name == "stable":
        return f"closed loop is unstable in the {i.case} case"
    if i.name == "band_top":
        return (f"|L| = {i.value:.3g} at the FRF's last line{where} exceeds {i.limit:.3g} (1 - 1/Ms limit): above the "
                f"measured band the loop could break the limits ({i.case} case); measure a wider band")
    if i.name == "ms":
        return f"peak sensitivity Ms = {i.value:.3g}{where} exceeds {limit} {i.limit:g} ({i.case} case)"
    if i.name == "pm_deg":
        return f"phase margin {i.value:.3g} deg{where} is below {limit} {i.limit:g} deg ({i.case} case)"
    if i.name in ("gm_db", "gm_low_db") and i.value >= i.limit:
        what = "gain margin" if i.name == "gm_db" else "gain-reduction margin"
        return (f"{what} {i.value:.4g} dB{where} meets {limit} {i.limit:g} dB by less than its line uncertainty "
                f"{i.uncertainty:.2g} dB ({PROOF_SIGMAS:g} sigma of the FRF's scatter there; {i.case} case): the "
                "lines do not prove it")
    if i.name == "gm_db":
        return f"gain margin {i.value:.3g} dB{where} is below {limit} {i.limit:g} dB ({i.case} case)"
    if i.name == "gm_low_db":
        return (f"gain-reduction margin {i.value:.3g} dB{where} is below {limit} {i.limit:g} dB ({i.case} case; "
                f"a saturating command may exceed its limit by only {saturation_overdrive(i.value):.3g} x)")
    return f"disk margin {i.value:.3g}{where} is below {limit} {i.limit:g} ({i.case} case)"


def check_cases(limits: Limits, cases: dict, checked: list[str] | tuple[str, ...]) -> LimitCheck:
    """Check ``limits`` in the named cases of ``{name: metrics or None}`` (cases that are None are skipped) and
    stability in every case that exists."""
    items = []
    for name, m in cases.items():
        if m is None:
            continue
        if name in checked:
            items += limits.check(m, name)
        else:
            items.append(_stability(m, name))
    return LimitCheck(limits, items)


def check_analysis(analysis, limits: Limits) -> tuple[LimitCheck, str]:
    """Check an analysis of any machine (an object whose ``cases`` maps case names to results with ``metrics``, or
    None): the limits in ``discrete`` when it was analysed on an FRF, else in ``ideal_discrete``, in each of its loops
    (``analysis.loops``: the prefixes of their case names, a cascade's ``position_discrete``; one loop by default);
    stability in every case. Returns the check and the name of the checked case (of the first loop)."""
    metrics = {name: None if c is None else c.metrics for name, c in analysis.cases.items()}
    checked = "discrete" if metrics.get("discrete") is not None else "ideal_discrete"
    loops = [p + checked for p in getattr(analysis, "loops", ("",)) if metrics.get(p + checked) is not None]
    return check_cases(limits, metrics, loops or [checked]), checked
