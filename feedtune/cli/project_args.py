"""A project file's arguments on the command line: ``feedtune tune``, ``analyze``, ``report`` without arguments.

:func:`expand` rewrites the command line before it is parsed. The project file (:mod:`feedtune.io.project_file`) is
``--project PATH`` when given (any command of :data:`PROJECT_COMMANDS`), else ``./feedtune.toml`` when the command
is given no argument (no STRUCTURE, MODEL, GAINS or FILE: options alone, such as ``--force``). Then every argument
and option the user did not give comes from the project: the command's own section (``[tune]``), then ``[axis]``
(:data:`AXIS_FILLS`: the model, FRFs, gains file and logs named once) and ``[limits]``. What the user typed wins;
arguments come from the project only when none is typed. One line on stderr names the project file and the command
as run, and the command's documents record both (:mod:`feedtune.io.provenance`).

``--force``, ``--json`` and ``--quiet`` are the user's to type: a project file cannot overwrite files on its own.
A key of a command section that is no option of the command, or a value of the wrong shape, is a data error naming
the project file and the key (exit 1); ``--project`` on another command, or without a file, a usage error (exit 2).
"""

from __future__ import annotations

import os
import shlex
from pathlib import Path

PROJECT_OPTION = "--project"

PROJECT_COMMANDS = {("tune",): "tune", ("analyze", "gains"): "analyze", ("report",): "report"}
"""The command paths a project file gives arguments to, and their sections."""

AXIS_FILLS = {
    "tune": {"model_file": ("model",), "frf": ("frf",), "out": ("gains",)},
    "analyze": {"gains_file": ("gains",), "frf": ("frf",)},
    "report": {"inputs": ("model", "gains", "frf", "logs")},
}
"""``{section: {parameter: [axis] keys}}``: what ``[axis]`` fills when the section does not."""

LIMIT_PARAMETERS = {"profile": "limits", "ms_max": "ms_max", "pm_min": "pm_min", "gm_min": "gm_min",
                    "gm_low_min": "gm_low_min", "dm_min": "dm_min"}
"""``[limits]`` key -> the parameter of ``--limits``, ``--ms-max`` ... (every project command takes them)."""

USER_ONLY = frozenset({"force", "as_json", "quiet", "help"})
"""Parameters a project file may not give: they change whether files are replaced and how the run is shown."""


def _leaf(root, tokens: list[str]):
    """``(path, command, rest)``: the command path ``tokens`` start with (``analyze`` + a gains file or nothing:
    ``analyze gains``), its click command and the tokens after it; ``(path, None, rest)`` for a group."""
    cmd, path, i = root, [], 0
    while getattr(cmd, "commands", None) is not None:
        subs = cmd.commands
        if i < len(tokens) and tokens[i] in subs:
            cmd = subs[tokens[i]]
            path.append(tokens[i])
            i += 1
        elif getattr(cmd, "default_command", None) in subs and (i >= len(tokens) or tokens[i] not in ("-h", "--help")):
            cmd = subs[cmd.default_command]  # 'analyze' alone or 'analyze FILE': the gains command
            path.append(cmd.name)
        else:
            return tuple(path), None, tokens[i:]
    return tuple(path), cmd, tokens[i:]


def _key(param) -> str:
    """A parameter's key in a project section: an option's long name with underscores (``--frf-map``:
    ``frf_map``), an argument's metavar in lower case (``MODEL``: ``model``)."""
    if getattr(param, "param_type_name", "") == "option":
        longs = [o for o in param.opts if o.startswith("--")]
        return (max(longs, key=len) if longs else param.opts[0]).lstrip("-").replace("-", "_")
    return str(param.metavar or param.name).lower()


def _given(command, tokens: list[str]) -> tuple[set[str], bool]:
    """The parameters ``tokens`` give (by name) and whether they hold an argument (a token that is no option)."""
    options = {}
    for p in command.params:
        if getattr(p, "param_type_name", "") == "option":
            for o in (*p.opts, *getattr(p, "secondary_opts", ())):
                options[o] = p
    given, positional, i = set(), False, 0
    while i < len(tokens):
        t = tokens[i]
        if t == "--":
            positional = positional or i + 1 < len(tokens)
            break
        name = t.split("=", 1)[0] if t.startswith("--") else t
        p = options.get(name)
        if p is not None:
            given.add(p.name)
            takes = 0 if (p.is_flag or getattr(p, "count", False)) or "=" in t else max(1, p.nargs)
            i += 1 + takes
            continue
        if t.startswith("-") and t != "-":
            i += 1  # an unknown option: the parser names it
            continue
        positional = True
        i += 1
    return given, positional


