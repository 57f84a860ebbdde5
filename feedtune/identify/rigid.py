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

Ill-conditioned problems (no acceleration, constant velocity, one direction only for the asymmetric model)
raise :class:`~feedtune.errors.IllConditionedError` naming the degenerate columns instead of returning
meaningless numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

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

SYMMETRIC_PARAMS = ("mass", "viscous", "coulomb", "offset")
ASYMMETRIC_PARAMS = ("mass", "viscous_pos", "coulomb_pos", "viscous_neg", "coulomb_neg")
COLUMN_LABELS = {
    "mass": "ddq (acceleration)", "viscous": "dq (velocity)", "coulomb": "sign(dq)", "offset": "1 (constant)",
    "viscous_pos": "dq for dq>0", "coulomb_pos": "1 for dq>0", "viscous_neg": "dq for dq<0",
    "coulomb_neg": "-1 for dq<0",
}


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
    if not log.is_uniform():
        raise DataError(f"{log.source}: time base is not uniform (sample intervals differ by more than "
                        "0.1 %); resample the log first")
    return log.dt


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
        raise UsageError(f"{name} must be a number, got {value!r}") from None
    if not (np.isfinite(x) and x > 0):
        raise UsageError(f"{name} must be > 0, got {value!r}")
    return x


# ------------------------------------------------------------------------------------------ result types
@dataclass(frozen=True)
class RigidFit:
    """Result of :func:`fit_rigid`.

    Attributes
    ----------
    model : RigidBodyModel
        The identified model (symmetric fit: ``offset`` identified; asymmetric fit: ``offset = 0``).
    values, std : dict of str to float
        Estimates and their standard deviations ``sqrt(diag(sigma^2 (W^T W)^-1))``; names are
        ``mass, viscous, coulomb, offset`` or ``mass, viscous_pos, coulomb_pos, viscous_neg, coulomb_neg``.
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
        Butterworth cut-off [Hz].
    filter_order : int
        Butterworth order.
    force_unit, position_unit : str
        Units of the force and of the position (``"m"`` or ``"rad"``).
    warnings : tuple of str
        What makes the fit unreliable (:mod:`feedtune.identify.data_quality`: coarse position quantization,
        a clipped command, a poor fit, a poorly determined mass).
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

    @property
    def units(self) -> dict[str, str]:
        """Unit of every estimated parameter."""
        f, p = self.force_unit, self.position_unit
        unit_of = {"mass": f"{f}/({p}/s^2)", "viscous": f"{f}/({p}/s)", "coulomb": f, "offset": f}
        return {name: unit_of[name.split("_")[0]] for name in self.values}

    def to_dict(self) -> dict:
        """JSON-ready summary with units."""
        return {
            "source": self.source,
            "model": "rigid-asymmetric" if self.asymmetric else "rigid",
            "values": dict(self.values),
            "std": dict(self.std),
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


def _check_settings(fs: float, cutoff_hz, filter_order, decimate) -> tuple[float, int, int]:
    cutoff = _positive_float(cutoff_hz, "cutoff_hz")
    if cutoff >= fs / 2:
        raise UsageError(f"cutoff_hz must be below the Nyquist frequency {fs / 2:g} Hz, got {cutoff:g}")
    if not (isinstance(filter_order, (int, np.integer)) and 1 <= filter_order <= 12):
        raise UsageError(f"filter_order must be an integer from 1 to 12, got {filter_order!r}")
    if decimate is None:
        # EMPS rule: Butterworth at 5x the dynamic bandwidth, decimation filter (0.8 fs / (2 nd)) at 2x it.
        factor = max(1, round(0.8 * (fs / 2) / (0.4 * cutoff)))
    elif isinstance(decimate, (int, np.integer)) and decimate >= 1:
        factor = int(decimate)
    else:
        raise UsageError(f"decimate must be an integer >= 1 or None, got {decimate!r}")
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
        raise UsageError(f"force_scale must be a finite non-zero number, got {force_scale!r}")
    dt = uniform_sample_time(log)
    cutoff, order, factor = _check_settings(1.0 / dt, cutoff_hz, filter_order, decimate)
    q, pos_unit = position_si(log, position)
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


def _regressor(dq: np.ndarray, ddq: np.ndarray, asymmetric: bool) -> np.ndarray:
    """Full-rate observation matrix (see module doc)."""
    s = np.sign(dq)
    if not asymmetric:
        return np.column_stack([ddq, dq, s, np.ones_like(dq)])
    o_pos = (1.0 + s) / 2.0
    o_neg = (1.0 - s) / 2.0
    return np.column_stack([ddq, dq * o_pos, s * o_pos, dq * o_neg, s * o_neg])


# ---------------------------------------------------------------------------------------- conditioning
def _check_directions(dq: np.ndarray, asymmetric: bool, where: str) -> None:
    if not asymmetric:
        return
    n = dq.size
    for sign, label, cols in ((1, ">", "viscous_pos, coulomb_pos"), (-1, "<", "viscous_neg, coulomb_neg")):
        count = int(np.count_nonzero(np.sign(dq) == sign))
        if count < max(20, n // 100):
            raise IllConditionedError(
                f"{where}: asymmetric model needs motion in both directions, but only {count} of {n} samples "
                f"have dq {label} 0 (columns {cols} are empty); use the symmetric model or a log that "
                "moves both ways")


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


def _check_mass(values: dict[str, float], std: dict[str, float], unit: str, where: str) -> None:
    mass, sd = values["mass"], std["mass"]
    if not (mass > 0 and sd <= MAX_MASS_RELATIVE_STD * mass):
        raise IllConditionedError(
            f"{where}: acceleration column ddq carries no usable information (mass = {mass:.4g} +/- {sd:.2g} "
            f"{unit}); the log needs clear acceleration phases (or check the sign of force_scale)")


# ------------------------------------------------------------------------------------------ public API
def fit_rigid(log: Log, *, force: str, position: str, asymmetric: bool = False, cutoff_hz: float = 100.0,
              filter_order: int = 4, decimate: int | None = None, force_scale: float = 1.0,
              velocity_threshold: float | None = None, force_unit: str | None = None) -> RigidFit:
    """Identify mass, viscous and Coulomb friction and offset from a tracking log by IDIM-LS.

    Model ``tau = M ddq + Fv dq + Fc sign(dq) + offset`` (asymmetric: ``Fv+, Fc+`` for ``dq > 0`` and
    ``Fv-, Fc-`` for ``dq < 0``, Coulomb values as magnitudes, no offset). Processing as in the EMPS
    benchmark; see the module docstring.

    Parameters
    ----------
    log : Log
        Uniformly sampled tracking log.
    force : str
        Column with the drive command or force [V, N or N*m]; multiplied by ``force_scale``.
    position : str
        Column with the measured position [m or rad; mm, um, nm and deg are converted].
    asymmetric : bool
        Separate viscous and Coulomb coefficients per direction.
    cutoff_hz : float
        Cut-off of the zero-phase Butterworth position filter [Hz] (about 5x the dynamic bandwidth).
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
        No motion, no acceleration, constant velocity only, or (asymmetric) motion in one direction only.
    """
    where = f"{log.source}: rigid-body fit"
    samples = _prepare(log, force, position, cutoff_hz, filter_order, decimate, force_scale, force_unit)
    names = ASYMMETRIC_PARAMS if asymmetric else SYMMETRIC_PARAMS
    _check_kinematics(samples, where)
    _check_directions(samples.velocity, asymmetric, where)
    full = np.column_stack([_regressor(samples.velocity, samples.acceleration, asymmetric),
                            samples.velocity, samples.force])
    dec = decimate_columns(full, samples.decimate)
    W, dq, y = dec[:, :-2], dec[:, -2], dec[:, -1]
    if velocity_threshold is not None:
        threshold = _positive_float(velocity_threshold, "velocity_threshold")
        keep = np.abs(dq) >= threshold
        W, dq, y = W[keep], dq[keep], y[keep]
    if y.size < 3 * len(names):
        raise DataError(f"{where}: only {y.size} samples left after decimation and velocity_threshold")
    cond, scaled_cond, norms = _scaled_condition(W, names, where)
    theta, *_ = np.linalg.lstsq(W, y, rcond=None)
    residual = y - W @ theta
    sigma2 = float(residual @ residual) / (y.size - len(names))
    std = np.sqrt(sigma2 * np.diag(np.linalg.inv(W.T @ W)))
    values = {n: float(v) for n, v in zip(names, theta, strict=True)}
    stds = {n: float(s) for n, s in zip(names, std, strict=True)}
    warnings = data_warnings(log, force, position, samples.force_unit)
    try:
        _check_mass(values, stds, f"{samples.force_unit}/({samples.position_unit}/s^2)", where)
    except IllConditionedError as exc:
        if not warnings:
            raise
        raise IllConditionedError(f"{exc}; the log: {'; '.join(warnings)}") from None
    rel = float(100.0 * np.linalg.norm(residual) / np.linalg.norm(y))
    unit_of = {"mass": f"{samples.force_unit}/({samples.position_unit}/s^2)"}
    warnings += fit_warnings(rel, values, stds, unit_of)
    return RigidFit(
        model=_model_from(values, samples),
        values=values,
        std=stds,
        relative_error_pct=rel,
        residual_rms=float(np.sqrt(np.mean(residual**2))),
        condition_number=cond,
        scaled_condition_number=scaled_cond,
        column_norms={n: float(c) for n, c in zip(names, norms, strict=True)},
        n_samples=int(y.size),
        decimate=samples.decimate,
        cutoff_hz=samples.cutoff_hz,
        filter_order=samples.filter_order,
        force_unit=samples.force_unit,
        position_unit=samples.position_unit,
        asymmetric=asymmetric,
        source=log.source,
        warnings=tuple(warnings),
    )


def data_warnings(log: Log, force: str, position: str, force_unit: str) -> list[str]:
    """Quantization of the position and clipping of the command in the raw log
    (:mod:`feedtune.identify.data_quality`)."""
    q, unit = position_si(log, position)
    found = [quantization_warning(q, f"position column {position!r}", unit),
             clipping_warning(log.get(force), f"command column {force!r}", log.unit(force) or force_unit)]
    return [w for w in found if w]


def _model_from(values: dict[str, float], samples: _Samples) -> RigidBodyModel:
    units = {"command_unit": samples.force_unit, "position_unit": samples.position_unit}
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
