"""Building a twin from ``--machine``, ``--param NAME=VALUE`` and ``--ideal`` (every simulate command)."""

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


def twin_from_options(machine: str, params: list[str] | None, ideal: bool, *, group: str = "ballscrew"):
    """The registered machine's twin; UsageError when the command group does not simulate ``machine``."""
    from ..errors import UsageError
    from ..machines import get_machine

    if machine != group:
        raise UsageError(f"unknown machine {machine!r} for this command; it runs the {group} twin "
                         f"(the gantry's experiments are under 'feedtune simulate gantry')")
    overrides = parse_params(params)
    try:
        return get_machine(machine).twin(overrides, ideal=ideal)
    except UsageError as exc:
        if not overrides:
            raise
        raise UsageError(f"--param: {exc}") from None
