"""What compensation buys in attitude: a FOG triad at rest on the level table, integrated to
roll, pitch and heading (issue 42, its first study; ``python -m fogbench.bench.attitude``, part
of the full ``fogbench bench``).

Each replicate is one power-on of a triad of the ``navigation`` preset (three gyros, each with
its own switch-on draws and noise streams, ``sim.fog``) on the MuJoCo table, level, still, at
45 deg latitude and heading 30 deg, sampled at 10 Hz. The first ``align_s`` seconds are the
lab's alignment; from their end each reading is integrated for ``hold_s`` seconds
(:func:`fogcomp.attitude.integrate_attitude`, the Earth's rate removed) from the true attitude:

* ``raw``: the triad's output as it is;
* ``bias_calibrated``: less each gyro's mean over the alignment minus the Earth's rate the lab
  knows there (what a lab does at switch-on, on samples it is not scored on);
* ``oracle``: less the true deterministic error terms (bias, switch-on bias, ramp, scale factor,
  misalignment, g terms, temperature): the floor no model of those terms beats.

and **gyrocompassing** over the alignment (:func:`fogcomp.attitude.gyrocompass` on the mean
rate and the true specific force): its heading error beside the closed form -b_E /
(Omega cos L) (Titterton & Weston 2004, ch. 10) from the true east bias over the window, an
oracle that needs no integration.

Every number is a mean over replicates with its 95 % Student t-interval.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from fogbench.run.runner import DETERMINISTIC
from fogcomp.units import DPH, EARTH_RATE

__all__ = ["attitude_study", "main"]

LATITUDE_DEG = 45.0
HEADING_DEG = 30.0
FS_HZ = 10.0
REPORT_S = (60.0, 600.0, 3600.0)


def _rig(keys: dict, fs: float):
    """The rig of a study: a [fog] table's keys at ``fs``, the level table at the study's site."""
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table
    from sim.rate_table import TableConfig
    from sim.rig import Rig

    params, *_ = _fog(_Table(dict(keys), "[fog]", "bench attitude"), fs)
    table = TableConfig(latitude=math.radians(LATITUDE_DEG), heading=math.radians(HEADING_DEG))
    return Rig(fs=fs, table=table, fog=params, axes=("x", "y", "z"))


def _one(rig, seed: int, align_s: float, hold_s: float, truth=None) -> tuple[dict, object]:
    """One power-on: {reading: {"heading_deg": [at REPORT_S], ...}, "gyrocompass": ...}."""
    from fogcomp.attitude import (attitude_errors, earth_rate_ned, gyrocompass,
                                  integrate_attitude, true_attitude)
    from sim.motion import Hold
    from sim.rig import Run, simulate_run

    run = Run(name="static", seed=seed, motion=(Hold(align_s + hold_s),), thermal=None)
    rd = simulate_run(rig, run, truth=truth)
    lat, fs = rig.table.latitude, rig.fs
    n_al = int(round(align_s * fs))
    n_sc = int(round(hold_s * fs))
    C = true_attitude(rd.truth.fog_quat, rig.table.heading)
    C0 = C[n_al]
    raw = np.asarray(rd.fog.raw, dtype=float)
    det = sum(np.asarray(v, dtype=float) for k, v in rd.fog.terms.items() if k in DETERMINISTIC)
    earth_b = C[:n_al].inv().apply(earth_rate_ned(lat)).mean(axis=0)
    readings = {"raw": raw, "bias_calibrated": raw - (raw[:n_al].mean(axis=0) - earth_b),
                "oracle": raw - det}
    out = {}
    idx = [int(round(t * fs)) for t in REPORT_S if t <= hold_s]
    for name, w in readings.items():
        est = integrate_attitude(C0, w[n_al:n_al + n_sc] / fs, fs, latitude=lat)
        e = attitude_errors(est[idx], C[[min(n_al + i, len(C) - 1) for i in idx]])
        out[name] = {k.replace("_rad", "_deg"): np.degrees(v) for k, v in e.items()}
    # gyrocompassing over the alignment: the heading it finds and the closed form
    f = rd.truth.specific_force[:n_al].mean(axis=0)
    found = gyrocompass(raw[:n_al].mean(axis=0), f, lat)
    err = attitude_errors(found, C[n_al // 2])["heading_error_rad"]
    bias_b = (raw[:n_al] - rd.truth.rate[:n_al]).mean(axis=0)
    b_east = C[n_al // 2].apply(bias_b)[1]                  # NED: y is east
    predicted = -b_east / (EARTH_RATE * math.cos(lat))
    out["gyrocompass"] = {"heading_error_deg": math.degrees(float(err)),
                          "predicted_deg": math.degrees(predicted)}
    return out, rd.truth


def _ci(v) -> tuple[float, float, float]:
    """(mean, 95 % Student t-interval of the mean) over replicates."""
    from fogbench.run.stats import mean_ci

    v = np.asarray(v, dtype=float)
    return (float(v.mean()), *mean_ci(v))


def attitude_study(replicates: int = 20, preset: str = "navigation", align_s: float = 600.0,
                   hold_s: float = 3600.0, seed: int = 4200, device: str | None = None) -> dict:
    """Every replicate's results: {"runs": [per replicate], "times_s": [...]}. ``device``: a
    device file instead of the preset (a triad device file: each gyro its own terms)."""
    keys = {"device": device} if device else {"preset": preset}
    rig = _rig({**keys, "axes": ["x", "y", "z"]}, FS_HZ)
    preset = f"device file {device}" if device else preset
    runs, truth = [], None
    for r in range(replicates):
        res, truth = _one(rig, seed + r, align_s, hold_s, truth)
        runs.append(res)
    return {"runs": runs, "times_s": [t for t in REPORT_S if t <= hold_s], "preset": preset,
            "align_s": align_s, "hold_s": hold_s}


def _fmt(m, lo, hi) -> str:
    """``mean [low, high]``; the interval as '-' where there is none (one replicate)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return f"{m:+.4f} [-]"
    return f"{m:+.4f} [{lo:+.4f}, {hi:+.4f}]"


