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
    # the fitted rate recovers the ramp rate: without noise the reading's error is its rounding,
    # |d| <= q / 2, and the least-squares slope of it over 101 readings is at most
    # q / 2 sum |w_j| (w_j the slope's weights): 9.3e-4 C/s (seen: 4e-5, the sawtooth averages)
    full = late & (t < 2900)
    np.testing.assert_allclose(rate[full], 0.01, atol=0.0625 / 2 * _sum_abs_w(101, 1.0))


def test_sensor_noise_has_its_configured_size():
    t = np.arange(0.0, 20000.0, 1.0)
    val, _ = read_sensor(np.full(t.size, 25.0), t, TempSensor(noise=0.05), seed=3)
    assert np.std(val) == pytest.approx(0.05, rel=0.05)


# ---- dT/dt: the least-squares slope of the readings over the rate window --------------------
from scipy.stats import chi2, norm  # noqa: E402

from sim.thermal import window_slope  # noqa: E402

Q = 0.0625   # a 12-bit sensor's LSB, C


def _s_tt(n, dt):
    """sum (t - tbar)^2 over n readings dt apart: the least-squares slope of readings with
    independent errors of variance s^2 has variance s^2 / S_tt."""
    return dt * dt * n * (n * n - 1) / 12.0


def _sum_abs_w(n, dt):
    """sum |w_j| of the slope's weights w_j = (t_j - tbar) / S_tt: a worst-case gain for an error
    bounded by a constant (the rounding, |d| <= q / 2)."""
    j = np.arange(n) * dt
    return np.abs(j - j.mean()).sum() / _s_tt(n, dt)


def _reading_variance(c, sigma, q):
    """Exact variance of one reading round((c + e) / q) q, e ~ N(0, sigma^2), of a constant c."""
    k = np.arange(np.floor((c - 10 * sigma) / q) - 1, np.ceil((c + 10 * sigma) / q) + 2)
    p = norm.cdf((k * q + q / 2 - c) / sigma) - norm.cdf((k * q - q / 2 - c) / sigma)
    mu = np.sum(p * k * q)
    return float(np.sum(p * (k * q - mu) ** 2))


