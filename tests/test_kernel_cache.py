"""The numba kernel cache is a private folder of the user's, and a folder someone else could write into is never
loaded from (issue 26): numba loads a cached kernel by unpickling its index, so a planted index file runs code.

Before: the cache under ``$XDG_CACHE_HOME/feedtune/numba/`` was used whoever owned it and whatever its permissions
(a planted index ran code), a relative ``XDG_CACHE_HOME`` put it in the working folder, and umask 002 made its
folders group-writable; an unwritable cache folder made numba write beside the installed package.
"""

from __future__ import annotations

import os
import pickle
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import feedtune
from feedtune import _kernel_cache as kc

CHILD = """
import numpy as np, os, sys, warnings
warnings.simplefilter("always")
from feedtune.identify.kalman import _filter_pass
out = np.empty((3, 4))
_filter_pass()(np.eye(3), np.zeros((3, 2)), np.zeros(4), np.ones(4), out)
print(os.environ["NUMBA_CACHE_DIR"])
"""
"""A run that compiles (or loads) one small cached kernel of feedtune's and prints the cache folder it used."""


def _child(cache_home: Path, *, umask: int | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(cache_home)
    code = CHILD if umask is None else f"import os; os.umask({umask:#o})\n" + CHILD
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)


class _Plant:
    """A pickle that creates ``marker`` when it is loaded (what a planted index file of the attacker's does)."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_private_folder_is_made_0700_whatever_the_umask(tmp_path):
    old = os.umask(0o002)
    try:
        path = tmp_path / "cache" / "feedtune" / "numba" / "abc"
        assert kc.private_folder(str(path), 3) is None
    finally:
        os.umask(old)
    for level in (path, path.parent, path.parent.parent):
        assert stat.S_IMODE(level.stat().st_mode) == 0o700


@pytest.mark.parametrize("mode, words", [(0o775, "writable by its group"), (0o757, "writable by others"),
                                         (0o777, "writable by its group")])
def test_a_folder_others_can_write_into_is_not_trusted(tmp_path, mode, words):
    d = tmp_path / "numba"
    d.mkdir()
    d.chmod(mode)
    assert words in kc.folder_problem(str(d))
    assert kc.folder_problem(str(tmp_path)) is None or "writable" in kc.folder_problem(str(tmp_path))


def test_a_symlinked_or_foreign_folder_is_not_trusted(tmp_path):
    (tmp_path / "real").mkdir(mode=0o700)
    (tmp_path / "link").symlink_to(tmp_path / "real")
    assert kc.folder_problem(str(tmp_path / "link")) == "is a symbolic link"
    if os.getuid() != 0:
        pytest.skip("changing a folder's owner needs root")
    os.chown(tmp_path / "real", 4242, 4242)
    assert "owned by user id 4242" in kc.folder_problem(str(tmp_path / "real"))


def test_a_numba_cache_dir_the_user_names_is_made_private_or_refused(monkeypatch, tmp_path):
    """Before: a NUMBA_CACHE_DIR that did not exist yet was left to numba, which made it with the umask's mode."""
    old = os.umask(0o002)
    try:
        monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
        assert kc.prepare() == str(tmp_path / "mine")
        assert stat.S_IMODE((tmp_path / "mine").stat().st_mode) == 0o700
        (tmp_path / "shared").mkdir(mode=0o700)
        (tmp_path / "shared").chmod(0o775)
        monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "shared"))
        with pytest.warns(kc.KernelCacheWarning, match=r"shared is writable by its group \(mode 775\) "
                                                        r"\(NUMBA_CACHE_DIR\)"):
            used = kc.prepare()
        assert used != str(tmp_path / "shared") and stat.S_IMODE(os.stat(used).st_mode) == 0o700
    finally:
        os.umask(old)


def test_a_relative_xdg_cache_home_is_ignored(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert kc.user_cache_base() == str(tmp_path / ".cache")
    assert kc.kernel_cache_dir().startswith(str(tmp_path / ".cache" / "feedtune" / "numba"))


def test_import_feedtune_leaves_numba_alone_until_it_is_needed():
    res = subprocess.run([sys.executable, "-c", "import sys, os, feedtune; print('numba' in sys.modules, "
                          "os.environ.get('NUMBA_CACHE_DIR'))"], capture_output=True, text=True,
                         env={k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}, check=True)
    assert res.stdout.split() == ["False", "None"]


@pytest.mark.slow
def test_a_planted_index_in_an_untrusted_cache_folder_is_not_loaded(tmp_path):
    """A good run finds where numba keeps the kernel's index; the same index name planted with a payload runs the
    payload when the folder is trusted (the control: the test can fail) and is not loaded when the folder is
    group-writable or someone else's: the run warns, compiles into a temporary folder and gives the same result."""
    good = _child(tmp_path / "good", umask=0o002)
    assert good.returncode == 0, good.stderr
    root = Path(good.stdout.split()[-1])
    assert root.is_relative_to(tmp_path / "good" / "feedtune" / "numba")
    for level in (root, root.parent, root.parent.parent):  # private although the umask was 002
        assert stat.S_IMODE(level.stat().st_mode) == 0o700, level
    (index,) = root.rglob("*kalman*.nbi")
    relative = index.relative_to(root)

    def plant(home: Path) -> Path:
        target = home / "feedtune" / "numba" / root.name / relative
        target.parent.mkdir(parents=True)
        for level in [target.parent, *target.parent.parents]:
            if level == home.parent:
                break
            level.chmod(0o700)
        marker = home / "PWNED"
        with open(target, "wb") as fh:
            pickle.dump(_Plant(marker), fh)
        return marker

    control = plant(tmp_path / "control")
    res = _child(tmp_path / "control")
    assert control.exists(), "the planted index of a trusted folder is loaded (the attack works there)"

    cases = {"group-writable": (tmp_path / "group", lambda d: d.chmod(0o770))}
    if os.getuid() == 0:
        cases["foreign"] = (tmp_path / "foreign", lambda d: os.chown(d, 4242, 4242))
    for name, (home, spoil) in cases.items():
        marker = plant(home)
        spoil(home / "feedtune" / "numba" / root.name)
        res = _child(home)
        assert res.returncode == 0, (name, res.stderr)
        assert not marker.exists(), f"{name}: the planted index was loaded"
        assert "KernelCacheWarning" in res.stderr and "no kernel is loaded from it" in res.stderr, res.stderr
        assert not Path(res.stdout.split()[-1]).is_relative_to(home)


def test_the_command_line_prints_the_warning_as_one_line(capsys):
    import warnings

    from feedtune.cli.main import _cli_warnings

    with _cli_warnings(), warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.warn("the kernel cache folder /x is writable by others: no kernel is loaded from it",
                      kc.KernelCacheWarning, stacklevel=1)
    err = capsys.readouterr().err
    assert err == "feedtune: warning: the kernel cache folder /x is writable by others: no kernel is loaded from it\n"
    assert feedtune.kernel_cache_dir is kc.kernel_cache_dir
