"""MATLAB ``.mat`` files: a variable loader for v5 and v7.3 files, and FRF read/write.

* v4/v5/v7 files are read with :func:`scipy.io.loadmat`; variables scipy cannot decode (MATLAB objects such
  as ``tf``) are skipped. MATLAB class objects (``frd``, ``zpk``, ``tf``, ``ss``, ``timeseries``: opaque ``MCOS``
  data that only MATLAB decodes, shown by scipy as ``MatlabOpaque`` beside a ``__function_workspace__``) are listed
  by name and class in :attr:`MatContents.objects`; a file whose data are only such objects is refused naming them
  and the MATLAB lines that re-export their data as plain arrays (:func:`object_advice`).
* v7.3 files are HDF5 and read with h5py: arrays are stored transposed (MATLAB is column-major), complex
  arrays as a compound type with fields ``real`` and ``imag``, char arrays as uint16 with the attribute
  ``MATLAB_class = "char"``.

FRF variables (defaults, all overridable): frequency vector ``freq_hz`` (or ``f``, ``freq``,
``frequency``) [Hz], one complex vector per channel named ``OUT_IN`` (e.g. ``x1_u``), coherence
``OUT_IN_coh``, optional char variables ``quantity``, ``input_unit``, ``output_unit``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..budget import ENV_VARIABLE, check_file, check_memory, fmt_bytes, memory_budget
from ..errors import DataError
from ..frf import Frf, normalize_quantity
from ._table import check_readable_file
from .atomic import atomic_output

FREQ_NAMES = ("freq_hz", "f", "freq", "frequency")
_CHANNEL_VAR_RE = re.compile(r"^([A-Za-z][A-Za-z0-9]*)_([A-Za-z][A-Za-z0-9]*)$")
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9]*$")


@dataclass(frozen=True)
class MatContents:
    """Variables of a MAT file.

    Attributes
    ----------
    name : str
        File name for messages.
    arrays : dict of str to ndarray
        Numeric variables (real or complex, any integer or float type) in MATLAB's shape (rows, columns).
    strings : dict of str to str
        Char variables (rows joined with newlines).
    skipped : list of str
        Variables that are neither numeric nor char (structs, cells, objects) or could not be decoded.
    version : str
        ``"5"`` (v4/v5/v7, scipy) or ``"7.3"`` (HDF5).
    objects : list of (str, str)
        MATLAB class objects ``(variable, class)`` (``("G", "frd")``), whose data only MATLAB decodes.
    """

    name: str
    arrays: dict[str, np.ndarray]
    strings: dict[str, str] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    version: str = "5"
    objects: list[tuple[str, str]] = field(default_factory=list)

    def available(self) -> str:
        """Comma-separated list of the numeric variables with their shapes, for messages."""
        items = [f"{k} {'x'.join(map(str, v.shape))}" for k, v in self.arrays.items()]
        return ", ".join(items) or "no numeric variables"

    def vector(self, var: str, what: str = "variable") -> np.ndarray:
        """A numeric variable as a 1-D array (row or column vector); errors name the variable."""
        if var not in self.arrays:
            unreadable = var in self.skipped or var in self.strings
            extra = " (it exists but could not be read as numbers)" if unreadable else ""
            raise DataError(f"{self.name}: no {what} {var!r}{extra}; numeric variables: {self.available()}")
        a = self.arrays[var]
        if a.ndim > 2 or (a.ndim == 2 and min(a.shape) > 1) or a.size == 0:
            shape = "x".join(map(str, a.shape))
            raise DataError(f"{self.name}: {what} {var!r} must be a vector, got shape {shape}")
        return a.reshape(-1)


def _is_numeric(a: object) -> bool:
    return isinstance(a, np.ndarray) and a.dtype.kind in "biufc" and a.dtype.names is None


def _char_to_str(a: np.ndarray) -> str:
    """A scipy char array (str dtype) to text."""
    if a.size == 0:
        return ""
    if a.ndim == 0:
        return str(a.item())
    return "\n".join(str(x).rstrip() for x in np.atleast_1d(a.squeeze()).reshape(-1))


_MI_MATRIX, _MI_COMPRESSED = 14, 15
_MI_TYPES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 14: 1, 15: 1, 16: 1, 17: 2, 18: 4}
"""MAT v5 data types and their item size [bytes] (miINT8 .. miUTF32)."""


def _check_v5_elements(buf: bytes, start: int, end: int, where: str, depth: int = 0) -> None:
    """Walk the data elements of a MAT v5 buffer and refuse one whose type or size does not fit (scipy's reader
    crashes the process on some corrupted files instead of raising)."""
    import struct
    import zlib

    off = start
    while off < end:
        if end - off < 8:
            raise DataError(f"{where}: truncated MAT data element at byte {off}")
        tag, nbytes = struct.unpack_from("<II", buf, off)
        if tag >> 16:  # small data element: type and size in the first 4 bytes, data in the next 4
            t, n = tag & 0xFFFF, tag >> 16
            if t not in _MI_TYPES or n > 4 or n % _MI_TYPES[t]:
                raise DataError(f"{where}: corrupt MAT data element at byte {off} (type {t}, {n} bytes)")
            off += 8
            continue
        if tag not in _MI_TYPES:
            raise DataError(f"{where}: corrupt MAT data element at byte {off} (unknown type {tag})")
        body = off + 8
        if nbytes > end - body:
            raise DataError(f"{where}: MAT data element at byte {off} claims {nbytes} bytes, {end - body} remain: "
                            "the file is truncated or corrupt")
        if tag == _MI_COMPRESSED:
            if depth:
                raise DataError(f"{where}: corrupt MAT file (a compressed element inside another)")
            d = zlib.decompressobj()
            limit = memory_budget()
            try:
                inner = d.decompress(buf[body:body + nbytes], limit)
            except zlib.error as exc:
                raise DataError(f"{where}: corrupt compressed MAT variable at byte {off} ({exc})") from None
            if d.unconsumed_tail:  # a compression bomb, or a variable too large for the memory budget
                raise DataError(f"{where}: the compressed MAT variable at byte {off} expands to more than the memory "
                                f"budget of {fmt_bytes(limit)} ({ENV_VARIABLE}); not read")
            if not d.eof or d.unused_data:
                raise DataError(f"{where}: corrupt compressed MAT variable at byte {off} (the stream does not end "
                                "where the element does)")
            _check_v5_elements(inner, 0, len(inner), where, depth + 1)
        elif tag == _MI_MATRIX:
            _check_v5_elements(buf, body, body + nbytes, where, depth + 1)
        elif nbytes % _MI_TYPES[tag]:
            raise DataError(f"{where}: corrupt MAT data element at byte {off} ({nbytes} bytes of {_MI_TYPES[tag]}-byte "
                            "items)")
        off = body + nbytes + ((-nbytes) % 8 if tag != _MI_COMPRESSED else 0)
    if off > end and depth:
        raise DataError(f"{where}: corrupt MAT file (an element overruns its parent)")


def _load_v5(path: Path) -> MatContents:
    import warnings

    import scipy.io
    from scipy.io.matlab import MatReadError, MatReadWarning

    check_file(path, 2.0, "reading")
    buf = path.read_bytes()
    _check_declared_sizes(path)
    if len(buf) >= 128 and buf[126:128] in (b"IM", b"MI") and buf[124:126] in (b"\x00\x01", b"\x01\x00"):
        if buf[126:128] == b"IM":  # little-endian files (everything written today); others go to scipy as they are
            _check_v5_elements(buf, 128, len(buf), str(path))
    try:
        with warnings.catch_warnings():  # several MATLAB objects all load under the key 'None': listed by _v5_objects
            warnings.simplefilter("ignore", MatReadWarning)
            raw = scipy.io.loadmat(str(path), squeeze_me=False, chars_as_strings=True)
    except (ValueError, TypeError, OSError, RuntimeError, MatReadError):  # RuntimeError: scipy refuses v7.3
        raise DataError(f"{path}: not a MATLAB .mat file (no valid MAT header or truncated)") from None
    except Exception:
        raw = _load_v5_by_variable(path)
    contents = _sort_v5(path, raw)
    if any(_is_opaque(v) for v in raw.values()):
        contents = replace(contents, objects=_v5_objects(buf),
                           skipped=[k for k in contents.skipped if not _is_opaque(raw.get(k))])
    return contents


def _is_opaque(value: object) -> bool:
    """A MATLAB class object as scipy returns it (``MatlabOpaque``: fields ``s0`` name, ``s1`` type system, ``s2``
    class)."""
    return type(value).__name__ == "MatlabOpaque"


_MX_OPAQUE = 17


def _int8_text(buf: bytes, off: int) -> tuple[str, int]:
    """An miINT8 element's text and the offset after it."""
    import struct

    tag, n = struct.unpack_from("<II", buf, off)
    if tag >> 16:
        n, tag = tag >> 16, tag & 0xFFFF
        return buf[off + 4:off + 4 + n].decode("latin-1"), off + 8
    return buf[off + 8:off + 8 + n].decode("latin-1"), off + 8 + n + (-n) % 8


