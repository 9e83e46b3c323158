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
