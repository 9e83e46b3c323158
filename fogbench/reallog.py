"""Real gyro logs from the command line: ``fogbench allan``, ``calibrate`` and ``compensate``.

The other log formats (EuRoC / TUM-VI CSV, ROS bags and MCAP, PX4 ULog) are read by
``fogbench.logformats`` into the same table; the output files' safety rules are
``fogbench.outdir.Outputs``, shared with ``fogbench device``.

A log is a CSV file (gzip accepted) whose header names carry their units, as the project's own keys
do: ``time_s``, ``gyro_x_dps`` / ``_rps`` / ``_dph``, ``acc_x_g`` / ``_mps2`` (``accel_`` is read as
``acc_``), ``temp_c``; ``_au`` marks raw sensor counts (only a calibration such as ``ferraris``
turns them into physical units). Files with other headers are mapped with
``--column gyro_z=GyroZ:dps``. The sample rate comes from the time column or from ``--fs``.

Everything is validated before any work starts and nothing is written when the input is refused:
each error (a :class:`LogError`) names the file, the row (line of the file) and the column.
Outputs are written to temporary files and renamed into place once all of them are complete.
"""

from __future__ import annotations

import csv
import functools
import gzip
import io
import json
import math
import re
import sys
import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .logformats import Rows
from .outdir import Outputs as _Outputs, _named, _same_file  # noqa: F401 (used by device.py)
from .logformats.euroc import bracketed_column, commented_header

__all__ = ["LogError", "Log", "read_log", "read_curve", "add_commands", "GYRO_UNITS",
           "ACC_UNITS", "MIN_RECORD_SAMPLES"]

DEG = math.pi / 180.0
G0 = 9.80665
EARTH_RATE = 7.2921150e-5          # rad/s, WGS-84 / IERS

#: Gyro unit suffixes and their factor to rad/s (None: raw counts, no physical unit).
GYRO_UNITS = {"dps": DEG, "deg_s": DEG, "rps": 1.0, "rad_s": 1.0, "dph": DEG / 3600.0,
              "au": None}
#: Accelerometer unit suffixes and their factor to m/s^2.
ACC_UNITS = {"g": G0, "mps2": 1.0, "au": None}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
TEMP_UNITS = {"c": 1.0}
_KINDS = {"gyro": GYRO_UNITS, "acc": ACC_UNITS}
_HEADER = re.compile(r"^(gyro|acc|accel)_([xyz])(?:_(.*))?$")

#: Fewest samples (in the longest gap-free piece) that ``allan`` and ``calibrate`` with a fitted
#: method accept: 64 samples give the overlapping Allan deviation 5 octave averaging times
#: (1, 2, 4, 8, 16 samples; the longest usable is (n - 1) // 2), the fewest from which the noise
#: terms' slopes can be told apart.
MIN_RECORD_SAMPLES = 64
#: Plausible local gravity, m/s^2 (9.78 at the equator to 9.83 at the poles at sea level, less
#: on mountains), for ``calibrate ferraris --g``.
G_RANGE_MPS2 = (9.7, 9.9)
#: Rows from which writing or compensating shows a progress bar on stderr (when it is a terminal).
PROGRESS_MIN_ROWS = 200_000


class LogError(ValueError):
    """A log file, a curve file or a command-line option is refused (one-line message)."""


class PlausibilityWarning(UserWarning):
    """A log's values contradict the unit its header names (read, but say so)."""


#: Largest magnitude a channel in a physical unit may reach, SI: (warn beyond, refuse beyond).
#: Rates: the widest-range gyros (projectile IMUs) measure about 20,000 deg/s; 10^6 deg/s (2,800
#: revolutions per second) is no measurement at all. Specific force: IMU accelerometers reach
#: 200 g, shock sensors 10^5 g. Temperatures: below absolute zero is refused, beyond 500 C
#: (past any FOG's survival range) warned.
MAGNITUDE_LIMITS = {"gyro": (2.0e4 * DEG, 1.0e6 * DEG), "acc": (2.0e3 * G0, 1.0e6 * G0)}
#: Sample rates of gyro logs, Hz: beyond this a time column's unit is suspect (warned).
PLAUSIBLE_FS_HZ = (0.01, 50_000.0)
_DISPLAY = {"gyro": (1.0 / DEG, "deg/s"), "acc": (1.0 / G0, "g")}


def _check_magnitude(path, ch: str, column: str, unit: str, v: np.ndarray,
                     first_line: Rows) -> None:
    """Refuse values no sensor measures in the unit the column names; warn of implausible
    ones (a unit contradicted by the values: deg/s under _rps reads 57 times too large)."""
    kind = ch.split("_")[0]
    if kind == "temp":
        i = int(np.argmin(v))
        if v[i] < -273.15:
            raise LogError(f"{path}: {first_line(i)}, column {column!r}: "
                           f"{_fmt_number(v[i])} C is below absolute zero")
        if float(np.max(v)) > 500.0:
            warnings.warn(PlausibilityWarning(
                f"{path}: column {column!r} reaches {float(np.max(v)):.4g} C, beyond any "
                "FOG's survival range: is it a temperature in deg C?"))
        return
    warn, refuse = MAGNITUDE_LIMITS[kind]
    scale, shown = _DISPLAY[kind]
    i = int(np.argmax(np.abs(v)))
    peak = abs(float(v[i]))
    if peak > refuse:
        raise LogError(f"{path}: {first_line(i)}, column {column!r}: "
                       f"{_fmt_number(v[i] / _unit_table(ch)[unit])} {unit} = "
                       f"{peak * scale:.3g} {shown}, which no sensor measures "
                       f"(refused beyond {refuse * scale:.0e} {shown}); check the column's unit")
    if peak > warn:
        warnings.warn(PlausibilityWarning(
            f"{path}: column {column!r} reaches {peak * scale:.4g} {shown} ("
            f"{first_line(i)}), beyond any {'gyro' if kind == 'gyro' else 'accelerometer'}'s "
            f"range ({warn * scale:g} {shown}): is its unit {unit!r} right?"))


# ---------------------------------------------------------------------------------------------
# stderr: one line per note or warning
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


@dataclass
class Log:
    """A validated log.

    Attributes
    ----------
    path : str
        The file.
    frame : pandas.DataFrame
        Every column as read (written back unchanged by ``compensate``).
    fs : float
        Sample rate, Hz.
    channels : dict of str to ndarray, shape (n,)
        The validated channels by canonical name (``gyro_x``, ``acc_y``, ``temp``), in SI units
        (rad/s, m/s^2, deg C) or raw counts where the unit is ``au``.
    units : dict of str to str
        Unit suffix of each channel as given (``dps``).
    sources : dict of str to str
        The file column each channel came from.
    segments : list of (int, int)
        Sample ranges [start, stop) of the gap-free pieces (one when there is no gap).
    """

    path: str
    frame: object
    fs: float
    channels: dict
    units: dict
    sources: dict
    segments: list = field(default_factory=list)
    origin: str = ""          # what in the file was read ("topic /imu0"), "" for a CSV

    @property
    def n(self) -> int:
        return len(self.frame)

    def describe(self) -> str:
        """One line: samples, the sample rate used (Hz) and the sampled duration (s, h), so a
        time column in the wrong unit shows at once."""
        d = self.n / self.fs
        pieces = f" in {len(self.segments)} gap-free pieces" if len(self.segments) > 1 else ""
        where = f" ({self.origin})" if self.origin else ""
        return (f"{self.path}{where}: {self.n} samples at {self.fs:.6g} Hz (interval "
                f"{1.0 / self.fs:.6g} s), {d:.6g} s = {d / 3600:.3g} h{pieces}")


# ---------------------------------------------------------------------------------------------
# Reading and validation
def _parse_mapping(items) -> dict:
    """``["gyro_z=GyroZ:dps", "a=b:c,d=e:f"]`` -> {"gyro_z": ("GyroZ", "dps"), ...}."""
    out = {}
    for item in items or []:
        for part in str(item).split(","):
            part = part.strip()
            if not part:
                continue
            m = re.fullmatch(r"(gyro_[xyz]|acc_[xyz]|temp|time)=(.+):([A-Za-z0-9_]+)", part)
            if not m:
                raise LogError(f"--column {part!r}: expected CHANNEL=HEADER:UNIT with CHANNEL one "
                               "of gyro_x/y/z, acc_x/y/z, temp, time (e.g. gyro_z=GyroZ:dps)")
            ch, src, unit = m.group(1), m.group(2), m.group(3).lower()
            if ch in out:
                raise LogError(f"--column: channel {ch!r} is mapped twice")
            other = next((c for c, (s_, _) in out.items() if s_ == src), None)
            if other is not None:
                raise LogError(f"--column: the file column {src!r} is mapped to two channels, "
                               f"{other} and {ch}; each channel needs its own column")
            out[ch] = (src, unit)
    return out


def _unit_table(channel: str) -> dict:
    if channel == "time":
        return TIME_UNITS
    if channel == "temp":
        return TEMP_UNITS
    return _KINDS[channel.split("_")[0]]


def _check_unit(path, channel: str, column: str, unit: str | None) -> str:
    table = _unit_table(channel)
    if unit is None or unit == "":
        raise LogError(f"{path}: column {column!r}: no unit suffix; name it e.g. "
                       f"{channel}_{next(iter(table))} or map it with --column "
                       f"{channel}={column}:UNIT (units: {', '.join(table)})")
    if unit not in table:
        raise LogError(f"{path}: column {column!r}: unknown unit {unit!r} for {channel}; "
                       f"known: {', '.join(table)}")
    return unit


