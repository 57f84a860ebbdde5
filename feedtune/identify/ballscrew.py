"""Identification of the ball-screw 2-mass model (thesis eq. 3.1-3.4, Table 3.1) from measured FRFs.

:func:`fit_ballscrew` fits ``m1, m2, b1, b2, k, c`` of :class:`~feedtune.models.ballscrew.BallScrewModel`
to the motor-side (``x1/u``) and, when measured, table-side (``x2/u``) frequency responses. The fit

* converts every FRF to position [rad per input unit] (position, velocity and acceleration FRFs all work;
  outputs in m are converted to equivalent screw rotation with ``lead_m_per_rad``),
* finds the first axial mode (the first strong peak of the acceleration FRF above the rigid-body level)
  and, by default, fits the band from a decade below it to twice its frequency, kept below any further
  resonance (torsional modes, current loop),
* minimises the logarithmic complex error ``log(H_model / H)`` (log-magnitude plus phase), with every point
  weighted by its share of the logarithmic frequency axis so that each decade counts equally, and by
  ``sqrt(coherence)`` when the coherence was measured,
* fits an equivalent delay ``exp(-s T)`` beside the model (sampling, computation, current loop) so that
  their phase lag is not mistaken for damping; the delay is reported but is not part of the model,
* starts from values read off the data: rigid-body inertia from the low-frequency acceleration level,
  mass split and stiffness from the anti-resonance and resonance frequencies of ``x1/u``, nut damping
  from the half-power width, viscous damping from the low-frequency phase.

Parameter standard deviations come from the Jacobian at the solution
(``cov = s^2 (J^T J)^-1`` with the residual variance ``s^2``).

The table-side response alone cannot separate the two masses: ``x2/u = (c s + k) / (s (m1 m2 s^3 + ...))``
only determines the total inertia, the mode and its damping. ``x1/u`` is therefore required.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..display import param_text
from ..errors import DataError, UsageError
from ..frf import Frf
from ..frf_quality import averages_of, line_errors, trust_of
from ..models.ballscrew import PARAM_NAMES, BallScrewModel, Mode, param_units

DEFAULT_CHANNELS = ("x1/u", "x2/u")
"""Default motor-side and table-side channel names ``OUT/IN``."""

_ANGLE_UNITS = {"rad": 1.0, "deg": np.pi / 180.0}
_LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6}

_PEAK_PROMINENCE_DB = 6.0
"""A resonance must stand this far [dB] above its surroundings and above the rigid-body level."""
_MIN_COHERENCE = 0.8
_LOW_COHERENCE_SHARE = 0.1
_REAL_POLE_MARGIN = 10.0
"""b1, b2 are poorly determined when the band starts more than this factor above the real pole."""
_REL_STD_LIMIT = 0.5
_X1, _X2 = 0, 1
_LOG_PARAMS = ("m1", "m2", "k")
"""Fitted as logarithms (always > 0); the others are scaled linear values with bound >= 0."""
_FIT_ORDER = ("m1", "m2", "k", "c", "b1", "b2", "delay")


# ----------------------------------------------------------------------------------------- value types
@dataclass(frozen=True)
class BallScrewFit:
    """Result of :func:`fit_ballscrew`.

    Attributes
    ----------
    model : BallScrewModel
        Identified parameters (control-signal equivalent units, see :mod:`feedtune.models.ballscrew`).
    std : dict of str to float
        One-sigma standard deviation of each parameter, same units as the parameter.
    modes : list of Mode
        Complex-pole modes of the model (frequency [Hz], damping ratio [-]).
    real_pole_hz : float
        Real pole [Hz] from viscous friction and total inertia.
    band_hz : tuple of float
        Fitted frequency band ``(low, high)`` [Hz].
    fit : dict of str to dict
        Per channel: ``nrmse`` (RMS over the band points of the relative complex error
        ``|H_model - H| / |H|`` [-], the same for position, velocity and acceleration data),
        ``mag_rms_db`` [dB], ``phase_rms_deg`` [deg] and ``n_points``.
    warnings : list of str
        Poor fit, poorly determined parameters, low coherence.
    delay_s : float
        Equivalent delay [s] fitted beside the model (0 when not fitted).
    delay_std_s : float
        Its standard deviation [s].
    detected_mode_hz : float
        Frequency [Hz] of the first axial mode found in the data (before the fit).
    """

    model: BallScrewModel
    std: dict[str, float]
    modes: list[Mode]
    real_pole_hz: float
    band_hz: tuple[float, float]
    fit: dict[str, dict[str, float | int]]
    warnings: list[str] = field(default_factory=list)
    delay_s: float = 0.0
    delay_std_s: float = 0.0
    detected_mode_hz: float = float("nan")

    def __repr__(self) -> str:
        """The model, the band, the fit error per channel, the delay and how many warnings (:attr:`warnings`)."""
        from ..display import call, quantity, span

        errors = ", ".join(f"{ch} {quantity(100.0 * f['nrmse'], '%')}" for ch, f in self.fit.items())
        parts = [repr(self.model), f"band {span(*self.band_hz, 'Hz')}", f"error {errors}"]
        if self.delay_s:
            parts.append(f"delay {quantity(self.delay_s * 1e6, 'us')}")
        parts.append(f"{len(self.warnings)} warning{'' if len(self.warnings) == 1 else 's'}")
        return call("BallScrewFit", parts)

    def to_dict(self) -> dict:
        """JSON-ready summary; units in the ``"units"`` entry."""
        unit_in = self.model.input_unit
        units = param_units(unit_in)
        units.update({"freq_hz": "Hz", "zeta": "-", "real_pole_hz": "Hz", "band_hz": "Hz", "delay_s": "s",
                      "nrmse": "-", "mag_rms_db": "dB", "phase_rms_deg": "deg",
                      "lead_m_per_rad": "m/rad"})
        return {
            "kind": "ballscrew",
            "params": {name: float(value) for name, value in self.model.params().items()},
            "units": units,
            "std": {name: float(value) for name, value in self.std.items()},
            "modes": [{"freq_hz": float(m.freq_hz), "zeta": float(m.zeta)} for m in self.modes],
            "real_pole_hz": float(self.real_pole_hz),
            "band_hz": [float(self.band_hz[0]), float(self.band_hz[1])],
            "detected_mode_hz": float(self.detected_mode_hz),
            "delay_s": float(self.delay_s),
            "delay_std_s": float(self.delay_std_s),
            "input_unit": unit_in,
            "lead_m_per_rad": float(self.model.lead_m_per_rad),
            "fit": {ch: {key: (int(v) if key == "n_points" else float(v)) for key, v in q.items()}
                    for ch, q in self.fit.items()},
            "warnings": [str(w) for w in self.warnings],
        }


@dataclass(frozen=True)
class _Series:
    """One channel of one file, as position response [rad/input unit] on frequencies > 0 Hz."""

    channel: str
    role: int
    freq_hz: np.ndarray
    response: np.ndarray
    coherence: np.ndarray | None
    source: str
    input_unit: str

    def select(self, lo_hz: float, hi_hz: float) -> _Series:
        """The part with ``lo_hz <= f <= hi_hz``."""
        m = (self.freq_hz >= lo_hz) & (self.freq_hz <= hi_hz)
        coh = None if self.coherence is None else self.coherence[m]
        return _Series(self.channel, self.role, self.freq_hz[m], self.response[m], coh, self.source,
                       self.input_unit)

    def acceleration_db(self) -> np.ndarray:
        """Magnitude of the acceleration response [dB re 1 rad/s^2 per input unit]."""
        w = 2 * np.pi * self.freq_hz
        return 20 * np.log10(np.maximum(np.abs(self.response) * w**2, 1e-300))


# ----------------------------------------------------------------------------------------- public API
def fit_ballscrew(
    frfs: Sequence[Frf] | Frf,
    *,
    band_hz: tuple[float, float] | None = None,
    channels: Sequence[str] | None = None,
    lead_m_per_rad: float | None = None,
    poor_fit_threshold: float = 0.1,
    fit_delay: bool = True,
) -> BallScrewFit:
    """Fit the ball-screw 2-mass model (eq. 3.1) to measured FRFs.

    Parameters
    ----------
    frfs : Frf or sequence of Frf
        Measured responses from the drive command to the motor-side position ``x1`` and (optionally) the
        table position ``x2``; position, velocity or acceleration FRFs. A channel found in several FRFs is
        fitted from all of them. Outputs in rad (equivalent screw rotation), deg, m, mm or um.
    band_hz : (float, float), optional
        Frequency band [Hz] to fit; it must contain the first axial mode. Default: from a tenth of the
        first axial mode (not below the lowest measured frequency) to twice the mode, kept below any
        further resonance.
    channels : sequence of str, optional
        Motor-side and table-side channel names ``OUT/IN`` in this order (default ``x1/u``, ``x2/u``;
        ``x2/u`` is used when present). One name fits the motor-side channel alone.
    lead_m_per_rad : float, optional
        Screw lead [m/rad] converting table travel to equivalent screw rotation; needed when an output is
        in m, mm or um, and stored in the model (default 0.02 / (2 pi) m/rad).
    poor_fit_threshold : float
        A channel whose ``nrmse`` exceeds this value [-] gets a "poor fit" warning.
    fit_delay : bool
        Fit an equivalent delay [s] beside the model (recommended for measured data).

    Returns
    -------
    BallScrewFit
        The model, standard deviations, modes, fit quality and warnings.

    Raises
    ------
    DataError
        Missing channels, unusable units, no resonance in the band, fewer band points than parameters.
    UsageError
        Invalid ``band_hz``, ``channels``, ``lead_m_per_rad`` or ``poor_fit_threshold``.

    Examples
    --------
    >>> from feedtune.models.ballscrew import THESIS_TABLE_3_1
    >>> frf = THESIS_TABLE_3_1.frf(np.geomspace(1, 1000, 400), quantity="acceleration")
    >>> result = fit_ballscrew([frf])
    >>> round(result.modes[0].freq_hz)
    130
    """
    frf_list = _as_frf_list(frfs)
    roles = _resolve_channels(channels)
    _check_positive(poor_fit_threshold, "poor_fit_threshold", "[-]")
    if lead_m_per_rad is not None:
        _check_positive(lead_m_per_rad, "lead_m_per_rad", "m/rad")
    noise_notes: list[str] = []
    series = _collect_series(frf_list, roles, lead_m_per_rad, noise_notes)
    input_unit = _common_input_unit(series)

    names = list(_FIT_ORDER if fit_delay else _FIT_ORDER[:-1])
    band, f_mode = _choose_band(series, band_hz, len(names))
    in_band = [s for s in (s.select(*band) for s in series) if s.freq_hz.size]

    problem = _Problem.build(in_band, names)
    start = _initial_values(in_band, f_mode)
    theta, std, converged = problem.solve(start, f_mode)

    lead = float(lead_m_per_rad) if lead_m_per_rad is not None else BallScrewModel.lead_m_per_rad
    model = BallScrewModel(**{p: theta[p] for p in PARAM_NAMES}, lead_m_per_rad=lead, input_unit=input_unit,
                           lead_given=lead_m_per_rad is not None)
    delay = theta.get("delay", 0.0)
    quality = _fit_quality(in_band, model, delay)
    outliers = {ch: _outlier_lines(f, np.log(r)) for ch, f, r in _channel_ratios(in_band, model, delay)}
    warnings = noise_notes + _fit_warnings(model, std, quality, in_band, band, poor_fit_threshold, converged, outliers)
    return BallScrewFit(
        model=model,
        std={p: std[p] for p in PARAM_NAMES},
        modes=model.modes(),
        real_pole_hz=model.real_pole_hz(),
        band_hz=band,
        fit=quality,
        warnings=warnings,
        delay_s=float(delay),
        delay_std_s=float(std.get("delay", 0.0)),
        detected_mode_hz=float(f_mode),
    )


# ----------------------------------------------------------------------------------------- inputs
def _as_frf_list(frfs: Sequence[Frf] | Frf) -> list[Frf]:
    """Accept one Frf or a sequence of them."""
    if isinstance(frfs, Frf):
        return [frfs]
    try:
        frf_list = list(frfs)
    except TypeError:
        raise UsageError(f"frfs must be an Frf or a sequence of Frf, got {type(frfs).__name__}") from None
    if not frf_list:
        raise UsageError("frfs is empty: give at least one measured FRF")
    for i, frf in enumerate(frf_list):
        if not isinstance(frf, Frf):
            raise UsageError(f"frfs[{i}] must be an Frf, got {type(frf).__name__}")
    return frf_list


def _check_positive(value: float, name: str, unit: str) -> None:
    """Raise UsageError unless ``value`` is a finite number > 0."""
    try:
        ok = np.isfinite(float(value)) and float(value) > 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise UsageError(f"{name} must be a finite number > 0 {unit}, got {value!r}", parameter=name)


def _resolve_channels(channels: Sequence[str] | None) -> list[tuple[str, int, bool]]:
    """Return ``[(name, role, required)]``: role 0 motor side (x1), 1 table side (x2)."""
    if channels is None:
        return [(DEFAULT_CHANNELS[0], _X1, True), (DEFAULT_CHANNELS[1], _X2, False)]
    if isinstance(channels, str):
        channels = [channels]
    names = list(channels)
    if not 1 <= len(names) <= 2:
        raise UsageError(f"channels must name the motor-side and table-side channels (1 or 2), got {names}",
                         parameter="channels")
    for name in names:
        if not isinstance(name, str) or name.count("/") != 1 or not all(name.split("/")):
            raise UsageError(f"channel name {name!r} must look like OUT/IN, e.g. x1/u")
    if len(set(names)) != len(names):
        raise UsageError(f"channels must be two different names, got {names}", parameter="channels")
    if len(names) == 1 and names[0].split("/")[0] == "x2":
        raise DataError(f"channel {names[0]} alone cannot separate m1 and m2 (it only determines the total "
                        "inertia and the mode): add the motor-side channel, e.g. channels=['x1/u', 'x2/u']")
    return [(name, role, True) for role, name in enumerate(names)]


def _position_scale(unit: str, lead_m_per_rad: float | None, where: str) -> float:
    """Factor converting an output unit to equivalent screw rotation [rad]."""
    key = str(unit).strip()
    if key in _ANGLE_UNITS:
        return _ANGLE_UNITS[key]
    if key in _LENGTH_UNITS:
        if lead_m_per_rad is None:
            raise UsageError(f"{where}: output unit is {key}; pass lead_m_per_rad (screw lead in m/rad) to "
                             "convert table travel to screw rotation")
        return _LENGTH_UNITS[key] / float(lead_m_per_rad)
    accepted = ", ".join([*_ANGLE_UNITS, *_LENGTH_UNITS])
    raise DataError(f"{where}: output unit {key!r} not supported for a ball-screw fit; "
                    f"expected one of {accepted}")


def _collect_series(
    frf_list: list[Frf], roles: list[tuple[str, int, bool]], lead_m_per_rad: float | None,
    notes: list[str] | None = None,
) -> list[_Series]:
    """Extract the requested channels from all FRFs as position responses in rad, each below where its lines turn
    to noise (``notes`` gets a line per channel cut)."""
    notes = [] if notes is None else notes
    series = []
    for name, role, required in roles:
        found = [frf for frf in frf_list if frf.has(name)]
        if not found and required:
            available = sorted({ch for frf in frf_list for ch in frf.channels})
            raise DataError(f"channel {name} not found in {', '.join(f.source for f in frf_list)} "
                            f"(available: {', '.join(available)}); pass channels=[motor-side, table-side]",
                            parameter="fit_ballscrew.channels")
        for frf in found:
            positive = frf.select(lo_hz=float(np.nextafter(0.0, 1.0)))
            if positive.freq_hz.size == 0:
                raise DataError(f"{frf.source}: channel {name} has no frequencies above 0 Hz")
            pos = positive.as_quantity("position")
            scale = _position_scale(frf.output_unit, lead_m_per_rad, frf.source)
            s = _Series(name, role, pos.freq_hz, pos.channel(name) * scale, pos.channel_coherence(name), frf.source,
                        frf.input_unit)
            series.append(_without_noise(s, averages_of(frf.meta), notes))
    return series


def _without_noise(s: _Series, averages: float | None, notes: list[str]) -> _Series:
    """The series below where its lines turn to noise (:mod:`feedtune.frf_quality`), with a note when lines were
    left out: a fit never follows lines whose 2-sigma error holds the origin."""
    coh = None if s.coherence is None or not np.all(np.isfinite(s.coherence)) else s.coherence
    trust = trust_of(s.freq_hz, line_errors(s.freq_hz, s.response, coh, averages), averages)
    if trust.noise_from_hz is None and trust.noise_below_hz is None:
        return s
    notes.append(f"{s.channel} ({s.source}): {trust.describe()}; left out of the fit")
    return s.select(trust.band_bottom_hz, trust.band_top_hz)


def _common_input_unit(series: list[_Series]) -> str:
    """The input unit shared by all used channels (DataError when they differ)."""
    units = {s.input_unit for s in series}
    if len(units) > 1:
        raise DataError(f"the FRFs use different input units ({', '.join(sorted(units))}); convert them to "
                        "one drive-command unit before fitting")
    return units.pop()


# ----------------------------------------------------------------------------------------- band
def _resonance_peaks(freq_hz: np.ndarray, level_db: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies [Hz] and levels [dB] of peaks standing out by the required prominence.

    A 5-point running median removes isolated noise spikes before the search.
    """
    from scipy.ndimage import median_filter
    from scipy.signal import find_peaks

    smooth = median_filter(level_db, size=5, mode="nearest") if level_db.size >= 5 else level_db
    idx, _ = find_peaks(smooth, prominence=_PEAK_PROMINENCE_DB)
    return freq_hz[idx], smooth[idx]


