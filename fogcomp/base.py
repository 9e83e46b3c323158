"""The estimator interface shared by every compensation method, its registry and its persistence.

A method is a class derived from :class:`Compensator`. It follows the scikit-learn contract:
``__init__`` stores hyperparameters only (the paper's values as defaults), ``fit`` validates its
inputs, learns, and returns ``self``; learned attributes end in ``_``; using a method before it is
fitted raises :class:`NotFittedError`.

Inputs travel in a :class:`GyroData` record (SI units, except temperature in degrees Celsius and
the specific force in units of g, the units in which gyro datasheets state their sensitivities).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

__all__ = [
    "GyroData",
    "Compensator",
    "NotFittedError",
    "DivergenceError",
    "ModelFileError",
    "register",
    "get_method",
    "make_method",
    "available_methods",
    "save_model",
    "load_model",
]

FORMAT_NAME = "fogcomp-model"
FORMAT_VERSION = 1
INPUT_NAMES = ("rate", "g", "temp", "temp_rate")


class NotFittedError(RuntimeError):
    """A method was asked to compensate before it was fitted."""


class DivergenceError(RuntimeError):
    """Training diverged (NaN or exploding loss). The runner reports the method as failed."""


class ModelFileError(ValueError):
    """A saved model file is missing, tampered with, of another version, or malformed."""


@dataclass(frozen=True)
class GyroData:
    """One gyro record, with whatever side information a method may need.

    Parameters
    ----------
    rate : ndarray, shape (n,)
        Gyro output, rad/s (an angular rate: angle increment / sample interval).
    fs : float
        Sample rate, Hz.
    g : ndarray, shape (n, 3), optional
        Specific force along the gyro's (x, y, z) axes, in g (9.80665 m/s^2). At rest this is
        the gravity projection, norm 1.
    temp : ndarray, shape (n,), optional
        Coil (or sensor) temperature, degrees C.
    temp_rate : ndarray, shape (n,), optional
        Temperature rate dT/dt, degrees C per second (= K/s).
    """

    rate: np.ndarray
    fs: float
    g: np.ndarray | None = None
    temp: np.ndarray | None = None
    temp_rate: np.ndarray | None = None
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        rate = _as_float_array("rate", self.rate, ndim=1)
        n = rate.shape[0]
        if n == 0:
            raise ValueError("rate: empty array, expected at least one sample")
        object.__setattr__(self, "rate", rate)
        if not (isinstance(self.fs, (int, float, np.floating, np.integer)) and np.isfinite(self.fs)
                and self.fs > 0):
            raise ValueError(f"fs: sample rate must be a positive finite number in Hz, got {self.fs!r}")
        object.__setattr__(self, "fs", float(self.fs))
        if self.g is not None:
            g = _as_float_array("g", self.g, ndim=2)
            if g.shape != (n, 3):
                raise ValueError(f"g: shape must be (n, 3) = ({n}, 3) to match rate, got {g.shape}")
            object.__setattr__(self, "g", g)
        for name in ("temp", "temp_rate"):
            v = getattr(self, name)
            if v is not None:
                v = _as_float_array(name, v, ndim=1)
                if v.shape[0] != n:
                    raise ValueError(f"{name}: length must be {n} to match rate, got {v.shape[0]}")
                object.__setattr__(self, name, v)

    def __len__(self) -> int:
        return self.rate.shape[0]

    def slice(self, sl: slice) -> "GyroData":
        """A sub-record, samples ``sl``."""
        return GyroData(
            rate=self.rate[sl], fs=self.fs,
            g=None if self.g is None else self.g[sl],
            temp=None if self.temp is None else self.temp[sl],
            temp_rate=None if self.temp_rate is None else self.temp_rate[sl],
            meta=dict(self.meta),
        )

    @staticmethod
    def concatenate(parts: list["GyroData"]) -> "GyroData":
        """Join records of the same sample rate end to end (for fitting on several runs)."""
        if not parts:
            raise ValueError("concatenate: no records given")
        fs = parts[0].fs
        for i, p in enumerate(parts):
            if p.fs != fs:
                raise ValueError(f"concatenate: record {i} has fs={p.fs} Hz, record 0 has {fs} Hz")

        def cat(name):
            vals = [getattr(p, name) for p in parts]
            if any(v is None for v in vals):
                return None
            return np.concatenate(vals)

        return GyroData(rate=cat("rate"), fs=fs, g=cat("g"), temp=cat("temp"),
                        temp_rate=cat("temp_rate"))


def _as_float_array(name: str, value: Any, ndim: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be read as a float array ({exc})") from None
    if arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        raise ValueError(f"{name}: non-finite value {arr[tuple(idx)]} at index {tuple(int(i) for i in idx)}")
    return arr


class Compensator:
    """Base class of every compensation method.

    Class attributes a method sets
    ------------------------------
    name : str
        Registry name used in scenario files (``method = "wnn"``).
    requires : tuple of str
        Which :class:`GyroData` fields ``fit`` and ``estimate_error`` need, among
        ``"rate"``, ``"g"``, ``"temp"``, ``"temp_rate"``.
    supervised : bool
        True when ``fit`` needs the reference rate (the rate the rig truly applied), so that the
        error to learn is ``data.rate - reference_rate``. Unsupervised methods (denoisers, the
        WNN whose target is derived from the raw signal itself) ignore it.
    random : bool
        True when the method draws random numbers; it then takes ``random_state``.

    Methods a subclass implements
    -----------------------------
    ``_fit(data, error)`` where ``error`` is ``data.rate - reference_rate`` (rad/s) or None, and
    ``_estimate(data)`` returning the estimated error, shape (n,), rad/s;
    ``_state()`` returning ``(json_dict, arrays_dict)`` of learned attributes, and
    ``_restore(json_dict, arrays_dict)``.
    """

    name: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ("rate",)
    supervised: ClassVar[bool] = False
    random: ClassVar[bool] = False

    # -- hyperparameters ---------------------------------------------------------------------
    def get_params(self) -> dict:
        """The constructor arguments, as stored."""
        import inspect

        sig = inspect.signature(type(self).__init__)
        return {k: getattr(self, k) for k in sig.parameters if k != "self"}

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    # -- public API ----------------------------------------------------------------------------
    def fit(self, data: GyroData, reference_rate: np.ndarray | None = None) -> "Compensator":
        """Learn the error model from ``data``.

        Parameters
        ----------
        data : GyroData
            Raw gyro record with the fields listed in ``requires``.
        reference_rate : ndarray, shape (n,), optional
            The angular rate the rig truly applied, rad/s. Required by supervised methods.

        Returns
        -------
        self
        """
        self._check_data(data, "fit")
        error = None
        if self.supervised:
            if reference_rate is None:
                raise ValueError(f"{self.name}: fit needs reference_rate (rad/s), the rate the rig "
                                 "applied, to learn the error = rate - reference_rate")
            ref = _as_float_array("reference_rate", reference_rate, ndim=1)
            if ref.shape[0] != len(data):
                raise ValueError(f"reference_rate: length must be {len(data)} to match rate, "
                                 f"got {ref.shape[0]}")
            error = data.rate - ref
        self._fit(data, error)
        self.fitted_ = True
        return self

    def estimate_error(self, data: GyroData) -> np.ndarray:
        """The estimated error of ``data.rate``, shape (n,), rad/s."""
        self._check_fitted()
        self._check_data(data, "estimate_error")
        err = np.asarray(self._estimate(data), dtype=float)
        if err.shape != data.rate.shape:
            raise RuntimeError(f"{self.name}: estimated error has shape {err.shape}, "
                               f"expected {data.rate.shape}")
        if not np.all(np.isfinite(err)):
            raise DivergenceError(f"{self.name}: estimated error contains non-finite values")
        return err

    def compensate(self, data: GyroData) -> np.ndarray:
        """The compensated rate, ``data.rate - estimate_error(data)``, shape (n,), rad/s."""
        return data.rate - self.estimate_error(data)

    def save(self, path: str | os.PathLike) -> None:
        """Save to ``path.json`` and ``path.npz`` (no pickle). See :func:`save_model`."""
        save_model(self, path)

    # -- helpers for subclasses ----------------------------------------------------------------
    def _rng(self) -> np.random.Generator:
        rs = getattr(self, "random_state", None)
        if isinstance(rs, np.random.Generator):
            return rs
        if rs is None:
            raise ValueError(f"{self.name}: random_state is None; give a seed or a "
                             "numpy Generator so that results are reproducible")
        return np.random.default_rng(rs)

    def _check_fitted(self) -> None:
        if not getattr(self, "fitted_", False):
            raise NotFittedError(f"{self.name}: this {type(self).__name__} is not fitted yet; "
                                 "call fit(data, ...) first")

    def _check_data(self, data: GyroData, where: str) -> None:
        if not isinstance(data, GyroData):
            raise TypeError(f"{self.name}.{where}: expected a fogcomp.GyroData, got "
                            f"{type(data).__name__}")
        for req in self.requires:
            if getattr(data, req) is None:
                raise ValueError(f"{self.name}.{where}: input '{req}' is required by this method "
                                 f"but is missing from the GyroData")

    # -- to be implemented ---------------------------------------------------------------------
    def _fit(self, data: GyroData, error: np.ndarray | None) -> None:  # pragma: no cover
        raise NotImplementedError

    def _estimate(self, data: GyroData) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _state(self) -> tuple[dict, dict]:  # pragma: no cover
        raise NotImplementedError

    def _restore(self, info: dict, arrays: dict) -> None:  # pragma: no cover
        raise NotImplementedError


# ---------------------------------------------------------------------------------------------
# Registry
_REGISTRY: dict[str, type[Compensator]] = {}


def register(cls: type[Compensator]) -> type[Compensator]:
    """Class decorator: make a method findable by its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__} has no registry name")
    if cls.name in _REGISTRY and _REGISTRY[cls.name] is not cls:
        raise ValueError(f"method name {cls.name!r} is registered twice")
    _REGISTRY[cls.name] = cls
    return cls


