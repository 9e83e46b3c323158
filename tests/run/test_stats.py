"""fogbench.run.stats against analytic results, scipy's own tests and slow obvious loops."""

import itertools
import math
import statistics

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats as sst

from fogbench.run.stats import (claim_verdict, mean_ci, ordering_probabilities, ordering_probability,
                            paired_difference, summarize)


# -- summary -------------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [2, 3, 10])
def test_the_t_interval_covers_the_true_mean_95_percent_of_the_time(n):
    # Exact for normal data at every n: with the normal quantile 1.96 instead of t, n = 2 would
    # cover only about 70 % and n = 3 about 83 %.
    trials, mu, hits = 3000, 3.0, 0
    for k in range(trials):
        x = np.random.default_rng([k, n]).normal(mu, 2.0, n)
        s = summarize(x)
        hits += s.ci_low <= mu <= s.ci_high
    # binomial standard error sqrt(.95 * .05 / 3000) = 0.004: +-0.015 is 3.8 of them
    assert abs(hits / trials - 0.95) < 0.015


def test_the_interval_matches_scipys_one_sample_t_test():
    rng = np.random.default_rng(1)
    for n in (2, 5, 30):
        x = rng.lognormal(0, 1, n)
        for level in (0.9, 0.95, 0.99):
            ref = sst.ttest_1samp(x, 0.0).confidence_interval(level)
            assert mean_ci(x, level) == pytest.approx((ref.low, ref.high), rel=1e-12)


@pytest.mark.parametrize("method", ["bca", "percentile"])
def test_bootstrap_and_t_interval_agree_for_large_normal_samples(method):
    x = np.random.default_rng(7).normal(10.0, 1.0, 600)
    t_lo, t_hi = mean_ci(x)
    b_lo, b_hi = mean_ci(x, method=method, seed=3)
    half = (t_hi - t_lo) / 2
    assert abs(b_lo - t_lo) < 0.08 * half and abs(b_hi - t_hi) < 0.08 * half
    # seeded: the same seed gives the same interval
    assert mean_ci(x[:50], method=method, seed=3) == mean_ci(x[:50], method=method, seed=3)


def test_summary_statistics_and_failures_are_counted_never_dropped():
    x = [1.0, np.nan, 4.0, 2.0, np.inf, 7.0]
    s = summarize(x)
    good = [1.0, 4.0, 2.0, 7.0]
    assert (s.n, s.n_failed) == (4, 2)
    assert s.failure_rate == pytest.approx(2 / 6)
    assert s.mean == pytest.approx(statistics.fmean(good))
    assert s.median == pytest.approx(statistics.median(good))
    assert s.std == pytest.approx(statistics.stdev(good))
    assert "2 of 6 replicates failed" in s.note
    d = s.as_dict()
    assert d["n_failed"] == 2 and d["ci_method"] == "t"


def test_one_two_equal_and_no_values():
    one = summarize([5.0])
    assert one.mean == 5.0 and one.median == 5.0
    assert math.isnan(one.std) and math.isnan(one.ci_low) and math.isnan(one.ci_high)
    assert "one replicate" in one.note
    assert one.as_dict()["ci_low"] is None
    two = summarize([1.0, 3.0])
    # t_{0.975, 1} = 12.706: half-width 12.706 * sqrt(2) / sqrt(2)
    assert two.ci == pytest.approx((2 - 12.7062047, 2 + 12.7062047), rel=1e-6)
    same = summarize([0.25] * 7)
    assert same.ci == (0.25, 0.25) and same.std == 0.0 and "zero-width" in same.note
    assert mean_ci([0.25] * 7, method="bca") == (0.25, 0.25)
    none = summarize([np.nan, np.nan])
    assert none.n == 0 and none.n_failed == 2 and none.failure_rate == 1.0
    assert math.isnan(none.mean) and "no replicate" in none.note


@pytest.mark.parametrize("kwargs, match", [
    (dict(values=[[1.0, 2.0]]), "1-D"),
    (dict(values=[True, False]), "dtype bool"),
    (dict(values=[1.0, 2.0], level=95), "level"),
    (dict(values=[1.0, 2.0], method="bootstrap"), "method"),
])
def test_bad_input_is_refused_with_its_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        summarize(**kwargs)
    with pytest.raises(ValueError, match="at least 3"):
        mean_ci([1.0, 2.0], method="bca")


