"""The files a pipeline writes: all or nothing into one folder, logs and FRFs as CSV text, JSON-ready values."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import UsageError


# ------------------------------------------------------------------------------------------ files
def check_out_dir(out_dir: str | os.PathLike[str], force: bool) -> Path:
    """Refuse an existing non-empty output folder without ``force``; the parent must exist and take new entries
    (errors naming ENAMETOOLONG, EACCES, EROFS as :func:`feedtune.io.atomic.ensure_writable`)."""
    from ..errors import DataError
    from ..io.atomic import check_folder_writable, check_name

    d = Path(out_dir)
    check_name(d)
    if d.exists() and not d.is_dir():
        raise DataError(f"{d} is a file; out_dir must be a folder", parameter="out_dir")
    if d.is_dir() and any(d.iterdir()) and not force:
        raise UsageError(f"{d} exists and is not empty; pass force=True to write into it", parameter="force")
    parent = d.parent if str(d.parent) else Path(".")
    if not parent.is_dir():
        raise DataError(f"{d}: folder {parent} does not exist")
    check_folder_writable(d, parent)
    return d


def write_texts(texts: dict, *, force: bool = False, out_dir: str | os.PathLike[str] | None = None) -> list[Path]:
    """Write ``{path: text}`` all-or-nothing (:func:`feedtune.io.atomic_outputs`); create ``out_dir`` if needed.

    Returns
    -------
    list of Path
        The files written.
    """
    from ..io import atomic_outputs

    created = False
    if out_dir is not None:
        d = Path(out_dir)
        if not d.exists():
            d.mkdir()
            created = True
        paths = [d / name for name in texts]
    else:
        paths = [Path(p) for p in texts]
    try:
        with atomic_outputs(paths, force=force) as temps:
            for tmp, text in zip(temps, texts.values(), strict=True):
                tmp.write_bytes(text.encode("utf-8"))
    except BaseException:
        if created and not any(Path(out_dir).iterdir()):
            Path(out_dir).rmdir()
        raise
    return paths


def experiment_texts(result, log_name: str, frf_name: str | None = None) -> dict:
    """CSV texts of an experiment's log (and FRF): ``{log_name: text[, frf_name: text]}``."""
    from ..io.frf_csv import frf_to_csv_text
    from ..io.log_csv import log_to_csv_text

    texts = {log_name: log_to_csv_text(result.log)}
    if frf_name is not None and result.frf is not None:
        texts[frf_name] = frf_to_csv_text(result.frf)
    return texts


def plain_json(obj):
    if isinstance(obj, dict):
        return {str(k): plain_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain_json(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj
