"""SINAMICS S120 (servo) speed controller and current setpoint filters, with the SINUMERIK position gain MD32200.

Written (one line each, ``;`` comments; drive data set 0, NC parameter set 0; docs/drive_export.md for sources):

* ``p1460[0]`` speed controller P gain [Nms/rad] = ``Kp`` in the motor frame [N m/(rad/s)];
* ``p1462[0]`` speed controller integral time [ms] = ``1000 Tn`` (0: no integral action);
* ``p1656[0]`` current setpoint filter activation, bit ``i`` = filter ``i + 1``;
* per filter ``i`` (1-4; parameters ``p1657 + 5 (i - 1)`` ...): type (1 = PT2 low pass, 2 = general second-order
  filter), denominator natural frequency [Hz], denominator damping, numerator natural frequency [Hz], numerator
  damping; a feedtune notch is a general second-order filter with equal frequencies, ``DN = zeta_p``,
  ``DZ = zeta_z``;
* ``$MA_POSCTRL_GAIN[0,AX1]`` (MD32200) [1000/min] = ``0.06 Kv`` [1/s] (1000/min = (m/min)/mm = 1000/60 1/s).

The law the target runs: the cascade law at the speed controller cycle (``p0115[1]``) and the position control cycle
of the NC, each parameter rounded to single precision (REAL32); a PT1 and filters beyond the fourth cannot be
written and are dropped. The cycles are the file's unless ``--fs``/``--position-fs`` say otherwise; they are written
as ``; requires:`` lines (not as parameters: both are set by the drive's and the NC's commissioning).
"""

from __future__ import annotations

import math

from ...control.cascade import CascadeLaw, describe_filter
from ...control.drive_tuning import Pt1Filter, Pt2Filter, SecondOrderFilter
from ...errors import DataError
from .common import (
    DriveOptions,
    DriveText,
    TargetLaw,
    cycle_lines,
    f32_text,
    float32,
    number,
    rates,
    read_cycles,
    to_motor_frame,
)

NAME = "sinamics"
TITLE = "SINAMICS S120 servo + SINUMERIK MD32200"
MAX_FILTERS = 4
KV_PER_1000_MIN = 1000.0 / 60.0
"""1/s per 1000/min: Kv [1/s] = Kv [1000/min] x 1000/60."""
FILTER_BASE = 1657
"""Filter 1's type parameter; filter i's five parameters start at p(1657 + 5 (i - 1))."""
CYCLES = ("speed controller cycle", "position control cycle")
"""The cycles a file states: the speed controller's (``p0115[1]``) and the NC's position control cycle
(``$MN_SYSCLOCK_CYCLE_TIME x $MN_POSCTRL_SYSCLOCK_TIME_RATIO``)."""


def _filter_lines(i: int, f) -> tuple[list[tuple[str, str, str]], int]:
    base = FILTER_BASE + 5 * i
    if isinstance(f, Pt2Filter):
        kind, fn, dn, fz, dz = 1, f.freq_hz, f.damping, f.freq_hz, f.damping
        what = "1 = PT2 low pass"
    else:
        kind, fn, dn, fz, dz = 2, f.den_freq_hz, f.den_damping, f.num_freq_hz, f.num_damping
        what = "2 = general second-order filter"
    n = i + 1
    rows = [(f"p{base}[0]", str(kind), f"filter {n} type: {what} ({describe_filter(f)})"),
            (f"p{base + 1}[0]", f32_text(fn), f"filter {n} denominator natural frequency fN [Hz]"),
            (f"p{base + 2}[0]", f32_text(dn), f"filter {n} denominator damping DN [-]"),
            (f"p{base + 3}[0]", f32_text(fz), f"filter {n} numerator natural frequency fZ [Hz]"
             + (" (unused by PT2; = fN)" if kind == 1 else "")),
            (f"p{base + 4}[0]", f32_text(dz), f"filter {n} numerator damping DZ [-]"
             + (" (unused by PT2; = DN)" if kind == 1 else ""))]
    return rows, (1 << i) if f.enabled else 0


