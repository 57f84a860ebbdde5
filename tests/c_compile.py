"""Compiling exported C headers in the tests: ``-std=c99 -Wall -Wextra -Werror``, and AddressSanitizer with
UndefinedBehaviorSanitizer (any finding aborts the run) where the compiler has them."""

from __future__ import annotations

import functools
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

WARNINGS = ["-std=c99", "-Wall", "-Wextra", "-Werror"]
SANITIZERS = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]


def compiler() -> str | None:
    """The C compiler (``cc`` or ``gcc``), or None."""
    return shutil.which("cc") or shutil.which("gcc")


@functools.cache
def sanitizer_flags(cc: str) -> tuple[str, ...]:
    """:data:`SANITIZERS` when ``cc`` builds and runs a program with them, else ()."""
    with tempfile.TemporaryDirectory() as tmp:
        src, exe = Path(tmp) / "t.c", Path(tmp) / "t"
        src.write_text("int main(void) { return 0; }\n")
        try:
            subprocess.run([cc, *SANITIZERS, "-o", str(exe), str(src)], check=True, capture_output=True)
            subprocess.run([str(exe)], check=True, capture_output=True)
        except (subprocess.CalledProcessError, OSError):
            return ()
    return tuple(SANITIZERS)


def compile_c(cc: str, source: Path, exe: Path, *, opt: str = "-O1") -> list[str]:
    """Compile ``source`` to ``exe`` with the warnings as errors and the sanitizers; returns the command."""
    cmd = [cc, *WARNINGS, opt, *sanitizer_flags(cc), "-o", str(exe), str(source), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=source.parent)
    return cmd


# ------------------------------------------------------------------------------------------ drivers of the headers
_GANTRY = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    ft_state s; ft_init(&s);
    double r, y1, y2, x, u[2];
    while (scanf("%lf %lf %lf %lf", &r, &y1, &y2, &x) == 4) {
        ft_step(&s, r, y1, y2, x, u);
        printf("%.17g %.17g\n", u[0], u[1]);
    }
    return 0;
}
"""
_AXIS = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    ft_state s; ft_init(&s);
    double r, x;
    while (scanf("%lf %lf", &r, &x) == 2) printf("%.17g\n", ft_step(&s, r, x));
    return 0;
}
"""
_BALLSCREW = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    ft_state s; ft_init(&s);
    double r, x1, x2;
    while (scanf("%lf %lf %lf", &r, &x1, &x2) == 3) printf("%.17g\n", ft_step(&s, r, x1, x2));
    return 0;
}
"""
DRIVERS = {"ballscrew": _BALLSCREW, "gantry": _GANTRY, "axis": _AXIS}
"""A ``main`` per gains kind that runs ``gains.h``'s ``ft_step`` on one line of inputs per sample (stdin) and prints
the command(s) with 17 digits."""


def run_header(cc: str, folder: Path, header: str, main_c: str, inputs: np.ndarray, *, opt: str = "-O1") -> np.ndarray:
    """Compile ``header`` (as ``gains.h``) with ``main_c`` in ``folder``, feed it ``inputs`` (one row per sample) and
    return its outputs, one row per sample."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "gains.h").write_text(header)
    (folder / "main.c").write_text(main_c)
    exe = folder / "prog"
    compile_c(cc, folder / "main.c", exe, opt=opt)
    text = "\n".join(" ".join(repr(float(v)) for v in row) for row in inputs) + "\n"
    res = subprocess.run([str(exe)], input=text, check=True, capture_output=True, text=True)
    return np.array([[float(v) for v in line.split()] for line in res.stdout.splitlines()])
