"""One figure per claim, and a report that opens on its verdicts.

A small scenario with three claims (a two-sided range, one between two methods that draw random
starts, one on a single run) is run through ``fogbench run``. Checked against what the run
directory itself holds, never against the figure code's own output:

- every claim has its figure, and each verdict line of the report links to it (the verdict
  word and the methods in the line are the ones ``metrics.json`` gives that claim);
- the numbers each figure draws (the interval ends of the improvement and of the paired
  differences, the claimed range, the replicates' points) are the ones in ``metrics.json``'s
  Monte Carlo section;
- those numbers in ``metrics.json`` are recomputed here by hand from the replicate files
  (``replicates/r*.json``: per replicate the mean over the claim's runs, over method seeds,
  ``100 (1 - method / comparator)``, a Student t-interval from scipy), so a figure that drew
  the wrong quantity, or an aggregate that stored it wrongly, fails.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from matplotlib.colors import to_hex
from scipy import stats as sps

from helpers import run_cli
from fogbench.outputs import files
from fogbench.report import claims as CF

SCENARIO = """
[scenario]
name = "claims_tiny"
sample_rate_hz = 10.0

[fog]
preset = "tactical"
switch_on_bias_dph = 5.0
temp_coeff_dph_per_c = 0.5

[thermal]
start_c = 10.0
[[thermal.steps]]
ramp_to_c = 30.0
rate_c_per_min = 10.0

[[runs]]
name = "a"
seed = 11
[[runs.motion]]
type = "hold"
duration_s = 150.0

[[runs]]
name = "b"
seed = 12
[[runs.motion]]
type = "rate"
rate_dps = 10.0
duration_s = 150.0

[[protocols]]
name = "own_run"
reference = "truth"      # one reading: the figures, not the lab's references, are tested here
fit = [{ run = "*", end_s = 75.0 }]
score = [{ run = "*", start_s = 75.0 }]

[[methods]]
name = "bp"
params = { max_epochs = 60 }

[[methods]]
name = "bp"
label = "bp_short"
params = { max_epochs = 5 }

[[methods]]
name = "poly_temp"

[[claims]]
text = "poly_temp removes 20 to 99 % of the error"
source = "a test"
metric = "rmse_dph"
better = "poly_temp"
than = "raw"
min_pct = 20.0
max_pct = 99.0

[[claims]]
text = "longer training helps"
source = "a test"
metric = "rmse_dph"
better = "bp"
than = "bp_short"
min_pct = 0.0

[[claims]]
text = "poly_temp removes nearly all of the error on run a"
source = "a test"
metric = "rmse_dph"
better = "poly_temp"
than = "raw"
run = "a"
min_pct = 99.99
"""

R, K = 4, 2


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("claims")
    scn = d / "claims_tiny.toml"
    scn.write_text(SCENARIO)
    out = d / "run"
    code, _, err = run_cli("run", scn, "--out", out, "--replicates", R, "--method-seeds", K,
                           "--jobs", 1, "--quiet", "--no-recording")
    assert code == 0, err
    return out


@pytest.fixture(scope="module")
def claims(run_dir):
    return json.loads((run_dir / "metrics.json").read_text())["montecarlo"]["claims"]


@pytest.fixture
def kept(monkeypatch):
    """Figures passed to ``_save``, kept open instead of written."""
    figs = []
    monkeypatch.setattr(files, "save_figure", lambda fig, path: figs.append(fig))
    yield figs
    import matplotlib.pyplot as plt

    for f in figs:
        plt.close(f)


def _by_gid(fig, gid):
    return [a for ax in fig.axes for a in ax.findobj(lambda o: o.get_gid() == gid)]


def _interval_drawn(fig, gid):
    """(low, high) of the error bar with this gid, and its mean (the marker)."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    arts = _by_gid(fig, gid)
    bars = [a for a in arts if isinstance(a, LineCollection)]
    marks = [a for a in arts if isinstance(a, Line2D)]
    assert len(bars) == 1 and len(marks) == 1, gid
    seg = np.asarray(bars[0].get_segments()[0])
    return float(seg[:, 1].min()), float(seg[:, 1].max()), float(marks[0].get_ydata()[0])


