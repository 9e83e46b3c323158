"""Tests of fogcomp.calibration: imucal's published result on its own session (real data), and a
synthetic session with known parameters."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fogcomp.calibration import FERRARIS_PARTS, TriadCalibration, ferraris_calibration

DEG = math.pi / 180.0


from helpers import need_realdata, realdata_dir as _realdata_dir  # noqa: E402


IMUCAL = _realdata_dir() / "imucal_ferraris"


def test_reproduces_imucal_example_cal():
    session, ref_file = IMUCAL / "annotated_session.csv", IMUCAL / "example_cal.json"
    need_realdata(session, ref_file)
    import pandas as pd

    df = pd.read_csv(session)
    acc = {p: g[["acc_x", "acc_y", "acc_z"]].to_numpy() for p, g in df.groupby("part")}
    gyr = {p: g[["gyr_x", "gyr_y", "gyr_z"]].to_numpy() for p, g in df.groupby("part")}
    # imucal's test: 204.8 Hz, g = 9.81, expected angle -360 deg.
    cal = ferraris_calibration(acc, gyr, 204.8, -2 * math.pi, g=9.81)
    ref = json.loads(ref_file.read_text())
    # Same equations on the same samples: only the order of float64 sums differs, so agreement
    # to 1e-10 of each matrix's largest entry (its noise-limited uncertainty is ~1e-3 relative).
    pairs = {"b_g": cal.gyro_bias, "K_g": np.diag(cal.gyro_scale) * DEG,   # per rad/s -> deg/s
             "R_g": cal.gyro_misalignment, "K_ga": cal.gyro_g_sensitivity,
             "b_a": cal.acc_bias, "K_a": np.diag(cal.acc_scale), "R_a": cal.acc_misalignment}
    for key, mine in pairs.items():
        r = np.asarray(ref[key])
        np.testing.assert_allclose(mine, r, rtol=0, atol=1e-10 * np.abs(r).max(), err_msg=key)


def _rot(ax, ang):
    c, s = math.cos(ang), math.sin(ang)
    i, j = [(1, 2), (2, 0), (0, 1)][ax]
    m = np.eye(3)
    m[i, i] = m[j, j] = c
    m[i, j], m[j, i] = -s, s
    return m


def test_recovers_known_parameters_of_a_synthetic_session():
    rng = np.random.default_rng(1)
    g, fs = 9.80665, 100.0
    truth = TriadCalibration(
        acc_scale=[200.0, 205.0, 210.0], acc_misalignment=_rot(0, 0.01) @ _rot(1, -0.02),
        acc_bias=[5.0, -3.0, 7.0], gyro_scale=[900.0, 950.0, 1000.0],
        gyro_misalignment=_rot(2, 0.015) @ _rot(0, 0.01), gyro_g_sensitivity=rng.normal(0, 0.05,
                                                                                        (3, 3)),
        gyro_bias=[1.5, -2.0, 0.5], g=g)
    ka, ra = np.diag(truth.acc_scale), truth.acc_misalignment
    kg, rg = np.diag(truth.gyro_scale), truth.gyro_misalignment
    acc, gyr = {}, {}
    n = 200
    for j, ax in enumerate("xyz"):
        for sign, tag in ((1, "p"), (-1, "a")):
            f = np.zeros(3)
            f[j] = sign * g
            acc[f"{ax}_{tag}"] = np.tile(ka @ ra @ f + truth.acc_bias, (n, 1))
            gyr[f"{ax}_{tag}"] = np.tile(truth.gyro_g_sensitivity @ f + truth.gyro_bias, (n, 1))
        # one turn of 2 pi about axis j in 4 s, with gravity along another axis turning with it
        k = int(4 * fs)
        w = np.zeros((k, 3))
        w[:, j] = 2 * math.pi / 4.0
        f0 = np.zeros(3)
        f0[(j + 1) % 3] = g
        fs_body = np.array([_rot(j, -2 * math.pi * i / k) @ f0 for i in range(k)])
        acc[f"{ax}_rot"] = fs_body @ (ka @ ra).T + truth.acc_bias
        gyr[f"{ax}_rot"] = w @ (kg @ rg).T + fs_body @ truth.gyro_g_sensitivity.T + truth.gyro_bias
    cal = ferraris_calibration(acc, gyr, fs, 2 * math.pi, g=g)
    for name in ("acc_scale", "acc_misalignment", "acc_bias", "gyro_scale", "gyro_misalignment",
                 "gyro_g_sensitivity", "gyro_bias"):
        np.testing.assert_allclose(getattr(cal, name), getattr(truth, name), rtol=1e-9,
                                   atol=1e-9, err_msg=name)
    # Applying it recovers the rates and specific force of the rotation.
    rate, f = cal.calibrate(gyr["z_rot"], acc["z_rot"])
    np.testing.assert_allclose(rate[:, 2], 2 * math.pi / 4.0, rtol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), g, rtol=1e-9)
    # JSON round trip
    back = TriadCalibration.from_dict(json.loads(cal.to_json()))
    np.testing.assert_array_equal(back.gyro_misalignment, cal.gyro_misalignment)


def test_bad_sessions_are_refused():
    good = {p: np.ones((5, 3)) for p in FERRARIS_PARTS}
    with pytest.raises(ValueError, match=r"gyro: missing part\(s\) \['z_rot'\]"):
        ferraris_calibration(good, {p: v for p, v in good.items() if p != "z_rot"}, 100.0, 6.28)
    with pytest.raises(ValueError, match="fs: sample rate"):
        ferraris_calibration(good, good, 0.0, 6.28)
    with pytest.raises(ValueError, match="angle"):
        ferraris_calibration(good, good, 100.0, 0.0)
    bad = dict(good)
    bad["x_p"] = np.full((5, 3), np.nan)
    with pytest.raises(ValueError, match=r"acc\['x_p'\]: non-finite value at sample 0"):
        ferraris_calibration(bad, good, 100.0, 6.28)
    with pytest.raises(ValueError, match="key 'format'"):
        TriadCalibration.from_dict({"format": "other"})
