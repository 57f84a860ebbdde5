"""Run the ``feedtune`` command line in-process from a test, as the console script does."""

from __future__ import annotations

import sys

from feedtune.cli.main import main


def run(args, capsys, monkeypatch) -> tuple[int, str, str]:
    """``feedtune ARGS`` through :func:`feedtune.cli.main.main`; return (exit code, stdout, stderr)."""
    monkeypatch.setattr(sys, "argv", ["feedtune", *map(str, args)])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    out, err = capsys.readouterr()
    return code, out, err