def _v5_objects(buf: bytes) -> list[tuple[str, str]]:
    """``(variable, class)`` of every top-level MATLAB class object of a little-endian MAT v5 file (an miMATRIX of
    class mxOPAQUE: array flags, then the variable name, the type system and the class name as miINT8 texts)."""
    import struct
    import zlib

    found: list[tuple[str, str]] = []

    def walk(data: bytes, nested: bool) -> None:
        off = 0
        while off + 8 <= len(data):
            tag, n = struct.unpack_from("<II", data, off)
            body = data[off + 8:off + 8 + n]
            if tag == _MI_COMPRESSED and not nested:
                try:
                    walk(zlib.decompress(body), True)
                except zlib.error:
                    return
            elif tag == _MI_MATRIX and len(body) >= 16:
                flags = struct.unpack_from("<I", body, 8)[0]
                if flags & 0xFF == _MX_OPAQUE:
                    try:
                        name, k = _int8_text(body, 16)
                        system, k = _int8_text(body, k)
                        cls, _ = _int8_text(body, k)
                    except (struct.error, UnicodeDecodeError):
                        cls, name, system = "", "", ""
                    if name and cls and system == "MCOS":
                        found.append((name, cls))
            off += 8 + n + ((-n) % 8 if tag != _MI_COMPRESSED else 0)

    if len(buf) >= 128 and buf[126:128] == b"IM":
        walk(buf[128:], False)
    return found