def available_methods() -> list[str]:
    """Registered method names, sorted."""
    from . import methods  # noqa: F401  (registers the built-in methods)

    return sorted(_REGISTRY)


def get_method(name: str) -> type[Compensator]:
    """The class registered under ``name``."""
    names = available_methods()
    if name not in _REGISTRY:
        raise KeyError(f"unknown method {name!r}; available: {', '.join(names)}")
    return _REGISTRY[name]


def make_method(name: str, **hyperparameters) -> Compensator:
    """An instance of method ``name`` with ``hyperparameters`` overriding the paper's defaults."""
    import inspect

    cls = get_method(name)
    allowed = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    unknown = sorted(set(hyperparameters) - set(allowed))
    if unknown:
        raise ValueError(f"method {name!r}: unknown hyperparameter(s) {unknown}; "
                         f"allowed: {allowed}")
    return cls(**hyperparameters)


# ---------------------------------------------------------------------------------------------
# Persistence: JSON (hyperparameters, scalar state, checksum) + NPZ (arrays), never pickle.
def _json_safe(v):
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


def _paths(path) -> tuple[Path, Path]:
    p = Path(path)
    if p.suffix in (".json", ".npz"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".json"), p.with_name(p.name + ".npz")


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def save_model(model: Compensator, path: str | os.PathLike) -> tuple[Path, Path]:
    """Save a fitted model as ``path.json`` + ``path.npz``; returns both paths.

    The JSON holds the format name and version, the method name, its hyperparameters, its scalar
    learned state and the SHA-256 of the NPZ, so that a tampered or mismatched pair is refused.
    """
    model._check_fitted()
    info, arrays = model._state()
    rs = model.get_params().get("random_state")
    params = {k: v for k, v in model.get_params().items()
              if not isinstance(v, np.random.Generator)}
    if isinstance(rs, np.random.Generator):
        params["random_state"] = None
    buf = io.BytesIO()
    np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    npz = buf.getvalue()
    doc = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "method": model.name,
        "hyperparameters": _json_safe(params),
        "state": _json_safe(info),
        "arrays_sha256": hashlib.sha256(npz).hexdigest(),
    }
    jpath, npath = _paths(path)
    atomic_write_bytes(npath, npz)
    atomic_write_bytes(jpath, json.dumps(doc, indent=2, allow_nan=False).encode())
    return jpath, npath