def _file_bytes(path: Path) -> bytes:
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


def _fmt_number(x) -> str:
    """A number as a person writes it (``inf``, ``1.5``), never ``np.float64(inf)``."""
    try:
        return f"{float(x):.10g}"
    except (TypeError, ValueError):
        return repr(x)


def _read_frame(path):
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
    raw = _file_bytes(p)
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise LogError(f"{path}: line {line}, column {col}: not UTF-8 text (byte "
                       f"0x{raw[exc.start]:02x}); save the file as UTF-8") from None
    skip = _leading_comments(raw)
    hash_header = commented_header(raw, skip)
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
    return frame, Rows(skip + 2)    # line number of data row 0 = skip + 2 (1-based, header)


def _numeric(path, frame, column: str, first_line: Rows) -> np.ndarray:
    import pandas as pd

    s = frame[column]
    values = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raw = s.iloc[i]
        if raw is None or (isinstance(raw, float) and math.isnan(raw)) or str(raw).strip() == "":
            what = "empty or NaN cell"
        elif isinstance(raw, str):
            what = f"non-numeric value {raw!r}" if not re.fullmatch(
                r"[+-]?(nan|inf|infinity)", raw.strip(), re.I) else f"non-finite value {raw!r}"
        else:
            what = f"non-finite value {_fmt_number(raw)}"
        n_bad = int(bad.sum())
        raise LogError(f"{path}: {first_line(i)}, column {column!r}: {what}"
                       + (f" ({n_bad} bad cells in this column)" if n_bad > 1 else ""))
    return values


def read_log(path, *, mapping=None, channels=None, fs=None, gaps: str = "refuse",
             time_tolerance: float = 0.05, min_samples: int = 2,
             fs_is_fallback: bool = False, model_mapping: dict | None = None,
             model_file=None, fmt: str | None = None, topic: str | None = None) -> Log:
    """Read and validate a log (see the module docstring).

    Parameters
    ----------
    path : str or Path
        CSV file, gzip accepted (``.gz``).
    mapping : list of str, optional
        ``--column`` items, ``CHANNEL=HEADER:UNIT``.
    channels : list of str, optional
        The channels needed (``gyro_x`` ...; ``gyro_*``: every gyro channel, at least one);
        None: every channel the header names. Each must be present.
    fs : float, optional
        Sample rate, Hz; required when there is no time column, checked against it otherwise.
    gaps : {"refuse", "split"}
        What to do with a gap in the time column (an interval more than 1.5 median intervals):
        refuse the file, or cut it into gap-free segments.
    time_tolerance : float
        Largest relative departure of a sample interval from the median one that is not a gap
        (default 0.05).
    min_samples : int
        Fewest samples the command needs (in the longest gap-free segment).
    fs_is_fallback : bool
        ``fs`` is only a stand-in for a log without a time column (not checked against one).
    model_mapping : dict of str to (str, str), optional
        Channel -> (column, unit) taken from a saved model (``compensate``); ``mapping`` wins
        over it, and an error names the model file, not a ``--column`` the user did not type.
    model_file : str or Path, optional
        The model file ``model_mapping`` comes from (for messages).
    fmt : {"csv", "euroc", "rosbag", "ulog"}, optional
        The file's format (``--format``); None: recognised from its content.
    topic : str, optional
        The IMU topic of a bag or ULog (``--topic``).

    Returns
    -------
    Log
    """
    if gaps not in ("refuse", "split"):
        raise LogError(f"--gaps: expected 'refuse' or 'split', got {gaps!r}")
    if not (math.isfinite(time_tolerance) and 0 < time_tolerance < 0.5):
        raise LogError(f"--time-tolerance: expected a fraction between 0 and 0.5, got "
                       f"{time_tolerance!r}")
    if fs is not None and not (math.isfinite(fs) and fs > 0):
        raise LogError(f"--fs: expected a positive, finite sample rate in Hz, got "
                       f"{_fmt_number(fs)}")
    mapped = _parse_mapping(mapping)
    from_model = {ch: v for ch, v in (model_mapping or {}).items() if ch not in mapped}
    frame, first_line, origin = _read_any(path, fmt, topic)
    if len(frame) == 0:
        raise LogError(f"{path}: no data rows")
    # Channel -> (column, unit as written); a unit is checked only for the channels used.
    found: dict[str, tuple[str, str | None]] = {}
    mapped_sources = {src for src, _ in [*mapped.values(), *from_model.values()]}
    for col in frame.columns:
        if col in mapped_sources:
            continue
        name = bracketed_column(col) or col
        m = _HEADER.match(name)
        if name.startswith("time_"):
            found["time"] = (col, name[5:].lower())
            continue
        if name.startswith("temp_") and name != col:
            found["temp"] = (col, name[5:].lower())
            continue
        if m:
            kind = "acc" if m.group(1) == "accel" else m.group(1)
            ch = f"{kind}_{m.group(2)}"
            if ch in mapped or ch in from_model:
                continue
            found[ch] = (col, m.group(3) and m.group(3).lower())
        elif col.startswith("time_") or col == "time":
            found["time"] = (col, col[5:].lower() or None)
        elif col.startswith("temp_") or col == "temp":
            found["temp"] = (col, col[5:].lower() or None)
    for ch, (src, unit) in mapped.items():
        if src not in frame.columns:
            raise LogError(f"{path}: --column {ch}={src}:{unit}: no column {src!r}; columns: "
                           f"{', '.join(frame.columns)}")
        found[ch] = (src, _check_unit(path, ch, src, unit))
    for ch, (src, unit) in from_model.items():
        if src not in frame.columns:
            raise LogError(f"{path}: no column {src!r} for {ch}: the model {model_file} names "
                           f"it (its calibration file's header); columns: "
                           f"{', '.join(frame.columns)}; map this log's column with --column "
                           f"{ch}=HEADER:{unit}")
        found[ch] = (src, unit)
    wanted = list(channels) if channels is not None else [c for c in found if c != "time"]
    if "gyro_*" in wanted:
        gyros = sorted(c for c in found if c.startswith("gyro_"))
        if not gyros:
            raise LogError(f"{path}: no gyro column (e.g. gyro_x_dps); columns: "
                           f"{', '.join(frame.columns)}; map another name with --column "
                           "gyro_x=HEADER:UNIT")
        i = wanted.index("gyro_*")
        wanted[i:i + 1] = [g for g in gyros if g not in wanted]
    if "acc_*?" in wanted:     # every accelerometer channel there is, perhaps none
        i = wanted.index("acc_*?")
        wanted[i:i + 1] = sorted(c for c in found if c.startswith("acc_") and c not in wanted)
    for ch in wanted:
        if ch not in found:
            raise LogError(f"{path}: missing column for {ch} (e.g. {ch}_"
                           f"{next(iter(_unit_table(ch)))}); columns: {', '.join(frame.columns)}"
                           f"; map another name with --column {ch}=HEADER:UNIT")
    for ch in [*wanted, *(["time"] if "time" in found else [])]:
        src, unit = found[ch]
        found[ch] = (src, _check_unit(path, ch, src, unit))
    values, units, sources = {}, {}, {}
    for ch in wanted:
        src, unit = found[ch]
        v = _numeric(path, frame, src, first_line)
        factor = _unit_table(ch)[unit]
        values[ch] = v if factor is None else v * factor
        units[ch], sources[ch] = unit, src
        if factor is not None:
            _check_magnitude(path, ch, src, unit, values[ch], first_line)
    n = len(frame)
    segments = [(0, n)]
    if "time" in found:
        src, unit = found["time"]
        t = _numeric(path, frame, src, first_line)
        if frame[src].dtype.kind in "iu":   # integer stamps (EuRoC ns): from the first row,
            # exactly (a float64 holds 1.4e18 ns only to 256 ns); messages give time since it
            t = (frame[src].to_numpy() - frame[src].iloc[0]).astype(float)
        t = t * TIME_UNITS[unit]
        if n < 2:
            raise LogError(f"{path}: one row only; a record needs at least {max(2, min_samples)}")
        dt = np.diff(t)
        bad = np.flatnonzero(dt <= 0)
        if bad.size:
            i = int(bad[0])
            word = "duplicated" if dt[i] == 0 else "not increasing"
            raise LogError(f"{path}: {first_line(i + 1)}, column {src!r}: time {word} "
                           f"({t[i + 1]:.10g} after {t[i]:.10g})")
        step = float(np.median(dt))
        fs_t = 1.0 / step
        gap = dt > 1.5 * step
        irregular = (np.abs(dt / step - 1.0) > time_tolerance) & ~gap
        if irregular.any():
            i = int(np.flatnonzero(irregular)[0])
            raise LogError(f"{path}: {first_line(i + 1)}, column {src!r}: irregular "
                           f"sampling, interval {dt[i]:.6g} s vs median {step:.6g} s (more "
                           f"than {time_tolerance:.0%} off; {int(irregular.sum())} such "
                           "intervals); resample the log or raise --time-tolerance")
        if gap.any():
            i = int(np.flatnonzero(gap)[0])
            if gaps == "refuse":
                raise LogError(f"{path}: {first_line(i + 1)}, column {src!r}: gap of "
                               f"{dt[i]:.6g} s ({dt[i] / step - 1:.0f} missing samples at "
                               f"{step:.6g} s) after time {t[i]:.10g}; {int(gap.sum())} gap(s) "
                               "in all; use --gaps split to analyse the pieces separately")
            cuts = np.flatnonzero(gap) + 1
            bounds = [0, *cuts.tolist(), n]
            segments = [(a, b) for a, b in zip(bounds[:-1], bounds[1:])]
        # The mean interval of the longest gap-free piece: far less sensitive than the median
        # to timestamps rounded to a few decimals.
        a0, b0 = max(segments, key=lambda ab: ab[1] - ab[0])
        if b0 - a0 >= 2:
            fs_t = (b0 - a0 - 1) / (t[b0 - 1] - t[a0])
        if fs is not None and not fs_is_fallback and abs(fs / fs_t - 1.0) > time_tolerance:
            raise LogError(f"{path}: --fs {fs:g} Hz disagrees with the time column "
                           f"{src!r}, which gives {fs_t:.6g} Hz")
        fs = fs_t
    elif fs is None:
        raise LogError(f"{path}: no time column (time_s) to take the sample rate from; "
                       "give --fs HZ")
    if not (math.isfinite(fs) and fs > 0):
        raise LogError(f"--fs: expected a positive sample rate in Hz, got {_fmt_number(fs)}")
    lo, hi = PLAUSIBLE_FS_HZ
    if not lo <= fs <= hi:
        where = f"the time column {found['time'][0]!r}" if "time" in found else "--fs"
        warnings.warn(PlausibilityWarning(
            f"{path}: {where} gives a sample rate of {fs:.6g} Hz, outside the {lo:g} Hz to "
            f"{hi / 1000:g} kHz of gyro logs: is the time unit in its name right (ms or us "
            "written under _s, or s under _ms)?"))
    longest = max(b - a for a, b in segments)
    if longest < min_samples:
        raise LogError(f"{path}: record too short: {longest} samples"
                       + (" in its longest gap-free piece" if len(segments) > 1 else "")
                       + f", this command needs at least {min_samples}")
    return Log(path=str(path), frame=frame, fs=float(fs), channels=values, units=units,
               sources=sources, segments=segments, origin=origin)


