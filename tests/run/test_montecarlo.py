"""Monte Carlo over replicates: a replicate's numbers depend only on the scenario and
its index (never on the engine, the number of workers, the order, or what ran before), the work
is resumable, failures are counted, and the aggregate states its intervals and verdicts."""

from __future__ import annotations

import contextlib
import json

import numpy as np
import pytest

from helpers import run_cli
from fogbench.run.engines import SerialExecutor, make_executor
from fogbench.run.workdir import MonteCarloError
from fogbench.run.montecarlo import ScenarioMC, replicate_task

SCENARIO = """
[scenario]
name = "mc_tiny"
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
reference = "truth"      # one reading: the Monte Carlo statistics, not the lab, are tested here
fit = [{ run = "*", end_s = 75.0 }]
score = [{ run = "*", start_s = 75.0 }]

[[methods]]
name = "bp"
params = { max_epochs = 60 }

[[methods]]
name = "poly_temp"

[[claims]]
text = "poly_temp removes all of the error"
source = "a test"
metric = "rmse_dph"
better = "poly_temp"
than = "raw"
min_pct = 99.99

[montecarlo]
replicates = 4
"""


@pytest.fixture
def scn(tmp_path):
    p = tmp_path / "mc_tiny.toml"
    p.write_text(SCENARIO)
    return p


def _digest(p):
    from fogbench.run.workdir import scenario_digest

    return scenario_digest(p.read_bytes().decode("utf-8", "replace"))


def run_mc(path, out, executor_cm, **kw):
    mc = ScenarioMC(path, out, **kw)
    with executor_cm as ex:
        mc.simulate_truths()
        mc.submit(ex)
        mc.run_first()
        mc.wait()
    assert mc.failures == []
    return mc, mc.finish("test")


