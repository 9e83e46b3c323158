"""What ``fogbench device show``, ``schema``, ``fit`` and ``check`` do, each a function of its
options (:class:`ShowOptions`, :class:`FitOptions`, :class:`CheckOptions`): every check before
any work, the outputs written only when every one is complete, replacing only files of their
own."""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fogbench.device.twin import (
    CHECK_CI,
    COVARIANCE_SHRINKAGE,
    MAX_CHECK_REPLICATES,
    _is_check_json,
    _plot_check,
    check_device,
    twin_curves,
)
from fogbench.device.file import (
    TRIAD_NEEDS,
    TriadFit,
    _device_params,
    _entry_interval,
    _is_device_file,
    _toml_value,
    preset_text,
)
from fogbench.device.fit import earth_projection, fit_device
from fogbench.device.logs import (
    _channel,
    _check_reference_flag,
    _read_static_log,
    _static_of,
    gyro_columns,
    _read_curve_axis,
    _read_multipos,
    _read_static,
    _read_thermal,
)
from fogbench.formats.errors import LogError
from fogbench.formats.table import fmt_number as _fmt_number
from fogbench.logs.options import LogOptions
from fogbench.outputs.folders import Outputs as _Outputs
from fogbench.scenario.device_triad import THERMAL_BUILD_KEYS, TRIAD_AXES
from fogcomp.units import DPH, DPS

__all__ = ["ShowOptions", "FitOptions", "CheckOptions", "show", "schema", "fit", "check"]


# ---------------------------------------------------------------------------------------------
# show, schema
@dataclass(frozen=True)
class ShowOptions:
    """``device show``: the preset or device file ``name``; or its noise written as Kalibr's
    ``kalibr`` / OpenVINS' ``openvins`` file at the IMU's ``rate_hz`` (``imu_topic``,
    ``inflate_density``, ``inflate_walk``), replacing one of its own with ``overwrite``."""

    name: str = ""
    kalibr: str | None = None
    openvins: str | None = None
    rate_hz: float | None = None
    imu_topic: str = "/imu0"
    inflate_density: float = 1.0
    inflate_walk: float = 1.0
    overwrite: bool = False


def schema() -> int:
    """Print the JSON Schema of a device file (the ``[fog]`` keys)."""
    from fogbench.scenario.device_file import fog_json_schema

    print(json.dumps(fog_json_schema(), indent=2))
    return 0


def show(opts: ShowOptions) -> int:
    """Print a preset (or a validated device file) as a device file, or write its noise as
    Kalibr / OpenVINS files."""
    p = Path(opts.name)
    is_file = p.suffix == ".toml" or p.exists()
    out = _Outputs(opts.overwrite, "device show")
    files = _noise_file_targets(opts, out)
    if is_file:
        from fogbench.scenario import ScenarioError
        from fogbench.scenario.device_file import load_device_file

        try:
            doc = load_device_file(p)
        except ScenarioError as exc:
            raise LogError(str(exc)) from None
        text = p.read_text(encoding="utf-8-sig")
    else:
        text = preset_text(opts.name)
        doc = {"preset": opts.name}
    if not files:
        sys.stdout.write(text)
        return 0
    _write_noise_files(files, opts, out, doc, str(opts.name))
    return 0


def _noise_file_targets(opts: ShowOptions, out: _Outputs) -> list:
    """--kalibr / --openvins of ``device show``: checked before any work; needs --rate-hz."""
    from fogbench.logs.allan import _tool_targets

    if not (opts.kalibr or opts.openvins):
        if opts.rate_hz is not None:
            raise LogError("--rate-hz: only with --kalibr or --openvins (the update_rate "
                           "written there)")
        return []
    if opts.rate_hz is None or not (math.isfinite(opts.rate_hz) and opts.rate_hz > 0):
        raise LogError("--kalibr/--openvins: give --rate-hz, the rate your IMU runs at (Kalibr's "
                       "update_rate; a device file has no sample rate)")
    return _tool_targets(out, opts, ())


