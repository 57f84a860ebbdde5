"""CLI conventions: ``--version`` and ``python -m feedtune``."""

from __future__ import annotations

import subprocess
import sys

from feedtune import __version__


def test_version_and_python_dash_m():
    for module in ("feedtune", "feedtune.cli.main"):
        res = subprocess.run([sys.executable, "-m", module, "--version"], capture_output=True, text=True, check=False)
        assert res.returncode == 0 and res.stdout.strip() == f"feedtune {__version__}", res
    res = subprocess.run([sys.executable, "-m", "feedtune", "nope"], capture_output=True, text=True, check=False)
    assert res.returncode == 2 and "nope" in res.stderr
