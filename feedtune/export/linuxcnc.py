"""A LinuxCNC HAL component that runs a gains file: ``ft_step()`` of its C header on the servo thread.

MC-PPC, the gantry's MIMO law and the loop-shaped axis fit no parameter set of LinuxCNC's ``pid`` component; their
target is a component of their own. :func:`hal_component` writes one C source in the shape of LinuxCNC's realtime
components (``src/hal/components/pid.c``; what ``halcompile`` generates from a ``.comp``: ``rtapi_app_main`` making
``count`` instances with ``hal_pin_*_newf`` pins and one ``hal_export_functf`` function, ``rtapi_app_exit``), with
the gains file's header (:func:`feedtune.export.c_header.c_header`) inlined, so that ``halcompile --install
NAME.c`` builds it (a realtime component for uspace/PREEMPT_RT: the header includes ``<string.h>``; a kernel-mode
RTAI build would need ``rtapi_string.h`` instead). Pins of instance ``N``, in the gains file's units
(:data:`PINS`)::

    NAME.N.enable           in  bit    runs the law; false: state reset, outputs 0
    NAME.N.<reference>      in  float  the reference P = PREVIEW_SAMPLES samples ahead [m or rad]
    NAME.N.<encoders>       in  float  the encoders (and a gantry's table position x) [m or rad]
    NAME.N.<commands>       out float  the command(s) [the file's command unit, or --out-unit with --scale-out]
    NAME.N.rate-fault       out bit    the thread's period is not the design's 1/fs: the law does not run
    function NAME.N.update  once per servo period, after the encoders are read and before the commands are written

On the rising edge of ``enable`` the component takes the reference as its origin and gives the law every position
relative to it (the gantry's table position, which selects the schedule, stays absolute), as the twin does: the
header's filters start from rest, so the law starts without a jump. LinuxCNC's motion controller gives the
reference ``motor-pos-cmd`` now, not ``P`` samples ahead: fed with it, the axis follows it ``P / fs`` late (2
samples, 0.1 ms at 20 kHz), which the following error includes. Each update compares the thread's period with
``1 / fs`` (:data:`RATE_TOLERANCE`) and holds the outputs at 0 with ``rate-fault`` set when they differ: a law
designed for another rate must not run.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import UsageError

RATE_TOLERANCE = 1e-3
"""Largest relative difference between the thread's period and ``1 / fs`` the component runs at [-]."""


@dataclass(frozen=True)
class KindPins:
    """The pins of one gains kind: inputs (name, C member, relative to the origin?) and outputs, and how ``step`` is
    called with them."""

    inputs: tuple[tuple[str, str, bool], ...]
    outputs: tuple[tuple[str, str], ...]
    call: str
    """``step`` call with ``{prefix}``, the inputs' members ``{in}`` and outputs ``{out}`` as format fields."""


PINS: dict[str, KindPins] = {
    "ballscrew": KindPins((("x-ref-preview", "x_ref", True), ("x1", "x1", True), ("x2", "x2", True)),
                          (("u", "u"),),
                          "*(c->u) = {prefix}_step(&c->st, r[0], r[1], r[2]);"),
    "gantry": KindPins((("y-ref-preview", "y_ref", True), ("y1", "y1", True), ("y2", "y2", True),
                        ("x", "x", False)),
                       (("u1", "u1"), ("u2", "u2")),
                       "{prefix}_step(&c->st, r[0], r[1], r[2], r[3], u); *(c->u1) = u[0]; *(c->u2) = u[1];"),
    "axis": KindPins((("x-ref-preview", "x_ref", True), ("x", "x", True)), (("u", "u"),),
                     "*(c->u) = {prefix}_step(&c->st, r[0], r[1]);"),
}
"""The pins of each gains kind (what its header's ``step`` takes and returns)."""


def _c_text(text: str) -> str:
    """``text`` safe inside a C string literal and a comment: printable ASCII without quotes, backslashes or ``*/``."""
    return re.sub(r'[^ -~]|["\\]', "", str(text)).replace("*/", "* /")


