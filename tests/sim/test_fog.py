"""The FOG error model: each term's signature, superposition and determinism."""

import math

import allantools
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fogcomp import units as U
from sim.fog import TERMS, FogParams, bias_instability_components, simulate_fog

FS = 100.0


def inputs(n, seed=0, moving=True):
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((n, 3)) * (0.5 if moving else 0.0)
    f = rng.standard_normal((n, 3))
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    f *= rng.uniform(0.5, 1.5, (n, 1))
    T = np.linspace(-40.0, 60.0, n)
    Tdot = np.sin(np.arange(n) / 500.0) * 0.01
    return w, f, T, Tdot


ALL_ON = FogParams(
    bias=1 * U.DPH, switch_on_bias_sigma=0.5 * U.DPH, arw=0.03 * U.DEG_RT_H,
    bias_instability=0.1 * U.DPH, gm_drift=0.5 * U.DPH, gm_time_constant=10.0,
    rrw=0.1 * U.DPH_RT_H, rate_ramp=0.5 * U.DPH_PER_H,
    quantization=0.5 * U.ARCSEC, scale_factor=100e-6, sf_nonlinearity=50e-6, sf_temp_coeff=1e-6,
    misalignment=((0, 1e-4, -2e-4), (3e-4, 0, 1e-4), (-1e-4, 2e-4, 0)),
    g_sens=(0.1 * U.DPH, -0.2 * U.DPH, 0.3 * U.DPH),
    g2_sens=tuple(x * U.DPH for x in (0.01, 0.02, -0.03, 0.04, -0.05, 0.06)),
    g_sens_switch_on_sigma=0.05 * U.DPH, g2_sens_switch_on_sigma=0.01 * U.DPH,
    temp_coeff=0.01 * U.DPH, temp_coeff2=1e-4 * U.DPH, temp_rate_coeff=0.2 * U.DPH * 60,
    temp_cross_coeff=0.004 * U.DPH * 60,
)


def only(term, params=ALL_ON):
    return FogParams(**{**params.__dict__, "disabled": tuple(t for t in TERMS if t != term)})


def test_all_terms_off_output_equals_truth():
    w, f, T, Td = inputs(5000)
    out = simulate_fog(FogParams(disabled=TERMS), FS, w, f, T, Td, axes=("x", "y", "z"), seed=3)
    assert np.array_equal(out.raw, w)
    assert out.terms == {}
    out = simulate_fog(FogParams(), FS, w, f, T, Td, axes=("z",), seed=3)
    assert np.array_equal(out.raw[:, 0], w[:, 2])


@settings(max_examples=25, deadline=None)
@given(on=st.sets(st.sampled_from([t for t in TERMS if t != "saturation"]), min_size=1), seed=st.integers(0, 2**32 - 1),
       axes=st.sampled_from([("z",), ("x", "y", "z"), ("y", "x")]))
def test_superposition_and_independent_streams(on, seed, axes):
    """raw = truth + sum of terms; and a term is the same whether or not the others are on
    (quantisation excepted: it quantises the sum; saturation, which clips the sum, has its own
    test below, and ALL_ON has no range)."""
    w, f, T, Td = inputs(3000, seed=1)
    params = FogParams(**{**ALL_ON.__dict__, "disabled": tuple(t for t in TERMS if t not in on)})
    out = simulate_fog(params, FS, w, f, T, Td, axes=axes, seed=seed)
    idx = ["xyz".index(a) for a in axes]
    total = w[:, idx] + sum(out.terms.values())
    np.testing.assert_allclose(out.raw, total, rtol=0, atol=1e-15)
    assert set(out.terms) == on
    for term in on - {"quantization"}:
        alone = simulate_fog(only(term), FS, w, f, T, Td, axes=axes, seed=seed)
        np.testing.assert_array_equal(alone.terms[term], out.terms[term], err_msg=term)


