"""``fogbench allan``: the Allan deviation of a log's gyro channels (or of a given curve), its
intervals, the identified noise terms, figures, and Kalibr / OpenVINS noise files."""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fogbench.formats.curve import read_curve
from fogbench.formats.errors import LogError
from fogbench.formats.table import DEG, GYRO_UNITS
from fogbench.formats.table import fmt_number as _fmt_number
from fogbench.outputs.folders import Outputs as _Outputs
from fogbench.outputs.folders import json_format as _json_format
from fogbench.outputs.folders import starts_with as _starts_with
from fogbench.console import warn
from fogbench.logs.options import LogOptions


def _is_allan_json(path: Path) -> bool:
    return _json_format(path) == "fogbench-allan"


def _plot(path_tmp: str, title: str, curve: dict, model, interval_label: str) -> None:
    import matplotlib.pyplot as plt

    from fogbench.report.noise import figure

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
            warn(f"{path}: {flag} {_fmt_number(flag_v)} overrides the curve's own "
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


def _allan_folder(out: _Outputs, opts, names) -> dict | None:
    """Check ``--out DIR`` for allan.json and one PNG per name (before any work)."""
    if not opts.out:
        return None
    if ".." in Path(opts.out).parts:
        raise LogError(f"--out {opts.out!r}: a path through '..' is refused; name the folder "
                       "directly")
    protect = [p for p in (opts.log, opts.curve) if p]
    return out.folder(Path(opts.out), protect, marker="allan.json", recognise=_is_allan_json,
                      members=[(f"allan_{n}.png", lambda q: _starts_with(q, b"\x89PNG"))
                               for n in names])


@dataclass(frozen=True)
class AllanOptions(LogOptions):
    """What ``fogbench allan`` is asked: a ``log`` (or a given ``curve`` with its interval's
    probability ``curve_ci`` and record length ``samples``), the gyro ``columns``
    ("gyro_x,gyro_z"; None: every one), the intervals' probability ``ci`` (None: one sigma), a
    stated noise ``model``; outputs: the folder ``out`` (allan.json and a PNG per axis), Kalibr's
    ``kalibr`` and OpenVINS' ``openvins`` files (``imu_topic``, ``inflate_density``,
    ``inflate_walk``), replacing earlier ones of its own with ``overwrite``."""

    log: str | None = None
    columns: str | None = None
    out: str | None = None
    curve: str | None = None
    curve_ci: float | None = None
    ci: float | None = None
    model: str | None = None
    samples: int | None = None
    overwrite: bool = False
    kalibr: str | None = None
    openvins: str | None = None
    imu_topic: str = "/imu0"
    inflate_density: float = 1.0
    inflate_walk: float = 1.0
    consistency: bool = False
    holdout: float = 0.5
    inflate_measured: bool = False


def _check_flags(opts: AllanOptions) -> float:
    """The flags checked before any work; returns the intervals' probability."""
    from fogcomp.allan import ONE_SIGMA_CI
    from fogcomp.noise import parse_model

    ci = ONE_SIGMA_CI if opts.ci is None else opts.ci
    if not (0 < ci < 1):
        raise LogError(f"--ci: expected a probability between 0 and 1, got {_fmt_number(ci)}")
    if opts.model is not None:
        try:
            parse_model(opts.model)
        except ValueError as exc:
            raise LogError(f"--model: {exc}") from None
    if opts.samples is not None and not opts.curve:
        raise LogError("--samples: only with --curve (a log's length is its own)")
    if opts.curve and opts.log is not None:
        raise LogError("allan: give either LOG.csv or --curve CURVE.csv, not both")
    if not opts.curve and opts.log is None:
        raise LogError("allan: give LOG.csv (or --curve CURVE.csv)")
    if (opts.consistency or opts.inflate_measured) and opts.curve:
        raise LogError("--consistency: needs a log (the filter runs over its samples), not "
                       "--curve")
    if not 0.05 <= opts.holdout <= 0.95:
        raise LogError(f"--holdout: expected the fraction of the log held out, 0.05 to 0.95, "
                       f"got {_fmt_number(opts.holdout)}")
    if opts.inflate_measured and (opts.inflate_density != 1.0 or opts.inflate_walk != 1.0):
        raise LogError("--inflate-measured: give it alone, not with --inflate-density or "
                       "--inflate-walk (the factor is the measured one)")
    if opts.inflate_measured and not (opts.kalibr or opts.openvins):
        raise LogError("--inflate-measured: inflates the values of --kalibr / --openvins; "
                       "name one of them")
    return ci


def _from_curve(opts: AllanOptions, out: _Outputs, ci: float):
    """The noise terms of each axis of a given curve: (results, meta, interval label, output
    targets, sample rate)."""
    from fogcomp.noise import identify_noise_model

    curves, unit, header = read_curve(opts.curve, opts.curve_ci, with_header=True)
    fs, samples = _curve_record(opts.curve, header, opts.fs, opts.samples)
    targets = _allan_folder(out, opts, list(curves))
    results = []
    for ax, (t, a, lo, hi) in curves.items():
        try:
            model = identify_noise_model(t, a**2, fs, samples, model=opts.model, ci=ci)
        except ValueError as exc:
            raise LogError(f"{opts.curve}: axis {ax!r}: {exc}") from None
        extra = {}
        if lo is not None:  # where the model lies inside the interval the curve came with
            m_adev = model.model_adev(t)
            inside = (m_adev >= lo) & (m_adev <= hi)
            extra["model_inside_given_interval"] = [bool(x) for x in inside]
        results.append((ax, {"taus": t, "adev": a, "low": lo, "high": hi}, model, extra))
    label = f"{opts.curve_ci:.0%} interval (given)" if opts.curve_ci else ""
    meta = {"curve_file": str(opts.curve), "adev_unit_in_file": unit, "fs_hz": fs,
            "n_samples": samples, "ci": ci}
    return results, meta, label, targets, fs


def _read_channels(opts: AllanOptions, with_acc: bool):
    """The log and its gyro channels to analyse (and accelerometers, for the noise files),
    each refused in raw counts or stuck."""
    chans = opts.columns.split(",") if opts.columns else None
    if chans is not None:
        for i, c in enumerate(chans):
            m = re.fullmatch(r"(gyro_[xyz])(?:_(.+))?", c.strip(), re.IGNORECASE)
            if not m or (m.group(2) is not None and m.group(2).lower() not in GYRO_UNITS):
                raise LogError(f"--columns: {c!r} is not a gyro channel (gyro_x, gyro_y, "
                               "gyro_z, or a column name with its unit such as gyro_x_dps: "
                               f"{', '.join(GYRO_UNITS)})")
            chans[i] = m.group(1).lower()   # gyro_x_dps, as the results print it: gyro_x
    log = opts.read(opts.log, (chans or ["gyro_*"]) + (["acc_*?"] if with_acc else []))
    if chans is None:
        chans = sorted(c for c in log.channels if c.startswith("gyro_"))
    accs = sorted(c for c in log.channels if c.startswith("acc_"))
    for ch in accs:
        if log.units[ch] == "au":
            raise LogError(f"{opts.log}: column {log.sources[ch]!r} is in raw counts (au); "
                           "the Kalibr noise densities need m/s^2 or g (calibrate it "
                           "first, e.g. fogbench calibrate ferraris)")
    for ch in chans:
        if log.units[ch] == "au":
            raise LogError(f"{opts.log}: column {log.sources[ch]!r} is in raw counts (au); "
                           "the Allan analysis needs a rate unit (dps, rps, dph)")
        v = log.channels[ch]
        if np.ptp(v) == 0:
            others = [c for c in chans if c != ch]
            raise LogError(f"{opts.log}: column {log.sources[ch]!r} is constant "
                           f"({_fmt_number(v[0] / GYRO_UNITS[log.units[ch]])} "
                           f"{log.units[ch]} in all {log.n} rows): a stuck channel has no "
                           "noise to analyse" + (f"; leave it out with --columns "
                                                 f"{','.join(others)}" if others else ""))
    return log, chans, accs


def _from_log(opts: AllanOptions, out: _Outputs, ci: float, with_acc: bool):
    """The Allan deviation and noise terms of each gyro channel of a log (and the
    accelerometers' noise terms for the noise files): (results, meta, label, targets, log,
    accelerometer models)."""
    from fogcomp.allan import allan_analysis

    log, chans, accs = _read_channels(opts, with_acc)
    targets = _allan_folder(out, opts, [f"{ch}_{log.units[ch]}" for ch in chans])
    results = []
    for ch in chans:
        curve, model = allan_analysis(log.channels[ch], log.fs, ci=ci, model=opts.model,
                                      segments=log.segments)
        results.append((f"{ch}_{log.units[ch]}", {
            "taus": curve.taus, "adev": curve.adev, "low": curve.low, "high": curve.high},
            model, {"edf": curve.edf.tolist(), "noise_alpha": curve.alpha.tolist()}))
    acc_models = {}
    for ch in accs if with_acc else []:
        _, acc_models[ch] = allan_analysis(log.channels[ch], log.fs, ci=ci,
                                           segments=log.segments)
    label = f"{ci:.1%} interval (EDF)"
    meta = {"log_file": str(opts.log), "fs_hz": log.fs, "n_samples": log.n,
            "duration_s": log.n / log.fs,
            "segments": [[a, b] for a, b in log.segments], "ci": ci}
    return results, meta, label, targets, log, acc_models


def _allan_doc(meta: dict, results: list) -> dict:
    """``allan.json``: the curves, their intervals and each axis's identified noise model."""
    from fogbench.report.noise import model_json

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
        entry["model_adev_dph"] = [float(x / dph) for x in ident.model_adev(curve["taus"])]
        entry["noise"] = model_json(ident)
        doc["columns"][name] = entry
    return doc


def allan(opts: AllanOptions) -> int:
    """``fogbench allan``: every check before any work, the analysis, then every output
    written together (none when one fails); prints the noise terms. Returns the exit status."""
    ci = _check_flags(opts)
    out = _Outputs(opts.overwrite, "allan")
    _allan_folder(out, opts, [])            # --out: a folder, placeable, not someone else's
    tool_files = _tool_targets(out, opts, tuple(p for p in (opts.log, opts.curve) if p))
    summary = None
    if opts.curve:
        results, meta, label, targets, fs = _from_curve(opts, out, ci)
        acc_models, src = {}, opts.curve
    else:
        results, meta, label, targets, log, acc_models = _from_log(opts, out, ci,
                                                                   bool(tool_files))
        fs, src, summary = log.fs, opts.log, log.describe()
    cons = None
    if opts.consistency or opts.inflate_measured:
        from fogbench.logs.consistency import measure

        # the results are named gyro_x_<unit>: the channel is gyro_x
        cons = measure(log, ["_".join(n.split("_")[:2]) for n, _, _, _ in results],
                       opts.holdout, opts.log, strict=opts.inflate_measured)
    tool_texts = _tool_texts(tool_files, opts, {n: m for n, _, m, _ in results}, acc_models,
                             fs, src, cons)
    doc = _allan_doc(meta, results)
    if cons is not None:
        from fogbench.logs.consistency import consistency_json

        for name, entry in consistency_json(cons, opts.holdout).items():
            doc["columns"][name]["consistency"] = entry
    try:
        for path, text in tool_texts:
            out.write_text(path, text)
        if targets is not None:
            from fogbench.outputs.files import json_ready  # no degrees of freedom: p is null

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
    from fogbench.report.noise import notes, table

    rows = [(name, ident) for name, _, ident, _ in results]
    print(table(rows))
    for line in notes(rows):
        print(line)
    if cons is not None:
        from fogbench.logs.consistency import lines

        for line in lines(cons):
            print(line)
    if targets is not None:
        print(f"wrote {targets['allan.json']} and {len(results)} figure(s) in {opts.out}")
    for path, _ in tool_texts:
        print(f"wrote {path}" + ("" if acc_models else " (gyroscope only: the log has no "
                                 "accelerometer columns; fill in the accelerometer_* keys)"))
    return 0


def _tool_targets(out: _Outputs, opts, protect: tuple) -> list:
    """--kalibr FILE, --openvins FILE: checked before any work (never a file fogbench allan
    did not write, never an input, one of ``protect``); [(kind, path)]. ``opts``: a command's
    options with ``kalibr``, ``openvins``, ``imu_topic``, ``inflate_density`` and
    ``inflate_walk``."""
    from fogbench.formats.kalibr import check_factor, is_own

    check_factor("--inflate-density", opts.inflate_density)
    check_factor("--inflate-walk", opts.inflate_walk)
    if not opts.imu_topic.startswith("/") or any(c.isspace() for c in opts.imu_topic):
        raise LogError(f"--imu-topic {opts.imu_topic!r}: expected a ROS topic name such as "
                       "/imu0")
    files = []
    for kind in ("kalibr", "openvins"):
        p = getattr(opts, kind)
        if p:
            files.append((kind, out.target(Path(p), protect, recognise=is_own,
                                           what=f"{kind} file", flag=f"--{kind}")))
    if len(files) == 2 and Path(files[0][1]).resolve() == Path(files[1][1]).resolve():
        raise LogError("--kalibr and --openvins name the same file; give each its own")
    return files


def _tool_texts(files, opts, gyro: dict, acc: dict, fs: float, src, cons=None) -> list:
    """The noise files' texts; with ``cons`` (--consistency) their comments say how the
    inflation factor was measured, and --inflate-measured applies it to both terms."""
    from fogbench.formats.kalibr import TEXTS, values_from_models

    values = values_from_models(gyro, acc or None)
    fd, fw, notes, applied = opts.inflate_density, opts.inflate_walk, (), False
    if cons is not None:
        from fogbench.logs.consistency import file_notes, measured_factor

        notes = tuple(file_notes(cons, opts.holdout))
        if opts.inflate_measured:
            fd = fw = measured_factor(cons)
            applied = True
    return [(p, TEXTS[kind](values, fs, str(src), topic=opts.imu_topic, inflate_density=fd,
                            inflate_walk=fw, measured=notes, measured_applied=applied))
            for kind, p in files]
