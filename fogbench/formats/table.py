"""A log's table validated, whatever its format: the channels its column names (or ``--column``)
give, their units (SI inside), magnitudes no sensor measures, the time column (increasing,
regular, gaps refused or split) and the sample rate. Each error (a :class:`LogError`) names the
file, the row in the file's own terms (:class:`~fogbench.formats.detect.Rows`) and the column.

A CSV log's header names carry their units, as the project's own keys do: ``time_s``,
``gyro_x_dps`` / ``_rps`` / ``_dph``, ``acc_x_g`` / ``_mps2`` (``accel_`` is read as ``acc_``),
``temp_c``; ``_au`` marks raw sensor counts (only a calibration such as ``ferraris`` turns them
into physical units). Files with other headers are mapped with ``--column gyro_z=GyroZ:dps``. The
sample rate comes from the time column or from ``--fs``.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fogcomp.units import G0

from fogbench.formats.detect import Rows
from fogbench.formats.csvfile import read_frame
from fogbench.formats.errors import LogError, PlausibilityWarning
from fogbench.formats.euroc import bracketed_column

__all__ = ["Log", "read_log", "GYRO_UNITS", "ACC_UNITS", "TIME_UNITS", "MIN_RECORD_SAMPLES",
           "fmt_number", "numeric"]

DEG = math.pi / 180.0

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

#: Fewest samples a gap-free piece needs to count (``--gaps split``): the shortest averaging
#: time, one sample interval, takes one second difference, of 3 samples. A shorter piece holds
#: no term of any averaging time; it is left out, and a note on stderr counts what was.
MIN_PIECE = 3

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
                           f"{fmt_number(v[i])} C is below absolute zero")
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
                       f"{fmt_number(v[i] / _unit_table(ch)[unit])} {unit} = "
                       f"{peak * scale:.3g} {shown}, which no sensor measures "
                       f"(refused beyond {refuse * scale:.0e} {shown}); check the column's unit")
    if peak > warn:
        warnings.warn(PlausibilityWarning(
            f"{path}: column {column!r} reaches {peak * scale:.4g} {shown} ("
            f"{first_line(i)}), beyond any {'gyro' if kind == 'gyro' else 'accelerometer'}'s "
            f"range ({warn * scale:g} {shown}): is its unit {unit!r} right?"))


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
    rows: Rows = field(default_factory=Rows)   # how a message names row i ("line 12")

    @property
    def n(self) -> int:
        return len(self.frame)

    def describe(self) -> str:
        """One line: samples, the sample rate used (Hz) and the sampled duration (s, h), so a
        time column in the wrong unit shows at once."""
        d = self.n / self.fs
        kept = sum(b - a for a, b in self.segments) if self.segments else self.n
        pieces = f" in {len(self.segments)} gap-free pieces" if len(self.segments) > 1 else ""
        if kept != self.n:
            pieces += f" ({kept} of them analysed{'' if pieces else ', in one piece'})"
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


def fmt_number(x) -> str:
    """A number as a person writes it (``inf``, ``1.5``), never ``np.float64(inf)``."""
    try:
        return f"{float(x):.10g}"
    except (TypeError, ValueError):
        return repr(x)


def numeric(path, frame, column: str, first_line: Rows) -> np.ndarray:
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
            what = f"non-finite value {fmt_number(raw)}"
        n_bad = int(bad.sum())
        raise LogError(f"{path}: {first_line(i)}, column {column!r}: {what}"
                       + (f" ({n_bad} bad cells in this column)" if n_bad > 1 else ""))
    return values


def read_log(path, *, mapping=None, channels=None, fs=None, gaps: str = "refuse",
             time_tolerance: float = 0.05, min_samples: int = 2, min_piece: int = MIN_PIECE,
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
    gaps : {"refuse", "split", "continuous"}
        What to do with an interval more than ``time_tolerance`` off the median one (a gap,
        more than 1.5 median intervals, or a jitter): refuse the file, or cut it there into
        gap-free segments (analysed together by the pooled Allan deviation); "continuous":
        refuse it, for a command that needs one record (its message does not offer
        ``--gaps split``).
    time_tolerance : float
        Largest relative departure of a sample interval from the median one that is not a cut
        (default 0.05; below 0.5, where a jitter could no longer be told from a dropout).
    min_samples : int
        Fewest samples the command needs (in the longest gap-free segment).
    min_piece : int
        Fewest samples of a gap-free piece under ``gaps="split"``: shorter ones are left out
        of ``segments`` and counted in a note on stderr (default :data:`MIN_PIECE`; 1 keeps
        every sample, for a command that works sample by sample).
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
    _check_options(gaps, time_tolerance, fs)
    mapped = _parse_mapping(mapping)
    from_model = {ch: v for ch, v in (model_mapping or {}).items() if ch not in mapped}
    frame, first_line, origin = _read_any(path, fmt, topic)
    if len(frame) == 0:
        raise LogError(f"{path}: no data rows")
    found = _columns(path, frame, mapped, from_model, model_file)
    wanted = _wanted(path, frame, channels, found)
    for ch in [*wanted, *(["time"] if "time" in found else [])]:
        src, unit = found[ch]
        found[ch] = (src, _check_unit(path, ch, src, unit))
    values, units, sources = _channel_values(path, frame, wanted, found, first_line)
    n = len(frame)
    segments = [(0, n)]
    if "time" in found:
        fs, segments = _timing(path, frame, found["time"], first_line, fs, fs_is_fallback,
                               gaps, time_tolerance, min_samples, min_piece)
    elif fs is None:
        raise LogError(f"{path}: no time column (time_s) to take the sample rate from; "
                       "give --fs HZ")
    _check_rate(path, fs, found)
    longest = max(b - a for a, b in segments)
    if longest < min_samples:
        raise LogError(f"{path}: record too short: {longest} samples"
                       + (" in its longest gap-free piece" if len(segments) > 1 else "")
                       + f", this command needs at least {min_samples}")
    return Log(path=str(path), frame=frame, fs=float(fs), channels=values, units=units,
               sources=sources, segments=segments, origin=origin, rows=first_line)


def _channel_values(path, frame, wanted, found, first_line):
    """(values in SI, units as written, source columns) of the ``wanted`` channels, each
    column numeric and its magnitude plausible for its unit."""
    values, units, sources = {}, {}, {}
    for ch in wanted:
        src, unit = found[ch]
        v = numeric(path, frame, src, first_line)
        factor = _unit_table(ch)[unit]
        values[ch] = v if factor is None else v * factor
        units[ch], sources[ch] = unit, src
        if factor is not None:
            _check_magnitude(path, ch, src, unit, values[ch], first_line)
    return values, units, sources


def _check_options(gaps: str, time_tolerance: float, fs) -> None:
    """--gaps, --time-tolerance and --fs checked before the file is read."""
    if gaps not in ("refuse", "split", "continuous"):
        raise LogError(f"--gaps: expected 'refuse' or 'split', got {gaps!r}")
    if not (math.isfinite(time_tolerance) and 0 < time_tolerance < 0.5):
        raise LogError(f"--time-tolerance: expected a fraction between 0 and 0.5, got "
                       f"{time_tolerance!r}")
    if fs is not None and not (math.isfinite(fs) and fs > 0):
        raise LogError(f"--fs: expected a positive, finite sample rate in Hz, got "
                       f"{fmt_number(fs)}")


def _columns(path, frame, mapped: dict, from_model: dict,
             model_file) -> dict[str, tuple[str, str | None]]:
    """Channel -> (column, unit as written) of every channel the header names, ``--column``
    maps or a saved model names; a unit is checked later, only for the channels used."""
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
    return found


def _wanted(path, frame, channels, found: dict) -> list[str]:
    """The channels a command asks for (``gyro_*``: every gyro, at least one; ``acc_*?``:
    every accelerometer there is; ``temp?``: a channel where there is one), each present."""
    wanted = list(channels) if channels is not None else [c for c in found if c != "time"]
    if "gyro_*" in wanted:
        gyros = sorted(c for c in found if c.startswith("gyro_"))
        if not gyros:
            raise LogError(f"{path}: no gyro column (e.g. gyro_x_dps); columns: "
                           f"{', '.join(frame.columns)}; map another name with --column "
                           "gyro_x=HEADER:UNIT")
        i = wanted.index("gyro_*")
        wanted[i:i + 1] = [g for g in gyros if g not in wanted]
        _note_unread(path, frame, found, gyros)
    if "acc_*?" in wanted:     # every accelerometer channel there is, perhaps none
        i = wanted.index("acc_*?")
        wanted[i:i + 1] = sorted(c for c in found if c.startswith("acc_") and c not in wanted)
    # ``temp?``: the channel where the log has it (an optional column)
    wanted = [c.removesuffix("?") for c in wanted
              if not c.endswith("?") or c.removesuffix("?") in found]
    for ch in wanted:
        if ch not in found:
            raise LogError(f"{path}: missing column for {ch} (e.g. {ch}_"
                           f"{next(iter(_unit_table(ch)))}); columns: {', '.join(frame.columns)}"
                           f"; map another name with --column {ch}=HEADER:UNIT")
    return wanted


def _note_unread(path, frame, found: dict, gyros: list[str]) -> None:
    """A note when fewer than three gyro axes are read and the header has numeric columns no
    channel took: a gyro axis under a name not recognised would otherwise go unanalysed
    silently."""
    if len(gyros) >= 3:
        return
    used = {src for src, _ in found.values()}
    unread = [str(c) for c in frame.columns if c not in used and frame[c].dtype.kind in "iuf"]
    if unread:
        from fogbench.console import note

        missing = [a for a in ("gyro_x", "gyro_y", "gyro_z") if a not in gyros]
        note(f"{path}: gyro axes read: {', '.join(found[g][0] for g in gyros)}; columns not "
             f"read: {', '.join(unread)} (a gyro axis under another name? map it with "
             f"--column {missing[0]}=HEADER:UNIT"
             + (f", the axis it is of {', '.join(missing)}" if len(missing) > 1 else "") + ")")


def _timing(path, frame, time_col: tuple[str, str], first_line, fs, fs_is_fallback: bool,
            gaps: str, time_tolerance: float, min_samples: int, min_piece: int = 1):
    """(sample rate, gap-free pieces) from the time column: increasing, regular within the
    tolerance, gaps refused or split at, and ``--fs`` (unless only a fallback) agreeing."""
    src, unit = time_col
    n = len(frame)
    segments = [(0, n)]
    t = numeric(path, frame, src, first_line)
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
    # Beyond the tolerance, an interval breaks the equal spacing the Allan deviation assumes,
    # whether samples are missing (a dropout, more than 1.5 median intervals) or not (a
    # jitter): refused, or under --gaps split a cut like any gap.
    off = np.abs(dt / step - 1.0) > time_tolerance
    if off.any():
        i = int(np.flatnonzero(off)[0])
        if gaps != "split":
            raise LogError(f"{path}: {first_line(i + 1)}, column {src!r}: "
                           + _off_message(t, dt, i, step, gap, off, time_tolerance,
                                          can_split=gaps == "refuse"))
        cuts = np.flatnonzero(off) + 1
        bounds = [0, *cuts.tolist(), n]
        segments = [(a, b) for a, b in zip(bounds[:-1], bounds[1:])]
        kept = [(a, b) for a, b in segments if b - a >= min_piece]
        if len(kept) < len(segments):
            short = [b - a for a, b in segments if b - a < min_piece]
            from fogbench.console import note

            note(f"{path}: {_count(len(short), 'piece')} of {len(segments)} left out, "
                 f"{_count(sum(short), 'sample')} in all: the pieces between its "
                 f"{_count(int(off.sum()), 'cut')} (intervals more than {time_tolerance:.0%} "
                 f"off the median) shorter than {min_piece} samples, the fewest the shortest "
                 f"averaging time (one interval) needs; {_count(len(kept), 'piece')} of "
                 f"{_count(sum(b - a for a, b in kept), 'sample')} analysed together")
        if not kept:
            raise LogError(f"{path}: column {src!r}: no piece of {min_piece} samples or more "
                           f"between its {int(off.sum())} intervals more than "
                           f"{time_tolerance:.0%} off the median {step:.6g} s"
                           + _jitter_advice(dt, step, gap, off, time_tolerance))
        segments = kept
        longest = max(b - a for a, b in kept)
        if longest < min_samples:
            raise LogError(f"{path}: record too short: {longest} samples in its longest "
                           f"gap-free piece, this command needs at least {min_samples} (its "
                           f"{int(off.sum())} intervals more than {time_tolerance:.0%} off the "
                           f"median {step:.6g} s are cuts)"
                           + _jitter_advice(dt, step, gap, off, time_tolerance))
    # The mean interval of the longest gap-free piece: far less sensitive than the median
    # to timestamps rounded to a few decimals.
    a0, b0 = max(segments, key=lambda ab: ab[1] - ab[0])
    if b0 - a0 >= 2:
        fs_t = (b0 - a0 - 1) / (t[b0 - 1] - t[a0])
    if fs is not None and not fs_is_fallback and abs(fs / fs_t - 1.0) > time_tolerance:
        raise LogError(f"{path}: --fs {fs:g} Hz disagrees with the time column "
                       f"{src!r}, which gives {fs_t:.6g} Hz")
    return fs_t, segments


def _count(k: int, word: str) -> str:
    return f"{k} {word}" + ("" if k == 1 else "s")


def _needed_tolerance(dt, step, gap) -> float | None:
    """The smallest tolerance (in hundredths, below 0.5) that takes every interval short of a
    gap as regular, or None when none below 0.5 does."""
    jitter = np.abs(dt[~gap] / step - 1.0)
    if not jitter.size:
        return None
    need = math.floor(float(jitter.max()) * 100.0 + 1.0) / 100.0
    return need if need < 0.5 else None


def _jitter_advice(dt, step, gap, off, time_tolerance: float) -> str:
    """'; ... --time-tolerance T keeps them inside the pieces' when some of the cuts are
    jitter (an interval within 1.5 median ones: no sample missing) a tolerance below 0.5
    accepts, else ''."""
    jitter = off & ~gap
    need = _needed_tolerance(dt, step, gap)
    if not jitter.any() or need is None:
        return ""
    return (f"; {int(jitter.sum())} of them are jitter, not dropouts (under 1.5 intervals, "
            f"no sample missing): --time-tolerance {need:g} keeps them inside the pieces")


def _off_message(t, dt, i: int, step: float, gap, off, time_tolerance: float,
                 can_split: bool = True) -> str:
    """What is wrong with the time column at interval ``i`` (the first beyond the tolerance) and
    what to do: the --gaps refuse error's text after the file and row (``can_split`` False: a
    command that needs one continuous record, which --gaps split cannot give)."""
    if gap[i]:
        head = (f"gap of {dt[i]:.6g} s ({dt[i] / step - 1:.0f} missing samples at {step:.6g} s) "
                f"after time {t[i]:.10g}")
    else:
        head = (f"irregular sampling, interval {dt[i]:.6g} s vs median {step:.6g} s (more than "
                f"{time_tolerance:.0%} off)")
    n_gap, n_jit = int(gap.sum()), int((off & ~gap).sum())
    counts = ", ".join(x for x in (f"{n_gap} gap(s) of more than 1.5 intervals" if n_gap else "",
                                   f"{n_jit} jitter(s) more than {time_tolerance:.0%} off"
                                   if n_jit else "") if x)
    need = _needed_tolerance(dt, step, gap)
    if can_split:
        advice = "use --gaps split to cut the log at each of them and analyse the pieces together"
        later = " (the gaps still need --gaps split)"
    elif n_gap:
        advice = ("this command needs one continuous record: give a gap-free stretch of the "
                  "log")
        later = " (the gaps still need a gap-free stretch)"
    else:
        advice = ("this command needs one regularly sampled record: resample the log to its "
                  "median interval")
        later = ""
    if n_jit and need is not None:
        advice += (f"; --time-tolerance {need:g} takes the jitter as regular"
                   + (later if n_gap else ""))
    return f"{head}; {counts} in all; {advice}"


#: Sample rates of IMU and gyro logs (a FOG's thermal log at 1 Hz, a MEMS part at some kHz);
#: a time column giving a rate outside them is warned of, with the time unit that would give a
#: rate inside (the nanosecond, microsecond, millisecond and second confusions).
USUAL_FS_HZ = (1.0, 20_000.0)


def _unit_hint(fs: float, unit: str | None) -> str:
    """The time unit under which the column's numbers would give a usual sample rate."""
    if unit not in TIME_UNITS:
        return ""
    for other, factor in TIME_UNITS.items():
        alt = fs * TIME_UNITS[unit] / factor
        if other != unit and USUAL_FS_HZ[0] <= alt <= USUAL_FS_HZ[1]:
            return (f"; if its times are in {other}, not {unit}, the rate is {alt:.6g} Hz: "
                    f"name the column time_{other} (or map it with --column "
                    f"time=HEADER:{other})")
    return ""


