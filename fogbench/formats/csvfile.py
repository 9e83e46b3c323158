"""The CSV text of a log: gzip by its magic bytes, leading ``#`` comments, EuRoC / TUM-VI's
``#`` header (:mod:`.euroc`), a count of fields per line (a short row is refused with its line),
then pandas' reader. By hand only the field count (no CSV reader we use reports a short row with
its line) and the comment lines."""

from __future__ import annotations

import csv
import gzip
import io
import zlib
from pathlib import Path

import numpy as np

from fogbench.formats.detect import Rows
from fogbench.formats.errors import LogError
from fogbench.formats.euroc import commented_header

__all__ = ["read_frame", "comment_fields", "file_bytes"]


def file_bytes(path: Path) -> bytes:
    """The file's bytes, gunzipped when it is gzip (by its magic bytes, whatever its name)."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise LogError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError, zlib.error) as exc:
            raise LogError(f"{path}: not a readable gzip file ({exc})") from None
    return raw


def _leading_comments(raw: bytes) -> int:
    """Lines at the top that start with ``#`` (comments before the header)."""
    k, pos = 0, 0
    while raw.startswith(b"#", pos):
        nl = raw.find(b"\n", pos)
        k += 1
        if nl < 0:
            break
        pos = nl + 1
    return k


def _field_counts(raw: bytes, skip: int) -> tuple[np.ndarray, np.ndarray]:
    """(line number, number of comma-separated fields) of every non-blank line after the first
    ``skip`` lines, header included. pandas fills a short row with NaN without a word (and a
    missing field in a column no command uses would pass); this count is what refuses it. By
    hand because no CSV reader we use reports it with the line: a count of commas per line,
    vectorised (about 0.2 s for 10^6 rows), or Python's csv module when fields are quoted."""
    if b'"' in raw:
        rows = csv.reader(io.StringIO(raw.decode("utf-8", "replace")))
        lines, counts = [], []
        for k, row in enumerate(rows, start=1):
            if k > skip and row and any(c.strip() for c in row):
                lines.append(rows.line_num)
                counts.append(len(row))
        return np.asarray(lines), np.asarray(counts)
    buf = np.frombuffer(raw, dtype=np.uint8)
    ends = np.flatnonzero(buf == 10)
    if ends.size == 0 or ends[-1] != buf.size - 1:
        ends = np.append(ends, buf.size)        # a last line without its newline
    starts = np.concatenate(([0], ends[:-1] + 1))
    length = ends - starts
    blank = (length == 0) | ((length == 1) & (buf[np.minimum(starts, buf.size - 1)] == 13))
    commas = np.zeros(starts.size, dtype=np.int64)
    full = ~blank
    if full.any():  # from each line's start to the next one's: the bytes between hold no comma
        commas[full] = np.add.reduceat((buf == 44).view(np.uint8), starts[full], dtype=np.int64)
    keep = ~blank
    keep[:skip] = False
    return np.flatnonzero(keep) + 1, commas[keep] + 1


def read_frame(path):
    import pandas as pd

    p = Path(path)
    if p.is_dir():
        raise LogError(f"{path}: is a directory; give a log file (CSV, MCAP, .db3, .bag, "
                       ".ulg) or a ROS 2 bag folder (one with metadata.yaml)")
    if p.is_symlink() and not p.exists():
        raise LogError(f"{path}: is a symbolic link that leads to no file (a loop, or its "
                       "target is missing)")
    if p.exists() and not p.is_file():
        raise LogError(f"{path}: not a regular file (a pipe, device or socket); give a CSV "
                       "file")
    if not p.is_file():
        raise LogError(f"{path}: file not found")
    raw = file_bytes(p)
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise LogError(f"{path}: line {line}, column {col}: not UTF-8 text (byte "
                       f"0x{raw[exc.start]:02x}); save the file as UTF-8") from None
    skip = _leading_comments(raw)
    hash_header = commented_header(raw, skip, path)
    if hash_header is not None:     # EuRoC / TUM-VI: the '#' line is the header
        raw = raw[:hash_header] + raw[hash_header + 1:]
        skip -= 1
    try:
        # The header as written: pandas renames a repeated name 'a' to 'a.1' in the frame.
        raw_header = pd.read_csv(io.BytesIO(raw), skiprows=skip, header=None, nrows=1,
                                 dtype=str, skipinitialspace=True, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise LogError(f"{path}: not a readable CSV file ({str(exc).splitlines()[0]})") from None
    names = [str(c).strip() for c in raw_header.iloc[0].tolist()] if len(raw_header) else []
    seen = set()
    for k, name in enumerate(names):
        if name in seen:
            raise LogError(f"{path}: line {skip + 1}: duplicate column name {name!r} in the "
                           f"header (columns {names.index(name) + 1} and {k + 1}); each column "
                           "needs its own name")
        seen.add(name)
    if len(names) == 1:
        for sep, word in ((";", "semicolons"), ("\t", "tabs"), ("|", "'|'")):
            if sep in names[0]:
                raise LogError(f"{path}: line {skip + 1}: one column {names[0]!r}: the "
                               f"file seems to be separated by {word}; fogbench reads "
                               "comma-separated files (convert it, e.g. with pandas: "
                               f"read_csv(sep={sep!r}).to_csv(...), minding decimal commas)")
    lines, counts = _field_counts(raw, skip)
    if counts.size:
        bad = np.flatnonzero(counts != counts[0])
        if bad.size:
            k = int(bad[0])
            raise LogError(f"{path}: line {lines[k]}: {counts[k]} field(s), the header (line "
                           f"{lines[0]}) has {counts[0]}; {bad.size} such row(s) in all: every "
                           "row needs one value per column")
    try:
        frame = pd.read_csv(io.BytesIO(raw), skiprows=skip, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise LogError(f"{path}: not a readable CSV file ({str(exc).splitlines()[0]})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    # line number of data row 0 = skip + 2 (1-based, header), unless blank lines (skipped by
    # the reader) lie between rows: then each row's own line, from the field count's
    data_lines = lines[1:] if counts.size else lines
    if data_lines.size and data_lines[-1] - data_lines[0] + 1 != data_lines.size:
        return frame, Rows(skip + 2, lines=data_lines)
    return frame, Rows(skip + 2)


def comment_fields(path) -> dict:
    """``key=value`` pairs of the comment lines (``#``) at the top of a file, separated by
    ``;`` (``# sensor=LN200; sample_rate_hz=400; n_samples=8640000``)."""
    raw = file_bytes(Path(path))
    out = {}
    for line in raw[:65536].decode("utf-8", "replace").splitlines():
        if not line.startswith("#"):
            break
        for part in line[1:].split(";"):
            if "=" in part:
                k, v = part.split("=", 1)
                out[k.strip()] = v.strip()
    return out
