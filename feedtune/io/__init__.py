"""File input/output: the only part of feedtune that touches the file system.

* FRFs: :func:`read_frf` / :func:`write_frf` (CSV, MATLAB v5/v7.3, UFF dataset 58), by extension.
* Logs: :func:`read_log` (CSV, MATLAB v5/v7.3, MDF4) and :func:`write_log_csv`.
* Documents: TOML with a JSON twin (:func:`write_document`, :func:`read_document`, :func:`dumps_toml`,
  :func:`quantity`, :func:`value_of`, :func:`require_schema`); model files (:func:`save_model`,
  :func:`load_model`).
* Atomic output: :func:`atomic_write_text`, :func:`atomic_write_bytes`, :func:`atomic_output`.

Heavy libraries (pandas, scipy, h5py, pyuff, asammdf) are imported only when a reader needs them.
The formats are described in ``docs/formats.md``.
"""

from ..quantity import is_quantity, quantity, value_of
from .atomic import atomic_output, atomic_outputs, atomic_write_bytes, atomic_write_text, ensure_writable
from .document import dumps_json, dumps_toml, read_document, require_schema, write_document
from .frf_csv import read_frf_csv, write_frf_csv
from .frf_mat import read_frf_mat, read_mat_variables, write_frf_mat
from .frf_read import FRF_EXTENSIONS, read_frf, write_frf
from .frf_uff import read_frf_uff, write_frf_uff
from .log_csv import write_log_csv
from .log_read import LOG_EXTENSIONS, read_log
from .model_file import load_model, model_document, register_model_kind, save_model

__all__ = [
    "FRF_EXTENSIONS",
    "LOG_EXTENSIONS",
    "atomic_output",
    "atomic_outputs",
    "atomic_write_bytes",
    "atomic_write_text",
    "dumps_json",
    "dumps_toml",
    "ensure_writable",
    "is_quantity",
    "load_model",
    "model_document",
    "quantity",
    "read_document",
    "read_frf",
    "read_frf_csv",
    "read_frf_mat",
    "read_frf_uff",
    "read_log",
    "read_mat_variables",
    "register_model_kind",
    "require_schema",
    "save_model",
    "value_of",
    "write_document",
    "write_frf",
    "write_frf_csv",
    "write_frf_mat",
    "write_frf_uff",
    "write_log_csv",
]
