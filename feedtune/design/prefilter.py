"""Least-squares trajectory pre-filter (thesis §3.2.4, eq. 3.16-3.23).

The tracking error of a drive under a tracking transfer function ``G_track`` is ``e = x_r - x = G_e x_r`` with
``G_e = 1 - G_track`` (reference minus measured position). Near zero frequency ``G_e(0) = 0`` and its
Maclaurin series is approximated by four terms (eq. 3.17), identified by least squares from ONE tracking run
on low-pass filtered derivatives of the reference (eq. 3.18-3.19)::

    e ~ K_vel v_f + K_acc a_f + K_jerk j_f + K_snap s_f
    v_f = G^2 s x_r,  a_f = G^3 s^2 x_r,  j_f = G^4 s^3 x_r,  s_f = G^5 s^4 x_r,  G(s) = w / (s + w)

with ``w = 2 pi lpf_hz`` (80 Hz in the thesis). The pre-filter offsets the reference by the predicted error
(eq. 3.20), ``x_r' = x_r + (K_vel s G^2 + K_acc s^2 G^3 + K_jerk s^3 G^4 + K_snap s^4 G^5) x_r``, so that
``e = (G_e - G_track Ĝ_e) x_r ~ G_e^2 x_r`` (eq. 3.23). The gains are in s, s^2, s^3 and s^4 whatever the
length unit, as long as the error and the reference share it.

Discretization: ``G`` and ``s G`` are discretized by the bilinear (Tustin) transform,
``G(z) = (wT/2)(1 + z^-1) / ((1 + wT/2) - (1 - wT/2) z^-1)`` and ``sG(z) = w (1 - z^-1) / (same)``. The
bilinear map is a substitution, so ``s^k G^(k+1)`` discretizes exactly into the product ``G(z) sG(z)^k`` (the
cascade the fit filters with) and the gains-file filter is exactly the fitted model; it has no delay (real
frequency response error ``O((wT)^2)``: 4e-5 at 80 Hz and 20 kHz), an exact differentiator zero at ``z = 1``
(the pre-filter never moves a reference at rest) and exact low-frequency derivatives. Pole-zero matching
(:mod:`feedtune.control.discretize`) would map the poles exactly but match the differentiator by a backward
difference, i.e. half a sample of lag on the velocity term; zero- and first-order holds do not compose.

The gains file holds the correction ``F(z) - 1`` as second-order sections (``prefilter_sos``), built from its
factors ``K G(z) sG(z) prod(sG(z) - d_i)`` (``d_i`` the roots of ``K_vel + K_acc d + K_jerk d^2 + K_snap d^3``)
without expanding the five-fold pole into a polynomial, so no precision is lost; the target runs
``x_r' = x_r + sosfilt(prefilter_sos, x_r)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..control.prefilter import (
    DEFAULT_LPF_HZ,
    GAIN_NAMES,
    GAIN_UNITS,
    ORDERS,
    _check_rates,
    _samples,
    correction_sos,
    derivative_section,
    lowpass_section,
)
from ..errors import DataError, IllConditionedError, UsageError
from ..log import Log

MAX_CONDITION = 1e6
"""Largest accepted condition number of the column-normalised regressor matrix [-]."""
ABSENT_RATIO = 1e-9
"""A filtered derivative is absent when its RMS is below this times ``w`` times the RMS of the one below it."""
INCONSISTENT_RATIO = 0.1
"""A logged derivative is replaced by the derivative of the one below it when they differ by more (RMS)."""
DERIVATIVE_UNITS = ("/s", "/s^2", "/s^3", "/s^4")










def _filter(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``sosfilt`` starting in the steady state of the first sample (no start-up transient for a log at rest)."""
    from scipy.signal import sosfilt, sosfilt_zi

    return sosfilt(sos, x, zi=sosfilt_zi(sos) * x[0])[0]


