"""Strapdown attitude (fogcomp.attitude) against motions whose answer is known in closed form.

Frames: NED navigation frame, attitude C^n_b (body -> NED) as scipy Rotations. Each truth here
is built independently of the integrator: closed-form attitudes and the exact integrals of their
body rates over each sample.
"""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fogcomp.attitude import (
    attitude_error_summary,
    attitude_errors,
    coning_drift_rate,
    earth_rate_ned,
    gyrocompass,
    inertial_attitude,
    integrate_attitude,
    orientation_error,
)

OMEGA_E = 7.2921150e-5   # rad/s, WGS-84 (stated again on purpose)
DPH = math.radians(1.0) / 3600.0
ARCSEC = math.radians(1.0) / 3600.0


def static_increments(C, lat, fs, n):
    """A body at rest on the Earth at attitude C (body -> NED): the gyros read C^T omega_ie."""
    w_b = C.inv().apply([OMEGA_E * math.cos(lat), 0.0, -OMEGA_E * math.sin(lat)])
    return np.tile(w_b / fs, (n, 1))


def test_earth_rate_ned_is_north_and_up():
    lat = math.radians(45.0)
    w = earth_rate_ned(lat)
    np.testing.assert_allclose(w, [OMEGA_E / math.sqrt(2), 0.0, -OMEGA_E / math.sqrt(2)])


def test_a_static_body_with_perfect_gyros_keeps_its_attitude():
    lat, fs, n = math.radians(52.0), 10.0, 36_000   # 1 h
    C0 = Rotation.from_euler("ZYX", [0.7, 0.1, -0.2])
    est = integrate_attitude(C0, static_increments(C0, lat, fs, n), fs, latitude=lat)
    assert orientation_error(est, Rotation.concatenate([C0] * (n + 1))).max() < 1e-3 * ARCSEC


def test_a_static_body_seen_from_inertial_space_turns_with_the_earth():
    """Integrated without removing the Earth's rate, a static body's gyros give its inertial
    attitude: the local-level attitude carried round the Earth's axis (an independent route to
    the Earth-rate handling of the local-level integration)."""
    lat, fs, n = math.radians(-33.0), 1.0, 6 * 3600
    C0 = Rotation.from_euler("ZYX", [2.0, -0.3, 0.25])
    t = np.arange(n + 1) / fs
    truth = inertial_attitude(Rotation.concatenate([C0] * (n + 1)), t, lat)
    est = integrate_attitude(truth[0], static_increments(C0, lat, fs, n), fs, latitude=None)
    # in 6 h the body turned 90 deg about the Earth's axis
    np.testing.assert_allclose(orientation_error(truth[:1], truth[-1:]), math.pi / 2, rtol=3e-3)
    assert orientation_error(est, truth).max() < 1e-3 * ARCSEC


@pytest.mark.parametrize("heading_deg", [0.0, 120.0])
def test_bias_on_the_vertical_gyro_gives_heading_error_b_t(heading_deg):
    """Level, static, a constant bias b on the down gyro: heading error b t (the body turns
    about down at b, heading grows toward east)."""
    lat, fs, n, b = math.radians(45.0), 10.0, 36_000, 0.01 * DPH
    C0 = Rotation.from_euler("ZYX", [math.radians(heading_deg), 0.0, 0.0])
    inc = static_increments(C0, lat, fs, n)
    inc[:, 2] += b / fs
    est = integrate_attitude(C0, inc, fs, latitude=lat)
    err = attitude_errors(est, Rotation.concatenate([C0] * (n + 1)))
    t = np.arange(n + 1) / fs
    ten_min = t <= 600.0
    np.testing.assert_allclose(err["heading_error_rad"][ten_min], b * t[ten_min], rtol=1e-3,
                               atol=1e-6 * ARCSEC)
    # Over longer times the error, fixed in inertial space, turns with the navigation frame
    # about the Earth's axis: its down component is b (sin^2 L t + cos^2 L sin(Omega t) / Omega)
    # (0.57 % below b t after an hour at 45 deg), the rest a tilt.
    x = OMEGA_E * t
    expect = b * (math.sin(lat) ** 2 * t + math.cos(lat) ** 2 * np.sin(x) / OMEGA_E)
    np.testing.assert_allclose(err["heading_error_rad"], expect, rtol=1e-4, atol=1e-6 * ARCSEC)
    tilt = np.hypot(err["roll_error_rad"], err["pitch_error_rad"])
    assert tilt[-1] < 0.1 * b * t[-1]


