"""Yaw model of a linear-motor T-gantry driven by two parallel actuators (thesis eq. 4.1-4.4, 4.16, 4.22).

The gantry beam (with the x-axis table on it) is a rigid body with total mass ``m`` whose centre of mass
(CoM) translates by ``ybar`` and rotates (yaw) by ``theta`` [rad] against the torsional stiffness ``k`` and
damping ``c`` of the air bearings (eq. 4.1)::

    m ybar''                       = f1 + f2
    J theta'' + c theta' + k theta = -a1 f1 + a2 f2

``a1`` and ``a2`` are the distances [m] from the CoM to the left (primary, encoder ``y1``, command ``u1``)
and right (secondary, ``y2``, ``u2``) actuators, ``a1 + a2 = L``. The encoders read ``y1 = ybar - a1
theta`` and ``y2 = ybar + a2 theta`` (eq. 4.2). In encoder coordinates (eq. 4.3)::

    M_y y'' + C_y y' + K_y y = u,    M_y = F_q^-1 M_q T^-1 = 1/L^2 [[a2^2 m + J, a1 a2 m - J],
                                                                 [a1 a2 m - J, a1^2 m + J]]
    C_y = c/L^2 [[1, -1], [-1, 1]],  K_y = k/L^2 [[1, -1], [-1, 1]]

The table position ``x`` [m] changes the inertia, ``J(x) = J0 + m_x (d + x)^2`` (eq. 4.16), and the mass
distribution ``alpha1 = m1/m = a2/L``, ``alpha2 = m2/m = a1/L`` (eq. 4.22), which the thesis identifies
as a linear function of ``x`` (Fig. 4.5): ``alpha1(x) = alpha1_0 + dalpha1_dx * x``.

Units are the thesis' control-signal equivalents: masses [V/(m/s^2)], inertia [V m s^2], torsional
damping [V m s], torsional stiffness [V m] (per rad of yaw); the inputs are the drive commands [V].
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..errors import DataError, UsageError
from .ballscrew import Mode

MODEL_SCHEMA = "feedtune.model/1"
MODEL_KIND = "gantry"
PARAM_NAMES = ("m", "L", "J0", "d", "m_x", "c", "k", "alpha1_0", "dalpha1_dx")
OUTPUTS = ("y1", "y2")
INPUTS = ("u1", "u2")


def param_units(input_unit: str = "V") -> dict[str, str]:
    """Units of the gantry parameters for drive commands in ``input_unit`` (``"V"`` or ``"N"``)."""
    u = input_unit
    return {
        "m": f"{u}/(m/s^2)", "L": "m", "J0": f"{u}*m*s^2", "d": "m", "m_x": f"{u}/(m/s^2)",
        "c": f"{u}*m*s", "k": f"{u}*m", "alpha1_0": "-", "dalpha1_dx": "1/m",
    }


# ----------------------------------------------------------------------------------- matrix helpers
def _as_square2(a, name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.shape != (2, 2) or not np.all(np.isfinite(arr)):
        raise DataError(f"gantry matrix {name} must be a finite 2x2 array, got shape {arr.shape}")
    return arr


def mck_frequency_response(M: np.ndarray, C: np.ndarray, K: np.ndarray, freq_hz) -> np.ndarray:
    """Position response ``(M s^2 + C s + K)^-1`` of a 2-DOF system on a grid, shape ``(2, 2, n_freq)``.

    Parameters
    ----------
    M, C, K : ndarray, shape (2, 2)
        Mass [V/(m/s^2)], damping [V/(m/s)] and stiffness [V/m] matrices in encoder coordinates.
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], all > 0 (the rigid-body mode makes the response infinite at 0 Hz).

    Returns
    -------
    ndarray of complex, shape (2, 2, n_freq)
        ``y_i / u_j`` [m/V]; the batched 2x2 inverse is taken with the adjugate formula.
    """
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if f.ndim != 1 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise DataError("gantry frequency response: freq_hz must be finite and > 0 Hz "
                        "(rigid-body mode at 0 Hz)")
    s = 2j * np.pi * f
    Z = K[:, :, None] + C[:, :, None] * s + M[:, :, None] * s**2
    det = Z[0, 0] * Z[1, 1] - Z[0, 1] * Z[1, 0]
    adj = np.array([[Z[1, 1], -Z[0, 1]], [-Z[1, 0], Z[0, 0]]])
    return adj / det


def mck_state_space(M: np.ndarray, C: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C_out)``: states ``[y1, y2, y1', y2']``, inputs ``[u1, u2]``, outputs ``[y1, y2]``."""
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
    B = np.vstack([np.zeros((2, 2)), Minv])
    C_out = np.hstack([np.eye(2), np.zeros((2, 2))])
    return A, B, C_out


