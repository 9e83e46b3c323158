"""Real gyro logs from the command line: ``fogbench allan``, ``calibrate`` and ``compensate``.

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

import json
import math
import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["LogError", "Log", "read_log", "read_curve", "add_commands", "GYRO_UNITS",
           "ACC_UNITS"]

DEG = math.pi / 180.0
G0 = 9.80665
EARTH_RATE = 7.2921150e-5          # rad/s, WGS-84 / IERS

#: Gyro unit suffixes and their factor to rad/s (None: raw counts, no physical unit).
GYRO_UNITS = {"dps": DEG, "deg_s": DEG, "rps": 1.0, "rad_s": 1.0, "dph": DEG / 3600.0,
              "au": None}
#: Accelerometer unit suffixes and their factor to m/s^2.
ACC_UNITS = {"g": G0, "mps2": 1.0, "au": None}
TIME_UNITS = {"s": 1.0, "ms": 1e-3}
TEMP_UNITS = {"c": 1.0}
_KINDS = {"gyro": GYRO_UNITS, "acc": ACC_UNITS}
_HEADER = re.compile(r"^(gyro|acc|accel)_([xyz])(?:_(.*))?$")


class LogError(ValueError):
    """A log file, a curve file or a command-line option is refused (one-line message)."""


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

    @property
    def n(self) -> int:
        return len(self.frame)


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


def _leading_comments(path: Path) -> int:
    import gzip

    opener = gzip.open if path.suffix == ".gz" else open
    k = 0
    try:
        with opener(path, "rt", errors="replace") as f:
            for line in f:
                if line.startswith("#"):
                    k += 1
                else:
                    break
    except OSError as exc:
        raise LogError(f"{path}: cannot be read ({exc})") from None
    return k


def _read_frame(path):
    import pandas as pd

    p = Path(path)
    if not p.is_file():
        raise LogError(f"{path}: file not found")
    skip = _leading_comments(p)
    try:
        frame = pd.read_csv(p, skiprows=skip, compression="infer", skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError,
            EOFError) as exc:
        raise LogError(f"{path}: not a readable CSV file ({str(exc).splitlines()[0]})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    dup = frame.columns[frame.columns.duplicated()]
    if len(dup):
        raise LogError(f"{path}: column {dup[0]!r} appears twice in the header")
    return frame, skip + 2          # line number of data row 0 = skip + 2 (1-based, header)


def _numeric(path, frame, column: str, first_line: int) -> np.ndarray:
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
            what = f"non-finite value {raw!r}"
        n_bad = int(bad.sum())
        raise LogError(f"{path}: line {first_line + i}, column {column!r}: {what}"
                       + (f" ({n_bad} bad cells in this column)" if n_bad > 1 else ""))
    return values


def read_log(path, *, mapping=None, channels=None, fs=None, gaps: str = "refuse",
             time_tolerance: float = 0.05, min_samples: int = 2,
             fs_is_fallback: bool = False) -> Log:
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

    Returns
    -------
    Log
    """
    if gaps not in ("refuse", "split"):
        raise LogError(f"--gaps: expected 'refuse' or 'split', got {gaps!r}")
    if not (math.isfinite(time_tolerance) and 0 < time_tolerance < 0.5):
        raise LogError(f"--time-tolerance: expected a fraction between 0 and 0.5, got "
                       f"{time_tolerance!r}")
    mapped = _parse_mapping(mapping)
    frame, first_line = _read_frame(path)
    if len(frame) == 0:
        raise LogError(f"{path}: no data rows")
    found: dict[str, tuple[str, str]] = {}
    mapped_sources = {src for src, _ in mapped.values()}
    for col in frame.columns:
        m = _HEADER.match(col)
        if col in mapped_sources:
            continue
        if m:
            kind = "acc" if m.group(1) == "accel" else m.group(1)
            ch = f"{kind}_{m.group(2)}"
            if ch in mapped:
                continue
            found[ch] = (col, _check_unit(path, ch, col, m.group(3) and m.group(3).lower()))
        elif col.startswith("time_") or col == "time":
            found["time"] = (col, _check_unit(path, "time", col, col[5:].lower() or None))
        elif col.startswith("temp_") or col == "temp":
            found["temp"] = (col, _check_unit(path, "temp", col, col[5:].lower() or None))
    for ch, (src, unit) in mapped.items():
        if src not in frame.columns:
            raise LogError(f"{path}: --column {ch}={src}:{unit}: no column {src!r}; columns: "
                           f"{', '.join(frame.columns)}")
        found[ch] = (src, _check_unit(path, ch, src, unit))
    wanted = list(channels) if channels is not None else [c for c in found if c != "time"]
    if "gyro_*" in wanted:
        gyros = sorted(c for c in found if c.startswith("gyro_"))
        if not gyros:
            raise LogError(f"{path}: no gyro column (e.g. gyro_x_dps); columns: "
                           f"{', '.join(frame.columns)}; map another name with --column "
                           "gyro_x=HEADER:UNIT")
        i = wanted.index("gyro_*")
        wanted[i:i + 1] = [g for g in gyros if g not in wanted]
    for ch in wanted:
        if ch not in found:
            raise LogError(f"{path}: missing column for {ch} (e.g. {ch}_"
                           f"{next(iter(_unit_table(ch)))}); columns: {', '.join(frame.columns)}"
                           f"; map another name with --column {ch}=HEADER:UNIT")
    values, units, sources = {}, {}, {}
    for ch in wanted:
        src, unit = found[ch]
        v = _numeric(path, frame, src, first_line)
        factor = _unit_table(ch)[unit]
        values[ch] = v if factor is None else v * factor
        units[ch], sources[ch] = unit, src
    n = len(frame)
    segments = [(0, n)]
    if "time" in found:
        src, unit = found["time"]
        t = _numeric(path, frame, src, first_line) * TIME_UNITS[unit]
        if n < 2:
            raise LogError(f"{path}: one row only; a record needs at least {max(2, min_samples)}")
        dt = np.diff(t)
        bad = np.flatnonzero(dt <= 0)
        if bad.size:
            i = int(bad[0])
            word = "duplicated" if dt[i] == 0 else "not increasing"
            raise LogError(f"{path}: line {first_line + i + 1}, column {src!r}: time {word} "
                           f"({t[i + 1]:.10g} after {t[i]:.10g})")
        step = float(np.median(dt))
        fs_t = 1.0 / step
        gap = dt > 1.5 * step
        irregular = (np.abs(dt / step - 1.0) > time_tolerance) & ~gap
        if irregular.any():
            i = int(np.flatnonzero(irregular)[0])
            raise LogError(f"{path}: line {first_line + i + 1}, column {src!r}: irregular "
                           f"sampling, interval {dt[i]:.6g} s vs median {step:.6g} s (more "
                           f"than {time_tolerance:.0%} off; {int(irregular.sum())} such "
                           "intervals); resample the log or raise --time-tolerance")
        if gap.any():
            i = int(np.flatnonzero(gap)[0])
            if gaps == "refuse":
                raise LogError(f"{path}: line {first_line + i + 1}, column {src!r}: gap of "
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
        raise LogError(f"--fs: expected a positive sample rate in Hz, got {fs!r}")
    longest = max(b - a for a, b in segments)
    if longest < min_samples:
        raise LogError(f"{path}: record too short: {longest} samples"
                       + (" in its longest gap-free piece" if len(segments) > 1 else "")
                       + f", this command needs at least {min_samples}")
    return Log(path=str(path), frame=frame, fs=float(fs), channels=values, units=units,
               sources=sources, segments=segments)


def read_curve(path, ci: float | None = None):
    """Read an Allan deviation curve: ``tau_s``, ``adev_<unit>``, optionally
    ``adev_ci_low_<unit>``/``adev_ci_high_<unit>`` (or ``adev_low_``/``adev_high_``) and an
    ``axis`` column. Returns ``{axis: (taus s, adev rad/s, low rad/s or None, high or None)}``
    and the unit suffix."""
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
            raise LogError(f"{path}: line {first_line + rows[bad[0]]}: tau_s and {col} must be "
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
class _Outputs:
    """Collects outputs; :meth:`commit` renames them into place all at once."""

    def __init__(self, overwrite: bool):
        self.overwrite = overwrite
        self.pending: list[tuple[str, Path]] = []

    def target(self, path: Path, protect: tuple = ()) -> Path:
        path = Path(path)
        for p in protect:
            if Path(p).resolve() == path.resolve():
                raise LogError(f"{path}: is an input of this command; choose another output")
        if path.exists() and not self.overwrite:
            raise LogError(f"{path}: exists; not overwritten (give --overwrite to replace it)")
        return path

    def temp(self, path: Path) -> str:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        os.close(fd)
        self.pending.append((tmp, path))
        return tmp

    def write_text(self, path: Path, text: str) -> None:
        with open(self.temp(path), "w") as f:
            f.write(text)

    def commit(self) -> None:
        umask = os.umask(0)
        os.umask(umask)
        for tmp, path in self.pending:
            os.chmod(tmp, 0o666 & ~umask)
            os.replace(tmp, path)
        self.pending.clear()

    def discard(self) -> None:
        for tmp, _ in self.pending:
            if os.path.exists(tmp):
                os.unlink(tmp)
        self.pending.clear()


# ---------------------------------------------------------------------------------------------
# allan
_DS_UNITS = {"N": "deg/sqrt(h)", "B": "deg/h", "K": "deg/h/sqrt(h)", "Q": "arcsec",
             "R": "deg/h/h"}


def _pooled_curve(rate, segments, fs):
    """Overlapping Allan deviation pooled over gap-free segments: the squared second differences
    of every segment are summed and divided by their total number (each segment's own are
    computed inside it); the EDF of independent segments add."""
    from fogcomp.allan import oadev_details

    longest = max(b - a for a, b in segments)
    m_all = 2 ** np.arange(int(math.floor(math.log2((longest - 1) // 2))) + 1)
    sums, counts = np.zeros(m_all.size), np.zeros(m_all.size)
    pieces = []
    for a, b in segments:
        n = b - a
        ok = m_all <= (n - 1) // 2
        if not ok.any():
            continue
        d = oadev_details(rate[a:b], fs, taus=m_all[ok] / fs)
        sums[ok] += d.adev**2 * d.n_terms
        counts[ok] += d.n_terms
        pieces.append((n, ok))
    return np.sqrt(sums / counts), m_all, pieces


def _allan_of(rate, log: Log, ci: float):
    from fogcomp.allan import (AllanCI, allan_analysis, confidence_interval, edf_greenhall,
                               identify_noise_terms)

    if len(log.segments) == 1:
        return allan_analysis(rate, log.fs, ci=ci)
    adev, m_all, pieces = _pooled_curve(rate, log.segments, log.fs)
    taus = m_all / log.fs
    err = adev / np.sqrt(2.0 * np.maximum(sum(n for n, _ in pieces) / m_all - 1.0, 1.0))
    alpha = identify_noise_terms(taus, adev, err).alpha(taus)
    edf = np.zeros(m_all.size)
    for n, ok in pieces:
        for i in np.flatnonzero(ok):
            edf[i] += edf_greenhall(int(alpha[i]), int(m_all[i]), n + 1)
    low, high = confidence_interval(adev, edf, ci)
    curve = AllanCI(taus=taus, adev=adev, low=low, high=high, edf=edf, alpha=alpha, ci=ci,
                    m=m_all, n=sum(n for n, _ in pieces), fs=log.fs)
    return curve, identify_noise_terms(taus, adev, adev_low=low, adev_high=high, ci=ci)


def _fmt_term(term) -> str:
    ds = term.to_datasheet()
    key = next(k for k in ds if not k.endswith("_sigma") and k not in
               ("status", "reason", "tau_range_s"))
    v, s = ds[key], ds[f"{key}_sigma"]
    if term.status == "identified":
        return f"{v:.4g} +- {s:.2g}" if s is not None else f"{v:.4g}"
    if term.status == "upper bound":
        return f"< {v:.4g}"
    return "-"


def _table(rows) -> str:
    head = ["column", "ARW deg/sqrt(h)", "BI deg/h", "RRW deg/h/sqrt(h)", "Q arcsec",
            "ramp deg/h/h"]
    body = [[name] + [_fmt_term(ident.terms[t]) for t in ("N", "B", "K", "Q", "R")]
            for name, ident in rows]
    widths = [max(len(r[i]) for r in [head] + body) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in [head] + body]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _plot(path_tmp: str, title: str, curve, ident, interval_label: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fogcomp.allan import _BASIS, NOISE_TERMS

    dph = DEG / 3600.0
    t = np.asarray(curve["taus"])
    fig, ax = plt.subplots(figsize=(7, 5))
    if curve.get("low") is not None:
        lo = np.maximum(np.asarray(curve["low"]), 1e-300)
        ax.fill_between(t, lo / dph, np.asarray(curve["high"]) / dph, color="C0", alpha=0.25,
                        label=interval_label)
    ax.loglog(t, np.asarray(curve["adev"]) / dph, "o-", color="C0", ms=3, label="Allan deviation")
    tt = np.logspace(math.log10(t.min()), math.log10(t.max()), 200)
    ax.loglog(tt, ident.model_adev(tt) / dph, "-", color="k", lw=1, label="fitted model")
    slopes = {"Q": "-1", "N": "-1/2", "B": "0", "K": "+1/2", "R": "+1"}
    for j, term in enumerate(NOISE_TERMS):
        nt = ident.terms[term]
        if nt.status == "not identified":
            continue
        if term == "B":
            y = np.full_like(tt, nt.value * 0.6643 / dph)
        else:
            y = np.sqrt(_BASIS[term](tt)) * nt.value / dph
        ax.loglog(tt, y, "--", lw=1, label=f"{term} (slope {slopes[term]}): "
                  f"{_fmt_term(nt)} {_DS_UNITS[term]}")
    ax.set_ylim(max(np.min(np.asarray(curve["adev"])) / dph / 5, 1e-12),
                np.max(np.asarray(curve["adev"])) / dph * 3)
    ax.set_xlabel("averaging time tau, s")
    ax.set_ylabel("Allan deviation, deg/h")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path_tmp, format="png", dpi=110)
    plt.close(fig)


def _cmd_allan(args) -> int:
    from fogcomp.allan import ONE_SIGMA_CI, identify_noise_terms

    ci = ONE_SIGMA_CI if args.ci is None else args.ci
    if not (0 < ci < 1):
        raise LogError(f"--ci: expected a probability between 0 and 1, got {ci}")
    out = _Outputs(args.overwrite)
    results = []          # (name, curve dict, ident, extra json)
    if args.curve:
        if args.log is not None:
            raise LogError("allan: give either LOG.csv or --curve CURVE.csv, not both")
        curves, unit = read_curve(args.curve, args.curve_ci)
        src = args.curve
        for ax, (t, a, lo, hi) in curves.items():
            try:
                ident = identify_noise_terms(t, a, adev_low=lo, adev_high=hi,
                                             ci=args.curve_ci if lo is not None else 0.95)
            except ValueError as exc:
                raise LogError(f"{args.curve}: axis {ax!r}: {exc}") from None
            results.append((ax, {"taus": t, "adev": a, "low": lo, "high": hi}, ident, {}))
        label = f"{args.curve_ci:.0%} interval (given)" if args.curve_ci else ""
        meta = {"curve_file": str(args.curve), "adev_unit_in_file": unit}
    else:
        if args.log is None:
            raise LogError("allan: give LOG.csv (or --curve CURVE.csv)")
        chans = args.columns.split(",") if args.columns else None
        if chans is not None:
            for c in chans:
                if not re.fullmatch(r"gyro_[xyz]", c):
                    raise LogError(f"--columns: {c!r} is not a gyro channel (gyro_x, gyro_y, "
                                   "gyro_z)")
        log = read_log(args.log, mapping=args.column, channels=chans or ["gyro_*"], fs=args.fs,
                       gaps=args.gaps, time_tolerance=args.time_tolerance, min_samples=9)
        if chans is None:
            chans = sorted(c for c in log.channels if c.startswith("gyro_"))
        src = args.log
        for ch in chans:
            if log.units[ch] == "au":
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is in raw counts (au); "
                               "the Allan analysis needs a rate unit (dps, rps, dph)")
            curve, ident = _allan_of(log.channels[ch], log, ci)
            results.append((f"{ch}_{log.units[ch]}", {
                "taus": curve.taus, "adev": curve.adev, "low": curve.low, "high": curve.high},
                ident, {"edf": curve.edf.tolist(), "noise_alpha": curve.alpha.tolist()}))
        label = f"{ci:.1%} interval (EDF)"
        meta = {"log_file": str(args.log), "fs_hz": log.fs, "n_samples": log.n,
                "segments": [[a, b] for a, b in log.segments], "ci": ci}
    outdir = Path(args.out) if args.out else None
    targets = {}
    if outdir is not None:
        protect = [p for p in (args.log, args.curve) if p]
        targets["json"] = out.target(outdir / "allan.json", protect)
        for name, *_ in results:
            targets[name] = out.target(outdir / f"allan_{name}.png", protect)
    doc = dict(meta)
    doc["columns"] = {}
    dph = DEG / 3600.0
    for name, curve, ident, extra in results:
        entry = {"tau_s": [float(x) for x in curve["taus"]],
                 "adev_dph": [float(x / dph) for x in curve["adev"]]}
        if curve["low"] is not None:
            entry["adev_low_dph"] = [float(x / dph) for x in curve["low"]]
            entry["adev_high_dph"] = [float(x / dph) for x in curve["high"]]
        entry.update(extra)
        entry["noise"] = ident.to_datasheet()
        doc["columns"][name] = entry
    try:
        if outdir is not None:
            out.write_text(targets["json"], json.dumps(doc, indent=2, allow_nan=False))
            for name, curve, ident, _ in results:
                _plot(out.temp(targets[name]), f"{Path(src).name}: {name}", curve, ident, label)
            out.commit()
    finally:
        out.discard()
    print(_table([(name, ident) for name, _, ident, _ in results]))
    if outdir is not None:
        print(f"wrote {targets['json']} and {len(results)} figure(s) in {outdir}")
    return 0


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


def _cmd_calibrate(args) -> int:
    import fogcomp

    method = args.method
    known = ["ferraris"] + fogcomp.available_methods()
    if method not in known:
        raise LogError(f"calibrate: unknown method {method!r}; available: {', '.join(known)}")
    out = _Outputs(overwrite=True)          # --out MODEL is what the user asked for
    model_path = Path(args.out)
    if model_path.suffix == ".json":
        model_path = model_path.with_suffix("")
    manifest = model_path.with_name(model_path.name + ".json")
    out.target(manifest, (args.log,))
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
    log = read_log(args.log, mapping=args.column, channels=need, fs=args.fs,
                   gaps=args.gaps, time_tolerance=args.time_tolerance, min_samples=16)
    if header_chans is None:
        axes = sorted(c for c in log.channels if c.startswith("gyro_"))
    ref = None
    if args.reference:
        m = re.fullmatch(r"(.+)_(dps|rps|dph|deg_s|rad_s)", args.reference)
        if not m:
            raise LogError(f"--reference {args.reference!r}: name a column with a rate unit "
                           "suffix (_dps, _rps, _dph)")
        if args.reference not in log.frame.columns:
            raise LogError(f"{args.log}: no column {args.reference!r} (--reference)")
        ref = _numeric(args.log, log.frame, args.reference, 2) * GYRO_UNITS[m.group(2)]
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
        models[ch] = fogcomp.make_method(method, **hp).fit(data, rr)
    paths = {ch: model_path.with_name(f"{model_path.name}.{ch}") for ch in axes}
    for ch, p in paths.items():
        out.target(p.with_name(p.name + ".json"), (args.log,))
    doc = {"format": "fogbench-log-model", "version": 1, "method": method, "fs_hz": log.fs,
           "axes": {ch: {"model": paths[ch].name, "unit": log.units[ch]} for ch in axes},
           "calibration_file": str(args.log)}
    try:
        # save_model writes atomically itself; the manifest goes last, so a model directory
        # without a complete manifest is never taken for a finished one.
        for ch in axes:
            fogcomp.save_model(models[ch], paths[ch])
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


def _calibrate_ferraris(args, out: _Outputs, manifest: Path) -> int:
    from fogcomp.calibration import FERRARIS_PARTS, ferraris_calibration

    if args.angle_deg is None:
        raise LogError("calibrate ferraris: give --angle-deg, the known angle of each rotation "
                       "(signed by the right-hand rule; imucal's default is -360)")
    chans = [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]
    log = read_log(args.log, mapping=args.column, channels=chans, fs=args.fs,
                   gaps="refuse", time_tolerance=args.time_tolerance, min_samples=2)
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
    doc = {"format": "fogbench-triad-model", "version": 1, "method": "ferraris",
           "fs_hz": log.fs, "calibration_file": str(args.log),
           "columns": {ch: {"column": log.sources[ch], "unit": log.units[ch]} for ch in chans},
           "calibration": cal.to_dict()}
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
def _load_manifest(path) -> tuple[dict, Path]:
    p = Path(path)
    if p.suffix != ".json":
        p = p.with_name(p.name + ".json")
    if not p.is_file():
        raise LogError(f"{p}: model file not found (written by fogbench calibrate --out)")
    try:
        doc = json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise LogError(f"{p}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") not in ("fogbench-log-model",
                                                              "fogbench-triad-model"):
        raise LogError(f"{p}: key 'format' must be 'fogbench-log-model' or "
                       "'fogbench-triad-model' (a file written by fogbench calibrate)")
    if doc.get("version") != 1:
        raise LogError(f"{p}: key 'version' is {doc.get('version')!r}; this fogbench reads 1")
    return doc, p


def _cmd_compensate(args) -> int:
    import pandas as pd

    import fogcomp

    out = _Outputs(overwrite=True)            # --out CLEAN.csv is what the user asked for
    target = out.target(Path(args.out), (args.log,))
    doc, mpath = _load_manifest(args.model)
    out.target(target, (mpath,))
    frame_new = {}
    if doc["format"] == "fogbench-triad-model":
        from fogcomp.calibration import TriadCalibration

        cal = TriadCalibration.from_dict(doc.get("calibration"), str(mpath))
        cols = doc.get("columns", {})
        chans = [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]
        mapping = list(args.column or [])
        mapped = _parse_mapping(mapping)
        for ch in chans:
            if ch not in mapped and ch in cols:
                mapping.append(f"{ch}={cols[ch]['column']}:{cols[ch]['unit']}")
        # Applying a triad calibration does not depend on the sample rate: without a time
        # column and --fs the calibration's own rate stands in (it is only reported).
        log = read_log(args.log, mapping=mapping, channels=chans,
                       fs=args.fs if args.fs else float(doc["fs_hz"]), fs_is_fallback=not args.fs,
                       gaps=args.gaps, time_tolerance=args.time_tolerance, min_samples=1)
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
        axes = doc.get("axes")
        if not isinstance(axes, dict) or not axes:
            raise LogError(f"{mpath}: key 'axes' must name at least one fitted gyro axis")
        models = {}
        for ch, info in axes.items():
            try:
                models[ch] = fogcomp.load_model(mpath.with_name(info["model"]))
            except (KeyError, TypeError):
                raise LogError(f"{mpath}: key 'axes.{ch}' must have a 'model' entry") from None
        need = list(axes)
        reqs = set().union(*(type(m).requires for m in models.values()))
        if "g" in reqs:
            need += ["acc_x", "acc_y", "acc_z"]
        if reqs & {"temp", "temp_rate"}:
            need += ["temp"]
        log = read_log(args.log, mapping=args.column, channels=need, fs=args.fs,
                       gaps=args.gaps, time_tolerance=args.time_tolerance, min_samples=2)
        if abs(log.fs / float(doc["fs_hz"]) - 1.0) > 1e-6:
            raise LogError(f"{args.log}: sample rate {log.fs:g} Hz differs from the "
                           f"calibration's {doc['fs_hz']:g} Hz ({mpath}); a fitted model is "
                           "tied to its sample rate")
        for ch, m in models.items():
            unit = log.units[ch]
            if unit == "au":
                raise LogError(f"{args.log}: column {log.sources[ch]!r} is in raw counts")
            comp = np.empty(log.n)
            for a, b in log.segments:
                comp[a:b] = m.compensate(_gyro_data(log, ch, slice(a, b)))
            frame_new[f"{ch}_comp_{unit}"] = comp / GYRO_UNITS[unit]
    clash = [c for c in frame_new if c in log.frame.columns]
    if clash:
        raise LogError(f"{args.log}: already has column {clash[0]!r}; compensating it again "
                       "would overwrite it")
    result = pd.concat([log.frame, pd.DataFrame(frame_new, index=log.frame.index)], axis=1)
    try:
        tmp = out.temp(target)
        result.to_csv(tmp, index=False, float_format="%.10g",
                      compression="gzip" if target.suffix == ".gz" else None)
        out.commit()
    finally:
        out.discard()
    print(f"compensate: {log.n} rows, added {', '.join(frame_new)}; wrote {target}")
    return 0


# ---------------------------------------------------------------------------------------------
# argparse
def _common(p) -> None:
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
                   "(tau_s, adev_<unit>, optional adev_ci_low_/high_<unit>, optional axis)")
    a.add_argument("--curve-ci", type=float,
                   help="probability content of the curve's interval columns (e.g. 0.95)")
    a.add_argument("--ci", type=float, help="probability content of the computed intervals "
                   "(default 0.683, one sigma)")
    a.add_argument("--overwrite", action="store_true", help="replace existing output files")
    _common(a)
    a.set_defaults(func=_cmd_allan)

    c = subparsers.add_parser("calibrate", help="fit a fogcomp method, or the Ferraris "
                              "six-position + three-rotation triad calibration, on a record")
    c.add_argument("method", help="a fogcomp method name, or 'ferraris'")
    c.add_argument("log", help="calibration record CSV")
    c.add_argument("--out", required=True, help="model path (writes MODEL.json [+ per axis])")
    c.add_argument("--axis", choices=("x", "y", "z"), help="only this gyro axis")
    c.add_argument("--reference", help="column holding the applied rate (e.g. table_rate_dps)")
    c.add_argument("--rate-dps", type=float, help="constant applied rate, deg/s")
    c.add_argument("--static", action="store_true", help="at rest: the Earth rate is applied")
    c.add_argument("--latitude-deg", type=float, help="latitude for --static, deg")
    c.add_argument("--heading-deg", type=float, help="heading of the x axis for --static, deg "
                   "from north, clockwise")
    c.add_argument("--z-up", action="store_true", help="--static body frame x forward, y left, "
                   "z up (default x forward, y right, z down)")
    c.add_argument("--seed", type=int, help="seed of methods that draw random numbers")
    c.add_argument("--angle-deg", type=float, help="ferraris: angle of each rotation, deg")
    c.add_argument("--g", type=float, default=G0, help="ferraris: gravity, m/s^2 (default "
                   "9.80665; imucal uses 9.81)")
    _common(c)
    c.set_defaults(func=_cmd_calibrate)

    m = subparsers.add_parser("compensate", help="apply a model from fogbench calibrate to a log")
    m.add_argument("model", help="MODEL(.json) written by fogbench calibrate")
    m.add_argument("log", help="log CSV")
    m.add_argument("--out", required=True, help="output CSV (.csv or .csv.gz)")
    _common(m)
    m.set_defaults(func=_cmd_compensate)
