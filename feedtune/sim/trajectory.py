"""Jerk- and snap-limited point-to-point trajectories with exact derivatives (thesis §3.2.4, §3.4, §4.5).

The profile
-----------
A rest-to-rest move over a distance ``D`` has the velocity

.. math:: v(t) = D\\,(b_{T_1} * b_{T_2} * \\dots * b_{T_n})(t), \\qquad b_T = \\mathrm{rect}_{[0, T]} / T,

a convolution of ``n`` normalised boxes (``n = 3`` jerk-limited, ``n = 4`` snap-limited). With the widths
ordered so that every box is at least as wide as all narrower ones together,
``T_k >= T_{k+1} + ... + T_n``, the shifted copies in each derivative never overlap, so

* peak velocity ``D/T1``, peak acceleration ``D/(T1 T2)``, peak jerk ``D/(T1 T2 T3)`` and, for ``n = 4``,
  peak snap ``D/(T1 T2 T3 T4)``; the duration is ``T1 + ... + Tn``;
* for ``n = 3`` the jerk takes only the values ``+J, 0, -J`` (7 segments: the standard double-S or
  "S-curve" profile: jerk ramp ``T3``, constant acceleration ``T2 - T3``, cruise ``T1 - T2 - T3``);
* for ``n = 4`` the snap takes only ``+S, 0, -S`` (15 segments) and the jerk is continuous.

For long moves ``T4 = j_max/s_max``, ``T3 = a_max/j_max``, ``T2 = v_max/a_max`` and ``T1 = D/v_max``.
When a move is too short to reach a limit, the peak of that derivative is lowered to the largest value for
which the ordering still holds (e.g. ``T1 = T2 + T3``: no cruise). Choosing each peak as large as possible,
from the highest derivative outwards, gives the shortest move of this family; for ``n = 3`` it is the usual
minimum-time 7-segment S-curve.

Exactness
---------
The highest derivative is piecewise constant between the knots (subset sums of the widths). The knot times
and the state (position and derivatives) at every knot are computed in exact rational arithmetic
(:class:`fractions.Fraction`) and rounded once; each sample is then evaluated from the polynomial of its
segment in local time. Every derivative is the analytic derivative of the position polynomial: no numerical
differentiation, no cancellation between large terms, and after the move the position is exactly the target
and all derivatives are exactly zero. Peak values never exceed the limits by more than a few rounding errors.
A sample that falls exactly on a knot takes the value of the segment starting there (right-continuous, which
matters only for the piecewise-constant top derivative).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache
from itertools import combinations

import numpy as np

from ..errors import DataError, UsageError
from ..log import Log, log_signal_names

__all__ = [
    "MAX_SAMPLES",
    "Move",
    "Trajectory",
    "acceleration_mask",
    "constant_velocity_mask",
    "log_signal_names",
    "multi_segment",
    "point_to_point",
]

MAX_SAMPLES = 10_000_000
"""Largest number of samples a generated trajectory may have."""
TYPICAL_FS_HZ = 20_000.0
"""A drive's sample rate [Hz], to tell a trajectory too long from a sample rate too high in messages."""

_DERIVATIVE_NAMES = ("position", "velocity", "acceleration", "jerk", "snap")
_UNITS = {"position": "m", "velocity": "m/s", "acceleration": "m/s^2", "jerk": "m/s^3", "snap": "m/s^4"}


