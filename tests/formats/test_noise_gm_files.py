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
