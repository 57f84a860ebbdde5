"""Two-mass model of a ball-screw drive's first axial mode (thesis eq. 3.1-3.4, Table 3.1).

Positions ``x1`` (rotating parts, rotary encoder) and ``x2`` (table, linear encoder) are expressed as
equivalent screw rotation [rad]; the input ``u`` is the drive command [V]. Masses are control-signal
equivalent inertias [V/(rad/s^2)], dampings [V/(rad/s)], stiffness [V/rad]. ``lead_m_per_rad`` converts
screw rotation to table travel (20 mm pitch: 0.02 / (2 pi) m/rad).

Equation of motion (eq. 3.1)::

    m1 x1'' = -b1 x1' + k (x2 - x1) + c (x2' - x1') + u + d1
    m2 x2'' = -b2 x2' + k (x1 - x2) + c (x1' - x2') + d2
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import DataError

PARAM_NAMES = ("m1", "m2", "b1", "b2", "k", "c")
LOWER_BOUNDS = {"b1": 0.0, "b2": 0.0, "c": 0.0}
"""Damping coefficients are not negative: :func:`feedtune.identify.ballscrew.fit_ballscrew` bounds them at 0 (m1, m2
and k are fitted as logarithms, never on a bound); a value on its bound is shown as such (the command line and the
report alike, :func:`feedtune.display.param_text`)."""


def param_units(input_unit: str = "V") -> dict[str, str]:
    """Units of ``m1, m2, b1, b2, k, c`` for a drive commanded in ``input_unit`` (V, A, N, N*m, %).

    Examples
    --------
    >>> param_units("A")["m1"]
    'A/(rad/s^2)'
    """
    u = input_unit
    return {"m1": f"{u}/(rad/s^2)", "m2": f"{u}/(rad/s^2)", "b1": f"{u}/(rad/s)", "b2": f"{u}/(rad/s)",
            "k": f"{u}/rad", "c": f"{u}/(rad/s)"}


PARAM_UNITS = param_units("V")
"""The units of the thesis' models (a drive commanded in V)."""


@dataclass(frozen=True)
class Mode:
    """A vibration mode: natural frequency [Hz] and damping ratio [-]."""

    freq_hz: float
    zeta: float


