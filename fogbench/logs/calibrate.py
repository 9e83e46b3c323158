"""``fogbench calibrate``: a fogcomp method fitted on a record against a reference rate (a
column, a constant table rate, or the Earth rate at rest), or the Ferraris six-position +
three-rotation triad calibration; the model files are written by :mod:`.modelfile`'s rules."""

from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fogcomp.units import G0

from fogbench.formats.errors import LogError
from fogbench.formats.table import DEG, GYRO_UNITS, Log
from fogbench.formats.table import fmt_number as _fmt_number
from fogbench.formats.table import numeric as _numeric
from fogbench.outputs.folders import Outputs as _Outputs
from fogbench.console import is_identifiability, note, warn
from fogbench.logs.modelfile import (
    MANIFEST_VERSION,
    _file_sha256,
    _is_fogcomp_model,
    _is_model_manifest,
    _sealed,
)
from fogbench.logs.options import LogOptions

#: Plausible local gravity, m/s^2 (9.78 at the equator to 9.83 at the poles at sea level, less
#: on mountains), for ``calibrate ferraris --g``.
G_RANGE_MPS2 = (9.7, 9.9)
EARTH_RATE = 7.2921150e-5          # rad/s, WGS-84 / IERS


def _earth_rate_body(latitude_deg: float, heading_deg: float, z_up: bool) -> np.ndarray:
    """Earth rate in a level body frame, rad/s: x along the heading, y right, z down (NED-like),
    or with ``z_up`` x forward, y left, z up. Titterton & Weston (2004) eq. 3.72 (NED)."""
    lat, psi = latitude_deg * DEG, heading_deg * DEG
    north, down = EARTH_RATE * math.cos(lat), -EARTH_RATE * math.sin(lat)
    w = np.array([north * math.cos(psi), -north * math.sin(psi), down])
    if z_up:
        w = w * np.array([1.0, -1.0, -1.0])
    return w


def _check_calibrate_flags(opts) -> None:
    """Refuse non-finite or implausible numbers in calibrate's flags, naming the flag."""
    def finite(flag, value, unit):
        if value is not None and not math.isfinite(value):
            raise LogError(f"{flag}: expected a finite number in {unit}, got "
                           f"{_fmt_number(value)}")

    finite("--rate-dps", opts.rate_dps, "deg/s")
    finite("--heading-deg", opts.heading_deg, "deg")
    finite("--latitude-deg", opts.latitude_deg, "deg")
    if opts.latitude_deg is not None and not -90.0 <= opts.latitude_deg <= 90.0:
        raise LogError(f"--latitude-deg: expected a latitude between -90 and 90 deg, got "
                       f"{_fmt_number(opts.latitude_deg)}")
    finite("--angle-deg", opts.angle_deg, "deg")
    if opts.angle_deg is not None and opts.angle_deg == 0:
        raise LogError("--angle-deg: the rotations' angle must not be 0")
    lo, hi = G_RANGE_MPS2
    if not (math.isfinite(opts.g) and lo <= opts.g <= hi):
        raise LogError(f"--g: expected the local gravity in m/s^2 (not in g), between {lo:g} "
                       f"and {hi:g}, got {_fmt_number(opts.g)}")


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
    return _numeric(path, log.frame, column, log.rows) * factor


@dataclass(frozen=True)
class CalibrateOptions(LogOptions):
    """What ``fogbench calibrate`` is asked: a fogcomp ``method`` (or "ferraris") fitted on the
    record ``log`` (only gyro ``axis`` "x", "y" or "z"; None: every one), against a reference:
    a ``reference`` column, a constant ``rate_dps``, or the Earth rate ``static`` at rest
    (``latitude_deg``, ``heading_deg``, ``z_up``); ``seed`` for a random method; Ferraris'
    ``angle_deg`` and local gravity ``g`` (m/s^2) and its ``kalibr`` / ``openvins`` intrinsics
    (``imu_topic``); the model written at ``out``, replacing one of its own with
    ``overwrite``."""

    method: str = ""
    log: str = ""
    out: str = ""
    axis: str | None = None
    reference: str | None = None
    rate_dps: float | None = None
    static: bool = False
    latitude_deg: float | None = None
    heading_deg: float | None = None
    z_up: bool = False
    seed: int | None = None
    angle_deg: float | None = None
    g: float = G0
    kalibr: str | None = None
    openvins: str | None = None
    imu_topic: str = "/imu0"
    overwrite: bool = False