# ----------------------------------------------------------------------------------------------------------
# Value types
# ----------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Move:
    """One rest-to-rest move inside a trajectory.

    Parameters
    ----------
    t_start, t_end : float
        Time the move starts and ends [s] (on the trajectory's time axis).
    start, target : float
        Position before and after the move [m].
    widths : tuple of float
        Box widths ``(T1, T2, T3[, T4])`` [s]; empty for a zero-length move.
    """

    t_start: float
    t_end: float
    start: float
    target: float
    widths: tuple[float, ...]

    @property
    def duration(self) -> float:
        """Length of the move [s]."""
        return self.t_end - self.t_start

    def to_dict(self) -> dict:
        """Plain description with units in the key names."""
        return {
            "t_start_s": float(self.t_start),
            "t_end_s": float(self.t_end),
            "start_m": float(self.start),
            "target_m": float(self.target),
            "box_widths_s": [float(w) for w in self.widths],
        }


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A sampled reference trajectory and its exact derivatives.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Uniform sample times [s], starting at 0.
    pos : ndarray, shape (n,)
        Position [m].
    vel : ndarray, shape (n,)
        Velocity [m/s].
    acc : ndarray, shape (n,)
        Acceleration [m/s^2].
    jerk : ndarray, shape (n,)
        Jerk [m/s^3].
    snap : ndarray, shape (n,)
        Snap [m/s^4] (identically zero between the knots of a jerk-limited profile, whose snap is a train
        of impulses).
    limits : dict
        What was requested: ``v_max`` [m/s], ``a_max`` [m/s^2], ``j_max`` [m/s^3], ``s_max`` [m/s^4] or None.
    sample_rate : float or None
        Sample rate [Hz]; None derives it from ``t``.
    moves : tuple of Move
        The rest-to-rest moves, in order.
    """

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    jerk: np.ndarray
    snap: np.ndarray
    limits: Mapping[str, float | None] = field(default_factory=dict)
    sample_rate: float | None = None
    moves: tuple[Move, ...] = ()

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise DataError("trajectory: time vector must be 1-D with at least 2 samples")
        for name in ("pos", "vel", "acc", "jerk", "snap"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != t.shape:
                raise DataError(f"trajectory: {name} has shape {a.shape}, time has {t.shape}")
            object.__setattr__(self, name, a)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "limits", dict(self.limits))
        object.__setattr__(self, "moves", tuple(self.moves))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        if self.sample_rate is not None:
            return float(self.sample_rate)
        return float((self.t.size - 1) / (self.t[-1] - self.t[0]))

    @property
    def duration(self) -> float:
        """Time of the last sample [s]."""
        return float(self.t[-1] - self.t[0])

    @property
    def profile(self) -> str:
        """``"snap-limited"``, ``"jerk-limited"`` or ``"constant"`` (no motion)."""
        if not any(m.widths for m in self.moves):
            return "constant"
        return "snap-limited" if self.limits.get("s_max") is not None else "jerk-limited"

    def peaks(self) -> dict[str, float]:
        """Largest absolute velocity [m/s], acceleration [m/s^2], jerk [m/s^3] and snap [m/s^4]."""
        return {
            "velocity": float(np.max(np.abs(self.vel))),
            "acceleration": float(np.max(np.abs(self.acc))),
            "jerk": float(np.max(np.abs(self.jerk))),
            "snap": float(np.max(np.abs(self.snap))),
        }

    def to_log(self, prefix: str = "x_ref") -> Log:
        """Return the trajectory as a :class:`~feedtune.log.Log`.

        Parameters
        ----------
        prefix : str
            Name of the position signal. The derivative names follow from it: ``"x_ref"`` gives
            ``x_ref, v_ref, a_ref, j_ref, s_ref``; any other stem is kept, e.g. ``"y_ref"`` gives
            ``y_ref, vy_ref, ay_ref, jy_ref, sy_ref`` so that several axes can share one log.

        Returns
        -------
        Log
            Signals in m, m/s, m/s^2, m/s^3 and m/s^4 on the trajectory's time base [s].
        """
        names = log_signal_names(prefix)
        values = (self.pos, self.vel, self.acc, self.jerk, self.snap)
        signals = dict(zip(names, values, strict=True))
        units = {nm: _UNITS[q] for nm, q in zip(names, _DERIVATIVE_NAMES, strict=True)}
        meta = {
            "source": "trajectory",
            "profile": self.profile,
            "limits": dict(self.limits),
            "fs_hz": self.fs,
            "moves": [m.to_dict() for m in self.moves],
        }
        return Log(self.t, signals, units, meta)

    def to_dict(self) -> dict:
        """JSON-ready summary: duration, distance, peaks, limits and moves (units in ``"units"``)."""
        return {
            "profile": self.profile,
            "duration": self.duration,
            "distance": float(self.pos[-1] - self.pos[0]),
            "start": float(self.pos[0]),
            "end": float(self.pos[-1]),
            "n_samples": self.n,
            "fs": self.fs,
            "peaks": self.peaks(),
            "limits": {k: (None if v is None else float(v)) for k, v in self.limits.items()},
            "moves": [m.to_dict() for m in self.moves],
            "units": {
                "duration": "s", "distance": "m", "start": "m", "end": "m", "fs": "Hz",
                "peaks": {"velocity": "m/s", "acceleration": "m/s^2", "jerk": "m/s^3", "snap": "m/s^4"},
                "limits": {"v_max": "m/s", "a_max": "m/s^2", "j_max": "m/s^3", "s_max": "m/s^4"},
            },
        }

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from ..display import call, quantity

        p = self.peaks()
        return call("Trajectory", [self.profile, f"{self.n} samples", f"fs={quantity(self.fs, 'Hz')}",
                                   f"duration={quantity(self.duration, 's')}",
                                   f"distance={quantity(float(self.pos[-1] - self.pos[0]), 'm')}",
                                   f"v_peak={quantity(p['velocity'], 'm/s')}",
                                   f"a_peak={quantity(p['acceleration'], 'm/s^2')}", f"{len(self.moves)} move(s)"])

    def plot(self, *, title: str | None = None):
        """Position, velocity, acceleration, jerk and snap over time (:func:`feedtune.plotting.plot_log`)."""
        from ..display import facade

        return facade("plot_log")(self.to_log(), title=title or f"{self.profile} trajectory")




# ----------------------------------------------------------------------------------------------------------
# Input checks
# ----------------------------------------------------------------------------------------------------------


def _number(name: str, value: object, what: str) -> float:
    """Convert ``value`` to a finite float or raise a one-line UsageError naming ``name``."""
    if isinstance(value, bool):
        raise UsageError(f"{name} must be {what}, got {value!r}")
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be {what}, got {value!r}") from None
    if not math.isfinite(x):
        raise UsageError(f"{name} must be {what}, got {value!r}")
    return x


def _positive(name: str, value: object, unit: str) -> float:
    x = _number(name, value, f"a finite positive number in {unit}")
    if x <= 0:
        raise UsageError(f"{name} must be a finite positive number in {unit}, got {value!r}")
    return x


def _non_negative(name: str, value: object, unit: str) -> float:
    x = _number(name, value, f"a finite non-negative number in {unit}")
    if x < 0:
        raise UsageError(f"{name} must be a finite non-negative number in {unit}, got {value!r}")
    return x


def _check_limits(v_max: object, a_max: object, j_max: object, s_max: object) -> tuple[float, ...]:
    """Validate the kinematic limits; return ``(v, a, j)`` or ``(v, a, j, s)``."""
    lims = [
        _positive("v_max", v_max, "m/s"),
        _positive("a_max", a_max, "m/s^2"),
        _positive("j_max", j_max, "m/s^3"),
    ]
    if s_max is not None:
        s = _positive("s_max", s_max, "m/s^4")
        _, a, j = lims
        if s < j * j / a:
            raise UsageError(
                f"s_max={s:g} m/s^4 is below j_max^2/a_max = {j * j / a:g} m/s^4, so j_max could never be "
                f"reached (jerk ramp j_max/s_max = {j / s:g} s is longer than the acceleration ramp "
                f"a_max/j_max = {a / j:g} s); raise s_max or lower j_max"
            )
        lims.append(s)
    return tuple(lims)


def _limits_dict(lims: tuple[float, ...]) -> dict[str, float | None]:
    return {"v_max": lims[0], "a_max": lims[1], "j_max": lims[2], "s_max": lims[3] if len(lims) > 3 else None}


# ----------------------------------------------------------------------------------------------------------
# Box widths
# ----------------------------------------------------------------------------------------------------------


def _ramp_widths(peak: float, lims: tuple[float, ...]) -> tuple[float, ...]:
    """Widths ``(T_k, ..., T_n)`` of the shortest ramp of derivative ``k-1`` from 0 to ``peak``.

    ``lims = (L_k, ..., L_n)`` are the limits of derivatives ``k ... n``. ``T_k = peak / P_k`` where the
    peak ``P_k`` of derivative ``k`` is its limit or, if smaller, the largest value whose own ramp fits
    inside ``T_k`` (``T_k >= T_{k+1} + ... + T_n``).
    """
    if len(lims) == 1:
        return (peak / lims[0],)
    p_k = min(lims[0], _largest_fitting_peak(peak, lims[1:]))
    return (peak / p_k, *_ramp_widths(p_k, lims[1:]))


def _largest_fitting_peak(area: float, lims: tuple[float, ...]) -> float:
    """Largest ``q`` with ``q * sum(_ramp_widths(q, lims)) <= area`` (the ramp fits in ``area / q``)."""
    if len(lims) == 1:
        return math.sqrt(area * lims[0])
    if len(lims) == 2:
        return _largest_fitting_peak_two(area, lims[0], lims[1])
    return _largest_fitting_peak_bisect(area, lims)


def _largest_fitting_peak_two(area: float, lim_a: float, lim_b: float) -> float:
    """Closed form of :func:`_largest_fitting_peak` for two inner limits.

    The inner ramp to ``q`` lasts ``q/lim_a + lim_a/lim_b`` when ``q >= lim_a^2/lim_b`` and
    ``2 sqrt(q/lim_b)`` otherwise, so ``q * duration = area`` is a quadratic or a power law in ``q``.
    """
    ratio = lim_a / lim_b
    if area >= 2.0 * lim_a * ratio * ratio:
        return 0.5 * lim_a * (math.sqrt(ratio * ratio + 4.0 * area / lim_a) - ratio)
    return (0.5 * area * math.sqrt(lim_b)) ** (2.0 / 3.0)


def _largest_fitting_peak_bisect(area: float, lims: tuple[float, ...]) -> float:
    """Bisection for :func:`_largest_fitting_peak`; returns the feasible end of the final bracket."""

    def excess(q: float) -> float:
        return q * sum(_ramp_widths(q, lims)) - area

    hi = math.sqrt(area * lims[0])  # the ramp lasts at least q/lims[0]
    if excess(hi) <= 0.0:
        return hi
    lo = 0.5 * hi
    while excess(lo) > 0.0:
        lo *= 0.5
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if excess(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return lo


def _box_widths(distance: float, lims: tuple[float, ...]) -> tuple[float, ...]:
    """Box widths ``(T1, ..., Tn)`` [s] for a move of ``distance > 0`` [m] under the limits.

    The floating-point widths are then nudged up (never down) until, in exact arithmetic, every peak is at
    most its limit and every ``T_k >= T_{k+1} + ... + T_n``.
    """
    widths = list(_ramp_widths(distance, lims))
    exact_d = Fraction(distance)
    product = Fraction(1)
    for k, limit in enumerate(lims):
        while exact_d / (product * Fraction(widths[k])) > Fraction(limit):
            widths[k] = math.nextafter(widths[k], math.inf)
        product *= Fraction(widths[k])
    for k in range(len(widths) - 2, -1, -1):
        inner = sum((Fraction(w) for w in widths[k + 1 :]), Fraction(0))
        if Fraction(widths[k]) < inner:
            widths[k] = float(inner)
            while Fraction(widths[k]) < inner:
                widths[k] = math.nextafter(widths[k], math.inf)
    return tuple(widths)


# ----------------------------------------------------------------------------------------------------------
# Exact piecewise-polynomial segments
# ----------------------------------------------------------------------------------------------------------


def _knot_events(widths: Sequence[Fraction]) -> dict[Fraction, int]:
    """Map each knot time (a subset sum of the widths) to the summed sign ``(-1)^|S|`` of its subsets."""
    events: dict[Fraction, int] = {}
    n = len(widths)
    for size in range(n + 1):
        for subset in combinations(widths, size):
            tau = sum(subset, Fraction(0))
            events[tau] = events.get(tau, 0) + (-1) ** size
    return events


def _taylor_step(state: list[Fraction], h: Fraction) -> list[Fraction]:
    """Advance ``(p, v, a, j, s)`` by ``h`` with constant top derivative (exact)."""
    out = []
    for m in range(5):
        acc = Fraction(0)
        term = Fraction(1)
        for r in range(5 - m):
            acc += state[m + r] * term
            term = term * h / (r + 1)
        out.append(acc)
    return out


def _exact_segments(
    distance: float, widths: tuple[float, ...]
) -> tuple[list[Fraction], list[list[Fraction]]]:
    """Knot times and exact states ``(p, v, a, j, s)`` at the start of each segment of one move.

    The ``n``-th derivative (``n = len(widths)``) on the segment after knot ``tau`` is
    ``distance / prod(T) * sum_{S: tau_S <= tau} (-1)^|S|``; the state is integrated exactly across segments.
    The last knot is the end of the move, where the state is exactly ``(distance, 0, 0, 0, 0)``.
    """
    exact_w = [Fraction(w) for w in widths]
    n = len(exact_w)
    scale = Fraction(distance)
    for w in exact_w:
        scale /= w
    events = _knot_events(exact_w)
    knots = sorted(events)
    state = [Fraction(0)] * 5
    level = 0
    states = []
    for k, tau in enumerate(knots[:-1]):
        level += events[tau]
        state[n] = scale * level
        states.append(list(state))
        state = _taylor_step(state, knots[k + 1] - tau)
    return knots, states


@lru_cache(maxsize=256)
def _move_table(
    distance: float, lims: tuple[float, ...]
) -> tuple[tuple[float, ...], tuple[Fraction, ...], tuple[tuple[Fraction, ...], ...]]:
    """Widths, knots and exact segment states of a move of ``distance > 0`` [m] (cached: repeated moves)."""
    widths = _box_widths(distance, lims)
    knots, states = _exact_segments(distance, widths)
    return widths, tuple(knots), tuple(tuple(st) for st in states)


@dataclass(frozen=True)
class _Pieces:
    """Global piecewise polynomial: segment start times [s] and Taylor coefficients ``(p, v, a, j, s)``."""

    starts: np.ndarray
    coefs: np.ndarray
    moves: tuple[Move, ...]
    end_of_motion: float
    total: float


class _PiecesBuilder:
    """Collects rest segments and moves on one time axis."""

    def __init__(self, start: float) -> None:
        self.cursor = 0.0
        self.position = start
        self.starts: list[float] = [0.0]
        self.coefs: list[list[float]] = [[start, 0.0, 0.0, 0.0, 0.0]]
        self.moves: list[Move] = []
        self.end_of_motion = 0.0

    def dwell(self, seconds: float) -> None:
        """Stay at the current position for ``seconds`` [s]."""
        self.cursor += seconds

    def move(self, target: float, lims: tuple[float, ...]) -> None:
        """Append a rest-to-rest move from the current position to ``target``."""
        distance = target - self.position
        t0 = self.cursor
        widths: tuple[float, ...] = ()
        if distance != 0.0:
            sign = 1.0 if distance > 0 else -1.0
            widths, knots, states = _move_table(abs(distance), lims)
            origin = Fraction(self.position)
            for tau, st in zip(knots[:-1], states, strict=True):
                self.starts.append(t0 + float(tau))
                row = [float(origin + int(sign) * st[0])] + [sign * float(x) for x in st[1:]]
                self.coefs.append(row)
            self.cursor = t0 + float(knots[-1])
            self.end_of_motion = self.cursor
        self.starts.append(self.cursor)
        self.coefs.append([target, 0.0, 0.0, 0.0, 0.0])
        self.moves.append(Move(t0, self.cursor, self.position, target, widths))
        self.position = target

    def build(self) -> _Pieces:
        """Freeze the collected segments into arrays."""
        starts = np.asarray(self.starts, dtype=float)
        coefs = np.asarray(self.coefs, dtype=float)
        return _Pieces(starts, coefs, tuple(self.moves), self.end_of_motion, self.cursor)


def _sample_count(pieces: _Pieces, fs: float, dwells: Mapping[str, float] | None = None,
                  move: str = "distance", v_max: float = math.nan) -> int:
    """Samples needed to cover the whole trajectory, with the last one at or after the end of the motion; a
    UsageError naming what makes it too long (the longest of the ``dwells`` ``{parameter: seconds}`` or the motion,
    ``move``, at ``v_max``, and ``fs``) when that exceeds :data:`MAX_SAMPLES` or the memory budget."""
    from ..budget import check_memory

    span = max(pieces.total, pieces.end_of_motion)
    estimate = span * fs
    if not math.isfinite(estimate) or estimate + 2 > MAX_SAMPLES:
        dwells = {k: v for k, v in (dwells or {}).items() if v > 0}
        moving = span - sum(dwells.values())
        longest = max(dwells, key=dwells.get) if dwells else None
        if span * TYPICAL_FS_HZ + 2 <= MAX_SAMPLES:  # a plausible duration: the sample rate is the culprit
            raise UsageError(f"fs={fs:g} Hz gives a trajectory of {span:g} s more than the {MAX_SAMPLES:,} samples "
                             f"allowed; servo drives sample at {TYPICAL_FS_HZ / 1e3:g} kHz or so", parameter="fs")
        why = (f"{longest}={dwells[longest]:g} s" if longest is not None and dwells[longest] >= moving
               else f"{moving:g} s of motion over {move} at v_max={v_max:g} m/s")
        raise UsageError(
            f"the trajectory lasts {span:g} s, mostly {why}, which at fs={fs:g} Hz needs more than the "
            f"{MAX_SAMPLES:,} samples allowed; shorten it or lower fs",
            parameter=(*dwells, move, "v_max", "fs"),
        )
    n = max(2, math.ceil(estimate) + 1)
    while (n - 1) / fs < pieces.end_of_motion:
        n += 1
    check_memory(n * 8.0 * 6, f"a trajectory of {span:g} s at fs={fs:g} Hz ({n:,} samples)", parameter="fs")
    return n


def _evaluate(pieces: _Pieces, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Position and its four derivatives at times ``t`` (vectorised Horner evaluation in local time)."""
    idx = np.searchsorted(pieces.starts, t, side="right") - 1
    np.clip(idx, 0, None, out=idx)
    tau = t - pieces.starts[idx]
    c = pieces.coefs[idx]
    p, v, a, j, s = c[:, 0], c[:, 1], c[:, 2], c[:, 3], c[:, 4]
    pos = p + tau * (v + tau * (a / 2.0 + tau * (j / 6.0 + tau * (s / 24.0))))
    vel = v + tau * (a + tau * (j / 2.0 + tau * (s / 6.0)))
    acc = a + tau * (j + tau * (s / 2.0))
    jerk = j + tau * s
    return pos, vel, acc, jerk, s.copy()


