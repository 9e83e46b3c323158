"""One figure per claim, and the report's opening that links each verdict to it.

A claim's verdict rests on a paired comparison: in every replicate the method and its comparator
run on the same power-on, and the claimed quantity is the method's improvement over the
comparator, ``100 (1 - method / comparator)`` of the claim's metric. Its figure shows

- left, the answer: that improvement in every replicate, the 95 % interval of its mean (the
  interval the verdict compares), the claimed range shaded, and the oracle's improvement over the
  same comparator beside it (the best a model of the deterministic error terms can do here);
- right, the same pairs in the metric's own unit: method minus comparator and oracle minus
  comparator, replicate by replicate, with the intervals of their means;
- below, for a claim between two methods that draw random starts, every start of each,
  replicate by replicate (the paired start distributions).

Every number drawn is read from the claim's entry in the Monte Carlo aggregate
(``metrics.json``, ``montecarlo.claims[i]``: ``summary``, ``oracle_improvement``, ``paired``,
``oracle_paired``, ``per_replicate``, ``over_seeds``); nothing is recomputed here. The artists
that carry those numbers have a ``gid`` (``claim_ci``, ``oracle_ci``, ``claim_diff_ci``,
``oracle_diff_ci``, ``claimed_range``; the replicates' points ``<gid>_points``) so that tests
can read them back.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from fogbench.outputs import files
from fogbench.report.maps import verdict_color
from fogbench.run.maps import side

__all__ = ["fig_claim", "draw_claim_figures", "claim_figure_name", "verdict_phrase",
           "verdicts_section", "open_on_answer", "SETUP_HEADING"]

#: The heading the report's set-up (scenario, rows, runs, protocols) starts under when the
#: report opens on the answer.
SETUP_HEADING = "## Set-up"
COL2 = 1.5                        # x of the second column (the oracle)
CLAIM_COLOR = "#2a9d3f"           # the claimed range (the colour of "agrees")
ORACLE_COLOR = "black"
ORACLE_TEXT = {"oracle": "oracle: the true error terms removed (no model of them does better)",
               "oracle_filter": "oracle_filter: the best filter given the true noise model"}
METRIC_NAMES = {"std_dps": "output std", "rmse_dph": "RMS error",
                "drift_rms_dph": "drift RMS", "bias_stability_100s_dph": "bias stability (100 s)",
                "coef_rms_error_dph": "coefficient error RMS", "mean_error_dph": "mean error",
                "angle_error_max_deg": "largest integrated angle error"}


def claim_figure_name(i: int) -> str:
    """The run-directory path of claim i's figure (i: its index in ``montecarlo.claims``)."""
    return f"figures/claim__{i:02d}.png"


def unit_of(metric: str) -> str:
    """The unit a metric's name ends in, as an axis label writes it."""
    for suffix, unit in (("_deg_rt_h", "deg/sqrt(h)"), ("_dph_rt_h", "deg/h/sqrt(h)"),
                         ("_dps", "deg/s"), ("_dph", "deg/h"), ("_pct", "per cent"),
                         ("_deg", "deg"), ("_s", "s")):
        if metric.endswith(suffix):
            return unit
    return "as the metric"


def claimed_text(c: dict) -> str:
    lo, hi = c.get("min_pct"), c.get("max_pct")
    if lo is not None and hi is not None:
        return f"{lo:g} to {hi:g} %"
    return f">= {lo:g} %" if lo is not None else f"<= {hi:g} %"


def verdict_phrase(c: dict) -> str:
    """``**disagrees** (falls short of the claim)``: the verdict and, for a disagreement, its
    side."""
    s = side(c)
    return f"**{c['verdict']}**" + (f" ({s} the claim)" if s else "")


def _num(v, metric: str = "_pct") -> str:
    if v is None or not math.isfinite(v):
        return "–"
    if metric.endswith("_pct"):
        return f"{v:.1f}"
    a = abs(v)
    return f"{v:.3e}" if a != 0 and (a < 1e-3 or a >= 1e5) else f"{v:.4g}"