def test_aggregate_is_identical_serial_two_processes_and_dask(scn, tmp_path):
    """The determinism law: one SHA-256 of the aggregate for every engine."""
    distributed = pytest.importorskip("distributed")
    digests = {}
    _, mc = run_mc(scn, tmp_path / "serial", make_executor(jobs=1))
    digests["serial"] = mc["digest"]
    _, mc = run_mc(scn, tmp_path / "procs", make_executor(jobs=2))
    digests["2 processes"] = mc["digest"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        _, mc = run_mc(scn, tmp_path / "dask", make_executor(scheduler=cluster.scheduler_address))
        digests["dask"] = mc["digest"]
    assert len(set(digests.values())) == 1, digests
    assert mc["replicates"] == 4


def test_a_replicate_depends_only_on_its_index(scn, tmp_path):
    """Replicate 3 computed alone, first, equals replicate 3 of a whole run; replicates differ."""
    mc, _ = run_mc(scn, tmp_path / "all", contextlib.nullcontext(SerialExecutor()))
    alone = replicate_task((str(scn), _digest(scn), 3, 1, None, {}, None, {}))  # no cached table motion either
    whole = mc.done[3]

    def metric(doc, r):
        return doc["protocols"]["own_run"]["runs"][r]["raw"]["rmse_dph"]

    assert metric(alone, "a") == metric(whole, "a") and metric(alone, "b") == metric(whole, "b")
    assert alone["protocols"]["own_run"]["runs"]["a"]["bp"]["rmse_dph"] == \
        whole["protocols"]["own_run"]["runs"]["a"]["bp"]["rmse_dph"]
    assert len({metric(mc.done[r], "a") for r in range(4)}) == 4  # new draws per replicate


def test_resume_skips_completed_replicates_and_gives_the_same_aggregate(scn, tmp_path):
    _, full = run_mc(scn, tmp_path / "full", make_executor(jobs=1))
    # a killed run: replicates 0 and 2 were written, 1 and 3 were in flight
    out = tmp_path / "killed"
    first = ScenarioMC(scn, out)
    first.run_first()
    first.work.write(replicate_task((str(scn), _digest(scn), 2, 1, None, {}, None, {})))
    # while it lives, its folder is its own: a second run into the same place is refused
    with pytest.raises(MonteCarloError, match="being filled by another fogbench process"):
        ScenarioMC(scn, out, resume=True)
    first.work.release()  # the process ends (the kernel releases its claim, even on kill -9)
    again = ScenarioMC(scn, out, resume=True)
    assert again.todo == [1, 3] and again.resumed == [0, 2]
    again.work.release()
    # without --resume the kept replicates are neither used nor deleted: refused, naming them
    with pytest.raises(MonteCarloError, match="2 replicate.*--resume"):
        ScenarioMC(scn, out)
    assert len(list(first.work.path.glob("r*.json"))) == 2
    resumed, mc = run_mc(scn, out, make_executor(jobs=1), resume=True)
    assert mc["digest"] == full["digest"]
    resumed.work.release()
    # an edited scenario is refused, naming the mismatch
    scn.write_text(scn.read_text().replace("seed = 12", "seed = 13"))
    with pytest.raises(MonteCarloError, match="another scenario file"):
        ScenarioMC(scn, out, resume=True)


def test_claim_beyond_the_oracle_is_untestable_and_intervals_are_stated(scn, tmp_path):
    _, mc = run_mc(scn, tmp_path / "o", make_executor(jobs=1))
    (claim,) = mc["claims"]
    # poly_temp is a model of deterministic terms: the oracle bounds it; noise stays, so
    # removing 99.99 % of the RMS error is more than the oracle can give
    assert claim["oracle_bounds_claim"] is True
    assert claim["oracle_improvement"]["ci_high"] < 99.99
    assert claim["verdict"] == "untestable"
    sm = mc["over_runs"]["own_run"]["raw"]["rmse_dph"]
    vals = np.array([v for v in mc["series"]["own_run"]["rmse_dph"]["raw"]])
    assert sm["n"] == 4 and np.isclose(sm["mean"], vals.mean())
    from scipy import stats

    half = stats.t.ppf(0.975, 3) * vals.std(ddof=1) / 2
    assert np.isclose(sm["ci_high"] - sm["mean"], half)


def test_a_failing_method_counts_as_failures_not_the_end(scn, tmp_path, monkeypatch):
    """A method that fails in some replicates: its failure rate is reported, the rest goes on."""
    import fogcomp
    from fogcomp.methods.temperature import PolyTemp

    real_fit = PolyTemp._fit

    def flaky(self, data, error):
        if abs(float(np.mean(data.rate))) % 2e-6 < 1e-6:  # data-dependent: some replicates
            raise fogcomp.DivergenceError("flaky on purpose")
        return real_fit(self, data, error)

    monkeypatch.setattr(PolyTemp, "_fit", flaky)
    _, mc = run_mc(scn, tmp_path / "f", make_executor(jobs=1))
    sm = mc["over_runs"]["own_run"]["poly_temp"]["rmse_dph"]
    assert sm["n"] + sm["n_failed"] == 4 and 0 < sm["n_failed"] < 4
    assert sm["failure_rate"] == sm["n_failed"] / 4
    assert mc["over_runs"]["own_run"]["bp"]["rmse_dph"]["n"] == 4


def _cli(*args):
    code, _, err = run_cli(*args)
    return code, err


def test_run_writes_replicates_and_the_aggregate(scn, tmp_path):
    out = tmp_path / "run"
    code, err = _cli("run", scn, "--out", out, "--replicates", 3, "--jobs", 1, "--quiet",
                     "--no-recording", "--no-figures")
    assert code == 0, err
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["montecarlo"]["replicates"] == 3
    assert sorted(p.name for p in (out / "replicates").glob("r*.json")) == \
        ["r00000.json", "r00001.json", "r00002.json"]
    assert not (tmp_path / ".run.replicates").exists()
    report = (out / "report.md").read_text()
    assert "## Over 3 replicates" in report and "**untestable**" in report
    # one replicate: today's single run, no Monte Carlo section
    code, err = _cli("run", scn, "--out", tmp_path / "one", "--replicates", 1, "--quiet",
                     "--no-recording", "--no-figures")
    assert code == 0, err
    assert "montecarlo" not in json.loads((tmp_path / "one" / "metrics.json").read_text())


@pytest.mark.parametrize("args,words", [
    (["--replicates", "0"], ["--replicates", ">= 1"]),
    (["--replicates", "two"], ["--replicates", "integer"]),
    (["--method-seeds", "-1"], ["--method-seeds"]),
    (["--jobs", "0"], ["--jobs"]),
    (["--scheduler", "tcp://127.0.0.1:9", "--replicates", "3"], ["tcp://127.0.0.1:9"]),
    (["--scheduler", "http://x"], ["scheduler"]),
    (["--resume"], ["--resume", "nothing to resume"]),
])
def test_bad_monte_carlo_input_is_one_line_exit_2_nothing_written(scn, tmp_path, args, words):
    out = tmp_path / "o"
    code, err = _cli("run", scn, "--out", out, "--quiet", "--no-recording", *args)
    assert code == 2, err
    last = err.strip().splitlines()[-1]  # argparse prints its usage above the error line
    assert "error" in last and "Traceback" not in err
    for w in words:
        assert w in last, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["mc_tiny.toml"]


@pytest.mark.parametrize("bad,words", [("replicates = 0", "replicates"),
                                       ("replicates = 2.5", "integer"),
                                       ("method_seeds = 0", "method_seeds")])
def test_bad_montecarlo_table_is_refused_at_load(scn, bad, words):
    scn.write_text(scn.read_text().replace("replicates = 4", bad))
    code, err = _cli("check", scn)
    assert code == 2 and "[montecarlo]" in err and words in err and str(scn) in err


def test_a_scenario_edited_during_the_run_is_not_mixed_in(scn):
    digest = _digest(scn)
    scn.write_text(scn.read_text().replace("seed = 12", "seed = 99"))
    with pytest.raises(MonteCarloError, match="changed during the run"):
        replicate_task((str(scn), digest, 1, 1, None, {}, None, {}))


# ---------------------------------------------------------------------------------------------
# Claims between two seeded methods, over their method starts
def test_p_better_is_the_mann_whitney_probability():
    """P(a start of A beats a start of B) against scipy's Mann-Whitney U / (K_a K_b), ties
    included, for both directions of 'better'."""
    from scipy.stats import mannwhitneyu

    from fogbench.run.aggregate import p_better

    rng = np.random.default_rng(3)
    for _ in range(20):
        a = np.round(rng.normal(0.0, 1.0, rng.integers(2, 25)), 1)     # rounded: ties occur
        b = np.round(rng.normal(0.3, 1.0, rng.integers(2, 25)), 1)
        u_b = mannwhitneyu(b, a).statistic          # pairs with b > a, ties half
        assert p_better(a, b, "lower") == pytest.approx(u_b / (a.size * b.size), abs=1e-12)
        u_a = mannwhitneyu(a, b).statistic
        assert p_better(a, b, "higher") == pytest.approx(u_a / (a.size * b.size), abs=1e-12)
    assert np.isnan(p_better([np.nan], [1.0]))
    assert p_better([1.0, np.nan], [2.0]) == 1.0          # a failed start is left out


def _seed_doc(r, a_vals, b_vals):
    runs = {"r1": {}, "r2": {}}
    seeds = {run: {"A": [{"x_dph": v + i} for v in a_vals],
                   "B": [{"x_dph": v + i} for v in b_vals]}
             for i, run in enumerate(runs)}
    return {"replicate": r, "protocols": {"p": {"runs": runs, "seeds": seeds}}}


def test_over_seeds_pools_starts_and_compares_within_replicates():
    """Two replicates whose A starts all beat B's in the same replicate, though replicate 1's
    A are worse than replicate 0's B (a between-replicate shift): the probability counts
    pairs inside a replicate only, so it is 1 in both; the pooled quantiles are those of the
    per-start means over the two runs (v + 0.5)."""
    from fogbench.run.aggregate import _over_seeds

    docs = [_seed_doc(0, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0]),
            _seed_doc(1, [11.0, 12.0, 13.0], [14.0, 15.0, 16.0])]
    o = _over_seeds(docs, "p", ["r1", "r2"], "A", "B", "x_dph")
    assert o["seeds_per_replicate"] == 3
    assert o["p_better_start"]["mean"] == 1.0 and o["p_better_start"]["n"] == 2
    pooled_a = np.array([1.5, 2.5, 3.5, 11.5, 12.5, 13.5])
    assert o["A"]["median"] == pytest.approx(np.median(pooled_a))
    assert o["A"]["q05"] == pytest.approx(np.quantile(pooled_a, 0.05))
    assert o["A"]["n"] == 6
    # reversed: B never beats A; a method without seeds gives no comparison
    assert _over_seeds(docs, "p", ["r1", "r2"], "B", "A", "x_dph")["p_better_start"]["mean"] == 0
    assert _over_seeds(docs, "p", ["r1", "r2"], "A", "C", "x_dph") is None