def _sample(pieces: _Pieces, fs: float, lims: tuple[float, ...], dwells: Mapping[str, float] | None = None,
            move: str = "distance") -> Trajectory:
    n = _sample_count(pieces, fs, dwells, move, lims[0])
    t = np.arange(n, dtype=float) / fs
    pos, vel, acc, jerk, snap = _evaluate(pieces, t)
    return Trajectory(t, pos, vel, acc, jerk, snap, _limits_dict(lims), fs, pieces.moves)


# ----------------------------------------------------------------------------------------------------------
# Public generators
# ----------------------------------------------------------------------------------------------------------


def point_to_point(
    distance: float,
    *,
    v_max: float,
    a_max: float,
    j_max: float,
    s_max: float | None = None,
    fs: float = 20000.0,
    start: float = 0.0,
    dwell_before: float = 0.0,
    dwell_after: float = 0.0,
) -> Trajectory:
    """Rest-to-rest move with limited velocity, acceleration, jerk and (optionally) snap.

    Parameters
    ----------
    distance : float
        Signed move length [m]; negative moves backwards, zero gives a constant trajectory.
    v_max : float
        Velocity limit [m/s].
    a_max : float
        Acceleration limit [m/s^2].
    j_max : float
        Jerk limit [m/s^3].
    s_max : float, optional
        Snap limit [m/s^4]. None: jerk-limited 7-segment profile (piecewise-constant jerk). Given: the
        snap-limited, jerk-continuous 15-segment profile; it must be at least ``j_max**2 / a_max``.
    fs : float
        Sample rate [Hz].
    start : float
        Start position [m].
    dwell_before, dwell_after : float
        Time at rest before and after the move [s].

    Returns
    -------
    Trajectory
        Samples from ``t = 0``; the last sample lies at or after the end of the move (and of
        ``dwell_after``), where the position is exactly ``start + distance`` and all derivatives are zero.

    Raises
    ------
    UsageError
        A non-finite or non-positive limit or sample rate, a negative dwell, ``s_max < j_max**2/a_max``,
        or more than :data:`MAX_SAMPLES` samples.

    Notes
    -----
    Short moves that cannot reach ``v_max`` (or ``a_max``, ``j_max``) get lower peaks; see the module
    docstring for the construction. Example: 0.1 m at 0.2 m/s, 2 m/s^2, 50 m/s^3 gives the widths
    ``T1 = 0.5, T2 = 0.1, T3 = 0.04`` s and lasts 0.64 s.
    """
    lims = _check_limits(v_max, a_max, j_max, s_max)
    dist = _number("distance", distance, "a finite number in m")
    rate = _positive("fs", fs, "Hz")
    origin = _number("start", start, "a finite number in m")
    before = _non_negative("dwell_before", dwell_before, "s")
    after = _non_negative("dwell_after", dwell_after, "s")
    builder = _PiecesBuilder(origin)
    builder.dwell(before)
    builder.move(origin + dist, lims)
    builder.dwell(after)
    return _sample(builder.build(), rate, lims, {"dwell_before": before, "dwell_after": after})


