"""Regenerate the bundled example files (run from the repository root: python examples/make_examples.py).

Every file is deterministic (fixed seeds) and small; together they let every command of the README tour
(``bash examples/tour.sh DIR``) run without a shared folder.

FRFs built from the thesis' Table 3.1 2-mass model with what real drives add and the 2-mass model lacks:
torsional modes at 440 and 1100 Hz (zero/pole pairs), a 450 Hz first-order current loop, and 2 % complex
measurement noise, with a coherence column; motor command ``u`` [V] to the rotary ``x1`` and linear ``x2``
encoders [rad]:

* ``ballscrew_frf.csv`` / ``.mat`` / ``.uff`` -- 1-2000 Hz, 1500 lines, noise seed 7.
* ``ballscrew_frf_m70.csv``, ``ballscrew_frf_m100.csv``, ``ballscrew_frf_m130.csv`` -- a machine family
  (or one drive under three table loads) for ``feedtune tune``: the same with the table mass ``m2`` at 0.7,
  1.0 and 1.3 times its Table 3.1 value, 800 lines, noise seeds 70, 100, 130, 8 significant digits.

Logs of the ball-screw digital twin (``feedtune simulate``, docs/twin.md) under the MC-PPC gains that the
README tour designs (``feedtune design ppc`` on ``ballscrew_frf.csv``, written as ``mcppc.toml``), each signal
rounded far below the encoder resolution (10 nm) and the noise:

* ``ballscrew_reversals.csv`` -- back and forth at 2, 50 and 200 mm/s, slowly through the low speeds first
  (seed 11), every 40th sample (500 Hz): ``x_ref``, ``x2``, ``u``, ``e2``, for ``feedtune identify rigid``
  and ``identify friction``.
* ``ballscrew_track.csv`` -- a 20 mm move at 200 mm/s (seed 1) at the gains' 20 kHz, for
  ``feedtune prefilter`` (which needs the target's rate) and ``analyze track``.
* ``ballscrew_ropesnap.csv`` -- a 0.5 V rope snap (seed 1), 0.1 s before to 0.4 s after the release, every
  4th sample (5 kHz), for ``feedtune analyze ropesnap``.

FRFs of the linear-motor T-gantry twin (``feedtune simulate gantry frf``, docs/gantry_twin.md; seed 1,
8 significant digits): ``gantry_frf_x-0.3.csv``, ``gantry_frf_x0.csv``, ``gantry_frf_x0.3.csv``, the 2x2 FRF
(u1, u2) -> (y1, y2) [m/V] with the table at x = -0.3, 0 and 0.3 m, for ``feedtune identify gantry`` and
``feedtune tune gantry``.

Vendor files (``vendor/``; the others there are written by hand):

* ``vendor/motor_bode.csv``, ``vendor/load_bode.csv`` -- ``vendor/two_channels.csv`` as a drive's analyser writes
  it, one Bode file per encoder (``Frequency [Hz],Magnitude [dB],Phase [deg],Coherence``; the load encoder counts
  the other way), for ``feedtune frf merge`` and the ``FILE:OUT/IN`` pieces.
* ``vendor/auto_servo_tuning.xml`` -- an auto-servo-tuning export built from the format facts
  (:mod:`feedtune.io.servo_tuning_xml`): the speed-loop plant of the example ball screw (motor speed over the
  command, 400 lines, with its coherence) and an original and a tuned speed controller, for ``feedtune frf info``.

The twin files need the ``feedtune`` of this checkout (run through ``python -m feedtune``); the whole run takes
about 20 s. A file whose content is unchanged is left as it is (a MATLAB file's header carries its creation
time), so regenerating leaves ``git status`` clean.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from feedtune import Frf
from feedtune.io import read_frf, read_log, write_frf, write_log_csv
from feedtune.log import Log
from feedtune.models import THESIS_TABLE_3_1
from feedtune.sim.trajectory import Trajectory, multi_segment

HERE = Path(__file__).resolve().parent

FILTERS = ["--notch", "420,0.55,0.7", "--notch", "1080,0.05,0.7", "--lpf", "2000"]
"""The filter pack of the README tour's ``feedtune design ppc``."""
FAMILY = ((0.7, "m70", 70), (1.0, "m100", 100), (1.3, "m130", 130))
"""Table-mass factor, file-name tag and noise seed of the machine family."""
GANTRY_X = ("-0.3", "0", "0.3")
"""Table positions [m] of the gantry FRFs."""
MAT_HEADER_TEXT = 116
"""Bytes of descriptive text (with the creation time) at the top of a MATLAB v5 file."""


