"""Where the shared example cases are: ../shared beside the repository (as in CI),
or MPMPP_SHARED_DIR for a checkout elsewhere (e.g. a git worktree)."""
import os
import pathlib

REPO = pathlib.Path(__file__).resolve().parents[2]
SHARED = pathlib.Path(os.environ.get("MPMPP_SHARED_DIR", REPO.parent / "shared"))
CASES = SHARED / "cases"
