"""Bad input and interruption (issue 14): each case ended as "internal error", a wrong exit code, silent data loss or
a silent exit before; now one line naming the file or option with the exit code of docs/conventions.md."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import pytest
from test_cli import run

from feedtune.io import read_frf, write_frf
from feedtune.io.atomic import TEMP_MARK, sweep_stale_temps
from feedtune.workflows.files import write_texts


@pytest.fixture(scope="module")
def example_text(examples_dir):
    return (examples_dir / "ballscrew_frf.csv").read_text()


def test_cr_only_line_endings_read_like_newlines(example_text, tmp_path, examples_dir):
    (tmp_path / "cr.csv").write_bytes(example_text.replace("\n", "\r").encode())
    a, b = read_frf(tmp_path / "cr.csv"), read_frf(examples_dir / "ballscrew_frf.csv")
    assert (a.response == b.response).all() and (a.freq_hz == b.freq_hz).all()


def test_a_huge_header_cell_is_named(example_text, tmp_path, capsys, monkeypatch):
    lines = example_text.splitlines()
    k = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    lines[k] += "," + "x" * 5_000_000
    (tmp_path / "big.csv").write_text("\n".join(lines) + "\n")
    code, _, err = run(["identify", "ballscrew", tmp_path / "big.csv"], capsys, monkeypatch)
    assert code == 1 and f"line {k + 1} is 5,0" in err and "characters long" in err and err.count("\n") == 1


def test_an_frf_scaled_by_1e_300_is_named_not_an_internal_error(examples_dir, tmp_path, capsys, monkeypatch):
    f = read_frf(examples_dir / "ballscrew_frf.csv")
    write_frf(replace(f, response=f.response * 1e-300), tmp_path / "tiny.csv")
    code, _, err = run(["identify", "ballscrew", tmp_path / "tiny.csv"], capsys, monkeypatch)
    assert code == 1 and "tiny.csv: channel" in err and "far outside a physical FRF" in err


@pytest.mark.parametrize("args, words", [
    (["simulate", "frf", "-o", "s.csv", "--seed", "-1"], "--seed"),
    (["simulate", "frf", "-o", "s.csv", "--period", "1e-9"], "excitation period --period 1e-09 s holds"),
    (["simulate", "gantry", "frf", "-o", "g.csv", "--period", "1e-7"], "excitation period --period 1e-07 s holds"),
    (["simulate", "frf", "-o", "f.csv", "--frf-out", "f.csv"], "--frf-out f.csv is also the file of --out"),
    (["simulate", "gantry", "frf", "-o", "g.csv", "--frf-out", "g.csv"], "is also the file of --out"),
])
def test_bad_options_are_usage_errors_before_any_work(args, words, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 2 and words in err
    assert not list(tmp_path.iterdir())


def test_a_model_of_the_wrong_kind_is_a_data_error_in_every_command(tmp_path, capsys, monkeypatch):
    from feedtune.io import save_model
    from feedtune.models import THESIS_TABLE_3_1
    from feedtune.models.gantry import THESIS_GANTRY

    save_model(tmp_path / "g.toml", THESIS_GANTRY)
    save_model(tmp_path / "b.toml", THESIS_TABLE_3_1)
    for args, needed in ((["design", "ppc", tmp_path / "g.toml"], "a ball-screw model is needed"),
                         (["tune", "mcppc", tmp_path / "g.toml"], "a ball-screw model is needed"),
                         (["design", "gantry", tmp_path / "b.toml"], "a gantry model is needed"),
                         (["tune", "gantry", tmp_path / "b.toml"], "a gantry model is needed")):
        code, _, err = run(args, capsys, monkeypatch)
        assert code == 1 and needed in err and err.count("\n") == 1, (args, err)


def test_an_unknown_quantity_is_a_usage_error(examples_dir, capsys, monkeypatch):
    code, _, err = run(["identify", "ballscrew", examples_dir / "ballscrew_frf.csv", "--quantity", "jerk"], capsys,
                       monkeypatch)
    assert code == 2 and "--quantity" in err and "jerk" in err


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_temporary_files_of_a_killed_process_are_swept_by_the_next_write(tmp_path):
    stale = tmp_path / f".a.csv{TEMP_MARK}{_dead_pid()}-abc.tmp.csv"
    live = tmp_path / f".b.csv{TEMP_MARK}{os.getppid()}-abc.tmp.csv"  # a running process: not ours to remove
    stale.write_text("half")
    live.write_text("half")
    write_texts({str(tmp_path / "c.csv"): "x\n"})
    assert not stale.exists() and live.exists() and (tmp_path / "c.csv").read_text() == "x\n"
    assert sweep_stale_temps(tmp_path) == []  # once per folder and process


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_a_signal_stops_the_demo_with_a_message_and_leaves_no_temporary_file(sig, code, word, tmp_path):
    """Before: SIGINT exited 130 without a word (typer swallowed it), SIGTERM left temporary files, and a kill in
    the last seconds left data without report.html."""
    out = tmp_path / "demo"
    p = subprocess.Popen([sys.executable, "-c", "from feedtune.cli.main import main; main()", "demo", "--out",
                          str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)  # imports done, the twin running (the demo takes several seconds more)
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code and err.strip().splitlines()[-1] == f"feedtune: {word}", err
    leftovers = [q for q in tmp_path.rglob("*") if TEMP_MARK in q.name]
    assert leftovers == []
    assert not out.exists()  # the demo folder appears whole (report included) or not at all


def test_numba_caches_go_to_a_user_cache_folder():
    import numba  # noqa: F401 (the cache folder is chosen when numba is first imported)

    import feedtune

    cache = os.environ["NUMBA_CACHE_DIR"]
    assert not os.path.abspath(cache).startswith(os.path.dirname(os.path.abspath(feedtune.__file__)))


def test_a_uff_file_cut_inside_a_record_or_a_short_data_block_is_refused(examples_dir, tmp_path):
    from feedtune.errors import DataError

    write_frf(read_frf(examples_dir / "ballscrew_frf.csv"), tmp_path / "ex.uff")
    lines = (tmp_path / "ex.uff").read_text().splitlines(keepends=True)
    marks = [i for i, line in enumerate(lines) if line.strip() == "-1"]
    (tmp_path / "cut.uff").write_text("".join(lines[:(marks[2] + marks[3]) // 2]))  # inside the second record
    with pytest.raises(DataError, match="ends inside a UFF record"):
        read_frf(tmp_path / "cut.uff")
    (tmp_path / "short.uff").write_text("".join(lines[:marks[1] - 1400] + lines[marks[1]:]))  # 100 of 1500 points
    with pytest.raises(DataError, match="holds 100 of its 1500 points"):
        read_frf(tmp_path / "short.uff")


def test_a_matlab_v73_char_variable_holding_non_characters_is_named(tmp_path):
    h5py = pytest.importorskip("h5py")
    import numpy as np

    from feedtune.errors import DataError

    path = tmp_path / "bad73.mat"
    with h5py.File(path, "w", userblock_size=512) as f:
        f.create_dataset("quantity", data=np.array([[70_000_000], [5]], dtype=np.uint32)).attrs["MATLAB_class"] = \
            np.bytes_("char")
        f.create_dataset("freq_hz", data=np.arange(1, 11, dtype=float)[None, :]).attrs["MATLAB_class"] = \
            np.bytes_("double")
    with open(path, "r+b") as fh:  # the MATLAB v7.3 header in the user block
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116, b" ") + b"\0" * 8
                 + b"\x00\x02IM")
    with pytest.raises(DataError, match="variable 'quantity' cannot be decoded"):
        read_frf(path)


def test_main_in_process_leaves_the_callers_signal_handlers_as_they_were(capsys, monkeypatch):
    """The CLI turns SIGINT/SIGTERM into a clean exit while it runs; called in-process (tests, notebooks) it must not
    leave its handlers behind (a pytest worker would then survive SIGTERM)."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    code, _, _ = run(["--help"], capsys, monkeypatch)
    assert code == 0
    assert {s: signal.getsignal(s) for s in before} == before


def test_the_kernel_cache_folder_follows_every_source_file(tmp_path):
    """numba keys a cached kernel on its own file; the twins inline laws from other files: the folder must change
    when any source does (a stale loop would run the old law)."""
    import feedtune

    pkg = tmp_path / "pkg"
    (pkg / "machines").mkdir(parents=True)
    (pkg / "machines" / "law.py").write_text("K = 1\n")
    (pkg / "twin.py").write_text("from .machines.law import K\n")
    before = feedtune.kernel_cache_dir(str(pkg))
    assert feedtune.kernel_cache_dir(str(pkg)) == before
    (pkg / "machines" / "law.py").write_text("K = 2\n")
    assert feedtune.kernel_cache_dir(str(pkg)) != before
    assert not before.startswith(str(pkg))