def test_determinism_under_a_seed():
    w, f, T, Td = inputs(4000)
    a = simulate_fog(ALL_ON, FS, w, f, T, Td, axes=("x", "y", "z"), seed=7)
    b = simulate_fog(ALL_ON, FS, w, f, T, Td, axes=("x", "y", "z"), seed=7)
    c = simulate_fog(ALL_ON, FS, w, f, T, Td, axes=("x", "y", "z"), seed=8)
    assert np.array_equal(a.raw, b.raw)
    assert all(np.array_equal(a.terms[k], b.terms[k]) for k in a.terms)
    assert not np.array_equal(a.terms["arw"], c.terms["arw"])
    assert a.draws["switch_on_bias"][0] != c.draws["switch_on_bias"][0]


def test_constant_and_switch_on_bias():
    w, f, T, Td = inputs(1000)
    p = FogParams(bias=2 * U.DPH, switch_on_bias_sigma=1 * U.DPH)
    draws = [simulate_fog(p, FS, w, f, axes=("z",), seed=s).draws["switch_on_bias"][0]
             for s in range(400)]
    out = simulate_fog(p, FS, w, f, axes=("z",), seed=0)
    err = out.raw[:, 0] - w[:, 2]
    np.testing.assert_allclose(err, 2 * U.DPH + draws[0], rtol=0, atol=1e-15)
    # switch-on draws: mean 0, std sigma (400 draws: std error of the std ~3.5 %)
    assert abs(np.mean(draws)) < 4 * U.DPH / math.sqrt(400)
    assert abs(np.std(draws) / U.DPH - 1.0) < 0.15


def test_g_and_g2_sensitivity_are_the_linear_and_quadratic_laws():
    w, f, T, Td = inputs(2000)
    d_lin = np.array([0.7, -0.4, 0.2]) * U.DPH
    d_sq = np.array([0.1, 0.2, 0.3, -0.1, 0.05, -0.2]) * U.DPH
    out = simulate_fog(FogParams(g_sens=tuple(d_lin), g2_sens=tuple(d_sq)), FS, w, f,
                       axes=("z",), seed=0)
    fx, fy, fz = f.T
    np.testing.assert_allclose(out.terms["g_sensitivity"][:, 0], d_lin @ f.T, rtol=1e-12)
    quad = (d_sq[0] * fx**2 + d_sq[1] * fy**2 + d_sq[2] * fz**2 + d_sq[3] * fx * fy
            + d_sq[4] * fy * fz + d_sq[5] * fx * fz)
    np.testing.assert_allclose(out.terms["g2_sensitivity"][:, 0], quad, rtol=1e-10, atol=1e-20)
    # doubling f doubles the linear term and quadruples the quadratic one
    out2 = simulate_fog(FogParams(g_sens=tuple(d_lin), g2_sens=tuple(d_sq)), FS, w, 2 * f,
                        axes=("z",), seed=0)
    np.testing.assert_allclose(out2.terms["g_sensitivity"], 2 * out.terms["g_sensitivity"])
    np.testing.assert_allclose(out2.terms["g2_sensitivity"], 4 * out.terms["g2_sensitivity"])


def test_g_coefficients_change_at_each_switch_on():
    w, f, *_ = inputs(10)
    p = FogParams(g_sens=(1e-5, 0, 0), g_sens_switch_on_sigma=1e-6)
    d = np.array([simulate_fog(p, FS, w, f, axes=("z",), seed=s).draws["g_sens"][0]
                  for s in range(300)])
    assert abs(d[:, 0].mean() - 1e-5) < 4 * 1e-6 / math.sqrt(300)
    assert abs(d.std(axis=0).mean() / 1e-6 - 1) < 0.15


def _term(params, term, w, T, Td, axis="z", n_f=None):
    """One error term for explicit per-sample inputs (rate w as (n, 3), T, Tdot)."""
    n = w.shape[0]
    f = np.tile([0.0, 0.0, 1.0], (n, 1))
    out = simulate_fog(params, FS, w, f, np.asarray(T, float), np.asarray(Td, float),
                       axes=(axis,), seed=0)
    return out.terms[term][:, 0]


