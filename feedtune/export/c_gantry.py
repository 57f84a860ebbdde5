"""The C headers of gantry gains documents (``kind = "gantry"``: MIMO or independent PIDs, thesis section 4.4.2) and
of loop-shaped x-axis documents (``kind = "axis"``, eq. 4.18-4.20).

Each is rendered from the runtime that executes the document (:class:`~feedtune.machines.gantry.runtime.
GantryRuntime`, :class:`~feedtune.machines.gantry.runtime.AxisRuntime`): the same sections, gains and schedule, and
``PREFIX_step()`` performs the operations of its ``step`` in the same order (docs/gantry_gains.md).

In ``float`` precision the filters are in difference form (:func:`~feedtune.export.c_common.difference_form`) and a
pre-filtered reference is carried in two parts, the reference and the pre-filter's small correction, which the
filters difference apart: their float sum would be rounded at the position's resolution, and the acceleration
feedforward's second difference would multiply that rounding.

An axis or gantry document with a ``[friction_feedforward]`` adds eq. 2.1 + viscous term of the previewed reference's
backward difference velocity [m/s] to the feedforward (:func:`~feedtune.export.c_common.friction_function`, as
:class:`~feedtune.machines.gantry.runtime.AxisRuntime` and :class:`~feedtune.machines.gantry.runtime.GantryRuntime`;
the gantry splits it ``alpha1 d, alpha2 d`` between the drives with the schedule's ``alpha`` at ``x``); the header
then includes ``<math.h>`` (link with ``-lm``).
"""

from __future__ import annotations

from .c_common import (
    CFilter,
    COptions,
    banner,
    filter_step_function,
    filter_type,
    friction_constants,
    friction_function,
    integrate_line,
    limit_lines,
    output_line,
    row_array,
    table_array,
)
from .c_shaper import shaper_c
from .c_text import comment_text

PREFILTER = ("prefilter_vel", "prefilter_acc", "prefilter_jerk", "prefilter_snap")
"""Sections of the pre-filter terms (velocity .. snap)."""


def _sampling(rt, opts: COptions) -> list[str]:
    P = opts.P
    return [f"#define {P}_FS_HZ {opts.num(rt.fs)}", f"#define {P}_DELAY_SAMPLES {rt.delay_samples}",
            f"#define {P}_PREVIEW_SAMPLES {rt.preview_samples}", ""]


COMMAND_FILTERS = ("H", "LEAD", "C")
"""Filters of an error or a command (the others filter the reference position)."""


def _filters(opts: COptions, rt, keys: dict[str, str]) -> dict[str, CFilter]:
    """The filters of the runtime ``rt`` named ``PREFIX_NAME`` (``keys``: name -> key of ``rt.sos``)."""
    return {n: CFilter(opts, f"{opts.P}_{n}", rt.sos[k], n not in COMMAND_FILTERS) for n, k in keys.items()}


def _state_arrays(flt: dict[str, CFilter], names, opts: COptions) -> list[str]:
    return [f"    {opts.real} {flt[n].state(n.lower())};" for n in names]


