"""Yaskawa Sigma-II SERVOPACK: speed loop gain, integral time constant, position loop gain and torque reference
filter as a parameter list (``Pn100 = 40 ; comment``), in the Sigma-II user manual's units (docs/drive_export.md).

The speed controller is ``Kv (1 + 1/(Ti s))`` with ``Kv`` in Hz: the torque per speed error is ``2 pi Kv J`` with
``J = J_M (1 + Pn103/100)`` the motor-side inertia the drive assumes (motor rotor ``J_M``, ``Pn103`` the load's
inertia ratio [%]), so the speed gain in Hz needs the inertia (``--inertia``, [kg m^2] = [N m/(rad/s^2)]):

* ``Pn100`` speed loop gain [Hz, integer 1-2000] = ``Kp / (2 pi J)``;
* ``Pn101`` speed loop integral time constant [0.01 ms, integer 15-51200] = ``Tn / 10 us``;
* ``Pn102`` position loop gain [1/s, integer 1-2000] = ``Kv``;
* ``Pn401`` torque reference filter time constant [0.01 ms, integer] = ``T`` of the law's first PT1 (0: none).

The law the target runs: each parameter rounded to its integer step (the quantization the certificate sees: a speed
gain in whole Hz, an integral time in 10 us), at the file's rates (or ``--fs``/``--position-fs``; the SERVOPACK's
cycles are not confirmed and are stated as ``; requires:`` lines), the PT1 of ``Pn401``; other filters (the notches
``Pn408``-``Pn40E``, whose form is not confirmed) are dropped, and a law without integral action or with
``Tn > 512 ms`` is refused. ``Pn103`` is not written: set it so that ``J_M (1 + Pn103/100) = J``.
"""

from __future__ import annotations

import math
import re

from ...control.cascade import CascadeLaw, describe_filter
from ...control.drive_tuning import Pt1Filter
from ...errors import DataError, UsageError
from .common import DriveOptions, DriveText, TargetLaw, cycle_lines, number, rates, read_cycles, to_motor_frame

NAME = "yaskawa"
TITLE = "Yaskawa Sigma-II SERVOPACK"
STEP_TI_S = 1e-5
"""``Pn101`` and ``Pn401``'s unit [s] (0.01 ms)."""
RANGES = {"Pn100": (1, 2000), "Pn101": (15, 51200), "Pn102": (1, 2000), "Pn401": (0, 65535)}
CYCLES = ("speed loop cycle", "position loop cycle")
_INERTIA = re.compile(r";\s*requires:\s*inertia J\s*=\s*([0-9.eE+-]+)")


def _inertia(options: DriveOptions) -> float:
    if options.inertia is None:
        raise UsageError(f"{NAME}: the speed loop gain is in Hz; give the motor-side inertia the drive assumes, "
                         "J_M (1 + Pn103/100), with --inertia [kg*m^2]", parameter="inertia")
    return options.inertia


def _integer(name: str, value: float) -> int:
    lo, hi = RANGES[name]
    n = round(value)
    if not lo <= n <= hi:
        raise UsageError(f"{NAME}: {name} = {value:.6g} rounds to {n}, outside its range {lo}-{hi}",
                         parameter="gains")
    return n


def write(law: CascadeLaw, options: DriveOptions, source: str = "") -> DriveText:
    """The parameter list of ``law`` (module docstring)."""
    if law.position_encoder != "motor":
        raise UsageError(f"{NAME}: the position loop closes on the load encoder; this export writes the motor "
                         "encoder's loop only", parameter="gains")
    m, frame = to_motor_frame(law, options, NAME)
    j = _inertia(options)
    fs, ratio = rates(law, options, None, None)
    if math.isinf(m.tn_s):
        raise UsageError(f"{NAME}: the law has no integral action; Pn101 holds 0.15-512 ms", parameter="gains")
    pt1 = next((f for f in m.enabled_filters if isinstance(f, Pt1Filter)), None)
    dropped = [f"{describe_filter(f)}: " + ("only the first PT1 is Pn401" if isinstance(f, Pt1Filter) else
                                            "the notch form of Pn408-Pn40E is not confirmed (not written)")
               for f in m.enabled_filters if f is not pt1]
    kv_hz = m.kp / (2 * math.pi * j)
    rows = [("Pn100", _integer("Pn100", kv_hz), f"speed loop gain [Hz] = Kp / (2 pi J) = {m.kp:.9g} / (2 pi x "
                                                f"{j:.9g}) = {kv_hz:.6g} Hz, rounded"),
            ("Pn101", _integer("Pn101", m.tn_s / STEP_TI_S), f"speed loop integral time constant [0.01 ms] = Tn "
                                                           f"{m.tn_s * 1e3:.6g} ms, rounded"),
            ("Pn102", _integer("Pn102", m.kv), f"position loop gain [1/s] = Kv {m.kv:.6g} 1/s, rounded"),
            ("Pn401", 0 if pt1 is None else _integer("Pn401", pt1.time_constant_s / STEP_TI_S),
             "torque reference filter time constant [0.01 ms] = T of the PT1" + (" (none: 0)" if pt1 is None else
                                                                                  f" {pt1.time_constant_s * 1e3:.6g} ms"
                                                                                  ", rounded"))]
    head = [f"; {TITLE}: written by feedtune from {source or 'a cascade gains file'} (Sigma-II units)",
            "; law: torque = 2 pi Pn100 J (1 + 1/(Pn101 s)) (speed error) through the Pn401 filter; speed reference "
            "= Pn102 (position error)",
            *(f"; conversion: {t}" for t in frame),
            f"; requires: inertia J = {j:.17g} kg*m^2 (set Pn103 so that J_M (1 + Pn103/100) = J)",
            *cycle_lines(fs, ratio, CYCLES, ";"),
            *(f"; not written: {d}" for d in dropped)]
    body = [f"{n} = {v}".ljust(14) + f"; {c}" for n, v, c in rows]
    return DriveText("\n".join(head + body) + "\n", tuple(dropped), {n: float(v) for n, v, _ in rows})


def read(text: str, where: str, options: DriveOptions, base: CascadeLaw | None = None) -> TargetLaw:
    """The law a parameter list of :func:`write`'s form runs (motor frame: rad, N m)."""
    from .common import parse_assignments

    values = parse_assignments(text, where, ";")
    stated = _INERTIA.search(text)
    j = options.inertia or (float(stated.group(1)) if stated else None)
    if j is None:
        raise DataError(f"{where}: the inertia the speed loop gain refers to is not stated; give it with --inertia "
                        "[kg*m^2]")
    fs, ratio = read_cycles(text, where, options, CYCLES)
    p = {}
    for name in RANGES:
        v = number(values, name, where, 0.0 if name == "Pn401" else None)
        lo, hi = RANGES[name]
        if v != round(v) or not lo <= v <= hi:
            raise DataError(f"{where}: {name} = {values.get(name)}: expected an integer {lo}-{hi}")
        p[name] = v
    filters = (Pt1Filter(p["Pn401"] * STEP_TI_S),) if p["Pn401"] else ()
    b = base
    law = CascadeLaw(2 * math.pi * p["Pn100"] * j, p["Pn101"] * STEP_TI_S, filters, p["Pn102"], fs, ratio,
                     b.delay_samples if b else 1, b.kv_ff if b else 1.0, b.inertia_ff if b else 0.0, "motor", "N*m",
                     "rad")
    return TargetLaw(law)


__all__ = ["NAME", "RANGES", "TITLE", "read", "write"]
