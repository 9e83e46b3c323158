"""Tests of fogcomp.allan: the overlapping Allan deviation and the noise identification.

References the values are checked against: allantools (an independent implementation), a slow
pure-Python twin of the textbook definition, the R package `avar` on a real ADIS16405 log
(/work/shared/realdata), and Allan variances known in closed form for synthetic noise.
"""

from __future__ import annotations

import gzip
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fogcomp.allan import (
    FLICKER_FLOOR_FACTOR,
    NoiseParams,
    allan_report,
    identify_noise,
    oadev,
    oadev_details,
)

allantools = pytest.importorskip("allantools")

DEG = math.pi / 180.0          # written out here, independent of fogcomp.units


# ---------------------------------------------------------------------------------------------
# Real data: /work/shared/realdata (or $FOGBENCH_REALDATA), never copied into the repository.
from helpers import need_realdata, realdata_dir as _realdata_dir  # noqa: E402


ADIS_DIR = _realdata_dir() / "adis16405_static"


@pytest.fixture(scope="module")
def adis():
    """The ADIS16405 static log as {column name: array} plus its reference Allan deviation."""
    log, ref = ADIS_DIR / "imu1.csv.gz", ADIS_DIR / "reference_oadev.csv"
    need_realdata(log, ref)
    with gzip.open(log, "rt") as f:
        names = f.readline().strip().split(",")
        values = np.loadtxt(f, delimiter=",", ndmin=2)
    data = {name: values[:, i] for i, name in enumerate(names)}
    with open(ref) as f:
        ref_names = f.readline().strip().split(",")
        ref_values = np.loadtxt(f, delimiter=",", ndmin=2)
    data["reference"] = {name: ref_values[:, i] for i, name in enumerate(ref_names)}
    return data


def test_real_log_is_what_the_readme_says(adis):
    t = adis["time_s"]
    assert t.shape == (1_000_000,)
    np.testing.assert_allclose(np.diff(t), 0.01, atol=1e-6)


# ---------------------------------------------------------------------------------------------
# oadev against allantools
FS_CHOICES = [1.0, 0.5, 100.0, 256.0, 1234.5]


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 3000), fs=st.sampled_from(FS_CHOICES),
       offset=st.floats(-10.0, 10.0), scale=st.floats(1e-6, 1e3))
def test_oadev_matches_allantools_octave(seed, n, fs, offset, scale):
    y = offset + scale * np.random.default_rng(seed).standard_normal(n)
    d = oadev_details(y, fs)
    taus_ref, adev_ref, _, ns_ref = allantools.oadev(y, rate=fs, data_type="freq", taus="octave")
    np.testing.assert_array_equal(d.taus, taus_ref)
    np.testing.assert_allclose(d.adev, adev_ref, rtol=1e-9, atol=0)
    np.testing.assert_array_equal(d.n_terms, ns_ref)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(5, 5000), fs=st.sampled_from(FS_CHOICES),
       data=st.data())
def test_oadev_matches_allantools_explicit_taus(seed, n, fs, data):
    m_max = (n - 1) // 2
    ms = data.draw(st.lists(st.integers(1, m_max), min_size=1, max_size=12, unique=True))
    ms = np.sort(ms)
    y = np.random.default_rng(seed).standard_normal(n)
    taus, adev = oadev(y, fs, taus=ms / fs)
    taus_ref, adev_ref, _, _ = allantools.oadev(y, rate=fs, data_type="freq", taus=ms / fs)
    np.testing.assert_allclose(taus, taus_ref, rtol=1e-15)
    np.testing.assert_allclose(adev, adev_ref, rtol=1e-9, atol=0)


# ---------------------------------------------------------------------------------------------
# oadev against the textbook definition, written as plainly as possible
def _oadev_twin(y: list[float], fs: float, m: int) -> float:
    """Half the mean square difference of every pair of adjacent overlapping cluster means."""
    n = len(y)
    means = [math.fsum(y[k:k + m]) / m for k in range(n - m + 1)]
    diffs = [(means[k + m] - means[k]) ** 2 for k in range(n - 2 * m + 1)]
    return math.sqrt(math.fsum(diffs) / (2 * len(diffs)))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 80), fs=st.sampled_from(FS_CHOICES))
