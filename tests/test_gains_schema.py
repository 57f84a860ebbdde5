"""Gains documents are validated before anything executes, analyses or exports them (issue 14).

Each deliberately broken document of the issue's list, for every gains kind, is refused by ``export c``
(:func:`c_header`), the analysis (:func:`analyze_gains`) and the runtime (:func:`load_runtime`) with the same one-line
:class:`DataError` naming the key; from the command line ``export c``, ``analyze`` and ``simulate`` give that line
with exit 1. Before, these documents were exported, analysed with exit 0, allocated until killed (a preview of 1e9
samples) or ended as "internal error". The schemas themselves are checked against the JSON Schema meta-schema, and
every document feedtune writes passes them.
"""

from __future__ import annotations

import copy

import pytest
from test_cli import run
from test_export_c_kinds import AXIS, BALLSCREW, MIMO, PID

from feedtune.errors import DataError
from feedtune.export.c_header import c_header
from feedtune.io import write_document
from feedtune.io.gains_schema import SCHEMAS, gains_schema, validate_gains
from feedtune.machines import analyze_gains, load_runtime

DOCS = {"ballscrew": BALLSCREW, "mimo": MIMO, "pid": PID, "axis": AXIS}
SOS = {"ballscrew": "filter_pack_sos", "mimo": "filter_pack_sos", "pid": "filter_pack_sos", "axis": "controller_sos"}


def _set(path, value):
    def edit(d):
        node = d
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
    return edit


def _pop(path):
    def edit(d):
        node = d
        for k in path[:-1]:
            node = node[k]
        node.pop(path[-1])
    return edit


def _unstable_section(name):
    def edit(d):
        d["filters"][SOS[name]][0][3:] = [1.0, -2.5, 1.5]  # poles at 1 and 1.5
    return edit


def _nan_coefficient(name):
    def edit(d):
        d["filters"][SOS[name]][0][0] = float("nan")
    return edit


CASES = {
    "fs 0": (lambda n: _set(["sampling", "fs_hz", "value"], 0.0), "sampling.fs_hz: must be > 0, got 0.0"),
    "fs negative": (lambda n: _set(["sampling", "fs_hz", "value"], -2e4), "sampling.fs_hz: must be > 0"),
    "delay -1": (lambda n: _set(["sampling", "delay_samples"], -1), "sampling.delay_samples: must be >= 0, got -1"),
    "delay inf": (lambda n: _set(["sampling", "delay_samples"], float("inf")),
                  "sampling.delay_samples: value must be a finite number, got inf"),
    "delay 'one'": (lambda n: _set(["sampling", "delay_samples"], "one"),
                    "sampling.delay_samples: expected an integer, got 'one'"),
    "preview 1e9": (lambda n: _set(["sampling", "preview_samples"], 10**9), "sampling.preview_samples: must be <="),
    "preview nan": (lambda n: _set(["sampling", "preview_samples"], float("nan")),
                    "sampling.preview_samples: value must be a finite number"),
    "gains = 5": (lambda n: _set(["gains"], 5), "gains: expected a table, got 5"),
    "sampling string": (lambda n: _set(["sampling"], "20kHz"), "sampling: expected a table, got '20kHz'"),
    "model = [1]": (lambda n: _set(["model"], [1]), "model: expected a table, got [1]"),
    "units = V": (lambda n: _set(["units"], "V"), "units: expected a table, got 'V'"),
    "no filter sections": (lambda n: _pop(["filters", SOS[n]]), "is missing"),
    "empty filter list": (lambda n: _set(["filters", SOS[n]], []), "expected at least 1 entry"),
    "nan coefficient": (_nan_coefficient, "value must be a finite number, got nan"),
    "unstable section": (_unstable_section, "section is unstable"),
    "400-digit integer": (lambda n: _set(["sampling", "delay_samples"], 10**400), "integer with 401 digits"),
    "kind list": (lambda n: _set(["kind"], ["ballscrew"]), "kind ['ballscrew'] unknown"),
    "bad notch list": (lambda n: _set(["filters", "continuous", "notches"], "bad"),
                       "filters.continuous.notches: expected a list, got 'bad'"),
}


def _broken(name, case):
    doc = copy.deepcopy(DOCS[name])
    CASES[case][0](name)(doc)
    return doc


@pytest.mark.parametrize("name", list(DOCS))
@pytest.mark.parametrize("case", list(CASES))
def test_every_broken_document_is_refused_with_the_same_line_everywhere(name, case):
    doc = _broken(name, case)
    messages = []
    for fn in (lambda d: c_header(d, where="g.toml"), lambda d: analyze_gains(d, "g.toml"),
               lambda d: load_runtime(d, "g.toml")):
        with pytest.raises(DataError) as err:
            fn(doc)
        messages.append(str(err.value))
    assert len(set(messages)) == 1, messages
    assert CASES[case][1] in messages[0]
    assert messages[0].startswith("g.toml: ") and "\n" not in messages[0]


@pytest.mark.parametrize("name", list(DOCS))
def test_documents_feedtune_writes_pass_and_the_schemas_are_valid_json_schemas(name):
    import jsonschema

    assert validate_gains(DOCS[name], "g.toml") == DOCS[name]["kind"]
    for kind in SCHEMAS:
        jsonschema.Draft202012Validator.check_schema(gains_schema(kind))


