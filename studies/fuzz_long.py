"""The long fuzz run: every property of tests/python/fuzz_properties.py with many examples
(default 2000 each; `python studies/fuzz_long.py 10000` for more), randomised (not the CI's
derandomised examples). Prints hypothesis statistics; exit code 0 when nothing failed."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TESTS = os.path.join(ROOT, "tests", "python")

if __name__ == "__main__":
    examples = sys.argv[1] if len(sys.argv) > 1 else "2000"
    env = dict(os.environ, MPMPP_FUZZ_EXAMPLES=examples, PYTHONPATH=os.pathsep.join(
        [os.path.join(ROOT, "python"), TESTS, os.environ.get("PYTHONPATH", "")]))
    raise SystemExit(subprocess.call(
        [sys.executable, "-X", "faulthandler", "-m", "pytest", "-q", "-p", "no:cacheprovider",
         "--hypothesis-show-statistics", os.path.join(TESTS, "fuzz_properties.py")], env=env, cwd=TESTS))
