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
import tempfile
from pathlib import Path

__all__ = ["MARKER", "OutDirError", "Terminated", "check_out_dir", "is_ours", "new_part_dir",
           "discard_part", "as_final", "replace_dir", "clean_stale", "install_signal_handlers",
           "check_signals", "signal_received", "Claim"]

MARKER = ".fogbench.json"
KINDS = ("run", "simulation")


class OutDirError(ValueError):
    """An output path the bench must not or cannot write; the message names it."""


# The signals' handling lives in fogbench.outputs.interrupts (imported first by the command line); the
# names stay importable from here.
from fogbench.outputs.interrupts import Terminated, check as check_signals, install as install_signal_handlers  # noqa: E402
from fogbench.outputs.interrupts import received as signal_received  # noqa: E402,F401


def _marker(path: Path, kinds=KINDS) -> dict | None:
    """The marker of a folder fogbench wrote (one of ``kinds``), or None."""
    try:
        doc = json.loads((Path(path) / MARKER).read_text())
    except (OSError, ValueError, RecursionError):
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
    from fogbench.outputs.files import atomic_write_text

    _MADE[tmp] = made
    try:
        atomic_write_text(tmp / MARKER, json.dumps({"kind": kind, **info, "pid": os.getpid()},
                                                    indent=2))
    except OSError as exc:
        discard_part(tmp)
        raise as_final(exc, tmp, out) from None
    except BaseException:
        discard_part(tmp)
        raise
    return tmp


def as_final(exc: OSError, tmp: Path, out: Path) -> OSError:
    """``exc`` naming the file as the user will look for it: a path inside the temporary
    directory ``tmp`` becomes the same path inside ``out``."""
    name = str(getattr(exc, "filename", "") or "")
    if name.startswith(str(tmp)):
        rest = name[len(str(tmp)):]
        return type(exc)(exc.errno, exc.strerror, str(out) + ("" if rest == f"/{MARKER}"
                                                               else rest))
    return exc


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


class Claim:
    """A folder taken by this process: created if missing (with the missing folders above it,
    removed again by :meth:`remove` when left empty) and locked by an exclusive ``flock`` on
    the folder itself, which the kernel releases when the process ends, even after kill -9, and
    this object when it is dropped. :meth:`acquire` raises ``busy(path)`` when another live
    process holds it."""

    def __init__(self, path: Path, busy):
        self.path = Path(path)
        self.busy = busy
        self.fd: int | None = None
        self.made: list[Path] = []
        self._finalizer = None

    def acquire(self) -> bool:
        """Take the folder; True when this call created it."""
        import weakref

        created = False
        q = self.path.parent
        while not q.exists() and q != q.parent:
            self.made.append(q)   # removed with the folder when left empty
            q = q.parent
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            os.mkdir(self.path)
            created = True
        except FileExistsError:
            pass
        except OSError as exc:
            raise OutDirError(f"{self.path}: cannot create it ({exc.strerror})") from None
        try:
            fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        except OSError as exc:
            raise OutDirError(f"{self.path}: cannot open it ({exc.strerror})") from None
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX: no lock
            fcntl = None
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                if created:
                    os.rmdir(self.path)
                raise self.busy(self.path) from None
        self.fd = fd
        self._finalizer = weakref.finalize(self, os.close, fd)
        return created

    def release(self) -> None:
        if self.fd is not None:
            self._finalizer()  # closes the descriptor, which releases the flock
            self.fd = None

    def remove(self) -> None:
        """Remove the folder and its contents, release it, and remove the folders made for it
        if nothing else was put there."""
        shutil.rmtree(self.path, ignore_errors=True)
        self.release()
        self.remove_made()

    def remove_made(self) -> None:
        for d in self.made:  # deepest first
            try:
                d.rmdir()
            except OSError:
                break
        self.made = []


# ---------------------------------------------------------------------------------------------
# Output files of the real-log commands (allan, calibrate, compensate, device): never someone
# else's file, never an input, all or nothing
def _named(exc: OSError, path) -> OSError:
    """``exc`` naming ``path`` when it names no file (a write on a full disk names none)."""
    from fogcomp._persistence import _named as named

    return named(exc, path)


