"""The C headers of gantry gains documents (``kind = "gantry"``: MIMO or independent PIDs, thesis section 4.4.2) and
of loop-shaped x-axis documents (``kind = "axis"``, eq. 4.18-4.20).

Each is rendered from the runtime that executes the document (:class:`~feedtune.machines.gantry.runtime.
GantryRuntime`, :class:`~feedtune.machines.gantry.runtime.AxisRuntime`): the same sections, gains and schedule, and
``PREFIX_step()`` performs the operations of its ``step`` in the same order (docs/gantry_gains.md).
"""

from __future__ import annotations

from .c_common import (
    COptions,
    banner,
    c_double,
    double_array,
    integrate_line,
    limit_lines,
    output_line,
    sos_array,
    sos_step_function,
    table_array,
)

PREFILTER = ("prefilter_vel", "prefilter_acc", "prefilter_jerk", "prefilter_snap")
"""Sections of the pre-filter terms (velocity .. snap)."""


def _sampling(rt, opts: COptions) -> list[str]:
    P = opts.P
    return [f"#define {P}_FS_HZ {c_double(rt.fs)}", f"#define {P}_DELAY_SAMPLES {rt.delay_samples}",
            f"#define {P}_PREVIEW_SAMPLES {rt.preview_samples}", ""]


def _state_arrays(names, P: str) -> list[str]:
    return [f"    double {n.lower()}[{P}_{n}_NSEC][2];" for n in names]


