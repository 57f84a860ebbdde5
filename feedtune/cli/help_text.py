"""What ``feedtune ... --help`` shows beyond the option declarations: choice lists, one example per command, and the
preparation of the command tree for typer's rich help (:func:`prepare_help`).

* **Choices.** An option with a fixed set of values declares them with :func:`choice`: the help shows
  ``auto|numba|python`` and the shell completes them. The values stay checked by the library (its messages name the
  parameter and list the values); the tuples here are copies of the library's constants, held equal to them by
  ``tests/test_cli_help.py``, so that ``feedtune --help`` needs no library import.
* **Examples.** :data:`EXAMPLES` holds the example of every command, run from the repository root on the files of
  ``examples/``; lines before the command's own line write its inputs. ``tests/test_cli_help.py`` extracts each from
  ``--help`` and runs it in a scratch folder. Lines stay within 76 characters (continued with `` \\``) so that an
  80-column terminal shows them unwrapped and they can be pasted into a shell.
* **Markup.** Help texts are plain text with units in brackets (``[Hz]``, ``[m/rad]``); :func:`prepare_help` escapes
  them for rich markup, joins the hard-wrapped lines of docstring paragraphs and hides typer's Python type names
  where a metavar or a flag says it all.
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable, Iterator, Sequence

ENGINES = ("auto", "numba", "python")
"""``--engine``: :data:`feedtune.sim.engine.ENGINES`."""
EXCITATIONS = ("multisine", "chirp", "prbs")
"""``simulate frf --excitation``: :data:`feedtune.machines.ballscrew.experiments.EXCITATIONS`."""
FRF_METHODS = ("h1", "periodic")
"""``frf --method``: :data:`feedtune.identify.frf_estimate.METHODS`."""
KALMAN_METHODS = ("steady-state", "filterpy")
"""``identify friction --method``: :data:`feedtune.identify.kalman.METHODS`."""
FRICTION_LAWS = ("stribeck", "hump", "lugre", "coulomb-viscous")
"""``--law``: :data:`feedtune.models.friction.LAWS`."""
QUANTITIES = ("position", "velocity", "acceleration")
"""``--quantity``: :data:`feedtune.frf.QUANTITIES`."""
SHAPES = ("circle", "diamond")
"""``simulate gantry contour --shape``: :data:`feedtune.sim.contour.SHAPES`."""
FEATURES = ("1um", "1mm", "200mm")
"""``simulate gantry contour --feature``: the keys of :data:`feedtune.sim.contour.THESIS_FEATURES`."""
TRACKING_TESTS = ("1mm_s", "200mm_s")
"""``simulate gantry track --test``: the keys of :data:`feedtune.machines.gantry.experiments.THESIS_TRACKING`."""
LIMITS_PROFILES = ("textbook", "thesis")
"""``--limits``: the keys of :data:`feedtune.analysis.limits.PROFILES`."""
ANTI_WINDUP = ("none", "clamp")
"""``export c --anti-windup``: :data:`feedtune.export.c_common.ANTI_WINDUP`."""
FILTER_CHOICES = ("own", "identical")
"""``--filters``: :data:`feedtune.tune.pid.FILTER_CHOICES`."""
LPF_ORDERS = ("1", "2")
"""``--lpf-order``: first or second order."""
SHAPER_TYPES = ("zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei")
"""``--shaper``: :data:`feedtune.control.shapers.SHAPER_TYPES`."""
SHAPER_AXES = ("x", "y", "z")
"""``design shaper --axis``: :data:`feedtune.io.shaper_file.AXES`."""


def choice(values: Sequence[str], metavar: str | None = None) -> dict:
    """Keyword arguments of ``typer.Option``/``typer.Argument`` that show ``values`` as ``a|b|c`` in the help (or
    ``metavar`` where the list is long: the help text names the values then) and complete them in the shell; the
    value itself stays a string checked where it is used."""
    values = tuple(values)

    def complete(incomplete: str) -> list[str]:
        return [v for v in values if v.startswith(incomplete)]

    return {"metavar": metavar or "|".join(values), "autocompletion": complete}


# ------------------------------------------------------------------------------------------ examples
_BS_MODEL = "feedtune identify ballscrew examples/ballscrew_frf.csv --out model.toml"
_DRIVE_CASCADE = ("feedtune design cascade examples/vendor/auto_servo_tuning.xml \\\n"
                  "    --drive-tuning examples/vendor/auto_servo_tuning.xml --out drive.toml")
_BS_FILTERS = "--notch 420,0.55,0.7 --notch 1080,0.05,0.7 --lpf 2000"
_BS_MCPPC = (f"feedtune design ppc model.toml \\\n    {_BS_FILTERS} \\\n"
             "    --frf examples/ballscrew_frf.csv --out mcppc.toml")
_GANTRY_MODEL = ("feedtune identify gantry examples/gantry_frf_x-0.3.csv \\\n"
                 "    examples/gantry_frf_x0.csv examples/gantry_frf_x0.3.csv \\\n"
                 "    --x -0.3 --x 0 --x 0.3 --span 1.484 --out gantry.toml")
_GANTRY_MIMO = ("feedtune design gantry gantry.toml --crossover-hz 60 --pm-deg 40 \\\n"
                "    --out mimo.toml")
_AXIS = ("feedtune design loopshape gantry.toml --crossover-hz 130 --pm-deg 35 \\\n"
         "    --out axis.toml")

EXAMPLES: dict[str, tuple[str, ...]] = {
    "identify ballscrew": (_BS_MODEL,),
    "identify rigid": ("feedtune identify rigid examples/ballscrew_reversals.csv \\\n"
                       "    --position x2 --input u --velocity-threshold 3 --out rigid.toml",),
    "identify friction": ("feedtune identify friction examples/ballscrew_reversals.csv \\\n"
                          "    --position x2 --min-speed 0.1 --out friction.toml",),
    "identify gantry": (_GANTRY_MODEL,),
    "identify mass": ("feedtune simulate gantry mass --x -0.3 --x 0.3 --out mass.csv",
                      "feedtune identify mass mass_x-0.3.csv mass_x0.3.csv --x -0.3 --x 0.3 \\\n"
                      "    --axis-log mass_axis.csv --out mass.toml"),
    "identify resonances": ("feedtune identify resonances \\\n"
                            "    examples/vendor/klipper_calibration_data_x.csv",),
    "frf estimate": ("feedtune simulate frf --seed 1 --out excitation.csv",
                     "feedtune frf estimate excitation.csv --input u --output x1,x2 \\\n"
                     "    --reference r --method periodic --out frf.csv"),
    "frf merge": ("feedtune frf merge examples/vendor/motor_bode.csv:x1/u \\\n"
                  "    examples/vendor/load_bode.csv:x2/u,scale=-1 --out frf.csv",),
    "frf info": ("feedtune frf info examples/vendor/auto_servo_tuning.xml",),
    "design ppc": (_BS_MODEL, _BS_MCPPC),
    "design ppi": (_BS_MODEL, f"feedtune design ppi model.toml \\\n    {_BS_FILTERS} \\\n"
                              "    --frf examples/ballscrew_frf.csv --out ppi.toml"),
    "design loopshape": (_GANTRY_MODEL, _AXIS),
    "design gantry": (_GANTRY_MODEL, _GANTRY_MIMO),
    "design cascade": (_DRIVE_CASCADE,),
    "design pid": (_GANTRY_MODEL, _GANTRY_MIMO,
                   "feedtune design pid gantry.toml --match mimo.toml --out pid.toml"),
    "design shaper": (_BS_MODEL, f"feedtune design ppi model.toml \\\n    {_BS_FILTERS} \\\n"
                                 "    --frf examples/ballscrew_frf.csv --out ppi.toml",
                      "feedtune design shaper ppi.toml --frf examples/ballscrew_frf_m70.csv \\\n"
                      "    --frf examples/ballscrew_frf_m100.csv \\\n"
                      "    --frf examples/ballscrew_frf_m130.csv --out ppi_shaped.toml"),
    "tune": (_BS_MODEL, "feedtune tune mcppc model.toml --frf examples/ballscrew_frf_m70.csv \\\n"
                        "    --frf examples/ballscrew_frf_m100.csv \\\n"
                        "    --frf examples/ballscrew_frf_m130.csv --out mcppc_family.toml"),
    "prefilter": (_BS_MODEL, _BS_MCPPC,
                  "feedtune prefilter examples/ballscrew_track.csv --gains mcppc.toml \\\n"
                  "    --out mcppc_pf.toml"),
    "analyze gains": (_BS_MODEL, _BS_MCPPC,
                      "feedtune analyze mcppc.toml --frf examples/ballscrew_frf.csv --check"),
    "analyze track": ("feedtune analyze track examples/ballscrew_track.csv",),
    "project init": (_BS_MODEL, "feedtune project init --model model.toml \\\n"
                                "    --frf examples/ballscrew_frf_m70.csv \\\n"
                                "    --frf examples/ballscrew_frf_m100.csv --gains gains.toml \\\n"
                                "    --structure mcppc --set tune.lpf=800"),
    "analyze ropesnap": ("feedtune analyze ropesnap examples/ballscrew_ropesnap.csv",),
    "export c": (_BS_MODEL, _BS_MCPPC,
                 "feedtune export c mcppc.toml --u-max 10 --anti-windup clamp --out mcppc.h"),
    "export klipper": ("feedtune design shaper \\\n    --psd examples/vendor/klipper_calibration_data_x.csv \\\n"
                       "    --out x_shaper.toml",
                       "feedtune export klipper x_shaper.toml --out input_shaper.cfg"),
    "export marlin": ("feedtune design shaper --mode 52.6,0.1 --shaper zv --out x_shaper.toml",
                      "feedtune export marlin x_shaper.toml --out shaper.gcode"),
    "export drive": (_DRIVE_CASCADE,
                     "feedtune export drive sinamics drive.toml --torque-constant 1.2 \\\n"
                     "    --frf examples/vendor/auto_servo_tuning.xml --out drive.txt"),
    "import drive": (_DRIVE_CASCADE,
                     "feedtune export drive sinamics drive.toml --torque-constant 1.2 \\\n"
                     "    --out drive.txt",
                     "feedtune import drive sinamics drive.txt --command-unit A \\\n"
                     "    --torque-constant 1.2 --out drive_back.toml"),
    "export linuxcnc": (_BS_MODEL, _BS_MCPPC,
                        "feedtune export linuxcnc mcppc.toml --u-max 10 --name ft_x \\\n"
                        "    --out ft_x.c"),
    "report": (_BS_MODEL, "feedtune report model.toml examples/ballscrew_frf.csv \\\n"
                          "    examples/ballscrew_track.csv examples/ballscrew_ropesnap.csv \\\n"
                          "    --out report.html"),
    "explore": (_BS_MODEL, _BS_MCPPC,
                "feedtune explore mcppc.toml --frf examples/ballscrew_frf.csv \\\n"
                "    --out explore.html"),
    "simulate frf": ("feedtune simulate frf --seed 1 --out excitation.csv",),
    "simulate track": (_BS_MODEL, _BS_MCPPC,
                       "feedtune simulate track --gains mcppc.toml --distance 0.02 --v-max 0.2 \\\n"
                       "    --out track.csv"),
    "simulate ropesnap": (_BS_MODEL, _BS_MCPPC,
                          "feedtune simulate ropesnap --gains mcppc.toml --out ropesnap.csv"),
    "simulate cut": (_BS_MODEL, _BS_MCPPC,
                     "feedtune simulate cut --gains mcppc.toml --speed 0.2 --out cut.csv"),
    "simulate gantry frf": ("feedtune simulate gantry frf --x -0.3 --x 0 --x 0.3 --out gantry.csv",),
    "simulate gantry axis-frf": ("feedtune simulate gantry axis-frf --x 0 --out axis.csv",),
    "simulate gantry mass": ("feedtune simulate gantry mass --x -0.3 --x 0.3 --out mass.csv",),
    "simulate gantry ropesnap": (_GANTRY_MODEL, _GANTRY_MIMO,
                                 "feedtune simulate gantry ropesnap --gains mimo.toml \\\n"
                                 "    --out ropesnap.csv"),
    "simulate gantry track": (_GANTRY_MODEL, _GANTRY_MIMO,
                              "feedtune simulate gantry track --gains mimo.toml --distance 0.02 \\\n"
                              "    --out track.csv"),
    "simulate gantry contour": (_GANTRY_MODEL, _GANTRY_MIMO, _AXIS,
                                "feedtune simulate gantry contour --gains mimo.toml \\\n"
                                "    --axis-gains axis.toml --size 0.02 --out contour.csv"),
    "trajectory": ("feedtune trajectory --distance 0.1 --v-max 0.5 --a-max 9.81 --j-max 500 \\\n"
                   "    --out traj.csv",),
    "demo": ("feedtune demo --out demo_out",),
    "warmup": ("feedtune warmup",),
    "log convert": ("feedtune log convert examples/ballscrew_reversals.csv --map position=x2 \\\n"
                    "    --unit position=rad --keep u,position --out reversals.csv",),
    "log resample": ("feedtune log resample examples/ballscrew_reversals.csv --fs 250 \\\n"
                     "    --out reversals_250hz.csv",),
    "fleet simulate": ("feedtune fleet simulate fleet --axes 4 --weeks 5 --drift-share 0.5",),
    "fleet run": ("feedtune fleet simulate fleet --axes 4 --weeks 5 --drift-share 0.5",
                  "feedtune fleet run fleet/fleet.toml --history history.parquet"),
    "fleet report": ("feedtune fleet simulate fleet --axes 4 --weeks 5 --drift-share 0.5",
                     "feedtune fleet run fleet/fleet.toml --history history.parquet",
                     "feedtune fleet report fleet/fleet.toml --history history.parquet \\\n"
                     "    --out fleet.html"),
    "log merge": ("feedtune log convert examples/ballscrew_track.csv --keep u --out u.csv",
                  "feedtune log convert examples/ballscrew_track.csv --keep x2_table \\\n"
                  "    --out x.csv",
                  "feedtune log merge u.csv x.csv --shift x2_table=0.0005 --out merged.csv"),
}
"""The example of every command (by its path after ``feedtune``), run from the repository root; the last line is
the command's own, the lines before it write its inputs."""

