"""``design shaper``: the input shaper for the modes a gains file's closed loop leaves ringing, robust over FRFs.

The modes come from the tracking responses ``T = x_load / x_r`` of the law a gains file runs
(:func:`feedtune.machines.analyze_gains`): on its design model (the ``ideal_discrete`` case: the discrete law on the
exactly discretized model) and on each measured FRF (the ``discrete`` case: the law as the target runs it, with hold
and delay, on the measurement). Each response's lightly damped peaks are fitted
(:func:`feedtune.analysis.tracking_modes.tracking_modes`); the strongest peak of all names the mode to shape, and
each case contributes its mode within a factor :data:`CLUSTER_RATIO` of it (a family measured at several loads or
positions: the mode moving from one FRF to the next). The shaper is then chosen for those modes
(:func:`feedtune.design.shaper_choice.choose_shaper`, at the gains file's sample rate: the taps the target runs);
the modes outside the cluster are reported with the vibration the chosen shaper leaves at them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..analysis.tracking_modes import TrackingMode, tracking_modes
from ..design.shaper_choice import MAX_VIBRATION, ShaperChoice, choose_shaper
from ..errors import DataError

CLUSTER_RATIO = 1.5
"""Modes within this factor of the strongest one's frequency are the same mode moving [-]."""
MIN_PEAK = 0.5
"""A tracking peak below this ``|T|`` passes less than half the reference at its frequency: not shaped [-]."""
MODEL_CASE = "ideal_discrete"
"""The analysis case of the design model: the discrete law on the zero-order-hold model."""
FRF_CASE = "discrete"
"""The analysis case of a measured FRF: the discrete law with hold and delay on the measurement."""


@dataclass(frozen=True)
class ShaperDesign:
    """A shaper chosen for the modes of a gains file's tracking responses.

    Parameters
    ----------
    modes : tuple of TrackingMode
        The shaped mode as found in each case (model, FRFs).
    other_modes : tuple of TrackingMode
        The lightly damped modes outside the cluster.
    other_vibrations : ndarray
        Residual vibration the chosen shaper leaves at each of ``other_modes`` [-].
    choice : ShaperChoice
        Every type designed for ``modes`` and the one chosen.
    source : str
        The gains file.
    """

    modes: tuple[TrackingMode, ...]
    other_modes: tuple[TrackingMode, ...]
    other_vibrations: np.ndarray
    choice: ShaperChoice
    source: str

    @property
    def model_mode(self) -> TrackingMode:
        """The shaped mode as found on the design model (the first one when the model case has none)."""
        return next((m for m in self.modes if m.source == "model"), self.modes[0])

    @property
    def shaper(self):
        """The chosen :class:`~feedtune.control.shapers.InputShaper`."""
        return self.choice.chosen.shaper

    def record(self) -> dict:
        """What the ``[shaper.choice]`` section keeps: the rule, the modes and the figures of the chosen shaper."""
        c = self.choice.chosen
        return {"rule": "least smoothing among the types whose worst residual vibration over the modes is within "
                        "max_vibration (feedtune.design.shaper_choice)",
                "max_vibration": self.choice.max_vibration, "modes": [m.to_dict() for m in self.modes],
                "worst_vibration": c.worst_vibration, "smoothing_m": c.smoothing_m, "accel": self.choice.accel,
                "duration_s": c.duration_s, "time_shift_s": c.time_shift_s, "meets_target": c.meets_target,
                "units": {"freq_hz": "Hz", "peak_freq_hz": "Hz", "smoothing_m": "m", "accel": "m/s^2",
                          "duration_s": "s", "time_shift_s": "s"}}

    def to_dict(self) -> dict:
        """Modes, other modes with the chosen shaper's vibration at them, and the choice."""
        return {"source": self.source, "modes": [m.to_dict() for m in self.modes],
                "other_modes": [{**m.to_dict(), "vibration": float(v)} for m, v in zip(self.other_modes,
                                                                                      self.other_vibrations,
                                                                                      strict=True)],
                **self.choice.to_dict()}


