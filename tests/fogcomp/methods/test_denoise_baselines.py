"""Tests of the Kalman and soft-threshold wavelet baselines against theory."""

import math

import numpy as np
import pytest

from fogcomp import GyroData, load_model, make_method, save_model
from fogcomp.methods.kalman import (
    KalmanDenoiser,
    corner_frequency_hz,
    estimate_noise,
    steady_state_gain,
)
from fogcomp.methods.wavelet_soft import WaveletSoftThreshold, soft_denoise, sure_threshold
from fogcomp.units import DEG_RT_H, DPS

FS = 100.0
RATE = -60 * DPS


def _white(seed, n, sigma, c=RATE):
    return c + sigma * np.random.default_rng(seed).normal(size=n)


# ---------------------------------------------------------------------------------------------
# Kalman
def _riccati_gain(q, r):
    """Steady-state gain of the scalar random-walk filter: P- = P + q, K = P-/(P- + r),
    P = (1 - K) P-  =>  P-^2 - q P- - q r = 0."""
    p_prior = (q + math.sqrt(q * q + 4 * q * r)) / 2
    return p_prior / (p_prior + r)


def _kalman_for(sigma, q_over_r, smoother=False):
    r = sigma**2
    q = q_over_r * r
    # R = ARW^2 fs, Q = RRW^2 / fs
    return KalmanDenoiser(arw_rad_rt_s=math.sqrt(r / FS), rrw_rad_s_rt_s=math.sqrt(q * FS),
                          smoother=smoother), q, r


@pytest.fixture(scope="module")
def kalman_runs():
    sigma, n = 1e-3, 20000
    data = GyroData(rate=_white(1, n, sigma), fs=FS)
    out = {}
    for smoother in (False, True):
        model, q, r = _kalman_for(sigma, 0.01, smoother)
        out[smoother] = model.fit(data).compensate(data)
    return data, out, q, r


def test_kalman_steady_state_variance_matches_theory(kalman_runs):
    # For a constant truth the steady-state filter is x_k = (1-K) x_(k-1) + K z_k, whose output
    # error is AR(1) with variance K^2 R / (1 - (1-K)^2) = K R / (2 - K). With Q = 0.01 R,
    # K = 0.095 and the error has about 19,000 (1-phi^2)/(1+phi^2) = 1,900 independent samples:
    # the sample variance scatters by sqrt(2/1900) = 3.3 %; tolerance 15 %.
    data, out, q, r = kalman_runs
    k = _riccati_gain(q, r)
    err = out[False][500:] - RATE
    assert np.var(err) == pytest.approx(k * r / (2 - k), rel=0.15)


def test_rts_smoother_variance_matches_theory_and_beats_filter(kalman_runs):
    # The steady-state RTS smoother of this model is the two-sided exponential filter with
    # weights (1-phi)/(1+phi) phi^|j|, phi = 1 - K (the stable root of the Wiener smoother's
    # denominator); its error variance for a constant truth is
    # R (1-phi)(1+phi^2)/(1+phi)^3, about half the filter's here.
    data, out, q, r = kalman_runs
    phi = 1 - _riccati_gain(q, r)
    err_s = out[True][500:-500] - RATE
    err_f = out[False][500:-500] - RATE
    assert np.var(err_s) == pytest.approx(r * (1 - phi) * (1 + phi**2) / (1 + phi) ** 3, rel=0.15)
    assert np.var(err_s) < 0.7 * np.var(err_f)


def _scalar_kalman(z, q, r, smoother):
    """Slow obvious twin: the scalar filter and RTS smoother written out."""
    xs, ps = [z[0]], [r]
    for zk in z[1:]:
        p_prior = ps[-1] + q
        gain = p_prior / (p_prior + r)
        xs.append(xs[-1] + gain * (zk - xs[-1]))
        ps.append((1 - gain) * p_prior)
    if not smoother:
        return np.array(xs)
    out = list(xs)
    for k in range(len(z) - 2, -1, -1):
        j = ps[k] / (ps[k] + q)
        out[k] = xs[k] + j * (out[k + 1] - xs[k])
    return np.array(out)


@pytest.mark.parametrize("smoother", [False, True])
def test_kalman_matches_plain_scalar_loop(smoother):
    sigma = 1e-3
    data = GyroData(rate=_white(2, 400, sigma) + 1e-4 * np.arange(400) / 400, fs=FS)
    model, q, r = _kalman_for(sigma, 0.003, smoother)
    got = model.fit(data).compensate(data)
    np.testing.assert_allclose(got, _scalar_kalman(data.rate, q, r, smoother), rtol=0,
                               atol=1e-12)