EXAMPLE_HEADING = "Example"
"""The first word of every example block (tests find the example by it)."""


def example_epilog(path: str) -> str:
    """The help epilog of the command ``path``: its example as rich markup."""
    lines = EXAMPLES[path]
    intro = "from the repository root" + ("; the first lines write its inputs" if len(lines) > 1 else "")
    body = "\n".join(lines)
    return f"[bold]{EXAMPLE_HEADING}[/bold] ({intro}):\n\n{escape(body)}"


def example_commands(text: str) -> list[str]:
    """The command lines of an example block in ``text`` (a ``--help`` output), continuations joined."""
    start = text.find(EXAMPLE_HEADING + " (")
    if start < 0:
        return []
    commands: list[str] = []
    pending = ""
    for raw in text[start:].splitlines()[1:]:
        line = raw.strip().strip("│").strip()
        if not pending and not line.startswith("feedtune "):
            continue
        if line.endswith("\\"):
            pending += line[:-1].strip() + " "
            continue
        commands.append(" ".join((pending + line).split()))
        pending = ""
    return commands


# ------------------------------------------------------------------------------------------ rich help
_MARKUP_TAG = re.compile(r"(\\*)(\[[a-z#/@][^[]*?])")
"""What rich reads as a markup tag (``rich.markup.escape`` uses the same expression)."""


