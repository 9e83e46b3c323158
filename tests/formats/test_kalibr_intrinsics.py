"""Ferraris intrinsics in Kalibr's and OpenVINS' conventions (fogbench.formats.kalibr).

Each test builds a calibration with known parameters, converts it, loads the written YAML with
PyYAML and applies the tool's own measurement model to it, written out here from the tools'
sources (not from the converter):

- Kalibr, IccSensors.py l. 999 / 1045 / 1049 (model ``scale-misalignment``, imu0 so C_i_b = I)::

      f_m = M_a f_i + b_a
      w_m = M_g (C_gyro_i w_i) + A (C_gyro_i f_i) + b_g

- OpenVINS, docs/propagation.dox l. 33-36 (forward) and, what the filter computes from a
  measurement, VioManagerOptions.h l. 319-322 / 343-349, State.h l. 96, Propagator.cpp
  l. 415-427::

      Dw = Tw^-1, Da = Ta^-1, "kalibr" model: only their lower triangles are kept
      f_I = R_IMUtoACC^T Da (a_m - b_a)
      w_I = R_IMUtoGYRO^T Dw (w_m - b_g - Tg f_I)

and compares with fogbench's own triad model (fogcomp.calibration: ``acc_raw = K_a R_a f_b +
b_a``, ``gyr_raw = K_g R_g w_b + K_ga f_b + b_g``, whose inverse is ``TriadCalibration.calibrate``)
for the same true rates and specific forces.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from fogbench.formats.kalibr import (INTRINSICS_TEXTS, NoiseValue, intrinsics_from_ferraris, is_own,
                             kalibr_intrinsics_text, openvins_intrinsics_text)
from fogcomp.calibration import TriadCalibration, ferraris_calibration

G = 9.80665
DEG = math.pi / 180.0


def _rot(ax, ang):
    c, s = math.cos(ang), math.sin(ang)
    i, j = [(1, 2), (2, 0), (0, 1)][ax]
    m = np.eye(3)
    m[i, i] = m[j, j] = c
    m[i, j], m[j, i] = -s, s
    return m


def _unit_rows(m):
    m = np.asarray(m, dtype=float)
    return m / np.linalg.norm(m, axis=1)[:, None]


def _known_cal(gyro_sign=(1.0, 1.0, 1.0)) -> TriadCalibration:
    """A triad in SI units (a log in physical units): percent-level scale errors, non-orthogonal
    sensitive axes a degree or two off the body axes, a full g-sensitivity matrix of tens of
    deg/h per g, biases."""
    acc_r = _unit_rows([[1.0, 0.02, -0.015], [-0.01, 1.0, 0.03], [0.025, -0.02, 1.0]])
    gyro_r = _unit_rows([[1.0, -0.03, 0.01], [0.02, 1.0, -0.025], [-0.015, 0.035, 1.0]])
    gyro_r = np.diag(gyro_sign) @ gyro_r
    kga = np.array([[30.0, -12.0, 5.0], [8.0, 25.0, -20.0], [-6.0, 15.0, 40.0]]) * (DEG / 3600 / G)
    return TriadCalibration(acc_scale=[1.02, 0.97, 1.005], acc_misalignment=acc_r,
                            acc_bias=[0.05, -0.03, 0.08], gyro_scale=[1.01, 0.985, 1.03],
                            gyro_misalignment=gyro_r, gyro_g_sensitivity=kga,
                            gyro_bias=[2e-4, -1e-4, 3e-4], g=G)


def _fogbench_raw(cal: TriadCalibration, w_b, f_b):
    """fogcomp.calibration's model, true to measured (its module docstring), checked against its
    own inverse ``calibrate`` so that this is fogbench's model and not a restatement."""
    acc = f_b @ (np.diag(cal.acc_scale) @ cal.acc_misalignment).T + cal.acc_bias
    gyr = (w_b @ (np.diag(cal.gyro_scale) @ cal.gyro_misalignment).T
           + f_b @ cal.gyro_g_sensitivity.T + cal.gyro_bias)
    w_back, f_back = cal.calibrate(gyr, acc)
    np.testing.assert_allclose(w_back, w_b, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f_back, f_b, rtol=0, atol=1e-12)
    return gyr, acc