def report(study: dict) -> list[str]:
    runs, times = study["runs"], study["times_s"]
    R = len(runs)
    lines = [f"attitude of a static {study['preset']} FOG triad (level, latitude "
             f"{LATITUDE_DEG:g} deg, heading {HEADING_DEG:g} deg, {FS_HZ:g} Hz), integrated "
             f"from the end of a {study['align_s']:g} s alignment; mean [95 % interval] over "
             f"{R} power-ons, deg"]
    for key, label in (("heading_error_deg", "heading"), ("orientation_error_deg",
                                                          "orientation")):
        lines.append(f"  {label} error after " + ", ".join(f"{t / 60:g} min" for t in times))
        for name in ("raw", "bias_calibrated", "oracle"):
            cells = [_fmt(*_ci([abs(r[name][key][i]) if key == "orientation_error_deg"
                                else r[name][key][i] for r in runs]))
                     for i in range(len(times))]
            lines.append(f"    {name:16s} " + "   ".join(cells))
    g = [r["gyrocompass"]["heading_error_deg"] for r in runs]
    p = [r["gyrocompass"]["predicted_deg"] for r in runs]
    d = np.asarray(g) - np.asarray(p)
    lines.append(f"  gyrocompassing over the alignment: heading error {_fmt(*_ci(g))}, "
                 f"RMS {math.sqrt(float(np.mean(np.square(g)))):.4f}; the closed form "
                 f"-b_E / (Omega cos L) from the true east bias {_fmt(*_ci(p))}; their "
                 f"difference at most {float(np.max(np.abs(d))):.2e} deg")
    return lines


def _rrd_outputs(path: str, overwrite: bool):
    """The --rrd recording checked before any work by the project's output rules
    (:class:`fogbench.outputs.folders.Outputs`: an existing file replaced only when it is a
    Rerun recording and with ``overwrite``, never a folder or a symbolic link); exits 2
    naming what is wrong."""
    import sys
    from pathlib import Path

    from fogbench.outputs.folders import OutDirError, Outputs

    def is_rrd(p: Path) -> bool:
        with open(p, "rb") as fh:
            return fh.read(4) == b"RRF2"

    p = Path(path)
    try:
        if p.suffix != ".rrd":
            raise OutDirError(f"--rrd {path}: the recording's name must end in .rrd")
        out = Outputs(overwrite, "bench attitude")
        out.target(p, recognise=is_rrd, what="Rerun recording", flag="--rrd")
    except OutDirError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    return out, p