_REEXPORT = {
    "frd": ("{v} = chgFreqUnit({v}, 'Hz'); f = {v}.Frequency; x1_u = squeeze({v}.ResponseData(1, 1, :)); "
            "save('{v}_frf.mat', 'f', 'x1_u', '-v7')"),
    "lti": ("f = logspace(0, 3, 400)'; x1_u = squeeze(freqresp({v}, 2*pi*f)); save('{v}_frf.mat', 'f', 'x1_u', "
            "'-v7')"),
    "timeseries": "t = {v}.Time; x = squeeze({v}.Data); save('{v}_log.mat', 't', 'x', '-v7')",
}
"""MATLAB lines that re-export an object's data as plain arrays feedtune reads (``{v}``: the variable); ``lti``
stands for zpk, tf and ss (their response on a grid in Hz: ``freqresp`` takes rad/s)."""
_LTI_CLASSES = ("zpk", "tf", "ss", "pid", "pidstd", "idtf", "idss", "idpoly", "idproc", "genss", "uss")


def object_advice(mat: MatContents) -> str:
    """What a file of MATLAB class objects holds and how to re-export each (empty without objects).

    Examples
    --------
    >>> print(object_advice(MatContents("G.mat", {}, objects=[("G", "frd")])))  # doctest: +NORMALIZE_WHITESPACE
    G.mat holds MATLAB objects that only MATLAB can decode: G (class frd); re-export their data as plain arrays in
    MATLAB: G = chgFreqUnit(G, 'Hz'); f = G.Frequency; x1_u = squeeze(G.ResponseData(1, 1, :)); save('G_frf.mat',
    'f', 'x1_u', '-v7') (and x2_u from ResponseData(2, 1, :) for a second output)
    """
    if not mat.objects:
        return ""
    names = ", ".join(f"{v} (class {c})" for v, c in mat.objects)
    lines = []
    for v, c in mat.objects:
        key = "lti" if c in _LTI_CLASSES else c
        if key in _REEXPORT:
            lines.append(_REEXPORT[key].format(v=v))
    how = ("; ".join(dict.fromkeys(lines)) if lines
           else "save each object's data as numeric variables (freq_hz and OUT_IN vectors, or t and signals)")
    extra = " (and x2_u from ResponseData(2, 1, :) for a second output)" if any(c == "frd" for _, c in mat.objects) \
        else ""
    return (f"{mat.name} holds MATLAB objects that only MATLAB can decode: {names}; re-export their data as plain "
            f"arrays in MATLAB: {how}{extra}")


