"""One BLAS thread around tiny dense-matrix work.

feedtune's dense linear algebra is on matrices of at most about 10 x 10 (``expm`` for exact zero-order holds, small
solves, Riccati equations), often batched over frequency or position grids. Multi-threaded BLAS only costs there:
OpenBLAS hands a 7 x 7 ``expm`` to its thread pool, which takes 2-3x longer on an idle 2-core machine and, when
other processes keep the cores busy, 16-20 ms instead of ~10 us (the pool's threads wait for cores). So the
command line runs every command with one BLAS thread, and the library functions that do such work limit the threads
while they run (:func:`single_threaded_blas`, :func:`blas_single_threaded`), which also protects library users who
call them from their own programs. ``benchmarks/bench_blas.py`` measures both.

Uses ``threadpoolctl`` (imported lazily); without it, nothing is limited.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

_CONTROLLER: list = []


def _controller():
    """The process' threadpoolctl controller (built once: it inspects the loaded libraries), or None.

    numpy and scipy bring their own OpenBLAS builds; scipy's is loaded with ``scipy.linalg``, so it is imported
    before the controller looks: a controller built before it would leave scipy's BLAS (``least_squares``' SVDs:
    130 ms instead of 1.5 ms on a 2383 x 9 Jacobian on a busy 2-core machine) with its thread pool."""
    if not _CONTROLLER:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency
            _CONTROLLER.append(None)
        else:
            import numpy  # noqa: F401
            import scipy.linalg  # noqa: F401

            _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0]


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Limit BLAS (OpenBLAS, MKL, BLIS) to one thread inside the block; the previous limits come back after it.

    Entering costs about 2 us once the controller exists (the first call, about 1 ms, inspects the process).
    """
    ctl = _controller()
    if ctl is None:
        yield
        return
    import numpy  # noqa: F401  (the BLAS numpy and scipy load must be in the process to be limited)

    with ctl.limit(limits=1, user_api="blas"):
        yield


def blas_single_threaded(fn: F) -> F:
    """Decorator: run ``fn`` inside :func:`single_threaded_blas`."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with single_threaded_blas():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
