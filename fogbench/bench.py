"""Throughput benchmark (prints figures; it is not a test and asserts nothing about speed).

Measured in one run, each ``repeats`` times, medians quoted:
1. bare ``mujoco.rollout`` of the rate-table model: physics steps per second, with the controls
   made beforehand (the reference);
2. the rig's truth (``simulate_truth``: commands, rollout, per-sample averaging, Earth rate):
   physics steps per second and truth samples per second, and its ratio to (1);
3. the FOG error model (``simulate_fog``, tactical preset, every term on): samples per second;

then the Allan deviation, the CSV writer, every method (the Kalman engines first), every bundled
scenario's first run and one replicate after it, the replicates per second, and the noise identifier
(``fogbench.bench_noise``: its accuracy and coverage on records of known noise, and the time to
identify 10^7 samples), and the device-file round trip (``fogbench.bench_device``: every preset's
static logs simulated, a device file fitted and compared with the preset).
"""

from __future__ import annotations

import math
import statistics
import time

import mujoco
import numpy as np
from mujoco import rollout

from sim.fog import simulate_fog
from sim.motion import ConstantRate, SineRate
from sim.rate_table import TableConfig, load_model, simulate_truth, substeps_for


def _tactical_params():
    from .scenario import _fog, _Table

    params, *_ = _fog(_Table({"preset": "tactical", "g2_sens_dph_per_g2": [0.01] * 6,
                              "temp_coeff2_dph_per_c2": 0.001,
                              "misalignment_mrad": [[0, 0.1, 0.1], [0.1, 0, 0.1], [0.1, 0.1, 0]],
                              "rate_ramp_dph_per_h": 0.01}, "[fog]", "bench"), 100.0)
    return params


