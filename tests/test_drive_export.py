"""Drive parameter sets (issue 28 items 1-3): each target's written numbers against its vendor's documented
equations, written out here by hand (SINAMICS's PI and filters, ODrive's controller.cpp step, LinuxCNC's pid.c step),
the re-certified figures as exported (|dL| < 0.1 dB / 1 deg up to the target's Nyquist frequency, dMs < 0.02),
refusals (ODrive when the design needs its notch; units the drive cannot take), and the round trip through
``import drive``. Plants: HSM150 identified from its real step logs (shared/data/real), the bundled auto-servo-tuning
export with its drive filters, and a two-mass axis in N m whose resonance needs a notch."""

from __future__ import annotations

import math
import re
import sys

import numpy as np
import pytest
from cli_run import run

from feedtune.control.drive_tuning import Pt2Filter, SecondOrderFilter
from feedtune.design.cascade import design_cascade
from feedtune.errors import DesignError, UsageError
from feedtune.export.drives import DriveOptions, export_drive, import_drive
from feedtune.io import load_model, read_document
from feedtune.io.cascade_gains import cascade_from_document
from feedtune.machines.certificate import FrfSource
from feedtune.models.ballscrew import BallScrewModel
from feedtune.workflows.deliver import deliver

HSM_OPTS = ["--map", "t=data[0]", "--map", "x=data[2]", "--map", "u=data[5]", "--unit", "x=rad", "--unit", "u=N*m"]
DL_DB, DL_DEG, DMS = 0.1, 1.0, 0.02


@pytest.fixture(scope="module")
def hsm(real_data_dir, tmp_path_factory):
    """HSM150's rigid body, identified from its 12 real step logs (N m, rad)."""
    from feedtune.cli.main import main

    out = tmp_path_factory.mktemp("hsm") / "hsm.toml"
    files = sorted((real_data_dir / "HSM150_motor_steps").glob("idf_*.mat"))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sys, "argv", ["feedtune", "identify", "rigid", *map(str, files), *HSM_OPTS, "--out", str(out)])
        with pytest.raises(SystemExit) as done:
            main()
    assert done.value.code in (0, None)
    return load_model(out)


def _doc(plant, **values) -> dict:
    d = deliver(design_cascade(plant, **values))
    assert d.ok, d.violations()
    return d.document


def _assert_figures(done):
    worst = done.worst()
    assert worst["max_dl_db"] < DL_DB and worst["max_dl_deg"] < DL_DEG and worst["max_abs_dms"] < DMS, worst
    for c in done.changes:  # up to the target's Nyquist frequency of each loop
        law = cascade_from_document(done.target_doc)[0]
        assert c.up_to_hz == pytest.approx((law.fs if c.loop == "speed" else law.fp) / 2, rel=0.01)


def _values(text: str, comment: str) -> dict[str, float]:
    out = {}
    for line in text.splitlines():
        m = re.match(rf"^\s*([^\s{comment}\[]+(?:\[[^\]]*\])?)\s*=\s*([-+0-9.eE]+)", line)
        if m:
            out[m.group(1)] = float(m.group(2))
    return out


def _rigid_speed_loop(f, j, b, kp, tn, filters):
    """L_v of a PI ``Kp (1 + 1/(s Tn))`` times drive filters on a rigid body ``1 / (J s + B)`` (speed per torque),
    continuous, written from the drives' documented forms."""
    s = 2j * np.pi * f
    c = kp * (1 + 1 / (s * tn))
    for flt in filters:
        if isinstance(flt, Pt2Filter):
            w = 2 * np.pi * flt.freq_hz
            c = c / ((s / w) ** 2 + 2 * flt.damping * s / w + 1)
        else:
            wz, wn = 2 * np.pi * flt.num_freq_hz, 2 * np.pi * flt.den_freq_hz
            c = c * ((s / wz) ** 2 + 2 * flt.num_damping * s / wz + 1)
            c = c / ((s / wn) ** 2 + 2 * flt.den_damping * s / wn + 1)
    return c / (j * s + b)


