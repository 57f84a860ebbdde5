"""LinuxCNC's ``pid`` HAL component: the whole cascade as one PID into a torque- or current-mode amplifier, written as
the ``[JOINT_n]`` keys of the machine's INI (``P``, ``I``, ``D``, ``FF0``, ``FF1``, ``FF2``, ``MAX_OUTPUT``) and the
servo period of ``[EMCMOT]``.

``pid.c`` per servo period ``T`` (LinuxCNC/linuxcnc ``src/hal/components/pid.c``): ``e = command - feedback``;
``errorI += e T``; ``errorD = (command - prev_cmd)/T - (feedback - prev_fb)/T``; ``output = P e + I errorI +
D errorD + FF0 command + FF1 commandD + FF2 commandDD`` (``commandD``, ``commandDD`` backward differences).
feedtune's cascade with both loops at the servo rate (``N = 1``), no filters, one encoder::

    u = Kp (Kv e + kv_ff vr - v) + I,  I += Kp/(fs Tn) (Kv e + kv_ff vr - v)

sums, with ``vr - v`` the backward difference of ``e``, to exactly that PID (the integral of ``e``'s backward
difference telescopes):

* ``P = Kp (Kv + 1/Tn)``, ``I = Kp Kv / Tn``, ``D = Kp``;
* ``FF0 = Kp (kv_ff - 1) / Tn``, ``FF1 = Kp (kv_ff - 1)``, ``FF2 = J_ff``.

Reading back, ``Kv`` and ``1/Tn`` are the roots of ``t^2 - (P/D) t + I/D`` (the PID is symmetric in them: either
assignment is the same law); the ``# cascade:`` comment feedtune writes says which is which, otherwise ``Kv`` is the
larger root. Complex roots (a PID no cascade equals) are refused.

Units: the output in the file's command unit (the amplifier's input scale is the HAL file's business), positions in
the joint's machine unit (``--machine-unit``: mm for a file in m, deg for one in rad, by default): every gain per
machine unit = the gain per position unit / (machine units per position unit).

The law the target runs: the cascade at the servo rate (``SERVO_PERIOD``, default 1 ms), its position loop at the same
rate, no current-setpoint filter (every filter dropped), numbers in double precision (written exactly).
"""

from __future__ import annotations

import math
import re

from ...control.cascade import CascadeLaw, describe_filter
from ...errors import DataError, UsageError
from .common import DriveOptions, DriveText, TargetLaw, number, rates

NAME = "linuxcnc-pid"
TITLE = "LinuxCNC pid (INI [JOINT_n])"
FS_HZ = 1000.0
"""LinuxCNC's default servo thread rate [Hz] (``[EMCMOT] SERVO_PERIOD = 1000000`` ns)."""
MACHINE_UNITS = {"m": {"m": 1.0, "mm": 1e3, "inch": 1 / 0.0254},
                 "rad": {"rad": 1.0, "deg": 180 / math.pi, "turn": 1 / (2 * math.pi)}}
"""Machine units per position unit, by the gains file's position unit."""
DEFAULT_MACHINE_UNIT = {"m": "mm", "rad": "deg"}
_CASCADE = re.compile(r"#\s*cascade:\s*Kv\s*=\s*([0-9.eE+-]+)\s*1/s")
_UNITS = re.compile(r"#\s*units:\s*output\s+(\S+)\s+per\s+(\S+)")


def _scale(position_unit: str, machine_unit: str | None) -> tuple[str, float]:
    units = MACHINE_UNITS.get(position_unit)
    if units is None:
        raise UsageError(f"{NAME}: positions in {position_unit!r}; expected rad or m", parameter="gains")
    mu = machine_unit or DEFAULT_MACHINE_UNIT[position_unit]
    if mu not in units:
        raise UsageError(f"machine_unit {mu!r}: for positions in {position_unit} expected one of "
                         f"{', '.join(units)}", parameter="machine_unit")
    return mu, units[mu]


def pid_gains(law: CascadeLaw) -> dict[str, float]:
    """``{P, I, D, FF0, FF1, FF2}`` of ``law`` per the file's position unit (module docstring)."""
    inv_tn = 0.0 if math.isinf(law.tn_s) else 1.0 / law.tn_s
    kp = law.kp
    return {"P": kp * (law.kv + inv_tn), "I": kp * law.kv * inv_tn, "D": kp,
            "FF0": kp * (law.kv_ff - 1.0) * inv_tn, "FF1": kp * (law.kv_ff - 1.0), "FF2": law.inertia_ff}


