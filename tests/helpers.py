"""What several test files share: where the real data is, and the command line run in-process."""

from __future__ import annotations

import contextlib
import io
import os
import signal
from pathlib import Path


def realdata_dir() -> Path:
    """The real recorded data: $FOGBENCH_REALDATA, else ../shared/realdata beside the clone.
    Never copied into the repository; tests that need it skip with a reason when it is absent."""
    env = os.environ.get("FOGBENCH_REALDATA")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "shared" / "realdata"


def run_cli(*args, cwd=None) -> tuple[int, str, str]:
    """``fogbench ARGS`` in this process, as the console command runs it: (exit code, stdout,
    stderr). The SIGTERM handler the command installs is put back afterwards."""
    from fogbench.cli import main

    out, err = io.StringIO(), io.StringIO()
    handler = signal.getsignal(signal.SIGTERM)
    try:
        with contextlib.chdir(cwd or os.getcwd()), contextlib.redirect_stdout(out), \
                contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as exc:  # argparse
                code = exc.code
    finally:
        signal.signal(signal.SIGTERM, handler)
    return code, out.getvalue(), err.getvalue()
