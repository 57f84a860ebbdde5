"""Progress of long work (feedtune.progress) and how the command line shows it (feedtune.cli.progress_display)."""

from __future__ import annotations

import io

import pytest

from feedtune import progress
from feedtune.cli.progress_display import TerminalReporter, shown


class _Recorder:
    def __init__(self):
        self.events = []

    def start(self, label, total):
        self.events.append(("start", label, total))

    def advance(self, units):
        self.events.append(("advance", units))

    def finish(self, label, seconds):
        assert seconds >= 0
        self.events.append(("finish", label))


def test_silent_without_reporter():
    assert not progress.active()
    progress.step("nothing shown")
    with progress.task("loop", total=3) as advance:
        advance()


def test_steps_close_in_order_and_tasks_nest():
    rec = _Recorder()
    with progress.reporting(rec):
        progress.step("measure")
        with progress.task("figures", total=2) as advance:
            advance()
            advance()
        progress.step("design")
    assert rec.events == [
        ("start", "measure", None), ("start", "figures", 2), ("advance", 1), ("advance", 1),
        ("finish", "figures"), ("finish", "measure"), ("start", "design", None), ("finish", "design"),
    ]
    assert not progress.active()


def test_plain_lines_when_not_a_terminal():
    stream = io.StringIO()
    with shown(quiet=False, stream=stream, delay_s=0):
        progress.step("tuning MC-PPC")
        with progress.task("figures", total=12):
            pass
    assert stream.getvalue().splitlines() == ["feedtune: tuning MC-PPC ...", "feedtune: figures (12) ..."]


def test_quiet_shows_nothing():
    stream = io.StringIO()
    with shown(quiet=True, stream=stream):
        progress.step("tuning")
    assert stream.getvalue() == ""


class _Tty(io.StringIO):
    """A terminal that records what is written to it."""

    def isatty(self):
        return True


def _screen(text: str, columns: int = 100, rows: int = 30) -> list[str]:
    pyte = pytest.importorskip("pyte")
    screen = pyte.Screen(columns, rows)
    pyte.Stream(screen).feed(text.replace("\n", "\r\n"))
    lines = [x.rstrip() for x in screen.display]
    while lines and not lines[-1]:
        lines.pop()
    return lines


def test_terminal_reporter_leaves_one_line_per_finished_step_and_erases_the_live_lines():
    tty = _Tty()
    rep = TerminalReporter(tty, width=100)
    rep.begin()
    with progress.reporting(rep):
        progress.step("simulating")
        with progress.search("tuning") as meter:
            progress.figure("Ki2", "V/(rad s)")
            meter.judged(4)
            progress.judged(3.5e4)
        rep.print_above("a line printed by the command\n", tty)
        progress.step("report")
    rep.end()
    lines = _screen(tty.getvalue())
    assert lines[0].startswith("  done tuning  0.") and lines[0].endswith(
        "s  (5 candidates judged, best Ki2 35000 V/(rad s))")
    assert lines[1] == "a line printed by the command"
    assert lines[2].startswith("done simulating  0.")
    assert lines[3].startswith("done report  0.")
    assert len(lines) == 4  # the live lines are gone
    assert "\x1b[?25h" in tty.getvalue()  # the cursor is shown again


def test_meter_counts_candidates_and_keeps_the_best():
    meter = progress.Meter()
    meter.figure, meter.unit = "Ki2", "V/(rad s)"
    meter.judged(3)
    meter.passed(2.0)
    meter.passed(1.0)
    assert meter.count == 3 and meter.best == 2.0
    assert meter.text() == "3 candidates judged, best Ki2 2 V/(rad s)"
    with progress.search("outer") as outer, progress.search("inner") as inner:
        assert inner is outer  # a search run inside another (per filter candidate) counts on the outer one


def test_plain_lines_only_for_steps_still_running_after_the_delay():
    import time

    stream = io.StringIO()
    with shown(quiet=False, stream=stream, delay_s=0.2):
        progress.step("quick")
        progress.step("slow")
        time.sleep(0.5)
    assert stream.getvalue().splitlines() == ["feedtune: slow ..."]


