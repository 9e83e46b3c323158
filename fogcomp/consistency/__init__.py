"""Noise models a navigation filter can trust: the bias-tracking Kalman filter an identified
noise model implies, its consistency where the truth is known (NEES over simulated records) and
where it is not (NIS on the held-out part of a real log), and the inflation factor that makes a
filter consistent, measured with its interval instead of guessed.

The filter and its discretisation are in ``_filter.py`` (its docstring has the table of states
and their exact discrete forms); the NEES and NIS tests, their bands and the inflation factor in
``_verdicts.py`` (its docstring has the statistics and their sources); the held-out procedure on
a log in ``_heldout.py`` (:func:`held_out`). The user's guide with the measured numbers:
``docs/guides/filter-consistency.md``.
"""

from ._filter import (BiasFilterModel, FilterRun, flicker_as_gm, from_noise_model, run_filter,
                      van_loan)
from ._heldout import HeldOut, held_out
from ._verdicts import (InflationResult, NeesResult, clopper_pearson, inflation_factor,
                        inflation_factors, nees_test, nis_scales, summarise_nees,
                        track_indices)

__all__ = ["BiasFilterModel", "FilterRun", "HeldOut", "InflationResult", "NeesResult",
           "clopper_pearson", "flicker_as_gm", "from_noise_model", "held_out",
           "inflation_factor", "inflation_factors", "nees_test", "nis_scales", "run_filter",
           "summarise_nees", "track_indices", "van_loan"]
