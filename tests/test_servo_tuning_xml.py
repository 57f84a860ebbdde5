"""The auto-servo-tuning XML export, from the format facts of issue 25: base-85 arrays, the plant FRF with its
coherence, the original and tuned speed controllers.

The references are the facts themselves, written out here independently of the reader (digits of a word by integer
division, a double's words by ``struct``), and the values a test file was built from: the round trip must give the
FRF to 1e-12 (it gives it to the bit) and the controllers exactly.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from cli_run import run

from feedtune.control.drive_tuning import DriveSpeedTuning, Pt1Filter, Pt2Filter, SecondOrderFilter, SpeedController
from feedtune.errors import DataError
from feedtune.io import read_frf
from feedtune.io.servo_tuning_xml import (
    ALPHABET,
    decode_raw,
    encode_raw,
    read_drive_speed_tuning,
    read_servo_tuning_frf,
    servo_tuning_xml,
)
from feedtune.models import THESIS_TABLE_3_1

TUNING = DriveSpeedTuning(
    SpeedController(0.8, 0.010, (Pt1Filter(1.0e-4), SecondOrderFilter(420.0, 0.05, 420.0, 0.5, enabled=False))),
    SpeedController(1.2, 0.006, (SecondOrderFilter(440.0, 0.03, 440.0, 0.3), Pt2Filter(2000.0, 0.7))),
    125e-6,
)


def _word_text(word: int) -> str:
    """Five base-85 digits of a 32-bit word, most significant first (the facts), or '.' for zero."""
    if word == 0:
        return "."
    digits = []
    for _ in range(5):
        word, d = divmod(word, 85)
        digits.append(ALPHABET[d])
    return "".join(reversed(digits))


def _facts_text(values) -> str:
    """Base-85 text of doubles written from the facts with struct and integer arithmetic."""
    out = []
    for v in values:
        hi, lo = struct.unpack(">II", struct.pack(">d", v))
        out += [_word_text(hi), _word_text(lo)]
    return "".join(out)


def test_the_alphabet_has_85_distinct_characters_none_of_them_xml_markup_or_the_zero_mark():
    assert len(ALPHABET) == len(set(ALPHABET)) == 85
    assert not set(ALPHABET) & set("<>&\"'.")


@pytest.mark.parametrize("values", [[1.0], [0.0, -0.0, 1.5, -2.5e-300], [np.pi, np.inf, -np.inf, 5e-324],
                                    list(np.random.default_rng(3).standard_normal(200) * 1e3)])
def test_encoder_is_the_facts_and_decoding_gives_every_bit_back(values):
    text = encode_raw(values)
    assert text == _facts_text(values)
    back = decode_raw(text)
    assert np.array_equal(np.asarray(values, dtype=">f8").view(">u8"), back.astype(">f8").view(">u8"))


def test_one_double_by_hand():
    """1.0 is the words 0x3FF00000 and 0: the first is 1072693248 = 20 * 85^4 + 46 * 85^3 + 59 * 85^2 + 55 * 85 +
    48 (digits k, K, X, T, M), the second the zero mark."""
    assert 20 * 85**4 + 46 * 85**3 + 59 * 85**2 + 55 * 85 + 48 == 0x3FF00000
    assert encode_raw([1.0]) == "kKXTM." and decode_raw(" kKXTM\n. ").tolist() == [1.0]


@pytest.mark.parametrize(("text", "fragment"), [("kKuh", "groups of five"), ("kKu.hR.", "groups of five"),
                                                 ("kKuhR", "words; doubles take two each"),
                                                 ("kK<hR.", "not a base-85 digit"), ("~~~~~.", "exceeds a 32-bit")])
def test_malformed_base85_is_one_line_naming_the_array(text, fragment):
    with pytest.raises(DataError, match=fragment):
        decode_raw(text, "tuning.xml: m_ValueVector")


@pytest.fixture
def export(tmp_path):
    f = np.geomspace(1.0, 2000.0, 400)
    plant = THESIS_TABLE_3_1.frf(f, quantity="velocity").channel("x1/u")
    coherence = np.clip(1 - 0.05 * (f / 2000.0), 0, 1)
    path = tmp_path / "tuning.xml"
    path.write_bytes(servo_tuning_xml(f, plant, TUNING, coherence))
    return path, f, plant, coherence


def test_round_trip_frf_and_controllers(export):
    path, f, plant, coherence = export
    assert path.read_bytes().startswith(b"<?xml version='1.0' encoding='ISO-8859-1'?>")
    frf = read_frf(path)  # the normal dispatch
    assert frf.channels == ["x1/u"] and frf.quantity == "velocity" and frf.input_unit == "A"
    assert np.max(np.abs(frf.freq_hz - f)) == 0 and np.max(np.abs(frf.channel("x1/u") - plant)) <= 1e-12 * np.max(
        np.abs(plant))
    assert np.array_equal(frf.channel_coherence("x1/u"), coherence)
    tuning = read_drive_speed_tuning(path)
    assert (tuning.original, tuning.tuned, tuning.sample_time_s) == (TUNING.original, TUNING.tuned, 125e-6)
    assert tuning.fs_hz == pytest.approx(8000.0)
    assert tuning.original.filters[1].enabled is False and tuning.original.enabled_filters == (Pt1Filter(1e-4),)


def test_the_controllers_response_is_pi_times_their_filters(export):
    """The PI law and each filter against their textbook forms, written out here."""
    f = np.array([10.0, 100.0, 440.0, 1000.0])
    s = 2j * np.pi * f
    tuned = TUNING.tuned
    w = 2 * np.pi * 440.0
    notch = (s**2 + 2 * 0.03 * w * s + w**2) / (s**2 + 2 * 0.3 * w * s + w**2)
    w2 = 2 * np.pi * 2000.0
    pt2 = w2**2 / (s**2 + 2 * 0.7 * w2 * s + w2**2)
    expected = 1.2 * (1 + 1 / (s * 0.006)) * notch * pt2
    assert np.allclose(tuned.response(f), expected, rtol=1e-12)
    assert abs(tuned.filters[0].response(440.0)) == pytest.approx(0.1)  # depth zeta_z / zeta_p


def test_the_value_types_say_what_they_hold():
    d = TUNING.to_dict()
    assert d["original"]["filters"][0] == {"kind": "PT1", "enabled": True, "time_constant_s": 1e-4}
    assert d["units"]["tn_s"] == "s" and d["sample_time_s"] == 125e-6
    assert repr(TUNING.tuned) == "SpeedController(Kp=1.2, Tn=6 ms, 2 filters)"
    assert "1 disabled" in repr(TUNING.original)
    with pytest.raises(DataError, match="Kp"):
        SpeedController(-1.0, 0.01)


def test_frf_info_prints_the_controllers_and_commands_read_the_plant(export, capsys, monkeypatch):
    path, *_ = export
    code, out, err = run(["frf", "info", path, "--json"], capsys, monkeypatch)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["drive_speed_tuning"]["tuned"]["kp"] == 1.2 and doc["unit"] == "rad/s/A"
    code, out, err = run(["frf", "info", path], capsys, monkeypatch)
    assert "tuned: Kp 1.2, Tn 6 ms" in out and "speed loop sampled every 125 us (8000 Hz)" in out
    assert "PT2 low-pass, 2000 Hz, D 0.7" in out and "(disabled)" in out
    code, out, err = run(["identify", "ballscrew", path, "--no-delay", "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert json.loads(out)["params"]["m1"]["unit"] == "A/(rad/s^2)"  # the export's units reach the model


def test_broken_exports_are_one_line_errors(tmp_path, export):
    path, *_ = export
    text = path.read_bytes()
    values = text.index(b"<raw>", text.index(b"m_ValueVector")) + 5
    cases = {
        "nolist.xml": (text.replace(b"m_SpeedControllerList", b"m_Other"), "m_SpeedControllerList"),
        "badchar.xml": (text[:values] + b"&lt;" + text[values + 1:], "not a base-85 digit"),  # '<' for a digit
        "short.xml": (text[:values] + text[values + 10:], "m_ValueVector holds 799 doubles for 400 frequencies"),
        "notxml.xml": (b"<a><b></a>", "not a readable XML file"),
    }
    for name, (data, fragment) in cases.items():
        bad = tmp_path / name
        bad.write_bytes(data)
        with pytest.raises(DataError, match=fragment):
            read_servo_tuning_frf(bad)
    from feedtune.errors import UsageError
    from feedtune.io import write_frf

    with pytest.raises(UsageError, match=r"writes FRFs as \.csv"):
        write_frf(read_frf(path), tmp_path / "out.xml")
