"""The bias filter a noise model implies, and its consistency tests (fogcomp.consistency):
checked against the discrete Riccati solution, Van Loan's discretisation, the chi-square law of
the NEES over Monte Carlo runs of the filter's own model, a simulated record missing a term, and
the ADIS16405 log."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from fogcomp.consistency import (BiasFilterModel, clopper_pearson, flicker_as_gm, held_out,
                                 nees_test, nis_scales, run_filter, track_indices, van_loan)
from fogcomp.units import DEG_RT_H, DPH, DPH_RT_H
from tests.helpers import need_realdata, realdata_dir


def _steady(model, n):
    r = run_filter(model, np.zeros(n))
    return r


def test_white_plus_random_walk_converges_to_the_riccati_solution():
    fs = 100.0
    m = BiasFilterModel(fs=fs, N=0.01, K=1e-2, bias_prior=0.01)
    mats = m.matrices()
    r = _steady(m, 4000)
    F, Q, H, R = mats["F"], mats["Qd"], mats["H"][None, :], np.array([[mats["Rm"]]])
    X = solve_discrete_are(F.T, H.T, Q, R)             # the a-priori steady covariance
    assert r.S[0, -1] == pytest.approx((H @ X @ H.T)[0, 0] + R[0, 0], rel=1e-9)
    post = X - X @ H.T @ np.linalg.inv(H @ X @ H.T + R) @ H @ X
    assert r.bias_var[0, -1] == pytest.approx(post[0, 0], rel=1e-9)


def test_three_states_converge_to_the_riccati_solution():
    m = BiasFilterModel(fs=50.0, N=0.02, K=2e-2, gm=((0.01, 2.0), (0.005, 0.5)))
    mats = m.matrices()
    r = _steady(m, 6000)
    F, Q, H, R = mats["F"], mats["Qd"], mats["H"][None, :], np.array([[mats["Rm"]]])
    X = solve_discrete_are(F.T, H.T, Q, R)
    assert r.S[0, -1] == pytest.approx((H @ X @ H.T)[0, 0] + R[0, 0], rel=1e-8)


def test_closed_forms_are_van_loans_discretisation():
    fs, K, s, T, R = 20.0, 3e-3, 0.02, 4.0, 1e-4
    m = BiasFilterModel(fs=fs, N=0.01, K=K, R=R, gm=((s, T),))
    mats = m.matrices()
    # continuous time: b' = r + w_K, r' = 0, g' = -g/T + w_g (density 2 s^2 / T)
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0 / T]])
    Qc = np.diag([K * K, 0.0, 2.0 * s * s / T])
    F, Qd = van_loan(A, Qc, 1.0 / fs)
    np.testing.assert_allclose(mats["F"], F, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(mats["Qd"], Qd, rtol=1e-9, atol=1e-20)


def _simulate_own_model(model, n, reps, rng):
    """Records drawn from the filter's own discrete model (prior, process and measurement noise
    as the filter states them): states (reps, n, d) and measurements (reps, n)."""
    mt = model.matrices()
    F, Q, P0, H, Rm = mt["F"], mt["Qd"], mt["P0"], mt["H"], mt["Rm"]
    d = F.shape[0]
    LQ = np.linalg.cholesky(Q + 1e-300 * np.eye(d))
    x = rng.standard_normal((reps, d)) @ np.linalg.cholesky(P0).T
    xs = np.empty((reps, n, d))
    z = np.empty((reps, n))
    for k in range(n):
        x = x @ F.T + rng.standard_normal((reps, d)) @ LQ.T
        xs[:, k] = x
        z[:, k] = x @ H + rng.standard_normal(reps) * math.sqrt(Rm)
    return xs, z


def test_nees_of_a_consistent_filter_has_the_chi_square_mean():
    """Full-state NEES of the filter over runs of its own model: mean d (= 2), inside the
    chi-square band of R runs (chi2(R d) / R, 99.9 %) at each tracked time."""
    from scipy.stats import chi2

    rng = np.random.default_rng(44)
    m = BiasFilterModel(fs=10.0, N=0.01, K=1e-3, gm=((0.01, 5.0),), bias_prior=0.02)
    reps, n = 400, 600
    xs, z = _simulate_own_model(m, n, reps, rng)
    tr = np.array([50, 200, 599])
    r = run_filter([m] * reps, z, track=tr)
    e = xs[:, tr] - r.x_track                                   # (reps, 3, 2)
    nees = np.einsum("rti,rtij,rtj->rt", e, np.linalg.inv(r.P_track), e)
    mean = nees.mean(axis=0)
    lo, hi = chi2.ppf([0.0005, 0.9995], reps * 2) / reps
    assert np.all((mean > lo) & (mean < hi)), (mean, lo, hi)
    # and the time-averaged NEES of the bias is inside its own band in about 95 % of runs
    tr2 = track_indices(n, 100)
    r2 = run_filter([m] * 200, z[:200], track=tr2)
    res = nees_test(r2, xs[:200, :, 0] + xs[:200, :, 1])
    inside = sum(v == "consistent" for v in res.verdict)
    lo_cp, hi_cp = clopper_pearson(inside, 200, 0.999)
    assert lo_cp <= 0.95 <= hi_cp, inside


def test_a_filter_missing_a_gauss_markov_term_is_flagged():
    """A 1 h record at 10 Hz of white noise plus a Gauss-Markov drift (the static_gm device),
    simulated by the project's FOG error model: the filter without the drift is overconfident
    in every record, the one with it consistent in most."""
    from sim.fog import FogParams, simulate_fog

    fs, n = 10.0, 36000
    N, s, T = 0.03 * DEG_RT_H, 0.5 * DPH, 100.0
    p = FogParams(arw=N, gm_drift=s, gm_time_constant=T)
    z, tb = [], []
    for r in range(6):
        o = simulate_fog(p, fs, np.zeros((n, 3)), np.zeros((n, 3)), seed=4400 + r)
        z.append(o.raw[:, 0])
        tb.append(o.terms["gm_drift"][:, 0])
    true = BiasFilterModel(fs=fs, N=N, gm=((s, T),))
    run = run_filter([true] * 6 + [true.without_gm()] * 6, np.vstack([z, z]),
                     track=track_indices(n, 100))
    res = nees_test(run, np.vstack([tb, tb]))
    assert res.verdict[6:] == ["overconfident"] * 6
    assert sum(v == "consistent" for v in res.verdict[:6]) >= 5


def test_flicker_approximation_matches_the_floor():
    taus = 2.0 ** np.arange(0, 14) / 100.0
    gm, err = flicker_as_gm(30 * DPH, 100.0, taus)
    assert err < 0.1 and len(gm) >= 4


def test_nis_scales_of_white_innovations():
    u = np.random.default_rng(1).standard_normal(2**14)
    L, st, dof = nis_scales(u)
    assert L[0] == 1 and dof[0] == 2**14 and dof[-1] >= 16
    assert np.all(np.abs(st - 1) < 5 * np.sqrt(2.0 / dof))


def test_refuses_a_model_without_white_noise():
    with pytest.raises(ValueError, match="N: the filter needs"):
        BiasFilterModel(fs=10.0, N=0.0, K=1e-3)


def test_adis16405_held_out_inflation():
    """The ADIS16405 static log (its x gyro, the first 100,000 samples: identified on 50,000,
    filtered on 50,000): the interval is ordered, and the identified model's verdict at f = 1
    agrees with where the interval's lower end lies."""
    path = realdata_dir() / "adis16405_static" / "imu1.csv.gz"
    need_realdata(path)
    import pandas as pd

    df = pd.read_csv(path, nrows=100_000)
    rate = np.deg2rad(df["gyro_x_dps"].to_numpy())
    h = held_out(rate, 100.0, terms=("all",), grid=np.geomspace(0.5, 50, 15))
    r = h.inflation["all"]
    assert r.f_low <= r.f_hat <= r.f_high
    assert r.consistent_at_1 == (r.f_low <= 1.0 <= r.f_high)