def test_oadev_matches_textbook_twin(seed, n, fs):
    y = np.random.default_rng(seed).standard_normal(n) + 0.3
    d = oadev_details(y, fs, taus="all")
    assert list(d.m) == list(range(1, (n - 1) // 2 + 1))
    twin = [_oadev_twin(list(y), fs, int(m)) for m in d.m]
    np.testing.assert_allclose(d.adev, twin, rtol=1e-12, atol=0)
    np.testing.assert_allclose(d.taus, d.m / fs, rtol=1e-15)


# ---------------------------------------------------------------------------------------------
# Laws
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 2000),
       a=st.floats(1e-3, 1e3) | st.floats(-1e3, -1e-3), c=st.floats(-100.0, 100.0))
def test_oadev_scales_with_gain_and_ignores_offset(seed, n, a, c):
    y = np.random.default_rng(seed).standard_normal(n)
    _, base = oadev(y, 10.0)
    _, moved = oadev(a * y + c, 10.0)
    np.testing.assert_allclose(moved, abs(a) * base, rtol=1e-9)


def test_oadev_of_linear_ramp_is_analytic():
    # Cluster means of r*t differ by exactly r*tau, so adev = r*tau/sqrt(2) at every tau.
    fs, r = 50.0, 2e-3
    y = r * np.arange(10_001) / fs
    taus, adev = oadev(y, fs)
    np.testing.assert_allclose(adev, r * taus / math.sqrt(2.0), rtol=1e-9)


def test_oadev_error_bars_match_monte_carlo_scatter():
    # adev_err is the IEEE 952 cluster-count estimate; its docstring claims ~30 % accuracy for
    # white and random-walk rate noise. Check it against the scatter of 300 realisations.
    rng = np.random.default_rng(7)
    n = 1024
    for make in (lambda: rng.standard_normal(n), lambda: np.cumsum(rng.standard_normal(n))):
        curves = np.array([oadev(make(), 1.0)[1] for _ in range(300)])
        d = oadev_details(make(), 1.0)
        empirical = curves.std(axis=0) / curves.mean(axis=0)
        predicted = d.adev_err / d.adev
        ratio = empirical / predicted
        assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio


# ---------------------------------------------------------------------------------------------
# Real data against the R package avar
def test_oadev_matches_avar_on_real_adis16405(adis):
    ref = adis["reference"]
    taus = ref["tau_s"]
    fs = 1.0 / np.median(np.diff(adis["time_s"]))
    assert abs(fs - 100.0) < 1e-6
    fs = 100.0
    checked = 0
    for col, values in ref.items():
        if col == "tau_s":
            continue
        signal = col.removeprefix("adev_")
        got_taus, got = oadev(adis[signal], fs, taus=taus)
        np.testing.assert_allclose(got_taus, taus, rtol=1e-12)
        # avar divides by 2(T-2m+1) instead of 2(T-2m) (README): agreement to 1e-5, not 1e-15.
        np.testing.assert_allclose(got, values, rtol=1e-5, atol=0, err_msg=col)
        checked += 1
    assert checked == 6


def test_identify_noise_on_real_adis16405(adis):
    # README guide (fits by hand): ARW 2.3-2.6 deg/sqrt(h) (datasheet 2.0); bias instability
    # about 27 deg/h on x, 45 deg/h on y and z. Bands are generous because it is a guide.
    for axis in "xyz":
        rate = adis[f"gyro_{axis}_dps"] * DEG
        _, _, p = allan_report(rate, 100.0)
        arw_deg_rt_h = p.N / DEG * 60.0
        bi_dph = p.B / DEG * 3600.0
        assert 2.0 <= arw_deg_rt_h <= 2.8, (axis, arw_deg_rt_h)
        assert 18.0 <= bi_dph <= 60.0, (axis, bi_dph)
        assert p.Q is None, (axis, p.Q)        # 0.05 deg/s steps at 100 Hz: far below the ARW


# ---------------------------------------------------------------------------------------------
# identify_noise on synthetic noise with analytic Allan variance
FS = 100.0
N_LONG = 2**18          # 2621 s at 100 Hz


def _white(rng, n, arw):
    """White rate noise of ARW ``arw`` rad/sqrt(s): sample std arw*sqrt(fs), avar arw^2/tau."""
    return arw * math.sqrt(FS) * rng.standard_normal(n)


