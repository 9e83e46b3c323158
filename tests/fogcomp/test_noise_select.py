"""The noise identifier's model selection (issue 41), each profile kind against its stated-model
twin: the same record fitted with the configured model stated. Where the twin finds a term
(identified, its 68 % interval above 0), the selection must find it too, and must not add a
term that was not configured. Records from generators written here (white noise, first-order
Gauss-Markov, an interval-mean random walk, flicker by spectral shaping), independent of
``sim`` and ``fogcomp``. Reduced runs (a few seeds, shorter records than the bench's 20 seeds:
``python -m fogbench.bench.noise_select``); and the API of the terms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from fogcomp.allan import allan_analysis
from fogcomp.noise import DATASHEET_VERSION, avar_model, identify_noise_model

DPH = math.pi / 180.0 / 3600.0            # written out here, independent of fogcomp.units
DEG_RT_H = math.pi / 180.0 / 60.0


def white(rng, n, fs, arw):
    return arw * math.sqrt(fs) * rng.standard_normal(n)


def gauss_markov(rng, n, fs, sigma, T):
    phi = math.exp(-1.0 / (fs * T))
    e = sigma * math.sqrt(1 - phi * phi) * rng.standard_normal(n)
    e[0] = sigma * rng.standard_normal()
    return lfilter([1.0], [1.0, -phi], e)


def random_walk(rng, n, fs, k):
    """Interval means of a rate random walk (start + half the increment + the bridge term)."""
    dt = 1.0 / fs
    inc = k * math.sqrt(dt) * rng.standard_normal(n)
    start = np.concatenate([[0.0], np.cumsum(inc)[:-1]])
    return start + 0.5 * inc + k * math.sqrt(dt / 12.0) * rng.standard_normal(n)


def flicker(rng, n, fs, B):
    """Flicker rate noise of one-sided PSD B^2 / (2 pi f) (IEEE Std 952 Table C.1), white noise
    shaped in frequency over twice the record (so the circular wrap falls outside it)."""
    m = 2 * n
    spec = np.fft.rfft(rng.standard_normal(m))
    f = np.fft.rfftfreq(m, 1.0 / fs)
    f[0] = f[1]
    # white of unit variance has one-sided PSD 2 / fs
    spec *= np.sqrt(B**2 / (2.0 * math.pi * f) * fs / 2.0)
    return np.fft.irfft(spec, m)[:n]


def _gm_found(model, T):
    return [g for g in model.gm_terms
            if g.status == "identified" and abs(math.log(g.tau / T)) < math.log(4.0)]


def _twin_check(make, fs, n, stated, configured, gm_times, seeds):
    """Per seed: the selected model and its stated twin. Returns (misses, phantoms): a miss is a
    configured term the twin finds and the selection does not; a phantom a record whose
    selection identifies a term not configured (or a Gauss-Markov term matched to none)."""
    misses, phantoms = [], 0
    for s in seeds:
        y = make(np.random.default_rng(4100 + s), n)
        sel = allan_analysis(y, fs, record_length=False)[1]
        twin = allan_analysis(y, fs, model=stated, record_length=False)[1]
        for k in configured:
            t = twin.term(k)
            if t.status == "identified" and t.low > 0 and sel.term(k).status != "identified":
                misses.append((s, k, sel.spec()))
        for T in gm_times:
            tw = [g for g in twin.gm_terms if g.status == "identified" and g.low > 0
                  and abs(math.log(g.tau / T)) < math.log(4.0)]
            if tw and not _gm_found(sel, T):
                misses.append((s, f"GM({T:g} s)", sel.spec()))
        extra = [t for t in sel.identified if t.term != "GM" and t.term not in configured]
        n_gm = sum(1 for g in sel.gm_terms if g.status == "identified")
        phantoms += int(bool(extra) or n_gm > len(gm_times))
    return misses, phantoms


@pytest.mark.slow
@pytest.mark.xfail(reason="issue 41's goal not met: with the flicker-or-GM bar at WVIC's -2, "
                   "2 of these 6 records read as N + B (bench: see docs, noise "
                   "identification); with +1 the GM came back in 18 of 20 but flicker records "
                   "read as GM in 15 of 20", strict=False)
def test_one_gauss_markov_term_is_selected_where_its_twin_finds_it():
    """White + GM(0.05 deg/h, 500 s) over 8 h at 10 Hz, the issue's first record (the old
    selection found the term in 3 of 20 and put flicker in its place): at most one miss in 6."""
    fs, n = 10.0, int(8 * 3600 * 10)

    def make(rng, n):
        return white(rng, n, fs, 0.01 * DEG_RT_H) + gauss_markov(rng, n, fs, 0.05 * DPH, 500.0)

    misses, phantoms = _twin_check(make, fs, n, "N + GM", ("N",), (500.0,), range(6))
    assert len(misses) <= 1 and phantoms <= 1, (misses, phantoms)


@pytest.mark.slow
@pytest.mark.xfail(reason="issue 41's goal not met: the 2000 s term, which the stated twin "
                   "finds, is selected in none of 4 (a random walk or nothing in its place)",
                   strict=False)
def test_two_gauss_markov_terms_a_decade_apart_are_both_selected():
    """White (0.01 deg/sqrt(h)) + GM(0.1 deg/h, 20 s) + GM(0.05 deg/h, 2000 s) over 12 h at
    10 Hz (the old selection never found the slow one): at most one miss in 4 records."""
    fs, n = 10.0, int(12 * 3600 * 10)

    def make(rng, n):
        return (white(rng, n, fs, 0.01 * DEG_RT_H) + gauss_markov(rng, n, fs, 0.1 * DPH, 20.0)
                + gauss_markov(rng, n, fs, 0.05 * DPH, 2000.0))

    misses, phantoms = _twin_check(make, fs, n, "N + GM + GM", ("N",), (20.0, 2000.0),
                                   range(4))
    assert len(misses) <= 1 and phantoms <= 1, (misses, phantoms)


@pytest.mark.slow
@pytest.mark.xfail(reason="issue 41's goal not met: K (its 68 % interval above 0 in the twin) "
                   "is not significant at the selection's 1 % level in 24 h, and with this "
                   "file's spectral flicker a Gauss-Markov term stands in for it in 2 of 4",
                   strict=False)
def test_flicker_and_random_walk_stay_flicker_and_random_walk():
    """White + flicker + RRW over 24 h at 10 Hz (tactical): flicker over the decades one
    Gauss-Markov hump cannot follow is not swapped for one; no miss, no phantom in 4."""
    fs, n = 10.0, int(24 * 3600 * 10)

    def make(rng, n):
        return (white(rng, n, fs, 0.03 * DEG_RT_H) + flicker(rng, n, fs, 0.1 * DPH)
                + random_walk(rng, n, fs, 0.1 * DPH / 60.0))

    misses, phantoms = _twin_check(make, fs, n, "N + B + K", ("N", "B", "K"), (), range(4))
    assert not misses and phantoms == 0, (misses, phantoms)


def test_mems_random_walk_and_gauss_markov_are_selected():
    """A MEMS-class record at 100 Hz over 2 h: white + RRW + GM(5 deg/h, 100 s): at most one
    miss in 4, no more than one phantom."""
    fs, n = 100.0, int(2 * 3600 * 100)

    def make(rng, n):
        return (white(rng, n, fs, 0.2 * DEG_RT_H) + random_walk(rng, n, fs, 2.0 * DPH / 60.0)
                + gauss_markov(rng, n, fs, 5.0 * DPH, 100.0))

    misses, phantoms = _twin_check(make, fs, n, "N + K + GM", ("N", "K"), (100.0,), range(4))
    assert len(misses) <= 1 and phantoms <= 1, (misses, phantoms)


@pytest.mark.slow
@pytest.mark.xfail(reason="issue 41's goal not met: with a slow Gauss-Markov term in the "
                   "model, the flicker (found by the twin) is not significant in 2 of 4",
                   strict=False)
def test_navigation_flicker_and_a_slow_gauss_markov_term_at_1_hz():
    """A navigation-class FOG at 1 Hz over 72 h: white + flicker + GM(0.005 deg/h, 3000 s): at
    most one miss in 4, no more than one phantom."""
    fs, n = 1.0, 72 * 3600

    def make(rng, n):
        return (white(rng, n, fs, 0.0015 * DEG_RT_H) + flicker(rng, n, fs, 0.003 * DPH)
                + gauss_markov(rng, n, fs, 0.005 * DPH, 3000.0))

    misses, phantoms = _twin_check(make, fs, n, "N + B + GM", ("N", "B"), (3000.0,), range(4))
    assert len(misses) <= 1 and phantoms <= 1, (misses, phantoms)


# --- the API of the terms --------------------------------------------------------------------
def _exact(co, gm, fs=10.0, n=2**20, model=None):
    taus = 2.0 ** np.arange(int(math.log2((n - 1) // 2)) + 1) / fs
    return identify_noise_model(taus, avar_model(taus, co, gm, fs), fs, n, model=model,
                                record_length=False)


def test_term_names_every_term_gauss_markov_included():
    m = _exact({"N": 1e-4}, [(3e-5, 20.0), (2e-5, 2000.0)])
    assert [g.tau for g in m.gm_terms] == sorted(g.tau for g in m.gm_terms)
    assert m.term("GM1") is m.gm_terms[0] and m.term("gm") is m.gm_terms[0]
    assert m.term("GM2").tau > m.term("GM1").tau
    with pytest.raises(KeyError, match="no term 'GM9'.*expected one of Q, N, B, K, R, GM1"):
        m.term("GM9")


def test_a_model_without_gauss_markov_term_bounds_one_at_the_times_the_record_sees():
    """White noise alone (its exact curve): term('GM') is a further term's 95 % upper bound,
    given at each correlation time inside the averaging times, no interval claimed."""
    m = _exact({"N": 1e-4}, [])
    g = m.term("GM")
    assert g.status == "upper bound" and not g.in_model and g.low is None and g.high is None
    times = [T for T, _ in g.bound_by_tau]
    assert len(times) >= 3 and m.taus[0] < min(times) and max(times) < m.taus[-1]
    assert g.bound == max(b for _, b in g.bound_by_tau) > 0
    # a Gauss-Markov term of sigma 3 times its bound at T would raise the curve beyond the
    # white noise's by more than its error: the bound is no larger than that (closed form)
    T, b = g.bound_by_tau[len(g.bound_by_tau) // 2]
    bump = avar_model(m.taus, {}, [(b, T)], m.fs) / avar_model(m.taus, {"N": 1e-4}, [], m.fs)
    assert bump.max() < 1.0


def test_upper_bound_has_one_meaning_and_a_zero_is_not_identified():
    """A stated model whose K is fitted as exactly zero (the curve is white noise alone): K is
    an upper bound, not 'identified'; every 'upper bound' term has a bound and no interval."""
    m = _exact({"N": 1e-4}, [], model="N + K")
    k = m.term("K")
    assert k.status in ("upper bound", "not identified"), k
    assert m.term("N").status == "identified"
    for t in m.terms:
        if t.status == "upper bound":
            assert t.bound is not None and t.low is None and t.high is None, t


def test_datasheet_is_versioned_and_names_every_term():
    m = _exact({"N": 1e-4}, [(3e-5, 50.0)])
    ds = m.to_datasheet()
    assert ds["format"] == "fogcomp.noise datasheet" and ds["version"] == DATASHEET_VERSION == 2
    names = [t["name"] for t in ds["terms"]]
    assert names[:5] == ["Q", "N", "B", "K", "R"] and "GM1" in names
    assert all(t["status"] in ("identified", "upper bound", "not identified")
               for t in ds["terms"])