def _span_drawn(fig):
    (span,) = _by_gid(fig, "claimed_range")
    if hasattr(span, "get_height"):               # matplotlib >= 3.9: a Rectangle
        return span.get_y(), span.get_y() + span.get_height(), span.axes
    ys = np.asarray(span.get_xy())[:, 1]
    return ys.min(), ys.max(), span.axes


# ---------------------------------------------------------------------------------------------
def test_each_claim_has_a_figure_and_each_verdict_line_links_to_it(run_dir, claims):
    assert len(claims) == 3
    report = (run_dir / "report.md").read_text()
    lines = report.splitlines()
    assert lines[0] == "# claims_tiny" and lines[2].startswith("**In short:** 3 claim")
    # the answer first: verdicts, then the evidence, then the set-up
    order = [report.index(h) for h in ("## Verdicts", "## Over 4 replicates", "### The papers",
                                       "## Set-up", "## Runs (power-ons)", "## Protocol ")]
    assert order == sorted(order)
    verdicts = report[report.index("## Verdicts"):report.index("## Over 4 replicates")]
    vlines = [ln for ln in verdicts.splitlines() if ln.startswith("- ")]
    assert len(vlines) == len(claims)
    for i, (ln, c) in enumerate(zip(vlines, claims)):
        m = re.match(r"- \[\*\*(\w+)\*\*[^\]]*\]\((figures/[^)]+\.png)\): (\S+) over (\S+),", ln)
        assert m, ln
        assert m.group(1) == c["verdict"] and (m.group(3), m.group(4)) == (c["better"],
                                                                          c["than"])
        png = run_dir / m.group(2)
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        # the evidence section links the same figure from the claim's own line and shows it
        assert report.count(f"]({m.group(2)})") >= 3, m.group(2)
    assert len({re.search(r"\((figures/[^)]+)\)", ln).group(1) for ln in vlines}) == 3
    assert sorted(p.name for p in (run_dir / "figures").glob("claim__*.png")) == \
        [f"claim__{i:02d}.png" for i in range(3)]


def test_the_numbers_drawn_are_those_of_metrics_json(claims, kept, tmp_path):
    for i, c in enumerate(claims):
        assert CF.fig_claim(c, tmp_path / f"c{i}.png")
        fig = kept[-1]
        sm, osm = c["summary"], c["oracle_improvement"]
        lo, hi, mean = _interval_drawn(fig, "claim_ci")
        assert (lo, hi, mean) == pytest.approx((sm["ci_low"], sm["ci_high"], sm["mean"]),
                                               rel=1e-12, abs=1e-12)
        lo, hi, mean = _interval_drawn(fig, "oracle_ci")
        assert (lo, hi, mean) == pytest.approx((osm["ci_low"], osm["ci_high"], osm["mean"]),
                                               rel=1e-12, abs=1e-12)
        d = c["paired"]["diff"]
        assert _interval_drawn(fig, "claim_diff_ci") == pytest.approx(
            (d["ci_low"], d["ci_high"], d["mean"]), rel=1e-12, abs=1e-15)
        d = c["oracle_paired"]["diff"]
        assert _interval_drawn(fig, "oracle_diff_ci") == pytest.approx(
            (d["ci_low"], d["ci_high"], d["mean"]), rel=1e-12, abs=1e-15)
        # the claimed range: its given ends; an open end runs past the visible axis
        s_lo, s_hi, ax = _span_drawn(fig)
        y0, y1 = ax.get_ylim()
        assert s_lo == pytest.approx(c["min_pct"]) if c["min_pct"] is not None else s_lo < y0
        assert s_hi == pytest.approx(c["max_pct"]) if c["max_pct"] is not None else s_hi > y1
        # the interval and the claimed bounds are in view
        for v in (sm["ci_low"], sm["ci_high"], c["min_pct"], c["max_pct"]):
            assert v is None or y0 < v < y1
        # every replicate's improvement is a point
        (pts,) = _by_gid(fig, "claim_ci_points")
        want = [v for v in c["per_replicate"]["improvement_pct"] if v is not None]
        assert sorted(pts.get_ydata()) == pytest.approx(sorted(want), rel=1e-12)
        # the verdict and its side are in the figure's text
        texts = " ".join(t.get_text() for t in fig.texts)
        assert c["verdict"].upper() in texts
    # the claim between two seeded methods has a third panel: every start of both
    c = claims[1]
    assert c["over_seeds"] is not None
    starts = [ln for ax in kept[1].axes[2:] for ln in ax.get_lines() if ln.get_marker() == "o"]
    drawn = sorted(y for ln in starts for y in ln.get_ydata())
    per = c["over_seeds"]["per_replicate"]
    assert drawn == pytest.approx(sorted(y for lab in ("bp", "bp_short") for rep in per[lab]
                                         for y in rep if y is not None), rel=1e-12)
    assert len(kept[0].axes) == 2 and len(kept[1].axes) == 3


