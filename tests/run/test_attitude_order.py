"""The suite summary's ranking of methods by a rate metric and by attitude (issue 42): best
first, a percentage improvement ranked largest first, a method scored on fewer runs not ranked
beside full means but named. Checked on a hand-made summary whose orders are known."""

from __future__ import annotations

from types import SimpleNamespace

from fogbench.run.suite import _attitude_order_lines


def _sm(mean, runs=None):
    d = {"n": 20, "mean": mean}
    if runs:
        d["runs"] = runs
    return d


def _mc(rate_metric, rows):
    return {"over_runs": {"p": {lab: {rate_metric: _sm(r, part), "angle_error_max_deg": _sm(a)}
                                for lab, (r, a, part) in rows.items()}}}


def test_orders_best_first_and_names_what_moved():
    mc = _mc("rmse_dph", {"raw": (3.0, 0.9, None), "a": (1.0, 0.5, None), "b": (2.0, 0.2, None)})
    line = _attitude_order_lines(mc, SimpleNamespace(claims=[]))[2]
    assert "by rmse_dph: a, b, raw; by angle_error_max_deg: b, a, raw" in line
    assert "a 1 -> 2" in line and "b 2 -> 1" in line


def test_an_improvement_is_ranked_largest_first():
    claim = SimpleNamespace(metric="improvement_rmse_pct")
    mc = _mc("improvement_rmse_pct", {"a": (80.0, 0.1, None), "b": (20.0, 0.4, None)})
    line = _attitude_order_lines(mc, SimpleNamespace(claims=[claim]))[2]
    assert "by improvement_rmse_pct: a, b;" in line and "(the same order)" in line


def test_a_method_on_fewer_runs_is_named_not_ranked():
    mc = _mc("rmse_dph", {"a": (1.0, 0.5, None), "b": (2.0, 0.2, None),
                          "c": (0.1, 0.01, ["run1"])})
    line = _attitude_order_lines(mc, SimpleNamespace(claims=[]))[2]
    assert "by rmse_dph: a, b;" in line and "not ranked (scored on fewer runs): c" in line
