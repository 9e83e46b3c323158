"""Inputs read with a bound: a device file that is a device node or a named pipe, an oversized
file, a FOGBENCH_REFERENCE that is not a value of --reference, a lab that believes a latitude
beyond the pole: each refused before any work with one line naming it, nothing written."""

from __future__ import annotations

import os
import sys
import time

import pytest

from helpers import run_cli

SCENARIO = """[scenario]
name = "s"
sample_rate_hz = 100.0
[table]
latitude_deg = {lat}
[fog]
{fog}
[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "rate"
duration_s = 1.0
rate_dps = 10.0
[[protocols]]
name = "p"
fit = [{{ run = "a", end_s = 0.5 }}]
score = [{{ run = "a", start_s = 0.5 }}]
{lab}
[[methods]]
name = "model_lstsq"
"""


def _write(tmp_path, fog='preset = "tactical"', lat=45.0, lab=""):
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO.format(fog=fog, lat=lat, lab=lab))
    return p


def _listing(d):
    return sorted(str(q.relative_to(d)) for q in d.rglob("*"))


@pytest.mark.parametrize("device", ["/dev/zero", "fifo"])
def test_a_device_file_that_is_not_a_regular_file_is_refused_at_once(tmp_path, device):
    if device == "fifo":
        device = str(tmp_path / "fifo")
        os.mkfifo(device)               # opening it would wait for a writer for ever
    p = _write(tmp_path, fog=f'device = "{device}"')
    before = _listing(tmp_path)
    t0 = time.monotonic()
    code, out, err = run_cli("run", p, "--out", tmp_path / "run", "--quiet")
    assert code == 2 and time.monotonic() - t0 < 30
    assert err.strip().splitlines()[-1] == (
        f"fogbench: error: {p}: [fog] key 'device': '{device}' ({device}): {device}: not a "
        "regular file (a pipe, device or socket); expected a device file (TOML)")
    assert _listing(tmp_path) == before


def test_an_oversized_scenario_file_is_refused_before_it_is_read(tmp_path):
    p = tmp_path / "big.toml"
    with open(p, "wb") as f:
        f.truncate(5 * 2**20)
    code, _, err = run_cli("check", p)
    assert code == 2
    assert "larger than any scenario file" in err and str(p) in err


def test_a_reference_variable_that_is_not_a_flag_value_is_refused(tmp_path, monkeypatch):
    p = _write(tmp_path)
    monkeypatch.setenv("FOGBENCH_REFERENCE", "Lab")
    code, _, err = run_cli("run", p, "--out", tmp_path / "run", "--quiet")
    assert code == 2
    assert "FOGBENCH_REFERENCE='Lab': expected 'lab' or 'truth'" in err
    assert not (tmp_path / "run").exists()
    monkeypatch.setenv("FOGBENCH_REFERENCE", "lab")    # a right value is taken
    code, _, err = run_cli("check", p)
    assert code == 0, err


def test_a_lab_believing_a_latitude_beyond_the_pole_is_refused(tmp_path):
    p = _write(tmp_path, lat=89.0, lab='[lab]\nlatitude_error_deg = 5.0\n')
    code, _, err = run_cli("check", p)
    assert code == 2
    assert "[lab] key 'latitude_error_deg': the lab would believe a latitude of 94 deg" in err
    ok = _write(tmp_path, lat=89.0, lab='[lab]\nlatitude_error_deg = -5.0\n')
    assert run_cli("check", ok)[0] == 0


def test_a_map_file_naming_itself_or_another_map_is_refused_naming_why(tmp_path):
    (tmp_path / "self.toml").write_text('scenario = "self.toml"\n[map]\n')
    (tmp_path / "a.toml").write_text('scenario = "b.toml"\n[map]\n')
    (tmp_path / "b.toml").write_text('scenario = "s.toml"\n[map]\n')
    _write(tmp_path)
    code, _, err = run_cli("check", tmp_path / "self.toml")
    assert code == 2 and "is this map file itself" in err
    code, _, err = run_cli("check", tmp_path / "a.toml")
    assert code == 2 and "is a map file too" in err


@pytest.mark.parametrize("ci", ["2", "-1", "0", "1"])
def test_a_curve_interval_probability_outside_0_1_is_refused(tmp_path, ci):
    curve = tmp_path / "c.csv"
    curve.write_text("tau_s,adev_dph,adev_ci_low_dph,adev_ci_high_dph\n1,1,0.9,1.1\n"
                     "2,0.8,0.7,0.9\n4,0.6,0.5,0.7\n")
    code, _, err = run_cli("allan", "--curve", curve, "--curve-ci", ci, "--fs", "10",
                           "--samples", "1000")
    assert code == 2
    assert err.strip().splitlines()[-1].startswith(
        "fogbench: error: --curve-ci: expected the probability content")


def test_checking_the_scenarios_folder_checks_its_maps_and_devices_too(tmp_path):
    """`fogbench check scenarios` reads the layout scenarios/ has: its scenario files, and the
    claim maps in maps/ and the device files in devices/ (a broken map file there fails the
    check, naming it); a folder further down (an output, a .venv) is not searched."""
    from pathlib import Path
    import shutil

    repo = Path(__file__).resolve().parents[2] / "scenarios"
    root = tmp_path / "scenarios"
    (root / "maps").mkdir(parents=True)
    (root / "devices").mkdir()
    (root / "out" / "deep").mkdir(parents=True)
    shutil.copy(repo / "paper000_wnn.toml", root)
    shutil.copy(repo / "maps" / "paper000_wnn.toml", root / "maps")
    shutil.copy(repo / "devices" / "adis16405_x.toml", root / "devices")
    (root / "out" / "deep" / "junk.toml").write_text("not = [toml")
    code, out, err = run_cli("check", root)
    assert code == 0, err
    assert f"{root / 'maps' / 'paper000_wnn.toml'}: ok: claim map" in out
    assert f"{root / 'devices' / 'adis16405_x.toml'}: ok: device file" in out
    assert "junk" not in out + err
    (root / "maps" / "paper000_wnn.toml").write_text("[map]\nreplicates = [")
    code, out, err = run_cli("check", root)
    assert code != 0 and str(root / "maps" / "paper000_wnn.toml") in err, (out, err)


def test_a_misspelled_required_key_is_named_beside_the_missing_one(tmp_path):
    """`sample_rate` for `sample_rate_hz`: the missing key's error names the near one the table
    has; a file with none of a scenario's tables is said to be checked as a device file."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "scenarios" / "static_gm.toml").read_text()
    assert "\nsample_rate_hz" in text
    p = tmp_path / "s.toml"
    p.write_text(text.replace("\nsample_rate_hz", "\nsample_rate"))
    code, _, err = run_cli("check", p)
    line = err.strip().splitlines()[-1]
    assert code == 2 and "'sample_rate_hz': missing" in line, err
    assert "the table has 'sample_rate': did you mean 'sample_rate_hz'?" in line, line
    bare = tmp_path / "bare.toml"
    bare.write_text('name = "s1"\nsample_rate = 100.0\n')
    code, _, err = run_cli("check", bare)
    assert code == 2 and "checked as a device file" in err and "unknown key(s)" in err, err
