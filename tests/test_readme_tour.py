"""The README's tour of the commands runs on the bundled example files (examples/tour.sh)."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
TOUR = REPO / "examples" / "tour.sh"


def _joined_lines(text: str) -> list[str]:
    """Lines with shell continuations (a trailing backslash) joined and runs of blanks collapsed."""
    out: list[str] = []
    pending = ""
    for line in text.splitlines():
        stripped = line.strip()
        if pending and stripped.startswith("#"):
            out.append(pending)
            pending = ""
        if stripped.endswith("\\"):
            pending += stripped[:-1] + " "
            continue
        out.append(" ".join((pending + stripped).split()))
        pending = ""
    if pending:
        out.append(" ".join(pending.split()))
    return out


def _tour_block() -> str:
    """The code block of the README section "Tour of the commands"."""
    text = README.read_text(encoding="utf-8")
    section = text.index("## Tour of the commands")
    start = text.index("```\n", section) + 4
    return text[start:text.index("```", start)]


def readme_tour_commands() -> list[str]:
    """The ``feedtune ...`` command lines of the README tour, continuations joined."""
    return [ln for ln in _joined_lines(_tour_block()) if ln.startswith("feedtune ")]


def tour_script_commands() -> list[str]:
    """The ``feedtune ...`` command lines of examples/tour.sh, continuations joined."""
    return [ln for ln in _joined_lines(TOUR.read_text(encoding="utf-8")) if ln.startswith("feedtune ")]


def tour_outputs() -> list[str]:
    """Every ``--out`` of the README tour, and the FRF that ``simulate frf`` writes beside its log."""
    outs = []
    for cmd in readme_tour_commands():
        words = shlex.split(cmd)
        outs += [words[i + 1] for i, w in enumerate(words[:-1]) if w in ("--out", "-o")]
        if words[1:3] == ["simulate", "frf"]:
            log = words[words.index("--out") + 1]
            outs.append(log[: -len(".csv")] + "_frf.csv")
    return outs


def test_readme_tour_parses_into_commands_with_outputs():
    cmds = readme_tour_commands()
    assert len(cmds) >= 20
    assert not [c for c in cmds if "|" in c or "..." in c or " LOG" in c], "tour lines must be runnable commands"
    for words in ("identify ballscrew", "identify rigid", "identify friction", "identify gantry", "design ppc",
                  "design ppi", "design gantry", "design pid", "design loopshape", "tune", "analyze", "export c",
                  "trajectory", "simulate", "frf", "prefilter", "report", "demo"):
        assert any(c.startswith(f"feedtune {words} ") for c in cmds), words
    assert {"model.toml", "mcppc.toml", "report.html", "demo_out"} <= set(tour_outputs())


def test_every_readme_example_path_exists():
    text = README.read_text(encoding="utf-8")
    paths = {m.rstrip(".,;:") for m in re.findall(r"examples/[\w.\-/]*", text)}
    assert "examples/tour.sh" in paths
    missing = sorted(p for p in paths if not (REPO / p).exists())
    assert not missing, f"README names example files that are not in the repository: {missing}"


def test_every_readme_tour_command_is_in_tour_sh():
    script = set(tour_script_commands())
    missing = [c for c in readme_tour_commands() if c not in script]
    assert not missing, f"README tour commands not run verbatim by examples/tour.sh: {missing}"


def test_tour_sh_runs_only_readme_commands():
    readme = set(readme_tour_commands())
    extra = [c for c in tour_script_commands() if c not in readme]
    assert not extra, f"examples/tour.sh runs commands that the README tour does not show: {extra}"


@pytest.mark.slow
def test_readme_tour_runs(tmp_path):
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    if shutil.which("feedtune", path=env["PATH"]) is None:
        pytest.skip("the feedtune command is not installed (pip install .)")
    out = tmp_path / "tour"
    res = subprocess.run(["bash", str(TOUR), str(out)], capture_output=True, text=True, env=env, timeout=900)
    assert res.returncode == 0, f"tour.sh exited {res.returncode}:\n{res.stdout[-3000:]}\n{res.stderr[-3000:]}"
    missing = [name for name in tour_outputs() if not (out / name).exists()]
    assert not missing, f"tour outputs missing: {missing}"
    for name in ("mcppc.h", "report.html", "demo_out/report.html", "friction.toml", "mcppc_pf.toml"):
        assert (out / name).stat().st_size > 0, name
    assert "#include" in (out / "mcppc.h").read_text(encoding="utf-8")


@pytest.mark.slow  # a fit, a design, four analysis cases and the report's figures
def test_readme_library_example_passes_the_default_limits_and_prints_its_verdict(monkeypatch, capsys):
    """The README's library example runs as printed from the repository root; its design passes the default limits
    (its comment says so), and the Ms it prints is the one its comment states."""
    pytest.importorskip("control")
    import matplotlib

    matplotlib.use("Agg")
    text = README.read_text(encoding="utf-8")
    start = text.index("```python\n", text.index("## Library")) + len("```python\n")
    code = text[start:text.index("```", start)]
    monkeypatch.chdir(REPO)
    scope: dict = {}
    exec(compile(code, "README.md (Library)", "exec"), scope)
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == "True []"
    assert f"{float(printed[1]):.3f}" in code  # the Ms the comment states
    assert 1.0 < float(printed[1]) <= 2.5  # within the default limit it claims to pass