def _check_rate(path, fs: float, found: dict) -> None:
    """A sample rate that is positive; one outside gyro logs' range refused (beyond what any
    log could be) or warned of, saying the time unit that was assumed and the one that would
    give a usual rate."""
    if not (math.isfinite(fs) and fs > 0):
        raise LogError(f"--fs: expected a positive sample rate in Hz, got {fmt_number(fs)}")
    lo, hi = PLAUSIBLE_FS_HZ
    where = f"the time column {found['time'][0]!r}" if "time" in found else "--fs"
    unit = found["time"][1] if "time" in found else None
    if not lo <= fs <= hi:
        warnings.warn(PlausibilityWarning(
            f"{path}: {where} gives a sample rate of {fs:.6g} Hz, outside the {lo:g} Hz to "
            f"{hi / 1000:g} kHz of gyro logs (its times read as {unit or 's'})"
            + (_unit_hint(fs, unit) or ": is the time unit in its name right?")))
    elif not USUAL_FS_HZ[0] <= fs <= USUAL_FS_HZ[1] and _unit_hint(fs, unit):
        warnings.warn(PlausibilityWarning(
            f"{path}: {where} gives a sample rate of {fs:.6g} Hz, unusual for an IMU or gyro "
            f"log (its times read as {unit})" + _unit_hint(fs, unit)))