def main(argv=None) -> int:
    a = argparse.ArgumentParser(prog="python -m fogbench.bench.attitude",
                                description=__doc__.splitlines()[0])
    a.add_argument("--replicates", type=int, default=20)
    a.add_argument("--preset", default="navigation")
    a.add_argument("--hold-s", type=float, default=3600.0)
    a.add_argument("--triad", action="store_true", help="the triad calibrated on the table, "
                   "then a manoeuvre (triad_study)")
    a.add_argument("--device", metavar="DEVICE.toml", help="a device file instead of the "
                   "preset (--triad: instead of TRIAD_KEYS); a triad device file ([x], [y], [z]) "
                   "drives each gyro with its own terms and its Tw, Tg_dph_per_g")
    a.add_argument("--rrd", metavar="PATH", help="with --triad: write a Rerun recording of the "
                   "first replicate's integrated attitudes beside the true one (.rrd; refused "
                   "if PATH exists and is not a Rerun recording)")
    a.add_argument("--overwrite", action="store_true", help="with --rrd: replace an existing "
                   "Rerun recording at PATH")
    args = a.parse_args(argv)
    if args.rrd and not args.triad:
        a.error("--rrd needs --triad")
    if args.rrd:
        rrd_out, rrd = _rrd_outputs(args.rrd, args.overwrite)
    if args.device:
        from fogbench.scenario import ScenarioError
        from fogbench.scenario.device_file import load_device_file

        try:
            load_device_file(args.device)          # refused before any simulation
        except ScenarioError as exc:
            raise SystemExit(f"--device: {exc}") from None
    if args.triad:
        study = triad_study(args.replicates, device=args.device)
        for line in triad_report(study):
            print(line, flush=True)
        if args.rrd:
            from fogbench.recording.attitude import write_attitude_recording

            h = study["history"]
            mag = []
            try:
                rrd_out.write(rrd, lambda tmp: mag.append(write_attitude_recording(
                    tmp, h["t"], h["truth"], h["estimates"],
                    title="triad attitude (bench attitude --triad)")))
                rrd_out.commit()
            finally:
                rrd_out.discard()
            mag = mag[0]
            print(f"wrote {args.rrd} (orientation errors drawn magnified {mag:g} times; open "
                  f"with: rerun {args.rrd})", flush=True)
        return 0
    for line in report(attitude_study(args.replicates, args.preset, hold_s=args.hold_s,
                                      device=args.device)):
        print(line, flush=True)
    return 0



# ---------------------------------------------------------------------------------------------
# The triad calibrated on the table, then a manoeuvre

#: The triad of the second study: the tactical preset with cross-axis terms the calibration is
#: to find. Illustrative values of a tactical triad's order (misalignments of 0.05-0.2 mrad,
#: g-sensitivities of 0.1-0.6 deg/h/g per axis and direction), not a datasheet's: the question
#: is whether the lab's procedure recovers what is configured.
TRIAD_KEYS = {"preset": "tactical", "axes": ["x", "y", "z"],
              "misalignment_mrad": [[0.0, 0.2, -0.1], [0.15, 0.0, 0.1], [-0.2, 0.05, 0.0]],
              "g_sens_dph_per_g": [[0.3, -0.2, 0.5], [0.1, 0.4, -0.3], [-0.2, 0.2, 0.6]]}
TRIAD_FS_HZ = 100.0


