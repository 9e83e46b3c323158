"""Saved models: a JSON file (hyperparameters, scalar state, manifest, checksums) and an NPZ
file (arrays), never pickle.

Format version 2 (version 1 checked only the .npz)::

    format, version, method, hyperparameters, state,
    arrays          {name: {"shape": [...], "dtype": "<f8"}} for every array in the .npz,
    arrays_sha256   SHA-256 of the .npz bytes,
    sha256          SHA-256 of the canonical JSON (sorted keys, no spaces) of every other key, so
                    that any edit of the .json (a learned number, a hyperparameter, the manifest
                    or the .npz checksum) is refused.

``method`` is the registry name of the method (:func:`fogcomp.method_id`; a plug-in class not
registered under its name is recorded as ``module:Class``), never a fogcomp module path.
The checksums detect damage and hand edits; they are not a signature: whoever rewrites both
checksums can make any file pass them. What they let through is then checked for consistency
(hyperparameters validated, arrays against the manifest, the restored model compensating a probe
record).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ._data import GyroData
from ._registry import get_method, make_method, method_id

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "ModelFileError",
    "atomic_write_bytes",
    "load_model",
    "save_model",
]

FORMAT_NAME = "fogcomp-model"
FORMAT_VERSION = 2


class ModelFileError(ValueError):
    """A saved model file is missing, tampered with, of another version, or malformed."""


_ARRAY_KINDS = "biuf"  # bool, integer and float arrays; no complex, string or object
_PROBE_SAMPLES = 512


def _json_safe(v):
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.floating,)):
        return float(v)
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _json_safe(x) for k, x in v.items()}
    return v


def _canonical_sha256(doc: dict) -> str:
    """SHA-256 of ``doc`` without its ``sha256`` key, as canonical JSON (sorted keys, compact)."""
    body = {k: v for k, v in doc.items() if k != "sha256"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _paths(path) -> tuple[Path, Path]:
    p = Path(path)
    if p.suffix in (".json", ".npz"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".json"), p.with_name(p.name + ".npz")


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    An ``OSError`` (a full disk, a file-size limit) names ``path`` (``exc.filename``): the write
    call itself says only "No space left on device". The temporary file is removed."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise _named(exc, path) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except OSError as exc:
        _unlink_quietly(tmp)
        raise _named(exc, path) from None
    except BaseException:
        _unlink_quietly(tmp)
        raise


def _unlink_quietly(path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _named(exc: OSError, path) -> OSError:
    """``exc`` with ``path`` as its file name when it has none (same class and errno)."""
    if getattr(exc, "filename", None):
        return exc
    return type(exc)(exc.errno, exc.strerror or str(exc), str(path))


def save_model(model, path: str | os.PathLike) -> tuple[Path, Path]:
    """Save a fitted model as ``path.json`` + ``path.npz``; returns both paths.

    The JSON holds the format name and version, the method name, its hyperparameters, its scalar
    learned state, the name, shape and dtype of every array in the NPZ, the SHA-256 of the NPZ and
    a SHA-256 of the JSON's own content, so that an edited, damaged or mismatched pair is refused
    by :func:`load_model`. A ``random_state`` given as a numpy Generator is saved as None (a
    loaded model compensates without it; give it a seed before fitting it again).

    Parameters
    ----------
    model : Compensator
        A fitted method.
    path : str or path-like
        The common stem of the pair (``model`` for ``model.json`` + ``model.npz``), or either
        file.

    Returns
    -------
    json_path, npz_path : pathlib.Path
        The two files written.
    """
    model._check_fitted()
    info, arrays = model._state()
    params = model.get_params()
    if isinstance(params.get("random_state"), (np.random.Generator, np.random.BitGenerator,
                                               np.random.SeedSequence)):
        params["random_state"] = None
    arrays = {k: np.asarray(v) for k, v in arrays.items()}
    for k, a in arrays.items():
        if a.dtype.kind not in _ARRAY_KINDS:
            raise TypeError(f"{model.name}: learned array {k!r} has dtype {a.dtype}; only boolean, "
                            "integer and real arrays are saved")
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    npz = buf.getvalue()
    doc = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "method": method_id(type(model)),
        "hyperparameters": _json_safe(params),
        "state": _json_safe(info),
        "arrays": {k: {"shape": list(a.shape), "dtype": a.dtype.str} for k, a in arrays.items()},
        "arrays_sha256": hashlib.sha256(npz).hexdigest(),
    }
    try:
        doc["sha256"] = _canonical_sha256(doc)
        text = json.dumps(doc, indent=2, allow_nan=False)
    except ValueError as exc:  # NaN or inf in a hyperparameter or scalar state
        raise ValueError(f"{model.name}: cannot save a non-finite number in the JSON part "
                         f"(hyperparameters or scalar state): {exc}") from None
    jpath, npath = _paths(path)
    atomic_write_bytes(npath, npz)
    atomic_write_bytes(jpath, text.encode("utf-8"))
    return jpath, npath


class _StateDict(dict):
    """A dict whose missing keys are a :class:`ModelFileError` naming the file and the key."""

    def __init__(self, values: dict, where: str, what: str):
        super().__init__(values)
        self._where = where
        self._what = what

    def __missing__(self, key):
        raise ModelFileError(f"{self._where}: {self._what} {key!r} is missing "
                             f"(present: {sorted(self)})")


def _read_json(jpath: Path) -> dict:
    try:
        raw = jpath.read_bytes()
    except OSError as exc:
        raise ModelFileError(f"{jpath}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{jpath}: not a saved model, not UTF-8 text (byte {exc.start} is "
                             f"0x{raw[exc.start]:02x})") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ModelFileError(f"{jpath}: not valid JSON ({exc})") from None
    except RecursionError:
        raise ModelFileError(f"{jpath}: not a saved model (JSON nested too deeply)") from None
    if not isinstance(doc, dict):
        raise ModelFileError(f"{jpath}: expected a JSON object, got {type(doc).__name__}")
    return doc


def _check_header(doc: dict, jpath: Path) -> None:
    if doc.get("format") != FORMAT_NAME:
        raise ModelFileError(f"{jpath}: key 'format' must be {FORMAT_NAME!r}, "
                             f"got {doc.get('format')!r}")
    version = doc.get("version")
    if version != FORMAT_VERSION or isinstance(version, bool):
        older = (isinstance(version, int) and not isinstance(version, bool)
                 and version < FORMAT_VERSION)
        hint = ("; it was saved by an older fogcomp, whose files do not protect their JSON "
                "against edits: fit the method again and save it" if older else "")
        raise ModelFileError(f"{jpath}: key 'version' is {version!r}; this fogcomp reads "
                             f"version {FORMAT_VERSION}{hint}")
    types = {"method": str, "hyperparameters": dict, "state": dict, "arrays": dict,
             "arrays_sha256": str, "sha256": str}
    for key, typ in types.items():
        if key not in doc:
            raise ModelFileError(f"{jpath}: missing key {key!r}")
        if not isinstance(doc[key], typ):
            raise ModelFileError(f"{jpath}: key {key!r} must be a JSON "
                                 f"{ {str: 'string', dict: 'object'}[typ] }, "
                                 f"got {type(doc[key]).__name__}")
    unknown = sorted(set(doc) - set(types) - {"format", "version"})
    if unknown:
        raise ModelFileError(f"{jpath}: unknown key(s) {unknown}")


def _read_arrays(npz: bytes, npath: Path) -> dict[str, np.ndarray]:
    try:
        z = np.load(io.BytesIO(npz), allow_pickle=False)
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise ValueError(f"holds a single {type(z).__name__}, not an .npz archive of arrays")
        with z:
            return {k: z[k] for k in z.files}
    except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        raise ModelFileError(f"{npath}: cannot be read as an .npz archive without pickle "
                             f"({type(exc).__name__}: {exc})") from None


def _check_manifest(arrays: dict, manifest: dict, jpath: Path, npath: Path) -> None:
    missing = sorted(set(manifest) - set(arrays))
    if missing:
        raise ModelFileError(f"{npath}: array(s) {missing} listed in {jpath} key 'arrays' are "
                             "missing")
    extra = sorted(set(arrays) - set(manifest))
    if extra:
        raise ModelFileError(f"{npath}: array(s) {extra} are not listed in {jpath} key 'arrays'")
    for k, a in arrays.items():
        spec = manifest[k]
        if not (isinstance(spec, dict) and isinstance(spec.get("shape"), list)
                and isinstance(spec.get("dtype"), str)):
            raise ModelFileError(f"{jpath}: key 'arrays.{k}' must be "
                                 "{\"shape\": [...], \"dtype\": \"...\"}")
        if list(a.shape) != spec["shape"]:
            raise ModelFileError(f"{npath}: array {k!r} has shape {a.shape}, the model was saved "
                                 f"with shape {tuple(spec['shape'])}")
        if a.dtype.str != spec["dtype"] or a.dtype.kind not in _ARRAY_KINDS:
            raise ModelFileError(f"{npath}: array {k!r} has dtype {a.dtype}, the model was saved "
                                 f"with dtype {spec['dtype']}")


def _probe_record(model) -> GyroData:
    """A short synthetic record with every input a method may need, to exercise a loaded model."""
    n = _PROBE_SAMPLES
    rng = np.random.default_rng(20240229)
    fs = getattr(model, "fs_", None)
    fs = float(fs) if isinstance(fs, (int, float)) and np.isfinite(fs) and fs > 0 else 10.0
    t = np.arange(n) / fs
    phase = 2 * np.pi * np.arange(n) / n
    g = np.stack([np.cos(phase) * 0.6, np.sin(phase) * 0.6, np.full(n, 0.8)], axis=1)
    temp = 25.0 + 5.0 * np.sin(phase)
    return GyroData(rate=1e-4 * rng.standard_normal(n) + 1e-3 * np.sin(phase), fs=fs, g=g,
                    temp=temp, temp_rate=np.gradient(temp, t))


def load_model(path: str | os.PathLike):
    """Load a model saved by :func:`save_model`.

    Parameters
    ----------
    path : str or path-like
        The common stem of the pair (``model`` for ``model.json`` + ``model.npz``), or either file.

    Returns
    -------
    Compensator
        The fitted model.

    Raises
    ------
    ModelFileError
        Naming the file and what is wrong: missing, not JSON, another format or version, the
        JSON edited after saving (its SHA-256), the NPZ damaged or from another save, a
        hyperparameter of the wrong type or value, a learned array of the wrong shape, a state
        key missing, or a restored model that cannot compensate.
    """
    jpath, npath = _paths(path)
    doc, npz = _read_checked_pair(jpath, npath)
    method = doc["method"]
    model = _unfitted_model(doc, method, jpath)
    arrays = _read_arrays(npz, npath)
    _check_manifest(arrays, doc["arrays"], jpath, npath)
    _restore_state(model, doc, arrays, method, jpath, npath)
    # A restored state can still be inconsistent (an array of another shape than the
    # hyperparameters imply, a NaN weight): compensate a probe record now rather than fail later.
    _check_probe(model, method, jpath, npath)
    return model


def _read_checked_pair(jpath: Path, npath: Path) -> tuple[dict, bytes]:
    """The JSON document and the NPZ bytes of a saved pair, both present, the JSON of this
    format and version, and both matching their checksums."""
    for p in (jpath, npath):
        if not p.is_file():
            raise ModelFileError(f"{p}: file not found (a saved model is a .json + .npz pair)")
    doc = _read_json(jpath)
    _check_header(doc, jpath)
    if _canonical_sha256(doc) != doc["sha256"]:
        raise ModelFileError(f"{jpath}: content does not match its checksum, key 'sha256' (the "
                             "JSON was edited or damaged after saving)")
    try:
        npz = npath.read_bytes()
    except OSError as exc:
        raise ModelFileError(f"{npath}: cannot be read ({exc.strerror or exc})") from None
    if hashlib.sha256(npz).hexdigest() != doc["arrays_sha256"]:
        raise ModelFileError(f"{npath}: checksum does not match {jpath} key 'arrays_sha256' "
                             "(file modified or from another save)")
    return doc, npz


def _unfitted_model(doc: dict, method: str, jpath: Path):
    """The method the file names, made with the file's hyperparameters (every one of them
    present, each checked as :func:`~fogcomp.make_method` checks it)."""
    try:
        cls = get_method(method)
    except KeyError as exc:
        raise ModelFileError(f"{jpath}: key 'method': {exc.args[0]}") from None

    import inspect

    hp = doc["hyperparameters"]
    expected = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    missing = [k for k in expected if k not in hp]
    if missing:
        raise ModelFileError(f"{jpath}: key 'hyperparameters' lacks {missing} of method "
                             f"{method!r} (no default is assumed for a saved model)")
    try:
        return make_method(method, **hp)  # refuses unknown names, checks every value
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{jpath}: key 'hyperparameters' of method {method!r}: "
                             f"{exc}") from None


def _restore_state(model, doc: dict, arrays: dict, method: str, jpath: Path,
                   npath: Path) -> None:
    """The learned state into ``model`` (a missing key or array named with its file), which is
    then fitted."""
    try:
        model._restore(_StateDict(doc["state"], str(jpath), "key 'state' entry"),
                       _StateDict(arrays, str(npath), "array"))
    except ModelFileError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise ModelFileError(f"{jpath}: key 'state' cannot be restored for method {method!r} "
                             f"({type(exc).__name__}: {exc})") from None
    model.fitted_ = True


def _check_probe(model, method: str, jpath: Path, npath: Path) -> None:
    """Refuse a restored model that cannot compensate a probe record."""
    import warnings

    probe = _probe_record(model)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.estimate_error(probe)
    except Exception as exc:  # noqa: BLE001 (any failure here means an unusable file)
        raise ModelFileError(f"{jpath} + {npath.name}: the restored {method!r} model cannot "
                             f"compensate a test record ({type(exc).__name__}: {exc}); the "
                             "learned state is inconsistent") from None
