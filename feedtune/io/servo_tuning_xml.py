"""A CNC's auto-servo-tuning XML export: the measured speed-loop FRF and the drive's speed controllers.

Format facts (issue 25; no public specification):

* XML in ISO-8859-1;
* numeric arrays are ``<raw>`` elements inside ``NumericArray`` elements named ``m_FrequencyVector`` and
  ``m_ValueVector``, base-85 text over the alphabet :data:`ALPHABET`: five characters give one big-endian 32-bit word
  (most significant character first), a single ``.`` a zero word; two words give one big-endian IEEE double; complex
  arrays are interleaved ``re, im`` (so a value vector of twice the frequency vector's length is complex);
* the plant FRF is the ``FrequencyResponseFunction`` named ``m_pPlant`` and its coherence ``m_pMeasCoherence``, both
  inside the ``DynamicModelList`` named ``m_SpeedControllerList``;
* the speed controllers are the elements of the ``LinkedList`` named ``m_listpSpeedLoopRegulators`` (first: the
  original, second: the tuned one) with ``m_dKpGain``, ``m_dIntegralTime`` and a ``ConTimeFilterList`` named
  ``m_CurrentFilters`` holding ``PT1Filter`` (``m_dTimeConst``), ``PT2Filter`` (``m_Frequency``, ``m_DampingRatio``)
  and ``SecondOrderFilter`` (``m_NumeratorFrequency``, ``m_NumeratorDampingRatio``, ``m_DenominatorFrequency``,
  ``m_DenominatorDampingRatio``) elements with ``m_bFilterIsEnabled``; the speed-loop sample time is
  ``m_dActValDelayTime``.

"Named" is read as an element's ``name`` attribute (or, failing one, its tag); a scalar member is an element so named
whose text (or ``value`` attribute) is the number, a flag ``1``/``0``/``true``/``false``.

Units. The export states none. :func:`read_servo_tuning_frf` takes the plant as the motor speed [rad/s] over the
current setpoint [A] (a velocity FRF ``x1/u``: output position unit rad, input unit A) on a grid in Hz; the
controllers' times are in s, filter frequencies in Hz (:mod:`feedtune.control.drive_tuning`). Where a drive states
otherwise, a piece's ``in=``/``out=``/``scale=`` (``feedtune.cli.frf_options``) corrects the FRF.

:func:`encode_raw` is the inverse of :func:`decode_raw`; :func:`servo_tuning_xml` builds a file from the facts above
(tests and the bundled example use it).
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from ..control.drive_tuning import DriveSpeedTuning, Pt1Filter, Pt2Filter, SecondOrderFilter, SpeedController
from ..errors import DataError
from ..frf import Frf
from ._table import read_bytes
from .atomic import atomic_write_bytes

ALPHABET = "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ!#$`()*+-/:;=?@[]^_{|}~"
"""The 85 characters of the export's base-85 digits, in order of value 0..84."""
ZERO_WORD = "."
"""A zero word written as one character."""
ENCODING = "ISO-8859-1"
FORMAT = "auto-servo-tuning XML"
"""``meta["format"]`` of an FRF read from such a file."""
CHANNEL = "x1/u"
"""The plant's channel: motor speed (motor encoder, ``x1``) over the current setpoint (``u``)."""
QUANTITY, INPUT_UNIT, OUTPUT_UNIT = "velocity", "A", "rad"
"""How the plant FRF is read (module docstring): (rad/s)/A."""
UNITS_NOTE = ("the export states no units: the plant is read as motor speed [rad/s] over current setpoint [A] on a "
              "grid in Hz")

_DIGITS = np.full(256, -1, dtype=np.int64)
_DIGITS[np.frombuffer(ALPHABET.encode("ascii"), dtype=np.uint8)] = np.arange(85)
_POWERS = 85 ** np.arange(4, -1, -1, dtype=np.int64)
_TOKEN_RE = re.compile(r"\.|[^.]{5}")
_SPACE_RE = re.compile(r"\s+")