def _by_hand(run_dir, c):
    """Per replicate, from the replicate files: the claim's metric for better, than and the
    oracle (mean over the claim's runs; a seeded method's value is the mean over its starts)."""
    out = {c["better"]: [], c["than"]: [], c["oracle"]: []}
    files = sorted((run_dir / "replicates").glob("r*.json"))
    assert len(files) == R
    for f in files:
        p = json.loads(f.read_text())["protocols"][c["protocol"]]
        for lab in out:
            per_run = []
            for run in c["runs"]:
                seeds = p.get("seeds", {}).get(run, {}).get(lab)
                per_run.append(np.mean([s[c["metric"]] for s in seeds]) if seeds
                               else p["runs"][run][lab][c["metric"]])
            out[lab].append(float(np.mean(per_run)))
    return {k: np.array(v) for k, v in out.items()}


def _t_interval(x):
    x = np.asarray(x, dtype=float)
    h = sps.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size)
    return x.mean() - h, x.mean() + h


def test_metrics_json_holds_the_claims_numbers_as_recomputed_by_hand(run_dir, claims):
    for c in claims:
        v = _by_hand(run_dir, c)
        a, b, o = v[c["better"]], v[c["than"]], v[c["oracle"]]
        imp, oimp = 100 * (1 - a / b), 100 * (1 - o / b)
        pr = c["per_replicate"]
        assert pr["replicate"] == list(range(R))
        for key, want in (("better", a), ("than", b), ("oracle", o), ("improvement_pct", imp),
                          ("oracle_improvement_pct", oimp)):
            assert pr[key] == pytest.approx(want.tolist(), rel=1e-9), key
        for sm, x in ((c["summary"], imp), (c["oracle_improvement"], oimp),
                      (c["paired"]["diff"], a - b), (c["oracle_paired"]["diff"], o - b)):
            lo, hi = _t_interval(x)
            assert (sm["mean"], sm["ci_low"], sm["ci_high"]) == pytest.approx(
                (x.mean(), lo, hi), rel=1e-9, abs=1e-12)
        # the verdict follows from the interval and the claimed range (the oracle first)
        lo, hi = _t_interval(imp)
        L = -math.inf if c["min_pct"] is None else c["min_pct"]
        H = math.inf if c["max_pct"] is None else c["max_pct"]
        if _t_interval(oimp)[1] < L:
            want = "untestable"
        elif L <= lo and hi <= H:
            want = "agrees"
        elif hi < L or lo > H:
            want = "disagrees"
        else:
            want = "inconclusive"
        assert c["verdict"] == want
    # the starts of the seeded claim, replicate by replicate, are the replicate files' seeds
    c = claims[1]
    for lab in ("bp", "bp_short"):
        for r, rep in enumerate(c["over_seeds"]["per_replicate"][lab]):
            p = json.loads((run_dir / "replicates" / f"r{r:05d}.json").read_text())
            seeds = p["protocols"]["own_run"]["seeds"]
            want = [np.mean([seeds[run][lab][k]["rmse_dph"] for run in c["runs"]])
                    for k in range(K)]
            assert rep == pytest.approx(want, rel=1e-12)


