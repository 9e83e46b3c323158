"""Issue 43: paper 002's gradient-descent starts trained together (``Bp.fit_starts``) against
the one-by-one fits as the slow twin, and the default ``fit_starts`` of any method."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fogcomp
from fogcomp import GyroData


def _thermal_record(n=516, seed=1):
    rng = np.random.default_rng(seed)
    T = np.linspace(-40.0, 60.0, n)
    Tr = np.gradient(T) + 0.01 * np.sin(np.arange(n) / 20.0)
    rate = 1e-6 * (0.3 * T + 0.002 * T ** 2 + 50.0 * Tr) + 1e-7 * rng.standard_normal(n)
    return GyroData(rate=rate, fs=0.01, temp=T, temp_rate=Tr), np.zeros(n)


@pytest.mark.parametrize("name,params", [("bp", {}), ("aco_bp", {}),
                                         ("aco_bp", {"search": "random"}),
                                         ("bp", {"precision": "float64", "max_epochs": 200}),
                                         ("bp", {"learning_rate": 50.0, "max_epochs": 50})])
def test_starts_trained_together_are_the_starts_trained_one_by_one(name, params):
    """Every start's weights, loss curve, stop and warnings are those of its own fit (the
    array program sums in another order only where float32 rounding would show: here none
    does), a diverging start included (learning rate 50: fails alone as together)."""
    data, ref = _thermal_record()
    K = 6
    alone = []
    for k in range(K):
        m = fogcomp.make_method(name, random_state=100 + k, **params)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                m.fit(data, ref)
                err = None
            except fogcomp.DivergenceError as exc:
                err = str(exc)
        alone.append((m, err, sorted(str(w.message) for w in caught)))
    models = [fogcomp.make_method(name, random_state=100 + k, **params) for k in range(K)]
    outcomes = type(models[0]).fit_starts(models, data, ref)
    assert len(outcomes) == K
    if params.get("learning_rate") == 50.0:
        assert all(err is not None for _, err, _ in alone)     # the case it is there for
    for (m1, err1, w1), m2, (exc, w2) in zip(alone, models, outcomes):
        assert (None if exc is None else str(exc)) == err1
        assert sorted(str(w.message) for w in w2) == w1
        if err1 is None:
            np.testing.assert_array_equal(m2.params_, m1.params_)
            np.testing.assert_array_equal(m2.loss_curve_, m1.loss_curve_)
            assert m2.stop_reason_ == m1.stop_reason_
            np.testing.assert_array_equal(m2.compensate(data), m1.compensate(data))


def test_lm_starts_and_mixed_settings_fall_back_to_one_by_one():
    data, ref = _thermal_record()
    models = [fogcomp.make_method("bp", training="lm", max_epochs=20, random_state=k)
              for k in range(3)]
    outcomes = type(models[0]).fit_starts(models, data, ref)
    alone = fogcomp.make_method("bp", training="lm", max_epochs=20, random_state=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone.fit(data, ref)
    assert all(exc is None for exc, _ in outcomes)
    np.testing.assert_array_equal(models[2].params_, alone.params_)


def test_a_start_whose_checks_fail_fails_alone():
    """A start that cannot start (no seed) fails with its own message in the batch; the
    others train."""
    data, ref = _thermal_record()
    models = [fogcomp.make_method("bp", max_epochs=10, random_state=k) for k in range(3)]
    models[1].random_state = None
    outcomes = type(models[0]).fit_starts(models, data, ref)
    assert outcomes[0][0] is None and outcomes[2][0] is None
    assert "random_state is None" in str(outcomes[1][0])


def test_a_subclass_with_its_own_training_is_fitted_one_by_one():
    """A plug-in that subclasses Bp and trains its own way gets its own code, not Bp's batch."""
    data, ref = _thermal_record()
    calls = []

    from fogcomp.methods.temperature import Bp

    class MyBp(Bp):
        name = "test_my_bp"

        def _train(self, theta, x, t):
            calls.append(self.random_state)
            super()._train(theta, x, t)

    models = [MyBp(max_epochs=5, random_state=k) for k in range(3)]
    outcomes = MyBp.fit_starts(models, data, ref)
    assert all(exc is None for exc, _ in outcomes) and calls == [0, 1, 2]


def test_aco_bp_starts_are_batched():
    """AcoBp (its own start search, Bp's training) takes the batched path: the colony runs per
    start, the descents together (no per-start _train call)."""
    data, ref = _thermal_record()
    models = [fogcomp.make_method("aco_bp", max_epochs=5, aco_iter=2, random_state=k)
              for k in range(3)]
    seen = []
    for m in models:
        m._train = lambda *a, m=m: seen.append(m)   # would be called one by one
    outcomes = type(models[0]).fit_starts(models, data, ref)
    assert all(exc is None for exc, _ in outcomes) and seen == []
