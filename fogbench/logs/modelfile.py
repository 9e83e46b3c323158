"""The model files ``fogbench calibrate`` writes and ``compensate`` reads: a manifest
(``MODEL.json``: format, version, its own SHA-256, the per-axis fogcomp model files pinned by
their checksums), checked whole before use; and how each is recognised as calibrate's own
output (only such a file is ever replaced)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from fogbench.formats.errors import LogError
from fogbench.formats.table import GYRO_UNITS
from fogbench.outputs.folders import json_format as _json_format
from fogbench.outputs.folders import starts_with as _starts_with

#: Version of the model files ``calibrate`` writes (2: checksummed, pinning the per-axis files).
MANIFEST_VERSION = 2


def _canonical_sha256(doc: dict) -> str:
    from fogcomp._persistence import _canonical_sha256 as sha

    return sha(doc)


def _sealed(doc: dict) -> dict:
    """``doc`` with ``sha256``: the SHA-256 of its canonical JSON (as fogcomp's model files)."""
    return {**doc, "sha256": _canonical_sha256(doc)}


def _file_sha256(path) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _model_error(path, text: str):
    from fogcomp import ModelFileError

    return ModelFileError(f"{path}: {text}")


def _key(doc: dict, key: str, kind, path, where: str = ""):
    """``doc[key]`` of the expected kind, else a ModelFileError naming the file and key."""
    name = f"{where}{key}"
    if key not in doc:
        raise _model_error(path, f"missing key {name!r}")
    v = doc[key]
    ok = {"str": isinstance(v, str) and v != "", "dict": isinstance(v, dict),
          "fs": isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
          and v > 0, "sha": isinstance(v, str) and re.fullmatch(r"[0-9a-f]{64}", v) is not None}
    if not ok[kind]:
        what = {"str": "a text", "dict": "a table", "fs": "a positive sample rate in Hz",
                "sha": "a SHA-256 (64 hex digits)"}[kind]
        raise _model_error(path, f"key {name!r} must be {what}, got {v!r}")
    return v


def _load_manifest(path) -> tuple[dict, Path]:
    """A model file of ``calibrate`` read and checked whole: format, version, its own checksum,
    every key with its type. The per-axis files are checked by :func:`_load_axis_models`."""
    p = Path(path)
    if p.suffix != ".json":
        p = p.with_name(p.name + ".json")
    if not p.is_file():
        raise LogError(f"{p}: model file not found (written by fogbench calibrate --out)")
    def no_constant(name):
        raise ValueError(f"{name} is not a number JSON allows")

    try:
        doc = json.loads(p.read_text(encoding="utf-8"), parse_constant=no_constant)
    except RecursionError:
        raise _model_error(p, "not a model file (JSON nested too deeply)") from None
    except ValueError as exc:  # JSON syntax, UTF-8, NaN / Infinity, integers of 4300 digits
        raise _model_error(p, f"not valid JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict) or doc.get("format") not in ("fogbench-log-model",
                                                              "fogbench-triad-model"):
        raise _model_error(p, "key 'format' must be 'fogbench-log-model' or "
                              "'fogbench-triad-model' (a file written by fogbench calibrate)")
    if doc.get("version") != MANIFEST_VERSION:
        raise _model_error(p, f"key 'version' is {doc.get('version')!r}; this fogbench reads "
                              f"{MANIFEST_VERSION} (calibrate again to write it)")
    _key(doc, "sha256", "sha", p)
    if doc["sha256"] != _canonical_sha256(doc):
        raise _model_error(p, "content does not match its checksum, key 'sha256' (the file was "
                              "edited or damaged); calibrate again")
    _key(doc, "method", "str", p)
    _key(doc, "fs_hz", "fs", p)
    if doc["format"] == "fogbench-triad-model":
        if doc["method"] != "ferraris":
            raise _model_error(p, f"key 'method' of a triad calibration must be 'ferraris', "
                                  f"got {doc['method']!r}")
        cols = _key(doc, "columns", "dict", p)
        for ch in [f"{k}_{a}" for k in ("acc", "gyro") for a in "xyz"]:
            entry = _key(cols, ch, "dict", p, "columns.")
            _key(entry, "column", "str", p, f"columns.{ch}.")
            _key(entry, "unit", "str", p, f"columns.{ch}.")
        _key(doc, "calibration", "dict", p)
    else:
        axes = _key(doc, "axes", "dict", p)
        if not axes:
            raise _model_error(p, "key 'axes' must name at least one fitted gyro axis")
        for ch, info in axes.items():
            if not re.fullmatch(r"gyro_[xyz]", ch) or not isinstance(info, dict):
                raise _model_error(p, f"key 'axes.{ch}': expected a gyro axis (gyro_x, gyro_y, "
                                      "gyro_z) with a table")
            for key, kind in (("model", "str"), ("unit", "str"), ("method", "str"),
                              ("json_sha256", "sha"), ("npz_sha256", "sha")):
                _key(info, key, kind, p, f"axes.{ch}.")
            if info["method"] != doc["method"]:
                raise _model_error(p, f"key 'axes.{ch}.method' is {info['method']!r}, the file's "
                                      f"method is {doc['method']!r}")
            if info["unit"] not in GYRO_UNITS or GYRO_UNITS[info["unit"]] is None:
                raise _model_error(p, f"key 'axes.{ch}.unit': expected a rate unit "
                                      f"({', '.join(u for u, f in GYRO_UNITS.items() if f)}), "
                                      f"got {info['unit']!r}")
            if Path(info["model"]).name != info["model"] or \
                    not info["model"].endswith(f".{ch}"):
                raise _model_error(p, f"key 'axes.{ch}.model' must name the {ch} file beside "
                                      f"the model file (ending in '.{ch}', as calibrate writes "
                                      f"it), got {info['model']!r}")
    return doc, p


def _load_axis_models(doc: dict, mpath: Path) -> dict:
    """The per-axis fogcomp models a manifest pins, each checked against the manifest: the
    SHA-256 of both of its files (a swapped, replaced or edited file is refused), its method,
    and its own sample rate where it keeps one (``fs_``)."""
    import fogcomp

    models = {}
    for ch, info in doc["axes"].items():
        stem = mpath.with_name(info["model"])
        for suffix, key in ((".json", "json_sha256"), (".npz", "npz_sha256")):
            f = stem.with_name(stem.name + suffix)
            try:
                digest = _file_sha256(f)
            except OSError as exc:
                raise _model_error(f, f"cannot be read ({exc.strerror or exc}); the model file "
                                      f"{mpath} names it for {ch}") from None
            if digest != info[key]:
                raise _model_error(f, f"does not match the checksum {mpath} pins for {ch} "
                                      f"(key 'axes.{ch}.{key}'): the file was replaced, swapped "
                                      "with another axis' or edited; calibrate again")
        model = fogcomp.load_model(stem)
        if model.name != info["method"]:
            raise _model_error(stem.with_name(stem.name + ".json"),
                               f"holds a {model.name!r} model, {mpath} says {info['method']!r}")
        fs_model = getattr(model, "fs_", None)
        if fs_model is not None and abs(float(fs_model) / float(doc["fs_hz"]) - 1.0) > 1e-9:
            raise _model_error(mpath, f"key 'fs_hz' is {doc['fs_hz']:g} Hz, the {ch} model was "
                                      f"fitted at {float(fs_model):g} Hz")
        models[ch] = model
    return models



def _is_model_manifest(path: Path) -> bool:
    return _json_format(path) in ("fogbench-log-model", "fogbench-triad-model")


def _is_fogcomp_model(path: Path) -> bool:
    if path.suffix == ".npz":        # the array half of a pair: a zip beside its own JSON half
        return _starts_with(path, b"PK") and _json_format(path.with_suffix(".json")) in (
            "fogcomp-model", None) and not path.with_suffix(".json").is_dir()
    return _json_format(path) == "fogcomp-model"
