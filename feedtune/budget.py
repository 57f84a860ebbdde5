"""The memory budget: what an input or an option may make feedtune allocate, checked before the allocation.

Every reader and every command computes the memory its inputs and options imply from their sizes (rows x columns of
a file from its size in bytes, periods x samples of an excitation, plateau windows, table positions, merge rates)
and refuses, with one line naming the option or the file and the size, what exceeds the budget
(:func:`check_memory`), instead of running out of memory half-way (or, with the operating system's overcommit, of
being killed) after minutes of work.

The budget (:func:`memory_budget`) is :data:`DEFAULT_FRACTION` of the machine's memory (the physical memory, or a
smaller cgroup limit), never more than what the process may still map under its address-space limit
(``ulimit -v``); the environment variable ``FEEDTUNE_MEMORY_BUDGET`` sets it: bytes with an optional unit
(``800M``, ``4G``, ``2GiB``, ``1.5e9``) or a percentage of the machine's memory (``25%``). docs/conventions.md
documents it.

Examples
--------
>>> import os
>>> os.environ["FEEDTUNE_MEMORY_BUDGET"] = "1G"
>>> memory_budget() == 2**30
True
>>> check_memory(8 * 10**6, "a table of 10**6 numbers")                        # fits: nothing happens
>>> check_memory(8e12, "samples=10**12 samples", parameter="samples")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
feedtune.errors.UsageError: samples=10**12 samples would take 7.28 TiB of memory, more than the memory budget ...
>>> del os.environ["FEEDTUNE_MEMORY_BUDGET"]
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable

from .errors import DataError, UsageError

ENV_VARIABLE = "FEEDTUNE_MEMORY_BUDGET"
"""The environment variable that sets the budget (bytes with a unit, or a percentage of the machine's memory)."""

DEFAULT_FRACTION = 0.5
"""The default budget as a fraction of the machine's memory [-]: room for the work of one command and for what else
runs on the machine."""

TWIN_SAMPLE_BYTES = 1024
"""Memory of one sample of a digital-twin run [bytes]: its inputs, the states and signals it logs, the log and its CSV
text (measured 310-550 bytes on the ball-screw twin's rope snap and FRF runs; rounded up)."""

ADDRESS_SPACE_FRACTION = 0.8
"""Fraction of the address space still free under ``ulimit -v`` (RLIMIT_AS) the budget may take [-]: the rest is
for the interpreter's own growth, temporaries and libraries loaded later."""

_UNITS = {"": 1, "b": 1, "k": 1 << 10, "kb": 1000, "kib": 1 << 10, "m": 1 << 20, "mb": 10**6, "mib": 1 << 20,
          "g": 1 << 30, "gb": 10**9, "gib": 1 << 30, "t": 1 << 40, "tb": 10**12, "tib": 1 << 40}
_SIZE_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*$")


def fmt_bytes(n: float) -> str:
    """A size [bytes] for messages: ``512 bytes``, ``3.2 MiB``, ``74.5 GiB``.

    Examples
    --------
    >>> fmt_bytes(512), fmt_bytes(3.2 * 2**20), fmt_bytes(8e10)
    ('512 bytes', '3.2 MiB', '74.5 GiB')
    """
    if not math.isfinite(n):
        return "an unbounded amount"
    if n < 1024:
        return f"{n:.0f} bytes"
    for unit in ("KiB", "MiB", "GiB", "TiB", "PiB"):
        n /= 1024.0
        if n < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
    raise AssertionError  # pragma: no cover


def machine_memory() -> int:
    """The machine's memory [bytes]: the physical memory, or the cgroup's memory limit when smaller."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # not POSIX
        total = 8 << 30
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as fh:
                text = fh.read().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < total:
            total = int(text)
    return int(total)


def _address_space_left() -> float:
    """Bytes the process may still map under its address-space limit (RLIMIT_AS); inf without one."""
    try:
        import resource
    except ImportError:  # Windows
        return math.inf
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY or soft < 0:
        return math.inf
    try:
        with open("/proc/self/statm") as fh:
            mapped = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        mapped = 0
    return max(soft - mapped, 0)


def parse_size(text: str, what: str = ENV_VARIABLE) -> int:
    """Bytes from ``800M``, ``4G``, ``2GiB``, ``1.5e9`` or ``25%`` (of :func:`machine_memory`).

    Raises
    ------
    UsageError
        Anything else, naming ``what``.

    Examples
    --------
    >>> parse_size("800M"), parse_size("2GB"), parse_size("1.5e9")
    (838860800, 2000000000, 1500000000)
    """
    s = str(text).strip()
    if s.endswith("%"):
        try:
            pct = float(s[:-1])
        except ValueError:
            pct = math.nan
        if not (0 < pct <= 100):
            raise UsageError(f"{what} expects a size such as 4G or a percentage in (0, 100], got {text!r}")
        return int(machine_memory() * pct / 100.0)
    m = _SIZE_RE.match(s)
    unit = m.group(2).lower() if m else ""
    if not m or unit not in _UNITS:
        raise UsageError(f"{what} expects a size such as 800M, 4G, 2GiB or 25%, got {text!r}")
    value = float(m.group(1)) * _UNITS[unit]
    if not (math.isfinite(value) and value >= 1 << 20):
        raise UsageError(f"{what} expects a size of at least 1M, got {text!r}")
    return int(value)


def memory_budget() -> int:
    """The memory one input or one option may make feedtune allocate [bytes] (see the module docstring)."""
    env = os.environ.get(ENV_VARIABLE, "").strip()
    budget = float(parse_size(env) if env else machine_memory() * DEFAULT_FRACTION)
    return int(min(budget, ADDRESS_SPACE_FRACTION * _address_space_left()))


def check_memory(nbytes: float, what: str, *, parameter: str | Iterable[str] | None = None,
                 file: str | None = None) -> None:
    """Refuse work whose memory ``nbytes`` exceeds :func:`memory_budget`, before it is allocated.

    Parameters
    ----------
    nbytes : float
        The memory the work needs [bytes] (an estimate from the sizes; may be inf).
    what : str
        The work in words, naming the parameter(s) or the file and their values (``"periods=1000000 of 10000
        samples"``, ``"big.csv (10 GiB)"``).
    parameter : str or sequence of str, optional
        The parameter(s) that set the size: the error is then a :class:`~feedtune.errors.UsageError` carrying them
        (the command line names their options).
    file : str, optional
        The input file that sets the size: the error is then a :class:`~feedtune.errors.DataError`.

    Raises
    ------
    UsageError, DataError
        ``nbytes`` exceeds the budget (or is not finite).
    """
    budget = memory_budget()
    if math.isfinite(nbytes) and nbytes <= budget:
        return
    text = (f"{what} would take {fmt_bytes(nbytes)} of memory, more than the memory budget of {fmt_bytes(budget)} "
            f"({ENV_VARIABLE}; default {DEFAULT_FRACTION:.0%} of the machine's memory)")
    if file is not None and parameter is None:
        raise DataError(text)
    raise UsageError(text, parameter=parameter)


def file_size(path: str | os.PathLike[str]) -> int:
    """The size of ``path`` [bytes] (0 when it cannot be read: the reader then names the problem)."""
    try:
        return os.stat(path).st_size
    except (OSError, ValueError):
        return 0


def check_file(path: str | os.PathLike[str], bytes_per_byte: float, what: str = "reading") -> None:
    """Refuse a file whose reading needs more than the budget: ``bytes_per_byte`` bytes of memory per byte of the
    file (the text and the numbers parsed from it), estimated from its size before it is opened."""
    size = file_size(path)
    check_memory(size * bytes_per_byte, f"{what} {path} ({fmt_bytes(size)})", file=str(path))
