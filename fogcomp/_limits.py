"""Limits on a method's code (its fit, its compensation, a conformance rule): a time limit,
and no way out of the process (``os._exit``) while it runs."""

from __future__ import annotations

import contextlib
import os
import signal
import threading

__all__ = ["MethodTimeout", "MethodExit", "time_limit", "no_exit", "sigint_seen"]


class MethodTimeout(BaseException):
    """Code did not finish within its time limit. A BaseException, so that a method's own
    ``except Exception`` cannot swallow it."""


@contextlib.contextmanager
def time_limit(seconds: float | None, what: str, verb: str = "return", note: str = ""):
    """Stop the code inside after ``seconds``: a SIGALRM timer raises
    ``MethodTimeout("<what> did not <verb> within <seconds> s<note>")`` where the code is. Only
    in a process's main thread (a worker process, or a serial run); elsewhere (a Dask worker's
    thread) no limit is set. Code stuck in C that never returns to the interpreter is stopped
    when it does."""
    if (seconds is None or not hasattr(signal, "setitimer")
            or threading.current_thread() is not threading.main_thread()):
        yield
        return

    def expire(signum, frame):
        raise MethodTimeout(f"{what} did not {verb} within {seconds:g} s{note}")

    old = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
        signal.setitimer(signal.ITIMER_REAL, 0.0)   # done: a late alarm cannot fail it now
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


class MethodExit(BaseException):
    """A method's code called ``os._exit`` (which would end the process, and the run, with no
    word). A BaseException, so that a method's own ``except Exception`` cannot swallow it."""


@contextlib.contextmanager
def no_exit(what: str):
    """While the code inside runs, ``os._exit`` raises :class:`MethodExit` naming ``what``
    instead of ending the process: a method's fit that calls it fails, the run goes on. A
    process the code started (a fork, a multiprocessing worker) keeps the real ``os._exit``."""
    real, pid = os._exit, os.getpid()

    def exit_(code):
        if os.getpid() != pid:
            real(code)
        raise MethodExit(f"{what} called os._exit({code}), which would have ended the process")

    os._exit = exit_
    try:
        yield
    finally:
        os._exit = real


@contextlib.contextmanager
def sigint_seen():
    """A list that holds True once a real SIGINT (Ctrl-C) arrived inside the block, the
    handler that was there still run; a method raising KeyboardInterrupt itself leaves it
    empty. Only in the main thread (elsewhere no signal arrives), and only where SIGINT is not
    ignored (a worker process of a pool ignores it: its parent handles Ctrl-C)."""
    seen: list = []
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        yield seen
        return
    before = signal.getsignal(signal.SIGINT)

    def handler(signum, frame):
        seen.append(True)
        if callable(before):
            before(signum, frame)
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, handler)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, before)
