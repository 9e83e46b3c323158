"""Tests of fogbench.reallog through its command functions: real data (ADIS16405 static log,
imucal's Ferraris session, the FOG curves) and every class of bad input, each checked to write
nothing."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest

from fogbench.reallog import LogError, add_commands

DEG = math.pi / 180.0


from helpers import realdata_dir as _realdata_dir  # noqa: E402


REAL = _realdata_dir()


def run(argv):
    """What the main CLI does: parse, call func, turn a ValueError into exit code 2."""
    p = argparse.ArgumentParser(prog="fogbench")
    add_commands(p.add_subparsers(dest="command", required=True))
    args = p.parse_args([str(a) for a in argv])
    try:
        return args.func(args), None
    except ValueError as exc:
        return 2, str(exc)


def _need(path: Path):
    if not path.exists():
        pytest.skip(f"real data not found at {path} (set FOGBENCH_REALDATA to the realdata "
                    "folder to run this test)")


# ---------------------------------------------------------------------------------------------
# Real data
def test_allan_on_adis16405_reproduces_avar_and_identifies_terms(tmp_path, capsys):
    log, ref = REAL / "adis16405_static" / "imu1.csv.gz", REAL / "adis16405_static" / \
        "reference_oadev.csv"
    _need(log)
    _need(ref)
    import pandas as pd

    code, err = run(["allan", log, "--out", tmp_path / "a"])
    assert code == 0, err
    doc = json.loads((tmp_path / "a" / "allan.json").read_text())
    assert doc["fs_hz"] == pytest.approx(100.0, rel=1e-9) and doc["n_samples"] == 1_000_000
    r = pd.read_csv(ref)
    for axis in "xyz":
        col = doc["columns"][f"gyro_{axis}_dps"]
        taus = np.array(col["tau_s"])
        mine = np.array(col["adev_dph"]) / 3600.0                 # deg/s
        idx = [int(np.argmin(np.abs(taus - t))) for t in r["tau_s"]]
        np.testing.assert_allclose(taus[idx], r["tau_s"], rtol=1e-12)
        # avar divides by 2(T-2m+1), not 2(T-2m) (its README): agreement to 1e-5.
        np.testing.assert_allclose(mine[idx], r[f"adev_gyro_{axis}_dps"], rtol=1e-5)
        lo, hi = np.array(col["adev_low_dph"]), np.array(col["adev_high_dph"])
        assert np.all(lo < col["adev_dph"]) and np.all(np.array(col["adev_dph"]) < hi)
        noise = col["noise"]
        arw = noise["angle_random_walk"]["arw_deg_rt_h"]
        bi = noise["bias_instability"]["bias_instability_dph"]
        # README guide: ARW 2.3-2.6 deg/sqrt(h); BI about 27 (x) and 45 (y, z) deg/h, by hand.
        assert 2.2 <= arw <= 2.7, (axis, arw)
        assert noise["bias_instability"]["status"] == "identified"
        assert (20 <= bi <= 40) if axis == "x" else (35 <= bi <= 55), (axis, bi)
        assert (tmp_path / "a" / f"allan_gyro_{axis}_dps.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "ARW deg/sqrt(h)" in out and "gyro_z_dps" in out


def test_allan_curve_mode_on_fog_curves(tmp_path, capsys):
    f = REAL / "fog_allan_curves" / "ln200_gyro_oadev.csv"
    _need(f)
    code, err = run(["allan", "--curve", f, "--curve-ci", "0.95", "--out", tmp_path / "c"])
    assert code == 0, err
    doc = json.loads((tmp_path / "c" / "allan.json").read_text())
    for ax in "xyz":
        arw = doc["columns"][ax]["noise"]["angle_random_walk"]["arw_deg_rt_h"]
        assert 0.034 <= arw <= 0.048          # README: about 0.04 deg/sqrt(h) at tau = 1 s
    code, err = run(["allan", "--curve", f])
    assert code == 2 and "--curve-ci" in err


def test_ferraris_calibrate_and_compensate_imucal_session(tmp_path):
    session, ref = REAL / "imucal_ferraris" / "annotated_session.csv", \
        REAL / "imucal_ferraris" / "example_cal.json"
    _need(session)
    _need(ref)
    cols = "acc_x=acc_x:au,acc_y=acc_y:au,acc_z=acc_z:au,gyro_x=gyr_x:au,gyro_y=gyr_y:au," \
           "gyro_z=gyr_z:au"
    code, err = run(["calibrate", "ferraris", session, "--fs", "204.8", "--angle-deg", "-360",
                     "--g", "9.81", "--column", cols, "--out", tmp_path / "cal"])
    assert code == 0, err
    cal = json.loads((tmp_path / "cal.json").read_text())["calibration"]
    r = json.loads(ref.read_text())
    np.testing.assert_allclose(cal["gyro_bias_raw"], r["b_g"], rtol=1e-10)
    np.testing.assert_allclose(np.array(cal["gyro_scale_raw_per_rps"]) * DEG,
                               np.diag(r["K_g"]), rtol=1e-10)
    np.testing.assert_allclose(cal["gyro_misalignment"], r["R_g"], atol=1e-12)
    np.testing.assert_allclose(cal["gyro_g_sensitivity_raw_per_mps2"], r["K_ga"], atol=1e-12)
    code, err = run(["compensate", tmp_path / "cal", session, "--out", tmp_path / "clean.csv"])
    assert code == 0, err
    import pandas as pd

    out = pd.read_csv(tmp_path / "clean.csv")
    src = pd.read_csv(session)
    assert list(out.columns[:len(src.columns)]) == list(src.columns)
    pd.testing.assert_frame_equal(out[src.columns], src, check_dtype=False)
    # Calibrated: |specific force| = g at rest; a rotation integrates to -360 deg.
    static = out[out.part == "z_p"]
    f = np.linalg.norm(static[["acc_x_cal_mps2", "acc_y_cal_mps2", "acc_z_cal_mps2"]], axis=1)
    assert np.mean(f) == pytest.approx(9.81, rel=0.01)
    rot = out[out.part == "z_rot"]["gyro_z_cal_dps"].sum() / 204.8
    assert rot == pytest.approx(-360.0, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# Synthetic logs: calibrate / compensate with a method, and bad input
FS = 100.0


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _log(path: Path, n=400, seed=0, extra=None) -> Path:
    import pandas as pd

    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    temp = 20 + 5 * np.sin(t / 2)
    df = pd.DataFrame({"time_s": t, "gyro_x_dps": 0.01 + 0.002 * (temp - 20)
                       + 1e-4 * rng.standard_normal(n), "temp_c": temp, "note": "a"})
    if extra:
        extra(df)
    df.to_csv(path, index=False)
    return path


def test_calibrate_static_then_compensate_removes_the_thermal_bias(tmp_path):
    log = _log(tmp_path / "cal.csv", n=2000)
    code, err = run(["calibrate", "poly_temp", log, "--static", "--latitude-deg", "0",
                     "--heading-deg", "0", "--out", tmp_path / "m"])
    assert code == 0, err
    code, err = run(["compensate", tmp_path / "m", log, "--out", tmp_path / "clean.csv.gz"])
    assert code == 0, err
    import pandas as pd

    out = pd.read_csv(tmp_path / "clean.csv.gz")
    assert list(out.columns) == ["time_s", "gyro_x_dps", "temp_c", "note", "gyro_x_comp_dps"]
    # At the equator heading north, x sees the full Earth rate, 15.04 deg/h.
    assert out["gyro_x_comp_dps"].mean() * 3600 == pytest.approx(15.041, abs=0.5)
    assert out["gyro_x_comp_dps"].std() < 2e-4


def _no_new_files(tmp_path, before):
    after = {p for p in tmp_path.rglob("*")}
    assert after == before, sorted(str(p) for p in after - before)


BAD = {
    "not increasing": (lambda df: df.__setitem__("time_s", df["time_s"].where(
        df.index != 50, 0.2)), r"line 52, column 'time_s': time not increasing"),
    "duplicated": (lambda df: df.__setitem__("time_s", df["time_s"].where(
        df.index != 50, df["time_s"][49])), r"line 52, column 'time_s': time duplicated"),
    "gap": (lambda df: df.__setitem__("time_s", df["time_s"] + (df.index >= 200) * 1.0),
            r"line 202, column 'time_s': gap of 1.01 s .*after time 1.99;.*--gaps split"),
    "irregular": (lambda df: df.__setitem__("time_s", df["time_s"] + (df.index == 100) * 0.003),
                  r"line 102, column 'time_s': irregular sampling"),
    "nan": (lambda df: df.__setitem__("gyro_x_dps", df["gyro_x_dps"].where(
        df.index != 7, np.nan)), r"line 9, column 'gyro_x_dps': empty or NaN cell"),
    "non-numeric": (lambda df: df.__setitem__("gyro_x_dps", df["gyro_x_dps"].astype(
        object).where(df.index != 9, "1.2.3")), r"line 11, column 'gyro_x_dps': non-numeric "
        r"value '1.2.3'"),
    "unknown unit": (lambda df: df.insert(1, "gyro_x_rpm", df.pop("gyro_x_dps")),
                     r"column 'gyro_x_rpm': unknown unit 'rpm'"),
    "missing column": (lambda df: df.pop("gyro_x_dps"),
                       r"no gyro column"),
}


@pytest.mark.parametrize("case", sorted(BAD))
@pytest.mark.parametrize("command", ["allan", "calibrate", "compensate"])
def test_bad_input_is_refused_and_nothing_written(tmp_path, case, command):
    edit, match = BAD[case]
    good = _log(tmp_path / "good.csv", n=2000)
    bad = _log(tmp_path / "bad.csv", n=2000, extra=edit)
    if command == "compensate":
        assert run(["calibrate", "poly_temp", good, "--rate-dps", "0", "--out",
                    tmp_path / "m"])[0] == 0
    before = {p for p in tmp_path.rglob("*")}
    argv = {"allan": ["allan", bad, "--out", tmp_path / "out"],
            "calibrate": ["calibrate", "poly_temp", bad, "--rate-dps", "0", "--out",
                          tmp_path / "m2"],
            "compensate": ["compensate", tmp_path / "m", bad, "--out", tmp_path / "o.csv"]}
    if case == "missing column" and command == "compensate":
        match = r"missing column for gyro_x"
    code, err = run(argv[command])
    assert code == 2
    import re

    assert re.search(match, err), err
    assert str(bad) in err or "--" in err
    _no_new_files(tmp_path, before)


def test_gaps_split_analyses_the_pieces(tmp_path):
    edit, _ = BAD["gap"]
    bad = _log(tmp_path / "gap.csv", n=4000, extra=edit)
    code, err = run(["allan", bad, "--gaps", "split", "--out", tmp_path / "o"])
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert doc["segments"] == [[0, 200], [200, 4000]]


def test_more_refusals_write_nothing(tmp_path):
    good = _log(tmp_path / "good.csv")
    short = _log(tmp_path / "short.csv", n=5)
    notime = _log(tmp_path / "notime.csv", extra=lambda df: df.pop("time_s"))
    before = {p for p in tmp_path.rglob("*")}
    cases = [
        (["allan", short, "--out", tmp_path / "o"], r"record too short: 5 samples"),
        (["allan", notime, "--out", tmp_path / "o"], r"no time column .* give --fs"),
        (["allan", good, "--fs", "50", "--out", tmp_path / "o"], r"--fs 50 Hz disagrees"),
        (["allan", good, "--column", "gyro_x=Nope:dps", "--out", tmp_path / "o"],
         r"no column 'Nope'"),
        (["allan", tmp_path / "absent.csv", "--out", tmp_path / "o"], r"file not found"),
        (["calibrate", "nosuch", good, "--out", tmp_path / "m"], r"unknown method 'nosuch'"),
        (["calibrate", "poly_temp", good, "--out", tmp_path / "m"], r"needs exactly one of"),
        (["calibrate", "ferraris", good, "--angle-deg", "360", "--out", tmp_path / "m"],
         r"missing column for acc_x"),
        (["compensate", tmp_path / "nomodel", good, "--out", tmp_path / "o.csv"],
         r"model file not found"),
        (["compensate", tmp_path / "nomodel", good, "--out", good], r"is an input"),
    ]
    for argv, match in cases:
        code, err = run(argv)
        assert code == 2, argv
        import re

        assert re.search(match, err), (argv, err)
    _no_new_files(tmp_path, before)


def test_allan_does_not_overwrite_unasked(tmp_path):
    good = _log(tmp_path / "good.csv", n=2000)
    assert run(["allan", good, "--out", tmp_path / "o"])[0] == 0
    stamp = (tmp_path / "o" / "allan.json").read_bytes()
    code, err = run(["allan", good, "--out", tmp_path / "o"])
    assert code == 2 and "--overwrite" in err
    assert (tmp_path / "o" / "allan.json").read_bytes() == stamp
    assert run(["allan", good, "--out", tmp_path / "o", "--overwrite"])[0] == 0


def test_log_error_is_a_value_error():
    assert issubclass(LogError, ValueError)