# ------------------------------------------------------------------------------------------ base 85
def decode_raw(text: str, where: str = "raw") -> np.ndarray:
    """The doubles of a ``<raw>`` element's base-85 text.

    Parameters
    ----------
    text : str
        Base-85 digits over :data:`ALPHABET` (whitespace ignored), ``.`` for a zero word.
    where : str
        Location for messages (file and array name).

    Returns
    -------
    ndarray of float64
        One double per two words.

    Raises
    ------
    DataError
        A character outside the alphabet, a group of fewer than five characters, a group above 2^32 - 1, or an odd
        number of words.

    Examples
    --------
    >>> decode_raw(encode_raw([1.0, -2.5, 0.0])).tolist()
    [1.0, -2.5, 0.0]
    """
    compact = _SPACE_RE.sub("", text or "")
    tokens = _TOKEN_RE.findall(compact)
    if sum(len(t) for t in tokens) != len(compact):
        raise DataError(f"{where}: base-85 text of {len(compact)} characters does not split into groups of five "
                        f"(and '.' zero words)")
    zero = np.array([t == ZERO_WORD for t in tokens], dtype=bool)
    groups = [t for t in tokens if t != ZERO_WORD]
    words = np.zeros(len(tokens), dtype=np.uint64)
    if groups:
        raw = np.frombuffer("".join(groups).encode("latin-1"), dtype=np.uint8).reshape(-1, 5)
        digits = _DIGITS[raw]
        if (digits < 0).any():
            k = int(np.flatnonzero((digits < 0).reshape(-1))[0])
            bad = chr(raw.reshape(-1)[k])
            raise DataError(f"{where}: {bad!r} is not a base-85 digit of this format (group {k // 5 + 1})")
        values = digits @ _POWERS
        if (values > 0xFFFFFFFF).any():
            k = int(np.flatnonzero(values > 0xFFFFFFFF)[0])
            raise DataError(f"{where}: group {k + 1} ({groups[k]!r}) exceeds a 32-bit word")
        words[~zero] = values.astype(np.uint64)
    if words.size % 2:
        raise DataError(f"{where}: {words.size} words; doubles take two each")
    return np.frombuffer(words.astype(">u4").tobytes(), dtype=">f8").astype(float)