def _rigid_body_level_db(freq_hz: np.ndarray, level_db: np.ndarray) -> float:
    """Median acceleration level [dB] over the lowest tenth of the logarithmic frequency range."""
    lf = np.log10(freq_hz)
    low = lf <= lf[0] + 0.1 * (lf[-1] - lf[0])
    return float(np.median(level_db[low]))


def _series_modes(s: _Series) -> tuple[float, np.ndarray]:
    """First axial mode [Hz] of one series (NaN if none) and all its resonance peaks [Hz]."""
    if s.freq_hz.size < 5:
        return float("nan"), np.empty(0)
    level = s.acceleration_db()
    peaks_hz, peaks_db = _resonance_peaks(s.freq_hz, level)
    strong = peaks_hz[peaks_db >= _rigid_body_level_db(s.freq_hz, level) + _PEAK_PROMINENCE_DB]
    return (float(strong[0]) if strong.size else float("nan")), peaks_hz


def _detect_modes(series: list[_Series]) -> tuple[float, float]:
    """First axial mode [Hz] (NaN when none) and the next resonance above it [Hz] (inf when none).

    The table-side channel shows the axial mode most cleanly and is preferred; the motor-side channel is
    used when the table side is absent or shows no resonance.
    """
    found = [(s.role, *_series_modes(s)) for s in series]
    modes = {role: [m for r, m, _ in found if r == role and np.isfinite(m)] for role in (_X1, _X2)}
    chosen = modes[_X2] or modes[_X1]
    if not chosen:
        return float("nan"), float("inf")
    f_mode = float(np.median(chosen))
    above = [p for _, _, peaks in found for p in peaks if p > 1.25 * f_mode]
    return f_mode, (float(min(above)) if above else float("inf"))