def _write_noise_files(files, opts: ShowOptions, out: _Outputs, doc: dict, source: str) -> None:
    """The device's white rate noise (arw) and rate random walk (rrw), SI from the validated
    [fog] keys, as Kalibr's gyroscope entries; the accelerometer entries left to fill in (a
    device file describes a gyro)."""
    from fogbench.formats.kalibr import TEXTS, NoiseValue
    from fogbench.scenario import ScenarioError
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table

    try:
        params = _fog(_Table(dict(doc), "device file", source), opts.rate_hz)[0]
    except ScenarioError as exc:
        raise LogError(str(exc)) from None
    values = {}
    triad = isinstance(params, tuple)     # a triad device file: Kalibr's one value per sensor
    for term, attr, key in (("N", "arw", "arw_deg_rt_h"), ("K", "rrw", "rrw_dph_rt_h")):
        v = max(float(getattr(p, attr)) for p in (params if triad else (params,)))
        what = (f"the largest {key} over the triad's [x], [y], [z]" if triad
                else f"the device's {key}")
        values["gyroscope", term] = (NoiseValue(v, what, "the gyro", {})
                                     if v > 0 else f"the device has no {key} (0); fill it in")
    for term in ("N", "K"):
        values["accelerometer", term] = ("a device file describes a gyro, not an "
                                         "accelerometer; fill it in")
    try:
        for kind, path in files:
            out.write_text(path, TEXTS[kind](values, opts.rate_hz, source, topic=opts.imu_topic,
                                             inflate_density=opts.inflate_density,
                                             inflate_walk=opts.inflate_walk,
                                             command="device show"))
        out.commit()
    finally:
        out.discard()
    for _, path in files:
        print(f"wrote {path} (gyroscope entries; fill in the accelerometer_* keys)")


# ---------------------------------------------------------------------------------------------
# fit
@dataclass(frozen=True)
class FitOptions(LogOptions):
    """``device fit``: the logs of one gyro (``static`` logs of separate power-ons, an Allan
    ``curve`` with its ``curve_ci`` and ``samples``, a ``thermal`` log, a ``multipos`` log with
    its ``reference`` column and the gyro's ``full_scale_dps``), its ``axis`` column, where the
    static logs were taken (``latitude_deg``, ``input_axis``, ``heading_deg``), the intervals'
    probability ``ci``, the shortest averaging time ``min_tau_s``; the device file ``out``,
    replacing one of its own with ``overwrite``."""

    static: list[str] = field(default_factory=list)
    curve: str | None = None
    thermal: str | None = None
    multipos: str | None = None
    reference: str | None = None
    full_scale_dps: float | None = None
    curve_ci: float | None = None
    samples: int | None = None
    axis: str | None = None
    latitude_deg: float | None = None
    input_axis: str | None = None
    heading_deg: float | None = None
    ci: float | None = None
    min_tau_s: float | None = None
    out: str = ""
    overwrite: bool = False


def _check_where(opts: FitOptions) -> None:
    """--latitude-deg, --input-axis, --heading-deg: together, and in range."""
    if opts.latitude_deg is not None:
        if not (-90 <= opts.latitude_deg <= 90):
            raise LogError(f"--latitude-deg: expected -90 to 90, got "
                           f"{_fmt_number(opts.latitude_deg)}")
        if opts.input_axis is None:
            raise LogError("--latitude-deg: give --input-axis up, down or level (the Earth "
                           "rate's projection on the gyro depends on it)")
        if opts.input_axis == "level" and opts.heading_deg is None:
            raise LogError("--input-axis level: give --heading-deg (the input axis's heading "
                           "from north)")
        if opts.heading_deg is not None:
            if opts.input_axis != "level":
                raise LogError("--heading-deg: only with --input-axis level (a vertical axis "
                               "has no heading)")
            if not (math.isfinite(opts.heading_deg) and -360 <= opts.heading_deg <= 360):
                raise LogError(f"--heading-deg: expected -360 to 360, got "
                               f"{_fmt_number(opts.heading_deg)}")
    elif opts.heading_deg is not None:
        raise LogError("--heading-deg: only with --latitude-deg (and --input-axis level)")
    elif opts.input_axis is not None and not opts.multipos:
        raise LogError("--input-axis: says the static logs' attitude, used with --latitude-deg "
                       "(the Earth rate's projection) or --multipos (the g terms at that "
                       "attitude); alone it would change nothing")


