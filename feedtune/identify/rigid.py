"""Rigid-body inverse-dynamics least squares (IDIM-LS) on tracking logs (thesis §2.1.1).

The recipe is the one of the EMPS benchmark (Janot, Gautier, Brunot 2019, ``Script_IDIM_LS.m``):

1. low-pass the measured position with a zero-phase Butterworth filter (``filtfilt``, order 4, cut-off
   ``5 x`` the dynamic bandwidth, 100 Hz for EMPS);
2. velocity and acceleration by central differences;
3. drop ``round(5 fs / cutoff)`` samples at each end (filter and difference edge effects);
4. build the observation matrix ``W = [ddq, dq, sign(dq), 1]`` (asymmetric friction:
   ``[ddq, dq O+, O+, dq O-, -O-]`` with ``O+ = (1 + sign dq)/2``, ``O- = (1 - sign dq)/2``, no offset
   column because ``O+ + O- = 1``) at the full rate;
5. parallel decimation: every column of ``W`` and the force are decimated by ``scipy.signal.decimate``
   (order-8 Chebyshev, zero phase; factor ``round(fs / cutoff)``, 10 for EMPS);
6. ordinary least squares, ``sigma^2 = ||r||^2 / (n - p)``, covariance ``sigma^2 (W^T W)^-1``.

Several logs (:func:`fit_rigid` with a list): each log is filtered, differentiated, trimmed and decimated on
its own (no filter runs across the joint of two files), then the decimated rows are stacked into one least-squares
problem with one set of parameters.

Cut-off rule (``cutoff_hz=None``, :func:`auto_cutoff_hz`): the motion's band ends at the lowest frequency where the
power spectral density of the velocity (central differences of the raw position; Welch, Hann windows of 4096
samples; a running median over 9 lines so that a lone quantization tone does not count), from its peak below fs/4
on, first falls to 20 dB above its noise floor (the median PSD over ``[fs/4, fs/2]``); the cut-off is 2.5 times
that (the decimation filter, at 0.4 times the cut-off, then passes the band), to two significant digits, within
what the log's length allows. It gives
100 Hz on the EMPS log (the published recipe: 5x its 20 Hz dynamic bandwidth) and 7-9 Hz on slow servo-motor steps
(HSM150), where 100 Hz biases the inertia low by the noise of the differentiated position (errors in the regressor).
With several logs each log gets its own. The rule is made for tracking and step logs (a continuous
spectrum); between the lines of a sine or multisine log the spectrum falls to the floor, so give such logs a
cut-off.

Directions are counted on the moving samples only: a decimated sample slower than :data:`STILL_FRACTION` of the
peak speed stands still (a step run's rest before the step, the filter's ringing around it); its ``sign(dq)`` says
nothing about a direction of motion.

One direction (the moving samples go one way): ``sign(dq)`` equals the constant column, so Coulomb friction and
offset cannot be separated -- the split would rest on the standstill samples, where static friction holds the axis
at any command below break-away. The fit then uses the moving samples of that direction and identifies the mass,
the viscous coefficient and their sum for that direction, ``constant = Fc sign(dq) + offset``, stored as the model's
offset with a warning that says so (the model then holds for motion in that direction only); the asymmetric model
falls back to the same fit. When those moving samples hold one speed (the middle 90 % within
:data:`ONE_SPEED_SPREAD`: a step to one speed), viscous friction and the constant cannot be separated either: the
fit is ``u = M a + B v`` with the constant taken as 0 -- what a step-response method assumes -- and the warning says
so (``B`` is then the command over the speed, an upper bound on the viscous coefficient). A log whose other
direction holds less than :data:`FEW_REVERSED` of the moving samples gets a warning that Coulomb friction and offset
rest on those few samples.

Signs: the fit is ordinary least squares as published; when a coefficient comes out with an unphysical sign
(viscous or Coulomb friction below 0) the fit is repeated within the bounds (``scipy.optimize.lsq_linear``,
viscous and Coulomb ``>= 0``, mass ``>= 0``; offset and the one-direction constant free), the parameters on their
bound are named with their unconstrained values, and the standard deviations are those of the free parameters: a
model file the loader refuses is never written. A mass that is not positive, or not determined within
:data:`MAX_MASS_RELATIVE_STD`, is refused.

Ill-conditioned problems (no acceleration, constant velocity) raise :class:`~feedtune.errors.IllConditionedError`
naming the degenerate columns instead of returning meaningless numbers.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import progress
from ..errors import DataError, IllConditionedError, UsageError
from ..log import Log
from ..models.rigid import RigidBodyModel
from .data_quality import clipping_warning, fit_warnings, quantization_warning

POSITION_SCALE = {
    "m": ("m", 1.0), "": ("m", 1.0), "mm": ("m", 1e-3), "um": ("m", 1e-6), "µm": ("m", 1e-6),
    "nm": ("m", 1e-9), "rad": ("rad", 1.0), "deg": ("rad", np.pi / 180.0),
}
"""Accepted position units and their conversion to SI (unit-less positions are taken as metres)."""

MAX_SCALED_CONDITION = 1e6
"""Largest accepted condition number of the column-normalised regressor."""

MAX_MASS_RELATIVE_STD = 0.25
"""Largest accepted relative standard deviation of the mass estimate."""

FEW_REVERSED = 0.05
"""Fraction of the moving samples moving the other way below which Coulomb friction and offset are flagged as weakly
separated."""
STILL_FRACTION = 0.02
"""A decimated sample slower than this fraction of the peak speed stands still: it counts for no direction [-]."""
ONE_SPEED_SPREAD = 0.1
"""One direction's moving samples hold one speed when their 95th percentile speed is within this fraction above the
5th: viscous friction and the constant cannot be separated [-]."""

AUTO_CUTOFF_DB = 20.0
"""Signal-to-noise ratio of the velocity spectrum that ends the motion's band [dB]."""
AUTO_CUTOFF_FACTOR = 2.5
"""Automatic cut-off over the motion's band: the decimation filter (at 0.4 x the cut-off) then passes the band."""

