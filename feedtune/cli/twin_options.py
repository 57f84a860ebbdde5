"""Building a twin from ``--machine``, ``--param NAME=VALUE`` and ``--ideal`` (every simulate command), its kernels
compiled first when they are not built yet (:func:`feedtune.workflows.warmup.ensure_kernels`)."""

from __future__ import annotations


def parse_params(items: list[str] | None) -> dict[str, str]:
    """``--param NAME=VALUE`` options as ``{NAME: VALUE}``; UsageError for an item without ``=``."""
    from ..errors import UsageError

    overrides = {}
    for item in items or []:
        key, sep, val = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"--param expects NAME=VALUE, got {item!r}")
        overrides[key.strip()] = val.strip()
    return overrides


def twin_from_options(machine: str, params: list[str] | None, ideal: bool, *, plant: str = "two_mass"):
    """The registered machine's twin; UsageError when the command group does not simulate ``machine`` (it runs the
    twins of the plant structure ``plant``)."""
    from .. import progress
    from ..errors import UsageError
    from ..machines import get_machine, machines_of
    from ..workflows.warmup import MACHINE_KERNELS, ensure_kernels

    names = machines_of(plant)
    if machine not in names:
        raise UsageError(f"unknown machine {machine!r} for this command; it runs the {' or '.join(names)} twin "
                         f"('feedtune simulate --help' lists the other machines' experiments)")
    overrides = parse_params(params)
    try:
        twin = get_machine(machine).twin(overrides, ideal=ideal)
    except UsageError as exc:
        if not overrides:
            raise
        raise UsageError(f"--param: {exc}") from None
    ensure_kernels(MACHINE_KERNELS.get(machine, ()))  # a first run compiles them as a step of its own
    progress.step(f"running the {machine} twin")
    return twin