# ------------------------------------------------------------------------------------------ SINAMICS
def test_sinamics_writes_the_tuned_hsm150_cascade_and_its_law_recertifies_unchanged(hsm):
    from feedtune.tune.cascade import tune_cascade

    tuned = tune_cascade(hsm, fs=8000.0, filter_choice="identical", filters=())
    doc = deliver(tuned).document
    done = export_drive(doc, "sinamics")
    v = _values(done.written.text, ";")
    law = cascade_from_document(doc)[0]
    # the documented units: p1460 [Nms/rad], p1462 [ms], MD32200 [1000/min] = (m/min)/mm = 1000/60 1/s
    assert v["p1460[0]"] == pytest.approx(law.kp, rel=1e-7)
    assert v["p1462[0]"] == pytest.approx(law.tn_s * 1e3, rel=1e-7)
    assert v["$MA_POSCTRL_GAIN[0,AX1]"] * 1000 / 60 == pytest.approx(law.kv, rel=1e-9)
    assert v["p1656[0]"] == 0
    _assert_figures(done)
    back = cascade_from_document(import_drive(done.written.text, "sinamics"))[0]
    assert (back.kp, back.tn_s, back.fs, back.fp) == (float(np.float32(law.kp)),
                                                      float(np.float32(law.tn_s * 1e3)) * 1e-3, law.fs, law.fp)


def test_sinamics_filters_of_the_auto_servo_tuning_export_by_their_documented_forms(tmp_path, capsys, monkeypatch):
    xml = "examples/vendor/auto_servo_tuning.xml"
    gains = tmp_path / "ast.toml"
    code, _, err = run(["design", "cascade", xml, "--drive-tuning", xml, "--kv", "50", "--out", gains], capsys,
                       monkeypatch)
    assert code == 0, err
    doc = read_document(gains)
    law, plant, _ = cascade_from_document(doc)
    kt = 1.2  # N m/A: the export's gains are in A
    src = [FrfSource.from_file(xml, __import__("feedtune").read_frf(xml))]
    done = export_drive(doc, "sinamics", DriveOptions(torque_constant=kt), src)
    _assert_figures(done)
    v = _values(done.written.text, ";")
    assert v["p1460[0]"] == pytest.approx(law.kp * kt, rel=1e-7)
    assert v["p1656[0]"] == 3  # both filters on
    assert (v["p1657[0]"], v["p1658[0]"], v["p1659[0]"], v["p1660[0]"], v["p1661[0]"]) == pytest.approx(
        (2, 440, 0.3, 440, 0.03), rel=1e-7)  # notch: general second order, fN = fZ, DN = zeta_p, DZ = zeta_z
    assert (v["p1662[0]"], v["p1663[0]"], v["p1664[0]"]) == pytest.approx((1, 2000, 0.7), rel=1e-7)  # PT2
    # the speed loop the written numbers give (PI and filters by their documented forms, Kt back to A) against the
    # file's, on its rigid-body model: the same to single precision
    f = np.geomspace(1, 3999, 2000)
    m = plant.mechanics
    mine = _rigid_speed_loop(f, m.mass, m.viscous, law.kp, law.tn_s, law.filters)
    filters = (SecondOrderFilter(v["p1660[0]"], v["p1661[0]"], v["p1658[0]"], v["p1659[0]"]),
               Pt2Filter(v["p1663[0]"], v["p1664[0]"]))
    theirs = _rigid_speed_loop(f, m.mass, m.viscous, v["p1460[0]"] / kt, v["p1462[0]"] * 1e-3, filters)
    assert np.max(np.abs(20 * np.log10(np.abs(theirs / mine)))) < 1e-5
    back = cascade_from_document(import_drive(done.written.text, "sinamics",
                                              DriveOptions(torque_constant=kt, command_unit="A")))[0]
    assert [type(x) for x in back.filters] == [SecondOrderFilter, Pt2Filter]
    assert back.kp == pytest.approx(law.kp, rel=1e-7) and back.kv == pytest.approx(law.kv, rel=1e-9)


# ------------------------------------------------------------------------------------------ ODrive
def _odrive_doc(hsm):
    """A cascade at ODrive's rates on HSM150 (8 kHz, both loops; ODrive's default pos_gain 20), its only filter the
    PT2 the encoder PLL is at 4000 rad/s."""
    return _doc(hsm, kp=0.01, tn_s=0.02, kv=20.0, fs=8000.0, position_ratio=1,
                filters=(Pt2Filter(4000 / (2 * math.pi), 1.0),))