def _random_walk(rng, n, rrw):
    """Rate random walk: avar = rrw^2 tau/3 + rrw^2/(6 fs^2 tau) (discrete-time term, tiny)."""
    return np.cumsum(rrw / math.sqrt(FS) * rng.standard_normal(n))


def _flicker(rng, n, b):
    """Flicker rate noise, one-sided PSD b^2/(pi f) (IEEE 952: two-sided (b^2/2pi)/f), so that
    the Allan deviation is flat at sqrt(2 ln2/pi) b. Made 8x longer and cut, so that the record
    also holds the low frequencies of a process that started long before it."""
    big = 8 * n
    f = np.fft.rfftfreq(big, 1.0 / FS)
    s = np.zeros_like(f)
    s[1:] = b**2 / (math.pi * f[1:])
    spec = np.sqrt(s * FS * big / 2) * (rng.standard_normal(f.shape) +
                                       1j * rng.standard_normal(f.shape)) / math.sqrt(2)
    return np.fft.irfft(spec, big)[:n]


def _report(rate):
    d = oadev_details(rate, FS)
    return identify_noise(d.taus, d.adev, d.adev_err)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), arw=st.floats(1e-6, 1e-1))
def test_white_noise_gives_arw(seed, arw):
    p = _report(_white(np.random.default_rng(seed), N_LONG, arw))
    assert p.N == pytest.approx(arw, rel=0.05)
    assert p.detected == {"Q": False, "N": True, "B": False, "K": False, "R": False}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_rate_random_walk_gives_rrw(seed):
    k = 2e-5
    p = _report(_random_walk(np.random.default_rng(seed), N_LONG, k))
    assert p.K == pytest.approx(k, rel=0.10)
    # The discrete-time white term is a third of the variance at one sample: never dominant.
    assert p.N is None and p.B is None and p.Q is None


def test_white_quantisation_error_gives_q():
    # Textbook quantisation noise: the angle carries a white error uniform over one step S,
    # variance S^2/12, so avar = 3 (S^2/12) / tau^2 and Q = S/sqrt(12) (IEEE 952 C.1).
    step = 2e-6
    rng = np.random.default_rng(11)
    angle = 0.01 * np.arange(N_LONG + 1) / FS + step * (rng.random(N_LONG + 1) - 0.5)
    p = _report(np.diff(angle) * FS)
    assert p.Q == pytest.approx(step / math.sqrt(12.0), rel=0.05)
    assert p.N is None and p.B is None and p.K is None and p.R is None


def test_quantised_angle_counter_gives_q():
    # A real quantiser: the output angle is a whole number of steps S, floor(theta/S + u) with
    # a fresh uniform dither u per sample, at a constant true rate. Given the fractional part f
    # of theta/S the error is 1-f with probability f and -f otherwise: zero mean, independent
    # from sample to sample, variance f(1-f), which averages to 1/6 over f. So avar =
    # 3 (S^2/6) / tau^2 and Q = S/sqrt(6).
    step = 1e-6
    rng = np.random.default_rng(12)
    rate = step * FS * (3 + 0.6180339887498949)         # 3.618... steps per sample
    counts = np.floor(rate * np.arange(N_LONG + 1) / FS / step + rng.random(N_LONG + 1))
    increments = np.diff(counts) * step
    assert np.all(np.abs(increments / step - np.round(increments / step)) < 1e-9)
    p = _report(increments * FS)
    assert p.Q == pytest.approx(step / math.sqrt(6.0), rel=0.05)
    assert p.N is None and p.B is None and p.K is None and p.R is None


def test_linear_ramp_gives_rate_ramp_exactly():
    r = 3e-6
    p = _report(r * np.arange(N_LONG) / FS)
    assert p.R == pytest.approx(r, rel=1e-6)
    assert p.detected == {"Q": False, "N": False, "B": False, "K": False, "R": True}


def test_ramp_plus_white_noise():
    r, arw = 1e-4, 0.01
    rng = np.random.default_rng(21)
    p = _report(r * np.arange(N_LONG) / FS + _white(rng, N_LONG, arw))
    assert p.R == pytest.approx(r, rel=0.05)
    assert p.N == pytest.approx(arw, rel=0.05)


