"""What every C header feedtune writes shares: number and identifier formatting, the precision, the filters (their
arrays, state and step function in either precision), the output limit with conditional integration, and the banner.

Conventions of every header: one ``PREFIX_state`` struct zeroed by ``PREFIX_init()``, and ``PREFIX_step()`` called
once per sample. In ``double`` precision (the default) the filters are normalised second-order sections ``[b0, b1,
b2, 1, a1, a2]`` run in transposed direct form II (as ``scipy.signal.sosfilt``). In ``float`` precision every state,
coefficient and operation is ``float`` and each filter is realised in difference form (:func:`difference_form`,
docs/export.md), which keeps a float32 target within :data:`FLOAT_ERROR_BOUND` of the double header's peak command.

Output limit and anti-windup (``--u-max``, ``--anti-windup``; docs/export.md): with ``U_MAX`` each command is
clamped to ``[-U_MAX, U_MAX]`` after the law. With ``clamp`` anti-windup, an integrator does not integrate in a sample
when the command it feeds was at the limit in the previous sample and the error has the sign that drives it further
(conditional integration; the integrators feed their command with a positive gain in every feedtune law). Without a
limit the header executes exactly the law of the gains file.

Output scale (``--scale-out``, ``--out-unit``): a drive whose input is not the unit the gains file commands in (a
design in N for a drive that takes V through its gain of 35.15 N/V) gets ``SCALE_OUT`` times the law's command, in
its own unit; the limit then holds in that unit, and the anti-windup's sign test follows the factor's sign.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..errors import DataError, UsageError
from ..io.provenance import created_by_text
from .c_text import comment_text

ANTI_WINDUP = ("none", "clamp")
"""Values of ``anti_windup``."""

PRECISIONS = ("double", "float")
"""Values of ``precision``: the C type of every state, coefficient and operation of a header."""

FLOAT_ERROR_BOUND = 1e-4
"""Largest difference between the commands of a ``float`` header and of the ``double`` header of the same gains file,
fed the same (float-representable) inputs, relative to the peak command of the double header [-]. Asserted in
tests/test_export_c_float.py for every gains kind, whose largest measured value is 2.4e-5 (docs/export.md gives the
values)."""


def float_bound_text() -> str:
    """:data:`FLOAT_ERROR_BOUND` as written in headers and help texts (``1e-4``)."""
    mantissa, exponent = f"{FLOAT_ERROR_BOUND:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}"


@dataclass(frozen=True)
class COptions:
    """Options of a header.

    Attributes
    ----------
    prefix : str
        Prefix of every C identifier.
    u_max : float or None
        Output limit [command unit] applied to every command; None for none.
    anti_windup : str
        ``none`` or ``clamp`` (conditional integration; needs ``u_max``).
    warning : str or None
        A line put at the top of the header (e.g. a design exported outside its limits).
    precision : str
        ``double`` or ``float``: the C type of every state, coefficient and operation (:data:`PRECISIONS`).
    scale_out : float or None
        Factor from the law's command unit to the drive's [out unit / command unit] applied to every command
        before the limit; None for none.
    out_unit : str or None
        The drive's unit of the scaled command (with ``scale_out``).
    """

    prefix: str = "ft"
    u_max: float | None = None
    anti_windup: str = "none"
    warning: str | None = None
    precision: str = "double"
    scale_out: float | None = None
    out_unit: str | None = None

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.prefix):
            raise UsageError(f"prefix {self.prefix!r} is not a valid C identifier (letters, digits, underscore)",
                             parameter="prefix")
        if self.u_max is not None and not (math.isfinite(self.u_max) and self.u_max > 0):
            raise UsageError(f"u_max must be a positive number, got {self.u_max!r}", parameter="u_max")
        if self.anti_windup not in ANTI_WINDUP:
            raise UsageError(f"anti_windup must be one of {', '.join(ANTI_WINDUP)}, got {self.anti_windup!r}",
                             parameter="anti_windup")
        if self.anti_windup == "clamp" and self.u_max is None:
            raise UsageError("anti_windup=clamp needs u_max (the limit the integrators must not wind up against)",
                             parameter=("anti_windup", "u_max"))
        if self.precision not in PRECISIONS:
            raise UsageError(f"precision must be one of {', '.join(PRECISIONS)}, got {self.precision!r}")
        if self.scale_out is not None and not (math.isfinite(self.scale_out) and self.scale_out != 0):
            raise UsageError(f"scale_out must be a finite non-zero number, got {self.scale_out!r}",
                             parameter="scale_out")
        if self.out_unit is not None and (self.scale_out is None or not re.fullmatch(r"[^*/\n]+[^\n]*", self.out_unit)
                                          or "*/" in self.out_unit):
            raise UsageError(f"out_unit {self.out_unit!r} needs scale_out and must be a unit such as V",
                             parameter="out_unit")

    def output_unit(self, unit: str) -> str:
        """The unit of the header's output for a law commanding in ``unit`` (comment-safe text)."""
        if self.scale_out is None:
            return comment_text(unit)
        return comment_text(self.out_unit or f"{unit} x {self.scale_out:g}")

    @property
    def P(self) -> str:
        """Prefix of the macros and constants (upper case)."""
        return self.prefix.upper()

    @property
    def real(self) -> str:
        """The C type of every state, coefficient and operation: ``double`` or ``float``."""
        return self.precision

    @property
    def single(self) -> bool:
        """True for a ``float`` header."""
        return self.precision == "float"

    def num(self, x: float) -> str:
        """A C literal of ``x`` in the header's precision (``f`` suffix in ``float``)."""
        return c_float(x) if self.single else c_double(x)

    def math(self, name: str) -> str:
        """The ``<math.h>`` function ``name`` (``fabs``, ``exp``) in the header's precision (``fabsf``, ``expf``)."""
        return name + "f" if self.single else name


