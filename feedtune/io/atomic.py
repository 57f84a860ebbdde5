"""Atomic file output: a destination is replaced whole when writing succeeds and left untouched otherwise.

Every writer in :mod:`feedtune.io` goes through these helpers. Data are first written to a temporary file
in the destination folder (same file system) and then renamed onto the destination with :func:`os.replace`,
so a reader never sees a half-written file and a failed write leaves nothing behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

from ..errors import DataError, UsageError


def ensure_writable(path: str | os.PathLike[str], force: bool) -> Path:
    """Check that ``path`` may be written and return it as a :class:`~pathlib.Path`.

    Parameters
    ----------
    path : str or path-like
        Destination file.
    force : bool
        Allow replacing an existing file.

    Raises
    ------
    UsageError
        The file exists and ``force`` is false.
    DataError
        The parent folder does not exist, or ``path`` is a folder.
    """
    p = Path(path)
    if p.is_dir():
        raise DataError(f"{p} is a folder; give a file name to write")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise DataError(f"{p}: folder {parent} does not exist")
    if p.exists() and not force:
        raise UsageError(f"{p} exists; pass force=True to overwrite", parameter="force")
    return p


def _default_mode(dest: Path) -> int:
    """Permission bits for a new file: the destination's when it exists, else ``0o666`` minus the umask."""
    if dest.exists():
        return dest.stat().st_mode & 0o7777
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


TEMP_MARK = ".ft"
"""Temporary files are named ``.NAME.ft<pid>-<random>.tmp<suffix>`` beside their destination."""
_SWEPT: set = set()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def sweep_stale_temps(folder: Path) -> list[Path]:
    """Remove the temporary files that a killed feedtune process (SIGKILL, power loss) left in ``folder``: those
    whose process no longer runs. Done once per folder and process, before the first write there."""
    key = folder.resolve()
    if key in _SWEPT:
        return []
    _SWEPT.add(key)
    removed = []
    for p in folder.glob(f".*{TEMP_MARK}*-*.tmp*"):
        head = p.name.rsplit(TEMP_MARK, 1)[-1].split("-", 1)[0]
        if head.isdigit() and int(head) != os.getpid() and not _pid_alive(int(head)):
            if p.is_dir():
                import shutil

                shutil.rmtree(p, ignore_errors=True)
            else:
                _remove_quietly(p)
            removed.append(p)
    return removed


@contextlib.contextmanager
def staged_folder(out: str | os.PathLike[str]) -> Iterator[Path]:
    """Build a folder of outputs under a temporary name beside ``out`` and move it into place when the block
    succeeds: a new ``out`` appears whole (one rename), an existing one (written into with ``--force``) gets each
    file replaced (:func:`os.replace`). On an error or a signal the staging folder is removed; one a killed process
    left is swept by the next write there (:func:`sweep_stale_temps`)."""
    import shutil

    dest = Path(out)
    parent = dest.parent if str(dest.parent) else Path(".")
    with contextlib.suppress(OSError):
        sweep_stale_temps(parent)
    try:
        stage = Path(tempfile.mkdtemp(dir=parent, prefix=f".{dest.name}{TEMP_MARK}{os.getpid()}-", suffix=".tmp"))
    except OSError as exc:
        raise DataError(f"cannot write {dest}: {exc.strerror or exc}") from None
    try:
        yield stage
        if not dest.exists():
            os.replace(stage, dest)
        else:
            for f in sorted(stage.iterdir(), key=lambda q: q.name == "report.html"):  # the report last
                os.replace(f, dest / f.name)
    except OSError as exc:
        raise DataError(f"cannot write {dest}: {exc.strerror or exc}") from None
    finally:
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)


def _make_temp(dest: Path, suffix: str | None) -> Path:
    """Create an empty temporary file beside ``dest`` and return its path (stale ones are swept first)."""
    sfx = dest.suffix if suffix is None else suffix
    folder = dest.parent if str(dest.parent) else Path(".")
    with contextlib.suppress(OSError):
        sweep_stale_temps(folder)
    try:
        fd, name = tempfile.mkstemp(dir=folder, prefix=f".{dest.name}{TEMP_MARK}{os.getpid()}-",
                                    suffix=f".tmp{sfx}")
    except OSError as exc:
        raise DataError(f"cannot write {dest}: {exc.strerror or exc}") from None
    os.close(fd)
    return Path(name)


def _remove_quietly(path: Path) -> None:
    with contextlib.suppress(OSError):
        path.unlink()


@contextlib.contextmanager
def atomic_outputs(
    paths: Sequence[str | os.PathLike[str]],
    *,
    force: bool = False,
    suffixes: Sequence[str | None] | None = None,
) -> Iterator[list[Path]]:
    """Write several files all-or-nothing: yield temporary paths, rename them onto ``paths`` on success.

    All destinations are checked with :func:`ensure_writable` before anything is written. When the block
    raises, every temporary file is removed and no destination changes. After the block, the temporary
    files are renamed one by one; if a rename fails, destinations already renamed in this call are removed
    again, so either all new files exist or none does.

    Parameters
    ----------
    paths : sequence of path-like
        Destination files.
    force : bool
        Allow replacing existing files.
    suffixes : sequence of str or None, optional
        File-name ending of each temporary file (default: the destination's suffix), for libraries that
        choose the format from the name.
    """
    dests = [ensure_writable(p, force) for p in paths]
    seen: dict[Path, int] = {}
    for i, d in enumerate(dests):
        key = d.resolve()
        if key in seen:
            from ..errors import UsageError

            raise UsageError(f"{d}: two outputs of this command would be written to the same file; give them "
                             "different names")
        seen[key] = i
    sfx = list(suffixes) if suffixes is not None else [None] * len(dests)
    temps: list[Path] = []
    try:
        for dest, s in zip(dests, sfx, strict=True):
            temps.append(_make_temp(dest, s))
        yield list(temps)
        modes = [_default_mode(d) for d in dests]
        for tmp, mode in zip(temps, modes, strict=True):
            if not tmp.exists():
                raise DataError(f"{tmp}: the writer did not create its output file")
            os.chmod(tmp, mode)
        done: list[Path] = []
        try:
            for tmp, dest in zip(temps, dests, strict=True):
                os.replace(tmp, dest)
                done.append(dest)
        except OSError as exc:
            for d in done:
                _remove_quietly(d)
            raise DataError(f"cannot write {dest}: {exc.strerror or exc}") from None
    finally:
        for tmp in temps:
            if tmp.exists():
                _remove_quietly(tmp)


@contextlib.contextmanager
def atomic_output(
    path: str | os.PathLike[str], *, force: bool = False, suffix: str | None = None
) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only when the block succeeds.

    For libraries that write files themselves (``scipy.io.savemat``, ``pyuff``, ``matplotlib``). The
    temporary file exists (empty) when the block starts.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_output(d / "a.txt") as tmp:
    ...     _ = tmp.write_text("hello")
    >>> (d / "a.txt").read_text()
    'hello'
    """
    with atomic_outputs([path], force=force, suffixes=[suffix]) as temps:
        yield temps[0]


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, *, force: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_output`); return the path."""
    with atomic_output(path, force=force) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    return Path(path)


def atomic_write_text(path: str | os.PathLike[str], text: str, *, force: bool = False) -> Path:
    """Write ``text`` as UTF-8 with ``\\n`` line ends to ``path`` atomically; return the path."""
    return atomic_write_bytes(path, text.encode("utf-8"), force=force)
