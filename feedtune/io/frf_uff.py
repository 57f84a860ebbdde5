"""Frequency response functions as Universal File Format dataset 58 (``.uff``, ``.unv``), via pyuff.

Each channel ``OUT/IN`` is one type-58 record with function type 4 (FRF): response entity name ``OUT``,
reference entity name ``IN``, ID line 1 ``OUT/IN``, frequency abscissa (specific data type 18) and an
ordinate specific data type of 8, 11 or 12 for displacement, velocity or acceleration. A coherence is a
record with function type 6 and the same names and nodes.

ASCII precision: UFF58 stores an uneven abscissa with 6 significant digits (E13.5) and double-precision
ordinates with 12 (E20.12). Use ``binary=True`` (dataset 58b) for full double precision.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import DataError
from ..frf import Frf, normalize_quantity
from ._table import check_readable_file
from .atomic import atomic_output

FUNC_FRF = 4
FUNC_COHERENCE = 6
SPEC_FREQUENCY = 18
SPEC_BY_QUANTITY = {"position": 8, "velocity": 11, "acceleration": 12}
QUANTITY_BY_SPEC = {v: k for k, v in SPEC_BY_QUANTITY.items()}
_UNIT_SUFFIX = {"position": ("",), "velocity": ("/s",),
                "acceleration": ("/s^2", "/s2", "/s**2", "/s²", "/(s^2)")}
_ENTITY_WIDTH = 10
_LABEL_WIDTH = 20


def _is_set(text: object) -> bool:
    s = str(text or "").strip()
    return bool(s) and s.upper() != "NONE"


def _node_key(rec: Mapping[str, object]) -> str:
    return f"{rec['rsp_node']}:{rec['rsp_dir']}/{rec['ref_node']}:{rec['ref_dir']}"


def _channel_name(rec: Mapping[str, object], channels: Mapping[str, str] | None) -> str:
    """``OUT/IN`` of a record: mapping by nodes, else entity names, else ``n<node>d<dir>/n<node>d<dir>``."""
    if channels and _node_key(rec) in channels:
        return channels[_node_key(rec)]
    if _is_set(rec.get("rsp_ent_name")) and _is_set(rec.get("ref_ent_name")):
        return f"{str(rec['rsp_ent_name']).strip()}/{str(rec['ref_ent_name']).strip()}"
    return f"n{rec['rsp_node']}d{rec['rsp_dir']}/n{rec['ref_node']}d{rec['ref_dir']}"


def _position_unit(label: object, quantity: str, default: str) -> str:
    """Position unit from an ordinate units label (``m/s^2`` of an acceleration FRF gives ``m``)."""
    if not _is_set(label):
        return default
    s = str(label).strip()
    for suffix in _UNIT_SUFFIX[quantity]:
        if suffix and s.endswith(suffix) and len(s) > len(suffix):
            base = s[: -len(suffix)]
            return base[1:-1] if base.startswith("(") and base.endswith(")") else base
    return s


def _check_complete(p: Path) -> None:
    """An ASCII UFF file is a sequence of blocks, each opened and closed by a line ``-1``: an odd number of such
    lines means the file ends inside a block (pyuff then silently drops that record)."""
    with open(p, "rb") as fh:
        head = fh.read(80)
        if b"\0" in head:  # binary 58b records hold raw bytes between the delimiters: not counted
            return
        fh.seek(0)
        marks = sum(1 for line in fh if line.strip() == b"-1")
    if marks % 2:
        raise DataError(f"{p}: the file ends inside a UFF record ({marks} block delimiters '-1', an odd number): "
                        "it was cut short")


def _read_records(p: Path) -> list[dict]:
    import pyuff

    try:
        uff = pyuff.UFF(str(p))
        types = np.asarray(uff.get_set_types())
        idx = [int(k) for k in np.flatnonzero(types == 58)]
        recs = uff.read_sets(idx) if idx else []
    except Exception as exc:
        raise DataError(f"{p}: not a readable UFF file ({' '.join(str(exc).split())[:100]})") from None
    _check_complete(p)
    recs = [recs] if isinstance(recs, dict) else list(recs)
    for r in recs:
        n, got = r.get("num_pts"), len(np.atleast_1d(r.get("data", [])))
        if n is not None and int(n) != got:
            name = str(r.get("id1", "")).strip() or "?"
            raise DataError(f"{p}: record {name!r} holds {got} of its {int(n)} points: the file was cut short or "
                            "edited")
    return recs


def _quantity_of(records: list[dict], name: str) -> str:
    specs = {int(r.get("ordinate_spec_data_type", 0) or 0) for r in records}
    qs = {QUANTITY_BY_SPEC.get(s, "position") for s in specs}
    if len(qs) > 1:
        raise DataError(f"{name}: FRF records measure different quantities ({', '.join(sorted(qs))}); "
                        "read them separately or pass quantity")
    return qs.pop()


def _common_frequency(records: list[dict], name: str) -> np.ndarray:
    f = np.asarray(records[0]["x"], dtype=float)
    for r in records[1:]:
        x = np.asarray(r["x"], dtype=float)
        if x.shape != f.shape or not np.allclose(x, f, rtol=1e-9, atol=0):
            raise DataError(f"{name}: record {r.get('id1', '').strip()!r} has another frequency axis than "
                            "the first FRF record; all channels must share one grid")
    return f


def read_frf_uff(
    path: str | os.PathLike[str],
    *,
    channels: Mapping[str, str] | None = None,
    quantity: str | None = None,
) -> Frf:
    """Read the FRF records (dataset 58, function type 4) and coherences (type 6) of a UFF file.

    Parameters
    ----------
    path : path-like
        The ``.uff``/``.unv`` file (ASCII or binary 58b).
    channels : mapping of str to str, optional
        ``{"RSPNODE:RSPDIR/REFNODE:REFDIR": "OUT/IN"}``, e.g. ``{"3:1/1:1": "x2/u"}``. Records without a
        mapping use their response/reference entity names, else ``n<node>d<dir>/n<node>d<dir>``.
    quantity : {"position", "velocity", "acceleration"}, optional
        Overrides the ordinate specific data type (8, 11, 12).

    Returns
    -------
    Frf
        Frequencies [Hz]; units from the ordinate/denominator unit labels (default rad/V).
    """
    p = check_readable_file(path)
    name = str(p)
    records = _read_records(p)
    frfs = [r for r in records if int(r.get("func_type", -1)) == FUNC_FRF]
    if not frfs:
        raise DataError(f"{name}: no FRF records (dataset 58 with function type 4) in the file")
    cohs = [r for r in records if int(r.get("func_type", -1)) == FUNC_COHERENCE]
    f = _common_frequency(frfs, name)
    resp: dict[str, np.ndarray] = {}
    for r in frfs:
        ch = _channel_name(r, channels)
        if ch in resp:
            raise DataError(f"{name}: two FRF records for channel {ch!r}; map them apart with channels")
        resp[ch] = np.asarray(r["data"], dtype=complex)
    coh = {}
    for r in cohs:
        ch = _channel_name(r, channels)
        if ch in resp and np.asarray(r["data"]).size == f.size:
            coh[ch] = np.real(np.asarray(r["data"])).astype(float)
    if quantity is not None:
        q = normalize_quantity(quantity, f"{name}: quantity")
    else:
        q = _quantity_of(frfs, name)
    out_unit = _position_unit(frfs[0].get("ordinate_axis_units_lab"), q, "rad")
    in_unit = str(frfs[0]["orddenom_axis_units_lab"]).strip() if _is_set(
        frfs[0].get("orddenom_axis_units_lab")) else "V"
    meta = {"source": name, "format": "uff58"}
    return Frf.from_channels(f, resp, coherence=coh or None, quantity=q, input_unit=in_unit,
                             output_unit=out_unit, meta=meta)


# ------------------------------------------------------------------------------------------------- writer
def _check_names(frf: Frf) -> None:
    for n in (*frf.outputs, *frf.inputs):
        if len(n) > _ENTITY_WIDTH or " " in n:
            raise DataError(f"{frf.source}: channel name {n!r} does not fit a UFF entity name "
                            f"(at most {_ENTITY_WIDTH} characters, no spaces)")


def _check_ascii_grid(frf: Frf) -> None:
    rounded = np.char.mod("%.5e", frf.freq_hz).astype(float)
    if np.any(np.diff(rounded) <= 0):
        raise DataError(f"{frf.source}: the frequency grid needs more than the 6 significant digits of ASCII "
                        "UFF58; write binary UFF (58b) or CSV")


def _unit_label(unit: str, quantity: str) -> str:
    suffix = _UNIT_SUFFIX[quantity][0]
    label = f"{unit}{suffix}" if "/" not in unit or not suffix else f"({unit}){suffix}"
    return label[:_LABEL_WIDTH]


def uff_records(frf: Frf, *, binary: bool = False) -> list[dict]:
    """The pyuff dataset-58 dictionaries :func:`write_frf_uff` writes (FRF records, then coherences)."""
    _check_names(frf)
    node_base = max(100, len(frf.outputs)) + 1
    common = {
        "type": 58, "binary": int(binary), "x": frf.freq_hz.copy(), "abscissa_spacing": 0,
        "abscissa_spec_data_type": SPEC_FREQUENCY, "abscissa_axis_lab": "Frequency",
        "abscissa_axis_units_lab": "Hz", "orddenom_spec_data_type": 0,
        "orddenom_axis_units_lab": frf.input_unit[:_LABEL_WIDTH], "z_axis_spec_data_type": 0,
        "id2": " ".join(frf.source.split())[-80:] or "NONE", "id3": "NONE", "id4": "NONE", "id5": "NONE",
        "load_case_id": 0,
    }
    frf_recs, coh_recs = [], []
    for i, o in enumerate(frf.outputs):
        for j, u in enumerate(frf.inputs):
            base = dict(common, id1=f"{o}/{u}", rsp_ent_name=o, ref_ent_name=u, rsp_node=i + 1, rsp_dir=1,
                        ref_node=node_base + j, ref_dir=1, ordinate_axis_lab=o[:_LABEL_WIDTH],
                        orddenom_axis_lab=u[:_LABEL_WIDTH])
            frf_recs.append(dict(base, func_type=FUNC_FRF, func_id=len(frf_recs) + 1,
                                 data=frf.response[i, j].astype(complex),
                                 ordinate_spec_data_type=SPEC_BY_QUANTITY[frf.quantity],
                                 ordinate_axis_units_lab=_unit_label(frf.output_unit, frf.quantity)))
            if frf.coherence is not None and np.all(np.isfinite(frf.coherence[i, j])):
                coh_recs.append(dict(base, func_type=FUNC_COHERENCE, func_id=len(coh_recs) + 1,
                                     data=frf.coherence[i, j].astype(float), ordinate_spec_data_type=0,
                                     ordinate_axis_units_lab="NONE", id1=f"{o}/{u} coherence"))
    return frf_recs + coh_recs


def write_frf_uff(frf: Frf, path: str | os.PathLike[str], *, force: bool = False,
                  binary: bool = False) -> None:
    """Write an FRF as UFF dataset 58 records (ASCII by default) atomically.

    Parameters
    ----------
    frf : Frf
        The response to write (any quantity; it is stored as measured).
    path : path-like
        Destination ``.uff`` file.
    force : bool
        Replace an existing file.
    binary : bool
        Write binary dataset 58b (full double precision) instead of ASCII.
    """
    import pyuff

    records = uff_records(frf, binary=binary)
    if not binary:
        _check_ascii_grid(frf)
    with atomic_output(path, force=force) as tmp:
        try:
            pyuff.UFF(str(tmp)).write_sets(records, mode="add")
        except Exception as exc:
            raise DataError(f"{path}: writing UFF58 failed ({' '.join(str(exc).split())[:100]})") from None