def _read_any(path, fmt: str | None, topic: str | None):
    """(frame, Rows, origin) of a log in any format ``fogbench.logformats`` reads."""
    from .logformats import FORMATS, detect, read_table

    if fmt is not None and fmt not in FORMATS:
        raise LogError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    kind = fmt or detect(path)
    if kind in ("csv", "euroc"):
        if topic is not None:
            raise LogError(f"--topic {topic!r}: {path} is a CSV file; --topic chooses the IMU "
                           "topic of a ROS bag, MCAP or ULog file")
        frame, rows = _read_frame(path)
        if kind == "euroc" and not any(bracketed_column(c) for c in frame.columns):
            raise LogError(f"{path}: --format euroc: its header is not EuRoC's (e.g. "
                           "'#timestamp [ns],w_RS_S_x [rad s^-1],...'); first line: "
                           f"{', '.join(frame.columns)}")
        return frame, rows, ""
    p = Path(path)
    if not p.exists():
        raise LogError(f"{path}: file not found")
    if not (p.is_file() or (kind == "rosbag" and p.is_dir())):
        raise LogError(f"{path}: not a regular file (a pipe, device, socket or folder); give "
                       f"the {kind} file" + (" or the bag's folder" if kind == "rosbag" else ""))
    return read_table(p, kind, topic)


def _comment_fields(path) -> dict:
    """``key=value`` pairs of the comment lines (``#``) at the top of a file, separated by
    ``;`` (``# sensor=LN200; sample_rate_hz=400; n_samples=8640000``)."""
    raw = _file_bytes(Path(path))
    out = {}
    for line in raw[:65536].decode("utf-8", "replace").splitlines():
        if not line.startswith("#"):
            break
        for part in line[1:].split(";"):
            if "=" in part:
                k, v = part.split("=", 1)
                out[k.strip()] = v.strip()
    return out


def read_curve(path, ci: float | None = None, with_header: bool = False):
    """Read an Allan deviation curve: ``tau_s``, ``adev_<unit>``, optionally
    ``adev_ci_low_<unit>``/``adev_ci_high_<unit>`` (or ``adev_low_``/``adev_high_``) and an
    ``axis`` column. Returns ``{axis: (taus s, adev rad/s, low rad/s or None, high or None)}``
    and the unit suffix (and, with ``with_header``, the ``key=value`` fields of its comment
    lines)."""
    if with_header:
        header = _comment_fields(path)
        curves, unit = read_curve(path, ci)
        return curves, unit, header
    frame, first_line = _read_frame(path)
    if "tau_s" not in frame.columns:
        raise LogError(f"{path}: missing column 'tau_s'; columns: {', '.join(frame.columns)}")
    adev_cols = [c for c in frame.columns if c.startswith("adev_") and not re.match(
        r"adev_(ci_)?(low|high)_", c)]
    if len(adev_cols) != 1:
        raise LogError(f"{path}: expected exactly one column adev_<unit> (e.g. adev_dps), "
                       f"found {adev_cols or 'none'}")
    col = adev_cols[0]
    unit = col[5:].lower()
    if unit not in GYRO_UNITS or GYRO_UNITS[unit] is None:
        raise LogError(f"{path}: column {col!r}: unknown unit {unit!r}; known: "
                       f"{', '.join(u for u, f in GYRO_UNITS.items() if f is not None)}")
    factor = GYRO_UNITS[unit]
    low = high = None
    for lo_name, hi_name in ((f"adev_ci_low_{col[5:]}", f"adev_ci_high_{col[5:]}"),
                             (f"adev_low_{col[5:]}", f"adev_high_{col[5:]}")):
        if lo_name in frame.columns or hi_name in frame.columns:
            if not (lo_name in frame.columns and hi_name in frame.columns):
                raise LogError(f"{path}: give both {lo_name!r} and {hi_name!r} or neither")
            low, high = lo_name, hi_name
    if low is not None and ci is None:
        raise LogError(f"{path}: the curve has interval columns; give their probability "
                       "content with --curve-ci (e.g. 0.95 for 95 % bounds)")
    taus = _numeric(path, frame, "tau_s", first_line)
    adev = _numeric(path, frame, col, first_line) * factor
    lo = None if low is None else _numeric(path, frame, low, first_line) * factor
    hi = None if high is None else _numeric(path, frame, high, first_line) * factor
    axes = frame["axis"].astype(str).to_numpy() if "axis" in frame.columns else \
        np.array(["curve"] * len(frame))
    out = {}
    for ax in dict.fromkeys(axes):
        sel = axes == ax
        rows = np.flatnonzero(sel)
        bad = np.flatnonzero((taus[sel] <= 0) | (adev[sel] <= 0))
        if bad.size:
            raise LogError(f"{path}: {first_line(rows[bad[0]])}: tau_s and {col} must be "
                           "positive")
        if sel.sum() < 3:
            raise LogError(f"{path}: axis {ax!r}: {int(sel.sum())} points; at least 3 needed")
        if np.unique(taus[sel]).size != sel.sum():
            raise LogError(f"{path}: axis {ax!r}: duplicated tau_s")
        out[ax] = (taus[sel], adev[sel], None if lo is None else lo[sel],
                   None if hi is None else hi[sel])
    return out, unit


# ---------------------------------------------------------------------------------------------
# Writing: temporary files, renamed into place at the end
# What each command recognises as its own output: only such a file is ever replaced (and only
# with --overwrite); anything else at an output path is refused.
_RECOGNISE_MAX_BYTES = 50_000_000
_COMPENSATED_COLUMN = re.compile(r"^(gyro_[xyz]_comp_[a-z0-9_]+|gyro_[xyz]_cal_dps|"
                                 r"acc_[xyz]_cal_mps2)$")


def _json_format(path: Path):
    """The ``format`` key of a small JSON object file, else None."""
    try:
        if path.stat().st_size > _RECOGNISE_MAX_BYTES:
            return None
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc.get("format") if isinstance(doc, dict) else None


def _starts_with(path: Path, magic: bytes) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(len(magic)) == magic
    except OSError:
        return False


def _is_model_manifest(path: Path) -> bool:
    return _json_format(path) in ("fogbench-log-model", "fogbench-triad-model")


def _is_fogcomp_model(path: Path) -> bool:
    if path.suffix == ".npz":        # the array half of a pair: a zip beside its own JSON half
        return _starts_with(path, b"PK") and _json_format(path.with_suffix(".json")) in (
            "fogcomp-model", None) and not path.with_suffix(".json").is_dir()
    return _json_format(path) == "fogcomp-model"


def _is_allan_json(path: Path) -> bool:
    return _json_format(path) == "fogbench-allan"


def _is_compensated_csv(path: Path) -> bool:
    """A CSV (gzip or not) whose header has the columns ``compensate`` adds."""
    try:
        opener = gzip.open if _starts_with(path, b"\x1f\x8b") else open
        with opener(path, "rt", encoding="utf-8", newline="") as f:
            header = next(csv.reader([f.readline(100_000)]), [])
    except (OSError, ValueError, EOFError):
        return False
    return any(_COMPENSATED_COLUMN.match(c.strip()) for c in header)


# ---------------------------------------------------------------------------------------------
# allan
def _plot(path_tmp: str, title: str, curve: dict, model, interval_label: str) -> None:
    import matplotlib.pyplot as plt

    from .noise_report import figure

    fig = figure(title, curve["taus"], curve["adev"], curve["low"], curve["high"], model,
                 interval_label)
    fig.savefig(path_tmp, format="png", dpi=110)
    plt.close(fig)


