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

__all__ = ["attitude_study", "main"]

LATITUDE_DEG = 45.0
HEADING_DEG = 30.0
FS_HZ = 10.0
#: the terms a model of the inputs could predict (fogbench.run.runner.DETERMINISTIC)
DETERMINISTIC = ("constant_bias", "switch_on_bias", "rate_ramp", "scale_factor", "misalignment",
                 "g_sensitivity", "g2_sensitivity", "temperature")
REPORT_S = (60.0, 600.0, 3600.0)


def _rig(preset: str):
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table
    from sim.rate_table import TableConfig
    from sim.rig import Rig

    params, *_ = _fog(_Table({"preset": preset}, "[fog]", "bench attitude"), FS_HZ)
    table = TableConfig(latitude=math.radians(LATITUDE_DEG), heading=math.radians(HEADING_DEG))
    return Rig(fs=FS_HZ, table=table, fog=params, axes=("x", "y", "z"))


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
    from fogcomp.units import EARTH_RATE

    predicted = -b_east / (EARTH_RATE * math.cos(lat))
    out["gyrocompass"] = {"heading_error_deg": math.degrees(float(err)),
                          "predicted_deg": math.degrees(predicted)}
    return out, rd.truth


def _ci(v) -> tuple[float, float, float]:
    from scipy import stats

    v = np.asarray(v, dtype=float)
    m = float(v.mean())
    if v.size < 2:
        return m, math.nan, math.nan
    h = float(stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / math.sqrt(v.size))
    return m, m - h, m + h


def attitude_study(replicates: int = 20, preset: str = "navigation", align_s: float = 600.0,
                   hold_s: float = 3600.0, seed: int = 4200) -> dict:
    """Every replicate's results: {"runs": [per replicate], "times_s": [...]}."""
    rig = _rig(preset)
    runs, truth = [], None
    for r in range(replicates):
        res, truth = _one(rig, seed + r, align_s, hold_s, truth)
        runs.append(res)
    return {"runs": runs, "times_s": [t for t in REPORT_S if t <= hold_s], "preset": preset,
            "align_s": align_s, "hold_s": hold_s}


def _fmt(m, lo, hi) -> str:
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


def main(argv=None) -> int:
    a = argparse.ArgumentParser(prog="python -m fogbench.bench.attitude",
                                description=__doc__.splitlines()[0])
    a.add_argument("--replicates", type=int, default=20)
    a.add_argument("--preset", default="navigation")
    a.add_argument("--hold-s", type=float, default=3600.0)
    args = a.parse_args(argv)
    for line in report(attitude_study(args.replicates, args.preset, hold_s=args.hold_s)):
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
