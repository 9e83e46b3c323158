"""The terms of an identified noise model as a caller reads them (issue 41): one name per term
(``NoiseModel.term``), one meaning of "upper bound", a further Gauss-Markov term's bound at the
correlation times the record can see, the versioned datasheet and the filter parameters of
every Gauss-Markov term.

Checked against what does not come from the identifier: exact Allan variance curves of stated
sums of processes (``avar_model``: the data then equal their expectation, so a stated model
recovers its terms to rounding), records simulated here with independent numpy generators, and
the bound's exact twin (the score inversion with the exact covariance at each value)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.signal import lfilter

from fogcomp.allan import allan_analysis
from fogcomp.noise import (DATASHEET_VERSION, avar_gm, avar_model, check_datasheet,
                           identify_noise_model)
from fogcomp.noise import _identify, _intervals
from fogcomp.noise._fit import _fisher_inverse, _jacobian, _Problem, _Spec

FS = 10.0


def white(rng, n, arw):
    return arw * math.sqrt(FS) * rng.standard_normal(n)


def gauss_markov(rng, n, sigma, T):
    phi = math.exp(-1.0 / (FS * T))
    e = sigma * math.sqrt(1 - phi * phi) * rng.standard_normal(n)
    e[0] = sigma * rng.standard_normal()
    return lfilter([1.0], [1.0, -phi], e)


def exact_curve(co: dict, gm, n: int = 2**20, fs: float = FS):
    """(taus, avar, fs, n) of the octave averaging times of an n-sample record whose Allan
    variance is exactly the model's."""
    taus = 2.0 ** np.arange(int(math.log2((n - 1) // 2)) + 1) / fs
    return taus, avar_model(taus, co, gm, fs), fs, n


N_ARW = 0.01
GM_A, GM_B = (0.02, 5.0), (0.01, 500.0)


@pytest.fixture(scope="module")
def two_gm():
    """The stated model N + GM + GM fitted to the exact curve of N + GM(5 s) + GM(500 s)."""
    return identify_noise_model(*exact_curve({"N": N_ARW}, [GM_A, GM_B]), model="N + GM + GM",
                                record_length=False)


# --- one name per term -----------------------------------------------------------------------
def test_each_gauss_markov_term_by_its_name(two_gm):
    m = two_gm
    for key, (sigma, T) in (("GM1", GM_A), ("GM2", GM_B)):
        t = m.term(key)
        assert t.term == "GM" and t.key == key and t.status == "identified" and t.in_model
        assert t.value == pytest.approx(sigma, rel=1e-3) and t.tau == pytest.approx(T, rel=1e-3)
    assert m.term("gm2") is m.term("GM2") and m.term(" n ") is m.term("N")
    assert m.gm_terms == [m.term("GM1"), m.term("GM2")]
    assert m.term("N").value == pytest.approx(N_ARW, rel=1e-3)
    # every term has one key, and term() finds it by it
    keys = [t.key for t in m.terms]
    assert len(set(keys)) == len(keys) and all(m.term(k) is t for k, t in zip(keys, m.terms))


def test_gm_alone_is_ambiguous_with_two_and_an_unknown_name_lists_the_names(two_gm):
    with pytest.raises(KeyError, match="ambiguous.*GM1.*GM2"):
        two_gm.term("GM")
    with pytest.raises(KeyError, match=r"no term 'Z'.*Q, N, B, K, R, GM1, GM2"):
        two_gm.term("Z")


def test_gm_names_the_only_gauss_markov_term_or_the_further_ones_bound():
    one = identify_noise_model(*exact_curve({"N": N_ARW}, [GM_B]), model="N + GM",
                               record_length=False)
    assert one.term("GM") is one.term("GM1") and one.term("GM").in_model
    assert one.term("GM").tau == pytest.approx(GM_B[1], rel=1e-3)
    further = one.term("GM2")             # max_gm 3 > 1: a further term's bound
    assert not further.in_model and further.status == "upper bound" and further.value is None
    none = identify_noise_model(*exact_curve({"N": N_ARW}, []), model="N",
                                record_length=False)
    assert none.gm_terms == [] and none.term("GM") is none.term("GM1")
    assert not none.term("GM").in_model
    # max_gm = 0: no Gauss-Markov candidate, none reported
    zero = identify_noise_model(*exact_curve({"N": N_ARW}, []), model="N", max_gm=0,
                                record_length=False)
    with pytest.raises(KeyError, match="no term 'GM'"):
        zero.term("GM")


def test_a_stated_model_on_a_record_recovers_two_gauss_markov_terms_by_name():
    """N + GM(2 s) + GM(200 s), 2^19 samples at 10 Hz (14.6 h, 260 times the slow term):
    the stated model "N + GM + GM" gives each term by name, sigma within 30 % and the
    correlation time within 40 % (the issue's measured bias of correlation times is 11-22 %)."""
    arw, (s1, t1), (s2, t2) = 0.02, (0.05, 2.0), (0.02, 200.0)
    n = 2**19
    rng = np.random.default_rng(41)
    y = white(rng, n, arw) + gauss_markov(rng, n, s1, t1) + gauss_markov(rng, n, s2, t2)
    _, m = allan_analysis(y, FS, model="N + GM + GM", record_length=False)
    for key, sigma, T in (("GM1", s1, t1), ("GM2", s2, t2)):
        t = m.term(key)
        assert t.status == "identified", t
        assert abs(t.value / sigma - 1) < 0.30 and abs(t.tau / T - 1) < 0.40, (key, t)
    assert abs(m.term("N").value / arw - 1) < 0.05


# --- one meaning of "upper bound" -----------------------------------------------------------
def _law(m):
    """The statuses' one meaning, for every term of a model."""
    for t in m.terms:
        if t.status == "identified":
            assert t.in_model and t.value > 0 and t.low <= t.value, t
            assert t.high is None or t.value <= t.high, t
        else:
            assert t.low is None and t.high is None and t.sigma is None, t
            assert (t.bound is not None) == (t.status == "upper bound"), t


def test_a_stated_term_fitted_as_exactly_zero_is_an_upper_bound():
    """The exact curve of N + K stated as N + B + K: B is fitted as exactly zero (the data are
    the model's), so it is not 'identified', and its bound is above 0."""
    m = identify_noise_model(*exact_curve({"N": N_ARW, "K": 1e-5}, [], n=2**18),
                             model="N + B + K", record_length=False)
    b = m.term("B")
    assert b.in_model and b.value == 0.0 and b.status == "upper bound" and b.bound > 0
    assert "B" not in m.spec()
    _law(m)


def test_a_weak_term_kept_in_the_model_reports_a_bound_not_an_interval():
    """The exact curve of N + K + a flicker small enough not to be significant: the selection
    keeps B in the model (every FOG has all processes) but reports it as a term the record
    does not show, by its bound: no interval that excludes 0. The curve holds B exactly, so
    the fitted value is B and the 95 % bound lies above it."""
    seen = 0
    for b_true in np.geomspace(1e-5, 3e-4, 8):
        m = identify_noise_model(*exact_curve({"N": N_ARW, "K": 1e-5, "B": b_true}, [],
                                              n=2**18), record_length=False)
        _law(m)
        b = m.term("B")
        if b.in_model and b.status != "identified":
            seen += 1
            assert b.status == "upper bound" and b.value == pytest.approx(b_true, rel=1e-3)
            assert b.bound > b.value
    assert seen >= 1


def test_the_law_holds_on_records_of_white_noise_and_a_weak_gauss_markov_term(weak_models):
    """Every term of the 20 models obeys the statuses' one meaning (``_law``), and both
    meanings occur: identified terms and upper bounds (the further Gauss-Markov term's)."""
    assert len(weak_models) == 20
    statuses = set()
    for m in weak_models:
        _law(m)
        statuses |= {t.status for t in m.terms}
    assert {"identified", "upper bound"} <= statuses, statuses


# --- a further Gauss-Markov term's bound -----------------------------------------------------
WEAK = (0.002, 25.6)          # sigma rad/s, T s: under the white noise's curve at every tau
ARW = 0.02


def _weak_gm_models(seeds=range(20)):
    n = 2**16
    for s in seeds:
        rng = np.random.default_rng(4100 + s)
        y = white(rng, n, ARW) + gauss_markov(rng, n, *WEAK)
        yield allan_analysis(y, FS, record_length=False)[1]


def test_the_bound_grid_spans_a_few_samples_to_a_tenth_of_the_record():
    m = identify_noise_model(*exact_curve({"N": N_ARW}, [], n=2**16), record_length=False)
    ts = [T for T, _ in m.term("GM").bound_by_tau]
    assert ts[0] == pytest.approx(4 / FS) and ts[-1] <= 2**16 / FS / 10 < 2 * ts[-1]
    np.testing.assert_allclose(np.diff(np.log2(ts)), 1.0)


@pytest.fixture(scope="module")
def weak_models():
    return list(_weak_gm_models())


def test_a_weak_gauss_markov_term_not_selected_is_below_its_bound(weak_models):
    """White noise + a Gauss-Markov term of 25.6 s (a correlation time on the grid) whose
    Allan variance stays under a tenth of the white noise's: where it is not selected, the
    further term's 95 % bound at 25.6 s holds the configured sigma in at least 85 % of the
    records, and the term at its bound stays under the measured curve (a bound the data
    hold, not a vacuous one)."""
    sigma, T = WEAK
    held, n_out = 0, 0
    for m in weak_models:
        if any(abs(math.log(g.tau / T)) < 1 for g in m.gm_terms):
            continue
        n_out += 1
        t = next(t for t in m.terms if t.term == "GM" and not t.in_model)
        b = next(b for Tg, b in t.bound_by_tau if Tg == pytest.approx(T))
        assert b is not None
        held += b >= sigma
        at = np.argmin(abs(m.taus - T))
        assert b**2 * avar_gm(m.taus[at:at + 1], T, FS)[0] < m.avar[at]
    assert n_out >= 15 and held >= 0.85 * n_out, (held, n_out)


def test_the_bound_matches_its_exact_twin():
    """The bound's sigma(c) holds the relative covariance of the estimates at the fit's; its
    twin computes the exact covariance at each value (the IEEE terms' way): within 5 % where
    the term at its bound stays under the measured curve."""
    rng = np.random.default_rng(7)
    n = 2**16
    y = white(rng, n, ARW) + gauss_markov(rng, n, *WEAK)
    curve, _ = allan_analysis(y, FS, record_length=False)
    t, v, m, segs, fs = _identify._checked_curve(curve.taus, curve.adev**2, FS, n)
    pb = _Problem(t, v, m, segs, fs, 0.001)
    _, fit, _, _ = _identify._fit_and_select(pb, None, 0.01, 3, 0.001)
    r = _identify._Report.of(pb, fit, 1.0, 0.6827, False, 0.01, False)
    term = _identify._gm_bound_term(r)
    n_lin, checked = len(fit.spec.linear), 0
    for T, b in term.bound_by_tau[::3]:
        if b is None:
            continue
        spec = _Spec(fit.spec.linear, tuple(sorted(fit.spec.gm + (T,))))
        forced = pb.solve(spec)
        g = spec.gm.index(T)
        k = n_lin + g

        def exact(c):
            hyp = _intervals._fit_with(forced, k, c)
            W = pb.weights(*hyp.coefficients())
            D = np.delete(_jacobian(pb, hyp), n_lin + len(spec.gm) + g, axis=1)
            return math.sqrt(max(_fisher_inverse(W @ D)[k, k] * r.scale, 0.0))

        _, c_b = _intervals._score_interval(pb, forced, k, r.z95, r.scale, lower=False,
                                            sig=exact)
        unit = avar_gm(pb.taus, T, fs)
        if np.max(b * b * unit / pb.avar) <= 1.0:
            assert b == pytest.approx(math.sqrt(c_b), rel=0.05), T
            checked += 1
    assert checked >= 2


# --- the datasheet -----------------------------------------------------------------------------
def test_the_datasheet_is_versioned_and_its_old_keys_fail_loudly(two_gm):
    ds = two_gm.to_datasheet()
    assert ds["version"] == DATASHEET_VERSION == 2 and ds["format"] == "fogcomp.noise datasheet"
    assert [t["key"] for t in ds["terms"]] == [t.key for t in two_gm.terms]
    gm2 = next(t for t in ds["terms"] if t["key"] == "GM2")
    assert gm2["gm_tau_s"] == pytest.approx(GM_B[1], rel=1e-3)
    # version 0's keys: a KeyError that names the new shape, by [] and by get (not None)
    for read in (lambda: ds["angle_random_walk"], lambda: ds.get("angle_random_walk", {})):
        with pytest.raises(KeyError, match="version 0"):
            read()
    assert ds.get("no such key") is None
    back = json.loads(json.dumps(ds))
    assert check_datasheet(back) == back
    v1 = {k: v for k, v in back.items() if k not in ("format", "version")}
    with pytest.raises(ValueError, match="version 1"):
        check_datasheet(v1)
    with pytest.raises(ValueError, match="version 3"):
        check_datasheet({**back, "version": 3})


def test_a_bound_only_term_has_no_interval_in_the_datasheet():
    m = identify_noise_model(*exact_curve({"N": N_ARW, "K": 1e-5}, [], n=2**18),
                             model="N + B + K", record_length=False)
    b = next(t for t in m.to_datasheet()["terms"] if t["key"] == "B")
    assert b["status"] == "upper bound" and b["bias_instability_dph_bound95"] > 0
    assert b["bias_instability_dph_low"] is None and b["bias_instability_dph_high"] is None
    gm = next(t for t in m.to_datasheet()["terms"] if t["term"] == "GM")
    assert gm["gm_sigma_dph_bound95_by_tau"] and not gm["in_model"]


# --- the filter takes every Gauss-Markov term --------------------------------------------------
def test_filter_parameters_hold_every_gauss_markov_term(two_gm):
    gms = [p for p in two_gm.filter_parameters() if p["term"] == "GM"]
    assert [p["continuous"]["tau_s"] for p in gms] == pytest.approx([GM_A[1], GM_B[1]],
                                                                     rel=1e-3)
    for p, (sigma, T) in zip(gms, (GM_A, GM_B)):
        assert p["continuous"]["sigma_rad_s"] == pytest.approx(sigma, rel=1e-3)
        assert p["discrete"]["phi"] == pytest.approx(math.exp(-1 / (FS * T)), rel=1e-5)