def _truth(n=40, seed=3):
    rng = np.random.default_rng(seed)
    w_b = rng.normal(0, 1.0, (n, 3))                       # rad/s
    f_b = rng.normal(0, 1.0, (n, 3)) * 3 + [0, 0, G]       # m/s^2, gravity and motion
    return w_b, f_b


def _load_openvins(text):
    first = text.split("\n", 1)[0]
    # OpenCV's FileStorage takes "%YAML" as the first bytes, then "%YAML:1." or "%YAML 1."
    assert first.startswith(("%YAML:1.", "%YAML 1."))
    doc = yaml.safe_load(text)                             # the whole file, as written
    return {k: np.array(v, dtype=float) if isinstance(v, list) else v
            for k, v in doc["imu0"].items()}


def _load_kalibr(text):
    imu = yaml.safe_load(text)["imu0"]
    return (np.array(imu["accelerometers"]["M"], dtype=float),
            np.array(imu["gyroscopes"]["M"], dtype=float),
            np.array(imu["gyroscopes"]["A"], dtype=float),
            np.array(imu["gyroscopes"]["C_gyro_i"], dtype=float), imu)


def _openvins_correct(ov, gyr, acc, b_g, b_a):
    """What OpenVINS' propagator computes from the measurements (Propagator.cpp l. 415-427),
    with its "kalibr" model's lower triangles (VioManagerOptions.h l. 343-344, State.h l. 96)."""
    dw = np.tril(np.linalg.inv(ov["Tw"]))
    da = np.tril(np.linalg.inv(ov["Ta"]))
    f_i = (acc - b_a) @ (ov["R_IMUtoACC"].T @ da).T
    w_i = (gyr - b_g - f_i @ ov["Tg"].T) @ (ov["R_IMUtoGYRO"].T @ dw).T
    return w_i, f_i


def _procrustes(src, dst):
    """The rotation R minimising |dst - src R^T| (Kabsch), and the largest residual."""
    u, _, vt = np.linalg.svd(dst.T @ src)
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    r = u @ d @ vt
    return r, float(np.abs(dst - src @ r.T).max())


def _is_rotation(r):
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-12)


def test_openvins_file_reproduces_fogbench_measurements_and_recovers_the_truth():
    cal = _known_cal()
    intr = intrinsics_from_ferraris(cal)
    ov = _load_openvins(openvins_intrinsics_text(intr, 200.0, "session.csv"))
    assert ov["model"] == "kalibr"
    np.testing.assert_array_equal(ov["R_IMUtoACC"], np.eye(3))
    _is_rotation(ov["R_IMUtoGYRO"])
    # the "kalibr" model keeps only the lower triangle of Tw^-1 and Ta^-1: nothing may be above
    for key in ("Tw", "Ta"):
        assert np.all(np.triu(ov[key], 1) == 0.0), key

    w_b, f_b = _truth()
    gyr, acc = _fogbench_raw(cal, w_b, f_b)
    b_g, b_a = cal.gyro_bias, cal.acc_bias       # both tools estimate these online
    # 1. What OpenVINS makes of fogbench's measurements is the truth in one rigid frame: the
    #    best rotation from the true (w, f) to OpenVINS' leaves no residual (frame-free check,
    #    it uses nothing but the file).
    w_i, f_i = _openvins_correct(ov, gyr, acc, b_g, b_a)
    r, res = _procrustes(np.vstack([w_b, f_b]), np.vstack([w_i, f_i]))
    assert res < 1e-12
    # that frame is the one the file's comments and the converter name, a small rotation
    np.testing.assert_allclose(r, intr.C_i_body, atol=1e-12)
    assert 0.5 < intr.angle_deg() < 5.0
    # 2. OpenVINS' forward model (propagation.dox l. 33-36) in that frame gives fogbench's
    #    measurements.
    w_I, f_I = w_b @ r.T, f_b @ r.T
    a_m = f_I @ (ov["Ta"] @ ov["R_IMUtoACC"]).T + b_a
    w_m = w_I @ (ov["Tw"] @ ov["R_IMUtoGYRO"]).T + f_I @ ov["Tg"].T + b_g
    np.testing.assert_allclose(a_m, acc, rtol=0, atol=1e-12)
    np.testing.assert_allclose(w_m, gyr, rtol=0, atol=1e-12)
    # 3. without Tg the rates would be off by the g-sensitivity: the term is there and counts
    w_no_tg, _ = _openvins_correct({**ov, "Tg": np.zeros((3, 3))}, gyr, acc, b_g, b_a)
    assert np.abs(w_no_tg - w_I).max() > 1e-4