def multi_segment(
    waypoints: Sequence[float],
    *,
    v_max: float,
    a_max: float,
    j_max: float,
    s_max: float | None = None,
    fs: float = 20000.0,
    dwell: float = 0.0,
) -> Trajectory:
    """Consecutive rest-to-rest moves through the waypoints, with a dwell between moves.

    Each move starts and ends at rest (the trajectory stops exactly at every waypoint) and uses the
    profile of :func:`point_to_point` under the same limits, so every limit holds throughout. ``dwell``
    seconds at rest separate consecutive moves; there is no dwell before the first or after the last move.
    A repeated waypoint is a move of zero length, so it adds one more dwell at that position.

    Parameters
    ----------
    waypoints : sequence of float
        Positions [m], at least two; the trajectory starts at the first.
    v_max, a_max, j_max : float
        Velocity [m/s], acceleration [m/s^2] and jerk [m/s^3] limits.
    s_max : float, optional
        Snap limit [m/s^4]; see :func:`point_to_point`.
    fs : float
        Sample rate [Hz].
    dwell : float
        Time at rest between moves [s].

    Returns
    -------
    Trajectory
        One move per consecutive pair of waypoints in ``moves``; ends exactly at the last waypoint.

    Raises
    ------
    UsageError
        Fewer than two or non-finite waypoints, bad limits (see :func:`point_to_point`), a negative dwell,
        or more than :data:`MAX_SAMPLES` samples.
    """
    lims = _check_limits(v_max, a_max, j_max, s_max)
    points = _check_waypoints(waypoints)
    rate = _positive("fs", fs, "Hz")
    pause = _non_negative("dwell", dwell, "s")
    builder = _PiecesBuilder(points[0])
    for k, target in enumerate(points[1:]):
        if k > 0:
            builder.dwell(pause)
        builder.move(target, lims)
    return _sample(builder.build(), rate, lims, {"dwell": pause * (len(points) - 2)}, "waypoints")