def test_kalman_noise_estimate_recovers_random_walk_plus_noise():
    # z = random walk (Q per step) + white noise (R): V(m) = 2R + mQ exactly in expectation.
    # Over repeated records of 20,000 samples the estimates scatter by about 1 % (R) and 7 % (Q)
    # (Monte-Carlo, 30 records); tolerances are about 4 of those.
    r, q, n = 1e-6, 1e-8, 20000
    rng = np.random.default_rng(4)
    z = RATE + np.cumsum(rng.normal(scale=math.sqrt(q), size=n)) + rng.normal(
        scale=math.sqrt(r), size=n)
    r_hat, q_hat, _ = estimate_noise(z)
    assert r_hat == pytest.approx(r, rel=0.05)
    assert q_hat == pytest.approx(q, rel=0.3)
    # through the estimator, in datasheet units, at two sample rates: ARW = sqrt(R / fs) and
    # RRW = sqrt(Q fs) describe the same gyro whatever the rate
    model = KalmanDenoiser().fit(GyroData(rate=z, fs=FS))
    assert model.arw_rad_rt_s_ == pytest.approx(math.sqrt(r / FS), rel=0.03)
    assert model.rrw_rad_s_rt_s_ == pytest.approx(math.sqrt(q * FS), rel=0.15)
    model4 = KalmanDenoiser().fit(GyroData(rate=z, fs=4 * FS))
    assert model4.arw_rad_rt_s_ == pytest.approx(model.arw_rad_rt_s_ / 2, rel=1e-12)
    assert model4.rrw_rad_s_rt_s_ == pytest.approx(model.rrw_rad_s_rt_s_ * 2, rel=1e-12)


@pytest.mark.parametrize("smoother", [False, True])
def test_kalman_preserves_mean_of_constant(smoother):
    # Defaults (noises estimated): on a constant rate Q comes out ~0 and the filter is the
    # running mean, whose average over the record has std sigma sqrt(2/n) (the weights
    # (H_n - H_j)/n have squared sum ~2/n); the smoother is at most as spread. Tolerance 5 std.
    sigma, n = 1e-3, 2500
    data = GyroData(rate=_white(5, n, sigma), fs=FS)
    comp = KalmanDenoiser(smoother=smoother).fit(data).compensate(data)
    assert abs(np.mean(comp) - RATE) < 5 * sigma * math.sqrt(2 / n)
    assert np.std(comp - RATE) < 0.2 * sigma  # and it does smooth


def test_kalman_state_round_trip(tmp_path):
    data = GyroData(rate=_white(6, 1000, 1e-3), fs=FS)
    model = make_method("kalman", smoother=True).fit(data)
    save_model(model, tmp_path / "k")
    loaded = load_model(tmp_path / "k")
    np.testing.assert_array_equal(loaded.estimate_error(data), model.estimate_error(data))
    assert loaded.arw_rad_rt_s_ == model.arw_rad_rt_s_


def test_kalman_bad_hyperparameters():
    data = GyroData(rate=_white(0, 100, 1e-3), fs=FS)
    with pytest.raises(ValueError, match="arw_rad_rt_s"):
        KalmanDenoiser(arw_rad_rt_s=-1.0).fit(data)
    with pytest.raises(ValueError, match="smoother"):
        KalmanDenoiser(smoother="yes").fit(data)


# ---------------------------------------------------------------------------------------------
# Soft-threshold wavelet
@pytest.mark.parametrize("level", [3, 4, 5, 6])
def test_wavelet_soft_on_white_noise_matches_theory(level):
    # Orthonormal db6 with periodization, level L = 3 .. 6, n = 2^16. The finest details of white
    # noise are N(0, sigma^2): MAD/0.6745 estimates sigma to about sqrt(1.36 / (n/2)) = 0.6 %,
    # so the universal threshold is sigma sqrt(2 ln n) within 3 %. It exceeds every detail
    # coefficient with probability -> 1 (a handful at most survive, shrunk to almost nothing),
    # so the output error is the level-L approximation of the noise: by Parseval its variance
    # is sigma^2 (n / 2^L) / n = sigma^2 / 2^L, estimated from n / 2^L >= 1,024 coefficients
    # (<= 4.4 % scatter); tolerance 15 %. The constant goes entirely into the approximation.
    sigma, n = 1e-3, 2**16
    data = GyroData(rate=_white(7, n, sigma), fs=FS)
    res = soft_denoise(data.rate, "db6", level, "periodization")
    assert res.sigma == pytest.approx(sigma, rel=0.03)
    assert res.threshold == pytest.approx(sigma * math.sqrt(2 * math.log(n)), rel=0.03)
    model = WaveletSoftThreshold(level=level, mode="periodization").fit(data)
    err = model.compensate(data) - RATE
    assert np.var(err) == pytest.approx(sigma**2 / 2**level, rel=0.15)
    np.testing.assert_array_equal(model.compensate(data), res.denoised)


