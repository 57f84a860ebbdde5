"""Where numba caches feedtune's compiled kernels: a private folder of the user's, checked before numba may load
anything from it.

numba loads a cached kernel by unpickling its index file: whoever can write into the cache folder can make feedtune
run their code. So the folder is ``$XDG_CACHE_HOME/feedtune/numba/<digest of the sources>`` (``~/.cache`` when
``XDG_CACHE_HOME`` is unset or relative: a relative one would put the cache in whatever folder the command runs in),
each level created 0700; a level that exists must be a real folder (not a symlink) owned by the user and writable by
nobody else. Otherwise (or when it cannot be created) the kernels of this run are compiled into a fresh private
temporary folder (removed at exit) and a :class:`KernelCacheWarning` says why; a ``NUMBA_CACHE_DIR`` the user set is
used when it passes the same check. The folder is prepared when numba is first imported (:func:`install`), so
``import feedtune`` stays cheap, and numba never falls back to writing beside the installed package.
"""

from __future__ import annotations

import os as _os
import sys as _sys

ENV_VARIABLE = "NUMBA_CACHE_DIR"


class KernelCacheWarning(UserWarning):
    """The kernel cache folder was not used (its owner or permissions are wrong, or it cannot be created)."""


def kernel_cache_dir(package_dir: str | None = None) -> str:
    """The folder numba caches feedtune's compiled kernels in: under the user's cache folder (never in the installed
    package), named after a digest of the package's sources (a few ms to read).

    numba keys a cached kernel on its own source file only; the twins' loops inline laws from other modules
    (``machines/gantry/law.py`` into ``twin.py``), so a change there, in a working copy or an upgrade, would
    otherwise leave the old law running from the cache.
    """
    import hashlib

    root = package_dir or _os.path.dirname(_os.path.abspath(__file__))
    digest = hashlib.blake2b(digest_size=8)
    for folder, dirs, files in sorted(_os.walk(root)):
        dirs.sort()
        for name in sorted(f for f in files if f.endswith(".py")):
            with open(_os.path.join(folder, name), "rb") as fh:
                digest.update(name.encode() + fh.read())
    return _os.path.join(user_cache_base(), "feedtune", "numba", digest.hexdigest())


def user_cache_base() -> str:
    """``$XDG_CACHE_HOME`` when it is an absolute path, else ``~/.cache`` (the XDG base directory rule)."""
    base = _os.environ.get("XDG_CACHE_HOME", "")
    if not _os.path.isabs(base):
        base = _os.path.join(_os.path.expanduser("~"), ".cache")
    return base


def folder_problem(path: str) -> str | None:
    """Why ``path`` (an existing folder) must not be trusted, or None: not a real folder, owned by someone else,
    or writable by its group or others."""
    import stat

    try:
        st = _os.lstat(path)
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    if stat.S_ISLNK(st.st_mode):
        return "is a symbolic link"
    if not stat.S_ISDIR(st.st_mode):
        return "is not a folder"
    if hasattr(_os, "getuid") and st.st_uid != _os.getuid():
        return f"is owned by user id {st.st_uid}, not by you ({_os.getuid()})"
    if st.st_mode & 0o022:
        return f"is writable by {'its group' if st.st_mode & 0o020 else 'others'} (mode {stat.S_IMODE(st.st_mode):o})"
    return None


def private_folder(path: str, levels: int) -> str | None:
    """Create ``path`` and its last ``levels - 1`` parents 0700 where missing and check every one of these levels
    (:func:`folder_problem`); return what is wrong (naming the folder), or None when ``path`` is safe to use."""
    parts = [path]
    for _ in range(levels - 1):
        parts.insert(0, _os.path.dirname(parts[0]))
    try:
        _os.makedirs(_os.path.dirname(parts[0]), exist_ok=True)
    except OSError as exc:
        return f"{_os.path.dirname(parts[0])} cannot be created ({exc.strerror})"
    for folder in parts:
        try:
            _os.mkdir(folder, 0o700)
        except FileExistsError:
            pass
        except OSError as exc:
            return f"{folder} cannot be created ({exc.strerror})"
        problem = folder_problem(folder)
        if problem:
            return f"{folder} {problem}"
    return None


def _temporary() -> str:
    """A fresh private folder for this run's kernels, removed at exit."""
    import atexit
    import shutil
    import tempfile

    path = tempfile.mkdtemp(prefix="feedtune-kernels-")
    atexit.register(shutil.rmtree, path, True)
    return path


def prepare() -> str:
    """Choose and check the cache folder, set ``NUMBA_CACHE_DIR`` to it and return it (see the module docstring);
    a folder that fails the check is replaced by a temporary one, with a :class:`KernelCacheWarning`."""
    import warnings

    given = _os.environ.get(ENV_VARIABLE)
    if given:
        if not _os.path.isabs(given):
            problem = f"{given} ({ENV_VARIABLE}) is a relative path"
        else:  # created 0700 when missing, checked as the default folder's last level
            problem = private_folder(given, 1)
            problem = problem and f"{problem} ({ENV_VARIABLE})"
    else:
        given = kernel_cache_dir()
        problem = private_folder(given, 3)
    if problem is None:
        _os.environ[ENV_VARIABLE] = given
        return given
    folder = _temporary()
    _os.environ[ENV_VARIABLE] = folder
    warnings.warn(f"the kernel cache folder {problem}: no kernel is loaded from it; this run compiles them into "
                  f"{folder} (make the folder yours and private, chmod 700, or remove it)", KernelCacheWarning,
                  stacklevel=3)
    return folder


class _BeforeNumba:
    """A one-shot import hook: prepares the cache folder when ``numba`` is first imported, then steps aside."""

    @staticmethod
    def find_spec(fullname, path=None, target=None):
        if fullname == "numba":
            uninstall()
            prepare()
        return None


def install() -> None:
    """Prepare the cache folder when numba is first imported (now, when it is imported already)."""
    if "numba" in _sys.modules:
        if not _os.environ.get(ENV_VARIABLE):
            prepare()
        return
    if not any(isinstance(f, _BeforeNumba) for f in _sys.meta_path):
        _sys.meta_path.insert(0, _BeforeNumba())


def uninstall() -> None:
    """Remove the import hook of :func:`install`."""
    _sys.meta_path[:] = [f for f in _sys.meta_path if not isinstance(f, _BeforeNumba)]


class PendingKernel:
    """A kernel compiling into the kernel cache in another process (a first run's background compile:
    :func:`feedtune.workflows.warmup.ensure_kernels`): the code that uses it calls :meth:`wait` before its first call,
    which then loads it from the cache instead of compiling it a second time."""

    def __init__(self) -> None:
        self._future = None
        self._pid = None

    def set(self, future) -> None:
        """``future`` (a :class:`concurrent.futures.Future`) ends when the kernel is in the cache; None: nothing to
        wait for. Only this process waits for it: a forked child holds a copy of the future that nothing will end,
        and compiles or loads the kernel itself."""
        self._future = future
        self._pid = _os.getpid()

    def _own(self):
        """The future, in the process that set it (None elsewhere)."""
        return self._future if self._pid == _os.getpid() else None

    def pending(self) -> bool:
        """Whether the other process is still compiling it."""
        future = self._own()
        return future is not None and not future.done()

    def wait(self) -> None:
        """Wait for the other process (once; at once when nothing compiles elsewhere or in a forked child)."""
        future, self._future = self._own(), None
        if future is not None:
            from concurrent.futures import wait

            wait([future])
