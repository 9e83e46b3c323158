"""How numbers and tables are written for people: shared by the report, the recording and the suite."""

from __future__ import annotations

import math

__all__ = ["KEY_METRICS", "fmt", "md_table"]

KEY_METRICS = ("std_dps", "rmse_dph", "drift_rms_dph", "bias_stability_100s_dph",
               "angle_error_final_deg", "coef_rms_error_dph", "arw_deg_rt_h",
               "bias_instability_dph", "rrw_dph_rt_h", "improvement_rmse_pct",
               "improvement_bias_stability_pct", "improvement_drift_pct", "fit_time_s")

def fmt(v, metric: str = "") -> str:
    if v is None:
        return "–"
    if isinstance(v, str):
        return v
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        return "–"
    if metric.endswith("_pct"):
        return f"{v:.1f}"
    if metric.endswith("time_s"):
        return f"{v:.3g}"
    a = abs(v)
    if a != 0 and (a < 1e-3 or a >= 1e5):
        return f"{v:.3e}"
    return f"{v:.4g}"


def md_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)