def load_model(path: str | os.PathLike) -> Compensator:
    """Load a model saved by :func:`save_model`; refuses tampered or wrong-version files."""
    jpath, npath = _paths(path)
    for p in (jpath, npath):
        if not p.exists():
            raise ModelFileError(f"{p}: file not found (a saved model is a .json + .npz pair)")
    try:
        doc = json.loads(jpath.read_text())
    except json.JSONDecodeError as exc:
        raise ModelFileError(f"{jpath}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT_NAME:
        raise ModelFileError(f"{jpath}: key 'format' must be {FORMAT_NAME!r}, "
                             f"got {doc.get('format') if isinstance(doc, dict) else doc!r}")
    if doc.get("version") != FORMAT_VERSION:
        raise ModelFileError(f"{jpath}: key 'version' is {doc.get('version')!r}; this fogcomp "
                             f"reads version {FORMAT_VERSION}")
    for key in ("method", "hyperparameters", "state", "arrays_sha256"):
        if key not in doc:
            raise ModelFileError(f"{jpath}: missing key {key!r}")
    npz = npath.read_bytes()
    if hashlib.sha256(npz).hexdigest() != doc["arrays_sha256"]:
        raise ModelFileError(f"{npath}: checksum does not match {jpath} key 'arrays_sha256' "
                             "(file modified or from another save)")
    try:
        get_method(doc["method"])
    except KeyError as exc:
        raise ModelFileError(f"{jpath}: key 'method': {exc.args[0]}") from None
    try:
        model = make_method(doc["method"], **doc["hyperparameters"])
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{jpath}: key 'hyperparameters': {exc}") from None
    try:
        with np.load(io.BytesIO(npz), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except ValueError as exc:
        raise ModelFileError(f"{npath}: cannot be read without pickle ({exc})") from None
    model._restore(doc["state"], arrays)
    model.fitted_ = True
    return model
