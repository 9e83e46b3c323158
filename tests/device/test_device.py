"""Device files (fogbench.device, fogbench.scenario.load_device_file): a preset shown as one
runs as the preset does; a fit from simulated static logs recovers the configured keys within
its intervals; `device check` tells a twin of the right device from a wrong one; the real
ADIS16405 log; bad input refused naming file and key, nothing written."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom

from fogbench.bench.device import CASES, round_trip, twin_in_band
from fogbench.device import MARKER, check_device, fit_device, preset_text, twin_curves
from fogbench.device.fit import StaticLog, earth_projection
from fogbench.scenario import ScenarioError, load_scenario
from fogbench.scenario.device_file import load_device_file
from fogcomp.allan import allan_analysis
from fogcomp.units import DPH
from sim.fog import FogParams, simulate_fog
from sim.rig import load_presets

from helpers import SMALL_SCENARIO, need_realdata, realdata_dir, run_cli

ADIS = realdata_dir() / "adis16405_static" / "imu1.csv.gz"
ROUND_TRIP_FAST = ("tactical", "mems_adis16405")     # the rest: slow, and fogbench bench


def _load(path):
    from fogbench.scenario.load import RUNNER_SECTIONS

    return load_scenario(path, extra_sections=RUNNER_SECTIONS)


def _write_log(path: Path, rate: np.ndarray, fs: float, acc_g=None, axis: str = "z") -> Path:
    """A static log CSV: time and the gyro (deg/s), with ``acc_g`` (3,) the accelerometer
    columns at that constant specific force (g)."""
    t = np.arange(rate.size) / fs
    with open(path, "w") as f:
        f.write(f"time_s,gyro_{axis}_dps" + (",acc_x_g,acc_y_g,acc_z_g" if acc_g is not None
                                             else "") + "\n")
        tail = "" if acc_g is None else "," + ",".join(f"{x:g}" for x in acc_g)
        for a, b in zip(t, np.degrees(rate)):
            f.write(f"{a:.6f},{b:.9e}{tail}\n")
    return path


def _static(params: FogParams, fs: float, n: int, seed: int) -> np.ndarray:
    z = np.zeros((n, 3))
    return simulate_fog(params, fs, z, z, axes=("z",), seed=seed).raw[:, 0]


# ---------------------------------------------------------------------------------------------
# one format: presets, device files, scenarios
@pytest.mark.parametrize("name", sorted(load_presets()))
def test_a_preset_shown_as_a_device_file_is_the_preset(name, tmp_path):
    text = preset_text(name)
    assert tomllib.loads(text) == load_presets()[name]       # same keys, same values
    dev = tmp_path / "dev.toml"
    dev.write_text(text)
    assert load_device_file(dev) == load_presets()[name]
    a = tmp_path / "a.toml"
    b = tmp_path / "b.toml"
    a.write_text(SMALL_SCENARIO.replace('preset = "tactical"', f'preset = "{name}"'))
    b.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "dev.toml"'))
    sa, sb = _load(a), _load(b)
    assert sa.fog == sb.fog and sa.thermal_model == sb.thermal_model
    assert "device file dev.toml" in sb.device and load_presets()[name]["source"] in sb.device


def test_scenario_keys_override_a_device_file_and_the_report_names_them(tmp_path):
    (tmp_path / "dev.toml").write_text(preset_text("tactical"))
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"',
                                        'device = "dev.toml"\narw_deg_rt_h = 0.5'))
    sc = _load(s)
    assert sc.fog.arw == pytest.approx(0.5 * math.radians(1) / 60)
    assert "arw_deg_rt_h = 0.5" in sc.device


@pytest.mark.parametrize("body, where", [
    ("arw_deg_rt_h = nan\n", "arw_deg_rt_h"),
    ("arw_deg_rt_h = -1.0\n", "arw_deg_rt_h"),
    ("arw_deg_rt_hh = 1.0\n", "arw_deg_rt_hh"),
    ('preset = "tactical"\n', "preset"),
    ('axes = ["z"]\n', "axes"),
    ("[fog]\narw_deg_rt_h = 1.0\n", "[fog]"),
    ("arw_deg_rt_h = \n", "not valid TOML"),
])
def test_bad_device_files_are_refused_naming_file_and_key(tmp_path, body, where):
    dev = tmp_path / "dev.toml"
    dev.write_text(body)
    with pytest.raises(ScenarioError) as e:
        load_device_file(dev)
    assert str(dev) in str(e.value) and where in str(e.value)
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "dev.toml"'))
    code, out, err = run_cli("check", s)
    assert code == 2 and str(dev) in err and where in err


def test_device_file_not_utf8_missing_or_with_a_preset_is_refused(tmp_path):
    dev = tmp_path / "dev.toml"
    dev.write_bytes(b"source = \"caf\xe9\"\n")
    with pytest.raises(ScenarioError, match="not UTF-8"):
        load_device_file(dev)
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "missing.toml"'))
    with pytest.raises(ScenarioError, match="missing.toml"):
        _load(s)
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"',
                                        'preset = "tactical"\ndevice = "dev.toml"'))
    with pytest.raises(ScenarioError, match="not both"):
        _load(s)


# ---------------------------------------------------------------------------------------------
# fitting
def _covers(fit, key, true) -> bool:
    e = fit.entry(key)
    return e is not None and e.low <= true <= e.high


def test_earth_projection_against_the_navigation_frame():
    """Up at latitude L: Omega sin L; level north: Omega cos L; level east: 0 (an independent
    statement of the Earth rate in the local level frame)."""
    om = 7.2921150e-5
    assert earth_projection(45.0, "up") == pytest.approx(om * math.sqrt(0.5))
    assert earth_projection(45.0, "down") == pytest.approx(-om * math.sqrt(0.5))
    assert earth_projection(30.0, "level", 0.0) == pytest.approx(om * math.cos(math.radians(30)))
    assert abs(earth_projection(30.0, "level", 90.0)) < 1e-15


@pytest.mark.parametrize("case", [c for c in CASES if c.preset in ROUND_TRIP_FAST],
                         ids=lambda c: c.preset)
def test_round_trip_on_six_seeds_finds_no_interval_that_misses_too_often(case):
    """The ``make test`` twin of the 20-seed test below, on 6 seeds: a key whose 68 % interval
    covers the configured value in so few seeds that a working 68 % interval would do it in
    under 5 % of trials fails (one or none of six; a vector key's components pooled). It catches
    a broken fit or an interval several times too narrow; the 60 % criterion needs 20 seeds.
    And the twin of one fit: its median Allan deviation inside the preset's 95 % band."""
    res = round_trip(case, seeds=6)
    _judge(case, res, rule="binomial")
    assert twin_in_band(case) >= 0.9


#: Known short of the 60 %: low_grade's ARW, 11 of 20 once the noise comes from all eight logs
#: pooled (12 of 19 from the longest alone). Over those 20 seeds the fitted ARW scatters by 7 %
#: of its value while its 68 % interval is +-2.8 % (+-3.6 % from one log): the identifier's
#: interval is too narrow where the 2 arcsec quantization and the white noise overlap at 100 Hz,
#: which pooling, narrowing the interval, exposes. Strict: it fails once the interval is right.
_LOW_GRADE_ARW = pytest.mark.xfail(strict=True, reason="low_grade ARW interval too narrow "
                                   "under quantization (11 of 20 pooled)")


@pytest.mark.slow
@pytest.mark.parametrize("case", [pytest.param(c, marks=_LOW_GRADE_ARW)
                                  if c.preset == "low_grade" else c for c in CASES],
                         ids=lambda c: c.preset)
def test_round_trip_each_determined_key_within_its_interval_in_60_pct_of_20_seeds(case):
    """Static logs of a preset (its noise, bias and switch-on bias) simulated, a device file
    fitted, compared with the preset: every key the fit determines in 5 or more of 20 seeds
    covers the configured value with its 68 % interval in at least 60 % of them (the issue's
    criterion; a term the preset does not have counts as configured 0, so a spurious one is a
    miss). Also ``fogbench bench`` (its round-trip table)."""
    _judge(case, round_trip(case, seeds=20))
    assert twin_in_band(case) >= 0.9


def _judge(case, res, rule="60 %"):
    """Every key determined in 5 or more seeds covers in 60 % of them; a vector key (the g and
    g^2 terms) is one key: its components' seeds pooled (each component alone, 20 seeds of a
    68 % interval, falls below 12 of 20 with probability 0.1: among 9 components one would)."""
    assert "arw_deg_rt_h" in res and "bias_dph" in res and "switch_on_bias_dph" in res, res
    assert "scale_factor_ppm" in res and "g_sens_dph_per_g[0]" in res, res
    pooled: dict = {}
    for key, (det, cov) in res.items():
        c = pooled.setdefault(key.split("[")[0], [0, 0])
        c[0] += det
        c[1] += cov
    for key, (det, cov) in pooled.items():
        if det >= 5 and rule == "binomial":
            # P(covers <= cov | det trials, 0.683) under 5 %: too few for a 68 % interval
            assert binom.cdf(cov, det, 0.683) >= 0.05, (case.preset, key, det, cov)
        elif det >= 5:
            assert cov / det >= 0.6, (case.preset, key, det, cov)


def test_switch_on_spread_removes_the_noise_of_each_mean():
    """No switch-on change at all, noisy short logs: the fitted repeatability is small against
    the spread of the raw means (the part each mean's own noise explains is taken out)."""
    params = FogParams(arw=0.5 * math.radians(1) / 60)
    logs = [StaticLog(f"s{k}", _static(params, 10.0, 600, k), 10.0) for k in range(12)]
    fit = fit_device(logs)
    raw_sd = np.std([np.mean(s.rate) for s in logs], ddof=1) / DPH
    sw = fit.entry("switch_on_bias_dph")
    assert sw.low == 0.0 and sw.value < 0.6 * raw_sd


def test_three_power_ons_warn_that_they_bound_the_repeatability_poorly():
    params = FogParams(arw=0.03 * math.radians(1) / 60, switch_on_bias_sigma=0.5 * DPH)
    logs = [StaticLog(f"s{k}", _static(params, 10.0, 3600, k), 10.0) for k in range(3)]
    fit = fit_device(logs)
    assert any("3 power-ons bound the switch-on repeatability poorly" in n for n in fit.notes)
    assert "switch_on_bias_dph" in fit.values()


# ---------------------------------------------------------------------------------------------
# the command line
def test_fit_cli_writes_a_device_file_that_a_scenario_runs(tmp_path):
    params = FogParams(arw=0.05 * math.radians(1) / 60, bias=2.0 * DPH)
    earth = earth_projection(45.0, "up")      # the log holds the Earth rate, up at 45 deg
    log = _write_log(tmp_path / "static.csv", _static(params, 10.0, 36_000, 3) + earth, 10.0)
    dev = tmp_path / "my.toml"
    code, out, err = run_cli("device", "fit", "--static", log, "--latitude-deg", "45",
                             "--input-axis", "up", "--out", dev)
    assert code == 0, err
    text = dev.read_text()
    assert text.startswith(MARKER) and "switch_on_bias_dph: default" in text
    doc = load_device_file(dev)
    # 2 deg/h of bias plus the Earth rate's 10.6 deg/h: the fit takes the Earth rate out
    assert doc["bias_dph"] == pytest.approx(2.0, abs=0.3)
    assert doc["arw_deg_rt_h"] == pytest.approx(0.05, rel=0.1)
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "my.toml"'))
    code, out, err = run_cli("check", s)
    assert code == 0, err
    # a second fit over it only with --overwrite; never over a file it did not write
    code, _, err = run_cli("device", "fit", "--static", log, "--out", dev)
    assert code == 2 and "--overwrite" in err
    code, _, err = run_cli("device", "fit", "--static", log, "--out", dev, "--overwrite")
    assert code == 0, err
    other = tmp_path / "mine.toml"
    other.write_text("# my notes\n")
    code, _, err = run_cli("device", "fit", "--static", log, "--out", other, "--overwrite")
    assert code == 2 and "not a device file written by fogbench device fit" in err
    assert other.read_text() == "# my notes\n"


@pytest.mark.parametrize("extra, msg", [
    ([], "give at least one --static"),
    (["--multipos", "{mp}", "--reference", "ref_dps"], "give at least one --static"),
    (["--static", "{log}", "--multipos", "{mp}"], "give --reference COLUMN"),
    (["--static", "{log}", "--multipos", "{mp}", "--reference", "table_dps"],
     "no column 'table_dps'"),
    (["--static", "{log}", "--multipos", "{mp}", "--reference", "ref"], "rate unit suffix"),
    (["--static", "{log}", "--reference", "ref_dps"], "--reference: only with --multipos"),
    (["--static", "{log}", "--multipos", "{mp}", "--reference", "ref_dps",
      "--full-scale-dps", "-5"], "--full-scale-dps"),
    (["--static", "{log}", "--multipos", "{log}", "--reference", "ref_dps"], "acc_x"),
    (["--static", "{log}", "--latitude-deg", "45"], "--input-axis"),
    (["--static", "{log}", "--latitude-deg", "95", "--input-axis", "up"], "--latitude-deg"),
    (["--static", "{log}", "--heading-deg", "10"], "only with --latitude-deg"),
    # the static log has no acc_x/y/z and no stated attitude: its bias cannot be freed of the
    # multi-position fit's g terms
    (["--static", "{log}", "--multipos", "{mp}", "--reference", "ref_dps"],
     "static log {log}: no accelerometer columns (acc_x, acc_y, acc_z) and no stated attitude"),
    (["--static", "{log}", "--multipos", "{mp}", "--reference", "ref_dps", "--input-axis",
      "level"], "or --input-axis up or down"),
    (["--static", "{log}", "--latitude-deg", "45", "--input-axis", "level"], "--heading-deg"),
    (["--static", "{log}", "--ci", "1.5"], "--ci"),
    (["--static", "{missing}"], "missing.csv"),
    # three gyro columns without --axis are a triad fit (tests/device/test_device_triad.py);
    # two are neither one gyro nor a triad
    (["--static", "{two}"], "2 gyro columns (gyro_x, gyro_y): a triad device file needs"),
    (["--static", "{three}", "--thermal", "{log}"], "--thermal: a triad fit"),
    (["--static", "{log}", "--out", "{log}"], "input"),
])
def test_fit_cli_refuses_bad_input_and_writes_nothing(tmp_path, extra, msg):
    log = _write_log(tmp_path / "static.csv", _static(FogParams(arw=1e-4), 10.0, 200, 1), 10.0)
    three = tmp_path / "three.csv"
    three.write_text("time_s,gyro_x_dps,gyro_y_dps,gyro_z_dps\n" + "".join(
        f"{i / 10:.1f},{np.sin(i)},{np.cos(i)},{np.sin(2 * i)}\n" for i in range(200)))
    two = tmp_path / "two.csv"
    two.write_text("time_s,gyro_x_dps,gyro_y_dps\n" + "".join(
        f"{i / 10:.1f},{np.sin(i)},{np.cos(i)}\n" for i in range(200)))
    mp = tmp_path / "multipos.csv"
    mp.write_text("time_s,gyro_z_dps,acc_x_g,acc_y_g,acc_z_g,ref_dps\n" + "".join(
        f"{i / 10:.1f},{np.sin(i)},0,0,{1 if i < 100 else -1},0.004\n" for i in range(200)))
    before = sorted(p.name for p in tmp_path.iterdir())
    args = [a.format(log=log, missing=tmp_path / "missing.csv", three=three, two=two, mp=mp)
            for a in extra]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "out" / "dev.toml")]
    code, _, err = run_cli("device", "fit", *args)
    assert code == 2 and msg.format(log=log) in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert log.read_text().startswith("time_s,gyro_z_dps")