def _default_band(f_mode: float, f_next: float, f_min: float, f_max: float) -> tuple[float, float]:
    """From a tenth of the mode to twice the mode, below the next resonance and within the data."""
    hi = 2.0 * f_mode
    if np.isfinite(f_next):
        hi = min(hi, f_next / 1.5 if f_next / 1.5 > 1.25 * f_mode else np.sqrt(f_mode * f_next))
    return max(f_mode / 10.0, f_min), min(hi, f_max)


def _check_band_value(band_hz) -> tuple[float, float]:
    """Validate a user band ``(low, high)`` [Hz]."""
    try:
        lo, hi = (float(v) for v in band_hz)
    except (TypeError, ValueError):
        raise UsageError(f"band_hz must be two numbers (low, high) in Hz, got {band_hz!r}",
                         parameter="band_hz") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise UsageError(f"band_hz must satisfy 0 <= low < high (Hz), got ({lo:g}, {hi:g})", parameter="band_hz")
    return lo, hi


def _check_point_count(series: list[_Series], band: tuple[float, float], n_params: int) -> None:
    """DataError when the band holds fewer FRF points than there are parameters."""
    lo, hi = band
    n_points = sum(int(np.count_nonzero((s.freq_hz >= lo) & (s.freq_hz <= hi))) for s in series)
    if n_points < n_params:
        raise DataError(f"band {lo:g}-{hi:g} Hz holds {n_points} FRF points; the fit needs at least "
                        f"{n_params} (one per parameter): widen band_hz or measure more points")


