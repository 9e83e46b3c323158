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
import re
import tempfile
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ._checks import _random_state

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
FORMAT_VERSION = 2
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
        if (isinstance(self.fs, (bool, np.bool_))
                or not isinstance(self.fs, (int, float, np.floating, np.integer))
                or not np.isfinite(self.fs) or self.fs <= 0):
            why = (" (a boolean is not a sample rate)"
                   if isinstance(self.fs, (bool, np.bool_)) else "")
            raise ValueError(f"fs: sample rate must be a positive finite number in Hz, "
                             f"got {self.fs!r}{why}")
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
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be read as an array ({exc})") from None
    kind = _refused_kind(raw)
    if kind:
        raise ValueError(f"{name}: {kind} values are not accepted, expected real numbers "
                         f"(dtype {raw.dtype}); convert explicitly if that is really meant")
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be read as a float array ({exc})") from None
    if arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        where = tuple(int(i) for i in idx)
        raise ValueError(f"{name}: non-finite value {arr[tuple(idx)]} at index {where}")
    return arr


def _refused_kind(raw: np.ndarray) -> str:
    """'boolean' or 'complex' when ``raw`` holds such values (which a float cast would hide)."""
    if raw.dtype.kind == "b":
        return "boolean"
    if raw.dtype.kind == "c":
        return "complex"
    if raw.dtype.kind == "O":
        for x in raw.flat:
            if isinstance(x, (bool, np.bool_)):
                return "boolean"
            if isinstance(x, (complex, np.complexfloating)):
                return "complex"
    return ""


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

    def check_params(self) -> None:
        """Check every hyperparameter now, without data.

        Calls the method's ``_validate()`` when its class defines one (each method checks the
        type and range of each of its hyperparameters there), and checks ``random_state`` for
        methods that draw random numbers. Lets a scenario loader refuse a bad hyperparameter before
        any simulation runs.

        Raises
        ------
        ValueError
            Naming the hyperparameter and what was expected.
        """
        if type(self).random:
            _random_state(getattr(self, "random_state", None))
        validate = getattr(self, "_validate", None)
        if callable(validate):
            validate()

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
# Registry: the built-in methods, plug-ins declared as entry points of the group
# ``fogcomp.methods`` (``importlib.metadata``, as pytest finds its plug-ins), and any class named
# ``module:Class`` of an importable, installed module (never a file path).
ENTRY_POINT_GROUP = "fogcomp.methods"
_REGISTRY: dict[str, type[Compensator]] = {}
_PLUGIN_PROBLEMS: dict[str, str] = {}     # entry-point name -> why it could not be loaded
_ENTRY_POINTS_READ = False
_CLASS_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*:"
                         r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


