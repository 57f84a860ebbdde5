"""Compiling exported C headers in the tests: ``-std=c99 -Wall -Wextra -Werror``, and AddressSanitizer with
UndefinedBehaviorSanitizer (any finding aborts the run) where the compiler has them."""

from __future__ import annotations

import functools
import shutil
import subprocess
import tempfile
from pathlib import Path

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
