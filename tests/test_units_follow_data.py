"""The command unit of the data (V, A, N) follows a design into every gain label, gains file, analysis, summary
and C header: a model identified in A gives gains in A/rad, a rigid-body model in N gives an axis in N/(m*s)."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import pytest

from feedtune.control.ballscrew_law import all_gain_units
from feedtune.design.loopshape import design_loopshape
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.export.c_header import c_header
from feedtune.io import save_model
from feedtune.io.gains import gains_document, law_from_document
from feedtune.io.gantry_gains import axis_gains_document
from feedtune.machines import analyze_gains, load_runtime
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.rigid import RigidBodyModel

# a volt anywhere in a unit string: "V", "V/rad", "rad/V", "V/(m*s)" (not "rev" or "Vel")
VOLT = re.compile(r"(^|[^A-Za-z])V($|[^A-Za-z])")


def _units_in(doc) -> list[str]:
    """Every unit string of a document (values of ``unit`` and ``command`` keys, the ``[units]`` tables)."""
    found = []

    def walk(node, key=None):
        if isinstance(node, dict):
            for k, v in node.items():
                if isinstance(v, str) and (k in ("unit", "command", "command_unit", "input_unit") or key == "units"):
                    found.append(v)
                walk(v, k)
        elif isinstance(node, list):
            for v in node:
                walk(v, key)

    walk(doc)
    return found


@pytest.mark.parametrize("structure", ["mcppc", "ppi"])
def test_a_ball_screw_model_in_amperes_gives_gains_in_amperes_everywhere(structure):
    model = replace(THESIS_TABLE_3_1, input_unit="A")
    design = (design_mcppc(model, beta=1.0, pole_hz=51.0, zeta=0.9) if structure == "mcppc"
              else design_ppi(model, Kpx=53.5, Kpv=2.43, Kiv=353.0))
    doc = json.loads(json.dumps(gains_document(design)))
    units = _units_in(doc)
    assert units and not [u for u in units if VOLT.search(u)], units
    assert doc["gains"]["Kv2"]["unit"] == "A/(rad/s)" and doc["model"]["params"]["m1"]["unit"] == "A/(rad/s^2)"
    # read back: the runtime accepts it, the law and model keep the unit, the analysis speaks of A
    assert load_runtime(doc, "gains").command_unit == "A"
    assert law_from_document(doc)[1].input_unit == "A"
    result = analyze_gains(doc, "gains").result
    assert result["command_unit"] == "A" and result["gain_units"] == all_gain_units("A")
    header = c_header(doc)
    comments = " ".join(re.findall(r"/\*(.*?)\*/", header, flags=re.S))
    assert "(A)" in header and "A/rad" in comments and not VOLT.search(comments), header[:600]


def test_a_rigid_body_model_in_newtons_gives_an_axis_in_newtons():
    emps = RigidBodyModel(mass=95.1, viscous=203.5, coulomb_pos=20.4, offset=-3.16, command_unit="N")
    design = design_loopshape(emps, crossover_hz=30.0, pm_deg=35.0, fs=1000.0)
    doc = json.loads(json.dumps(axis_gains_document(design)))
    units = _units_in(doc)
    assert units and not [u for u in units if VOLT.search(u)], units
    assert doc["units"]["command"] == "N" and doc["gains"]["K"]["unit"] == "N/(m*s)"
    assert doc["feedforward"]["mass"] == {"value": pytest.approx(95.1), "unit": "N/(m/s^2)"}
    assert load_runtime(doc, "axis").command_unit == "N"


def test_cli_design_on_a_model_file_in_amperes(tmp_path):
    from typer.testing import CliRunner

    from feedtune.cli.main import app

    model = replace(THESIS_TABLE_3_1, input_unit="A")
    save_model(tmp_path / "m.toml", model)
    out = tmp_path / "g.toml"
    res = CliRunner().invoke(app, ["design", "ppc", str(tmp_path / "m.toml"), "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    result = json.loads(res.stdout)
    assert result["command_unit"] == "A" and result["gain_units"]["Kx1"] == "A/rad"
    text = out.read_text()
    assert 'command = "A"' in text and not VOLT.search(" ".join(re.findall(r'unit = "([^"]*)"', text)))
    res = CliRunner().invoke(app, ["analyze", str(out)])
    assert res.exit_code == 0 and "rad/A" in res.stdout and "rad/V" not in res.stdout


def test_a_rotary_bench_identified_without_a_lead_stays_in_rad(tmp_path):
    import numpy as np

    from feedtune.identify.ballscrew import fit_ballscrew
    from feedtune.io import load_model

    frf = replace(THESIS_TABLE_3_1, input_unit="A").frf(np.logspace(0.5, 3.3, 400))
    rotary = fit_ballscrew([frf]).model
    assert not rotary.lead_given
    save_model(tmp_path / "rotary.toml", rotary)
    assert "lead_m_per_rad" not in (tmp_path / "rotary.toml").read_text()
    assert not load_model(tmp_path / "rotary.toml").lead_given
    doc = gains_document(design_mcppc(rotary))
    assert "lead_m_per_rad" not in doc["model"] and not law_from_document(doc)[1].lead_given
    screw = fit_ballscrew([frf], lead_m_per_rad=0.01 / (2 * np.pi)).model
    save_model(tmp_path / "screw.toml", screw)
    assert load_model(tmp_path / "screw.toml").lead_given
