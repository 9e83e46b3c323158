"""The runner, the protocol loader, reports and the suite's bound check, end to end."""

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fogcomp import Compensator, DivergenceError, register
from fogbench.scenario.load import RUNNER_SECTIONS
from fogbench.scenario import ScenarioError, load_plan, load_scenario
from fogbench.run.suite import run_suite

ROOT = Path(__file__).resolve().parents[2]


@register
class _Broken(Compensator):
    """A deliberately broken method: it adds a large error instead of removing one."""

    name = "test_broken_adds_error"

    def __init__(self):
        pass

    def _fit(self, data, error):
        pass

    def _estimate(self, data):
        return np.full(len(data), -1.0)  # compensated = raw + 1 rad/s

    def _state(self):
        return {}, {}

    def _restore(self, info, arrays):
        pass


@register
class _Diverges(Compensator):
    name = "test_always_diverges"

    def __init__(self):
        pass

    def _fit(self, data, error):
        raise DivergenceError("loss became NaN at iteration 3")

    def _estimate(self, data):  # pragma: no cover
        raise AssertionError

    def _state(self):  # pragma: no cover
        return {}, {}

    def _restore(self, info, arrays):  # pragma: no cover
        pass


SMALL = """
[scenario]
name = "small"
description = "a small end-to-end scenario"
sample_rate_hz = 50.0

[fog]
preset = "low_grade"
arw_deg_rt_h = 0.8      # white noise dominant (MEMS-class), so the analytic std below holds
gm_drift_dps = 0.0

[[runs]]
name = "fit"
seed = 1
[[runs.motion]]
type = "rate"
rate_dps = -60.0
duration_s = 12.0

[[runs]]
name = "test"
seed = 2
[[runs.motion]]
type = "rate"
rate_dps = -60.0
duration_s = 8.0

[compensation]
ci = true

[[protocols]]
name = "held_out"
skip_s = 1.0
fit = ["fit"]
score = ["test"]

[[methods]]
name = "wavelet_soft"

[[methods]]
name = "kalman"

[[methods]]
name = "METHOD3"

[[bounds]]
protocol = "held_out"
method = "wavelet_soft"
metric = "std_dps"
max = 0.1
note = "the denoiser must cut the 0.13 deg/s raw noise"

[[bounds]]
protocol = "held_out"
method = "METHOD3"
metric = "rmse_dph"
max = 1000.0
note = "a compensator must not add error"
"""


def scenario(tmp_path, method3="kalman", label3="kalman_copy", extra="", name="small.toml"):
    text = SMALL.replace('name = "METHOD3"', f'name = "{method3}"\nlabel = "{label3}"')
    text = text.replace('method = "METHOD3"', f'method = "{label3}"') + extra
    d = tmp_path / "scen"
    d.mkdir(exist_ok=True)
    p = d / name
    p.write_text(text)
    return p


def plan_of(path):
    return load_plan(load_scenario(path, extra_sections=RUNNER_SECTIONS))


def test_loader_refuses_scoring_on_fitted_samples(tmp_path):
    p = scenario(tmp_path)
    p.write_text(p.read_text().replace('score = ["test"]', 'score = ["test", "fit"]'))
    with pytest.raises(ScenarioError, match=r"run 'fit' is scored on \d+ samples it was fitted on"):
        plan_of(p)
    # allowed only when flagged in_sample and beside a held-out protocol
    p.write_text(p.read_text().replace('skip_s = 1.0', 'skip_s = 1.0\nin_sample = true'))
    with pytest.raises(ScenarioError, match="must stand beside a held-out one"):
        plan_of(p)


def test_loader_refuses_unknown_methods_params_and_bad_bounds(tmp_path):
    with pytest.raises(ScenarioError, match=r"\[\[methods\]\]\[2\] key 'name': unknown method"):
        plan_of(scenario(tmp_path, method3="no_such_method"))
    p = scenario(tmp_path)
    p.write_text(p.read_text().replace('name = "wavelet_soft"',
                                       'name = "wavelet_soft"\nparams = { thresh = 1.0 }'))
    with pytest.raises(ScenarioError, match="key 'params'.*unknown hyperparameter"):
        plan_of(p)
    bounds = [('max = 0.1', '', "a bound needs 'min', 'max' or both"),
              ('max = 0.1', 'max = 0.1\nmin = 0.5', "expected min <= max"),
              ('metric = "std_dps"', 'metric = "precision"', "key 'metric': expected one of"),
              ('protocol = "held_out"\nmethod', 'protocol = "nope"\nmethod',
               "key 'protocol': expected one of")]
    for old, new, words in bounds:
        p = scenario(tmp_path)
        p.write_text(p.read_text().replace(old, new, 1))
        with pytest.raises(ScenarioError) as exc:
            plan_of(p)
        msg = str(exc.value)
        assert "[[bounds]][0]" in msg and str(p) in msg and words in msg, msg


