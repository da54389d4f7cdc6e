import os
from pathlib import Path

import pytest

#: The repository root: designs and example cells are read from there.
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _at_root(monkeypatch):
    """Designs name their data relative to the repository root."""
    monkeypatch.chdir(ROOT)
    yield


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def workers() -> int:
    return max(1, min(2, os.cpu_count() or 1))