SYMMETRIC_PARAMS = ("mass", "viscous", "coulomb", "offset")
ONE_DIRECTION_PARAMS = ("mass", "viscous", "constant")
ONE_SPEED_PARAMS = ("mass", "viscous")
ASYMMETRIC_PARAMS = ("mass", "viscous_pos", "coulomb_pos", "viscous_neg", "coulomb_neg")
COLUMN_LABELS = {
    "mass": "ddq (acceleration)", "viscous": "dq (velocity)", "coulomb": "sign(dq)", "offset": "1 (constant)",
    "viscous_pos": "dq for dq>0", "coulomb_pos": "1 for dq>0", "viscous_neg": "dq for dq<0",
    "coulomb_neg": "-1 for dq<0", "constant": "1 (constant)",
}
LOWER_BOUNDS = {"mass": 0.0, "viscous": 0.0, "coulomb": 0.0, "viscous_pos": 0.0, "coulomb_pos": 0.0,
                "viscous_neg": 0.0, "coulomb_neg": 0.0}
"""Physical lower bounds of the fitted parameters (offset and the one-direction constant are free)."""


# ----------------------------------------------------------------------------------------- shared helpers
def position_si(log: Log, name: str) -> tuple[np.ndarray, str]:
    """A position column converted to SI and its unit (``"m"`` or ``"rad"``).

    Parameters
    ----------
    log : Log
        The log holding the column.
    name : str
        Column name.

    Returns
    -------
    position : ndarray
        Position [m] or [rad].
    unit : str
        ``"m"`` or ``"rad"``.
    """
    raw_unit = log.unit(name).strip()
    if raw_unit not in POSITION_SCALE:
        raise DataError(f"{log.source}: position column {name!r} has unit {raw_unit!r}; expected one of "
                        f"{', '.join(u for u in POSITION_SCALE if u)}")
    unit, scale = POSITION_SCALE[raw_unit]
    return log.get(name) * scale, unit


def uniform_sample_time(log: Log) -> float:
    """Sample time [s] of a uniformly sampled log; a non-uniform time base is a :class:`DataError`."""
    return log.check_uniform("the rigid-body fit")


def default_force_unit(raw_unit: str, scale: float, position_unit: str) -> str:
    """Unit of ``scale * column``: the column's own unit when ``scale == 1``, else N (m) or N*m (rad)."""
    if scale == 1.0 and raw_unit:
        return raw_unit
    if scale == 1.0:
        return "V"
    return "N" if position_unit == "m" else "N*m"