def write(law: CascadeLaw, options: DriveOptions, source: str = "", joint: int = 0) -> DriveText:
    """The INI keys of ``law`` (module docstring)."""
    if law.position_encoder != "motor":
        raise UsageError(f"{NAME}: the position loop closes on the load encoder; pid has one feedback",
                         parameter="gains")
    fs, _ = rates(law, options, FS_HZ, 1)
    period_ns = 1e9 / fs
    if abs(period_ns - round(period_ns)) > 1e-6:
        raise UsageError(f"fs_hz {fs:g}: SERVO_PERIOD is a whole number of ns", parameter="fs_hz")
    mu, c = _scale(law.position_unit, options.machine_unit)
    g = pid_gains(law)
    u, p = law.command_unit, law.position_unit
    dropped = [f"{describe_filter(f)}: pid has no filter" for f in law.enabled_filters]
    why = {"P": f"Kp (Kv + 1/Tn) [{u}/{p}]", "I": f"Kp Kv / Tn [{u}/({p} s)]", "D": f"Kp [{u}/({p}/s)]",
           "FF0": f"Kp (kv_ff - 1) / Tn [{u}/{p}]", "FF1": f"Kp (kv_ff - 1) [{u}/({p}/s)]",
           "FF2": f"J_ff [{u}/({p}/s^2)]"}
    tn = "none" if math.isinf(law.tn_s) else f"{law.tn_s:.17g} s"
    lines = [f"# {TITLE}: written by feedtune from {source or 'a cascade gains file'}",
             "# the cascade (speed PI, position gain, feedforward) as one PID at the servo rate, output to a torque or "
             "current-mode amplifier",
             f"# cascade: Kv = {law.kv:.17g} 1/s, Kp = {law.kp:.17g} {u}/({p}/s), Tn = {tn}, kv_ff = {law.kv_ff:.17g}",
             f"# units: output {u} per {mu}",
             f"# conversion: every gain per {mu} = per {p} / {c:.17g} ({mu} per {p})",
             *(f"# not written: {d}" for d in dropped),
             "# HAL: setp pid.N.Pgain [JOINT_n]P (Igain I, Dgain D, FF0, FF1, FF2, maxoutput MAX_OUTPUT)",
             "[EMCMOT]", f"# servo thread period [ns]: the rate this law is certified at ({fs:g} Hz)",
             f"SERVO_PERIOD = {round(period_ns)}", "", f"[JOINT_{joint}]"]
    params: dict[str, float] = {"SERVO_PERIOD": float(round(period_ns))}
    for k in ("P", "I", "D", "FF0", "FF1", "FF2"):
        v = g[k] / c
        lines += [f"# {k} = {why[k]} / {c:.17g}", f"{k} = {v!r}"]
        params[k] = v
    out_max = options.u_max or 0.0
    lines += [f"# MAX_OUTPUT [{u}]: the output limit (0: none)", f"MAX_OUTPUT = {out_max!r}"]
    params["MAX_OUTPUT"] = out_max
    return DriveText("\n".join(lines) + "\n", tuple(dropped), params)


def read(text: str, where: str, options: DriveOptions, base: CascadeLaw | None = None,
         joint: int = 0) -> TargetLaw:
    """The law an INI's ``[JOINT_n]`` pid keys and ``[EMCMOT] SERVO_PERIOD`` run, in the output unit per the
    position unit (rad or m) of the machine unit."""
    sections: dict[str, dict[str, str]] = {}
    current = None
    for i, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line[0] in "#;":
            continue
        if line.startswith("[") and line.endswith("]"):
            current = sections.setdefault(line[1:-1].strip(), {})
            continue
        name, eq, value = line.partition("=")
        if not eq or current is None:
            raise DataError(f"{where}: line {i}: expected KEY = VALUE inside a [SECTION], got {raw.strip()!r}")
        current[name.strip()] = value.strip()
    sec = sections.get(f"JOINT_{joint}")
    if sec is None:
        raise DataError(f"{where}: no [JOINT_{joint}] section")
    units = _UNITS.search(text)
    cu = options.command_unit or (units.group(1) if units else None)
    if cu is None:
        raise DataError(f"{where}: the pid output's unit is not stated; give it with --command-unit (A, N*m, V ...)")
    mu = options.machine_unit or (units.group(2) if units else None)
    pu = next((p for p, m in MACHINE_UNITS.items() if mu in m), None)
    if pu is None:
        raise DataError(f"{where}: the joint's machine unit is not stated; give it with --machine-unit "
                        "(mm, m, inch, deg, rad, turn)")
    c = MACHINE_UNITS[pu][mu]
    emc = sections.get("EMCMOT", {})
    fs = options.fs_hz or (1e9 / number(emc, "SERVO_PERIOD", where) if "SERVO_PERIOD" in emc else FS_HZ)
    g = {k: number(sec, k, where, 0.0) * c for k in ("P", "I", "D", "FF0", "FF1", "FF2")}
    kp = g["D"]
    if kp <= 0:
        raise DataError(f"{where}: [JOINT_{joint}] D = {sec.get('D', '0')}: the cascade's speed gain Kp is D (> 0); "
                        "a PID without D is no speed loop")
    s, prod = g["P"] / kp, g["I"] / kp
    disc = s * s - 4 * prod
    if disc < -1e-12 * s * s or s < 0 or prod < 0:
        raise DataError(f"{where}: [JOINT_{joint}] P, I, D: t^2 - (P/D) t + I/D has no two real roots >= 0: no "
                        "cascade (Kv, Tn) equals this PID")
    r1 = 0.5 * (s + math.sqrt(max(disc, 0.0)))
    r2 = s - r1
    hint = _CASCADE.search(text)
    kv, inv_tn = r1, r2
    if hint is not None and abs(float(hint.group(1)) - r2) < abs(float(hint.group(1)) - r1):
        kv, inv_tn = r2, r1
    kv_ff = 1.0 + g["FF1"] / kp
    law = CascadeLaw(kp, math.inf if inv_tn <= 0 else 1.0 / inv_tn, (), kv, fs, 1,
                     base.delay_samples if base else 1, kv_ff, g["FF2"], "motor", cu, pu)
    notes = []
    ff0 = kp * (kv_ff - 1.0) * inv_tn
    if abs(g["FF0"] - ff0) > 1e-9 * max(abs(g["FF0"]), abs(ff0), 1e-300):
        notes.append(f"FF0 = {g['FF0'] / c:g} is not Kp (kv_ff - 1)/Tn = {ff0 / c:g}: the reference path differs "
                     "from the cascade's (the loops do not)")
    return TargetLaw(law, tuple(notes))


__all__ = ["FS_HZ", "MACHINE_UNITS", "NAME", "TITLE", "pid_gains", "read", "write"]
