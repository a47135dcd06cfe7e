"""Environment for child Python processes started by tests: a child imports exactly the
mpmpp the test process imported (the installed wheel in CI and `make test`, python/ with
an in-place build during development), never the bare source folder without _core."""
import os
import sys


def child_env(*extra_paths: str, **variables: str) -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([*extra_paths, *sys.path]), **variables)