def calibration_program():
    """The lab's program: at each turntable angle 0, 90, 180, 270 deg, the tilt 0 -> +90 ->
    -90 -> 0 deg with 30 s dwells (rotations about the sensor's x or y, and gravity along +-x,
    +-y, +z); then two turns about z each way level and at tilt 90. Tilt and turntable never
    move at once: the lab's reference integrates the commanded path, and a combined move's
    actual path turns the body otherwise (the rotations do not commute)."""
    from sim.motion import ConstantRate, Positions

    d = math.radians
    tilts = lambda: Positions(tilts=(0.0, d(90), d(-90), 0.0), headings=(0.0,), dwell=30.0,
                              move_time=15.0)
    quarter = ConstantRate(9.0, d(10))
    return (tilts(), quarter, tilts(), quarter, tilts(), quarter, tilts(), quarter,
            ConstantRate(36.0, d(10)), ConstantRate(36.0, d(-10)),
            Positions(tilts=(d(90),), headings=(0.0,), dwell=5.0, move_time=15.0),
            ConstantRate(36.0, d(10)), ConstantRate(36.0, d(-10)),
            Positions(tilts=(0.0,), headings=(0.0,), dwell=10.0, move_time=15.0))


def manoeuvre_program(align_s: float = 600.0, hold_s: float = 600.0):
    """Alignment (level, still), a turn about z, the tilt out and back about x and, a quarter
    turn on, about y, a quarter turn back, then a hold: it ends in the pose it started in."""
    from sim.motion import ConstantRate, Hold, Positions

    d = math.radians
    tilts = Positions(tilts=(d(60), d(-60), 0.0), headings=(0.0,), dwell=5.0, move_time=10.0)
    return (Hold(align_s, tilt=0.0), ConstantRate(36.0, d(10)), tilts,
            ConstantRate(9.0, d(10)), tilts, ConstantRate(9.0, d(-10)), Hold(hold_s))


def triad_study(replicates: int = 20, seed: int = 4300, align_s: float = 600.0,
                hold_s: float = 600.0, device: str | None = None) -> dict:
    """Per replicate: the triad calibrated on one power-on of the lab's program (its lab
    references, ``fogcomp.triad.fit_triad`` over :func:`fogcomp.triad.motion_blocks`), the
    fitted matrices against the configured ones (z-scores), then another power-on's manoeuvre
    integrated from the end of its alignment: raw, bias at alignment only, the triad model
    with the bias at alignment, the oracle and the truth itself (the integration's floor);
    orientation and heading errors at the manoeuvre's end and after the hold, deg."""
    from fogcomp.attitude import (attitude_errors, earth_rate_ned, integrate_attitude,
                                  true_attitude)
    from fogcomp.triad import fit_triad, motion_blocks
    from sim.lab import LabKnowledge, commanded_angles, lab_reference
    from fogbench.scenario.device_triad import triad_matrices
    from sim.rig import Run, simulate_run

    keys = TRIAD_KEYS if device is None else {"device": device, "axes": ["x", "y", "z"]}
    rig = _rig(keys, TRIAD_FS_HZ)
    fs, lat = rig.fs, rig.table.latitude
    # the configured M and G: row a from gyro a's terms (a triad device file: each its own)
    true_M, true_G = triad_matrices(rig.fog)
    n_al = int(round(align_s * fs))
    man = manoeuvre_program(align_s, hold_s)
    n_hold = int(round(hold_s * fs))
    cal_truth = test_truth = None
    out = []
    shown: dict = {}            # the first replicate's integrated attitudes (the recording)
    history = None
    for r in range(replicates):
        cal = simulate_run(rig, Run("calibration", seed + 2 * r, calibration_program(), None),
                           truth=cal_truth)
        cal_truth = cal.truth
        lab = LabKnowledge()
        ref, f = lab_reference(cal.truth, rig.table, lab)
        tilt_c, _ = commanded_angles(cal.truth, lab)
        model = fit_triad(cal.fog.raw, ref, f,
                          blocks=motion_blocks(tilt_c, cal.truth.turn_rate_cmd, fs))
        zM = ((model.M - true_M) / model.M_se)
        zG = ((model.G - true_G) / model.G_se)
        test = simulate_run(rig, Run("manoeuvre", seed + 2 * r + 1, man, None), truth=test_truth)
        test_truth = test.truth
        C = true_attitude(test.truth.fog_quat, rig.table.heading)
        raw = np.asarray(test.fog.raw, dtype=float)
        f_true = np.asarray(test.truth.specific_force, dtype=float)   # ideal accelerometers
        earth_b = C[:n_al].inv().apply(earth_rate_ned(lat))
        det = sum(np.asarray(v, dtype=float) for k, v in test.fog.terms.items()
                  if k in DETERMINISTIC)
        b_triad = model.bias_at(raw[:n_al], earth_b, f_true[:n_al])
        readings = {
            "raw": raw,
            "bias_at_alignment": raw - (raw[:n_al] - earth_b).mean(axis=0),
            "triad_calibrated": model.correct(raw, f_true, bias=b_triad),
            "oracle": raw - det,
            "truth": np.asarray(test.truth.rate, dtype=float),
        }
        n = raw.shape[0]
        ends = {"manoeuvre_end": n - n_hold, "hold_end": n}
        res = {"zM": zM, "zG": zG, "M_err_mrad": (model.M - true_M) * 1e3,
               "G_err_dph_per_g": (model.G - true_G) / DPH}
        for name, w in readings.items():
            est = integrate_attitude(C[n_al], w[n_al:] / fs, fs, latitude=lat)
            if r == 0 and name != "truth":
                shown[name] = est[:-1]
            idx = [e - n_al for e in ends.values()]
            err = attitude_errors(est[idx], C[[min(e, n - 1) for e in ends.values()]])
            res[name] = {k.replace("_rad", "_deg"): np.degrees(v) for k, v in err.items()}
        out.append(res)
        if r == 0:
            history = {"t": np.arange(n - n_al) / fs, "truth": C[n_al:], "estimates": shown}
    return {"runs": out, "ends": ["manoeuvre_end", "hold_end"], "true_M": true_M,
            "true_G": true_G, "align_s": align_s, "hold_s": hold_s, "device": device,
            "history": history}


