"""The estimator contract, checked over every registered method."""

import json

import numpy as np
import pytest

import fogcomp
from fogcomp import GyroData, ModelFileError, NotFittedError
from fogcomp.units import DPH

METHODS = fogcomp.available_methods()
FS = 10.0


def record(n=400, seed=0):
    """A record every method can use: a slowly moving rate, g, temperature and its rate."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    truth = 0.01 * np.sin(2 * np.pi * 0.05 * t)
    g = rng.standard_normal((n, 3))
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    g *= rng.uniform(0.8, 1.2, (n, 1))
    temp = 20 + 10 * np.sin(2 * np.pi * t / t[-1])
    temp_rate = np.gradient(temp, t)
    err = (5 + 2 * g[:, 0] - g[:, 2] ** 2 + 0.1 * (temp - 20) + 3 * temp_rate) * DPH
    rate = truth + err + 1e-4 * rng.standard_normal(n)
    return GyroData(rate=rate, fs=FS, g=g, temp=temp, temp_rate=temp_rate), truth


def make(name):
    m = fogcomp.make_method(name)
    if m.random:
        m.random_state = 3
    return m


def test_registry_holds_the_papers_methods_and_the_baselines():
    for name in ("wnn", "aco_bp", "bp", "poly_temp", "flnn", "flnn_lstsq", "kalman",
                 "wavelet_soft", "model_lstsq"):
        assert name in METHODS
    with pytest.raises(KeyError, match="unknown method 'nope'; available: aco_bp"):
        fogcomp.get_method("nope")
    with pytest.raises(ValueError, match="unknown hyperparameter"):
        fogcomp.make_method("wnn", hidden_units=3)


@pytest.mark.parametrize("name", METHODS)
def test_fit_returns_self_and_compensate_is_raw_minus_error(name):
    data, truth = record()
    m = make(name)
    assert m.fit(data, truth) is m
    err = m.estimate_error(data)
    out = m.compensate(data)
    assert out.shape == data.rate.shape and err.shape == data.rate.shape
    np.testing.assert_allclose(out, data.rate - err, rtol=0, atol=1e-18)
    assert all(k.endswith("_") for k in vars(m) if k not in m.get_params())


@pytest.mark.parametrize("name", METHODS)
def test_compensating_before_fit_is_a_clear_error(name):
    data, _ = record()
    with pytest.raises(NotFittedError, match="not fitted"):
        make(name).compensate(data)


@pytest.mark.parametrize("name", METHODS)
def test_determinism_under_a_seed(name):
    data, truth = record()
    a = make(name).fit(data, truth).compensate(data)
    b = make(name).fit(data, truth).compensate(data)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("name", METHODS)
def test_save_load_round_trip_compensates_identically(name, tmp_path):
    data, truth = record()
    m = make(name).fit(data, truth)
    m.save(tmp_path / "model")
    back = fogcomp.load_model(tmp_path / "model")
    assert type(back) is type(m)
    other, _ = record(seed=5)
    np.testing.assert_array_equal(back.compensate(other), m.compensate(other))
    # the arrays file is read without pickle
    with np.load(tmp_path / "model.npz", allow_pickle=False) as z:
        assert all(z[k].dtype != object for k in z.files)


def test_tampered_or_wrong_version_files_are_refused(tmp_path):
    data, truth = record()
    make("flnn_lstsq").fit(data, truth).save(tmp_path / "m")
    npz = tmp_path / "m.npz"
    blob = bytearray(npz.read_bytes())
    blob[-30] ^= 0xFF
    npz.write_bytes(bytes(blob))
    with pytest.raises(ModelFileError, match="checksum"):
        fogcomp.load_model(tmp_path / "m")
    make("flnn_lstsq").fit(data, truth).save(tmp_path / "m")
    doc = json.loads((tmp_path / "m.json").read_text())
    doc["version"] = 99
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="version"):
        fogcomp.load_model(tmp_path / "m")
    with pytest.raises(ModelFileError, match="not found"):
        fogcomp.load_model(tmp_path / "absent")


@pytest.mark.parametrize("name", METHODS)
def test_nan_and_wrong_shapes_are_refused_with_a_clear_message(name):
    data, truth = record()
    bad = data.rate.copy()
    bad[7] = np.nan
    with pytest.raises(ValueError, match=r"rate: non-finite value nan at index \(7,\)"):
        make(name).fit(GyroData(rate=bad, fs=FS, g=data.g, temp=data.temp,
                                temp_rate=data.temp_rate), truth)
    with pytest.raises(ValueError, match=r"g: shape must be \(n, 3\)"):
        GyroData(rate=data.rate, fs=FS, g=data.g[:, :2])
    m = make(name)
    if m.supervised:
        with pytest.raises(ValueError, match="reference_rate"):
            m.fit(data, truth[:-1])
        with pytest.raises(ValueError, match="needs reference_rate"):
            m.fit(data)
    missing = [r for r in m.requires if r != "rate"]
    if missing:
        with pytest.raises(ValueError, match=f"input '{missing[0]}' is required"):
            m.fit(GyroData(rate=data.rate, fs=FS), truth)


def test_a_diverging_method_raises_divergence_error():
    data, truth = record()
    with pytest.raises(fogcomp.DivergenceError):
        fogcomp.make_method("bp", learning_rate=1e6, random_state=1).fit(data, truth)