@pytest.mark.parametrize("case", ["nan coefficient", "unstable section", "delay -1", "400-digit integer"])
def test_a_document_found_valid_once_is_still_refused_after_an_edit(case):
    """Validation remembers valid documents by content: the same document edited in place is checked again, and
    the remembered answer of an equal copy is the kind."""
    doc = copy.deepcopy(DOCS["mimo"])
    assert validate_gains(doc, "g.toml") == "gantry"
    assert validate_gains(copy.deepcopy(doc), "h.toml") == "gantry"
    CASES[case][0]("mimo")(doc)
    for where in ("g.toml", "h.toml"):
        with pytest.raises(DataError, match=f"^{where}: "):
            validate_gains(doc, where)


def test_an_integrator_is_allowed_only_in_the_axis_controller():
    axis = copy.deepcopy(AXIS)
    assert any(abs(s[3] + s[4] + s[5]) < 1e-9 for s in axis["filters"]["controller_sos"])  # its PI has z = 1
    validate_gains(axis, "axis.toml")
    mimo = copy.deepcopy(MIMO)
    mimo["filters"]["filter_pack_sos"][0][3:] = [1.0, -1.0, 0.0]  # an integrator in a filter pack
    with pytest.raises(DataError, match=r"filters.filter_pack_sos\[0\]: section is unstable"):
        validate_gains(mimo, "mimo.toml")


@pytest.mark.parametrize("case", ["delay -1", "preview 1e9", "unstable section", "400-digit integer"])
def test_the_commands_give_the_same_line_and_exit_1(case, tmp_path, capsys, monkeypatch):
    path = tmp_path / "g.toml"
    write_document(path, _broken("ballscrew", case))
    lines = set()
    for args in (["export", "c", path, "-o", tmp_path / "g.h"], ["analyze", path],
                 ["simulate", "ropesnap", "-g", path, "-o", tmp_path / "r.csv"]):
        code, _, err = run(args, capsys, monkeypatch)
        assert code == 1 and err.count("\n") == 1, (args, err)
        lines.add(err.replace(str(tmp_path) + "/", ""))
    assert len(lines) == 1, lines
    assert not (tmp_path / "g.h").exists() and not (tmp_path / "r.csv").exists()


# ------------------------------------------------------------------ model and mass documents
@pytest.mark.parametrize("edit, words", [
    (lambda d: d.update(kind=["ballscrew"]), "is not a known model kind"),
    (lambda d: d["params"]["m1"].update(value=10**400), "params.m1.value: integer with 401 digits"),
    (lambda d: d["params"]["k"].update(value=float("inf")), "params.k.value: value must be a finite number"),
])
def test_broken_model_documents_are_one_line_data_errors(edit, words, tmp_path):
    """Before: TypeError (unhashable kind) and OverflowError (a 400-digit integer) as internal errors."""
    import json
    import re

    from feedtune.io import load_model, model_document
    from feedtune.models import THESIS_TABLE_3_1

    doc = model_document(THESIS_TABLE_3_1)
    edit(doc)
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc, allow_nan=True))
    with pytest.raises(DataError, match=re.escape(words)):
        load_model(path)


def test_model_schemas_refuse_values_outside_their_physical_range(tmp_path):
    """A Stribeck level with the wrong sign (the issue's mirrored fit wrote ds_pos = -108 N and load_model took it),
    a mass distribution outside (0, 1) and a negative mass in a mass file are refused, naming the key; the model
    schemas are valid JSON Schemas and accept what feedtune writes."""
    import json

    import jsonschema

    from feedtune.io import load_model, model_document, save_model
    from feedtune.io.mass_file import read_mass_document
    from feedtune.io.model_schema import MODEL_SCHEMAS, model_schema
    from feedtune.models.friction import StribeckFriction
    from feedtune.models.gantry import THESIS_GANTRY

    for kind in [*MODEL_SCHEMAS, "mass"]:
        jsonschema.Draft202012Validator.check_schema(model_schema(kind))
    friction = StribeckFriction(20.0, 25.0, -19.0, -24.0, 0.01, command_unit="N", velocity_unit="m/s")
    save_model(tmp_path / "f.toml", friction)
    assert load_model(tmp_path / "f.toml") == friction
    doc = model_document(friction)
    doc["params"]["ds_pos"]["value"] = -108.0
    (tmp_path / "bad_f.json").write_text(json.dumps(doc))
    with pytest.raises(DataError, match=r"params\.ds_pos: must be >= 0, got -108"):
        load_model(tmp_path / "bad_f.json")
    doc = model_document(THESIS_GANTRY)
    doc["params"]["alpha1_0"]["value"] = 1.5
    (tmp_path / "bad_g.json").write_text(json.dumps(doc))
    with pytest.raises(DataError, match=r"alpha1_0 must lie in \(0, 1\), got 1\.5"):  # the loader's own check
        load_model(tmp_path / "bad_g.json")
    mass = {"schema": "feedtune.mass/1", "kind": "gantry_mass", "input_unit": "V",
            "m": {"value": -2.7, "unit": "V/(m/s^2)"}, "alpha1_0": {"value": 0.5, "unit": "-"},
            "dalpha1_dx": {"value": -0.17, "unit": "1/m"}}
    (tmp_path / "mass.json").write_text(json.dumps(mass))
    with pytest.raises(DataError, match=r"mass\.json: m: must be > 0"):
        read_mass_document(tmp_path / "mass.json")