def test_kalibr_block_reproduces_fogbench_measurements():
    cal = _known_cal()
    intr = intrinsics_from_ferraris(cal)
    m_a, m_g, a, c_gi, imu = _load_kalibr(kalibr_intrinsics_text(intr, 200.0, "session.csv"))
    assert imu["model"] == "scale-misalignment"
    np.testing.assert_array_equal(np.array(imu["T_i_b"]), np.eye(4))
    # Kalibr's M_accel / M_gyro are lower triangular (IccSensors.py l. 955-965), C_gyro_i a
    # rotation
    assert np.all(np.triu(m_a, 1) == 0.0) and np.all(np.triu(m_g, 1) == 0.0)
    _is_rotation(c_gi)

    w_b, f_b = _truth(seed=5)
    gyr, acc = _fogbench_raw(cal, w_b, f_b)
    # Kalibr's accelerometer model with C_i_b = I: f_m = M_a f_i + b. Its frame i follows from
    # the file alone: f_i = M_a^-1 (f_m - b), a rotation of the true f_b.
    f_i = (acc - cal.acc_bias) @ np.linalg.inv(m_a).T
    r, res = _procrustes(f_b, f_i)
    assert res < 1e-12
    w_i = w_b @ r.T
    w_m = (w_i @ c_gi.T) @ m_g.T + (f_i @ c_gi.T) @ a.T + cal.gyro_bias
    np.testing.assert_allclose(w_m, gyr, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f_i @ m_a.T + cal.acc_bias, acc, rtol=0, atol=1e-12)


def test_kalibr_and_openvins_files_describe_one_sensor():
    """OpenVINS' example file maps Kalibr's result as Tw = gyroscopes:M, R_IMUtoGYRO = C_gyro_i,
    Ta = accelerometers:M (config/rpng_sim/kalibr_imu_chain.yaml l. 19-24); its Tg multiplies
    f_I where Kalibr's A multiplies C_gyro_i f_i, so Tg = A C_gyro_i ("Tg is A" only where
    C_gyro_i is the identity)."""
    intr = intrinsics_from_ferraris(_known_cal())
    m_a, m_g, a, c_gi, _ = _load_kalibr(kalibr_intrinsics_text(intr, 100.0, "s.csv"))
    ov = _load_openvins(openvins_intrinsics_text(intr, 100.0, "s.csv"))
    np.testing.assert_array_equal(ov["Tw"], m_g)
    np.testing.assert_array_equal(ov["Ta"], m_a)
    np.testing.assert_array_equal(ov["R_IMUtoGYRO"], c_gi)
    np.testing.assert_allclose(ov["Tg"], a @ c_gi, rtol=0, atol=1e-18)
    assert np.abs(ov["Tg"] - a).max() > 1e-3 * np.abs(a).max()   # not equal here: C_gyro_i != I


def test_g_sensitivity_units_by_hand():
    """Aligned unit-scale triads and a g-sensitivity of 10 / -4 / 7 deg/h per g on the diagonal
    plus 2 deg/h per g of y's response to x: Tg and A are those values x (pi/180)/3600 / 9.80665
    in (rad/s)/(m/s^2), the frames the identity."""
    per_g = np.array([[10.0, 0.0, 0.0], [2.0, -4.0, 0.0], [0.0, 0.0, 7.0]])
    cal = TriadCalibration(np.ones(3), np.eye(3), np.zeros(3), np.ones(3), np.eye(3),
                           per_g * (math.pi / 180 / 3600) / 9.80665, np.zeros(3), G)
    intr = intrinsics_from_ferraris(cal)
    ov = _load_openvins(openvins_intrinsics_text(intr, 400.0, "s.csv"))
    _, m_g, a, c_gi, _ = _load_kalibr(kalibr_intrinsics_text(intr, 400.0, "s.csv"))
    hand = per_g * 4.84813681109536e-06 / 9.80665   # 1 deg/h = 4.84813681109536e-06 rad/s
    np.testing.assert_allclose(ov["Tg"], hand, rtol=1e-12, atol=0)
    np.testing.assert_allclose(a, hand, rtol=1e-12, atol=0)
    for m in (ov["Tw"], ov["Ta"], ov["R_IMUtoGYRO"], m_g, c_gi):
        np.testing.assert_array_equal(m, np.eye(3))
    assert ov["update_rate"] == 400.0


