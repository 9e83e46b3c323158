"""The scenario loader refuses every kind of bad input, naming file, key and expectation."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fogcomp import units as U
from fogbench.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[2]

GOOD = """
[scenario]
name = "tiny"
sample_rate_hz = 10.0

[table]
radius_m = 0.05

[fog]
preset = "tactical"
arw_deg_rt_h = 0.05

[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "hold"
duration_s = 3.0
[[runs.motion]]
type = "rate"
rate_dps = 20.0
duration_s = 2.0
tilt_deg = 30.0
"""


def write(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_good_scenario_loads_in_si(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD))
    assert sc.fs == 10.0 and sc.axes == ("z",)
    assert sc.fog.arw == pytest.approx(0.05 * math.pi / 180 / 60)      # override
    assert sc.fog.bias_instability == pytest.approx(0.1 * U.DPH)        # from the preset
    assert sc.runs[0].motion[1].rate == pytest.approx(math.radians(20.0))
    assert sc.runs[0].motion[1].tilt == pytest.approx(math.radians(30.0))
    assert sc.runs[0].duration == 5.0


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("*.toml")), ids=lambda p: p.name)
def test_bundled_scenarios_load(path):
    from fogbench.scenario.load import RUNNER_SECTIONS
    from fogbench.scenario import load_plan

    sc = load_scenario(path, extra_sections=RUNNER_SECTIONS)
    load_plan(sc)
    assert sc.runs


BAD = [
    # (change, words the message must contain)
    (lambda t: t.replace('sample_rate_hz = 10.0', ''), ["[scenario]", "sample_rate_hz", "missing"]),
    (lambda t: t.replace('sample_rate_hz = 10.0', 'sample_rate_hz = "ten"'),
     ["sample_rate_hz", "number"]),
    (lambda t: t.replace('sample_rate_hz = 10.0', 'sample_rate_hz = -1.0'),
     ["sample_rate_hz", "> 0"]),
    (lambda t: t.replace('radius_m = 0.05', 'radius_m = 0.05\nradius_cm = 5'),
     ["[table]", "unknown", "radius_cm"]),
    (lambda t: t.replace('radius_m = 0.05', 'radius_m = 2.0'), ["radius_m", "<= 0.14"]),
    (lambda t: t.replace('arw_deg_rt_h = 0.05', 'arw_dph = 0.05'), ["[fog]", "unknown", "arw_dph"]),
    (lambda t: t.replace('arw_deg_rt_h = 0.05', 'arw_deg_rt_h = -0.05'), ["arw_deg_rt_h", ">= 0"]),
    (lambda t: t.replace('preset = "tactical"', 'preset = "strategic"'), ["preset", "tactical"]),
    (lambda t: t.replace('type = "hold"', 'type = "spin"'), ["motion[0]", "type", "hold"]),
    (lambda t: t.replace('duration_s = 3.0', 'duration_s = 3.05'), ["duration_s", "whole number"]),
    (lambda t: t.replace('rate_dps = 20.0', 'rate_deg_s = 20.0'), ["motion[1]", "rate_dps", "missing"]),
    (lambda t: t.replace('seed = 1', 'seed = 1.5'), ["seed", "integer"]),
    (lambda t: t.replace('seed = 1', ''), ["seed", "missing"]),
    (lambda t: t + '\n[extra]\nx = 1\n', ["top level", "unknown", "extra"]),
    (lambda t: t.replace('[[runs]]\nname = "a"', '[[runs]]\nname = "a"\nsed = 3'), ["'a'", "sed"]),
    (lambda t: t + '\n[[runs]]\nname = "a"\nseed = 2\n[[runs.motion]]\ntype = "hold"\nduration_s = 1.0\n',
     ["name", "unique"]),
    (lambda t: t.replace('[fog]', '[fog]\naxes = ["z", "w"]'), ["axes", "'w'"]),
    (lambda t: t.replace('[fog]', '[fog]\ng_sens_dph_per_g = [1.0, 2.0]'), ["g_sens_dph_per_g", "3 numbers"]),
    (lambda t: t.replace('[fog]', '[fog]\nbias_instability_band_hz = [1.0, 20.0]'),
     ["bias_instability_band_hz", "Nyquist"]),
    (lambda t: t.replace('[fog]', '[fog]\ndisabled_terms = ["shupe"]'), ["disabled_terms", "shupe"]),
    (lambda t: t + '\n[thermal]\nstart_c = 20.0\n[[thermal.steps]]\nramp_to_c = 30.0\n',
     ["[thermal] steps[0]", "rate_c_per_min", "missing", "> 0"]),
    (lambda t: t.replace('[[runs.motion]]\ntype = "hold"\nduration_s = 3.0',
                         '[[runs.motion]]\ntype = "positions"\ntilts_deg = [0.0, 180.0]\n'
                         'headings_deg = [0.0]\nmove_s = 1.0\ndwell_s = 1.0'),
     ["move_s", "takes"]),
    (lambda t: t + '\n[scenario2\n', ["not valid TOML"]),
    # the device's thermal build and range
    (lambda t: t.replace('[fog]', '[fog]\nrange_dps = 0.0'), ["range_dps", "> 0"]),
    (lambda t: t.replace('[fog]', '[fog]\ntemp_sensor_location = "case"'),
     ["temp_sensor_location", "housing"]),
    (lambda t: t.replace('[fog]', '[fog]\ntemp_sensor_resolution_c = 5.0'),
     ["temp_sensor_resolution_c", "<="]),
    (lambda t: t.replace('[fog]', '[fog]\ntemp_rate_cooling_ratio = -1.0'),
     ["temp_rate_cooling_ratio", ">= 0"]),
]


@pytest.mark.parametrize("change,words", BAD, ids=[w[0] + "-" + str(i) for i, (_, w) in enumerate(BAD)])
def test_bad_input_is_refused_with_file_and_key(tmp_path, change, words):
    p = write(tmp_path, change(GOOD))
    with pytest.raises(ScenarioError) as exc:
        load_scenario(p)
    msg = str(exc.value)
    assert str(p) in msg
    for w in words:
        assert w in msg, f"{w!r} not in: {msg}"


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "nope.toml")


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "fogbench", *args], capture_output=True,
                          text=True, cwd=cwd or ROOT)


def test_cli_simulate_writes_complete_documented_output(tmp_path):
    scen = write(tmp_path, GOOD)
    out = tmp_path / "out"
    r = run_cli("simulate", str(scen), "--out", str(out))
    assert r.returncode == 0, r.stderr
    manifest = json.loads((out / "simulation.json").read_text())
    assert manifest["runs"] == ["a"] and "mujoco" in manifest["versions"]
    meta = json.loads((out / "a.json").read_text())
    assert meta["seed"] == 1 and meta["samples"] == 50
    with np.load(out / "a.npz", allow_pickle=False) as z:
        raw, truth = z["raw_rps"], z["truth_rate_rps"]
        terms = sum(z[k] for k in z.files if k.startswith("term_"))
        np.testing.assert_allclose(raw[:, 0], truth[:, 2] + terms[:, 0], atol=1e-15)
        assert z["t_s"].shape == (50,)
    assert not list(out.glob(".*part"))  # no temporary files left behind


def test_cli_bad_scenario_exits_nonzero_with_message_on_stderr(tmp_path):
    scen = write(tmp_path, GOOD.replace("seed = 1", "seed = -1"))
    out = tmp_path / "out"
    r = run_cli("simulate", str(scen), "--out", str(out))
    assert r.returncode == 2
    assert "seed" in r.stderr and str(scen) in r.stderr and r.stdout == ""
    assert not out.exists()


def test_same_seed_gives_identical_files(tmp_path):
    scen = write(tmp_path, GOOD)
    for d in ("o1", "o2"):
        assert run_cli("simulate", str(scen), "--out", str(tmp_path / d), "--quiet").returncode == 0
    with np.load(tmp_path / "o1" / "a.npz") as a, np.load(tmp_path / "o2" / "a.npz") as b:
        assert a.files == b.files
        for k in a.files:
            assert np.array_equal(a[k], b[k]), k
