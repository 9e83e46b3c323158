"""``fogbench compensate``: a model from ``fogbench calibrate`` applied to a log, written as the
log's own columns (back exactly) plus the compensated ones, as CSV (gzip by the name)."""

from __future__ import annotations

import csv
import gzip
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fogbench.formats.errors import LogError
from fogbench.formats.table import DEG, GYRO_UNITS, read_log
from fogbench.outputs.folders import Outputs as _Outputs
from fogbench.outputs.folders import starts_with as _starts_with
from fogbench.logs.calibrate import _gyro_data
from fogbench.console import PROGRESS_MIN_ROWS, note, progress_bar, warn
from fogbench.logs.modelfile import _load_axis_models, _load_manifest, _model_error
from fogbench.logs.options import LogOptions

_COMPENSATED_COLUMN = re.compile(r"^(gyro_[xyz]_comp_[a-z0-9_]+|gyro_[xyz]_cal_dps|"
                                 r"acc_[xyz]_cal_mps2)$")


def _is_compensated_csv(path: Path) -> bool:
    """A CSV (gzip or not) whose header has the columns ``compensate`` adds."""
    try:
        opener = gzip.open if _starts_with(path, b"\x1f\x8b") else open
        with opener(path, "rt", encoding="utf-8", newline="") as f:
            header = next(csv.reader([f.readline(100_000)]), [])
    except (OSError, ValueError, EOFError):
        return False
    return any(_COMPENSATED_COLUMN.match(c.strip()) for c in header)


#: gzip level of a ``.csv.gz`` output: 1 writes the 10^6-row ADIS log about 5x faster than
#: the default 9 (pandas' and gzip's) for a file about 1.3x larger.
GZIP_LEVEL = 1
_WRITE_CHUNK_ROWS = 100_000


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
            progress_bar(len(frame), "writing", "row", progress) as bar:
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


@dataclass(frozen=True)
class CompensateOptions(LogOptions):
    """What ``fogbench compensate`` is asked: the ``model`` (MODEL.json from ``fogbench
    calibrate``) applied to the ``log``, written as the CSV ``out`` (.csv or .csv.gz),
    replacing one of its own with ``overwrite``."""

    model: str = ""
    log: str = ""
    out: str = ""
    overwrite: bool = False


def _compensate_target(out: _Outputs, opts: CompensateOptions, protect) -> Path:
    target = Path(opts.out)
    if target.is_dir():
        raise LogError(f"--out {target}: is a directory; --out names the output CSV file "
                       f"(e.g. {target / 'clean.csv'})")
    if not (target.name.lower().endswith(".csv") or target.name.lower().endswith(".csv.gz")):
        raise LogError(f"--out {target}: expected a .csv or .csv.gz file name")
    return out.target(target, tuple(protect), recognise=_is_compensated_csv,
                      what="compensated CSV (with _comp_ or _cal_ columns)")


def _model_files(doc: dict, mpath: Path) -> list[Path]:
    """The files of a model: its manifest and, per axis, its JSON and arrays."""
    files = [mpath]
    if doc["format"] == "fogbench-log-model":
        for info in doc["axes"].values():
            stem = mpath.with_name(info["model"])
            files += [stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz")]
    return files


def _apply_triad(opts: CompensateOptions, doc: dict, mpath: Path):
    """A Ferraris triad calibration applied: (log, new columns)."""
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
    log = read_log(opts.log, fmt=opts.format, topic=opts.topic, mapping=opts.column,
                   channels=chans, fs=opts.fs if opts.fs else float(doc["fs_hz"]),
                   fs_is_fallback=not opts.fs, gaps=opts.gaps,
                   time_tolerance=opts.time_tolerance, min_samples=1, min_piece=1,
                   model_mapping=from_model, model_file=mpath)
    note(log.describe())
    for ch in chans:
        if log.units[ch] != cols.get(ch, {}).get("unit", log.units[ch]):
            raise LogError(f"{opts.log}: column {log.sources[ch]!r} is in "
                           f"{log.units[ch]}, the calibration was made in "
                           f"{cols[ch]['unit']}")
    w, a = cal.calibrate(np.column_stack([log.channels[f"gyro_{x}"] for x in "xyz"]),
                         np.column_stack([log.channels[f"acc_{x}"] for x in "xyz"]))
    new = {}
    for j, x in enumerate("xyz"):
        new[f"gyro_{x}_cal_dps"] = w[:, j] / DEG
    for j, x in enumerate("xyz"):
        new[f"acc_{x}_cal_mps2"] = a[:, j]
    return log, new


def _apply_axis_models(opts: CompensateOptions, doc: dict, mpath: Path):
    """Per-axis fogcomp models applied, gap-free piece by piece: (log, new columns)."""
    import fogcomp

    axes = doc["axes"]
    models = _load_axis_models(doc, mpath)
    need = list(axes)
    reqs = set().union(*(type(m).requires for m in models.values()))
    if "g" in reqs:
        need += ["acc_x", "acc_y", "acc_z"]
    if reqs & {"temp", "temp_rate"}:
        need += ["temp"]
    log = opts.read(opts.log, need, min_samples=2, min_piece=1)
    note(log.describe())
    if abs(log.fs / float(doc["fs_hz"]) - 1.0) > 1e-6:
        raise LogError(f"{opts.log}: sample rate {log.fs:g} Hz differs from the "
                       f"calibration's {doc['fs_hz']:g} Hz ({mpath}); a fitted model is "
                       "tied to its sample rate")
    for ch in models:
        if log.units[ch] == "au":
            raise LogError(f"{opts.log}: column {log.sources[ch]!r} is in raw counts")
    new = {}
    with progress_bar(len(models), "compensating", "axis", log.n >= PROGRESS_MIN_ROWS) as bar:
        for ch, m in models.items():
            unit = log.units[ch]
            comp = np.empty(log.n)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                for a, b in log.segments:
                    try:
                        comp[a:b] = m.compensate(_gyro_data(log, ch, slice(a, b)))
                    except (fogcomp.DivergenceError, ValueError) as exc:
                        raise LogError(f"{opts.log}: the {m.name} model ({mpath}) cannot "
                                       f"compensate {ch} (column {log.sources[ch]!r}, "
                                       f"{log.rows(a)} to {log.rows(b - 1)}): {exc}") from None
            for w in caught:
                warn(f"compensate, {ch}: {w.message}")
            new[f"{ch}_comp_{unit}"] = comp / GYRO_UNITS[unit]
            bar.update(1)
    return log, new


def compensate(opts: CompensateOptions) -> int:
    """``fogbench compensate``: the model read and checked whole, applied to the log, the log's
    own columns written back exactly with the compensated ones beside them. Returns the exit
    status."""
    import pandas as pd

    out = _Outputs(opts.overwrite, "compensate")
    target = _compensate_target(out, opts, (opts.log,))
    doc, mpath = _load_manifest(opts.model)
    _compensate_target(out, opts, (opts.log, *_model_files(doc, mpath)))
    if doc["format"] == "fogbench-triad-model":
        log, frame_new = _apply_triad(opts, doc, mpath)
    else:
        log, frame_new = _apply_axis_models(opts, doc, mpath)
    clash = [c for c in frame_new if c in log.frame.columns]
    if clash:
        raise LogError(f"{opts.log}: already has column {clash[0]!r}; compensating it again "
                       "would overwrite it")
    for col, v in frame_new.items():
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise LogError(f"{opts.log}: {log.rows(bad[0])}: the compensated {col} is not finite "
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