def _choose_band(series: list[_Series], band_hz, n_params: int) -> tuple[tuple[float, float], float]:
    """Return the fit band [Hz] and the first axial mode [Hz] inside it."""
    f_mode, f_next = _detect_modes(series)
    f_min = min(float(s.freq_hz[0]) for s in series)
    f_max = max(float(s.freq_hz[-1]) for s in series)
    if band_hz is None:
        if not np.isfinite(f_mode):
            sources = ", ".join(sorted({s.source for s in series}))
            raise DataError(f"{sources}: no resonance found in {', '.join(sorted({s.channel for s in series}))} "
                            f"({f_min:g}-{f_max:g} Hz): the data must show the first axial mode, or pass "
                            "band_hz around it", parameter="band_hz")
        band = _default_band(f_mode, f_next, f_min, f_max)
        _check_point_count(series, band, n_params)
        return band, f_mode
    lo, hi = _check_band_value(band_hz)
    _check_point_count(series, (lo, hi), n_params)
    inside, _ = _detect_modes([s.select(lo, hi) for s in series])
    if not np.isfinite(inside):
        seen = f"the first axial mode found in the data is at {f_mode:.4g} Hz" if np.isfinite(f_mode) \
            else "no resonance was found in the data"
        raise DataError(f"band_hz {lo:g}-{hi:g} Hz must contain the first axial mode; {seen}", parameter="band_hz")
    return (lo, hi), inside