def rotation_about_z_increments(w, fs, n):
    """Body turning about its z (= down) at w from heading 0, no Earth rate: exact increments."""
    return np.tile([0.0, 0.0, w / fs], (n, 1))


@pytest.mark.parametrize("theta_deg", [90.0, 360.0, -720.0])
def test_scale_factor_error_through_a_rotation_gives_s_theta_about_that_axis(theta_deg):
    s, fs = 300e-6, 100.0
    theta = math.radians(theta_deg)
    w = math.copysign(math.radians(30.0), theta)
    n = int(round(theta / w * fs))
    inc = rotation_about_z_increments(w, fs, n)
    truth = Rotation.from_euler("Z", (np.arange(n + 1) * w / fs)[:, None])
    est = integrate_attitude(Rotation.identity(), inc * (1.0 + s), fs)
    err = attitude_errors(est, truth)
    np.testing.assert_allclose(err["heading_error_rad"][-1], s * theta, rtol=1e-6)
    assert np.abs(err["roll_error_rad"]).max() < 1e-12
    assert np.abs(err["pitch_error_rad"]).max() < 1e-12


@pytest.mark.parametrize("theta_deg", [1.0, 10.0, 90.0, 180.0])
def test_misalignment_during_a_rotation_about_z_gives_m_theta_on_x(theta_deg):
    """The x gyro's input axis tilted by m toward z reads m w while the body turns about z at w.
    In the navigation frame the error is m (sin theta, 1 - cos theta, 0): m theta about the
    (initial) x axis for small theta, the arc of the turning x axis beyond."""
    m, fs, w = 100e-6, 100.0, math.radians(30.0)
    theta = math.radians(theta_deg)
    n = int(round(theta / w * fs))
    theta = n * w / fs
    inc = rotation_about_z_increments(w, fs, n)
    inc[:, 0] += m * w / fs
    truth = Rotation.from_euler("Z", (np.arange(n + 1) * w / fs)[:, None])
    est = integrate_attitude(Rotation.identity(), inc, fs)
    psi = (est * truth.inv())[-1].as_rotvec()     # error in NED: C_est = exp(psi) C_true
    np.testing.assert_allclose(psi, m * np.array([math.sin(theta), 1 - math.cos(theta), 0.0]),
                               rtol=1e-4, atol=1e-6 * m + 2 * m * m * theta)  # O(m^2) beyond
    if theta_deg <= 1.0:
        np.testing.assert_allclose(psi[0], m * theta, rtol=1e-4)


def coning_truth(alpha, Omega, t):
    """Classical coning: C(t) = exp([alpha u(t) x]), u = (cos Omega t, sin Omega t, 0)."""
    u = np.stack([np.cos(Omega * t), np.sin(Omega * t), np.zeros_like(t)], axis=1)
    return Rotation.from_rotvec(alpha * u)


def coning_increments(alpha, Omega, t):
    """Exact integrals over [t_m, t_m+1] of the coning body rate
    omega_b = (-Omega sin a sin Omega t, Omega sin a cos Omega t, -Omega (1 - cos a))."""
    c, s = np.cos(Omega * t), np.sin(Omega * t)
    sa = math.sin(alpha)
    return np.stack([sa * np.diff(c), sa * np.diff(s),
                     -Omega * (1 - math.cos(alpha)) * np.diff(t)], axis=1)


def test_coning_body_rate_is_that_of_the_coning_attitude():
    """The closed form body rate (used for the increments) against the attitude differenced."""
    alpha, Omega, h = math.radians(2.0), 2 * math.pi * 1.3, 1e-6
    t = np.linspace(0.0, 1.0, 7)
    C0, C1 = coning_truth(alpha, Omega, t), coning_truth(alpha, Omega, t + h)
    w_num = (C0.inv() * C1).as_rotvec() / h
    sa = math.sin(alpha)
    w = np.stack([-Omega * sa * np.sin(Omega * (t + h / 2)), Omega * sa * np.cos(Omega * (t + h / 2)),
                  np.full_like(t, -Omega * (1 - math.cos(alpha)))], axis=1)
    np.testing.assert_allclose(w_num, w, atol=1e-8)


