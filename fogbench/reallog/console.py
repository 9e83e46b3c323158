"""What the log commands say on stderr: one ``fogbench: ...`` line per note or warning, and a
progress bar for long work."""

from __future__ import annotations

import functools
import sys
import warnings

#: Rows from which writing or compensating shows a progress bar on stderr (when it is a terminal).
PROGRESS_MIN_ROWS = 200_000



def _note(text: str) -> None:
    """One ``fogbench: ...`` line on stderr (what the command is working on)."""
    print(f"fogbench: {text}", file=sys.stderr)


def _warning(text) -> None:
    """One ``fogbench: warning: ...`` line on stderr, whatever newlines ``text`` holds."""
    print(f"fogbench: warning: {' '.join(str(text).split())}", file=sys.stderr)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    _warning(message)


def _warnings_as_lines(func):
    """Run a command with every Python warning printed as one ``fogbench: warning:`` line on
    stderr (no category, source file or source line)."""
    @functools.wraps(func)
    def command(args):
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.showwarning = _show_warning
            return func(args)
    return command


def _is_identifiability(w) -> bool:
    return w.category.__name__ == "IdentifiabilityWarning"



def _progress(total: int, desc: str, unit: str, show: bool):
    """A tqdm bar on stderr, shown only for long work (``show``) on a terminal."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, unit_scale=unit == "row", file=sys.stderr,
                disable=None if show else True, mininterval=0.5, leave=False)
