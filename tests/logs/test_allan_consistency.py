"""``fogbench allan LOG --consistency``: the NIS of the filter a log's noise model implies on its
held-out part, the measured inflation factor printed, in allan.json and in the comments of the
Kalibr / OpenVINS files (and applied with --inflate-measured); refusals on stderr, exit 2."""

from __future__ import annotations

import json
import math

import numpy as np

from helpers import run_parsed as run


def _log(path, n=24_000, fs=100.0, seed=44):
    """A static gyro log, deg/s: white rate noise plus a rate random walk (one axis)."""
    rng = np.random.default_rng(seed)
    N, K = 2e-4, 2e-5
    w = rng.normal(0, N * math.sqrt(fs), n) + np.cumsum(rng.normal(0, K / math.sqrt(fs), n))
    t = np.arange(n) / fs
    with open(path, "w") as f:
        f.write("time_s,gyro_x_dps\n")
        for ti, wi in zip(t, np.rad2deg(w)):
            f.write(f"{ti:.4f},{wi:.9g}\n")


def _yaml(path):
    import yaml

    return yaml.safe_load(path.read_text())


def test_consistency_is_measured_written_and_applied_when_asked(tmp_path):
    log = tmp_path / "g.csv"
    _log(log)
    code, err = run(["allan", log, "--out", tmp_path / "a", "--consistency", "--kalibr",
                     tmp_path / "m.yaml", "--inflate-measured"])
    assert code == 0, err
    doc = json.loads((tmp_path / "a" / "allan.json").read_text())
    c = doc["columns"]["gyro_x_dps"]["consistency"]
    for key in ("identified_model", "kalibr_model"):
        r = c[key]
        assert r["f_low"] <= r["f_hat"] <= r["f_high"]
    assert c["n_held_out"] == 12_000
    text = (tmp_path / "m.yaml").read_text()
    assert "consistency measured by fogbench allan --consistency" in text
    assert "--inflate-measured" in text
    # the value written is the identified one times the measured factor
    assert run(["allan", log, "--kalibr", tmp_path / "plain.yaml"])[0] == 0
    plain = (tmp_path / "plain.yaml").read_text()
    assert "consistency measured" not in plain        # unchanged without the flag
    f = max(1.0, c["kalibr_model"]["f_low"])
    assert _yaml(tmp_path / "m.yaml")["gyroscope_noise_density"] == \
        __import__("pytest").approx(f * _yaml(tmp_path / "plain.yaml")[
            "gyroscope_noise_density"], rel=1e-6)


def test_refusals_name_the_flag(tmp_path):
    log = tmp_path / "g.csv"
    _log(log, n=4000)
    code, err = run(["allan", "--curve", log, "--consistency"])
    assert code == 2 and "--consistency: needs a log" in err
    code, err = run(["allan", log, "--kalibr", tmp_path / "k.yaml", "--inflate-measured",
                     "--inflate-density", "3"])
    assert code == 2 and "--inflate-measured" in err
    code, err = run(["allan", log, "--consistency", "--holdout", "0.99"])
    assert code == 2 and "--holdout" in err
    assert not (tmp_path / "k.yaml").exists()


def test_the_measured_factor_is_refused_where_none_was_measured():
    """--inflate-measured writes the largest lower end over the axes, at least 1; a column
    whose factor is beyond the grid, not finite or not measured is refused, naming it."""
    from types import SimpleNamespace

    import pytest

    from fogbench.formats.errors import LogError
    from fogbench.logs.consistency import measured_factor

    def col(f_low, flag=""):
        return {"kalibr": SimpleNamespace(f_low=f_low, f_hat=f_low, f_high=f_low,
                                          flags={"f_low": flag, "f_hat": "", "f_high": ""})}

    assert measured_factor({"gyro_x": col(0.8), "gyro_y": col(1.3)}) == 1.3
    assert measured_factor({"gyro_x": col(0.6)}) == 1.0
    with pytest.raises(LogError, match="gyro_y"):
        measured_factor({"gyro_x": col(1.1), "gyro_y": col(1000.0, ">")})
    with pytest.raises(LogError, match="gyro_z"):
        measured_factor({"gyro_x": col(1.1), "gyro_z": col(float("nan"))})
    with pytest.raises(LogError, match="no factor was measured"):
        measured_factor({"gyro_x": {"error": "too short"}})