# ------------------------------------------------------------------------------------------ regressors
@dataclass(frozen=True)
class Regressors:
    """Filtered reference derivatives ``s^k G^(k+1) x_r`` for ``k = 1 .. 4`` (eq. 3.19).

    Attributes
    ----------
    columns : dict of str to ndarray
        ``"vel"`` [u/s], ``"acc"`` [u/s^2], ``"jerk"`` [u/s^3], ``"snap"`` [u/s^4] (``u`` the length unit),
        for every order up to the highest one asked for.
    sources : dict of str to str
        Where each column came from (a log signal, or the filtered derivative of the order below).
    """

    columns: dict
    sources: dict

    def matrix(self, orders: Sequence[str]) -> np.ndarray:
        """Columns of ``orders`` side by side, shape (n, len(orders))."""
        return np.column_stack([self.columns[o] for o in orders])


def filtered_derivatives(fs: float, lpf_hz: float = DEFAULT_LPF_HZ, *, x_ref=None,
                         derivatives: Mapping[str, object] | None = None, names: Mapping[str, str] | None = None,
                         max_order: int = 4) -> Regressors:
    """The pre-filter's regressors from a reference position and/or its derivatives.

    A given derivative ``d_k`` gives ``G^(k+1) d_k`` directly. A missing one (or one that disagrees with
    the derivative of the order below by more than :data:`INCONSISTENT_RATIO` RMS, e.g. the ``s_ref`` of a
    jerk-limited profile, which is zero between the knots where the true snap is a train of impulses) is
    the filtered derivative ``sG(z)`` of the column below, starting from ``G(z) x_r``. Filters start in the
    steady state of the first sample (for ``x_r``: of the ramp through its first two samples), so a log that
    starts at rest or at constant velocity has no start-up transient.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    lpf_hz : float
        Pole frequency of ``G`` [Hz].
    x_ref : array_like, shape (n,), optional
        Reference position [u].
    derivatives : dict, optional
        ``{"vel": v, "acc": a, "jerk": j, "snap": s}`` (any subset) [u/s, u/s^2, u/s^3, u/s^4].
    names : dict, optional
        Signal names for the ``sources`` record (default the order names).
    max_order : int
        Highest order to compute (1..4).

    Returns
    -------
    Regressors

    Raises
    ------
    DataError
        Neither ``x_ref`` nor a derivative low enough to build every order is given, or lengths differ.
    """
    lpf_hz, fs = _check_rates(lpf_hz, fs)
    derivatives = dict(derivatives or {})
    unknown = sorted(set(derivatives) - set(ORDERS))
    if unknown:
        raise UsageError(f"derivatives: unknown order {unknown[0]!r}; expected {', '.join(ORDERS)}")
    names = {"pos": "x_ref", **{o: o for o in ORDERS}, **(names or {})}
    g_sec, d_sec = lowpass_section(lpf_hz, fs), derivative_section(lpf_hz, fs)
    signals = {k: _samples(v, names.get(k, k)) for k, v in (("pos", x_ref), *derivatives.items()) if v is not None}
    sizes = {v.size for v in signals.values()}
    if len(sizes) > 1:
        raise DataError("reference signals differ in length: " + ", ".join(f"{names.get(k, k)} {v.size}"
                                                                          for k, v in signals.items()))
    below, v0 = None, 0.0
    if "pos" in signals:  # G x_r, order 0 of the chain, in the steady state of the initial ramp x0 + v0 t
        x = signals["pos"]
        v0 = (x[1] - x[0]) * fs
        below = _filter(g_sec, x - (x[0] + v0 * np.arange(x.size) / fs))
    origin = (names["pos"], 0)  # (signal, times differentiated) behind ``below``
    columns, sources = {}, {}
    for k, order in enumerate(ORDERS[:max_order], start=1):
        chained = None if below is None else _filter(d_sec, below) + (v0 if k == 1 else 0.0)
        direct = None if order not in signals else _filter(np.vstack([g_sec] * (k + 1)), signals[order])
        note = ""
        if direct is not None and chained is not None and _disagree(direct, chained):
            direct, note = None, f" ({names[order]} disagrees with it)"
        if direct is not None:
            columns[order], origin = direct, (names[order], 0)
        elif chained is not None:
            columns[order], origin = chained, (origin[0], origin[1] + 1)
        else:
            raise DataError(f"no reference for the {order} regressor: the log needs {names['pos']} or "
                            f"{names[order]} (or a lower derivative)")
        sources[order] = _derivative_label(*origin) + note
        # s^(k+1) G^(k+2) = sG (s^k G^(k+1)): the next order differentiates this column
        below = columns[order]
    return Regressors(columns, sources)