def c_double(x: float) -> str:
    """A C double literal that reads back to the same value."""
    x = float(x)
    if not math.isfinite(x):
        raise DataError(f"cannot write {x!r} as a C constant")
    r = repr(x)
    return r if ("e" in r or "." in r) else r + ".0"


def c_float(x: float) -> str:
    """A C float literal (``f`` suffix) that reads back to ``x`` rounded to float32 (the shortest such decimal)."""
    x = float(x)
    with np.errstate(over="ignore"):
        f = np.float32(x)
    if not (math.isfinite(x) and np.isfinite(f)):
        raise DataError(f"cannot write {x!r} as a C float constant (beyond +-3.4e38)")
    r = str(f)
    return (r if ("e" in r or "." in r) else r + ".0") + "f"


def _normalised(sos, name: str, where: str) -> np.ndarray:
    """The sections ``[b0, b1, b2, 1, a1, a2]`` divided by their ``a0`` in double precision, as the double header
    writes them."""
    rows = np.asarray(sos, float).reshape(-1, 6)
    if np.any(rows[:, 3] == 0):
        raise DataError(f"{where}: {name} has a section with a0 = 0")
    return rows / rows[:, 3:4]


def sos_array(name: str, sos, where: str = "gains file", nsec: str | None = None) -> list[str]:
    """``static const double NAME[n][6]`` of sections normalised by their ``a0``, and ``#define NSEC n`` (``nsec``,
    default ``NAME_NSEC``)."""
    rows = ["    {" + ", ".join(c_double(c) for c in r) + "}" for r in _normalised(sos, name, where)]
    if not rows:
        rows.append("    {1.0, 0.0, 0.0, 1.0, 0.0, 0.0}")
    return [f"#define {nsec or name + '_NSEC'} {len(rows)}",
            f"static const double {name}[{len(rows)}][6] = {{\n" + ",\n".join(rows) + "\n};", ""]


def row_array(name: str, values, comment: str = "", real: str = "double") -> list[str]:
    """``static const REAL NAME[n]`` (one row) with a comment (``real``: ``double`` or ``float``)."""
    fmt = c_float if real == "float" else c_double
    vals = ", ".join(fmt(v) for v in np.asarray(values, float).ravel())
    return [f"static const {real} {name}[{np.asarray(values).size}] = {{{vals}}};" + (f" /* {comment} */"
                                                                                     if comment else "")]


def table_array(name: str, rows, comment: str = "", real: str = "double") -> list[str]:
    """``static const REAL NAME[n][m]`` (``real``: ``double`` or ``float``)."""
    fmt = c_float if real == "float" else c_double
    a = np.asarray(rows, float)
    body = ",\n".join("    {" + ", ".join(fmt(v) for v in r) + "}" for r in a)
    return ([f"/* {comment} */"] if comment else []) + [f"static const {real} {name}[{a.shape[0]}][{a.shape[1]}] = "
                                                         f"{{\n{body}\n}};", ""]


