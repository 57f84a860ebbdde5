"""``feedtune ... --help`` follows the typer/rich conventions, and every command's example runs.

Every command's help renders (exit 0, no traceback), names each value by a metavar or its choices (no Python type such
as ``<list[str]>`` or ``<float,float>``), keeps units in brackets (``[m/rad]``: not eaten as rich markup) and ends with
an example; the example is read back from the help as an 80-column terminal shows it and run, line by line, in a
scratch folder that holds only a link to ``examples/``. Shell completion scripts show. The vocabulary (controller
names, analysis-case titles, choice lists) is the library's, and the summaries' numbers are rounded to what they mean.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from cli_run import run

from feedtune.cli import help_text
from feedtune.cli.common import fmt, fmt_band, fmt_hz, fmt_length, fmt_param
from feedtune.cli.main import app, renamed_options

REPO = Path(__file__).resolve().parents[1]
COMMANDS = [path for path, _ in help_text.iter_commands(app)]
GROUPS = sorted({" ".join(p.split()[:i]) for p in COMMANDS for i in range(1, len(p.split()))})
PYTHON_TYPE = re.compile(r"<(?:bool|int|float|str|path|file|directory|Path|list\[[^>]*|tuple[^>]*|[a-z]+ range"
                         r"|[a-z]+(?:,[a-z]+)+|[a-z0-9_-]+(?:\|[a-z0-9_-]+)+)>")
"""A type as typer prints it when no metavar is given: ``<float>``, ``<list[Path]>``, ``<float,float>``, ``<int
range>``, ``<bool>``, ``<h1|periodic>``."""
ANSI = re.compile(r"\x1b\[[0-9;]*m")

SLOW_EXAMPLES = {"demo", "warmup", "tune", "report", "explore", "frf estimate", "identify mass", "design pid",
                 "simulate frf", "simulate track", "simulate ropesnap", "simulate cut", "simulate gantry frf",
                 "simulate gantry axis-frf", "simulate gantry mass", "simulate gantry ropesnap",
                 "simulate gantry track", "simulate gantry contour"}
"""Examples that run a twin experiment, a tuner's search or the demo (2-30 s each on a 2-core machine): CI runs them
(``-m slow``); the quick set runs the rest (about 15 s in all)."""


def _help(args, capsys, monkeypatch, columns: int = 80) -> str:
    monkeypatch.setenv("COLUMNS", str(columns))
    monkeypatch.delenv("FORCE_COLOR", raising=False)
    monkeypatch.delenv("TERMINAL_WIDTH", raising=False)
    code, out, err = run([*args, "--help"], capsys, monkeypatch)
    assert code == 0, (args, err)
    assert "Traceback" not in out + err and not err, (args, err)
    return ANSI.sub("", out)


def test_every_command_is_listed_with_an_example():
    assert len(COMMANDS) >= 30
    assert set(COMMANDS) == set(help_text.EXAMPLES), set(COMMANDS) ^ set(help_text.EXAMPLES)
    for path, lines in help_text.EXAMPLES.items():
        assert lines[-1].startswith(f"feedtune {path.replace('gains', '').strip()}") or path == "analyze gains", path
        for line in "\n".join(lines).splitlines():
            assert len(line) <= 76, (path, line)  # shown unwrapped on an 80-column terminal


@pytest.mark.parametrize("command", COMMANDS)
def test_help_renders_with_metavars_and_an_example(command, capsys, monkeypatch):
    out = _help(command.split(), capsys, monkeypatch)
    assert f"feedtune {command} [OPTIONS]" in " ".join(out.split())
    assert not PYTHON_TYPE.search(out), PYTHON_TYPE.search(out).group()
    assert "list[" not in out and "<float" not in out
    assert "Example (from the repository root" in out
    # the example as the terminal shows it is the one the module holds: no line wrapped, nothing eaten as markup
    shown = help_text.example_commands(out)
    expected = [" ".join(line.replace("\\\n", " ").split()) for line in help_text.EXAMPLES[command]]
    assert shown == expected


@pytest.mark.parametrize("group", ["", *GROUPS])
def test_group_help_lists_one_line_summaries(group, capsys, monkeypatch):
    out = _help(group.split(), capsys, monkeypatch, columns=100)
    assert not PYTHON_TYPE.search(out), PYTHON_TYPE.search(out).group()
    listed = {line.split("│")[1].split()[0]: line for line in out.splitlines()
              if line.startswith("│ ") and len(line.split("│")) > 2 and line.split("│")[1].strip()}
    subs = {p.split()[len(group.split())] for p in COMMANDS if p.startswith(group)}
    assert subs <= set(listed), subs - set(listed)
    for name in subs:  # a summary is one sentence that ends with a full stop, not cut at "eq."
        assert listed[name].rstrip(" │").endswith("."), listed[name]
        assert not listed[name].rstrip(" │").endswith(("eq.", "Fig.")), listed[name]


def test_units_in_brackets_are_not_eaten_as_markup(capsys, monkeypatch):
    out = " ".join(_help(["identify", "ballscrew"], capsys, monkeypatch, columns=200).split())
    assert "[m/rad]" in out and "[Hz]" in out
    out = " ".join(_help(["design", "gantry"], capsys, monkeypatch, columns=200).split())
    assert "[s, s^2, s^3, s^4]" in out


def test_choices_show_as_choices(capsys, monkeypatch):
    out = " ".join(_help(["simulate", "frf"], capsys, monkeypatch, columns=200).split())
    assert "auto|numba|python" in out and "multisine|chirp|prbs" in out
    out = " ".join(_help(["design", "pid"], capsys, monkeypatch, columns=200).split())
    assert "own|identical" in out and "textbook|thesis" in out and "HZ,ZETA_Z,ZETA_P" in out


def test_choice_lists_are_the_librarys():
    from feedtune.analysis.limits import PROFILES
    from feedtune.export.c_common import ANTI_WINDUP
    from feedtune.frf import QUANTITIES
    from feedtune.identify.frf_estimate import METHODS as FRF_METHODS
    from feedtune.identify.kalman import METHODS as KALMAN_METHODS
    from feedtune.machines.ballscrew.experiments import EXCITATIONS
    from feedtune.machines.gantry.experiments import THESIS_TRACKING
    from feedtune.models.friction import LAWS
    from feedtune.sim.contour import SHAPES, THESIS_FEATURES
    from feedtune.sim.engine import ENGINES
    from feedtune.tune.pid import FILTER_CHOICES

    h = help_text
    assert h.ENGINES == tuple(ENGINES) and h.EXCITATIONS == tuple(EXCITATIONS)
    assert h.FRF_METHODS == tuple(FRF_METHODS) and h.KALMAN_METHODS == tuple(KALMAN_METHODS)
    assert h.FRICTION_LAWS == tuple(LAWS) and h.QUANTITIES == tuple(QUANTITIES) and h.SHAPES == tuple(SHAPES)
    assert h.FEATURES == tuple(THESIS_FEATURES) and h.TRACKING_TESTS == tuple(THESIS_TRACKING)
    assert h.LIMITS_PROFILES == tuple(PROFILES) and h.ANTI_WINDUP == tuple(ANTI_WINDUP)
    assert h.FILTER_CHOICES == tuple(FILTER_CHOICES)


def test_one_vocabulary_for_controllers_and_cases():
    """The command line's names are the report's: controllers MC-PPC, P-PI, MIMO, PID; each analysis case one short
    name (the JSON key) and one long title."""
    from feedtune.analysis.cases import CASE_TITLES, CASES
    from feedtune.cli.summary import CONTROLLER_NAMES
    from feedtune.cli.tune_cmd import TITLES
    from feedtune.report import design, sections

    assert tuple(CASE_TITLES) == CASES
    assert design.CASE_TITLES == CASE_TITLES
    for kind, label in CONTROLLER_NAMES.items():
        assert sections.controller_label(kind) == label, kind
    assert sections.BASELINE_CONTROLLERS == ("P-PI", "PID")
    assert TITLES == {s: CONTROLLER_NAMES["mimo" if s == "gantry" else s] for s in TITLES}


def test_completion_scripts_show_and_complete_choices():
    env = {**os.environ, "COLUMNS": "80"}
    feedtune = [sys.executable, "-m", "feedtune"]
    done = subprocess.run([*feedtune, "--show-completion", "bash"], capture_output=True, text=True, env=env,
                          timeout=60)
    assert done.returncode == 0 and "_FEEDTUNE_COMPLETE=complete_bash" in done.stdout, done.stderr
    done = subprocess.run(feedtune, capture_output=True, text=True, timeout=60,
                          env={**env, "_FEEDTUNE_COMPLETE": "complete_bash",
                               "COMP_WORDS": "feedtune simulate frf --engine ", "COMP_CWORD": "4"})
    assert done.returncode == 0 and done.stdout.split() == ["auto", "numba", "python"], done
    done = subprocess.run(feedtune, capture_output=True, text=True, timeout=60,
                          env={**env, "_FEEDTUNE_COMPLETE": "complete_bash", "COMP_WORDS": "feedtune desi",
                               "COMP_CWORD": "1"})
    assert done.stdout.split() == ["design"], done


def test_help_imports_no_heavy_library():
    """``feedtune --help`` loads the command tree only: the numerics are imported inside the commands."""
    code = ("import sys, feedtune.cli.main; heavy = {'scipy', 'matplotlib', 'pandas', 'numba', 'cvxpy', 'h5py', "
            "'pyuff', 'filterpy', 'jsonschema'}; print(sorted(heavy & {m.split('.')[0] for m in sys.modules}))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done


def test_deprecated_spellings_still_work_and_are_hidden(tmp_path, capsys, monkeypatch):
    assert renamed_options(["design", "pid", "m.toml", "--x", "0.1", "--x-min=-0.2"]) == \
        ["design", "pid", "m.toml", "--design-x", "0.1", "--x-min=-0.2"]
    assert renamed_options(["design", "gantry", "m.toml", "--x=0.1"]) == ["design", "gantry", "m.toml",
                                                                          "--design-x=0.1"]
    assert renamed_options(["simulate", "gantry", "frf", "--keep-delay", "--", "--keep-delay"]) == \
        ["simulate", "gantry", "frf", "--keep-sampling", "--", "--keep-delay"]
    assert renamed_options(["simulate", "gantry", "track", "--x", "0.1"]) == ["simulate", "gantry", "track", "--x",
                                                                               "0.1"]
    code, _, err = run(["design", "pid", tmp_path / "missing.toml", "--x", "0.1"], capsys, monkeypatch)
    assert code != 0 and "--x is deprecated; use --design-x" in err and "No such option" not in err, err
    out = _help(["simulate", "gantry", "frf"], capsys, monkeypatch, columns=200)
    assert "--keep-sampling" in out and "--keep-delay" not in out
    out = _help(["design", "gantry"], capsys, monkeypatch, columns=200)
    assert "--design-x" in out and not re.search(r"│ --x\s", out)


def test_numbers_are_rounded_to_their_meaning():
    assert fmt(0.0019359, "V") == "0.001936 V" and fmt(65078.6) == "65080" and fmt(13.0037) == "13"
    assert fmt(159200.3) == "159200" and fmt(1.07877e7) == "1.079e+07" and fmt(2.2851e-6) == "2.285e-06"
    assert fmt(65078.64, "", 6) == "65078.6" and fmt(None) == "-" and fmt(0.0) == "0" and fmt(-0.10971) == "-0.1097"
    assert fmt_band(13.0037, 260.075) == "13.0-260.1 Hz" and fmt_band(0.5, 2000) == "0.5-2000 Hz"
    assert fmt_hz(1234.5) == "1234" and fmt_hz(96.18) == "96.2"
    assert fmt_length(9.995e-2) == "99.95 mm" and fmt_length(1.51249e-5) == "15.12 um" and fmt_length(2.0) == "2 m"
    # a bounded fit leaves a parameter on its bound up to rounding: printed as the bound
    assert fmt_param(4.513e-31, "V/(rad/s)", 6.703e-4, 0.0) == "0 V/(rad/s)  (at its lower bound; std 0.00067)"
    assert fmt_param(0.01383, "V/(rad/s)", 3.397e-4, 0.0) == "0.01383 V/(rad/s)  (std 0.00034)"
    assert fmt_param(1e-9, "V", 1e-10, 0.0) == "1e-09 V  (std 1e-10)"  # small, but resolved: not on the bound


def test_identify_summary_rounds_and_marks_bounds(examples_dir, capsys, monkeypatch):
    code, out, err = run(["identify", "ballscrew", examples_dir / "ballscrew_frf.csv"], capsys, monkeypatch)
    assert code == 0, err
    assert "band 13.0-260.1 Hz" in out
    assert re.search(r"b1 += 0 V/\(rad/s\)  \(at its lower bound; std [0-9.e-]+\)", out), out
    assert not re.search(r"= [0-9.]+e-[12][0-9]", out), out  # no 1e-31 "values" left


# ------------------------------------------------------------------------------------------ the examples run
_PREREQUISITES: dict[str, dict[str, bytes]] = {}
"""Files each prerequisite line wrote (by its text), so that a line shared by several examples runs once per
process; the command's own line always runs."""


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and "examples" not in p.relative_to(folder).parts}


