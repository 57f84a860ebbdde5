"""Where numba caches feedtune's compiled kernels (set before numba is imported, in :mod:`feedtune`)."""

from __future__ import annotations

import os as _os


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
    base = _os.environ.get("XDG_CACHE_HOME") or _os.path.join(_os.path.expanduser("~"), ".cache")
    return _os.path.join(base, "feedtune", "numba", digest.hexdigest())
