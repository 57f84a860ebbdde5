"""Pipelines across stages: the demos (measure, identify, tune, test, compare) and the files they write."""

from __future__ import annotations


def run_machine_demo(machine: str, *, seed: int = 0, engine: str = "auto", limits=None, keep_raw: bool = False,
                     objective=None):
    """The demo of a registered machine (:func:`feedtune.machines.get_machine`): measure, identify, tune, test and
    compare on its twin; nothing is written.

    Parameters
    ----------
    machine : str
        A registered machine with a demo (:attr:`~feedtune.machines.registry.MachineEntry.demo`): ``ballscrew``,
        ``gantry`` (UsageError for another name).
    seed : int
        Seed of the excitation phases and the measurement noise.
    engine : str
        Simulation engine: ``auto``, ``numba`` or ``python``.
    limits : Limits, optional
        The limits every controller is tuned and checked under (default: ``textbook``).
    keep_raw : bool
        Also keep the raw excitation logs (gantry).
    objective : str or Objective, optional
        What every tuner maximises (:class:`feedtune.tune.search.Objective`; default its default, ``stiffness``;
        the ball screw's may carry a compliance cap).

    Returns
    -------
    DemoResult or GantryDemoResult
        ``texts`` (the files), ``to_dict()``, ``summary()`` (what ``feedtune demo`` prints).
    """
    from ..errors import UsageError
    from ..machines import get_machine, machines
    from ..structures import resolve

    entry = get_machine(machine)
    if entry.demo is None:
        raise UsageError(f"machine {machine!r} has no demo; demos: "
                         f"{', '.join(m.name for m in machines() if m.demo is not None)}")
    return resolve(entry.demo)(seed=seed, engine=engine, limits=limits, keep_raw=keep_raw, objective=objective)