def _check_name(name: str) -> str:
    if not re.fullmatch(r"[a-z][a-z0-9_]{0,30}", name):
        raise UsageError(f"component name {name!r}: lower-case letters, digits and '_', starting with a letter, at "
                         "most 31 characters (a HAL name and a C identifier)", parameter="name")
    return name


def hal_component(doc: dict, *, name: str = "feedtune", where: str = "gains file", warning: str | None = None,
                  **header_options) -> str:
    """The C source of a LinuxCNC HAL component running the gains document (module docstring).

    Parameters
    ----------
    doc : dict
        A gains document of any kind (:data:`PINS`).
    name : str
        The component's name: the module, and the prefix of its pins and function (``NAME.0.u``).
    where : str
        The document's name in messages.
    warning : str, optional
        A line at the top (e.g. that the design is not certified).
    **header_options
        ``u_max``, ``anti_windup``, ``scale_out``, ``out_unit`` of :func:`feedtune.export.c_header.c_header`
        (double precision: HAL floats are doubles).

    Raises
    ------
    UsageError
        A bad name or option.
    DataError
        A document the runtime refuses.
    """
    from .c_header import c_header

    name = _check_name(name)
    if header_options.get("precision", "double") != "double":
        raise UsageError("a LinuxCNC component is written in double precision (HAL floats are doubles)",
                         parameter="precision")
    header_options.pop("precision", None)
    prefix = "ft"
    header = c_header(doc, prefix=prefix, where=where, warning=warning, **header_options)
    pins = _pins_of(doc, where)
    P = prefix.upper()
    members = [f"    hal_float_t *{m};" for m in [m for _, m, _ in pins.inputs] + [m for _, m in pins.outputs]]
    n_in = len(pins.inputs)
    make_pins = [f'    r = hal_pin_float_newf(HAL_IN, &(c->{m}), comp_id, "%s.{pin}", prefix);\n'
                 "    if (r != 0) return r;" for pin, m, _ in pins.inputs]
    make_pins += [f'    r = hal_pin_float_newf(HAL_OUT, &(c->{m}), comp_id, "%s.{pin}", prefix);\n'
                  "    if (r != 0) return r;" for pin, m in pins.outputs]
    read = [f"    r[{i}] = *(c->{m}){' - c->origin' if rel else ''};" for i, (_, m, rel) in enumerate(pins.inputs)]
    zero = [f"        *(c->{m}) = 0.0;" for _, m in pins.outputs]
    call = pins.call.format(prefix=prefix)
    source = _c_text(where)
    lines = [
        f"/* LinuxCNC HAL component '{name}' generated by feedtune from {source} -- do not edit.",
        *([f" * WARNING: {_c_text(warning)}"] if warning else []),
        f" * Build and install: halcompile --install {name}.c   (realtime, uspace/PREEMPT_RT)",
        f" * Load: loadrt {name} count=1; addf {name}.0.update servo-thread (after the encoders are read)",
        " * Pins in the gains file's units; see the pin list below and docs/drive_export.md. */",
        "#include \"rtapi.h\"",
        "#include \"rtapi_app.h\"",
        "#include \"hal.h\"",
        "",
        'MODULE_AUTHOR("feedtune");',
        f'MODULE_DESCRIPTION("feedtune law of {source} on the servo thread");',
        'MODULE_LICENSE("GPL");',
        "static int count = 1;",
        'RTAPI_MP_INT(count, "number of instances");',
        "",
        "/* ------------------------------------------------ the gains file's C header (feedtune export c) */",
        header,
        "/* ------------------------------------------------ the component */",
        f"#define {P}_RATE_TOLERANCE {RATE_TOLERANCE!r}",
        "",
        "struct ft_instance {",
        "    hal_bit_t *enable;",
        "    hal_bit_t *rate_fault;",
        *members,
        f"    {prefix}_state st;",
        "    double origin;  /* the reference when enable rose: the law sees positions relative to it */",
        "    int running;",
        "};",
        "",
        "static int comp_id;",
        "static struct ft_instance *instances;",
        "",
        "static void update(void *arg, long period) {",
        "    struct ft_instance *c = arg;",
        f"    double r[{n_in}];",
        *(["    double u[2];"] if len(pins.outputs) == 2 else []),
        f"    double design_ns = 1e9 / {P}_FS_HZ, dev = (double)period - design_ns;",
        f"    int rate_ok = (dev < 0 ? -dev : dev) <= {P}_RATE_TOLERANCE * design_ns;",
        "    *(c->rate_fault) = !rate_ok;",
        "    if (!*(c->enable) || !rate_ok) {",
        *zero,
        "        c->running = 0;",
        "        return;",
        "    }",
        "    if (!c->running) {",
        f"        {prefix}_init(&c->st);",
        f"        c->origin = *(c->{pins.inputs[0][1]});",
        "        c->running = 1;",
        "    }",
        *read,
        f"    {call}",
        "}",
        "",
        "static int export_instance(char *prefix, struct ft_instance *c) {",
        "    int r;",
        '    r = hal_pin_bit_newf(HAL_IN, &(c->enable), comp_id, "%s.enable", prefix);',
        "    if (r != 0) return r;",
        '    r = hal_pin_bit_newf(HAL_OUT, &(c->rate_fault), comp_id, "%s.rate-fault", prefix);',
        "    if (r != 0) return r;",
        *make_pins,
        "    c->running = 0;",
        "    c->origin = 0.0;",
        '    return hal_export_functf(update, c, 1, 0, comp_id, "%s.update", prefix);',
        "}",
        "",
        "int rtapi_app_main(void) {",
        "    int i, r;",
        "    char buf[HAL_NAME_LEN + 1];",
        "    if (count < 1) count = 1;",
        f'    comp_id = hal_init("{name}");',
        "    if (comp_id < 0) return comp_id;",
        "    instances = hal_malloc(count * sizeof(struct ft_instance));",
        "    if (instances == 0) {",
        f'        rtapi_print_msg(RTAPI_MSG_ERR, "{name}: hal_malloc failed\\n");',
        "        hal_exit(comp_id);",
        "        return -1;",
        "    }",
        "    for (i = 0; i < count; i++) {",
        f'        rtapi_snprintf(buf, sizeof(buf), "{name}.%d", i);',
        "        r = export_instance(buf, &instances[i]);",
        "        if (r != 0) {",
        f'            rtapi_print_msg(RTAPI_MSG_ERR, "{name}: exporting %s failed\\n", buf);',
        "            hal_exit(comp_id);",
        "            return r;",
        "        }",
        "    }",
        "    hal_ready(comp_id);",
        "    return 0;",
        "}",
        "",
        "void rtapi_app_exit(void) {",
        "    hal_exit(comp_id);",
        "}",
        "",
    ]
    return "\n".join(lines)


def _pins_of(doc: dict, where: str) -> KindPins:
    """The pins of a gains document's kind; UsageError naming the kinds a component exists for."""
    kind = doc.get("kind")
    if kind not in PINS:
        raise UsageError(f"{where}: a LinuxCNC component exists for gains kinds {', '.join(PINS)}, not {kind!r}")
    return PINS[kind]


def pin_list(doc: dict, name: str = "feedtune") -> list[tuple[str, str, str]]:
    """``(pin, direction, what)`` of instance 0 of the component of a gains document (for the summary and docs)."""
    pins = _pins_of(doc, "gains document")
    out = [(f"{name}.0.enable", "in bit", "runs the law")]
    out += [(f"{name}.0.{p}", "in float", "relative to the origin" if rel else "absolute")
            for p, _, rel in pins.inputs]
    out += [(f"{name}.0.{p}", "out float", "command") for p, _ in pins.outputs]
    return [*out, (f"{name}.0.rate-fault", "out bit", "period is not 1/fs")]