def gantry_header(doc: dict, rt, opts: COptions, where: str = "gains file") -> str:
    """The header of a gantry gains document executed by ``rt`` (a ``GantryRuntime``, which has validated it)."""
    prefix, P, R, num, unit = opts.prefix, opts.P, opts.real, opts.num, comment_text(rt.command_unit)
    mimo = rt.controller == "mimo"
    fr = rt.friction
    shaper = shaper_c(rt, opts, rt.source)
    ncol = rt.schedule.shape[1] if rt._prefilter_on else 5
    law = ("MIMO law of section 4.4.2 (lead on the CoM error, damping of the yaw error, integral action, CoM "
           "feedforward)" if mimo else "independent PIDs on each side with the CoM feedforward")
    if fr is not None:
        law += " and friction feedforward (eq. 2.1 + viscous) split alpha1 : alpha2"
    out = banner(f"Gantry controller '{comment_text(rt.controller)}': {law}.", doc, opts, [
        f"fs = {rt.fs:g} Hz, computational delay {rt.delay_samples} sample(s), reference preview "
        f"{rt.preview_samples} sample(s). Positions in m, commands u1, u2 in {unit}.",
        f"Call {prefix}_init() once, then {prefix}_step() every sample with the gantry reference y_r[k + "
        f"{P}_PREVIEW_SAMPLES], the encoders y1[k], y2[k] and the table position x[k] [m] (schedule);",
        "apply u1, u2 with the computational delay the design assumed. A NaN x uses the first schedule row."])
    out += [*(["#include <math.h>"] if fr is not None else []), "", *_sampling(rt, opts), *limit_lines(opts, unit)]
    g = rt.gains
    if mimo:
        out += [f"static const {R} {P}_BETA = {num(g['beta'])}; /* {unit}/(m/s), yaw damping */",
                f"static const {R} {P}_KI = {num(g['ki'])}; /* {unit}/(m s), integral gain */"]
    else:
        units = {"kp": f"{unit}/m", "kd": f"{unit}/(m/s)", "ki": f"{unit}/(m s)"}
        out += [f"static const {R} {P}_{k.upper()} = {num(g[k])}; /* {units[k[:2]]} */"
                for k in ("kp1", "kd1", "ki1", "kp2", "kd2", "ki2")]
    out += ["", f"#define {P}_NX {rt.schedule_x.size}", f"#define {P}_NCOL {ncol}",
            *row_array(f"{P}_SCHED_X", rt.schedule_x, "table positions of the schedule [m]", R), ""]
    out += table_array(f"{P}_SCHED", rt.schedule[:, :ncol],
                       "schedule rows: alpha1, alpha2 [-], m11, m12, m22 [" + unit + "/(m/s^2)]"
                       + (", k_vel..k_snap side 1 then side 2 [s..s^4]" if ncol > 5 else ""), R)
    out += ["", *friction_constants(fr, opts)] if fr is not None else []
    out += shaper.constants if shaper else []
    names = ["H", "POS", "ACC"] + (["LEAD"] if mimo else []) + (["PV", "PA", "PJ", "PS"] if ncol > 5 else [])
    keys = {"H": "filter_pack", "POS": "position", "ACC": "acceleration", "LEAD": "lead", "PV": PREFILTER[0],
            "PA": PREFILTER[1], "PJ": PREFILTER[2], "PS": PREFILTER[3]}
    flt = _filters(opts, rt, {n: keys[n] for n in names})
    out += filter_type(opts)
    for n in names:
        out += flt[n].arrays()
    twice = ["H", "POS", "ACC"]
    # the reference of each side: ra1 = r + rc1 (double: summed; float: two parts, differenced apart)
    ra1, c1, ra2, c2 = ("r", "rc1", "r", "rc2") if opts.single else ("ra1", None, "ra2", None)
    out += [
        "typedef struct {",
        *(shaper.state if shaper else []),
        *[f"    {R} {flt[n].state(n.lower() + '1')}, {flt[n].state(n.lower() + '2')};" for n in twice],
        *_state_arrays(flt, [n for n in names if n not in twice], opts),
        f"    {R} e1_prev, e2_prev, ie1, ie2, u1_prev, u2_prev;",
        *([f"    {R} r_prev;  /* previous y_r_preview [m]: the friction's reference velocity */"] if fr is not None
          else []),
        "    int started;",
        f"}} {prefix}_state;",
        "",
        f"static inline void {prefix}_init({prefix}_state *s) {{ memset(s, 0, sizeof(*s)); }}",
        "",
        *filter_step_function(opts),
        *friction_function(fr, opts),
        *(shaper.function if shaper else []),
        "/* the schedule row at table position x [m]: linear interpolation, clamped at the ends */",
        f"static inline void {prefix}_schedule({R} x, {R} *row) {{",
        "    int i = 0;",
        f"    while (i < {P}_NX && {P}_SCHED_X[i] <= x) ++i;",
        f"    if (i == 0 || i == {P}_NX) {{",
        f"        for (int c = 0; c < {P}_NCOL; ++c) row[c] = {P}_SCHED[i == 0 ? 0 : {P}_NX - 1][c];",
        "        return;",
        "    }",
        f"    {R} w = (x - {P}_SCHED_X[i - 1]) * ({num(1.0)} / ({P}_SCHED_X[i] - {P}_SCHED_X[i - 1]));",
        f"    for (int c = 0; c < {P}_NCOL; ++c)",
        f"        row[c] = {P}_SCHED[i - 1][c] + w * ({P}_SCHED[i][c] - {P}_SCHED[i - 1][c]);",
        "}",
        "",
        f"/* y_r_preview = y_r[k + {P}_PREVIEW_SAMPLES] [m]; y1, y2 = encoders at k [m]; x = table position [m];",
        f"   writes u[0], u[1] [{opts.output_unit(unit)}] */",
        f"static inline void {prefix}_step({prefix}_state *s, {R} y_r_preview, {R} y1, {R} y2, {R} x, "
        f"{R} *u) {{",
        *([shaper.call("y_r_preview")] if shaper else []),
        f"    {R} sr[{P}_NCOL];",
        f"    {prefix}_schedule(x, sr);",
        "    float r = y_r_preview, rc1 = 0.0f, rc2 = 0.0f;  /* the references of the sides: r + rc1, r + rc2 */"
        if opts.single else "    double r = y_r_preview, ra1 = r, ra2 = r;",
    ]
    if ncol > 5:
        lhs1, lhs2 = ("rc1 = ", "rc2 = ") if opts.single else ("ra1 = r + ", "ra2 = r + ")
        out += [
            f"    {R} d0 = {flt['PV'].call('pv', 'r')};",
            f"    {R} d1 = {flt['PA'].call('pa', 'r')};",
            f"    {R} d2 = {flt['PJ'].call('pj', 'r')};",
            f"    {R} d3 = {flt['PS'].call('ps', 'r')};",
            f"    {lhs1}sr[5] * d0 + sr[6] * d1 + sr[7] * d2 + sr[8] * d3;",
            f"    {lhs2}sr[9] * d0 + sr[10] * d1 + sr[11] * d2 + sr[12] * d3;",
        ]
    out += [
        f"    {R} acc1 = {flt['ACC'].call('acc1', ra1, c1)};",
        f"    {R} acc2 = {flt['ACC'].call('acc2', ra2, c2)};",
        f"    {R} e1 = {flt['POS'].call('pos1', ra1, c1)} - y1;",
        f"    {R} e2 = {flt['POS'].call('pos2', ra2, c2)} - y2;",
        *([f"    {R} fr = {prefix}_friction(s->started ? (r - s->r_prev) * {P}_FS_HZ : {opts.num(0.0)});"
           "  /* split alpha1 : alpha2 */",
           "    s->r_prev = r;"] if fr is not None else []),
        "    if (!s->started) { s->e1_prev = e1; s->e2_prev = e2; s->started = 1; }",
        integrate_line(opts, "s->ie1", "e1", f"{P}_FS_HZ", "s->u1_prev"),
        integrate_line(opts, "s->ie2", "e2", f"{P}_FS_HZ", "s->u2_prev"),
        f"    {R} w1, w2;",
    ]
    if mimo:
        out += [
            f"    {R} a1 = sr[0], a2 = sr[1];",
            f"    {R} v = {flt['LEAD'].call('lead', 'a1 * e1 + a2 * e2')};",
            f"    {R} dd = {P}_BETA * ((e1 - e2) - (s->e1_prev - s->e2_prev)) * {P}_FS_HZ;",
            f"    w1 = a1 * (v + dd + {P}_KI * s->ie1);",
            f"    w2 = a2 * (v - dd + {P}_KI * s->ie2);",
        ]
    else:
        out += [
            f"    w1 = {P}_KP1 * e1 + {P}_KD1 * (e1 - s->e1_prev) * {P}_FS_HZ + {P}_KI1 * s->ie1;",
            f"    w2 = {P}_KP2 * e2 + {P}_KD2 * (e2 - s->e2_prev) * {P}_FS_HZ + {P}_KI2 * s->ie2;",
        ]
    out += [
        "    s->e1_prev = e1; s->e2_prev = e2;",
        *output_line(opts, "u1", f"{flt['H'].call('h1', 'w1')} + sr[2] * acc1 + sr[3] * acc2"
                     + (" + sr[0] * fr" if fr is not None else "")),
        *output_line(opts, "u2", f"{flt['H'].call('h2', 'w2')} + sr[3] * acc1 + sr[4] * acc2"
                     + (" + sr[1] * fr" if fr is not None else "")),
        "    s->u1_prev = u1; s->u2_prev = u2;",
        "    u[0] = u1; u[1] = u2;",
        "}",
        "",
        f"#endif /* {P}_GAINS_H */",
        "",
    ]
    return "\n".join(out)


