"""fogcomp.check_method: every built-in method keeps the contract, the working test plug-in
does, and each planted violation (tests/plugin_violations.py, one per rule) fails its rule with
a message saying what was wrong."""

from __future__ import annotations

import time

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


def test_an_in_place_change_of_the_input_fails_its_rule_whatever_ran_before():
    """Every rule gets records of its own: a fit that centres the caller's rate in place
    cannot hide behind an earlier rule that changed the shared record first."""
    from plugin_methods import MutatesInput

    rep = fogcomp.check_method(MutatesInput, probe_samples=1000)
    failed = {r.rule: r.message for r in rep.failures}
    assert "inputs_not_modified" in failed, str(rep)
    assert "modified the input array 'rate' in place" in failed["inputs_not_modified"]


def test_os_exit_and_a_methods_own_keyboard_interrupt_fail_rules_not_the_process():
    from plugin_methods import HardExits, RaisesInterrupt

    rep = fogcomp.check_method(HardExits, probe_samples=1000)
    msg = {r.rule: r.message for r in rep.failures}["fit_returns_self"]
    assert "MethodExit" in msg and "os._exit(0)" in msg
    rep = fogcomp.check_method(RaisesInterrupt, probe_samples=1000)
    msg = {r.rule: r.message for r in rep.failures}["fit_returns_self"]
    assert "KeyboardInterrupt (not a Ctrl-C" in msg


def test_a_hanging_method_costs_one_timeout_and_every_rule_is_said_as_it_ends():
    t0 = time.monotonic()
    code, out, err = run_cli("check-method", "plugin_methods:Hangs", "--rule-timeout-s", "0.5",
                             "--probe-samples", "1000")
    assert code == 1 and time.monotonic() - t0 < 30
    assert "did not finish within 0.5 s" in out
    assert "not checked: rule fit_returns_self did not finish within 0.5 s" in out
    progress = [ln for ln in err.splitlines() if ln.lstrip().startswith("[")]
    assert len(progress) == len(RULES) and progress[0].lstrip().startswith("[1/10] ok")
    code, out, _ = run_cli("check-method", "plugin_methods:HardExits", "--quiet")
    assert code == 1 and "os._exit(0)" in out