def test_show_prints_a_preset_and_refuses_an_unknown_name(tmp_path):
    code, out, _ = run_cli("device", "show", "navigation")
    assert code == 0 and tomllib.loads(out) == load_presets()["navigation"]
    code, _, err = run_cli("device", "show", "no_such")
    assert code == 2 and "tactical" in err


# ---------------------------------------------------------------------------------------------
# check
def test_check_tells_the_right_twin_from_a_wrong_one():
    """A log of a device: its own twin agrees at (nearly) every averaging time; a twin with
    three times the ARW does not at the short ones (where the ARW shows)."""
    fs, n = 10.0, 36_000
    right = FogParams(arw=0.05 * math.radians(1) / 60, bias_instability=0.5 * DPH,
                      bi_band=(1e-6, 1.0))
    wrong = FogParams(arw=0.15 * math.radians(1) / 60, bias_instability=0.5 * DPH,
                      bi_band=(1e-6, 1.0))
    y = _static(right, fs, n, 77)
    curve, _ = allan_analysis(y, fs, ci=0.95)
    good = check_device(curve, twin_curves(right, fs, [(0, n)], curve.taus, 20, seed=1))
    bad = check_device(curve, twin_curves(wrong, fs, [(0, n)], curve.taus, 20, seed=1))
    assert good["share"] >= 0.9
    assert bad["share"] <= 0.6 and not bad["agree"][:4].any()