def _curve_record(path, header: dict, fs, samples) -> tuple[float, int]:
    """The sample rate and length of the record a given curve came from: ``--fs`` /
    ``--samples``, else the curve file's first line (``# ...; sample_rate_hz=400;
    n_samples=8640000; ...``, as the curves in shared/realdata carry them)."""
    def number(key, kind):
        v = header.get(key)
        if v is None:
            return None
        try:
            x = kind(float(v)) if kind is int else float(v)
        except ValueError:
            raise LogError(f"{path}: line 1: {key}={v!r} is not a number") from None
        return x

    given = {"--fs": (fs, number("sample_rate_hz", float), "sample_rate_hz"),
             "--samples": (samples, number("n_samples", int), "n_samples")}
    for flag, (flag_v, file_v, key) in given.items():
        if flag_v is not None and file_v is not None and not math.isclose(
                float(flag_v), float(file_v), rel_tol=1e-9):
            _warning(f"{path}: {flag} {_fmt_number(flag_v)} overrides the curve's own "
                     f"{key}={_fmt_number(file_v)} (line 1)")
    fs = fs if fs is not None else number("sample_rate_hz", float)
    samples = samples if samples is not None else number("n_samples", int)
    if fs is None or samples is None:
        raise LogError(f"{path}: the record the curve was computed from is unknown: give --fs "
                       "HZ and --samples N (its sample rate and number of samples: the "
                       "identifier's covariance of the curve's points depends on them), or "
                       "write them in its first line as '# sample_rate_hz=...; n_samples=...'")
    if not (math.isfinite(fs) and fs > 0):
        raise LogError(f"{path}: sample rate {_fmt_number(fs)} Hz: expected a positive number")
    if samples < 8:
        raise LogError(f"{path}: {samples} samples: expected at least 8")
    return float(fs), int(samples)


def _allan_folder(out: _Outputs, args, names) -> dict | None:
    """Check ``--out DIR`` for allan.json and one PNG per name (before any work)."""
    if not args.out:
        return None
    if ".." in Path(args.out).parts:
        raise LogError(f"--out {args.out!r}: a path through '..' is refused; name the folder "
                       "directly")
    protect = [p for p in (args.log, args.curve) if p]
    return out.folder(Path(args.out), protect, marker="allan.json", recognise=_is_allan_json,
                      members=[(f"allan_{n}.png", lambda q: _starts_with(q, b"\x89PNG"))
                               for n in names])


def _cmd_allan(args) -> int:
    from fogcomp.allan import ONE_SIGMA_CI, allan_analysis
    from fogcomp.noise import identify_noise_model, parse_model

    ci = ONE_SIGMA_CI if args.ci is None else args.ci
    if not (0 < ci < 1):
        raise LogError(f"--ci: expected a probability between 0 and 1, got {_fmt_number(ci)}")
    if args.model is not None:
        try:
            parse_model(args.model)
        except ValueError as exc:
            raise LogError(f"--model: {exc}") from None
    for flag, v in (("--samples", args.samples),):
        if v is not None and not args.curve:
            raise LogError(f"{flag}: only with --curve (a log's length is its own)")
    out = _Outputs(args.overwrite, "allan")
    _allan_folder(out, args, [])            # --out: a folder, placeable, not someone else's
    tool_files = _tool_targets(out, args)
    results = []          # (name, curve dict, model, extra json)
    summary = None
    if args.curve:
        if args.log is not None:
            raise LogError("allan: give either LOG.csv or --curve CURVE.csv, not both")
        curves, unit, header = read_curve(args.curve, args.curve_ci, with_header=True)
        fs, samples = _curve_record(args.curve, header, args.fs, args.samples)
        targets = _allan_folder(out, args, list(curves))
        src = args.curve
        for ax, (t, a, lo, hi) in curves.items():
            try:
                model = identify_noise_model(t, a**2, fs, samples, model=args.model, ci=ci)
            except ValueError as exc:
                raise LogError(f"{args.curve}: axis {ax!r}: {exc}") from None
            extra = {}
            if lo is not None:  # where the model lies inside the interval the curve came with
                m_adev = model.model_adev(t)
                inside = (m_adev >= lo) & (m_adev <= hi)
                extra["model_inside_given_interval"] = [bool(x) for x in inside]
            results.append((ax, {"taus": t, "adev": a, "low": lo, "high": hi}, model, extra))
        label = f"{args.curve_ci:.0%} interval (given)" if args.curve_ci else ""
        meta = {"curve_file": str(args.curve), "adev_unit_in_file": unit, "fs_hz": fs,
                "n_samples": samples, "ci": ci}
    else:
        if args.log is None:
            raise LogError("allan: give LOG.csv (or --curve CURVE.csv)")
        chans = args.columns.split(",") if args.columns else None
        if chans is not None:
            for c in chans:
                if not re.fullmatch(r"gyro_[xyz]", c):
                    raise LogError(f"--columns: {c!r} is not a gyro channel (gyro_x, gyro_y, "
                                   "gyro_z)")
        log = read_log(args.log, **_source(args), mapping=args.column,
                       channels=(chans or ["gyro_*"]) + (["acc_*?"] if tool_files else []),
                       fs=args.fs, gaps=args.gaps, time_tolerance=args.time_tolerance,
                       min_samples=MIN_RECORD_SAMPLES)
        if chans is None:
            chans = sorted(c for c in log.channels if c.startswith("gyro_"))
        accs = sorted(c for c in log.channels if c.startswith("acc_"))
        for ch in accs:
            if log.units[ch] == "au":
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is in raw counts (au); "
                               "the Kalibr noise densities need m/s^2 or g (calibrate it "
                               "first, e.g. fogbench calibrate ferraris)")
        for ch in chans:
            if log.units[ch] == "au":
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is in raw counts (au); "
                               "the Allan analysis needs a rate unit (dps, rps, dph)")
            v = log.channels[ch]
            if np.ptp(v) == 0:
                others = [c for c in chans if c != ch]
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is constant "
                               f"({_fmt_number(v[0] / GYRO_UNITS[log.units[ch]])} "
                               f"{log.units[ch]} in all {log.n} rows): a stuck channel has no "
                               "noise to analyse" + (f"; leave it out with --columns "
                                                     f"{','.join(others)}" if others else ""))
        targets = _allan_folder(out, args, [f"{ch}_{log.units[ch]}" for ch in chans])
        src = args.log
        summary = log.describe()
        for ch in chans:
            curve, model = allan_analysis(log.channels[ch], log.fs, ci=ci, model=args.model,
                                          segments=log.segments)
            results.append((f"{ch}_{log.units[ch]}", {
                "taus": curve.taus, "adev": curve.adev, "low": curve.low, "high": curve.high},
                model, {"edf": curve.edf.tolist(), "noise_alpha": curve.alpha.tolist()}))
        acc_models = {}
        for ch in accs if tool_files else []:
            _, acc_models[ch] = allan_analysis(log.channels[ch], log.fs, ci=ci,
                                               segments=log.segments)
        label = f"{ci:.1%} interval (EDF)"
        meta = {"log_file": str(args.log), "fs_hz": log.fs, "n_samples": log.n,
                "duration_s": log.n / log.fs,
                "segments": [[a, b] for a, b in log.segments], "ci": ci}
    if args.curve:
        acc_models = {}
    tool_texts = _tool_texts(tool_files, args, {n: m for n, _, m, _ in results}, acc_models,
                             fs if args.curve else log.fs, src)
    doc = {"format": "fogbench-allan", "version": 2, **meta}
    doc["columns"] = {}
    dph = DEG / 3600.0
    for name, curve, ident, extra in results:
        entry = {"tau_s": [float(x) for x in curve["taus"]],
                 "adev_dph": [float(x / dph) for x in curve["adev"]]}
        if curve["low"] is not None:
            entry["adev_low_dph"] = [float(x / dph) for x in curve["low"]]
            entry["adev_high_dph"] = [float(x / dph) for x in curve["high"]]
        entry.update(extra)
        from .noise_report import model_json

        entry["model_adev_dph"] = [float(x / dph) for x in ident.model_adev(curve["taus"])]
        entry["noise"] = model_json(ident)
        doc["columns"][name] = entry
    try:
        for path, text in tool_texts:
            out.write_text(path, text)
        if targets is not None:
            from .io import json_ready   # a fit on no degrees of freedom has no p-value: null

            out.write_text(targets["allan.json"],
                           json.dumps(json_ready(doc), indent=2, allow_nan=False))
            for name, curve, ident, _ in results:
                out.write(targets[f"allan_{name}.png"],
                          lambda tmp, n=name, c=curve, i=ident: _plot(
                              tmp, f"{Path(src).name}: {n}", c, i, label))
        out.commit()
    finally:
        out.discard()
    if summary:
        print(summary)
    from .noise_report import notes, table

    rows = [(name, ident) for name, _, ident, _ in results]
    print(table(rows))
    for line in notes(rows):
        print(line)
    if targets is not None:
        print(f"wrote {targets['allan.json']} and {len(results)} figure(s) in {args.out}")
    for path, _ in tool_texts:
        print(f"wrote {path}" + ("" if acc_models else " (gyroscope only: the log has no "
                                 "accelerometer columns; fill in the accelerometer_* keys)"))
    return 0


def _tool_targets(out: _Outputs, args) -> list:
    """--kalibr FILE, --openvins FILE: checked before any work (never a file fogbench allan
    did not write, never an input); [(kind, path)]."""
    from .kalibr import check_factor, is_own

    check_factor("--inflate-density", args.inflate_density)
    check_factor("--inflate-walk", args.inflate_walk)
    if not args.imu_topic.startswith("/") or any(c.isspace() for c in args.imu_topic):
        raise LogError(f"--imu-topic {args.imu_topic!r}: expected a ROS topic name such as "
                       "/imu0")
    protect = tuple(p for p in (args.log, args.curve) if p)
    files = []
    for kind in ("kalibr", "openvins"):
        p = getattr(args, kind)
        if p:
            files.append((kind, out.target(Path(p), protect, recognise=is_own,
                                           what=f"{kind} file", flag=f"--{kind}")))
    if len(files) == 2 and Path(files[0][1]).resolve() == Path(files[1][1]).resolve():
        raise LogError("--kalibr and --openvins name the same file; give each its own")
    return files