def mck_yaw_mode(M: np.ndarray, C: np.ndarray, K: np.ndarray) -> Mode:
    """Yaw mode of a 2-DOF gantry: the pair of largest-magnitude eigenvalues (the rigid body sits at 0).

    The natural frequency is ``sqrt(l1 l2)`` and the damping ``-(l1 + l2) / (2 sqrt(l1 l2))`` of that pair,
    which covers under- and over-damped modes alike.
    """
    A, _, _ = mck_state_space(M, C, K)
    lam = np.linalg.eigvals(A)
    pair = lam[np.argsort(np.abs(lam))[-2:]]
    wn = math.sqrt(abs((pair[0] * pair[1]).real))
    zeta = float(-(pair[0] + pair[1]).real / (2 * wn)) if wn > 0 else float("nan")
    return Mode(wn / (2 * math.pi), zeta)


# ------------------------------------------------------------------------------------ value types
@dataclass(frozen=True)
class GantryPhysicalParams:
    """Physical parameters at one table position, obtained by inverting eq. 4.3.

    Attributes
    ----------
    m : float
        Total mass [V/(m/s^2)], the sum of all entries of ``M_y``.
    J : float
        Yaw inertia about the CoM [V m s^2], ``L^2 det(M_y) / m``.
    a1, a2 : float
        CoM distance to the left / right actuator [m].
    alpha1, alpha2 : float
        Mass fractions ``m1/m = a2/L`` and ``m2/m = a1/L`` [-].
    c, k : float
        Torsional damping [V m s] and stiffness [V m], ``L^2 c_y`` and ``L^2 k_y``.
    """

    m: float
    J: float
    a1: float
    a2: float
    alpha1: float
    alpha2: float
    c: float
    k: float
    input_unit: str = "V"

    def to_dict(self) -> dict:
        """JSON-ready dict with a ``units`` entry."""
        u = self.input_unit
        return {
            "m": self.m, "J": self.J, "a1": self.a1, "a2": self.a2, "alpha1": self.alpha1,
            "alpha2": self.alpha2, "c": self.c, "k": self.k,
            "units": {"m": f"{u}/(m/s^2)", "J": f"{u}*m*s^2", "a1": "m", "a2": "m", "alpha1": "-",
                      "alpha2": "-", "c": f"{u}*m*s", "k": f"{u}*m"},
        }


def physical_from_matrices(M: np.ndarray, C: np.ndarray, K: np.ndarray, L: float,
                           input_unit: str = "V") -> GantryPhysicalParams:
    """Invert eq. 4.3: ``M_y, C_y, K_y`` in encoder coordinates to ``m, J, a1, a2, c, k``.

    ``m`` is the sum of the entries of ``M_y``; the row sums are ``m1 = alpha1 m`` and ``m2 = alpha2 m``;
    ``det(M_y) = m J / L^2``. ``c_y`` and ``k_y`` are the anti-symmetric projections
    ``[1, -1] C_y [1, -1]^T / 4`` (equal to ``c11`` when the constraints of §4.3.3 hold).
    """
    m = float(M.sum())
    if not m > 0:
        raise DataError(f"gantry mass matrix has total mass {m:g} <= 0; cannot derive physical parameters")
    alpha1 = float(M[0].sum() / m)
    alpha2 = float(M[1].sum() / m)
    J = float(L**2 * np.linalg.det(M) / m)
    v = np.array([1.0, -1.0])
    c_y = float(v @ C @ v / 4.0)
    k_y = float(v @ K @ v / 4.0)
    return GantryPhysicalParams(m=m, J=J, a1=alpha2 * L, a2=alpha1 * L, alpha1=alpha1, alpha2=alpha2,
                                c=c_y * L**2, k=k_y * L**2, input_unit=input_unit)