def _derivative_label(name: str, n: int) -> str:
    return name if n == 0 else f"d/dt {name}" if n == 1 else f"d{n}/dt{n} {name}"


def _disagree(direct: np.ndarray, chained: np.ndarray) -> bool:
    scale = max(_rms(direct), _rms(chained))
    return scale > 0 and _rms(direct - chained) > INCONSISTENT_RATIO * scale




def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else 0.0


# ------------------------------------------------------------------------------------------ result
@dataclass(frozen=True)
class PrefilterFit:
    """Least-squares pre-filter gains identified from one tracking run.

    Attributes
    ----------
    lpf_hz : float
        Pole frequency of ``G`` [Hz].
    fs : float
        Sample rate of the log [Hz].
    orders : tuple of str
        The orders fitted (a subset of :data:`ORDERS`); the others have gain 0.
    gains : dict
        ``K_vel`` [s], ``K_acc`` [s^2], ``K_jerk`` [s^3], ``K_snap`` [s^4].
    std : dict
        Standard deviation of each fitted gain [same units], from the residual variance; the residual of a
        tracking run is correlated in time, so read these as a lower bound.
    condition_number : float
        Of the regressor matrix with columns scaled to unit norm [-].
    error_rms : float
        RMS of the tracking error of the run [u].
    fitted_rms : float
        RMS of the part of it the model predicts (``sum K_k regressor_k``) [u].
    residual_rms : float
        RMS of what remains: the achievable RMS error with the pre-filter (to first order, eq. 3.23) [u].
    n_samples : int
        Samples used.
    sources : dict
        Where each regressor and the error came from.
    length_unit : str
        ``u``: the unit of the error and reference (``"m"``, ``"rad"`` or ``""``).
    """

    lpf_hz: float
    fs: float
    orders: tuple
    gains: dict
    std: dict
    condition_number: float
    error_rms: float
    fitted_rms: float
    residual_rms: float
    n_samples: int
    sources: dict = field(default_factory=dict)
    length_unit: str = "m"

    @property
    def predicted_reduction(self) -> float:
        """``1 - residual_rms / error_rms``: fraction of the RMS error the pre-filter removes [-]."""
        return 1.0 - self.residual_rms / self.error_rms if self.error_rms > 0 else 0.0

    def maclaurin(self) -> dict:
        """Maclaurin coefficients of the fitted ``Ĝ_e(s) = sum_k K_k s^k G^(k+1)`` (eq. 3.16-3.17).

        ``G^n = (1 + s/w)^-n`` contributes ``C(m, k) (-1/w)^(m-k)`` to the coefficient of ``s^m``, so these
        are the estimates ``c1 .. c4`` of ``G_e'(0), G_e''(0)/2!, G_e'''(0)/3!, G_e''''(0)/4!`` [s .. s^4]; they
        equal the gains when ``lpf_hz`` is far above the trajectory's content.
        """
        return maclaurin_coefficients(self.gains, self.lpf_hz)

    def correction_sos(self) -> np.ndarray:
        """Second-order sections of ``F(z) - 1`` at ``fs`` (see :func:`correction_sos`)."""
        return correction_sos(self.gains, self.lpf_hz, self.fs)

    def to_dict(self) -> dict:
        """JSON-ready: gains, standard deviations, Maclaurin coefficients, fit statistics, units."""
        u = self.length_unit or "u"
        return {
            "lpf_hz": self.lpf_hz,
            "fs_hz": self.fs,
            "orders": list(self.orders),
            "gains": dict(self.gains),
            "std": dict(self.std),
            "maclaurin": self.maclaurin(),
            "condition_number": self.condition_number,
            "error_rms": self.error_rms,
            "fitted_rms": self.fitted_rms,
            "residual_rms": self.residual_rms,
            "predicted_reduction": self.predicted_reduction,
            "n_samples": self.n_samples,
            "sources": dict(self.sources),
            "units": {**GAIN_UNITS, "lpf_hz": "Hz", "fs_hz": "Hz", "error_rms": u, "fitted_rms": u,
                      "residual_rms": u, "predicted_reduction": "1", "condition_number": "1",
                      "maclaurin": {"c1": "s", "c2": "s^2", "c3": "s^3", "c4": "s^4"}},
        }