def test_temperature_law():
    """Paper 002 eq. 1 read as a smooth bias b(T, Tdot), checked by its derivatives and special
    cases rather than by the closed form: b(T_ref, 0) = 0; at Tdot = 0 the central first
    difference at T_ref is the static slope c1 and every second difference is 2 c2 h^2 (a
    parabola in T); at T = T_ref it is linear in Tdot with slope c3 (the Shupe coefficient);
    the mixed difference b(T+h, Td+k) - b(T+h, Td) - b(T, Td+k) + b(T, Td) is c4 h k."""
    c1, c2, c3, c4 = 1e-6, 2e-8, 3e-4, 5e-6
    p = FogParams(temp_ref=20.0, temp_coeff=c1, temp_coeff2=c2, temp_rate_coeff=c3,
                  temp_cross_coeff=c4)
    h, k = 0.5, 0.002
    T = 20.0 + h * np.arange(-40, 41)                 # uniform grid through T_ref
    w = np.zeros((T.size, 3))
    b0 = _term(p, "temperature", w, T, np.zeros(T.size))
    assert b0[40] == 0.0                              # b(T_ref, 0) = 0
    assert (b0[41] - b0[39]) / (2 * h) == pytest.approx(c1, rel=1e-9)
    np.testing.assert_allclose(np.diff(b0, 2), 2 * c2 * h * h, rtol=1e-6)
    Td = k * np.arange(-20, 21)
    b1 = _term(p, "temperature", np.zeros((Td.size, 3)), np.full(Td.size, 20.0), Td)
    np.testing.assert_allclose(np.diff(b1), c3 * k, rtol=1e-9)
    rng = np.random.default_rng(0)
    T0, Td0 = rng.uniform(-40, 60, 50), rng.uniform(-0.01, 0.01, 50)
    z = np.zeros((50, 3))
    mixed = (_term(p, "temperature", z, T0 + h, Td0 + k) - _term(p, "temperature", z, T0 + h, Td0)
             - _term(p, "temperature", z, T0, Td0 + k) + _term(p, "temperature", z, T0, Td0))
    np.testing.assert_allclose(mixed, c4 * h * k, rtol=1e-6)


def test_scale_factor_misalignment_and_ramp():
    """The scale-factor error stated by what it must do, not by its formula: odd in the rate;
    at T_ref and rates far below full scale its slope is k0 (the nonlinearity, k_nl w|w|/w_fs,
    is second order); the nonlinearity is k_nl * w_fs at full scale by definition; the
    temperature coefficient is the numerical derivative d(error)/dT / w. Misalignment is the
    response to the other axes' rates (a finite difference in each). The rate ramp has zero
    second differences in time and slope rate_ramp."""
    k0, knl, kT, wfs = 1e-4, 2e-5, 1e-6, 5.0
    p = FogParams(scale_factor=k0, sf_nonlinearity=knl, full_scale=wfs, sf_temp_coeff=kT,
                  temp_ref=20.0)
    rates = np.array([-wfs, -1.0, -1e-3, 1e-3, 1.0, wfs])
    w = np.zeros((rates.size, 3))
    w[:, 0] = rates
    sf = _term(p, "scale_factor", w, np.full(rates.size, 20.0), np.zeros(rates.size), "x")
    np.testing.assert_allclose(sf, -sf[::-1], rtol=1e-12)            # odd
    # slope at 1e-3 rad/s: k0 (1 + k_nl 1e-3 / (w_fs k0)), within 4e-5 of k0
    assert sf[3] / 1e-3 == pytest.approx(k0, rel=1e-4)
    assert sf[5] - k0 * wfs == pytest.approx(knl * wfs, rel=1e-9)   # k_nl at full scale
    dT = 0.25
    up = _term(p, "scale_factor", w, np.full(rates.size, 20.0 + dT), np.zeros(rates.size), "x")
    dn = _term(p, "scale_factor", w, np.full(rates.size, 20.0 - dT), np.zeros(rates.size), "x")
    np.testing.assert_allclose((up - dn) / (2 * dT) / rates, kT, rtol=1e-6)
    m = FogParams(misalignment=((0, 1e-3, 2e-3), (0, 0, 0), (0, 0, 0)))
    base = np.zeros((3, 3))
    base[:, 0] = 0.3
    T3, Z3 = np.full(3, 20.0), np.zeros(3)
    for axis_j, want in ((1, 1e-3), (2, 2e-3)):
        moved = base.copy()
        moved[:, axis_j] += 0.7
        d = _term(m, "misalignment", moved, T3, Z3, "x") - _term(m, "misalignment", base, T3, Z3,
                                                                  "x")
        np.testing.assert_allclose(d / 0.7, want, rtol=1e-9)
    r = FogParams(rate_ramp=1e-7)
    ramp = _term(r, "rate_ramp", np.zeros((3000, 3)), np.full(3000, 20.0), np.zeros(3000), "x")
    np.testing.assert_allclose(np.diff(ramp) * FS, 1e-7, rtol=1e-6)
    assert np.max(np.abs(np.diff(ramp, 2))) < 1e-12 * 1e-7 * 3000 / FS