def test_reversed_gyro_axis_keeps_a_proper_rotation():
    """A gyro whose z axis turns the other way (R_g's diagonal -1, as fogcomp reports it):
    C_gyro_i stays a rotation, the sign goes into M, and the round trip still holds."""
    cal = _known_cal(gyro_sign=(1.0, 1.0, -1.0))
    intr = intrinsics_from_ferraris(cal)
    ov = _load_openvins(openvins_intrinsics_text(intr, 200.0, "s.csv"))
    _is_rotation(ov["R_IMUtoGYRO"])
    assert np.all(np.triu(ov["Tw"], 1) == 0.0)
    assert ov["Tw"][2, 2] < 0 < min(ov["Tw"][0, 0], ov["Tw"][1, 1])
    assert np.trace(ov["R_IMUtoGYRO"]) > 2.99              # near the identity, not a half turn
    w_b, f_b = _truth(seed=7)
    gyr, acc = _fogbench_raw(cal, w_b, f_b)
    w_i, f_i = _openvins_correct(ov, gyr, acc, cal.gyro_bias, cal.acc_bias)
    _, res = _procrustes(np.vstack([w_b, f_b]), np.vstack([w_i, f_i]))
    assert res < 1e-12


def test_raw_count_calibration_with_its_si_factors():
    """A calibration made on counts (1000 counts per rad/s, 2000 per m/s^2): with the SI value
    of one count the tools' matrices are the SI ones; without, they would be 1000 times off."""
    si = _known_cal()
    counts = TriadCalibration(si.acc_scale * 2000, si.acc_misalignment, si.acc_bias * 2000,
                              si.gyro_scale * 1000, si.gyro_misalignment,
                              si.gyro_g_sensitivity * 1000, si.gyro_bias * 1000, G)
    a, b = intrinsics_from_ferraris(si), intrinsics_from_ferraris(counts, gyro_si=1e-3,
                                                                  acc_si=5e-4)
    for name in ("Ta", "Tw", "R_IMUtoGYRO", "Tg", "A", "C_i_body", "acc_bias", "gyro_bias"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-12,
                                   atol=1e-15, err_msg=name)
    assert abs(intrinsics_from_ferraris(counts).Tw[0, 0]) > 100


def test_synthetic_ferraris_session_through_openvins():
    """End to end: a six-position + three-rotation session simulated from known SI parameters,
    calibrated by fogcomp's ferraris_calibration, converted, and OpenVINS' correction applied to
    the z rotation's readings gives the turn's rate and gravity's magnitude."""
    truth = _known_cal()
    ka, ra = np.diag(truth.acc_scale), truth.acc_misalignment
    kg, rg = np.diag(truth.gyro_scale), truth.gyro_misalignment
    fs, n = 100.0, 50
    acc, gyr = {}, {}
    for j, ax in enumerate("xyz"):
        for sign, tag in ((1, "p"), (-1, "a")):
            f = np.zeros(3)
            f[j] = sign * G
            acc[f"{ax}_{tag}"] = np.tile(ka @ ra @ f + truth.acc_bias, (n, 1))
            gyr[f"{ax}_{tag}"] = np.tile(truth.gyro_g_sensitivity @ f + truth.gyro_bias, (n, 1))
        k = int(4 * fs)
        w = np.zeros((k, 3))
        w[:, j] = 2 * math.pi / 4.0
        f0 = np.zeros(3)
        f0[(j + 1) % 3] = G
        f_body = np.array([_rot(j, -2 * math.pi * i / k) @ f0 for i in range(k)])
        acc[f"{ax}_rot"] = f_body @ (ka @ ra).T + truth.acc_bias
        gyr[f"{ax}_rot"] = w @ (kg @ rg).T + f_body @ truth.gyro_g_sensitivity.T + truth.gyro_bias
    cal = ferraris_calibration(acc, gyr, fs, 2 * math.pi, g=G)
    intr = intrinsics_from_ferraris(cal)
    ov = _load_openvins(openvins_intrinsics_text(intr, fs, "session.csv"))
    w_i, f_i = _openvins_correct(ov, gyr["z_rot"], acc["z_rot"], intr.gyro_bias, intr.acc_bias)
    np.testing.assert_allclose(np.linalg.norm(w_i, axis=1), 2 * math.pi / 4.0, rtol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(f_i, axis=1), G, rtol=1e-9)
    # the rate is along the body z axis, expressed in I
    np.testing.assert_allclose(w_i / np.linalg.norm(w_i, axis=1)[:, None],
                               np.tile(intr.C_i_body[:, 2], (len(w_i), 1)), atol=1e-9)