def _decimals(*vs) -> int:
    """Decimal places that give the largest of ``vs`` three significant digits."""
    big = max((abs(v) for v in vs if v is not None and math.isfinite(v)), default=0.0)
    return 1 if big == 0 else max(0, 2 - int(math.floor(math.log10(big))))


def _ci(sm: dict | None, metric: str = "_pct") -> str:
    if not sm or sm.get("mean") is None:
        return "no value"
    txt = _num(sm["mean"], metric)
    if sm.get("ci_low") is not None and sm.get("ci_high") is not None:
        txt += f" [{_num(sm['ci_low'], metric)}, {_num(sm['ci_high'], metric)}]"
    return txt


def _runs_text(c: dict) -> str:
    runs = c.get("runs") or []
    return f"on {runs[0]}" if len(runs) == 1 else f"mean over {len(runs)} scored runs"


# ---------------------------------------------------------------------------------------------
# The figure
def _column(ax, x: float, values, sm: dict | None, color, gid: str, rng, metric: str,
            unit: str) -> list[float]:
    """Replicate values as points left of ``x``, the mean and its interval as a bar right of it,
    the numbers written beside the bar; returns the y values drawn (for the limits)."""
    ys = []
    v = np.array([np.nan if y is None else y for y in (values or [])], dtype=float)
    v = v[np.isfinite(v)]
    if v.size:
        ax.plot(x - 0.12 + rng.uniform(-0.05, 0.05, v.size), v, "o", ms=4, alpha=0.55,
                color=color, mec="none", zorder=3, gid=f"{gid}_points")
        ys += v.tolist()
    if sm and sm.get("mean") is not None:
        lo, hi = sm.get("ci_low"), sm.get("ci_high")
        m = sm["mean"]
        if lo is not None and hi is not None:
            cont = ax.errorbar([x + 0.12], [m], yerr=[[m - lo], [hi - m]], fmt="D", ms=7,
                               color=color, ecolor=color, elinewidth=3, capsize=7, capthick=2,
                               zorder=4)
            ys += [lo, hi]
        else:
            cont = ax.errorbar([x + 0.12], [m], fmt="D", ms=7, color=color, zorder=4)
        cont.lines[0].set_gid(gid)
        for part in cont.lines[2]:
            part.set_gid(gid)
        ys.append(m)
        d = 1 if metric.endswith("_pct") else _decimals(m, lo, hi)

        def f(v):
            return "–" if v is None else f"{v:.{d}f}"

        ax.annotate(f"{f(m)} {unit}\n[{f(lo)}, {f(hi)}]",
                    (x + 0.22, m), xytext=(0, 0), textcoords="offset points", va="center",
                    ha="left", fontsize=8.5, color=color, fontweight="bold", zorder=6,
                    # on a white ground: a claim's dashed bound or the zero line through the
                    # number (paper002's "-0.6 %" on the 0 % bound) no longer strikes it out
                    bbox={"boxstyle": "square,pad=0.15", "facecolor": "white", "alpha": 0.85,
                          "edgecolor": "none"})
    return ys


def _limits(ax, ys: list[float], bounds: list[float]) -> None:
    """y: every value drawn and the claimed bounds, padded; x: room for the numbers written
    right of the last column."""
    allv = [y for y in ys + bounds if y is not None and math.isfinite(y)]
    if allv:
        lo, hi = min(allv), max(allv)
        pad = 0.12 * (hi - lo) if hi > lo else max(1e-9, 0.1 * abs(hi))
        ax.set_ylim(lo - pad, hi + pad)
    ax.set_xlim(-0.45, COL2 + 1.3)


