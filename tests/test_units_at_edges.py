"""Units at the edges of the toolkit: a header whose output is in the drive's unit (``export c --scale-out``), and a
rotary axis' tracking log in rad (``analyze track``).

References: the header without the scale, compiled and run on the same inputs (the scaled header must return FACTOR
times its command, clamped at the limit in the drive's unit, with the anti-windup following FACTOR's sign), and
the closed form of a sinusoidal error (max A, RMS A / sqrt 2).
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from cli_run import run
from test_export_c_kinds import BALLSCREW_MAIN, _run_c

from feedtune.control.filters import FilterPack, Notch
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import UsageError
from feedtune.export.c_header import c_header
from feedtune.io import write_log_csv
from feedtune.io.gains import gains_document
from feedtune.log import Log
from feedtune.models import THESIS_TABLE_3_1

GCC = shutil.which("gcc")
BALLSCREW = gains_document(design_mcppc(THESIS_TABLE_3_1, filters=FilterPack([Notch(420.0, 0.55, 0.7)], 2000.0)))


def _run(tmp_path, header: str, inputs: np.ndarray) -> np.ndarray:
    return _run_c(tmp_path, header, BALLSCREW_MAIN, inputs)[:, 0]


@pytest.mark.skipif(GCC is None, reason="gcc not installed")
@pytest.mark.parametrize("factor", [1 / 35.15065, -0.5])
def test_the_scaled_header_returns_factor_times_the_command_with_the_limit_in_the_drives_unit(tmp_path, factor):
    """A ramp that saturates the output, then a reversal: the scaled header with limit U equals FACTOR times the
    unscaled header with limit U / |FACTOR| (the clamp and the conditional integration commute with the scale,
    including its sign), sample by sample."""
    n = 3000
    r = np.r_[np.linspace(0.0, 2.0, n // 2), np.linspace(2.0, 1.9, n - n // 2)]
    inputs = np.column_stack([r, 0.9 * r, 0.8 * r])
    u_max = 2.0
    plain = _run(tmp_path, c_header(BALLSCREW, u_max=u_max / abs(factor), anti_windup="clamp"), inputs)
    scaled = _run(tmp_path, c_header(BALLSCREW, u_max=u_max, anti_windup="clamp", scale_out=factor,
                                     out_unit="V"), inputs)
    assert np.max(np.abs(plain)) == pytest.approx(u_max / abs(factor))  # it saturated
    assert np.max(np.abs(scaled - factor * plain)) <= 1e-12 * u_max
    header = c_header(BALLSCREW, u_max=u_max, scale_out=factor, out_unit="V")
    assert "#define FT_SCALE_OUT" in header and "V per V" in header and "/* V: every command is clamped" in header


def test_scale_options_are_checked(tmp_path, capsys, monkeypatch):
    with pytest.raises(UsageError, match="scale_out"):
        c_header(BALLSCREW, scale_out=0.0)
    with pytest.raises(UsageError, match="out_unit"):
        c_header(BALLSCREW, out_unit="V")
    from feedtune.io import write_document

    gains = tmp_path / "g.toml"
    write_document(gains, BALLSCREW)
    code, _, err = run(["export", "c", gains, "--scale-out", "1/0", "--out", tmp_path / "g.h"], capsys, monkeypatch)
    assert code == 2 and "--scale-out expects a number or a ratio" in err and not (tmp_path / "g.h").exists()
    code, out, err = run(["export", "c", gains, "--scale-out", "1/35.15065", "--out-unit", "V", "--json", "--out",
                          tmp_path / "g.h"], capsys, monkeypatch)
    assert code == 0, err
    assert json.loads(out)["scale_out"] == pytest.approx(1 / 35.15065)


def test_analyze_track_reads_a_rotary_axis_in_rad(tmp_path, capsys, monkeypatch):
    t = np.arange(0.0, 1.0, 1e-3)
    amplitude = 20e-6
    error = amplitude * np.sin(2 * np.pi * 40.0 * t)
    reference = 0.5 * np.sin(2 * np.pi * t)
    path = tmp_path / "rotary.csv"
    write_log_csv(Log(t, {"x_ref": reference, "x": reference - error, "err": error},
                      {"x_ref": "rad", "x": "rad", "err": ""}), path)
    code, out, err = run(["analyze", "track", path, "--position", "x", "--json"], capsys, monkeypatch)
    assert code == 0, err
    doc = json.loads(out)
    overall = doc["metrics"]["overall"]
    assert overall["max_m"] == pytest.approx(np.max(np.abs(error)), rel=1e-9)  # the sampled crest, 0.2 % below A
    assert overall["rms_m"] == pytest.approx(amplitude / np.sqrt(2), rel=1e-9)  # 40 whole periods
    assert doc["units"]["max_m"] == "rad" and doc["units"]["duration_s"] == "s"
    code, out, err = run(["analyze", "track", path, "--error", "err", "--unit", "err=rad"], capsys, monkeypatch)
    assert code == 0 and "max 19.96 urad, RMS 14.14 urad" in out, err
    code, out, err = run(["analyze", "track", path, "--error", "err", "--unit", "err=urad", "--scale", "err=1e6"],
                         capsys, monkeypatch)
    assert "RMS 14.14 urad" in out, err
    code, _, err = run(["analyze", "track", path, "--error", "err", "--unit", "err=deg"], capsys, monkeypatch)
    assert code == 1 and "expected m or rad" in err
