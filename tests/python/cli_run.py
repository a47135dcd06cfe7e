"""Running the ``mpmpp`` command line in-process for the tests: (exit code, stdout, stderr)."""
import contextlib
import io

from mpmpp import cli


def run_cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()