def test_run_writes_metrics_report_and_figures_from_a_clean_directory(tmp_path):
    p = scenario(tmp_path, method3="test_always_diverges", label3="diverges")
    out = tmp_path / "clean" / "run"
    r = subprocess.run([sys.executable, "-m", "fogbench", "run", str(p), "--out", str(out),
                        "--no-recording", "--quiet"], capture_output=True, text=True, cwd=ROOT,
                       env={**__import__("os").environ,
                            "PYTHONPATH": f"{ROOT}:{Path(__file__).resolve().parents[1]}"})
    # the diverging method is registered only in this test process, so the subprocess
    # refuses the scenario: run it in-process instead
    assert r.returncode == 2 and "unknown method 'test_always_diverges'" in r.stderr
    assert not out.exists()
    from fogbench.report import write_run_dir
    from fogbench.run.runner import run_scenario

    res = run_scenario(p)
    write_run_dir(res, out, recording=False)
    doc = json.loads((out / "metrics.json").read_text())
    m = doc["protocols"]["held_out"]["runs"]["test"]
    assert m["diverges"]["status"] == "failed" and "NaN" in m["diverges"]["error"]
    # the low-grade FOG's ARW of 0.8 deg/sqrt(h) at 50 Hz: 0.8 / 60 * sqrt(50) = 0.094 deg/s
    assert abs(m["raw"]["std_dps"] / (0.8 / 60 * 50**0.5) - 1) < 0.1
    assert m["wavelet_soft"]["std_dps"] < m["raw"]["std_dps"] / 3
    assert m["kalman"]["fit_time_s"] >= 0 and "compensate_time_s" in m["kalman"]
    # the oracle removes the deterministic terms: its mean error is the noise's, near zero
    assert abs(m["oracle"]["mean_error_dph"]) < abs(m["raw"]["mean_error_dph"])
    report = (out / "report.md").read_text()
    assert "FAILED: DivergenceError: loss became NaN" in report
    for fig in ("timeseries", "psd", "allan"):
        png = out / "figures" / f"held_out__test__{fig}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"figures/held_out__test__{fig}.png" in report
    with np.load(out / "data" / "test.npz", allow_pickle=False) as z:
        assert z["raw_rps"].shape == (400, 1)
    assert not list(out.parent.glob(".*part"))


def test_scored_samples_are_never_the_fitted_ones(tmp_path):
    from fogbench.run.runner import run_scenario

    res = run_scenario(scenario(tmp_path))
    (item,) = res.scored
    assert item.run == "test" and item.piece.raw.size == 7 * 50
    rd = res.data["test"]
    np.testing.assert_array_equal(item.piece.raw, rd.fog.raw[50:, 0])


def test_suite_check_fails_on_a_broken_method_and_passes_otherwise(tmp_path, capsys):
    good = scenario(tmp_path)
    assert run_suite(good.parent, tmp_path / "rep", check=True, jobs=1, recording=False,
                     quiet=True) == 0
    summary = (tmp_path / "rep" / "README.md").read_text()
    assert "[small](small/report.md)" in summary and "Every declared bound holds." in summary
    # every method across scenarios, beside the summary and linked from it
    assert "[compare.md](compare.md)" in summary
    cmp = json.loads((tmp_path / "rep" / "compare.json").read_text())
    assert cmp["format"] == "fogbench-compare" and cmp["rows"]
    assert (tmp_path / "rep" / "compare.png").stat().st_size > 0

    bad_dir = tmp_path / "bad"
    bad_dir.mkdir()
    bad = scenario(tmp_path, method3="test_broken_adds_error", label3="broken")
    (bad_dir / "small.toml").write_text(bad.read_text())
    capsys.readouterr()
    code = run_suite(bad_dir, tmp_path / "rep2", check=True, jobs=1, recording=False,
                     quiet=True)
    err = capsys.readouterr().err
    assert code == 1
    assert "small: protocol held_out, run test, method broken, rmse_dph" in err
    assert "outside [–, 1000]" in err
    # without --check the same suite reports but does not fail on the bound
    assert run_suite(bad_dir, tmp_path / "rep3", check=False, jobs=1, recording=False,
                     quiet=True) == 0