@dataclass(frozen=True)
class GantryModelAtX:
    """The gantry's 2x2 matrices of eq. 4.3 in encoder coordinates ``(y1, y2)`` at one table position.

    Attributes
    ----------
    x : float
        Table position [m].
    M, C, K : ndarray, shape (2, 2)
        Mass [V/(m/s^2)], damping [V/(m/s)] and stiffness [V/m] matrices.
    L : float
        Span between the actuators [m] (needed to return to CoM/yaw coordinates).
    input_unit : str
        Unit of the drive commands (``"V"``).
    """

    x: float
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    L: float
    input_unit: str = "V"

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", float(self.x))
        object.__setattr__(self, "L", float(self.L))
        for name in ("M", "C", "K"):
            object.__setattr__(self, name, _as_square2(getattr(self, name), name))

    def frequency_response(self, freq_hz) -> np.ndarray:
        """Position FRF ``y_i / u_j`` [m/V] on ``freq_hz`` [Hz > 0], shape ``(2, 2, n_freq)``."""
        return mck_frequency_response(self.M, self.C, self.K, freq_hz)

    def frf(self, freq_hz, quantity: str = "position"):
        """The FRF as a :class:`~feedtune.frf.Frf` with outputs ``y1, y2`` [m] and inputs ``u1, u2``."""
        from ..frf import Frf

        f = np.asarray(freq_hz, dtype=float)
        h = self.frequency_response(f)
        out = Frf(f, h, OUTPUTS, INPUTS, "position", input_unit=self.input_unit, output_unit="m",
                  meta={"source": f"gantry model at x = {self.x:g} m"})
        return out.as_quantity(quantity)

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)``: states ``[y1, y2, y1', y2']`` [m, m/s], inputs ``[u1, u2]``, outputs ``y1, y2``."""
        return mck_state_space(self.M, self.C, self.K)

    def yaw_mode(self) -> Mode:
        """Yaw mode frequency [Hz] and damping ratio [-]."""
        return mck_yaw_mode(self.M, self.C, self.K)

    def physical(self) -> GantryPhysicalParams:
        """``m, J, a1, a2, alpha1, alpha2, c, k`` at this position (eq. 4.3 inverted)."""
        return physical_from_matrices(self.M, self.C, self.K, self.L, self.input_unit)

    def to_dict(self) -> dict:
        """JSON-ready dict of the matrices (row-major nested lists) with units."""
        u = self.input_unit
        return {
            "x": self.x, "L": self.L, "M": self.M.tolist(), "C": self.C.tolist(), "K": self.K.tolist(),
            "units": {"x": "m", "L": "m", "M": f"{u}/(m/s^2)", "C": f"{u}/(m/s)", "K": f"{u}/m"},
        }

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from ..display import call, number, quantity

        def mat(a):
            return "[" + "; ".join(" ".join(number(v) for v in row) for row in a) + "]"

        u, mode = self.input_unit, self.yaw_mode()
        return call("GantryModelAtX", [f"x={quantity(self.x, 'm')}", f"M={mat(self.M)} {u}/(m/s^2)",
                                       f"C={mat(self.C)} {u}/(m/s)", f"K={mat(self.K)} {u}/m",
                                       f"yaw {quantity(mode.freq_hz, 'Hz')} zeta {quantity(mode.zeta)}"])

    def plot(self, freq_hz=None, *, frf=None, title: str | None = None):
        """The 2x2 position FRF [dB, deg], with a measured FRF when given (:func:`feedtune.plotting.plot_model`)."""
        from ..display import facade

        return facade("plot_model")(self, freq_hz, frf=frf, title=title)

    def to_control(self):
        """A python-control ``StateSpace``, inputs ``u1, u2``, outputs ``y1, y2`` [m]."""
        from ..display import facade

        return facade("gantry_to_control")(self)

    @classmethod
    def from_control(cls, sys, *, L: float, x: float = 0.0, **kwargs) -> GantryModelAtX:
        """``M, C, K`` of a 2x2 python-control system (:func:`feedtune.interop_control.gantry_from_control`)."""
        from ..display import facade

        return facade("gantry_from_control")(sys, L=L, x=x, **kwargs)


@dataclass(frozen=True)
class GantryModel:
    """T-gantry yaw model with table-position dependent inertia and mass distribution (eq. 4.1-4.4, 4.16).

    Parameters
    ----------
    m : float
        Total control-signal equivalent mass of the gantry and table [V/(m/s^2)].
    L : float
        Span between the two actuators / encoders [m].
    J0 : float
        Yaw inertia term of ``J(x) = J0 + m_x (d + x)^2`` [V m s^2].
    d : float
        Offset of the table position in ``J(x)`` [m].
    m_x : float
        Table (x-axis) mass in ``J(x)`` [V/(m/s^2)].
    c : float
        Torsional damping of the air bearings [V m s].
    k : float
        Torsional stiffness of the air bearings [V m].
    alpha1_0 : float
        Left-side mass fraction ``alpha1 = m1/m = a2/L`` at ``x = 0`` [-].
    dalpha1_dx : float
        Slope of ``alpha1`` with table position [1/m]; ``alpha2 = 1 - alpha1``.
    input_unit : str
        Unit of the drive commands.

    Examples
    --------
    >>> mode = THESIS_GANTRY.yaw_mode(0.0)
    >>> round(mode.freq_hz, 1), round(100 * mode.zeta, 1)
    (94.3, 3.4)
    """

    m: float
    L: float
    J0: float
    d: float
    m_x: float
    c: float
    k: float
    alpha1_0: float = 0.5
    dalpha1_dx: float = 0.0
    input_unit: str = "V"
    meta: Mapping[str, str] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        for name in PARAM_NAMES:
            try:
                v = float(getattr(self, name))
            except (TypeError, ValueError):
                raise DataError(f"gantry parameter {name} must be a number, "
                                f"got {getattr(self, name)!r}") from None
            if not math.isfinite(v):
                raise DataError(f"gantry parameter {name} must be finite, got {v}")
            object.__setattr__(self, name, v)
        for name in ("m", "L", "J0", "k"):
            if getattr(self, name) <= 0:
                raise DataError(f"gantry parameter {name} must be > 0, got {getattr(self, name):g}")
        for name in ("m_x", "c"):
            if getattr(self, name) < 0:
                raise DataError(f"gantry parameter {name} must be >= 0, got {getattr(self, name):g}")
        if not 0.0 < self.alpha1_0 < 1.0:
            raise DataError(f"gantry parameter alpha1_0 must lie in (0, 1), got {self.alpha1_0:g}")
        object.__setattr__(self, "meta", dict(self.meta))

    # ------------------------------------------------------------------ position dependence
    def inertia(self, x: float) -> float:
        """Yaw inertia ``J(x) = J0 + m_x (d + x)^2`` [V m s^2] at table position ``x`` [m] (eq. 4.16)."""
        x = _position(x)
        return self.J0 + self.m_x * (self.d + x) ** 2

    def alpha(self, x: float) -> tuple[float, float]:
        """Mass distribution ``(alpha1, alpha2)`` [-] at table position ``x`` [m]; they sum to 1."""
        x = _position(x)
        a1 = self.alpha1_0 + self.dalpha1_dx * x
        if not 0.0 < a1 < 1.0:
            raise UsageError(f"table position x = {x:g} m puts the gantry CoM outside the actuator span "
                             f"(alpha1 = {a1:.3g}); expected 0 < alpha1 < 1")
        return a1, 1.0 - a1

    def arms(self, x: float) -> tuple[float, float]:
        """Distances ``(a1, a2)`` [m] from the CoM to the left / right actuator: ``a1 = alpha2 L``."""
        alpha1, alpha2 = self.alpha(x)
        return alpha2 * self.L, alpha1 * self.L

    def side_masses(self, x: float) -> tuple[float, float]:
        """``(m1, m2) = (alpha1 m, alpha2 m)`` [V/(m/s^2)]: the row sums of ``M_y`` at ``x`` [m]."""
        alpha1, alpha2 = self.alpha(x)
        return alpha1 * self.m, alpha2 * self.m

    # ---------------------------------------------------------------------- matrices (eq. 4.3)
    def at(self, x: float) -> GantryModelAtX:
        """The 2x2 matrices ``M_y, C_y, K_y`` of eq. 4.3 at table position ``x`` [m]."""
        a1, a2 = self.arms(x)
        J, m, L2 = self.inertia(x), self.m, self.L**2
        M = np.array([[a2**2 * m + J, a1 * a2 * m - J], [a1 * a2 * m - J, a1**2 * m + J]]) / L2
        S = np.array([[1.0, -1.0], [-1.0, 1.0]])
        return GantryModelAtX(x=float(x), M=M, C=self.c / L2 * S, K=self.k / L2 * S, L=self.L,
                              input_unit=self.input_unit)

    def frequency_response(self, freq_hz, x: float) -> np.ndarray:
        """Position FRF from ``(u1, u2)`` to ``(y1, y2)`` [m/V], shape ``(2, 2, n_freq)``, ``freq_hz > 0``."""
        return self.at(x).frequency_response(freq_hz)

    def frf(self, freq_hz, x: float, quantity: str = "position"):
        """The model FRF at ``x`` [m] as an :class:`~feedtune.frf.Frf` (outputs y1, y2; inputs u1, u2)."""
        return self.at(x).frf(freq_hz, quantity)

    def state_space(self, x: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)`` at ``x`` [m]: states ``y1, y2, y1', y2'``, inputs ``u1, u2``, outputs ``y1, y2``."""
        return self.at(x).state_space()

    def yaw_mode(self, x: float) -> Mode:
        """Yaw mode at ``x`` [m]: ``sqrt(k/J)/(2 pi)`` [Hz] and ``c / (2 sqrt(k J))`` [-]."""
        J = self.inertia(x)
        return Mode(math.sqrt(self.k / J) / (2 * math.pi), self.c / (2 * math.sqrt(self.k * J)))

    # ------------------------------------------------------------------------------ export
    def params(self) -> dict[str, float]:
        """The nine parameters as a dict (units in :func:`param_units`)."""
        return {name: float(getattr(self, name)) for name in PARAM_NAMES}

    def to_dict(self) -> dict:
        """JSON-ready dict of the parameters with a ``units`` entry."""
        out: dict = dict(self.params())
        out["input_unit"] = self.input_unit
        out["units"] = param_units(self.input_unit)
        out["meta"] = {str(k): str(v) for k, v in self.meta.items()}
        return out

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from ..display import call, params, quantity

        mode = self.yaw_mode(0.0)
        return call("GantryModel", [*params(self.params(), param_units(self.input_unit)),
                                    f"yaw at x=0: {quantity(mode.freq_hz, 'Hz')} zeta {quantity(mode.zeta)}"])

    def plot(self, freq_hz=None, *, x: float = 0.0, frf=None, title: str | None = None):
        """The 2x2 position FRF at table position ``x`` [m], with a measured FRF when given
        (:func:`feedtune.plotting.plot_model`)."""
        from ..display import facade

        return facade("plot_model")(self, freq_hz, frf=frf, x=x, title=title)

    def to_control(self, x: float = 0.0):
        """A python-control ``StateSpace`` at table position ``x`` [m] (inputs ``u1, u2``, outputs ``y1, y2``)."""
        from ..display import facade

        return facade("gantry_to_control")(self, x)


