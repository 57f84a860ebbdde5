"""The axial-mode compliance of a ball-screw law: the cap the tuners' objective puts on it (thesis Fig. 3.12).

The thesis judges the immunity to chatter by the most negative real part of the table's response to a table force,
``x2/d2`` [rad/V] (eq. 3.26-3.27): the more negative, the more a cutting process can feed energy into the axial mode.
The compliance here is minus that real part, on the ``ideal`` case (the continuous model with the continuous law, the
figure ``feedtune analyze`` prints as "d2->x2 most negative real part"), so that a cap taken from a design's analysis
means the same number in the tuner.
"""

from __future__ import annotations

from ..analysis.ballscrew import analyze_case, plant_cases
from ..models.ballscrew import BallScrewModel


class AxialCompliance:
    """``compliance(law)`` -> minus the most negative real part of ``x2/d2`` [rad/V] in the ``ideal`` case.

    Parameters
    ----------
    model : BallScrewModel
    fs : float
        Sample rate [Hz] (the plant cases' grid).
    delay_samples : int
        Computational delay [samples].
    """

    def __init__(self, model: BallScrewModel, fs: float, delay_samples: int) -> None:
        self._pc = plant_cases(model, fs, delay_samples, None)["ideal"]

    def __call__(self, law) -> float:
        dmin, _ = analyze_case(law, self._pc, responses=True).disturbance_min_real()
        return float("inf") if dmin is None else max(-float(dmin), 0.0)