def test_files_load_whole_carry_the_mark_and_the_noise_when_given(tmp_path):
    intr = intrinsics_from_ferraris(_known_cal())
    values = {("gyroscope", "N"): NoiseValue(1e-05, "identified", "gyro_z", {}),
              ("gyroscope", "K"): NoiseValue(2.5e-06, "upper bound", "gyro_x", {}),
              ("accelerometer", "N"): NoiseValue(0.002, "identified", "acc_x", {}),
              ("accelerometer", "K"): NoiseValue(3e-4, "identified", "acc_y", {})}
    for kind, write in INTRINSICS_TEXTS.items():
        bare = write(intr, 200.0, "session.csv", topic="/imu1")
        full = write(intr, 200.0, "session.csv", topic="/imu1", values=values)
        for text in (bare, full):
            p = tmp_path / f"{kind}.yaml"
            p.write_text(text)
            assert is_own(p)
            imu = yaml.safe_load(p.read_text())["imu0"]
            assert imu["rostopic"] == "/imu1"
            assert imu["update_rate"] == 200.0 and imu["time_offset"] == 0.0
            leaves = [x for key in ("Tw", "Ta", "Tg", "R_IMUtoGYRO", "R_IMUtoACC")
                      for row in imu.get(key, []) for x in row]
            leaves += [x for sub in ("accelerometers", "gyroscopes") if sub in imu
                       for m in imu[sub].values() for row in m for x in row]
            assert len(leaves) == (45 if kind == "openvins" else 36)
            assert all(type(x) is float for x in leaves)   # never a string such as "1e-05"
        assert "gyroscope_noise_density" not in yaml.safe_load(bare)["imu0"]
        imu = yaml.safe_load(full)["imu0"]
        assert imu["gyroscope_noise_density"] == 1e-05            # a float, not "1e-05"
        assert imu["gyroscope_random_walk"] == 2.5e-06
        assert imu["accelerometer_noise_density"] == 0.002
        assert imu["accelerometer_random_walk"] == 3e-4
    # a file someone else wrote is not "own"
    other = tmp_path / "other.yaml"
    other.write_text("%YAML:1.0\nimu0:\n  model: kalibr\n")
    assert not is_own(other)


def test_bad_input_is_refused():
    cal = _known_cal()
    with pytest.raises(TypeError, match="TriadCalibration"):
        intrinsics_from_ferraris(cal.to_dict())
    for bad in (0.0, -1.0, float("nan"), float("inf"), True, "1"):
        with pytest.raises(ValueError, match="gyro_si"):
            intrinsics_from_ferraris(cal, gyro_si=bad)
    with pytest.raises(ValueError, match="acc_si"):
        intrinsics_from_ferraris(cal, acc_si=0)


# ---------------------------------------------------------------------------------------------
# The command line: calibrate ferraris --kalibr / --openvins
def _calibrated_session(tmp_path):
    """imucal's real Ferraris session (raw counts) calibrated by fogbench and written out by
    compensate: the same session in physical units, which a calibration of its own must find
    already calibrated (scale factors 1, no misalignment, no g-sensitivity, no bias)."""
    from helpers import need_realdata
    from helpers import realdata_dir, run_parsed as run
    REAL = realdata_dir()

    session = REAL / "imucal_ferraris" / "annotated_session.csv"
    need_realdata(session)
    cols = ("acc_x=acc_x:au,acc_y=acc_y:au,acc_z=acc_z:au,gyro_x=gyr_x:au,gyro_y=gyr_y:au,"
            "gyro_z=gyr_z:au")
    assert run(["calibrate", "ferraris", session, "--fs", "204.8", "--angle-deg", "-360",
                "--g", "9.81", "--column", cols, "--out", tmp_path / "cal"])[0] == 0
    assert run(["compensate", tmp_path / "cal", session, "--out", tmp_path / "si.csv"])[0] == 0
    si = ",".join([f"acc_{a}=acc_{a}_cal_mps2:mps2" for a in "xyz"]
                  + [f"gyro_{a}=gyro_{a}_cal_dps:dps" for a in "xyz"])
    return tmp_path / "si.csv", si, run


