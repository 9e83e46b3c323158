"""The MuJoCo rate table against analytic kinematics."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.earth import EARTH_RATE
from sim.motion import ConstantRate, Hold, Positions, SineRate
from sim.rate_table import TableConfig, simulate_truth

NO_EARTH = TableConfig(earth_rate=False)


def up_in_sensor(tilt, heading):
    """Unit 'up' in the FOG frame: sensor = world . Rx(tilt) . Rz(heading), so
    up_sensor = Rz(heading)^T Rx(tilt)^T e_z = (sin t sin h, sin t cos h, cos t)."""
    return np.array([math.sin(tilt) * math.sin(heading), math.sin(tilt) * math.cos(heading),
                     math.cos(tilt)])


def test_at_rest_level_accelerometer_reads_one_g_up():
    tr = simulate_truth([Hold(3.0)], 10.0, NO_EARTH)
    np.testing.assert_allclose(tr.specific_force, np.tile([0, 0, 1.0], (30, 1)), atol=1e-9)
    np.testing.assert_allclose(tr.table_rate, 0.0, atol=1e-12)


@settings(max_examples=12, deadline=None)
@given(tilt=st.floats(-180, 180), heading=st.floats(-180, 180))
def test_gravity_projection_has_norm_one_and_follows_the_angles(tilt, heading):
    t, h = math.radians(tilt), math.radians(heading)
    seg = Positions(tilts=(t,), headings=(h,), dwell=5.0, move_time=20.0,
                    max_rate=math.radians(30.0), max_accel=math.radians(60.0))
    tr = simulate_truth([seg], 10.0, TableConfig(earth_rate=False, tilt_slew=math.radians(20.0)))
    last = slice(-20, None)  # the last 2 s of the dwell: at rest
    np.testing.assert_allclose(np.linalg.norm(tr.gravity, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(tr.specific_force[last], axis=1), 1.0, atol=1e-6)
    # The table reaches the commanded angles within its servo stiffness (gravity sag < 1e-3 rad).
    expect = up_in_sensor(t, h)
    np.testing.assert_allclose(tr.specific_force[last], np.tile(expect, (20, 1)), atol=2e-3)
    np.testing.assert_allclose(tr.gravity[last], tr.specific_force[last], atol=1e-6)


def test_constant_rate_matches_command_within_servo_ripple():
    rate = math.radians(-60.0)
    tr = simulate_truth([ConstantRate(10.0, rate)], 100.0, NO_EARTH)
    steady = tr.table_rate[300:, 2]  # after spin-up (0.3 s at 200 deg/s^2) and settling
    assert abs(steady.mean() - rate) < 1e-6 * abs(rate) + 1e-9
    assert steady.std() < 1e-5 * abs(rate)
    # Tilted 90 deg with the FOG off-axis, the unbalance loads the rate servo once per turn:
    # ripple appears, but stays a small fraction of the rate and averages out.
    cfg = TableConfig(earth_rate=False, radius=0.1)
    tr = simulate_truth([Hold(6.0, tilt=math.pi / 2), ConstantRate(12.0, rate)], 100.0, cfg)
    steady = tr.table_rate[600 + 300:, 2]
    ripple = steady - rate
    assert 1e-7 < ripple.std() < 1e-3 * abs(rate)
    n_rev = int(len(steady) / 100 * abs(rate) / (2 * math.pi)) * 600  # whole revolutions
    assert abs(ripple[:n_rev].mean()) < 1e-5 * abs(rate)


def test_centripetal_specific_force_of_an_off_axis_fog():
    r, w = 0.12, math.radians(300.0)
    tr = simulate_truth([ConstantRate(5.0, w)], 100.0, TableConfig(earth_rate=False, radius=r))
    f = tr.specific_force[300:]
    # The FOG's mass off-axis loads the tilt servo once per turn: the turntable axis wobbles by
    # m g r / kp ~ 1e-4 rad, so gravity leaks into x and y at that level.
    np.testing.assert_allclose(f[:, 0], -w * w * r / 9.80665, atol=2e-4)
    np.testing.assert_allclose(f[:, 2], 1.0, atol=1e-4)


def test_tangential_specific_force_while_the_turntable_accelerates_is_alpha_r():
    """Spin-up at the table's acceleration limit alpha: the FOG r off the axis feels alpha r
    along the turntable's tangent (+y for a positive turn with the FOG on +x) and omega^2 r
    inward, omega the table's rate at that sample; after the spin-up the tangential term is 0.
    (MuJoCo's accelerometer read 0.50 g here instead of 0.036 g: the explicit joint
    acceleration under implicitfast.)"""
    r, alpha = 0.1, math.radians(200.0)
    cfg = TableConfig(earth_rate=False, radius=r, turn_accel=alpha)
    tr = simulate_truth([Hold(1.0), ConstantRate(5.0, math.radians(300.0))], 100.0, cfg)
    ramp = slice(110, 240)   # 1.1 s to 2.4 s: the rate ramps to 300 deg/s in 1.5 s
    np.testing.assert_allclose(tr.specific_force[ramp, 1], alpha * r / 9.80665, rtol=2e-3)
    # to 3e-4 g: the rate is sampled at the physics steps, the differenced velocity between
    # them, half a step apart: alpha dt omega r = 1.5e-4 g at the ramp's end (dt = 1 ms)
    w = tr.turn_rate[ramp]
    np.testing.assert_allclose(tr.specific_force[ramp, 0], -w * w * r / 9.80665, atol=3e-4)
    np.testing.assert_allclose(tr.specific_force[ramp, 2], 1.0, atol=1e-4)
    np.testing.assert_allclose(tr.specific_force[350:, 1], 0.0, atol=2e-4)


@pytest.mark.parametrize("lat_deg,heading_deg", [(45.0, 0.0), (30.0, 90.0), (-60.0, 210.0)])
def test_earth_rate_is_added_for_latitude_and_heading(lat_deg, heading_deg):
    lat, psi = math.radians(lat_deg), math.radians(heading_deg)
    tr = simulate_truth([Hold(2.0)], 10.0, TableConfig(latitude=lat, heading=psi))
    north = EARTH_RATE * math.cos(lat)
    # world x at azimuth psi, y at psi - 90 deg: north = (cos psi, sin psi) in world x, y
    expect = [north * math.cos(psi), north * math.sin(psi), EARTH_RATE * math.sin(lat)]
    np.testing.assert_allclose(tr.rate, np.tile(expect, (20, 1)), atol=1e-12)


def test_settled_hold_fast_path_equals_full_simulation():
    segs = [Hold(4.0, tilt=math.radians(30.0)), ConstantRate(2.0, 0.5), Hold(40.0)]
    fast = simulate_truth(segs, 10.0, TableConfig(radius=0.05, settle_time=5.0))
    full = simulate_truth(segs, 10.0, TableConfig(radius=0.05, settle_time=600.0))
    assert fast.settled_fast_path_s > 30.0 and full.settled_fast_path_s == 0.0
    for name, a in full.as_arrays().items():
        np.testing.assert_allclose(getattr(fast, name), a, atol=1e-9, err_msg=name)


def test_sine_rate_is_tracked_with_servo_lag_only():
    amp, f = math.radians(20.0), 0.5
    tr = simulate_truth([SineRate(8.0, amp, f)], 100.0, NO_EARTH)
    err = tr.table_rate[100:, 2] - tr.turn_rate_cmd[100:]
    # A command acts from the next physics step on: the truth lags the command by dt = 1 ms,
    # an error of amp * 2 pi f * dt on a sine; the stiff servo adds little to that.
    lag_bound = amp * 2 * math.pi * f * 1e-3
    assert np.abs(err).max() < 1.2 * lag_bound