@pytest.mark.parametrize("level", [20.0, 20.02])
def test_constant_temperature_reads_zero_rate_within_its_standard_error(level):
    """A constant read with noise and rounding: the readings are independent with the exact
    variance s^2 of a rounded normal (on a step, 20.000 C, the rounding hides most of the noise;
    between steps it adds to it). Disjoint windows of n = 61 readings give independent slopes of
    mean 0 and variance s^2 / S_tt: their mean is 0 within 3 standard errors and their scatter
    is s^2 / S_tt within the chi-square 0.1 %..99.9 % range."""
    sigma, fs = 0.02, 1.0
    t = np.arange(0.0, 40000.0, 1.0 / fs)
    s = TempSensor(noise=sigma, resolution=Q, rate=fs, rate_window=60.0)
    val, rate = read_sensor(np.full(t.size, level), t, s, seed=11)
    n = 61
    idx = np.arange(n // 2, t.size - n // 2, n)          # centres of disjoint full windows
    r = rate[idx]
    var = _reading_variance(level, sigma, Q) / _s_tt(n, 1.0 / fs)
    assert np.var(val) == pytest.approx(_reading_variance(level, sigma, Q), rel=0.1)
    se = math.sqrt(var / r.size)
    assert abs(r.mean()) < 3 * se
    m = r.size
    ratio = np.var(r, ddof=1) / var
    assert chi2.ppf(0.001, m - 1) / (m - 1) < ratio < chi2.ppf(0.999, m - 1) / (m - 1)
    # the mean over every sample is 0 within the same kind of error (it is a weighted sum of the
    # readings; the sample slopes overlap, so this is a loose check: 3 standard errors of one)
    assert abs(rate.mean()) < 3 * math.sqrt(var)
    # and without noise a constant reads exactly zero, interior and ends
    _, r0 = read_sensor(np.full(t.size, level), t, TempSensor(resolution=Q, rate_window=60.0))
    assert np.all(r0 == 0.0)


def test_record_shorter_than_the_window_gets_the_whole_records_slope():
    """The review's case (paper000_wnn, test_m90): 12 readings of a constant 20.000 C at 1 Hz
    with a 60 s window. Each sample gets the least-squares slope of the whole record (one value
    per record), of mean 0 and standard deviation s sqrt(12 / (n (n^2 - 1))) / dt; the old
    end-to-end difference gave 0.0625 C / 11 s = 0.34 C/min for one flipped end reading."""
    sigma, n = 0.02, 12
    t = np.arange(0.0, n, 0.01)                           # 100 Hz FOG samples, 1 Hz readings
    s = TempSensor(noise=sigma, resolution=Q, rate=1.0, rate_window=60.0)
    sd = math.sqrt(_reading_variance(20.0, sigma, Q) / _s_tt(n, 1.0))
    rates = []
    for seed in range(3000):
        val, rate = read_sensor(np.full(t.size, 20.0), t, s, seed=seed)
        assert np.all(rate == rate[0])
        readings = val[::100]
        assert rate[0] == pytest.approx(np.polyfit(np.arange(n), readings, 1)[0], abs=1e-12)
        rates.append(rate[0])
    rates = np.array(rates)
    assert abs(rates.mean()) < 3 * sd / math.sqrt(rates.size)
    assert rates.std(ddof=1) == pytest.approx(sd, rel=0.1)
    # one end reading one step low: (n - 1) / 2 * q / S_tt, not q / ((n - 1) dt)
    v = np.full(n, 20.0)
    v[-1] -= Q
    assert window_slope(v, 1.0, 30)[0] == pytest.approx(-5.5 * Q / 143.0, abs=1e-15)


def test_ramp_slope_is_recovered_within_its_analytic_error():
    """A ramp of slope b read with noise sigma and rounding q: the reading is b t + e + d with
    d the rounding error. Where the ramp crosses several steps per window and the noise dithers
    the rounding (sigma ~ q / 3 here), d behaves as independent uniform noise of variance
    q^2 / 12 (Widrow's model): the slope's error has mean 0 and variance
    (sigma^2 + q^2 / 12) / S_tt. Without that model, |d| <= q / 2 always, so every window's
    error is at most q / 2 sum |w_j| plus the noise's sigma sqrt(1 / S_tt) times 5."""
    sigma, b = 0.02, 0.0093                              # 0.56 C/min, 1.5 steps per 10 s
    fs, rd = 10.0, 1.0                                   # 10 Hz samples, 1 Hz readings
    t = np.arange(0.0, 40000.0, 1.0 / fs)
    s = TempSensor(noise=sigma, resolution=Q, rate=rd, rate_window=100.0)
    _, rate = read_sensor(20.0 + b * t, t, s, seed=4)
    r = rate[:: int(fs / rd)]                            # one per reading
    n = 101
    var = (sigma ** 2 + Q ** 2 / 12) / _s_tt(n, 1.0 / rd)
    idx = np.arange(n // 2, r.size - n // 2, n)
    e = r[idx] - b
    assert abs(e.mean()) < 3 * math.sqrt(var / e.size)
    m = e.size
    ratio = np.var(e, ddof=1) / var
    assert chi2.ppf(0.001, m - 1) / (m - 1) < ratio < chi2.ppf(0.999, m - 1) / (m - 1)
    # the worst-case bound, at every reading (the windows cut at the ends included)
    k = np.arange(r.size)
    nk = np.minimum(k + n // 2, r.size - 1) - np.maximum(k - n // 2, 0) + 1
    bound = np.array([Q / 2 * _sum_abs_w(int(c), 1.0) + 5 * sigma / math.sqrt(_s_tt(int(c), 1.0))
                      for c in nk])
    assert np.all(np.abs(r - b) <= bound)


def _slope_twin(v, dt, half):
    """Slow obvious twin: numpy.polyfit of a straight line in every window, cut at the ends."""
    m = v.size
    t = np.arange(m) * dt
    out = np.empty(m)
    for k in range(m):
        lo, hi = max(0, k - half), min(m - 1, k + half)
        out[k] = np.polyfit(t[lo:hi + 1], v[lo:hi + 1], 1)[0]
    return out


@pytest.mark.parametrize("m,half", [(2, 1), (3, 1), (12, 30), (40, 3), (61, 30), (62, 30),
                                    (300, 20), (400, 90)])
def test_window_slope_matches_a_polyfit_per_sample(m, half):
    rng = np.random.default_rng(m * 1000 + half)
    v = 20.0 + 0.01 * np.arange(m) + rng.standard_normal(m) * 0.05
    v = np.round(v / Q) * Q
    for dt in (1.0, 0.25):
        np.testing.assert_allclose(window_slope(v, dt, half), _slope_twin(v, dt, half),
                                   rtol=0, atol=1e-12)


def test_a_zero_window_is_the_central_difference_of_neighbours():
    """rate_window 0: the central difference of the neighbouring readings, adjacent at the ends
    (the README's "0: the neighbouring readings")."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 50.0, 1.0)
    node = 20.0 + rng.standard_normal(t.size)
    val, rate = read_sensor(node, t, TempSensor())
    np.testing.assert_allclose(rate[1:-1], (val[2:] - val[:-2]) / 2.0, atol=1e-13)
    assert rate[0] == pytest.approx(val[1] - val[0])
    assert rate[-1] == pytest.approx(val[-1] - val[-2])
