"""How numbers and tables are written for people: shared by the report, the recording and the suite."""

from __future__ import annotations

import math

from fogbench.run.metrics import KEY_METRICS

__all__ = ["fmt", "md_table", "decimation", "ci_text", "failed_everywhere", "failed_text",
           "p_better_text", "key_metric", "metrics_table"]


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


def decimation(n: int, max_points: int) -> int:
    """The display stride k (every k-th sample) that keeps ``n`` samples under ``max_points``."""
    return max(1, int(math.ceil(n / max_points)))


def ci_text(sm: dict | None, metric: str) -> str:
    """``mean [lo, hi]`` of a replicate summary, or why there is none."""
    if not sm or not sm.get("n"):
        return "not computed" if not sm or not sm.get("n_failed") else "failed"
    txt = fmt(sm["mean"], metric)
    if sm.get("ci_low") is not None and sm.get("ci_high") is not None:
        txt += f" [{fmt(sm['ci_low'], metric)}, {fmt(sm['ci_high'], metric)}]"
    if sm.get("n_failed"):
        txt += f" ({sm['n_failed']} failed)"
    if sm.get("runs"):      # a mean over fewer runs than the protocol scores (montecarlo)
        txt += f" on {', '.join(sm['runs'])} only"
    return txt


def failed_everywhere(mc: dict | None, protocol: str) -> dict[str, dict]:
    """The methods of ``protocol`` that failed in every replicate (``montecarlo``'s
    ``failed_methods``, empty in a run written before it was kept): label -> its record."""
    got = ((mc or {}).get("failed_methods") or {}).get(protocol) or {}
    return {lab: f for lab, f in got.items()
            if isinstance(f, dict) and f.get("failed") and f.get("failed") == f.get("replicates")}


def failed_text(f: dict) -> str:
    """``failed in R of R: <first error>``: a method that failed everywhere, in one cell."""
    return f"failed in {f['failed']} of {f['replicates']}: {f.get('first_error') or '–'}"


def p_better_text(p: dict) -> str:
    """``mean [lo, hi]`` of a probability over replicates, the t-interval clipped to [0, 1]."""
    if not p or not p.get("n"):
        return "not computed"
    txt = f"{p['mean']:.2f}"
    if p.get("ci_low") is not None and p.get("ci_high") is not None:
        txt += f" [{max(0.0, p['ci_low']):.2f}, {min(1.0, p['ci_high']):.2f}]"
    return txt


#: How a table says the filter oracle has no value on a piece (the reason follows)
ORACLE_FILTER_NOT = "filter oracle: not computed,"


def metrics_table(by_method: dict, cell=None) -> str:
    """The key metrics of every method on one scored run as a Markdown table: a column per
    key metric any method has, a status column; a failed method's row says why.
    ``cell(label, metric, value)`` formats a cell (default :func:`fmt`)."""
    metrics = [m for m in KEY_METRICS
               if any(isinstance(v, dict) and m in v for v in by_method.values())]
    rows = []
    for lab, m in by_method.items():
        if m.get("status") == "failed":
            rows.append([lab] + ["–"] * len(metrics) + [f"FAILED: {m.get('error', '')}"])
            continue
        if m.get("status") == "not computed":   # the filter oracle where its model does not hold
            rows.append([lab] + ["–"] * len(metrics)
                        + [f"{ORACLE_FILTER_NOT} {m.get('reason', '')}"])
            continue
        rows.append([lab] + [cell(lab, x, m.get(x)) if cell else fmt(m.get(x), x)
                             for x in metrics] + ["ok"])
    return md_table(["method"] + metrics + ["status"], rows)


def key_metric(mc: dict, protocol: str, plan) -> str | None:
    """The metric a protocol's distribution figure shows: a claim's, else the first key one."""
    have = mc["over_runs"].get(protocol, {}).get("raw", {})
    for c in plan.claims:
        if c.metric in have:
            return c.metric
    for m in ("drift_rms_dph", "bias_stability_100s_dph", "rmse_dph", "coef_rms_error_dph",
              "arw_deg_rt_h", "std_dps"):
        if m in have:
            return m
    return None