def _identity(path: Path) -> tuple | None:
    """What a path is now: None when nothing is there, else (device, inode, size, modification
    time in ns) of the entry itself (a symbolic link not followed)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError:
        return ("unreadable",)
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def _same_file(a, b) -> bool:
    a, b = Path(a), Path(b)
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    try:
        return a.resolve() == b.resolve()
    except (OSError, RuntimeError):  # a symbolic link loop (RuntimeError before Python 3.13)
        return os.path.abspath(a) == os.path.abspath(b)


def _check_place(path: Path, flag: str) -> None:
    """The nearest existing ancestor of ``path`` is a writable directory (missing folders are
    created when the outputs are written)."""
    anc = path.parent
    while not anc.exists() and anc != anc.parent:
        if anc.is_symlink():            # dangling link
            break
        anc = anc.parent
    if not anc.is_dir():
        raise OutDirError(f"{flag} {path}: {anc} is not a directory")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutDirError(f"{flag} {path}: the folder {anc} is not writable")


class Outputs:
    """Checks every output path before any work, collects the outputs as temporary files, and
    :meth:`commit` renames them into place all at once.

    An existing output is refused unless ``overwrite``; even then only a file that ``recognise``
    identifies as this command's own output is replaced, and never an input."""

    def __init__(self, overwrite: bool, command: str):
        self.overwrite = overwrite
        self.command = command
        self.pending: list[tuple[str, Path]] = []
        self.created: list[Path] = []   # folders made for the outputs: removed if it fails
        self.claimed: dict[Path, str] = {}   # every output path checked, and the flag naming it
        #: what each output path was when it was checked (None: absent): the file replaced at
        #: the end must still be that one (:meth:`commit`)
        self.seen: dict[Path, tuple | None] = {}

    def _claim(self, path: Path, flag: str) -> None:
        """Refuse two options naming one output file (the later write would replace the
        earlier one's without a word); the same option may check its path again."""
        key = Path(os.path.realpath(path))    # (a symbolic link loop: its own path)
        other = self.claimed.setdefault(key, flag)
        if other != flag:
            raise OutDirError(f"{path}: {other} and {flag} both write this file; give each its "
                              "own path")

    def target(self, path: Path, protect: tuple = (), *, recognise=None, what: str = "output",
               flag: str = "--out") -> Path:
        """Check one output file; returns its path.

        Parameters
        ----------
        path : Path
            The file to write.
        protect : tuple of paths
            Inputs of the command: never written.
        recognise : callable of Path to bool
            True for a file this command wrote (the only kind ever replaced).
        what : str
            What the output is, for messages ("model file").
        flag : str
            The option that named it, for messages.
        """
        path = Path(path)
        for p in protect:
            if _same_file(p, path):
                raise OutDirError(f"{path}: is an input of this command; choose another output")
        if path.is_dir():
            raise OutDirError(f"{flag} {path}: is a directory; {flag} names a file here")
        _check_place(path, flag)
        self._claim(path, flag)
        if path.is_symlink() or path.exists():
            if path.is_symlink() or not path.is_file() or recognise is None or \
                    not recognise(path):
                raise OutDirError(f"{path}: exists and is not a {what} written by fogbench "
                               f"{self.command}; not replaced (not even with --overwrite); "
                               f"choose another {flag}")
            if not self.overwrite:
                raise OutDirError(f"{path}: exists; not replaced (--overwrite replaces it)")
        self.seen[path] = _identity(path)
        return path

    def folder(self, path: Path, protect: tuple = (), *, marker: str, recognise,
               members: list, flag: str = "--out") -> dict:
        """Check an output folder holding ``marker`` (recognised by ``recognise``) and
        ``members`` (name -> recogniser); returns {name: path} for the marker and members.
        An existing marker or member is replaced only with ``overwrite`` and only when the
        folder's marker is recognised as this command's own."""
        path = Path(path)
        if path.exists() and not path.is_dir():
            raise OutDirError(f"{flag} {path}: is a file, not a folder; {flag} names the folder "
                           f"for {marker} and the figures")
        _check_place(path / marker, flag)
        names = [marker, *(n for n, _ in members)]
        paths = {n: path / n for n in names}
        for n, p in paths.items():
            self._claim(p, flag)
            for q in protect:
                if _same_file(q, p):
                    raise OutDirError(f"{p}: is an input of this command; choose another output")
        existing = [n for n, p in paths.items() if p.exists() or p.is_symlink()]
        if existing:
            m = paths[marker]
            if not (m.is_file() and not m.is_symlink() and recognise(m)):
                raise OutDirError(f"{path / existing[0]}: exists and {path} is not a folder written "
                               f"by fogbench {self.command} (no {marker} of its own); not "
                               f"replaced (not even with --overwrite); choose another {flag}")
            for n, rec in members:
                p = paths[n]
                if (p.exists() or p.is_symlink()) and (
                        p.is_symlink() or not p.is_file() or not rec(p)):
                    raise OutDirError(f"{p}: exists and is not a file written by fogbench "
                                   f"{self.command}; not replaced (not even with --overwrite); "
                                   f"choose another {flag}")
            if not self.overwrite:
                raise OutDirError(f"{path / existing[0]}: exists; not replaced (--overwrite "
                               "replaces the outputs of fogbench "
                               f"{self.command} in {path})")
        for p in paths.values():
            self.seen[p] = _identity(p)
        return paths

    def _mkdirs(self, folder: Path) -> None:
        missing = []
        q = folder
        while not q.exists() and q != q.parent:
            missing.append(q)
            q = q.parent
        for d in reversed(missing):
            d.mkdir()
            self.created.append(d)

    def temp(self, path: Path) -> str:
        """A temporary file beside ``path`` (renamed onto it by :meth:`commit`)."""
        try:
            self._mkdirs(path.parent)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        except OSError as exc:
            raise _named(exc, path) from None
        os.close(fd)
        self.pending.append((tmp, path))
        return tmp

    def write(self, path: Path, fn) -> None:
        """``fn(temporary path)`` writes the output ``path``; an ``OSError`` names ``path``."""
        tmp = self.temp(path)
        try:
            fn(tmp)
        except OSError as exc:
            raise _named(exc, path) from None

    def write_text(self, path: Path, text: str) -> None:
        def put(tmp):
            with open(tmp, "w") as f:
                f.write(text)

        self.write(path, put)

    def save_model(self, model, stem: Path) -> tuple[Path, Path]:
        """``fogcomp.save_model`` to a temporary stem beside ``stem``; :meth:`commit` renames
        both files (``stem.json``, ``stem.npz``) into place with the rest."""
        import fogcomp

        try:
            self._mkdirs(stem.parent)
            tmp = Path(tempfile.mkdtemp(dir=stem.parent, prefix=f".{stem.name}.",
                                        suffix=".tmp"))
        except OSError as exc:
            raise _named(exc, stem) from None
        self.created.append(tmp)
        final = (stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz"))
        try:
            jtmp, ntmp = fogcomp.save_model(model, tmp / "model")
        except OSError as exc:  # named as the user will look for it, not by its temporary name
            target = final[1] if str(exc.filename or "").endswith(".npz") else final[0]
            raise type(exc)(exc.errno, exc.strerror, str(target)) from None
        self.pending += [(str(jtmp), final[0]), (str(ntmp), final[1])]
        return final

    def commit(self) -> None:
        """Put every output in place (none after Ctrl-C or SIGTERM), never over a file that is
        not the one checked before the work: an output that was absent is created exclusively
        (a hard link of the temporary file, which fails if anything took its name meanwhile),
        and one that existed is replaced only while it is still that file (same inode, size
        and modification time). Created ones are put in place first, so a refusal among them
        takes back what this call created and leaves every other file as it was."""
        check_signals()
        umask = os.umask(0)
        os.umask(umask)
        for tmp, path in self.pending:
            if _identity(path) != self.seen.get(path, _identity(path)):
                raise self._changed(path)
        before = {p: self.seen.get(p, _identity(p)) for _, p in self.pending}
        new = [(t, p) for t, p in self.pending if before[p] is None]
        old = [(t, p) for t, p in self.pending if before[p] is not None]
        linked: list[Path] = []
        for tmp, path in new:
            try:
                os.chmod(tmp, 0o666 & ~umask)
                os.link(tmp, path)
            except FileExistsError:
                for q in linked:
                    os.unlink(q)
                raise self._changed(path) from None
            except OSError as exc:
                for q in linked:
                    os.unlink(q)
                raise _named(exc, path) from None
            linked.append(path)
        for tmp, path in new:
            os.unlink(tmp)
        for tmp, path in old:
            try:
                os.chmod(tmp, 0o666 & ~umask)
                if _identity(path) != before[path]:
                    raise self._changed(path)
                os.replace(tmp, path)
            except OSError as exc:
                raise _named(exc, path) from None
        self.pending.clear()
        self._remove_created(only_empty=True)
        self.created = [d for d in self.created if d.exists()]

    def _changed(self, path: Path) -> OutDirError:
        return OutDirError(f"{path}: appeared or changed while fogbench {self.command} ran; "
                           "it was left as it is and nothing was written. Run the command again "
                           "(or give another output path)")

    def _remove_created(self, only_empty: bool) -> None:
        import shutil

        for d in reversed(self.created):
            if not d.is_dir():
                continue
            if d.name.endswith(".tmp"):  # our own temporary folder (a model's files)
                shutil.rmtree(d, ignore_errors=True)
            elif not only_empty or not any(d.iterdir()):
                try:
                    d.rmdir()
                except OSError:
                    pass

    def discard(self) -> None:
        """Remove the temporary files and the folders made for the outputs (if still empty):
        a failed command leaves nothing behind."""
        for tmp, _ in self.pending:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        self.pending.clear()
        self._remove_created(only_empty=True)
        self.created.clear()


# What a command recognises as its own output: only such a file is ever replaced.
_RECOGNISE_MAX_BYTES = 50_000_000


def json_format(path: Path):
    """The ``format`` key of a small JSON object file, else None."""
    try:
        if path.stat().st_size > _RECOGNISE_MAX_BYTES:
            return None
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc.get("format") if isinstance(doc, dict) else None


def starts_with(path: Path, magic: bytes) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(len(magic)) == magic
    except OSError:
        return False