def maclaurin_coefficients(gains: Mapping[str, float], lpf_hz: float) -> dict:
    """Coefficients ``c1 .. c4`` of ``s, s^2, s^3, s^4`` in ``sum_k K_k s^k G^(k+1)``, ``G = w/(s + w)`` [s^k].

    Parameters
    ----------
    gains : dict
        ``K_vel .. K_snap`` [s .. s^4] (missing ones are 0).
    lpf_hz : float
        Pole frequency of ``G`` [Hz].
    """
    w = 2 * math.pi * float(lpf_hz)
    K = [float(gains.get(GAIN_NAMES[o], 0.0)) for o in ORDERS]
    return {f"c{m}": sum(K[k - 1] * math.comb(m, k) * (-1.0 / w) ** (m - k) for k in range(1, m + 1))
            for m in range(1, 5)}


# ------------------------------------------------------------------------------------------ fit
def _check_orders(orders) -> tuple:
    if isinstance(orders, str):
        orders = [o.strip() for o in orders.split(",") if o.strip()]
    got = [str(o).strip().lower() for o in (orders or [])]
    bad = [o for o in got if o not in ORDERS]
    if bad or not got:
        raise UsageError(f"orders must be a non-empty subset of {', '.join(ORDERS)}, got {', '.join(got) or 'none'}")
    if len(set(got)) != len(got):
        raise UsageError(f"orders name {', '.join(o for o in ORDERS if got.count(o) > 1)} twice")
    return tuple(o for o in ORDERS if o in got)


def fit_prefilter_arrays(fs: float, error, *, x_ref=None, derivatives: Mapping[str, object] | None = None,
                         lpf_hz: float = DEFAULT_LPF_HZ, orders=ORDERS, names: Mapping[str, str] | None = None,
                         length_unit: str = "m") -> PrefilterFit:
    """Fit the pre-filter gains to a tracking error and its reference (arrays, uniform sampling).

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    error : array_like, shape (n,)
        Tracking error ``x_r - x`` (reference minus measured position) [u].
    x_ref : array_like, shape (n,), optional
        Reference position [u].
    derivatives : dict, optional
        Reference derivatives ``{"vel", "acc", "jerk", "snap"}`` [u/s .. u/s^4] (any subset; the rest is
        computed by filtered differentiation, see :func:`filtered_derivatives`).
    lpf_hz : float
        Pole frequency of the low-pass ``G`` [Hz] (default 80 Hz, as in the thesis).
    orders : sequence of str or str
        Orders to fit (default all four; e.g. ``("vel", "acc")`` or ``"vel,acc,jerk"``).
    names : dict, optional
        Signal names used in messages and the ``sources`` record.
    length_unit : str
        Unit ``u`` of the error and the reference (for the report).

    Returns
    -------
    PrefilterFit

    Raises
    ------
    IllConditionedError
        A regressor is absent (reference at rest, constant velocity only, ...) or the regressors are
        collinear (condition number above :data:`MAX_CONDITION`); the message names them.
    DataError
        Missing or malformed signals.
    """
    orders = _check_orders(orders)
    names = {"error": "error", "pos": "x_ref", **{o: o for o in ORDERS}, **(names or {})}
    e = _samples(error, names["error"])
    regs = filtered_derivatives(fs, lpf_hz, x_ref=x_ref, derivatives=derivatives, names=names,
                                max_order=ORDERS.index(orders[-1]) + 1)
    n = next(iter(regs.columns.values())).size
    if e.size != n:
        raise DataError(f"{names['error']} has {e.size} samples, the reference has {n}")
    if n <= len(orders) + 1:
        raise DataError(f"{n} samples are too few to fit {len(orders)} pre-filter gains")
    _check_present(regs, orders, lpf_hz, names)
    X = regs.matrix(orders)
    scale = np.linalg.norm(X, axis=0)
    theta_s, _, _, sv = np.linalg.lstsq(X / scale, e, rcond=None)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    if not cond <= MAX_CONDITION:
        raise IllConditionedError(_collinear_message(X / scale, orders, cond, names))
    theta = theta_s / scale
    fitted = X @ theta
    resid = e - fitted
    dof = max(n - len(orders), 1)
    cov_s = np.linalg.pinv((X / scale).T @ (X / scale)) * float(resid @ resid) / dof
    std = np.sqrt(np.clip(np.diag(cov_s), 0, None)) / scale
    gains = {GAIN_NAMES[o]: 0.0 for o in ORDERS}
    gains.update({GAIN_NAMES[o]: float(t) for o, t in zip(orders, theta, strict=True)})
    sources = {**regs.sources, "error": names["error"]}
    return PrefilterFit(float(lpf_hz), float(fs), orders, gains,
                        {GAIN_NAMES[o]: float(s) for o, s in zip(orders, std, strict=True)}, cond, _rms(e),
                        _rms(fitted), _rms(resid), n, sources, length_unit)


