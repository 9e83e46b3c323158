"""Tests of fogcomp.metrics against hand computations, plain-Python twins and analytic results."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fogcomp.metrics import (
    ALLAN_MIN_DURATION_S,
    bias_stability,
    bias_stability_segments,
    coefficient_errors,
    integrated_angle_error,
    psd,
    rmse,
    smooth,
    std,
    summary,
)

DEG = math.pi / 180.0          # written out here, independent of fogcomp.units
DPH = DEG / 3600.0


# ---------------------------------------------------------------------------------------------
# std, smooth
@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=200))
def test_std_matches_statistics_stdev(values):
    assert std(values) == pytest.approx(statistics.stdev(values), rel=1e-9, abs=1e-9)


def test_std_of_constant_is_zero_and_offset_does_not_matter():
    assert std(np.full(1000, 0.3)) == 0.0
    x = np.random.default_rng(0).standard_normal(1000) * 1e-6
    assert std(x + 1e3) == pytest.approx(std(x), rel=1e-6)


@settings(max_examples=30, deadline=None)
@given(values=st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=100),
       fs=st.sampled_from([1.0, 2.0, 10.0]), window=st.integers(1, 7))
def test_smooth_matches_loop_of_block_means(values, fs, window):
    window_s = window / fs
    nb = len(values) // window
    if nb == 0:
        with pytest.raises(ValueError, match=r"x: record of .* shorter than one window"):
            smooth(values, fs, window_s)
        return
    expected = [statistics.fmean(values[i * window:(i + 1) * window]) for i in range(nb)]
    np.testing.assert_allclose(smooth(values, fs, window_s), expected, rtol=1e-12, atol=1e-9)


def test_smooth_drops_incomplete_last_block():
    np.testing.assert_array_equal(smooth([1, 3, 5, 7, 100], 1.0, 2.0), [2.0, 6.0])


# ---------------------------------------------------------------------------------------------
# bias stability (Qiu et al., eq. 5)
def test_bias_stability_by_hand():
    # 100 s windows at 0.02 Hz = 2 samples: F = 1.5, 3.5, 5.5, 7.5, mean 4.5, squared deviations
    # 9 + 1 + 1 + 9 = 20, / (4 - 1), sqrt = 2.5820; with K = 2 output units per rad/s: 1.2910.
    x = [1, 2, 3, 4, 5, 6, 7, 8, 99]               # the 9th sample is an incomplete window
    assert bias_stability(x, 0.02) == pytest.approx(math.sqrt(20 / 3), rel=1e-12)
    assert bias_stability(x, 0.02, scale_factor=2.0) == pytest.approx(math.sqrt(20 / 3) / 2,
                                                                      rel=1e-12)


def test_bias_stability_of_constant_is_zero():
    assert bias_stability(np.full(3000, 7.3e-5), 10.0) == 0.0


def test_bias_stability_of_white_noise():
    # Means of w = window_s * fs white samples of std sigma have std sigma / sqrt(w); the sample
    # std of 1000 of them is within 3 * 1/sqrt(2 * 999) = 6.7 % of it at 3 sigma.
    sigma, fs = 2e-4, 10.0
    x = sigma * np.random.default_rng(3).standard_normal(1000 * 1000)
    assert bias_stability(x, fs, 100.0) == pytest.approx(sigma / math.sqrt(100.0 * fs), rel=0.067)


def test_bias_stability_segments_of_two_noise_levels():
    fs, w = 1.0, 10.0
    rng = np.random.default_rng(4)
    x = np.concatenate([1e-3 * rng.standard_normal(40_000), 1e-2 * rng.standard_normal(40_000)])
    got = bias_stability_segments(x, fs, [(0, 40_000), (40_000, 80_000)], window_s=w)
    # 4000 windows per segment: sample std within 3/sqrt(2*3999) = 3.4 %
    np.testing.assert_allclose(got, [1e-3 / math.sqrt(10), 1e-2 / math.sqrt(10)], rtol=0.034)


def test_bias_stability_segments_equals_bias_stability_of_slices():
    fs = 2.0
    x = np.random.default_rng(5).standard_normal(2000)
    bounds = [(0.0, 300.0), (250.0, 1000.0), (10.5, 411.0)]
    got = bias_stability_segments(x, fs, bounds, window_s=5.0)
    expected = [bias_stability(x[0:600], fs, 5.0), bias_stability(x[500:2000], fs, 5.0),
                bias_stability(x[21:822], fs, 5.0)]
    np.testing.assert_allclose(got, expected, rtol=1e-12)


@pytest.mark.parametrize("bounds, match", [
    ([(10.0, 5.0)], r"bounds\[0\]: expected 0 <= start_s < end_s"),
    ([(0.0, 50.0), (0.0, 2000.0)], r"bounds\[1\]: expected 0 <= start_s < end_s <= 1000 s"),
    ([(-1.0, 5.0)], r"bounds\[0\]"),
    ([(0.0, 15.0)], r"bounds\[0\]: segment .* at least two complete windows"),
    ([1.0, 2.0], r"bounds: expected a non-empty sequence of \(start_s, end_s\) pairs"),
    ([], r"bounds: expected a non-empty sequence"),
])
def test_bias_stability_segments_rejects_bad_bounds(bounds, match):
    with pytest.raises(ValueError, match=match):
        bias_stability_segments(np.zeros(1000), 1.0, bounds, window_s=10.0)


# ---------------------------------------------------------------------------------------------
# PSD
def test_psd_of_white_noise_is_flat_and_parseval_consistent():
    sigma, fs = 0.3, 200.0
    x = sigma * np.random.default_rng(6).standard_normal(2**18)
    f, pxx = psd(x, fs)
    assert f[0] == 0.0 and f[-1] == pytest.approx(fs / 2)
    inner = pxx[1:-1]
    # One-sided density of white noise: 2 sigma^2 / fs (about 15 averages x 2**14 bins: 1 %)
    assert np.mean(inner) == pytest.approx(2 * sigma**2 / fs, rel=0.01)
    assert np.std(inner) / np.mean(inner) < 0.5
    df = f[1] - f[0]
    assert np.sum(pxx) * df == pytest.approx(np.var(x), rel=0.01)


def test_psd_of_sine_integrates_to_its_mean_square():
    fs, amp, f0 = 100.0, 2.0, 12.5
    t = np.arange(2**16) / fs
    f, pxx = psd(amp * np.sin(2 * math.pi * f0 * t), fs, nperseg=1024)
    df = f[1] - f[0]
    assert f[np.argmax(pxx)] == pytest.approx(f0)
    assert np.sum(pxx) * df == pytest.approx(amp**2 / 2, rel=1e-3)


@pytest.mark.parametrize("nperseg", [1, 10_000, 2.5, True])
def test_psd_rejects_bad_nperseg(nperseg):
    with pytest.raises(ValueError, match=r"nperseg: expected an integer between 2 and len"):
        psd(np.zeros(1000), 1.0, nperseg=nperseg)


@pytest.mark.parametrize("kind", ["white", "ar1"])
def test_band_averaged_psd_intervals_cover_the_true_spectrum_as_often_as_they_say(kind):
    """The 68 % chi-square interval of each band of psd_bands, from its EDF, holds the true
    spectrum in 68 % of bands over replicates: white noise (2 s^2 / fs) and an AR(1) process
    x_k = 0.9 x_(k-1) + e_k (2 s^2 / fs / |1 - 0.9 exp(-2 pi i f / fs)|^2, a spectrum falling
    25 dB to Nyquist), the true value averaged over the band's Welch frequencies as the estimate
    is. Bands of one ordinate and bands of many are checked apart: the EDF of a band of m
    Hann-windowed ordinates (band_edf) is what is under test."""
    from scipy.signal import lfilter
    from scipy.stats import chi2

    from fogcomp.metrics import psd_bands

    rng = np.random.default_rng(11)
    fs, n, sigma, phi = 10.0, 6000, 0.3, 0.9
    a = 0.15865525393145707
    hits = {True: [0, 0], False: [0, 0]}
    for _ in range(150):
        e = rng.normal(0.0, sigma, n)
        x = e if kind == "white" else lfilter([1.0], [1.0, -phi], e)
        _, pxx, edf = psd_bands(x, fs)
        # the Welch frequencies of each band, for the band's true mean
        nper = 2 ** math.floor(math.log2(n / 4.5))
        fw = np.arange(1, nper // 2) * fs / nper
        k = np.floor(10 * np.log10(fw / fw[0]) + 1e-9).astype(int)
        if kind == "white":
            s_true = np.full(fw.size, 2.0 * sigma**2 / fs)
        else:
            s_true = 2.0 * sigma**2 / fs / np.abs(1.0 - phi * np.exp(-2j * np.pi * fw / fs))**2
        true = np.array([s_true[k == b].mean() for b in np.unique(k)])
        assert true.size == pxx.size
        ok = (pxx * edf / chi2.ppf(1 - a, edf) <= true) & (true <= pxx * edf / chi2.ppf(a, edf))
        many = edf > 1.5 * edf[0]
        for flag in (True, False):
            hits[flag][0] += int(np.count_nonzero(ok[many == flag]))
            hits[flag][1] += int(np.count_nonzero(many == flag))
    for flag, (h, t) in hits.items():
        assert t > 500
        assert abs(h / t - (1 - 2 * a)) < 0.04, (kind, "many" if flag else "one", h / t)


def test_band_edf_of_one_ordinate_is_its_own_and_of_many_grows_as_independent_pairs():
    from fogcomp.metrics import band_edf

    assert band_edf(30.0, 1) == 30.0
    # m ordinates with neighbour correlation 4/9 and 1/36: about m / 1.94 independent ones
    assert band_edf(30.0, 1000) == pytest.approx(30.0 * 1000 / (1 + 8 / 9 + 1 / 18), rel=1e-2)
    with pytest.raises(ValueError, match="m: expected at least 1"):
        band_edf(30.0, 0)


# ---------------------------------------------------------------------------------------------
# Against truth
@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=1,
                max_size=100))
def test_rmse_matches_plain_python(pairs):
    x, t = zip(*pairs)
    expected = math.sqrt(math.fsum((a - b) ** 2 for a, b in pairs) / len(pairs))
    assert rmse(x, t) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_rmse_of_constant_offset():
    truth = np.sin(np.linspace(0, 10, 1000))
    assert rmse(truth + 0.25, truth) == pytest.approx(0.25, rel=1e-12)


def test_integrated_angle_error_of_bias_steps():
    # +b for the first half, -b for the second: the angle error climbs to b*T/2, back to 0.
    fs, b, n = 50.0, 1e-3, 5000
    truth = np.cos(np.arange(n) / fs)
    err = np.where(np.arange(n) < n // 2, b, -b)
    out = integrated_angle_error(truth + err, truth, fs)
    assert set(out) == {"angle_error_final_rad", "angle_error_max_rad"}
    assert out["angle_error_final_rad"] == pytest.approx(0.0, abs=1e-12)
    assert out["angle_error_max_rad"] == pytest.approx(b * (n // 2) / fs, rel=1e-9)
    neg = integrated_angle_error(truth - b, truth, fs)
    assert neg["angle_error_final_rad"] == pytest.approx(-b * n / fs, rel=1e-9)
    assert neg["angle_error_max_rad"] == pytest.approx(b * n / fs, rel=1e-9)


def test_coefficient_errors_by_hand():
    out = coefficient_errors({"arw_deg_rt_h": 2.2, "d0_dph": -1.0, "zero": 0.5},
                             {"arw_deg_rt_h": 2.0, "d0_dph": -0.8, "zero": 0.0})
    assert out["arw_deg_rt_h"]["error"] == pytest.approx(0.2)
    assert out["arw_deg_rt_h"]["abs_error"] == pytest.approx(0.2)
    assert out["arw_deg_rt_h"]["rel_error"] == pytest.approx(0.1)
    assert out["d0_dph"]["error"] == pytest.approx(-0.2)
    assert out["d0_dph"]["abs_error"] == pytest.approx(0.2)
    assert out["d0_dph"]["rel_error"] == pytest.approx(0.25)
    assert out["zero"]["rel_error"] is None and out["zero"]["abs_error"] == 0.5
    arr = coefficient_errors({"d_dph": [1.0, 2.0]}, {"d_dph": [2.0, 2.0]})
    np.testing.assert_allclose(arr["d_dph"]["rel_error"], [0.5, 0.0])


@pytest.mark.parametrize("est, true, match", [
    ({"a": 1.0, "b": 2.0}, {"a": 1.0}, r"estimated: unknown key\(s\) \['b'\]"),
    ({"a": 1.0}, {"a": 1.0, "c": 3.0}, r"estimated: missing key\(s\) \['c'\]"),
    ({"a": float("nan")}, {"a": 1.0}, r"estimated\['a'\]: expected finite"),
    ({"a": [1.0, 2.0]}, {"a": 1.0}, r"estimated\['a'\]: shape \(2,\) must match true \(\)"),
    ({"a": "x"}, {"a": 1.0}, r"estimated\['a'\]: cannot be read as a number"),
    ([1.0], {"a": 1.0}, r"estimated: expected a dict"),
])
def test_coefficient_errors_rejects(est, true, match):
    with pytest.raises(ValueError, match=match):
        coefficient_errors(est, true)


# ---------------------------------------------------------------------------------------------
# summary
def test_summary_static_white_noise():
    fs, arw_deg_rt_h = 100.0, 0.05
    arw = arw_deg_rt_h * DEG / 60.0                            # rad/sqrt(s)
    x = 10 * DPH + arw * math.sqrt(fs) * np.random.default_rng(8).standard_normal(200_000)
    s = summary(x, fs)
    sigma = arw * math.sqrt(fs)
    assert s["duration_s"] == 2000.0
    assert s["std_dph"] == pytest.approx(sigma / DPH, rel=0.01)
    assert s["std_dps"] == pytest.approx(s["std_dph"] / 3600.0, rel=1e-12)
    # 20 windows of 100 s: sigma/sqrt(1e4), sample std within 3/sqrt(38) = 49 %
    assert s["bias_stability_100s_dph"] == pytest.approx(sigma / 100.0 / DPH, rel=0.49)
    assert s["arw_deg_rt_h"] == pytest.approx(arw_deg_rt_h, rel=0.05)
    assert s["bias_instability_dph"] is None and s["rrw_dph_rt_h"] is None
    for key in ("rmse_dps", "rmse_dph", "angle_error_final_deg", "angle_error_max_deg"):
        assert key not in s


def test_summary_with_truth_scores_the_error():
    fs, n = 10.0, 5000
    t = np.arange(n) / fs
    truth = 5 * DEG * np.sin(2 * math.pi * 0.05 * t)        # a rate table moving +-5 deg/s
    bias = 3 * DPH
    s = summary(truth + bias, fs, truth=truth)
    assert s["rmse_dph"] == pytest.approx(3.0, rel=1e-9)
    assert s["rmse_dps"] == pytest.approx(3.0 / 3600.0, rel=1e-9)
    assert s["mean_error_dph"] == pytest.approx(3.0, rel=1e-9)
    # a constant 3 deg/h error for 500 s: 1500 deg*s/h = 0.41667 deg
    assert s["angle_error_final_deg"] == pytest.approx(3.0 * 500.0 / 3600.0, rel=1e-9)
    assert s["angle_error_max_deg"] == pytest.approx(3.0 * 500.0 / 3600.0, rel=1e-9)
    assert s["std_dph"] < 1e-9                   # the motion is not counted as noise
    # only the rounding of truth + bias is left: every identified noise term is negligible
    for key in ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h", "quantisation_arcsec"):
        assert s[key] is None or s[key] < 1e-6, (key, s[key])


def test_summary_of_exactly_constant_error_has_no_allan_terms():
    s = summary(np.full(20_000, 0.01), 100.0, truth=np.zeros(20_000))
    assert s["std_dph"] == 0.0 and s["bias_stability_100s_dph"] == 0.0
    for key in ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h", "quantisation_arcsec",
                "rate_ramp_dph_per_h", "bias_instability_floor_dph"):
        assert s[key] is None


def test_summary_short_record_leaves_out_what_it_cannot_compute():
    fs = 100.0
    n = int(fs * ALLAN_MIN_DURATION_S) - 1
    s = summary(np.random.default_rng(9).standard_normal(n), fs)
    assert "bias_stability_100s_dph" not in s
    assert "arw_deg_rt_h" not in s and "bias_instability_dph" not in s
    assert s["std_dps"] > 0


def test_summary_keys_carry_units():
    s = summary(np.random.default_rng(10).standard_normal(30_000), 100.0,
                truth=np.zeros(30_000))
    units = ("_s", "_dps", "_dph", "_deg", "_deg_rt_h", "_dph_rt_h", "_arcsec", "_dph_per_h")
    assert all(k.endswith(units) for k in s), sorted(s)


# ---------------------------------------------------------------------------------------------
# Input validation
@pytest.mark.parametrize("func", [std, lambda x: smooth(x, 1.0, 1.0),
                                  lambda x: bias_stability(x, 1.0, 1.0),
                                  lambda x: psd(x, 1.0)])
@pytest.mark.parametrize("x, match", [
    ([1.0, float("nan"), 2.0, 3.0], r"x: non-finite value nan at index 1"),
    (np.zeros((4, 2)), r"x: expected a 1-D array"),
])
def test_signal_checks_name_the_argument(func, x, match):
    with pytest.raises(ValueError, match=match.replace("x:", "(x|rate):")):
        func(x)


def test_too_short_inputs():
    with pytest.raises(ValueError, match=r"x: expected at least 2 samples, got 1"):
        std([1.0])
    with pytest.raises(ValueError, match=r"rate: bias stability needs at least two complete "
                                         r"windows of 100 s, the record has 1"):
        bias_stability(np.zeros(150), 1.0)
    with pytest.raises(ValueError, match=r"compensated: expected at least 2 samples"):
        summary([1.0], 1.0)


def test_bad_fs_window_scale_factor_and_shapes():
    with pytest.raises(ValueError, match=r"fs: expected a positive finite number"):
        smooth(np.zeros(10), 0.0, 1.0)
    with pytest.raises(ValueError, match=r"window_s: must be a whole number .* of samples"):
        smooth(np.zeros(10), 3.0, 0.5)
    with pytest.raises(ValueError, match=r"scale_factor: expected a positive finite number"):
        bias_stability(np.zeros(10), 1.0, 1.0, scale_factor=-1.0)
    with pytest.raises(ValueError, match=r"truth: shape \(3,\) must match x \(4,\)"):
        rmse(np.zeros(4), np.zeros(3))
    with pytest.raises(ValueError, match=r"truth: shape \(3,\) must match compensated \(4,\)"):
        summary(np.zeros(4), 1.0, truth=np.zeros(3))
    with pytest.raises(ValueError, match=r"truth: non-finite"):
        integrated_angle_error(np.zeros(3), [0.0, float("inf"), 0.0], 1.0)


@pytest.mark.parametrize("kw, msg", [({"per_decade": 0}, "per_decade: expected a positive"),
                                     ({"segments": True}, "segments: expected a positive"),
                                     ({"x": np.zeros(10)}, "x")])
def test_psd_bands_refuses_bad_arguments_naming_them(kw, msg):
    from fogcomp.metrics import psd_bands

    args = {"x": np.zeros(1000), "fs": 1.0, **kw}
    with pytest.raises(ValueError, match=msg):
        psd_bands(**args)