# ----------------------------------------------------------------------------------------- initial values
def _smoothed(values: np.ndarray) -> np.ndarray:
    """5-point running median (no change for shorter arrays)."""
    from scipy.ndimage import median_filter

    return median_filter(values, size=5, mode="nearest") if values.size >= 5 else values


def _half_power_zeta(s: _Series, f_mode: float) -> float:
    """Damping ratio [-] from the half-power width of the acceleration peak near ``f_mode`` (NaN if none)."""
    mag = _smoothed(np.abs(s.response) * (2 * np.pi * s.freq_hz) ** 2)
    near = np.flatnonzero(np.abs(s.freq_hz / f_mode - 1) < 0.15)
    if near.size < 3:
        return float("nan")
    ipk = int(near[np.argmax(mag[near])])
    below = np.flatnonzero(mag[:ipk] < mag[ipk] / np.sqrt(2))
    above = np.flatnonzero(mag[ipk:] < mag[ipk] / np.sqrt(2))
    if below.size == 0 or above.size == 0:
        return float("nan")
    width = s.freq_hz[ipk + above[0]] - s.freq_hz[below[-1]]
    return float(width / (2 * s.freq_hz[ipk]))


def _anti_resonance_hz(x1: list[_Series], f_mode: float) -> float:
    """Anti-resonance [Hz] of the motor-side acceleration below the mode (NaN if not seen)."""
    best = []
    for s in x1:
        m = (s.freq_hz < 0.98 * f_mode)
        if np.count_nonzero(m) < 3:
            continue
        mag = _smoothed(np.abs(s.response[m]) * (2 * np.pi * s.freq_hz[m]) ** 2)
        i = int(np.argmin(mag))
        if 0 < i < mag.size - 1:
            best.append(float(s.freq_hz[m][i]))
    return float(np.median(best)) if best else float("nan")


def _inverted_sign_message(s: _Series, below: np.ndarray) -> str:
    """The error for a channel whose rigid-body response has the wrong sign (a position behind a double
    integrator lags by 180 deg; a channel counting the other way leads by about 0 deg)."""
    phase = round(float(np.degrees(np.angle(np.median(s.response[below] / np.abs(s.response[below]))))))
    return (f"{s.source}: channel {s.channel}: its phase below the first axial mode is {phase:+d} deg where a "
            "position response of a rigid body has -180 deg: the channel's sign looks inverted (an encoder or a "
            f"drive counting the other way); flip it with scale={s.channel}=-1 when reading the FRF or check the "
            "channels")


def _rigid_body_estimates(series: list[_Series], f_mode: float, f_anti: float) -> tuple[float, float]:
    """Total inertia ``m1 + m2`` and total viscous damping ``b1 + b2`` from the low-frequency response.

    Below the mode ``x2/u ~ 1 / (s (M s + b) (1 - (f/f_mode)^2))`` and ``x1/u`` has the extra factor
    ``1 - (f/f_anti)^2``; the level gives ``M``, the phase lead of ``s^2 x/u`` gives ``b``.
    """
    masses, dampings = [], []
    for s in series:
        f_top = 0.4 * f_mode
        if s.role == _X1 and np.isfinite(f_anti):
            f_top = min(f_top, 0.5 * f_anti)
        m = s.freq_hz <= max(f_top, s.freq_hz[min(2, s.freq_hz.size - 1)])
        f = s.freq_hz[m]
        w = 2 * np.pi * f
        shape = 1 - (f / f_mode) ** 2
        if s.role == _X1 and np.isfinite(f_anti):
            shape = shape / (1 - (f / f_anti) ** 2)
        inv_acc = 1.0 / (s.response[m] * (1j * w) ** 2 * shape)      # ~ M + b / (j w)
        masses.append(np.median(inv_acc.real))
        dampings.append(np.median(-inv_acc.imag * w))
        if masses[-1] < 0:
            raise DataError(_inverted_sign_message(s, m), parameter="read_frf.scale")
    total_mass = float(np.median(masses))
    if not (np.isfinite(total_mass) and total_mass > 0):
        raise DataError("cannot read the rigid-body inertia off the FRF below the first axial mode: "
                        "check the channels and that the band starts below the mode")
    damping = float(np.median(dampings))
    return total_mass, (damping if np.isfinite(damping) and damping > 0 else 0.0)