def test_check_cli_writes_its_folder_and_refuses_a_bad_device(tmp_path):
    params = FogParams(arw=0.05 * math.radians(1) / 60)
    log = _write_log(tmp_path / "static.csv", _static(params, 10.0, 6000, 3), 10.0)
    dev = tmp_path / "my.toml"
    code, _, err = run_cli("device", "fit", "--static", log, "--out", dev)
    assert code == 0, err
    code, out, err = run_cli("device", "check", dev, log, "--replicates", "19",
                             "--out", tmp_path / "chk")
    assert code == 0, err
    assert "whole-curve test" in out and "agrees with the device" in out
    assert (tmp_path / "chk" / "device_check.json").exists()
    assert (tmp_path / "chk" / "device_check.png").stat().st_size > 10_000
    assert "agree within their intervals at" in out
    for r in ("3", "18", "100000000"):   # too few for a 5 % test; more than any needs
        code, _, err = run_cli("device", "check", dev, log, "--replicates", r)
        assert code == 2 and "--replicates" in err
    bad = tmp_path / "bad.toml"
    bad.write_text("arw_deg_rt_h = 'a lot'\n")
    code, _, err = run_cli("device", "check", bad, log, "--out", tmp_path / "chk2")
    assert code == 2 and str(bad) in err and "arw_deg_rt_h" in err
    assert not (tmp_path / "chk2").exists()


# ---------------------------------------------------------------------------------------------
# the real ADIS16405 log
def test_adis16405_twin_agrees_with_the_real_curve_except_where_the_sensor_filters(tmp_path):
    """The loop on a real log: a device file fitted to the ADIS16405 static log (x axis, noise
    fitted from 0.04 s on), its twin simulated under the log's conditions. Measured (README):
    the two Allan curves agree within their intervals at 74 % of the averaging times, short of
    the issue's 90 %: at 0.01-0.04 s the log lies below the white-noise line (17 % at 0.01 s:
    the sensor's own low-pass filtering, which the error model does not have), and around
    0.64 s it is 2 % above the twin where its interval is +-0.9 %. From 1 s on they agree."""
    need_realdata(ADIS)
    dev = tmp_path / "adis.toml"
    code, out, err = run_cli("device", "fit", "--static", ADIS, "--axis", "x", "--min-tau-s",
                             "0.04", "--out", dev)
    assert code == 0, err
    doc = load_device_file(dev)
    assert 2.2 <= doc["arw_deg_rt_h"] <= 2.7        # realdata README: 2.3-2.6 deg/sqrt(h)
    assert 20 <= doc["bias_instability_dph"] <= 40   # realdata README: about 27 on x
    code, out, err = run_cli("device", "check", dev, ADIS, "--axis", "x", "--replicates", "19",
                             "--out", tmp_path / "chk")
    import json

    res = json.loads((tmp_path / "chk" / "device_check.json").read_text())
    # the whole curve disagrees: below 0.04 s the sensor's own filter, which the error model
    # lacks, puts the log below every twin (exit status 1, the check failing as it should)
    assert code == 1 and res["verdict"] == "disagrees" and res["p_value"] <= 0.05, err
    tau, agree = np.array(res["tau_s"]), np.array(res["agree"])
    assert res["share_agree"] >= 0.7
    assert agree[tau >= 1.0].all()
    low = np.array(res["log_adev_dph"]) < np.array(res["twin_low_dph"])
    assert low[tau <= 0.04].all()          # the log below the twin where the sensor filters


def test_a_map_point_on_a_device_file_is_the_scenario_with_that_device(tmp_path):
    """`unset = ["fog.preset"]` with `set = {"fog.device" = ...}`: the point's device is the
    device file's, as a plain scenario naming it gives; `fogbench check` takes device files."""
    from fogbench.scenario import load_plan

    (tmp_path / "dev.toml").write_text(preset_text("navigation"))
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO + '''
[map]
replicates = 2
[[map.axes]]
name = "device"
source = "test"
[[map.axes.points]]
label = "preset"
[[map.axes.points]]
label = "file"
set = { "fog.device" = "dev.toml" }
unset = ["fog.preset"]
''')
    plan = load_plan(_load(s))
    from fogbench.scenario.load import RUNNER_SECTIONS

    point = next(p for p in plan.map.points if p.labels == ("file",))
    at_point = load_scenario(s, extra_sections=RUNNER_SECTIONS, overrides=point.overrides)
    plain = tmp_path / "plain.toml"
    plain.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "dev.toml"'))
    assert at_point.fog == _load(plain).fog != _load(s).fog
    code, out, err = run_cli("check", tmp_path / "dev.toml", s)
    assert code == 0, err
    assert "ok: device file" in out and "a claim map of 2 point(s)" in out
    s.write_text(s.read_text().replace('unset = ["fog.preset"]',
                                       'unset = ["fog.preset", "fog.device"]'))
    code, _, err = run_cli("check", s)
    assert code == 2 and "unset" in err and "also in set" in err


def test_a_run_keeps_the_device_it_ran_and_resume_refuses_an_edited_one(tmp_path):
    """The device file's text goes with the scenario's: into the run folder's scenario.toml,
    and into the digest --resume compares, so an edited device file is refused before any
    work; an error in the device file names the scenario that asked for it."""
    dev = tmp_path / "dev.toml"
    dev.write_text(preset_text("tactical"))
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "dev.toml"'))
    out = tmp_path / "run"
    code, _, err = run_cli("run", s, "--out", out, "--replicates", "2", "--no-recording",
                           "--no-figures")
    assert code == 0, err
    kept = (out / "scenario.toml").read_text()
    assert "arw_deg_rt_h = 0.03" in kept and "sha256" in kept
    dev.write_text(preset_text("tactical").replace("arw_deg_rt_h = 0.03", "arw_deg_rt_h = 0.06"))
    code, _, err = run_cli("run", s, "--out", out, "--replicates", "3", "--resume",
                           "--no-recording", "--no-figures")
    assert code == 2 and "Traceback" not in err, err
    dev.write_text("arw_deg_rt_h = -1.0\n")
    code, _, err = run_cli("check", s)
    assert code == 2 and str(s) in err and "[fog] key 'device'" in err and str(dev) in err