def triad_report(study: dict) -> list[str]:
    runs = study["runs"]
    R = len(runs)
    z = np.array([np.concatenate([r["zM"].ravel(), r["zG"].ravel()]) for r in runs])
    inM = float(np.mean(np.abs(z[:, :9]) <= 1.96))
    inG = float(np.mean(np.abs(z[:, 9:]) <= 1.96))
    what = ("a tactical FOG triad (cross-axis terms configured)" if study.get("device") is None
            else f"the FOG triad of {study['device']}")
    lines = [f"{what} calibrated on the table "
             f"against the lab's references, over {R} power-ons: the fitted M's 9 entries "
             f"inside their 95 % intervals {inM:.0%} of the time, G's {inG:.0%} (nominal 95 %); "
             f"RMS error M {float(np.sqrt(np.mean([np.square(r['M_err_mrad']) for r in runs]))):.4f}"
             f" mrad, G {float(np.sqrt(np.mean([np.square(r['G_err_dph_per_g']) for r in runs]))):.3f}"
             " deg/h/g",
             (f"  the device: preset {TRIAD_KEYS['preset']} with misalignment_mrad "
              f"{TRIAD_KEYS['misalignment_mrad']} and g_sens_dph_per_g "
              f"{TRIAD_KEYS['g_sens_dph_per_g']} (illustrative, not a datasheet's)"
              if study.get("device") is None else
              f"  the device: device file {study['device']} (M diagonal "
              f"{np.round(np.diag(study['true_M']), 6).tolist()}, G "
              f"{np.round(study['true_G'] / DPH, 4).tolist()} deg/h/g)"),
             f"  then another power-on: {study['align_s']:g} s alignment, a manoeuvre (a turn, "
             f"tilts about x and y), {study['hold_s']:g} s hold; mean [95 % interval], deg"]
    for key, label in (("orientation_error_deg", "orientation"), ("heading_error_deg",
                                                                   "heading")):
        lines.append(f"  {label} error at the manoeuvre's end, after the hold")
        for name in ("raw", "bias_at_alignment", "triad_calibrated", "oracle", "truth"):
            cells = [_fmt(*_ci([r[name][key][i] for r in runs])) for i in range(2)]
            lines.append(f"    {name:18s} " + "   ".join(cells))
    floor = max(float(np.max(r["truth"]["orientation_error_deg"])) for r in runs) * 3600.0
    lines.append(f"  the truth integrated (the strapdown algorithm's floor at {TRIAD_FS_HZ:g} Hz): "
                 f"at most {floor:.3g} arcsec")
    return lines


if __name__ == "__main__":
    raise SystemExit(main())