def _initial_values(series: list[_Series], f_mode: float) -> dict[str, float]:
    """Physical start values read off the band data (see module docstring)."""
    x1 = [s for s in series if s.role == _X1]
    preferred = [s for s in series if s.role == _X2] or x1
    f_anti = _anti_resonance_hz(x1, f_mode)
    total_mass, total_damping = _rigid_body_estimates(series, f_mode, f_anti)
    ratio = (f_anti / f_mode) ** 2 if np.isfinite(f_anti) else 0.8
    ratio = float(np.clip(ratio, 0.02, 0.98))                    # m1 / (m1 + m2)
    m1 = ratio * total_mass
    m2 = total_mass - m1
    zetas = [z for z in (_half_power_zeta(s, f_mode) for s in preferred) if np.isfinite(z)]
    zeta = float(np.clip(np.median(zetas), 0.002, 0.3)) if zetas else 0.03
    reduced = m1 * m2 / total_mass
    k = reduced * (2 * np.pi * f_mode) ** 2
    c = 2 * zeta * np.sqrt(k * reduced)
    return {"m1": m1, "m2": m2, "k": k, "c": c, "b1": 0.9 * total_damping, "b2": 0.1 * total_damping,
            "delay": 0.0}


# ----------------------------------------------------------------------------------------- least squares
@dataclass(frozen=True)
class _Problem:
    """Weighted logarithmic least-squares problem over all band points."""

    s: np.ndarray
    log_h: np.ndarray
    is_x1: np.ndarray
    weight: np.ndarray
    names: tuple[str, ...]

    @classmethod
    def build(cls, series: list[_Series], names: list[str]) -> _Problem:
        """Stack all series; weight points by log-frequency share and sqrt(coherence)."""
        freq = np.concatenate([s.freq_hz for s in series])
        response = np.concatenate([s.response for s in series])
        if np.any(response == 0):
            bad = next(s for s in series if np.any(s.response == 0))
            raise DataError(f"{bad.source}: channel {bad.channel} has zero response values in the band")
        for sr in series:
            mag = np.abs(sr.response)
            if mag.min() < 1e-200 or mag.max() > 1e200:
                raise DataError(f"{sr.source}: channel {sr.channel}: |H| spans {mag.min():.3g} to {mag.max():.3g} "
                                f"rad/{sr.input_unit}; far outside a physical FRF: check the "
                                "file's scale and units")
        weight = np.concatenate([_point_weights(s) for s in series])
        is_x1 = np.concatenate([np.full(s.freq_hz.size, s.role == _X1) for s in series])
        return cls(2j * np.pi * freq, np.log(response), is_x1, weight, tuple(names))

    # -- parameter mapping: x (optimiser) <-> theta (physical)
    def scales(self, start: dict[str, float], f_mode: float) -> np.ndarray:
        """Reference values of the linear parameters (log parameters use 1); delay: 0.05 rad at the mode."""
        c_ref = max(start["c"], 1e-12)
        refs = {"c": c_ref, "b1": max(start["b1"] + start["b2"], 0.1 * c_ref),
                "delay": 0.05 / (2 * np.pi * f_mode)}
        refs["b2"] = refs["b1"]
        return np.array([1.0 if n in _LOG_PARAMS else refs[n] for n in self.names])

    def to_theta(self, x: np.ndarray, scale: np.ndarray) -> dict[str, float]:
        """Physical parameters from optimiser variables."""
        return {n: float(np.exp(v) if n in _LOG_PARAMS else v * sc)
                for n, v, sc in zip(self.names, x, scale, strict=True)}

    def to_x(self, theta: dict[str, float], scale: np.ndarray) -> np.ndarray:
        """Optimiser variables from physical parameters."""
        return np.array([np.log(theta[n]) if n in _LOG_PARAMS else theta[n] / sc
                         for n, sc in zip(self.names, scale, strict=True)])

    # -- model
    def log_model(self, theta: dict[str, float]) -> np.ndarray:
        """``log`` of the model position response (with the delay) at every point."""
        m1, m2, b1, b2, k, c = (theta[p] for p in PARAM_NAMES)
        s = self.s
        a1 = m1 * b2 + m2 * b1 + (m1 + m2) * c
        a2 = b1 * b2 + (b1 + b2) * c + (m1 + m2) * k
        a3 = (b1 + b2) * k
        den = s * (((m1 * m2 * s + a1) * s + a2) * s + a3)
        num = np.where(self.is_x1, (m2 * s + c + b2) * s + k, c * s + k)
        return np.log(num / den) - s * theta.get("delay", 0.0)

    def log_model_gradient(self, theta: dict[str, float]) -> np.ndarray:
        """``d log H_model / d theta`` at every point, shape ``(n_points, n_params)``."""
        m1, m2, b1, b2, k, c = (theta[p] for p in PARAM_NAMES)
        s = self.s
        x1 = self.is_x1
        a1 = m1 * b2 + m2 * b1 + (m1 + m2) * c
        a2 = b1 * b2 + (b1 + b2) * c + (m1 + m2) * k
        a3 = (b1 + b2) * k
        poly = ((m1 * m2 * s + a1) * s + a2) * s + a3
        num = np.where(x1, (m2 * s + c + b2) * s + k, c * s + k)
        s2, s3 = s * s, s * s * s
        dpoly = {
            "m1": m2 * s3 + (b2 + c) * s2 + k * s,
            "m2": m1 * s3 + (b1 + c) * s2 + k * s,
            "b1": m2 * s2 + (b2 + c) * s + k,
            "b2": m1 * s2 + (b1 + c) * s + k,
            "k": (m1 + m2) * s + (b1 + b2),
            "c": (m1 + m2) * s2 + (b1 + b2) * s,
        }
        dnum = {
            "m1": 0 * s, "m2": np.where(x1, s2, 0), "b1": 0 * s, "b2": np.where(x1, s, 0), "k": 1 + 0 * s,
            "c": s,
        }
        cols = [(-s if n == "delay" else dnum[n] / num - dpoly[n] / poly) for n in self.names]
        return np.stack(cols, axis=1)

    # -- residuals
    def residual(self, x: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Weighted ``[Re, Im]`` of ``log(H_model / H)`` with the phase wrapped to (-pi, pi]."""
        d = self.log_model(self.to_theta(x, scale)) - self.log_h
        d = d.real + 1j * np.angle(np.exp(1j * d.imag))
        return np.concatenate([self.weight * d.real, self.weight * d.imag])

    def jacobian(self, x: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual` with respect to the optimiser variables."""
        theta = self.to_theta(x, scale)
        chain = np.array([theta[n] if n in _LOG_PARAMS else sc
                          for n, sc in zip(self.names, scale, strict=True)])
        g = self.log_model_gradient(theta) * chain * self.weight[:, None]
        return np.concatenate([g.real, g.imag])

    def solve(
        self, start: dict[str, float], f_mode: float
    ) -> tuple[dict[str, float], dict[str, float], bool]:
        """Least squares from ``start``; return parameters, standard deviations and convergence flag."""
        from scipy.optimize import least_squares

        scale = self.scales(start, f_mode)
        lower = np.array([-np.inf if n in _LOG_PARAMS else 0.0 for n in self.names])
        x0 = np.maximum(self.to_x(start, scale), lower)
        if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(scale)) and np.all(scale > 0)):
            bad = ", ".join(f"{n} = {v:.3g}" for n, v in start.items() if not (np.isfinite(v) and abs(v) < 1e150))
            raise DataError(f"the fit cannot start: its starting values are not finite numbers ({bad or 'scales'}); "
                            "the FRF's magnitudes are far outside a physical range: check its scale and units")
        result = least_squares(self.residual, x0, jac=self.jacobian, bounds=(lower, np.inf), args=(scale,),
                               method="trf", x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12,
                               max_nfev=500)
        theta = self.to_theta(result.x, scale)
        theta.update({n: 0.0 for n in ("b1", "b2", "c", "delay") if n in theta and theta[n] < 0})
        std = self._standard_deviations(result.x, result.fun, scale)
        return theta, std, bool(result.status > 0)

    def _standard_deviations(
        self, x: np.ndarray, residual: np.ndarray, scale: np.ndarray
    ) -> dict[str, float]:
        """One-sigma parameter errors from ``s^2 (J^T J)^-1`` (column-scaled pseudo-inverse)."""
        jac = self.jacobian(x, scale)
        dof = max(residual.size - x.size, 1)
        variance = float(residual @ residual) / dof
        norms = np.linalg.norm(jac, axis=0)
        norms[norms == 0] = 1.0
        js = jac / norms
        cov = np.linalg.pinv(js.T @ js, rcond=1e-13) / np.outer(norms, norms) * variance
        std_x = np.sqrt(np.maximum(np.diag(cov), 0.0))
        std_x[np.linalg.norm(jac, axis=0) == 0] = np.inf
        theta = self.to_theta(x, scale)
        return {n: float(theta[n] * sx if n in _LOG_PARAMS else sc * sx)
                for n, sx, sc in zip(self.names, std_x, scale, strict=True)}


