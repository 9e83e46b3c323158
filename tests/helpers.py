"""What several test files share: where the real data is, a small scenario, and the command
line run in-process."""

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


def need_realdata(*paths: Path) -> None:
    """Skip the calling test, naming what is missing, unless every path exists."""
    import pytest

    missing = [p for p in paths if not Path(p).exists()]
    if missing:
        pytest.skip(f"real data not found at {missing[0]} (set FOGBENCH_REALDATA to the "
                    "realdata folder to run this test)")


def run_cli(*args, cwd=None) -> tuple[int, str, str]:
    """``fogbench ARGS`` in this process, as the console command runs it: (exit code, stdout,
    stderr). The SIGTERM and SIGINT handlers the command installs are put back afterwards."""
    from fogbench.cli import main

    out, err = io.StringIO(), io.StringIO()
    handlers = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        with contextlib.chdir(cwd or os.getcwd()), contextlib.redirect_stdout(out), \
                contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as exc:  # argparse
                code = exc.code
    finally:
        for s, h in handlers.items():
            signal.signal(s, h)
    return code, out.getvalue(), err.getvalue()


#: A small valid scenario (tactical FOG, two 30 s runs at 10 Hz, one wavelet method), the
#: seed that test_safety edits and the fuzzer mutates.
SMALL_SCENARIO = """
[scenario]
name = "tiny"
sample_rate_hz = 10.0

[fog]
preset = "tactical"

[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "hold"
duration_s = 30.0

[[runs]]
name = "b"
seed = 2
[[runs.motion]]
type = "rate"
rate_dps = 10.0
duration_s = 30.0

[[protocols]]
name = "p"
fit = ["a"]
score = ["b"]

[[methods]]
name = "wavelet_soft"
"""


def run_tasks(executor, fn, items, *, progress=None):
    """Submit ``fn(item)`` for every item of ``items`` on a ``concurrent.futures`` executor;
    yield ``(index, future)`` as each completes (the order depends on the engine), advancing
    ``progress`` (a :class:`fogbench.console.Progress`) once per task with failures counted; on
    leaving early every task not yet started is cancelled. The determinism tests' driver."""
    import concurrent.futures as cf

    futures = {executor.submit(fn, item): i for i, item in enumerate(items)}
    try:
        for fut in cf.as_completed(futures):
            if progress is not None:
                progress.advance(failed=fut.cancelled() or fut.exception() is not None)
            yield futures[fut], fut
    finally:
        for fut in futures:
            fut.cancel()


def read_run(path):
    """The arrays of a ``<run>.npz`` written by ``fogbench simulate`` (no pickle)."""
    import numpy as np

    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def run_parsed(argv):
    """A command as the main CLI runs it, in this process: parse, call its function, a
    ValueError as exit status 2 with its message; returns (status, message or None)."""
    from fogbench.cli import build_parser

    args = build_parser().parse_args([str(a) for a in argv])
    try:
        return args.func(args), None
    except ValueError as exc:
        return 2, str(exc)