def test_over_seeds_higher_is_better_for_percent_metrics_and_counts_failed_starts():
    """On a `_pct` metric a larger value is better: A's starts (all larger) beat B's with
    probability 1. A start without a value (a failed fit) is left out and counted."""
    from fogbench.run.aggregate import _over_seeds

    def doc(r, a, b):
        seeds = {"r1": {"A": [{"x_pct": v} if v is not None else {"status": "failed"}
                              for v in a],
                        "B": [{"x_pct": v} for v in b]}}
        return {"replicate": r, "protocols": {"p": {"runs": {"r1": {}}, "seeds": seeds}}}

    docs = [doc(0, [50.0, 60.0, None], [10.0, 20.0, 30.0]),
            doc(1, [55.0, 65.0, 70.0], [15.0, 25.0, 35.0])]
    o = _over_seeds(docs, "p", ["r1"], "A", "B", "x_pct")
    assert o["p_better_start"]["mean"] == 1.0
    assert o["failed_starts"] == {"A": 1, "B": 0} and o["starts"] == {"A": 6, "B": 6}
    assert o["A"]["n"] == 5
    assert _over_seeds(docs, "p", ["r1"], "B", "A", "x_pct")["p_better_start"]["mean"] == 0.0


def test_every_replicate_is_kept_when_callbacks_run_late(scn, tmp_path):
    """A pool marks a future done before its done-callbacks run (in the pool's own thread):
    ``wait()`` must not return with a finished replicate not yet stored. Here every callback
    runs 0.5 s late; all 4 replicates are in the aggregate, each stored once."""
    import concurrent.futures as cf
    import threading

    timers = []

    class LateFuture(cf.Future):
        def add_done_callback(self, fn):
            t = threading.Timer(0.5, fn, args=(self,))
            timers.append(t)
            t.start()

    class LateExecutor(SerialExecutor):
        def submit(self, fn, /, *args, **kwargs):
            fut = LateFuture()
            fut.set_running_or_notify_cancel()
            fut.set_result(fn(*args, **kwargs))
            return fut

    calls = []
    mc = ScenarioMC(scn, tmp_path / "late")
    with contextlib.nullcontext(LateExecutor()) as ex:
        mc.simulate_truths()
        mc.submit(ex, on_done=calls.append)
        mc.run_first()
        mc.wait()
    agg = mc.finish("test")
    for t in timers:
        t.join()
    assert agg["replicates"] == 4
    assert sorted(mc.done) == [0, 1, 2, 3]
    assert calls == [True, True, True]          # progress advanced once per replicate