def _log_identity(path) -> tuple:
    """What makes two logs the same: the SHA-256 of the content (of what a gzip file holds),
    else, for a file that cannot be read here, its resolved path (the reader says why)."""
    import gzip
    import hashlib

    p = Path(path)
    if not p.is_file():                     # a folder (a bag), a pipe: never opened here
        return ("path", str(p.resolve()))
    try:
        with open(p, "rb") as f:
            gz = f.read(2) == b"\x1f\x8b"
        h = hashlib.sha256()
        with (gzip.open(p, "rb") if gz else open(p, "rb")) as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        return ("content", h.hexdigest())
    except (OSError, EOFError):
        return ("path", str(p.resolve()))


def _check_fit_flags(opts: FitOptions) -> float:
    """Every flag of ``device fit`` checked before any log is read; returns the intervals'
    probability."""
    from fogcomp.allan import ONE_SIGMA_CI

    if not opts.static and not opts.curve:
        raise LogError("device fit: give at least one --static LOG.csv or --curve CURVE.csv "
                       "(with --thermal or --multipos too: those fits need their noise model)")
    ci = ONE_SIGMA_CI if opts.ci is None else opts.ci
    if not (0 < ci < 1):
        raise LogError(f"--ci: expected a probability between 0 and 1, got {_fmt_number(ci)}")
    _check_where(opts)
    if not opts.curve:
        for flag, v in (("--samples", opts.samples), ("--curve-ci", opts.curve_ci)):
            if v is not None:
                raise LogError(f"{flag}: only with --curve")
    seen = {}
    for p in opts.static:   # the same log twice (or the same bytes under two names, gzipped
        key = _log_identity(p)   # or not) is not two power-ons
        if key in seen:
            raise LogError(f"--static {p}: the same log as {seen[key]} (" + (
                "the same file" if key[0] == "path" else "the same content under another "
                "name") + "); each static log is one power-on")
        seen[key] = p
    if opts.min_tau_s is not None and not (opts.min_tau_s > 0 and math.isfinite(opts.min_tau_s)):
        raise LogError(f"--min-tau-s: expected a positive number of seconds, got "
                       f"{_fmt_number(opts.min_tau_s)}")
    if opts.reference and not opts.multipos:
        raise LogError("--reference: only with --multipos")
    if opts.multipos:
        _check_reference_flag(opts.reference)
    if opts.full_scale_dps is not None:
        if not opts.multipos:
            raise LogError("--full-scale-dps: only with --multipos")
        if not (math.isfinite(opts.full_scale_dps) and 0 < opts.full_scale_dps <= 1e5):
            raise LogError(f"--full-scale-dps: expected a full scale in deg/s (0 to 1e5), got "
                           f"{_fmt_number(opts.full_scale_dps)}")
    return ci


def _read_fit_logs(opts: FitOptions, first=None):
    """(static logs, curve, thermal log, multi-position log) as :func:`fit_device` takes them,
    each log's summary said on stderr, and the multi-position log's gyro axis (None without
    one); its axis and the static logs' must be one. ``first``: the first static log, read
    already (its summary said)."""
    statics = []
    for k, p in enumerate(opts.static):
        if k == 0 and first is not None:
            log = first
            s = _static_of(p, log, _channel(log, opts.axis, p), acc=bool(opts.multipos))
        else:
            s, log = _read_static(p, opts, acc=bool(opts.multipos), temp=bool(opts.thermal))
            print(log.describe(), file=sys.stderr)
        statics.append(_stated_attitude(s, s.axis, opts))
    if len({s.axis for s in statics}) > 1:
        raise LogError("--static: the logs' gyro columns are on different body axes (" + ", ".join(
            f"{s.name}: {s.column}" for s in statics) + "); a device file is one gyro: choose "
            "it with --axis, or map the columns with --column gyro_x=HEADER:UNIT")
    if statics and any(abs(s.fs / statics[0].fs - 1.0) > 1e-3 for s in statics):
        raise LogError("--static: the logs have different sample rates (" + ", ".join(
            f"{s.name}: {s.fs:g} Hz" for s in statics) + "); a device file is fitted at one")
    curve = None
    if opts.curve:
        ax, (t, a, _, _), fs, samples = _read_curve_axis(opts)
        curve = (f"{opts.curve} (axis {ax})", t, a**2, fs, samples)
    thermal = None
    if opts.thermal:
        thermal, tlog = _read_thermal(opts.thermal, opts, acc=bool(opts.multipos))
        print(tlog.describe(), file=sys.stderr)
        thermal = _stated_attitude(thermal, next(c for c in tlog.channels
                                                 if c.startswith("gyro_"))[-1], opts)
    multipos, axis = None, None
    if opts.multipos:
        multipos, mlog = _read_multipos(opts.multipos, opts)
        print(mlog.describe(), file=sys.stderr)
        axis = next(c for c in mlog.channels if c.startswith("gyro_"))[-1]
        if statics and axis != statics[0].axis:
            raise LogError(f"--multipos {opts.multipos}: its gyro column "
                           f"{multipos.column!r} is on body axis {axis}, the static logs' on "
                           f"{statics[0].axis} ({statics[0].column}); a device file is one gyro: "
                           "choose it with --axis, or map the columns with --column")
    return statics, curve, thermal, multipos, axis


