"""The optional shared QP problem sets (Maros-Meszaros, qpbenchmark MPC sequences): not part of
the repository. CI lays them out in ../shared beside the checkout; MPMPP_SHARED_DIR points
elsewhere. Tests that need them skip, saying why, when they are absent."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SHARED_DIR = Path(os.environ.get("MPMPP_SHARED_DIR", REPO.parent / "shared"))
QP_DIR = SHARED_DIR / "qp"


def require_qp_set(name: str) -> Path:
    """The folder of the QP problem set ``name``; skips the test if it is not there."""
    folder = QP_DIR / name
    if not folder.is_dir():
        pytest.skip(f"optional QP problem set {name!r} not found at {folder} "
                    f"(put the shared data beside the checkout or set MPMPP_SHARED_DIR)")
    return folder