def _tool_texts(files, args, gyro: dict, acc: dict, fs: float, src) -> list:
    from .kalibr import TEXTS, values_from_models

    values = values_from_models(gyro, acc or None)
    return [(p, TEXTS[kind](values, fs, str(src), topic=args.imu_topic,
                            inflate_density=args.inflate_density,
                            inflate_walk=args.inflate_walk)) for kind, p in files]


# ---------------------------------------------------------------------------------------------
# calibrate
def _earth_rate_body(latitude_deg: float, heading_deg: float, z_up: bool) -> np.ndarray:
    """Earth rate in a level body frame, rad/s: x along the heading, y right, z down (NED-like),
    or with ``z_up`` x forward, y left, z up. Titterton & Weston (2004) eq. 3.72 (NED)."""
    lat, psi = latitude_deg * DEG, heading_deg * DEG
    north, down = EARTH_RATE * math.cos(lat), -EARTH_RATE * math.sin(lat)
    w = np.array([north * math.cos(psi), -north * math.sin(psi), down])
    if z_up:
        w = w * np.array([1.0, -1.0, -1.0])
    return w


def _check_calibrate_flags(args) -> None:
    """Refuse non-finite or implausible numbers in calibrate's flags, naming the flag."""
    def finite(flag, value, unit):
        if value is not None and not math.isfinite(value):
            raise LogError(f"{flag}: expected a finite number in {unit}, got "
                           f"{_fmt_number(value)}")

    finite("--rate-dps", args.rate_dps, "deg/s")
    finite("--heading-deg", args.heading_deg, "deg")
    finite("--latitude-deg", args.latitude_deg, "deg")
    if args.latitude_deg is not None and not -90.0 <= args.latitude_deg <= 90.0:
        raise LogError(f"--latitude-deg: expected a latitude between -90 and 90 deg, got "
                       f"{_fmt_number(args.latitude_deg)}")
    finite("--angle-deg", args.angle_deg, "deg")
    if args.angle_deg is not None and args.angle_deg == 0:
        raise LogError("--angle-deg: the rotations' angle must not be 0")
    lo, hi = G_RANGE_MPS2
    if not (math.isfinite(args.g) and lo <= args.g <= hi):
        raise LogError(f"--g: expected the local gravity in m/s^2 (not in g), between {lo:g} "
                       f"and {hi:g}, got {_fmt_number(args.g)}")


def _one_attitude(log: Log, max_deg: float = 5.0) -> str | None:
    """When the record's accelerometers show a single attitude (the mean specific force of
    each tenth of the record within ``max_deg`` of the overall mean), describe it; else None
    (also when there are no accelerometers in m/s^2 or g)."""
    if not all(f"acc_{a}" in log.channels and log.units[f"acc_{a}"] != "au" for a in "xyz"):
        return None
    f = np.column_stack([log.channels[f"acc_{a}"] for a in "xyz"])
    mean = f.mean(axis=0)
    if not np.linalg.norm(mean) > 0:
        return None
    parts = np.array([c.mean(axis=0) for c in np.array_split(f, min(10, len(f)))])
    cos = parts @ mean / (np.linalg.norm(parts, axis=1) * np.linalg.norm(mean))
    spread = math.degrees(math.acos(float(np.clip(cos.min(), -1.0, 1.0))))
    if spread > max_deg:
        return None
    g = mean / G0
    return (f"the specific force stays within {spread:.2g} deg of ({g[0]:.3f}, {g[1]:.3f}, "
            f"{g[2]:.3f}) g throughout")


def reference_unit(column: str) -> float:
    """rad/s per unit of a reference-rate column (``--reference``), named with its unit."""
    m = re.fullmatch(r"(.+)_(dps|rps|dph|deg_s|rad_s)", column)
    if not m:
        raise LogError(f"--reference {column!r}: name a column with a rate unit suffix (_dps, "
                       "_rps, _dph)")
    return GYRO_UNITS[m.group(2)]


def reference_rate(path, log: Log, column: str) -> np.ndarray:
    """The reference rate of a log's column ``column`` (``--reference``), rad/s."""
    factor = reference_unit(column)
    if column not in log.frame.columns:
        raise LogError(f"{path}: no column {column!r} (--reference)")
    return _numeric(path, log.frame, column, 2) * factor


def _cmd_calibrate(args) -> int:
    import fogcomp

    method = args.method
    if method != "ferraris":
        try:           # a built-in, an entry-point plug-in or module:Class
            fogcomp.get_method(method)
        except KeyError as exc:
            raise LogError(f"calibrate: {exc.args[0]} (or ferraris)") from None
    _check_calibrate_flags(args)
    out = _Outputs(args.overwrite, "calibrate")
    model_path = Path(args.out)
    if model_path.name in ("", ".", "..") or ".." in model_path.parts:
        raise LogError(f"--out {args.out!r}: name the model file (e.g. --out models/kal), not "
                       "a folder; a path through '..' is refused")
    if model_path.suffix == ".json":
        model_path = model_path.with_suffix("")
    manifest = model_path.with_name(model_path.name + ".json")
    out.target(manifest, (args.log,), recognise=_is_model_manifest, what="model file")
    if method == "ferraris":
        return _calibrate_ferraris(args, out, manifest)
    cls = fogcomp.get_method(method)
    refs = [x for x in (args.reference, args.rate_dps, args.static or None) if x is not None]
    if cls.supervised and len(refs) != 1:
        raise LogError(f"calibrate {method}: a supervised method needs exactly one of "
                       "--reference COLUMN, --rate-dps RATE, --static (with --latitude-deg, "
                       "--heading-deg)")
    if not cls.supervised and refs:
        raise LogError(f"calibrate {method}: this method learns from the signal alone; "
                       "--reference / --rate-dps / --static do not apply")
    if args.static and (args.latitude_deg is None or args.heading_deg is None):
        raise LogError("--static: give --latitude-deg and --heading-deg (Earth rate in the body)")
    if cls.random and args.seed is None:
        raise LogError(f"calibrate {method}: the method draws random numbers; give --seed N")
    axes = [f"gyro_{a}" for a in (args.axis or "xyz")]
    header_chans = None
    if args.axis:
        header_chans = list(axes)
    need = list(header_chans or ["gyro_*"])
    if "g" in cls.requires:
        need += ["acc_x", "acc_y", "acc_z"]
    if "temp" in cls.requires or "temp_rate" in cls.requires:
        need += ["temp"]
    log = read_log(args.log, **_source(args), mapping=args.column, channels=need, fs=args.fs,
                   gaps=args.gaps, time_tolerance=args.time_tolerance,
                   min_samples=MIN_RECORD_SAMPLES)
    if header_chans is None:
        axes = sorted(c for c in log.channels if c.startswith("gyro_"))
    paths = {ch: model_path.with_name(f"{model_path.name}.{ch}") for ch in axes}
    for ch, p in paths.items():
        for suffix in (".json", ".npz"):
            out.target(p.with_name(p.name + suffix), (args.log,), recognise=_is_fogcomp_model,
                       what="model file")
    _note(log.describe())
    attitude = _one_attitude(log) if "g" in cls.requires else None
    ref = None
    if args.reference:
        ref = reference_rate(args.log, log, args.reference)
    models = {}
    for ch in axes:
        if log.units[ch] == "au":
            raise LogError(f"{args.log}: column {log.sources[ch]!r} is in raw counts; "
                           f"{method} needs a rate unit")
        if args.rate_dps is not None:
            r = np.full(log.n, args.rate_dps * DEG)
        elif args.static:
            r = np.full(log.n, _earth_rate_body(args.latitude_deg, args.heading_deg,
                                                args.z_up)["xyz".index(ch[-1])])
        else:
            r = ref
        parts, refs_ = [], []
        for a, b in log.segments:
            parts.append(_gyro_data(log, ch, slice(a, b)))
            refs_.append(None if r is None else r[a:b])
        data = fogcomp.GyroData.concatenate(parts) if len(parts) > 1 else parts[0]
        rr = None if r is None else np.concatenate(refs_)
        hp = {"random_state": args.seed} if cls.random else {}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            models[ch] = fogcomp.make_method(method, **hp).fit(data, rr)
        ident = getattr(models[ch], "identifiability_", None)
        if attitude is not None:
            rank = f"rank {ident.rank} of {ident.n_terms}" if ident is not None else ""
            _warning(f"calibrate {method}, {ch}: {args.log} holds one attitude only "
                     f"({attitude}): from one attitude only the bias is identifiable (the bias "
                     "and the g-sensitive terms add up to one constant there); the fitted "
                     "g-sensitivity is not meaningful"
                     + (f" (the fit's {rank} comes from accelerometer noise alone)"
                        if rank else "")
                     + "; calibrate on a record with several attitudes (e.g. six positions)")
            caught = [w for w in caught if not _is_identifiability(w)]
        for w in caught:
            _warning(f"calibrate {method}, {ch}: {w.message}")
    try:
        # every file is written under a temporary name and renamed into place with the others
        # (the manifest last): a failure leaves no model set without its manifest
        entries = {}
        for ch in axes:
            jpath, npath = out.save_model(models[ch], paths[ch])
            pending = dict((final, tmp) for tmp, final in out.pending)
            entries[ch] = {"model": paths[ch].name, "unit": log.units[ch], "method": method,
                           "json_sha256": _file_sha256(pending[jpath]),
                           "npz_sha256": _file_sha256(pending[npath])}
        doc = _sealed({"format": "fogbench-log-model", "version": MANIFEST_VERSION,
                       "method": method, "fs_hz": log.fs, "axes": entries,
                       "calibration_file": str(args.log)})
        out.write_text(manifest, json.dumps(doc, indent=2, allow_nan=False))
        out.commit()
    finally:
        out.discard()
    print(f"calibrate {method}: fitted {', '.join(axes)} on {log.n} samples at {log.fs:g} Hz; "
          f"wrote {manifest} and {len(axes)} model file pair(s)")
    return 0