def escape(text: str) -> str:
    """``text`` with every ``[...]`` that rich would read as markup escaped (``[m/rad]`` -> ``\\[m/rad]``)."""
    text = _MARKUP_TAG.sub(lambda m: f"{m.group(1)}{m.group(1)}\\{m.group(2)}", text)
    return text + "\\" if text.endswith("\\") and not text.endswith("\\\\") else text


def unwrap(doc: str) -> str:
    """A docstring with the hard line breaks inside each paragraph joined (rich keeps single newlines)."""
    paragraphs = inspect.cleandoc(doc).split("\n\n")
    return "\n\n".join(p if p.startswith("\b") else " ".join(p.split("\n")) for p in paragraphs)


def iter_commands(app, path: tuple[str, ...] = ()) -> Iterator[tuple[str, object]]:
    """``(path, CommandInfo)`` of every command of a Typer app and its sub-apps."""
    for info in app.registered_commands:
        name = info.name or info.callback.__name__.lower().replace("_", "-")
        yield " ".join((*path, name)), info
    for group in app.registered_groups:
        yield from iter_commands(group.typer_instance, (*path, group.name))


def iter_apps(app) -> Iterator[object]:
    yield app
    for group in app.registered_groups:
        yield from iter_apps(group.typer_instance)


def _prepare_text(obj, attribute: str, transform: Callable[[str], str]) -> None:
    """Apply ``transform`` to a help text attribute once (option declarations are shared between commands)."""
    done = getattr(obj, "_feedtune_help_done", set())
    value = getattr(obj, attribute, None)
    if attribute in done or not isinstance(value, str):
        return
    setattr(obj, attribute, transform(value))
    try:
        obj._feedtune_help_done = done | {attribute}
    except AttributeError:  # pragma: no cover - a slotted object: prepared once per process anyway
        pass


