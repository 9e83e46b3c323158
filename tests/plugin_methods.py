"""Plug-in methods for the tests (importable as ``plugin_methods:Class`` while tests/ is on the
path): one that works and one for each way a plug-in can fail a run."""

from __future__ import annotations

import sys
import time

import numpy as np

from fogcomp import Compensator


class MeanBias(Compensator):
    """Removes the fit record's mean error (a working plug-in)."""

    name = "test_mean_bias"
    supervised = True

    def __init__(self, scale: float = 1.0):
        self.scale = scale

    def _validate(self):
        if isinstance(self.scale, bool) or not isinstance(self.scale, (int, float)):
            raise ValueError(f"scale: expected a number, got {self.scale!r}")

    def _fit(self, data, error):
        self.bias_ = float(np.mean(error)) * self.scale

    def _estimate(self, data):
        return np.full(len(data), self.bias_)

    def _state(self):
        return {"bias_": self.bias_}, {}

    def _restore(self, info, arrays):
        self.bias_ = float(info["bias_"])


class Raises(MeanBias):
    name = "test_raises"

    def _fit(self, data, error):
        raise RuntimeError("planted failure in fit")


class Hangs(MeanBias):
    name = "test_hangs"

    def _fit(self, data, error):
        while True:                      # and swallows what an Exception handler catches
            try:
                time.sleep(0.05)
            except Exception:  # noqa: BLE001
                pass


class WrongShape(MeanBias):
    name = "test_wrong_shape"

    def _estimate(self, data):
        return np.zeros(len(data) + 1)


class NonFinite(MeanBias):
    name = "test_non_finite"

    def _estimate(self, data):
        return np.full(len(data), np.nan)


class Exits(MeanBias):
    name = "test_exits"

    def _fit(self, data, error):
        sys.exit(3)


class BadConstructor(MeanBias):
    name = "test_bad_constructor"

    def __init__(self, scale: float = 1.0):
        raise RuntimeError("planted failure in __init__")


class WrongOutput(MeanBias):
    """compensate() itself overridden (past Compensator.estimate_error's shape check)."""

    name = "test_wrong_output"

    def compensate(self, data):
        return np.zeros((len(data), 1))


class MutatesInput(MeanBias):
    """Centres the caller's rate array in place (a bug the contract catches)."""

    name = "test_mutates_input"

    def _fit(self, data, error):
        r = data.rate
        r[:] -= np.median(r)
        super()._fit(data, error)


class HardExits(MeanBias):
    """Ends the process with os._exit(0) in its fit."""

    name = "test_hard_exits"

    def _fit(self, data, error):
        import os

        os._exit(0)


class RaisesInterrupt(MeanBias):
    """Raises KeyboardInterrupt itself (no Ctrl-C was pressed)."""

    name = "test_raises_interrupt"

    def _fit(self, data, error):
        raise KeyboardInterrupt("planted in fit")