def axis_header(doc: dict, rt, opts: COptions, where: str = "gains file") -> str:
    """The header of a loop-shaped x-axis gains document executed by ``rt`` (an ``AxisRuntime``).

    The integral action is inside the controller's sections (``K (Ti s + 1) / s`` times leads and filters), so there
    is no separate integrator to hold: ``--anti-windup clamp`` is refused for an axis (see :func:`check_axis`).
    """
    check_axis(opts)
    prefix, P, R, num, unit = opts.prefix, opts.P, opts.real, opts.num, comment_text(rt.command_unit)
    pre = rt._prefilter_on
    fr = rt.friction
    shaper = shaper_c(rt, opts, rt.source)
    out = banner("Loop-shaped x-axis controller (eq. 4.18-4.20) with mass feedforward"
                 + (", friction feedforward (eq. 2.1 + viscous)" if fr is not None else "")
                 + " and trajectory pre-filter.",
                 doc, opts, [
                     f"fs = {rt.fs:g} Hz, computational delay {rt.delay_samples} sample(s), reference preview "
                     f"{rt.preview_samples} sample(s). Positions in m, command u_x in {unit}.",
                     f"Call {prefix}_init() once, then {prefix}_step() every sample with x_r[k + "
                     f"{P}_PREVIEW_SAMPLES] and the encoder x[k]; apply u_x with the delay the design assumed."])
    out += [*(["#include <math.h>"] if fr is not None else []), "", *_sampling(rt, opts), *limit_lines(opts, unit),
            f"static const {R} {P}_MASS = {num(rt.mass)}; /* {unit}/(m/s^2), feedforward mass */"]
    if pre:
        out += [f"static const {R} {P}_K_{t.upper()} = {num(k)}; /* s^{i + 1} */"
                for i, (t, k) in enumerate(zip(("vel", "acc", "jerk", "snap"), rt.prefilter_gains, strict=True))]
    out.append("")
    out += friction_constants(fr, opts)
    out += shaper.constants if shaper else []
    names = ["C", "POS", "ACC"] + (["PV", "PA", "PJ", "PS"] if pre else [])
    keys = {"C": "controller", "POS": "position", "ACC": "acceleration", "PV": PREFILTER[0], "PA": PREFILTER[1],
            "PJ": PREFILTER[2], "PS": PREFILTER[3]}
    flt = _filters(opts, rt, {n: keys[n] for n in names})
    out += filter_type(opts)
    for n in names:
        out += flt[n].arrays()
    # the pre-filtered reference ra = r + rc (double: summed; float: two parts, differenced apart)
    ra, corr, lhs = ("r", "rc", "rc = ") if opts.single else ("ra", None, "ra = r + ")
    out += [
        "typedef struct {",
        *(shaper.state if shaper else []),
        *_state_arrays(flt, names, opts),
        f"    {R} u_prev;",
        *([f"    {R} r_prev;  /* previous x_r_preview [m]: the friction's reference velocity */",
           "    int started;"] if fr is not None else []),
        f"}} {prefix}_state;",
        "",
        f"static inline void {prefix}_init({prefix}_state *s) {{ memset(s, 0, sizeof(*s)); }}",
        "",
        *filter_step_function(opts),
        *friction_function(fr, opts),
        *(shaper.function if shaper else []),
        f"/* x_r_preview = x_r[k + {P}_PREVIEW_SAMPLES] [m]; x = encoder at k [m]; returns u_x "
        f"[{opts.output_unit(unit)}] */",
        f"static inline {R} {prefix}_step({prefix}_state *s, {R} x_r_preview, {R} x) {{",
        *([shaper.call("x_r_preview")] if shaper else []),
        "    float r = x_r_preview, rc = 0.0f;  /* the pre-filtered reference r + rc */" if opts.single
        else "    double r = x_r_preview, ra = r;",
    ]
    if pre:
        out += [f"    {lhs}{P}_K_VEL * {flt['PV'].call('pv', 'r')} + {P}_K_ACC * {flt['PA'].call('pa', 'r')}",
                f"           + {P}_K_JERK * {flt['PJ'].call('pj', 'r')} + {P}_K_SNAP * {flt['PS'].call('ps', 'r')};"]
    out += [
        f"    {R} uff = {P}_MASS * {flt['ACC'].call('acc', 'r')};",
        *([f"    uff += {prefix}_friction(s->started ? (r - s->r_prev) * {P}_FS_HZ : {num(0.0)});",
           "    s->r_prev = r; s->started = 1;"] if fr is not None else []),
        f"    {R} e = {flt['POS'].call('pos', ra, corr)} - x;",
        *output_line(opts, "u", f"{flt['C'].call('c', 'e')} + uff"),
        "    s->u_prev = u;",
        "    return u;",
        "}",
        "",
        f"#endif /* {P}_GAINS_H */",
        "",
    ]
    return "\n".join(out)


def check_axis(opts: COptions) -> None:
    """UsageError for options an axis header cannot honour."""
    from ..errors import UsageError

    if opts.anti_windup == "clamp":
        raise UsageError("anti_windup=clamp is not available for an axis gains file: its integral action is "
                         "inside the controller's sections, with no integrator to hold (use u_max alone)",
                         parameter=("anti_windup", "u_max"))