#: A column whose interval (without one, its points) spans less than this fraction of its
#: panel's y range (paper000's WNN: 1.4 [0.8, 2.0] % on an axis to the oracle's 100 %, an
#: interval inside its marker) gets a zoomed inset of its own, its points and interval in it.
ZOOM_FRACTION = 0.08


def _zoom_inset(ax, values, sm: dict | None, color, gid: str, bounds=()) -> bool:
    """An inset over the half of ``ax`` away from column 0's values, showing that column's
    replicate points and its mean with its interval at their own scale (and any of ``bounds``,
    the claimed range's ends, that falls in it), linked to where it sits on the main axis."""
    pts = [y for y in (values or []) if y is not None and math.isfinite(y)]
    ci = [y for y in ((sm or {}).get("ci_low"), (sm or {}).get("ci_high"), (sm or {}).get("mean"))
          if y is not None and math.isfinite(y)]
    v = pts + ci
    if not v:
        return False
    y0, y1 = ax.get_ylim()
    lo, hi = min(v), max(v)
    # the interval the verdict rests on decides (paper000's -0.89 [-8.5, 6.7] deg/h among
    # points to +45 on a 700 deg/h axis); without one, the points
    judged = ci if len(ci) == 3 else v
    if len(v) < 2 or not hi > lo or max(judged) - min(judged) >= ZOOM_FRACTION * (y1 - y0):
        return False        # (one value or all equal: nothing an inset could spread out)
    zlo, zhi = lo - 0.15 * (hi - lo), hi + 0.15 * (hi - lo)
    upper = 0.5 * (lo + hi) < 0.5 * (y0 + y1)       # the column sits low: the inset goes high
    ins = ax.inset_axes([0.14, 0.55 if upper else 0.06, 0.3, 0.38])  # its labels inside ax
    rng = np.random.default_rng(0)
    if pts:
        ins.plot(-0.12 + rng.uniform(-0.05, 0.05, len(pts)), pts, "o", ms=3.5, alpha=0.55,
                 color=color, mec="none", gid=f"{gid}_points")
    if sm and sm.get("mean") is not None and sm.get("ci_low") is not None:
        m = sm["mean"]
        cont = ins.errorbar([0.12], [m], yerr=[[m - sm["ci_low"]], [sm["ci_high"] - m]],
                            fmt="D", ms=5, color=color, elinewidth=2.5, capsize=5, capthick=1.5)
        cont.lines[0].set_gid(gid)
        for part in cont.lines[2]:
            part.set_gid(gid)
    for b in bounds:
        if b is not None and zlo < b < zhi:
            ins.axhline(b, color=CLAIM_COLOR, lw=1.0, ls="--")
    if zlo < 0.0 < zhi:
        ins.axhline(0.0, color="0.4", lw=0.8)
    ins.set_xlim(-0.35, 0.35)
    ins.set_ylim(zlo, zhi)
    ins.set_xticks([])
    ins.tick_params(labelsize=7)
    ins.set_title("zoomed in", fontsize=7, pad=2)
    ins.grid(True, axis="y", alpha=0.3)
    ax.indicate_inset_zoom(ins, edgecolor="0.5")
    return True


