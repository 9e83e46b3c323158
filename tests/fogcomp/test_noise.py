"""The composite noise identifier (fogcomp.noise), checked against what does not depend on it:
each process's Allan variance from its autocovariance summed by brute force, the mean and the
covariance of the estimates over many simulated records (independent numpy generators), and
the identifier's estimates, intervals and selections against the configured values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from fogcomp.allan import allan_analysis, oadev_details
from fogcomp.noise import (avar_covariance, avar_gm, avar_model, avar_term,
                           identify_noise_model, parse_model)
from fogcomp.noise import _covariance as COV, _fit, _intervals

FS = 10.0


# --- generators written here, independent of sim/ ------------------------------------------
def white(rng, n, arw):
    return arw * math.sqrt(FS) * rng.standard_normal(n)


def interval_mean_random_walk(rng, n, k):
    """Rate random walk averaged over each sample interval, exactly: the mean of Brownian
    motion over an interval is its start value plus half the increment plus a bridge term of
    variance dt/12 (per unit diffusion)."""
    dt = 1.0 / FS
    inc = k * math.sqrt(dt) * rng.standard_normal(n)
    start = np.concatenate([[0.0], np.cumsum(inc)[:-1]])
    return start + 0.5 * inc + k * math.sqrt(dt / 12.0) * rng.standard_normal(n)


def gauss_markov(rng, n, sigma, T):
    phi = math.exp(-1.0 / (FS * T))
    e = sigma * math.sqrt(1 - phi * phi) * rng.standard_normal(n)
    e[0] = sigma * rng.standard_normal()
    return lfilter([1.0], [1.0, -phi], e)


def quantised_white_angle(rng, n, step):
    """A white angle error uniform over one step (Q = step / sqrt(12), IEEE 952 C.1)."""
    return np.diff(step * (rng.random(n + 1) - 0.5)) * FS


# --- each process's Allan variance ---------------------------------------------------------
def brute_avar(gamma, m: int) -> float:
    """AVAR(m) = (1/m^2) sum_{|h|<m} (m - |h|) [gamma(h) - gamma(m + h)] of a stationary
    process with autocovariance gamma (the definition, summed term by term)."""
    h = np.arange(-(m - 1), m)
    return float(np.sum((m - np.abs(h)) * (gamma(np.abs(h)) - gamma(np.abs(m + h))))) / m**2


@pytest.mark.parametrize("T", [0.05, 0.3, 2.0, 40.0, 1e4])
def test_gauss_markov_closed_form_equals_the_autocovariance_sum(T):
    phi = math.exp(-1.0 / (FS * T))
    for m in (1, 2, 3, 7, 64, 500):
        want = brute_avar(lambda h: phi ** h, m)
        assert avar_gm([m / FS], T, FS)[0] == pytest.approx(want, rel=1e-9), m


@pytest.mark.parametrize("term", ["Q", "N", "B", "K"])
def test_the_angle_covariance_gives_the_table_of_allan_variances(term):
    # E[d^2] = 6 G(0) - 8 G(tau) + 2 G(2 tau) from the generalised autocovariance of the angle
    # must be 2 tau^2 AVAR(tau) of the table (IEEE 952 C.1)
    tau0 = 1.0 / FS
    for m in (1, 4, 100, 4096):
        if term == "Q":
            e = 6.0                                  # the delta: G(0) = Q^2, else 0
        else:
            g = [COV._g_unit(term, None, np.array([float(x)]), tau0)[0] for x in (0, m, 2 * m)]
            e = 6 * g[0] - 8 * g[1] + 2 * g[2]
        tau = m * tau0
        assert e / (2 * tau**2) == pytest.approx(avar_term(term, [tau])[0], rel=1e-12)


def test_gauss_markov_angle_covariance_gives_its_allan_variance():
    tau0, T = 1.0 / FS, 3.0
    for m in (1, 5, 200):
        g = [COV._g_unit("GM", T, np.array([float(x)]), tau0)[0] for x in (0, m, 2 * m)]
        e = 6 * g[0] - 8 * g[1] + 2 * g[2]
        assert e / (2 * (m * tau0) ** 2) == pytest.approx(avar_gm([m * tau0], T, FS)[0],
                                                         rel=1e-10)


def test_the_quadrature_equals_the_term_by_term_sum(monkeypatch):
    """The fast path (Gauss-Legendre between the kinks) against the slow obvious twin (every
    lag summed), for each process, on averaging factors where both can run."""
    n, procs = 400_000, [("N", None), ("K", None), ("B", None), ("GM", 30.0), ("GM", 0.7),
                         ("Q", None)]
    for mi, mj in [(512, 512), (700, 3000), (64, 2048), (1024, 4096)]:
        monkeypatch.setattr(COV, "_EXACT_MAX", 10**9)
        s2e, s1e = COV._pair_sums(procs, mi, mj, n, FS)
        monkeypatch.setattr(COV, "_EXACT_MAX", 16)
        s2q, s1q = COV._pair_sums(procs, mi, mj, n, FS)
        np.testing.assert_allclose(s2q, s2e, rtol=1e-2, atol=1e-12 * np.abs(s2e).max())
        np.testing.assert_allclose(s1q, s1e, rtol=1e-2, atol=1e-12 * np.abs(s1e).max())


# --- the mean and covariance of the estimates over simulated records ------------------------
CASES = {
    "white": (dict(N=0.3), (), lambda rng, n: white(rng, n, 0.3)),
    "random walk": (dict(K=0.05), (), lambda rng, n: interval_mean_random_walk(rng, n, 0.05)),
    "Gauss-Markov": (dict(), ((0.2, 20.0),), lambda rng, n: gauss_markov(rng, n, 0.2, 20.0)),
    "white + GM + quantisation": (
        dict(N=0.1, Q=0.01 / math.sqrt(12)), ((0.2, 5.0),),
        lambda rng, n: (white(rng, n, 0.1) + gauss_markov(rng, n, 0.2, 5.0)
                        + quantised_white_angle(rng, n, 0.01))),
}


@pytest.mark.parametrize("case", list(CASES))
def test_mean_and_covariance_of_the_estimates_match_monte_carlo(case):
    co, gm, make = CASES[case]
    n, reps = 4096, 1500
    m = 2 ** np.arange(11)
    rng = np.random.default_rng(7)
    est = np.array([oadev_details(make(rng, n), FS, taus=m / FS).adev ** 2
                    for _ in range(reps)])
    cov = avar_covariance(m, n, FS, co, gm)
    mean = avar_model(m / FS, co, gm, FS)
    sd_mean = np.sqrt(np.diag(cov) / reps)
    # the mean: within 4 standard errors (the covariance's own), every octave
    assert np.all(np.abs(est.mean(axis=0) - mean) < 4 * sd_mean), case
    # the variance: a sample variance of 1500 draws is known to about 4 % (more for the
    # skewed long-tau estimates): within 20 %
    np.testing.assert_allclose(est.var(axis=0, ddof=1), np.diag(cov), rtol=0.2)
    # neighbouring octaves' correlation (0.5-0.9 here) to 0.1
    emp = np.corrcoef(est.T)
    ana = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    np.testing.assert_allclose(np.diag(emp, 1), np.diag(ana, 1), atol=0.1)


# --- the identifier against configured values ----------------------------------------------
def _records(make, n, seeds):
    for s in seeds:
        yield allan_analysis(make(np.random.default_rng(1000 + s), n), FS,
                             record_length=False)[1]


def test_white_and_random_walk_come_back_with_honest_intervals():
    """20 records of ARW + RRW (2^17 samples at 10 Hz, 3.6 h): both identified in every one,
    each estimate's median relative error within 10 %, the 68 % intervals covering the
    configured value in 55-80 % of records, nothing else identified in more than 1 of 20."""
    arw, rrw = 0.02, 0.003
    models = list(_records(lambda rng, n: white(rng, n, arw)
                           + interval_mean_random_walk(rng, n, rrw), 2**17, range(20)))
    for term, want in (("N", arw), ("K", rrw)):
        ts = [m.term(term) for m in models]
        assert all(t.status == "identified" for t in ts), term
        err = np.median([t.value / want - 1 for t in ts])
        assert abs(err) < 0.10, (term, err)
        cover = np.mean([t.low <= want <= t.high for t in ts])
        assert 0.55 <= cover <= 0.80, (term, cover)
    extra = sum(1 for m in models for t in m.identified if t.term not in ("N", "K"))
    assert extra <= 1, [m.spec() for m in models]


def test_a_strong_gauss_markov_term_comes_back_with_its_correlation_time():
    """ARW + a Gauss-Markov term that stands above it around its correlation time (sigma 0.5
    rad/s... scaled: 25 times the ARW's deviation at tau = T), records of 100 T: sigma within
    20 % and T within 30 % (medians over 10 records), intervals covering in most."""
    arw, sigma, T = 0.02, 0.05, 20.0
    models = list(_records(lambda rng, n: white(rng, n, arw) + gauss_markov(rng, n, sigma, T),
                           int(100 * T * FS), range(10)))
    gms = [m.gm_terms for m in models]
    assert sum(len(g) == 1 for g in gms) >= 9, [m.spec() for m in models]
    found = [g[0] for g in gms if len(g) == 1]
    assert abs(np.median([g.value / sigma - 1 for g in found])) < 0.20
    assert abs(np.median([g.tau / T - 1 for g in found])) < 0.30
    assert np.mean([(g.tau_low or 0.0) <= T <= (g.tau_high or np.inf) for g in found]) >= 0.5
    assert all("B" not in m.spec() for m in models)


def test_an_absent_flicker_is_not_identified():
    """ARW + RRW, no flicker: the bias instability is not identified in 20 records (at most 1,
    the selection's level), and is reported as an upper bound instead."""
    models = list(_records(lambda rng, n: white(rng, n, 0.02)
                           + interval_mean_random_walk(rng, n, 0.003), 2**16, range(20)))
    statuses = [m.term("B").status for m in models]
    assert statuses.count("identified") <= 1, statuses
    assert all(m.term("B").bound is not None for m in models
               if m.term("B").status == "upper bound")


def test_record_length_prediction_matches_longer_records():
    """The record length the model predicts for a given precision, checked by simulation: the
    predicted relative sigma of K at 4 times the record against the scatter of K over 16
    records that long (a factor 1.6 either way: 16 records give the scatter to about 20 %)."""
    arw, rrw, n = 0.02, 0.003, 2**15
    make = (lambda rng, nn: white(rng, nn, arw) + interval_mean_random_walk(rng, nn, rrw))
    m0 = allan_analysis(make(np.random.default_rng(1), n), FS, model="N + K",
                        record_length=False)[1]
    pb = _fit._Problem(m0.taus, m0.avar, (m0.taus * FS).astype(int), (n,), FS, 0.001)
    pb.set_weights(*m0.coefficients())
    fit = _fit._Fit(_fit._Spec(("N", "K")), np.array([arw**2, rrw**2]), 0.0)
    predicted = _intervals._predicted_rel_sigma(pb, fit, 1, 4 * n)
    longer = [t.term("K").value for t in _records_stated(make, 4 * n, range(16), "N + K")]
    observed = np.std(longer, ddof=1) / rrw
    assert 1 / 1.6 < observed / predicted < 1.6, (observed, predicted)


def _records_stated(make, n, seeds, model):
    for s in seeds:
        yield allan_analysis(make(np.random.default_rng(2000 + s), n), FS, model=model,
                             record_length=False)[1]


# --- filter parameters, stated models --------------------------------------------------------
def test_filter_parameters_in_continuous_and_discrete_form():
    fs, n = 100.0, 2**20
    taus = 2 ** np.arange(19) / fs
    N, K, sig, T = 1e-4, 1e-7, 3e-5, 50.0
    avar = avar_model(taus, {"N": N, "K": K}, [(sig, T)], fs)
    m = identify_noise_model(taus, avar, fs, n, model="N + K + GM", record_length=False)
    by = {p["term"]: p for p in m.filter_parameters()}
    # Kalibr's units: noise density rad/s/sqrt(Hz), random walk rad/s^2/sqrt(Hz)
    assert by["N"]["continuous"]["noise_density_rad_s_rt_hz"] == pytest.approx(N, rel=1e-4)
    assert by["N"]["discrete"]["rate_sigma_rad_s"] == pytest.approx(N * 10.0, rel=1e-4)
    assert by["K"]["continuous"]["random_walk_rad_s2_rt_hz"] == pytest.approx(K, rel=1e-3)
    assert by["K"]["discrete"]["bias_step_sigma_rad_s"] == pytest.approx(K / 10.0, rel=1e-3)
    gm = by["GM"]
    assert gm["continuous"]["tau_s"] == pytest.approx(T, rel=1e-3)
    assert gm["discrete"]["phi"] == pytest.approx(math.exp(-1 / (fs * T)), rel=1e-6)
    # the discrete driving noise keeps the stationary variance: sigma_w^2 / (1 - phi^2)
    phi = gm["discrete"]["phi"]
    assert gm["discrete"]["driving_sigma_rad_s"] ** 2 / (1 - phi**2) == pytest.approx(
        sig**2, rel=1e-3)


def test_parse_model():
    assert parse_model("N + B + K") == (("N", "B", "K"), 0)
    assert parse_model("k+gm+N+GM") == (("N", "K"), 2)
    assert parse_model(["Q", "N"]) == (("Q", "N"), 0)
    for bad, match in (("", "at least one"), ("N + N", "twice"), ("N + Z", "unknown term"),
                       (3, "expected terms")):
        with pytest.raises(ValueError, match=match):
            parse_model(bad)


def test_the_covariance_kernel_at_nine_shifts_at_once_is_the_double_loop_to_the_bit():
    """``_f_unit`` evaluates g at its nine shifts in one call; the slow obvious twin, the double
    loop over a, b it replaced, gives the same numbers to the last bit for every process, on
    term-by-term lags and on quadrature nodes."""
    def loop(kind, T, h, mi, mj, tau0):
        out = np.zeros_like(h, dtype=float)
        for a in range(3):
            for b in range(3):
                arg = h + a * mi - b * mj
                if kind == "Q":
                    out += COV._C[a] * COV._C[b] * (arg == 0)
                else:
                    out += COV._C[a] * COV._C[b] * COV._g_unit(kind, T, np.abs(arg), tau0)
        return out

    tau0 = 1.0 / FS
    nodes, _ = COV._gl_nodes(COV._geometric_pieces(-5000.5, 9000.5, "both"))
    for h in (np.arange(-700.0, 3001.0), nodes):
        for kind, T in [("N", None), ("K", None), ("B", None), ("GM", 30.0), ("GM", 0.7),
                        ("Q", None)]:
            for mi, mj in [(1, 1), (700, 3000), (64, 2048)]:
                fast = COV._f_unit(kind, T, h, mi, mj, tau0)
                np.testing.assert_array_equal(fast, loop(kind, T, h, mi, mj, tau0))
                assert np.any(fast != 0) or (kind == "Q" and h is nodes)  # Q: integer lags