def test_quantisation_steps_are_whole_quanta_and_lose_no_angle():
    n = 20000
    rng = np.random.default_rng(2)
    w = np.zeros((n, 3))
    w[:, 2] = 0.01 + 1e-3 * rng.standard_normal(n)
    Q = 2.0 * U.ARCSEC
    out = simulate_fog(FogParams(quantization=Q), FS, w, np.tile([0, 0, 1.0], (n, 1)),
                       axes=("z",), seed=4)
    pulses = out.raw[:, 0] / FS / Q
    np.testing.assert_allclose(pulses, np.round(pulses), atol=1e-6)
    # a pulse counter loses no angle: the accumulated error stays within one quantum
    angle_err = np.cumsum(out.terms["quantization"][:, 0]) / FS
    assert np.abs(angle_err).max() <= Q * (1 + 1e-9)
    # quantisation noise of the angle is uniform over one quantum: its Allan deviation is
    # sqrt(3) (Q / sqrt(12)) / tau (IEEE Std 952, with the coefficient Q/sqrt(12))
    taus, adev, *_ = allantools.oadev(out.terms["quantization"][:, 0], rate=FS,
                                      data_type="freq", taus=[0.1, 1.0])
    np.testing.assert_allclose(adev, math.sqrt(3) * Q / math.sqrt(12) / taus, rtol=0.1)


def adev_of(term, params, n, seed=11, taus=None, fs=FS):
    w = np.zeros((n, 3))
    f = np.tile([0, 0, 1.0], (n, 1))
    out = simulate_fog(only(term, params), fs, w, f, axes=("z",), seed=seed)
    return allantools.oadev(out.raw[:, 0], rate=fs, data_type="freq", taus=taus)[:2]


def test_arw_allan_slope_minus_half():
    N = 0.05 * U.DEG_RT_H
    taus, ad = adev_of("arw", FogParams(arw=N), 200_000, taus=[0.1, 1.0, 10.0])
    np.testing.assert_allclose(ad, N / np.sqrt(taus), rtol=0.05)


def test_rrw_allan_slope_plus_half():
    K = 5 * U.DPH_RT_H
    taus, ad = adev_of("rrw", FogParams(rrw=K), 400_000, taus=[30.0, 100.0, 300.0])
    np.testing.assert_allclose(ad, K * np.sqrt(taus / 3), rtol=0.15)


@pytest.mark.parametrize("seed", [21, 22])
def test_bias_instability_has_a_flat_allan_floor_of_0664_B(seed):
    B = 0.1 * U.DPH
    p = FogParams(bias_instability=B, bi_band=(1e-4, 1.0), bi_per_decade=3)
    # 10^6 samples at 10 Hz: at tau = 300 s the estimate's own scatter is about 6 %
    taus, ad = adev_of("bias_instability", p, 1_000_000, seed=seed,
                       taus=[10.0, 30.0, 100.0, 300.0], fs=10.0)
    np.testing.assert_allclose(ad / B, 0.664, rtol=0.1)