def test_calibrate_ferraris_writes_tool_files_that_a_calibrated_session_finds_identity(tmp_path):
    log, cols, run = _calibrated_session(tmp_path)
    code, err = run(["calibrate", "ferraris", log, "--fs", "204.8", "--angle-deg", "-360",
                     "--g", "9.81", "--column", cols, "--out", tmp_path / "again",
                     "--kalibr", tmp_path / "imu.yaml", "--openvins", tmp_path / "chain.yaml",
                     "--imu-topic", "/imu1"])
    assert code == 0, err
    k = yaml.safe_load((tmp_path / "imu.yaml").read_text())["imu0"]
    o = yaml.safe_load((tmp_path / "chain.yaml").read_text())["imu0"]
    # The Ferraris estimate on its own output is the identity only to about 2e-6 here: the
    # calibrated session's rotations integrate to -360 deg to about 1e-6 (test_reallog's
    # check), and the scale factors come from those integrals. The raw session's matrices are
    # 900 counts per rad/s and misaligned by about 1e-2, so the tolerance still tells the
    # identity from any mix-up of rows, transposes or units.
    for m in (k["gyroscopes"]["M"], k["accelerometers"]["M"], o["Tw"], o["Ta"],
              k["gyroscopes"]["C_gyro_i"], o["R_IMUtoGYRO"]):
        np.testing.assert_allclose(m, np.eye(3), atol=1e-5)
    for m in (o["Tg"], k["gyroscopes"]["A"]):     # (rad/s)/(m/s^2)
        np.testing.assert_allclose(m, np.zeros((3, 3)), atol=1e-7)
    assert o["rostopic"] == k["rostopic"] == "/imu1"
    assert o["update_rate"] == pytest.approx(204.8)
    assert is_own(tmp_path / "imu.yaml") and is_own(tmp_path / "chain.yaml")


def test_calibrate_ferraris_tool_files_are_refused_for_raw_counts_and_other_methods(tmp_path):
    from helpers import need_realdata
    from helpers import realdata_dir, run_parsed as run
    REAL = realdata_dir()

    session = REAL / "imucal_ferraris" / "annotated_session.csv"
    need_realdata(session)
    cols = ("acc_x=acc_x:au,acc_y=acc_y:au,acc_z=acc_z:au,gyro_x=gyr_x:au,gyro_y=gyr_y:au,"
            "gyro_z=gyr_z:au")
    code, err = run(["calibrate", "ferraris", session, "--fs", "204.8", "--angle-deg", "-360",
                     "--column", cols, "--out", tmp_path / "cal", "--kalibr",
                     tmp_path / "imu.yaml"])
    assert code == 2 and "raw counts" in err and len(err.strip().splitlines()) >= 1, err
    code, err = run(["calibrate", "poly_temp", session, "--out", tmp_path / "p", "--openvins",
                     tmp_path / "c.yaml"])
    assert code == 2 and "--openvins: only with calibrate ferraris" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_the_noise_files_write_numbers_pyyaml_reads_as_numbers():
    """PyYAML (Kalibr reads its imu.yaml with it) takes '1e-05' for a string: a noise
    density of one significant digit must still load as a float."""
    from fogbench.formats.kalibr import kalibr_text, openvins_text

    values = {("gyroscope", "N"): NoiseValue(1e-5, "identified", "gyro_z_rps", {}),
              ("gyroscope", "K"): NoiseValue(2e-7, "identified", "gyro_z_rps", {}),
              ("accelerometer", "N"): NoiseValue(1e-3, "identified", "acc_z_mps2", {}),
              ("accelerometer", "K"): NoiseValue(3e-5, "identified", "acc_z_mps2", {})}
    for text in (kalibr_text(values, 200.0, "log.csv"), openvins_text(values, 200.0, "log.csv")):
        doc = yaml.safe_load(text)
        doc = doc.get("imu0", doc)
        assert doc["gyroscope_noise_density"] == 1e-5
        assert doc["accelerometer_random_walk"] == 3e-5
        assert isinstance(doc["update_rate"], float)