def _model_paths(opts: CalibrateOptions, out: _Outputs) -> tuple[Path, Path]:
    """(model path without suffix, its manifest), the manifest's place checked."""
    model_path = Path(opts.out)
    if model_path.name in ("", ".", "..") or ".." in model_path.parts:
        raise LogError(f"--out {opts.out!r}: name the model file (e.g. --out models/kal), not "
                       "a folder; a path through '..' is refused")
    if model_path.suffix == ".json":
        model_path = model_path.with_suffix("")
    manifest = model_path.with_name(model_path.name + ".json")
    if model_path.suffix:        # --out cal.txt: said, not silently cal.txt.json
        from fogbench.console import note

        note(f"--out {opts.out}: the model is written as {manifest} (a .json manifest, with "
             "its arrays beside it in .npz where it has any); name it without a suffix or "
             "with .json")
    out.target(manifest, (opts.log,), recognise=_is_model_manifest, what="model file")
    return model_path, manifest


def _check_method_flags(opts: CalibrateOptions, cls) -> None:
    """A fogcomp method's flags: exactly one reference for a supervised one, none for the
    others, a seed for a random one."""
    method = opts.method
    for flag in ("kalibr", "openvins"):
        if getattr(opts, flag, None):
            raise LogError(f"--{flag}: only with calibrate ferraris (the triad's intrinsics); "
                           f"the noise terms come from fogbench allan LOG --{flag}")
    refs = [x for x in (opts.reference, opts.rate_dps, opts.static or None) if x is not None]
    if cls.supervised and len(refs) != 1:
        raise LogError(f"calibrate {method}: a supervised method needs exactly one of "
                       "--reference COLUMN, --rate-dps RATE, --static (with --latitude-deg, "
                       "--heading-deg)")
    if not cls.supervised and refs:
        raise LogError(f"calibrate {method}: this method learns from the signal alone; "
                       "--reference / --rate-dps / --static do not apply")
    if opts.static and (opts.latitude_deg is None or opts.heading_deg is None):
        raise LogError("--static: give --latitude-deg and --heading-deg (Earth rate in the body)")
    if cls.random and opts.seed is None:
        raise LogError(f"calibrate {method}: the method draws random numbers; give --seed N")


def _read_for_method(opts: CalibrateOptions, cls):
    """The log, with the channels the method requires, and the gyro channels to fit."""
    axes = [f"gyro_{a}" for a in (opts.axis or "xyz")]
    header_chans = list(axes) if opts.axis else None
    need = list(header_chans or ["gyro_*"])
    if "g" in cls.requires:
        need += ["acc_x", "acc_y", "acc_z"]
    if "temp" in cls.requires or "temp_rate" in cls.requires:
        need += ["temp"]
    log = opts.read(opts.log, need)
    if header_chans is None:
        axes = sorted(c for c in log.channels if c.startswith("gyro_"))
    return log, axes