def test_resume_after_the_device_file_was_edited_names_the_device_file(tmp_path):
    """Replicates kept by a killed run, then the device file edited: --resume refuses naming the
    device file, not "the scenario file was edited"."""
    from fogbench.run.montecarlo import MonteCarloError, ScenarioMC

    dev = tmp_path / "dev.toml"
    dev.write_text(preset_text("tactical"))
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "dev.toml"'))
    first = ScenarioMC(s, tmp_path / "run", replicates=3)
    first.run_first()                     # replicate 0 kept, then the process "is killed"
    first.work.release()
    dev.write_text(preset_text("tactical").replace("arw_deg_rt_h = 0.03", "arw_deg_rt_h = 0.06"))
    with pytest.raises(MonteCarloError, match="another device file, or of the scenario's device "
                                              "file before it was edited"):
        ScenarioMC(s, tmp_path / "run", replicates=3, resume=True)


# ---------------------------------------------------------------------------------------------
# thermal
def _thermal_run(name: str, fs: float, seed: int):
    """A static log (2 h) and a thermal run (20 -> 40 -> 0 -> 20 deg C at 0.5 deg C/min, 6.3 h)
    of a preset: its noise and temperature terms, its thermal build and sensor."""
    from fogbench.bench.joint import _thermal_program
    from fogbench.bench.noise import _noise_only
    from fogbench.device.thermal import ThermalLog
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table
    from sim.thermal import simulate_thermal

    params, _, _, _, model, _ = _fog(_Table({"preset": name}, "[fog]", "test"), fs)
    prog = _thermal_program()
    n = int(prog.duration * fs)
    th = simulate_thermal(prog, np.arange(n) / fs, model, seed=seed)
    z = np.zeros((n, 3))
    y = simulate_fog(params, fs, z, z, temp=th.coil, temp_rate=th.coil_rate, axes=("z",),
                     seed=seed).raw[:, 0]
    static = StaticLog("static", _static(_noise_only(params), fs, int(2 * 3600 * fs),
                                         seed + 10**6), fs)
    return static, ThermalLog("thermal", y, th.sensor, fs)


@pytest.mark.parametrize("name, fs", [("tactical", 10.0), ("paper002_fog", 1.0)])
def test_thermal_fit_covers_the_presets_temperature_terms(name, fs):
    """A thermal run of a preset (sensor on the coil for tactical; on the housing, the coil
    1582 s behind it, for paper002_fog), the noise model from a static log: each temperature
    coefficient's 68 % interval covers the preset's value in at least 60 % of 10 seeds, and
    where the fit places the sensor (the coil, or the housing with a lag) it is where the
    preset has it in at least 60 % of those seeds."""
    from fogbench.device.thermal import KEYS

    truth = {k: load_presets()[name].get(k, 0.0) for k, _ in KEYS}
    hits = {k: 0 for k in truth}
    places, lags = [], []
    for seed in range(10):
        static, thermal = _thermal_run(name, fs, seed)
        fit = fit_device([static], thermal=thermal)
        for k in truth:
            e = fit.entry(k)
            hits[k] += e.low <= truth[k] <= e.high
        lag = fit.entry("coil_time_constant_s")
        if lag is not None:
            lags.append((lag.low, lag.high))
        loc = fit.entry("temp_sensor_location")
        places.append(None if loc is None else loc.value)
    for k, h in hits.items():
        assert h >= 6, (name, k, hits)
    # the lag's 68 % profile interval excludes the true lag now and then: judged like the rest
    placed = [p for p in places if p is not None]
    right = sum(p == load_presets()[name]["temp_sensor_location"] for p in placed)
    assert right >= 0.6 * len(placed), places
    if name == "paper002_fog":     # the coil 1582 s behind the housing it reads
        assert len(lags) >= 6 and sum(a <= 1582.0 <= b for a, b in lags) >= 0.6 * len(lags), lags
    print(name, hits, places, lags)


def test_thermal_fit_from_the_command_line(tmp_path):
    static, thermal = _thermal_run("paper002_fog", 1.0, 3)
    s = _write_log(tmp_path / "static.csv", static.rate, 1.0)
    t = tmp_path / "thermal.csv"
    with open(t, "w") as f:
        f.write("time_s,gyro_z_dps,temp_c\n")
        for i, (a, b) in enumerate(zip(np.degrees(thermal.rate), thermal.temp)):
            f.write(f"{i:.1f},{a:.9e},{b:.4f}\n")
    dev = tmp_path / "dev.toml"
    code, out, err = run_cli("device", "fit", "--thermal", t, "--out", dev)
    assert code == 2 and "those fits need their noise model" in err and not dev.exists()
    nocol = tmp_path / "notemp.csv"
    nocol.write_text("\n".join(ln.rsplit(",", 1)[0] for ln in t.read_text().splitlines()))
    code, out, err = run_cli("device", "fit", "--static", s, "--thermal", nocol, "--out", dev)
    assert code == 2 and "temp" in err and not dev.exists()
    code, out, err = run_cli("device", "fit", "--static", s, "--thermal", t, "--out", dev)
    assert code == 0, err
    doc = load_device_file(dev)
    assert doc["temp_sensor_location"] == "housing"
    assert 0.3 < doc["temp_rate_coeff_dph_per_c_per_min"] < 0.7     # preset: 0.462
    assert "thermal log" in dev.read_text()


@pytest.mark.parametrize("k, m", [(1, 6), (2, 5), (7, 9), (30, 4)])
def test_block_covariance_against_the_sample_covariance_averaged_by_brute_force(k, m):
    """The covariance of m means of k samples equals A S A' with S the Toeplitz matrix of the
    samples' autocovariance and A the averaging matrix (a slow obvious twin)."""
    from scipy.linalg import toeplitz

    from fogbench.device.thermal import block_covariance
    from fogbench.run.runner import noise_autocovariance

    p = FogParams(arw=0.03 * math.radians(1) / 60, bias_instability=0.1 * DPH,
                  bi_band=(1e-6, 0.1), gm_drift=0.2 * DPH, gm_time_constant=50.0,
                  quantization=1e-6)
    S = toeplitz(noise_autocovariance(p, 10.0, m * k))
    A = np.kron(np.eye(m), np.ones((1, k)) / k)
    ref = A @ S @ A.T
    np.testing.assert_allclose(block_covariance(p, 10.0, k, m), ref, rtol=1e-9,
                               atol=1e-12 * np.abs(ref).max())


def test_a_single_ramp_is_refused_as_inseparable():
    from fogbench.device.thermal import ThermalLog, fit_thermal

    fs, n = 1.0, 3600
    T = 20.0 + 20.0 * np.arange(n) / n
    y = 0.01 * DPH * (T - 20.0) + _static(FogParams(arw=1e-5), fs, n, 1)
    with pytest.raises(ValueError, match="cannot separate"):
        fit_thermal(ThermalLog("ramp", y, T, fs), FogParams(arw=1e-5), 0.683)


# ---------------------------------------------------------------------------------------------
# multi-position, centrifuge and rate-table logs
def _positions(*fs, hold=50):
    return np.repeat(np.array(fs, dtype=float), hold, axis=0)