def test_wavelet_soft_preserves_mean_of_constant():
    # Default settings (symmetric extension, deepest level). The approximation keeps the
    # lowest frequencies, where the mean lives: the output's mean scatters about like the raw
    # mean, sigma / sqrt(n) (1.2 of that over 40 seeds); tolerance 5.
    sigma, n = 1e-3, 2500
    data = GyroData(rate=_white(8, n, sigma), fs=FS)
    model = make_method("wavelet_soft").fit(data)
    comp = model.compensate(data)
    assert abs(np.mean(comp) - RATE) < 5 * sigma / math.sqrt(n)
    assert np.std(comp - RATE) < 0.3 * sigma
    # a noise-free constant is passed through untouched
    flat = GyroData(rate=np.full(1000, RATE), fs=FS)
    np.testing.assert_allclose(model.compensate(flat), RATE, rtol=0, atol=1e-14)


def test_wavelet_soft_fixed_threshold_zero_is_identity():
    data = GyroData(rate=_white(9, 777, 1e-3), fs=FS)
    model = WaveletSoftThreshold(threshold=0.0).fit(data)
    np.testing.assert_allclose(model.compensate(data), data.rate, rtol=0, atol=1e-13)


def test_wavelet_soft_too_deep_level_warns_and_bad_input_raises():
    data = GyroData(rate=_white(10, 1000, 1e-3), fs=FS)
    with pytest.warns(UserWarning, match="deeper than a record of 1000 samples"):
        WaveletSoftThreshold(level=12).fit(data)
    with pytest.raises(ValueError, match="threshold"):
        WaveletSoftThreshold(threshold="stein").fit(data)
    with pytest.raises(ValueError, match="wavelet"):
        WaveletSoftThreshold(wavelet="bior2.2").fit(data)


def test_wavelet_soft_state_round_trip(tmp_path):
    data = GyroData(rate=_white(11, 1000, 1e-3), fs=FS)
    model = make_method("wavelet_soft").fit(data)
    save_model(model, tmp_path / "w")
    loaded = load_model(tmp_path / "w")
    np.testing.assert_array_equal(loaded.estimate_error(data), model.estimate_error(data))
    assert loaded.sigma_ == model.sigma_


# ---------------------------------------------------------------------------------------------
# Kalman: datasheet tuning, carried state, warm-up
def test_kalman_datasheet_units_are_the_si_tuning():
    data = GyroData(rate=_white(12, 500, 1e-3) + 1e-3 * np.sin(np.arange(500) / 30), fs=FS)
    ds = KalmanDenoiser(arw_deg_rt_h=0.1, rate_walk_dps_rt_s=0.02).fit(data)
    si = KalmanDenoiser(arw_rad_rt_s=0.1 * math.pi / 180 / 60,
                        rrw_rad_s_rt_s=0.02 * math.pi / 180).fit(data)
    np.testing.assert_allclose(ds.compensate(data), si.compensate(data), rtol=0, atol=1e-15)
    assert ds.variogram_.size == 0                       # nothing estimated from the record


def test_kalman_corner_frequency_is_the_analytic_low_pass():
    """Datasheet tuning: ARW N and a rate walk K sized for the motion make the steady filter a
    first-order low-pass with its -3 dB corner at K / (2 pi N) (Kalman-Bucy, continuous
    limit). A noise-free sine at that frequency comes out at 1/sqrt(2) of its amplitude and
    one decade above at about 1/10 (first-order roll-off); measured after the warm-up."""
    arw = 0.5 * DEG_RT_H
    fc = 0.5
    k = 2 * math.pi * fc * arw
    assert corner_frequency_hz(arw, k) == pytest.approx(fc)
    model = KalmanDenoiser(arw_rad_rt_s=arw, rrw_rad_s_rt_s=k)
    t = np.arange(20000) / FS
    for f, want in ((fc, 1 / math.sqrt(2)), (10 * fc, 1 / math.sqrt(101))):
        z = np.sin(2 * math.pi * f * t)
        out = model.fit(GyroData(rate=z, fs=FS)).compensate(GyroData(rate=z, fs=FS))
        skip = 2 * model.settling_samples()
        ref_s, ref_c = np.sin(2 * math.pi * f * t[skip:]), np.cos(2 * math.pi * f * t[skip:])
        amp = math.hypot(2 * np.mean(out[skip:] * ref_s), 2 * np.mean(out[skip:] * ref_c))
        assert amp == pytest.approx(want, rel=0.04)