def test_a_device_file_gives_its_filter(tmp_path):
    """The tactical preset's ARW and RRW, converted by hand, and a Gauss-Markov drift."""
    from fogbench.device.filter import filter_model

    dev = tmp_path / "dev.toml"
    dev.write_text('source = "test"\narw_deg_rt_h = 0.03\nrrw_dph_rt_h = 0.1\n'
                   'gm_drift_dps = 0.00013888889\ngm_time_constant_s = 100.0\n')
    m = filter_model(dev, 10.0)
    assert m.N == pytest.approx(0.03 * DEG_RT_H, rel=1e-9)
    assert m.K == pytest.approx(0.1 * DPH_RT_H, rel=1e-9)
    assert m.gm[0][0] == pytest.approx(0.5 * DPH, rel=1e-6) and m.gm[0][1] == 100.0
    assert m.states == ["b", "gm0"]


def test_batched_inflation_factors_equal_one_at_a_time():
    from fogcomp.consistency import inflation_factor, inflation_factors

    rng = np.random.default_rng(3)
    m = BiasFilterModel(fs=10.0, N=0.01, K=1e-3, gm=((0.01, 5.0),))
    zs = rng.standard_normal((2, 3000)) * 0.05
    grid = np.geomspace(0.5, 20, 9)
    batch = inflation_factors([m, m.inflated(2.0)], zs, grid=grid)
    one = [inflation_factor(m, [zs[0]], grid=grid), inflation_factor(m.inflated(2.0), [zs[1]],
                                                                     grid=grid)]
    for b, o in zip(batch, one):
        assert (b.f_low, b.f_hat, b.f_high) == pytest.approx((o.f_low, o.f_hat, o.f_high),
                                                             rel=1e-12)
        np.testing.assert_allclose(b.nis_grid, o.nis_grid, rtol=1e-12)
