"""The Kalman baseline's fast path against filterpy's full loop (the reference library).

The fast path (``fogcomp.methods.kalman.local_level_filter``) runs filterpy over the transient and
the steady-state recursion after it, or the running mean's closed form when Q = 0. It must give
filterpy's estimates: the tolerance is 1e-9 of the record's standard deviation (the switch to the
steady gain happens where the posterior variance is within 1e-12 of its steady state, so the
gains differ by less than that).
"""

from __future__ import annotations

import numpy as np
import pytest

from fogcomp import GyroData
from fogcomp.methods.kalman import KalmanDenoiser, local_level_filter

FS = 100.0
TOL = 1e-9


def _record(n, q, r, seed, offset=0.0):
    rng = np.random.default_rng(seed)
    return offset + np.cumsum(rng.normal(0.0, np.sqrt(q), n)) + rng.normal(0.0, np.sqrt(r), n)


CASES = [  # (q, r): steady gain ~0.03 (short transient), ~3e-3, Q = 0 (the running mean)
    (1e-3, 1.0), (1e-5, 1.0), (0.0, 1.0)]


@pytest.mark.parametrize("q,r", CASES)
@pytest.mark.parametrize("smoother", [False, True])
@pytest.mark.parametrize("prior", ["diffuse", "carried"])
def test_the_fast_path_gives_filterpys_estimates(q, r, smoother, prior):
    n = 15_000
    z = _record(n, q, r, seed=3, offset=-1.0)
    x0, p0 = (z[0], r) if prior == "diffuse" else (0.5, 0.2 * r)
    ref, pref = local_level_filter(z, q, r, x0, p0, smoother=smoother, engine="filterpy")
    got, pgot = local_level_filter(z, q, r, x0, p0, smoother=smoother)
    assert np.max(np.abs(got - ref)) <= TOL * np.std(z)
    assert np.max(np.abs(pgot - pref) / pref) <= 1e-9


@pytest.mark.parametrize("params", [
    {}, {"smoother": True}, {"start": "carry"}, {"start": "carry", "smoother": True},
    {"rrw_rad_s_rt_s": 0.0}, {"rrw_rad_s_rt_s": 0.0, "smoother": True}])
def test_the_denoiser_gives_the_same_output_on_either_engine(params):
    """Through the method as the bench runs it (fit on one record, compensate another)."""
    fit = GyroData(rate=_record(8_000, 1e-4, 1.0, seed=5), fs=FS)
    test = GyroData(rate=_record(12_000, 1e-4, 1.0, seed=6, offset=0.3), fs=FS)
    outs = []
    for engine in ("filterpy", "fast"):
        m = KalmanDenoiser(engine=engine, **params).fit(fit)
        outs.append(m.compensate(test))
    assert np.max(np.abs(outs[1] - outs[0])) <= TOL * np.std(test.rate)


def test_an_unknown_engine_is_refused():
    with pytest.raises(ValueError, match="engine"):
        KalmanDenoiser(engine="numba").fit(GyroData(rate=_record(100, 0.0, 1.0, 1), fs=FS))


@pytest.mark.slow
@pytest.mark.parametrize("q", [1e-4, 1e-6, 0.0])
@pytest.mark.parametrize("smoother", [False, True])
def test_the_fast_path_on_a_million_samples(q, smoother):
    """Issue 23's length (``make test-all``; the 15,000-sample twins above run in ``make test``):
    10^6 samples, so that a slow drift of the steady recursion away from filterpy would show."""
    n, r = 1_000_000, 1.0
    z = _record(n, q, r, seed=11)
    ref, pref = local_level_filter(z, q, r, z[0], r, smoother=smoother, engine="filterpy")
    got, pgot = local_level_filter(z, q, r, z[0], r, smoother=smoother)
    assert np.max(np.abs(got - ref)) <= TOL * np.std(z)
    assert np.max(np.abs(pgot - pref) / pref) <= 1e-9


def _q_for_gain(k: float, r: float) -> float:
    """The process variance whose steady gain is k (from K = P-/(P- + r), P-^2 = q (P- + r))."""
    pp = k * r / (1.0 - k)
    return pp * pp / (pp + r)


@pytest.mark.parametrize("gain", [1e-1, 1e-2, 1e-3])
@pytest.mark.parametrize("smoother", [False, True])
def test_the_fast_path_is_filterpy_at_every_gain_transient_included(gain, smoother):
    """Issue 43: the transient runs as scalars, not through filterpy's 1 x 1 matrices; at steady
    gains 0.1, 0.01 and 0.001 (transients of about 140, 1,400 and 14,000 samples from a diffuse
    prior) the estimates are filterpy's to 1e-12 relative, on a record longer than the
    transient, and the transient alone is filterpy's to rounding."""
    from fogcomp.methods.kalman import _filter_scalar, _transient_length, steady_state_gain

    r = 1.0
    q = _q_for_gain(gain, r)
    assert steady_state_gain(q, r) == pytest.approx(gain, rel=1e-12)
    n = 20_000
    z = _record(n, q, r, seed=7, offset=0.4)
    assert 0 < _transient_length(q, r, 1e6, n) < n
    ref, pref = local_level_filter(z, q, r, 0.0, 1e6, smoother=smoother, engine="filterpy")
    got, pgot = local_level_filter(z, q, r, 0.0, 1e6, smoother=smoother)
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert np.max(np.abs(pgot - pref) / pref) <= 1e-11
    if not smoother:
        m = 2_000
        x, p = _filter_scalar(z[:m], q, r, 0.0, 1e6)
        assert np.max(np.abs(x - ref[:m])) <= 1e-14 * np.max(np.abs(ref[:m]))
        assert np.max(np.abs(p - pref[:m]) / pref[:m]) <= 1e-14
