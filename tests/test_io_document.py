"""TOML/JSON documents, model files and atomic output."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest
import tomllib

from feedtune.errors import DataError, UsageError
from feedtune.io import (
    atomic_output,
    atomic_write_text,
    dumps_toml,
    ensure_writable,
    load_model,
    quantity,
    read_document,
    register_model_kind,
    require_schema,
    save_model,
    value_of,
    write_document,
)
from feedtune.models.ballscrew import THESIS_TABLE_3_1, BallScrewModel

NESTED = {
    "schema": "feedtune.gains/1",
    "title": 'quotes " and \\ backslash\nnew line, tab\t, unicode µ ω, del \x7f',
    "enabled": True,
    "count": 3,
    "big": 2**53 + 1,
    "third": 1 / 3,
    "tiny": 1e-300,
    "huge": 1.7976931348623157e308,
    "neg_zero": -0.0,
    "pos_inf": math.inf,
    "neg_inf": -math.inf,
    "grid": [0.1, 0.2, 0.30000000000000004],
    "names": ["x1", "x2"],
    "empty": [],
    "gain": quantity(0.001858, "V/(rad/s^2)"),
    "limits": [quantity(1.0, "Hz"), quantity(2.5, "Hz")],
    "sos": [[1.0, -1.9, 0.95, 1.0, -1.8, 0.81], [0.5, 0.0, -0.5, 1.0, -0.1, 0.2]],
    "x2/u": {"weight": 1.5},
    "controller": {
        "kind": "mc-ppc",
        "ts": quantity(1e-4, "s"),
        "poles": {"freq_hz": [50.0, 80.0], "zeta": [0.7, 0.5]},
        "empty_table": {},
        "notch": [
            {"freq_hz": 130.0, "depth": quantity(-20.0, "dB"), "extra": {"note": "first"}},
            {"freq_hz": 260.0, "depth": quantity(-10.0, "dB"), "stages": [{"k": 1}, {"k": 2}]},
        ],
    },
}


def test_toml_round_trip_through_tomllib_is_exact():
    text = dumps_toml(NESTED)
    back = tomllib.loads(text)
    assert back == NESTED
    assert math.copysign(1.0, back["neg_zero"]) == -1.0


def test_toml_layout_inline_quantities_and_matrix_rows():
    text = dumps_toml(NESTED)
    assert 'gain = { value = 0.001858, unit = "V/(rad/s^2)" }' in text
    rows = "\n    [1.0, -1.9, 0.95, 1.0, -1.8, 0.81],\n    [0.5, 0.0, -0.5, 1.0, -0.1, 0.2],\n"
    assert f"sos = [{rows}]" in text
    assert "[controller.poles]" in text and "[[controller.notch]]" in text
    assert '["x2/u"]' in text
    assert "pos_inf = inf" in text and "neg_inf = -inf" in text


def test_toml_nan_none_numpy_values():
    doc = {"a": float("nan"), "b": None, "c": np.float64(2.5), "d": np.arange(3),
           "e": {"f": None, "g": (1, 2)}}
    back = tomllib.loads(dumps_toml(doc))
    assert math.isnan(back["a"]) and "b" not in back and back["c"] == 2.5
    assert back["d"] == [0, 1, 2] and back["e"] == {"g": [1, 2]}
    with pytest.raises(DataError, match=r"x\[1\] is None"):
        dumps_toml({"x": [1.0, None]})


def test_write_document_toml_and_json_twin(tmp_path):
    paths = write_document(tmp_path / "g.toml", NESTED)
    assert [p.name for p in paths] == ["g.toml", "g.json"]
    raw_json = (tmp_path / "g.json").read_text()
    assert json.loads(raw_json)["pos_inf"] == "inf" and "Infinity" not in raw_json
    assert read_document(tmp_path / "g.toml") == NESTED
    assert read_document(tmp_path / "g.json") == NESTED
    write_document(tmp_path / "only.json", {"schema": "x/1", "v": quantity(2.0, "m")})
    assert not (tmp_path / "only.toml").exists()
    assert read_document(tmp_path / "only.json")["v"] == {"value": 2.0, "unit": "m"}


def test_write_document_both_or_neither(tmp_path):
    (tmp_path / "g.json").write_text("{}")
    with pytest.raises(UsageError, match=r"g\.json exists; pass force=True"):
        write_document(tmp_path / "g.toml", {"a": 1})
    assert not (tmp_path / "g.toml").exists()
    write_document(tmp_path / "g.toml", {"a": 1}, force=True)
    assert read_document(tmp_path / "g.json") == {"a": 1} == read_document(tmp_path / "g.toml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.json", "g.toml"]


def test_read_document_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('a = 1\nb = "open\n')
    with pytest.raises(DataError, match=r"bad\.toml: TOML syntax error.*line 2"):
        read_document(bad)
    badj = tmp_path / "bad.json"
    badj.write_text('{\n  "a": 1,\n  "b": \n}')
    with pytest.raises(DataError, match=r"bad\.json: JSON syntax error at line 4"):
        read_document(badj)
    with pytest.raises(DataError, match=r"nope\.toml: file not found"):
        read_document(tmp_path / "nope.toml")
    with pytest.raises(DataError, match=r"expected \.toml or \.json"):
        read_document(tmp_path / "x.yaml")


def test_value_of_and_require_schema():
    assert value_of(2.0) == 2.0
    assert value_of(quantity(3.0, "m"), "m") == 3.0
    assert value_of(4, "m") == 4.0
    assert value_of({"value": "inf", "unit": "Hz"}, "Hz", finite=False) == math.inf
    with pytest.raises(DataError, match=r"m.toml: fs: expected a finite number, got inf"):
        value_of({"value": "inf", "unit": "Hz"}, "Hz", "m.toml: fs")
    with pytest.raises(DataError, match=r"m.toml: k: integer with 400 digits, beyond the range of a float"):
        value_of(10**399, where="m.toml: k")
    with pytest.raises(DataError, match=r"m.toml: params.k: unit 'N/m' where 'V/rad' is expected"):
        value_of(quantity(1.0, "N/m"), "V/rad", "m.toml: params.k")
    with pytest.raises(DataError, match="expected a number"):
        value_of("ten", where="x")
    assert require_schema({"schema": "feedtune.model/1.3"}, "feedtune.model", "m.toml") == (1, 3)
    newer = r"m\.toml: feedtune\.model/2 comes from a newer feedtune; this feedtune reads feedtune\.model/1"
    with pytest.raises(DataError, match=newer):
        require_schema({"schema": "feedtune.model/2"}, "feedtune.model", "m.toml")
    with pytest.raises(DataError, match=r"this is a gains file, .*\(feedtune\.gains\); expected a model file"):
        require_schema({"schema": "feedtune.gains/1"}, "feedtune.model", "m.toml")
    with pytest.raises(DataError, match="no 'schema' entry"):
        require_schema({}, "feedtune.model", "m.toml")


# ------------------------------------------------------------------------------------------ model files
def test_model_round_trip_with_thesis_table_values(tmp_path):
    fit = {"band_hz": [10.0, 400.0], "rms_error": quantity(0.03, "dB"), "channels": ["x1/u", "x2/u"]}
    save_model(tmp_path / "bs.toml", THESIS_TABLE_3_1, fit=fit)
    text = (tmp_path / "bs.toml").read_text()
    # Table 3.1 of the thesis, written with the unit of each parameter
    assert 'm1 = { value = 0.001858, unit = "V/(rad/s^2)" }' in text
    assert 'k = { value = 210.02, unit = "V/rad" }' in text
    assert 'c = { value = 0.014, unit = "V/(rad/s)" }' in text
    for path in (tmp_path / "bs.toml", tmp_path / "bs.json"):
        model = load_model(path)
        assert model == THESIS_TABLE_3_1
    doc = read_document(tmp_path / "bs.toml")
    assert doc["schema"] == "feedtune.model/1" and doc["kind"] == "ballscrew" and doc["fit"] == fit
    # axial mode of Table 3.1: sqrt(k (m1 + m2) / (m1 m2)) / (2 pi) ~ 130 Hz
    m1, m2, k = 1.858e-3, 0.379e-3, 210.02
    undamped = math.sqrt(k * (m1 + m2) / (m1 * m2)) / (2 * math.pi)
    assert doc["modes"][0]["freq_hz"] == pytest.approx(undamped, rel=2e-3)


def test_model_input_unit_changes_parameter_units(tmp_path):
    m = BallScrewModel(m1=95.0, m2=10.0, b1=200.0, b2=0.0, k=1e6, c=50.0, lead_m_per_rad=1e-3, input_unit="N")
    save_model(tmp_path / "n.json", m)
    assert read_document(tmp_path / "n.json")["params"]["m1"]["unit"] == "N/(rad/s^2)"
    assert load_model(tmp_path / "n.json") == m


@pytest.mark.parametrize(
    ("edit", "fragment"),
    [
        (lambda d: d.update(kind="gantry-x"), "kind = 'gantry-x' is not a known model kind"),
        (lambda d: d["params"].pop("k"), "params.k is missing"),
        (lambda d: d["params"].update(b1=-1.0), "params.b1 = -1 must be finite and >= 0"),
        (lambda d: d["params"].update(m2=0.0), "params.m2 = 0 must be finite and > 0"),
        (lambda d: d["params"]["k"].update(unit="N/m"), "params.k: unit 'N/m'"),
        (lambda d: d.update(schema="feedtune.model/7"), "feedtune.model/7 comes from a newer feedtune"),
        (lambda d: d.pop("params"), "missing [params]"),
    ],
)
def test_model_errors_name_file_and_key(tmp_path, edit, fragment):
    save_model(tmp_path / "m.json", THESIS_TABLE_3_1)
    doc = read_document(tmp_path / "m.json")
    edit(doc)
    write_document(tmp_path / "bad.json", doc)
    with pytest.raises(DataError) as err:
        load_model(tmp_path / "bad.json")
    assert "bad.json" in str(err.value) and fragment in str(err.value)


def test_gantry_kind_registered_on_first_use(tmp_path):
    from feedtune.models.gantry import GantryModel

    model = GantryModel(m=30.0, L=0.8, J0=2.0, d=0.1, m_x=10.0, c=50.0, k=2e6, alpha1_0=0.4)
    save_model(tmp_path / "g.toml", model)
    assert 'kind = "gantry"' in (tmp_path / "g.toml").read_text()
    assert load_model(tmp_path / "g.json") == model


def test_register_model_kind(tmp_path, monkeypatch):
    from feedtune.io import model_file

    monkeypatch.setattr(model_file, "_REGISTRY", dict(model_file._REGISTRY))  # the test's kind leaves with it

    @dataclass(frozen=True)
    class RigidBody:
        mass: float

    register_model_kind("rigid-test", lambda doc, where: RigidBody(value_of(doc["mass"], "kg", where)),
                        lambda model: {"mass": quantity(model.mass, "kg")}, RigidBody)
    save_model(tmp_path / "r.toml", RigidBody(2.5))
    assert 'kind = "rigid-test"' in (tmp_path / "r.toml").read_text()
    assert load_model(tmp_path / "r.toml") == RigidBody(2.5)
    with pytest.raises(DataError, match="no model kind is registered"):
        save_model(tmp_path / "x.toml", object())


# --------------------------------------------------------------------------------------------- atomic
def test_atomic_output_leaves_nothing_on_failure(tmp_path):
    dest = tmp_path / "out.mat"
    with pytest.raises(RuntimeError), atomic_output(dest) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".mat" and tmp.exists()
        tmp.write_bytes(b"half")
        raise RuntimeError("writer crashed")
    assert list(tmp_path.iterdir()) == []
    atomic_write_text(dest, "old")
    with pytest.raises(RuntimeError), atomic_output(dest, force=True) as tmp:
        tmp.write_text("new, half")
        raise RuntimeError("writer crashed")
    assert dest.read_text() == "old" and list(tmp_path.iterdir()) == [dest]


def test_atomic_write_refuses_overwrite_and_missing_folder(tmp_path):
    p = tmp_path / "a.txt"
    atomic_write_text(p, "one")
    with pytest.raises(UsageError, match=r"a\.txt exists; pass force=True to overwrite"):
        atomic_write_text(p, "two")
    assert p.read_text() == "one"
    atomic_write_text(p, "two", force=True)
    assert p.read_text() == "two"
    with pytest.raises(DataError, match="does not exist"):
        ensure_writable(tmp_path / "no" / "a.txt", force=True)
    with pytest.raises(DataError, match="is a folder"):
        ensure_writable(tmp_path, force=True)