# ------------------------------------------------------------------------------------------ ball-screw FRFs
def torsional(f: np.ndarray, f0: float, zeta_z: float, zeta_p: float) -> np.ndarray:
    """A zero/pole pair with unit gain at 0 Hz, resonance-like when ``zeta_p < zeta_z``."""
    s = 2j * np.pi * f
    w = 2 * np.pi * f0
    w_z = w * 0.95
    return (s**2 + 2 * zeta_z * w_z * s + w_z**2) / (s**2 + 2 * zeta_p * w * s + w**2) * (w / w_z) ** 2


def two_mass_response(model, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``G11 = x1/u`` and ``G21 = x2/u`` of eq. 3.4 [rad/V], evaluated as the example files were first written."""
    m1, m2, b1, b2, k, c = (model.m1, model.m2, model.b1, model.b2, model.k, model.c)
    a1 = m1 * b2 + m2 * b1 + (m1 + m2) * c
    a2 = b1 * b2 + (b1 + b2) * c + (m1 + m2) * k
    a3 = (b1 + b2) * k
    s = 2j * np.pi * np.asarray(f, float)
    den = np.polyval(np.array([m1 * m2, a1, a2, a3, 0.0]), s)
    return np.polyval(np.array([m2, c + b2, k]), s) / den, np.polyval(np.array([c, k]), s) / den


def example_frf(seed: int = 7, model=THESIS_TABLE_3_1, lines: int = 1500, source: str | None = None) -> Frf:
    """The example FRF of ``model`` on ``lines`` log-spaced lines over 1-2000 Hz (see module docstring)."""
    f = np.logspace(0, np.log10(2000), lines)
    g11, g21 = two_mass_response(model, f)
    s = 2j * np.pi * f
    extra = torsional(f, 440, 0.05, 0.02) * torsional(f, 1100, 0.05, 0.02) * (2 * np.pi * 450) / (s + 2 * np.pi * 450)
    rng = np.random.default_rng(seed)
    h = np.stack([g11, g21]) * extra
    noise = 0.02 / np.sqrt(2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    h = h * (1 + noise)
    coh = np.clip(1 - 0.5 * np.abs(noise) ** 2 - 0.02 * (f / 2000) ** 2, 0, 1)
    return Frf(
        f,
        h[:, None, :],
        ("x1", "x2"),
        ("u",),
        "position",
        coh[:, None, :],
        input_unit="V",
        output_unit="rad",
        meta={
            "source": source or "feedtune example: Table 3.1 + torsional modes 440/1100 Hz + 450 Hz current loop",
            "seed": str(seed),
        },
    )


def family_frf(factor: float, seed: int) -> Frf:
    """The example FRF with the table mass ``m2`` at ``factor`` times its Table 3.1 value (800 lines)."""
    model = replace(THESIS_TABLE_3_1, m2=THESIS_TABLE_3_1.m2 * factor)
    frf = example_frf(seed, model, lines=800, source=f"feedtune example: Table 3.1 with m2 x {factor:g} "
                      "+ torsional modes 440/1100 Hz + 450 Hz current loop")
    return rounded_frf(frf, 8, m2=f"{model.m2:.6g} V/(rad/s^2)")


# ------------------------------------------------------------------------------------------ rounding
def significant(a: np.ndarray, digits: int) -> np.ndarray:
    """``a`` rounded to ``digits`` significant digits (short CSV text; far below the noise of every file)."""
    a = np.asarray(a)
    if np.iscomplexobj(a):
        return significant(a.real, digits) + 1j * significant(a.imag, digits)
    flat = [float(f"{v:.{digits}g}") for v in np.asarray(a, float).ravel()]
    return np.array(flat).reshape(a.shape)


def rounded_frf(frf: Frf, digits: int, **meta: str) -> Frf:
    """``frf`` with its responses and coherence rounded to ``digits`` significant digits, ``meta`` added."""
    coherence = None if frf.coherence is None else significant(frf.coherence, digits)
    return replace(frf, response=significant(frf.response, digits), coherence=coherence,
                   meta={**frf.meta, **meta})


def trimmed_log(log: Log, decimals: dict[str, int], every: int, meta: dict) -> Log:
    """Every ``every``-th sample of the signals named in ``decimals``, each rounded to its number of decimals
    (far below the encoder resolution and the noise), with new metadata."""
    keep = slice(0, None, every)
    t = np.round(log.t[keep], 9)
    signals = {n: np.round(log[n][keep], d) + 0.0 for n, d in decimals.items()}
    return Log(t, signals, {n: log.unit(n) for n in decimals}, meta)


# ------------------------------------------------------------------------------------------ writing
def same_content(a: Path, b: Path) -> bool:
    """True when the files hold the same bytes (for MATLAB files: after the header text with its date)."""
    if not b.exists():
        return False
    x, y = a.read_bytes(), b.read_bytes()
    if a.suffix == ".mat" and x[:19] == y[:19] == b"MATLAB 5.0 MAT-file":
        return x[MAT_HEADER_TEXT:] == y[MAT_HEADER_TEXT:]
    return x == y


def settle(new: Path, dest: Path) -> None:
    """Move ``new`` to ``dest`` unless ``dest`` already holds the same content; say which."""
    if same_content(new, dest):
        new.unlink()
        print(f"unchanged {dest.relative_to(HERE.parent)} ({dest.stat().st_size / 1000:.0f} kB)")
        return
    os.replace(new, dest)
    print(f"wrote {dest.relative_to(HERE.parent)} ({dest.stat().st_size / 1000:.0f} kB)")


def put_frf(frf: Frf, name: str, tmp: Path) -> None:
    """Write an FRF into examples/ (through ``tmp``)."""
    staged = tmp / f"staged_{name}"
    write_frf(frf, staged, force=True)
    settle(staged, HERE / name)


def put_log(log: Log, name: str, tmp: Path) -> None:
    """Write a log into examples/ (through ``tmp``)."""
    staged = tmp / f"staged_{name}"
    write_log_csv(log, staged, force=True)
    settle(staged, HERE / name)


def feedtune(tmp: Path, *args: str) -> None:
    """Run the ``feedtune`` command of this checkout in ``tmp`` (relative names in the files it writes), quietly."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(HERE.parent), os.environ.get("PYTHONPATH")]))}
    res = subprocess.run([sys.executable, "-m", "feedtune", *args], cwd=tmp, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"make_examples: feedtune {' '.join(args)} failed ({res.returncode}):\n{res.stderr}")


# ------------------------------------------------------------------------------------------ twin runs
def reversal_trajectory(fs: float) -> Trajectory:
    """Back and forth at 2, 50 and 200 mm/s, each speed both ways, slowly through zero at first."""
    parts = [
        multi_segment([0, 0.001, -0.001, 0], v_max=0.002, a_max=0.02, j_max=1, fs=fs, dwell=0.05),
        multi_segment([0, 0.015, -0.015, 0], v_max=0.05, a_max=0.5, j_max=20, fs=fs, dwell=0.05),
        multi_segment([0, 0.05, -0.05, 0], v_max=0.2, a_max=2, j_max=50, fs=fs, dwell=0.05),
    ]
    rest = round(0.05 * fs)
    keys = ("pos", "vel", "acc", "jerk", "snap")
    cols: dict[str, list] = {k: [np.zeros(rest)] for k in keys}
    for p in parts:
        for k in keys:
            cols[k] += [getattr(p, k)[:-1], np.zeros(rest)]
    data = {k: np.concatenate(v) for k, v in cols.items()}
    n = data["pos"].size
    return Trajectory(np.arange(n) / fs, **data, sample_rate=fs)


def twin_logs(tmp: Path) -> None:
    """The tour's MC-PPC design, then the twin's reversal, tracking and rope-snap logs under it."""
    frf = str(HERE / "ballscrew_frf.csv")
    feedtune(tmp, "identify", "ballscrew", frf, "--out", "model.toml")
    feedtune(tmp, "design", "ppc", "model.toml", *FILTERS, "--frf", frf, "--out", "mcppc.toml")
    gains = "mcppc.toml (feedtune design ppc on examples/ballscrew_frf.csv, as in the README tour)"

    write_log_csv(reversal_trajectory(20000.0).to_log(), tmp / "reversals_traj.csv", force=True)
    feedtune(tmp, "simulate", "track", "--gains", "mcppc.toml", "--trajectory", "reversals_traj.csv",
             "--seed", "11", "--out", "reversals_raw.csv")
    log = read_log(tmp / "reversals_raw.csv")
    meta = {"source": "feedtune twin run (examples/make_examples.py): back and forth at 2, 50, 200 mm/s",
            "experiment": "track", "controller": "mcppc", "gains": gains, "seed": 11,
            "decimated": "every 40th sample of the 20 kHz twin (500 Hz)"}
    put_log(trimmed_log(log, {"x_ref": 10, "x2": 8, "u": 6, "e2": 10}, 40, meta), "ballscrew_reversals.csv", tmp)

    feedtune(tmp, "simulate", "track", "--gains", "mcppc.toml", "--distance", "0.02", "--v-max", "0.2",
             "--a-max", "9.81", "--j-max", "500", "--dwell-after", "0.05", "--seed", "1", "--out", "track_raw.csv")
    log = read_log(tmp / "track_raw.csv")
    meta = {"source": "feedtune twin run (examples/make_examples.py): 20 mm at 200 mm/s, 9.81 m/s^2, 500 m/s^3",
            "experiment": "track", "controller": "mcppc", "gains": gains, "seed": 1}
    decimals = {"x_ref": 11, "v_ref": 9, "a_ref": 7, "j_ref": 5, "x2_table": 10, "u": 6, "e2": 11}
    put_log(trimmed_log(log, decimals, 1, meta), "ballscrew_track.csv", tmp)

    feedtune(tmp, "simulate", "ropesnap", "--gains", "mcppc.toml", "--rope-force", "0.5", "--after", "0.4",
             "--seed", "1", "--out", "ropesnap_raw.csv")
    log = read_log(tmp / "ropesnap_raw.csv")
    meta = {"source": "feedtune twin run (examples/make_examples.py): 0.5 V rope snap",
            "experiment": "ropesnap", "controller": "mcppc", "gains": gains, "seed": 1,
            "t_release_s": log.meta["t_release_s"], "force_V": 0.5,
            "decimated": "every 4th sample of the 20 kHz twin (5 kHz)"}
    put_log(trimmed_log(log, {"x2_table": 10, "x2": 8, "u": 6}, 4, meta), "ballscrew_ropesnap.csv", tmp)


def gantry_frfs(tmp: Path) -> None:
    """The gantry twin's 2x2 FRFs at three table positions."""
    xs = [a for x in GANTRY_X for a in ("--x", x)]
    feedtune(tmp, "simulate", "gantry", "frf", *xs, "--seed", "1", "--out", "gantry.csv")
    for x in GANTRY_X:
        frf = read_frf(tmp / f"gantry_x{x}_frf.csv")
        meta = {k: v for k, v in frf.meta.items() if k not in ("source", "format", "origin")}
        meta = {"source": f"{frf.meta['origin']} (feedtune simulate gantry frf, seed 1)", **meta}
        put_frf(rounded_frf(replace(frf, meta=meta), 8), f"gantry_frf_x{x}.csv", tmp)


# ------------------------------------------------------------------------------------------ vendor files
def vendor_bode_files(tmp: Path) -> None:
    """``vendor/two_channels.csv`` split into one Bode file per encoder, cells copied as they are."""
    lines = (HERE / "vendor" / "two_channels.csv").read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    for name, prefix in (("motor_bode.csv", "Motor"), ("load_bode.csv", "Load")):
        cols = [0] + [header.index(f"{prefix} {what}") for what in ("Mag [dB]", "Phase [deg]", "Coherence")]
        rows = ["Frequency [Hz],Magnitude [dB],Phase [deg],Coherence"]
        rows += [",".join(line.split(",")[j] for j in cols) for line in lines[1:]]
        staged = tmp / f"staged_{name}"
        staged.write_text("\n".join(rows) + "\n", encoding="utf-8")
        settle(staged, HERE / "vendor" / name)


def servo_tuning_export(tmp: Path) -> None:
    """The example ball screw's speed-loop plant and two speed controllers as an auto-servo-tuning XML export."""
    from feedtune.control.drive_tuning import (
        DriveSpeedTuning,
        Pt1Filter,
        Pt2Filter,
        SecondOrderFilter,
        SpeedController,
    )
    from feedtune.io.servo_tuning_xml import servo_tuning_xml

    frf = example_frf(seed=25, lines=400, source="auto-servo-tuning example").as_quantity("velocity")
    original = SpeedController(0.8, 0.010, (Pt1Filter(1.0e-4), SecondOrderFilter(420.0, 0.05, 420.0, 0.5, False)))
    tuned = SpeedController(1.2, 0.006, (SecondOrderFilter(440.0, 0.03, 440.0, 0.3), Pt2Filter(2000.0, 0.7)))
    data = servo_tuning_xml(frf.freq_hz, significant(frf.channel("x1/u"), 8), DriveSpeedTuning(original, tuned, 125e-6),
                            significant(frf.channel_coherence("x1/u"), 6))
    staged = tmp / "staged_auto_servo_tuning.xml"
    staged.write_bytes(data)
    settle(staged, HERE / "vendor" / "auto_servo_tuning.xml")


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="feedtune_examples_") as name:
        tmp = Path(name)
        frf = example_frf()
        for ext in ("csv", "mat", "uff"):
            put_frf(frf, f"ballscrew_frf.{ext}", tmp)
        for factor, tag, seed in FAMILY:
            put_frf(family_frf(factor, seed), f"ballscrew_frf_{tag}.csv", tmp)
        vendor_bode_files(tmp)
        servo_tuning_export(tmp)
        twin_logs(tmp)
        gantry_frfs(tmp)


if __name__ == "__main__":
    main()
