"""Logs from MATLAB files (v5 via scipy, v7.3 via h5py).

Every real numeric vector becomes a candidate signal (the ones with the time vector's length are kept);
scalars and char variables go to ``meta``; matrix columns are reached through a mapping ``var[k]``
(0-based column ``k``); variables scipy cannot decode (MATLAB objects) are ignored.
"""

from __future__ import annotations

import os
import re

import numpy as np

from ..errors import DataError
from .frf_mat import MatContents, object_advice, read_mat_variables
from .log_read import RawLog

_COLUMN_SPEC_RE = re.compile(r"^\s*([A-Za-z_]\w*)\s*\[\s*(\d+)\s*\]\s*$")


def _is_vector(a: np.ndarray) -> bool:
    return a.ndim <= 2 and a.size >= 2 and (a.ndim == 1 or min(a.shape) == 1)


def _scalar(a: np.ndarray) -> object:
    v = a.reshape(-1)[0]
    if np.iscomplexobj(v):
        return str(v)
    return int(v) if a.dtype.kind in "biu" else float(v)


def _resolver(mat: MatContents):
    def resolve(spec: str) -> np.ndarray:
        m = _COLUMN_SPEC_RE.match(spec)
        var = m.group(1) if m else spec.strip()
        if var not in mat.arrays:
            raise DataError(f"{mat.name}: no variable {var!r}; numeric variables: {mat.available()}")
        a = mat.arrays[var]
        if np.iscomplexobj(a):
            raise DataError(f"{mat.name}: variable {var!r} is complex; a log signal must be real")
        if m is None:
            if not _is_vector(a):
                raise DataError(f"{mat.name}: variable {var!r} is a {'x'.join(map(str, a.shape))} matrix; "
                                f"pick a column with {var}[k] (k = 0..{a.shape[-1] - 1})")
            return a.reshape(-1).astype(float)
        k = int(m.group(2))
        if a.ndim != 2 or k >= a.shape[1]:
            raise DataError(f"{mat.name}: {spec}: variable {var!r} has shape {'x'.join(map(str, a.shape))}, "
                            f"no column {k} (columns are numbered from 0)")
        return a[:, k].astype(float)

    return resolve


def read_log_mat_raw(path: str | os.PathLike[str]) -> RawLog:
    """Read a MATLAB file into a :class:`RawLog` (vectors as columns, scalars and strings as meta)."""
    mat = read_mat_variables(path)
    columns: dict[str, np.ndarray] = {}
    meta: dict[str, object] = {"format": f"mat v{mat.version}"}
    refused: dict[str, str] = {}
    for var, a in mat.arrays.items():
        if a.size == 1:
            meta[var] = _scalar(a)
        elif _is_vector(a) and np.iscomplexobj(a):
            columns[var] = np.zeros(a.size)  # a placeholder: refused where it would become a signal
            refused[var] = "is complex; a log signal must be real (store its real part or magnitude)"
        elif _is_vector(a):
            columns[var] = a.reshape(-1).astype(float)
    meta.update({("origin" if k == "source" else k): v for k, v in mat.strings.items()})
    if mat.skipped:
        meta["skipped_variables"] = ", ".join(mat.skipped)
    if mat.objects:
        if not any(a.size >= 2 and not np.iscomplexobj(a) for a in mat.arrays.values()):
            raise DataError(object_advice(mat))
        meta["matlab_objects"] = ", ".join(f"{v} ({c})" for v, c in mat.objects)
    return RawLog(mat.name, columns, {}, meta, _resolver(mat), refused=refused)
