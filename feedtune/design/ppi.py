"""P-PI position-velocity cascade of a ball-screw drive (thesis Figure 3.9, eq. 3.25, 3.27).

Velocity PI on the motor side (``x1``), position P on the table (``x2``), velocity feedforward into the
velocity loop and acceleration (inertia and viscous) feedforward ``U_ff = (m1 + m2) s^2 + (b1 + b2) s``
into the command, the same filter pack as MC-PPC::

    u = G_fp (Kpv + Kiv / s) (Kpx (x_r - x2) + s x_r - s x1) + U_ff x_r

It is the shared ball-screw law (:mod:`feedtune.control.ballscrew_law`) with ``Kx1 = Kiv, Kv1 = Kpv,
Kx2 = Kpv Kpx, Kv2 = 0, Ki2 = Kiv Kpx`` and ``R1 = 1``. :func:`feedtune.tune.ppi.tune_ppi` searches the gains with
the highest first crossover under the limits policy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..control.ballscrew_law import BallScrewLaw
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..errors import UsageError
from ..lti import Zpk
from ..models.ballscrew import BallScrewModel


@dataclass(frozen=True)
class PpiDesign:
    """A P-PI cascade design.

    Attributes
    ----------
    model : BallScrewModel
    ppi_gains : dict
        ``Kpx`` [1/s], ``Kpv`` [V/(rad/s)], ``Kiv`` [V/rad].
    filters : FilterPack
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    tuning : dict
        How the gains were obtained (user, or the search and its limit).
    """

    model: BallScrewModel
    ppi_gains: dict
    filters: FilterPack
    fs: float
    delay_samples: int
    tuning: dict

    kind = "ppi"

    @property
    def gains(self) -> dict:
        """Equivalent gains of the shared law [V/rad, V/rad, V/(rad/s), V/(rad/s), V/(rad s)]."""
        return equivalent_gains(**self.ppi_gains)

    def __repr__(self) -> str:
        from ..control.ballscrew_law import ppi_units
        from ..display import design_repr

        return design_repr("PpiDesign", [], self.ppi_gains, ppi_units(self.model.input_unit), self.filters, self.fs,
                           self.delay_samples)

    def law(self) -> BallScrewLaw:
        """The implementable control law."""
        return BallScrewLaw(
            self.gains,
            self.filters.zpk(),
            Zpk.constant(1.0),
            acceleration_feedforward(self.model),
            self.fs,
            self.delay_samples,
        )

    def design_dict(self) -> dict:
        """Design parameters with units."""
        return dict(self.tuning)


def equivalent_gains(Kpx: float, Kpv: float, Kiv: float) -> dict:
    """Shared-law gains of a P-PI cascade."""
    return {"Kx1": Kiv, "Kx2": Kpv * Kpx, "Kv1": Kpv, "Kv2": 0.0, "Ki2": Kiv * Kpx}


def acceleration_feedforward(model: BallScrewModel) -> Zpk:
    """``(m1 + m2) s^2 + (b1 + b2) s`` [V/rad]: inertia and viscous-friction feedforward."""
    return Zpk.from_tf([model.total_inertia, model.b1 + model.b2, 0.0], [1.0])


def _check_gains(Kpx: float, Kpv: float, Kiv: float, model: BallScrewModel | None = None,
                 fs: float | None = None) -> None:
    """UsageError naming the gain unless the three are finite, >= 0 (Kpv > 0) and, given the model and the sample
    rate, each puts its corner below the Nyquist frequency ``pi fs`` [rad/s] (the position loop's ``Kpx``, the
    velocity loop's ``Kpv / (m1 + m2)``, the PI corner ``Kiv / Kpv``): a gain beyond it cannot close a sampled loop."""
    for name, v in (("Kpx", Kpx), ("Kpv", Kpv), ("Kiv", Kiv)):
        if not (np.isfinite(v) and v >= 0):
            raise UsageError(f"{name} must be a finite gain >= 0, got {v}", parameter=name)
    if Kpv <= 0:
        raise UsageError("Kpv must be > 0", parameter="Kpv")
    if model is None or fs is None:
        return
    nyquist = np.pi * fs
    inertia = model.m1 + model.m2
    for name, value, corner, what in (("Kpx", Kpx, Kpx, "the position loop's crossover"),
                                      ("Kpv", Kpv, Kpv / inertia, "the velocity loop's crossover Kpv / (m1 + m2)"),
                                      ("Kiv", Kiv, Kiv / Kpv, "the PI corner Kiv / Kpv")):
        if corner >= nyquist:
            raise UsageError(f"{name}={value:g} puts {what} at {corner:.3g} rad/s, above the Nyquist frequency "
                             f"pi fs = {nyquist:.3g} rad/s", parameter=name)


def design_ppi(
    model: BallScrewModel,
    *,
    Kpx: float,
    Kpv: float,
    Kiv: float,
    filters: FilterPack | None = None,
    fs: float = 20000.0,
    delay_samples: int = 1,
) -> PpiDesign:
    """P-PI with the user's gains ``Kpx`` [1/s], ``Kpv`` [V/(rad/s)], ``Kiv`` [V/rad]."""
    check_sampling(fs, delay_samples)
    _check_gains(Kpx, Kpv, Kiv, model, fs)
    filters = filters or FilterPack()
    filters.check_nyquist(fs)
    return PpiDesign(
        model,
        {"Kpx": float(Kpx), "Kpv": float(Kpv), "Kiv": float(Kiv)},
        filters,
        float(fs),
        int(delay_samples),
        {"method": "user gains"},
    )