# ------------------------------------------------------------------ single precision: the difference form
@dataclass(frozen=True)
class DifferenceStage:
    """One stage of a filter in difference form (:func:`difference_form`): with the difference operator ``D = 1 -
    z^-1``, ``y = gain * sum_j num[j] D^j x / prod_i A_i(z)``.

    Attributes
    ----------
    num : tuple of float
        Coefficients of ``D^0 .. D^nd`` of the product of the stage's numerators, divided by ``gain`` (largest
        magnitude in [0.5, 1] after rounding) [-].
    den : tuple of (float, float)
        Each pole section ``A(z) = 1 + a1 z^-1 + a2 z^-2`` as ``(1 + a1 + a2, 1 - a2)`` (delta form); sections
        without poles are left out [-].
    gain : float
        The power of two moved out of the numerator, applied to the stage's output [output unit / input unit].
    """

    num: tuple[float, ...]
    den: tuple[tuple[float, float], ...]
    gain: float

    @property
    def nd(self) -> int:
        """Order of the numerator in ``D`` (the number of differences taken of the stage's input)."""
        return len(self.num) - 1


def _poly_mul(p: list[Fraction], q: list[Fraction]) -> list[Fraction]:
    out = [Fraction(0)] * (len(p) + len(q) - 1)
    for i, a in enumerate(p):
        for j, b in enumerate(q):
            out[i + j] += a * b
    return out


def _sections(rows: np.ndarray) -> tuple[list[Fraction], list[tuple[Fraction, Fraction]]]:
    """The product of the numerators of normalised sections as a polynomial in ``D = 1 - z^-1`` (exact), and their
    delta-form pole sections ``(1 + a1 + a2, 1 - a2)`` (those with poles)."""
    num, poles = [Fraction(1)], []
    for r in rows:
        b0, b1, b2, _, a1, a2 = (Fraction(float(c)) for c in r)
        num = _poly_mul(num, [b0 + b1 + b2, -b1 - 2 * b2, b2])
        if a1 != 0 or a2 != 0:
            poles.append((1 + a1 + a2, 1 - a2))
    return num, poles


def _stage(rows: np.ndarray, name: str, where: str, *, zeros: bool = True, poles: bool = True) -> DifferenceStage:
    """The sections ``rows`` (normalised) as one stage (their numerators with ``zeros``, their poles with
    ``poles``), computed exactly and rounded once to float32."""
    num, den = _sections(rows)
    num, den = (num if zeros else [Fraction(1)]), (den if poles else [])
    while len(num) > 1 and num[-1] == 0:
        num.pop()
    peak = max(abs(c) for c in num)
    exponent = math.frexp(float(peak))[1] if peak else 0
    if not -126 <= exponent <= 127:
        raise DataError(f"{where}: {name} has a gain of 2^{exponent}, beyond the float32 range")
    scale = Fraction(2) ** exponent

    def f32(x: Fraction) -> float:
        c_float(float(x))  # refuses what float32 cannot hold
        return float(np.float32(float(x)))

    return DifferenceStage(num=tuple(f32(c / scale) for c in num), den=tuple((f32(a), f32(b)) for a, b in den),
                           gain=float(scale))


