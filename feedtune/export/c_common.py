"""What every C header feedtune writes shares: number and identifier formatting, second-order-section arrays and
their step function, the output limit with conditional integration, and the banner.

Conventions of every header: ``double`` arithmetic, filters as normalised second-order sections ``[b0, b1, b2, 1,
a1, a2]`` run in transposed direct form II (as ``scipy.signal.sosfilt``), one ``PREFIX_state`` struct zeroed by
``PREFIX_init()``, and ``PREFIX_step()`` called once per sample.

Output limit and anti-windup (``--u-max``, ``--anti-windup``; docs/export.md): with ``U_MAX`` each command is
clamped to ``[-U_MAX, U_MAX]`` after the law. With ``clamp`` anti-windup, an integrator does not integrate in a sample
when the command it feeds was at the limit in the previous sample and the error has the sign that drives it further
(conditional integration; the integrators feed their command with a positive gain in every feedtune law). Without a
limit the header executes exactly the law of the gains file.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError

ANTI_WINDUP = ("none", "clamp")
"""Values of ``anti_windup``."""


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
    """

    prefix: str = "ft"
    u_max: float | None = None
    anti_windup: str = "none"
    warning: str | None = None

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.prefix):
            raise UsageError(f"--prefix {self.prefix!r} is not a valid C identifier (letters, digits, underscore)")
        if self.u_max is not None and not (math.isfinite(self.u_max) and self.u_max > 0):
            raise UsageError(f"--u-max must be a positive number, got {self.u_max!r}")
        if self.anti_windup not in ANTI_WINDUP:
            raise UsageError(f"--anti-windup must be one of {', '.join(ANTI_WINDUP)}, got {self.anti_windup!r}")
        if self.anti_windup == "clamp" and self.u_max is None:
            raise UsageError("--anti-windup clamp needs --u-max (the limit the integrators must not wind up against)")

    @property
    def P(self) -> str:
        """Prefix of the macros and constants (upper case)."""
        return self.prefix.upper()


def c_double(x: float) -> str:
    """A C double literal that reads back to the same value."""
    x = float(x)
    if not math.isfinite(x):
        raise DataError(f"cannot write {x!r} as a C constant")
    r = repr(x)
    return r if ("e" in r or "." in r) else r + ".0"


def sos_array(name: str, sos, where: str = "gains file") -> list[str]:
    """``static const double NAME[n][6]`` of sections normalised by their ``a0``, and ``#define NAME_NSEC n``."""
    rows = []
    for r in np.asarray(sos, float).reshape(-1, 6):
        if r[3] == 0:
            raise DataError(f"{where}: {name} has a section with a0 = 0")
        rows.append("    {" + ", ".join(c_double(c / r[3]) for c in r) + "}")
    if not rows:
        rows.append("    {1.0, 0.0, 0.0, 1.0, 0.0, 0.0}")
    return [f"#define {name}_NSEC {len(rows)}",
            f"static const double {name}[{len(rows)}][6] = {{\n" + ",\n".join(rows) + "\n};", ""]


def double_array(name: str, values, comment: str = "") -> list[str]:
    """``static const double NAME[n]`` (one row) with a comment."""
    vals = ", ".join(c_double(v) for v in np.asarray(values, float).ravel())
    return [f"static const double {name}[{np.asarray(values).size}] = {{{vals}}};" + (f" /* {comment} */"
                                                                                     if comment else "")]


def table_array(name: str, rows, comment: str = "") -> list[str]:
    """``static const double NAME[n][m]``."""
    a = np.asarray(rows, float)
    body = ",\n".join("    {" + ", ".join(c_double(v) for v in r) + "}" for r in a)
    return ([f"/* {comment} */"] if comment else []) + [f"static const double {name}[{a.shape[0]}][{a.shape[1]}] = "
                                                         f"{{\n{body}\n}};", ""]


def sos_step_function(prefix: str) -> list[str]:
    """``PREFIX_sos_step``: one sample through cascaded sections (transposed direct form II)."""
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


def limit_lines(opts: COptions, unit: str) -> list[str]:
    """The output-limit and anti-windup macros and the clamp function."""
    P = opts.P
    if opts.u_max is None:
        return [f"/* no output limit: {opts.prefix}_step returns the law's command unclamped (export with --u-max to "
                "clamp it) */", ""]
    return [
        f"#define {P}_U_MAX {c_double(opts.u_max)} /* {unit}: every command is clamped to +-{P}_U_MAX */",
        f"#define {P}_ANTI_WINDUP {1 if opts.anti_windup == 'clamp' else 0} /* 1: conditional integration */",
        f"static inline double {opts.prefix}_clamp(double u) {{",
        f"    return u > {P}_U_MAX ? {P}_U_MAX : (u < -{P}_U_MAX ? -{P}_U_MAX : u);",
        "}",
        "",
    ]


def integrate_line(opts: COptions, state: str, error: str, fs: str, last_u: str) -> str:
    """``state += error / fs``, skipped (with clamp anti-windup) while ``last_u`` sits at the limit and the error
    drives it further."""
    if opts.anti_windup != "clamp":
        return f"    {state} += {error} / {fs};"
    P = opts.P
    return (f"    if (!(({last_u} >= {P}_U_MAX && {error} > 0.0) || ({last_u} <= -{P}_U_MAX && {error} < 0.0))) "
            f"{state} += {error} / {fs};")


def output_line(opts: COptions, target: str, expr: str) -> list[str]:
    """``target = expr``, clamped with a limit."""
    if opts.u_max is None:
        return [f"    double {target} = {expr};"]
    return [f"    double {target} = {opts.prefix}_clamp({expr});"]


def banner(what: str, doc: dict, opts: COptions, lines: list[str]) -> list[str]:
    """The opening comment: source, the law, units, the limit, a warning."""
    out = [f"/* Generated by {doc.get('created_by', 'feedtune')} -- do not edit.", f" * {what}"]
    out += [f" * {line}" for line in lines]
    if opts.warning:
        out.append(f" * WARNING: {opts.warning}")
    out.append(" */")
    P = opts.P
    out += [f"#ifndef {P}_GAINS_H", f"#define {P}_GAINS_H", "#include <string.h>"]
    return out