# -- paired difference ---------------------------------------------------------------------------
def slow_paired(a, b, better):
    wins = ties = losses = 0
    diffs = []
    for x, y in zip(a, b):
        okx, oky = math.isfinite(x), math.isfinite(y)
        if okx and oky:
            diffs.append(x - y)
            if x == y:
                ties += 1
            elif (x < y) == (better == "lower"):
                wins += 1
            else:
                losses += 1
        elif okx:
            wins += 1
        elif oky:
            losses += 1
        else:
            ties += 1
    return diffs, wins, ties, losses


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 40),
       better=st.sampled_from(["lower", "higher"]))
def test_paired_difference_matches_a_slow_loop_and_scipys_paired_t_test(seed, n, better):
    rng = np.random.default_rng(seed)
    a = np.round(rng.normal(1.0, 0.5, n), 1)     # rounding makes ties
    b = np.round(a + rng.normal(0.1, 0.3, n), 1)
    a[rng.random(n) < 0.15] = np.nan
    b[rng.random(n) < 0.15] = np.nan
    p = paired_difference(a, b, better=better)
    diffs, wins, ties, losses = slow_paired(a.tolist(), b.tolist(), better)
    assert (p.first_better, p.tied, p.second_better) == pytest.approx(
        (wins / n, ties / n, losses / n))
    assert p.diff.n == len(diffs) and p.diff.n_failed == n - len(diffs)
    assert (p.first_failed, p.second_failed) == (int(np.isnan(a).sum()), int(np.isnan(b).sum()))
    if len(diffs) >= 1:
        assert p.diff.mean == pytest.approx(statistics.fmean(diffs), abs=1e-12)
    both = np.isfinite(a) & np.isfinite(b)
    if len(diffs) >= 2 and len(set(diffs)) > 1:
        ref = sst.ttest_rel(a[both], b[both]).confidence_interval(0.95)
        assert p.diff.ci == pytest.approx((ref.low, ref.high), rel=1e-9, abs=1e-12)


