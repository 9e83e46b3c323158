"""fogcomp: fiber-optic gyro error compensation methods, behind one estimator interface.

Works on arrays, sample rates and units only (no simulation, no scenario files), so that it
serves a real recorded gyro log as well as the fogbench simulation.

>>> import fogcomp
>>> data = fogcomp.GyroData(rate=rate_rad_s, fs=100.0)
>>> model = fogcomp.make_method("wavelet_soft").fit(data)
>>> clean = model.compensate(data)
"""

from ._data import GyroData
from ._estimator import Compensator, DivergenceError, NotFittedError
from ._persistence import ModelFileError, load_model, save_model
from ._registry import (
    PluginError,
    available_methods,
    get_method,
    make_method,
    method_id,
    plugin_problems,
    register,
)
from .conformance import check_method

__all__ = [
    "Compensator",
    "DivergenceError",
    "GyroData",
    "ModelFileError",
    "NotFittedError",
    "PluginError",
    "method_id",
    "plugin_problems",
    "available_methods",
    "check_method",
    "get_method",
    "load_model",
    "make_method",
    "register",
    "save_model",
]
