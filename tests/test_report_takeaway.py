"""The one-line takeaway at the top of a report, and the side of a "disagrees" in it."""

from fogbench.report import _with_takeaway, takeaway


def _c(verdict, mean, lo=70.0, hi=90.0):
    return {"verdict": verdict, "min_pct": lo, "max_pct": hi, "summary": {"mean": mean}}


def test_the_takeaway_counts_verdicts_and_says_which_side_a_disagreement_is_on():
    mc = {"replicates": 20, "claims": [_c("agrees", 80.0), _c("disagrees", 93.6),
                                       _c("disagrees", 40.0), _c("inconclusive", 71.0),
                                       _c("disagrees", 10.0)]}
    line = takeaway(mc)
    assert line.startswith("**In short:** 5 claim verdict(s) over 20 replicates: 1 agree, "
                           "2 disagree (falls short of the claim), 1 disagree (exceeds the "
                           "claim), 1 inconclusive")
    text = _with_takeaway("# name\n\ndescription\n\nmore", mc)
    assert text.splitlines()[2] == line
    assert takeaway({"claims": []}) is None


def _s(mean, lo, hi):
    return {"n": 20, "n_failed": 0, "mean": mean, "ci_low": lo, "ci_high": hi}


def test_without_claims_the_takeaway_places_each_method_by_its_interval_against_raw():
    from types import SimpleNamespace

    from fogbench.claim_figures import metric_takeaway

    def prot(**labs):
        out = {"raw": {"rmse_dph": _s(600.0, 570.0, 630.0)}}
        for lab, (m, lo, hi) in labs.items():
            out[lab] = {"rmse_dph": _s(600.0, 570.0, 630.0),
                        "improvement_rmse_pct": _s(m, lo, hi)}
        return out

    mc = {"replicates": 20, "claims": [],
          "over_runs": {"held_out": prot(wnn=(0.8, 0.5, 1.2), kalman=(-375.0, -427.0, -324.0),
                                         wavelet=(0.3, -0.2, 0.8), bias=(1e-9, 1e-10, 2e-9),
                                         oracle=(1.6, -0.3, 3.5)),
                        "held_out.ideal": prot(wnn=(5.0, 4.0, 6.0))}}
    plan = SimpleNamespace(claims=[], protocols=[
        SimpleNamespace(name="held_out", twin_of=None),
        SimpleNamespace(name="held_out.ideal", twin_of="held_out")])
    text = metric_takeaway(mc, plan)
    (line,) = [x for x in text.splitlines() if x.startswith("- ")]   # the twin is left out
    assert line.startswith("- `held_out`, rmse_dph: ")
    assert "better: wnn 0.8 [0.5, 1.2];" in line
    assert "not told apart from raw: wavelet 0.3 [-0.2, 0.8];" in line
    assert "worse: kalman -375.0 [-427.0, -324.0];" in line
    assert "unchanged (within 0.05 %): bias" in line
    assert line.endswith("(oracle: oracle 1.6 [-0.3, 3.5])")
    assert "over 20 replicates" in text
    # the report opens on it
    from fogbench.claim_figures import open_on_answer
    out = open_on_answer("# name\n\nset-up", "## Over 20 replicates", mc, {}, plan)
    assert out.splitlines()[2].startswith("**In short**")
    # no key metric with an improvement: no takeaway
    assert metric_takeaway({"over_runs": {"p": {"raw": {"gm_tau_s": _s(1, 0, 2)}}}},
                           plan) is None
