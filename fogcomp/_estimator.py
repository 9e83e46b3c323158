"""The contract every compensation method keeps: :class:`Compensator`.

A method is a class derived from :class:`Compensator`. It follows the scikit-learn contract:
``__init__`` stores hyperparameters only (the paper's values as defaults), ``fit`` validates its
inputs, learns, and returns ``self``; learned attributes end in ``_``; using a method before it is
fitted raises :class:`NotFittedError`. Inputs travel in a :class:`~fogcomp.GyroData` record.
"""

from __future__ import annotations

import os
from typing import ClassVar

import numpy as np

from ._checks import _random_state
from ._data import INPUT_NAMES, GyroData, _as_float_array
from ._persistence import save_model

__all__ = ["Compensator", "DivergenceError", "NotFittedError"]


class NotFittedError(RuntimeError):
    """A method was asked to compensate before it was fitted."""


class DivergenceError(RuntimeError):
    """Training diverged (NaN or exploding loss). The runner reports the method as failed."""


class Compensator:
    """Base class of every compensation method.

    A method sets the class attributes below and implements ``_fit(data, error)``, where
    ``error`` is ``data.rate - reference_rate`` (rad/s) or None, and ``_estimate(data)``
    returning the estimated error, shape (n,), rad/s; ``_state()`` returning
    ``(json_dict, arrays_dict)`` of learned attributes, and ``_restore(json_dict,
    arrays_dict)``.

    Attributes
    ----------
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

    # -- the contract, before any data ---------------------------------------------------------
    @classmethod
    def _contract_problem(cls) -> str | None:
        """Why this class cannot be a method (None: it can): the structural contract checked
        before any data (:func:`fogcomp.check_method` checks the behaviour). Called by
        ``fogcomp._registry.class_problem`` for every class it is given."""
        import inspect

        if cls is Compensator:
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
        self._fit(data, self._error_of(data, reference_rate))
        self.fitted_ = True
        return self

    @classmethod
    def fit_starts(cls, models: list, data: GyroData,
                   reference_rate: np.ndarray | None = None) -> list:
        """Fit several models of this class that differ only in ``random_state`` (the starts of
        a random method) on the same data: per model, in order, ``(exception or None, the
        warnings it raised)``. This one fits them one by one; a method whose starts can be
        trained together overrides it with the same results, to rounding (``fogcomp.methods.
        temperature.Bp``: issue 43). An exception that is not an ``Exception`` (a time limit,
        Ctrl-C) ends the whole call."""
        import warnings

        out = []
        for model in models:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    model.fit(data, reference_rate)
                    err = None
                except Exception as exc:    # noqa: BLE001 - each start's failure is its own
                    err = exc
            out.append((err, list(caught)))
        return out

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
    def _error_of(self, data: GyroData, reference_rate) -> np.ndarray | None:
        """The checks of :meth:`fit` and the error a supervised method learns, ``rate -
        reference_rate`` (None for an unsupervised one)."""
        self._check_data(data, "fit")
        if not self.supervised:
            return None
        if reference_rate is None:
            raise ValueError(f"{self.name}: fit needs reference_rate (rad/s), the rate the rig "
                             "applied, to learn the error = rate - reference_rate")
        ref = _as_float_array("reference_rate", reference_rate, ndim=1)
        if ref.shape[0] != len(data):
            raise ValueError(f"reference_rate: length must be {len(data)} to match rate, "
                             f"got {ref.shape[0]}")
        return data.rate - ref

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
