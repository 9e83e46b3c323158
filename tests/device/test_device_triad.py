"""Triad device files (fogbench.scenario.device_triad, issue 42): the format read back as
written; `device fit` on a three-axis static log recovers each gyro's configured bias and ARW
within its stated interval; one-axis files load as before; a triad file drives the simulated
triad (each gyro its own terms, the matrices when given); bad input refused naming file, column
or key; the real ADIS16405 log's triad fit equals its three one-axis fits."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fogbench.device.file import DeviceFit, Entry, TriadFit
from fogbench.scenario import ScenarioError, load_scenario
from fogbench.scenario.device_file import _fog, load_device_file
from fogbench.scenario.device_triad import triad_matrices
from fogbench.scenario.tables import _Table
from fogcomp.units import DEG_RT_H, DPH
from sim.fog import FogParams, simulate_fog

from helpers import SMALL_SCENARIO, need_realdata, realdata_dir, run_cli

ADIS = realdata_dir() / "adis16405_static" / "imu1.csv.gz"
REPO = Path(__file__).resolve().parents[2]

#: the configured triad of the fit test: each gyro its own bias and ARW, far apart, so that a
#: gyro fitted from another's column cannot fall inside its interval
BIAS_DPH = {"x": 20.0, "y": -35.0, "z": 60.0}
ARW_DEG_RT_H = {"x": 0.05, "y": 0.15, "z": 0.4}

TRIAD_TEXT = """source = "a test triad"
Tw = [[1.0002, 0.0002, -0.0001], [0.00015, 0.9997, 0.0001], [-0.0002, 0.00005, 1.0001]]
Tg_dph_per_g = [[0.3, -0.2, 0.5], [0.1, 0.4, -0.3], [-0.2, 0.2, 0.6]]
coil_time_constant_s = 900.0

[x]
bias_dph = 1.5
arw_deg_rt_h = 0.01
input_axis = "x"

[y]
bias_dph = -2.5
arw_deg_rt_h = 0.02
bias_instability_dph = 0.05

