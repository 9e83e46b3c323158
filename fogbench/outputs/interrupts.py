"""Ctrl-C and SIGTERM: one line and 130 / 143, whenever they arrive, and nothing put in place
after them.

This module imports only the standard library's ``signal`` and ``sys``, so that the command line
installs its handlers before anything heavy is imported (a signal during the imports then ends
like any other). The handlers record each signal and raise ``KeyboardInterrupt`` / ``Terminated``;
an exception raised where Python cannot propagate it (a ``__del__``, a weakref or a matplotlib
callback) is only printed by Python as "Exception ignored ...": :func:`install` replaces that print
for these two exceptions and for whatever fails in a ``__del__`` after a signal (the record stays), and :func:`check` raises the signal again before an
output is put in place.
"""

from __future__ import annotations

import signal
import sys

__all__ = ["Terminated", "install", "received", "check", "block", "unblock", "pending",
           "consume"]


class Terminated(BaseException):
    """SIGTERM arrived: unwind (so temporary directories are removed), then exit 143."""


_RECEIVED: list[int] = []
_default_unraisable = sys.unraisablehook


def _term(signum, frame):
    _RECEIVED.append(signum)
    raise Terminated()


def _int(signum, frame):
    _RECEIVED.append(signum)
    raise KeyboardInterrupt()


def _unraisable(unraisable) -> None:
    """Python's report of an exception it cannot raise (in a ``__del__``, a weakref callback):
    silent for the signals' own exceptions (recorded, raised again by :func:`check`), and for
    any after a signal: an object whose ``__init__`` the signal cut short fails in its
    ``__del__`` (pyparsing's ``Forward``: "no attribute 'expr'"), the signal's consequence."""
    if isinstance(unraisable.exc_value, (Terminated, KeyboardInterrupt)) or _RECEIVED:
        return
    _default_unraisable(unraisable)


def install() -> None:
    """Turn SIGTERM into :class:`Terminated` and SIGINT into ``KeyboardInterrupt``, record each
    signal (:func:`received`), and keep Python from printing them where it cannot raise them."""
    _RECEIVED.clear()
    signal.signal(signal.SIGTERM, _term)
    signal.signal(signal.SIGINT, _int)
    sys.unraisablehook = _unraisable


def received() -> int | None:
    """The last signal received since :func:`install`, or None."""
    return _RECEIVED[-1] if _RECEIVED else None


def check() -> None:
    """Raise the exception of a signal that arrived (even one whose exception was swallowed):
    called before an output is put in place, so nothing lands after Ctrl-C or SIGTERM."""
    sig = received()
    if sig == signal.SIGTERM:
        raise Terminated()
    if sig == signal.SIGINT:
        raise KeyboardInterrupt()


SIGNALS = (signal.SIGINT, signal.SIGTERM)


def block() -> set:
    """Block SIGINT and SIGTERM in this thread (they stay pending); returns the old mask."""
    return signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)


def unblock(old) -> None:
    signal.pthread_sigmask(signal.SIG_SETMASK, old)


def consume() -> None:
    """Take the pending (blocked) SIGINT and SIGTERM, so that unblocking does not deliver
    them again."""
    while signal.sigtimedwait(SIGNALS, 0) is not None:
        pass


def pending() -> int | None:
    """A blocked SIGTERM or SIGINT waiting to be delivered, or None."""
    waiting = signal.sigpending()
    for sig in (signal.SIGTERM, signal.SIGINT):
        if sig in waiting:
            return sig
    return None