_CLASS_BYTES = {"double": 8, "single": 4, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4, "uint32": 4,
                "int64": 8, "uint64": 8, "logical": 1, "char": 2}


def _check_declared_sizes(path: Path) -> None:
    """Refuse, before loading, a v5 file whose variables declare more memory than the budget (their shapes and
    classes from scipy's ``whosmat``; a compressed variable is small on disk and large in memory)."""
    import scipy.io

    try:
        entries = scipy.io.whosmat(str(path))
    except Exception:  # the loader names what is wrong with the file
        return
    total, largest = 0.0, ("", 0.0)
    for name, shape, cls in entries:
        n = float(np.prod([float(k) for k in shape])) * _CLASS_BYTES.get(cls, 8) * (2 if cls == "double" else 1)
        total += n
        largest = max(largest, (name, n), key=lambda e: e[1])
    check_memory(total, f"{path}: its variables ({largest[0]!r} the largest)", file=str(path))


def _short(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:120] or type(exc).__name__


def _load_v5_by_variable(path: Path) -> dict[str, object]:
    """Load variable by variable, dropping those scipy cannot decode."""
    import scipy.io

    try:
        names = [w[0] for w in scipy.io.whosmat(str(path))]
    except Exception as exc:
        raise DataError(f"{path}: not a MATLAB .mat file ({_short(exc)})") from None
    out: dict[str, object] = {}
    for var in names:
        try:
            out.update(scipy.io.loadmat(str(path), variable_names=[var], squeeze_me=False,
                                        chars_as_strings=True))
        except Exception:
            out[var] = None
    return out


def _sort_v5(path: Path, raw: Mapping[str, object]) -> MatContents:
    arrays: dict[str, np.ndarray] = {}
    strings: dict[str, str] = {}
    skipped: list[str] = []
    for key, val in raw.items():
        if key.startswith("__"):
            continue
        if _is_numeric(val):
            arrays[key] = np.asarray(val)
        elif isinstance(val, np.ndarray) and val.dtype.kind == "U":
            strings[key] = _char_to_str(val)
        else:
            skipped.append(key)
    return MatContents(str(path), arrays, strings, skipped, "5")


def _h5_class(obj: object) -> str:
    cls = getattr(obj, "attrs", {}).get("MATLAB_class", b"")
    return cls.decode() if isinstance(cls, bytes) else str(cls)


def _h5_dataset(ds: object, where: str = "") -> np.ndarray | str | None:
    """Decode one v7.3 dataset into MATLAB orientation; None when it is not numeric or char. Its declared size is
    checked against the memory budget before it is read (a dataset may declare 2e9 rows in a small file)."""
    cls = _h5_class(ds)
    if ds.attrs.get("MATLAB_empty", 0):
        return None
    shape = tuple(int(k) for k in (ds.shape or ()))
    check_memory(float(np.prod([float(k) for k in shape])) * ds.dtype.itemsize * 2,
                 f"{where}: variable {ds.name.lstrip('/')!r} ({'x'.join(map(str, shape))})", file=where)
    data = ds[()]
    if not isinstance(data, np.ndarray):
        data = np.asarray(data)
    if data.dtype.names is not None:
        if {"real", "imag"} <= set(data.dtype.names):
            data = data["real"] + 1j * data["imag"]
        else:
            return None
    data = data.T
    if cls == "char":
        rows = np.atleast_2d(data)
        if rows.dtype.kind not in "iu" or (rows.size and (rows.min() < 0 or rows.max() > 0x10FFFF)):
            raise ValueError("its char data holds values that are not characters (UTF-16 code units expected)")
        return "\n".join("".join(map(chr, row)).rstrip() for row in rows.astype(np.uint32))
    if data.dtype.kind not in "biufc" or cls in ("cell", "struct", "function_handle"):
        return None
    if cls == "logical":
        data = data.astype(bool)
    return data