def tracking_cases(doc: Mapping, where: str, frfs: Sequence[tuple[str, object]] = ()) -> list[tuple[str, object]]:
    """``[(name, case)]``: the design model's :data:`MODEL_CASE` and each FRF's :data:`FRF_CASE` of the gains
    document's analysis (each case has ``freq_hz`` and ``tracking``)."""
    from ..machines import analyze_gains

    out = []
    if not frfs:
        out.append(("model", analyze_gains(doc, where).analysis.cases[MODEL_CASE]))
    for k, (name, frf) in enumerate(frfs):
        cases = analyze_gains(doc, where, frf).analysis.cases
        if k == 0:
            out.append(("model", cases[MODEL_CASE]))
        out.append((name, cases[FRF_CASE]))
    return out


def modes_of_cases(cases: Sequence[tuple[str, object]], *, max_freq_hz: float | None = None,
                   min_peak: float = MIN_PEAK) -> list[TrackingMode]:
    """Every lightly damped mode of the cases' tracking responses with ``|T| >= min_peak``."""
    found = []
    for name, case in cases:
        found += [m for m in tracking_modes(case.freq_hz, case.tracking, source=name, max_freq_hz=max_freq_hz)
                  if m.peak >= min_peak]
    return found


def cluster(modes: Sequence[TrackingMode]) -> tuple[list[TrackingMode], list[TrackingMode]]:
    """``(shaped, others)``: per source the strongest mode within :data:`CLUSTER_RATIO` of the strongest of all,
    and the rest (module docstring)."""
    if not modes:
        return [], []
    top = max(modes, key=lambda m: m.peak)
    shaped: dict[str, TrackingMode] = {}
    for m in sorted(modes, key=lambda m: -m.peak):
        if top.freq_hz / CLUSTER_RATIO <= m.freq_hz <= top.freq_hz * CLUSTER_RATIO and m.source not in shaped:
            shaped[m.source] = m
    chosen = set(map(id, shaped.values()))
    return list(shaped.values()), [m for m in modes if id(m) not in chosen]


def design_shaper(doc: Mapping, where: str, frfs: Sequence[tuple[str, object]] = (), *,
                  kinds: Sequence[str] | None = None, max_vibration: float = MAX_VIBRATION,
                  accel: float | None = None) -> ShaperDesign:
    """The shaper for the modes of a gains document's tracking responses (module docstring).

    Parameters
    ----------
    doc : Mapping
        A gains document (any kind with a tracking response: ball screw, gantry, axis).
    where : str
        Its name in messages.
    frfs : sequence of (str, Frf)
        Measured FRFs and their names (gantry FRFs at their recorded table positions).
    kinds : sequence of str, optional
        Shaper types to try (default all six).
    max_vibration : float
        Bound on the residual vibration at every mode [-].
    accel : float, optional
        Acceleration of the smoothing figure [m/s^2] (default Klipper's 5 m/s^2).

    Raises
    ------
    DataError
        No lightly damped mode in any tracking response: nothing to shape.
    """
    from ..control.shapers import SHAPER_TYPES, SMOOTHING_ACCEL
    from ..io.gains import read_sampling

    fs, _, _ = read_sampling(dict(doc), where)
    cases = tracking_cases(doc, where, frfs)
    modes, others = cluster(modes_of_cases(cases, max_freq_hz=fs / 4))
    if not modes:
        names = ", ".join(n for n, _ in cases)
        raise DataError(f"{where}: the tracking responses ({names}) have no lightly damped peak (|T| >= {MIN_PEAK:g}, "
                        "3 dB prominence, damping below 0.3): the move leaves no mode ringing that a shaper would "
                        "cancel", parameter="frfs")
    choice = choose_shaper([m.freq_hz for m in modes], [m.damping for m in modes], kinds=kinds or SHAPER_TYPES,
                           max_vibration=max_vibration, fs=fs, accel=accel or SMOOTHING_ACCEL)
    taps = choice.chosen.shaper.sampled(fs)
    other_v = np.array([float(taps.vibration(m.freq_hz, m.damping)) for m in others])
    return ShaperDesign(tuple(modes), tuple(others), other_v, choice, where)
