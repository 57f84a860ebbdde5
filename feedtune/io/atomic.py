"""Atomic file output: a destination appears whole when writing succeeds and is left untouched otherwise.

Every writer in :mod:`feedtune.io` goes through these helpers. Data are first written to a temporary file
in the destination folder (same file system) and then published under the destination's name, so a reader never
sees a half-written file and a failed write leaves nothing behind. Without ``force`` a destination is created
exclusively (a hard link of the temporary file, which fails when the name exists): a second writer that started
before the first one finished fails cleanly instead of silently replacing its file. With ``force`` only a regular
file (or a symbolic link, which is replaced, not followed) is replaced, never a device, a FIFO or a socket. Errors
of the file system name the path and the error (``no space left on device (ENOSPC)``, :func:`os_error_text`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

from ..errors import DataError, UsageError

NAME_MAX = 255
"""Longest file name [bytes] where the file system does not say (``os.pathconf``)."""
PATH_MAX = 4096
"""Longest path [bytes] the system call accepts on Linux."""


def os_error_text(exc: OSError) -> str:
    """What an :class:`OSError` says, with the symbolic name of its error: ``no space left on device (ENOSPC)``.

    Examples
    --------
    >>> os_error_text(OSError(errno.ENOSPC, "No space left on device"))
    'no space left on device (ENOSPC)'
    """
    text = exc.strerror or str(exc) or type(exc).__name__
    text = text[:1].lower() + text[1:]
    name = errno.errorcode.get(exc.errno or -1)
    return f"{text} ({name})" if name else text


def write_error(path: str | os.PathLike[str], exc: OSError) -> DataError:
    """The one-line error of a failed write of ``path``: ``cannot write PATH: REASON (ENAME)``."""
    return DataError(f"cannot write {path}: {os_error_text(exc)}")


def kind_of(mode: int) -> str:
    """``a FIFO``, ``a character device``... for messages about a file that is not a regular file."""
    for test, word in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block "
                       "device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder")):
        if test(mode):
            return word
    return "not a regular file"


def check_name(p: Path) -> None:
    """DataError (ENAMETOOLONG) when the file name or the whole path is longer than the file system takes."""
    name = os.fsencode(p.name)
    parent = p.parent if str(p.parent) else Path(".")
    try:
        limit = os.pathconf(parent, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        limit = NAME_MAX
    if len(name) > limit:
        raise DataError(f"cannot write {str(p)[:80]}...: the file name is {len(name)} bytes long, more than the "
                        f"{limit} this file system takes (ENAMETOOLONG)")
    if len(os.fsencode(os.path.abspath(p))) >= PATH_MAX:
        raise DataError(f"cannot write {str(p)[:80]}...: the path is longer than the {PATH_MAX} bytes the system "
                        "takes (ENAMETOOLONG)")


def check_folder_writable(p: Path, parent: Path) -> None:
    """DataError naming EROFS or EACCES when nothing can be created in ``parent``."""
    if os.access(parent, os.W_OK | os.X_OK):
        return
    try:
        read_only = bool(os.statvfs(parent).f_flag & getattr(os, "ST_RDONLY", 1))
    except (OSError, AttributeError):
        read_only = False
    code = errno.EROFS if read_only else errno.EACCES
    raise write_error(p, OSError(code, os.strerror(code)))


def ensure_writable(path: str | os.PathLike[str], force: bool) -> Path:
    """Check that ``path`` may be written and return it as a :class:`~pathlib.Path`.

    Parameters
    ----------
    path : str or path-like
        Destination file.
    force : bool
        Allow replacing an existing regular file.

    Raises
    ------
    UsageError
        The file exists and ``force`` is false.
    DataError
        The parent folder does not exist or cannot be written to (EACCES, EROFS), ``path`` is a folder, a name longer
        than the file system takes (ENAMETOOLONG), or with ``force`` an existing file that is not a regular file.
    """
    p = Path(path)
    check_name(p)
    parent = p.parent if str(p.parent) else Path(".")
    try:
        st = os.lstat(p)
    except FileNotFoundError:
        st = None
    except NotADirectoryError:
        raise DataError(f"{p}: {parent} is not a folder") from None
    except OSError as exc:
        raise write_error(p, exc) from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise DataError(f"{p} is a folder; give a file name to write")
    if not parent.is_dir():
        raise DataError(f"{p}: folder {parent} does not exist")
    if st is not None:
        if not force:
            raise UsageError(f"{p} exists; pass force=True to overwrite", parameter="force")
        _check_replaceable(p)
    check_folder_writable(p, parent)
    return p


def _check_replaceable(p: Path) -> None:
    """DataError unless ``p`` is absent, a regular file or a symbolic link (the link is replaced, not its target)."""
    try:
        mode = os.lstat(p).st_mode
    except FileNotFoundError:
        return
    if not (stat.S_ISREG(mode) or stat.S_ISLNK(mode)):
        raise DataError(f"{p} is {kind_of(mode)}; --force replaces only regular files")


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
def staged_folder(out: str | os.PathLike[str], force: bool = False) -> Iterator[Path]:
    """Build a folder of outputs under a temporary name beside ``out`` and move it into place when the block
    succeeds: a new ``out`` (or an empty one) appears whole (one rename, which fails when another process filled the
    name meanwhile: no silent replacement); with ``force`` an existing non-empty one gets each file replaced
    (:func:`os.replace`, regular files only). On an error or a signal the staging folder is removed; one a killed
    process left is swept by the next write there (:func:`sweep_stale_temps`)."""
    import shutil

    dest = Path(out)
    parent = dest.parent if str(dest.parent) else Path(".")
    with contextlib.suppress(OSError):
        sweep_stale_temps(parent)
    try:
        stage = Path(tempfile.mkdtemp(dir=parent, prefix=f".{dest.name}{TEMP_MARK}{os.getpid()}-", suffix=".tmp"))
    except OSError as exc:
        raise write_error(dest, exc) from None
    try:
        yield stage
        if force and dest.is_dir() and any(dest.iterdir()):
            files = sorted(stage.iterdir(), key=lambda q: q.name == "report.html")  # the report last
            for f in files:
                _check_replaceable(dest / f.name)
            for f in files:
                os.replace(f, dest / f.name)
        else:
            try:
                os.rename(stage, dest)
            except OSError as exc:
                if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR, errno.EISDIR):
                    raise
                raise UsageError(f"{dest} was written by another process while this command ran; nothing of this "
                                 "run was kept (pass force=True to write into it)", parameter="force") from None
    except OSError as exc:
        raise write_error(dest, exc) from None
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
        raise write_error(dest, exc) from None
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
        try:
            yield list(temps)
        except OSError as exc:  # the writer's: a full disk, a quota
            raise write_error(dests[0] if len(dests) == 1 else _culprit(exc, dests, temps), exc) from None
        modes = [_default_mode(d) for d in dests]
        for tmp, mode in zip(temps, modes, strict=True):
            if not tmp.exists():
                raise DataError(f"{tmp}: the writer did not create its output file")
            os.chmod(tmp, mode)
        done: list[Path] = []
        try:
            for tmp, dest in zip(temps, dests, strict=True):
                _publish(tmp, dest, force)
                done.append(dest)
        except BaseException as exc:
            for d in done:
                _remove_quietly(d)
            if isinstance(exc, OSError):
                raise write_error(dest, exc) from None
            raise
    finally:
        for tmp in temps:
            if tmp.exists():
                _remove_quietly(tmp)


def _culprit(exc: OSError, dests: list[Path], temps: list[Path]) -> Path:
    """The destination whose temporary file an error names (the first destination when it names none)."""
    name = str(getattr(exc, "filename", "") or "")
    for dest, tmp in zip(dests, temps, strict=True):
        if name and os.path.basename(name) == tmp.name:
            return dest
    return dests[0]


_NO_LINKS = {errno.EPERM, errno.EXDEV, errno.EMLINK, errno.ENOSYS, getattr(errno, "ENOTSUP", -1),
             getattr(errno, "EOPNOTSUPP", -1)}
"""Errors of :func:`os.link` on file systems without hard links (then the name is reserved with ``O_EXCL``)."""


def _publish(tmp: Path, dest: Path, force: bool) -> None:
    """Give the finished temporary file ``tmp`` the name ``dest``: replacing a regular file with ``force``, else
    only when the name is free (a hard link, or an ``O_EXCL`` reservation where the file system has no links)."""
    if force:
        _check_replaceable(dest)
        os.replace(tmp, dest)
        return
    try:
        os.link(tmp, dest)
    except FileExistsError:
        raise _taken(dest) from None
    except OSError as exc:
        if exc.errno not in _NO_LINKS:
            raise
        try:
            os.close(os.open(dest, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        except FileExistsError:
            raise _taken(dest) from None
        os.replace(tmp, dest)
        return
    _remove_quietly(tmp)


def _taken(dest: Path) -> UsageError:
    return UsageError(f"{dest} was created by another process while this command ran; it is not replaced (pass "
                      "force=True to overwrite)", parameter="force")


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