def _run_line(line: str, folder: Path, capsys, monkeypatch) -> None:
    words = shlex.split(line)
    assert words[0] == "feedtune"
    code, _, err = run(words[1:], capsys, monkeypatch)
    assert code == 0, f"{line}\n{err}"


def _example(command: str, tmp_path: Path, capsys, monkeypatch) -> None:
    out = _help(command.split(), capsys, monkeypatch)
    lines = help_text.example_commands(out)
    assert lines, out
    folder = tmp_path / "scratch"
    folder.mkdir()
    (folder / "examples").symlink_to(REPO / "examples", target_is_directory=True)
    monkeypatch.chdir(folder)
    for line in lines[:-1]:
        if line not in _PREREQUISITES:
            before = _files(folder)
            _run_line(line, folder, capsys, monkeypatch)
            _PREREQUISITES[line] = {k: v for k, v in _files(folder).items() if k not in before}
        else:
            for name, data in _PREREQUISITES[line].items():
                (folder / name).parent.mkdir(parents=True, exist_ok=True)
                (folder / name).write_bytes(data)
    _run_line(lines[-1], folder, capsys, monkeypatch)


@pytest.mark.parametrize("command", sorted(set(COMMANDS) - SLOW_EXAMPLES))
def test_example_runs(command, tmp_path, capsys, monkeypatch):
    _example(command, tmp_path, capsys, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize("command", sorted(SLOW_EXAMPLES))
def test_slow_example_runs(command, tmp_path, capsys, monkeypatch):
    _example(command, tmp_path, capsys, monkeypatch)


def test_slow_examples_are_commands():
    assert SLOW_EXAMPLES <= set(COMMANDS)


def test_completion_installs_into_a_home_folder(tmp_path):
    """``feedtune --install-completion bash`` writes the script and sources it from ``~/.bashrc`` (HOME: a temporary
    folder), and a bash that sources the script registers the completion function for ``feedtune``."""
    env = {**os.environ, "HOME": str(tmp_path), "SHELL": "/bin/bash"}
    done = subprocess.run([sys.executable, "-m", "feedtune", "--install-completion", "bash"], capture_output=True,
                          text=True, env=env, timeout=60)
    assert done.returncode == 0, done.stderr
    script = tmp_path / ".bash_completions" / "feedtune.sh"
    assert script.is_file() and str(script) in (tmp_path / ".bashrc").read_text()
    registered = subprocess.run(["bash", "-c", f"source '{script}' && complete -p feedtune"], capture_output=True,
                                text=True, env=env, timeout=60)
    assert registered.returncode == 0 and "feedtune" in registered.stdout, registered.stderr
