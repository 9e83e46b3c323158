"""Thermal chamber program and coil lag against the analytic first-order response."""

import math

import numpy as np
import pytest

from sim.thermal import ThermalHold, ThermalProgram, ThermalRamp, simulate_thermal


def paper002_program(tau=600.0):
    steps = [ThermalHold(3600.0)]
    for T in (-20, 0, 20, 40, 60):
        steps += [ThermalRamp(float(T), 0.2 / 60), ThermalHold(3600.0)]
    return ThermalProgram(start=-40.0, steps=tuple(steps), coil_time_constant=tau)


def test_paper002_program_duration_and_levels():
    p = paper002_program()
    # 6 holds of 1 h and 5 ramps of 20 C at 0.2 C/min (100 min each)
    assert p.duration == pytest.approx(6 * 3600 + 5 * 6000)
    t, temp = p.breakpoints()
    assert list(temp) == [-40, -40, -20, -20, 0, 0, 20, 20, 40, 40, 60, 60]


@pytest.mark.parametrize("fs", [1.0, 0.1, 7.0])
def test_coil_follows_a_ramp_with_the_analytic_first_order_lag(fs):
    """From a soak, a ramp u = u0 + s t through a lag tau gives
    x(t) = u(t) - s tau (1 - exp(-t / tau)) and dx/dt = s (1 - exp(-t / tau))."""
    tau, s = 600.0, 0.2 / 60
    p = ThermalProgram(start=-40.0, steps=(ThermalRamp(60.0, s),), coil_time_constant=tau)
    t = np.arange(0, p.duration, 1 / fs)
    th = simulate_thermal(p, t)
    expect = -40 + s * t - s * tau * (1 - np.exp(-t / tau))
    np.testing.assert_allclose(th.coil, expect, atol=1e-9)
    np.testing.assert_allclose(th.coil_rate, s * (1 - np.exp(-t / tau)), atol=1e-12)
    np.testing.assert_allclose(th.chamber, -40 + s * t, atol=1e-9)


def test_coil_decays_to_the_hold_temperature():
    tau = 300.0
    p = ThermalProgram(start=0.0, steps=(ThermalRamp(10.0, 1.0), ThermalHold(5000.0)),
                       coil_time_constant=tau)
    t = np.arange(0.0, p.duration, 1.0)
    th = simulate_thermal(p, t)
    after = t >= 10.0
    x10 = th.coil[10]
    expect = 10.0 + (x10 - 10.0) * np.exp(-(t[after] - 10.0) / tau)
    np.testing.assert_allclose(th.coil[after], expect, atol=1e-9)
    assert abs(th.coil[-1] - 10.0) < 1e-6


def test_past_the_end_the_chamber_holds():
    p = ThermalProgram(start=5.0, steps=(ThermalRamp(15.0, 0.1),), coil_time_constant=0.0)
    th = simulate_thermal(p, np.arange(0.0, 400.0, 1.0))
    assert th.chamber[-1] == 15.0 and th.coil[-1] == 15.0
    assert math.isclose(th.chamber[50], 10.0)


# ---- two thermal nodes, the Shupe bias on the coil's heat flux, the sensor -------------------
from scipy.integrate import solve_ivp  # noqa: E402

from fogcomp import units as U  # noqa: E402
from sim.fog import FogParams, simulate_fog  # noqa: E402
from sim.thermal import TempSensor, ThermalModel, read_sensor  # noqa: E402


def _ode_twin(prog, t, tau_h, tau_c):
    """Slow obvious twin: integrate the chain with scipy's solver (tight tolerances)."""
    bt, btemp = prog.breakpoints()

    def f(tt, x):
        u = np.interp(tt, bt, btemp)
        return [(u - x[0]) / tau_h, (x[0] - x[1]) / tau_c]

    sol = solve_ivp(f, (t[0], t[-1]), [btemp[0]] * 2, t_eval=t, rtol=1e-10, atol=1e-10,
                    max_step=5.0)
    return sol.y[0], sol.y[1]


@pytest.mark.parametrize("tau_h,tau_c", [(300.0, 600.0), (1200.0, 200.0), (500.0, 500.0)])
def test_two_node_chain_matches_an_ode_solver(tau_h, tau_c):
    p = ThermalProgram(start=0.0, steps=(ThermalHold(100.0), ThermalRamp(30.0, 0.5 / 60),
                                         ThermalHold(2000.0), ThermalRamp(-10.0, 1.0 / 60),
                                         ThermalHold(3000.0)))
    t = np.arange(0.0, p.duration, 2.0)
    th = simulate_thermal(p, t, ThermalModel(housing_time_constant=tau_h,
                                             coil_time_constant=tau_c))
    h, c = _ode_twin(p, t, tau_h, tau_c)
    np.testing.assert_allclose(th.housing, h, atol=2e-5)
    np.testing.assert_allclose(th.coil, c, atol=2e-5)
    # the coil's rate is its heat flux: (housing - coil) / tau_c
    np.testing.assert_allclose(th.coil_rate, (h - c) / tau_c, atol=1e-7)