def difference_form(sos, joint: bool, name: str = "filter", where: str = "gains file",
                    pre=None) -> tuple[DifferenceStage, ...]:
    """Rewrite normalised second-order sections so that float32 arithmetic keeps their output.

    The double header's sections differentiate positions with coefficients up to 6e8 (the ball screw's feedforward
    ``{2.83e8, -5.67e8, 2.83e8}`` is ``2.83e8 D^2`` within 6e-8, ``D = 1 - z^-1``): in float32, products of a
    position with such coefficients round to errors larger than their sum. The difference form takes the
    differences of the input first, each exactly (the difference of two nearby floats is exact), then weighs them
    with well-conditioned coefficients:

    1. every numerator ``b0 + b1 z^-1 + b2 z^-2`` is written ``c0 + c1 D + c2 D^2`` (``c0 = b0 + b1 + b2``, ``c1 =
       -b1 - 2 b2``, ``c2 = b2``); with ``joint`` the numerators of all the sections are multiplied into one
       polynomial in ``D``, so that every difference is taken of the filter's own input and never of a rounded
       intermediate result (filters of reference positions); without, each section is a stage of its own (filters
       of errors and commands, broadband signals whose high-order differences would grow as 2^order);
    2. the poles follow as delta-form sections ``(1 + a1 + a2, 1 - a2)``: both are small for poles near ``z = 1``
       and keep their relative precision in float32, where ``a1``, ``a2`` themselves would not;
    3. the power of two just above each stage's largest numerator coefficient is moved out as the stage's gain (an
       exact scaling, which changes no rounding: the coefficients lie in [0.5, 1]).

    Every coefficient is computed exactly (rational arithmetic) from the double header's coefficients and rounded
    once to float32.

    Parameters
    ----------
    sos : array_like, shape (n, 6)
        Second-order sections ``[b0, b1, b2, a0, a1, a2]``.
    joint : bool
        One stage for all the sections (True) or one per section.
    name, where : str
        The filter and its source, for error messages.
    pre : array_like, shape (m, 6), optional
        Sections of a filter ``PRE`` applied before: the form realises ``SOS(z) PRE(z)`` as the numerators of
        ``sos`` (one stage, whose differences are taken of the input itself), then each section of ``PRE`` as a
        stage of its own (the numerator's output is a broadband command), then the poles of ``sos``. For a
        differentiating ``sos`` (a feedforward) and a ``PRE`` whose output corrects a position (a pre-filter), this
        never rounds ``PRE``'s output to float, whose rounding errors the differences would multiply (3e9 V/rad at
        the Nyquist frequency for the ball screw's feedforward).

    Returns
    -------
    tuple of DifferenceStage
        The stages in order, their coefficients rounded to float32 values.

    Raises
    ------
    DataError
        A section with ``a0 = 0``, or a coefficient beyond the float32 range.
    """
    rows = _normalised(sos, name, where)
    if pre is not None:
        pre_rows = _normalised(pre, name + " pre-filter", where)
        return (_stage(rows, name, where, poles=False), *(_stage(r[None, :], name, where) for r in pre_rows),
                _stage(rows, name, where, zeros=False))
    if joint or len(rows) <= 1:
        return (_stage(rows, name, where),)
    plain = np.array([1.0, 0.0, 0.0, 1.0, 0.0, 0.0])
    kept = [r for r in rows if not np.array_equal(r, plain)] or [plain]  # identity sections are left out
    return tuple(_stage(r[None, :], name, where) for r in kept)