def _gyro_data(log: Log, ch: str, sl: slice):
    import fogcomp

    g = temp = temp_rate = None
    if all(f"acc_{a}" in log.channels for a in "xyz"):
        if any(log.units[f"acc_{a}"] == "au" for a in "xyz"):
            g = None
        else:
            g = np.column_stack([log.channels[f"acc_{a}"][sl] for a in "xyz"]) / G0
    if "temp" in log.channels:
        temp = log.channels["temp"][sl]
        temp_rate = np.gradient(temp, 1.0 / log.fs) if temp.size > 1 else np.zeros_like(temp)
    return fogcomp.GyroData(rate=log.channels[ch][sl], fs=log.fs, g=g, temp=temp,
                            temp_rate=temp_rate)


#: Scale factor range, SI per SI, of a triad whose columns are in a physical unit (dps, g, ...):
#: a calibration gives values near 1 there; beyond a factor 2 the unit in the header is wrong.
PHYSICAL_SCALE_RANGE = (0.5, 2.0)


def _check_triad(path, log: Log, acc: dict, gyro: dict, cal) -> None:
    """Refuse a triad calibration that contradicts the procedure's physics (swapped or
    mislabelled columns), naming the columns; nothing is written then."""
    from fogcomp.calibration import ferraris_plausibility

    problems = ferraris_plausibility(acc, gyro, cal)
    lo, hi = PHYSICAL_SCALE_RANGE
    for sensor, scale in (("acc", cal.acc_scale), ("gyro", cal.gyro_scale)):
        for j, ax in enumerate("xyz"):
            ch = f"{sensor}_{ax}"
            if log.units[ch] != "au" and not lo <= abs(scale[j]) <= hi:
                problems.append((ch, f"its scale factor comes out {abs(scale[j]):.4g} "
                                     f"{log.units[ch]} per {log.units[ch]} (a physical unit "
                                     f"gives {lo:g} to {hi:g}): is the unit in its name right?"))
    if problems:
        ch, why = problems[0]
        swapped = any(c.startswith("acc_") and "gravity" in w for c, w in problems)
        raise LogError(
            f"{path}: column {log.sources[ch]!r} ({ch}): {why}"
            + (f"; {len(problems) - 1} more such problem(s)" if len(problems) > 1 else "")
            + ("; are the accelerometer and gyro columns swapped? (accelerometer columns: "
               + ", ".join(log.sources[f"acc_{a}"] for a in "xyz") + "; gyro columns: "
               + ", ".join(log.sources[f"gyro_{a}"] for a in "xyz") + ")" if swapped else "")
            + "; nothing was written")


def _calibrate_ferraris(args, out: _Outputs, manifest: Path) -> int:
    from fogcomp.calibration import FERRARIS_PARTS, ferraris_calibration

    if args.angle_deg is None:
        raise LogError("calibrate ferraris: give --angle-deg, the known angle of each rotation "
                       "(signed by the right-hand rule; imucal's default is -360)")
    chans = [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]
    log = read_log(args.log, **_source(args), mapping=args.column, channels=chans, fs=args.fs,
                   gaps="refuse", time_tolerance=args.time_tolerance, min_samples=2)
    _note(log.describe())
    if "part" not in log.frame.columns:
        raise LogError(f"{args.log}: missing column 'part' (x_p, x_a, ..., z_rot), which "
                       "says which position or rotation each row belongs to")
    part = log.frame["part"].astype(str).str.strip().to_numpy()
    known = set(FERRARIS_PARTS)
    unknown = sorted(set(part) - known)
    if unknown:
        i = int(np.flatnonzero(part == unknown[0])[0])
        raise LogError(f"{args.log}: line {i + 2}, column 'part': unknown part {unknown[0]!r}; "
                       f"expected {', '.join(FERRARIS_PARTS)}")
    acc, gyro = {}, {}
    for p in FERRARIS_PARTS:
        sel = part == p
        if sel.sum() < 2:
            raise LogError(f"{args.log}: part {p!r} has {int(sel.sum())} rows; a Ferraris "
                           "session needs every part with at least 2")
        acc[p] = np.column_stack([log.channels[f"acc_{a}"][sel] for a in "xyz"])
        gyro[p] = np.column_stack([log.channels[f"gyro_{a}"][sel] for a in "xyz"])
    cal = ferraris_calibration(acc, gyro, log.fs, args.angle_deg * DEG, g=args.g)
    _check_triad(args.log, log, acc, gyro, cal)
    doc = _sealed({"format": "fogbench-triad-model", "version": MANIFEST_VERSION,
                   "method": "ferraris", "fs_hz": log.fs, "calibration_file": str(args.log),
                   "columns": {ch: {"column": log.sources[ch], "unit": log.units[ch]}
                               for ch in chans},
                   "calibration": cal.to_dict()})
    try:
        out.write_text(manifest, json.dumps(doc, indent=2, allow_nan=False))
        out.commit()
    finally:
        out.discard()
    k = cal.gyro_scale * DEG
    print(f"calibrate ferraris: {log.n} samples at {log.fs:g} Hz, g = {args.g} m/s^2, rotations "
          f"{args.angle_deg:g} deg; gyro scale {k.round(4).tolist()} per deg/s, bias "
          f"{cal.gyro_bias.round(4).tolist()}; wrote {manifest}")
    return 0


# ---------------------------------------------------------------------------------------------
# compensate
#: Version of the model files ``calibrate`` writes (2: checksummed, pinning the per-axis files).
MANIFEST_VERSION = 2


def _canonical_sha256(doc: dict) -> str:
    from fogcomp.base import _canonical_sha256 as sha

    return sha(doc)


def _sealed(doc: dict) -> dict:
    """``doc`` with ``sha256``: the SHA-256 of its canonical JSON (as fogcomp's model files)."""
    return {**doc, "sha256": _canonical_sha256(doc)}


def _file_sha256(path) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _model_error(path, text: str):
    from fogcomp.base import ModelFileError

    return ModelFileError(f"{path}: {text}")


def _key(doc: dict, key: str, kind, path, where: str = ""):
    """``doc[key]`` of the expected kind, else a ModelFileError naming the file and key."""
    name = f"{where}{key}"
    if key not in doc:
        raise _model_error(path, f"missing key {name!r}")
    v = doc[key]
    ok = {"str": isinstance(v, str) and v != "", "dict": isinstance(v, dict),
          "fs": isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
          and v > 0, "sha": isinstance(v, str) and re.fullmatch(r"[0-9a-f]{64}", v) is not None}
    if not ok[kind]:
        what = {"str": "a text", "dict": "a table", "fs": "a positive sample rate in Hz",
                "sha": "a SHA-256 (64 hex digits)"}[kind]
        raise _model_error(path, f"key {name!r} must be {what}, got {v!r}")
    return v


def _load_manifest(path) -> tuple[dict, Path]:
    """A model file of ``calibrate`` read and checked whole: format, version, its own checksum,
    every key with its type. The per-axis files are checked by :func:`_load_axis_models`."""
    p = Path(path)
    if p.suffix != ".json":
        p = p.with_name(p.name + ".json")
    if not p.is_file():
        raise LogError(f"{p}: model file not found (written by fogbench calibrate --out)")
    def no_constant(name):
        raise ValueError(f"{name} is not a number JSON allows")

    try:
        doc = json.loads(p.read_text(encoding="utf-8"), parse_constant=no_constant)
    except RecursionError:
        raise _model_error(p, "not a model file (JSON nested too deeply)") from None
    except ValueError as exc:  # JSON syntax, UTF-8, NaN / Infinity, integers of 4300 digits
        raise _model_error(p, f"not valid JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict) or doc.get("format") not in ("fogbench-log-model",
                                                              "fogbench-triad-model"):
        raise _model_error(p, "key 'format' must be 'fogbench-log-model' or "
                              "'fogbench-triad-model' (a file written by fogbench calibrate)")
    if doc.get("version") != MANIFEST_VERSION:
        raise _model_error(p, f"key 'version' is {doc.get('version')!r}; this fogbench reads "
                              f"{MANIFEST_VERSION} (calibrate again to write it)")
    _key(doc, "sha256", "sha", p)
    if doc["sha256"] != _canonical_sha256(doc):
        raise _model_error(p, "content does not match its checksum, key 'sha256' (the file was "
                              "edited or damaged); calibrate again")
    _key(doc, "method", "str", p)
    _key(doc, "fs_hz", "fs", p)
    if doc["format"] == "fogbench-triad-model":
        if doc["method"] != "ferraris":
            raise _model_error(p, f"key 'method' of a triad calibration must be 'ferraris', "
                                  f"got {doc['method']!r}")
        cols = _key(doc, "columns", "dict", p)
        for ch in [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]:
            entry = _key(cols, ch, "dict", p, "columns.")
            _key(entry, "column", "str", p, f"columns.{ch}.")
            _key(entry, "unit", "str", p, f"columns.{ch}.")
        _key(doc, "calibration", "dict", p)
    else:
        axes = _key(doc, "axes", "dict", p)
        if not axes:
            raise _model_error(p, "key 'axes' must name at least one fitted gyro axis")
        for ch, info in axes.items():
            if not re.fullmatch(r"gyro_[xyz]", ch) or not isinstance(info, dict):
                raise _model_error(p, f"key 'axes.{ch}': expected a gyro axis (gyro_x, gyro_y, "
                                      "gyro_z) with a table")
            for key, kind in (("model", "str"), ("unit", "str"), ("method", "str"),
                              ("json_sha256", "sha"), ("npz_sha256", "sha")):
                _key(info, key, kind, p, f"axes.{ch}.")
            if info["method"] != doc["method"]:
                raise _model_error(p, f"key 'axes.{ch}.method' is {info['method']!r}, the file's "
                                      f"method is {doc['method']!r}")
            if info["unit"] not in GYRO_UNITS or GYRO_UNITS[info["unit"]] is None:
                raise _model_error(p, f"key 'axes.{ch}.unit': expected a rate unit "
                                      f"({', '.join(u for u, f in GYRO_UNITS.items() if f)}), "
                                      f"got {info['unit']!r}")
            if Path(info["model"]).name != info["model"] or \
                    not info["model"].endswith(f".{ch}"):
                raise _model_error(p, f"key 'axes.{ch}.model' must name the {ch} file beside "
                                      f"the model file (ending in '.{ch}', as calibrate writes "
                                      f"it), got {info['model']!r}")
    return doc, p