def test_estimability_of_the_g_terms_follows_from_the_positions():
    """Analytic: six positions (each axis up and down) at 1 g determine the linear terms only
    (fx^2 + fy^2 + fz^2 = 1 = the constant; the cross terms are zero); the tumble's 45 deg
    positions add the cross terms but never separate the squares from the constant; a
    centrifuge (other than 1 g) separates them; the scale factor needs a rate."""
    from fogbench.device.multipos import TERMS, design, estimable, lab_program

    names = [n for n, _ in TERMS]
    six = _positions(*np.eye(3), *-np.eye(3))
    got = dict(zip(names, estimable(design(six, np.zeros(len(six))))))
    assert [n for n in names if got[n]] == ["fx", "fy", "fz"]
    c = math.sqrt(0.5)
    tumble = _positions(*np.eye(3), *-np.eye(3), [c, c, 0], [c, -c, 0], [-c, c, 0],
                        [0, c, c], [0, c, -c], [0, -c, c], [c, 0, c], [c, 0, -c], [-c, 0, c])
    got = dict(zip(names, estimable(design(tumble, np.zeros(len(tumble))))))
    assert [n for n in names if not got[n]] == ["constant", "fx^2", "fy^2", "fz^2",
                                                "scale factor", "non-linearity"]
    # x up on a turning table at one rate, +-0.1 rad/s: the scale factor and the
    # non-linearity (ref |ref|, odd in the rate) move together; a second rate separates them
    one = np.vstack([tumble, _positions([1, 0, 0], [1, 0, 0])])
    got = dict(zip(names, estimable(design(one, np.concatenate([np.zeros(len(tumble)),
                                                                np.repeat([0.1, -0.1], 50)])))))
    assert [n for n in names if not got[n]] == ["constant", "fx^2", "fy^2", "fz^2",
                                                "scale factor", "non-linearity"]
    two = np.vstack([tumble, _positions([1, 0, 0], [1, 0, 0], [1, 0, 0])])
    got = dict(zip(names, estimable(design(two, np.concatenate([np.zeros(len(tumble)),
                                                                np.repeat([0.1, -0.1, 0.3],
                                                                          50)])))))
    assert [n for n in names if not got[n]] == ["constant", "fx^2", "fy^2", "fz^2"]
    f, ref, parts = lab_program(1.0, hold_s=10.0)
    assert estimable(design(f, ref)).all() and len(parts) == 38
    # measured attitudes: accelerometer noise (1 mg) and scale errors (0.1 %) leave
    # fx^2 + fy^2 + fz^2 a little off 1; still not separable from the constant
    rng = np.random.default_rng(0)
    measured = tumble * (1 + np.array([1e-3, -5e-4, 2e-4])) + 1e-3 * rng.standard_normal(
        tumble.shape)
    got = dict(zip(names, estimable(design(measured, np.zeros(len(tumble))))))
    assert [n for n in names if not got[n]] == ["constant", "fx^2", "fy^2", "fz^2",
                                                "scale factor", "non-linearity"]


def test_multipos_fit_against_ordinary_least_squares_on_white_noise():
    """White noise only and fewer than 3000 samples (one sample per block): the generalised
    fit is ordinary least squares, so its estimate and standard errors equal numpy's lstsq with
    sigma^2 (X'X)^-1 (a slow obvious twin written out here), and the terms a six-position log
    cannot determine are None."""
    from fogbench.device.multipos import MultiposLog, fit_multipos

    rng = np.random.default_rng(4)
    six = _positions(*np.eye(3), *-np.eye(3), hold=300)
    n, fs, arw = len(six), 10.0, 1e-5
    d = np.array([3.0, -2.0, 1.0]) * DPH
    rate = 5 * DPH + six @ d + rng.standard_normal(n) * arw * math.sqrt(fs)
    res = fit_multipos(MultiposLog("six", rate, np.zeros(n), six, fs), FogParams(arw=arw),
                       ci=0.683)
    X = np.column_stack([np.ones(n), six])            # what six positions determine (bias
    beta, *_ = np.linalg.lstsq(X, rate, rcond=None)    # with the squares; the linear terms)
    resid = rate - X @ beta
    s2 = max(resid @ resid / (n - 4) / (arw**2 * fs), 1.0) * arw**2 * fs
    sd = np.sqrt(np.diag(np.linalg.inv(X.T @ X)) * s2)
    z = 1.0004                                          # norm.ppf(0.8415)
    for j, name in enumerate(("fx", "fy", "fz"), start=1):
        v, lo, hi = res[name]
        assert v == pytest.approx(beta[j], rel=1e-6, abs=1e-12)
        assert (hi - lo) / 2 == pytest.approx(z * sd[j], rel=1e-3)
    for name in ("constant", "fx^2", "fx fy", "scale factor"):
        assert res[name] is None


def test_multipos_fit_from_the_command_line_writes_the_g_keys(tmp_path):
    """A simulated lab program of the tactical preset through the CLI: the g terms, scale
    factor and non-linearity written with intervals, the file runs as a scenario's device;
    a six-position log writes only the linear g terms and says why."""
    from fogbench.device.multipos import lab_program
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table

    fs = 10.0
    preset, *_ = _fog(_Table({"preset": "tactical"}, "[fog]", "test"), fs)
    f, ref, _ = lab_program(fs)
    w = np.zeros((ref.size, 3))
    w[:, 0] = ref
    y = simulate_fog(preset, fs, w, f, axes=("x",), seed=2).raw[:, 0]
    mp = tmp_path / "multipos.csv"
    t = np.arange(ref.size) / fs
    np.savetxt(mp, np.column_stack([t, np.degrees(y), f, np.degrees(ref)]), delimiter=",",
               header="time_s,gyro_z_dps,acc_x_g,acc_y_g,acc_z_g,ref_dps", comments="",
               fmt="%.10g")
    # simulated at zero specific force: its accelerometer says so
    log = _write_log(tmp_path / "static.csv", _static(preset, fs, 36_000, 3), fs, (0, 0, 0))
    dev = tmp_path / "tac.toml"
    code, out, err = run_cli("device", "fit", "--static", log, "--multipos", mp, "--reference",
                             "ref_dps", "--full-scale-dps", "490", "--out", dev)
    assert code == 0, err
    doc = load_device_file(dev)
    assert doc["scale_factor_ppm"] == pytest.approx(100.0, abs=3.0)
    assert doc["sf_nonlinearity_ppm"] == pytest.approx(50.0, abs=6.0)
    assert doc["full_scale_dps"] == 490.0
    # the preset's 0.1 deg/h/g (its interval about +-0.07 at 68 %); g^2 terms 0 (+-0.25)
    assert np.allclose(doc["g_sens_dph_per_g"], 0.1, atol=0.25)
    assert np.any(np.abs(doc["g_sens_dph_per_g"]) > 0.02)      # not the "written 0" path
    assert np.allclose(doc["g2_sens_dph_per_g2"], 0.0, atol=0.8)
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', 'device = "tac.toml"'))
    code, _, err = run_cli("check", s)
    assert code == 0, err
    # six positions only: the linear terms, the rest listed as not identifiable
    six = _positions(*np.eye(3), *-np.eye(3), hold=600)
    y6 = simulate_fog(preset, fs, np.zeros((len(six), 3)), six, axes=("x",), seed=3).raw[:, 0]
    np.savetxt(mp, np.column_stack([np.arange(len(six)) / fs, np.degrees(y6), six,
                                    np.zeros(len(six))]), delimiter=",",
               header="time_s,gyro_z_dps,acc_x_g,acc_y_g,acc_z_g,ref_dps", comments="",
               fmt="%.10g")
    code, out, err = run_cli("device", "fit", "--static", log, "--multipos", mp, "--reference",
                             "ref_dps", "--out", dev, "--overwrite")
    assert code == 0, err
    text = dev.read_text()
    assert "g_sens_dph_per_g = [" in text and "g2_sens_dph_per_g2: default" in text
    assert "scale_factor_ppm: default" in text
    assert "not identifiable from its attitudes and rates: constant (confounded with fx^2" in text


def test_the_json_schema_is_the_validators_own(tmp_path):
    """`device schema` emits the keys and ranges the loader enforces: every preset's keys are in
    it with values inside its ranges, and for every number with a range the loader accepts the
    schema's bounds and refuses a value just past them, naming the key."""
    import json

    code, out, _ = run_cli("device", "schema")
    assert code == 0
    props = json.loads(out)["properties"]
    for name, preset in load_presets().items():
        assert set(preset) <= set(props), (name, set(preset) - set(props))
        for k, v in preset.items():
            p = props[k]
            if p.get("type") == "number":
                assert p.get("minimum", -math.inf) <= v <= p.get("maximum", math.inf), (name, k)
    dev = tmp_path / "d.toml"
    checked = 0
    for k, p in props.items():
        if p.get("type") != "number" or "maximum" not in p:
            continue
        hi = p["maximum"]
        dev.write_text(f"{k} = {hi!r}\n")
        try:
            load_device_file(dev)
        except ScenarioError as exc:   # a bound of a combination (e.g. below another key)
            assert k in str(exc)
            continue
        dev.write_text(f"{k} = {hi + max(abs(hi), 1.0) * 1e-6!r}\n")
        with pytest.raises(ScenarioError, match=k):
            load_device_file(dev)
        checked += 1
    assert checked >= 25


