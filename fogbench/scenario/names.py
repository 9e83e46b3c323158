"""What a scenario may name: the rule for names that become parts of paths (scenario, run,
protocol, method label), and the metrics a bound, claim or map may ask for."""

from __future__ import annotations

import re

# Names that become parts of paths (scenario, run, protocol, method label): a safe character set.
_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
NAME_RULE = ("1 to 64 characters from A-Z a-z 0-9 _ . -, starting with a letter or digit "
             "(it becomes part of file and folder names)")


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be used as a path component, or None when it can."""
    if not _NAME_RE.fullmatch(name) or name.endswith("."):
        return f"expected {NAME_RULE}, got {name!r}"
    return None


#: Every metric a bound, claim or map may name (the keys of ``metrics.json`` per method).
METRIC_NAMES = {
    "std_dps", "std_dph", "rmse_dph", "rmse_dps", "bias_stability_100s_dph", "angle_error_final_deg",
    "angle_error_max_deg", "arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
    "bias_instability_floor_dph", "gm_sigma_dph", "gm_tau_s",
    "fit_time_s", "compensate_time_s", "improvement_std_pct", "improvement_rmse_pct",
    "improvement_bias_stability_pct", "coef_rms_error_dph", "drift_rms_dph",
    "improvement_drift_pct", "mean_error_dph", "coef_rms_stderr_dph", "coef_z_rms",
}
