"""Tests of fogcomp.allan: the overlapping Allan deviation, and the noise identification of
records whose Allan variance is known in closed form (through allan_analysis, the path every
command and report takes).

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

from fogcomp.allan import FLICKER_FLOOR_FACTOR, allan_analysis, oadev, oadev_details
from fogcomp.noise import identify_noise_model

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
    # about 27 deg/h on x, 45 deg/h on y and z. Bands are generous because it is a guide; the
    # fit's own interval must be honest about the model's misfit of a real MEMS curve (its
    # estimated model error is stated, and J brought to its degrees of freedom).
    for axis in "xyz":
        rate = adis[f"gyro_{axis}_dps"] * DEG
        _, m = allan_analysis(rate, 100.0)
        n = m.term("N")
        assert n.status == "identified"
        assert 2.0 <= n.value / DEG * 60.0 <= 2.8, (axis, n.value / DEG * 60.0)
        b = m.term("B")
        bi = (b.value if b.status == "identified" else b.bound) / DEG * 3600.0
        assert 18.0 <= bi <= 60.0, (axis, b)
        assert m.term("Q").status != "identified"  # 0.05 deg/s steps at 100 Hz: under the ARW
        assert m.model_error > 0.001 and m.p_value > 0.05


# ---------------------------------------------------------------------------------------------
# the identifier on synthetic noise with analytic Allan variance
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
    """The identified model of a record, terms selected (what ``fogbench allan`` reports)."""
    return allan_analysis(rate, FS, record_length=False)[1]


def _identified(model) -> set:
    return {t.term for t in model.identified}


# Derandomized: "only N is identified" holds at the selection's level, not always. A term
# enters when it lowers J by more than its 1 % critical value, so a record of pure white noise
# shows a spurious flicker term now and then (seed 1_623_663_498, arw 0.0625 gave B = 0.0084,
# 13 % of N: CI drew it once). The rate of such false terms is what fogbench.bench.noise
# measures over many records; here the same 8 records every run.
@settings(max_examples=8, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), arw=st.floats(1e-6, 1e-1))
def test_white_noise_gives_arw(seed, arw):
    m = _report(_white(np.random.default_rng(seed), N_LONG, arw))
    n = m.term("N")
    assert n.value == pytest.approx(arw, rel=0.02)
    # 2621 s at 100 Hz: the ARW is known to about 0.1 %, its 68 % interval says so
    assert n.low < n.value < n.high and (n.high - n.low) / n.value < 0.01
    assert _identified(m) == {"N"}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_rate_random_walk_gives_rrw(seed):
    k = 2e-5
    m = _report(_random_walk(np.random.default_rng(seed), N_LONG, k))
    assert m.term("K").value == pytest.approx(k, rel=0.10)
    # a random walk sampled at points, not averaged over each interval, carries a white part:
    # avar = k^2 tau / 3 + k^2 / (6 fs^2 tau), i.e. N = k / (sqrt(6) fs); the fit finds it
    assert m.term("N").value == pytest.approx(k / (math.sqrt(6.0) * FS), rel=0.2)
    assert _identified(m) == {"N", "K"}


def test_white_quantisation_error_gives_q():
    # Textbook quantisation noise: the angle carries a white error uniform over one step S,
    # variance S^2/12, so avar = 3 (S^2/12) / tau^2 and Q = S/sqrt(12) (IEEE 952 C.1).
    step = 2e-6
    rng = np.random.default_rng(11)
    angle = 0.01 * np.arange(N_LONG + 1) / FS + step * (rng.random(N_LONG + 1) - 0.5)
    m = _report(np.diff(angle) * FS)
    assert m.term("Q").value == pytest.approx(step / math.sqrt(12.0), rel=0.02)
    assert _identified(m) == {"Q"}


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
    m = _report(increments * FS)
    assert m.term("Q").value == pytest.approx(step / math.sqrt(6.0), rel=0.02)
    assert _identified(m) == {"Q"}


def test_ramp_plus_white_noise():
    r, arw = 1e-4, 0.01
    rng = np.random.default_rng(21)
    m = _report(r * np.arange(N_LONG) / FS + _white(rng, N_LONG, arw))
    assert m.term("R").value == pytest.approx(r, rel=0.05)
    assert m.term("N").value == pytest.approx(arw, rel=0.02)


def test_white_plus_random_walk():
    # Crossover at tau = sqrt(3) arw / rrw = 17 s, about seven octaves of each slope.
    arw, rrw = 0.01, 1e-3
    rng = np.random.default_rng(31)
    m = _report(_white(rng, N_LONG, arw) + _random_walk(rng, N_LONG, rrw))
    assert m.term("N").value == pytest.approx(arw, rel=0.02)
    k = m.term("K")
    assert k.value == pytest.approx(rrw, rel=0.25) and k.low <= rrw <= k.high
    assert _identified(m) == {"N", "K"}


def test_flicker_generator_has_the_intended_psd():
    from scipy.signal import welch

    b = 1e-2
    f, pxx = welch(_flicker(np.random.default_rng(41), N_LONG, b), FS, nperseg=4096)
    band = (f > 0.1) & (f < 10.0)
    assert np.mean(pxx[band] * math.pi * f[band] / b**2) == pytest.approx(1.0, rel=0.1)


@pytest.mark.parametrize("seed", [41, 42, 43])
def test_flicker_plus_white_gives_bias_instability(seed):
    # Flicker b dominates above tau = arw^2 / (0.441 b^2) = 2.3 s. The fitted flicker
    # coefficient, not the floor reading, is the estimate: it must cover b with its interval
    # widened to two sigma (three fixed seeds), and the floor reading is reported beside it.
    arw, b = 0.01, 1e-2
    rng = np.random.default_rng(seed)
    m = _report(_flicker(rng, N_LONG, b) + _white(rng, N_LONG, arw))
    bt = m.term("B")
    assert bt.status == "identified"
    half = (bt.high - bt.low) / 2
    assert abs(bt.value - b) <= 2 * half + 1e-12, (bt.value, bt.low, bt.high)
    assert m.term("N").value == pytest.approx(arw, rel=0.02)
    assert m.floor_reading["value"] is not None and m.floor_reading["tau_s"] > 2.3


def test_exact_curve_gives_its_coefficients_and_the_floor_reading_is_beside_it():
    # An exact white + flat-floor + random-walk curve of a 10^6-sample record: the fit gives
    # the coefficients, the IEEE 952 floor reading (minimum / 0.664) is larger than B, because
    # white noise and the random walk still add to the curve at its minimum.
    fs, n = 100.0, 10**6
    m_ = 2 ** np.arange(19)
    taus = m_ / fs
    nn, b, k = 1e-4, 3e-5, 3e-6        # the minimum near 60 s, inside the reliable part
    avar = nn**2 / taus + (2 * math.log(2) / math.pi) * b**2 + k**2 * taus / 3
    m = identify_noise_model(taus, avar, fs, n, model="N + B + K", record_length=False)
    for term, want in (("N", nn), ("B", b), ("K", k)):
        assert m.term(term).value == pytest.approx(want, rel=1e-6), term
    reading = m.floor_reading["value"]
    assert reading == pytest.approx(np.sqrt(avar).min() / 0.66428, rel=1e-4)
    assert reading > 1.05 * b
    assert FLICKER_FLOOR_FACTOR == pytest.approx(0.664, abs=5e-4)


def test_identification_is_equivariant_under_gain():
    rng = np.random.default_rng(51)
    y = _white(rng, 2**15, 1e-3) + _random_walk(rng, 2**15, 1e-4)
    _, m1 = allan_analysis(y, FS, record_length=False)
    _, m2 = allan_analysis(1e3 * y, FS, record_length=False)
    assert m1.spec() == m2.spec()
    for t1, t2 in zip(m1.terms, m2.terms):
        assert t1.status == t2.status
        if t1.value is not None:
            assert t2.value == pytest.approx(1e3 * t1.value, rel=1e-5)


def test_to_datasheet_units():
    # Conversions written out by hand: deg/sqrt(h) = rad/sqrt(s) * (180/pi) * sqrt(3600) ...
    fs, n = 100.0, 2**20
    taus = 2 ** np.arange(19) / fs
    q, nn, b, k, r = 1e-6, 1e-4, 1e-5, 1e-7, 1e-9
    avar = (3 * q**2 / taus**2 + nn**2 / taus + (2 * math.log(2) / math.pi) * b**2
            + k**2 * taus / 3 + r**2 * taus**2 / 2)
    m = identify_noise_model(taus, avar, fs, n, model="Q+N+B+K+R", record_length=False)
    ds = m.datasheet_values()
    r2d = 180.0 / math.pi
    assert ds["arw_deg_rt_h"] == pytest.approx(1e-4 * r2d * 60.0, rel=1e-5)
    assert ds["bias_instability_dph"] == pytest.approx(1e-5 * r2d * 3600.0, rel=1e-5)
    assert ds["rrw_dph_rt_h"] == pytest.approx(1e-7 * r2d * 3600.0 * 60.0, rel=1e-5)
    assert ds["quantisation_arcsec"] == pytest.approx(1e-6 * r2d * 3600.0, rel=1e-5)
    assert ds["rate_ramp_dph_per_h"] == pytest.approx(1e-9 * r2d * 3600.0 * 3600.0, rel=1e-5)


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


@pytest.mark.parametrize("kwargs, match", [
    (dict(taus=[0.1, 0.2], avar=[1, 1]), r"taus: expected at least 3"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1]), r"taus, avar: expected two 1-D arrays"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 0, 1]), r"positive finite values.*constant record"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, np.nan, 1]), r"positive finite"),
    (dict(taus=[0.1, 0.2, 0.2], avar=[1, 1, 1]), r"averaging times must be distinct"),
    (dict(taus=[0.1, 0.25, 0.4], avar=[1, 1, 1]), r"whole multiple of 1/fs"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1, 1], n=7), r"n: expected the number of samples"),
    (dict(taus=[0.1, 0.2, 0.8], avar=[1, 1, 1], n=9), r"needs more than the 9 samples"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1, 1], model="N + X"), r"model: unknown term 'X'"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1, 1], model="N+B+K"), r"not enough points"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1, 1], alpha=0.7), r"alpha: expected a test level"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1, 1], max_gm=9), r"max_gm: expected an integer"),
    (dict(taus=[0.1, 0.2, 0.4], avar=[1, 1, 1], ci=1.0), r"ci: expected a probability"),
])
def test_identify_noise_model_rejects_bad_input(kwargs, match):
    args = {"fs": 10.0, "n": 1000, **kwargs}
    with pytest.raises(ValueError, match=match):
        identify_noise_model(args.pop("taus"), args.pop("avar"), args.pop("fs"), args.pop("n"),
                             **args)