def _load_axis_models(doc: dict, mpath: Path) -> dict:
    """The per-axis fogcomp models a manifest pins, each checked against the manifest: the
    SHA-256 of both of its files (a swapped, replaced or edited file is refused), its method,
    and its own sample rate where it keeps one (``fs_``)."""
    import fogcomp

    models = {}
    for ch, info in doc["axes"].items():
        stem = mpath.with_name(info["model"])
        for suffix, key in ((".json", "json_sha256"), (".npz", "npz_sha256")):
            f = stem.with_name(stem.name + suffix)
            try:
                digest = _file_sha256(f)
            except OSError as exc:
                raise _model_error(f, f"cannot be read ({exc.strerror or exc}); the model file "
                                      f"{mpath} names it for {ch}") from None
            if digest != info[key]:
                raise _model_error(f, f"does not match the checksum {mpath} pins for {ch} "
                                      f"(key 'axes.{ch}.{key}'): the file was replaced, swapped "
                                      "with another axis' or edited; calibrate again")
        model = fogcomp.load_model(stem)
        if model.name != info["method"]:
            raise _model_error(stem.with_name(stem.name + ".json"),
                               f"holds a {model.name!r} model, {mpath} says {info['method']!r}")
        fs_model = getattr(model, "fs_", None)
        if fs_model is not None and abs(float(fs_model) / float(doc["fs_hz"]) - 1.0) > 1e-9:
            raise _model_error(mpath, f"key 'fs_hz' is {doc['fs_hz']:g} Hz, the {ch} model was "
                                      f"fitted at {float(fs_model):g} Hz")
        models[ch] = model
    return models


#: gzip level of a ``.csv.gz`` output: 1 writes the 10^6-row ADIS log about 5x faster than
#: the default 9 (pandas' and gzip's) for a file about 1.3x larger.
GZIP_LEVEL = 1
_WRITE_CHUNK_ROWS = 100_000