def _strip_project(tokens: list[str]) -> tuple[list[str], str | None, bool]:
    """``tokens`` without ``--project PATH`` / ``--project=PATH``; the path; whether the option was there."""
    from ..errors import UsageError

    out, path, seen, i = [], None, False, 0
    while i < len(tokens):
        t = tokens[i]
        if t == "--":
            out += tokens[i:]
            break
        if t == PROJECT_OPTION or t.startswith(PROJECT_OPTION + "="):
            if t == PROJECT_OPTION:
                if i + 1 >= len(tokens) or tokens[i + 1].startswith("-"):
                    raise UsageError(f"{PROJECT_OPTION} needs a project file (feedtune.toml) or its folder")
                path, i = tokens[i + 1], i + 2
            else:
                path, i = t.split("=", 1)[1], i + 1
            seen = True
            continue
        out.append(t)
        i += 1
    return out, path, seen


def _shown(p: Path) -> str:
    """A path for the command line: relative to the current folder when under it, else absolute."""
    absolute = os.path.abspath(p)
    rel = os.path.relpath(absolute)
    return absolute if rel.startswith("..") else rel


def _resolve_piece(project, value: str) -> str:
    """A report input: a path, or an FRF of pieces ``a.csv:x1/u+b.csv:x2/u,scale=-1`` (each file resolved)."""
    from ..errors import UsageError
    from .frf_options import parse_frf_argument

    try:
        pieces = parse_frf_argument(value, base=project.folder)
    except UsageError:  # not an FRF argument: the command names what is wrong with it
        return value
    out, start = [], 0
    for k, piece in enumerate(pieces):  # each piece's text: its file name as written, then its SPEC
        name = str(piece.path)
        at = value.index(name, start)
        end = value.index(str(pieces[k + 1].path), at + len(name)) - 1 if k + 1 < len(pieces) else len(value)
        out.append(_shown(project.resolve(name)) + value[at + len(name):end])
        start = end
    return "+".join(out)


def _values(project, key: str, param, value) -> list[str]:
    """The command-line tokens of the project's value ``key`` (``tune.filters``, ``axis.frf``) for ``param``."""
    from ..errors import DataError

    where = f"{project.path}: {key}"
    is_option = getattr(param, "param_type_name", "") == "option"
    if is_option and param.is_flag:
        if not isinstance(value, bool):
            raise DataError(f"{where}: expected true or false, got {value!r}")
        longs = [o for o in param.opts if o.startswith("--")] or list(param.opts)
        if value:
            return [longs[0]]
        off = [o for o in getattr(param, "secondary_opts", ()) if o.startswith("--")]
        return [off[0]] if off else []
    many = bool(getattr(param, "multiple", False)) or param.nargs == -1
    items = list(value) if isinstance(value, list) else [value]
    if isinstance(value, list) and not many and param.nargs == 1:
        raise DataError(f"{where}: expected one value, got a list of {len(value)}")
    if not many and param.nargs > 1 and len(items) != param.nargs:
        raise DataError(f"{where}: expected {param.nargs} values, got {len(items)}")
    if any(isinstance(v, bool) for v in items):
        raise DataError(f"{where}: expected {'a path' if _is_path(param) else 'a value'}, got {value!r}")
    if _is_path(param):
        text = [_resolve_piece(project, str(v)) if param.name == "inputs" else _shown(project.resolve(str(v)))
                for v in items]
    else:
        text = [repr(v) if isinstance(v, float) else str(v) for v in items]
    if not is_option:
        return text
    flag = max((o for o in param.opts if o.startswith("--")), key=len, default=param.opts[0])
    if many:
        return [t for v in text for t in (flag, v)]
    return [flag, *text]


def _is_path(param) -> bool:
    """Whether a parameter takes paths (typer's ``Path`` annotation; click's ``Path`` type)."""
    descriptor = getattr(param, "type_descriptor", None)
    if descriptor is not None:
        return "Path" in str(descriptor.annotation)
    return getattr(getattr(param, "type", None), "name", "") == "path"


