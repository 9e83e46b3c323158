"""Truth closure: integrate perfect-gyro samples (the truth's rate, every error off) to attitude
and compare with the table's own poses. Prints the final and worst orientation error, arcsec,
for a program that tilts and turns at once and for every table program of scenarios/*.toml.

    python -m fogbench.bench.truth_closure [--scenarios] [--dt 1e-3]

(``scripts/truth_closure.py`` runs the same; ``tests/sim/test_truth_closure.py`` uses its
program and :func:`closure`.)
"""

from __future__ import annotations

import argparse
import dataclasses
import glob
import math
import sys
import time


from fogcomp.attitude import integrate_attitude, orientation_error, true_attitude
from sim.motion import ConstantRate, Hold, Positions, RateSteps, SineRate
from sim.rate_table import TableConfig, simulate_truth

ARCSEC = math.radians(1 / 3600)
D = math.radians


def tilt_and_turn_program():
    """~193 s: spin while tilting, positions, a sine, rate steps, a hold."""
    return [
        Hold(2.0),
        ConstantRate(20.0, D(60.0), tilt=D(90.0)),     # spins up while the tilt moves 90 deg
        ConstantRate(10.0, D(-45.0), tilt=D(30.0)),
        Positions(tilts=(D(0.0), D(90.0), D(180.0)), headings=(D(90.0), D(-90.0)),
                  dwell=3.0, move_time=10.0),
        SineRate(20.0, D(40.0), 0.5, tilt=D(45.0)),
        RateSteps((D(10.0), D(-30.0), D(100.0), D(0.0)), 8.0, tilt=D(-60.0)),
        Hold(31.0, tilt=D(0.0)),
    ]


def closure(segments, fs, cfg, tilt0=0.0):
    """(the orientation error of the truth's rate integrated against the table's poses, arcsec,
    at every sample; the truth) of a program simulated at ``fs`` on a table ``cfg``."""
    tr = simulate_truth(segments, fs, cfg, tilt0=tilt0)
    true = true_attitude(tr.fog_quat, cfg.heading)
    lat = cfg.latitude if cfg.earth_rate else None
    est = integrate_attitude(true[0], tr.rate / fs, fs, latitude=lat)
    return orientation_error(est[:len(true)], true) / ARCSEC, tr


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenarios", action="store_true", help="every scenario's table programs")
    ap.add_argument("--dt", type=float, default=None, help="physics step, s")
    ap.add_argument("--fs", type=float, default=100.0)
    ap.add_argument("--radius", type=float, default=0.1)
    ap.add_argument("--scenario-fs", type=float, default=None,
                    help="simulate the scenarios' programs at this rate instead of their own "
                         "(the integrator's own error shrinks; the truth's stays)")
    ap.add_argument("--only", default="", help="only scenario files containing this text")
    a = ap.parse_args(argv)
    cfg = TableConfig(radius=a.radius)
    if a.dt:
        cfg = dataclasses.replace(cfg, physics_dt=a.dt)
    prog = tilt_and_turn_program()
    t0 = time.perf_counter()
    err, _ = closure(prog, a.fs, cfg)
    fin, worst = float(err[-1]), float(err.max())
    print(f"tilt-and-turn program ({sum(s.duration for s in prog):g} s, fs {a.fs:g} Hz, "
          f"dt {cfg.physics_dt:g} s): final {fin:.4f} arcsec, worst {worst:.4f} arcsec "
          f"({time.perf_counter() - t0:.1f} s)")
    if a.scenarios:
        from fogbench.scenario.load import load_scenario
        from fogbench.scenario.load import RUNNER_SECTIONS
        seen = set()
        for path in sorted(glob.glob("scenarios/*.toml")):
            if a.only not in path:
                continue
            try:
                sc = load_scenario(path, extra_sections=RUNNER_SECTIONS)
            except Exception as e:  # noqa: BLE001 - report and go on
                print(f"{path}: not loaded ({e})", file=sys.stderr)
                continue
            for run in sc.runs:
                key = (run.motion, run.tilt0, sc.table, sc.fs)
                if key in seen:
                    continue
                seen.add(key)
                t0 = time.perf_counter()
                fs = a.scenario_fs or sc.fs
                err, _ = closure(run.motion, fs, sc.table, run.tilt0)
                fin, worst = float(err[-1]), float(err.max())
                print(f"{path} {run.name} ({run.duration:g} s, fs {fs:g}): final {fin:.4f}, "
                      f"worst {worst:.4f} arcsec ({time.perf_counter() - t0:.1f} s)")


if __name__ == "__main__":
    main()