def _check_present(regs: Regressors, orders: tuple, lpf_hz: float, names: Mapping[str, str]) -> None:
    """IllConditionedError naming the orders whose filtered derivative is (numerically) zero."""
    w = 2 * math.pi * lpf_hz
    rms = {o: _rms(c) for o, c in regs.columns.items()}
    if rms["vel"] == 0:
        raise IllConditionedError(f"the reference does not move ({names['pos']} is constant): a tracking run with "
                                  "velocity, acceleration, jerk and snap is needed to fit the pre-filter")
    absent = [o for o in orders if o != "vel" and rms[o] <= ABSENT_RATIO * w * rms[ORDERS[ORDERS.index(o) - 1]]]
    if absent:
        what = ", ".join(absent)
        hint = " (constant velocity only)" if "acc" in absent else ""
        raise IllConditionedError(f"the reference has no {what}{hint}: the regressor is zero, so its gain cannot be "
                                  "identified; record a run that accelerates (a point-to-point move), or fit "
                                  "fewer orders")


def _collinear_message(Xs: np.ndarray, orders: tuple, cond: float, names: Mapping[str, str]) -> str:
    _, _, vt = np.linalg.svd(Xs, full_matrices=False)
    v = np.abs(vt[-1])
    involved = [o for o, c in zip(orders, v, strict=True) if c >= 0.3 * v.max()]
    return (f"the {', '.join(involved)} regressors are nearly collinear in this run (condition number {cond:.3g} "
            f"> {MAX_CONDITION:g}): their gains cannot be separated; use a run with distinct acceleration, jerk "
            "and snap phases (a point-to-point move with dwells), or fit fewer orders")


