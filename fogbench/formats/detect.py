"""What every log reader shares: a log's format recognised from its content (magic bytes, a
bag's folder), what a gzip-compressed file holds, and :class:`Rows`, which names a row of the
table in the file's own terms (a CSV's line, a bag's message)."""

from __future__ import annotations

import gzip
import zlib
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Rows", "FORMATS", "detect", "gzip_payload"]

FORMATS = ("csv", "euroc", "rosbag", "ulog")

_MAGIC = {b"\x89MCAP0\r\n": "rosbag", b"ULog\x01\x12\x35": "ulog", b"SQLite format 3\x00":
          "rosbag", b"#ROSBAG V2.0": "rosbag"}
#: What each magic names, and the file name it has uncompressed.
_KIND = {b"\x89MCAP0\r\n": ("MCAP file", ".mcap"), b"ULog\x01\x12\x35": ("ULog file", ".ulg"),
         b"SQLite format 3\x00": ("ROS 2 bag (SQLite .db3)", ".db3"),
         b"#ROSBAG V2.0": ("ROS 1 bag", ".bag")}
_GZIP = b"\x1f\x8b"


@dataclass(frozen=True)
class Rows:
    """How an error names row ``i`` of the table: ``line N`` of a text file (``first`` the line
    of row 0), or ``message N on TOPIC`` of a bag or ULog (``what``)."""

    first: int = 2
    what: str | None = None
    #: The file's line of each row, where rows are not consecutive lines (a CSV with blank
    #: lines, which the CSV reader skips).
    lines: object = field(default=None, compare=False)

    def __call__(self, i: int) -> str:
        if self.what is None:
            if self.lines is not None and 0 <= int(i) < len(self.lines):
                return f"line {int(self.lines[int(i)])}"
            return f"line {self.first + int(i)}"
        return f"message {int(i) + 1} of {self.what}"


def detect(path) -> str:
    """The format of ``path`` by its content: "rosbag" (a ROS 2 bag folder, MCAP, SQLite,
    ROS 1 bag), "ulog", else "csv" (the CSV reader recognises EuRoC's header itself)."""
    p = Path(path)
    if p.is_dir():
        return "rosbag" if (p / "metadata.yaml").is_file() else "csv"   # csv: refuses a folder
    if not p.is_file():     # a pipe or a device would block the read: the CSV reader refuses it
        return "csv"
    try:
        with open(p, "rb") as f:
            head = f.read(16)
    except OSError:
        return "csv"                 # the CSV reader names what is wrong with the path
    if head.startswith(_GZIP):   # a compressed CSV, or a compressed ULog, MCAP or bag
        head = _gunzipped_head(p)
    for magic, fmt in _MAGIC.items():
        if head.startswith(magic):
            return fmt
    return "csv"


def _gunzipped_head(p: Path) -> bytes:
    """The first 16 bytes a gzip-compressed file holds (empty when it cannot be read: the CSV
    reader then says what is wrong with it)."""
    try:
        with gzip.open(p, "rb") as f:
            return f.read(16)
    except (OSError, EOFError, zlib.error):
        return b""


def gzip_payload(path) -> tuple[str, str] | None:
    """None when ``path`` is not a gzip-compressed regular file; else (what it holds, e.g.
    "MCAP file", and the command that decompresses it beside it)."""
    p = Path(path)
    if not p.is_file():
        return None
    try:
        with open(p, "rb") as f:
            if f.read(2) != _GZIP:
                return None
    except OSError:
        return None
    head = _gunzipped_head(p)
    what, suffix = next((v for m, v in _KIND.items() if head.startswith(m)), ("file", ""))
    if p.name.endswith(".gz") and len(p.name) > 3:
        how = f"gunzip -k {p.name}, which writes {p.name[:-3]}"
    else:
        how = f"gunzip -c {p.name} > {p.stem}.uncompressed{suffix or p.suffix}"
    return what, how