def _load_v73(path: Path) -> MatContents:
    import h5py

    arrays: dict[str, np.ndarray] = {}
    strings: dict[str, str] = {}
    skipped: list[str] = []
    objects: list[tuple[str, str]] = []
    try:
        with h5py.File(path, "r") as fh:
            for key, obj in fh.items():
                if key.startswith("#"):
                    continue
                try:
                    val = _h5_dataset(obj, str(path)) if isinstance(obj, h5py.Dataset) else None
                except (ValueError, TypeError, OverflowError) as exc:
                    raise DataError(f"{path}: variable {key!r} cannot be decoded: {_short(exc)}") from None
                if getattr(obj, "attrs", {}).get("MATLAB_object_decode") is not None:
                    objects.append((key, _h5_class(obj)))
                elif isinstance(val, str):
                    strings[key] = val
                elif isinstance(val, np.ndarray):
                    arrays[key] = val
                else:
                    skipped.append(key)
    except OSError as exc:
        raise DataError(f"{path}: cannot read the HDF5 (MATLAB v7.3) file ({_short(exc)})") from None
    return MatContents(str(path), arrays, strings, skipped, "7.3", objects)


def read_mat_variables(path: str | os.PathLike[str]) -> MatContents:
    """Read the numeric and char variables of a MATLAB file (v4/v5/v7 or v7.3).

    Parameters
    ----------
    path : path-like
        The ``.mat`` file.

    Raises
    ------
    DataError
        Missing file, folder, or not a MAT file.
    """
    import h5py

    p = check_readable_file(path)
    if h5py.is_hdf5(str(p)):
        return _load_v73(p)
    return _load_v5(p)  # checks the file's size and its variables' declared sizes first


# ------------------------------------------------------------------------------------------------ FRF read
def _frequency(mat: MatContents, freq_var: str | None) -> tuple[str, np.ndarray]:
    if freq_var is None:
        found = [n for n in FREQ_NAMES if n in mat.arrays]
        if not found:
            raise DataError(f"{mat.name}: no frequency variable ({', '.join(FREQ_NAMES)}); pass freq_var=NAME. "
                            f"Numeric variables: {mat.available()}", parameter="read_frf.freq_var")
        freq_var = found[0]
    f = mat.vector(freq_var, "frequency variable")
    if np.iscomplexobj(f):
        raise DataError(f"{mat.name}: frequency variable {freq_var!r} is complex; it must be real [Hz]")
    return freq_var, f.astype(float)


def _default_channels(mat: MatContents, n: int, freq_var: str) -> dict[str, str]:
    found: dict[str, str] = {}
    for var, a in mat.arrays.items():
        m = _CHANNEL_VAR_RE.match(var)
        if var == freq_var or not m or not np.iscomplexobj(a) or a.size != n or min(a.shape, default=0) > 1:
            continue
        found[f"{m.group(1)}/{m.group(2)}"] = var
    if not found:
        raise DataError(f"{mat.name}: no channel variables found; name complex vectors OUT_IN (e.g. x1_u) "
                        f"or pass channels={{'x1/u': 'VAR'}}. Numeric variables: {mat.available()}",
                        parameter="read_frf.channels")
    return found


def _sized_vector(mat: MatContents, var: str, n: int, what: str) -> np.ndarray:
    a = mat.vector(var, what)
    if a.size != n:
        raise DataError(f"{mat.name}: {what} {var!r} has {a.size} values, the frequency vector has {n}")
    return a


def _coherence_vars(mat: MatContents, channels: Mapping[str, str],
                    coherence: Mapping[str, str] | None) -> dict[str, str]:
    if coherence is not None:
        unknown = set(coherence) - set(channels)
        if unknown:
            names = ", ".join(sorted(unknown))
            raise DataError(f"{mat.name}: coherence given for unknown channel(s) {names}")
        return dict(coherence)
    out = {}
    for ch, var in channels.items():
        for cand in (ch.replace("/", "_") + "_coh", var + "_coh"):
            if cand in mat.arrays:
                out[ch] = cand
                break
    return out