@dataclass(frozen=True)
class CFilter:
    """One filter (cascade of second-order sections) of a header, in the header's precision.

    Attributes
    ----------
    opts : COptions
        The header's options (prefix, precision).
    base : str
        Base of its C names (e.g. ``FT_FF``): ``BASE_NSEC`` in double; ``BASE``, ``BASE_NST``, ``BASE_NUM``,
        ``BASE_DEN`` in float.
    sos : array_like, shape (n, 6)
        Its sections ``[b0, b1, b2, a0, a1, a2]``.
    reference : bool
        True for a filter of a reference position (float: one joint stage, see :func:`difference_form`), False
        for a filter of an error or a command (float: one stage per section).
    where : str
        Its source, for error messages.
    array : str or None
        Name of the double header's section array (default ``base``).
    pre : array_like or None
        Float headers: sections of a filter ``PRE`` applied before: the filter realises ``SOS(z) PRE(z)`` (see
        :func:`difference_form`).
    """

    opts: COptions
    base: str
    sos: object
    reference: bool
    where: str = "gains file"
    array: str | None = None
    pre: object = None

    @property
    def stages(self) -> tuple[DifferenceStage, ...]:
        """Its difference form (float headers)."""
        return difference_form(self.sos, self.reference, self.array or self.base, self.where, self.pre)

    def arrays(self) -> list[str]:
        """The constants: the section array (double) or the stages of the difference form (float)."""
        if not self.opts.single:
            return sos_array(self.array or self.base, self.sos, self.where, nsec=f"{self.base}_NSEC")
        st, B, p = self.stages, self.base, self.opts.prefix
        num = [c for s in st for c in s.num]
        den = [d for s in st for d in s.den] or [(0.0, 0.0)]
        rows, i_num, i_den = [], 0, 0
        for k, s in enumerate(st):
            rows.append(f"    {{{B}_NUM + {i_num}, {B}_DEN + {i_den}, {s.nd}, {len(s.den)}, {c_float(s.gain)}}}"
                        f"{',' if k < len(st) - 1 else ''}  /* gain 2^{math.frexp(s.gain)[1] - 1} */")
            i_num, i_den = i_num + len(s.num), i_den + len(s.den)
        return [
            f"#define {B}_NST {len(st)}",
            f"static const float {B}_NUM[{len(num)}] = {{{', '.join(c_float(c) for c in num)}}};",
            f"static const float {B}_DEN[{len(den)}][2] = {{"
            + ", ".join("{" + ", ".join(c_float(c) for c in d) + "}" for d in den) + "};",
            f"static const {p}_stage {B}[{len(st)}] = {{\n" + "\n".join(rows) + "\n};",
            "",
        ]

    def state(self, field: str) -> str:
        """The declarators of its state in the state struct, named after ``field``."""
        if not self.opts.single:
            return f"{field}[{self.base}_NSEC][2]"
        st = self.stages
        return f"{field}_d[{max(sum(s.nd for s in st), 1)}][2], {field}_p[{max(sum(len(s.den) for s in st), 1)}][2]"

    def call(self, field: str, x: str, corr: str | None = None) -> str:
        """The C expression of one sample of input ``x`` through it (state ``s->field``). In float, ``corr`` is a
        small correction added to ``x`` (e.g. a pre-filter's), differenced apart from it."""
        p = self.opts.prefix
        if not self.opts.single:
            return f"{p}_sos_step({self.array or self.base}, s->{field}, {self.base}_NSEC, {x})"
        return f"{p}_filter_step({self.base}, {self.base}_NST, s->{field}_d, s->{field}_p, {x}, {corr or '0.0f'})"


def filter_type(opts: COptions) -> list[str]:
    """The typedef of a stage of a filter in difference form (float headers; before the first filter)."""
    if not opts.single:
        return []
    return [
        "/* a stage of a filter in difference form: y = gain * sum_j num[j] D^j x / (np pole sections den),",
        "   D = 1 - z^-1 (docs/export.md); a filter is an array of stages */",
        f"typedef struct {{ const float *num; const float (*den)[2]; int nd, np; float gain; }} {opts.prefix}_stage;",
        "",
    ]


def filter_step_function(opts: COptions) -> list[str]:
    """``PREFIX_sos_step`` (double: cascaded sections, transposed direct form II) or ``PREFIX_filter_step`` (float:
    the stages of the difference form)."""
    prefix = opts.prefix
    if not opts.single:
        return [
            "/* one sample through cascaded second-order sections, transposed direct form II */",
            f"static inline double {prefix}_sos_step(const double (*sos)[6], double (*w)[2], int n, double x) {{",
            "    for (int i = 0; i < n; ++i) {",
            "        double y = sos[i][0] * x + w[i][0];",
            "        w[i][0] = sos[i][1] * x - sos[i][4] * y + w[i][1];",
            "        w[i][1] = sos[i][2] * x - sos[i][5] * y;",
            "        x = y;",
            "    }",
            "    return x;",
            "}",
            "",
        ]
    return [
        "/* one sample of x = a + b (b: a small correction, 0 for none) through the n stages f of a filter in",
        "   difference form. A stage takes the differences D^j of a and of b apart (d: their previous values; the",
        "   difference of two nearby floats is exact), weighs them with num[j], runs its pole sections in delta form",
        "   (p: y[k-1], D y[k-1] of each; D^2 y = v - (1 + a1 + a2) y[k-1] - (1 - a2) D y[k-1]), then its gain */",
        f"static inline float {prefix}_filter_step(const {prefix}_stage *f, int n, float (*d)[2], float (*p)[2], "
        "float a, float b) {",
        "    for (int k = 0; k < n; ++k, d += f->nd, p += f->np, ++f) {",
        "        float v = f->num[0] * (a + b);",
        "        for (int j = 0; j < f->nd; ++j) {",
        "            float da = a - d[j][0], db = b - d[j][1];",
        "            d[j][0] = a; d[j][1] = b;",
        "            a = da; b = db;",
        "            v += f->num[j + 1] * (a + b);",
        "        }",
        "        for (int i = 0; i < f->np; ++i) {",
        "            float dd = v - f->den[i][0] * p[i][0] - f->den[i][1] * p[i][1];",
        "            p[i][1] += dd;",
        "            p[i][0] += p[i][1];",
        "            v = p[i][0];",
        "        }",
        "        a = f->gain * v;",
        "        b = 0.0f;",
        "    }",
        "    return a;",
        "}",
        "",
    ]