def test_an_empty_device_file_is_refused(tmp_path):
    dev = tmp_path / "empty.toml"
    dev.write_text('# nothing yet\nsource = "me"\n')
    with pytest.raises(ScenarioError, match="holds no \\[fog\\] keys"):
        load_device_file(dev)


def test_fs_given_over_a_curve_header_is_warned_of(tmp_path):
    curve = realdata_dir() / "fog_allan_curves" / "imar_gyro_oadev.csv"
    need_realdata(curve)
    code, _, err = run_cli("device", "fit", "--curve", curve, "--curve-ci", "0.95",
                           "--fs", "1234", "--out", tmp_path / "d.toml")
    assert "--fs 1234 overrides the curve's own sample_rate_hz=" in err, err


def test_one_log_under_two_names_is_one_power_on(tmp_path):
    """The same static log given twice (a copy, or gzipped beside the original) would make the
    switch-on spread 0 [0, 0]: refused, naming both, before any log is read."""
    import gzip
    import shutil

    log = tmp_path / "x.csv"
    rng = np.random.default_rng(1)
    log.write_text("time_s,gyro_x_dps\n" + "".join(
        f"{i / 100:.2f},{v:.6e}\n" for i, v in enumerate(rng.standard_normal(5000) * 1e-3)))
    shutil.copy(log, tmp_path / "copy.csv")
    with open(log, "rb") as f, gzip.open(tmp_path / "x.csv.gz", "wb") as g:
        g.write(f.read())
    for other in ("copy.csv", "x.csv.gz"):
        code, _, err = run_cli("device", "fit", "--static", log, "--static", tmp_path / other,
                               "--axis", "x", "--out", tmp_path / "dev.toml")
        assert code == 2, err
        assert f"the same log as {log}" in err and "the same content under another name" in err
    assert not (tmp_path / "dev.toml").exists()


def test_the_whole_curve_test_is_exact_under_the_null_and_sees_a_missing_term():
    """curve_test on curves with a known law (correlated log-normal Allan deviations at 8
    averaging times, 39 twins): when the log is one more draw, p <= 0.05 in 5 % of 400 trials
    (within the binomial 99.9 % interval); when the log's curve has a term the twins lack (a
    doubling at the longest three taus, about 2.8 of their spread at each), p <= 0.05 in at
    least 90 % (measured: 97 % of 300; a rise of 60 % is seen in 64 %, the diagonal statistic
    giving up the correlation between averaging times, see COVARIANCE_SHRINKAGE)."""
    from scipy.stats import binom

    from fogbench.device.twin import curve_test

    rng = np.random.default_rng(11)
    T, R, trials = 8, 39, 400
    base = np.log(np.geomspace(1.0, 0.2, T))
    A = rng.standard_normal((T, T)) * 0.05 + np.diag(np.linspace(0.05, 0.2, T))
    draw = lambda k: np.exp(base + rng.standard_normal((k, T)) @ A.T)   # noqa: E731
    null = [curve_test(draw(1)[0], draw(R))["p_value"] for _ in range(trials)]
    lo, hi = binom.ppf([0.0005, 0.9995], trials, 0.05) / trials
    rate = np.mean(np.array(null) <= 0.05)
    assert lo <= rate <= hi, rate
    rise = np.ones(T)
    rise[-3:] = 2.0
    alt = [curve_test(draw(1)[0] * rise, draw(R))["p_value"] for _ in range(100)]
    assert np.mean(np.array(alt) <= 0.05) >= 0.9


def test_a_six_position_test_recovers_d1(tmp_path):
    """The classic six-position test (each axis up and down, 10 min each) of paper 004's gyro
    (d1 = 7.352 deg/h/g, paper 004 Table 1, plus its switch-on draw): d1 comes back within its
    interval (the scale-factor columns, excited by the Earth rate alone, took it away: the
    reference is +-Omega sin(latitude) exactly where fx = +-1); the scale factor is said not
    fitted for that reason, and the squares' note names what they are confounded with."""
    from fogbench.device.fit import StaticLog
    from fogbench.device.multipos import MultiposLog, six_positions
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table
    from sim.fog import simulate_fog

    fs = 10.0
    preset, *_ = _fog(_Table({"preset": "paper004_gyro"}, "[fog]", "t"), fs)
    f, ref, _ = six_positions(fs)
    w = np.zeros((ref.size, 3))
    w[:, 0] = ref
    out = simulate_fog(preset, fs, w, f, axes=("x",), seed=4)
    d1 = float(out.draws["g_sens"][0][0]) / DPH
    rest = np.zeros((int(2 * 3600 * fs), 3))
    static = StaticLog("rest", simulate_fog(preset, fs, rest, rest, axes=("x",),
                                            seed=5).raw[:, 0], fs, f=(0.0, 0.0, 0.0),
                       f_source="zero specific force (simulated so)")
    fit = fit_device([static], multipos=MultiposLog("six", out.raw[:, 0], ref, f, fs))
    e = fit.entry("g_sens_dph_per_g")
    assert e is not None and e.low[0] is not None, fit.undetermined
    assert e.low[0] <= d1 <= e.high[0], (d1, e.value[0], e.low[0], e.high[0])
    assert "reference rate stays within" in fit.undetermined["scale_factor_ppm"]
    note = next(n for n in fit.notes if "not identifiable from its attitudes" in n)
    assert "fx^2 (confounded with constant, fy^2, fz^2" in note
    assert "fx fy (not excited" in note


def test_a_thermal_log_with_a_gap_is_refused_without_offering_a_split(tmp_path):
    """The thermal fit needs one continuous record (its temperature lag runs through the whole
    log): a log with a dropout is refused naming the row, and the advice is to give a gap-free
    stretch, not --gaps split (which the thermal fit cannot take); nothing is written."""
    rng = np.random.default_rng(0)
    s = _write_log(tmp_path / "static.csv", rng.standard_normal(4000) * 1e-5, 1.0)
    t = tmp_path / "thermal.csv"
    rows = [f"{i:.1f},{1e-3 * rng.standard_normal():.9e},{20 + i / 200:.4f}"
            for i in range(3000) if not 1000 <= i < 1010]
    t.write_text("time_s,gyro_z_dps,temp_c\n" + "\n".join(rows) + "\n")
    dev = tmp_path / "dev.toml"
    code, out, err = run_cli("device", "fit", "--static", s, "--thermal", t, "--out", dev)
    line = err.strip().splitlines()[-1]
    assert code == 2 and str(t) in line and "gap of 11 s" in line, err
    assert "needs one continuous record" in line and "--gaps split" not in line, line
    assert not dev.exists()


def test_noise_terms_come_from_every_static_log_pooled():
    """Eight static power-ons of 2 h at 10 Hz of a gyro with white noise and flicker (ARW
    0.01 deg/sqrt(h), flicker 0.08 deg/h): the noise terms come from all eight pooled (each
    log's second differences inside it; the switch-on bias between them drops out), not from
    the first: the flicker interval is less than half as wide as one log's (1/sqrt(8) for
    independent logs) and holds 0.08 within 10 %; the file says the logs were pooled. Measured
    over 10 seeds: identified in 10 (one log: 9), median 0.0769 deg/h, 68 % interval covering
    0.08 in 5."""
    from fogbench.device.file import _device_from_values

    fs = 10.0
    n = int(2 * 3600 * fs)
    params = _device_from_values({"arw_deg_rt_h": 0.01, "bias_instability_dph": 0.08}, fs)
    z = np.zeros((n, 3))
    logs = [StaticLog(f"s{k}", simulate_fog(params, fs, z, z, axes=("z",),
                                            seed=500 + k).raw[:, 0] + 1e-5 * k, fs)
            for k in range(8)]
    pooled, one = fit_device(logs), fit_device(logs[:1])
    e, e1 = pooled.entry("bias_instability_dph"), one.entry("bias_instability_dph")
    assert e is not None and e1 is not None
    assert (e.high - e.low) < 0.5 * (e1.high - e1.low), (e, e1)
    assert abs(e.value / 0.08 - 1) < 0.1, e
    assert "8 static logs pooled" in e.source