def test_odrive_gains_in_turns_run_the_same_torque_as_the_cascade(hsm):
    doc = _odrive_doc(hsm)
    done = export_drive(doc, "odrive")
    _assert_figures(done)
    v = _values(done.written.text, "#")
    p = "odrv0.axis0."
    assert v[p + "encoder.config.bandwidth"] == pytest.approx(4000, rel=1e-7)
    law = cascade_from_document(doc)[0]
    # controller.cpp by hand, in turns, the velocity estimate a backward difference; feedtune's law by hand in rad
    rng = np.random.default_rng(3)
    n, fs = 400, 8000.0
    r, x = np.cumsum(rng.normal(0, 1e-3, n)), np.cumsum(rng.normal(0, 1e-3, n))
    integ, u_od, u_ft, i_ft = 0.0, [], [], 0.0
    for k in range(n):
        t = 1 / fs
        rt, xt = r / (2 * math.pi), x / (2 * math.pi)
        vel_set = (rt[k] - rt[k - 1]) * fs if k else 0.0
        vel_est = (xt[k] - xt[k - 1]) * fs if k else 0.0
        v_err = vel_set + v[p + "controller.config.pos_gain"] * (rt[k] - xt[k]) - vel_est
        u_od.append(v[p + "controller.config.vel_gain"] * v_err + integ)
        integ += v[p + "controller.config.vel_integrator_gain"] * t * v_err
        e = law.kv * (r[k] - x[k]) + ((r[k] - r[k - 1]) - (x[k] - x[k - 1])) * fs * (k > 0)
        i_ft += law.kp / (fs * law.tn_s) * e
        u_ft.append(law.kp * e + i_ft)
    assert np.max(np.abs(np.array(u_od) - u_ft)) < 1e-6 * np.max(np.abs(u_ft))
    back = cascade_from_document(import_drive(done.written.text, "odrive"))[0]
    assert back.kp == pytest.approx(law.kp, rel=1e-6) and back.tn_s == pytest.approx(law.tn_s, rel=1e-6)
    assert back.kv == pytest.approx(law.kv, rel=1e-7) and back.fs == 8000 and back.position_ratio == 1
    json_done = export_drive(doc, "odrive", as_json=True)
    assert cascade_from_document(import_drive(json_done.written.text, "odrive"))[0] == back


def _two_mass_doc(notch: bool, pll: bool = True):
    """A motor (1.1e-4 kg m^2) on a load (2e-4 kg m^2) through a 389 Hz, lightly damped coupling, in N m and rad,
    under a cascade at 8 kHz whose notch at the mode it needs (with ODrive's encoder PLL as a PT2 at 4000 rad/s, or a
    faster speed loop without)."""
    mech = BallScrewModel(m1=1.1e-4, m2=2e-4, b1=1e-4, b2=0.0, k=425.0, c=2e-4, input_unit="N*m", lead_given=False)
    f0 = mech.modes()[0].freq_hz
    assert f0 == pytest.approx(389.5, abs=0.1)
    filters = (SecondOrderFilter(f0, 0.02, f0, 0.5),) if notch else ()
    d = deliver(design_cascade(mech, kp=0.02 if pll else 0.12, tn_s=0.01, kv=20.0, fs=8000.0, position_ratio=1,
                               filters=(*filters, Pt2Filter(4000 / (2 * math.pi), 1.0)) if pll else filters))
    return d


def test_odrive_is_refused_when_the_design_needs_its_notch():
    with_notch, without = _two_mass_doc(True), _two_mass_doc(False)
    assert with_notch.ok and not without.ok  # feedtune's own analysis: the notch is what makes it pass
    with pytest.raises(DesignError, match=r"odrive: without notch 389.5 Hz .* fails the limits"):
        export_drive(with_notch.document, "odrive")
    done = export_drive(with_notch.document, "sinamics")  # SINAMICS has the filter
    _assert_figures(done)


