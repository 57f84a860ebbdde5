"""Engine choice and the compile cache every machine's closed loop shares.

A twin's closed loop is one plain-Python function over scalars and arrays. With numba installed (a hard
dependency, so normally always) it is compiled once per process with ``njit(cache=True, nogil=True)``; the
``python`` engine runs the same function uncompiled (slow, for debugging and for checking the compiled one).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import UsageError

ENGINES = ("auto", "numba", "python")

_COMPILED: dict[Callable, Callable] = {}


def numba_available() -> bool:
    """True when numba can be imported (the compiled closed loops are then used)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def choose_engine(engine: str) -> str:
    """``numba`` or ``python`` for an ``engine`` option of ``auto``, ``numba`` or ``python``.

    Raises
    ------
    UsageError
        An unknown engine, or ``numba`` requested without numba installed.
    """
    if engine not in ENGINES:
        raise UsageError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if engine == "auto":
        return "numba" if numba_available() else "python"
    if engine == "numba" and not numba_available():
        raise UsageError("engine 'numba' requested but numba is not installed (pip install numba)")
    return engine


def compiled(func: Callable) -> Callable:
    """``func`` compiled by numba (``njit(cache=True, nogil=True)``), once per process."""
    if func not in _COMPILED:
        import numba

        _COMPILED[func] = numba.njit(cache=True, nogil=True)(func)
    return _COMPILED[func]


def kernel(func: Callable, engine: str) -> Callable:
    """``func`` as the chosen engine runs it: compiled for ``numba``, itself for ``python``."""
    return func if choose_engine(engine) == "python" else compiled(func)


def sample_vector(x, name: str, n: int | None = None, *, min_size: int = 2) -> np.ndarray:
    """``x`` as a finite 1-D float array of ``n`` samples (or at least ``min_size``).

    Raises
    ------
    UsageError
        Not numbers, the wrong length, or NaN/infinite values (names ``name``).
    """
    try:
        a = np.asarray(x, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise UsageError(f"{name}: expected a sequence of numbers") from None
    if a.size < min_size or (n is not None and a.size != n):
        least = "at least 1" if min_size == 1 else f"at least {min_size}"
        raise UsageError(f"{name}: expected {n if n is not None else least} samples, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise UsageError(f"{name}: contains NaN or infinite values")
    return a