def fig_claim(c: dict, path: Path) -> bool:
    """Claim ``c`` (an entry of ``montecarlo.claims``) as one figure (see the module doc)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sm = c.get("summary") or {}
    if sm.get("mean") is None:
        return False     # no replicate gave the claimed quantity: nothing to draw
    metric, unit = c["metric"], unit_of(c["metric"])
    mname = METRIC_NAMES.get(metric, metric)
    starts = _starts(c)
    rng = np.random.default_rng(0)             # horizontal jitter of the points only
    fig = plt.figure(figsize=(12.0, 8.8 if starts else 5.0))
    gs = fig.add_gridspec(2 if starts else 1, 2, width_ratios=(1.0, 1.0),
                          height_ratios=(1.0, 0.8) if starts else None, hspace=0.42,
                          wspace=0.42, top=0.85 if starts else 0.76,
                          bottom=0.08 if starts else 0.11)
    ax = fig.add_subplot(gs[0, 0])
    bx = fig.add_subplot(gs[0, 1])
    vcol = verdict_color(c, "tab:blue")
    _panel_improvement(ax, c, vcol, rng, mname)
    _panel_paired(bx, c, vcol, rng, mname, unit)
    if starts:
        _draw_starts(fig.add_subplot(gs[1, :]), c, starts, metric, mname, unit)
    _claim_heading(fig, c, vcol)
    _claim_legend(fig, c, vcol, bool(starts))
    files.save_figure(fig, path)
    return True


def _panel_improvement(ax, c: dict, vcol: str, rng, mname: str) -> None:
    """fig_claim's left panel: the improvement per replicate with its mean and interval, the
    claimed range shaded, the oracle's improvement beside it."""
    sm, pr = c.get("summary") or {}, c.get("per_replicate") or {}
    oracle = c.get("oracle", "oracle")
    lo, hi = c.get("min_pct"), c.get("max_pct")
    ax.axhspan(-1e12 if lo is None else lo, 1e12 if hi is None else hi, color=CLAIM_COLOR,
               alpha=0.16, zorder=0, gid="claimed_range")
    for b in (lo, hi):
        if b is not None:
            ax.axhline(b, color=CLAIM_COLOR, lw=1.2, ls="--", zorder=1)
    ax.axhline(0.0, color="0.4", lw=0.8, zorder=1)
    ys = _column(ax, 0, pr.get("improvement_pct"), sm, vcol, "claim_ci", rng, "_pct", "%")
    bound = c.get("oracle_bounds_claim", True)
    ys += _column(ax, COL2, pr.get("oracle_improvement_pct"), c.get("oracle_improvement"),
                  ORACLE_COLOR, "oracle_ci", rng, "_pct", "%")
    _limits(ax, ys, [lo, hi])
    _zoom_inset(ax, pr.get("improvement_pct"), sm, vcol, "claim_ci_zoom", (lo, hi))
    ax.set_xticks([0, COL2], [c["better"], oracle + ("" if bound else "\n(not a bound)")],
                  fontsize=9)
    ax.set_ylabel(f"improvement over {c['than']}, per cent\n"
                  f"100 (1 - {mname} / {mname} of {c['than']})", fontsize=9)
    first = (c.get("paired") or {}).get("first_better")
    ax.set_title(f"The claim: {c['better']} over {c['than']}\n"
                 + (f"{c['better']} better in {100 * first:.0f} % of the replicates"
                    if first is not None else ""), fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)


def _panel_paired(bx, c: dict, vcol: str, rng, mname: str, unit: str) -> None:
    """fig_claim's right panel: the same pairs as differences in the metric's unit (method
    minus comparator, and the oracle minus comparator), per replicate."""
    metric, oracle = c["metric"], c.get("oracle", "oracle")
    pr = c.get("per_replicate") or {}
    pd, opd = (c.get("paired") or {}).get("diff"), (c.get("oracle_paired") or {}).get("diff")

    def diff(a, b):
        return [None if x is None or y is None else x - y for x, y in zip(a or [], b or [])]

    bx.axhline(0.0, color="0.4", lw=0.8, zorder=1)
    ys = _column(bx, 0, diff(pr.get("better"), pr.get("than")), pd, vcol, "claim_diff_ci", rng,
                 metric, unit)
    ys += _column(bx, COL2, diff(pr.get("oracle"), pr.get("than")), opd, ORACLE_COLOR,
                  "oracle_diff_ci", rng, metric, unit)
    _limits(bx, ys, [])
    _zoom_inset(bx, diff(pr.get("better"), pr.get("than")), pd, vcol, "claim_diff_ci_zoom")
    bx.set_xticks([0, COL2], [f"{c['better']}\nminus {c['than']}", f"{oracle}\nminus {c['than']}"],
                  fontsize=9)
    bx.set_ylabel(f"paired difference of {mname}, {unit}"
                  + ("" if metric.endswith("_pct") else f"\n(below 0: lower than {c['than']})"),
                  fontsize=9)
    bx.set_title(f"The same pairs in {unit}\n(method minus comparator, per replicate)",
                 fontsize=10)
    bx.grid(True, axis="y", alpha=0.3)