def _stated_attitude(log, axis: str, opts: FitOptions):
    """A static or thermal log without accelerometer columns at the attitude ``--input-axis up``
    or ``down`` states: the specific force +-1 g along its gyro's body axis ``axis``."""
    from dataclasses import replace

    if log.f is not None or opts.input_axis not in ("up", "down"):
        return log
    f = [0.0, 0.0, 0.0]
    f["xyz".index(axis)] = 1.0 if opts.input_axis == "up" else -1.0
    return replace(log, f=tuple(f), f_source=f"stated: --input-axis {opts.input_axis}")


def _options_line(opts: FitOptions) -> list[str]:
    """The fit's options as a command line names them, for the file's header."""
    out = [f"--axis {opts.axis}"] if opts.axis else []
    out += [f"{flag} {v}" for flag, v in (
        ("--min-tau-s", opts.min_tau_s), ("--latitude-deg", opts.latitude_deg),
        ("--input-axis", opts.input_axis), ("--heading-deg", opts.heading_deg),
        ("--ci", opts.ci), ("--gaps", opts.gaps if opts.gaps != "refuse" else None),
        ("--fs", opts.fs), ("--samples", opts.samples), ("--curve-ci", opts.curve_ci),
        ("--reference", opts.reference), ("--full-scale-dps", opts.full_scale_dps))
        if v is not None]
    return out + [f"--column {c}" for c in (opts.column or [])]


def _write_device_file(out: _Outputs, target: Path, text: str) -> None:
    """The device file written, once what was written reads back as a device file (the
    scenario's own checks)."""
    from fogbench.scenario import ScenarioError
    from fogbench.scenario.device_file import load_device_file

    try:
        out.write_text(target, text)
        tmp = out.pending[-1][0]
        try:
            load_device_file(tmp)
        except ScenarioError as exc:
            raise LogError(f"device fit: a fitted value is out of the range a device file "
                           f"allows ({str(exc).replace(tmp, str(target))}); check the log's "
                           "units (the column's unit suffix) and sample rate") from None
        out.commit()
    finally:
        out.discard()


