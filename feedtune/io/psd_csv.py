"""Power spectral densities as Klipper writes them: ``resonances_*.csv`` and ``calibration_data_*.csv``.

Klipper's ``TEST_RESONANCES`` and ``SHAPER_CALIBRATE`` (``klippy/extras/shaper_calibrate.py``,
``save_calibration_data``) write one row per frequency bin below 200 Hz::

    freq,psd_x,psd_y,psd_z,psd_xyz,zv(52.6),mzv(54.2),ei(64.8),2hump_ei(80.6),3hump_ei(96.2)
    51.8,1.552e+03,7.070e+02,6.374e+04,6.674e+04,0.011,0.047,0.052,0.083,0.085

* ``freq`` [Hz] (written with one decimal), the PSDs of the accelerometer's x, y, z and their sum in
  (mm/s^2)^2/Hz (four significant digits);
* a calibration file adds one column per fitted shaper, named ``TYPE(FREQ)``: the vibration [-] it leaves at each
  frequency (the largest over the damping ratios Klipper tries);
* Klipper divides the PSDs by ``f + 0.1 Hz`` and zeroes them below 5 Hz before fitting, and a calibration file is
  written after that; so a file with shaper columns is read as normalised and one without as raw (the rule of
  Klipper's own ``scripts/calibrate_shaper.py``).

Lines starting with ``#`` are comments.
"""

from __future__ import annotations

import os
import re

import numpy as np

from ..errors import DataError
from ..spectrum import PsdSpectrum
from ._table import check_regular_file, parse_table, read_table_data

KLIPPER_COLUMNS = ("freq", "psd_x", "psd_y", "psd_z", "psd_xyz")
"""The first five columns of Klipper's PSD files."""
KLIPPER_UNIT = "(mm/s^2)^2/Hz"
"""Unit of Klipper's PSDs: the accelerometer's acceleration in mm/s^2."""
_SHAPER_COLUMN_RE = re.compile(r"^([A-Za-z0-9_]+)\((\d+(?:\.\d*)?)\)$")

READ_BYTES_PER_BYTE = 4.0
"""Memory reading a PSD file takes per byte of it, an upper bound (its bytes and the table parsed from them, as the
FRF CSV reader's); checked against the memory budget before the file is read (:func:`feedtune.budget.check_file`)."""


def is_klipper_header(cells) -> bool:
    """True for a header row that starts ``freq,psd_x,psd_y,psd_z,psd_xyz`` (any case, blanks stripped)."""
    names = tuple(str(c).strip().lower() for c in list(cells)[:len(KLIPPER_COLUMNS)])
    return names == KLIPPER_COLUMNS


_WHY = {"an FRF": "an FRF needs the phase of the response to a known input",
        "a log": "a log holds signals over time"}


def not_a_spectrum_reader(name: str, what: str) -> DataError:
    """The one line every reader gives when a Klipper PSD file is where ``what`` (``"an FRF"``, ``"a log"``) must be:
    what the file is, why it cannot serve and what reads it."""
    text = (f"{name}: a Klipper resonance test (power spectral densities: magnitude only, no phase, no excitation), "
            f"not {what}; {_WHY[what]}")
    return DataError(f"{text}; its resonances and input shapers: find_resonances(read_psd_csv(path))",
                     cli=f"{text}; its resonances and input shapers: feedtune identify resonances {name}")


def shaper_column(name: str) -> tuple[str, float] | None:
    """``("mzv", 54.2)`` from a shaper column's header ``mzv(54.2)``; None for another name."""
    m = _SHAPER_COLUMN_RE.match(name.strip())
    return (m.group(1).lower(), float(m.group(2))) if m else None


def read_psd_csv(path: str | os.PathLike[str]) -> PsdSpectrum:
    """Read a Klipper ``resonances_*.csv`` or ``calibration_data_*.csv`` file (module docstring).

    Parameters
    ----------
    path : path-like
        The CSV file.

    Returns
    -------
    PsdSpectrum
        PSDs ``x``, ``y``, ``z``, ``xyz`` in (mm/s^2)^2/Hz, ``normalized`` when the file carries shaper columns,
        those columns in ``shaper_columns``.

    Raises
    ------
    DataError
        Not such a file (the header is named), a column that is not ``TYPE(FREQ)``, malformed numbers.
    """
    from ..budget import check_file

    check_regular_file(path)  # a FIFO or a device would block or never end
    check_file(path, READ_BYTES_PER_BYTE, "reading the PSD")
    text, name = read_table_data(path, "CSV")
    table = parse_table(text, name, require_header=True)
    if not is_klipper_header(table.columns):
        raise DataError(f"{name}: not a Klipper PSD file (the header starts {', '.join(table.columns[:5])}; expected "
                        f"{','.join(KLIPPER_COLUMNS)})")
    data = table.data
    extra = {}
    for j, col in enumerate(table.columns[len(KLIPPER_COLUMNS):], start=len(KLIPPER_COLUMNS)):
        if shaper_column(col) is None:
            raise DataError(f"{name}: column {col!r} is neither a PSD nor a shaper column TYPE(FREQ) such as mzv(54.2)")
        extra[col] = data[:, j]
    psd = {key.removeprefix("psd_"): data[:, j] for j, key in enumerate(KLIPPER_COLUMNS) if j}
    meta = {"source": name, "format": "Klipper PSD CSV"}
    return PsdSpectrum(np.asarray(data[:, 0]), psd, KLIPPER_UNIT, normalized=bool(extra), shaper_columns=extra,
                       meta=meta)
