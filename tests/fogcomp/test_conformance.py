"""fogcomp.check_method: every built-in method keeps the contract, the working test plug-in
does, and each planted violation (tests/plugin_violations.py, one per rule) fails its rule with
a message saying what was wrong."""

from __future__ import annotations

import numpy as np
import pytest

import fogcomp
from fogcomp.conformance import RULES

from helpers import run_cli
from plugin_violations import PLANTED


@pytest.mark.parametrize("name", fogcomp.available_methods())
def test_every_builtin_method_keeps_the_contract(name):
    report = fogcomp.check_method(name)
    assert report.ok, str(report)
    probe = next(r for r in report.results if r.rule == "probe_1e5")
    assert probe.seconds is not None and probe.seconds > 0


def test_the_working_plugin_keeps_the_contract():
    assert fogcomp.check_method("plugin_methods:MeanBias").ok


def test_every_rule_has_a_planted_violation():
    assert set(PLANTED) == set(RULES)


@pytest.mark.parametrize("rule", RULES)
def test_a_planted_violation_fails_its_rule(rule):
    cls = PLANTED[rule]
    state = np.random.get_state()
    report = fogcomp.check_method(cls, probe_samples=60_000)
    failed = {r.rule: r.message for r in report.failures}
    assert rule in failed, str(report)
    assert failed[rule], "a failure says what was wrong"
    assert "check_method" in str(report) and "FAIL " + rule in str(report)
    after = np.random.get_state()       # the check puts numpy's global state back
    assert np.array_equal(state[1], after[1]) and state[2] == after[2]


def test_check_method_from_the_command_line():
    code, out, _ = run_cli("check-method", "plugin_methods:MeanBias", "--probe-samples", "1000")
    assert code == 0 and "every rule holds" in out
    code, out, _ = run_cli("check-method", "plugin_violations:ForgetsState")
    assert code == 1 and "FAIL save_load_exact" in out
    code, _, err = run_cli("check-method", "no_such_mod:X")
    assert code == 2 and "no module 'no_such_mod'" in err


def test_a_method_that_exits_or_hangs_fails_the_rule_and_the_check_goes_on():
    from plugin_methods import Exits, Hangs

    rep = fogcomp.check_method(Exits, probe_samples=1000)
    assert not rep.ok and "SystemExit" in next(r.message for r in rep.failures
                                               if r.rule == "fit_returns_self")
    rep = fogcomp.check_method(Hangs, probe_samples=1000, timeout_s=0.5)
    msg = next(r.message for r in rep.failures if r.rule == "fit_returns_self")
    assert "did not finish within 0.5 s" in msg