# ------------------------------------------------------------------ limit, integrators, banner
def limit_lines(opts: COptions, unit: str) -> list[str]:
    """The output scale, the output-limit and anti-windup macros and the clamp function."""
    P, R = opts.P, opts.real
    unit = comment_text(unit)
    out_unit = opts.output_unit(unit)
    scale = [] if opts.scale_out is None else [
        f"#define {P}_SCALE_OUT {opts.num(opts.scale_out)} /* {out_unit} per {unit}: {opts.prefix}_step "
        f"returns the law's command [{unit}] times {P}_SCALE_OUT, in {out_unit} */"]
    unit = out_unit
    if opts.u_max is None:
        return [*scale, f"/* no output limit: {opts.prefix}_step returns the law's command unclamped (export with "
                "--u-max to clamp it) */", ""]
    return [
        *scale,
        f"#define {P}_U_MAX {opts.num(opts.u_max)} /* {unit}: every command is clamped to +-{P}_U_MAX */",
        f"#define {P}_ANTI_WINDUP {1 if opts.anti_windup == 'clamp' else 0} /* 1: conditional integration */",
        f"static inline {R} {opts.prefix}_clamp({R} u) {{",
        f"    return u > {P}_U_MAX ? {P}_U_MAX : (u < -{P}_U_MAX ? -{P}_U_MAX : u);",
        "}",
        "",
    ]


def integrate_line(opts: COptions, state: str, error: str, fs: str, last_u: str) -> str:
    """``state += error / fs``, skipped (with clamp anti-windup) while ``last_u`` sits at the limit and the error
    drives it further."""
    if opts.anti_windup != "clamp":
        return f"    {state} += {error} / {fs};"
    P, zero = opts.P, opts.num(0.0)
    up, down = (">", "<") if opts.scale_out is None or opts.scale_out > 0 else ("<", ">")  # the scale's sign
    return (f"    if (!(({last_u} >= {P}_U_MAX && {error} {up} {zero}) || ({last_u} <= -{P}_U_MAX && {error} {down} "
            f"{zero}))) {state} += {error} / {fs};")


def output_line(opts: COptions, target: str, expr: str) -> list[str]:
    """``target = expr`` (times the output scale), clamped with a limit."""
    if opts.scale_out is not None:
        expr = f"{opts.P}_SCALE_OUT * ({expr})"
    if opts.u_max is None:
        return [f"    {opts.real} {target} = {expr};"]
    return [f"    {opts.real} {target} = {opts.prefix}_clamp({expr});"]


def precision_lines(opts: COptions) -> list[str]:
    """The banner lines of a float header (none for double): what it computes and how far from the double header."""
    if not opts.single:
        return []
    return ["Single precision (--float): every state, coefficient and operation is float. The filters are in",
            "difference form (docs/export.md): the differences of the input first, each exact, then well-conditioned",
            f"coefficients. Fed the same inputs, the commands stay within {float_bound_text()} x the peak command of "
            "the double",
            "header (measured for every gains kind); positions rounded to float carry their own error "
            "(docs/export.md)."]


def banner(what: str, doc: dict, opts: COptions, lines: list[str]) -> list[str]:
    """The opening comment: source, the law, units, the precision, the limit, a warning."""
    out = [f"/* Generated by {comment_text(created_by_text(doc))} -- do not edit.",
           f" * {comment_text(what, 1000)}"]
    out += [f" * {comment_text(line, 1000)}" for line in [*lines, *precision_lines(opts)]]
    if opts.warning:
        out.append(f" * WARNING: {comment_text(opts.warning, 1000)}")
    out.append(" */")
    P = opts.P
    out += [f"#ifndef {P}_GAINS_H", f"#define {P}_GAINS_H", "#include <string.h>"]
    return out


