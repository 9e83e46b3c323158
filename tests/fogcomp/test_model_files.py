"""Saved model files: every kind of damage is a ModelFileError naming the file and the fault.

Each test builds its damage itself. "Forged" means the checksums in the .json were recomputed
after the damage, as a careless tool or a person who read the format could do; those files must
still be refused by the consistency checks behind the checksums. Also: the save/load round trip as
a property, and GyroData refusing booleans and complex numbers.
"""

import hashlib
import io
import json
import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fogcomp
from fogcomp import GyroData, ModelFileError
from fogcomp.units import DPH

FS = 10.0


def record(n=300, seed=0):
    """A record every method can fit: rate, g, temperature and its rate; and the true rate."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    truth = 0.01 * np.sin(2 * np.pi * 0.05 * t)
    g = rng.standard_normal((n, 3))
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    temp = 20 + 10 * np.sin(2 * np.pi * t / t[-1])
    temp_rate = np.gradient(temp, t)
    err = (5 + 2 * g[:, 0] - g[:, 2] ** 2 + 0.1 * (temp - 20) + 3 * temp_rate) * DPH
    rate = truth + err + 1e-4 * rng.standard_normal(n)
    return GyroData(rate=rate, fs=FS, g=g, temp=temp, temp_rate=temp_rate), truth


# Hyperparameters that make each method quick to fit (a few iterations are enough to exercise
# every learned attribute).
FAST = {
    "flnn": {"n_iter": 5, "random_state": 1},
    "bp": {"max_epochs": 20, "random_state": 1},
    "aco_bp": {"max_epochs": 10, "aco_iter": 3, "n_ants": 4, "n_candidates": 4, "random_state": 1},
    "wnn": {"max_iter": 5, "random_state": 1},
}


def fitted(name, data=None, truth=None):
    if data is None:
        data, truth = record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fogcomp.make_method(name, **FAST.get(name, {})).fit(data, truth)


def saved(tmp_path, name="bp"):
    stem = tmp_path / "m"
    fitted(name).save(stem)
    return stem, tmp_path / "m.json", tmp_path / "m.npz"


def forge(jpath, npz_bytes=None):
    """Recompute both checksums of a (damaged) pair, as the format documents them."""
    doc = json.loads(jpath.read_text())
    npath = jpath.with_suffix(".npz")
    if npz_bytes is not None:
        npath.write_bytes(npz_bytes)
    doc["arrays_sha256"] = hashlib.sha256(npath.read_bytes()).hexdigest()
    body = {k: v for k, v in doc.items() if k != "sha256"}
    doc["sha256"] = hashlib.sha256(
        json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    jpath.write_text(json.dumps(doc))


def edit_json(jpath, fn):
    doc = json.loads(jpath.read_text())
    fn(doc)
    jpath.write_text(json.dumps(doc))


def npz_with(npath, **changes):
    """The .npz bytes with some arrays replaced (value None deletes the array)."""
    with np.load(npath, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    for k, v in changes.items():
        if v is None:
            del arrays[k]
        else:
            arrays[k] = v
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def assert_refused(stem, *fragments):
    with pytest.raises(ModelFileError) as info:
        fogcomp.load_model(stem)
    msg = str(info.value)
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in {msg!r}"
    return msg


# -- edits without forging: the JSON's own checksum -----------------------------------------------
def test_a_learned_number_multiplied_by_1000_in_the_json_is_refused(tmp_path):
    stem, jpath, _ = saved(tmp_path, "bp")
    edit_json(jpath, lambda d: d["state"].__setitem__("y_half_", d["state"]["y_half_"] * 1000))
    assert_refused(stem, str(jpath), "'sha256'", "edited")


def test_a_hyperparameter_edited_in_the_json_is_refused(tmp_path):
    stem, jpath, _ = saved(tmp_path, "flnn_lstsq")
    edit_json(jpath, lambda d: d["hyperparameters"].__setitem__("rcond", 0.5))
    assert_refused(stem, str(jpath), "'sha256'")


def test_the_array_manifest_or_npz_checksum_edited_in_the_json_is_refused(tmp_path):
    stem, jpath, npath = saved(tmp_path, "flnn_lstsq")
    edit_json(jpath, lambda d: d["arrays"]["coef"].__setitem__("shape", [3]))
    assert_refused(stem, str(jpath), "'sha256'")
    stem, jpath, npath = saved(tmp_path, "flnn_lstsq")
    edit_json(jpath, lambda d: d.__setitem__("arrays_sha256", "0" * 64))
    assert_refused(stem, str(jpath), "'sha256'")


def test_a_modified_npz_is_refused_by_its_checksum(tmp_path):
    stem, _, npath = saved(tmp_path, "flnn_lstsq")
    npath.write_bytes(npz_with(npath, coef=np.zeros(10)))
    assert_refused(stem, str(npath), "checksum", "arrays_sha256")


# -- damaged files ------------------------------------------------------------------------------
def test_a_json_of_random_bytes_is_refused_not_a_unicode_error(tmp_path):
    stem, jpath, _ = saved(tmp_path)
    jpath.write_bytes(b"\xff\xfe" + np.random.default_rng(0).bytes(500))
    assert_refused(stem, str(jpath), "not UTF-8")
    jpath.write_bytes(b"model: 1, \x01\x02 not json")
    assert_refused(stem, str(jpath), "not valid JSON")
    jpath.write_text("[1, 2, 3]")
    assert_refused(stem, str(jpath), "JSON object")
    jpath.write_text("[" * 100_000)
    assert_refused(stem, str(jpath))


def test_a_truncated_npz_with_a_forged_checksum_is_refused_not_a_bad_zip_file(tmp_path):
    stem, jpath, npath = saved(tmp_path)
    blob = npath.read_bytes()
    for cut in (len(blob) // 2, 10, 0):
        forge(jpath, blob[:cut])
        assert_refused(stem, str(npath), ".npz")
    # random bytes: np.load would take them for a pickle
    forge(jpath, b"\x80\x04" + np.random.default_rng(1).bytes(300))
    assert_refused(stem, str(npath), "without pickle")
    # a single .npy instead of an archive
    buf = io.BytesIO()
    np.save(buf, np.zeros(3))
    forge(jpath, buf.getvalue())
    assert_refused(stem, str(npath))


def test_an_npz_member_with_a_corrupted_body_is_refused(tmp_path):
    stem, jpath, npath = saved(tmp_path, "flnn_lstsq")
    blob = bytearray(npath.read_bytes())
    start = blob.find(b"coef.npy") + len(b"coef.npy") + 100  # inside the member's data
    blob[start:start + 8] = b"\x00" * 8
    forge(jpath, bytes(blob))
    assert_refused(stem, str(npath), "BadZipFile")   # the zip's own CRC catches it


def test_an_array_of_the_wrong_shape_is_refused_at_load(tmp_path):
    stem, jpath, npath = saved(tmp_path, "flnn_lstsq")
    forge(jpath, npz_with(npath, coef=np.zeros(9)))
    assert_refused(stem, str(npath), "'coef'", "shape (9,)", "(10,)")


def test_a_wrong_shape_consistent_with_a_forged_manifest_fails_the_probe_at_load(tmp_path):
    # Without the probe this is a matmul shape error at compensate time.
    for name, key, value in (("flnn_lstsq", "coef", np.zeros(9)),
                             ("bp", "params", np.zeros(7)),
                             ("bp", "x_center", np.zeros(5))):
        stem = tmp_path / name / key
        fitted(name).save(stem)
        jpath, npath = stem.parent / f"{key}.json", stem.parent / f"{key}.npz"
        npath.write_bytes(npz_with(npath, **{key: value}))
        edit_json(jpath, lambda d: d["arrays"][key].__setitem__("shape", list(value.shape)))
        forge(jpath)
        assert_refused(stem, str(jpath), "cannot compensate", "inconsistent")


def test_a_nan_learned_weight_behind_forged_checksums_is_refused(tmp_path):
    stem, jpath, npath = saved(tmp_path, "flnn_lstsq")
    coef = np.full(10, np.nan)
    forge(jpath, npz_with(npath, coef=coef))
    assert_refused(stem, str(jpath), "non-finite")


def test_a_deleted_state_key_is_refused_not_a_key_error(tmp_path):
    stem, jpath, _ = saved(tmp_path, "bp")
    edit_json(jpath, lambda d: d["state"].pop("n_epochs_"))
    forge(jpath)
    assert_refused(stem, str(jpath), "'state'", "'n_epochs_'", "missing")


def test_a_deleted_array_is_refused_not_a_key_error(tmp_path):
    stem, jpath, npath = saved(tmp_path, "bp")
    forge(jpath, npz_with(npath, params=None))
    assert_refused(stem, str(npath), "'params'", "missing")
    # and with the manifest forged to match: the method's own lookup names it
    edit_json(jpath, lambda d: d["arrays"].pop("params"))
    forge(jpath)
    assert_refused(stem, str(npath), "array 'params' is missing")


def test_a_state_value_of_the_wrong_type_is_refused(tmp_path):
    stem, jpath, _ = saved(tmp_path, "bp")
    edit_json(jpath, lambda d: d["state"].__setitem__("n_epochs_", "many"))
    forge(jpath)
    assert_refused(stem, str(jpath), "'state'", "many")


@pytest.mark.parametrize("name, key, value", [
    ("bp", "hidden_size", "nine"),
    ("bp", "learning_rate", -1.0),
    ("wnn", "level", "four"),
    ("wavelet_soft", "wavelet", "db99"),
    ("flnn", "n_iter", 2.5),
    ("flnn", "random_state", True),
])
def test_a_hyperparameter_of_the_wrong_type_or_value_is_refused_on_load(tmp_path, name, key,
                                                                       value):
    stem = tmp_path / "m"
    fitted(name).save(stem)
    jpath = tmp_path / "m.json"
    edit_json(jpath, lambda d: d["hyperparameters"].__setitem__(key, value))
    forge(jpath)
    assert_refused(stem, str(jpath), "'hyperparameters'", key)


def test_a_missing_or_unknown_hyperparameter_is_refused_on_load(tmp_path):
    stem, jpath, _ = saved(tmp_path, "bp")
    edit_json(jpath, lambda d: d["hyperparameters"].pop("hidden_size"))
    forge(jpath)
    assert_refused(stem, str(jpath), "lacks ['hidden_size']")
    stem, jpath, _ = saved(tmp_path, "bp")
    edit_json(jpath, lambda d: d["hyperparameters"].__setitem__("hidden_units", 3))
    forge(jpath)
    assert_refused(stem, str(jpath), "unknown hyperparameter", "hidden_units")


def test_wrong_types_of_the_header_keys_are_refused(tmp_path):
    stem, jpath, _ = saved(tmp_path)
    edit_json(jpath, lambda d: d.__setitem__("state", [1, 2]))
    assert_refused(stem, str(jpath), "key 'state' must be a JSON object")
    stem, jpath, _ = saved(tmp_path)
    edit_json(jpath, lambda d: d.pop("sha256"))
    assert_refused(stem, str(jpath), "missing key 'sha256'")
    stem, jpath, _ = saved(tmp_path)
    edit_json(jpath, lambda d: d.__setitem__("method", "nope"))
    forge(jpath)
    assert_refused(stem, str(jpath), "unknown method 'nope'")


def test_a_model_saved_by_the_version_1_format_is_refused_with_a_version_message(tmp_path):
    # Version 1 as fogcomp wrote it before: no 'sha256', no 'arrays' manifest.
    stem, jpath, npath = saved(tmp_path, "flnn_lstsq")
    doc = json.loads(jpath.read_text())
    old = {k: doc[k] for k in ("format", "method", "hyperparameters", "state", "arrays_sha256")}
    old["version"] = 1
    jpath.write_text(json.dumps(old, indent=2))
    msg = assert_refused(stem, str(jpath), "'version' is 1", "reads version 2")
    assert "older" in msg and "fit the method again" in msg
    edit_json(jpath, lambda d: d.__setitem__("version", 99))
    msg = assert_refused(stem, "'version' is 99")
    assert "older" not in msg


def test_missing_files_are_refused(tmp_path):
    stem, jpath, npath = saved(tmp_path)
    os.unlink(npath)
    assert_refused(stem, str(npath), "not found")
    assert_refused(tmp_path / "absent", "not found")


# -- the round trip, as a property --------------------------------------------------------------
ROUND_TRIP = ["flnn_lstsq", "poly_temp", "model_lstsq", "wavelet_soft", "kalman", "flnn", "bp",
              "aco_bp", "wnn"]


def test_the_round_trip_list_holds_every_built_in_method():
    # other test modules register toy methods of their own: compare with fogcomp's
    built_in = [n for n in fogcomp.available_methods()
                if fogcomp.get_method(n).__module__.startswith("fogcomp.methods.")]
    assert sorted(ROUND_TRIP) == built_in


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(ROUND_TRIP), seed=st.integers(0, 2**32 - 1),
       n=st.integers(200, 600), scale=st.floats(1e-3, 1e3))
def test_save_then_load_compensates_identically(tmp_path, name, seed, n, scale):
    data, truth = record(n=n, seed=seed)
    data = GyroData(rate=data.rate * scale, fs=FS, g=data.g, temp=data.temp,
                    temp_rate=data.temp_rate)
    m = fitted(name, data, truth * scale)
    stem = tmp_path / f"{name}-{seed}"
    m.save(stem)
    back = fogcomp.load_model(stem)
    assert type(back) is type(m)
    # JSON has no tuple: compare the hyperparameters as JSON
    assert json.dumps(back.get_params(), sort_keys=True) == json.dumps(m.get_params(),
                                                                        sort_keys=True)
    other, _ = record(n=257, seed=seed + 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        np.testing.assert_array_equal(back.compensate(other), m.compensate(other))
        np.testing.assert_array_equal(back.compensate(data), m.compensate(data))


# -- check_params and make_method ---------------------------------------------------------------
def test_check_params_calls_the_methods_validate_without_data():
    m = fogcomp.make_method("bp")
    m.hidden_size = 0
    with pytest.raises(ValueError, match="hidden_size"):
        m.check_params()
    with pytest.raises(ValueError, match="hidden_size"):
        fogcomp.make_method("bp", hidden_size="nine")


def test_check_params_refuses_a_random_state_that_is_not_a_seed():
    for bad in (True, -1, 1.5, "seed"):
        with pytest.raises(ValueError, match="random_state"):
            fogcomp.make_method("flnn", random_state=bad)
    for good in (None, 0, 2**40, np.random.default_rng(1), np.random.SeedSequence(3)):
        fogcomp.make_method("flnn", random_state=good).check_params()


def test_check_params_is_a_no_op_for_a_method_without_validate():
    class Plain(fogcomp.Compensator):
        name = "plain_test_only"

        def __init__(self, k=1):
            self.k = k

    assert Plain(k="anything").check_params() is None  # no _validate: nothing to refuse


# -- GyroData: booleans and complex numbers are not rates ------------------------------------------
@pytest.mark.parametrize("fs", [True, False, np.bool_(True)])
def test_a_boolean_sample_rate_is_refused(fs):
    with pytest.raises(ValueError, match=r"fs: .*boolean"):
        GyroData(rate=np.zeros(4), fs=fs)


@pytest.mark.parametrize("field", ["rate", "g", "temp", "temp_rate"])
@pytest.mark.parametrize("kind, make", [
    ("boolean", lambda shape: np.ones(shape, dtype=bool)),
    ("complex", lambda shape: np.ones(shape) + 0j),
    ("boolean", lambda shape: np.ones(shape, dtype=bool).tolist()),
    ("complex", lambda shape: np.full(shape, 1 + 2j, dtype=object)),
    ("text", lambda shape: np.full(shape, "0.1")),                  # "0.1" read as 0.1 before
    ("text", lambda shape: np.full(shape, "0.1", dtype=object)),
    ("text", lambda shape: np.full(shape, b"0.1")),
])
def test_boolean_complex_or_text_arrays_are_refused_with_the_argument_name(field, kind, make):
    n = 5
    kw = {"rate": np.zeros(n), "fs": FS}
    kw[field] = make((n, 3) if field == "g" else (n,))
    with pytest.raises(ValueError, match=rf"^{field}: {kind} values are not accepted"):
        GyroData(**kw)


def test_real_inputs_of_other_dtypes_are_still_accepted():
    d = GyroData(rate=np.arange(4, dtype=np.int16), fs=np.int64(100), temp=[1, 2, 3, 4],
                 temp_rate=np.zeros(4, dtype=np.float32))
    assert d.rate.dtype == float and d.fs == 100.0 and d.temp.dtype == float


def test_a_boolean_reference_rate_is_refused():
    data, truth = record()
    with pytest.raises(ValueError, match="reference_rate: boolean"):
        fogcomp.make_method("poly_temp").fit(data, truth > 0)