def test_start_series_holds_every_start_and_the_figure_draws_them(scn, tmp_path):
    """With K = 3 starts: ``start_series`` holds, per replicate, each start's metric averaged
    over the scored runs, as read back from the replicate files; the mean over a replicate's
    starts is the replicate value the claims use (``series``); the starts figure is drawn."""
    from fogbench.report.montecarlo import fig_starts

    mc, agg = run_mc(scn, tmp_path / "k3", make_executor(jobs=1), method_seeds=3)
    got = agg["start_series"]["own_run"]["rmse_dph"]["bp"]
    assert len(got) == 4 and all(len(rep) == 3 for rep in got)
    for r, rep in enumerate(got):
        doc = json.loads((mc.work.path / f"r{r:05d}.json").read_text()) \
            if (mc.work.path / f"r{r:05d}.json").exists() else mc.done[r]
        seeds = doc["protocols"]["own_run"]["seeds"]
        for k in range(3):
            want = np.mean([seeds[run]["bp"][k]["rmse_dph"] for run in seeds])
            assert rep[k] == pytest.approx(want, rel=1e-12)
        assert agg["series"]["own_run"]["rmse_dph"]["bp"][r] == pytest.approx(np.mean(rep),
                                                                              rel=1e-12)
    assert "poly_temp" not in agg["start_series"]["own_run"]["rmse_dph"]   # draws no start
    path = tmp_path / "starts.png"
    assert fig_starts(mc.res0, agg, path) and path.stat().st_size > 1000


def test_a_mean_over_fewer_runs_names_them_and_the_takeaway_says_so():
    """dynamic_rates' filter oracle exists on its static run alone: the report's first line
    gave it as 65.6 % beside methods averaged over both runs. A label's mean over a subset of
    the scored runs names them (``runs``), and the takeaway says "on <run> only"."""
    from types import SimpleNamespace

    from fogbench.report import claims as CF
    from fogbench.run import montecarlo as MC

    docs = [{"replicate": r, "protocols": {"p": {"runs": {
        "moving": {"raw": {"rmse_dph": 10.0 + r}, "oracle": {"rmse_dph": 9.0 + r}},
        "static": {"raw": {"rmse_dph": 4.0 + r}, "oracle": {"rmse_dph": 3.0 + r},
                   "oracle_filter": {"rmse_dph": 1.0 + 0.1 * r}}}}}} for r in range(4)]
    plan = SimpleNamespace(methods=(), claims=(), paper=(), protocols=(
        SimpleNamespace(name="p", twin_of=None, in_sample=False),))
    mc = MC.aggregate(docs, SimpleNamespace(), plan)
    of = mc["over_runs"]["p"]["oracle_filter"]["rmse_dph"]
    assert of["runs"] == ["static"] and of["mean"] == pytest.approx(1.15)
    assert "runs" not in mc["over_runs"]["p"]["raw"]["rmse_dph"]          # both runs
    assert mc["over_runs"]["p"]["raw"]["rmse_dph"]["mean"] == pytest.approx(8.5)
    _, refs = CF._placed(mc["over_runs"]["p"], "rmse_dph")
    (ref,) = [r for r in refs if r.startswith("oracle_filter")]
    assert ref.endswith("on static only"), refs
    assert not any(r.startswith("oracle ") and "only" in r for r in refs), refs
