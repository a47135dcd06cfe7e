"""Runs the property/fuzz suite (fuzz_properties.py) in a child pytest: a crash or abort in
the C++ engine fails this test with the child's output (faulthandler names the property and
the line) instead of killing the session; the time limit turns a hang into a failure too.
MPMPP_FUZZ_EXAMPLES sets the examples per property (CI default 40)."""
import os
import subprocess
import sys
from child_process import child_env

HERE = os.path.dirname(os.path.abspath(__file__))


def test_fuzz_properties_in_child_process():
    env = child_env(HERE)
    examples = int(os.environ.get("MPMPP_FUZZ_EXAMPLES", "40"))
    proc = subprocess.run(
        [sys.executable, "-X", "faulthandler", "-m", "pytest", "-q", "-p", "no:cacheprovider",
         os.path.join(HERE, "fuzz_properties.py")],
        capture_output=True, text=True, env=env, cwd=HERE, timeout=max(300, 5 * examples))
    assert proc.returncode == 0, (f"fuzz suite failed (exit {proc.returncode}):\n"
                                  f"{proc.stdout[-6000:]}\n{proc.stderr[-3000:]}")
