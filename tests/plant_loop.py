"""An independent discrete loop of a ball-screw gains file on a known continuous plant, for tests that hold a
certificate to the plant it claims something about (issue 23).

Nothing here comes from the analysis under test: the plant is the rational transfer function the example FRFs were
built from (examples/make_examples.py), sampled exactly by a zero-order hold (the aliasing sum), the controller is the
gains file's own numbers run through the law of docs/gains.md, and crossings and margins are found by brute force on a
dense grid.
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import numpy as np
import tomllib
from scipy.signal import sosfreqz

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def make_examples():
    """examples/make_examples.py as a module (the formulas of the example FRFs)."""
    spec = importlib.util.spec_from_file_location("make_examples", EXAMPLES / "make_examples.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def family_plant(factor: float):
    """``f -> (G11, G21)`` [rad/V] of the example family's noise-free plant with the table mass at ``factor`` times
    its Table 3.1 value: the two-mass model, torsional modes at 440 and 1100 Hz and the 450 Hz current loop."""
    ex = make_examples()
    from feedtune.models import THESIS_TABLE_3_1

    model = replace(THESIS_TABLE_3_1, m2=THESIS_TABLE_3_1.m2 * factor)

    def plant(f):
        f = np.asarray(f, float)
        g11, g21 = ex.two_mass_response(model, f)
        s = 2j * np.pi * f
        extra = (ex.torsional(f, 440, 0.05, 0.02) * ex.torsional(f, 1100, 0.05, 0.02)
                 * (2 * np.pi * 450) / (s + 2 * np.pi * 450))
        return g11 * extra, g21 * extra

    return plant


def zoh_sampled(plant, f: np.ndarray, fs: float, terms: int = 40, block: int = 4096):
    """The plant sampled by a zero-order hold at ``fs`` [Hz], exactly: ``G_d = (1 - z^-1) / T * sum_k G(s_k) / s_k``
    over ``s_k = j 2 pi (f + k fs)``, ``|k| <= terms`` (the plant rolls off as ``1/s^3``, each term as ``1/k^4``:
    the truncation error is below 1e-7 of the sum), ``block`` lines at a time."""
    f = np.asarray(f, float)
    k = np.arange(-terms, terms + 1)[:, None]
    out = [np.empty(f.shape, complex), np.empty(f.shape, complex)]
    for lo in range(0, f.size, block):
        fb = f[lo:lo + block]
        fk = fb[None, :] + k * fs
        z1 = np.exp(-2j * np.pi * fb / fs)
        for o, g in zip(out, plant(fk.ravel()), strict=True):
            o[lo:lo + block] = (1 - z1) * fs * np.sum(g.reshape(fk.shape) / (2j * np.pi * fk), axis=0)
    return tuple(out)


def gains_loop(gains_file: str | Path, plant, f: np.ndarray) -> np.ndarray:
    """``L(e^{j 2 pi f / fs})`` broken at the command ``u``: ``F_p z^-d (K1 G11 + K2 G21)`` with
    ``K1 = Kx1 + Kv1 D``, ``K2 = Kx2 + Kv2 D + Ki2 I``, ``D = (1 - z^-1) fs`` and ``I = 1 / (fs (1 - z^-1))``
    (docs/gains.md), the filter pack's own second-order sections and the file's delay."""
    doc = tomllib.loads(Path(gains_file).read_text(encoding="utf-8"))
    fs = float(doc["sampling"]["fs_hz"]["value"])
    d = int(doc["sampling"]["delay_samples"])
    g = {k: float(v["value"]) for k, v in doc["gains"].items()}
    f = np.asarray(f, float)
    z1 = np.exp(-2j * np.pi * f / fs)
    D = (1 - z1) * fs
    integral = 1 / (fs * (1 - z1))
    sos = np.asarray(doc["filters"]["filter_pack_sos"], float)
    fp = sosfreqz(sos, worN=f, fs=fs)[1] if len(sos) else np.ones_like(f, complex)
    g11, g21 = zoh_sampled(plant, f, fs)
    k1 = g["Kx1"] + g["Kv1"] * D
    k2 = g["Kx2"] + g["Kv2"] * D + g["Ki2"] * integral
    return fp * z1**d * (k1 * g11 + k2 * g21)


def dense_grid(fs: float, lo: float = 1.0, n: int = 400_001) -> np.ndarray:
    """``n`` log-spaced lines from ``lo`` to just below the Nyquist frequency [Hz]."""
    return np.logspace(np.log10(lo), np.log10(0.4999 * fs), n)


def first_crossover(f: np.ndarray, L: np.ndarray) -> float:
    """The first frequency [Hz] where ``|L|`` falls through 1 (linear interpolation in log |L| between lines)."""
    a = np.log(np.abs(L))
    i = np.flatnonzero((a[:-1] > 0) & (a[1:] <= 0))[0]
    return float(f[i] + (f[i + 1] - f[i]) * a[i] / (a[i] - a[i + 1]))


def worst_margins(f: np.ndarray, L: np.ndarray) -> dict:
    """Ms, the smallest |PM| [deg] over every crossover and the smallest |GM| [dB] over every phase crossover of the
    dense loop (brute force)."""
    a = np.abs(L)
    up = np.flatnonzero(np.signbit(a[:-1] - 1) != np.signbit(a[1:] - 1))
    pm = [abs(180.0 - abs(np.degrees(np.angle(L[i])))) for i in up]
    im = np.imag(L)
    pc = np.flatnonzero((np.signbit(im[:-1]) != np.signbit(im[1:])) & (np.real(L[:-1]) < 0))
    gm = [abs(-20 * np.log10(a[i])) for i in pc]
    return {"ms": float(np.max(1 / np.abs(1 + L))), "pm_deg": min(pm, default=np.inf),
            "gm_db": min(gm, default=np.inf)}