def test_bias_instability_psd_is_one_over_f_in_band():
    """Analytic check of the component design. A continuum of Lorentzians with corners from f_lo
    to f_hi gives S(f) = B^2/(pi f) * (2/pi) (atan(f/f_lo) - atan(f/f_hi)): 1/f inside the band,
    rolling off at its edges. A discrete sum (3 per decade, log spacing ratio r) stands for the
    continuum over [f_lo / sqrt(r), f_hi sqrt(r)] (the midpoint rule); it must follow it within
    2 %."""
    B, f_lo, f_hi = 1e-6, 1e-4, 1.0
    corners, sigma = bias_instability_components(B, (f_lo, f_hi), 3)
    f = np.geomspace(3e-4, 3e-1, 40)
    tc = 1 / (2 * np.pi * corners)
    S = (4 * sigma**2 * tc[None, :] / (1 + (2 * np.pi * f[:, None] * tc[None, :]) ** 2)).sum(1)
    r = corners[1] / corners[0]
    lo, hi = f_lo / np.sqrt(r), f_hi * np.sqrt(r)
    continuum = B**2 / (np.pi * f) * (2 / np.pi) * (np.arctan(f / lo) - np.arctan(f / hi))
    np.testing.assert_allclose(S / continuum, 1.0, rtol=0.02)
    mid = (f > 3e-3) & (f < 3e-2)
    np.testing.assert_allclose(S[mid] * np.pi * f[mid] / B**2, 1.0, rtol=0.03)


def test_saturation_clips_and_flags():
    """Beyond the measurement range the output is clipped to +-range and the sample flagged;
    inside it nothing changes; raw = truth + terms still holds."""
    n = 2000
    w = np.zeros((n, 3))
    w[:, 2] = np.linspace(-10.0, 10.0, n)             # rad/s, through +-573 deg/s
    R = math.radians(400.0)
    p = FogParams(range=R, scale_factor=1e-3)
    out = simulate_fog(p, FS, w, np.tile([0, 0, 1.0], (n, 1)), axes=("z",), seed=0)
    sensed = w[:, 2] * (1 + 1e-3)
    beyond = np.abs(sensed) > R
    assert beyond.any() and (~beyond).any()
    np.testing.assert_array_equal(out.saturated[:, 0], beyond)
    np.testing.assert_allclose(out.raw[beyond, 0], np.sign(sensed[beyond]) * R, rtol=1e-15)
    np.testing.assert_allclose(out.raw[~beyond, 0], sensed[~beyond], rtol=1e-14)
    np.testing.assert_allclose(out.raw, w[:, [2]] + sum(out.terms.values()), atol=1e-14)
    # without a range nothing is clipped
    free = simulate_fog(FogParams(scale_factor=1e-3), FS, w, np.tile([0, 0, 1.0], (n, 1)))
    assert not free.saturated.any() and "saturation" not in free.terms


def test_gauss_markov_drift_has_its_variance_and_correlation_time():
    """Stationary first-order Gauss-Markov: variance s^2 and autocorrelation exp(-lag / tc)."""
    s, tc, n = 0.1, 2.0, 400_000
    out = simulate_fog(only("gm_drift", FogParams(gm_drift=s, gm_time_constant=tc)), FS,
                       np.zeros((n, 3)), np.tile([0, 0, 1.0], (n, 1)), axes=("z",), seed=5)
    x = out.terms["gm_drift"][:, 0]
    assert np.std(x) == pytest.approx(s, rel=0.05)
    lag = int(tc * FS)
    rho = np.corrcoef(x[:-lag], x[lag:])[0, 1]
    assert rho == pytest.approx(math.exp(-1.0), abs=0.03)


def test_bias_instability_starts_from_zero_at_power_on():
    """The in-run flicker process starts at zero at every power-on (its run-to-run part is the
    labelled switch-on bias): over many power-ons the first sample's spread is far below the
    stationary spread, and it grows with time."""
    B = 1.0 * U.DPH
    p = FogParams(bias_instability=B, bi_band=(1e-6, 0.1))
    n, firsts, lasts = 2000, [], []
    for seed in range(200):
        x = simulate_fog(only("bias_instability", p), 1.0, np.zeros((n, 3)),
                         np.tile([0, 0, 1.0], (n, 1)), axes=("z",), seed=seed).raw[:, 0]
        firsts.append(x[0])
        lasts.append(x[-1])
    corners, sigma = bias_instability_components(B, (1e-6, 0.1), 3)
    stationary = sigma * math.sqrt(len(corners))
    assert np.std(firsts) < 0.01 * stationary
    assert np.std(lasts) > 10 * np.std(firsts)