def _paper004_one_power_on(fs: float):
    """paper 004's gyro with the g terms' switch-on spreads off (one multi-position log
    measures its own power-on's g terms: with them on, a static log of another power-on holds
    other g terms, which no fit of these logs can know)."""
    from dataclasses import replace

    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table

    preset, *_ = _fog(_Table({"preset": "paper004_gyro"}, "[fog]", "t"), fs)
    return replace(preset, g_sens_switch_on_sigma=0.0, g2_sens_switch_on_sigma=0.0)


def test_static_bias_at_one_g_is_freed_of_the_g_terms_the_old_way_double_counts(tmp_path):
    """A static log of paper 004's gyro with its input axis x up (specific force +1 g on x: its
    mean holds d1 + d4 = 8.62 deg/h of g terms) and the lab's multi-position program of the
    same device, fitted together: bias_dph is the preset's bias plus that power-on's switch-on
    draw within its interval; the static mean alone (the fit before this, which the
    simulation then adds the g terms to again) is outside it by the g terms. Through the
    command line too: the accelerometer columns read, the correction noted, the mounting
    written (input_axis = "x")."""
    from fogbench.device.multipos import MultiposLog, lab_program

    fs = 10.0
    dev = _paper004_one_power_on(fs)
    f, ref, _ = lab_program(fs)
    w = np.zeros((ref.size, 3))
    w[:, 0] = ref
    mp = simulate_fog(dev, fs, w, f, axes=("x",), seed=11)
    n = int(2 * 3600 * fs)
    up = np.zeros((n, 3))
    up[:, 0] = 1.0                                    # x up: +1 g on x
    st = simulate_fog(dev, fs, np.zeros((n, 3)), up, axes=("x",), seed=12)
    true_bias = (dev.bias + float(st.draws["switch_on_bias"][0])) / DPH
    g_held = float(st.draws["g_sens"][0][0] + st.draws["g2_sens"][0][0]) / DPH
    assert g_held == pytest.approx(7.352 + 1.268)
    static = StaticLog("up", st.raw[:, 0], fs, f=(1.0, 0.0, 0.0), f_source="stated", axis="x")
    fit = fit_device([static], multipos=MultiposLog("lab", mp.raw[:, 0], ref, f, fs),
                     input_axis="x")
    e = fit.entry("bias_dph")
    assert e.low <= true_bias <= e.high, (true_bias, e.value, e.low, e.high)
    uncorrected = float(np.mean(st.raw[:, 0])) / DPH
    assert not e.low <= uncorrected <= e.high      # the old way: the g terms counted twice
    assert abs(uncorrected - true_bias) > 8.0
    assert any("bias_dph is corrected for the g terms" in n for n in fit.notes)
    assert fit.entry("input_axis").value == "x"
    # the command line: acc columns read from the static log
    log = _write_log(tmp_path / "up.csv", st.raw[:, 0], fs, (1, 0, 0), axis="x")
    mpf = tmp_path / "lab.csv"
    np.savetxt(mpf, np.column_stack([np.arange(ref.size) / fs, np.degrees(mp.raw[:, 0]), f,
                                     np.degrees(ref)]), delimiter=",",
               header="time_s,gyro_x_dps,acc_x_g,acc_y_g,acc_z_g,ref_dps", comments="",
               fmt="%.10g")
    out = tmp_path / "dev.toml"
    code, _, err = run_cli("device", "fit", "--static", log, "--multipos", mpf, "--reference",
                           "ref_dps", "--out", out)
    assert code == 0, err
    doc = load_device_file(out)
    assert doc["input_axis"] == "x"
    assert doc["bias_dph"] == pytest.approx(e.value, abs=1e-3)
    assert "# NOTE: bias_dph is corrected for the g terms" in out.read_text()


def test_a_scenario_on_another_axis_than_the_devices_mounting_is_refused_or_warned(tmp_path):
    """A device file records its mounting (input_axis): a scenario whose sensitive axes differ
    is refused when the device has g terms (they would multiply the wrong components of the
    specific force), warned of when it has none, both naming the two axes; the same axis, and
    an older file without the key, load without a word."""
    import warnings

    tac = preset_text("tactical")                      # g_sens_dph_per_g = [0.1, 0.1, 0.1]
    (tmp_path / "x.toml").write_text(tac + 'input_axis = "x"\n')
    (tmp_path / "old.toml").write_text(tac)
    noise = "arw_deg_rt_h = 0.03\nbias_dph = 1.0\n"
    (tmp_path / "noise_x.toml").write_text(noise + 'input_axis = "x"\n')
    assert load_device_file(tmp_path / "x.toml")["input_axis"] == "x"   # alone: no axes

    def scenario(device, axes=None):
        s = tmp_path / "s.toml"
        s.write_text(SMALL_SCENARIO.replace('preset = "tactical"', f'device = "{device}"'
                                            + (f"\naxes = {axes}" if axes else "")))
        return s

    with pytest.raises(ScenarioError) as exc:
        _load(scenario("x.toml"))                      # axes default ["z"]
    msg = str(exc.value)
    assert "input_axis = 'x'" in msg and "axes = ['z']" in msg and "g terms" in msg, msg
    with pytest.raises(ScenarioError, match=r"axes = \['x', 'y'\]"):
        _load(scenario("x.toml", '["x", "y"]'))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _load(scenario("x.toml", '["x"]')).axes == ("x",)
        assert _load(scenario("old.toml")).axes == ("z",)             # older file: no key
    with pytest.warns(UserWarning, match=r"input_axis = 'x'.*axes = \['z'\]"):
        _load(scenario("noise_x.toml"))
    schema = __import__("fogbench.scenario.device_file", fromlist=["x"]).fog_json_schema()
    assert schema["properties"]["input_axis"]["enum"] == ["x", "y", "z"]


def test_joint_round_trip_reproduces_each_log_the_fits_one_at_a_time_do_not():
    """fogbench.bench.joint on 3 seeds of the issue's lab (eight static power-ons of paper
    004's gyro with temperature terms, x up, soaked at 0 to 40 deg C; a thermal
    run; the lab's multi-position program): the joint file's twin reproduces every log's mean
    and the static logs' Allan curves in most seeds; with the bias the fits wrote one at a time
    (the static means' mean, the g and temperature terms then added again) no log's mean, 8.6
    deg/h of g terms and 0.5 of temperature terms off. `fogbench bench` runs it on 20 seeds."""
    from fogbench.bench.joint import joint_round_trip, summary

    r = joint_round_trip(3, attitudes=((1.0, 0.0, 0.0),) * 8)
    c = summary(r)
    assert c["after_seeds"] >= 2 and c["after_means"] >= 22 and c["after_thermal"] >= 2, c
    # before: 8.6 deg/h of g terms counted twice; a seed whose temperature terms the thermal
    # run determines poorly has a wide bias interval that can take even that
    assert c["before_means"] <= 8 and c["before_seeds"] <= 1, c
    err = np.array([x["bias_error_dph"] for x in r["seeds"]])
    assert np.all(np.abs(err[:, 0]) > 7.5) and np.all(np.abs(err[:, 1]) < 1.0), err


