"""The one-line takeaway at the top of a report, and the side of a "disagrees" in it."""

from fogbench.report.claims import open_on_answer, takeaway


def _c(verdict, mean, lo=70.0, hi=90.0):
    return {"verdict": verdict, "min_pct": lo, "max_pct": hi, "summary": {"mean": mean},
            "better": "wnn", "than": "raw", "metric": "std_dps", "protocol": "held_out",
            "source": "paper 000", "text": "a claim"}


def test_the_takeaway_counts_verdicts_and_says_which_side_a_disagreement_is_on():
    mc = {"replicates": 20, "claims": [_c("agrees", 80.0), _c("disagrees", 93.6),
                                       _c("disagrees", 40.0), _c("inconclusive", 71.0),
                                       _c("disagrees", 10.0)]}
    line = takeaway(mc)
    assert line.startswith("**In short:** 5 claim verdict(s) over 20 replicates: 1 agree, "
                           "2 disagree (falls short of the claim), 1 disagree (exceeds the "
                           "claim), 1 inconclusive")
    text = open_on_answer("# name\n\ndescription\n\nmore", "## Over 20 replicates", mc, {})
    assert text.splitlines()[2] == line
    assert text.splitlines()[0] == "# name"      # the title, then the answer, then the rest
    assert takeaway({"claims": []}) is None


def _s(mean, lo, hi):
    return {"n": 20, "n_failed": 0, "mean": mean, "ci_low": lo, "ci_high": hi}


def test_without_claims_the_takeaway_places_each_method_by_its_interval_against_raw():
    from types import SimpleNamespace

    from fogbench.report.claims import metric_takeaway

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
    from fogbench.report.claims import open_on_answer
    out = open_on_answer("# name\n\nset-up", "## Over 20 replicates", mc, {}, plan)
    assert out.splitlines()[2].startswith("**In short**")
    # no key metric with an improvement: no takeaway
    assert metric_takeaway({"over_runs": {"p": {"raw": {"gm_tau_s": _s(1, 0, 2)}}}},
                           plan) is None


def test_a_key_metric_every_method_leaves_unchanged_is_followed_by_the_rmse():
    """lab_references' bias_lab opened on "unchanged" for every method: its key metric, the
    100 s bias stability, cannot see the constant a bias fit removes. The RMSE's improvement
    follows it (what `fogbench compare` ranks on); a protocol whose key metric tells the
    methods apart gets no second line."""
    from types import SimpleNamespace

    from fogbench.report.claims import metric_takeaway

    def labs(stab, rmse):
        out = {"raw": {"bias_stability_100s_dph": _s(1.0, 0.9, 1.1), "rmse_dph": _s(4.4, 4, 5)}}
        for lab in ("bias_lstsq", "model_lstsq"):
            out[lab] = {"bias_stability_100s_dph": _s(1.0, 0.9, 1.1),
                        "improvement_bias_stability_pct": _s(*stab),
                        "rmse_dph": _s(3.8, 3.5, 4.1), "improvement_rmse_pct": _s(*rmse)}
        return out

    plan = SimpleNamespace(claims=[], protocols=[SimpleNamespace(name="b", twin_of=None),
                                                 SimpleNamespace(name="c", twin_of=None)])
    mc = {"replicates": 20, "over_runs": {"b": labs((0.0, 0.0, 0.0), (14.0, 12.1, 16.0)),
                                          "c": labs((30.0, 25.0, 35.0), (14.0, 12.1, 16.0))}}
    lines = [x for x in metric_takeaway(mc, plan).splitlines() if x.startswith("- ")]
    assert [x.split(":")[0] for x in lines] == [
        "- `b`, bias_stability_100s_dph", "- `b`, rmse_dph", "- `c`, bias_stability_100s_dph"]
    assert lines[0].startswith("- `b`, bias_stability_100s_dph: unchanged (within 0.05 %)")
    assert lines[1].startswith("- `b`, rmse_dph: better: bias_lstsq 14.0 [12.1, 16.0]")