def prepare_help(app) -> None:
    """Make the Typer app ``app`` ready for rich help: escape the markup of every help text, unwrap docstring
    paragraphs, add the example epilog of every command in :data:`EXAMPLES`, and show no Python type names beside
    flags and named arguments (:func:`readable_types`). Idempotent."""
    import typer.models

    readable_types()
    for sub in iter_apps(app):
        _prepare_text(sub.info, "help", lambda t: escape(unwrap(t)))
    for path, info in iter_commands(app):
        if info.help is None and info.callback.__doc__:
            info.help = inspect.getdoc(info.callback)
        _prepare_text(info, "help", lambda t: escape(unwrap(t)))
        if info.epilog is None and path in EXAMPLES:
            info.epilog = example_epilog(path)
        for parameter in inspect.signature(info.callback).parameters.values():
            if isinstance(parameter.default, typer.models.ParameterInfo):
                _prepare_text(parameter.default, "help", escape)


def readable_types() -> None:
    """Show no type beside a flag (``--force``, not ``--force <bool>``) or beside an argument that has a metavar
    (``MODEL``, not ``MODEL <path>``): recent typer versions print the Python type of every parameter in the rich
    help. Options name their value by their metavar (``--fs HZ``). A no-op where typer lacks the method."""
    from typer import core

    argument_cls = getattr(core, "TyperArgument", None)
    for cls in (getattr(core, "TyperOption", None), argument_cls):
        original = getattr(cls, "display_type_rich", None)
        if original is None or getattr(original, "_feedtune", False):
            continue

        def display_type_rich(self, ctx, _original=original):
            if getattr(self, "is_flag", False) and self.metavar is None:
                return None
            if argument_cls is not None and isinstance(self, argument_cls) and self.metavar:
                return None
            return _original(self, ctx)

        display_type_rich._feedtune = True
        cls.display_type_rich = display_type_rich
