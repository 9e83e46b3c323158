"""Truth in a tilted, turning frame against independent rotation computations (scipy's
Rotation, a local-level ENU construction), not the expressions of sim/earth.py or rate_table.py."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sim.motion import ConstantRate, Hold
from sim.rate_table import TableConfig, simulate_truth

OMEGA_E = 7.2921150e-5  # rad/s, WGS-84 (stated here again on purpose)


def earth_in_world(lat, heading):
    """Earth rate in the table's world frame from the ENU frame: Omega = (0, W cos lat,
    W sin lat) in ENU; world x is the horizontal unit vector at azimuth `heading` from north,
    world z is up, world y = z x x."""
    w_enu = np.array([0.0, OMEGA_E * math.cos(lat), OMEGA_E * math.sin(lat)])
    x = np.array([math.sin(heading), math.cos(heading), 0.0])
    z = np.array([0.0, 0.0, 1.0])
    y = np.cross(z, x)
    return np.array([x @ w_enu, y @ w_enu, z @ w_enu])


@pytest.mark.parametrize("tilt_deg,rate_dps,fs", [(30.0, 600.0, 10.0), (-70.0, -250.0, 5.0)])
def test_earth_rate_in_a_tilted_turning_frame_is_the_mean_over_each_sample(tilt_deg, rate_dps,
                                                                            fs):
    lat, heading = math.radians(52.0), math.radians(35.0)
    cfg = TableConfig(latitude=lat, heading=heading)
    tilt, w = math.radians(tilt_deg), math.radians(rate_dps)
    tr = simulate_truth([Hold(3.0, tilt=tilt), ConstantRate(6.0, w)], fs, cfg)
    earth_part = tr.rate - tr.table_rate
    w_world = earth_in_world(lat, heading)
    k0 = int(6.0 * fs)   # from 3 s into the spin: at constant rate
    # the truth is the mean over the sample interval [k/fs, (k+1)/fs] (what a FOG integrates),
    # here by the trapezoid on a grid 4 times finer than the physics step
    nsub = 4 * int(round(1.0 / fs / cfg.physics_dt))
    sub = np.arange(nsub + 1) / (fs * nsub)
    wts = np.full(nsub + 1, 1.0 / nsub)
    wts[[0, -1]] *= 0.5
    for k in range(k0, tr.t.size):
        # start orientation from MuJoCo's quaternion (scipy wants x, y, z, w); within the sample
        # the FOG turns about its own z at the joint's mean rate (its angle change over it)
        q = tr.fog_quat[k]
        R0 = Rotation.from_quat([q[1], q[2], q[3], q[0]])
        rates = tr.turn_rate[k]
        Rs = R0 * Rotation.from_rotvec(np.outer(sub * rates, [0.0, 0.0, 1.0]))
        v = Rs.inv().apply(w_world)               # Earth rate in sensor axes at each instant
        mean = wts @ v
        np.testing.assert_allclose(earth_part[k], mean, atol=2e-4 * OMEGA_E, err_msg=f"k={k}")
    # the sample-start projection would be wrong by several deg/h on x/y here
    start = np.array([Rotation.from_quat([q[1], q[2], q[3], q[0]]).inv().apply(w_world)
                      for q in tr.fog_quat[k0:]])
    assert np.max(np.abs(start[:, :2] - earth_part[k0:, :2])) > 0.05 * OMEGA_E


def test_specific_force_on_a_tilted_spinning_table():
    """FOG at radius r on a turntable tilted by theta, spinning at w: in the FOG frame the
    accelerometer reads the centripetal -w^2 r along x plus 'up' (1 g) rotated into the
    turning frame, averaged over each sample. |f| != 1 and the direction follows."""
    r, w, theta, fs = 0.1, math.radians(240.0), math.radians(40.0), 20.0
    cfg = TableConfig(earth_rate=False, radius=r)
    tr = simulate_truth([Hold(3.0, tilt=theta), ConstantRate(8.0, w)], fs, cfg)
    g = 9.80665
    sub = np.linspace(0.0, 1.0 / fs, 401)
    ks = range(int(7.0 * fs), tr.t.size)
    expect = []
    for k in ks:
        psi = tr.turn[k] + tr.turn_rate[k] * sub        # turntable angle within the sample
        # world <- FOG: Rx(theta) Rz(psi); up in FOG axes = Rz(psi)^T Rx(theta)^T e_z
        up = np.array([Rotation.from_euler("z", -p).apply(
            Rotation.from_euler("x", -theta).apply([0, 0, 1.0])) for p in psi])
        f = up.copy()
        f[:, 0] -= w * w * r / g
        expect.append(np.trapezoid(f, sub, axis=0) * fs)
    expect = np.array(expect)
    got = tr.specific_force[list(ks)]
    # servo compliance under the spinning unbalance: ~1e-4 rad of wobble, so 2e-4 g
    np.testing.assert_allclose(got, expect, atol=2e-3)
    norm = np.linalg.norm(got, axis=1)
    assert np.max(np.abs(norm - 1.0)) > 0.05     # |f| != 1: it swings with the turn
    np.testing.assert_allclose(norm, np.linalg.norm(expect, axis=1), atol=2e-3)