def project_values(project, section: str, command) -> dict:
    """``{parameter name: (key, value)}`` the project gives ``command`` (section, then ``[axis]``, ``[limits]``);
    DataError naming the file and the key that is no option of the command."""
    from ..errors import DataError

    params = {p.name: p for p in command.params}
    by_key = {_key(p): p for p in command.params}
    by_key.update({p.name: p for p in command.params})
    out: dict = {}
    for name, keys in AXIS_FILLS[section].items():
        values = []
        for k in keys:
            v = {"model": project.model, "gains": project.gains, "frf": list(project.frf),
                 "logs": list(project.logs)}[k]
            values += v if isinstance(v, list) else ([v] if v is not None else [])
        if values and name in params:
            many = getattr(params[name], "multiple", False) or params[name].nargs == -1
            values = [os.path.abspath(v) for v in values]  # resolved already (against the project's folder)
            out[name] = (f"axis.{keys[0]}", values if many else values[0])
    for k, v in project.limits.items():
        out[LIMIT_PARAMETERS[k]] = (f"limits.{k}", v)
    for k, v in project.section(section).items():
        p = by_key.get(k) or by_key.get(k.replace("-", "_"))
        if p is None or p.name in USER_ONLY:
            if p is not None:
                raise DataError(f"{project.path}: {section}.{k}: {_key(p).replace('_', '-')} is given on the "
                                "command line only")
            known = sorted({_key(q).replace("_", "-") for q in command.params if q.name not in USER_ONLY})
            raise DataError(f"{project.path}: {section}.{k}: not an argument or option of feedtune "
                            f"{'analyze' if section == 'analyze' else section}; expected one of {', '.join(known)}")
        out[p.name] = (f"{section}.{k}", v)
    return out


def expand(tokens: list[str], root) -> tuple[list[str], Path | None]:
    """The command line ``tokens`` (after ``feedtune``) with a project's arguments filled in (module docstring), and
    the project file used (None: the tokens as given, ``--project`` aside)."""
    import typer

    from ..errors import DataError, UsageError
    from ..io.project_file import PROJECT_FILE, find_project, read_project

    path, command, rest = _leaf(root, list(tokens))
    rest, given_path, asked = _strip_project(rest)
    section = PROJECT_COMMANDS.get(path)
    if any(t in ("-h", "--help") for t in rest) or command is None:
        if asked and command is None:
            raise UsageError(f"{PROJECT_OPTION} goes after the command: feedtune tune|analyze|report "
                             f"{PROJECT_OPTION} PATH")
        return ([*path, *rest] if asked else list(tokens)), None
    if section is None:
        if asked:
            raise UsageError(f"{PROJECT_OPTION}: feedtune {' '.join(path)} takes no project file (only "
                             "tune, analyze and report do)")
        return list(tokens), None
    given, positional = _given(command, rest)
    if asked:
        p = Path(os.path.expanduser(given_path))
        file = p / PROJECT_FILE if p.is_dir() else p
        if not os.path.lexists(file):
            raise UsageError(f"{PROJECT_OPTION} {given_path}: no such project file")
    else:
        file = find_project() if not positional else None
        if file is None:
            return list(tokens), None
    project = read_project(file)
    filled: list[str] = []
    arguments: list[tuple] = []
    for name, (key, value) in project_values(project, section, command).items():
        param = next(p for p in command.params if p.name == name)
        if getattr(param, "param_type_name", "") == "argument":
            if not positional:
                arguments.append((name, key, value))
        elif name not in given:
            filled += _values(project, key, param, value)
    ordered = []
    if not positional:
        for p in command.params:  # arguments in the command's order
            if getattr(p, "param_type_name", "") == "argument":
                hit = next((a for a in arguments if a[0] == p.name), None)
                if hit is None and p.required:
                    raise DataError(f"{file}: [{section}] {_key(p)} is missing (the command's {p.metavar or p.name}"
                                    + ("; or [axis] " + " or ".join(AXIS_FILLS[section][p.name])
                                       if p.name in AXIS_FILLS[section] else "") + ")")
                if hit is not None:
                    ordered += _values(project, hit[1], p, hit[2])
    out = [*path, *ordered, *filled, *rest]
    typer.echo(f"feedtune: project {_shown(file)}: {command_text(out)}", err=True)
    return out, file


def command_text(tokens: list[str]) -> str:
    """``feedtune TOKENS`` quoted as a shell would need it."""
    return "feedtune " + shlex.join(str(t) for t in tokens)


__all__ = ["AXIS_FILLS", "PROJECT_COMMANDS", "command_text", "expand", "project_values"]
