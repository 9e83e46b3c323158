"""Output directories that never destroy a user's files.

Every directory the bench writes (a run directory, a simulation directory) is built in a hidden
temporary sibling ``.<name>.<random>.part`` and renamed into place when complete. Its first file
is a marker, ``.fogbench.json``, naming what wrote it (kind, scenario, version). An existing
path is replaced only when it is an empty directory or a directory carrying the marker of the
same kind; anything else is refused, with the path and what to do, before any work starts.
Stale temporary directories of our own (left by a kill) are recognised by the marker and removed
at the next write into the same parent.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import tempfile
from pathlib import Path

__all__ = ["MARKER", "OutDirError", "Terminated", "check_out_dir", "is_ours", "new_part_dir",
           "discard_part", "replace_dir", "clean_stale", "install_signal_handlers", "check_signals",
           "signal_received"]

MARKER = ".fogbench.json"
KINDS = ("run", "simulation")


class OutDirError(ValueError):
    """An output path the bench must not or cannot write; the message names it."""


class Terminated(BaseException):
    """SIGTERM arrived: unwind (so temporary directories are removed), then exit 143."""


#: The signals (SIGINT, SIGTERM) received since :func:`install_signal_handlers`. A signal's
#: exception can be swallowed where Python ignores exceptions (a ``__del__``, a weakref or a
#: matplotlib callback): the record lets :func:`check_signals` raise it again before anything is
#: put in place, and the command line never exit 0 after a signal.
_RECEIVED: list[int] = []


def install_signal_handlers() -> None:
    """Turn SIGTERM into :class:`Terminated` and SIGINT into ``KeyboardInterrupt``, so
    ``finally`` blocks clean up, and record each signal (:func:`signal_received`)."""
    _RECEIVED.clear()

    def _term(signum, frame):
        _RECEIVED.append(signum)
        raise Terminated()

    def _int(signum, frame):
        _RECEIVED.append(signum)
        raise KeyboardInterrupt()

    signal.signal(signal.SIGTERM, _term)
    signal.signal(signal.SIGINT, _int)


def signal_received() -> int | None:
    """The last signal received since the handlers were installed, or None."""
    return _RECEIVED[-1] if _RECEIVED else None


def check_signals() -> None:
    """Raise the exception of a signal that arrived (even one whose exception was swallowed):
    called before an output is put in place, so nothing lands after Ctrl-C or SIGTERM."""
    sig = signal_received()
    if sig == signal.SIGTERM:
        raise Terminated()
    if sig == signal.SIGINT:
        raise KeyboardInterrupt()


def _marker(path: Path, kinds=KINDS) -> dict | None:
    """The marker of a folder fogbench wrote (one of ``kinds``), or None."""
    try:
        doc = json.loads((Path(path) / MARKER).read_text())
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) and doc.get("kind") in kinds else None


def is_ours(path: Path, kind: str) -> bool:
    """True when ``path`` is a directory that a fogbench command of ``kind`` wrote."""
    m = _marker(path) if path.is_dir() and not path.is_symlink() else None
    return m is not None and m.get("kind") == kind


def check_out_dir(out: str | os.PathLike, kind: str, flag: str = "--out") -> Path:
    """Validate an output directory before any work; return it as an absolute path.

    Accepted: a path that does not exist (its parent must be a writable directory, or creatable),
    an empty directory, or a directory this bench wrote for ``kind`` (it will be replaced whole).
    Refused with :class:`OutDirError`: an existing file, a symlink, a directory holding anything
    else (the user's files), the root or a path without a name.
    """
    given = str(out)
    if given.strip() == "":
        raise OutDirError(f"{flag}: empty path; give a directory to write the {kind} into")
    p = Path(os.path.abspath(os.path.expanduser(given)))
    cwd = Path(os.path.abspath(os.getcwd()))
    if Path(given).name in (".", "..") or p == cwd or p in cwd.parents:
        raise OutDirError(f"{flag} {given!r} ({p}) is the current folder or holds it; a run "
                          "replaces its output folder whole, so it must not be where you "
                          f"work. Give a new directory, e.g. {flag} {kind}s/my_{kind}")
    if p.name in ("", ".", "..") or p == p.parent:
        raise OutDirError(f"{flag} {given!r}: not a directory the bench can create or replace; "
                          f"give a new directory, e.g. {flag} {kind}s/my_{kind}")
    if p.is_symlink():
        raise OutDirError(f"{flag} {given!r} ({p}) is a symbolic link; it was left untouched. "
                          "Give a new directory path")
    if p.exists():
        if not p.is_dir():
            raise OutDirError(f"{flag} {given!r} ({p}) is an existing file; it was left "
                              "untouched. Give a new directory path")
        try:
            entries = [e for e in os.listdir(p)]
        except OSError as exc:
            raise OutDirError(f"{flag} {given!r} ({p}): cannot read it ({exc.strerror})") from None
        if entries and not is_ours(p, kind):
            what = (f"a fogbench {_marker(p)['kind']} directory, not a {kind} directory"
                    if _marker(p) else f"not a fogbench {kind} directory (it has no {MARKER})")
            raise OutDirError(
                f"{flag} {given!r} ({p}) already holds {len(entries)} file(s) and is {what}; "
                "nothing was written or removed. Give a new or empty directory, or remove it "
                "yourself if you mean to replace it")
    parent = p.parent
    anc = parent
    while not anc.exists():
        anc = anc.parent
    if not anc.is_dir():
        raise OutDirError(f"{flag} {given!r}: {anc} is a file, not a directory")
    try:  # the only sure test of writability: create (and remove) a directory there
        os.rmdir(tempfile.mkdtemp(dir=anc, prefix=".fogbench-probe."))
    except OSError as exc:
        raise OutDirError(f"{flag} {given!r}: cannot create a directory in {anc} "
                          f"({exc.strerror})") from None
    return p


#: Folders made to hold a temporary directory (its missing ancestors), removed with it by
#: :func:`discard_part` when they are left empty: a failed command leaves no empty folder.
_MADE: dict[Path, list[Path]] = {}


def new_part_dir(out: Path, kind: str, info: dict) -> Path:
    """Create the hidden temporary sibling of ``out`` and write the marker into it first."""
    made, q = [], out.parent
    while not q.exists() and q != q.parent:
        made.append(q)
        q = q.parent
    out.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(out)
    tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".part"))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes it private; the result is an ordinary folder
    from .io import atomic_write_text

    _MADE[tmp] = made
    try:
        atomic_write_text(tmp / MARKER, json.dumps({"kind": kind, **info, "pid": os.getpid()},
                                                    indent=2))
    except BaseException:
        discard_part(tmp)
        raise
    return tmp


def discard_part(tmp: Path) -> None:
    """Remove a temporary directory of :func:`new_part_dir` and the folders made for it, if
    nothing else was put in them."""
    shutil.rmtree(tmp, ignore_errors=True)
    for d in _MADE.pop(tmp, []):  # deepest first
        try:
            d.rmdir()
        except OSError:
            break


def replace_dir(tmp: Path, out: Path, kind: str) -> None:
    """Move the complete ``tmp`` into place at ``out``, replacing an empty directory or one of
    ours of the same kind; anything else that appeared meanwhile is refused, ``tmp`` removed."""
    try:
        check_signals()
        check_out_dir(out, kind)
    except BaseException:
        discard_part(tmp)
        raise
    _MADE.pop(tmp, None)
    if out.exists():
        old = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".old"))
        os.rmdir(old)
        os.replace(out, old)
        try:
            os.replace(tmp, out)
        except BaseException:
            os.replace(old, out)  # put the previous directory back: never neither
            raise
        shutil.rmtree(old)
    else:
        os.replace(tmp, out)


def clean_stale(out: Path) -> list[Path]:
    """Remove our own leftovers beside ``out`` (``.<name>.*.part`` / ``.old`` with the marker)."""
    removed = []
    if not out.parent.is_dir():
        return removed
    for q in out.parent.glob(f".{out.name}.*"):
        m = _marker(q) if q.suffix in (".part", ".old") and q.is_dir() and not q.is_symlink() \
            else None
        if m is not None and not _alive(m.get("pid")):
            shutil.rmtree(q, ignore_errors=True)
            removed.append(q)
    return removed


def _alive(pid) -> bool:
    """Whether the process that wrote a temporary directory is still running (on this host)."""
    if not isinstance(pid, int) or pid <= 0 or pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