@pytest.mark.slow
def test_a_terminal_shows_progress_during_the_demo_and_json_stays_alone_on_stdout(tmp_path):
    """``feedtune demo --json`` with stderr on a pseudo-terminal: a live display there, only JSON on stdout."""
    import json
    import os
    import pty
    import subprocess
    import sys

    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "feedtune", "demo", "--out", str(tmp_path / "d"), "--json"],
                            stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL, cwd=tmp_path)
    os.close(slave)
    seen = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the terminal closed: the process ended
            break
        if not chunk:
            break
        seen += chunk
    out, _ = proc.communicate(timeout=300)
    os.close(master)
    assert proc.returncode == 0, seen.decode(errors="replace")[-2000:]
    doc = json.loads(out)  # stdout is one JSON document and nothing else
    assert doc["kind"] == "demo.ballscrew" and isinstance(doc["warnings"], list)
    text = seen.decode(errors="replace")
    for step in ("measuring the FRF on the twin", "tuning MC-PPC and P-PI", "report: drawing"):
        assert step in text, text[-2000:]
    assert "\x1b[" in text  # a live display (cursor control), not plain lines


SPINNER = "⠋⠙⠹⠸⠼⠴⠦⠧⠇⠏"


def _clean_end(run, summary: str, written: list[str]):
    """Progress within 2 s (on a loaded machine: within 2.5 times the command line's own start, which it cannot
    beat), and a final screen that ends with the summary and the paths written, with no progress line among or
    after them."""
    from pty_screen import feedtune_command, run_on_terminal

    assert run.code == 0, "\n".join(run.lines[-30:])
    shown = run.first_seen(lambda text: any(ch in text for ch in SPINNER))
    start = run_on_terminal(feedtune_command("--version")).seconds  # the interpreter and the command line's import
    assert shown is not None and shown < max(2.0, 2.5 * start), (shown, start)
    assert run.tail(len(written)) == written, "\n".join(run.lines[-30:])
    at = max((i for i, line in enumerate(run.lines) if line.startswith(summary)), default=None)
    assert at is not None, "\n".join(run.lines[-30:])
    assert not any(ch in line for line in run.lines[at:] for ch in SPINNER + "━"), "\n".join(run.lines[-30:])
    assert not any(line.startswith("done ") for line in run.lines[at:]), "\n".join(run.lines[-30:])


@pytest.mark.slow
def test_tune_ppi_on_a_terminal_shows_progress_and_ends_clean(tmp_path, examples_dir):
    """``tune ppi`` with three FRFs on a pseudo-terminal: progress within 2 s with the search's live figures, and a
    final screen ending with the summary and the path written."""
    from pty_screen import feedtune_command, run_on_terminal

    frfs = [str(examples_dir / f"ballscrew_frf_m{m}.csv") for m in (70, 100, 130)]
    run_on_terminal(feedtune_command("identify", "ballscrew", examples_dir / "ballscrew_frf.csv", "--out",
                                     "model.toml"), cwd=tmp_path)
    run = run_on_terminal(feedtune_command("tune", "ppi", "model.toml", *[a for f in frfs for a in ("--frf", f)],
                                           "--out", "ppi.toml"), cwd=tmp_path)
    _clean_end(run, "P-PI tuned:", ["wrote ppi.toml"])
    assert run.first_seen(lambda text: "candidates judged, best Ki2" in text) is not None
    assert any(line.startswith("done tuning P-PI") for line in run.lines)


@pytest.mark.slow
def test_demo_on_a_terminal_ends_with_the_summary_and_the_report_path(tmp_path):
    from pty_screen import feedtune_command, run_on_terminal

    run = run_on_terminal(feedtune_command("demo", "--out", "d"), cwd=tmp_path)
    _clean_end(run, "MC-PPC is better in", ["wrote 24 files to d", "report: d/report.html"])


def test_report_on_a_terminal_ends_with_the_paths_written(tmp_path, examples_dir):
    from pty_screen import feedtune_command, run_on_terminal

    run = run_on_terminal(feedtune_command("report", examples_dir / "ballscrew_frf.csv", "--out", "r.html"),
                          cwd=tmp_path)
    last = run.tail(1)[0]
    assert last.startswith("wrote r.html ("), "\n".join(run.lines[-30:])
    _clean_end(run, "report with", [last])


def test_quiet_demo_help_and_every_command_has_quiet():
    import typer.main

    from feedtune.cli.main import app

    group = typer.main.get_command(app)

    def commands(cmd, path=()):
        subs = getattr(cmd, "commands", None)
        if subs:
            for name, sub in subs.items():
                yield from commands(sub, (*path, name))
        else:
            yield path, cmd

    missing = [" ".join(p) for p, cmd in commands(group) if not any("--quiet" in prm.opts for prm in cmd.params
                                                                   if hasattr(prm, "opts"))]
    assert not missing, missing