def gantry_header(doc: dict, rt, opts: COptions) -> str:
    """The header of a gantry gains document executed by ``rt`` (a ``GantryRuntime``)."""
    prefix, P, unit = opts.prefix, opts.P, rt.command_unit
    mimo = rt.controller == "mimo"
    ncol = rt.schedule.shape[1] if rt._prefilter_on else 5
    law = ("MIMO law of section 4.4.2 (lead on the CoM error, damping of the yaw error, integral action, CoM "
           "feedforward)" if mimo else "independent PIDs on each side with the CoM feedforward")
    out = banner(f"Gantry controller '{rt.controller}': {law}.", doc, opts, [
        f"fs = {rt.fs:g} Hz, computational delay {rt.delay_samples} sample(s), reference preview "
        f"{rt.preview_samples} sample(s). Positions in m, commands u1, u2 in {unit}.",
        f"Call {prefix}_init() once, then {prefix}_step() every sample with the gantry reference y_r[k + "
        f"{P}_PREVIEW_SAMPLES], the encoders y1[k], y2[k] and the table position x[k] [m] (schedule);",
        "apply u1, u2 with the computational delay the design assumed. A NaN x uses the first schedule row."])
    out += ["", *_sampling(rt, opts), *limit_lines(opts, unit)]
    g = rt.gains
    if mimo:
        out += [f"static const double {P}_BETA = {c_double(g['beta'])}; /* {unit}/(m/s), yaw damping */",
                f"static const double {P}_KI = {c_double(g['ki'])}; /* {unit}/(m s), integral gain */"]
    else:
        units = {"kp": f"{unit}/m", "kd": f"{unit}/(m/s)", "ki": f"{unit}/(m s)"}
        out += [f"static const double {P}_{k.upper()} = {c_double(g[k])}; /* {units[k[:2]]} */"
                for k in ("kp1", "kd1", "ki1", "kp2", "kd2", "ki2")]
    out += ["", f"#define {P}_NX {rt.schedule_x.size}", f"#define {P}_NCOL {ncol}",
            *double_array(f"{P}_SCHED_X", rt.schedule_x, "table positions of the schedule [m]"), ""]
    out += table_array(f"{P}_SCHED", rt.schedule[:, :ncol],
                       "schedule rows: alpha1, alpha2 [-], m11, m12, m22 [" + unit + "/(m/s^2)]"
                       + (", k_vel..k_snap side 1 then side 2 [s..s^4]" if ncol > 5 else ""))
    names = ["H", "POS", "ACC"] + (["LEAD"] if mimo else []) + (["PV", "PA", "PJ", "PS"] if ncol > 5 else [])
    keys = {"H": "filter_pack", "POS": "position", "ACC": "acceleration", "LEAD": "lead", "PV": PREFILTER[0],
            "PA": PREFILTER[1], "PJ": PREFILTER[2], "PS": PREFILTER[3]}
    for n in names:
        out += sos_array(f"{P}_{n}", rt.sos[keys[n]])
    twice = ["H", "POS", "ACC"]
    out += [
        "typedef struct {",
        *[f"    double {n.lower()}1[{P}_{n}_NSEC][2], {n.lower()}2[{P}_{n}_NSEC][2];" for n in twice],
        *_state_arrays([n for n in names if n not in twice], P),
        "    double e1_prev, e2_prev, ie1, ie2, u1_prev, u2_prev;",
        "    int started;",
        f"}} {prefix}_state;",
        "",
        f"static inline void {prefix}_init({prefix}_state *s) {{ memset(s, 0, sizeof(*s)); }}",
        "",
        *sos_step_function(prefix),
        "/* the schedule row at table position x [m]: linear interpolation, clamped at the ends */",
        f"static inline void {prefix}_schedule(double x, double *row) {{",
        "    int i = 0;",
        f"    while (i < {P}_NX && {P}_SCHED_X[i] <= x) ++i;",
        f"    if (i == 0 || i == {P}_NX) {{",
        f"        for (int c = 0; c < {P}_NCOL; ++c) row[c] = {P}_SCHED[i == 0 ? 0 : {P}_NX - 1][c];",
        "        return;",
        "    }",
        f"    double w = (x - {P}_SCHED_X[i - 1]) * (1.0 / ({P}_SCHED_X[i] - {P}_SCHED_X[i - 1]));",
        f"    for (int c = 0; c < {P}_NCOL; ++c)",
        f"        row[c] = {P}_SCHED[i - 1][c] + w * ({P}_SCHED[i][c] - {P}_SCHED[i - 1][c]);",
        "}",
        "",
        f"/* y_r_preview = y_r[k + {P}_PREVIEW_SAMPLES] [m]; y1, y2 = encoders at k [m]; x = table position [m];",
        f"   writes u[0], u[1] [{unit}] */",
        f"static inline void {prefix}_step({prefix}_state *s, double y_r_preview, double y1, double y2, double x, "
        "double *u) {",
        f"    double sr[{P}_NCOL];",
        f"    {prefix}_schedule(x, sr);",
        "    double r = y_r_preview, ra1 = r, ra2 = r;",
    ]
    if ncol > 5:
        out += [
            f"    double d0 = {prefix}_sos_step({P}_PV, s->pv, {P}_PV_NSEC, r);",
            f"    double d1 = {prefix}_sos_step({P}_PA, s->pa, {P}_PA_NSEC, r);",
            f"    double d2 = {prefix}_sos_step({P}_PJ, s->pj, {P}_PJ_NSEC, r);",
            f"    double d3 = {prefix}_sos_step({P}_PS, s->ps, {P}_PS_NSEC, r);",
            "    ra1 = r + sr[5] * d0 + sr[6] * d1 + sr[7] * d2 + sr[8] * d3;",
            "    ra2 = r + sr[9] * d0 + sr[10] * d1 + sr[11] * d2 + sr[12] * d3;",
        ]
    out += [
        f"    double acc1 = {prefix}_sos_step({P}_ACC, s->acc1, {P}_ACC_NSEC, ra1);",
        f"    double acc2 = {prefix}_sos_step({P}_ACC, s->acc2, {P}_ACC_NSEC, ra2);",
        f"    double e1 = {prefix}_sos_step({P}_POS, s->pos1, {P}_POS_NSEC, ra1) - y1;",
        f"    double e2 = {prefix}_sos_step({P}_POS, s->pos2, {P}_POS_NSEC, ra2) - y2;",
        "    if (!s->started) { s->e1_prev = e1; s->e2_prev = e2; s->started = 1; }",
        integrate_line(opts, "s->ie1", "e1", f"{P}_FS_HZ", "s->u1_prev"),
        integrate_line(opts, "s->ie2", "e2", f"{P}_FS_HZ", "s->u2_prev"),
        "    double w1, w2;",
    ]
    if mimo:
        out += [
            "    double a1 = sr[0], a2 = sr[1];",
            f"    double v = {prefix}_sos_step({P}_LEAD, s->lead, {P}_LEAD_NSEC, a1 * e1 + a2 * e2);",
            f"    double dd = {P}_BETA * ((e1 - e2) - (s->e1_prev - s->e2_prev)) * {P}_FS_HZ;",
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
        *output_line(opts, "u1", f"{prefix}_sos_step({P}_H, s->h1, {P}_H_NSEC, w1) + sr[2] * acc1 + sr[3] * acc2"),
        *output_line(opts, "u2", f"{prefix}_sos_step({P}_H, s->h2, {P}_H_NSEC, w2) + sr[3] * acc1 + sr[4] * acc2"),
        "    s->u1_prev = u1; s->u2_prev = u2;",
        "    u[0] = u1; u[1] = u2;",
        "}",
        "",
        f"#endif /* {P}_GAINS_H */",
        "",
    ]
    return "\n".join(out)


