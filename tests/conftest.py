"""Shared test fixtures.

Real meshes live in ``../shared/data/meshes`` (see its SOURCES.md). Tests that
need them use the ``shared_mesh`` fixture and skip with a clear reason where
``../shared`` is absent (a user's clone).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_MESHES = Path(os.environ.get("POLISHPATH_SHARED", REPO.parent / "shared")) / "data" / "meshes"


def shared_mesh_path(name: str) -> Path:
    """Path of a shared mesh, or skip the test with the reason."""
    p = SHARED_MESHES / name
    if not p.exists():
        pytest.skip(f"shared mesh {name} not found at {SHARED_MESHES} (../shared is absent in a user's clone)")
    return p


@pytest.fixture
def shared_mesh():
    """``shared_mesh("lilium.obj") -> Path`` (skips when ../shared is absent)."""
    return shared_mesh_path
