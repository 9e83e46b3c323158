"""Laws of the configured devices: each preset's flicker floor over its own band, the oracle's
residual is noise only, and the fitted paper002_fog reproduces paper 002 Table 1 per segment
within the residual its fit reports (scripts/fit_paper002_preset.py)."""

import math

import allantools
import numpy as np
import pytest

from fogbench.scenario.device_file import _fog
from fogbench.scenario.tables import _Table
from fogcomp import units as U
from sim.fog import simulate_fog
from sim.rig import load_presets
from sim.thermal import ThermalHold, ThermalProgram, ThermalRamp, simulate_thermal


def preset(name, fs=1.0):
    params, _, _, _, thermal, _ = _fog(_Table({"preset": name}, "[fog]", "test"), fs)
    return params, thermal


def allan_of_psd(S, f, tau):
    """Allan variance from a one-sided PSD by numerical integration of the Allan transfer
    function 2 sin^4(pi f tau) / (pi f tau)^2 (IEEE Std 952, eq. C.2): independent of how the
    simulator builds its flicker."""
    x = np.pi * f * tau
    return np.trapezoid(S * 2 * np.sin(x) ** 4 / x**2, f)


@pytest.mark.parametrize("name", [n for n, v in load_presets().items()
                                  if v.get("bias_instability_dph")])
def test_flicker_floor_over_each_presets_band(name):
    """The sum of Gauss-Markov components of each preset gives a flat Allan floor of 0.664 B
    for averaging times well inside its band: tau from 3 / f_high to 0.03 / f_low, capped at
    one day (the longest record a scenario holds)."""
    from sim.fog import bias_instability_components

    p, _ = preset(name, fs=200.0)
    B, (f_lo, f_hi) = p.bias_instability, p.bi_band
    corners, sigma = bias_instability_components(B, p.bi_band, p.bi_per_decade)
    f = np.geomspace(f_lo * 1e-3, f_hi * 1e3, 20000)
    tc = 1 / (2 * np.pi * corners)
    S = (4 * sigma**2 * tc[None, :] / (1 + (2 * np.pi * f[:, None] * tc[None, :]) ** 2)).sum(1)
    taus = np.geomspace(3.0 / f_hi, min(0.03 / f_lo, 86400.0), 8)
    ad = np.sqrt([allan_of_psd(S, f, t) for t in taus])
    np.testing.assert_allclose(ad / B, math.sqrt(2 * math.log(2) / math.pi), rtol=0.08)


def test_oracle_residual_has_only_the_noise_signatures():
    """Raw minus the true deterministic terms (the oracle) minus the truth, for the tactical
    preset in a thermal ramp with every term on: its Allan deviation is that of the configured
    ARW, flicker and rate random walk (sum of variances), not of any temperature or bias term."""
    fs, n = 10.0, 400_000
    p, tm = preset("tactical", fs)
    prog = ThermalProgram(start=0.0, steps=(ThermalRamp(40.0, 0.5 / 60.0), ThermalHold(1e5)))
    t = np.arange(n) / fs
    th = simulate_thermal(prog, t, tm)
    w = np.zeros((n, 3))
    f = np.tile([0.0, 0.0, 1.0], (n, 1))
    out = simulate_fog(p, fs, w, f, th.coil, th.coil_rate, ("z",), seed=12)
    noise = ("arw", "bias_instability", "gm_drift", "rrw", "quantization")
    assert set(out.terms) - set(noise)      # deterministic terms are present and large
    resid = out.raw[:, 0] - out.deterministic_error(exclude=noise)[:, 0] - w[:, 2]
    taus, ad, *_ = allantools.oadev(resid, rate=fs, data_type="freq",
                                    taus=[1.0, 10.0, 100.0, 1000.0])
    N, K, B = p.arw, p.rrw, p.bias_instability
    Q = p.quantization
    model = np.sqrt(N**2 / taus + K**2 * taus / 3 + (0.664 * B) ** 2 + 3 * Q**2 / 12 / taus**2)
    np.testing.assert_allclose(ad / model, 1.0, rtol=0.2)


# Paper 002 Table 1 (deg/h), per segment, test samples 1-3, typed from the paper.
TABLE1 = np.array([
    [0.0079, 0.0117, 0.0102], [0.0540, 0.0543, 0.0561], [0.0084, 0.0101, 0.0078],
    [0.0632, 0.0612, 0.0627], [0.0110, 0.0092, 0.0085], [0.0696, 0.0687, 0.0669],
    [0.0090, 0.0074, 0.0082], [0.0620, 0.0558, 0.0564], [0.0089, 0.0083, 0.0098],
    [0.0381, 0.0403, 0.0436], [0.0079, 0.0089, 0.0097]])
# The fit's reported residuals (scripts/fit_paper002_preset.py, sim/presets.toml): the largest
# |log(model / paper)| over the segments is 0.54 (ramp 0..20); the whole run is 3.3x the paper's.
FIT_MAX_LOG_RESIDUAL = 0.54
WHOLE_RUN_RATIO = 3.28


def test_fitted_paper002_preset_reproduces_table1_within_its_residual():
    """Simulate the preset (every term on) through the paper's program, three power-ons as the
    paper's three runs, and compute eq. 5 per segment. Each segment's mean over the three runs
    lies within the fit's largest residual of the paper's mean (plus the simulation's own
    three-run scatter, 0.15 in log), holds stay calm and ramps carry the thermal error."""
    fs = 1.0
    p, tm = preset("paper002_fog", fs)
    steps = [ThermalHold(3600.0)]
    for T in (-20.0, 0.0, 20.0, 40.0, 60.0):
        steps += [ThermalRamp(T, 0.2 / 60.0), ThermalHold(3600.0)]
    prog = ThermalProgram(start=-40.0, steps=tuple(steps))
    n = int(prog.duration * fs)
    t = np.arange(n) / fs
    bt = prog.breakpoints()[0]
    w = np.zeros((n, 3))
    f = np.tile([0.0, 0.0, 1.0], (n, 1))

    def bs(x):
        return np.std(x[: x.size // 100 * 100].reshape(-1, 100).mean(1), ddof=1) / U.DPH

    seg, whole = [], []
    for seed in (1, 2, 3):
        th = simulate_thermal(prog, t, tm, seed=seed)
        raw = simulate_fog(p, fs, w, f, th.coil, th.coil_rate, ("z",), seed=seed).raw[:, 0]
        seg.append([bs(raw[int(bt[i]):int(bt[i + 1])]) for i in range(len(bt) - 1)])
        whole.append(bs(raw))
    seg = np.mean(seg, axis=0)
    lr = np.abs(np.log(seg / TABLE1.mean(axis=1)))
    print("sim / paper per segment:", np.round(seg / TABLE1.mean(axis=1), 2))
    assert np.all(lr < FIT_MAX_LOG_RESIDUAL + 0.15)
    assert seg[0::2].max() < 0.02 and seg[1::2].min() > 0.03     # holds calm, ramps not
    print("whole run sim / paper:", np.mean(whole) / 0.0541)
    assert abs(math.log(np.mean(whole) / 0.0541 / WHOLE_RUN_RATIO)) < 0.2
