"""One JSON envelope for the ``--json`` output of every command (``docs/json.md``).

Every command prints one object with the same top-level keys:

* ``kind``: the command, dotted: ``identify.ballscrew``, ``design.ppc``, ``tune.ppi``, ``analyze.gains``,
  ``simulate.gantry.frf``, ``demo.ballscrew`` (:func:`command_kind`);
* ``feedtune_version``;
* ``inputs``: every argument and option of the command that shapes the result, as given (paths as typed, not
  resolved; options not given are null), without ``--json``, ``--force``, the output paths and the progress options
  (:func:`command_inputs`);
* the command's results (its keys are listed in ``docs/json.md`` and checked by ``feedtune/schemas/<kind>.json``);
* ``warnings``: a list of strings, always present: every warning the command prints (on stderr or in its summary)
  and those its result carries, in that order, each once;
* ``check``: the limits verdict, where a limit applies (``design``, ``tune``, ``analyze GAINS``, ``export c``).

Identified parameters (``params``) and designed gains (``gains``) are spelled one way everywhere:
``{"value": v, "unit": "...", "std": s_or_null}`` (:func:`quantity`).

The warnings of a run are collected in the command-line context (:func:`warn`, :func:`collect`), so the helpers a
command calls (FRF readers, the sample-rate rule) add theirs without passing a collector around; :func:`emit`
builds the envelope and prints it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import typer

#: Key of the warnings list in the command-line context's ``meta`` (shared by every context of one run).
_META_KEY = "feedtune.envelope.warnings"

#: ``inputs`` leaves these out: they change where or how the result is shown, not the result.
NOT_INPUTS = frozenset({"json", "force", "quiet", "progress", "no_progress", "verbose", "help", "version"})

#: Commands whose first argument names what they run: its value completes the kind (``tune ppi`` -> ``tune.ppi``).
SUBKIND_ARGUMENT = {"tune": "structure", "demo": "machine"}

SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"
"""The JSON Schema dialect of ``feedtune/schemas/*.json``."""


# ------------------------------------------------------------------------------------------ values
def quantity(value, unit: str, std=None) -> dict:
    """``{"value": value, "unit": unit, "std": std}``: one identified parameter or designed gain.

    Parameters
    ----------
    value : float or None
        The value in ``unit``.
    unit : str
        Its unit (``"-"`` for a number without one).
    std : float or None
        Its standard deviation in ``unit``; None when the method gives none (designed gains, given values).
    """
    return {"value": value, "unit": unit or "-", "std": std}


def quantities(values: Mapping, units: Mapping, std: Mapping | None = None,
               names: Iterable[str] | None = None) -> dict:
    """``{name: quantity(values[name], units[name], std.get(name))}`` for ``names`` (default: every value)."""
    std = std or {}
    return {k: quantity(values[k], units.get(k, "-"), std.get(k)) for k in (values if names is None else names)
            if k in values}


def analysis_warnings(analysis: Mapping | None) -> list[str]:
    """The warnings of every analysis case (``{case: {..., "warnings": [...]}}``), each named by its case."""
    out = []
    for case, a in (analysis or {}).items():
        if isinstance(a, Mapping):
            out += [f"{case} case: {w}" for w in a.get("warnings") or []]
    return out


def design_result(result: Mapping, gains_kind: str | None = None) -> dict:
    """A design or analysis result (``gains`` as numbers in ``gain_units``, ``kind`` the gains kind) in the envelope's
    spelling: ``gains_kind`` instead of ``kind``, ``gains`` as :func:`quantity` entries; the warnings of its
    analysis cases and of its tuning record are collected (:func:`collect`)."""
    out = dict(result)
    old_kind = out.pop("kind", None)
    out = {"gains_kind": gains_kind or old_kind, **out}
    out["gains"] = quantities(result.get("gains", {}), result.get("gain_units", {}))
    design = result.get("design")
    if isinstance(design, Mapping):
        collect(*(design.get("warnings") or []))
    collect(*analysis_warnings(result.get("analysis")))
    return out


# ------------------------------------------------------------------------------------------ the run's context
def _context():
    """The command-line context of the running command, None outside a command (library use)."""
    try:  # recent typer releases carry their own copy of click (typer._click), with its own context stack
        from typer._click.globals import get_current_context
    except ImportError:  # pragma: no cover - older typer runs on click itself
        from click import get_current_context
    return get_current_context(silent=True)


def _collected() -> list[str] | None:
    ctx = _context()
    return None if ctx is None else ctx.meta.setdefault(_META_KEY, [])


def collect(*messages) -> None:
    """Add warnings to the ``--json`` envelope of the running command (empty messages and repeats are skipped)."""
    bucket = _collected()
    if bucket is None:
        return
    for m in messages:
        text = cli_text(m) if m else ""
        if text and text not in bucket:
            bucket.append(text)


def cli_text(message) -> str:
    """A warning in the command line's words (a library :class:`~feedtune.errors.Notice` names parameters; here
    they are the options); other messages as they are."""
    from ..errors import Notice, cli_message

    return cli_message(message) if isinstance(message, Notice) else str(message)


def warn(message: str) -> None:
    """Print ``feedtune: warning: MESSAGE`` on stderr and add it to the ``--json`` envelope."""
    typer.echo(f"feedtune: warning: {cli_text(message)}", err=True)
    collect(message)


def command_kind() -> str:
    """The running command as a dotted kind: ``identify.ballscrew``, ``tune.ppi``, ``analyze.gains``."""
    ctx = _context()
    if ctx is None:
        return "feedtune"
    names, c = [], ctx
    while c.parent is not None:
        names.append(c.info_name)
        c = c.parent
    names.reverse()
    if not names and ctx.command.name:  # a command run on its own (an app of one command)
        names = [ctx.command.name]
    sub = SUBKIND_ARGUMENT.get(".".join(names))
    if sub and ctx.params.get(sub):
        names.append(str(ctx.params[sub]))
    return ".".join(names) or "feedtune"


def _input_key(param) -> str:
    """An option's long name without dashes (``--frf-map`` -> ``frf_map``), an argument's name."""
    if getattr(param, "param_type_name", "") == "option":
        long = [o for o in param.opts if o.startswith("--")]
        if long:
            return max(long, key=len)[2:].replace("-", "_")
    return str(param.name).rstrip("_")


def command_inputs() -> dict:
    """The running command's arguments and options (see the module docstring), JSON-ready."""
    from .common import jsonable

    ctx = _context()
    if ctx is None:
        return {}
    out = {}
    for param in ctx.command.params:
        key = _input_key(param)
        if key in NOT_INPUTS or key == "out" or key.endswith("_out") or param.name not in ctx.params:
            continue
        value = ctx.params[param.name]
        out[key] = jsonable(list(value) if isinstance(value, tuple) else value)
    return out


# ------------------------------------------------------------------------------------------ the envelope
def build(result: Mapping, *, kind: str | None = None, check: Mapping | None = None) -> dict:
    """The envelope of ``result`` (module docstring), JSON-ready.

    Parameters
    ----------
    result : Mapping
        The command's results; its own ``kind`` (a library record's) is dropped, its ``warnings`` come first in the
        envelope's, its ``check`` is kept.
    kind : str, optional
        The envelope's kind (default: :func:`command_kind`).
    check : Mapping, optional
        The limits verdict, when the result has none of its own.
    """
    from .. import __version__
    from .common import jsonable

    body = dict(result)
    body.pop("kind", None)
    own = list(body.pop("warnings", None) or [])
    check = body.pop("check", check)
    warnings: list[str] = []
    for w in own + list(_collected() or []):
        text = cli_text(w) if w else ""
        if text and text not in warnings:
            warnings.append(text)
    doc = {"kind": kind or command_kind(), "feedtune_version": __version__, "inputs": command_inputs(), **body,
           "warnings": warnings}
    if check is not None:
        doc["check"] = check
    return jsonable(doc)


def emit(result: Mapping, *, kind: str | None = None, check: Mapping | None = None) -> None:
    """Print the envelope of ``result`` (:func:`build`) as one JSON object on stdout."""
    from .common import print_json

    print_json(build(result, kind=kind, check=check))


# ------------------------------------------------------------------------------------------ schemas
def schema_path(kind: str):
    """The JSON Schema (draft 2020-12) of a kind's envelope: ``feedtune/schemas/<kind>.json`` (package data)."""
    from importlib.resources import files

    return files("feedtune").joinpath("schemas", f"{kind}.json")


def load_schema(kind: str) -> dict:
    """The JSON Schema of a kind's envelope as a dict; UsageError naming the kind when there is none."""
    import json

    from ..errors import UsageError

    path = schema_path(kind)
    if not path.is_file():
        raise UsageError(f"no JSON schema for kind {kind!r} (feedtune/schemas/{kind}.json)")
    return json.loads(path.read_text(encoding="utf-8"))


def validate(doc: Mapping) -> None:
    """Validate an envelope against the schema of its ``kind`` (jsonschema); ``jsonschema.ValidationError`` if not."""
    import jsonschema

    schema = load_schema(str(doc.get("kind")))
    jsonschema.Draft202012Validator(schema, format_checker=None).validate(doc)
