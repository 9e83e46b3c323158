"""A minimal compensation method: the example of "How to add a method" (docs/development).

A constant bias learned from a calibration record where the applied rate is known (supervised),
removed from every later record. Check it against the contract with

    PYTHONPATH=docs/examples .venv/bin/fogbench check-method my_method:ConstantBias
"""

import numpy as np

from fogcomp import Compensator


class ConstantBias(Compensator):
    """The mean error of the fitting record, removed from every record.

    Parameters
    ----------
    trim : float, default 0.0
        Fraction of the error samples left out at each end before the mean (0 to 0.4): a
        trimmed mean, robust to a few outliers.

    Attributes
    ----------
    bias_ : float
        The learned bias, rad/s.
    """

    name = "constant_bias"          # the name scenarios and make_method use
    requires = ("rate",)            # the GyroData fields fit and compensate read
    supervised = True               # fit needs the applied rate: error = rate - reference
    random = False                  # draws no random numbers (else it takes random_state)

    def __init__(self, trim: float = 0.0):
        self.trim = trim            # store the hyperparameters as given, nothing else

    def _validate(self) -> None:
        if isinstance(self.trim, bool) or not isinstance(self.trim, (int, float)) \
                or not 0.0 <= self.trim <= 0.4:
            raise ValueError(f"trim: expected a number from 0 to 0.4, got {self.trim!r}")

    def _fit(self, data, error):
        self._validate()
        e = np.sort(error)
        k = int(self.trim * len(e))
        self.bias_ = float(np.mean(e[k:len(e) - k]))

    def _estimate(self, data):
        return np.full(len(data), self.bias_)

    def _state(self):
        return {"bias": self.bias_}, {}          # JSON-able values, named arrays

    def _restore(self, info, arrays):
        self.bias_ = float(info["bias"])