def test_paired_difference_refuses_unpaired_lengths():
    with pytest.raises(ValueError, match="equal lengths"):
        paired_difference([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="better"):
        paired_difference([1.0, 2.0], [1.0, 3.0], better="smaller")


# -- claim verdicts ------------------------------------------------------------------------------
def around(c, n=200, spread=0.01, seed=0):
    """Values whose interval of the mean is c +- about 0.0014."""
    return c + spread * np.random.default_rng(seed).standard_normal(n)


@pytest.mark.parametrize("lo, hi, expected", [
    (40, 60, "agrees"),
    (None, 60, "agrees"),
    (40, None, "agrees"),
    (49.9, 50.1, "agrees"),
    (60, 70, "disagrees"),
    (10, 40, "disagrees"),
    (None, 49, "disagrees"),
    (51, None, "disagrees"),
    (50, 60, "inconclusive"),       # a bound inside the interval
    (None, 50, "inconclusive"),
    (50, 50, "inconclusive"),
])
def test_verdict_truth_table(lo, hi, expected):
    v = claim_verdict(around(50.0), lo, hi)
    assert v.verdict == expected, v.reason
    x = around(50.0)
    held = sum((lo is None or xi >= lo) and (hi is None or xi <= hi) for xi in x) / len(x)
    assert v.held == pytest.approx(held)


def test_verdict_bounds_are_inclusive_on_a_zero_width_interval():
    x = [50.0] * 5
    assert claim_verdict(x, 50, 60).verdict == "agrees"
    assert claim_verdict(x, 50.000001, 60).verdict == "disagrees"
    assert claim_verdict(x, None, 50).verdict == "agrees"


@pytest.mark.parametrize("oracle_c, better, lo, hi, expected", [
    (45.0, "higher", 48, 60, "untestable"),     # oracle interval entirely below the claim
    (48.0, "higher", 48, 60, "agrees"),         # oracle interval straddles lo: testable
    (55.0, "higher", 48, 60, "agrees"),
    (45.0, "higher", None, 60, "agrees"),       # no lower bound: nothing asked of the oracle
    (55.0, "lower", 40, 52, "untestable"),      # error metric: oracle entirely above hi
    (55.0, "lower", 40, None, "agrees"),
])
def test_untestable_when_the_claim_asks_more_than_the_oracle(oracle_c, better, lo, hi, expected):
    v = claim_verdict(around(50.0), lo, hi, oracle=around(oracle_c, seed=1), better=better)
    assert v.verdict == expected, v.reason
    assert v.oracle is not None and v.oracle.mean == pytest.approx(oracle_c, abs=0.01)
    if expected == "untestable":
        assert "oracle" in v.reason


def test_untestable_needs_an_oracle_interval():
    # one oracle replicate has no interval: the claim is judged on the method's interval
    v = claim_verdict([50.0, 50.5, 49.5], 48, 60, oracle=[45.0, np.nan, np.nan])
    assert v.verdict != "untestable"


def test_failed_replicates_count_as_not_held_and_one_value_is_inconclusive():
    v = claim_verdict([55.0, np.nan, 52.0, np.nan], 50, 60)
    assert v.held == 0.5 and v.summary.n_failed == 2
    one = claim_verdict([55.0], 50, 60)
    assert one.verdict == "inconclusive" and one.held == 1.0 and "no interval" in one.reason
    assert one.as_dict()["summary"]["ci_low"] is None


@pytest.mark.parametrize("lo, hi, match", [
    (None, None, "at least one"),
    (60, 50, "above hi"),
    (True, 50, "lo"),
    (float("nan"), 50, "lo"),
])
def test_bad_claims_are_refused(lo, hi, match):
    with pytest.raises(ValueError, match=match):
        claim_verdict([1.0, 2.0], lo, hi)


# -- orderings -----------------------------------------------------------------------------------
def slow_orderings(values, better):
    names = list(values)
    R = len(next(iter(values.values())))
    seen = {}
    for r in range(R):
        row = {k: values[k][r] for k in names}
        ok = {k: v for k, v in row.items() if math.isfinite(v)}
        distinct = sorted(set(ok.values()), reverse=(better == "higher"))
        groups = [tuple(sorted(k for k in ok if ok[k] == d)) for d in distinct]
        failed = tuple(sorted(k for k in names if k not in ok))
        if failed:
            groups.append(failed)
        label = " < ".join(" = ".join(g) for g in groups)
        seen[label] = seen.get(label, 0) + 1
    return {k: c / R for k, c in seen.items()}


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 4), R=st.integers(1, 30),
       better=st.sampled_from(["lower", "higher"]))
def test_ordering_probabilities_match_a_slow_loop(seed, k, R, better):
    rng = np.random.default_rng(seed)
    values = {f"m{i}": rng.integers(0, 4, R).astype(float) for i in range(k)}   # many ties
    for v in values.values():
        v[rng.random(R) < 0.1] = np.nan
    got = ordering_probabilities(values, better=better)
    assert {o.label: o.probability for o in got} == pytest.approx(slow_orderings(values, better))
    assert sum(o.count for o in got) == R
    assert [o.count for o in got] == sorted((o.count for o in got), reverse=True)
    # the strict orders' probabilities add up to the share of replicates with no tie or failure
    M = np.column_stack(list(values.values()))
    clean = np.mean([np.all(np.isfinite(row)) and len(set(row)) == k for row in M])
    total = sum(ordering_probability(values, list(p), better=better)
                for p in itertools.permutations(values))
    assert total == pytest.approx(clean)


def test_ordering_of_a_known_example():
    values = {"bp": [3.0, 1.0, 2.0, 2.0], "aco_bp": [1.0, 2.0, 1.0, np.nan],
              "poly": [2.0, 3.0, 2.0, 1.0]}
    got = {o.label: o.probability for o in ordering_probabilities(values)}
    assert got == {"aco_bp < poly < bp": 0.25, "bp < aco_bp < poly": 0.25,
                   "aco_bp < bp = poly": 0.25, "poly < bp < aco_bp": 0.25}
    assert ordering_probability(values, ["aco_bp", "poly", "bp"]) == 0.25
    with pytest.raises(ValueError, match="distinct names"):
        ordering_probability(values, ["aco_bp", "nope"])
    with pytest.raises(ValueError, match="one value per replicate"):
        ordering_probabilities({"a": [1.0], "b": [1.0, 2.0]})
