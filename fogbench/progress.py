"""A progress bar on stderr: replicates (or percent) done / total, rate and time left (tqdm)."""

from __future__ import annotations

import sys
import threading

from tqdm import tqdm

__all__ = ["Progress"]


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