def _fit_axis(opts: CalibrateOptions, log: Log, ch: str, ref, attitude):
    """The method fitted on one gyro channel against its reference (a rate, the Earth rate,
    a column, or none); its warnings said as lines."""
    import fogcomp

    method = opts.method
    cls = fogcomp.get_method(method)
    if log.units[ch] == "au":
        raise LogError(f"{opts.log}: column {log.sources[ch]!r} is in raw counts; "
                       f"{method} needs a rate unit")
    if opts.rate_dps is not None:
        r = np.full(log.n, opts.rate_dps * DEG)
    elif opts.static:
        r = np.full(log.n, _earth_rate_body(opts.latitude_deg, opts.heading_deg,
                                            opts.z_up)["xyz".index(ch[-1])])
    else:
        r = ref
    parts, refs_ = [], []
    for a, b in log.segments:
        parts.append(_gyro_data(log, ch, slice(a, b)))
        refs_.append(None if r is None else r[a:b])
    data = fogcomp.GyroData.concatenate(parts) if len(parts) > 1 else parts[0]
    rr = None if r is None else np.concatenate(refs_)
    hp = {"random_state": opts.seed} if cls.random else {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = fogcomp.make_method(method, **hp).fit(data, rr)
    ident = getattr(model, "identifiability_", None)
    if attitude is not None:
        rank = f"rank {ident.rank} of {ident.n_terms}" if ident is not None else ""
        warn(f"calibrate {method}, {ch}: {opts.log} holds one attitude only "
             f"({attitude}): from one attitude only the bias is identifiable (the bias "
             "and the g-sensitive terms add up to one constant there); the fitted "
             "g-sensitivity is not meaningful"
             + (f" (the fit's {rank} comes from accelerometer noise alone)"
                if rank else "")
             + "; calibrate on a record with several attitudes (e.g. six positions)")
        caught = [w for w in caught if not is_identifiability(w)]
    for w in caught:
        warn(f"calibrate {method}, {ch}: {w.message}")
    return model


def _write_models(opts: CalibrateOptions, out: _Outputs, log: Log, models: dict, paths: dict,
                  manifest: Path) -> None:
    """Every model file under a temporary name, renamed into place with the others (the
    manifest last): a failure leaves no model set without its manifest."""
    try:
        entries = {}
        for ch, model in models.items():
            jpath, npath = out.save_model(model, paths[ch])
            pending = dict((final, tmp) for tmp, final in out.pending)
            entries[ch] = {"model": paths[ch].name, "unit": log.units[ch],
                           "method": opts.method,
                           "json_sha256": _file_sha256(pending[jpath]),
                           "npz_sha256": _file_sha256(pending[npath])}
        doc = _sealed({"format": "fogbench-log-model", "version": MANIFEST_VERSION,
                       "method": opts.method, "fs_hz": log.fs, "axes": entries,
                       "calibration_file": str(opts.log)})
        out.write_text(manifest, json.dumps(doc, indent=2, allow_nan=False))
        out.commit()
    finally:
        out.discard()


def calibrate(opts: CalibrateOptions) -> int:
    """``fogbench calibrate``: every check before any work, a model per gyro axis (or the
    Ferraris triad calibration), every file written together. Returns the exit status."""
    import fogcomp

    method = opts.method
    if method != "ferraris":
        try:           # a built-in, an entry-point plug-in or module:Class
            fogcomp.get_method(method)
        except KeyError as exc:
            raise LogError(f"calibrate: {exc.args[0]} (or ferraris)") from None
    _check_calibrate_flags(opts)
    out = _Outputs(opts.overwrite, "calibrate")
    model_path, manifest = _model_paths(opts, out)
    if method == "ferraris":
        return _calibrate_ferraris(opts, out, manifest)
    cls = fogcomp.get_method(method)
    _check_method_flags(opts, cls)
    log, axes = _read_for_method(opts, cls)
    paths = {ch: model_path.with_name(f"{model_path.name}.{ch}") for ch in axes}
    for ch, p in paths.items():
        for suffix in (".json", ".npz"):
            out.target(p.with_name(p.name + suffix), (opts.log,), recognise=_is_fogcomp_model,
                       what="model file")
    note(log.describe())
    attitude = _one_attitude(log) if "g" in cls.requires else None
    ref = reference_rate(opts.log, log, opts.reference) if opts.reference else None
    models = {ch: _fit_axis(opts, log, ch, ref, attitude) for ch in axes}
    _write_models(opts, out, log, models, paths, manifest)
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


def _calibrate_ferraris(opts, out: _Outputs, manifest: Path) -> int:
    from fogcomp.calibration import FERRARIS_PARTS, ferraris_calibration

    if opts.angle_deg is None:
        raise LogError("calibrate ferraris: give --angle-deg, the known angle of each rotation "
                       "(signed by the right-hand rule; imucal's default is -360)")
    tools = _intrinsics_targets(out, opts)
    chans = [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]
    log = opts.read(opts.log, chans, gaps="continuous", min_samples=2)
    note(log.describe())
    raw = [ch for ch in chans if log.units[ch] == "au"]
    if tools and raw:
        raise LogError(f"{opts.log}: column {log.sources[raw[0]]!r} is in raw counts (au); "
                       "Kalibr and OpenVINS read rad/s and m/s^2 (sensor_msgs/Imu), so "
                       f"--{tools[0][0]} needs every column in a physical unit")
    if "part" not in log.frame.columns:
        raise LogError(f"{opts.log}: missing column 'part' (x_p, x_a, ..., z_rot), which "
                       "says which position or rotation each row belongs to")
    part = log.frame["part"].astype(str).str.strip().to_numpy()
    known = set(FERRARIS_PARTS)
    unknown = sorted(set(part) - known)
    if unknown:
        i = int(np.flatnonzero(part == unknown[0])[0])
        raise LogError(f"{opts.log}: {log.rows(i)}, column 'part': unknown part {unknown[0]!r}; "
                       f"expected {', '.join(FERRARIS_PARTS)}")
    acc, gyro = {}, {}
    for p in FERRARIS_PARTS:
        sel = part == p
        if sel.sum() < 2:
            raise LogError(f"{opts.log}: part {p!r} has {int(sel.sum())} rows; a Ferraris "
                           "session needs every part with at least 2")
        acc[p] = np.column_stack([log.channels[f"acc_{a}"][sel] for a in "xyz"])
        gyro[p] = np.column_stack([log.channels[f"gyro_{a}"][sel] for a in "xyz"])
    cal = ferraris_calibration(acc, gyro, log.fs, opts.angle_deg * DEG, g=opts.g)
    _check_triad(opts.log, log, acc, gyro, cal)
    doc = _sealed({"format": "fogbench-triad-model", "version": MANIFEST_VERSION,
                   "method": "ferraris", "fs_hz": log.fs, "calibration_file": str(opts.log),
                   "columns": {ch: {"column": log.sources[ch], "unit": log.units[ch]}
                               for ch in chans},
                   "calibration": cal.to_dict()})
    intr = None
    if tools:
        from fogbench.formats.kalibr import INTRINSICS_TEXTS, intrinsics_from_ferraris

        intr = intrinsics_from_ferraris(cal)
    try:
        out.write_text(manifest, json.dumps(doc, indent=2, allow_nan=False))
        for kind, path in tools:
            out.write_text(path, INTRINSICS_TEXTS[kind](intr, log.fs, str(opts.log),
                                                        topic=opts.imu_topic))
        out.commit()
    finally:
        out.discard()
    # the gyro scale factors: counts per deg/s for raw counts, else output per true rate in
    # the same unit (1 when the unit is right); the biases in the gyro columns' unit
    factor = {a: GYRO_UNITS[log.units[f"gyro_{a}"]] for a in "xyz"}
    raw_counts = all(factor[a] is None for a in "xyz")
    kg = [cal.gyro_scale[j] * (DEG if raw_counts else 1.0) for j in range(3)]
    bg = [cal.gyro_bias[j] / (factor[a] or 1.0) for j, a in enumerate("xyz")]
    unit = "/".join(dict.fromkeys(log.units[f"gyro_{a}"] for a in "xyz"))
    print(f"calibrate ferraris: {log.n} samples at {log.fs:g} Hz, g = {opts.g} m/s^2, rotations "
          f"{opts.angle_deg:g} deg; gyro scale {[float(f'{x:.7g}') for x in kg]} "
          + ("counts per deg/s" if raw_counts else f"{unit} per {unit}")
          + f", bias {[float(f'{x:.4g}') for x in bg]} {unit}; wrote {manifest}")
    for kind, path in tools:
        print(f"wrote {path} ({kind}: the frame I is the accelerometer triad's, "
              f"{intr.angle_deg():.3g} deg from the calibration's body frame; noise keys left "
              "to fill in from fogbench allan)")
    return 0


def _intrinsics_targets(out: _Outputs, opts) -> list:
    """--kalibr FILE, --openvins FILE of calibrate ferraris, checked before any work (never a
    file fogbench did not write, never an input, never another output): [(kind, path)]."""
    from fogbench.formats.kalibr import is_own

    if not opts.imu_topic.startswith("/") or any(c.isspace() for c in opts.imu_topic):
        raise LogError(f"--imu-topic {opts.imu_topic!r}: expected a ROS topic name such as "
                       "/imu0")
    return [(kind, out.target(Path(p), (opts.log,), recognise=is_own, what=f"{kind} file",
                              flag=f"--{kind}"))
            for kind in ("kalibr", "openvins") if (p := getattr(opts, kind, None))]