def fit(opts: FitOptions) -> int:
    """``device fit``: the logs read, the device fitted, the file written; prints every key
    with its interval and every key left undetermined with the reason."""
    ci = _check_fit_flags(opts)
    inputs = [Path(p) for p in opts.static] + [Path(p) for p in (opts.curve, opts.thermal,
                                                                 opts.multipos) if p]
    out = _Outputs(opts.overwrite, "device fit")
    target = out.target(Path(opts.out), tuple(inputs), recognise=_is_device_file,
                        what="device file")
    if target.suffix != ".toml":
        raise LogError(f"--out {target}: a device file ends in .toml")
    first = None
    if opts.static and opts.axis is None:     # a triad log (gyro_x, gyro_y, gyro_z)?
        first = _read_static_log(opts.static[0], opts, acc=bool(opts.multipos),
                                 temp=bool(opts.thermal))
        print(first.describe(), file=sys.stderr)
        if len(gyro_columns(first)) > 1:
            return _fit_triad(opts, ci, out, target, first)
    statics, curve, thermal, multipos, mp_axis = _read_fit_logs(opts, first)
    full_scale = None if opts.full_scale_dps is None else opts.full_scale_dps * DPS
    earth = None
    if opts.latitude_deg is not None:
        earth = earth_projection(opts.latitude_deg, opts.input_axis, opts.heading_deg or 0.0)
    try:
        result = fit_device(statics, curve, earth, ci, opts.min_tau_s, thermal, multipos,
                            full_scale, input_axis=opts.axis or (statics[0].axis if statics
                                                                 else mp_axis))
    except ValueError as exc:
        raise LogError(f"device fit: {exc}") from None
    result.options = _options_line(opts)
    _write_device_file(out, target, result.to_toml())
    w = max([36] + [len(e.key) for e in result.entries] + [len(k) for k in result.undetermined])
    for e in result.entries:
        print(f"{e.key:<{w}} {_toml_value(e.value):>14} {_entry_interval(e)}")
    for k, why in result.undetermined.items():
        print(f"{k:<{w}} {'-':>14}  {why}")
    for n in result.notes:
        print(f"note: {n}")
    print(f"wrote {target}")
    return 0


def _triad_refusals(opts: FitOptions, path, cols: list[str]) -> None:
    """What a triad fit does not take, refused before any fit (naming the log, its columns and
    the flag)."""
    if cols != [f"gyro_{a}" for a in TRIAD_AXES]:
        raise LogError(f"{path}: {len(cols)} gyro columns ({', '.join(cols)}): a triad device "
                       "file needs gyro_x, gyro_y and gyro_z; for a one-axis device file choose "
                       "the column with --axis")
    for flag, v in (("--curve", opts.curve), ("--thermal", opts.thermal),
                    ("--multipos", opts.multipos), ("--latitude-deg", opts.latitude_deg),
                    ("--input-axis", opts.input_axis), ("--heading-deg", opts.heading_deg)):
        if v is not None:
            raise LogError(f"{flag}: a triad fit ({path} has {', '.join(cols)} and no --axis "
                           "was given) takes static logs only, each gyro's bias stated "
                           "uncorrected for the Earth rate; fit one gyro at a time with --axis "
                           "x, y or z to use " + flag)


def _fit_triad(opts: FitOptions, ci: float, out: _Outputs, target: Path, first) -> int:
    """``device fit`` on static logs with gyro_x, gyro_y and gyro_z and no ``--axis``: each
    column fitted as the one-axis fit fits it (:func:`fit_device`, the column's body axis its
    input axis), written as one triad device file (:class:`TriadFit`)."""
    logs = [(opts.static[0], first)]
    _triad_refusals(opts, opts.static[0], gyro_columns(first))
    for p in opts.static[1:]:
        log = _read_static_log(p, opts, temp=bool(opts.thermal))
        print(log.describe(), file=sys.stderr)
        _triad_refusals(opts, p, gyro_columns(log))
        logs.append((p, log))
    if any(abs(log.fs / logs[0][1].fs - 1.0) > 1e-3 for _, log in logs):
        raise LogError("--static: the logs have different sample rates (" + ", ".join(
            f"{p}: {log.fs:g} Hz" for p, log in logs) + "); a device file is fitted at one")
    per_axis = {a: [_static_of(p, log, f"gyro_{a}") for p, log in logs] for a in TRIAD_AXES}
    fits = {}
    for a, statics in per_axis.items():
        try:
            fits[a] = fit_device(statics, None, None, ci, opts.min_tau_s, input_axis=a)
        except ValueError as exc:
            raise LogError(f"device fit: gyro_{a}: {exc}") from None
        for e in fits[a].entries:
            if e.key == "bias_dph":
                e.source = e.source.replace(
                    "(give --latitude-deg and --input-axis)", "(a triad fit takes no "
                    "--latitude-deg: fit the gyro alone with --axis for that)")
    inputs = [f"static log {p} ({log.channels['gyro_x'].size} samples at {log.fs:g} Hz, "
              f"columns {', '.join(log.sources[f'gyro_{a}'] for a in TRIAD_AXES)})"
              for p, log in logs]
    result = TriadFit(axes=fits, ci=ci, inputs=inputs, options=_options_line(opts))
    _write_device_file(out, target, result.to_toml())
    w = max([36] + [len(e.key) for f in fits.values() for e in f.entries]
            + [len(k) for f in fits.values() for k in f.undetermined])
    for a, f in fits.items():
        print(f"[{a}]")
        for e in f.entries:
            print(f"{e.key:<{w}} {_toml_value(e.value):>14} {_entry_interval(e)}")
        for k, why in f.undetermined.items():
            if k not in THERMAL_BUILD_KEYS:
                print(f"{k:<{w}} {'-':>14}  {why}")
        for n in f.notes:
            print(f"note ({a}): {n}")
    for k, why in TRIAD_NEEDS.items():
        print(f"{k:<{w}} {'-':>14}  {why}")
    print(f"wrote {target} (a triad device file: [x], [y], [z])")
    return 0


