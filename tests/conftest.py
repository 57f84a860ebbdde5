"""Shared test fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _shared_dir() -> Path:
    env = os.environ.get("FEEDTUNE_SHARED")
    return Path(env) if env else REPO.parent / "shared"


@pytest.fixture(scope="session")
def real_data_dir() -> Path:
    """``../shared/data/real`` beside the repository; tests that need it skip when it is absent."""
    d = _shared_dir() / "data" / "real"
    if not d.is_dir():
        pytest.skip(f"real measurement data not found at {d} (set FEEDTUNE_SHARED to the shared/ folder)")
    return d


@pytest.fixture(scope="session")
def examples_dir() -> Path:
    """The repository's bundled example files."""
    return REPO / "examples"