def encode_raw(values: Sequence[float] | np.ndarray) -> str:
    """Base-85 text of doubles, the inverse of :func:`decode_raw` (zero words as ``.``).

    Parameters
    ----------
    values : sequence of float
        The doubles (a complex array goes in as its interleaved ``re, im``).

    Returns
    -------
    str
        Five characters per big-endian 32-bit word, ``.`` per zero word.
    """
    words = np.frombuffer(np.asarray(values, dtype=">f8").tobytes(), dtype=">u4").astype(np.int64)
    digits = (words[:, None] // _POWERS[None, :]) % 85
    alphabet = np.frombuffer(ALPHABET.encode("ascii"), dtype=np.uint8)
    chars = alphabet[digits]
    return "".join(ZERO_WORD if w == 0 else row.tobytes().decode("ascii") for w, row in zip(words, chars,
                                                                                            strict=True))


def _interleaved(values: np.ndarray) -> np.ndarray:
    z = np.asarray(values, dtype=complex)
    return np.column_stack([z.real, z.imag]).reshape(-1)


# ------------------------------------------------------------------------------------------ XML
def _named(element: ET.Element, name: str) -> ET.Element | None:
    """The first element below ``element`` (or itself) named ``name`` (``name`` attribute, else tag)."""
    for e in element.iter():
        if e.get("name") == name:
            return e
    for e in element.iter():
        if e.tag == name:
            return e
    return None


def _parse(path: str | os.PathLike[str]) -> ET.Element:
    data = read_bytes(path)
    try:
        return ET.fromstring(data)
    except ET.ParseError as exc:
        raise DataError(f"{path}: not a readable XML file ({exc})") from None


def is_servo_tuning_xml(path: str | os.PathLike[str]) -> bool:
    """True when an XML file holds the speed-controller list of an auto-servo-tuning export."""
    try:
        return _named(_parse(path), "m_SpeedControllerList") is not None
    except DataError:
        return False


def _array(parent: ET.Element, name: str, where: str) -> np.ndarray:
    node = _named(parent, name)
    if node is None:
        raise DataError(f"{where}: no NumericArray named {name!r}")
    raw = node.find(".//raw") if node.tag != "raw" else node
    if raw is None:
        raise DataError(f"{where}: {name} has no <raw> element")
    return decode_raw(raw.text or "", f"{where}: {name}")


def _frf_values(lst: ET.Element, name: str, where: str, n: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    node = _named(lst, name)
    if node is None:
        raise DataError(f"{where}: no FrequencyResponseFunction named {name!r} in m_SpeedControllerList")
    here = f"{where}: {name}"
    f = _array(node, "m_FrequencyVector", here)
    v = _array(node, "m_ValueVector", here)
    if v.size == 2 * f.size:
        v = v[0::2] + 1j * v[1::2]
    elif v.size != f.size:
        raise DataError(f"{here}: m_ValueVector holds {v.size} doubles for {f.size} frequencies (expected "
                        f"{f.size} real or {2 * f.size} interleaved complex)")
    return f, v


def read_servo_tuning_frf(path: str | os.PathLike[str], *, quantity: str | None = None) -> Frf:
    """The speed-loop plant FRF (and its coherence) of an auto-servo-tuning XML export (module docstring).

    Parameters
    ----------
    path : path-like
        The ``.xml`` file.
    quantity : str, optional
        Overrides the quantity the plant is read as (default velocity: motor speed over current setpoint).

    Returns
    -------
    Frf
        Channel ``x1/u``, frequencies in Hz, (rad/s)/A as a velocity FRF, coherence [-]; ``meta["format"]`` is
        :data:`FORMAT`, ``meta["units_note"]`` says how the units were taken.

    Raises
    ------
    DataError
        Not such an export, a missing array, a malformed base-85 text, coherence outside 0..1 or on another grid.
    """
    root = _parse(path)
    lst = _named(root, "m_SpeedControllerList")
    if lst is None:
        raise DataError(f"{path}: no DynamicModelList named 'm_SpeedControllerList'; not an auto-servo-tuning "
                        "export")
    f, plant = _frf_values(lst, "m_pPlant", str(path))
    coherence = None
    if _named(lst, "m_pMeasCoherence") is not None:
        fc, coh = _frf_values(lst, "m_pMeasCoherence", str(path))
        if fc.size != f.size or not np.allclose(fc, f, rtol=1e-9, atol=0):
            raise DataError(f"{path}: m_pMeasCoherence is on another frequency grid than m_pPlant "
                            f"({fc.size} and {f.size} lines)")
        coherence = np.real(coh)
        if np.any(coherence < -1e-9) or np.any(coherence > 1 + 1e-9) or not np.all(np.isfinite(coherence)):
            raise DataError(f"{path}: m_pMeasCoherence holds values outside 0..1")
        coherence = np.clip(coherence, 0.0, 1.0)
    meta = {"source": str(path), "format": FORMAT, "units_note": UNITS_NOTE}
    return Frf.from_channels(f, {CHANNEL: plant}, coherence=None if coherence is None else {CHANNEL: coherence},
                             quantity=quantity or QUANTITY, input_unit=INPUT_UNIT, output_unit=OUTPUT_UNIT, meta=meta)


def _scalar(parent: ET.Element, name: str, where: str, required: bool = True) -> float | None:
    node = _named(parent, name)
    if node is None:
        if required:
            raise DataError(f"{where}: no {name}")
        return None
    text = node.get("value", node.text or "").strip()
    try:
        return float(text)
    except ValueError:
        raise DataError(f"{where}: {name} = {text!r} is not a number") from None


def _flag(parent: ET.Element, name: str, where: str) -> bool:
    node = _named(parent, name)
    if node is None:
        return True
    text = node.get("value", node.text or "").strip().lower()
    if text in ("1", "true", "yes"):
        return True
    if text in ("0", "false", "no"):
        return False
    raise DataError(f"{where}: {name} = {text!r} is not a flag (1/0, true/false)")


_FILTERS = {
    "PT1Filter": (Pt1Filter, ("m_dTimeConst",)),
    "PT2Filter": (Pt2Filter, ("m_Frequency", "m_DampingRatio")),
    "SecondOrderFilter": (SecondOrderFilter, ("m_NumeratorFrequency", "m_NumeratorDampingRatio",
                                              "m_DenominatorFrequency", "m_DenominatorDampingRatio")),
}


def _controller(node: ET.Element, where: str) -> SpeedController:
    kp = _scalar(node, "m_dKpGain", where)
    tn = _scalar(node, "m_dIntegralTime", where)
    filters = []
    holder = _named(node, "m_CurrentFilters")
    for k, e in enumerate(holder if holder is not None else []):
        if e.tag not in _FILTERS:
            raise DataError(f"{where}: m_CurrentFilters element {k + 1} is a {e.tag}; known filters: "
                            f"{', '.join(_FILTERS)}")
        cls, names = _FILTERS[e.tag]
        here = f"{where}: {e.tag} {k + 1}"
        filters.append(cls(*(_scalar(e, n, here) for n in names), enabled=_flag(e, "m_bFilterIsEnabled", here)))
    try:
        return SpeedController(kp, tn, tuple(filters))
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def read_drive_speed_tuning(path: str | os.PathLike[str]) -> DriveSpeedTuning:
    """The drive's original and tuned speed controllers of an auto-servo-tuning XML export (module docstring).

    Parameters
    ----------
    path : path-like
        The ``.xml`` file.

    Returns
    -------
    DriveSpeedTuning
        ``original`` (first regulator), ``tuned`` (second, or None), the speed-loop sample time [s].

    Raises
    ------
    DataError
        No ``m_listpSpeedLoopRegulators`` or no regulator in it, a missing or malformed member.
    """
    root = _parse(path)
    lst = _named(root, "m_listpSpeedLoopRegulators")
    if lst is None:
        raise DataError(f"{path}: no LinkedList named 'm_listpSpeedLoopRegulators'")
    regulators = list(lst)
    if not regulators:
        raise DataError(f"{path}: m_listpSpeedLoopRegulators holds no speed controller")
    names = ("original", "tuned")
    controllers = [_controller(r, f"{path}: {names[k]} speed controller") for k, r in enumerate(regulators[:2])]
    ts = _scalar(root, "m_dActValDelayTime", str(path), required=False)
    return DriveSpeedTuning(controllers[0], controllers[1] if len(controllers) > 1 else None,
                            ts if ts is not None and math.isfinite(ts) and ts > 0 else None, str(path))


# ------------------------------------------------------------------------------------------ building files
def _xml_scalar(parent: ET.Element, name: str, value: float) -> None:
    ET.SubElement(parent, "double", name=name).text = repr(float(value))


def _xml_array(parent: ET.Element, name: str, values: np.ndarray) -> None:
    ET.SubElement(ET.SubElement(parent, "NumericArray", name=name), "raw").text = encode_raw(values)


def _xml_frf(parent: ET.Element, name: str, freq_hz: np.ndarray, values: np.ndarray) -> None:
    node = ET.SubElement(parent, "FrequencyResponseFunction", name=name)
    _xml_array(node, "m_FrequencyVector", np.asarray(freq_hz, dtype=float))
    v = np.asarray(values)
    _xml_array(node, "m_ValueVector", _interleaved(v) if np.iscomplexobj(v) else v.astype(float))


def _filter_names(f) -> tuple[str, tuple[float, ...]]:
    if isinstance(f, Pt1Filter):
        return "PT1Filter", (f.time_constant_s,)
    if isinstance(f, Pt2Filter):
        return "PT2Filter", (f.freq_hz, f.damping)
    return "SecondOrderFilter", (f.num_freq_hz, f.num_damping, f.den_freq_hz, f.den_damping)


def servo_tuning_xml(freq_hz: np.ndarray, plant: np.ndarray, tuning: DriveSpeedTuning,
                     coherence: np.ndarray | None = None) -> bytes:
    """An auto-servo-tuning export built from the format facts (module docstring), for tests and examples.

    Parameters
    ----------
    freq_hz : ndarray
        Frequency grid [Hz].
    plant : ndarray of complex
        Motor speed over current setpoint [(rad/s)/A] on ``freq_hz``.
    tuning : DriveSpeedTuning
        The original and tuned speed controllers and the sample time.
    coherence : ndarray, optional
        Coherence [-] on ``freq_hz``.

    Returns
    -------
    bytes
        The XML document in ISO-8859-1.
    """
    root = ET.Element("AutoServoTuning", version="1")
    lst = ET.SubElement(root, "DynamicModelList", name="m_SpeedControllerList")
    _xml_frf(lst, "m_pPlant", freq_hz, np.asarray(plant, dtype=complex))
    if coherence is not None:
        _xml_frf(lst, "m_pMeasCoherence", freq_hz, np.asarray(coherence, dtype=float))
    regs = ET.SubElement(root, "LinkedList", name="m_listpSpeedLoopRegulators")
    for ctrl in (tuning.original, tuning.tuned):
        if ctrl is None:
            continue
        node = ET.SubElement(regs, "SpeedController")
        _xml_scalar(node, "m_dKpGain", ctrl.kp)
        _xml_scalar(node, "m_dIntegralTime", 0.0 if math.isinf(ctrl.tn_s) else ctrl.tn_s)
        filters = ET.SubElement(node, "ConTimeFilterList", name="m_CurrentFilters")
        for f in ctrl.filters:
            tag, values = _filter_names(f)
            e = ET.SubElement(filters, tag)
            ET.SubElement(e, "bool", name="m_bFilterIsEnabled").text = "1" if f.enabled else "0"
            for name, value in zip(_FILTERS[tag][1], values, strict=True):
                _xml_scalar(e, name, value)
    if tuning.sample_time_s is not None:
        _xml_scalar(root, "m_dActValDelayTime", tuning.sample_time_s)
    ET.indent(root)
    return ET.tostring(root, encoding=ENCODING, xml_declaration=True)


def write_servo_tuning_xml(path: str | os.PathLike[str], freq_hz: np.ndarray, plant: np.ndarray,
                           tuning: DriveSpeedTuning, coherence: np.ndarray | None = None, *,
                           force: bool = False) -> None:
    """Write :func:`servo_tuning_xml` atomically (``force``: replace an existing file)."""
    atomic_write_bytes(path, servo_tuning_xml(freq_hz, plant, tuning, coherence), force=force)