# ---------------------------------------------------------------------------------------------
# check
@dataclass(frozen=True)
class CheckOptions(LogOptions):
    """``device check``: the ``device`` file against a static ``log`` (its ``axis`` column) or
    an Allan ``curve`` with intervals (``curve_ci``, ``samples``), over ``replicates`` twins
    drawn from ``seed``; the figure and JSON into the folder ``out``, replacing its own with
    ``overwrite``."""

    device: str = ""
    log: str | None = None
    curve: str | None = None
    curve_ci: float | None = None
    samples: int | None = None
    axis: str | None = None
    replicates: int = 39
    seed: int = 0
    out: str | None = None
    overwrite: bool = False


def _check_check_flags(opts: CheckOptions) -> None:
    from fogbench.scenario import ScenarioError
    from fogbench.scenario.device_file import load_device_file

    if not 0 <= opts.seed < 2**31:
        raise LogError(f"--seed: expected a whole number from 0 to 2^31 - 1, got {opts.seed}")
    if not 19 <= opts.replicates <= MAX_CHECK_REPLICATES:
        raise LogError(f"--replicates: expected 19 (the fewest for a test at the 5 % level: "
                       f"p takes the values k / (replicates + 1)) to {MAX_CHECK_REPLICATES}, "
                       f"got {opts.replicates}")
    from fogbench.scenario.device_triad import is_triad

    try:
        doc = load_device_file(opts.device)    # the device file first, before the log is read
    except ScenarioError as exc:
        raise LogError(str(exc)) from None
    if is_triad(doc) and opts.axis is None:
        raise LogError(f"{opts.device}: a triad device file (tables [x], [y], [z]); device "
                       "check compares one gyro with one column: choose it with --axis x, y or "
                       "z (the log's column and the device's table of that axis)")
    if (opts.log is None) == (opts.curve is None):
        raise LogError("device check: give either LOG.csv or --curve CURVE.csv")


