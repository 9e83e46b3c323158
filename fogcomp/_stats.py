"""Statistical constants shared by the Allan analysis (:mod:`fogcomp.allan`) and the noise
identification (:mod:`fogcomp.noise`): kept below both, so that the identification does not
import the analysis that calls it."""

import math

__all__ = ["ONE_SIGMA_CI"]

#: Probability content of a one-sigma interval, erf(1/sqrt(2)) = 0.6827.
ONE_SIGMA_CI = math.erf(1.0 / math.sqrt(2.0))
