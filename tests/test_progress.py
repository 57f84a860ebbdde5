"""Progress of long work (feedtune.progress) and how the command line shows it (feedtune.cli.progress_display)."""

from __future__ import annotations

import io

import pytest

from feedtune import progress
from feedtune.cli.progress_display import PlainReporter, RichReporter, shown


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


def test_rich_reporter_leaves_one_line_per_finished_step():
    from rich.console import Console
    from rich.progress import Progress

    out = io.StringIO()
    console = Console(file=out, force_terminal=True, width=80)
    with Progress(console=console, transient=True) as live, progress.reporting(RichReporter(live)):
        progress.step("simulating")
        progress.step("report")
    text = out.getvalue()
    assert "simulating" in text and "report" in text and "done" in text
    assert isinstance(PlainReporter(out), PlainReporter)


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
