"""What fogbench says on stderr: progress bars (replicates done, rows written), one
``fogbench: ...`` line per note or warning, and Python warnings printed as such lines."""

from __future__ import annotations

import functools
import sys
import threading
import warnings

from tqdm import tqdm

__all__ = ["Progress", "note", "warn", "warnings_as_lines", "progress_bar",
           "is_identifiability", "PROGRESS_MIN_ROWS"]


class Progress:
    """Replicates done / total, their rate and the time left, on stderr; silent when ``quiet``.

    Parameters
    ----------
    total : int
        Number of tasks (replicates) expected, >= 0.
    desc : str
        Label printed before the bar, e.g. the scenario name.
    quiet : bool
        Print nothing at all.
    unit : str
        What one task is called in the rate ("replicate/s").
    file : text stream, optional
        Where to write; default ``sys.stderr`` (never stdout, which carries results).

    Examples
    --------
    >>> with Progress(20, "paper000_wnn") as bar:
    ...     for fut in futures:
    ...         bar.advance(failed=fut.exception() is not None)
    """

    def __init__(self, total: int, desc: str = "", *, quiet: bool = False,
                 unit: str = "replicate", file=None):
        if isinstance(total, bool) or not isinstance(total, int) or total < 0:
            raise ValueError(f"total: expected a non-negative integer, got {total!r}")
        self.total = total
        self.done = 0
        self.failed = 0
        self._lock = threading.Lock()   # advanced from a pool's callback thread and this one
        # percent of one piece of work: no count and no rate, only the bar and the times
        fmt = "{l_bar}{bar}| [{elapsed}<{remaining}]" if unit == "%" else None
        self._bar = tqdm(total=total, desc=desc or None, unit=unit,
                         file=sys.stderr if file is None else file, disable=bool(quiet),
                         dynamic_ncols=True, mininterval=0.5, smoothing=0.1, leave=True,
                         bar_format=fmt)

    def advance(self, n: int = 1, failed: int | bool = 0) -> None:
        """Count ``n`` more tasks done, ``failed`` of them failed (shown beside the bar)."""
        with self._lock:
            self.done += n
            if failed:
                self.failed += int(failed)
                self._bar.set_postfix_str(f"{self.failed} failed", refresh=False)
            self._bar.update(n)

    def to_fraction(self, fraction: float) -> None:
        """Move the bar to ``fraction`` (0..1) of ``total``, for work reported as a fraction
        (the rig's rollout: ``simulate_run(..., progress=bar.to_fraction)``)."""
        target = min(self.total, max(self.done, int(round(float(fraction) * self.total))))
        if target > self.done:
            self.advance(target - self.done)

    def close(self) -> None:
        self._bar.close()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


#: Rows from which writing or compensating shows a progress bar on stderr (when it is a terminal).
PROGRESS_MIN_ROWS = 200_000


def note(text: str) -> None:
    """One ``fogbench: ...`` line on stderr (what the command is working on)."""
    print(f"fogbench: {text}", file=sys.stderr)


def warn(text) -> None:
    """One ``fogbench: warning: ...`` line on stderr, whatever newlines ``text`` holds."""
    print(f"fogbench: warning: {' '.join(str(text).split())}", file=sys.stderr)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    warn(message)


def warnings_as_lines(func):
    """Run a command with every Python warning printed as one ``fogbench: warning:`` line on
    stderr (no category, source file or source line)."""
    @functools.wraps(func)
    def command(args):
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.showwarning = _show_warning
            return func(args)
    return command


def is_identifiability(w) -> bool:
    return w.category.__name__ == "IdentifiabilityWarning"


def progress_bar(total: int, desc: str, unit: str, show: bool):
    """A tqdm bar on stderr, shown only for long work (``show``) on a terminal."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, unit_scale=unit == "row", file=sys.stderr,
                disable=None if show else True, mininterval=0.5, leave=False)