def test_coning_drifts_without_the_correction_and_not_with_it():
    alpha, Omega, fs, dur = math.radians(1.0), 2 * math.pi * 2.0, 100.0, 60.0
    n = int(dur * fs)
    t = np.arange(n + 1) / fs
    truth = coning_truth(alpha, Omega, t)
    inc = coning_increments(alpha, Omega, t)
    plain = integrate_attitude(truth[0], inc, fs, coning=False)
    corrected = integrate_attitude(truth[0], inc, fs, coning=True)
    # error about the cone axis (z), body frame: C_true^T C_est
    drift_plain = (truth.inv() * plain)[-1].as_rotvec()[2] / dur
    drift_corr = (truth.inv() * corrected)[-1].as_rotvec()[2] / dur
    expect = coning_drift_rate(alpha, Omega, 1.0 / fs)
    # the uncorrected update misses the coning term: the estimate drifts at minus it
    np.testing.assert_allclose(drift_plain, -expect, rtol=2e-2)
    assert expect > 0.1 * ARCSEC        # 0.1 arcsec/s and more: a real drift
    assert abs(drift_corr) < 0.01 * expect
    assert orientation_error(corrected, truth).max() < 0.02 * orientation_error(plain,
                                                                               truth).max()


def test_coning_drift_rate_small_angle_form():
    """(1/2) Omega sin^2 a (1 - sinc) ~ Omega^3 T^2 a^2 / 12 for small Omega T and a."""
    a, Om, T = 1e-3, 5.0, 1e-3
    np.testing.assert_allclose(coning_drift_rate(a, Om, T), Om ** 3 * T ** 2 * a ** 2 / 12,
                               rtol=1e-4)


@pytest.mark.parametrize("lat_deg,heading_deg,b_dph", [(45.0, 0.0, 0.01), (45.0, 30.0, -0.05),
                                                       (-30.0, 250.0, 0.02)])
def test_gyrocompassing_heading_error_is_the_east_bias_over_omega_cos_lat(lat_deg, heading_deg,
                                                                         b_dph):
    """Level body, bias b on the gyro pointing east: heading error -b / (Omega cos L) (the found
    north turns toward the biased east gyro). At 45 deg, 0.01 deg/h is about 3 arcmin."""
    lat, psi, b = math.radians(lat_deg), math.radians(heading_deg), b_dph * DPH
    C = Rotation.from_euler("ZYX", [psi, 0.0, 0.0])
    w_b = C.inv().apply(earth_rate_ned(lat))
    f_b = C.inv().apply([0.0, 0.0, -9.80665])        # at rest: specific force points up
    east_b = C.inv().apply([0.0, 1.0, 0.0])
    found = gyrocompass(w_b + b * east_b, f_b, lat)
    err = attitude_errors(found, C)
    expect = -b / (OMEGA_E * math.cos(lat))
    np.testing.assert_allclose(err["heading_error_rad"], expect, rtol=1e-3)
    assert abs(err["roll_error_rad"]) < 1e-12 and abs(err["pitch_error_rad"]) < 1e-12
    if lat_deg == 45.0 and b_dph == 0.01:
        assert 3.0 < abs(expect) / math.radians(1 / 60) < 3.3
    # without the bias, north is found exactly
    assert orientation_error(gyrocompass(w_b, f_b, lat), C) < 1e-9


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="dtheta must have shape"):
        integrate_attitude(Rotation.identity(), np.zeros((5, 2)), 10.0)
    with pytest.raises(ValueError, match="single"):
        integrate_attitude(Rotation.identity(2), np.zeros((5, 3)), 10.0)
    with pytest.raises(ValueError, match="fs"):
        integrate_attitude(Rotation.identity(), np.zeros((5, 3)), 0.0)


def test_the_error_summary_reads_the_errors_at_stated_times_in_degrees():
    fs, n = 10.0, 12_000   # 20 min
    truth = Rotation.identity(n + 1)
    t = np.arange(n + 1) / fs
    drift = math.radians(1.0) / 600.0          # heading drifts 1 deg per 10 min
    est = Rotation.from_euler("Z", (drift * t)[:, None])
    s = attitude_error_summary(est, truth, fs)
    assert s["heading_error_deg_at_60s"] == pytest.approx(0.1)
    assert s["heading_error_deg_at_600s"] == pytest.approx(1.0)
    assert "heading_error_deg_at_3600s" not in s           # past the record
    assert s["heading_error_rms_deg"] == pytest.approx(2.0 / math.sqrt(3), rel=1e-3)
    assert s["roll_error_rms_deg"] == pytest.approx(0.0, abs=1e-12)
    assert s["orientation_error_deg_at_600s"] == pytest.approx(1.0)