def _record_curve(opts: CheckOptions):
    """(curve with taus, adev, low, high; sample rate; gap-free pieces; samples; interval's
    name) of the log or the given curve."""
    from fogcomp.allan import allan_analysis

    if opts.log is not None:
        s, log = _read_static(opts.log, opts)
        print(log.describe(), file=sys.stderr)
        segments = list(s.segments)
        curve, _ = allan_analysis(s.rate, s.fs, ci=CHECK_CI, segments=segments,
                                  alternative=False)
        return curve, s.fs, segments, int(s.rate.size), f"{CHECK_CI:.0%} interval (EDF)"
    _, (t, a, lo, hi), fs, n = _read_curve_axis(opts)
    if lo is None:
        raise LogError(f"{opts.curve}: no interval columns (adev_ci_low_/high_<unit>): "
                       "the check compares intervals")
    m = np.rint(np.asarray(t) * fs)
    if np.any(np.abs(m - np.asarray(t) * fs) > 1e-6 * m) or np.any(m > (n - 1) // 2):
        raise LogError(f"{opts.curve}: its averaging times are not whole numbers of "
                       f"samples at {fs:g} Hz within {n} samples (--fs, --samples)")
    from types import SimpleNamespace

    curve = SimpleNamespace(taus=np.asarray(t), adev=np.asarray(a), low=np.asarray(lo),
                            high=np.asarray(hi))
    return curve, fs, [(0, n)], n, f"{opts.curve_ci:.0%} interval (given)"


def _print_check(what: str, curve, res: dict) -> None:
    print(f"{'tau_s':>10} {what + ' deg/h':>12} {what + ' interval':>23} "
          f"{'twin 95 % band':>23}  agree")
    for i, t in enumerate(curve.taus):
        print(f"{t:10.4g} {curve.adev[i] / DPH:12.4g} [{curve.low[i] / DPH:9.4g}, "
              f"{curve.high[i] / DPH:9.4g}] [{res['band_low'][i] / DPH:9.4g}, "
              f"{res['band_high'][i] / DPH:9.4g}]  {'yes' if res['agree'][i] else 'NO'}")
    print(f"the {what}'s Allan deviation and the twin's agree within their intervals at "
          f"{res['share']:.0%} of the averaging times ({int(res['agree'].sum())} of "
          f"{res['agree'].size})")
    print(f"whole-curve test (the {what}'s distance from the twins' curves, ranked among each "
          f"twin's distance from the others; exact at any record length): p = "
          f"{res['p_value']:.3g}: the {what} "
          + ("agrees with" if res["agrees"] else "DISAGREES with")
          + f" the device at the {res['level']:.0%} level")


def check(opts: CheckOptions) -> int:
    """``device check``: the device's twin at rest under the record's conditions, its Allan
    curves beside the record's; prints the comparison and the whole-curve test, writes them
    with ``out``. Returns 0 when the record agrees with the device, 1 when it does not."""
    from fogbench.console import Progress

    _check_check_flags(opts)
    src = Path(opts.log if opts.log is not None else opts.curve)
    out = _Outputs(opts.overwrite, "device check")
    targets = None
    if opts.out:
        targets = out.folder(Path(opts.out), (Path(opts.device), src),
                             marker="device_check.json", recognise=_is_check_json,
                             members=[("device_check.png", lambda p: p.suffix == ".png")])
    curve, fs, segments, n, interval = _record_curve(opts)
    params, _ = _device_params(opts.device, fs, opts.axis)
    with Progress(opts.replicates, "twin") as bar:
        twin = twin_curves(params, fs, segments, curve.taus, opts.replicates,
                           seed=opts.seed, progress=lambda r: bar.advance())
    if not np.all(np.isfinite(twin)) or np.all(twin == 0):
        raise LogError(f"{opts.device}: the device's twin at rest has no noise (every Allan "
                       "deviation zero or undefined): a device file without noise terms has "
                       "nothing to compare with a log")
    res = check_device(curve, twin)
    what = "log" if opts.log is not None else "curve"
    doc = {"format": "fogbench-device-check", "version": 1, "device": str(opts.device),
           what: str(src), "fs_hz": fs, "n_samples": n, "replicates": opts.replicates,
           "interval": interval, "tau_s": curve.taus.tolist(),
           "log_adev_dph": (curve.adev / DPH).tolist(),
           "log_low_dph": (curve.low / DPH).tolist(), "log_high_dph": (curve.high / DPH).tolist(),
           "twin_median_dph": (res["median"] / DPH).tolist(),
           "twin_low_dph": (res["band_low"] / DPH).tolist(),
           "twin_high_dph": (res["band_high"] / DPH).tolist(),
           "agree": [bool(x) for x in res["agree"]], "share_agree": res["share"],
           "test": "Monte Carlo rank of the squared distance of the log Allan deviations from "
                   "the twins', each averaging time weighted by the twins' variance (covariance "
                   f"shrunk to its diagonal by {COVARIANCE_SHRINKAGE:g})",
           "p_value": res["p_value"],
           "statistic": res["statistic"], "level": res["level"],
           "verdict": "agrees" if res["agrees"] else "disagrees"}
    _print_check(what, curve, res)
    if targets is not None:
        try:
            out.write_text(targets["device_check.json"], json.dumps(doc, indent=2))
            out.write(targets["device_check.png"], lambda tmp: _plot_check(
                tmp, f"{Path(opts.device).name} against {src.name}", curve, res, interval,
                what))
            out.commit()
        finally:
            out.discard()
        print(f"wrote {targets['device_check.json']} and {targets['device_check.png']}")
    return 0 if res["agrees"] else 1
