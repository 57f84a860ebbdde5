"""Shapers and laws carried to their targets (issue 28, items 2 and 4), held to references outside the code under test.

* the C header of a gains file with a ``[shaper]`` against the Python runtime, compiled and fed the same samples;
* the LinuxCNC component compiled against a stub of the HAL API (``tests/hal_stub.py``, no LinuxCNC needed): its
  update equals the header's ``ft_step`` sample by sample (bit for bit: the same C, compiled by the same compiler),
  its outputs stay 0 while disabled and when the thread's period is not ``1 / fs``;
* Klipper's ``[input_shaper]`` written from the real Voron resonance file: the frequency Klipper itself wrote into
  the file, read back exactly; Marlin's ``M593`` for a ZV, and the refusal of what Marlin cannot be told.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from c_compile import DRIVERS, compiler, run_header
from cli_run import run
from hal_stub import write_stub

from feedtune.control.shapers import InputShaper
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.ppi import design_ppi
from feedtune.errors import UsageError
from feedtune.export.c_header import c_header
from feedtune.export.linuxcnc import hal_component
from feedtune.export.printer import klipper_section, marlin_gcode, read_klipper_section
from feedtune.io.gains import gains_document
from feedtune.io.gantry_gains import gantry_gains_document
from feedtune.io.shaper_file import with_shaper
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.machines.gantry.runtime import GantryRuntime
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.gantry import THESIS_GANTRY

KLIPPER = "klipper_voron24_resonances"
CALIBRATION = "calibration_data_x_20230306_225431.csv"

BALLSCREW_MAIN, GANTRY_MAIN = DRIVERS["ballscrew"], DRIVERS["gantry"]


def _cc() -> str:
    cc = compiler()
    if cc is None:
        pytest.skip("no C compiler")
    return cc


def ppi_with_shaper() -> dict:
    doc = gains_document(design_ppi(THESIS_TABLE_3_1, Kpx=53.2, Kpv=2.33, Kiv=657.0))
    return with_shaper(doc, InputShaper.design("ei", 122.45, 0.056))


def gantry_with_shaper() -> dict:
    doc = gantry_gains_document(design_gantry_mimo(THESIS_GANTRY, crossover_hz=60, pm_deg=40))
    return with_shaper(doc, InputShaper.design("zvd", 71.3, 0.05))


def _signals(n: int, fs: float, seed: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A reference with both signs of velocity and two noisy encoders near it [m]."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    r = 1e-3 * (1 - np.cos(2 * np.pi * 7 * t)) + 2e-4 * np.sign(np.sin(2 * np.pi * 23 * t))
    return r, r + 1e-6 * rng.standard_normal(n), r + 1e-6 * rng.standard_normal(n)


def _run(exe: Path, rows: np.ndarray, args: list[str] = ()) -> str:
    text = "\n".join(" ".join(f"{v:.17g}" for v in row) for row in rows)
    return subprocess.run([str(exe), *args], input=text, capture_output=True, text=True, check=True).stdout


# ------------------------------------------------------------------------------------------ C header vs runtime
def test_the_ball_screw_header_with_a_shaper_runs_the_runtimes_law(tmp_path):
    doc = ppi_with_shaper()
    r, x1, x2 = _signals(3000, 20000.0)
    u_c = run_header(_cc(), tmp_path, c_header(doc), BALLSCREW_MAIN, np.column_stack([r, x1, x2]))[:, 0]
    rt = GainsRuntime.from_document(doc)
    u_py = np.array([rt.step(a, b, c) for a, b, c in zip(r, x1, x2, strict=True)])
    np.testing.assert_allclose(u_c, u_py, rtol=0, atol=1e-12 * np.abs(u_py).max())
    plain = GainsRuntime.from_document({k: v for k, v in doc.items() if k != "shaper"})
    u_plain = np.array([plain.step(a, b, c) for a, b, c in zip(r, x1, x2, strict=True)])
    assert np.abs(u_plain - u_py).max() > 0.01 * np.abs(u_py).max()  # the shaper acts


def test_the_gantry_header_with_a_shaper_runs_the_runtimes_law(tmp_path):
    doc = gantry_with_shaper()
    y, y1, y2 = _signals(2000, 15000.0, seed=6)
    x = np.linspace(-0.3, 0.3, y.size)
    u_c = run_header(_cc(), tmp_path, c_header(doc), GANTRY_MAIN, np.column_stack([y, y1, y2, x]))
    rt = GantryRuntime.from_document(doc)
    u_py = np.array([rt.step(*row) for row in zip(y, y1, y2, x, strict=True)])
    np.testing.assert_allclose(u_c, u_py, rtol=0, atol=1e-12 * np.abs(u_py).max())


# ------------------------------------------------------------------------------------------ LinuxCNC component
def _component(cc: str, folder: Path, doc: dict) -> Path:
    folder.mkdir(exist_ok=True)
    write_stub(folder)
    (folder / "ft_test.c").write_text(hal_component(doc, name="ft_test"))
    exe = folder / "component"
    # the component and the stub's driver as one program; the component's own warnings are errors too
    cmd = [cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O1", "-I", str(folder), "-o", str(exe),
           str(folder / "ft_test.c"), str(folder / "hal_stub.c"), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


def _relative(rows: np.ndarray, relative: list[bool]) -> np.ndarray:
    """The inputs as the component gives them to ``ft_step``: positions relative to the reference at enable."""
    out = rows.copy()
    for j, rel in enumerate(relative):
        if rel:
            out[:, j] = rows[:, j] - rows[0, 0]
    return out


@pytest.mark.parametrize("kind", ["ballscrew", "gantry"])
def test_the_linuxcnc_component_steps_as_ft_step_sample_by_sample(tmp_path, kind):
    cc = _cc()
    fs = {"ballscrew": 20000.0, "gantry": 15000.0}[kind]
    if kind == "ballscrew":
        doc, main = ppi_with_shaper(), BALLSCREW_MAIN
        r, a, b = _signals(3000, fs)
        r = r + 0.0123  # an origin far from 0: the component starts the law from it
        rows = np.column_stack([r, a + 0.0123, b + 0.0123])
        ins, outs, relative = ["x-ref-preview", "x1", "x2"], ["u"], [True, True, True]
    else:
        doc, main = gantry_with_shaper(), GANTRY_MAIN
        r, a, b = _signals(2000, fs, seed=8)
        rows = np.column_stack([r + 0.05, a + 0.05, b + 0.05, np.linspace(0.3, -0.3, r.size)])
        ins, outs, relative = ["y-ref-preview", "y1", "y2", "x"], ["u1", "u2"], [True, True, True, False]
    assert doc["sampling"]["fs_hz"]["value"] == fs
    exe = _component(cc, tmp_path / "hal", doc)
    period = str(round(1e9 / fs))
    args = [period, *(f"ft_test.0.{p}" for p in ins), "--", *(f"ft_test.0.{p}" for p in outs)]
    enabled = np.column_stack([np.ones(len(rows)), rows])
    lines = _run(exe, enabled, args).splitlines()
    assert lines[0] == "function ft_test.0.update"
    got = np.array([line.split() for line in lines[1:]], float)
    assert np.all(got[:, -1] == 0)  # no rate fault at the design's period
    want = run_header(cc, tmp_path / "direct", c_header(doc), main, _relative(rows, relative))
    assert np.array_equal(got[:, :-1], want)  # bit for bit
    assert np.abs(want).max() > 0.1  # volts: the law acts

    # disabled: outputs 0; a thread at another period: outputs 0 and the fault raised
    off = _run(exe, np.column_stack([np.zeros(5), rows[:5]]), args).splitlines()[1:]
    assert all(float(v) == 0.0 for line in off for v in line.split())
    slow = _run(exe, enabled[:5], [str(round(1e9 / fs * 1.01)), *args[1:]]).splitlines()[1:]
    assert all(line.split()[-1] == "1" and all(float(v) == 0.0 for v in line.split()[:-1]) for line in slow)


def test_a_bad_component_name_is_refused():
    with pytest.raises(UsageError, match="component name"):
        hal_component(ppi_with_shaper(), name="Bad-Name")


# ------------------------------------------------------------------------------------------ printers
def test_klipper_section_from_the_real_file_gives_klippers_own_frequency(tmp_path, real_data_dir, capsys,
                                                                         monkeypatch):
    from feedtune.io.psd_csv import read_psd_csv, shaper_column

    calibration = real_data_dir / KLIPPER / CALIBRATION
    monkeypatch.chdir(tmp_path)
    code, _, err = run(["design", "shaper", "--psd", calibration, "--out", "x.toml"], capsys, monkeypatch)
    assert code == 0, err
    code, _, err = run(["export", "klipper", "x.toml", "--out", "printer.cfg"], capsys, monkeypatch)
    assert code == 0, err
    section = read_klipper_section((tmp_path / "printer.cfg").read_text())
    klippers = dict(shaper_column(c) for c in read_psd_csv(calibration).shaper_columns)
    assert section["x"]["type"] == "zv"  # Klipper recommended ZV for this printer
    assert abs(section["x"]["freq_hz"] / klippers["zv"] - 1) < 0.05
    assert section["x"]["freq_hz"] == pytest.approx(klippers["zv"], abs=0.05)  # the 0.2 Hz grid: exactly


def test_klipper_and_marlin_text_round_trip_and_refusals():
    zv, ei = InputShaper.design("zv", 52.6, 0.1), InputShaper.design("ei", 64.8, 0.1)
    back = read_klipper_section(klipper_section([(zv, "x"), (ei, "y")]))
    assert back == {"x": {"type": "zv", "freq_hz": 52.6, "damping": 0.1},
                    "y": {"type": "ei", "freq_hz": 64.8, "damping": 0.1}}
    assert "M593 X F52.6 D0.1" in marlin_gcode([(zv, "x")])
    with pytest.raises(UsageError, match="Marlin cannot be told a ei"):
        marlin_gcode([(ei, "x")])
    with pytest.raises(UsageError, match="one shaper per axis"):
        klipper_section([(zv, "x"), (ei, "x")])
