"""``fogbench attitude LOG``: a static triad log integrated to roll, pitch and heading, raw and
with its bias calibrated on the log's first part, against the truth a static log has (no
motion: the attitude it started in).

Steps (each named where it is done):

1. **Initial attitude** (:func:`initial_attitude`): levelling from the mean specific force of
   the first ``align_s`` seconds (roll and pitch; down is -f) and the heading the user states
   (``--heading-deg``, default 0: a static log's own heading is unknown and a MEMS triad cannot
   gyrocompass, its bias being larger than the Earth's rate), or an attitude given whole
   (``--initial-rpy-deg`` or ``--initial-quat``).
2. **Raw**: the gyros' angle increments (rate / fs) integrated from there by
   :func:`fogcomp.attitude.integrate_attitude` (two-sample coning correction; the Earth's rate at
   ``--latitude-deg`` removed, or, without it, left in: then up to 15 deg/h of the drift is the
   Earth's).
3. **Bias-calibrated**: each gyro's bias taken as its mean over the first ``calibrate_s``
   seconds less the Earth's rate there (at the stated latitude and heading; static: the two
   cancel, so neither needs to be right for this reading), subtracted from the rest of the log,
   which is integrated from the same attitude: scored on samples it was not fitted on.
4. **Drift over windows**: the scored part cut into windows of ``window_s`` seconds, each
   integrated from the true attitude at its start, raw and calibrated. The error at each
   window's end is one draw of the drift over that time: their mean, standard deviation and the
   95 % Student t-interval of the mean (windows of one record are not independent power-ons:
   the interval speaks for this log's stretch, not for the sensor type).

Angles are reported in deg; inside, SI (rad, rad/s).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fogbench.console import warn
from fogbench.formats.errors import LogError
from fogbench.logs.options import LogOptions
from fogbench.outputs.folders import Outputs, json_format

__all__ = ["AttitudeOptions", "attitude", "initial_attitude", "static_attitude_drift"]

AXES = ("gyro_x", "gyro_y", "gyro_z")
ACCS = ("acc_x", "acc_y", "acc_z")
#: Times at which the errors are reported, s (those within the record).
REPORT_TIMES_S = (60.0, 600.0, 3600.0)
#: A static log's specific force keeps its direction: the largest change of the 10 s means'
#: direction from the first one, deg, before the log is refused as moving.
STATIC_TOLERANCE_DEG = 2.0


@dataclass(frozen=True)
class AttitudeOptions(LogOptions):
    """What ``fogbench attitude`` is asked: the ``log``, the site's ``latitude_deg`` (None: the
    Earth's rate is not removed), the triad's ``heading_deg`` at the start (x axis from north,
    clockwise), or a whole initial attitude (``initial_rpy_deg`` "roll,pitch,heading" or
    ``initial_quat`` "w,x,y,z", body to NED); ``align_s`` (levelling), ``calibrate_s`` (the
    bias's part; None: the first 20 % of the log), ``window_s`` (drift windows); outputs in the
    folder ``out`` (attitude.json, attitude.png), replaced with ``overwrite``."""

    log: str | None = None
    latitude_deg: float | None = None
    heading_deg: float = 0.0
    initial_rpy_deg: str | None = None
    initial_quat: str | None = None
    align_s: float = 60.0
    calibrate_s: float | None = None
    window_s: float = 600.0
    out: str | None = None
    overwrite: bool = False


def _numbers(text: str, n: int, flag: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in text.split(",")])
    except ValueError:
        raise LogError(f"{flag}: expected {n} numbers separated by commas, got {text!r}") from None
    if v.size != n or not np.all(np.isfinite(v)):
        raise LogError(f"{flag}: expected {n} finite numbers separated by commas, got {text!r}")
    return v


def _given_attitude(opts: AttitudeOptions):
    """The initial attitude the flags give whole (a Rotation), or None (levelling)."""
    from scipy.spatial.transform import Rotation

    if opts.initial_rpy_deg is not None and opts.initial_quat is not None:
        raise LogError("attitude: give either --initial-rpy-deg or --initial-quat, not both")
    if opts.initial_rpy_deg is not None:
        roll, pitch, heading = _numbers(opts.initial_rpy_deg, 3, "--initial-rpy-deg")
        if abs(pitch) > 90.0:
            raise LogError(f"--initial-rpy-deg: pitch {pitch:g} deg is beyond +-90 deg (roll, "
                           "pitch, heading: z-y-x Euler angles, pitch in [-90, 90])")
        return Rotation.from_euler("ZYX", [heading, pitch, roll], degrees=True)
    if opts.initial_quat is not None:
        q = _numbers(opts.initial_quat, 4, "--initial-quat")
        norm = float(np.linalg.norm(q))
        if abs(norm - 1.0) > 1e-6:
            raise LogError(f"--initial-quat: (w, x, y, z) = {opts.initial_quat} has norm "
                           f"{norm:.9g}, not 1: it is not a rotation (normalise it, to 1e-6)")
        return Rotation.from_quat([q[1], q[2], q[3], q[0]])
    return None


def _check_flags(opts: AttitudeOptions) -> None:
    if opts.log is None:
        raise LogError("attitude: give LOG (a triad log: gyro_x, gyro_y, gyro_z)")
    lat = opts.latitude_deg
    if lat is not None and not (math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise LogError(f"--latitude-deg: expected -90 to 90, got {lat:g}")
    if not math.isfinite(opts.heading_deg):
        raise LogError(f"--heading-deg: expected a finite number, got {opts.heading_deg:g}")
    for flag, v in (("--align-s", opts.align_s), ("--window-s", opts.window_s),
                    ("--calibrate-s", opts.calibrate_s)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise LogError(f"{flag}: expected a positive number of seconds, got {v:g}")
    if opts.heading_deg and (opts.initial_rpy_deg or opts.initial_quat):
        raise LogError("--heading-deg: the initial attitude given whole holds the heading; "
                       "leave --heading-deg out")
    _given_attitude(opts)


def initial_attitude(specific_force, heading: float):
    """C^n_b (body -> NED) from the mean specific force at rest (any unit; it points up) and
    the heading, rad: roll = atan2(-f_y, -f_z), pitch = atan2(f_x, sqrt(f_y^2 + f_z^2))
    (Titterton & Weston 2004, section 10.2.1, eqs. 10.7-10.8, for NED body axes x forward,
    y right, z down)."""
    from scipy.spatial.transform import Rotation

    fx, fy, fz = np.asarray(specific_force, dtype=float)
    roll = math.atan2(-fy, -fz)
    pitch = math.atan2(fx, math.hypot(fy, fz))
    return Rotation.from_euler("ZYX", [heading, pitch, roll])


def _earth(m, fs: float, lat):
    """E^m: the NED frame's turn with the Earth over m samples (identity without a latitude)."""
    from scipy.spatial.transform import Rotation

    from fogcomp.attitude import earth_rate_ned

    m = np.atleast_1d(np.asarray(m, dtype=float))
    if lat is None:
        return Rotation.identity(m.size)
    return Rotation.from_rotvec(-np.outer(m / fs, earth_rate_ned(lat)))


def _window_errors(hist, C0, fs: float, lat, n_win: int) -> np.ndarray:
    """Each window's (roll, pitch, heading) error at its end, rad, shape (k, 3), had the
    integration restarted from the true attitude ``C0`` at the window's start: from one history
    ``hist`` (``C_m = E^m C0 B_m``, :func:`fogcomp.attitude.integrate_attitude`) the body
    product of the window, ``B_s^-1 B_e``, gives ``E^W C0 B_s^-1 B_e`` (the same update; only the
    window's first coning term keeps the sample before it, as a running integration would)."""
    from fogcomp.attitude import attitude_errors

    k = (len(hist) - 1) // n_win
    if k == 0:
        return np.zeros((0, 3))
    idx = np.arange(k + 1) * n_win
    B = C0.inv() * _earth(idx, fs, lat).inv() * hist[idx]
    est = _earth(n_win, fs, lat) * C0 * B[:-1].inv() * B[1:]
    e = attitude_errors(est, C0)
    return np.column_stack([e["roll_error_rad"], e["pitch_error_rad"], e["heading_error_rad"]])


def _summary(errs_deg: np.ndarray) -> dict:
    """Mean, sd and 95 % t-interval of the mean (:func:`fogbench.run.stats.mean_ci`) of each
    angle's window errors, deg (at least one window: the flags are checked for it)."""
    from fogbench.run.stats import mean_ci

    k = errs_deg.shape[0]
    out = {"windows": k}
    for j, name in enumerate(("roll", "pitch", "heading")):
        v = errs_deg[:, j]
        low, high = mean_ci(v)
        out[name] = {"mean_deg": float(np.mean(v)),
                     "sd_deg": float(np.std(v, ddof=1)) if k > 1 else math.nan,
                     "ci_low_deg": low, "ci_high_deg": high,
                     "rms_deg": float(np.sqrt(np.mean(v * v)))}
    return out


def static_attitude_drift(rate, fs: float, C0, latitude: float | None, n_cal: int,
                          window_n: int) -> dict:
    """The drift of a static triad (``rate`` (n, 3) rad/s, body axes) integrated from its true
    attitude ``C0``: raw from the start and, with the bias of the first ``n_cal`` samples
    removed, from sample ``n_cal`` on (each series of roll, pitch, heading error, rad, at every
    sample); and both over windows of ``window_n`` samples of the scored part."""
    from fogcomp.attitude import attitude_errors, earth_rate_ned, integrate_attitude

    rate = np.asarray(rate, dtype=float)
    earth_b = (C0.inv().apply(earth_rate_ned(latitude)) if latitude is not None
               else np.zeros(3))
    bias = rate[:n_cal].mean(axis=0) - earth_b
    raw = attitude_errors(integrate_attitude(C0, rate / fs, fs, latitude=latitude), C0)
    raw_scored = integrate_attitude(C0, rate[n_cal:] / fs, fs, latitude=latitude)
    cal_hist = integrate_attitude(C0, (rate[n_cal:] - bias) / fs, fs, latitude=latitude)
    return {
        "bias_rad_s": bias,
        "raw": raw, "calibrated": attitude_errors(cal_hist, C0),
        "windows_raw": np.degrees(_window_errors(raw_scored, C0, fs, latitude, window_n)),
        "windows_calibrated": np.degrees(_window_errors(cal_hist, C0, fs, latitude, window_n)),
    }


def _check_static(acc: np.ndarray, fs: float, where: str) -> None:
    """Refuse a log whose specific force turns (not static: its truth is not known here)."""
    k = max(1, int(round(10.0 * fs)))
    m = acc[: (acc.shape[0] // k) * k].reshape(-1, k, 3).mean(axis=1)
    if m.shape[0] < 2:
        return
    u = m / np.linalg.norm(m, axis=1, keepdims=True)
    ang = np.degrees(np.arccos(np.clip(u @ u[0], -1.0, 1.0)))
    moved = np.flatnonzero(ang > STATIC_TOLERANCE_DEG)
    if moved.size:
        i = int(moved[0])
        raise LogError(f"{where}: the log is not static: the mean specific force of the 10 s "
                       f"from data row {i * k + 1} is {ang[i]:.1f} deg from the first 10 s' "
                       f"(more than {STATIC_TOLERANCE_DEG:g} deg; {float(ang.max()):.1f} at "
                       "most); fogbench attitude scores static logs, whose true attitude is "
                       "the one they start in")


def _plot(path_tmp: str, title: str, fs: float, res: dict, t_cal: float) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    for ax, key, label in zip(axes, ("roll_error_rad", "pitch_error_rad", "heading_error_rad",
                                     "orientation_error_rad"),
                              ("roll", "pitch", "heading", "orientation")):
        raw, cal = res["raw"][key], res["calibrated"][key]
        ax.plot(np.arange(len(raw)) / fs / 60.0, np.degrees(raw), lw=0.8, label="raw")
        ax.plot((t_cal + np.arange(len(cal)) / fs) / 60.0, np.degrees(cal), lw=0.8,
                label=f"bias from the first {t_cal:g} s")
        ax.set_ylabel(f"{label} error, deg")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title(title, fontsize=9)
    axes[-1].set_xlabel("time, min")
    fig.tight_layout()
    fig.savefig(path_tmp, format="png", dpi=110)
    plt.close(fig)


def _at_times(series: dict, fs: float) -> dict:
    out = {}
    for t in REPORT_TIMES_S:
        i = int(round(t * fs))
        if i < len(series["heading_error_rad"]):
            out[f"{t:g}"] = {k.replace("_rad", "_deg"): math.degrees(float(v[i]))
                             for k, v in series.items()}
    return out


def attitude(opts: AttitudeOptions) -> int:
    """``fogbench attitude``: every check before any work, the integrations, the outputs
    written together; prints the drift table. Returns the exit status."""
    from fogbench.outputs.files import json_ready

    _check_flags(opts)
    given = _given_attitude(opts)
    out = Outputs(opts.overwrite, "attitude")
    targets = None
    if opts.out:
        if ".." in Path(opts.out).parts:
            raise LogError(f"--out {opts.out!r}: a path through '..' is refused; name the "
                           "folder directly")
        targets = out.folder(Path(opts.out), [opts.log], marker="attitude.json",
                             recognise=lambda p: json_format(p) == "fogbench-attitude",
                             members=[("attitude.png", lambda q: q.read_bytes()[:4]
                                       == b"\x89PNG")])
    try:
        log = opts.read(opts.log, list(AXES) + [f"{a}?" for a in ACCS], gaps="continuous")
    except LogError as exc:
        if "missing column for gyro_" in str(exc):
            raise LogError(f"{exc} (attitude integrates a triad: it needs gyro_x, gyro_y and "
                           "gyro_z)") from None
        raise
    for ch in AXES:
        if log.units[ch] == "au":
            raise LogError(f"{opts.log}: column {log.sources[ch]!r} is in raw counts (au); "
                           "attitude needs a rate unit (dps, rps, dph)")
    fs, n = log.fs, log.n
    accs = [a for a in ACCS if a in log.channels]
    if given is None and len(accs) < 3:
        raise LogError(f"{opts.log}: levelling needs the accelerometers acc_x, acc_y, acc_z "
                       f"(found {', '.join(accs) or 'none'}); give the initial attitude with "
                       "--initial-rpy-deg or --initial-quat instead")
    n_align = min(n, max(1, int(round(opts.align_s * fs))))
    n_cal = int(round((opts.calibrate_s if opts.calibrate_s is not None else 0.2 * n / fs) * fs))
    window_n = int(round(opts.window_s * fs))
    cal_s = n_cal / fs if opts.calibrate_s is None else opts.calibrate_s
    if n_cal < 1:
        raise LogError(f"--calibrate-s: {cal_s:g} s is shorter than one sample "
                       f"({1 / fs:g} s at {fs:g} Hz)")
    if n_cal >= n:
        raise LogError(f"--calibrate-s: {cal_s:g} s leaves nothing to score in a "
                       f"{n / fs:g} s log")
    if window_n < 1:
        raise LogError(f"--window-s: {opts.window_s:g} s is shorter than one sample "
                       f"({1 / fs:g} s at {fs:g} Hz)")
    if window_n > n - n_cal:
        raise LogError(f"--window-s: {opts.window_s:g} s is longer than the scored part "
                       f"({(n - n_cal) / fs:g} s after the bias's {n_cal / fs:g} s)")
    rate = np.column_stack([log.channels[a] for a in AXES])
    if len(accs) == 3:
        acc = np.column_stack([log.channels[a] for a in ACCS])
        _check_static(acc, fs, str(opts.log))
    lat = None if opts.latitude_deg is None else math.radians(opts.latitude_deg)
    C0 = given if given is not None else initial_attitude(acc[:n_align].mean(axis=0),
                                                          math.radians(opts.heading_deg))
    if lat is None:
        warn("attitude: no --latitude-deg: the Earth's rate is left in the raw integration "
             "(up to 15 deg/h of its drift); the bias-calibrated one is not affected (static: "
             "the bias takes it)")
    res = static_attitude_drift(rate, fs, C0, lat, n_cal, window_n)
    roll0, pitch0, head0 = (math.degrees(a) for a in C0.as_euler("ZYX")[::-1])
    doc = {
        "format": "fogbench-attitude", "version": 1, "log_file": str(opts.log), "fs_hz": fs,
        "n_samples": n, "duration_s": n / fs,
        "initial_attitude_deg": {"roll": roll0, "pitch": pitch0, "heading": head0,
                                 "from": "given" if given is not None else
                                 f"levelled over the first {n_align / fs:g} s, heading as "
                                 "stated"},
        "latitude_deg": opts.latitude_deg, "calibrate_s": n_cal / fs, "window_s": window_n / fs,
        "bias_dph": (res["bias_rad_s"] * 180.0 / math.pi * 3600.0).tolist(),
        "raw_at_s": _at_times(res["raw"], fs),
        "calibrated_at_s": _at_times(res["calibrated"], fs),
        "windows": {"raw": _summary(res["windows_raw"]),
                    "calibrated": _summary(res["windows_calibrated"])},
        "notes": ["The truth of a static log is the attitude it starts in; windows of one "
                  "record are not independent power-ons."],
    }
    try:
        if targets is not None:
            out.write_text(targets["attitude.json"],
                           json.dumps(json_ready(doc), indent=2, allow_nan=False))
            out.write(targets["attitude.png"], lambda tmp: _plot(
                tmp, f"{Path(opts.log).name}: static attitude drift", fs, res, n_cal / fs))
        out.commit()
    finally:
        out.discard()
    print(log.describe())
    print(_table(doc))
    if targets is not None:
        print(f"wrote {targets['attitude.json']} and attitude.png in {opts.out}")
    return 0


def _table(doc: dict) -> str:
    w = doc["window_s"]
    lines = [f"initial attitude: roll {doc['initial_attitude_deg']['roll']:.3f}, pitch "
             f"{doc['initial_attitude_deg']['pitch']:.3f}, heading "
             f"{doc['initial_attitude_deg']['heading']:.3f} deg "
             f"({doc['initial_attitude_deg']['from']})",
             "bias from the first {:g} s: x {:.2f}, y {:.2f}, z {:.2f} deg/h".format(
                 doc["calibrate_s"], *doc["bias_dph"]),
             "",
             f"error after {w:g} s of free integration, over "
             f"{doc['windows']['raw']['windows']} windows of the scored part "
             "(mean [95 % interval of the mean], rms), deg:",
             f"{'':12s}{'roll':>34s}{'pitch':>34s}{'heading':>34s}"]
    for key in ("raw", "calibrated"):
        s = doc["windows"][key]
        cells = [f"{s[a]['mean_deg']:+9.4f} [{s[a]['ci_low_deg']:+.4f}, "
                 f"{s[a]['ci_high_deg']:+.4f}] {s[a]['rms_deg']:.4f}"
                 for a in ("roll", "pitch", "heading")]
        lines.append(f"{key:12s}" + "".join(f"{c:>34s}" for c in cells))
    return "\n".join(lines)
