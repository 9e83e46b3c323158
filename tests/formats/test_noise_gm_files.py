"""Every Gauss-Markov term the record shows reaches the files a filter designer reads (issue
41): Kalibr's and OpenVINS' noise files (no Gauss-Markov state: every term in comments) and
the device file (its error model holds one: the rule, and the others, in the file)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import yaml

from fogcomp.noise import avar_model, identify_noise_model

FS = 10.0
DPH = math.pi / 180 / 3600
TERMS = [(0.02, 5.0), (0.01, 500.0)]          # sigma rad/s, T s


@pytest.fixture(scope="module")
def model():
    """N + GM(5 s) + GM(500 s) stated on its own exact Allan variance curve."""
    n = 2**20
    taus = 2.0 ** np.arange(int(math.log2((n - 1) // 2)) + 1) / FS
    return identify_noise_model(taus, avar_model(taus, {"N": 0.01}, TERMS, FS), FS, n,
                                model="N + GM + GM", record_length=False)


def _load(text):
    if text.startswith("%YAML:1.0"):
        text = text.split("\n", 1)[1]
    doc = yaml.safe_load(text)
    return doc.get("imu0", doc)


def test_kalibr_and_openvins_files_list_every_gauss_markov_term(model):
    from fogbench.formats.kalibr import gm_terms, kalibr_text, openvins_text, values_from_models

    got = gm_terms({"gyro_x": model, "gyro_y": model})
    assert [(ax, T) for ax, _, T, _ in got] == [
        ("gyro_x", pytest.approx(5.0, rel=1e-3)), ("gyro_x", pytest.approx(500.0, rel=1e-3)),
        ("gyro_y", pytest.approx(5.0, rel=1e-3)), ("gyro_y", pytest.approx(500.0, rel=1e-3))]
    values = values_from_models({"gyro_x": model}, None)
    for text in (kalibr_text(values, FS, "log.csv"), openvins_text(values, FS, "log.csv")):
        comments = [ln for ln in text.splitlines() if ln.lstrip().startswith("#")]
        gm = [ln for ln in comments if "gyro_x: sigma" in ln]
        assert len(gm) == 2, text
        read = [tuple(float(x) for x in re.search(r"sigma (\S+) rad/s, tau (\S+) s", ln)
                      .groups()) for ln in gm]
        assert read == [pytest.approx(t, rel=1e-3) for t in TERMS]
        assert any("no state for them" in ln for ln in comments)
        doc = _load(text)
        assert doc["gyroscope_noise_density"] == pytest.approx(0.01, rel=1e-3)
        assert not any("gm" in k.lower() or "markov" in k.lower() for k in doc)


def test_the_device_file_takes_the_largest_sigma_and_names_the_others(model):
    from fogbench.device.file import DeviceFit
    from fogbench.device.fit import GM_RULE, _noise_entries

    fit = DeviceFit()
    _noise_entries(fit, model, "the test curve", FS)
    assert fit.entry("gm_drift_dps").value == pytest.approx(0.02 * 180 / math.pi, rel=1e-3)
    assert fit.entry("gm_time_constant_s").value == pytest.approx(5.0, rel=1e-3)
    text = fit.to_toml()
    note = next(ln for ln in text.splitlines() if ln.startswith("# NOTE:") and "Gauss" in ln)
    assert GM_RULE in note
    sigma_dph, tau = (float(x) for x in re.search(r"out: (\S+) deg/h, tau (\S+) s", note).groups())
    assert sigma_dph == pytest.approx(0.01 / DPH, rel=1e-2) and tau == pytest.approx(500, rel=1e-2)


# --- a correlation time bounded on one side only ----------------------------------------------
@pytest.fixture(scope="module")
def open_tau(tmp_path_factory):
    """4 h at 2 Hz of white noise and a rate random walk, with N + GM stated: the slow term
    stands in for the walk and its correlation time is bounded below only (the record cannot
    rule out longer times). The CSV a user would hand to ``fogbench allan``."""
    rng = np.random.default_rng(0)
    fs, n = 2.0, 4 * 3600 * 2
    k = 0.5 * math.pi / 180 / 3600 / 60                     # 0.5 deg/h/sqrt(h)
    y = 0.01 * math.pi / 180 / 60 * math.sqrt(fs) * rng.standard_normal(n) \
        + np.cumsum(rng.standard_normal(n)) * k / math.sqrt(fs)
    p = tmp_path_factory.mktemp("open_tau") / "rw.csv"
    np.savetxt(p, np.column_stack([np.arange(n) / fs, np.degrees(y)]), delimiter=",",
               header="time_s,gyro_z_dps", comments="")
    return p


def test_an_open_side_of_the_correlation_time_is_written_by_every_output(open_tau, tmp_path):
    """allan (table, allan.json, Kalibr and OpenVINS comments) and the device file write a
    one-sided interval of T as one-sided ('inf', null, '-'), not a crash and not a number."""
    import json

    from helpers import run_cli

    from fogbench.device.file import DeviceFit
    from fogbench.device.fit import _noise_entries
    from fogcomp.allan import allan_analysis

    y = np.radians(np.loadtxt(open_tau, delimiter=",", skiprows=1)[:, 1])
    m = allan_analysis(y, 2.0, model="N + GM", record_length=False)[1]
    g = m.term("GM1")
    assert g.status == "identified" and g.tau_low is not None and g.tau_high is None, g
    out = tmp_path / "a"
    code, so, se = run_cli("allan", str(open_tau), "--model", "N + GM", "--out", str(out),
                           "--kalibr", str(tmp_path / "imu.yaml"),
                           "--openvins", str(tmp_path / "ov.yaml"))
    assert code == 0, se
    assert "inf] s" in so
    text = (out / "allan.json").read_text()
    json.loads(text)
    assert '"gm_tau_high_s": null' in text
    for f in ("imu.yaml", "ov.yaml"):
        assert "..inf s)" in (tmp_path / f).read_text()
    fit = DeviceFit()
    _noise_entries(fit, m, "the test record", 2.0)
    line = next(ln for ln in fit.to_toml().splitlines() if ln.startswith("# gm_time_constant_s"))
    assert line.rstrip().endswith(", -]"), line