def _positive_float(value, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {value!r}", parameter=name) from None
    if not (np.isfinite(x) and x > 0):
        raise UsageError(f"{name} must be > 0, got {value!r}", parameter=name)
    return x


# ------------------------------------------------------------------------------------------ result types
@dataclass(frozen=True)
class RigidFit:
    """Result of :func:`fit_rigid`.

    Attributes
    ----------
    model : RigidBodyModel
        The identified model (symmetric fit: ``offset`` identified; asymmetric fit: ``offset = 0``; one
        direction: ``constant`` as the offset, no Coulomb friction).
    values, std : dict of str to float
        Estimates and their standard deviations ``sqrt(diag(sigma^2 (W^T W)^-1))``; names are
        ``mass, viscous, coulomb, offset``, ``mass, viscous_pos, coulomb_pos, viscous_neg, coulomb_neg`` or (one
        direction) ``mass, viscous, constant``.
    relative_error_pct : float
        ``100 ||r|| / ||tau||`` on the decimated samples [%].
    residual_rms : float
        RMS of the residual [force unit].
    condition_number : float
        2-norm condition number of the decimated regressor (as published for EMPS: 25.99).
    scaled_condition_number : float
        Condition number after normalising every column to unit norm.
    column_norms : dict of str to float
        Norm of each decimated regressor column (in its own unit).
    n_samples : int
        Number of decimated samples in the fit.
    decimate : int
        Decimation factor used.
    cutoff_hz : float
        Butterworth cut-off [Hz] (the highest of the logs' when chosen per log).
    filter_order : int
        Butterworth order.
    cutoff_rule : str
        ``"given"`` or how it was chosen from the data (:func:`auto_cutoff_hz`, per log).
    force_unit, position_unit : str
        Units of the force and of the position (``"m"`` or ``"rad"``).
    warnings : tuple of str
        What makes the fit unreliable (:mod:`feedtune.identify.data_quality`: coarse position quantization,
        a clipped command, a poor fit, a poorly determined mass), the directions, and parameters on their bounds.
    on_bound : dict of str to dict
        Parameters held on their physical bound (module docstring: signs): ``{name: {"bound", "unconstrained",
        "std"}}``; their ``std`` is NaN (None in :meth:`to_dict`).
    """

    model: RigidBodyModel
    values: dict[str, float]
    std: dict[str, float]
    relative_error_pct: float
    residual_rms: float
    condition_number: float
    scaled_condition_number: float
    column_norms: dict[str, float]
    n_samples: int
    decimate: int
    cutoff_hz: float
    filter_order: int
    force_unit: str
    position_unit: str
    asymmetric: bool = False
    source: str = field(default="log")
    warnings: tuple = ()
    cutoff_rule: str = "given"
    on_bound: dict = field(default_factory=dict)

    @property
    def units(self) -> dict[str, str]:
        """Unit of every estimated parameter."""
        f, p = self.force_unit, self.position_unit
        unit_of = {"mass": f"{f}/({p}/s^2)", "viscous": f"{f}/({p}/s)", "coulomb": f, "offset": f, "constant": f}
        return {name: unit_of[name.split("_")[0]] for name in self.values}

    def to_dict(self) -> dict:
        """JSON-ready summary with units."""
        return {
            "source": self.source,
            "model": ("rigid-one-direction" if "constant" in self.values
                      else "rigid-one-speed" if "coulomb" not in self.values and "coulomb_pos" not in self.values
                      else "rigid-asymmetric" if self.asymmetric else "rigid"),
            "cutoff_rule": self.cutoff_rule,
            "values": dict(self.values),
            "std": {k: (float(v) if np.isfinite(v) else None) for k, v in self.std.items()},
            "on_bound": {k: dict(v) for k, v in self.on_bound.items()},
            "units": {**self.units, "relative_error_pct": "%", "residual_rms": self.force_unit,
                      "cutoff_hz": "Hz"},
            "relative_error_pct": self.relative_error_pct,
            "residual_rms": self.residual_rms,
            "condition_number": self.condition_number,
            "scaled_condition_number": self.scaled_condition_number,
            "column_norms": dict(self.column_norms),
            "n_samples": self.n_samples,
            "decimate": self.decimate,
            "cutoff_hz": self.cutoff_hz,
            "filter_order": self.filter_order,
            "warnings": list(self.warnings),
            "rigid_model": self.model.to_dict(),
        }


@dataclass(frozen=True)
class RigidValidation:
    """Result of :func:`validate_rigid`: how well a model predicts the force of another log.

    Attributes
    ----------
    relative_error_pct : float
        ``100 ||tau - tau_model|| / ||tau||`` on the decimated samples [%].
    residual_rms : float
        RMS force error [force unit].
    n_samples : int
        Number of decimated samples compared.
    force_unit : str
        Unit of the force.
    """

    relative_error_pct: float
    residual_rms: float
    n_samples: int
    force_unit: str
    source: str = "log"

    def to_dict(self) -> dict:
        """JSON-ready summary with units."""
        return {
            "source": self.source,
            "relative_error_pct": self.relative_error_pct,
            "residual_rms": self.residual_rms,
            "n_samples": self.n_samples,
            "units": {"relative_error_pct": "%", "residual_rms": self.force_unit},
        }


# ----------------------------------------------------------------------------------- signal processing
@dataclass(frozen=True)
class _Samples:
    """Filtered kinematics and force at the full rate, edges trimmed."""

    force: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    decimate: int
    force_unit: str
    position_unit: str
    cutoff_hz: float
    filter_order: int
    dt: float
    position_peak: float


def _shortest_cutoff(n: int, fs: float) -> float:
    """The lowest cut-off [Hz] whose edge trim and decimation a log of ``n`` samples at ``fs`` [Hz] can afford,
    with a 25 % margin (``2 round(5 fs / fc) + 30 round(fs / fc) <= n``)."""
    return 1.25 * (10.0 + 30.0) * fs / n


def auto_cutoff_hz(position: np.ndarray, dt: float) -> tuple[float, str]:
    """The Butterworth cut-off chosen from a log's position (module docstring: cut-off rule).

    Parameters
    ----------
    position : ndarray
        Raw position samples [m or rad].
    dt : float
        Sample time [s].

    Returns
    -------
    (float, str)
        The cut-off [Hz] and a sentence saying how it was chosen.

    Raises
    ------
    DataError
        A log too short for the cut-off its motion needs.
    """
    from scipy import signal
    from scipy.ndimage import median_filter

    fs = 1.0 / dt
    v = np.gradient(np.asarray(position, float), dt)
    n = v.size
    f, psd = signal.welch(v, fs=fs, nperseg=min(n, 4096), detrend="linear")
    floor = float(np.median(psd[f >= fs / 4]))
    smooth = median_filter(psd, size=9, mode="nearest")  # a lone line (a quantization tone) does not count
    peak = int(np.argmax(np.where(f < fs / 4, smooth, 0.0)))  # the motion's peak, below the floor's band
    edge_i = _band_end(smooth > floor * 10 ** (AUTO_CUTOFF_DB / 10), peak)
    lo, hi = _shortest_cutoff(n, fs), 0.4 * fs
    varies = np.std(signal.detrend(v)) > 1e-6 * np.max(np.abs(v))  # more than round-off of a constant speed
    if floor <= 0 or edge_i is None or edge_i <= 1 or not varies:  # no band: noise from the first line on
        edge = min(100.0, hi) / AUTO_CUTOFF_FACTOR
        how = "no velocity content above the noise floor: 100 Hz (the EMPS recipe)"
    else:
        edge = float(f[edge_i])
        how = (f"{AUTO_CUTOFF_FACTOR:g} x {edge:.3g} Hz, where the velocity spectrum falls to {AUTO_CUTOFF_DB:g} dB "
               "above its noise floor")
    cutoff = AUTO_CUTOFF_FACTOR * edge
    if cutoff < lo / 2:
        raise DataError(f"{n} samples are too few for the automatic cut-off: the motion needs {cutoff:.3g} Hz, "
                        f"but the filter edges and the decimation of a log this short need at least {lo:.3g} Hz; "
                        "give a longer log or cutoff_hz")
    cutoff = float(f"{min(max(cutoff, lo), hi):.2g}")
    if AUTO_CUTOFF_FACTOR * edge < lo:
        how += f"; raised to {cutoff:g} Hz, the lowest the log's length allows"
    return cutoff, how


def _band_end(above: np.ndarray, start: int) -> int | None:
    """Index of the first line at or after ``start`` where ``above`` is False; None when there is none."""
    below = np.flatnonzero(~above[start:])
    return int(below[0]) + start if below.size else None


def _auto_cutoff_of(log: Log, q: np.ndarray, dt: float) -> tuple[float, str]:
    """:func:`auto_cutoff_hz` of a log, its errors naming the log."""
    try:
        return auto_cutoff_hz(q, dt)
    except DataError as exc:
        raise DataError(f"{log.source}: {exc}") from None


def _check_settings(fs: float, cutoff_hz, filter_order, decimate) -> tuple[float, int, int]:
    cutoff = _positive_float(cutoff_hz, "cutoff_hz")
    if cutoff >= fs / 2:
        raise UsageError(f"cutoff_hz must be below the Nyquist frequency {fs / 2:g} Hz, got {cutoff:g}",
                         parameter="cutoff_hz")
    if not (isinstance(filter_order, (int, np.integer)) and 1 <= filter_order <= 12):
        raise UsageError(f"filter_order must be an integer from 1 to 12, got {filter_order!r}",
                         parameter="filter_order")
    if decimate is None:
        # EMPS rule: Butterworth at 5x the dynamic bandwidth, decimation filter (0.8 fs / (2 nd)) at 2x it.
        factor = max(1, round(0.8 * (fs / 2) / (0.4 * cutoff)))
    elif isinstance(decimate, (int, np.integer)) and decimate >= 1:
        factor = int(decimate)
    else:
        raise UsageError(f"decimate must be an integer >= 1 or None, got {decimate!r}", parameter="decimate")
    return cutoff, int(filter_order), factor


def _decimation_stages(factor: int) -> list[int]:
    """Split a decimation factor into stages of at most 13 (scipy's advice); a larger prime stays whole."""
    stages = []
    while factor > 1:
        for f in range(min(factor, 13), 1, -1):
            if factor % f == 0:
                break
        else:
            f = factor
        stages.append(f)
        factor //= f
    return stages


def decimate_columns(x: np.ndarray, factor: int) -> np.ndarray:
    """Zero-phase decimation along axis 0 (order-8 Chebyshev IIR per stage; FIR for a prime stage > 13)."""
    from scipy import signal

    for f in _decimation_stages(factor):
        x = signal.decimate(x, f, ftype="fir" if f > 13 else "iir", axis=0, zero_phase=True)
    return x


def _prepare(log: Log, force: str, position: str, cutoff_hz, filter_order, decimate,
             force_scale, force_unit: str | None) -> _Samples:
    from scipy import signal

    scale = float(force_scale)
    if not (np.isfinite(scale) and scale != 0):
        raise UsageError(f"force_scale must be a finite non-zero number, got {force_scale!r}", parameter="force_scale")
    dt = uniform_sample_time(log)
    q, pos_unit = position_si(log, position)
    if cutoff_hz is None:
        cutoff_hz = _auto_cutoff_of(log, q, dt)[0]
    cutoff, order, factor = _check_settings(1.0 / dt, cutoff_hz, filter_order, decimate)
    tau = log.get(force) * scale
    border = round(5.0 / (dt * cutoff))
    n_needed = 2 * border + factor * 30 + 3 * (order + 1)
    if log.n < n_needed:
        raise DataError(f"{log.source}: {log.n} samples are too few for cutoff_hz={cutoff:g} and "
                        f"decimate={factor} (need at least {n_needed})")
    if np.ptp(q) == 0:
        raise IllConditionedError(f"{log.source}: position column {position!r} is constant: the axis did not "
                                  "move, so mass and friction cannot be identified")
    b, a = signal.butter(order, cutoff, fs=1.0 / dt)
    q_f = signal.filtfilt(b, a, q)
    dq = np.gradient(q_f, dt)
    ddq = np.gradient(dq, dt)
    keep = slice(border, log.n - border)
    unit = force_unit or default_force_unit(log.unit(force), scale, pos_unit)
    return _Samples(tau[keep], dq[keep], ddq[keep], factor, unit, pos_unit, cutoff, order, dt,
                    float(np.max(np.abs(q_f))))


def _regressor(dq: np.ndarray, ddq: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Full-rate observation matrix of the symmetric or asymmetric parameters ``names`` (see module doc)."""
    s = np.sign(dq)
    if names == SYMMETRIC_PARAMS:
        return np.column_stack([ddq, dq, s, np.ones_like(dq)])
    o_pos = (1.0 + s) / 2.0
    o_neg = (1.0 - s) / 2.0
    return np.column_stack([ddq, dq * o_pos, s * o_pos, dq * o_neg, s * o_neg])


# ---------------------------------------------------------------------------------------- conditioning
def _directions(dq: np.ndarray, asymmetric: bool, unit: str) -> tuple[tuple[str, ...], np.ndarray, list[str]]:
    """The parameters the moving samples can separate, the samples the fit uses and what to say about it (module
    docstring: directions, one direction)."""
    n = dq.size
    still = np.abs(dq) < STILL_FRACTION * float(np.max(np.abs(dq)))
    n_still = int(np.count_nonzero(still))
    n_pos = int(np.count_nonzero((dq > 0) & ~still))
    n_neg = int(np.count_nonzero((dq < 0) & ~still))
    moving = n_pos + n_neg
    few = min(n_pos, n_neg)
    names = ASYMMETRIC_PARAMS if asymmetric else SYMMETRIC_PARAMS
    if few < max(20, moving // 100):
        sign = 1.0 if n_pos >= n_neg else -1.0
        way = "dq > 0" if sign > 0 else "dq < 0"
        use = sign * dq >= STILL_FRACTION * float(np.max(np.abs(dq)))
        wanted = "per-direction friction" if asymmetric else "Coulomb friction and offset"
        standstill = (f", {n_still} stand still (|dq| below {100 * STILL_FRACTION:g} % of the peak speed)"
                      if n_still else "")
        rest = (f"; the split would rest on the {n_still} standstill samples, where static friction holds the axis at "
                "any command below break-away" if n_still else "")
        head = (f"the data move in one direction only ({way} in {max(n_pos, n_neg)} of {n} samples{standstill}, the "
                f"other way in {few}): {wanted} cannot be separated{rest}; ")
        speed = np.abs(dq[use])
        lo, hi = np.percentile(speed, [5.0, 95.0]) if speed.size else (0.0, 0.0)
        if hi <= (1.0 + ONE_SPEED_SPREAD) * lo:
            return ONE_SPEED_PARAMS, use, [
                head + f"the moving samples hold one speed ({float(np.median(speed)):.4g} {unit}, the middle 90 % "
                f"within {100 * (hi / lo - 1):.2g} %), so viscous friction and the constant Fc sign(dq) + offset "
                "cannot be separated either: fitted u = M a + B v with the constant taken as 0 (as a step-response "
                "method does; B is the command over the speed, an upper bound on the viscous coefficient, and the "
                f"model holds for {way} only; add a run at another speed to separate them)"]
        return ONE_DIRECTION_PARAMS, use, [
            head + "fitted mass, viscous friction and their constant sum Fc sign(dq) + offset on the moving samples "
            f"of this direction, stored as the offset (the model holds for {way} only; add a log that moves the "
            "other way to separate them)"]
    notes = []
    if few < FEW_REVERSED * moving:
        notes.append(f"only {few} of {moving} moving samples ({100 * few / moving:.2g} %) move the other way: the "
                     "split between Coulomb friction and offset rests on them (check it against a log that moves "
                     "both ways)")
    return names, np.ones(n, bool), notes


def _check_kinematics(samples: _Samples, where: str) -> None:
    """Empty velocity or acceleration columns (round-off level only) are an ill-conditioned problem."""
    dq, ddq, dt = samples.velocity, samples.acceleration, samples.dt
    v_peak = float(np.max(np.abs(dq)))
    if v_peak == 0:
        raise IllConditionedError(f"{where}: velocity column dq is zero: the axis did not move")
    acc_rms = float(np.sqrt(np.mean(ddq**2)))
    # round-off of two differences, or an acceleration that changes the speed by 1e-6 of its peak in the log
    roundoff = 1e5 * np.finfo(float).eps * samples.position_peak / dt**2
    negligible = 1e-6 * v_peak / (dq.size * dt)
    if acc_rms <= max(roundoff, negligible):
        raise IllConditionedError(f"{where}: acceleration column ddq is empty (rms {acc_rms:.3g} "
                                  f"{samples.position_unit}/s^2): the log has no acceleration, so the mass "
                                  "cannot be identified")


def _scaled_condition(W: np.ndarray, names: tuple[str, ...], where: str) -> tuple[float, float, np.ndarray]:
    """Condition numbers and column norms; near-dependent columns raise :class:`IllConditionedError`."""
    norms = np.linalg.norm(W, axis=0)
    empty = [COLUMN_LABELS[n] for n, c in zip(names, norms, strict=True) if c == 0]
    if empty:
        raise IllConditionedError(f"{where}: regressor columns {', '.join(empty)} are zero")
    sv_scaled, vt = np.linalg.svd(W / norms, full_matrices=False)[1:]
    scaled_cond = float(sv_scaled[0] / sv_scaled[-1]) if sv_scaled[-1] > 0 else float("inf")
    if not scaled_cond <= MAX_SCALED_CONDITION:
        null = np.abs(vt[-1])
        involved = [COLUMN_LABELS[n] for n, c in zip(names, null, strict=True) if c > 0.1 * null.max()]
        raise IllConditionedError(
            f"{where}: regressor columns {', '.join(involved)} are (nearly) linearly dependent "
            f"(column-scaled condition number {scaled_cond:.3g} > {MAX_SCALED_CONDITION:g}); a "
            "constant-velocity run or a run without enough speed variation cannot separate these terms")
    sv = np.linalg.svd(W, compute_uv=False)
    return float(sv[0] / sv[-1]), scaled_cond, norms


def _bounded_least_squares(W: np.ndarray, y: np.ndarray, names: tuple[str, ...]):
    """Ordinary least squares, repeated within :data:`LOWER_BOUNDS` when a coefficient comes out below its bound
    (module docstring: signs): values, std by name (NaN on a bound), the parameters on their bound and the
    residual."""
    theta, *_ = np.linalg.lstsq(W, y, rcond=None)
    lower = np.array([LOWER_BOUNDS.get(n, -np.inf) for n in names])
    free = np.ones(len(names), bool)
    on_bound = {}
    if np.any(theta < lower):
        from scipy.optimize import lsq_linear

        residual = y - W @ theta
        sigma2 = float(residual @ residual) / max(y.size - len(names), 1)
        std_u = np.sqrt(sigma2 * np.diag(np.linalg.inv(W.T @ W)))
        bounded = lsq_linear(W, y, bounds=(lower, np.full(len(names), np.inf)), method="bvls").x
        free = ~(bounded <= lower + 1e-12 * np.maximum(np.abs(bounded).max(), 1e-300))
        bounded[~free] = lower[~free]
        on_bound = {n: {"bound": float(lower[k]), "unconstrained": float(theta[k]), "std": float(std_u[k])}
                    for k, n in enumerate(names) if not free[k]}
        theta = bounded
    residual = y - W @ theta
    sigma2 = float(residual @ residual) / max(y.size - int(np.count_nonzero(free)), 1)
    std = np.full(len(names), np.nan)
    Wf = W[:, free]
    std[free] = np.sqrt(sigma2 * np.diag(np.linalg.inv(Wf.T @ Wf)))
    return theta, {n: float(s) for n, s in zip(names, std, strict=True)}, on_bound, residual


def _bound_warnings(on_bound: dict, force_unit: str, position_unit: str) -> list[str]:
    """One line per parameter held on its bound, with its unconstrained value: within 3 std of the bound the data do
    not identify it; further below, the rigid-body model does not describe the log there."""
    units = {"viscous": f"{force_unit}/({position_unit}/s)", "coulomb": force_unit}
    out = []
    for name, b in on_bound.items():
        if name == "mass":
            continue
        clear = b["unconstrained"] + 3.0 * b["std"] < b["bound"]
        why = ("more than 3 std below it: the rigid-body model does not describe the log there (check the fit's "
               "error and the motion)" if clear else "within 3 std of it: the data do not identify it")
        out.append(f"{name} came out {b['unconstrained']:.4g} +/- {b['std']:.2g} {units[name.split('_')[0]]} "
                   f"unconstrained, below its physical bound {b['bound']:g} ({why}); held on the bound")
    return out


def _check_mass(values: dict[str, float], std: dict[str, float], unit: str, where: str,
                on_bound: dict | None = None) -> None:
    mass, sd = values["mass"], std["mass"]
    if on_bound and "mass" in on_bound:  # held at 0: report the unconstrained value
        mass, sd = on_bound["mass"]["unconstrained"], on_bound["mass"]["std"]
    if not (mass > 0 and sd <= MAX_MASS_RELATIVE_STD * mass):
        raise IllConditionedError(
            f"{where}: acceleration column ddq carries no usable information (mass = {mass:.4g} +/- {sd:.2g} "
            f"{unit}); the log needs clear acceleration phases (or check the sign of force_scale)")


# ------------------------------------------------------------------------------------------ public API
@progress.tasked("fitting the rigid body")
def fit_rigid(log: Log | Sequence[Log], *, force: str, position: str, asymmetric: bool = False,
              cutoff_hz: float | None = None, filter_order: int = 4, decimate: int | None = None,
              force_scale: float = 1.0, velocity_threshold: float | None = None,
              force_unit: str | None = None) -> RigidFit:
    """Identify mass, viscous and Coulomb friction and offset from one or several tracking logs by IDIM-LS.

    Model ``tau = M ddq + Fv dq + Fc sign(dq) + offset`` (asymmetric: ``Fv+, Fc+`` for ``dq > 0`` and
    ``Fv-, Fc-`` for ``dq < 0``, Coulomb values as magnitudes, no offset; one direction only: ``M, Fv`` and a
    constant). Processing as in the EMPS benchmark; see the module docstring.

    Parameters
    ----------
    log : Log or sequence of Log
        Uniformly sampled tracking log(s) with the same columns; several logs are processed one by one and
        their decimated rows stacked (module docstring).
    force : str
        Column with the drive command or force [V, N or N*m]; multiplied by ``force_scale``.
    position : str
        Column with the measured position [m or rad; mm, um, nm and deg are converted].
    asymmetric : bool
        Separate viscous and Coulomb coefficients per direction.
    cutoff_hz : float or None
        Cut-off of the zero-phase Butterworth position filter [Hz] (about 5x the dynamic bandwidth); None
        chooses it from each log (:func:`auto_cutoff_hz`).
    filter_order : int
        Butterworth order (applied forward and backward).
    decimate : int or None
        Parallel decimation factor; ``None`` uses ``round(fs / cutoff_hz)`` (the EMPS rule, 10 at 1 kHz and
        100 Hz). Factors above 13 are applied in stages.
    force_scale : float
        Multiplies the force column, e.g. the drive gain [N/V] (EMPS: 35.15065).
    velocity_threshold : float or None
        Drop decimated samples with ``|dq|`` below this speed [m/s or rad/s] (where ``sign(dq)`` is
        unreliable). ``None`` keeps all samples (the published recipe).
    force_unit : str or None
        Unit of ``force_scale * force``; default: the column's unit when ``force_scale == 1``, else N (linear
        axis) or N*m (rotary axis).

    Returns
    -------
    RigidFit
        Estimates, standard deviations, relative error, condition numbers.

    Raises
    ------
    IllConditionedError
        No motion, no acceleration or constant velocity only.
    DataError
        Logs whose position or force units differ.
    """
    logs = [log] if isinstance(log, Log) else list(log)
    if not logs:
        raise UsageError("fit_rigid needs at least one log")
    source = logs[0].source if len(logs) == 1 else f"{len(logs)} logs ({logs[0].source}, ...)"
    where = f"{source}: rigid-body fit"
    rules = []
    prepared = []
    for lg in logs:
        cut = cutoff_hz
        if cut is None:
            cut, how = _auto_cutoff_of(lg, position_si(lg, position)[0], uniform_sample_time(lg))
            rules.append((cut, how))
        samples = _prepare(lg, force, position, cut, filter_order, decimate, force_scale, force_unit)
        _check_kinematics(samples, f"{lg.source}: rigid-body fit")
        prepared.append(samples)
    first = prepared[0]
    for lg, smp in zip(logs[1:], prepared[1:], strict=True):
        if (smp.position_unit, smp.force_unit) != (first.position_unit, first.force_unit):
            raise DataError(f"{lg.source}: position in {smp.position_unit} and force in {smp.force_unit}, but "
                            f"{logs[0].source} has {first.position_unit} and {first.force_unit}; the logs of one "
                            "fit must share their units")
    # every candidate column decimated once (decimation is linear); the directions of the decimated velocity
    # decide which of them the data can separate
    dec = np.vstack([decimate_columns(np.column_stack([_regressor(smp.velocity, smp.acceleration, SYMMETRIC_PARAMS),
                                                       _regressor(smp.velocity, smp.acceleration, ASYMMETRIC_PARAMS),
                                                       smp.velocity, smp.force]), smp.decimate)
                     for smp in prepared])
    dq, y = dec[:, -2], dec[:, -1]
    if velocity_threshold is not None:
        keep = np.abs(dq) >= _positive_float(velocity_threshold, "velocity_threshold")
        dec, dq, y = dec[keep], dq[keep], y[keep]
    names, use, direction_notes = _directions(dq, asymmetric, f"{first.position_unit}/s")
    columns = {SYMMETRIC_PARAMS: [0, 1, 2, 3], ASYMMETRIC_PARAMS: [4, 5, 6, 7, 8],
               ONE_DIRECTION_PARAMS: [0, 1, 3], ONE_SPEED_PARAMS: [0, 1]}[names]
    W, y = dec[use][:, columns], y[use]
    if y.size < 3 * len(names):
        raise DataError(f"{where}: only {y.size} samples left after decimation and velocity_threshold")
    cond, scaled_cond, norms = _scaled_condition(W, names, where)
    theta, stds, on_bound, residual = _bounded_least_squares(W, y, names)
    values = {n: float(v) for n, v in zip(names, theta, strict=True)}
    warnings = [w for lg in logs for w in data_warnings(lg, force, position, first.force_unit)]
    try:
        _check_mass(values, stds, f"{first.force_unit}/({first.position_unit}/s^2)", where, on_bound)
    except IllConditionedError as exc:
        if not warnings:
            raise
        raise IllConditionedError(f"{exc}; the log: {'; '.join(warnings)}",
                                  parameter=[p for w in warnings for p in getattr(w, "parameters", ())]) from None
    rel = float(100.0 * np.linalg.norm(residual) / np.linalg.norm(y))
    unit_of = {"mass": f"{first.force_unit}/({first.position_unit}/s^2)"}
    warnings = (direction_notes + warnings + fit_warnings(rel, values, stds, unit_of)
                + _bound_warnings(on_bound, first.force_unit, first.position_unit))
    return RigidFit(
        model=_model_from(values, first),
        values=values,
        std=stds,
        relative_error_pct=rel,
        residual_rms=float(np.sqrt(np.mean(residual**2))),
        condition_number=cond,
        scaled_condition_number=scaled_cond,
        column_norms={n: float(c) for n, c in zip(names, norms, strict=True)},
        n_samples=int(y.size),
        decimate=max(smp.decimate for smp in prepared),
        cutoff_hz=max(smp.cutoff_hz for smp in prepared),
        filter_order=first.filter_order,
        force_unit=first.force_unit,
        position_unit=first.position_unit,
        asymmetric=asymmetric and names == ASYMMETRIC_PARAMS,
        source=source,
        warnings=tuple(dict.fromkeys(warnings)),
        cutoff_rule="given" if cutoff_hz is not None else _rule_text(rules),
        on_bound=on_bound,
    )


def _rule_text(rules: list[tuple[float, str]]) -> str:
    """How the cut-offs of one or several logs were chosen, in one sentence."""
    if len(rules) == 1:
        return f"{rules[0][0]:g} Hz: {rules[0][1]}"
    cuts = [c for c, _ in rules]
    raised = sum("raised" in how for _, how in rules)
    return (f"{min(cuts):g}-{max(cuts):g} Hz over the {len(rules)} logs, each {AUTO_CUTOFF_FACTOR:g} x where its "
            f"velocity spectrum falls to {AUTO_CUTOFF_DB:g} dB above its noise floor"
            + (f" (raised to the lowest its length allows in {raised})" if raised else ""))


def data_warnings(log: Log, force: str, position: str, force_unit: str) -> list[str]:
    """Quantization of the position and clipping of the command in the raw log
    (:mod:`feedtune.identify.data_quality`)."""
    q, unit = position_si(log, position)
    found = [quantization_warning(q, f"position column {position!r}", unit),
             clipping_warning(log.get(force), f"command column {force!r}", log.unit(force) or force_unit)]
    return [w for w in found if w]


def _model_from(values: dict[str, float], samples: _Samples) -> RigidBodyModel:
    units = {"command_unit": samples.force_unit, "position_unit": samples.position_unit}
    if set(values) == set(ONE_SPEED_PARAMS):
        return RigidBodyModel(mass=values["mass"], viscous=values["viscous"], **units)
    if "constant" in values:
        return RigidBodyModel(mass=values["mass"], viscous=values["viscous"], offset=values["constant"], **units)
    if "offset" in values:
        return RigidBodyModel(mass=values["mass"], viscous=values["viscous"], coulomb_pos=values["coulomb"],
                              coulomb_neg=values["coulomb"], offset=values["offset"], **units)
    return RigidBodyModel(mass=values["mass"], viscous=values["viscous_pos"],
                          coulomb_pos=values["coulomb_pos"], coulomb_neg=values["coulomb_neg"], offset=0.0,
                          viscous_neg=values["viscous_neg"], **units)


def validate_rigid(log: Log, model: RigidBodyModel, *, force: str, position: str, cutoff_hz: float = 100.0,
                   filter_order: int = 4, decimate: int | None = None, force_scale: float = 1.0,
                   velocity_threshold: float | None = None) -> RigidValidation:
    """Relative force error of a rigid-body model on another log (cross-validation, same processing).

    The model's force is computed from the filtered kinematics at the full rate and decimated in parallel
    with the measured force, exactly as in :func:`fit_rigid`.

    Parameters
    ----------
    log : Log
        Uniformly sampled validation log.
    model : RigidBodyModel
        Model to test (e.g. ``fit_rigid(...).model``); its position unit must match the log's.
    force, position, cutoff_hz, filter_order, decimate, force_scale, velocity_threshold
        As for :func:`fit_rigid`.

    Returns
    -------
    RigidValidation
        Relative error [%] and RMS error [force unit].
    """
    samples = _prepare(log, force, position, cutoff_hz, filter_order, decimate, force_scale,
                       model.command_unit)
    if samples.position_unit != model.position_unit:
        raise DataError(f"{log.source}: position column {position!r} is in {samples.position_unit} but the "
                        f"model is in {model.position_unit}")
    predicted = model.force(samples.acceleration, samples.velocity)
    dec = decimate_columns(np.column_stack([predicted, samples.velocity, samples.force]), samples.decimate)
    if velocity_threshold is not None:
        threshold = _positive_float(velocity_threshold, "velocity_threshold")
        dec = dec[np.abs(dec[:, 1]) >= threshold]
    if dec.shape[0] == 0:
        raise DataError(f"{log.source}: no samples left after velocity_threshold")
    err = dec[:, 2] - dec[:, 0]
    return RigidValidation(
        relative_error_pct=float(100.0 * np.linalg.norm(err) / np.linalg.norm(dec[:, 2])),
        residual_rms=float(np.sqrt(np.mean(err**2))),
        n_samples=int(dec.shape[0]),
        force_unit=model.command_unit,
        source=log.source,
    )
