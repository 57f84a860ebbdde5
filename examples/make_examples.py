"""Regenerate the bundled example files (run from the repository root: python examples/make_examples.py).

``ballscrew_frf.csv`` / ``.mat`` / ``.uff`` hold a ball-screw FRF from the motor command ``u`` [V] to the
rotary ``x1`` and linear ``x2`` encoders [rad], 1-2000 Hz, built from the thesis' Table 3.1 2-mass model
with what real drives add and the 2-mass model lacks: torsional modes at 440 and 1100 Hz (zero/pole pairs),
a 450 Hz first-order current loop, and 2 % complex measurement noise (seed 7), with a coherence column.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from feedtune import Frf
from feedtune.io import write_frf
from feedtune.models import THESIS_TABLE_3_1

HERE = Path(__file__).resolve().parent


def torsional(f: np.ndarray, f0: float, zeta_z: float, zeta_p: float) -> np.ndarray:
    """A zero/pole pair with unit gain at 0 Hz, resonance-like when ``zeta_p < zeta_z``."""
    s = 2j * np.pi * f
    w = 2 * np.pi * f0
    w_z = w * 0.95
    return (s**2 + 2 * zeta_z * w_z * s + w_z**2) / (s**2 + 2 * zeta_p * w * s + w**2) * (w / w_z) ** 2


def example_frf(seed: int = 7) -> Frf:
    """The example FRF (see module docstring)."""
    f = np.logspace(0, np.log10(2000), 1500)
    g = THESIS_TABLE_3_1.frequency_response(f)
    s = 2j * np.pi * f
    extra = torsional(f, 440, 0.05, 0.02) * torsional(f, 1100, 0.05, 0.02) * (2 * np.pi * 450) / (s + 2 * np.pi * 450)
    rng = np.random.default_rng(seed)
    h = np.stack([g["G11"], g["G21"]]) * extra
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
            "source": "feedtune example: Table 3.1 + torsional modes 440/1100 Hz + 450 Hz current loop",
            "seed": str(seed),
        },
    )


def main() -> None:
    frf = example_frf()
    for ext in ("csv", "mat", "uff"):
        write_frf(frf, HERE / f"ballscrew_frf.{ext}", force=True)
        print(f"wrote examples/ballscrew_frf.{ext}")


if __name__ == "__main__":
    main()