def main(seconds: float = 600.0, repeats: int = 5, noise_seeds: int = 20) -> int:
    fs = 100.0
    cfg = TableConfig(radius=0.1)
    k, dt = substeps_for(fs, cfg.physics_dt)
    segs = [ConstantRate(seconds / 2, math.radians(-60.0), tilt=math.radians(30.0)),
            SineRate(seconds / 2, math.radians(20.0), 0.5)]
    nsteps = int(round(seconds / dt))
    model = load_model(cfg, dt)
    data = mujoco.MjData(model)
    state = np.zeros(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ctrl = np.zeros((1, nsteps, model.nu))
    ctrl[0, :, 2] = math.radians(-60.0)

    bare, rig = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rollout.rollout(model, data, state[None], ctrl)
        bare.append(nsteps / (time.perf_counter() - t0))
        t0 = time.perf_counter()
        truth = simulate_truth(segs, fs, cfg)
        rig.append(truth.physics_steps / (time.perf_counter() - t0))
    n_fog = int(seconds * fs) * 10
    params = _tactical_params()
    rng = np.random.default_rng(0)
    w = rng.standard_normal((n_fog, 3)) * 0.1
    f = np.tile([0.0, 0.0, 1.0], (n_fog, 1))
    T = np.linspace(-40, 60, n_fog)
    Tdot = np.full(n_fog, 0.2 / 60)
    fog = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate_fog(params, fs, w, f, T, Tdot, axes=("z",), seed=1)
        fog.append(n_fog / (time.perf_counter() - t0))

    mb, mr, mf = (statistics.median(x) for x in (bare, rig, fog))
    print(f"fogbench bench: {repeats} repeats, medians; physics dt = {dt * 1e3:g} ms, "
          f"{k} physics steps per FOG sample at {fs:g} Hz")
    print(f"  bare mujoco.rollout        {mb / 1e6:8.3f} M physics steps/s  ({nsteps} steps)")
    print(f"  rig truth (simulate_truth) {mr / 1e6:8.3f} M physics steps/s  = "
          f"{mr / k / 1e3:8.1f} k truth samples/s   ratio to bare rollout {mr / mb:6.1%}")
    print(f"  FOG error model            {mf / 1e6:8.3f} M samples/s  ({n_fog} samples, tactical "
          f"preset, all terms, one axis)")
    print("  aims: rig >= 80 % of bare rollout; error model >= 10 M samples/s")
    print(f"  spread (min..max): bare {min(bare) / 1e6:.3f}..{max(bare) / 1e6:.3f}, "
          f"rig {min(rig) / 1e6:.3f}..{max(rig) / 1e6:.3f}, "
          f"fog {min(fog) / 1e6:.3f}..{max(fog) / 1e6:.3f} M/s")
    from .bench_allan import bench_allan, bench_compensate_write

    print()
    bench_allan(n=10**7, repeats=min(repeats, 3))
    print()
    bench_compensate_write(repeats=min(repeats, 3))
    from .bench_methods import main as bench_methods

    print()
    bench_methods(repeats=min(repeats, 3))
    print()
    bench_scenario_replicates()
    print()
    bench_replicates()
    from .bench_noise import run as bench_noise

    print()
    bench_noise(seeds=noise_seeds)
    from .bench_device import run as bench_device

    print()
    bench_device(seeds=noise_seeds)
    return 0


def _warm_up(i: int) -> int:
    import fogbench.runner  # noqa: F401  (the imports a replicate needs)

    time.sleep(0.2)  # keep this worker busy so that every worker gets one
    return i


def bench_scenario_replicates(root=None) -> list[dict]:
    """Every bundled scenario: its first run (the table's motion simulated by MuJoCo, then
    replicate 0 in full, as ``fogbench run`` and the suite do) and one replicate after it (the
    table's motion reused, what each further replicate costs a worker), in one process, each
    once; the replicate as a ratio to the first run. ``make run`` costs about the first runs
    plus (R - 1) replicates per scenario, shared between the processes."""
    import tempfile
    from pathlib import Path

    from .executor import SerialExecutor
    from .montecarlo import ScenarioMC

    root = Path(root) if root else Path(__file__).resolve().parents[1] / "scenarios"
    paths = sorted(root.glob("*.toml"))
    print(f"Scenarios: the first run (table + replicate 0) and one replicate after it, one "
          f"process, wall time, {len(paths)} scenario(s) of {root}")
    print(f"  {'scenario':<26}{'table s':>9}{'replicate 0 s':>15}{'replicate 1 s':>15}"
          f"{'replicate / first run':>23}{'replicates':>12}", flush=True)
    rows = []
    for path in paths:
        with tempfile.TemporaryDirectory() as d:
            mc = ScenarioMC(path, Path(d) / "run", replicates=2)
            mc.simulate_truths()
            t0 = time.perf_counter()
            mc.run_first()
            first_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            with SerialExecutor() as ex:
                mc.submit(ex)
                mc.wait()
            rep_s = time.perf_counter() - t0
            failed = bool(mc.failures)
            mc.work.remove()
        row = {"scenario": mc.sc.name, "table_s": mc.truth_s, "first_s": first_s,
               "replicate_s": rep_s, "ratio": rep_s / (mc.truth_s + first_s),
               "replicates": mc.plan.replicates, "failed": failed}
        rows.append(row)
        print(f"  {row['scenario']:<26}{row['table_s']:>9.1f}{first_s:>15.1f}{rep_s:>15.1f}"
              f"{row['ratio']:>23.2f}{row['replicates']:>12}"
              + ("  (the replicate failed)" if failed else ""), flush=True)
    total = sum(r["table_s"] + r["first_s"] + (r["replicates"] - 1) * r["replicate_s"]
                for r in rows)
    print(f"  one process would need about {total / 60:.1f} min for every scenario's replicates "
          "(first run + (R - 1) replicates each); make run shares them between the processes "
          "and also writes figures, recordings and the claim maps")
    return rows


def bench_replicates(names=("paper000_wnn", "paper002_acobp"), replicates: int = 10) -> None:
    """Replicates per second of two bundled scenarios on 1 and on 2 local processes, and the
    parallel efficiency (rate on 2 / (2 x rate on 1)); the table's motion is simulated before
    the clock starts, as the runner does once per run definition."""
    import tempfile
    from pathlib import Path

    from .executor import make_executor
    from .montecarlo import ScenarioMC

    root = Path(__file__).resolve().parents[1] / "scenarios"
    print(f"Monte Carlo: {replicates} replicates after replicate 0, wall time")
    for name in names:
        path = root / f"{name}.toml"
        if not path.exists():
            print(f"  {name}: {path} not found; skipped")
            continue
        rates = {}
        for jobs in (1, 2):
            with tempfile.TemporaryDirectory() as d:
                mc = ScenarioMC(path, Path(d) / "run", replicates=replicates + 1)
                mc.simulate_truths()
                with make_executor(jobs=jobs) as ex:
                    # start the workers and import the bench in them before the clock starts
                    for f in [ex.submit(_warm_up, i) for i in range(2 * jobs)]:
                        f.result()
                    t0 = time.perf_counter()
                    mc.submit(ex)
                    mc.wait()
                    rates[jobs] = replicates / (time.perf_counter() - t0)
                mc.work.remove()
        print(f"  {name:16s} {rates[1]:7.2f} replicates/s on 1 process, {rates[2]:7.2f} on 2: "
              f"parallel efficiency {rates[2] / (2 * rates[1]):.0%}")
