"""The rig's speed: bare ``mujoco.rollout`` of the rate-table model with the controls made
beforehand (the reference); the rig's truth (``simulate_truth``: commands, rollout, per-sample
averaging, Earth rate) as a ratio to it; the FOG error model (``simulate_fog``, tactical preset,
every term on) in samples per second."""

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
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table

    params, *_ = _fog(_Table({"preset": "tactical", "g2_sens_dph_per_g2": [0.01] * 6,
                              "temp_coeff2_dph_per_c2": 0.001,
                              "misalignment_mrad": [[0, 0.1, 0.1], [0.1, 0, 0.1], [0.1, 0.1, 0]],
                              "rate_ramp_dph_per_h": 0.01}, "[fog]", "bench"), 100.0)
    return params


def bench_rig(seconds: float = 600.0, repeats: int = 5) -> None:
    """Print the rig's and the error model's speed (see the module docstring)."""
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
