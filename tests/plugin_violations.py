"""One planted violation of each rule of fogcomp.check_method, on the working plug-in
``plugin_methods.MeanBias`` (tests/fogcomp/test_conformance.py)."""

from __future__ import annotations

import numpy as np

from fogcomp import Compensator
from plugin_methods import MeanBias


class InitSetsState(MeanBias):           # init_stores_only
    def __init__(self, scale: float = 1.0):
        self.scale = scale
        self.bias_ = 0.0


class GetParamsLies(MeanBias):           # get_params_round_trip
    def get_params(self):
        return {"scale": self.scale * 2}


class NoValidation(MeanBias):            # check_params_refuses_wrong_types
    def _validate(self):
        pass


class FitReturnsNone(MeanBias):          # fit_returns_self
    def fit(self, data, reference_rate=None):
        super().fit(data, reference_rate)
        return None


class NoFittedCheck(MeanBias):           # not_fitted_raises
    def estimate_error(self, data):
        return np.full(len(data), getattr(self, "bias_", 0.0))


class ModifiesInput(MeanBias):           # inputs_not_modified
    def _fit(self, data, error):
        data.rate[:] -= float(np.mean(error))
        self.bias_ = 0.0


class UsesGlobalRandom(MeanBias):        # reproducible
    def _fit(self, data, error):
        self.bias_ = float(np.mean(error)) + 1e-12 * np.random.standard_normal()


class ReadsUndeclaredInput(MeanBias):    # bad_input_refused
    def _fit(self, data, error):
        self.bias_ = float(np.mean(error)) + 0.0 * float(np.mean(data.temp))


class ForgetsState(MeanBias):            # save_load_exact
    def _state(self):
        return {"bias_": 0.0}, {}


class FailsOnLongRecords(MeanBias):      # probe_1e5
    def _estimate(self, data):
        return np.full(len(data), np.nan if len(data) > 50_000 else self.bias_)


PLANTED = {"init_stores_only": InitSetsState, "get_params_round_trip": GetParamsLies,
           "check_params_refuses_wrong_types": NoValidation, "fit_returns_self": FitReturnsNone,
           "not_fitted_raises": NoFittedCheck, "inputs_not_modified": ModifiesInput,
           "reproducible": UsesGlobalRandom, "bad_input_refused": ReadsUndeclaredInput,
           "save_load_exact": ForgetsState, "probe_1e5": FailsOnLongRecords}
assert all(issubclass(c, Compensator) for c in PLANTED.values())
