"""Method sweeps (bands over a baseline's settings) and bounds relative to another row."""

from __future__ import annotations

import pytest

from fogbench.scenario.load import RUNNER_SECTIONS
from fogbench.scenario import ScenarioError, load_plan, load_scenario
from fogbench.run.suite import check_bounds

BASE = """
[scenario]
name = "sw"
sample_rate_hz = 50.0
[fog]
preset = "tactical"
[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "rate"
rate_dps = 10.0
duration_s = 20.0
[[runs]]
name = "b"
seed = 2
[[runs.motion]]
type = "rate"
rate_dps = 10.0
duration_s = 20.0
[[protocols]]
name = "p"
fit = ["a"]
score = ["b"]
[[methods]]
name = "wavelet_soft"
label = "ws"
SWEEP
[[bounds]]
protocol = "p"
method = "ws"
metric = "rmse_dph"
relative_to = "raw"
max = 1.0
"""


def plan_of(tmp_path, sweep):
    p = tmp_path / "s.toml"
    p.write_text(BASE.replace("SWEEP", sweep))
    return p, load_plan(load_scenario(p, extra_sections=RUNNER_SECTIONS))


def test_a_sweep_expands_to_every_combination_with_safe_labels(tmp_path):
    _, plan = plan_of(tmp_path, 'sweep = { level = [3, 4], threshold = ["universal", "sure"] }')
    labels = [m.label for m in plan.methods]
    assert labels == ["ws.level-3.threshold-universal", "ws.level-3.threshold-sure",
                      "ws.level-4.threshold-universal", "ws.level-4.threshold-sure"]
    assert {m.group for m in plan.methods} == {"ws"}
    assert plan.methods[3].params == {"level": 4, "threshold": "sure"}
    # the default threshold is "universal", the default level is not swept here: no member
    # carries every default, so none is flagged as the paper's setting
    assert not any(m.paper_setting for m in plan.methods)
    _, plan = plan_of(tmp_path, 'sweep = { threshold = ["sure", "universal"] }')
    assert [m.paper_setting for m in plan.methods] == [False, True]


def test_default_in_a_sweep_is_the_constructor_default(tmp_path):
    """``"default"`` stands for a default TOML cannot write (wavelet_soft's level = None, the
    deepest level the record allows): the member gets no value for the key, is labelled
    "level-default" and, with the other keys at their defaults, is the paper's setting. Run,
    it equals the method with no parameters (the deepest level, not any fixed one)."""
    import numpy as np

    import fogcomp
    from fogcomp import GyroData

    _, plan = plan_of(tmp_path, 'sweep = { level = [3, "default"], '
                                'threshold = ["universal", "sure"] }')
    by = {m.label: m for m in plan.methods}
    m = by["ws.level-default.threshold-universal"]
    assert m.params == {"threshold": "universal"} and m.paper_setting
    assert not by["ws.level-default.threshold-sure"].paper_setting
    assert not by["ws.level-3.threshold-universal"].paper_setting
    x = np.random.default_rng(0).normal(size=1000)
    d = GyroData(rate=x, fs=100.0)
    a = fogcomp.make_method("wavelet_soft", **m.params).fit(d).compensate(d)
    b = fogcomp.make_method("wavelet_soft").fit(d).compensate(d)
    c = fogcomp.make_method("wavelet_soft", level=3).fit(d).compensate(d)
    assert np.array_equal(a, b) and not np.allclose(a, c)


@pytest.mark.parametrize("sweep,words", [
    ('sweep = { threshold = ["default", "universal"] }', ["sweep", "threshold", "same"]),
    ('sweep = { levels = [3] }', ["sweep", "levels", "not a hyperparameter"]),
    ('sweep = { level = 3 }', ["sweep", "non-empty list"]),
    ('sweep = { level = [3, 3] }', ["sweep", "distinct"]),
    ('sweep = { level = ["four"] }', ["sweep", "level", "four"]),
    ('params = { level = 3 }\nsweep = { level = [3, 4] }', ["sweep", "both"]),
    ('sweep = { level = [1, 2, 3, 4, 5, 6, 7, 8, 9], threshold = ["sure", "universal"], '
     'wavelet = ["db1", "db2", "db3", "db4"] }', ["sweep", "combinations"]),
])
def test_bad_sweeps_are_refused_naming_the_key(tmp_path, sweep, words):
    with pytest.raises(ScenarioError) as exc:
        plan_of(tmp_path, sweep)
    msg = str(exc.value)
    assert "[[methods]]" in msg
    for w in words:
        assert w in msg, msg


def _doc(raw, members):
    runs = {"b": {"raw": {"rmse_dph": raw}, **{k: {"rmse_dph": v} for k, v in members.items()}}}
    return {"protocols": {"p": {"runs": runs}}}


def test_a_relative_bound_holds_for_every_member_of_a_sweep(tmp_path):
    _, plan = plan_of(tmp_path, 'sweep = { level = [3, 4] }')
    ok = _doc(10.0, {"ws.level-3": 9.0, "ws.level-4": 10.0})
    assert check_bounds("sw", plan, ok) == []
    bad = check_bounds("sw", plan, _doc(10.0, {"ws.level-3": 9.0, "ws.level-4": 12.5}))
    assert len(bad) == 1 and "ws.level-4" in bad[0] and "1.25 x raw" in bad[0]
    # with replicates the bound is checked on the mean over replicates
    mc_doc = {"protocols": {}, "montecarlo": {"summary": {"p": {"b": {
        "raw": {"rmse_dph": {"n": 5, "n_failed": 0, "mean": 10.0}},
        "ws.level-3": {"rmse_dph": {"n": 5, "n_failed": 0, "mean": 11.0}},
        "ws.level-4": {"rmse_dph": {"n": 4, "n_failed": 1, "mean": 8.0}}}}}}}
    bad = check_bounds("sw", plan, mc_doc)
    assert len(bad) == 2 and "1.1 x raw" in bad[0] and "failed in 1 replicate" in bad[1]