def _point_weights(s: _Series) -> np.ndarray:
    """``sqrt`` of each point's share of the log-frequency axis (mean square 1), times ``sqrt(coherence)``."""
    if s.freq_hz.size > 1:
        spacing = np.gradient(np.log(s.freq_hz))
        weight = np.sqrt(spacing / spacing.mean())
    else:
        weight = np.ones(1)
    if s.coherence is not None:
        coh = np.where(np.isfinite(s.coherence), np.clip(s.coherence, 0.0, 1.0), 1.0)
        weight = weight * np.sqrt(coh)
    return weight


# ----------------------------------------------------------------------------------------- quality
def _channel_ratios(series: list[_Series], model: BallScrewModel, delay: float):
    """``(channel, lines [Hz], model / measured)`` per channel over the band points."""
    for channel in dict.fromkeys(s.channel for s in series):
        parts = [s for s in series if s.channel == channel]
        freq = np.concatenate([s.freq_hz for s in parts])
        measured = np.concatenate([s.response for s in parts])
        g = model.frequency_response(freq)["G11" if parts[0].role == _X1 else "G21"]
        yield channel, freq, g * np.exp(-2j * np.pi * freq * delay) / measured


def _fit_quality(series: list[_Series], model: BallScrewModel, delay: float) -> dict[str, dict]:
    """Per-channel nrmse, magnitude and phase RMS errors over the band points."""
    out = {}
    for channel, freq, ratio in _channel_ratios(series, model, delay):
        out[channel] = {
            "nrmse": float(np.sqrt(np.mean(np.abs(ratio - 1) ** 2))),
            "mag_rms_db": float(np.sqrt(np.mean((20 * np.log10(np.abs(ratio))) ** 2))),
            "phase_rms_deg": float(np.sqrt(np.mean(np.angle(ratio, deg=True) ** 2))),
            "n_points": int(freq.size),
        }
    return out