[z]
bias_dph = 3.5
arw_deg_rt_h = 0.03
quantization_arcsec = 0.5
"""


def _fog_of(keys: dict, fs: float = 100.0, file: str = "test"):
    return _fog(_Table(dict(keys), "[fog]", file), fs)


def _write_triad_log(path: Path, rates: np.ndarray, fs: float) -> Path:
    """A static log CSV: time and gyro_x/y/z in deg/s (rates: (n, 3), rad/s)."""
    t = np.arange(rates.shape[0]) / fs
    d = np.degrees(rates)
    with open(path, "w") as f:
        f.write("time_s,gyro_x_dps,gyro_y_dps,gyro_z_dps\n")
        for i in range(t.size):
            f.write(f"{t[i]:.6f},{d[i, 0]:.9e},{d[i, 1]:.9e},{d[i, 2]:.9e}\n")
    return path


def _configured_log(path: Path, fs: float, n: int, seed: int) -> Path:
    """A static three-axis log whose gyros have the configured biases and ARWs, each simulated
    alone (sim.fog's one-axis path, no triad code)."""
    z = np.zeros((n, 3))
    cols = [simulate_fog(FogParams(bias=BIAS_DPH[a] * DPH, arw=ARW_DEG_RT_H[a] * DEG_RT_H),
                         fs, z, z, axes=(a,), seed=seed).raw[:, 0] for a in "xyz"]
    return _write_triad_log(path, np.column_stack(cols), fs)


# ---------------------------------------------------------------------------------------------
# the format
def test_a_triad_fit_written_reads_back_with_every_axis_value(tmp_path):
    fits = {}
    for k, a in enumerate("xyz"):
        f = DeviceFit()
        f.entries = [Entry("arw_deg_rt_h", 0.01 * (k + 1), 0.009, 0.011, "test"),
                     Entry("bias_dph", -3.25 + 10 * k, -4.0, -2.5, "test"),
                     Entry("input_axis", a, None, None, "test"),
                     Entry("bias_instability_band_hz", [1e-6, 1.0], None, None, "chosen")]
        f.undetermined = {"rrw_dph_rt_h": "why", "coil_time_constant_s": "a thermal log"}
        fits[a] = f
    text = TriadFit(axes=fits, inputs=["static log a.csv"], options=["--min-tau-s 0.04"]).to_toml()
    p = tmp_path / "t.toml"
    p.write_text(text)
    doc = load_device_file(p)
    assert tomllib.loads(text) == doc
    for k, a in enumerate("xyz"):
        assert doc[a] == {"arw_deg_rt_h": 0.01 * (k + 1), "bias_dph": -3.25 + 10 * k,
                          "input_axis": a, "bias_instability_band_hz": [1e-6, 1.0]}
    # each value with its interval in the comment above it; the thermal build not per axis
    assert "# bias_dph: test [-4, -2.5]\nbias_dph = 6.75" in text
    assert "[x]" in text and "#   coil_time_constant_s: default" not in text
    params, _, _, axes, _, _ = _fog_of({"device": str(p)}, file=str(tmp_path / "s.toml"))
    assert axes == ("x", "y", "z")
    assert [q.bias for q in params] == pytest.approx([(-3.25 + 10 * k) * DPH for k in range(3)])
    assert [q.arw for q in params] == pytest.approx([0.01 * (k + 1) * DEG_RT_H for k in range(3)])


def test_a_triad_file_gives_each_gyro_its_terms_and_the_matrices(tmp_path):
    p = tmp_path / "tri.toml"
    p.write_text(TRIAD_TEXT)
    doc = load_device_file(p)
    params, _, _, axes, thermal, _ = _fog_of({"device": str(p)}, file=str(tmp_path / "s.toml"))
    cfg = tomllib.loads(TRIAD_TEXT)
    for i, a in enumerate("xyz"):
        assert params[i].bias == pytest.approx(cfg[a]["bias_dph"] * DPH)
        assert params[i].arw == pytest.approx(cfg[a]["arw_deg_rt_h"] * DEG_RT_H)
    assert params[1].bias_instability == pytest.approx(0.05 * DPH)
    assert params[0].bias_instability == 0.0 and params[2].quantization > 0
    assert thermal.coil_time_constant == 900.0
    M, G = triad_matrices(params)
    np.testing.assert_allclose(M, np.asarray(doc["Tw"]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(G, np.asarray(doc["Tg_dph_per_g"]) * DPH, rtol=1e-12)
    # a scenario's axes pick the triad's gyros: one gyro alone is a plain FogParams
    one, _, _, axes1, _, _ = _fog_of({"device": str(p), "axes": ["y"]},
                                     file=str(tmp_path / "s.toml"))
    assert isinstance(one, FogParams) and axes1 == ("y",) and one == params[1]


def test_a_triad_simulates_each_gyro_as_it_would_alone():
    """One FogParams per axis: each column what that axis's params give alone, and a triad of
    three equal sets is the one-set triad exactly (every stream keyed by the body axis)."""
    fs, n = 50.0, 4000
    rng = np.random.default_rng(0)
    w = rng.normal(0, 0.2, (n, 3))
    f = np.tile([0.1, -0.2, 0.97], (n, 1))
    ps = (FogParams(bias=1e-5, arw=1e-4, scale_factor=1e-4, misalignment=((0, 2e-4, 0), (0, 0, 0),
                                                                          (0, 0, 0)),
                    g_sens=(1e-6, 0, 0), quantization=1e-6),
          FogParams(bias=-2e-5, arw=2e-4, rrw=1e-6),
          FogParams(bias=3e-5, bias_instability=1e-5, g_sens=(0, 0, 2e-6)))
    tri = simulate_fog(ps, fs, w, f, axes=("x", "y", "z"), seed=9)
    for j, a in enumerate("xyz"):
        alone = simulate_fog(ps[j], fs, w, f, axes=(a,), seed=9)
        np.testing.assert_array_equal(tri.raw[:, j], alone.raw[:, 0])
        for t, v in alone.terms.items():
            np.testing.assert_array_equal(tri.terms[t][:, j], v[:, 0])
    same = simulate_fog((ps[2],) * 3, fs, w, f, axes=("x", "y", "z"), seed=9)
    one = simulate_fog(ps[2], fs, w, f, axes=("x", "y", "z"), seed=9)
    np.testing.assert_array_equal(same.raw, one.raw)


def test_a_scenario_runs_a_triad_device_file(tmp_path):
    (tmp_path / "tri.toml").write_text(TRIAD_TEXT)
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO.replace('preset = "tactical"',
                                        'device = "tri.toml"\naxes = ["x", "y", "z"]'))
    from fogbench.scenario.load import RUNNER_SECTIONS

    sc = load_scenario(s, extra_sections=RUNNER_SECTIONS)
    assert sc.axes == ("x", "y", "z") and len(sc.fog) == 3
    assert [p.bias / DPH for p in sc.fog] == pytest.approx([1.5, -2.5, 3.5])
    code, _, err = run_cli("check", s)
    assert code == 0, err


# ---------------------------------------------------------------------------------------------
# one-axis files as before
def test_one_axis_device_files_load_as_before(tmp_path):
    """The fitted files of scenarios/devices (written before triads existed): the same keys,
    the same FogParams as the keys converted by hand, one gyro on the scenario's default axis."""
    for path in sorted((REPO / "scenarios" / "devices").glob("*.toml")):
        raw = tomllib.loads(path.read_text())
        doc = load_device_file(path)
        assert doc == raw
        params, _, _, axes, _, _ = _fog_of({"device": str(path)}, file=str(tmp_path / "s.toml"))
        assert isinstance(params, FogParams) and axes == ("z",)
        assert params.arw == pytest.approx(raw.get("arw_deg_rt_h", 0.0) * math.radians(1) / 60)
        assert params.bias_instability == pytest.approx(raw.get("bias_instability_dph", 0.0) * DPH)
        assert params.bias == pytest.approx(raw.get("bias_dph", 0.0) * DPH)
    dev = tmp_path / "one.toml"
    dev.write_text('source = "s"\nbias_dph = 2.0\narw_deg_rt_h = 0.1\n')
    z = np.zeros((1000, 3))
    p, *_ = _fog_of({"device": str(dev)}, file=str(tmp_path / "s.toml"))
    np.testing.assert_array_equal(
        simulate_fog(p, 10.0, z, z, axes=("z",), seed=1).raw,
        simulate_fog(FogParams(bias=2.0 * DPH, arw=0.1 * DEG_RT_H), 10.0, z, z, axes=("z",),
                     seed=1).raw)


# ---------------------------------------------------------------------------------------------
# the fit
def test_triad_fit_recovers_each_gyros_configured_bias_and_arw(tmp_path):
    """A 1 h static log at 10 Hz, three gyros with different biases and ARWs (each simulated
    alone): each axis table's 99 % intervals hold that gyro's configured values, and not the
    other gyros' (no column mixed up with another)."""
    log = _configured_log(tmp_path / "tri.csv", 10.0, 36_000, seed=5)
    dev = tmp_path / "tri.toml"
    code, out, err = run_cli("device", "fit", "--static", log, "--ci", "0.99", "--out", dev)
    assert code == 0, err
    assert "a triad device file" in out
    text = dev.read_text()
    doc = load_device_file(dev)
    assert set(doc) >= {"x", "y", "z", "source"}
    for a in "xyz":
        t = doc[a]
        assert t["input_axis"] == a
        lo, hi = _interval(text, a, "bias_dph")
        assert lo <= BIAS_DPH[a] <= hi, (a, lo, hi)
        assert all(not lo <= BIAS_DPH[b] <= hi for b in "xyz" if b != a)
        lo, hi = _interval(text, a, "arw_deg_rt_h")
        assert lo <= ARW_DEG_RT_H[a] <= hi, (a, lo, hi)
        assert all(not lo <= ARW_DEG_RT_H[b] <= hi for b in "xyz" if b != a)


def _interval(text: str, axis: str, key: str) -> tuple[float, float]:
    """The interval written in the comment of ``key`` in table ``[axis]``."""
    body = text.split(f"\n[{axis}]\n", 1)[1].split("\n[", 1)[0]
    line = next(ln for ln in body.splitlines() if ln.startswith(f"# {key}:"))
    lo, hi = line.rsplit("[", 1)[1].rstrip("]").split(",")
    return float(lo), float(hi)


# ---------------------------------------------------------------------------------------------
# refusals
@pytest.mark.parametrize("body, msg", [
    (TRIAD_TEXT.split("[z]")[0], "has [x], [y] and not [z]"),
    (TRIAD_TEXT.replace("[y]\n", "[y]\ncoil_time_constant_s = 10.0\n"),
     "[y] key 'coil_time_constant_s'"),
    (TRIAD_TEXT.replace("[x]\n", "[x]\nscale_factor_ppm = 100.0\n"),
     "[x] key 'scale_factor_ppm': the triad's Tw gives it"),
    (TRIAD_TEXT.replace("[z]\n", "[z]\ng_sens_dph_per_g = [0.1, 0.0, 0.0]\n"),
     "[z] key 'g_sens_dph_per_g': the triad's Tg_dph_per_g gives it"),
    (TRIAD_TEXT.replace("Tw = [[1.0002, 0.0002, -0.0001], ", "Tw = ["),
     "key 'Tw': expected a 3x3"),
    (TRIAD_TEXT.replace("Tw = [[1.0002,", "Tw = [[1.5,"), "key 'Tw'"),
    (TRIAD_TEXT.replace('input_axis = "x"', 'input_axis = "y"'), "[x] key 'input_axis'"),
    (TRIAD_TEXT.replace("[x]\n", "bias_dph = 1.0\n[x]\n"), "key 'bias_dph': at the top level"),
    (TRIAD_TEXT.replace("arw_deg_rt_h = 0.02", "arw_deg_rt_h = -0.02"), "'arw_deg_rt_h'"),
])
def test_bad_triad_files_are_refused_naming_file_and_key(tmp_path, body, msg):
    dev = tmp_path / "tri.toml"
    dev.write_text(body)
    with pytest.raises(ScenarioError, match=None) as exc:
        load_device_file(dev)
    assert str(dev) in str(exc.value) and msg in str(exc.value), str(exc.value)


def test_one_gyro_consumers_refuse_a_triad_file_without_an_axis(tmp_path):
    dev = tmp_path / "tri.toml"
    dev.write_text(TRIAD_TEXT)
    log = tmp_path / "one.csv"
    log.write_text("time_s,gyro_z_dps\n" + "".join(f"{i / 10:.1f},{np.sin(i)}\n"
                                                   for i in range(400)))
    code, _, err = run_cli("device", "check", dev, log, "--out", tmp_path / "chk")
    assert code == 2 and str(dev) in err and "--axis" in err, err
    assert not (tmp_path / "chk").exists()
    # with --axis, its gyro z is the device
    from fogbench.device.file import _device_params

    p, _ = _device_params(dev, 10.0, "z")
    assert p.bias == pytest.approx(3.5 * DPH)


# ---------------------------------------------------------------------------------------------
# the real ADIS16405 log
def test_adis_triad_fit_equals_its_three_one_axis_fits(tmp_path):
    need_realdata(ADIS)
    tri = tmp_path / "tri.toml"
    code, _, err = run_cli("device", "fit", "--static", ADIS, "--min-tau-s", "0.04", "--out", tri)
    assert code == 0, err
    doc = load_device_file(tri)
    text = tri.read_text()
    for a in "xyz":
        one = tmp_path / f"{a}.toml"
        code, _, err = run_cli("device", "fit", "--static", ADIS, "--axis", a, "--min-tau-s",
                               "0.04", "--out", one)
        assert code == 0, err
        ref = load_device_file(one)
        assert doc[a]["bias_dph"] == ref["bias_dph"]
        # every key the one-axis fit writes, with the same value (the file's source apart)
        assert doc[a] == {k: v for k, v in ref.items() if k != "source"}
        # the interval too: the one-axis file's comment line, word for word
        line = next(ln for ln in one.read_text().splitlines() if ln.startswith("# bias_dph:"))
        assert line.rsplit("[", 1)[1] == next(
            ln for ln in text.split(f"\n[{a}]\n", 1)[1].splitlines()
            if ln.startswith("# bias_dph:")).rsplit("[", 1)[1]
    # the three biases are the log's own, far apart (README: 1,432, -1,397, -983 deg/h over
    # the first 2,000 s; here the whole log)
    assert doc["x"]["bias_dph"] > 1000 and doc["y"]["bias_dph"] < -1000
    assert -1500 < doc["z"]["bias_dph"] < -500
