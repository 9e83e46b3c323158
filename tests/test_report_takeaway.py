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