@dataclass(frozen=True)
class BallScrewModel:
    """Ball-screw 2-mass model (eq. 3.1); parameters in control-signal equivalent units (see module doc).

    Examples
    --------
    >>> m = THESIS_TABLE_3_1
    >>> round(m.modes()[0].freq_hz)
    130
    """

    m1: float
    m2: float
    b1: float
    b2: float
    k: float
    c: float
    lead_m_per_rad: float = 0.02 / (2 * np.pi)
    input_unit: str = "V"
    lead_given: bool = True
    """False for a model identified on a rotary bench with no lead given: ``lead_m_per_rad`` is then the thesis'
    placeholder, and reports show the axis in rad, its own unit, not in table travel."""

    def __post_init__(self) -> None:
        for name in PARAM_NAMES:
            v = float(getattr(self, name))
            if not np.isfinite(v) or v < 0:
                raise DataError(f"ball-screw parameter {name} must be finite and >= 0, got {v}")
            object.__setattr__(self, name, v)
        for name in ("m1", "m2", "k"):
            if getattr(self, name) <= 0:
                raise DataError(f"ball-screw parameter {name} must be > 0")
        if not self.lead_m_per_rad > 0:
            raise DataError("lead_m_per_rad must be > 0 m/rad")

    def params(self) -> dict[str, float]:
        """The six physical parameters as a dict."""
        return {k: v for k, v in asdict(self).items() if k in PARAM_NAMES}

    # -------------------------------------------------------- transfer functions
    def a_coeffs(self) -> tuple[float, float, float]:
        """Denominator coefficients a1, a2, a3 of eq. 3.4."""
        m1, m2, b1, b2, k, c = (self.m1, self.m2, self.b1, self.b2, self.k, self.c)
        a1 = m1 * b2 + m2 * b1 + (m1 + m2) * c
        a2 = b1 * b2 + (b1 + b2) * c + (m1 + m2) * k
        a3 = (b1 + b2) * k
        return a1, a2, a3

    def denominator(self) -> np.ndarray:
        """``m1 m2 s^4 + a1 s^3 + a2 s^2 + a3 s`` in descending powers."""
        a1, a2, a3 = self.a_coeffs()
        return np.array([self.m1 * self.m2, a1, a2, a3, 0.0])

    def numerators(self) -> dict[str, np.ndarray]:
        """Numerators of G11 (x1/u), G13 (x1/d2), G21 (x2/u), G23 (x2/d2) in descending powers."""
        m1, m2, b1, b2, k, c = (self.m1, self.m2, self.b1, self.b2, self.k, self.c)
        return {
            "G11": np.array([m2, c + b2, k]),
            "G13": np.array([c, k]),
            "G21": np.array([c, k]),
            "G23": np.array([m1, c + b1, k]),
        }

    def frequency_response(self, freq_hz, keys=None) -> dict[str, np.ndarray]:
        """Position responses G11, G12, G13, G21, G22, G23 [rad/V] on a grid [Hz] (vectorised); only ``keys``
        (names among G11, G13, G21, G23) when given."""
        s = 2j * np.pi * np.asarray(freq_hz, float)
        nums = self.numerators()
        with np.errstate(divide="ignore", invalid="ignore"):
            inv_den = 1.0 / np.polyval(self.denominator(), s)
            out = {name: np.polyval(nums[name], s) * inv_den for name in (nums if keys is None else keys)}
        if keys is None:
            out["G12"] = out["G11"]
            out["G22"] = out["G21"]
        return out

    def frf(self, freq_hz, quantity: str = "position"):
        """The model's u -> (x1, x2) FRF as an :class:`~feedtune.frf.Frf`."""
        from ..frf import Frf

        g = self.frequency_response(freq_hz)
        h = np.stack([g["G11"], g["G21"]])[:, None, :]
        f = Frf(
            np.asarray(freq_hz, float),
            h,
            ("x1", "x2"),
            ("u",),
            "position",
            input_unit=self.input_unit,
            output_unit="rad",
            meta={"source": "ball-screw model"},
        )
        return f.as_quantity(quantity)

    # --------------------------------------------------------------- state space
    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)`` of eq. 3.3: states ``[x1, x2, x1', x2']``, inputs ``[u, d1, d2]``, outputs ``[x1, x2]``."""
        m1, m2, b1, b2, k, c = (self.m1, self.m2, self.b1, self.b2, self.k, self.c)
        A = np.array(
            [
                [0, 0, 1, 0],
                [0, 0, 0, 1],
                [-k / m1, k / m1, -(c + b1) / m1, c / m1],
                [k / m2, -k / m2, c / m2, -(c + b2) / m2],
            ]
        )
        B = np.array([[0, 0, 0], [0, 0, 0], [1 / m1, 1 / m1, 0], [0, 0, 1 / m2]])
        C = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
        return A, B, C

    def state_space_integral(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, B1)`` of the five-state model ``[x1, x2, x1', x2', int x2]`` used by MC-PPC (eq. 3.6)."""
        A4, B4, _ = self.state_space()
        A = np.zeros((5, 5))
        A[:4, :4] = A4
        A[4, 1] = 1.0
        B = np.zeros((5, 1))
        B[:4, 0] = B4[:, 0]
        return A, B

    # --------------------------------------------------------------------- modes
    def poles(self) -> np.ndarray:
        """Open-loop poles [rad/s]: the integrator, the real pole and the axial-mode pair."""
        return np.roots(self.denominator())

    def modes(self) -> list[Mode]:
        """Complex-pole modes (frequency [Hz], damping [-]) sorted by frequency."""
        p = self.poles()
        out = []
        for r in p[p.imag > 0]:
            wn = abs(r)
            out.append(Mode(float(wn / (2 * np.pi)), float(-r.real / wn)))
        return sorted(out, key=lambda m: m.freq_hz)

    def real_pole_hz(self) -> float:
        """Frequency [Hz] of the real pole from viscous friction and total inertia (0 when b1 = b2 = 0)."""
        p = self.poles()
        real = p[(np.abs(p.imag) < 1e-9 * np.maximum(1, np.abs(p))) & (np.abs(p) > 1e-12)]
        return float(np.abs(real).min() / (2 * np.pi)) if real.size else 0.0

    @property
    def total_inertia(self) -> float:
        """``m1 + m2`` [V/(rad/s^2)]."""
        return self.m1 + self.m2

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from ..display import call, params, quantity

        modes = ", ".join(f"mode {quantity(m.freq_hz, 'Hz')} zeta {quantity(m.zeta)}" for m in self.modes())
        lead = f"lead={quantity(self.lead_m_per_rad * 1e3, 'mm/rad')}" if self.lead_given else "no lead"
        return call("BallScrewModel", [*params(self.params(), param_units(self.input_unit)), modes, lead])

    def plot(self, freq_hz=None, *, frf=None, title: str | None = None):
        """``x1/u`` and ``x2/u`` magnitude [dB] and phase [deg], with a measured FRF when given
        (:func:`feedtune.plotting.plot_model`); returns the matplotlib Figure."""
        from ..display import facade

        return facade("plot_model")(self, freq_hz, frf=frf, title=title)

    def to_control(self, form: str = "ss"):
        """The model as a python-control ``StateSpace`` (eq. 3.3; ``form="tf"``: ``TransferFunction``), inputs
        ``u, d1, d2``, outputs ``x1, x2`` (:func:`feedtune.interop_control.ballscrew_to_control`)."""
        from ..display import facade

        return facade("ballscrew_to_control")(self, form)

    @classmethod
    def from_control(cls, sys, **kwargs) -> BallScrewModel:
        """The model of a python-control system with input ``u`` and outputs ``x1, x2``
        (:func:`feedtune.interop_control.ballscrew_from_control`)."""
        from ..display import facade

        return facade("ballscrew_from_control")(sys, **kwargs)


THESIS_TABLE_3_1 = BallScrewModel(m1=1.858e-3, m2=0.379e-3, b1=1.020e-3, b2=0.0, k=210.02, c=0.014)
"""The parameters identified in the thesis (Table 3.1)."""
