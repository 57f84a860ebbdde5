"""The C header of a cascade gains document (``kind = "cascade"``, docs/cascade.md).

Rendered from the runtime that executes the document (:class:`~feedtune.machines.cascade.runtime.CascadeRuntime`):
``PREFIX_step()`` performs the operations of :func:`feedtune.machines.cascade.law.cascade_step` in the same order --
the position loop every ``N`` calls (its speed setpoint and current feedforward held in between), the speed from the
encoder's backward difference, the PI with its backward-Euler integral, the current-setpoint filters -- so that the
header, the runtime and the twin's compiled loop agree sample by sample (tests/test_cascade_law.py).

With ``--u-max`` the current setpoint is clamped; ``--anti-windup clamp`` then holds the speed integral while the
previous setpoint sat at the limit and the speed error drives it further (conditional integration). In ``float``
precision the filters are in difference form (:func:`~feedtune.export.c_common.difference_form`).
"""

from __future__ import annotations

import math

from .c_common import CFilter, COptions, banner, filter_step_function, filter_type, limit_lines, output_line
from .c_text import comment_text


def cascade_header(doc: dict, rt, opts: COptions, where: str = "gains file") -> str:
    """The header of a cascade gains document executed by ``rt`` (a ``CascadeRuntime``)."""
    prefix, P, R, num = opts.prefix, opts.P, opts.real, opts.num
    unit, pos = comment_text(rt.command_unit), comment_text(rt.position_unit)  # the file's text, comment-safe
    out_unit = opts.output_unit(unit)
    load = rt.load_encoder
    tn = "no integral action" if math.isinf(rt.tn_s) else f"Tn = {rt.tn_s * 1e3:.6g} ms"
    out = banner("Drive cascade: speed PI with current-setpoint filters, position P with velocity and acceleration "
                 "feedforward.", doc, opts, [
                     f"Speed loop at fs = {rt.fs:g} Hz ({tn}), position loop every {rt.position_ratio} calls "
                     f"({rt.fp:g} Hz) on the {'load' if load else 'motor'} encoder; computational delay "
                     f"{rt.delay_samples} sample(s).",
                     f"Positions in {pos}, the current setpoint in {out_unit}.",
                     f"Call {prefix}_init() once, then {prefix}_step() every speed-loop sample with the position "
                     f"setpoint r, the motor encoder x1 and the load encoder x2 (x1 again without one);",
                     "apply the returned setpoint with the delay the design assumed."])
    ki_ts = 0.0 if math.isinf(rt.tn_s) else rt.kp / (rt.fs * rt.tn_s)
    out += ["", f"#define {P}_FS_HZ {num(rt.fs)}", f"#define {P}_FP_HZ {num(rt.fs / rt.position_ratio)}",
            f"#define {P}_POSITION_RATIO {rt.position_ratio}", f"#define {P}_DELAY_SAMPLES {rt.delay_samples}",
            "", *limit_lines(opts, unit),
            f"static const {R} {P}_KP = {num(rt.kp)}; /* {unit}/({pos}/s), speed-loop gain */",
            f"static const {R} {P}_KI_TS = {num(ki_ts)}; /* {unit}/{pos}: Kp / (fs Tn), the integral per sample */",
            f"static const {R} {P}_KV = {num(rt.kv)}; /* 1/s, position-loop gain */",
            f"static const {R} {P}_KV_FF = {num(rt.kv_ff)}; /* -, velocity feedforward factor */",
            f"static const {R} {P}_J_FF = {num(rt.inertia_ff)}; /* {unit}/({pos}/s^2), acceleration feedforward */",
            ""]
    filters = rt.sos.size > 0
    flt = CFilter(opts, f"{P}_F", rt.sos, False) if filters else None
    if flt is not None:
        out += filter_type(opts)
        out += flt.arrays()
    clamp = opts.anti_windup == "clamp"
    zero = num(0.0)
    integral = f"    s->integral += {P}_KI_TS * e;"
    if clamp:
        up, down = (">", "<") if opts.scale_out is None or opts.scale_out > 0 else ("<", ">")
        integral = (f"    if (!((s->u_prev >= {P}_U_MAX && e {up} {zero}) || (s->u_prev <= -{P}_U_MAX && e {down} "
                    f"{zero}))) s->integral += {P}_KI_TS * e;")
    out += [
        "typedef struct {",
        *([f"    {R} {flt.state('f')};"] if flt is not None else []),
        f"    {R} x1_prev, integral, speed_set, current_ff, r_prev, vr_prev, u_prev;",
        "    int started, count;",
        f"}} {prefix}_state;",
        "",
        f"static inline void {prefix}_init({prefix}_state *s) {{ memset(s, 0, sizeof(*s)); }}",
        "",
        *(filter_step_function(opts) if flt is not None else []),
        f"/* r: position setpoint [{pos}]; x1, x2: motor and load encoders [{pos}]; returns the current setpoint "
        f"[{out_unit}] */",
        f"static inline {R} {prefix}_step({prefix}_state *s, {R} r, {R} x1, {R} x2) {{",
        *([] if load else ["    (void)x2;"]),
        f"    if (!s->started) {{ s->started = 1; s->x1_prev = x1; s->r_prev = r; s->vr_prev = {zero}; "
        "s->count = 0; }",
        "    if (s->count == 0) {  /* a position-loop sample */",
        f"        {R} vr = (r - s->r_prev) * {P}_FP_HZ;",
        f"        {R} ar = (vr - s->vr_prev) * {P}_FP_HZ;",
        "        s->r_prev = r; s->vr_prev = vr;",
        f"        s->speed_set = {P}_KV * (r - {'x2' if load else 'x1'}) + {P}_KV_FF * vr;",
        f"        s->current_ff = {P}_J_FF * ar;",
        "    }",
        f"    if (++s->count >= {P}_POSITION_RATIO) s->count = 0;",
        f"    {R} v = (x1 - s->x1_prev) * {P}_FS_HZ;",
        "    s->x1_prev = x1;",
        f"    {R} e = s->speed_set - v;",
        integral,
        f"    {R} c = {P}_KP * e + s->integral + s->current_ff;",
        *output_line(opts, "u", flt.call("f", "c") if flt is not None else "c"),
        "    s->u_prev = u;",
        "    return u;",
        "}",
        "",
        f"#endif /* {P}_GAINS_H */",
        "",
    ]
    return "\n".join(out)


__all__ = ["cascade_header"]