def _suite_holds_its_bounds(out, only_ci: bool):
    """A short Monte Carlo (2 replicates) of the bundled scenarios, checked against their
    declared bounds. The bounds come from the configured devices and the methods'
    "no worse than raw" rules, not from the code's output, so a regression in the simulator, a
    method or the scoring makes this fail. No figures (`--no-figures`): they were half of its
    time, and a figure that cannot be drawn is a note in the report, never a failure, so they
    checked nothing here; tests/report/test_report_*.py and test_claim_figures.py draw them."""
    docs = [tomllib.loads(p.read_text()) for p in (ROOT / "scenarios").glob("*.toml")]
    names = sorted(d["scenario"]["name"] for d in docs
                   if not only_ci or d.get("compensation", {}).get("ci"))
    assert names, "no scenario files in scenarios/"
    # the claim maps' points are left out here (tests/run/test_maps.py runs maps)
    r = subprocess.run([sys.executable, "-m", "fogbench", "suite", "--replicates", "2",
                        "--check", "--no-recording", "--no-figures", "--no-map", "--quiet",
                        "--out", str(out)]
                       + (["--ci"] if only_ci else []),
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, (r.stdout + r.stderr)[-4000:]
    assert f"{len(names)}/{len(names)} scenario(s) ran" in r.stdout, r.stdout
    summary = (out / ("README.partial.md" if only_ci else "README.md")).read_text()
    for name in names:
        assert f"## [{name}]({name}/report.md)" in summary, f"{name} missing from the summary"
        assert (out / name / "metrics.json").exists()
        assert "figures: none drawn (--no-figures)" in (out / name / "report.md").read_text()
        assert not (out / name / "figures").exists(), name
    return names


def test_the_ci_scenarios_hold_their_bounds_over_two_replicates(tmp_path):
    """What `make test` runs of the real suite: the scenarios marked `ci = true` (six of ten,
    about a minute and a half here; paper002, paper004, static_allan and lab_references, whose
    replicates take 10 to 70 s each, only in the test below)."""
    names = _suite_holds_its_bounds(tmp_path / "reports", only_ci=True)
    assert len(names) >= 6, names


@pytest.mark.slow
def test_every_bundled_scenario_holds_its_bounds_over_two_replicates(tmp_path):
    """`make test-all`: every scenario, as the one above does the `ci = true` ones."""
    _suite_holds_its_bounds(tmp_path / "reports", only_ci=False)


def test_claim_verdicts_state_agreement_with_the_numbers():
    from fogbench.scenario import Claim, Plan
    from fogbench.run.suite import claim_verdicts

    doc = {"protocols": {"p": {"in_sample": False, "runs": {
        "r1": {"raw": {"x_dph": 1.0}, "m": {"x_dph": 0.25}},
        "r2": {"raw": {"x_dph": 2.0}, "m": {"x_dph": 0.5}}}}}}
    claim = Claim("m removes 70-80 %", "paper", "x_dph", "m", "raw", 70.0, 80.0)
    plan = Plan((), (), (), (), "z", claims=(claim,))
    (v,) = claim_verdicts(plan, doc)
    # one replicate is one draw: never a verdict, but the numbers and where they fall
    assert "+75.0 %" in v and "this one draw within it" in v and "r2: 0.5 vs 2" in v
    assert "**inconclusive**" in v
    plan = Plan((), (), (), (), "z", claims=(Claim("m removes 80 %+", "paper", "x_dph", "m",
                                                     "raw", 80.0, None),))
    (v,) = claim_verdicts(plan, doc)
    assert "this one draw outside it" in v and "claim 80.. %" in v and "**inconclusive**" in v


STATIC_THERMAL = """
[scenario]
name = "static_thermal"
description = "a static FOG through a short ramp: the lab's reference is the truth"
sample_rate_hz = 1.0

[fog]
preset = "paper002_fog"
axes = ["z"]

[thermal]
start_c = 20.0
steps = [{ ramp_to_c = 30.0, rate_c_per_min = 1.0 }, { hold_s = 300.0 }]

[[runs]]
name = "fit"
seed = 1
[[runs.motion]]
type = "hold"
duration_s = 900.0

[[runs]]
name = "test"
seed = 2
[[runs.motion]]
type = "hold"
duration_s = 900.0

[compensation]
axis = "z"

[[protocols]]
name = "held_out"
fit = ["fit"]
score = ["test"]

[[methods]]
name = "bp"
params = { max_epochs = 30 }

[[methods]]
name = "poly_temp"

[[methods]]
name = "model_lstsq"
params = { terms = ["bias", "temp"] }
"""


def _numbers_differ(a, b, path=""):
    """Paths where two metrics documents differ, timings left out."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in set(a) | set(b)
                if not any(w in k for w in ("time", "per_s", "wall", "fit_reused_from"))
                for d in _numbers_differ(a.get(k), b.get(k), f"{path}/{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b))
                for d in _numbers_differ(x, y, f"{path}[{i}]")]
    same = a == b or (isinstance(a, float) and isinstance(b, float)
                      and np.isnan(a) and np.isnan(b))
    return [] if same else [path]


def test_an_ideal_twin_fitted_on_the_same_bytes_reuses_the_fit_and_scores_as_a_refit(
        tmp_path, monkeypatch):
    """Issue 43: on a static table the lab's reference is the truth, so a protocol and its
    ideal-lab twin hand each method the same samples and the same seed; the twin takes the
    first fit (said in its record) and every metric is what fitting it again gives."""
    import fogbench.run.runner as R

    p = tmp_path / "static_thermal.toml"
    p.write_text(STATIC_THERMAL)
    reused = R.run_scenario(str(p), replicate=1, method_seeds=2)
    assert set(reused.fits) == {"held_out", "held_out.ideal"}
    for label in ("bp", "poly_temp"):
        assert "fit_reused_from" not in reused.fits["held_out"][label][0]
        assert reused.fits["held_out.ideal"][label][0]["fit_reused_from"] == "held_out"
    # model_lstsq reads the specific force, which the lab computes and the truth simulates
    # (they differ in the last bits): fitted again
    assert "fit_reused_from" not in reused.fits["held_out.ideal"]["model_lstsq"][0]
    monkeypatch.setattr(R, "_reuse", lambda entry, fit_sel, score_sel: None)
    refit = R.run_scenario(str(p), replicate=1, method_seeds=2)
    assert "fit_reused_from" not in refit.fits["held_out.ideal"]["bp"][0]
    # the two runs' metrics are the same numbers, the bp seeds' included
    assert _numbers_differ(reused.metrics, refit.metrics) == []
    ideal = [s for s in reused.scored if s.protocol == "held_out.ideal"][0]
    assert len(ideal.seed_metrics["bp"]) == 2


def test_a_fit_reused_by_another_protocol_says_what_it_is_scored_on_there(tmp_path):
    """A deterministic method fitted on the same bytes by two protocols (an in-sample one
    before the held-out one) is fitted once; the second record names its own scored runs and
    where the fit comes from; a random method's starts (seeded per protocol) are not shared."""
    import fogbench.run.runner as R

    in_sample = ('[[protocols]]\nname = "in_sample"\nin_sample = true\nfit = ["fit"]\n'
                 'score = ["fit"]\n\n[[protocols]]\nname = "held_out"')
    p = tmp_path / "static_thermal.toml"
    p.write_text(STATIC_THERMAL.replace('[[protocols]]\nname = "held_out"', in_sample))
    res = R.run_scenario(str(p))
    rec = res.fits["held_out"]["poly_temp"][0]
    assert rec["fit_reused_from"] == "in_sample"
    assert rec["scored_on"] == res.fits["held_out.ideal"]["poly_temp"][0]["scored_on"]
    assert rec["scored_on"] != res.fits["in_sample"]["poly_temp"][0]["scored_on"]
    assert "fit_reused_from" not in res.fits["held_out"]["bp"][0]


def test_a_method_whose_fit_starts_returns_garbage_is_reported_failed_and_the_run_goes_on(
        tmp_path, monkeypatch):
    """A plug-in's fit_starts that returns the wrong shape fails its starts, named, and the
    other methods are scored."""
    import fogcomp
    import fogbench.run.runner as R

    from fogcomp.methods.temperature import Bp

    class _Garbage(Bp):
        name = "test_garbage_starts"

        @classmethod
        def fit_starts(cls, models, data, reference_rate=None):
            return "not a list"

    from fogcomp import _registry

    monkeypatch.setattr(_registry, "_REGISTRY", dict(_registry._REGISTRY))   # undone after
    fogcomp.register(_Garbage)
    p = tmp_path / "static_thermal.toml"
    p.write_text(STATIC_THERMAL + '\n[[methods]]\nname = "test_garbage_starts"\n'
                 'params = { max_epochs = 5 }\n\n[montecarlo]\nmethod_seeds = 2\n')
    res = R.run_scenario(str(p), replicate=1, method_seeds=2)
    rec = res.fits["held_out"]["test_garbage_starts"][0]
    assert rec["status"] == "failed" and "fit_starts returned str" in rec["error"]
    assert res.fits["held_out"]["poly_temp"][0]["status"] == "ok"
