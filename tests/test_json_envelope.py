"""The one ``--json`` envelope of every command (docs/json.md), checked against ``feedtune/schemas/<kind>.json``.

Every command runs with ``--json`` on the bundled examples (``examples/``, ``tests/fixtures``) from a scratch folder
that holds a copy of them, so paths are given as a user types them from the repository root; its output must validate
against the JSON Schema of its ``kind``. A script-style test then reads ``params``/``gains``, ``warnings`` and
``check`` across the identify, design, tune and analyze commands the one way docs/json.md describes, and compares the
numbers with independent references (Table 3.1, the gantry twin, the P-PI law, the analysis it checks).
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import sys
from pathlib import Path

import jsonschema
import pytest
from cli_run import run

from feedtune.cli.envelope import SCHEMA_DIALECT, SUBKIND_ARGUMENT, load_schema
from feedtune.cli.main import main
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.gantry import THESIS_GANTRY

REPO = Path(__file__).resolve().parents[1]
SCHEMAS = REPO / "feedtune" / "schemas"
FILTERS = ["--notch", "420,0.55,0.7", "--notch", "1080,0.05,0.7", "--lpf", "2000"]
GANTRY_FRFS = ["examples/gantry_frf_x-0.3.csv", "examples/gantry_frf_x0.csv", "examples/gantry_frf_x0.3.csv",
               "--x", "-0.3", "--x", "0", "--x", "0.3", "--span", "1.484"]
REVERSALS = ["examples/ballscrew_reversals.csv", "--position", "x2"]
TOP = ("kind", "feedtune_version", "inputs", "warnings")


# ------------------------------------------------------------------------------------------ the scratch folder
def _main(args: list) -> str:
    """``feedtune ARGS`` in-process (module fixtures have no capsys); its stdout. Fails on a non-zero exit."""
    out, err = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        mp.setattr(sys, "argv", ["feedtune", *map(str, args)])
        try:
            main()
        except SystemExit as exc:
            assert not exc.code, f"feedtune {' '.join(map(str, args))}: {err.getvalue()}"
    return out.getvalue()


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    """A folder with a copy of examples/ and tests/fixtures and the files the later commands read (model, gains,
    logs), written by the commands themselves, and a one-way stretch of the reversals log."""
    d = tmp_path_factory.mktemp("envelope")
    shutil.copytree(REPO / "examples", d / "examples", ignore=shutil.ignore_patterns("*.py", "*.sh", "*.mat", "*.uff"))
    shutil.copytree(REPO / "tests" / "fixtures", d / "tests" / "fixtures")
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(d)
        for args in (
            ["identify", "ballscrew", "examples/ballscrew_frf.csv", "--out", "model.toml"],
            ["design", "ppc", "model.toml", "--beta", "4", "--pole-hz", "50", "--zeta", "0.7", *FILTERS,
             "--out", "mcppc.toml"],
            ["identify", "rigid", *REVERSALS, "--velocity-threshold", "3", "--out", "rigid.toml"],
            ["identify", "gantry", *GANTRY_FRFS, "--out", "gantry.toml"],
            ["design", "gantry", "gantry.toml", "--out", "mimo.toml"],
            ["design", "loopshape", "gantry.toml", "--crossover-hz", "130", "--pm-deg", "35", "--out", "axis.toml"],
            ["simulate", "frf", "--out", "excitation.csv", "--period", "0.1", "--periods", "2", "--f-lo", "10"],
            ["simulate", "gantry", "mass", "--out", "mass.csv", "--x", "-0.3", "--x", "0.3"],
            ["log", "convert", "examples/ballscrew_track.csv", "--keep", "x_ref", "--out", "ref.csv"],
            ["log", "convert", "examples/ballscrew_track.csv", "--keep", "u", "--out", "u.csv"],
            ["fleet", "simulate", "fleet", "--axes", "2", "--weeks", "3", "--drift-share", "0"],
            ["fleet", "run", "fleet/fleet.toml", "--history", "history.parquet", "--jobs", "1"],
            ["design", "shaper", "--mode", "52.6,0.1", "--shaper", "zv", "--out", "x_shaper.toml"],
            ["design", "cascade", "examples/vendor/auto_servo_tuning.xml", "--drive-tuning",
             "examples/vendor/auto_servo_tuning.xml", "--kv", "50", "--out", "cascade.toml"],
            ["export", "drive", "sinamics", "cascade.toml", "--torque-constant", "1.2", "--out", "cascade.txt"],
        ):
            _main(args)
    from feedtune.io import read_log, write_log_csv
    from feedtune.log import Log

    log = read_log(d / "examples" / "ballscrew_reversals.csv")  # two moves forward (0.6 and 16 rad/s), no return
    window = (log.t >= 1.9) & (log.t <= 3.0)
    write_log_csv(Log(log.t[window], {k: log[k][window] for k in log.signals}, log.units, log.meta),
                  d / "one_way.csv")
    return d


# ------------------------------------------------------------------------------------------ every command
CASES = {  # id: (kind, arguments); each runs in well under 5 s
    "identify ballscrew": ("identify.ballscrew", ["identify", "ballscrew", "examples/ballscrew_frf.csv"]),
    "identify ballscrew vendor": ("identify.ballscrew", ["identify", "ballscrew", "examples/vendor/bode_db.csv",
                                                         "--no-delay"]),
    "identify rigid": ("identify.rigid", ["identify", "rigid", *REVERSALS, "--velocity-threshold", "3"]),
    "identify friction model": ("identify.friction", ["identify", "friction", *REVERSALS, "--model", "rigid.toml",
                                                      "--min-speed", "0.1"]),
    "identify friction joint": ("identify.friction", ["identify", "friction", *REVERSALS, "--min-speed", "0.1"]),
    "identify friction steady-state": ("identify.friction", ["identify", "friction", *REVERSALS, "--steady-state"]),
    "identify friction one direction": ("identify.friction", ["identify", "friction", "one_way.csv", "--position",
                                                              "x2"]),
    "identify gantry": ("identify.gantry", ["identify", "gantry", *GANTRY_FRFS]),
    "identify mass": ("identify.mass", ["identify", "mass", "mass_x-0.3.csv", "mass_x0.3.csv", "--x", "-0.3",
                                        "--x", "0.3", "--axis-log", "mass_axis.csv"]),
    "identify resonances": ("identify.resonances", ["identify", "resonances",
                                                    "examples/vendor/klipper_calibration_data_x.csv"]),
    "frf merge": ("frf.merge", ["frf", "merge", "examples/vendor/motor_bode.csv:x1/u",
                                "examples/vendor/load_bode.csv:x2/u,scale=-1", "--out", "merged.csv", "--force"]),
    "frf info": ("frf.info", ["frf", "info", "examples/vendor/auto_servo_tuning.xml"]),
    "log resample": ("log.resample", ["log", "resample", "examples/ballscrew_reversals.csv", "--fs", "250", "--out",
                                      "resampled.csv", "--force"]),
    "frf": ("frf.estimate", ["frf", "excitation.csv", "--input", "u", "--output", "x1,x2", "--reference", "r",
                    "--method", "periodic"]),
    "design ppc allow-unstable": ("design.ppc", ["design", "ppc", "model.toml", "--beta", "4", "--pole-hz", "50",
                                                 "--zeta", "0.7", *FILTERS, "--frf", "examples/ballscrew_frf.csv",
                                                 "--allow-unstable"]),
    "design ppi": ("design.ppi", ["design", "ppi", "model.toml", "--kpx", "60", "--kpv", "0.3", "--kiv", "20"]),
    "design gantry": ("design.gantry", ["design", "gantry", "gantry.toml"]),
    "design pid": ("design.pid", ["design", "pid", "gantry.toml", "--kp", "1e5", "--kd", "500", "--ki", "1e6"]),
    "design loopshape": ("design.loopshape", ["design", "loopshape", "gantry.toml", "--crossover-hz", "130",
                                              "--pm-deg", "35"]),
    "design cascade": ("design.cascade", ["design", "cascade", "examples/vendor/auto_servo_tuning.xml",
                                          "--drive-tuning", "examples/vendor/auto_servo_tuning.xml"]),
    "tune mcppc": ("tune.mcppc", ["tune", "mcppc", "model.toml", *FILTERS]),
    "tune cascade": ("tune.cascade", ["tune", "cascade", "rigid.toml"]),
    "tune ppi": ("tune.ppi", ["tune", "ppi", "model.toml", "--frf", "examples/ballscrew_frf_m70.csv", *FILTERS]),
    "tune pid": ("tune.pid", ["tune", "pid", "gantry.toml", "--filters", "identical", "--notch", "110,0.5,0.7",
                              "--lpf", "450"]),
    "analyze ballscrew": ("analyze.gains", ["analyze", "mcppc.toml", "--frf", "examples/ballscrew_frf.csv"]),
    "analyze gantry": ("analyze.gains", ["analyze", "gains", "mimo.toml"]),
    "analyze axis": ("analyze.gains", ["analyze", "axis.toml", "--check"]),
    "analyze track": ("analyze.track", ["analyze", "track", "examples/ballscrew_track.csv"]),
    "analyze ropesnap": ("analyze.ropesnap", ["analyze", "ropesnap", "examples/ballscrew_ropesnap.csv"]),
    "prefilter": ("prefilter", ["prefilter", "examples/ballscrew_track.csv", "--gains", "mcppc.toml",
                                "--out", "mcppc_pf.toml", "--force"]),
    "export c": ("export.c", ["export", "c", "mcppc.toml", "--out", "mcppc.h", "--force"]),
    "export klipper": ("export.klipper", ["export", "klipper", "x_shaper.toml"]),
    "export marlin": ("export.marlin", ["export", "marlin", "x_shaper.toml", "--out", "x.gcode", "--force"]),
    "export drive": ("export.drive", ["export", "drive", "sinamics", "cascade.toml", "--torque-constant", "1.2",
                                      "--frf", "examples/vendor/auto_servo_tuning.xml", "--out", "s.txt", "--force"]),
    "import drive": ("import.drive", ["import", "drive", "sinamics", "cascade.txt", "--command-unit", "A",
                                      "--torque-constant", "1.2", "--out", "back.toml", "--force"]),
    "export linuxcnc": ("export.linuxcnc", ["export", "linuxcnc", "mcppc.toml", "--out", "ft.c", "--force"]),
    "design shaper psd": ("design.shaper", ["design", "shaper", "--psd",
                                            "examples/vendor/klipper_calibration_data_x.csv"]),
    "design shaper modes": ("design.shaper", ["design", "shaper", "--mode", "98.8,0.045", "--mode", "137,0.068",
                                              "--fs", "20000"]),
    "report": ("report", ["report", "model.toml", "mcppc.toml", "examples/ballscrew_frf.csv", "--out",
                          "report.html", "--force"]),
    "trajectory": ("trajectory", ["trajectory", "--distance", "0.005", "--v-max", "0.1", "--a-max", "5",
                                  "--j-max", "500", "--out", "traj.csv", "--force"]),
    "simulate frf": ("simulate.frf", ["simulate", "frf", "--out", "sim_frf.csv", "--period", "0.1", "--periods",
                                      "2", "--f-lo", "10", "--force"]),
    "simulate track": ("simulate.track", ["simulate", "track", "--gains", "mcppc.toml", "--distance", "0.002",
                                          "--out", "sim_track.csv", "--force"]),
    "simulate ropesnap": ("simulate.ropesnap", ["simulate", "ropesnap", "--gains", "mcppc.toml", "--t-release",
                                                "0.2", "--after", "0.1", "--out", "sim_rope.csv", "--force"]),
    "simulate cut": ("simulate.cut", ["simulate", "cut", "--gains", "mcppc.toml", "--cut-length", "0.005",
                                      "--speed", "0.1", "--out", "sim_cut.csv", "--force"]),
    "simulate gantry frf": ("simulate.gantry.frf", ["simulate", "gantry", "frf", "--x", "0", "--periods", "2",
                                                    "--out", "g_frf.csv", "--force"]),
    "simulate gantry axis-frf": ("simulate.gantry.axis-frf", ["simulate", "gantry", "axis-frf", "--out",
                                                              "g_axis_frf.csv", "--force"]),
    "simulate gantry mass": ("simulate.gantry.mass", ["simulate", "gantry", "mass", "--x", "-0.3", "--x", "0.3",
                                                      "--out", "g_mass.csv", "--force"]),
    "simulate gantry track": ("simulate.gantry.track", ["simulate", "gantry", "track", "--gains", "mimo.toml",
                                                        "--out", "g_track.csv", "--force"]),
    "log convert": ("log.convert", ["log", "convert", "tests/fixtures/vendor_daq_preamble.csv", "--skip-rows", "4",
                                    "--time", "col0", "--map", "force=col1", "--map", "input=col3", "--scale",
                                    "force=-200", "--keep", "force,input", "--out", "daq.csv", "--force"]),
    "log merge": ("log.merge", ["log", "merge", "ref.csv", "u.csv", "--out", "merged.csv", "--force"]),
    "fleet simulate": ("fleet.simulate", ["fleet", "simulate", "fleet_1", "--axes", "1", "--weeks", "2", "--force"]),
    "fleet run": ("fleet.run", ["fleet", "run", "fleet/fleet.toml", "--history", "history.parquet", "--jobs", "1"]),
    "fleet report": ("fleet.report", ["fleet", "report", "fleet/fleet.toml", "--history", "history.parquet", "--jobs",
                                      "1", "--out", "fleet.html", "--force"]),
    "project init": ("project.init", ["project", "init", "--model", "model.toml", "--frf",
                                      "examples/ballscrew_frf_m70.csv", "--gains", "g.toml", "--structure", "mcppc",
                                      "--out", "project.toml", "--force"]),
}
SLOW_CASES = {  # more than 5 s each (the gantry rope snap: compiling its closed loop)
    "warmup": ("warmup", ["warmup"]),
    "simulate gantry ropesnap": ("simulate.gantry.ropesnap", ["simulate", "gantry", "ropesnap", "--gains",
                                                              "mimo.toml", "--t-release", "0.2", "--after", "0.1",
                                                              "--out", "g_rope.csv", "--force"]),
    "tune gantry": ("tune.gantry", ["tune", "gantry", "gantry.toml", "--notch", "110,0.5,0.7", "--lpf", "450",
                                    "--lead", "154,70"]),
    "tune loopshape": ("tune.loopshape", ["tune", "loopshape", "gantry.toml"]),
    "simulate gantry contour": ("simulate.gantry.contour", ["simulate", "gantry", "contour", "--gains", "mimo.toml",
                                                            "--axis-gains", "axis.toml", "--out", "g_contour.csv",
                                                            "--force"]),
    "demo ballscrew": ("demo.ballscrew", ["demo", "--out", "demo_ballscrew", "--force"]),
    "demo gantry": ("demo.gantry", ["demo", "gantry", "--out", "demo_gantry", "--force"]),
}


def run_json(args: list, capsys, monkeypatch) -> dict:
    """``feedtune ARGS --json``: exit 0, stdout one JSON object."""
    code, out, err = run([*args, "--json"], capsys, monkeypatch)
    assert code == 0, err
    return json.loads(out)


def check_envelope(kind: str, args: list, work: Path, capsys, monkeypatch) -> dict:
    monkeypatch.chdir(work)
    doc = run_json(args, capsys, monkeypatch)
    assert doc["kind"] == kind
    assert list(doc)[:3] == ["kind", "feedtune_version", "inputs"] and all(k in doc for k in TOP)
    jsonschema.Draft202012Validator(load_schema(kind)).validate(doc)
    given = [a for a in args if isinstance(a, str) and (a.startswith("examples/") or a.startswith("tests/"))]
    inputs = json.dumps(doc["inputs"])
    for path in given:  # every input file appears in inputs as given (relative, not resolved)
        assert json.dumps(path) in inputs, (path, doc["inputs"])
    assert "json" not in doc["inputs"] and "force" not in doc["inputs"] and "out" not in doc["inputs"]
    return doc


@pytest.mark.parametrize("case", sorted(CASES))
def test_every_command_prints_one_envelope_valid_against_its_schema(case, work, capsys, monkeypatch):
    kind, args = CASES[case]
    check_envelope(kind, args, work, capsys, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(SLOW_CASES))
def test_long_commands_print_one_envelope_valid_against_its_schema(case, work, capsys, monkeypatch):
    kind, args = SLOW_CASES[case]
    check_envelope(kind, args, work, capsys, monkeypatch)


# ------------------------------------------------------------------------------------------ the schemas
def _leaf_commands() -> list[str]:
    """Every ``feedtune`` command with a ``--json`` option, as a kind (``tune`` and ``demo`` by what they run)."""
    import typer

    from feedtune.cli.main import app
    from feedtune.cli.tune_cmd import TITLES
    from feedtune.machines import machine_names

    def walk(cmd, path):
        subs = getattr(cmd, "commands", None)
        if subs:
            for name, sub in subs.items():
                yield from walk(sub, [*path, name])
        elif any("--json" in getattr(p, "opts", ()) for p in cmd.params):
            yield ".".join(path)

    kinds = []
    for path in walk(typer.main.get_command(app), []):
        values = {"tune": TITLES, "demo": machine_names()}.get(path)
        kinds += [f"{path}.{v}" for v in values] if values else [path]
    return kinds


def test_every_command_with_json_has_a_schema_and_a_case():
    kinds = set(_leaf_commands())
    files = {p.name[: -len(".json")] for p in SCHEMAS.glob("*.json")}
    assert kinds == files
    covered = {kind for kind, _ in (*CASES.values(), *SLOW_CASES.values())}
    assert covered == files
    assert set(SUBKIND_ARGUMENT) == {"tune", "demo"}


def test_schemas_are_draft_2020_12_with_the_same_envelope():
    common = None
    for path in sorted(SCHEMAS.glob("*.json")):
        schema = json.loads(path.read_text(encoding="utf-8"))
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["$schema"] == SCHEMA_DIALECT
        kind = path.name[: -len(".json")]
        assert schema["properties"]["kind"] == {"const": kind}, path.name
        assert set(TOP) <= set(schema["required"]), path.name
        common = common or schema["$defs"]
        assert schema["$defs"] == common, f"{path.name}: $defs differ from the other schemas'"
    quantity = jsonschema.Draft202012Validator({**common["quantity"], "$defs": common})
    assert quantity.is_valid({"value": 1.0, "unit": "V/rad", "std": None})
    assert not quantity.is_valid({"value": 1.0, "unit": "V/rad"})  # std always present
    assert not quantity.is_valid({"value": 1.0, "unit": "V/rad", "std": -1.0})
    assert not quantity.is_valid({"value": 1.0, "unit": "V/rad", "std": 0.1, "stdev": 0.1})


# ------------------------------------------------------------------------------------------ a user's script
WARNING_LINE = re.compile(r"^\s*(?:feedtune: )?warning: (.*)$", re.M)

SCRIPT = [  # identify, design, tune and analyze: read the same way, no key that depends on the command
    ["identify", "ballscrew", "examples/ballscrew_frf.csv"],
    ["identify", "rigid", *REVERSALS, "--velocity-threshold", "3"],
    ["identify", "friction", *REVERSALS, "--min-speed", "0.1"],
    ["identify", "friction", *REVERSALS, "--steady-state"],
    ["identify", "gantry", *GANTRY_FRFS],
    ["identify", "mass", "mass_x-0.3.csv", "mass_x0.3.csv", "--x", "-0.3", "--x", "0.3", "--axis-log",
     "mass_axis.csv"],
    ["design", "ppc", "model.toml", "--beta", "4", "--pole-hz", "50", "--zeta", "0.7", *FILTERS, "--frf",
     "examples/ballscrew_frf.csv", "--allow-unstable"],
    ["design", "ppi", "model.toml", "--kpx", "60", "--kpv", "0.3", "--kiv", "20"],
    ["design", "gantry", "gantry.toml"],
    ["design", "loopshape", "gantry.toml", "--crossover-hz", "130", "--pm-deg", "35"],
    ["tune", "ppi", "model.toml", "--frf", "examples/ballscrew_frf_m70.csv", *FILTERS],
    ["analyze", "mcppc.toml", "--frf", "examples/ballscrew_frf.csv"],
    ["analyze", "mimo.toml"],
    ["analyze", "track", "examples/ballscrew_track.csv"],
    ["analyze", "ropesnap", "examples/ballscrew_ropesnap.csv"],
]


def test_a_script_reads_params_warnings_and_check_of_every_identify_design_tune_and_analyze(work, capsys,
                                                                                            monkeypatch):
    monkeypatch.chdir(work)
    docs = {}
    for args in SCRIPT:
        doc = run_json(args, capsys, monkeypatch)
        group = doc["kind"].split(".")[0]
        table = doc["params"] if group == "identify" else doc.get("gains")
        if group in ("identify", "design", "tune"):
            assert table, doc["kind"]
        for name, q in (table or {}).items():  # one spelling: value, unit, std
            assert set(q) == {"value", "unit", "std"}, (doc["kind"], name)
            assert isinstance(q["unit"], str) and q["unit"], (doc["kind"], name)
            assert q["std"] is None or q["std"] >= 0, (doc["kind"], name)
        assert all(isinstance(w, str) and w for w in doc["warnings"])
        limited = group in ("design", "tune") or doc["kind"] == "analyze.gains"
        assert ("check" in doc) == limited, doc["kind"]
        if limited:
            check = doc["check"]
            assert check["ok"] == (not check["violations"]), doc["kind"]
            if "analysis" in doc:  # the checked case's Ms as the analysis reports it
                ms = [i for i in check["items"] if i["name"] == "ms"]
                assert ms and ms[0]["value"] == pytest.approx(doc["analysis"][check["checked_case"]]["ms"])
                if ms[0]["value"] > check["limits"]["ms_max"]:
                    assert not check["ok"] and ms[0]["ok"] is False
        # every warning the command prints (summary or stderr) is in the envelope
        code, out, err = run(args, capsys, monkeypatch)
        assert code == 0, err
        printed = WARNING_LINE.findall(out + "\n" + err)
        assert set(printed) <= set(doc["warnings"]), (args, printed, doc["warnings"])
        docs.setdefault(doc["kind"], []).append((doc, printed))

    # the numbers, read the same way, against references the code under test does not compute
    params = docs["identify.ballscrew"][0][0]["params"]
    for name in ("m2", "k", "c"):  # the example FRF is the Table 3.1 drive with a current loop and torsional modes
        assert params[name]["value"] == pytest.approx(THESIS_TABLE_3_1.params()[name], rel=0.02), name
    assert params["k"]["unit"] == "V/rad" and params["m1"]["unit"] == "V/(rad/s^2)" and params["delay"]["unit"] == "s"
    assert 0 < params["k"]["std"] < 0.01 * params["k"]["value"]
    assert docs["identify.ballscrew"][0][1], "identify ballscrew prints its poorly-determined warnings"
    rigid = docs["identify.rigid"][0][0]
    assert {k: q["value"] for k, q in rigid["params"].items()} == rigid["values"]
    assert {k: q["std"] for k, q in rigid["params"].items()} == rigid["std"]
    joint, steady = (d for d, _ in docs["identify.friction"])
    assert joint["params"]["dc_pos"]["unit"] == "V" and joint["params"]["omega_pos"]["unit"] == "rad/s"
    assert steady["params"]["dc_pos"]["value"] == pytest.approx(joint["params"]["dc_pos"]["value"], rel=0.2)
    assert docs["identify.friction"][1][1], "the steady-state fit prints warnings"
    gantry = docs["identify.gantry"][0][0]["params"]
    for name in ("m", "J0", "k"):
        assert gantry[name]["value"] == pytest.approx(getattr(THESIS_GANTRY, name), rel=0.05), name
        assert gantry[name]["std"] is None
    mass = docs["identify.mass"][0][0]["params"]
    assert mass["m"]["value"] == pytest.approx(THESIS_GANTRY.m, rel=0.05) and mass["m"]["unit"] == "V/(m/s^2)"
    assert mass["m_x"]["value"] == pytest.approx(THESIS_GANTRY.m_x, rel=0.05)

    unstable, printed = docs["design.ppc"][0]
    assert not unstable["check"]["ok"] and unstable["check"]["violations"]
    assert any(w.endswith("(written because of --allow-unstable)") for w in printed)
    ppi = docs["design.ppi"][0][0]["gains"]  # P-PI as state feedback: Kx2 = Kpx Kpv
    assert ppi["Kpx"] == {"value": 60.0, "unit": "1/s", "std": None}
    assert ppi["Kx2"]["value"] == pytest.approx(60.0 * 0.3) and ppi["Kx2"]["unit"] == "V/rad"
    tuned, printed = docs["tune.ppi"][0]
    assert tuned["check"]["ok"] and tuned["check"]["checked_case"] == "discrete"
    assert any("far below the Nyquist frequency" in w for w in printed)  # printed on stderr, in the envelope too
    assert all(i["frf"] == "examples/ballscrew_frf_m70.csv" for i in tuned["check"]["items"])
    analyzed = docs["analyze.gains"][0][0]
    assert analyzed["gains_kind"] == "ballscrew" and analyzed["controller"] == "mcppc"
    assert analyzed["gains"] == unstable["gains"]  # the gains file holds what design ppc printed
    assert docs["analyze.gains"][1][0]["gains_kind"] == "gantry"
    assert docs["design.loopshape"][0][0]["gains"]["K"]["unit"] == "V/(m*s)"