def test_white_plus_random_walk():
    # Crossover at tau = sqrt(3) arw / rrw = 17 s, about seven octaves of each slope.
    arw, rrw = 0.01, 1e-3
    rng = np.random.default_rng(31)
    p = _report(_white(rng, N_LONG, arw) + _random_walk(rng, N_LONG, rrw))
    assert p.N == pytest.approx(arw, rel=0.05)
    assert p.K == pytest.approx(rrw, rel=0.25)


def test_flicker_generator_has_the_intended_psd():
    from scipy.signal import welch

    b = 1e-2
    f, pxx = welch(_flicker(np.random.default_rng(41), N_LONG, b), FS, nperseg=4096)
    band = (f > 0.1) & (f < 10.0)
    assert np.mean(pxx[band] * math.pi * f[band] / b**2) == pytest.approx(1.0, rel=0.1)


@pytest.mark.parametrize("seed", [41, 42, 43])
def test_flicker_plus_white_gives_bias_instability(seed):
    # Flicker b dominates above tau = arw^2 / (0.441 b^2) = 2.3 s. Single flicker realisations
    # scatter a lot (1/f noise has most of its power at the lowest frequencies): over 20 other
    # seeds the floor reading B/b had mean 0.93 (the minimum of noisy points reads low), sd
    # 0.14 and worst 0.51, so these fixed seeds are checked to 35 % only; the exact 0.664
    # reading is checked on an exact curve below. The ARW is checked to 5 %.
    arw, b = 0.01, 1e-2
    rng = np.random.default_rng(seed)
    p = _report(_flicker(rng, N_LONG, b) + _white(rng, N_LONG, arw))
    assert p.B == pytest.approx(b, rel=0.35)
    assert p.N == pytest.approx(arw, rel=0.05)
    assert p.B_tau > 2.3


def test_identify_noise_without_error_bars_still_fits():
    # Without adev_err every point has the same weight; on an exact model curve the fit is exact.
    # Q leads below 0.03 s, N up to 170 s, K up to 6700 s, R above: every term shows.
    taus = np.logspace(-3, 5, 50)
    q, n, k, r = 1e-5, 1e-4, 1e-6, 1e-8
    avar = 3 * q**2 / taus**2 + n**2 / taus + k**2 * taus / 3 + r**2 * taus**2 / 2
    p = identify_noise(taus, np.sqrt(avar))
    assert p.Q == pytest.approx(q, rel=1e-6)
    assert p.N == pytest.approx(n, rel=1e-6)
    assert p.K == pytest.approx(k, rel=1e-6)
    assert p.R == pytest.approx(r, rel=1e-6)


def test_identify_noise_reads_flat_floor_with_0664():
    # An exact curve white + flat floor: B = floor / sqrt(2 ln 2 / pi) = floor / 0.6643.
    taus = np.logspace(-2, 4, 40)
    n, b = 1e-4, 1e-5
    adev = np.sqrt(n**2 / taus + (2 * math.log(2) / math.pi) * b**2)
    p = identify_noise(taus, adev)
    expected_floor = adev.min()
    assert p.B == pytest.approx(expected_floor / 0.66428, rel=1e-4)
    assert p.B == pytest.approx(b, rel=0.02)           # the floor is almost all flicker there
    assert p.B_tau == taus[np.argmin(adev)]
    assert FLICKER_FLOOR_FACTOR == pytest.approx(0.664, abs=5e-4)


def test_identify_noise_is_equivariant_under_gain():
    rng = np.random.default_rng(51)
    d = oadev_details(_white(rng, 2**15, 1e-3) + _random_walk(rng, 2**15, 1e-4), FS)
    p1 = identify_noise(d.taus, d.adev, d.adev_err)
    p2 = identify_noise(d.taus, 1e3 * d.adev, 1e3 * d.adev_err)
    for term in "QNBKR":
        v1, v2 = getattr(p1, term), getattr(p2, term)
        assert (v1 is None) == (v2 is None)
        if v1 is not None:
            assert v2 == pytest.approx(1e3 * v1, rel=1e-6)


