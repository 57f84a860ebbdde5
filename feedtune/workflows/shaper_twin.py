"""Command shapers and the pre-filter compared on a machine's twin: the same move, one run per candidate.

Each candidate is the gains file with a ``[shaper]`` (or without any: ``none``), run through its runtime on the twin
as ``feedtune simulate ... track`` runs it -- the full twin, or the twin reduced to the gains file's own design model
(``model=True``: the identified model in the time domain, no unmodelled dynamics, friction, noise or saturation).
Per run (:class:`TwinRun`):

* **ringing** at the mode, after the command ended (:func:`feedtune.analysis.ringing.ringing_after`) on the load --
  the table travel of a ball screw, the centre of mass ``alpha1 y1 + alpha2 y2`` of a gantry (what the tracking
  response of the mode was analysed on) -- and its ratio to the unshaped run's;
* **added delay**: the shaper's duration (the command, and so the move, ends that much later) and its lag;
* **tracking error**: the largest ``|x_r - x_load|`` against the commanded reference (the shaper's lag included:
  what the user asked for) and against the reference the servo was given (the shaped one: the servo's own error).

The ball screw's LS pre-filter (``[prefilter]``, fitted by ``feedtune prefilter``) is one more candidate when the file
has one: ``none`` is then run without it, ``pre-filter`` with it, and the chosen shaper also together with it. Each
machine's move is one entry of :data:`MOVERS`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..analysis.ringing import ringing_after
from ..errors import UsageError


@dataclass(frozen=True)
class TwinRun:
    """One candidate's run (module docstring).

    Parameters
    ----------
    label : str
        ``none``, ``pre-filter``, a shaper type, or ``pre-filter + TYPE``.
    ringing_m : float
        Band-passed RMS of the load at the mode after the command ended [m].
    ratio : float
        ``ringing_m`` over the ``none`` run's [-].
    duration_s, lag_s : float
        The shaper's duration and lag [s] (0 without a shaper).
    max_error_m, max_servo_error_m : float
        Largest tracking error against the commanded and against the shaped reference [m].
    tripped : str
        The twin's trip message ("" when the run completed).
    """

    label: str
    ringing_m: float
    ratio: float
    duration_s: float
    lag_s: float
    max_error_m: float
    max_servo_error_m: float
    tripped: str = ""

    def to_dict(self) -> dict:
        """The fields (units in the keys)."""
        return {"label": self.label, "ringing_m": self.ringing_m, "ratio": self.ratio, "duration_s": self.duration_s,
                "lag_s": self.lag_s, "max_error_m": self.max_error_m, "max_servo_error_m": self.max_servo_error_m,
                "tripped": self.tripped}


@dataclass(frozen=True)
class Move:
    """A point-to-point move that excites the mode: distance [m], limits [m/s, m/s^2, m/s^3], rest after [s]."""

    distance: float = 0.002
    v_max: float = 0.05
    a_max: float = 2.0
    j_max: float = 1e6
    dwell_after: float = 0.25

    def trajectory(self, fs: float):
        """The move sampled at ``fs`` [Hz] (:func:`feedtune.sim.trajectory.point_to_point`), 10 ms of rest first."""
        from ..sim.trajectory import point_to_point

        return point_to_point(self.distance, v_max=self.v_max, a_max=self.a_max, j_max=self.j_max, fs=fs,
                              dwell_before=0.01, dwell_after=self.dwell_after)


DEFAULT_MOVES = {"ballscrew": Move(0.002, 0.05, 20.0, 1e6), "axis": Move(0.002, 0.05, 20.0, 1e6),
                 "gantry": Move(0.004, 0.05, 2.0, 1e6)}
"""The move :func:`compare_on_twin` is shown with when none is given, per gains kind: the ball screw's 2.5 ms of
acceleration at 20 m/s^2 are shorter than the period of its 100-140 Hz closed-loop mode, so they excite it by
micrometres, far above the twin's noise floor (at 2 m/s^2 the mode rings by about 0.1 um and the floor of some 10 nm
makes a ratio of 10 % of noise); the gantry's 2 m/s^2 keep its drives within their 10 V."""


def default_move(kind: str | None) -> Move:
    """The move of :data:`DEFAULT_MOVES` for a gains kind (:class:`Move`'s defaults for another)."""
    return DEFAULT_MOVES.get(str(kind), Move())


def _ballscrew(doc: Mapping, where: str, traj, *, model: bool, overrides: Mapping, x: float, seed: int):
    """``(t, commanded, load, servo reference)`` of a ball-screw move [s, m]."""
    from ..machines import get_machine, load_runtime
    from ..machines.ballscrew.experiments import run_tracking

    rt = load_runtime(dict(doc), where)
    if model:
        from ..io.gains import law_from_document
        from ..machines.ballscrew.twin import BallScrewTwin, TwinParams

        _, m, _ = law_from_document(dict(doc), where)
        twin = BallScrewTwin(TwinParams.ideal(m, rt.fs, rt.delay_samples).with_overrides(dict(overrides)))
    else:
        twin = get_machine("ballscrew").twin(dict(overrides))
    res = run_tracking(twin, rt, traj, seed=seed)
    return res, res.log["x_ref"], res.log["x2_table"], rt