#: EuRoC / TUM-VI's imu0/data.csv columns: a file with some of them has all seven.
EUROC_COLUMNS = ("time", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z")


def _check_euroc_columns(path, frame) -> None:
    """A EuRoC-style header (``w_RS_S_x [rad s^-1]``, ...) holds its seven columns: one
    missing is refused naming it (it ran on two axes without a word)."""
    euroc = [c for c in frame.columns if re.match(r"^\s*[wa]_RS_S_[xyz]\s*\[", c)]
    if not euroc:
        return
    have = {bracketed_column(c).rsplit("_", 1)[0] for c in frame.columns
            if bracketed_column(c)}
    missing = [c for c in EUROC_COLUMNS if c not in have]
    if missing:
        names = {"time": "timestamp [ns]", "gyro_x": "w_RS_S_x [rad s^-1]",
                 "gyro_y": "w_RS_S_y [rad s^-1]", "gyro_z": "w_RS_S_z [rad s^-1]",
                 "acc_x": "a_RS_S_x [m s^-2]", "acc_y": "a_RS_S_y [m s^-2]",
                 "acc_z": "a_RS_S_z [m s^-2]"}
        raise LogError(f"{path}: a EuRoC / TUM-VI header without "
                       f"{', '.join(repr(names[c]) for c in missing)}: it has "
                       f"{', '.join(frame.columns)}; a EuRoC imu0/data.csv has all seven "
                       "columns (a damaged or cut file?); give the columns to read with "
                       "--column if it is another format")


def _read_any(path, fmt: str | None, topic: str | None):
    """(frame, Rows, origin) of a log in any format ``fogbench.formats`` reads."""
    from fogbench.formats.detect import FORMATS, detect

    if fmt is not None and fmt not in FORMATS:
        raise LogError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    kind = fmt or detect(path)
    if kind in ("csv", "euroc"):
        if topic is not None:
            raise LogError(f"--topic {topic!r}: {path} is a CSV file; --topic chooses the IMU "
                           "topic of a ROS bag, MCAP or ULog file")
        frame, rows = read_frame(path)
        _check_euroc_columns(path, frame)
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


def read_table(path, fmt: str, topic: str | None):
    """(frame, Rows, description) of a bag or ULog; the CSV formats are read by the caller."""
    if fmt == "rosbag":
        from fogbench.formats.rosbag import read_imu_topic

        return read_imu_topic(path, topic)
    if fmt == "ulog":
        from fogbench.formats.ulog import read_ulog

        return read_ulog(path, topic)
    raise ValueError(fmt)
