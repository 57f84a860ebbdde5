"""The input shaper of a gains file in its C header: a reference filter applied to the previewed position reference.

A gains file with a ``[shaper]`` (:mod:`feedtune.io.shaper_file`) gets, in every kind's header, the taps as constants,
a ring buffer of the reference's history in the state, and ``PREFIX_shape()``, which the step function calls first on
its reference argument, as the runtimes do (:class:`~feedtune.control.shapers.ShaperFilter`: the sum in tap order,
the same operations)::

    buf[pos] = x;  y = sum_i W[i] * buf[(pos - D[i]) mod LEN];  pos = (pos + 1) mod LEN

The ring buffer holds ``LEN = D[last] + 1`` values (``PREFIX_SHAPER_LEN``): 174 doubles for a 116 Hz EI shaper at 20
kHz, 20001 for a 1 Hz ZV one (160 kB of state).

Single precision is refused: the shaped reference ``sum_i W[i] x[k - D[i]]`` would be rounded at the position's
resolution before the reference filters difference it, the cancellation that the float headers' difference form
exists to avoid (docs/export.md); its two-part form is not written yet.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import UsageError
from .c_common import COptions, c_double


@dataclass(frozen=True)
class ShaperC:
    """The C pieces of a shaper for one header (``None`` of :func:`shaper_c` without a ``[shaper]``).

    Attributes
    ----------
    constants, state, function : list of str
        Lines of the constants (before the state struct), of the state struct's members, and of ``PREFIX_shape()``
        (before the step function).
    prefix : str
        The identifiers' prefix.
    """

    constants: list[str]
    state: list[str]
    function: list[str]
    prefix: str

    def call(self, variable: str) -> str:
        """The step function's first line: ``variable = PREFIX_shape(s, variable);``."""
        return f"    {variable} = {self.prefix}_shape(s, {variable});  /* input shaper ([shaper]) */"


def shaper_c(runtime, opts: COptions, where: str = "gains file") -> ShaperC | None:
    """The C pieces of ``runtime.shaper`` (its :class:`~feedtune.control.shapers.SampledShaper`), or None.

    Raises
    ------
    UsageError
        ``precision="float"`` with a shaper (module docstring).
    """
    taps = getattr(runtime, "shaper", None)
    if taps is None:
        return None
    if opts.single:
        raise UsageError(f"{where}: a [shaper] is exported in double precision only (its float form would round "
                         "the shaped reference at the position's resolution before the filters difference it); "
                         "export without precision='float'", parameter="precision")
    P, prefix = opts.P, opts.prefix
    n = int(taps.delays.size)
    delays = ", ".join(str(int(d)) for d in taps.delays)
    weights = ", ".join(c_double(w) for w in taps.weights)
    constants = [
        f"/* input shaper: x_s[k] = sum_i {P}_SHAPER_W[i] x[k - {P}_SHAPER_D[i]], {n} taps over "
        f"{taps.duration_s * 1e3:.6g} ms (lag {taps.time_shift_s * 1e3:.6g} ms) */",
        f"#define {P}_SHAPER_NTAPS {n}",
        f"#define {P}_SHAPER_LEN {taps.length}",
        f"static const int {P}_SHAPER_D[{n}] = {{{delays}}}; /* samples */",
        f"static const double {P}_SHAPER_W[{n}] = {{{weights}}}; /* -, summing to 1 */",
        "",
    ]
    state = [f"    double shaper_buf[{P}_SHAPER_LEN]; /* the reference's history [position unit] */",
             "    int shaper_pos;"]
    function = [
        f"/* the input shaper on the reference (ring buffer of {P}_SHAPER_LEN samples) */",
        f"static inline double {prefix}_shape({prefix}_state *s, double x) {{",
        "    double y = 0.0;",
        "    s->shaper_buf[s->shaper_pos] = x;",
        f"    for (int i = 0; i < {P}_SHAPER_NTAPS; ++i) {{",
        f"        int j = s->shaper_pos - {P}_SHAPER_D[i];",
        f"        y += {P}_SHAPER_W[i] * s->shaper_buf[j < 0 ? j + {P}_SHAPER_LEN : j];",
        "    }",
        f"    s->shaper_pos = s->shaper_pos + 1 < {P}_SHAPER_LEN ? s->shaper_pos + 1 : 0;",
        "    return y;",
        "}",
        "",
    ]
    return ShaperC(constants, state, function, prefix)