OUTLIER_SIGMAS = 8.0
"""A line is an outlier when its log residual exceeds this many robust standard deviations (1.4826 MAD) of its
channel's residuals and a factor of 1.5 in magnitude or 25 deg in phase."""


def _outlier_lines(freq: np.ndarray, log_ratio: np.ndarray) -> list[float]:
    """Lines [Hz] whose complex log residual ``log(model / measured)`` stands out (robust test of
    :data:`OUTLIER_SIGMAS`): single bad lines (a glitch, a harmonic of the mains) that bias a least-squares fit."""
    r = np.abs(log_ratio - np.median(log_ratio.real) - 1j * np.median(log_ratio.imag))
    mad = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    floor = min(np.log(1.5), np.radians(25.0))
    bad = (r > np.median(r) + OUTLIER_SIGMAS * max(mad, 1e-12)) & (r > floor)
    return [float(f) for f in freq[bad]]


def _fit_warnings(
    model: BallScrewModel,
    std: dict[str, float],
    quality: dict[str, dict],
    series: list[_Series],
    band: tuple[float, float],
    poor_fit_threshold: float,
    converged: bool,
    outliers: dict | None = None,
) -> list[str]:
    """Human-readable warnings about fit quality and parameter determination."""
    warnings = []
    if not converged:
        warnings.append("least squares did not converge within its iteration limit; check the band and data")
    for channel, q in quality.items():
        if q["nrmse"] > poor_fit_threshold:
            warnings.append(f"poor fit of {channel}: nrmse {q['nrmse']:.3g} > {poor_fit_threshold:g} "
                            f"(magnitude {q['mag_rms_db']:.2g} dB rms, "
                            f"phase {q['phase_rms_deg']:.2g} deg rms)")
    pole = model.real_pole_hz()
    if band[0] > _REAL_POLE_MARGIN * pole:
        warnings.append(f"b1, b2 poorly determined: viscous damping shapes the response only near and below "
                        f"the real pole at {pole:.3g} Hz, and the band starts at {band[0]:.3g} Hz")
    params = model.params()
    for name in PARAM_NAMES:
        value, sigma = params[name], std[name]
        if not sigma <= _REL_STD_LIMIT * abs(value):
            unit = param_units(model.input_unit)[name]
            lower = None if name in _LOG_PARAMS else 0.0  # the fit's bound (m1, m2, k are fitted as logarithms)
            warnings.append(f"{name} poorly determined (relative std > {100 * _REL_STD_LIMIT:.0f} %): "
                            f"{param_text(value, unit, sigma, lower)}")
    if not model.modes():
        warnings.append("the fitted model has no oscillatory mode (over-damped): check the band and channels")
    for channel, lines in (outliers or {}).items():
        if lines:
            shown = ", ".join(f"{f:.4g}" for f in lines[:5]) + (" ..." if len(lines) > 5 else "")
            warnings.append(f"{len(lines)} line(s) of {channel} stand out from the fit ({shown} Hz; more than "
                            f"{OUTLIER_SIGMAS:g} robust standard deviations): outliers bias the fit; remove them or "
                            "narrow the band")
    warnings.extend(_coherence_warnings(series))
    return warnings


def _coherence_warnings(series: list[_Series]) -> list[str]:
    """Warn for channels whose coherence is below 0.8 at more than a tenth of the band points."""
    warnings = []
    for s in series:
        if s.coherence is None or not np.any(np.isfinite(s.coherence)):
            continue
        coh = s.coherence[np.isfinite(s.coherence)]
        low = coh < _MIN_COHERENCE
        if low.mean() > _LOW_COHERENCE_SHARE:
            warnings.append(f"low coherence in {s.channel} ({s.source}): below {_MIN_COHERENCE:g} at "
                            f"{100 * low.mean():.0f} % of the band points (min {coh.min():.2f})")
    return warnings