def read_frf_mat(
    path: str | os.PathLike[str],
    *,
    freq_var: str | None = None,
    channels: Mapping[str, str] | None = None,
    coherence: Mapping[str, str] | None = None,
    quantity: str | None = None,
) -> Frf:
    """Read an FRF from a MATLAB file (v5 or v7.3).

    Parameters
    ----------
    path : path-like
        The ``.mat`` file.
    freq_var : str, optional
        Name of the frequency vector [Hz]; default the first of ``freq_hz``, ``f``, ``freq``, ``frequency``.
    channels : mapping of str to str, optional
        ``{"OUT/IN": variable}``, e.g. ``{"x1/u": "H_rot", "x2/u": "H_lin"}``; real vectors are accepted.
        Default: every complex vector named ``OUT_IN`` with the frequency vector's length.
    coherence : mapping of str to str, optional
        ``{"OUT/IN": variable}`` of coherence vectors [-]; default ``OUT_IN_coh`` (or ``VAR_coh``).
    quantity : {"position", "velocity", "acceleration"}, optional
        Overrides the file's ``quantity`` char variable (default position).

    Returns
    -------
    Frf
        Response in ``output_unit / input_unit`` (char variables, default rad/V).
    """
    mat = read_mat_variables(path)
    if mat.objects and not (channels or freq_var) and not any(n in mat.arrays for n in FREQ_NAMES):
        raise DataError(object_advice(mat))
    fvar, f = _frequency(mat, freq_var)
    n = f.size
    chan_vars = dict(channels) if channels else _default_channels(mat, n, fvar)
    resp = {ch: _sized_vector(mat, var, n, f"channel {ch} variable") for ch, var in chan_vars.items()}
    coh_vars = _coherence_vars(mat, chan_vars, coherence)
    coh = {ch: _sized_vector(mat, var, n, f"coherence {ch} variable").real.astype(float)
           for ch, var in coh_vars.items()}
    q = quantity if quantity is not None else mat.strings.get("quantity", "position")
    q = normalize_quantity(q, f"{mat.name}: quantity")
    meta = {"source": mat.name, "format": f"mat v{mat.version}"}
    if "source" in mat.strings:
        meta["origin"] = mat.strings["source"]
    return Frf.from_channels(f, resp, coherence=coh or None, quantity=q,
                             input_unit=mat.strings.get("input_unit", "V"),
                             output_unit=mat.strings.get("output_unit", "rad"), meta=meta)


# ----------------------------------------------------------------------------------------------- FRF write
def frf_mat_variables(frf: Frf) -> dict[str, object]:
    """The variables :func:`write_frf_mat` stores (column vectors and char values)."""
    for name in (*frf.outputs, *frf.inputs):
        if not _NAME_RE.match(name):
            raise DataError(f"{frf.source}: channel name {name!r} cannot form a MATLAB variable OUT_IN; "
                            "use letters and digits only (e.g. x1, u)")
    out: dict[str, object] = {"freq_hz": frf.freq_hz.reshape(-1, 1)}
    for i, o in enumerate(frf.outputs):
        for j, u in enumerate(frf.inputs):
            out[f"{o}_{u}"] = frf.response[i, j].reshape(-1, 1)
            if frf.coherence is not None and np.all(np.isfinite(frf.coherence[i, j])):
                out[f"{o}_{u}_coh"] = frf.coherence[i, j].reshape(-1, 1)
    out.update(quantity=frf.quantity, input_unit=frf.input_unit, output_unit=frf.output_unit,
               source=frf.source)
    return out


def write_frf_mat(frf: Frf, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """Write an FRF as a MATLAB v5 file (complex column vectors ``OUT_IN``, ``freq_hz`` [Hz]) atomically.

    Parameters
    ----------
    frf : Frf
        The response to write.
    path : path-like
        Destination ``.mat`` file.
    force : bool
        Replace an existing file.
    """
    import scipy.io

    variables = frf_mat_variables(frf)
    with atomic_output(path, force=force, suffix=".mat") as tmp:
        scipy.io.savemat(str(tmp), variables, do_compression=True, oned_as="column")