def _check_waypoints(waypoints: Sequence[float]) -> list[float]:
    try:
        arr = np.asarray(waypoints, dtype=float)
    except (TypeError, ValueError):
        raise UsageError("waypoints must be a list of positions in m") from None
    if arr.ndim != 1 or arr.size < 2:
        raise UsageError(f"waypoints must be a flat list of at least 2 positions in m, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise UsageError(f"waypoints[{bad}] is not a finite position in m")
    return [float(x) for x in arr]


# ----------------------------------------------------------------------------------------------------------
# Phase masks
# ----------------------------------------------------------------------------------------------------------


def _relative_small(x: np.ndarray, tol: float) -> np.ndarray:
    """``|x| <= tol * max|x|`` (all True for an identically zero signal)."""
    mag = np.abs(x)
    return mag <= tol * float(np.max(mag))


def constant_velocity_mask(traj: Trajectory, tol: float = 1e-6) -> np.ndarray:
    """Samples cruising at the peak velocity.

    A sample cruises when ``|vel| >= (1 - tol) * max|vel|`` and acceleration, jerk and snap are each at
    most ``tol`` times their peak magnitude. Moves of a multi-segment trajectory that do not reach the
    overall peak velocity are not included; a short move without cruise contributes no samples.

    Parameters
    ----------
    traj : Trajectory
        The reference trajectory.
    tol : float
        Relative tolerance (dimensionless, 0 <= tol < 1).

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    tol = _check_tol(tol)
    speed = np.abs(traj.vel)
    v_peak = float(np.max(speed))
    if v_peak == 0.0:
        return np.zeros(traj.n, dtype=bool)
    cruising = speed >= (1.0 - tol) * v_peak
    for x in (traj.acc, traj.jerk, traj.snap):
        cruising &= _relative_small(x, tol)
    return cruising


def acceleration_mask(traj: Trajectory, tol: float = 1e-6) -> np.ndarray:
    """Samples in an acceleration or deceleration transient.

    True where acceleration, jerk or snap exceeds ``tol`` times its peak magnitude, i.e. everywhere
    except at rest and while cruising at constant velocity.

    Parameters
    ----------
    traj : Trajectory
        The reference trajectory.
    tol : float
        Relative tolerance (dimensionless, 0 <= tol < 1).

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    tol = _check_tol(tol)
    quiet = np.ones(traj.n, dtype=bool)
    for x in (traj.acc, traj.jerk, traj.snap):
        quiet &= _relative_small(x, tol)
    return ~quiet


def _check_tol(tol: float) -> float:
    x = _number("tol", tol, "a relative tolerance between 0 and 1")
    if not 0.0 <= x < 1.0:
        raise UsageError(f"tol must be a relative tolerance between 0 and 1, got {tol!r}")
    return x