class PluginError(KeyError):
    """A plug-in method that cannot be used: its module does not import, or what it names is
    not a usable :class:`Compensator` subclass. The message gives the reason. (A KeyError, as an
    unknown name is, so that callers refusing unknown methods refuse these too; the runner tells
    them apart and reports the method as failed instead.)"""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def register(cls: type[Compensator]) -> type[Compensator]:
    """Class decorator: make a method findable by its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__} has no registry name")
    if cls.name in _REGISTRY and _REGISTRY[cls.name] is not cls:
        raise ValueError(f"method name {cls.name!r} is registered twice")
    _REGISTRY[cls.name] = cls
    return cls


def class_problem(cls) -> str | None:
    """Why ``cls`` cannot be a method (None: it can): the structural contract checked before
    any data (the behaviour is :func:`fogcomp.check_method`'s)."""
    import inspect

    if not (isinstance(cls, type) and issubclass(cls, Compensator)) or cls is Compensator:
        return f"{cls!r} is not a subclass of fogcomp.Compensator"
    if not isinstance(cls.name, str) or not cls.name:
        return f"{cls.__name__} has no registry name (class attribute 'name')"
    bad = [r for r in cls.requires if r not in INPUT_NAMES] if isinstance(
        cls.requires, tuple) else ["(requires is not a tuple)"]
    if bad:
        return (f"{cls.__name__}.requires names {bad}; expected a tuple among "
                f"{list(INPUT_NAMES)}")
    for m in ("_fit", "_estimate", "_state", "_restore"):
        if getattr(cls, m) is getattr(Compensator, m):
            return f"{cls.__name__} does not implement {m}"
    try:
        sig = inspect.signature(cls.__init__)
    except (TypeError, ValueError) as exc:
        return f"{cls.__name__}.__init__ has no readable signature ({exc})"
    required = [p.name for p in list(sig.parameters.values())[1:]
                if p.default is inspect.Parameter.empty
                and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    if required:
        return (f"{cls.__name__}.__init__ has hyperparameters without defaults {required} "
                "(every hyperparameter needs a default, the method's own setting)")
    if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in sig.parameters.values()):
        return f"{cls.__name__}.__init__ takes *args or **kwargs (name every hyperparameter)"
    return None


def _read_entry_points() -> None:
    """Load the plug-ins of the ``fogcomp.methods`` entry-point group once; one that fails to
    import or is no usable method is kept in ``_PLUGIN_PROBLEMS`` with the reason."""
    global _ENTRY_POINTS_READ
    if _ENTRY_POINTS_READ:
        return
    _ENTRY_POINTS_READ = True
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in _REGISTRY:
            if getattr(_REGISTRY[ep.name], "__module__", "").startswith("fogcomp."):
                _PLUGIN_PROBLEMS[ep.name] = (f"entry point {ep.name!r} ({ep.value}) has the "
                                             "name of a built-in method")
            continue
        try:
            cls = ep.load()
        except BaseException as exc:  # noqa: BLE001 (a plug-in's import may do anything)
            if isinstance(exc, KeyboardInterrupt):
                raise
            _PLUGIN_PROBLEMS[ep.name] = (f"entry point {ep.name!r} ({ep.value}) does not "
                                         f"import: {type(exc).__name__}: {exc}")
            continue
        problem = class_problem(cls)
        if problem is None and cls.name != ep.name:
            problem = (f"entry point {ep.name!r} ({ep.value}) names a class whose 'name' is "
                       f"{cls.name!r}; they must agree")
        if problem:
            _PLUGIN_PROBLEMS[ep.name] = f"entry point {ep.name!r}: {problem}"
        else:
            _REGISTRY[ep.name] = cls


def available_methods() -> list[str]:
    """Method names, sorted: the built-ins and the plug-ins of the entry-point group
    ``fogcomp.methods`` that load (:func:`plugin_problems` lists those that do not)."""
    from . import methods  # noqa: F401  (registers the built-in methods)

    _read_entry_points()
    return sorted(_REGISTRY)


def plugin_problems() -> dict[str, str]:
    """Entry-point plug-ins that could not be loaded: name -> reason."""
    available_methods()
    return dict(_PLUGIN_PROBLEMS)


def _import_class(name: str) -> type[Compensator]:
    import importlib

    if not _CLASS_NAME.match(name):
        raise KeyError(f"method {name!r}: a plug-in class is named module:Class (an importable, "
                       "installed module, e.g. mypkg.methods:MyMethod), never a file path")
    mod_name, _, qual = name.partition(":")
    try:
        obj = importlib.import_module(mod_name)
    except ModuleNotFoundError as exc:
        if exc.name and (mod_name == exc.name or mod_name.startswith(exc.name + ".")):
            raise KeyError(f"method {name!r}: no module {exc.name!r} is installed (pip install "
                           "the plug-in's package into this environment)") from None
        raise PluginError(f"method {name!r}: its module does not import: "
                          f"ModuleNotFoundError: {exc}") from None
    except BaseException as exc:  # noqa: BLE001 (a plug-in's import may do anything)
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise PluginError(f"method {name!r}: its module does not import: "
                          f"{type(exc).__name__}: {exc}") from None
    for part in qual.split("."):
        if not hasattr(obj, part):
            raise KeyError(f"method {name!r}: module {mod_name!r} has no {qual!r}")
        obj = getattr(obj, part)
    problem = class_problem(obj)
    if problem:
        raise PluginError(f"method {name!r}: {problem}")
    return obj


def get_method(name: str) -> type[Compensator]:
    """The class registered under ``name`` (a built-in or an entry-point plug-in), or the class
    ``module:Class`` names.

    Raises
    ------
    KeyError
        An unknown name (the message lists the available ones).
    PluginError
        A plug-in that does not import or is not a usable method (the message says why).
    """
    names = available_methods()
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name in _PLUGIN_PROBLEMS:
        raise PluginError(_PLUGIN_PROBLEMS[name])
    if ":" in name:
        return _import_class(name)
    raise KeyError(f"unknown method {name!r}; available: {', '.join(names)} (or a plug-in "
                   "named module:Class)")


def method_id(cls: type[Compensator]) -> str:
    """The name that finds ``cls`` again (:func:`get_method`): its registry name when it is
    registered under it, else ``module:Class``."""
    if _REGISTRY.get(cls.name) is cls:
        return cls.name
    return f"{cls.__module__}:{cls.__qualname__}"


def make_method(name: str, **hyperparameters) -> Compensator:
    """An instance of method ``name`` with ``hyperparameters`` overriding the paper's defaults.

    The hyperparameters are checked at once (:meth:`Compensator.check_params`), so a wrong type or
    value is a ``ValueError`` naming the hyperparameter here, not after minutes of work in ``fit``.
    """
    import inspect

    cls = get_method(name)
    allowed = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    unknown = sorted(set(hyperparameters) - set(allowed))
    if unknown:
        raise ValueError(f"method {name!r}: unknown hyperparameter(s) {unknown}; "
                         f"allowed: {allowed}")
    model = cls(**hyperparameters)
    model.check_params()
    return model


# ---------------------------------------------------------------------------------------------
# Persistence: JSON (hyperparameters, scalar state, manifest, checksums) + NPZ (arrays), never
# pickle.
#
# Format version 2 (version 1 checked only the .npz):
#   format, version, method, hyperparameters, state,
#   arrays          {name: {"shape": [...], "dtype": "<f8"}} for every array in the .npz,
#   arrays_sha256   SHA-256 of the .npz bytes,
#   sha256          SHA-256 of the canonical JSON (sorted keys, no spaces) of every other key, so
#                   that any edit of the .json (a learned number, a hyperparameter, the manifest or
#                   the .npz checksum) is refused.
# The checksums detect damage and hand edits; they are not a signature: whoever rewrites both
# checksums can make any file pass them. What they let through is then checked for consistency
# (hyperparameters validated, arrays against the manifest, the restored model compensating a probe
# record).
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


def save_model(model: Compensator, path: str | os.PathLike) -> tuple[Path, Path]:
    """Save a fitted model as ``path.json`` + ``path.npz``; returns both paths.

    The JSON holds the format name and version, the method name, its hyperparameters, its scalar
    learned state, the name, shape and dtype of every array in the NPZ, the SHA-256 of the NPZ and
    a SHA-256 of the JSON's own content, so that an edited, damaged or mismatched pair is refused
    by :func:`load_model`. A ``random_state`` given as a numpy Generator is saved as None (a
    loaded model compensates without it; give it a seed before fitting it again).
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


def _probe_record(model: Compensator) -> GyroData:
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


def load_model(path: str | os.PathLike) -> Compensator:
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
    method = doc["method"]
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
        model = make_method(method, **hp)  # refuses unknown names, checks every value
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{jpath}: key 'hyperparameters' of method {method!r}: "
                             f"{exc}") from None

    arrays = _read_arrays(npz, npath)
    _check_manifest(arrays, doc["arrays"], jpath, npath)
    try:
        model._restore(_StateDict(doc["state"], str(jpath), "key 'state' entry"),
                       _StateDict(arrays, str(npath), "array"))
    except ModelFileError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise ModelFileError(f"{jpath}: key 'state' cannot be restored for method {method!r} "
                             f"({type(exc).__name__}: {exc})") from None
    model.fitted_ = True
    # A restored state can still be inconsistent (an array of another shape than the
    # hyperparameters imply, a NaN weight): compensate a probe record now rather than fail later.
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
    return model