def test_a_disagreement_names_its_side_in_the_verdict_line_and_the_figure(kept, tmp_path):
    """Made-up claims (no run): above the claimed range reads "exceeds the claim", below it
    "falls short of the claim", in the report's line and the figure's verdict text."""
    def claim(mean, lo, hi):
        sm = {"n": 5, "n_failed": 0, "mean": mean, "ci_low": lo, "ci_high": hi}
        return {"text": "t", "source": "s", "protocol": "p", "in_sample": False,
                "metric": "rmse_dph", "better": "m", "than": "raw", "runs": ["r"],
                "min_pct": 70.0, "max_pct": 90.0, "verdict": "disagrees", "summary": sm,
                "oracle_improvement": {**sm, "mean": 97.0, "ci_low": 96.0, "ci_high": 98.0},
                "oracle": "oracle", "oracle_bounds_claim": True,
                "paired": {"diff": {**sm, "mean": -1.0, "ci_low": -1.2, "ci_high": -0.8},
                           "first_better": 1.0},
                "oracle_paired": {"diff": {**sm, "mean": -1.3, "ci_low": -1.4,
                                           "ci_high": -1.2}}}

    mc = {"replicates": 5, "claims": [claim(93.6, 93.0, 94.2), claim(40.0, 35.0, 45.0)]}
    lines = [ln for ln in CF.verdicts_section(mc, {("claim", 0): "figures/claim__00.png"})
             if ln.startswith("- ")]
    assert lines[0].startswith("- [**disagrees** (exceeds the claim)](figures/claim__00.png)")
    assert lines[1].startswith("- **disagrees** (falls short of the claim): m over raw")
    colours = []
    for c, words in zip(mc["claims"], ("exceeds the claim", "falls short of the claim")):
        assert CF.fig_claim(c, tmp_path / "c.png")
        (verdict_text,) = [t for t in kept[-1].texts if words in t.get_text()]
        colours.append(to_hex(verdict_text.get_color()))
    # the two sides are told apart by colour too: better than the paper said is not red
    assert colours[1] == "#c0392b" and colours[0] not in (colours[1], "#2a9d3f")


def test_an_interval_lost_in_its_marker_gets_a_zoomed_inset(claims, kept, tmp_path):
    """paper000: the WNN's 1.4 [0.8, 2.0] % on an axis up to the oracle's 100 % was an interval
    inside its marker. A column spanning under ZOOM_FRACTION of its panel gets an inset where
    its points and its interval (the same numbers) fill the height; a column that reads on the
    main axis gets none."""
    import copy

    c = copy.deepcopy(claims[0])
    n = len(c["per_replicate"]["improvement_pct"])
    rng = np.random.default_rng(1)
    pts = list(1.4 + 0.6 * rng.standard_normal(n))
    c["per_replicate"]["improvement_pct"] = pts
    c["per_replicate"]["oracle_improvement_pct"] = [100.0] * n
    c["summary"].update(mean=1.4, ci_low=0.8, ci_high=2.0)
    c["oracle_improvement"].update(mean=100.0, ci_low=100.0, ci_high=100.0)
    assert CF.fig_claim(c, tmp_path / "c.png")
    fig = kept[-1]
    (ins,) = [a for a in fig.axes[0].child_axes if a.get_title() == "zoomed in"]
    lo, hi, mean = _interval_drawn(fig, "claim_ci_zoom")
    assert (lo, hi, mean) == pytest.approx((0.8, 2.0, 1.4), rel=1e-12)
    (dots,) = _by_gid(fig, "claim_ci_zoom_points")
    assert sorted(dots.get_ydata()) == pytest.approx(sorted(pts), rel=1e-12)
    y0, y1 = ins.get_ylim()
    assert y0 < min(pts) and max(pts) < y1 and (2.0 - 0.8) > 0.1 * (y1 - y0)
    # a narrow interval among spread points (paper000's -0.89 [-8.5, 6.7] with points to +45
    # on a 700-wide axis): the interval decides, an inset
    kept.clear()
    c["per_replicate"]["improvement_pct"] = pts[:-2] + [-30.0, 45.0]
    c["per_replicate"]["oracle_improvement_pct"] = [600.0] * n
    c["oracle_improvement"].update(mean=600.0, ci_low=590.0, ci_high=610.0)
    c["summary"].update(mean=-0.89, ci_low=-8.5, ci_high=6.7)
    assert CF.fig_claim(c, tmp_path / "c1.png")
    assert [a.get_title() for a in kept[-1].axes[0].child_axes] == ["zoomed in"]
    # an interval as wide as its panel allows reads on the main axis: no inset
    kept.clear()
    c["summary"].update(mean=300.0, ci_low=0.0, ci_high=600.0)
    assert CF.fig_claim(c, tmp_path / "c2.png")
    assert not kept[-1].axes[0].child_axes