# ------------------------------------------------------------------------------------------ LinuxCNC pid
def test_linuxcnc_pid_is_the_cascade_sample_by_sample_by_pid_c(hsm):
    doc = _doc(hsm, kp=0.01, tn_s=0.04, kv=15.0, fs=1000.0, position_ratio=1, kv_ff=0.8)
    done = export_drive(doc, "linuxcnc-pid")
    _assert_figures(done)
    assert done.worst()["max_dl_db"] < 1e-9  # the PID is the cascade exactly
    v = _values(done.written.text, "#")
    assert v["SERVO_PERIOD"] == 1_000_000
    law = cascade_from_document(doc)[0]
    c = 180 / math.pi  # deg per rad: the joint's machine unit
    rng = np.random.default_rng(5)
    n, fs = 300, 1000.0
    r, x = (np.r_[0.0, np.cumsum(rng.normal(0, 1e-2, n - 1))] for _ in range(2))  # from rest at 0, as enabled
    rd, xd = r * c, x * c
    err_i, u_pid, u_ft, i_ft, prev_cmd_d = 0.0, [], [], 0.0, 0.0
    for k in range(n):  # calc_pid: errorI += e T; errorD = commandD - feedbackD; output = ...
        e = rd[k] - xd[k]
        err_i += e / fs
        cmd_d = (rd[k] - rd[k - 1]) * fs if k else 0.0
        fb_d = (xd[k] - xd[k - 1]) * fs if k else 0.0
        cmd_dd = (cmd_d - prev_cmd_d) * fs
        prev_cmd_d = cmd_d
        u_pid.append(v["P"] * e + v["I"] * err_i + v["D"] * (cmd_d - fb_d) + v["FF0"] * rd[k] + v["FF1"] * cmd_d
                     + v["FF2"] * cmd_dd)
        vr = (r[k] - r[k - 1]) * fs if k else 0.0  # feedtune's law (LAW_TEXT) with N = 1, by hand
        ar = (vr - ((r[k - 1] - r[k - 2]) * fs if k > 1 else 0.0)) * fs if k else 0.0
        ev = law.kv * (r[k] - x[k]) + law.kv_ff * vr - ((x[k] - x[k - 1]) * fs if k else 0.0)
        i_ft += law.kp / (fs * law.tn_s) * ev
        u_ft.append(law.kp * ev + i_ft + law.inertia_ff * ar)
    assert np.max(np.abs(np.array(u_pid) - u_ft)) < 1e-9 * np.max(np.abs(u_ft))
    back = cascade_from_document(import_drive(done.written.text, "linuxcnc-pid"))[0]
    for a, b in ((back.kp, law.kp), (back.tn_s, law.tn_s), (back.kv, law.kv), (back.kv_ff, law.kv_ff),
                 (back.inertia_ff, law.inertia_ff)):
        assert a == pytest.approx(b, rel=1e-12)


def test_linuxcnc_pid_refuses_a_law_that_its_servo_rate_cannot_run(hsm):
    from feedtune.tune.cascade import tune_cascade

    doc = deliver(tune_cascade(hsm, fs=8000.0, filter_choice="identical", filters=())).document
    with pytest.raises(DesignError, match=r"linuxcnc-pid: the law the drive runs \(speed loop at 1000 Hz"):
        export_drive(doc, "linuxcnc-pid")


# ------------------------------------------------------------------------------------------ AX8000
def test_ax8000_startup_list_holds_the_real32_objects_and_recertifies_unchanged(hsm):
    import struct
    import xml.etree.ElementTree as ET

    from feedtune.tune.cascade import tune_cascade

    doc = deliver(tune_cascade(hsm, fs=8000.0, filter_choice="identical", filters=())).document
    law = cascade_from_document(doc)[0]
    done = export_drive(doc, "ax8000")
    _assert_figures(done)
    objects = {}
    for cmd in ET.fromstring(done.written.text.encode()).iter("InitCmd"):  # index, subindex, REAL32 little endian
        key = (int(cmd.findtext("Index")[2:], 16), int(cmd.findtext("SubIndex")))
        objects[key] = struct.unpack("<f", bytes.fromhex(cmd.findtext("Data")))[0]
        assert cmd.findtext("Transition") == "PS"
    # Beckhoff's units: 0x3140:01 N m/(rad/s), 0x3140:02 s, 0x30C0:01 1/s
    assert objects == {(0x3140, 1): pytest.approx(law.kp, rel=1e-7), (0x3140, 2): pytest.approx(law.tn_s, rel=1e-7),
                       (0x30C0, 1): pytest.approx(law.kv, rel=1e-7)}
    back = cascade_from_document(import_drive(done.written.text, "ax8000"))[0]
    assert (back.kp, back.tn_s, back.kv) == (objects[(0x3140, 1)], objects[(0x3140, 2)], objects[(0x30C0, 1)])
    assert (back.fs, back.fp) == (law.fs, law.fp)
    with_notch, without = _two_mass_doc(True, pll=False), _two_mass_doc(False, pll=False)
    assert with_notch.ok and not without.ok
    with pytest.raises(DesignError, match=r"ax8000: without notch 389.5 Hz"):
        export_drive(with_notch.document, "ax8000")


