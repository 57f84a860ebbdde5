"""Constrained least-squares identification of the T-gantry yaw model from 2x2 FRFs (thesis §4.3.3).

At each frequency the symmetric dynamic stiffness ``Z = K - w^2 M + j w C`` of eq. 4.6 is the inverse of the
measured position FRF ``G``, so ``G Z = I`` (eq. 4.7) is linear in the nine parameters
``Theta = [m11 m12 m22 c11 c12 c22 k11 k12 k22]`` (eq. 4.8). Real and imaginary parts of the four entries of
``G Z - I`` give eight equations per frequency (the regressor of eq. 4.9, rebuilt here from eq. 4.6-4.8
because the converted text lost some of its entries). The equality constraints of the text (eq. 4.13,
rebuilt likewise)::

    m11 + m12       = m1     known mass distribution (row sums of M_y = alpha_i m)
    m12 + m22       = m2
    c11 + 2 c12 + c22 = 0    zero external viscous friction ([1 1] C [1 1]^T = 0)
    c11 - c22       = 0      with the row above: c11 = -c12 = c22 (symmetric damping)
    k11 + k12       = 0      symmetric stiffness k11 = -k12 = k22
    k12 + k22       = 0

are imposed with Lagrange multipliers by solving the KKT system of eq. 4.15 on column-scaled parameters
(see ``docs/gantry_identification.md``). With ``bounds=True`` the same problem is also solved with cvxpy
under the physical bounds ``c >= 0``, ``k >= 0`` and a positive semi-definite mass matrix.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, IllConditionedError, UsageError
from ..frf import Frf
from ..models.ballscrew import Mode
from ..models.gantry import GantryModel, GantryModelAtX, GantryPhysicalParams, mck_frequency_response

THETA_NAMES = ("m11", "m12", "m22", "c11", "c12", "c22", "k11", "k12", "k22")
CONSTRAINT_NAMES = ("m11+m12=m1", "m12+m22=m2", "c11+2c12+c22=0", "c11-c22=0", "k11+k12=0", "k12+k22=0")
MAX_KKT_CONDITION = 1e12
MIN_BAND_POINTS = 5
MIN_FIT_POSITIONS = 3
# default band around the yaw mode f_y: [BAND_LOW f_y, min(BAND_HIGH f_y, sqrt(f_y f_next))]
BAND_LOW = 0.6
BAND_HIGH = 1.6
_LENGTH_UNITS = {"": 1.0, "m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "nm": 1e-9}
# index of the symmetric-matrix entry (j, k) in [x11, x12, x22]
_SYM = ((0, 1), (1, 2))


# ---------------------------------------------------------------------------------- result types
@dataclass(frozen=True)
class GantryFitAtX:
    """Constrained FRF fit of the gantry model at one table position.

    Attributes
    ----------
    model : GantryModelAtX
        Fitted ``M_y`` [V/(m/s^2)], ``C_y`` [V/(m/s)], ``K_y`` [V/m] in encoder coordinates.
    physical : GantryPhysicalParams
        ``m, J, a1, a2, alpha1, alpha2, c, k`` from inverting eq. 4.3.
    yaw_mode : Mode
        Yaw mode of the fitted model: frequency [Hz] and damping ratio [-].
    theta : dict
        The nine parameters of eq. 4.8 (``m..`` [V/(m/s^2)], ``c..`` [V/(m/s)], ``k..`` [V/m]).
    band_hz : tuple of float
        Frequency band used [Hz].
    n_freq : int
        Number of frequencies in the band.
    constraint_residual : float
        Largest relative residual ``|L_i Theta - xi_i| / (|L_i| |Theta| + |xi_i|)`` of the constraints [-].
    fit_error : dict
        Relative RMS error ``||G_fit - G|| / ||G||`` of each channel ``"y1/u1"``... over the band [-].
    kkt_condition : float
        2-norm condition number of the column-scaled KKT matrix of eq. 4.15.
    bounds : bool
        True when the returned parameters come from the bounded cvxpy solve.
    kkt_cvxpy_agreement : float or None
        Largest relative difference between the KKT and cvxpy parameters (None without ``bounds``).
    mass_distribution : tuple of float or None
        The side masses ``(m1, m2)`` [V/(m/s^2)] imposed, or None.
    """

    model: GantryModelAtX
    physical: GantryPhysicalParams
    yaw_mode: Mode
    theta: Mapping[str, float]
    band_hz: tuple[float, float]
    n_freq: int
    constraint_residual: float
    fit_error: Mapping[str, float]
    kkt_condition: float
    bounds: bool
    kkt_cvxpy_agreement: float | None
    mass_distribution: tuple[float, float] | None

    @property
    def x(self) -> float:
        """Table position [m]."""
        return self.model.x

    @property
    def M(self) -> np.ndarray:
        """Mass matrix ``M_y`` [V/(m/s^2)]."""
        return self.model.M

    @property
    def C(self) -> np.ndarray:
        """Damping matrix ``C_y`` [V/(m/s)]."""
        return self.model.C

    @property
    def K(self) -> np.ndarray:
        """Stiffness matrix ``K_y`` [V/m]."""
        return self.model.K

    def to_dict(self) -> dict:
        """JSON-ready dict; units in the nested ``units`` entries and key names."""
        return {
            "x": self.x,
            "matrices": self.model.to_dict(),
            "physical": self.physical.to_dict(),
            "yaw_mode": {"freq_hz": self.yaw_mode.freq_hz, "zeta": self.yaw_mode.zeta},
            "theta": dict(self.theta),
            "band_hz": list(self.band_hz),
            "n_freq": self.n_freq,
            "constraint_residual": self.constraint_residual,
            "fit_error": dict(self.fit_error),
            "kkt_condition": self.kkt_condition,
            "bounds": self.bounds,
            "kkt_cvxpy_agreement": self.kkt_cvxpy_agreement,
            "mass_distribution": None if self.mass_distribution is None else list(self.mass_distribution),
            "units": {"x": "m", "theta": "m..: V/(m/s^2), c..: V/(m/s), k..: V/m",
                      "mass_distribution": "V/(m/s^2)", "constraint_residual": "-", "fit_error": "-"},
        }


@dataclass(frozen=True)
class GantryFit:
    """Gantry model identified from FRFs at several table positions (eq. 4.16).

    Attributes
    ----------
    fits : tuple of GantryFitAtX
        The per-position fits, in the order given.
    model : GantryModel
        ``m`` (mean), ``J0, d, m_x`` (least squares of ``J(x)``), ``c, k`` (means) and the straight-line
        mass distribution ``alpha1(x)``.
    m_x_given : bool
        True when ``m_x`` was fixed by the caller (only ``J0`` and ``d`` fitted).
    inertia_rms_residual : float
        RMS relative deviation of the per-position ``J`` from ``J0 + m_x (d + x)^2`` [-].
    c_spread, k_spread : float
        Relative standard deviation of ``c`` and ``k`` over the positions [-] (``c_spread`` is None when
        the mean damping is zero).
    """

    fits: tuple[GantryFitAtX, ...]
    model: GantryModel
    m_x_given: bool
    inertia_rms_residual: float
    c_spread: float | None
    k_spread: float

    @property
    def xs(self) -> tuple[float, ...]:
        """Table positions [m]."""
        return tuple(f.x for f in self.fits)

    def yaw_modes(self) -> list[dict]:
        """Per position: fitted yaw mode and the one the combined model predicts (Hz, -)."""
        out = []
        for f in self.fits:
            pred = self.model.yaw_mode(f.x)
            out.append({"x": f.x, "fit_freq_hz": f.yaw_mode.freq_hz, "fit_zeta": f.yaw_mode.zeta,
                        "model_freq_hz": pred.freq_hz, "model_zeta": pred.zeta})
        return out

    def to_dict(self) -> dict:
        """JSON-ready dict with units."""
        return {
            "model": self.model.to_dict(),
            "m_x_given": self.m_x_given,
            "inertia_rms_residual": self.inertia_rms_residual,
            "c_spread": self.c_spread,
            "k_spread": self.k_spread,
            "yaw_modes": self.yaw_modes(),
            "fits": [f.to_dict() for f in self.fits],
            "units": {"inertia_rms_residual": "-", "c_spread": "-", "k_spread": "-",
                      "yaw_modes": "x: m, freq: Hz, zeta: -"},
        }


# ------------------------------------------------------------------------- regressor, constraints
def gantry_regressor(freq_hz: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Regressor ``Phi`` (8N x 9) and target ``Y`` (8N) of eq. 4.9-4.10, rebuilt from eq. 4.6-4.8.

    Parameters
    ----------
    freq_hz : ndarray, shape (N,)
        Frequencies [Hz].
    G : ndarray of complex, shape (2, 2, N)
        Measured position FRF ``y_i / u_j`` [m/V].

    Returns
    -------
    Phi : ndarray, shape (8 N, 9)
        Rows per frequency: Re and Im of the entries (1,1), (1,2), (2,1), (2,2) of ``G Z``.
    Y : ndarray, shape (8 N,)
        Re and Im of the identity: 1 for Re(1,1) and Re(2,2), else 0.
    """
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    n = w.size
    Phi_c = np.zeros((n, 2, 2, 9), dtype=complex)
    for i in range(2):
        for k in range(2):
            for j in range(2):
                p = _SYM[j][k]
                Phi_c[:, i, k, p] += -(w**2) * G[i, j]
                Phi_c[:, i, k, 3 + p] += 1j * w * G[i, j]
                Phi_c[:, i, k, 6 + p] += G[i, j]
    Phi = np.stack([Phi_c.real, Phi_c.imag], axis=3).reshape(8 * n, 9)
    Y = np.zeros((n, 2, 2, 2))
    Y[:, 0, 0, 0] = 1.0
    Y[:, 1, 1, 0] = 1.0
    return Phi, Y.reshape(8 * n)


