"""Building a twin from ``--machine``, ``--param NAME=VALUE`` and ``--ideal`` (every simulate command); its kernels
compile on first use (``feedtune warmup`` compiles them ahead: :func:`feedtune.workflows.warmup.ensure_kernels`)."""

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
    from ..errors import UsageError
    from ..machines import get_machine, machines_of

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
    # nothing printed and nothing compiled here: the command's checks that need the twin (--x within its travel, an
    # output derived from --out) come first; its kernels compile on first use (`feedtune warmup` does it ahead)
    return twin