def test_the_logs_of_one_device_fit_are_of_one_gyro_axis_and_input_axis_needs_a_use(tmp_path):
    """A multi-position log on body axis x beside static logs on z is refused naming both (its
    g terms would be taken out of the other gyro's bias); --input-axis without --latitude-deg
    or --multipos, which would change nothing, is refused; nothing is written."""
    fs = 10.0
    rng = np.random.default_rng(1)
    static = _write_log(tmp_path / "static.csv", rng.standard_normal(4000) * 1e-5, fs,
                        (0, 0, 0))
    mp = tmp_path / "mp.csv"
    t = np.arange(200) / fs
    np.savetxt(mp, np.column_stack([t, rng.standard_normal(200), np.zeros((200, 2)),
                                    np.ones(200), np.zeros(200)]), delimiter=",",
               header="time_s,gyro_x_dps,acc_x_g,acc_y_g,acc_z_g,ref_dps", comments="")
    dev = tmp_path / "d.toml"
    code, _, err = run_cli("device", "fit", "--static", static, "--multipos", mp,
                           "--reference", "ref_dps", "--out", dev)
    line = err.strip().splitlines()[-1]
    assert code == 2 and "body axis x" in line and "on z" in line and str(mp) in line, err
    code, _, err = run_cli("device", "fit", "--static", static, "--input-axis", "up",
                           "--out", dev)
    assert code == 2 and "--input-axis" in err and "alone it would change nothing" in err, err
    assert not dev.exists()


@pytest.mark.parametrize("header, advice", [
    ("time_s,gyro_x_dps,GyroY,gyro_z_dps", "--column gyro_y=HEADER:UNIT"),
    ("time_s,GyroX,GyroY,gyro_z_dps", "--column gyro_x=HEADER:UNIT, the axis it is of gyro_x, "
                                      "gyro_y"),
])
def test_the_unread_column_note_names_the_axis_that_is_missing(tmp_path, header, advice):
    rng = np.random.default_rng(0)
    p = tmp_path / "log.csv"
    p.write_text(header + "\n" + "".join(
        f"{i * 0.01:.2f},{a:.5f},{b:.5f},{c:.5f}\n"
        for i, (a, b, c) in enumerate(rng.standard_normal((3000, 3)))))
    code, _, err = run_cli("allan", p)
    assert code == 0 and advice in err, err


def test_allan_columns_takes_every_unit_spelling_and_refuses_another(tmp_path):
    rng = np.random.default_rng(0)
    p = tmp_path / "log.csv"
    p.write_text("time_s,gyro_x_dps\n" + "".join(
        f"{i * 0.01:.2f},{a:.5f}\n" for i, a in enumerate(rng.standard_normal(3000))))
    for name in ("gyro_x", "gyro_x_dps", "gyro_x_deg_s", "GYRO_X_DPS"):
        code, _, err = run_cli("allan", p, "--columns", name)
        assert code == 0, (name, err)
    code, _, err = run_cli("allan", p, "--columns", "gyro_x_bogus")
    assert code == 2 and "'gyro_x_bogus' is not a gyro channel" in err, err


def _each(flag: str, paths) -> list:
    return [x for p in paths for x in (flag, p)]


def _csv(path: Path, fs: float, columns: dict) -> Path:
    """A log CSV: time and the named columns (header: unit suffix included)."""
    n = len(next(iter(columns.values())))
    np.savetxt(path, np.column_stack([np.arange(n) / fs, *columns.values()]), delimiter=",",
               header="time_s," + ",".join(columns), comments="", fmt="%.10g")
    return path


def test_static_bias_is_taken_to_the_reference_temperature_from_each_logs_temp_column(tmp_path):
    """Static logs soaked at 30, 10 and 40 deg C with a temp column, a thermal run (its
    accelerometer columns say its attitude) and the lab's multi-position program of one device
    with temperature terms (fogbench.bench.joint.JOINT_DEVICE: k1 = 0.05 deg/h/C): through the
    command line, bias_dph refers to 20 deg C (the terms at each log's temperature taken out,
    and noted); static logs without the temp column are stated as at their own temperature;
    some with and some without is refused naming them, and nothing is written."""
    from fogbench.bench.joint import _lab

    fs = 10.0
    lab = _lab(0, fs, 1.0, ((1.0, 0.0, 0.0),) * 3, thermal=True)
    statics = []
    for s in lab.statics:
        statics.append(_csv(tmp_path / f"{s.name}.csv", fs, {
            "gyro_x_dps": np.degrees(s.rate), "acc_x_g": np.ones(s.rate.size),
            "acc_y_g": np.zeros(s.rate.size), "acc_z_g": np.zeros(s.rate.size),
            "temp_c": s.temp}))
    th = lab.thermal
    thermal = _csv(tmp_path / "thermal.csv", fs, {
        "gyro_x_dps": np.degrees(th.rate), "temp_c": th.temp,
        "acc_x_g": np.ones(th.rate.size), "acc_y_g": np.zeros(th.rate.size),
        "acc_z_g": np.zeros(th.rate.size)})
    m = lab.multipos
    mp = _csv(tmp_path / "lab.csv", fs, {"gyro_x_dps": np.degrees(m.rate), "acc_x_g": m.f[:, 0],
                                         "acc_y_g": m.f[:, 1], "acc_z_g": m.f[:, 2],
                                         "ref_dps": np.degrees(m.ref)})
    out = tmp_path / "dev.toml"
    args = ["--thermal", thermal, "--multipos", mp, "--reference", "ref_dps", "--out", out]
    code, stdout, err = run_cli("device", "fit", *_each("--static", statics), *args)
    assert code == 0, err
    doc = load_device_file(out)
    text = out.read_text()
    assert "bias_dph refers to 20 deg C" in text and "30 deg C" in text, text
    true = lab.bias_dph          # the preset's bias; each power-on adds its switch-on draw
    assert abs(doc["bias_dph"] - true) < 1.5, doc["bias_dph"]
    # the same static logs without their temp column: stated at their own temperature, and
    # the bias holds the 0.5 deg/h the temperature terms give at 30 deg C
    bare = []
    for p in statics:
        rows = np.genfromtxt(p, delimiter=",", names=True)
        bare.append(_csv(tmp_path / f"bare_{p.name}", fs, {
            k: rows[k] for k in ("gyro_x_dps", "acc_x_g", "acc_y_g", "acc_z_g")}))
    out2 = tmp_path / "dev2.toml"
    code, _, err = run_cli("device", "fit", *_each("--static", bare), *args[:-1], out2)
    assert code == 0, err
    assert "at their own (unlogged) temperature" in out2.read_text()
    # the logs at 30, 10 and 40 deg C: k1 = 0.05 deg/h/C times their mean 6.67 C above 20
    assert load_device_file(out2)["bias_dph"] - doc["bias_dph"] == pytest.approx(0.333, abs=0.2)
    # mixed: refused before anything is written
    out3 = tmp_path / "dev3.toml"
    code, _, err = run_cli("device", "fit", *_each("--static", [statics[0], bare[1]]),
                           *args[:-1], out3)
    line = err.strip().splitlines()[-1]
    assert code == 2 and "no temperature column" in line and str(bare[1]) in line, err
    assert not out3.exists()


def test_optional_columns_a_fit_does_not_use_are_not_read(tmp_path):
    """A static log's temperature column is read only with --thermal, a thermal log's
    accelerometer columns only with --multipos: a log whose unused column is unreadable (a
    temperature in deg F, accelerometers in raw counts) fits as before."""
    fs = 10.0
    rng = np.random.default_rng(2)
    n = 4000
    st = _csv(tmp_path / "static.csv", fs, {"gyro_z_dps": rng.standard_normal(n) * 1e-3,
                                            "temp_f": np.full(n, 77.0)})
    out = tmp_path / "d.toml"
    code, _, err = run_cli("device", "fit", "--static", st, "--out", out)
    assert code == 0 and out.exists(), err
