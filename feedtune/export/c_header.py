"""``feedtune export c``: a self-contained C header that executes a gains file on a real-time target.

One entry point for every gains kind (:func:`c_header`): the document is first read by the runtime that executes it
(:func:`feedtune.machines.load_runtime`), so the header refuses exactly what the runtime refuses, with the same
one-line error; then the emitter its gains format names (:mod:`feedtune.structures`) renders it. Headers need only
``<string.h>`` (and ``<math.h>`` for a friction feedforward) and compile with ``gcc -Wall -Wextra -Werror -std=c99``.
The document's strings reach the header only as comment-safe text (:mod:`feedtune.export.c_text`): nothing a gains
file says can become code.

Options (:class:`~feedtune.export.c_common.COptions`): the prefix of the identifiers, an output limit and
conditional-integration anti-windup, a warning line, and the precision: ``double`` (default) or ``float``, whose
filters are rewritten in difference form so that a float32 target stays within
:data:`~feedtune.export.c_common.FLOAT_ERROR_BOUND` of the double header's peak command (and which also compiles with
``-Wdouble-promotion -Wfloat-conversion``: no double arithmetic).
"""

from __future__ import annotations

from .c_common import COptions
from .c_text import comment_safe, comment_text


def c_header(doc: dict, *, prefix: str = "ft", where: str = "gains file", u_max: float | None = None,
             anti_windup: str = "none", warning: str | None = None, precision: str = "double",
             scale_out: float | None = None, out_unit: str | None = None) -> str:
    """Render a gains document as a C header.

    Parameters
    ----------
    doc : dict
        A gains document of any kind (ball screw, gantry MIMO or PID, x axis).
    prefix : str
        Prefix of every C identifier (letters, digits, underscore).
    where : str
        Name of the source for error messages.
    u_max : float, optional
        Output limit [command unit, or ``out_unit`` with ``scale_out``]: every command is clamped to
        ``[-u_max, u_max]``.
    anti_windup : {"none", "clamp"}
        ``clamp``: an integrator does not integrate while its command sits at the limit and the error drives it
        further (needs ``u_max``; not for an axis, whose integral action is inside its sections).
    warning : str, optional
        A line at the top of the header (e.g. that the design is outside its limits).
    precision : {"double", "float"}
        C type of every state, coefficient and operation. ``float``: the filters are rewritten in difference form
        (:func:`~feedtune.export.c_common.difference_form`); fed the same inputs, the commands stay within
        :data:`~feedtune.export.c_common.FLOAT_ERROR_BOUND` of the peak command of the double header.
    scale_out : float, optional
        Factor from the file's command unit to the drive's [``out_unit`` per command unit]: the header returns the
        law's command times it (e.g. ``1 / 35.15`` V/N for a design in N on a drive taking V).
    out_unit : str, optional
        The drive's unit of the scaled command (e.g. ``"V"``).

    Raises
    ------
    DataError
        A document the runtime refuses (named in the message).
    UsageError
        Bad options.
    """
    from ..machines import load_runtime
    from ..structures import gains_format, resolve

    opts = COptions(prefix=prefix, u_max=u_max, anti_windup=anti_windup,
                    warning=None if warning is None else comment_text(warning, 1000), precision=precision,
                    scale_out=scale_out, out_unit=out_unit)
    rt = load_runtime(doc, where)  # validates the document itself
    return resolve(gains_format(doc["kind"]).emitter)(comment_safe(doc), rt, opts, where)  # text as comment-safe
