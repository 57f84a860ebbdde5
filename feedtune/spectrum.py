"""The :class:`PsdSpectrum` value type: power spectral densities of a measured vibration, magnitude only.

A resonance test that records the machine's vibration but not the excitation (a 3D printer's accelerometer sweep, a
spectrum analyser's autospectrum) gives power spectral densities, not an FRF: no phase and no input, so no model of
the plant can be fitted to it and no loop can be analysed with it. What it does tell is where the machine rings and how
little that ringing is damped: :func:`feedtune.identify.resonances.find_resonances` picks those, and
:mod:`feedtune.design.input_shaper` fits the command shapers that cancel them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import DataError
from .frf import check_frequency_grid


@dataclass(frozen=True)
class PsdSpectrum:
    """Power spectral densities of a measured vibration on one frequency grid.

    Parameters
    ----------
    freq_hz : ndarray, shape (n,)
        Frequency grid [Hz], strictly increasing, >= 0.
    psd : dict of str to ndarray
        One PSD per measured direction (``"x"``, ``"y"``, ``"z"``, and their sum ``"xyz"``), each shape (n,) and
        >= 0, in :attr:`unit`.
    unit : str
        Unit of the PSDs, e.g. ``"(mm/s^2)^2/Hz"`` for an accelerometer in mm/s^2.
    normalized : bool
        Whether the PSDs are already divided by ``f + 0.1 Hz`` and zeroed below 5 Hz, as Klipper does before it
        fits shapers (and writes its ``calibration_data`` files).
    shaper_columns : dict of str to ndarray
        Columns the file carries beside the PSDs, by their header (``"mzv(54.2)"``): the vibration a fitted shaper
        leaves at each frequency [-].
    meta : dict
        Free-form metadata (``source``: the file).
    """

    freq_hz: np.ndarray
    psd: Mapping[str, np.ndarray]
    unit: str = ""
    normalized: bool = False
    shaper_columns: Mapping[str, np.ndarray] = field(default_factory=dict)
    meta: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        where = str(self.meta.get("source", "spectrum"))
        f = check_frequency_grid(self.freq_hz, where)
        psd = {}
        for name, values in self.psd.items():
            v = np.asarray(values, dtype=float).reshape(-1)
            if v.size != f.size:
                raise DataError(f"{where}: PSD {name!r} has {v.size} values for {f.size} frequencies")
            if not np.all(np.isfinite(v)) or np.any(v < 0):
                raise DataError(f"{where}: PSD {name!r} holds a negative or non-finite value")
            psd[name] = v
        if not psd:
            raise DataError(f"{where}: no PSD column")
        shapers = {k: np.asarray(v, dtype=float).reshape(-1) for k, v in self.shaper_columns.items()}
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "psd", psd)
        object.__setattr__(self, "shaper_columns", shapers)
        object.__setattr__(self, "meta", dict(self.meta))

    @property
    def source(self) -> str:
        """Where the spectrum came from (file name) or ``"spectrum"``."""
        return str(self.meta.get("source", "spectrum"))

    def get(self, name: str) -> np.ndarray:
        """One PSD; an unknown name is a :class:`DataError` listing what exists."""
        try:
            return self.psd[name]
        except KeyError:
            raise DataError(f"{self.source}: no PSD {name!r}; PSDs: {', '.join(self.psd)}") from None

    def __repr__(self) -> str:
        f = self.freq_hz
        extra = f", {len(self.shaper_columns)} shaper columns" if self.shaper_columns else ""
        return (f"PsdSpectrum({' '.join(self.psd)}, {f.size} lines, {f[0]:.4g}-{f[-1]:.4g} Hz, {self.unit or '-'}"
                f"{', normalized' if self.normalized else ''}{extra}, source={self.source!r})")

    def to_dict(self) -> dict:
        """``freq_hz`` [Hz], ``psd`` (lists, in ``unit``), ``unit``, ``normalized``, ``shaper_columns``, ``source``."""
        return {"freq_hz": self.freq_hz.tolist(), "psd": {k: v.tolist() for k, v in self.psd.items()},
                "unit": self.unit, "normalized": self.normalized,
                "shaper_columns": {k: v.tolist() for k, v in self.shaper_columns.items()}, "source": self.source}
