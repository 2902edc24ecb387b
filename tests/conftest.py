from __future__ import annotations

import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SHARED_BVH = REPO.parent / "shared" / "data" / "bvh"
sys.path.insert(0, str(Path(__file__).resolve().parent))


def shared_files(sub: str = "*") -> list[Path]:
    if not SHARED_BVH.is_dir():
        return []
    return sorted(SHARED_BVH.glob(f"{sub}/*.bvh"))


def need_shared() -> None:
    if not SHARED_BVH.is_dir():
        pytest.skip(f"shared BVH data not found at {SHARED_BVH} (it lives beside the repository)")


@pytest.fixture
def shared_dir() -> Path:
    need_shared()
    return SHARED_BVH


def shared_params(sub: str = "*"):
    files = shared_files(sub)
    if not files:
        return [pytest.param(None, marks=pytest.mark.skip(
            reason=f"shared BVH data not found at {SHARED_BVH}"))]
    return [pytest.param(f, id=f.name) for f in files]
