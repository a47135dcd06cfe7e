"""`python -m mpmpp ...`: the `mpmpp` command line, for an environment whose scripts folder is
not on PATH (a venv not activated, a plant PC's locked-down Python)."""
import sys

from .cli import main

sys.exit(main())