def test_to_datasheet_units():
    # Conversions written out by hand: deg/sqrt(h) = rad/sqrt(s) * (180/pi) * sqrt(3600) ...
    p = NoiseParams(Q=1e-6, N=1e-4, B=1e-5, K=1e-7, R=1e-9, B_tau=100.0)
    ds = p.to_datasheet()
    r2d = 180.0 / math.pi
    assert ds["arw_deg_rt_h"] == pytest.approx(1e-4 * r2d * 60.0)
    assert ds["bias_instability_dph"] == pytest.approx(1e-5 * r2d * 3600.0)
    assert ds["rrw_dph_rt_h"] == pytest.approx(1e-7 * r2d * 3600.0 * 60.0)
    assert ds["quantisation_arcsec"] == pytest.approx(1e-6 * r2d * 3600.0)
    assert ds["rate_ramp_dph_per_h"] == pytest.approx(1e-9 * r2d * 3600.0 * 3600.0)
    assert ds["bias_instability_tau_s"] == 100.0
    none = NoiseParams(Q=None, N=1e-4, B=None, K=None, R=None).to_datasheet()
    assert none["bias_instability_dph"] is None and none["arw_deg_rt_h"] is not None


def test_allan_report_is_oadev_plus_identify_noise():
    rng = np.random.default_rng(61)
    y = _white(rng, 2**14, 1e-3)
    taus, adev, p = allan_report(y, FS)
    t2, a2 = oadev(y, FS)
    np.testing.assert_array_equal(taus, t2)
    np.testing.assert_array_equal(adev, a2)
    assert p.N == pytest.approx(1e-3, rel=0.05)


# ---------------------------------------------------------------------------------------------
# Input validation
@pytest.mark.parametrize("rate, match", [
    (np.array([1.0, np.nan, 2.0, 3.0]), r"rate: non-finite value nan at index 1"),
    (np.array([1.0, np.inf, 2.0, 3.0]), r"rate: non-finite"),
    (np.zeros((10, 2)), r"rate: expected a 1-D array"),
    (np.array([1.0, 2.0]), r"rate: expected at least 3 samples, got 2"),
    ("abc", r"rate: cannot be read"),
])
def test_oadev_rejects_bad_rate(rate, match):
    with pytest.raises(ValueError, match=match):
        oadev(rate, 10.0)


@pytest.mark.parametrize("fs", [0.0, -1.0, float("nan"), float("inf"), "100", None, True])
def test_oadev_rejects_bad_fs(fs):
    with pytest.raises(ValueError, match=r"fs: sample rate must be a positive finite number"):
        oadev(np.ones(10), fs)


@pytest.mark.parametrize("taus, match", [
    ([0.15], r"taus: every averaging time must be a whole multiple of the sample interval"),
    ([0.5], r"taus: the longest averaging time .* is \(n-1\)//2 = 4 samples"),
    ([0.0], r"taus: averaging times must be positive"),
    ([[0.1, 0.2]], r"taus: expected a non-empty 1-D array"),
    ([], r"taus: expected a non-empty 1-D array"),
    ("decade", r"taus: unknown keyword 'decade'"),
])
def test_oadev_rejects_bad_taus(taus, match):
    with pytest.raises(ValueError, match=match):
        oadev(np.random.default_rng(0).standard_normal(10), 10.0, taus=taus)


@pytest.mark.parametrize("taus, adev, err, match", [
    ([1, 2], [1, 1], None, r"taus: expected at least 3"),
    ([1, 2, 3], [1, 1], None, r"adev: shape \(2,\) must match taus \(3,\)"),
    ([1, 2, 3], [1, 0, 1], None, r"adev: expected positive finite values.*constant signal"),
    ([1, 2, 3], [1, np.nan, 1], None, r"adev: expected positive finite"),
    ([1, 2, 2], [1, 1, 1], None, r"taus: averaging times must be distinct"),
    ([1, -2, 3], [1, 1, 1], None, r"taus: expected positive finite"),
    ([[1, 2, 3]], [[1, 1, 1]], None, r"taus: expected a 1-D array"),
    ([1, 2, 3], [1, 1, 1], [0.1, -0.1, 0.1], r"adev_err: expected non-negative"),
    ([1, 2, 3], [1, 1, 1], [0.1, 0.1], r"adev_err: shape \(2,\) must match"),
])
def test_identify_noise_rejects_bad_curves(taus, adev, err, match):
    with pytest.raises(ValueError, match=match):
        identify_noise(taus, adev, err)


def test_identify_noise_rejects_bad_options():
    with pytest.raises(ValueError, match=r"model_error: expected a positive finite number"):
        identify_noise([1, 2, 3], [1, 1, 1], model_error=0.0)