# ------------------------------------------------------------------------------------------ Yaskawa
def test_yaskawa_speed_gain_in_hz_needs_the_inertia_and_its_integer_steps_recertify(hsm):
    from feedtune.control.drive_tuning import Pt1Filter

    doc = _doc(hsm, kp=0.1, tn_s=0.0123456, kv=123.4, fs=8000.0, position_ratio=8, filters=(Pt1Filter(0.00012),))
    law = cascade_from_document(doc)[0]
    with pytest.raises(UsageError, match="--inertia"):
        export_drive(doc, "yaskawa")
    j = hsm.mass  # the motor-side inertia the drive assumes: J_M (1 + Pn103/100) [kg m^2]
    done = export_drive(doc, "yaskawa", DriveOptions(inertia=j))
    _assert_figures(done)
    v = _values(done.written.text, ";")
    # Sigma-II user's manual: Kv (1 + 1/(Ti s)) with Kv [Hz] the speed loop gain at the inertia J (torque per speed
    # error 2 pi Kv J), Ti in 0.01 ms, the position loop gain in 1/s, the torque reference filter in 0.01 ms
    assert v["Pn100"] == round(law.kp / (2 * math.pi * j)) and v["Pn101"] == round(law.tn_s / 1e-5)
    assert v["Pn102"] == round(law.kv) and v["Pn401"] == 12
    back = cascade_from_document(import_drive(done.written.text, "yaskawa"))[0]
    assert back.kp == pytest.approx(2 * math.pi * v["Pn100"] * j, rel=1e-12)
    assert back.tn_s == pytest.approx(v["Pn101"] * 1e-5, rel=1e-12) and back.kv == v["Pn102"]
    assert back.filters[0].time_constant_s == pytest.approx(v["Pn401"] * 1e-5, rel=1e-12)
    # a filter time off the 10 us grid: the rounded PT1 is what the certificate judges (2.9 % off its corner)
    off = export_drive(_doc(hsm, kp=0.1, tn_s=0.0123456, kv=123.4, fs=8000.0, position_ratio=8,
                            filters=(Pt1Filter(0.000123456),)), "yaskawa", DriveOptions(inertia=j))
    f = 4000.0  # the PT1's ratio at the speed loop's Nyquist frequency, continuous: a lower bound of the change
    bound = 20 * math.log10(abs((1 + 2j * math.pi * f * 0.000123456) / (1 + 2j * math.pi * f * 0.00012)))
    assert off.worst()["max_dl_db"] > bound > 0.1


# ------------------------------------------------------------------------------------------ units and the CLI
def test_units_the_drive_cannot_take_are_refused_in_one_line(hsm, examples_dir, tmp_path, capsys, monkeypatch):
    import json

    doc_a = json.loads(json.dumps(_odrive_doc(hsm)).replace("N*m", "A"))  # the same numbers, a current command
    with pytest.raises(UsageError, match="--torque-constant"):
        export_drive(doc_a, "sinamics")
    gains = tmp_path / "ppi.toml"
    code, _, err = run(["identify", "ballscrew", examples_dir / "ballscrew_frf.csv", "--out", tmp_path / "m.toml"],
                       capsys, monkeypatch)
    assert code == 0, err
    code, _, err = run(["design", "ppi", tmp_path / "m.toml", "--kpx", "60", "--kpv", "0.3", "--kiv", "20", "--out",
                        gains], capsys, monkeypatch)
    assert code == 0, err
    code, _out, err = run(["export", "drive", "sinamics", gains, "--out", tmp_path / "x.txt"], capsys, monkeypatch)
    assert code == 1 and "a P-PI gains file" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.txt").exists()


def test_cli_refusal_writes_nothing_and_no_overwrite_without_force(hsm, tmp_path, capsys, monkeypatch):
    from feedtune.io import write_document

    with_notch = _two_mass_doc(True).document
    gains = tmp_path / "tm.toml"
    write_document(gains, with_notch)
    out = tmp_path / "tm.odrive.py"
    code, _, err = run(["export", "drive", "odrive", gains], capsys, monkeypatch)
    assert code == 1 and "without notch 389.5 Hz" in err and "nothing written" in err and not out.exists()
    code, stdout, err = run(["export", "drive", "sinamics", gains], capsys, monkeypatch)
    assert code == 0, err
    assert "max |dL|" in stdout and (tmp_path / "tm.sinamics.txt").exists()
    code, _, err = run(["export", "drive", "sinamics", gains], capsys, monkeypatch)
    assert code == 2 and "--force" in err
    back = tmp_path / "back.toml"
    code, stdout, err = run(["import", "drive", "sinamics", tmp_path / "tm.sinamics.txt", "--out", back], capsys,
                            monkeypatch)
    assert code == 0, err
    code, stdout, err = run(["analyze", back], capsys, monkeypatch)
    assert code == 1 and "no plant model" in err  # a drive's file holds no model: analyse it on its FRF
