"""Mode-compensating pole-placement control (MC-PPC) of a ball-screw drive (thesis §3.2.2-3.2.3).

Five-state model ``z = [x1, x2, x1', x2', int x2]`` (eq. 3.6), closed-loop poles by eq. 3.7-3.8: the axial
mode's real part is moved ``beta`` times further left at the same damped frequency, and the rigid-body
poles are placed at ``pole_hz`` (a complex pair with damping ``zeta`` and a real pole). Gains by the robust
Kautsky-Nichols/Tits-Yang algorithm (``scipy.signal.place_poles``), not Ackermann's formula. The rotary
command generator ``G_r`` (eq. 3.12) and model inversion ``G_ff`` (eq. 3.13) are returned as transfer
functions and discretized by pole-zero matching with reference preview.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..control.ballscrew_law import BallScrewLaw
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..errors import DesignError, UsageError
from ..lti import Zpk
from ..models.ballscrew import BallScrewModel


@dataclass(frozen=True)
class McppcDesign:
    """An MC-PPC design.

    Attributes
    ----------
    model : BallScrewModel
    beta, pole_hz, zeta : float
        Design parameters (eq. 3.7-3.8): damping multiplier [-], rigid-body pole frequency [Hz], damping [-].
    gains : dict
        ``Kx1, Kx2, Kv1, Kv2, Ki2`` [V/rad, V/rad, V/(rad/s), V/(rad/s), V/(rad s)].
    poles : ndarray
        Requested closed-loop poles [rad/s].
    filters : FilterPack
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    tuning : dict
        How the parameters were chosen (``{"method": "user design"}`` when given; :func:`feedtune.tune.mcppc.
        tune_mcppc` records its rule); part of :meth:`design_dict`.
    """

    model: BallScrewModel
    beta: float
    pole_hz: float
    zeta: float
    gains: dict
    poles: np.ndarray
    filters: FilterPack
    fs: float
    delay_samples: int
    tuning: dict = field(default_factory=lambda: {"method": "user design"})

    kind = "mcppc"

    def __repr__(self) -> str:
        from ..control.ballscrew_law import gain_units
        from ..display import design_repr, quantity

        return design_repr("McppcDesign", [f"beta={quantity(self.beta)}", f"pole_hz={quantity(self.pole_hz, 'Hz')}",
                                           f"zeta={quantity(self.zeta)}"],
                           self.gains, gain_units(self.model.input_unit), self.filters, self.fs, self.delay_samples)

    def law(self) -> BallScrewLaw:
        """The implementable control law (gains, G_fp, G_r, G_ff)."""
        return BallScrewLaw(
            self.gains,
            self.filters.zpk(),
            rotary_command_generator(self.model),
            model_inversion(self.model),
            self.fs,
            self.delay_samples,
        )

    def closed_loop_poles(self) -> np.ndarray:
        """Eigenvalues of ``A - B1 K`` of the five-state model (filters excluded) [rad/s]."""
        A, B = self.model.state_space_integral()
        K = np.array([[self.gains[n] for n in ("Kx1", "Kx2", "Kv1", "Kv2", "Ki2")]])
        return np.linalg.eigvals(A - B @ K)

    def design_dict(self) -> dict:
        """Design parameters with units."""
        return {"beta": self.beta, "pole_hz": self.pole_hz, "zeta": self.zeta, **self.tuning}


def desired_poles(model: BallScrewModel, beta: float, pole_hz: float, zeta: float) -> np.ndarray:
    """Closed-loop poles of eq. 3.7-3.8 [rad/s]."""
    if not beta >= 1:
        raise UsageError(f"beta must be >= 1 (it multiplies the mode's decay rate), got {beta}", parameter="beta")
    if not pole_hz > 0:
        raise UsageError(f"pole_hz must be > 0 Hz, got {pole_hz}", parameter="pole_hz")
    if not 0 < zeta < 1:
        raise UsageError(f"zeta must be between 0 and 1 (exclusive), got {zeta}", parameter="zeta")
    p = model.poles()
    mode = p[np.argmax(p.imag)]
    if mode.imag <= 0:
        raise DesignError("the model has no underdamped axial mode to compensate")
    sigma1, wd1 = -mode.real, mode.imag
    w2 = 2 * np.pi * pole_hz
    wd2 = w2 * np.sqrt(1 - zeta**2)
    return np.array(
        [
            -beta * sigma1 + 1j * wd1,
            -beta * sigma1 - 1j * wd1,
            -zeta * w2 + 1j * wd2,
            -zeta * w2 - 1j * wd2,
            -w2 + 0j,
        ]
    )


def place_gains(model: BallScrewModel, poles: np.ndarray) -> dict:
    """State-feedback gains with ``eig(A - B1 K) = poles`` by ``scipy.signal.place_poles`` (YT method)."""
    from scipy.signal import place_poles

    A, B = model.state_space_integral()
    target = np.sort_complex(poles)
    best, best_err = None, np.inf
    for T in (np.eye(5), _balancing(A)):  # plain first; a balanced basis when that is not accurate
        At, Bt = np.linalg.solve(T, A @ T), np.linalg.solve(T, B)
        try:
            res = place_poles(At, Bt, poles, method="YT", maxiter=100)
        except ValueError as exc:
            raise DesignError(f"pole placement failed: {exc}") from None
        K = res.gain_matrix @ np.linalg.inv(T)
        got = np.sort_complex(np.linalg.eigvals(A - B @ K))
        err = float(np.max(np.abs(got - target) / np.abs(target)))
        if err < best_err:
            best, best_err = K, err
        if err < 1e-9:
            break
    if best_err > 1e-6:
        raise DesignError(f"pole placement is numerically inaccurate (relative pole error {best_err:.1e})")
    return dict(zip(("Kx1", "Kx2", "Kv1", "Kv2", "Ki2"), map(float, best[0]), strict=True))


def _balancing(A: np.ndarray) -> np.ndarray:
    from scipy.linalg import matrix_balance

    return matrix_balance(A, permute=False)[1]


def rotary_command_generator(model: BallScrewModel) -> Zpk:
    """``G_r(s) = (m2 s^2 + (b2 + c) s + k) / (c s + k)`` (eq. 3.12): rotary motion for a table command."""
    return Zpk.from_tf([model.m2, model.b2 + model.c, model.k], [model.c, model.k])


def model_inversion(model: BallScrewModel) -> Zpk:
    """``G_ff(s) = (m1 m2 s^4 + a1 s^3 + a2 s^2 + a3 s) / (c s + k)`` (eq. 3.13) [V/rad]."""
    return Zpk.from_tf(model.denominator(), [model.c, model.k])


def design_mcppc(
    model: BallScrewModel,
    *,
    beta: float = 4.0,
    pole_hz: float = 50.0,
    zeta: float = 0.7,
    filters: FilterPack | None = None,
    fs: float = 20000.0,
    delay_samples: int = 1,
) -> McppcDesign:
    """Design MC-PPC (eq. 3.5-3.13).

    Parameters
    ----------
    model : BallScrewModel
    beta : float
        Multiplier of the axial mode's decay rate (>= 1).
    pole_hz : float
        Rigid-body closed-loop pole frequency [Hz].
    zeta : float
        Damping of the rigid-body complex pole pair [-].
    filters : FilterPack, optional
        Notches and low-pass (eq. 3.9-3.10); none by default.
    fs : float
        Sample rate of the target [Hz].
    delay_samples : int
        Computational delay of the target [samples].

    Returns
    -------
    McppcDesign
    """
    check_sampling(fs, delay_samples)
    if np.isfinite(pole_hz) and pole_hz >= fs / 2:
        raise UsageError(f"pole_hz={pole_hz:g} Hz must lie below the Nyquist frequency fs/2 = {fs / 2:g} Hz",
                         parameter="pole_hz")
    filters = filters or FilterPack()
    filters.check_nyquist(fs)
    poles = desired_poles(model, beta, pole_hz, zeta)
    gains = place_gains(model, poles)
    return McppcDesign(
        model, float(beta), float(pole_hz), float(zeta), gains, poles, filters, float(fs), int(delay_samples)
    )