def _progress(total: int, desc: str, unit: str, show: bool):
    """A tqdm bar on stderr, shown only for long work (``show``) on a terminal."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, unit_scale=unit == "row", file=sys.stderr,
                disable=None if show else True, mininterval=0.5, leave=False)


def _write_csv(frame, path, *, gz: bool, progress: bool = False) -> None:
    """Write ``frame`` as CSV (gzip level :data:`GZIP_LEVEL` when ``gz``), header as the
    column names, every number in its shortest round-trip form (the input's values come back
    exactly). pyarrow's CSV writer (about 8x faster than pandas' ``to_csv``) in chunks of
    100,000 rows with a progress bar; pandas for a frame pyarrow cannot convert, or when
    pyarrow is not installed."""
    import contextlib
    import io

    head = io.StringIO()
    csv.writer(head, lineterminator="\n").writerow([str(c) for c in frame.columns])
    try:
        import pyarrow as pa
        import pyarrow.csv as pacsv
    except ImportError:  # pragma: no cover - pyarrow comes with rerun-sdk
        pa = None
    table = None
    if pa is not None:
        try:
            table = pa.Table.from_pandas(frame, preserve_index=False)
        except (pa.ArrowException, TypeError, ValueError):
            table = None
    with open(path, "wb") as raw, \
            (gzip.GzipFile(fileobj=raw, mode="wb", compresslevel=GZIP_LEVEL, mtime=0) if gz
             else contextlib.nullcontext(raw)) as f, \
            _progress(len(frame), "writing", "row", progress) as bar:
        f.write(head.getvalue().encode("utf-8"))
        if table is not None:
            writer = pacsv.CSVWriter(f, table.schema,
                                     write_options=pacsv.WriteOptions(include_header=False))
            for batch in table.to_batches(max_chunksize=_WRITE_CHUNK_ROWS):
                writer.write_batch(batch)
                bar.update(batch.num_rows)
            writer.close()
        else:
            for start in range(0, len(frame), _WRITE_CHUNK_ROWS):
                chunk = frame.iloc[start:start + _WRITE_CHUNK_ROWS]
                f.write(chunk.to_csv(index=False, header=False,
                                     lineterminator="\n").encode("utf-8"))
                bar.update(len(chunk))


#: Significant digits of the columns ``compensate`` adds (as ``%.10g``): a relative
#: resolution of 5e-10, far below any gyro's noise; the input's columns are written back exactly.
ADDED_DIGITS = 10


def _significant(x, digits: int = ADDED_DIGITS) -> np.ndarray:
    """``x`` rounded to ``digits`` significant digits (the float nearest to the decimal that
    ``'%.{digits}g' % x`` prints, so the CSV writer's shortest form has at most ``digits``).

    Parameters
    ----------
    x : array_like, shape (n,)
        Finite or non-finite numbers (zeros and non-finite values are kept as they are).
    digits : int
        Significant digits, 1 to 15.
    """
    x = np.asarray(x, dtype=float)
    out = x.copy()
    ok = np.isfinite(x) & (x != 0)
    p = digits - 1 - np.floor(np.log10(np.abs(x[ok])))
    # 10^|p| is an exact double up to 10^22: then one correctly rounded operation gives the
    # double nearest to the decimal; the rare values beyond that range are formatted one by one.
    exact = np.abs(p) <= 22
    v, pe = x[ok][exact], p[exact]
    pos = pe >= 0
    r = np.empty_like(v)
    r[pos] = np.round(v[pos] * 10.0 ** pe[pos]) / 10.0 ** pe[pos]
    r[~pos] = np.round(v[~pos] / 10.0 ** -pe[~pos]) * 10.0 ** -pe[~pos]
    sub = out[ok]
    sub[exact] = r
    sub[~exact] = [float(f"{q:.{digits}g}") for q in x[ok][~exact]]
    out[ok] = sub
    return out


def _compensate_target(out: _Outputs, args, protect) -> Path:
    target = Path(args.out)
    if target.is_dir():
        raise LogError(f"--out {target}: is a directory; --out names the output CSV file "
                       f"(e.g. {target / 'clean.csv'})")
    if not (target.name.lower().endswith(".csv") or target.name.lower().endswith(".csv.gz")):
        raise LogError(f"--out {target}: expected a .csv or .csv.gz file name")
    return out.target(target, tuple(protect), recognise=_is_compensated_csv,
                      what="compensated CSV (with _comp_ or _cal_ columns)")


def _cmd_compensate(args) -> int:
    import pandas as pd

    import fogcomp

    out = _Outputs(args.overwrite, "compensate")
    target = _compensate_target(out, args, (args.log,))
    doc, mpath = _load_manifest(args.model)
    model_files = [mpath]
    if doc["format"] == "fogbench-log-model":
        for info in doc["axes"].values():
            stem = mpath.with_name(info["model"])
            model_files += [stem.with_name(stem.name + ".json"),
                            stem.with_name(stem.name + ".npz")]
    _compensate_target(out, args, (args.log, *model_files))
    frame_new = {}
    if doc["format"] == "fogbench-triad-model":
        from fogcomp.calibration import TriadCalibration

        try:
            cal = TriadCalibration.from_dict(doc["calibration"], f"{mpath}: key 'calibration'")
        except ValueError as exc:
            raise _model_error(mpath, str(exc).removeprefix(f"{mpath}: ")) from None
        cols = doc["columns"]
        chans = [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]
        from_model = {ch: (cols[ch]["column"], cols[ch]["unit"]) for ch in chans if ch in cols}
        # Applying a triad calibration does not depend on the sample rate: without a time
        # column and --fs the calibration's own rate stands in (it is only reported).
        log = read_log(args.log, **_source(args), mapping=args.column, channels=chans,
                       fs=args.fs if args.fs else float(doc["fs_hz"]), fs_is_fallback=not args.fs,
                       gaps=args.gaps, time_tolerance=args.time_tolerance, min_samples=1,
                       model_mapping=from_model, model_file=mpath)
        _note(log.describe())
        for ch in chans:
            if log.units[ch] != cols.get(ch, {}).get("unit", log.units[ch]):
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is in "
                               f"{log.units[ch]}, the calibration was made in "
                               f"{cols[ch]['unit']}")
        w, a = cal.calibrate(np.column_stack([log.channels[f"gyro_{x}"] for x in "xyz"]),
                             np.column_stack([log.channels[f"acc_{x}"] for x in "xyz"]))
        for j, x in enumerate("xyz"):
            frame_new[f"gyro_{x}_cal_dps"] = w[:, j] / DEG
        for j, x in enumerate("xyz"):
            frame_new[f"acc_{x}_cal_mps2"] = a[:, j]
    else:
        axes = doc["axes"]
        models = _load_axis_models(doc, mpath)
        need = list(axes)
        reqs = set().union(*(type(m).requires for m in models.values()))
        if "g" in reqs:
            need += ["acc_x", "acc_y", "acc_z"]
        if reqs & {"temp", "temp_rate"}:
            need += ["temp"]
        log = read_log(args.log, **_source(args), mapping=args.column, channels=need, fs=args.fs,
                       gaps=args.gaps, time_tolerance=args.time_tolerance, min_samples=2)
        _note(log.describe())
        if abs(log.fs / float(doc["fs_hz"]) - 1.0) > 1e-6:
            raise LogError(f"{args.log}: sample rate {log.fs:g} Hz differs from the "
                           f"calibration's {doc['fs_hz']:g} Hz ({mpath}); a fitted model is "
                           "tied to its sample rate")
        for ch in models:
            if log.units[ch] == "au":
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is in raw counts")
        with _progress(len(models), "compensating", "axis",
                       log.n >= PROGRESS_MIN_ROWS) as bar:
            for ch, m in models.items():
                unit = log.units[ch]
                comp = np.empty(log.n)
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    for a, b in log.segments:
                        try:
                            comp[a:b] = m.compensate(_gyro_data(log, ch, slice(a, b)))
                        except (fogcomp.DivergenceError, ValueError) as exc:
                            raise LogError(f"{args.log}: the {m.name} model ({mpath}) cannot "
                                           f"compensate {ch} (column {log.sources[ch]!r}, lines "
                                           f"{a + 2}-{b + 1}): {exc}") from None
                for w in caught:
                    _warning(f"compensate, {ch}: {w.message}")
                frame_new[f"{ch}_comp_{unit}"] = comp / GYRO_UNITS[unit]
                bar.update(1)
    clash = [c for c in frame_new if c in log.frame.columns]
    if clash:
        raise LogError(f"{args.log}: already has column {clash[0]!r}; compensating it again "
                       "would overwrite it")
    for col, v in frame_new.items():
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise LogError(f"{args.log}: line {bad[0] + 2}: the compensated {col} is not finite "
                           f"({bad.size} rows); the log's values are beyond what the model "
                           "can apply to (check the units of the input columns)")
    frame_new = {k: _significant(v) for k, v in frame_new.items()}
    result = pd.concat([log.frame, pd.DataFrame(frame_new, index=log.frame.index)], axis=1)
    try:
        out.write(target, lambda tmp: _write_csv(result, tmp,
                                                 gz=target.name.lower().endswith(".gz"),
                                                 progress=log.n >= PROGRESS_MIN_ROWS))
        out.commit()
    finally:
        out.discard()
    print(f"compensate: {log.n} rows, added {', '.join(frame_new)}; wrote {target}")
    return 0


# ---------------------------------------------------------------------------------------------
# argparse
def _source(args) -> dict:
    """--format and --topic as read_log's keywords."""
    return {"fmt": getattr(args, "format", None), "topic": getattr(args, "topic", None)}


def _common(p) -> None:
    p.add_argument("--format", choices=("csv", "euroc", "rosbag", "ulog"),
                   help="the log's format (default: recognised from the file: a CSV, a "
                   "EuRoC/TUM-VI imu0/data.csv, a ROS 1/2 bag or MCAP file, a PX4 ULog)")
    p.add_argument("--topic", help="a bag's sensor_msgs/msg/Imu topic, or a ULog's "
                   "sensor_gyro, sensor_gyro:1, sensor_combined (default: the only one)")
    p.add_argument("--column", action="append", metavar="CH=HEADER:UNIT",
                   help="map a file column to a channel, e.g. gyro_z=GyroZ:dps (repeatable, or "
                        "comma-separated)")
    p.add_argument("--fs", type=float, help="sample rate, Hz (when the log has no time column)")
    p.add_argument("--gaps", choices=("refuse", "split"), default="refuse",
                   help="a gap in the time column: refuse the file (default) or split at it")
    p.add_argument("--time-tolerance", type=float, default=0.05,
                   help="largest relative departure of a sample interval from the median one "
                        "(default 0.05)")


def add_commands(subparsers) -> None:
    """Add ``allan``, ``calibrate`` and ``compensate`` to a ``fogbench`` argparse subparsers
    object; each sets ``func`` to a function of the parsed args returning the exit code."""
    a = subparsers.add_parser("allan", help="Allan deviation, confidence intervals and noise "
                              "terms of a gyro log (or of a given curve)")
    a.add_argument("log", nargs="?", help="log CSV (gzip accepted)")
    a.add_argument("--columns", help="gyro channels to analyse, comma-separated (default all)")
    a.add_argument("--out", help="folder for allan.json and one PNG per axis")
    a.add_argument("--curve", help="identify the noise terms of a given curve instead "
                   "(tau_s, adev_<unit>, optional adev_ci_low_/high_<unit>, optional axis; its "
                   "record's sample rate and length from --fs/--samples or its first line)")
    a.add_argument("--curve-ci", type=float,
                   help="probability content of the curve's interval columns (e.g. 0.95)")
    a.add_argument("--ci", type=float, help="probability content of the computed intervals "
                   "(default 0.683, one sigma)")
    a.add_argument("--model", help="a stated noise model, e.g. 'N + B + K' or 'N + GM + GM' "
                   "(terms Q, N, B, K, R, GM): fitted as stated, no selection")
    a.add_argument("--samples", type=int, help="--curve: number of samples of the record the "
                   "curve came from (default: its first line's n_samples=)")
    a.add_argument("--overwrite", action="store_true", help="replace the outputs of an earlier "
                   "fogbench allan in --out (recognised by its allan.json; nothing else)")
    a.add_argument("--kalibr", metavar="IMU.yaml", help="write Kalibr's imu.yaml: noise "
                   "density (Allan N) and random walk (K) of the gyroscopes and, when the log "
                   "has them, the accelerometers, SI, and update_rate")
    a.add_argument("--openvins", metavar="kalibr_imu_chain.yaml", help="the same values as "
                   "OpenVINS' kalibr_imu_chain.yaml")
    a.add_argument("--imu-topic", default="/imu0", help="rostopic written in --kalibr and "
                   "--openvins (default /imu0)")
    a.add_argument("--inflate-density", type=float, default=1.0, help="multiply the noise "
                   "densities written by this factor (default 1: none; stated in the file)")
    a.add_argument("--inflate-walk", type=float, default=1.0, help="multiply the random walks "
                   "written by this factor (default 1: none; stated in the file)")
    _common(a)
    a.set_defaults(func=_warnings_as_lines(_cmd_allan))

    c = subparsers.add_parser("calibrate", help="fit a fogcomp method, or the Ferraris "
                              "six-position + three-rotation triad calibration, on a record")
    c.add_argument("method", help="a fogcomp method name, or 'ferraris'")
    c.add_argument("log", help="calibration record CSV")
    c.add_argument("--out", required=True, help="model path (writes MODEL.json [+ per axis])")
    c.add_argument("--axis", choices=("x", "y", "z"), help="only this gyro axis")
    c.add_argument("--reference", help="column holding the applied rate (e.g. table_rate_dps)")
    c.add_argument("--rate-dps", type=float, help="constant applied rate, deg/s")
    c.add_argument("--static", action="store_true", help="at rest: the Earth rate is applied")
    c.add_argument("--latitude-deg", type=float, help="latitude for --static, deg, -90 to 90")
    c.add_argument("--heading-deg", type=float, help="heading of the x axis for --static, deg "
                   "from north, clockwise")
    c.add_argument("--z-up", action="store_true", help="--static body frame x forward, y left, "
                   "z up (default x forward, y right, z down)")
    c.add_argument("--seed", type=int, help="seed of methods that draw random numbers")
    c.add_argument("--angle-deg", type=float, help="ferraris: angle of each rotation, deg")
    c.add_argument("--g", type=float, default=G0, help="ferraris: local gravity in m/s^2 (not "
                   "in g), 9.7 to 9.9 (default 9.80665; imucal uses 9.81)")
    c.add_argument("--overwrite", action="store_true", help="replace a model written by an "
                   "earlier fogbench calibrate (recognised by its format key; nothing else)")
    _common(c)
    c.set_defaults(func=_warnings_as_lines(_cmd_calibrate))

    m = subparsers.add_parser("compensate", help="apply a model from fogbench calibrate to a log")
    m.add_argument("model", help="MODEL(.json) written by fogbench calibrate")
    m.add_argument("log", help="log CSV")
    m.add_argument("--out", required=True, help="output CSV (.csv or .csv.gz)")
    m.add_argument("--overwrite", action="store_true", help="replace a CSV written by an "
                   "earlier fogbench compensate (recognised by its _comp_/_cal_ columns; "
                   "nothing else, never an input)")
    _common(m)
    m.set_defaults(func=_warnings_as_lines(_cmd_compensate))