def test_kalman_settling_samples_is_where_the_gain_settles():
    """The filter's own posterior variance P_k gives its gain P_k / R (filterpy's run);
    ``settling_samples`` is the first sample where it is within 5 % of the Riccati value."""
    sigma = 1e-3
    model, q, r = _kalman_for(sigma, 1e-3)
    data = GyroData(rate=_white(13, 2000, sigma), fs=FS)
    model.engine = "filterpy"
    model.fit(data)
    _, ps = model._run(data.rate, FS, None)
    gain = ps / r
    k_ss = steady_state_gain(q, r)
    first = int(np.argmax(np.abs(gain - k_ss) <= 0.05 * k_ss))
    assert model.settling_samples() == first


def test_kalman_carry_continues_the_fitting_record():
    """``start="carry"``: a record that follows the fitting record is filtered as if the filter
    had run through both without a restart (the twin: one filter over the joined record)."""
    sigma = 1e-3
    z = _white(14, 3000, sigma) + 2e-3 * np.sin(np.arange(3000) / 200)
    first, second = GyroData(rate=z[:2000], fs=FS), GyroData(rate=z[2000:], fs=FS)
    model, _, _ = _kalman_for(sigma, 1e-3)
    model.start = "carry"
    model.fit(first)
    whole, _, _ = _kalman_for(sigma, 1e-3)
    joined = whole.fit(first).compensate(GyroData(rate=z, fs=FS))
    np.testing.assert_allclose(model.compensate(second), joined[2000:], rtol=0, atol=1e-15)
    restart, _, _ = _kalman_for(sigma, 1e-3)
    assert restart.fit(first).compensate(second)[0] == second.rate[0]   # restart: x_0 = z_0


@pytest.mark.parametrize("kw, arg", [
    ({"arw_rad_rt_s": float("nan")}, "arw_rad_rt_s"),
    ({"arw_deg_rt_h": -0.1}, "arw_deg_rt_h"),
    ({"arw_deg_rt_h": 0.1, "arw_rad_rt_s": 1e-5}, "arw_deg_rt_h"),
    ({"rate_walk_dps_rt_s": "fast"}, "rate_walk_dps_rt_s"),
    ({"smoother": "yes"}, "smoother"),
    ({"start": "warm"}, "start"),
])
def test_kalman_validate_refuses_without_data(kw, arg):
    with pytest.raises(ValueError, match=arg):
        KalmanDenoiser(**kw)._validate()


# ---------------------------------------------------------------------------------------------
# Wavelet: SURE threshold
def test_sure_threshold_is_near_the_oracle_threshold():
    """Stein's unbiased risk estimate picks, from the data alone, a threshold whose true loss
    ||soft(x, t) - mu||^2 is within 15 % of the best threshold's (the oracle, which knows mu),
    for sparse and dense means alike (Donoho & Johnstone 1995)."""
    rng = np.random.default_rng(15)
    n = 4096
    for frac, size in ((0.05, 4.0), (0.3, 2.0), (1.0, 0.5)):
        mu = np.where(rng.random(n) < frac, size * rng.choice([-1, 1], n), 0.0)
        x = mu + rng.normal(size=n)
        ts = np.linspace(0, 4, 401)

        def loss(t):
            return np.mean((np.sign(x) * np.maximum(np.abs(x) - t, 0) - mu) ** 2)

        best = min(loss(t) for t in ts)
        assert loss(sure_threshold(x)) <= 1.15 * best, (frac, size)


def test_wavelet_sure_keeps_more_than_universal_and_validates():
    sigma, n = 1e-3, 2**14
    data = GyroData(rate=_white(16, n, sigma) + 3e-3 * np.sin(np.arange(n) / 5.0), fs=FS)
    uni = soft_denoise(data.rate, "db6", 6, "periodization", "universal")
    sure = soft_denoise(data.rate, "db6", 6, "periodization", "sure")
    assert sure.level_thresholds.shape == (6,)
    assert np.all(sure.level_thresholds <= uni.threshold + 1e-15)
    model = WaveletSoftThreshold(level=6, mode="periodization", threshold="sure").fit(data)
    np.testing.assert_array_equal(model.compensate(data), sure.denoised)
    for kw, arg in (({"level": "four"}, "level"), ({"wavelet": "db99"}, "wavelet"),
                    ({"threshold": float("nan")}, "threshold"), ({"mode": "wrap"}, "mode"),
                    ({"level": 2.0}, "level")):
        with pytest.raises(ValueError, match=arg):
            WaveletSoftThreshold(**kw)._validate()
