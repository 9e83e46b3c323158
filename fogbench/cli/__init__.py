"""The ``fogbench`` command line: one module per command, each only parsing its flags and
calling the function that does the work with plain arguments.

Commands: ``simulate``, ``run``, ``check``, ``suite``, ``view``, ``bench``, ``check-method``
(the bench's scenarios and methods); ``allan``, ``calibrate``, ``compensate``, ``attitude`` (a user's
own logs); ``device show|schema|fit|check`` (device files); ``compare`` (every method across
scenarios). Bad input ends with one ``fogbench: error: ...`` line on stderr and status 2; Ctrl-C
and SIGTERM with one line and 130 / 143, leaving no half-written file.
"""

from __future__ import annotations

# The signals' handlers before any other import: Ctrl-C or SIGTERM during the imports ends with
# the one line too (fogbench.outputs.interrupts imports only signal and sys).
from fogbench.outputs import interrupts as _signals

if __name__ in ("__main__", "fogbench.cli"):
    _signals.install()

import argparse
import os
import sys

# One BLAS thread per process: the bench parallelises over processes (replicates, scenarios);
# threaded BLAS on top of that made the network fits 3-6x slower on a 2-core machine.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

__all__ = ["main", "build_parser"]

#: The command modules, in the order ``fogbench --help`` lists them.
COMMANDS = ("simulate", "run", "check", "suite", "view", "bench", "check_method", "allan",
            "calibrate", "compensate", "attitude", "device", "compare")


def build_parser() -> argparse.ArgumentParser:
    """The ``fogbench`` parser: every command module's ``add_parser``."""
    import importlib

    p = argparse.ArgumentParser(prog="fogbench", description="FOG error-compensation testbench")
    sub = p.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        importlib.import_module(f"fogbench.cli.{name}").add_parser(sub)
    return p


_INTERRUPTED = "fogbench: interrupted; files already complete are kept, none is half-written"
_TERMINATED = ("fogbench: terminated (SIGTERM); files already complete are kept, none is "
               "half-written")


def _error_line(exc: BaseException, text: str) -> None:
    """The one error line, then the notes an exception carries (e.g. where resumable work was
    kept), so that the last line says what is left."""
    print(f"fogbench: error: {text}", file=sys.stderr)
    for note in getattr(exc, "__notes__", ()):
        print(f"fogbench: {note}", file=sys.stderr)


def _os_error_text(exc: OSError) -> str:
    where = exc.filename if getattr(exc, "filename", None) else None
    text = exc.strerror or str(exc) or type(exc).__name__
    return f"{text} ({where})" if where else text


def _dispatch(argv) -> int | None:
    """Parse and run the command; bad input as its one error line and status 2; None when a
    signal ended it."""
    try:
        # imports inside: a signal during them ends with the one line too
        from fogbench.cli._common import method_environment
        from fogbench.scenario.environment import method_environment as inherited
        from fogbench.scenario.environment import method_environment_set

        args = build_parser().parse_args(argv)
        # read by load_scenario/load_plan here (and sent with each replicate to its worker)
        with method_environment_set({**inherited(), **method_environment(args)}):
            from fogbench.scenario.environment import reference_override

            reference_override()     # a FOGBENCH_REFERENCE of the shell checked before any work
            return args.func(args)
    except ValueError as exc:  # ScenarioError, LogError, EngineError, ...: bad input
        _error_line(exc, str(exc))
        return 2
    except FileNotFoundError as exc:
        _error_line(exc, _os_error_text(exc))
        return 2
    except RecursionError:  # a JSON or TOML input nested thousands of levels deep
        print("fogbench: error: an input file is nested too deeply to be read (thousands of "
              "levels of brackets); it is not a file fogbench writes or reads", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `fogbench allan ... | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:  # a full disk, a permission: one line naming the file, not a traceback
        _error_line(exc, _os_error_text(exc))
        return 1
    except (KeyboardInterrupt, _signals.Terminated):
        return None
    except Exception:
        # a signal that surfaced as another exception (mujoco's import turns an interrupt
        # during its initialisation into ImportError): the signal's ending, not a traceback
        if not _signals.received():
            raise
        return None


def main(argv=None) -> int:
    """Run ``fogbench`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    import signal as _signal

    _signals.install()
    code = _dispatch(argv)
    if code == 141:
        return 141
    # The work is over: a signal from now on stays pending (and is answered here, not by a
    # silent death while the interpreter shuts down); one that arrived on the way, even one
    # whose exception was swallowed in a callback, still ends the command.
    old_mask = _signals.block()
    sig = _signals.received() or _signals.pending()
    _signals.consume()
    if argv is not None:  # called in a process that goes on (tests, scripts): as it was
        _signals.unblock(old_mask)
    if sig is not None or code is None:
        term = sig == _signal.SIGTERM
        print(_TERMINATED if term else _INTERRUPTED, file=sys.stderr)
        return 143 if term else 130
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