def gantry_constraints(side_masses: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """Constraint matrix ``L`` and right-hand side ``xi`` of eq. 4.13 (rebuilt; rows in ``CONSTRAINT_NAMES``).

    Without ``side_masses`` the two mass rows are left out and the mass matrix is fitted freely.
    """
    rows = np.zeros((6, 9))
    rows[0, [0, 1]] = 1.0
    rows[1, [1, 2]] = 1.0
    rows[2, [3, 4, 5]] = [1.0, 2.0, 1.0]
    rows[3, [3, 5]] = [1.0, -1.0]
    rows[4, [6, 7]] = 1.0
    rows[5, [7, 8]] = 1.0
    xi = np.zeros(6)
    if side_masses is None:
        return rows[2:], xi[2:]
    xi[:2] = side_masses
    return rows, xi


# ---------------------------------------------------------------------------------- solvers
@dataclass(frozen=True)
class _ScaledProblem:
    """``min |Phi t - Y|^2`` s.t. ``L t = xi``; ``Theta = scale * t``, rows of ``L`` of unit norm."""

    Phi: np.ndarray
    Y: np.ndarray
    L: np.ndarray
    xi: np.ndarray
    scale: np.ndarray


def _scale_problem(Phi: np.ndarray, Y: np.ndarray, Lc: np.ndarray, xi: np.ndarray,
                   where: str) -> _ScaledProblem:
    norms = np.linalg.norm(Phi, axis=0)
    if not np.all(np.isfinite(norms)) or np.any(norms == 0):
        raise DataError(f"{where}: FRF in the fit band is zero or not finite; cannot build the regressor")
    scale = 1.0 / norms
    Ls = Lc * scale
    row = np.linalg.norm(Ls, axis=1)
    return _ScaledProblem(Phi * scale, Y, Ls / row[:, None], xi / row, scale)


def _solve_kkt(prob: _ScaledProblem, where: str) -> tuple[np.ndarray, float]:
    """Solve eq. 4.15 ``[[2 Phi^T Phi, L^T], [L, 0]] [Theta; Lambda] = [2 Phi^T Y; xi]``.

    Returns ``Theta`` (unscaled) and the condition number of the scaled KKT matrix.
    """
    n, r = prob.Phi.shape[1], prob.L.shape[0]
    A = np.zeros((n + r, n + r))
    A[:n, :n] = 2.0 * prob.Phi.T @ prob.Phi
    A[:n, n:] = prob.L.T
    A[n:, :n] = prob.L
    b = np.concatenate([2.0 * prob.Phi.T @ prob.Y, prob.xi])
    cond = float(np.linalg.cond(A))
    if not math.isfinite(cond) or cond > MAX_KKT_CONDITION:
        raise IllConditionedError(f"{where}: KKT matrix of the constrained fit is ill-conditioned (cond "
                                  f"{cond:.3g} > {MAX_KKT_CONDITION:.0e}); widen the band")
    sol = np.linalg.solve(A, b)
    return sol[:n] * prob.scale, cond


def _solve_bounded(prob: _ScaledProblem, where: str) -> np.ndarray:
    """Same problem with cvxpy and physical bounds: c >= 0, k >= 0, M positive semi-definite."""
    import cvxpy as cp

    Q, R = np.linalg.qr(prob.Phi)
    t = cp.Variable(prob.Phi.shape[1])
    th = cp.multiply(prob.scale, t)
    m11, m12, m22 = th[0], th[1], th[2]
    cons = [
        prob.L @ t == prob.xi,
        th[3] - 2 * th[4] + th[5] >= 0,   # 4 c_y >= 0
        th[6] - 2 * th[7] + th[8] >= 0,   # 4 k_y >= 0
        m11 >= 0,
        m22 >= 0,
        cp.SOC(m11 + m22, cp.hstack([2 * m12, m11 - m22])),   # m11 m22 >= m12^2
    ]
    problem = cp.Problem(cp.Minimize(cp.sum_squares(R @ t - Q.T @ prob.Y)), cons)
    try:
        problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    except cp.error.SolverError as exc:
        raise IllConditionedError(f"{where}: bounded fit failed in the cvxpy solver ({exc})") from None
    if problem.status != cp.OPTIMAL or t.value is None:
        raise IllConditionedError(f"{where}: bounded fit did not converge (cvxpy status {problem.status})")
    return np.asarray(t.value) * prob.scale


def _max_relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    floor = 1e-12 * float(np.max(np.abs(a)))
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(a), floor)))


