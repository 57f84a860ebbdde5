"""Every numeric option of every command given nonsense values (nan, -1, 1e400, 0, inf), by hand:
``python benchmarks/fuzz_options.py [COMMAND PREFIX]``.

Each command runs in-process on files this script makes first (twin runs, models and gains files of both machines),
with one numeric option replaced; the run must end with feedtune's own error, a usage error, or success — never
another exception (an internal error). Runs longer than 15 s are counted as slow and stopped. Prints the crashes,
the slow runs and the totals; exits 1 on a crash.
"""

from __future__ import annotations

import os
import signal
import sys
import tempfile
from pathlib import Path

from typer.main import get_command
from typer.testing import CliRunner

from feedtune.cli.main import app
from feedtune.errors import FeedtuneError

BASE = {
    "identify ballscrew": ["bs_frf.csv"],
    "identify rigid": ["track.csv", "--position", "x2", "--input", "u"],
    "identify friction": ["track.csv", "--position", "x2", "--input", "u", "--model", "bs_model.toml"],
    "identify gantry": ["g_frf.csv", "--x", "0", "--span", "1.484"],
    "identify mass": None,
    "frf": ["frfrun.csv", "--input", "u", "--output", "x1,x2"],
    "design ppc": ["bs_model.toml", "--beta", "4", "--pole-hz", "50", "--zeta", "0.7"],
    "design ppi": ["bs_model.toml", "--kpx", "30", "--kpv", "2", "--kiv", "1000"],
    "design loopshape": ["g_model.toml", "--crossover-hz", "100", "--pm-deg", "35"],
    "design gantry": ["g_model.toml"],
    "design pid": ["g_model.toml", "--kp", "1000", "--kd", "10", "--ki", "100"],
    "tune": ["ppi", "bs_model.toml", "--frf", "bs_frf.csv"],
    "prefilter": ["track.csv", "--gains", "bs_gains.toml"],
    "report": ["bs_gains.toml", "bs_frf.csv", "-o", "r.html"],
    "trajectory": ["--distance", "0.1", "--v-max", "0.2", "--a-max", "5", "--j-max", "500", "-o", "traj.csv"],
    "demo": None,
    "analyze gains": ["bs_gains.toml", "--frf", "bs_frf.csv"],
    "analyze track": ["track.csv"],
    "analyze ropesnap": ["rs.csv"],
    "export c": ["bs_gains.toml", "-o", "g.h"],
    "simulate frf": ["-o", "s.csv"],
    "simulate track": ["-g", "bs_gains.toml", "--distance", "0.05", "-o", "s.csv"],
    "simulate ropesnap": ["-g", "bs_gains.toml", "-o", "s.csv"],
    "simulate cut": ["-g", "bs_gains.toml", "-o", "s.csv"],
    "simulate gantry frf": ["-o", "s.csv", "--period", "0.1", "--periods", "2"],
    "simulate gantry axis-frf": ["-o", "s.csv", "--period", "0.1", "--periods", "2"],
    "simulate gantry mass": ["-o", "s.csv"],
    "simulate gantry ropesnap": ["-g", "g_gains.toml", "-o", "s.csv"],
    "simulate gantry track": ["-g", "g_gains.toml", "-o", "s.csv"],
    "simulate gantry contour": ["-g", "g_gains.toml", "--axis-gains", "a_gains.toml", "-o", "s.csv"],
}
"""The arguments each command runs with (None: not run here: it needs several positions, or is slow)."""

VALUES = ["nan", "-1", "1e400", "0", "inf"]


class SlowRunError(Exception):
    """A run that took longer than the alarm."""


def _alarm(*_):
    raise SlowRunError()


def leaves(c, path):
    subs = getattr(c, "commands", None)
    if subs:
        for n, s in subs.items():
            yield from leaves(s, [*path, n])
    else:
        yield " ".join(path), c


def make_files(runner: CliRunner) -> None:
    """The inputs BASE names, in the current folder."""
    from feedtune.design.gantry_mimo import design_gantry_mimo
    from feedtune.design.loopshape import design_loopshape
    from feedtune.design.mcppc import design_mcppc
    from feedtune.io import save_model, write_document
    from feedtune.io.gains import gains_document
    from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
    from feedtune.models import THESIS_TABLE_3_1
    from feedtune.models.gantry import THESIS_GANTRY

    save_model("bs_model.toml", THESIS_TABLE_3_1)
    save_model("g_model.toml", THESIS_GANTRY)
    write_document("bs_gains.toml", gains_document(design_mcppc(THESIS_TABLE_3_1)))
    write_document("g_gains.toml", gantry_gains_document(design_gantry_mimo(THESIS_GANTRY)))
    write_document("a_gains.toml", axis_gains_document(design_loopshape(0.6977, crossover_hz=100, pm_deg=35)))
    for args in (["simulate", "frf", "-o", "frfrun.csv", "--frf-out", "bs_frf.csv"],
                 ["simulate", "track", "-g", "bs_gains.toml", "--distance", "0.05", "-o", "track.csv"],
                 ["simulate", "ropesnap", "-g", "bs_gains.toml", "-o", "rs.csv"],
                 ["simulate", "gantry", "frf", "-o", "g.csv", "--frf-out", "g_frf.csv", "--period", "0.2"]):
        r = runner.invoke(app, args)
        assert r.exit_code == 0, (args, r.output, r.exception)


def main(only: str | None = None) -> int:
    runner = CliRunner()
    signal.signal(signal.SIGALRM, _alarm)
    crashes, slow, runs = [], [], 0
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        make_files(runner)
        for name, c in leaves(get_command(app), []):
            base = BASE.get(name)
            if base is None or (only and not name.startswith(only)):
                continue
            force = ["--force"] if any("--force" in q.opts for q in c.params) else []
            opts = [p for p in c.params
                    if p.param_type_name == "option" and p.type_descriptor.annotation in (float, int)]
            for p in opts:
                for v in VALUES:
                    runs += 1
                    signal.alarm(15)
                    try:
                        r = runner.invoke(app, [*name.split(), *base, p.opts[0], v, *force])
                        exc = r.exception
                        if isinstance(exc, SlowRunError):
                            slow.append((name, p.opts[0], v))
                        elif exc is not None and not isinstance(exc, (FeedtuneError, SystemExit)):
                            crashes.append((name, p.opts[0], v, f"{type(exc).__name__}: {str(exc)[:100]}"))
                    except SlowRunError:
                        slow.append((name, p.opts[0], v))
                    finally:
                        signal.alarm(0)
        os.chdir(Path.home())
    for c in crashes:
        print("CRASH", *c)
    print(f"{runs} runs, {len(crashes)} crashes, {len(slow)} slow (stopped after 15 s): {slow[:10]}")
    return 1 if crashes else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else None))