def _position(x) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise UsageError(f"table position x must be a number [m], got {x!r}") from None
    if not math.isfinite(v):
        raise UsageError(f"table position x must be finite [m], got {v}")
    return v








THESIS_GANTRY = GantryModel(
    m=2.722, L=1.484, J0=0.4342, d=0.1655, m_x=0.6977, c=18.17, k=159.2e3,
    alpha1_0=0.5, dalpha1_dx=-0.6977 / (2.722 * 1.484),
    meta={"source": "thesis eq. 4.16 and §4.3.1-4.3.3; alpha1_0 and dalpha1_dx are assumed (Fig. 4.5 "
                    "is not in the text): equal split at x = 0 and the CoM shift m_x x / m of a table "
                    "moving from the left (y1) towards the right (y2) actuator"},
)
"""The T-gantry identified in the thesis (eq. 4.16, L = 1.484 m, m_y = 2.722 V/(m/s^2)).

The yaw mode at ``x = 0`` is 94.3 Hz with 3.4 % damping, as stated in the text. The thesis plots but does
not tabulate the mass distribution (Fig. 4.5); the values here assume an equal split at ``x = 0`` and the
CoM shift of a rigid table moving from the left towards the right actuator
(``dalpha1_dx = -m_x / (m L)``). The yaw mode does not depend on them.
"""