def _constraint_residual(Lc: np.ndarray, xi: np.ndarray, theta: np.ndarray) -> float:
    den = np.abs(Lc) @ np.abs(theta) + np.abs(xi)
    res = np.abs(Lc @ theta - xi)
    return float(np.max(res / np.where(den > 0, den, 1.0)))


def matrices_from_theta(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Symmetric ``M, C, K`` (2x2) from ``Theta = [m11 m12 m22 c11 c12 c22 k11 k12 k22]``."""
    mats = []
    for a, b, c in theta.reshape(3, 3):
        mats.append(np.array([[a, b], [b, c]]))
    return mats[0], mats[1], mats[2]


# ---------------------------------------------------------------------------------- FRF input
def _gantry_channels(frf: Frf, outputs: Sequence[str],
                     inputs: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies [Hz > 0] and the 2x2 position FRF [m/input] in the order (y1, y2) x (u1, u2)."""
    if not isinstance(frf, Frf):
        raise UsageError(f"gantry fit expects an Frf, got {type(frf).__name__}")
    if len(outputs) != 2 or len(inputs) != 2:
        raise UsageError("gantry fit needs exactly two outputs (y1, y2) and two inputs (u1, u2)")
    unit = frf.output_unit.strip()
    if unit not in _LENGTH_UNITS:
        raise DataError(f"{frf.source}: gantry FRF outputs must be lengths (m, mm, um, nm), "
                        f"got unit {unit!r}")
    idx = [[frf.index(f"{o}/{i}") for i in inputs] for o in outputs]
    positive = frf.freq_hz > 0
    if not np.any(positive):
        raise DataError(f"{frf.source}: gantry FRF has no frequency above 0 Hz")
    pos = frf.select(lo_hz=float(frf.freq_hz[positive][0])).as_quantity("position")
    G = np.array([[pos.response[i, j] for (i, j) in row] for row in idx]) * _LENGTH_UNITS[unit]
    return pos.freq_hz, G


def differential_response(G: np.ndarray) -> np.ndarray:
    """``[-1 1] G [-1 1]^T``: the yaw response ``L^2 / (J s^2 + c s + k)``; the rigid-body term cancels."""
    return G[0, 0] - G[0, 1] - G[1, 0] + G[1, 1]


def _log_peaks(magnitude: np.ndarray, min_ratio: float) -> np.ndarray:
    """Indices of peaks of ``magnitude`` that stand ``min_ratio`` x above their base (log prominence)."""
    from scipy.signal import find_peaks

    level = np.log10(np.maximum(magnitude, np.finfo(float).tiny))
    idx, _ = find_peaks(level, prominence=math.log10(min_ratio))
    return idx


def yaw_accelerance(freq_hz: np.ndarray, G: np.ndarray) -> np.ndarray:
    """``|w^2 [-1 1] G [-1 1]^T|``: the yaw accelerance; flat above the yaw mode, ~0 at low frequency.

    Measurement noise of the rigid-body dominated entries leaves a noisy but tiny floor here, so the
    yaw resonance stands out by far in linear scale.
    """
    return np.abs(differential_response(G)) * (2 * np.pi * freq_hz) ** 2


def detect_yaw_mode_hz(freq_hz: np.ndarray, G: np.ndarray) -> float:
    """Frequency [Hz] of the yaw resonance: the lowest strong peak of the yaw accelerance.

    A peak is strong when its (linear) prominence is at least 30 % of the most prominent one's.
    """
    from scipy.signal import find_peaks

    idx, props = find_peaks(yaw_accelerance(freq_hz, G), prominence=0.0)
    prom = props["prominences"]
    if idx.size == 0 or not prom.max() > 0:
        raise DataError("gantry FRF: no yaw resonance found in the differential response "
                        "(y1 - y2)/(u1 - u2); pass band_hz around the yaw mode")
    return float(freq_hz[idx[prom >= 0.3 * prom.max()].min()])


def default_band(freq_hz: np.ndarray, G: np.ndarray) -> tuple[float, float]:
    """Default fit band [Hz]: ``0.6 f_y`` up to ``min(1.6 f_y, sqrt(f_y f_next))``.

    ``f_y`` is the detected yaw mode; ``f_next`` the next resonance above ``1.15 f_y`` in the summed
    accelerance ``sum_ij |w^2 G_ij|`` (unmodelled pitch/bending modes), if any.
    """
    f_yaw = detect_yaw_mode_hz(freq_hz, G)
    accelerance = np.sum(np.abs(G), axis=(0, 1)) * (2 * np.pi * freq_hz) ** 2
    peaks = freq_hz[_log_peaks(accelerance, 1.5)]
    above = peaks[peaks > 1.15 * f_yaw]
    hi = BAND_HIGH * f_yaw
    if above.size:
        hi = min(hi, math.sqrt(f_yaw * float(above.min())))
    return BAND_LOW * f_yaw, hi


def _band_contains_yaw_peak(freq_hz: np.ndarray, G: np.ndarray) -> bool:
    """True when the yaw accelerance has an interior maximum 20 % above both band edges."""
    mag = yaw_accelerance(freq_hz, G)
    if mag.size < MIN_BAND_POINTS:
        return False
    i = int(np.argmax(mag))
    edge = max(float(np.median(mag[:3])), float(np.median(mag[-3:])))
    return 2 <= i <= mag.size - 3 and mag[i] >= 1.2 * edge


def _resolve_band(freq: np.ndarray, G: np.ndarray, band_hz, where: str) -> tuple[float, float]:
    if band_hz is None:
        return default_band(freq, G)
    try:
        lo, hi = (float(v) for v in band_hz)
    except (TypeError, ValueError):
        raise UsageError(f"band_hz must be two numbers (low, high) in Hz, got {band_hz!r}",
                         parameter="band_hz") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise UsageError(f"band_hz must satisfy 0 <= low < high (Hz), got ({lo:g}, {hi:g})", parameter="band_hz")
    sel = (freq >= lo) & (freq <= hi)
    if int(sel.sum()) < MIN_BAND_POINTS:
        raise DataError(f"{where}: only {int(sel.sum())} frequencies in the band {lo:g}-{hi:g} Hz; "
                        f"need >= {MIN_BAND_POINTS}")
    if not _band_contains_yaw_peak(freq[sel], G[..., sel]):
        raise DataError(f"{where}: band {lo:g}-{hi:g} Hz does not contain the yaw mode (no peak of the "
                        "differential response (y1 - y2)/(u1 - u2) inside); choose a band around it")
    return lo, hi


def _side_masses(value, where: str) -> tuple[float, float] | None:
    if value is None:
        return None
    try:
        m1, m2 = (float(v) for v in value)
    except (TypeError, ValueError):
        raise UsageError(f"{where}: mass_distribution must be (m1, m2) in V/(m/s^2), got {value!r}") from None
    if not (math.isfinite(m1) and math.isfinite(m2) and m1 > 0 and m2 > 0):
        raise UsageError(f"{where}: mass_distribution (m1, m2) must be finite and > 0, got ({m1:g}, {m2:g})")
    return m1, m2


def _check_number(value, name: str, unit: str, positive: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number [{unit}], got {value!r}",
                         parameter=name if name.isidentifier() else None) from None
    if not math.isfinite(v) or (positive and v <= 0):
        raise UsageError(f"{name} must be finite{' and > 0' if positive else ''} [{unit}], got {v:g}",
                         parameter=name if name.isidentifier() else None)
    return v


def _fit_errors(freq: np.ndarray, G: np.ndarray, model: GantryModelAtX,
                outputs: Sequence[str], inputs: Sequence[str]) -> dict[str, float]:
    Gm = mck_frequency_response(model.M, model.C, model.K, freq)
    err = np.linalg.norm(Gm - G, axis=2) / np.linalg.norm(G, axis=2)
    return {f"{o}/{i}": float(err[a, b]) for a, o in enumerate(outputs) for b, i in enumerate(inputs)}


# -------------------------------------------------------------------------------- public API
def fit_gantry_frf(frf: Frf, *, x: float, L: float, band_hz: tuple[float, float] | None = None,
                   mass_distribution: tuple[float, float] | None = None, bounds: bool = False,
                   outputs: Sequence[str] = ("y1", "y2"), inputs: Sequence[str] = ("u1", "u2")
                   ) -> GantryFitAtX:
    """Fit ``M_y, C_y, K_y`` (eq. 4.3) to a measured 2x2 FRF at one table position (eq. 4.5-4.15).

    Parameters
    ----------
    frf : Frf
        FRF with channels ``y1/u1, y1/u2, y2/u1, y2/u2`` (position, velocity or acceleration outputs in a
        length unit m/mm/um/nm; inputs the drive commands, usually V).
    x : float
        Table position [m] at which the FRF was measured.
    L : float
        Span between the two actuators/encoders [m] (1.484 m in the thesis).
    band_hz : (float, float), optional
        Fit band [Hz]; it must contain the yaw mode. Default: detected around the yaw mode (see
        :func:`default_band`), 60-142 Hz for the thesis gantry.
    mass_distribution : (float, float), optional
        Known side masses ``(m1, m2) = (alpha1 m, alpha2 m)`` [V/(m/s^2)] (e.g. from
        :meth:`~feedtune.identify.mass.MassFit.side_masses`); imposed as the row sums of ``M_y``.
    bounds : bool
        Also solve with cvxpy under ``c >= 0``, ``k >= 0`` and ``M_y >= 0``; the bounded solution is returned
        and its agreement with the KKT solution reported.
    outputs, inputs : pair of str
        Channel names of the left/right encoders and actuators.

    Returns
    -------
    GantryFitAtX

    Raises
    ------
    DataError
        Missing channels, non-length outputs, too few points in the band, a band without the yaw mode.
    IllConditionedError
        KKT matrix ill-conditioned, a non-physical unbounded fit, or a failed bounded solve.
    UsageError
        Bad band, position, span or mass distribution values.
    """
    x = _check_number(x, "table position x", "m")
    L = _check_number(L, "actuator span L", "m", positive=True)
    where = frf.source if isinstance(frf, Frf) else "gantry FRF"
    side = _side_masses(mass_distribution, where)
    freq, G = _gantry_channels(frf, outputs, inputs)
    band = _resolve_band(freq, G, band_hz, where)
    sel = (freq >= band[0]) & (freq <= band[1])
    if int(sel.sum()) < MIN_BAND_POINTS:
        raise DataError(f"{where}: only {int(sel.sum())} frequencies in the band {band[0]:g}-{band[1]:g} Hz; "
                        f"need >= {MIN_BAND_POINTS}")
    f_band, G_band = freq[sel], G[..., sel]
    Phi, Y = gantry_regressor(f_band, G_band)
    Lc, xi = gantry_constraints(side)
    prob = _scale_problem(Phi, Y, Lc, xi, where)
    theta, cond = _solve_kkt(prob, where)
    agreement = None
    if bounds:
        theta_bounded = _solve_bounded(prob, where)
        agreement = _max_relative_difference(theta, theta_bounded)
        theta = theta_bounded
    M, C, K = matrices_from_theta(theta)
    model = GantryModelAtX(x=x, M=M, C=C, K=K, L=L, input_unit=frf.input_unit)
    physical = model.physical()
    if not bounds and (physical.J <= 0 or physical.k <= 0 or physical.c < 0):
        raise IllConditionedError(
            f"{where}: fit at x = {x:g} m is not physical (J = {physical.J:.3g}, c = {physical.c:.3g}, "
            f"k = {physical.k:.3g}); check the band {band[0]:g}-{band[1]:g} Hz or use bounds")
    return GantryFitAtX(
        model=model, physical=physical, yaw_mode=model.yaw_mode(),
        theta=dict(zip(THETA_NAMES, (float(v) for v in theta), strict=True)), band_hz=band,
        n_freq=int(sel.sum()), constraint_residual=_constraint_residual(Lc, xi, theta),
        fit_error=_fit_errors(f_band, G_band, model, outputs, inputs), kkt_condition=cond,
        bounds=bool(bounds),
        kkt_cvxpy_agreement=agreement, mass_distribution=side)


def _side_masses_per_position(mass_distribution, xs: np.ndarray) -> list[tuple[float, float] | None]:
    if mass_distribution is None:
        return [None] * xs.size
    if hasattr(mass_distribution, "side_masses"):
        return [tuple(mass_distribution.side_masses(float(x))) for x in xs]
    items = list(mass_distribution)
    if len(items) != xs.size:
        raise UsageError(f"mass_distribution has {len(items)} entries for {xs.size} positions; give one "
                         "(m1, m2) pair per position or a MassFit")
    return items


def fit_inertia_law(xs: np.ndarray, J: np.ndarray, m_x: float | None = None) -> tuple[float, float, float]:
    """Least squares of ``J(x) = J0 + m_x (d + x)^2`` (eq. 4.16); returns ``(J0, d, m_x)``.

    With ``m_x`` unknown, ``J = p0 + p1 x + p2 x^2`` gives ``m_x = p2``, ``d = p1 / (2 p2)``,
    ``J0 = p0 - p2 d^2``. With ``m_x`` given, ``J - m_x x^2 = q0 + q1 x`` gives ``d = q1 / (2 m_x)``.
    """
    if m_x is None:
        A = np.column_stack([np.ones_like(xs), xs, xs**2])
        p = np.linalg.lstsq(A / np.linalg.norm(A, axis=0), J, rcond=None)[0] / np.linalg.norm(A, axis=0)
        if not p[2] > 0:
            raise IllConditionedError(f"yaw inertia J(x) does not grow quadratically with x (curvature "
                                      f"{p[2]:.3g}); pass m_x (e.g. from fit_axis_mass) or add positions")
        m_x = float(p[2])
        d = float(p[1] / (2 * p[2]))
        return float(p[0] - m_x * d**2), d, m_x
    A = np.column_stack([np.ones_like(xs), xs])
    q = np.linalg.lstsq(A, J - m_x * xs**2, rcond=None)[0]
    d = float(q[1] / (2 * m_x))
    return float(q[0] - m_x * d**2), d, float(m_x)


def fit_gantry(frfs: Sequence[Frf], xs: Sequence[float], *, L: float,
               band_hz: tuple[float, float] | None = None, mass_distribution=None, bounds: bool = False,
               m_x: float | None = None, outputs: Sequence[str] = ("y1", "y2"),
               inputs: Sequence[str] = ("u1", "u2")) -> GantryFit:
    """Identify the position-dependent gantry model from FRFs at >= 3 table positions (eq. 4.16).

    Parameters
    ----------
    frfs : sequence of Frf
        One 2x2 FRF per table position (see :func:`fit_gantry_frf`).
    xs : sequence of float
        Table positions [m], at least three distinct.
    L : float
        Span between the actuators [m].
    band_hz : (float, float), optional
        Fit band [Hz] for all positions; default: detected per position.
    mass_distribution : MassFit or sequence of (m1, m2), optional
        Known side masses [V/(m/s^2)]: an object with ``side_masses(x)`` or one pair per position.
    bounds : bool
        Use the bounded cvxpy solve at each position.
    m_x : float, optional
        Table mass [V/(m/s^2)] (e.g. from :func:`~feedtune.identify.mass.fit_axis_mass`); when given only
        ``J0`` and ``d`` are fitted.
    outputs, inputs : pair of str
        Channel names.

    Returns
    -------
    GantryFit
        Per-position fits and the combined :class:`~feedtune.models.gantry.GantryModel`.

    Raises
    ------
    DataError
        Any error of :func:`fit_gantry_frf`.
    UsageError
        ``frfs`` and ``xs`` of different lengths, fewer than three distinct positions, bad ``L`` or ``m_x``.
    """
    frfs = list(frfs)
    try:
        x = np.asarray(xs, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise UsageError(f"table positions xs must be numbers [m], got {xs!r}") from None
    if x.size != len(frfs):
        raise UsageError(f"got {len(frfs)} FRFs but {x.size} table positions; give one position per FRF",
                         parameter="xs")
    L = _check_number(L, "L", "m", positive=True)  # the options first, then what they must fit
    if m_x is not None:
        m_x = _check_number(m_x, "m_x", "V/(m/s^2)", positive=True)
    if np.unique(x).size < MIN_FIT_POSITIONS:
        raise UsageError(f"the J(x) fit needs FRFs at >= {MIN_FIT_POSITIONS} distinct table positions xs, "
                         f"got {np.unique(x).size}", parameter="xs")
    sides = _side_masses_per_position(mass_distribution, x)
    fits = tuple(
        fit_gantry_frf(f, x=float(xi), L=L, band_hz=band_hz, mass_distribution=side, bounds=bounds,
                       outputs=outputs, inputs=inputs)
        for f, xi, side in zip(frfs, x, sides, strict=True))
    return _combine_fits(fits, x, L, m_x)


def _combine_fits(fits: tuple[GantryFitAtX, ...], x: np.ndarray, L: float, m_x: float | None) -> GantryFit:
    phys = [f.physical for f in fits]
    J = np.array([p.J for p in phys])
    c = np.array([p.c for p in phys])
    k = np.array([p.k for p in phys])
    J0, d, mx = fit_inertia_law(x, J, m_x)
    J_model = J0 + mx * (d + x) ** 2
    alpha1 = np.array([p.alpha1 for p in phys])
    slope, a0 = np.polyfit(x, alpha1, 1)
    model = GantryModel(
        m=float(np.mean([p.m for p in phys])), L=L, J0=J0, d=d, m_x=mx, c=float(c.mean()), k=float(k.mean()),
        alpha1_0=float(a0), dalpha1_dx=float(slope), input_unit=fits[0].model.input_unit,
        meta={"source": f"fit_gantry over x = {', '.join(f'{v:g}' for v in x)} m"})
    return GantryFit(
        fits=fits, model=model, m_x_given=m_x is not None,
        inertia_rms_residual=float(np.sqrt(np.mean(((J - J_model) / J_model) ** 2))),
        c_spread=float(c.std() / abs(c.mean())) if c.mean() != 0 else None,
        k_spread=float(k.std() / k.mean()))
