"""model_lstsq: the engineer's full deterministic error model by least squares.

Truth: the generating coefficients, in the datasheet units they were written in.
"""

import warnings

import numpy as np
import pytest

import fogcomp
from fogcomp import GyroData
from fogcomp.methods.flnn import IdentifiabilityWarning
from fogcomp.units import DPH, PPM

TRUE = {
    "bias_dph": 5.0, "scale_factor_ppm": 120.0,
    "gx_dph_per_g": 1.0, "gy_dph_per_g": -2.0, "gz_dph_per_g": 0.5,
    "gxx_dph_per_g2": 0.3, "gyy_dph_per_g2": -0.2, "gzz_dph_per_g2": 0.1,
    "gxy_dph_per_g2": 0.05, "gyz_dph_per_g2": -0.07, "gxz_dph_per_g2": 0.02,
    "temp_dph_per_c": 0.01, "temp_rate_dph_per_c_per_s": 30.0, "temp2_dph_per_c2": -4e-4,
}
T0 = 25.0


def record(n=3000, seed=0, constant_temp=False, temp2=False, true=TRUE):
    """Varied rate, g of varied norm (a centrifuge-like table), and a temperature with
    independent T and dT/dt; raw = (1 + k) w + e, written out term by term."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    w = 0.5 * np.sin(2 * np.pi * t / 300) + rng.normal(0, 0.3, n)           # rad/s
    g = rng.normal(size=(n, 3))
    g *= (rng.uniform(0.5, 2.0, n) / np.linalg.norm(g, axis=1))[:, None]
    if constant_temp:
        T, Td = np.full(n, 31.0), np.zeros(n)
    else:
        T = 20 + 30 * np.sin(2 * np.pi * t / 3000) + 5 * np.sin(2 * np.pi * t / 700)
        Td = (30 * 2 * np.pi / 3000) * np.cos(2 * np.pi * t / 3000) + \
             (5 * 2 * np.pi / 700) * np.cos(2 * np.pi * t / 700)
    gx, gy, gz = g.T
    e_dph = (true["bias_dph"] + true["gx_dph_per_g"] * gx + true["gy_dph_per_g"] * gy
             + true["gz_dph_per_g"] * gz + true["gxx_dph_per_g2"] * gx ** 2
             + true["gyy_dph_per_g2"] * gy ** 2 + true["gzz_dph_per_g2"] * gz ** 2
             + true["gxy_dph_per_g2"] * gx * gy + true["gyz_dph_per_g2"] * gy * gz
             + true["gxz_dph_per_g2"] * gx * gz + true["temp_dph_per_c"] * (T - T0)
             + true["temp_rate_dph_per_c_per_s"] * Td)
    if temp2:
        e_dph = e_dph + true["temp2_dph_per_c2"] * (T - T0) ** 2
    raw = (1 + true["scale_factor_ppm"] * PPM) * w + e_dph * DPH
    return GyroData(rate=raw, fs=1.0, g=g, temp=T, temp_rate=Td), w


@pytest.mark.parametrize("temp2", [False, True])
def test_recovers_every_coefficient(temp2):
    data, w = record(temp2=temp2)
    terms = ("bias", "scale_factor", "g", "g2", "temp", "temp_rate") + (("temp2",) if temp2 else ())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = fogcomp.make_method("model_lstsq", t0_c=T0, terms=terms).fit(data, w)
    c = m.coef_dict()
    for key, val in TRUE.items():
        if key == "temp2_dph_per_c2" and not temp2:
            assert key not in c
            continue
        assert c[key] == pytest.approx(val, rel=1e-9), key
    assert c["t0_c"] == T0
    assert m.identifiability_.full_rank
    # the compensated rate is the true rate (scale factor inverted, not just subtracted)
    np.testing.assert_allclose(m.compensate(data), w, rtol=0, atol=1e-12)
    fresh, w2 = record(n=500, seed=9, temp2=temp2)
    np.testing.assert_allclose(m.compensate(fresh), w2, rtol=0, atol=1e-12)


def test_scale_factor_estimate_is_k_over_1_plus_k_of_raw():
    """Only a scale-factor error: estimate_error(raw) = k / (1 + k) * raw exactly."""
    data, w = record()
    k = 2e-3
    raw = (1 + k) * w
    d = GyroData(rate=raw, fs=1.0, g=data.g, temp=data.temp, temp_rate=data.temp_rate)
    m = fogcomp.make_method("model_lstsq", terms=("scale_factor",)).fit(d, w)
    assert m.coef_dict()["scale_factor_ppm"] == pytest.approx(2000.0, rel=1e-9)
    np.testing.assert_allclose(m.estimate_error(d), k / (1 + k) * raw, rtol=1e-9)


def test_default_reference_temperature_is_training_mean():
    data, w = record()
    m = fogcomp.make_method("model_lstsq").fit(data, w)
    assert m.t0_c_ == pytest.approx(np.mean(data.temp))
    c = m.coef_dict()
    # bias at the mean temperature = bias at T0 + temp coefficient * (mean - T0)
    expected = TRUE["bias_dph"] + TRUE["temp_dph_per_c"] * (np.mean(data.temp) - T0)
    assert c["bias_dph"] == pytest.approx(expected, rel=1e-9)
    assert c["temp_dph_per_c"] == pytest.approx(TRUE["temp_dph_per_c"], rel=1e-9)


def test_constant_temperature_warns_and_still_compensates():
    data, w = record(constant_temp=True)
    with pytest.warns(IdentifiabilityWarning, match="temp"):
        m = fogcomp.make_method("model_lstsq", t0_c=T0).fit(data, w)
    rep = m.identifiability_
    assert rep.rank == rep.n_terms - 2                   # T - T0 ~ bias; dT/dt = 0
    names = rep.names
    assert not rep.identified[names.index("bias")] and not rep.identified[names.index("temp")]
    assert not rep.identified[names.index("temp_rate")]
    assert rep.identified[names.index("scale_factor")] and rep.identified[names.index("gx")]
    # the identified combination bias + (31 - 25) * temp comes out right
    c = m.coef_dict()
    assert c["bias_dph"] + 6.0 * c["temp_dph_per_c"] == pytest.approx(
        TRUE["bias_dph"] + 6.0 * TRUE["temp_dph_per_c"], rel=1e-9)
    assert c["gyy_dph_per_g2"] == pytest.approx(TRUE["gyy_dph_per_g2"], rel=1e-9)
    np.testing.assert_allclose(m.compensate(data), w, rtol=0, atol=1e-12)


def test_unit_g_ties_bias_and_squared_terms():
    data, w = record()
    g = data.g / np.linalg.norm(data.g, axis=1)[:, None]
    d = GyroData(rate=data.rate, fs=1.0, g=g, temp=data.temp, temp_rate=data.temp_rate)
    with pytest.warns(IdentifiabilityWarning):
        m = fogcomp.make_method("model_lstsq", t0_c=T0).fit(d, w)
    null = m.identifiability_.null_space
    assert len(null) == 1
    assert null[0] == pytest.approx({"bias": 0.5, "gxx": -0.5, "gyy": -0.5, "gzz": -0.5},
                                    abs=1e-9)


def test_round_trip(tmp_path):
    data, w = record(n=500)
    m = fogcomp.make_method("model_lstsq", terms=("bias", "scale_factor", "temp")).fit(data, w)
    m.save(tmp_path / "m")
    back = fogcomp.load_model(tmp_path / "m")
    assert back.coef_dict() == m.coef_dict()
    np.testing.assert_array_equal(back.estimate_error(data), m.estimate_error(data))


@pytest.mark.parametrize("kw, arg", [
    ({"terms": ("bias", "humidity")}, "terms"),
    ({"terms": "bias"}, "terms"),
    ({"terms": ()}, "terms"),
    ({"t0_c": "room"}, "t0_c"),
    ({"rcond": -1.0}, "rcond"),
])
def test_bad_hyperparameters_name_the_argument(kw, arg):
    data, w = record(n=50)
    with pytest.raises(ValueError, match=arg):
        fogcomp.make_method("model_lstsq", **kw).fit(data, w)


def test_estimate_term_by_term_matches_the_design_matrix():
    """The compensation accumulates term by term (no (n, p) design); its slow twin builds the
    design with the fitting code's own column builder and inverts raw = (1 + k) w + e."""
    data, w = record(n=500, temp2=True)
    terms = ("bias", "scale_factor", "g", "g2", "temp", "temp_rate", "temp2")
    m = fogcomp.make_method("model_lstsq", t0_c=T0, terms=terms).fit(data, w)
    other, _ = record(n=300, seed=3, temp2=True)
    X = m._columns(other, other.rate, terms, m.t0_c_)
    k = m.coef_[1]
    want = (k * other.rate + X @ m.coef_ - k * X[:, 1]) / (1 + k)
    np.testing.assert_allclose(m.estimate_error(other), want, rtol=1e-12, atol=1e-18)
    g_only = fogcomp.make_method("model_lstsq", terms=("g",)).fit(data, w)
    np.testing.assert_allclose(g_only.estimate_error(other), other.g @ g_only.coef_,
                               rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("kw, arg", [
    ({"terms": ("bias", 3)}, "terms"),
    ({"t0_c": True}, "t0_c"),
    ({"t0_c": float("inf")}, "t0_c"),
    ({"rcond": "small"}, "rcond"),
])
def test_validate_refuses_without_data(kw, arg):
    with pytest.raises(ValueError, match=arg):
        fogcomp.make_method("model_lstsq", **kw)._validate()