def _shupe_only(th, c3=0.4, ratio=1.0):
    p = FogParams(temp_rate_coeff=c3 * U.DPH * 60, temp_rate_cooling_ratio=ratio)
    n = th.coil.size
    out = simulate_fog(p, 1.0, np.zeros((n, 3)), np.tile([0, 0, 1.0], (n, 1)), th.coil,
                       th.coil_rate, ("z",))
    return out.terms["temperature"][:, 0] / U.DPH


def test_zero_shupe_bias_for_zero_heat_flux():
    """Where housing and coil are at one temperature there is no heat flux and no Shupe bias:
    at the soak before a ramp, and at the instant the coil's temperature peaks (the housing has
    turned back and crosses it), found here from the node temperatures, not from the rate."""
    p = ThermalProgram(start=10.0, steps=(ThermalHold(500.0), ThermalRamp(30.0, 2.0 / 60),
                                          ThermalRamp(10.0, 2.0 / 60), ThermalHold(6000.0)))
    t = np.arange(0.0, p.duration, 1.0)
    th = simulate_thermal(p, t, ThermalModel(housing_time_constant=200.0,
                                             coil_time_constant=400.0))
    bias = _shupe_only(th)
    assert np.all(bias[:500] == 0.0)
    gap = th.housing - th.coil
    k = np.flatnonzero((gap[:-1] > 0) & (gap[1:] <= 0))
    assert k.size == 1
    k = int(k[0])
    # linear interpolation to the crossing: the bias there is zero to the sampling's resolution
    frac = gap[k] / (gap[k] - gap[k + 1])
    b_cross = bias[k] + frac * (bias[k + 1] - bias[k])
    assert abs(b_cross) < 1e-9
    assert np.max(np.abs(bias)) > 0.3 * 0.4 * 2.0   # and it is not zero elsewhere


def test_after_the_lag_shupe_bias_is_proportional_to_the_ramp_rate():
    """Two first-order lags in a chain follow a ramp r with dTc/dt -> r once both have settled
    (the final-value theorem on s^2 X(s) = r / ((1 + s th)(1 + s tc))): the Shupe bias -> c3 r,
    the same constant for every rate."""
    c3, out = 0.4, {}
    for r in (0.1, 0.5, 2.0):
        p = ThermalProgram(start=-20.0, steps=(ThermalRamp(-20.0 + r * 200.0, r / 60.0),))
        t = np.arange(0.0, p.duration, 1.0)
        th = simulate_thermal(p, t, ThermalModel(housing_time_constant=150.0,
                                                 coil_time_constant=300.0))
        out[r] = _shupe_only(th, c3)[-1]
    for r, b in out.items():
        assert b == pytest.approx(c3 * r, rel=1e-4)


def test_cooling_asymmetry_gives_a_hysteresis_loop():
    """Heating then cooling over the same temperatures: with a cooling ratio the bias differs
    between the two legs at the same coil temperature; without it the legs are mirror images."""
    p = ThermalProgram(start=0.0, steps=(ThermalRamp(40.0, 1.0 / 60), ThermalHold(3000.0),
                                         ThermalRamp(0.0, 1.0 / 60), ThermalHold(3000.0)))
    t = np.arange(0.0, p.duration, 1.0)
    th = simulate_thermal(p, t, ThermalModel(housing_time_constant=100.0,
                                             coil_time_constant=200.0))
    up = (t > 1500) & (t < 2300)
    down = (t > 6900) & (t < 7700)
    for ratio, expect in ((1.0, 1.0), (1.5, 1.5)):
        b = _shupe_only(th, 0.3, ratio)
        assert -b[down].mean() / b[up].mean() == pytest.approx(expect, rel=1e-3)


def test_sensor_quantises_lags_and_is_read_at_its_rate():
    t = np.arange(0.0, 3000.0, 0.1)
    node = 20.0 + 0.01 * t                          # a ramp of 0.6 C/min
    s = TempSensor(location="coil", time_constant=50.0, resolution=0.0625, rate=1.0,
                   rate_window=100.0)
    val, rate = read_sensor(node, t, s)
    steps = val / 0.0625
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    # one reading per second, held: at most one change per 10 FOG samples
    assert np.all(np.diff(val)[np.arange(t.size - 1) % 10 != 9] == 0.0)
    # after the lag the reading trails the node by rate * tau (to the resolution)
    late = t > 1000.0
    np.testing.assert_allclose(val[late], node[late] - 0.01 * 50.0, atol=0.0625 / 2 + 0.01 * 1)
    # the differenced rate recovers the ramp rate (quantisation over 100 s: 0.0625 / 100 C/s)
    np.testing.assert_allclose(rate[late & (t < 2900)], 0.01, atol=0.0625 / 100 * 1.01)


def test_sensor_noise_has_its_configured_size():
    t = np.arange(0.0, 20000.0, 1.0)
    val, _ = read_sensor(np.full(t.size, 25.0), t, TempSensor(noise=0.05), seed=3)
    assert np.std(val) == pytest.approx(0.05, rel=0.05)