def _gantry(doc: Mapping, where: str, traj, *, model: bool, overrides: Mapping, x: float, seed: int):
    """``(t, commanded, load, servo reference)`` of a gantry y move at table position ``x`` [s, m]; the load is the
    centre of mass ``alpha1 y1 + alpha2 y2``."""
    from ..machines import get_machine, load_runtime
    from ..machines.gantry.experiments import run_gantry_tracking

    rt = load_runtime(dict(doc), where)
    if model:
        from ..io.gantry_gains import gantry_law_from_document
        from ..machines.gantry.twin import GantryTwin, GantryTwinParams

        _, m, _, _ = gantry_law_from_document(dict(doc), where)
        twin = GantryTwin(GantryTwinParams.ideal(m, rt.fs, rt.delay_samples).with_overrides(dict(overrides)))
    else:
        twin = get_machine("gantry").twin(dict(overrides))
    res = run_gantry_tracking(twin, rt, traj, x=x, seed=seed)
    a1, a2 = rt.schedule_at(x)[:2]
    return res, res.log["y_ref"], a1 * res.run.y1 + a2 * res.run.y2, rt


MOVERS: dict[str, Callable] = {"ballscrew": _ballscrew, "gantry": _gantry}
"""The move of each gains ``kind`` on its machine's twin: ``(result, commanded, load, runtime)``."""
PREFILTER_SECTION = {"ballscrew": "prefilter"}
"""The gains kinds whose LS pre-filter is an optional section (run with and without it)."""


def compare_on_twin(doc: Mapping, where: str, shapers: Mapping[str, object], freq_hz: float, *,
                    move: Move | None = None, model: bool = False, overrides: Mapping | None = None, x: float = 0.0,
                    seed: int = 0, chosen: str | None = None) -> list[TwinRun]:
    """Run the move once per candidate and measure each (module docstring).

    Parameters
    ----------
    doc : Mapping
        The gains document (``ballscrew`` or ``gantry``), without or with a ``[shaper]`` (replaced per candidate).
    where : str
        Its name in messages.
    shapers : mapping of str to InputShaper
        The shapers to try, by label.
    freq_hz : float
        The mode whose ringing is measured [Hz].
    move : Move, optional
        The move (default :class:`Move`: 2 mm at 50 mm/s, 2 m/s^2, a jerk of 1e6 m/s^3 that excites the mode).
    model : bool
        Run the twin of the file's design model instead of the full twin.
    overrides : mapping, optional
        Twin parameters (``feedtune simulate --param``).
    x : float
        Table position of a gantry move [m].
    seed : int
        Noise seed, the same for every run.
    chosen : str, optional
        The label of the chosen shaper: also run together with the pre-filter when the file has one.
    """
    from ..io.gains import read_sampling
    from ..io.shaper_file import with_shaper

    kind = doc.get("kind")
    if kind not in MOVERS:
        raise UsageError(f"{where}: twin runs are available for gains kinds {', '.join(MOVERS)}, not {kind!r}",
                         parameter="doc")
    mover = MOVERS[kind]
    base = {k: v for k, v in doc.items() if k != "shaper"}
    pre_key = PREFILTER_SECTION.get(kind)
    has_pre = pre_key is not None and base.get(pre_key) is not None
    plain = {k: v for k, v in base.items() if k != pre_key} if has_pre else base
    candidates: list[tuple[str, Mapping]] = [("none", plain)]
    if has_pre:
        candidates.append(("pre-filter", base))
    for label, shaper in shapers.items():
        candidates.append((label, with_shaper(plain, shaper, where=where)))
        if has_pre and label == chosen:
            candidates.append((f"pre-filter + {label}", with_shaper(base, shaper, where=where)))
    move = move or Move()
    runs: list[TwinRun] = []
    reference = None
    for label, d in candidates:
        traj = move.trajectory(read_sampling(dict(d), where)[0])
        res, commanded, load, rt = mover(d, where, traj, model=model, overrides=overrides or {}, x=x, seed=seed)
        taps = rt.shaper
        duration = 0.0 if taps is None else taps.duration_s
        lag = 0.0 if taps is None else taps.time_shift_s
        t = res.log.t
        if res.run.tripped:
            runs.append(TwinRun(label, np.nan, np.nan, duration, lag, np.nan, np.nan, res.run.trip_message))
            continue
        moving = np.flatnonzero(np.abs(np.diff(commanded)) > 0)
        t_end = float(t[moving[-1] + 1]) + duration
        ring = ringing_after(t, load, t_end, freq_hz)
        if reference is None:
            reference = ring
        servo_ref = commanded if taps is None else taps.apply(commanded - commanded[0]) + commanded[0]
        runs.append(TwinRun(label, ring, ring / reference if reference else np.nan, duration, lag,
                            float(np.max(np.abs(commanded - load))), float(np.max(np.abs(servo_ref - load)))))
    return runs


def shaper_candidates(choice, labels: Sequence[str] | None = None) -> dict[str, object]:
    """``{type: shaper}`` of a :class:`~feedtune.design.shaper_choice.ShaperChoice` (all its types, or ``labels``)."""
    return {c.kind: c.shaper for c in choice.candidates if labels is None or c.kind in labels}