def axis_header(doc: dict, rt, opts: COptions) -> str:
    """The header of a loop-shaped x-axis gains document executed by ``rt`` (an ``AxisRuntime``).

    The integral action is inside the controller's sections (``K (Ti s + 1) / s`` times leads and filters), so there
    is no separate integrator to hold: ``--anti-windup clamp`` is refused for an axis (see :func:`check_axis`).
    """
    prefix, P, unit = opts.prefix, opts.P, rt.command_unit
    pre = rt._prefilter_on
    out = banner("Loop-shaped x-axis controller (eq. 4.18-4.20) with mass feedforward and trajectory pre-filter.",
                 doc, opts, [
                     f"fs = {rt.fs:g} Hz, computational delay {rt.delay_samples} sample(s), reference preview "
                     f"{rt.preview_samples} sample(s). Positions in m, command u_x in {unit}.",
                     f"Call {prefix}_init() once, then {prefix}_step() every sample with x_r[k + "
                     f"{P}_PREVIEW_SAMPLES] and the encoder x[k]; apply u_x with the delay the design assumed."])
    out += ["", *_sampling(rt, opts), *limit_lines(opts, unit),
            f"static const double {P}_MASS = {c_double(rt.mass)}; /* {unit}/(m/s^2), feedforward mass */"]
    if pre:
        out += [f"static const double {P}_K_{t.upper()} = {c_double(k)}; /* s^{i + 1} */"
                for i, (t, k) in enumerate(zip(("vel", "acc", "jerk", "snap"), rt.prefilter_gains, strict=True))]
    out.append("")
    names = ["C", "POS", "ACC"] + (["PV", "PA", "PJ", "PS"] if pre else [])
    keys = {"C": "controller", "POS": "position", "ACC": "acceleration", "PV": PREFILTER[0], "PA": PREFILTER[1],
            "PJ": PREFILTER[2], "PS": PREFILTER[3]}
    for n in names:
        out += sos_array(f"{P}_{n}", rt.sos[keys[n]])
    out += [
        "typedef struct {",
        *_state_arrays(names, P),
        "    double u_prev;",
        f"}} {prefix}_state;",
        "",
        f"static inline void {prefix}_init({prefix}_state *s) {{ memset(s, 0, sizeof(*s)); }}",
        "",
        *sos_step_function(prefix),
        f"/* x_r_preview = x_r[k + {P}_PREVIEW_SAMPLES] [m]; x = encoder at k [m]; returns u_x [{unit}] */",
        f"static inline double {prefix}_step({prefix}_state *s, double x_r_preview, double x) {{",
        "    double r = x_r_preview, ra = r;",
    ]
    if pre:
        out += [f"    ra = r + {P}_K_VEL * {prefix}_sos_step({P}_PV, s->pv, {P}_PV_NSEC, r) + {P}_K_ACC * "
                f"{prefix}_sos_step({P}_PA, s->pa, {P}_PA_NSEC, r)",
                f"           + {P}_K_JERK * {prefix}_sos_step({P}_PJ, s->pj, {P}_PJ_NSEC, r) + {P}_K_SNAP * "
                f"{prefix}_sos_step({P}_PS, s->ps, {P}_PS_NSEC, r);"]
    out += [
        f"    double uff = {P}_MASS * {prefix}_sos_step({P}_ACC, s->acc, {P}_ACC_NSEC, r);",
        f"    double e = {prefix}_sos_step({P}_POS, s->pos, {P}_POS_NSEC, ra) - x;",
        *output_line(opts, "u", f"{prefix}_sos_step({P}_C, s->c, {P}_C_NSEC, e) + uff"),
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
        raise UsageError("--anti-windup clamp is not available for an axis gains file: its integral action is "
                         "inside the controller's sections, with no integrator to hold (use --u-max alone)")
