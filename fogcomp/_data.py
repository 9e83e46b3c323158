"""The record every method works on: :class:`GyroData`.

SI units, except temperature in degrees Celsius and the specific force in units of g, the units
in which gyro datasheets state their sensitivities.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["INPUT_NAMES", "GyroData"]

#: The fields of a :class:`GyroData` a method may require (``Compensator.requires``).
INPUT_NAMES = ("rate", "g", "temp", "temp_rate")


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
    """'boolean', 'complex' or 'text' when ``raw`` holds such values (which a float cast would
    hide: ``np.asarray(["0.1"], dtype=float)`` reads text as numbers without a word)."""
    if raw.dtype.kind == "b":
        return "boolean"
    if raw.dtype.kind == "c":
        return "complex"
    if raw.dtype.kind in "USV":
        return "text"
    if raw.dtype.kind == "O":
        for x in raw.flat:
            if isinstance(x, (bool, np.bool_)):
                return "boolean"
            if isinstance(x, (complex, np.complexfloating)):
                return "complex"
            if isinstance(x, (str, bytes)):
                return "text"
    return ""