def fit_prefilter(log: Log, *, lpf_hz: float = DEFAULT_LPF_HZ, orders=ORDERS, reference: str = "x_ref",
                  error: str | None = None, position: str | None = None,
                  lead_m_per_rad: float | None = None) -> PrefilterFit:
    """Fit the pre-filter gains to one tracking run recorded in a log (eq. 3.18).

    Parameters
    ----------
    log : Log
        Uniformly sampled. Needs the reference ``reference`` (``x_ref`` [m]) and/or its derivatives
        ``v_ref, a_ref, j_ref, s_ref`` [m/s .. m/s^4] (names from
        :func:`feedtune.sim.trajectory.log_signal_names`), and the tracking error or the measured position.
    lpf_hz : float
        Pole frequency of ``G`` [Hz].
    orders : sequence of str or str
        Orders to fit (default all four).
    reference : str
        Name of the reference position signal.
    error : str, optional
        Tracking error signal ``reference - measured`` [m]. Default: ``e2`` when the log has it.
    position : str, optional
        Measured table position, used when there is no error signal: ``error = reference - position``.
        Default: the first of ``x2_table``, ``x2`` in the log.
    lead_m_per_rad : float, optional
        Screw lead [m/rad] to convert a position in rad to the reference's m (a ball-screw table encoder
        logged in rad of screw rotation).

    Returns
    -------
    PrefilterFit

    Raises
    ------
    DataError
        Missing signals (named, with what the log has), non-uniform sampling, units that do not match.
    IllConditionedError
        See :func:`fit_prefilter_arrays`.
    """
    from ..log import log_signal_names

    if not isinstance(log, Log):
        raise UsageError(f"fit_prefilter expects a Log, got {type(log).__name__}")
    if not log.is_uniform(1e-3):
        raise DataError(f"{log.source}: the pre-filter fit needs uniformly sampled data (constant time step)")
    sig_names = log_signal_names(reference)
    derivs = {o: log[n] for o, n in zip(ORDERS, sig_names[1:], strict=True) if n in log}
    x_ref = log[reference] if reference in log else None
    if x_ref is None and not derivs:
        raise DataError(f"{log.source}: no reference signal {reference!r} (or {', '.join(sig_names[1:])}); "
                        f"available: {', '.join(log.signals)}; map a column to it when reading the log "
                        f"(mapping={reference}=COLUMN)", parameter="read_log.mapping")
    unit = _reference_unit(log, reference, sig_names)
    e, err_name = _error_signal(log, x_ref, reference, unit, error, position, lead_m_per_rad)
    names = {"error": err_name, "pos": reference, **dict(zip(ORDERS, sig_names[1:], strict=True))}
    try:
        return fit_prefilter_arrays(log.fs, e, x_ref=x_ref, derivatives=derivs, lpf_hz=lpf_hz, orders=orders,
                                    names=names, length_unit=unit)
    except IllConditionedError as exc:
        raise IllConditionedError(f"{log.source}: {exc}") from None


def _reference_unit(log: Log, reference: str, sig_names: tuple) -> str:
    """The length unit of the reference (``m``, ``rad`` or ``""``), checked across position and derivatives."""
    unit = log.unit(reference) if reference in log else ""
    for name, suffix in zip(sig_names[1:], DERIVATIVE_UNITS, strict=True):
        if name in log and log.unit(name):
            got = log.unit(name)
            base = got[: -len(suffix)] if got.endswith(suffix) else None
            if base is None or (unit and base != unit):
                raise DataError(f"{log.source}: {name} is in {got!r}; expected {(unit or 'm') + suffix!r} to match "
                                f"{reference}")
            unit = unit or base
    return unit


def _error_signal(log: Log, x_ref, reference: str, unit: str, error: str | None, position: str | None,
                  lead: float | None) -> tuple[np.ndarray, str]:
    if error is None and position is None:
        error = "e2" if "e2" in log else None
        position = None if error else next((p for p in ("x2_table", "x2") if p in log), None)
        if error is None and position is None:
            raise DataError(f"{log.source}: no tracking error 'e2' and no measured position 'x2_table' or 'x2'; "
                            f"available: {', '.join(log.signals)}; name one with error= or position=",
                            parameter=("error", "position"))
    if error is not None:
        return log[error] * _factor_to(log, error, unit, lead), error
    if x_ref is None:
        raise DataError(f"{log.source}: the error is computed as {reference} - {position}, but there is no "
                        f"{reference!r}; available: {', '.join(log.signals)}")
    return x_ref - log[position] * _factor_to(log, position, unit, lead), f"{reference} - {position}"


def _factor_to(log: Log, name: str, want: str, lead: float | None) -> float:
    """Factor converting signal ``name`` to the reference's unit ``want`` (m <-> rad through the lead)."""
    got = log.unit(name)
    if got == want or not got or not want:
        return 1.0
    if {got, want} != {"m", "rad"}:
        raise DataError(f"{log.source}: {name} is in {got!r} but the reference is in {want!r}")
    if lead is None or not (math.isfinite(lead) and lead > 0):
        raise DataError(f"{log.source}: {name} is in {got!r} but the reference is in {want!r}; give the screw lead "
                        "(lead_m_per_rad=) to convert", parameter="fit_prefilter.lead_m_per_rad")
    return lead if got == "rad" else 1.0 / lead
















