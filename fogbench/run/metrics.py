"""The names of the metrics a run records (``metrics.json``): each protocol's key metrics and
the improvement over raw that each error metric has."""

from __future__ import annotations

__all__ = ["KEY_METRICS", "IMPROVEMENT_OF"]

KEY_METRICS = ("std_dps", "rmse_dph", "drift_rms_dph", "bias_stability_100s_dph",
               "angle_error_final_deg", "angle_error_max_deg", "coef_rms_error_dph", "arw_deg_rt_h",
               "bias_instability_dph", "rrw_dph_rt_h", "improvement_rmse_pct",
               "improvement_bias_stability_pct", "improvement_drift_pct", "fit_time_s")
#: the improvement over raw (%, 100 (1 - method / raw) in the same replicate) of each error
#: metric that has one (fogbench.run.runner.score writes them)
IMPROVEMENT_OF = {"std_dps": "improvement_std_pct", "rmse_dph": "improvement_rmse_pct",
                  "bias_stability_100s_dph": "improvement_bias_stability_pct",
                  "drift_rms_dph": "improvement_drift_pct"}