def write(law: CascadeLaw, options: DriveOptions, source: str = "") -> DriveText:
    """The parameter list of ``law`` (module docstring)."""
    m, frame = to_motor_frame(law, options, NAME)
    fs, ratio = rates(law, options, None, None)
    dropped, filters = [], []
    for f in m.filters:
        if isinstance(f, Pt1Filter):
            dropped.append(f"{describe_filter(f)}: SINAMICS's current setpoint filters are PT2 or general second "
                           "order (no PT1)")
        elif len(filters) == MAX_FILTERS:
            dropped.append(f"{describe_filter(f)}: beyond the {MAX_FILTERS} current setpoint filters p1656-p1676")
        else:
            filters.append(f)
    rows: list[tuple[str, str, str]] = []
    rows.append(("p1460[0]", f32_text(m.kp), f"speed controller P gain [Nms/rad] = Kp {m.kp:.9g} N*m/(rad/s)"))
    tn_ms = 0.0 if math.isinf(m.tn_s) else m.tn_s * 1e3
    rows.append(("p1462[0]", f32_text(tn_ms), "speed controller integral time [ms] = Tn [s] x 1000"
                 + (" (0: no integral action)" if math.isinf(m.tn_s) else f" = {m.tn_s:.9g} s x 1000")))
    mask, frows = 0, []
    for i, f in enumerate(filters):
        r, bit = _filter_lines(i, f)
        frows += r
        mask |= bit
    rows.append(("p1656[0]", str(mask), "current setpoint filter activation: bit i = filter i+1 "
                 f"(filters {', '.join(str(i + 1) for i in range(len(filters)) if mask >> i & 1) or 'none'} on)"))
    rows += frows
    kv_md = 0.06 * m.kv
    rows.append((f"$MA_POSCTRL_GAIN[0,{options.axis}]", f"{kv_md:.17g}",
                 f"MD32200 position loop gain [1000/min] = 0.06 x Kv {m.kv:.9g} 1/s"))
    head = [f"; {TITLE}: written by feedtune from {source or 'a cascade gains file'}",
            "; law: speed PI Kp (1 + 1/(s Tn)) then the current setpoint filters; NC position gain Kv on the speed "
            "setpoint",
            *(f"; conversion: {t}" for t in frame),
            *cycle_lines(fs, ratio, CYCLES, ";"),
            "; (the speed controller cycle is p0115[1]; the position control cycle the NC's $MN_SYSCLOCK_CYCLE_TIME x "
            "$MN_POSCTRL_SYSCLOCK_TIME_RATIO)",
            *(f"; not written: {d}" for d in dropped)]
    if m.kv_ff != 1.0 or m.inertia_ff:
        head.append(f"; not written: velocity feedforward x{m.kv_ff:.6g} and torque feedforward "
                    f"{m.inertia_ff:.6g} N*m/(rad/s^2) (set by the NC's FFW_MODE/VELO_FFW_WEIGHT)")
    width = max(len(n) + len(v) for n, v, _ in rows) + 4
    body = [f"{n} = {v}".ljust(width) + f"; {c}" for n, v, c in rows]
    return DriveText("\n".join(head + body) + "\n", tuple(dropped), {n: float(v) for n, v, _ in rows})


def read(text: str, where: str, options: DriveOptions, base: CascadeLaw | None = None) -> TargetLaw:
    """The law a parameter list of :func:`write`'s form runs (motor frame: rad, N m); ``base`` gives what the list
    does not hold (the computational delay, the position encoder, the feedforward)."""
    from .common import parse_assignments

    values = parse_assignments(text, where, ";")
    fs, ratio = read_cycles(text, where, options, CYCLES)
    kp = float32(number(values, "p1460[0]", where))
    tn_ms = float32(number(values, "p1462[0]", where))
    mask = int(number(values, "p1656[0]", where, 0.0))
    filters = []
    for i in range(MAX_FILTERS):
        b = FILTER_BASE + 5 * i
        if f"p{b}[0]" not in values:
            continue
        kind = int(number(values, f"p{b}[0]", where))
        fn, dn = (float32(number(values, f"p{b + k}[0]", where)) for k in (1, 2))
        on = bool(mask >> i & 1)
        if kind == 1:
            filters.append(Pt2Filter(fn, dn, on))
        elif kind == 2:
            fz, dz = (float32(number(values, f"p{b + k}[0]", where)) for k in (3, 4))
            filters.append(SecondOrderFilter(fz, dz, fn, dn, on))
        else:
            raise DataError(f"{where}: p{b}[0] = {kind}: expected 1 (PT2) or 2 (general second order)")
    axis_kv = [k for k in values if k.startswith("$MA_POSCTRL_GAIN[0")]
    kv = number(values, axis_kv[0], where) * KV_PER_1000_MIN if axis_kv else 0.0
    b = base or CascadeLaw(1.0, math.inf)
    law = CascadeLaw(kp, math.inf if tn_ms == 0 else tn_ms * 1e-3, tuple(filters), kv, fs, ratio,
                     b.delay_samples, b.kv_ff if base else 1.0, b.inertia_ff if base else 0.0, b.position_encoder,
                     "N*m", "rad")
    return TargetLaw(law)


__all__ = ["NAME", "TITLE", "read", "write"]