def _claim_heading(fig, c: dict, vcol: str) -> None:
    """fig_claim's heading: the claim's words, the verdict in its colour with the interval
    against the claimed range, and where it was scored."""
    sm = c.get("summary") or {}
    side_txt = side(c)
    n = sm.get("n", 0) + (sm.get("n_failed") or 0)
    head = textwrap.fill(f"{c['source']}: \"{c['text']}\"", 125)
    verdict = (f"{c['verdict'].upper()}" + (f", {side_txt} the claim" if side_txt else "")
               + f": {_ci(sm)} % against the claimed {claimed_text(c)}")
    where = (f"protocol {c['protocol']} ({'in-sample' if c.get('in_sample') else 'held out'}), "
             f"{c['metric']} {_runs_text(c)}, {n} replicates")
    fig.suptitle(head, fontsize=10, y=1.0, va="bottom")
    h = fig.get_figheight()
    fig.text(0.5, 1.0 - 0.1 / h, verdict, fontsize=12, fontweight="bold", color=vcol,
             ha="center", va="top")
    fig.text(0.5, 1.0 - 0.4 / h, where, fontsize=9, ha="center", va="top", color="0.25")


def _claim_legend(fig, c: dict, vcol: str, starts: bool) -> None:
    """fig_claim's legend under the panels: the claimed range, a replicate, the mean and its
    interval, the method in its verdict colour, the oracle (and why it is no bound)."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    metric, oracle = c["metric"], c.get("oracle", "oracle")
    bound = c.get("oracle_bounds_claim", True)
    handles = [Patch(color=CLAIM_COLOR, alpha=0.3, label=f"claimed: {claimed_text(c)}"),
               plt.Line2D([], [], marker="o", ls="none", color="0.4", alpha=0.6,
                          label="one replicate"),
               plt.Line2D([], [], marker="D", color="0.2", lw=3,
                          label="mean and its 95 % t-interval over replicates"),
               plt.Line2D([], [], marker="D", ls="none", color=vcol,
                          label=f"{c['better']} (verdict colour: {c['verdict']}"
                          + (f", {side(c)} the claim)" if side(c) else ")")),
               plt.Line2D([], [], marker="D", ls="none", color=ORACLE_COLOR,
                          label=ORACLE_TEXT.get(oracle, oracle)
                          + ("" if bound else f" (not a bound: {c['better']} also filters)")
                          + (";\nits output is one constant (the rate is), so its std is 0 "
                             "and its improvement 100 % by construction"
                             if oracle == "oracle_filter" and metric.startswith("std_")
                             else ""))]
    fig.legend(handles=handles, loc="upper center", ncol=3, fontsize=8.5, frameon=False,
               bbox_to_anchor=(0.5, 0.0 if not starts else -0.01))


def _starts(c: dict) -> dict | None:
    o = c.get("over_seeds") or {}
    per = o.get("per_replicate") or {}
    if not per.get(c["better"]) or not per.get(c["than"]):
        return None
    return per


def _draw_starts(ax, c: dict, per: dict, metric: str, mname: str, unit: str) -> None:
    """Every start of the two methods, replicate by replicate (paired: same power-on), and the
    replicate means the claim uses."""
    colors = {c["better"]: verdict_color(c, "tab:blue"), c["than"]: "tab:blue"}
    if colors[c["than"]] == colors[c["better"]]:
        colors[c["than"]] = "tab:purple"
    allv = []
    for k, lab in enumerate((c["better"], c["than"])):
        dx = -0.17 if k == 0 else 0.17
        for r, rep in enumerate(per[lab]):
            v = np.array([np.nan if y is None else y for y in rep], dtype=float)
            v = v[np.isfinite(v)]
            if not v.size:
                continue
            allv += v.tolist()
            ax.plot(np.full(v.size, r + dx), v, "o", ms=3.5, alpha=0.5, color=colors[lab],
                    mec="none", label=f"{lab}: one start" if r == 0 else None)
            ax.plot([r + dx - 0.12, r + dx + 0.12], [v.mean()] * 2, color=colors[lab], lw=2.5,
                    label=f"{lab}: mean of the replicate's starts" if r == 0 else None)
    reps = (c.get("per_replicate") or {}).get("replicate") or list(range(len(per[c["better"]])))
    ax.set_xticks(range(len(reps)), [str(r) for r in reps], fontsize=8)
    ax.set_xlim(-0.6, len(reps) - 0.4)
    ax.set_xlabel("replicate (both methods on the same power-on)")
    ax.set_ylabel(f"{mname}, {unit}", fontsize=9)
    if allv and min(allv) > 0 and max(allv) / min(allv) > 20:
        ax.set_yscale("log")
    elif len(allv) >= 20:
        # a few stray starts would squash the rest into a line: the axis spans the bulk (2nd to
        # 98th percentile, widened by its own span each way) and the starts beyond it are
        # drawn on its edge as triangles and counted
        q_lo, q_hi = np.percentile(allv, [2, 98])
        span = max(q_hi - q_lo, 1e-12)
        bot, top = q_lo - span, q_hi + span
        out_hi = [y for y in allv if y > top]
        out_lo = [y for y in allv if y < bot]
        if out_hi or out_lo:
            ax.set_ylim(bot if out_lo else min(allv) - 0.05 * span,
                        top if out_hi else max(allv) + 0.05 * span)
            for lab, dx in ((c["better"], -0.17), (c["than"], 0.17)):
                for r, rep in enumerate(per[lab]):
                    for y in rep:
                        if y is not None and (y > top or y < bot):
                            ax.plot([r + dx], [top if y > top else bot],
                                    "^" if y > top else "v", ms=7, color=colors[lab],
                                    clip_on=False, zorder=5)
            bits = ([f"{len(out_hi)} start(s) above the axis (up to "
                     f"{_num(max(out_hi), metric)} {unit})"] if out_hi else []) + \
                   ([f"{len(out_lo)} below (down to {_num(min(out_lo), metric)} {unit})"]
                    if out_lo else [])
            ax.text(0.005, 0.97, "triangles: " + "; ".join(bits), transform=ax.transAxes,
                    fontsize=8, va="top", ha="left", color="0.25")
    o = c["over_seeds"]
    p = o.get("p_better_start") or {}
    ptxt = "" if p.get("mean") is None else (
        f"; a start of {c['better']} beats a start of {c['than']} with probability "
        f"{p['mean']:.2f}" + (f" [{max(0.0, p['ci_low']):.2f}, {min(1.0, p['ci_high']):.2f}]"
                              if p.get("ci_low") is not None else "") + " (0.5: no difference)")
    ax.set_title(f"Every method start, replicate by replicate{ptxt}", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0), frameon=False)


def draw_claim_figures(mc: dict, figdir: Path, figure) -> dict:
    """Claim i's figure into ``figdir`` (``claim__<i>.png``) through ``figure(what, fn, *args)``
    (the run directory's guard that notes a figure it cannot draw); returns the report's
    ``fig_names`` entries, ``("claim", i) -> "figures/claim__<i>.png"``."""
    names = {}
    for i, c in enumerate(mc.get("claims") or []):
        name = claim_figure_name(i)
        if figure(f"claim {i}", fig_claim, c, Path(figdir) / Path(name).name):
            names[("claim", i)] = name
    return names


# ---------------------------------------------------------------------------------------------
# The report's opening
def verdict_link(c: dict, fn: str | None) -> str:
    """The verdict phrase, linked to the claim's figure when it was drawn."""
    phrase = verdict_phrase(c)
    return f"[{phrase}]({fn})" if fn else phrase


def verdicts_section(mc: dict, fig_names: dict) -> list[str]:
    """``## Verdicts``: one line per claim (and protocol), the verdict first and linked to its
    figure, then the interval against the claimed range and the oracle, then the claim."""
    claims = mc.get("claims") or []
    if not claims:
        return []
    L = ["## Verdicts", "",
         "Each claim's improvement of the method over its comparator: mean [95 % interval] over "
         f"{mc.get('replicates')} replicates against the claimed range, the oracle beside it. "
         "The verdict links to the claim's figure.", ""]
    for i, c in enumerate(claims):
        fn = fig_names.get(("claim", i))
        tag = "in-sample" if c.get("in_sample") else "held out"
        L.append(f"- {verdict_link(c, fn)}: {c['better']} over {c['than']}, {c['metric']} "
                 f"{_runs_text(c)} (`{c['protocol']}`, {tag}): "
                 f"{claim_failed_text(mc, c) or _ci(c.get('summary')) + ' %'} "
                 f"against the claimed {claimed_text(c)}; oracle "
                 f"{_ci(c.get('oracle_improvement'))} %. {c['source']}: \"{c['text']}\"")
    L.append("")
    return L


def claim_failed_text(mc: dict, c: dict) -> str | None:
    """Which side of claim ``c`` failed in every replicate, with its first error (None when
    neither did): ``<method> failed in R of R: <error>``, joined by "; "."""
    from fogbench.report.fmt import failed_everywhere, failed_text

    failed = failed_everywhere(mc, c["protocol"])
    parts = [f"{lab} {failed_text(failed[lab])}" for lab in dict.fromkeys((c["better"], c["than"]))
             if lab in failed]
    return "; ".join(parts) or None


#: an improvement whose whole interval is within this of 0 (%) is "unchanged", whatever its sign:
#: a bias removed leaves the 100 s bias stability the same to rounding (1e-12 %), which
#: printed at 0.1 % reads 0.0 and is no improvement
UNCHANGED_PCT = 0.05


def _placed(labs: dict, imp: str, failed: dict | None = None) -> tuple[dict, list]:
    """The methods' improvements ``imp`` placed by their intervals (groups of (sort key,
    text)), and the oracles' texts; ``failed`` (label -> record: the methods that failed in
    every replicate) the last group, each with its first error."""
    from fogbench.report.fmt import ci_text, failed_text

    failed = failed or {}
    groups: dict[str, list] = {"better": [], "not told apart from raw": [], "worse": [],
                               f"unchanged (within {UNCHANGED_PCT} %)": [], "failed": []}
    refs = []
    for lab, mets in labs.items():
        sm = mets.get(imp)
        if lab in failed:
            groups["failed"].append((0, f"{lab} ({failed_text(failed[lab])})"))
            continue
        if lab == "raw" or not sm or not (sm.get("n") or sm.get("n_failed")):
            continue
        txt = f"{lab} {ci_text(sm, imp)}"   # ("on <run> only": a mean over fewer runs)
        if lab.startswith("oracle"):
            refs.append(txt)
            continue
        lo, hi = sm.get("ci_low"), sm.get("ci_high")
        if lo is not None and hi is not None and max(abs(lo), abs(hi)) < UNCHANGED_PCT:
            g = f"unchanged (within {UNCHANGED_PCT} %)"
        else:
            g = ("better" if lo is not None and lo > 0 else
                 "worse" if hi is not None and hi < 0 else "not told apart from raw")
        mean = sm.get("mean")
        groups[g].append((math.inf if mean is None else -mean, txt))    # best first
    return groups, refs


def metric_takeaway(mc: dict, plan) -> str | None:
    """The top of a report without claims: per protocol (ideal-lab twins left out), the key
    metric's improvement over raw, each method placed by its interval over the replicates:
    better than raw (the interval above 0), worse (below 0) or not told apart; the oracles
    beside them. Where every method leaves the key metric unchanged (a bias correction under
    the 100 s bias stability, which a constant does not move), the RMSE's improvement too
    (what `fogbench compare` ranks them on). None when no protocol has an improvement of a
    key metric."""
    from fogbench.report.fmt import failed_everywhere, key_metric
    from fogbench.run.metrics import IMPROVEMENT_OF

    twins = {p.name for p in getattr(plan, "protocols", []) if getattr(p, "twin_of", None)}
    n_rep = mc.get("replicates")
    lines = []
    for prot, labs in (mc.get("over_runs") or {}).items():
        if prot in twins:
            continue
        metric = key_metric(mc, prot, plan)
        todo = [metric]
        while todo:
            metric = todo.pop(0)
            imp = IMPROVEMENT_OF.get(metric)
            if imp is None:
                continue
            groups, refs = _placed(labs, imp, failed_everywhere(mc, prot))
            parts = [f"{g}: " + ", ".join(t for _, t in sorted(v))
                     for g, v in groups.items() if v]
            if not parts:
                continue
            lines.append(f"- `{prot}`, {metric}: " + "; ".join(parts)
                         + (f" (oracle: {', '.join(refs)})" if refs else ""))
            if metric != "rmse_dph" and len([g for g, v in groups.items()
                                             if v and g != "failed"]) == 1 and \
                    groups[f"unchanged (within {UNCHANGED_PCT} %)"]:
                todo.append("rmse_dph")
    if not lines:
        return None
    over = f" over {n_rep} replicates" if n_rep else ""
    return (f"**In short** (no claims here; each method's improvement over raw in the key "
            f"metric, %, mean [95 % interval]{over}, placed by its interval):\n\n"
            + "\n".join(lines))


def takeaway(mc: dict, plan=None) -> str | None:
    """One line for the top of a report: how the claims fared over the replicates; without
    claims, :func:`metric_takeaway`."""
    claims = mc.get("claims") or []
    if not claims:
        return metric_takeaway(mc, plan) if plan is not None else None
    count: dict[str, int] = {}
    for c in claims:
        word = c["verdict"]
        if word == "disagrees":
            word = f"disagree ({side(c)} the claim)"
        count[word] = count.get(word, 0) + 1
    order = ["agrees", "disagree (falls short of the claim)", "disagree (exceeds the claim)",
             "inconclusive", "untestable"]
    words = {"agrees": "agree"}
    parts = [f"{count[w]} {words.get(w, w)}" for w in order if w in count]
    parts += [f"{n} {w}" for w, n in count.items() if w not in order]
    n_rep = mc.get("replicates")
    over = f" over {n_rep} replicates" if n_rep else ""
    return (f"**In short:** {len(claims)} claim verdict(s){over}: " + ", ".join(parts)
            + " (each claim under each protocol; details in \"The papers' claims\").")


def open_on_answer(text: str, mc_section: str, mc: dict, fig_names: dict, plan=None) -> str:
    """The report reordered to open on the answer: its title, the one-line takeaway, the
    verdicts (each linked to its figure), the Monte Carlo evidence, then the set-up (the
    scenario's description, rows, runs and protocols) under :data:`SETUP_HEADING`."""
    title, _, rest = text.partition("\n\n")
    parts = [title]
    line = takeaway(mc, plan)
    if line:
        parts.append(line)
    verdicts = verdicts_section(mc, fig_names)
    if verdicts:
        parts.append("\n".join(verdicts).rstrip("\n"))
    parts += [mc_section.rstrip("\n"), f"{SETUP_HEADING}\n\n{rest}"]
    return "\n\n".join(parts)
