"""The x-axis law of thesis section 4.4.3: loop-shaped PI with lead stages and filters (eq. 4.18), mass
feedforward (eq. 4.19) and the trajectory pre-filter (eq. 4.20).

:class:`AxisLaw` is what a runtime, an analysis and a gains file need; :class:`~feedtune.design.loopshape.
LoopShapeDesign` adds the design targets and the plant it was designed on.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from ..lti import Zpk
from .discretize import matched
from .filters import FilterPack
from .prefilter import PrefilterGains, preview_samples


@dataclass(frozen=True)
class AxisLaw:
    """``C(s) = K (Ti s + 1)/s * prod(lead stages) * filters``, feedforward ``m s^2`` and a pre-filter.

    Attributes
    ----------
    mass : float
        Feedforward mass ``m_x`` [command unit/(m/s^2)].
    gain : float
        ``K`` [command unit/(m s)].
    ti_s : float
        Integral time ``Ti`` [s].
    lead_stages : tuple of LeadStage
        Lead stages centred at the crossover.
    filters : FilterPack
        Notches and low-pass filters.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    prefilter : PrefilterGains
        Pre-filter gains of eq. 4.20.
    prefilter_hz : float
        Pre-filter low-pass frequency [Hz].
    """

    mass: float
    gain: float
    ti_s: float
    lead_stages: tuple
    filters: FilterPack
    fs: float
    delay_samples: int
    prefilter: PrefilterGains
    prefilter_hz: float

    kind = "loopshape"

    @property
    def lead_deg(self) -> float:
        """Total phase lead of the stages at the crossover [deg]."""
        return float(sum(s.phase_deg for s in self.lead_stages))

    def pi_zpk(self) -> Zpk:
        """``(Ti s + 1)/s``."""
        return Zpk([-1.0 / self.ti_s], [0.0], self.ti_s)

    def controller(self) -> Zpk:
        """Continuous ``C(s)`` [command unit/m] of eq. 4.18 including the filter pack."""
        return self._controllers[0]

    def controller_discrete(self) -> Zpk:
        """Pole-zero-matched ``C(z)`` at ``fs``."""
        return self._controllers[1]

    @cached_property
    def _controllers(self) -> tuple[Zpk, Zpk]:
        """``(C(s), C(z))``, made once per law (a law is a value; analyses and searches evaluate them often)."""
        c = self.pi_zpk() * self.filters.zpk() * self.gain
        for stage in self.lead_stages:
            c = c * stage.zpk()
        return c, matched(c, self.fs).tf

    def feedforward(self) -> Zpk:
        """``m_x s^2`` [command unit/m] (eq. 4.19)."""
        return Zpk([0.0, 0.0], [], self.mass)

    @property
    def preview_samples(self) -> int:
        """Reference look-ahead of the discrete feedforward [samples]."""
        return preview_samples(self.fs)