# ------------------------------------------------------------------ friction feedforward
def friction_constants(ff, opts: COptions) -> list[str]:
    """The constants of a friction feedforward (``ff``: a :class:`~feedtune.control.friction.FrictionFeedforward`,
    or None for none): eq. 2.1's levels and Stribeck velocities (the coulomb-viscous law: its Coulomb levels), the
    viscous coefficients, the band and the friction at its edges, velocities in its unit."""
    if ff is None:
        return []
    P, R, num = opts.P, opts.real, opts.num
    f = ff.friction
    edge_pos, edge_neg = ff.edges()
    fv_pos, fv_neg = ff.viscous
    unit, vu = comment_text(ff.command_unit), comment_text(ff.velocity_unit)
    stribeck = ff.law != "coulomb-viscous"
    head = ("Stribeck friction (eq. 2.1) + viscous friction" if stribeck else "Coulomb + viscous friction")
    return [
        f"/* {head} feedforward, reference velocity in {vu}, linear inside +-V_BAND */",
        f"static const {R} {P}_FR_DC_POS = {num(f.dc_pos)}; /* {unit} */",
        *([f"static const {R} {P}_FR_DS_POS = {num(f.ds_pos)}; /* {unit} */"] if stribeck else []),
        f"static const {R} {P}_FR_DC_NEG = {num(f.dc_neg)}; /* {unit} */",
        *([f"static const {R} {P}_FR_DS_NEG = {num(f.ds_neg)}; /* {unit} */",
           f"static const {R} {P}_FR_OMEGA_POS = {num(f.omega_pos)}; /* {vu} */",
           f"static const {R} {P}_FR_OMEGA_NEG = {num(f.omega_negative)}; /* {vu} */"] if stribeck else []),
        f"static const {R} {P}_FR_FV_POS = {num(fv_pos)}; /* {unit}/({vu}) */",
        f"static const {R} {P}_FR_FV_NEG = {num(fv_neg)}; /* {unit}/({vu}) */",
        f"static const {R} {P}_FR_V_BAND = {num(ff.v_band)}; /* {vu} */",
        f"static const {R} {P}_FR_EDGE_POS = {num(edge_pos)}; /* {unit}, friction at +V_BAND */",
        f"static const {R} {P}_FR_EDGE_NEG = {num(edge_neg)}; /* {unit}, friction at -V_BAND */",
        "",
    ]


def friction_function(ff, opts: COptions) -> list[str]:
    """``PREFIX_friction(v)``: eq. 2.1 plus the viscous term of the reference velocity (the coulomb-viscous law:
    ``Fc + Fv v``), linear through zero inside ``+-V_BAND`` (the formula of
    :meth:`~feedtune.models.friction.StribeckFriction.smoothed`); nothing for ``ff = None``."""
    if ff is None:
        return []
    prefix, P, R, zero, exp = opts.prefix, opts.P, opts.real, opts.num(0.0), opts.math("exp")
    if ff.law == "coulomb-viscous":
        pos = f"{P}_FR_DC_POS + {P}_FR_FV_POS * v"
        neg = f"{P}_FR_DC_NEG + {P}_FR_FV_NEG * v"
    else:
        pos = (f"{P}_FR_DC_POS + ({P}_FR_DS_POS - {P}_FR_DC_POS) * {exp}(-a / {P}_FR_OMEGA_POS) "
               f"+ {P}_FR_FV_POS * v")
        neg = (f"{P}_FR_DC_NEG + ({P}_FR_DS_NEG - {P}_FR_DC_NEG) * {exp}(-a / {P}_FR_OMEGA_NEG) "
               f"+ {P}_FR_FV_NEG * v")
    return [
        f"/* friction feedforward d(v) [command unit] for the reference velocity v "
        f"[{comment_text(ff.velocity_unit)}] */",
        f"static inline {R} {prefix}_friction({R} v) {{",
        f"    {R} a = {opts.math('fabs')}(v);",
        f"    if (a < {P}_FR_V_BAND) return (v >= {zero} ? {P}_FR_EDGE_POS : {P}_FR_EDGE_NEG) * a / {P}_FR_V_BAND;",
        f"    if (v > {zero}) return {pos};",
        f"    return {neg};",
        "}",
        "",
    ]
