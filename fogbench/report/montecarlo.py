"""The Monte Carlo part of a report: its text (distributions, intervals, orderings, bands of
swept settings) and its figures (``replicates.png``, ``starts.png``, ``runs.png``)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fogbench.outputs import files
from fogbench.report.claims import (
    SETUP_HEADING,
    claim_failed_text,
    unit_of,
    verdict_link,
)
from fogbench.report.fmt import (
    ORACLE_FILTER_NOT,
    ci_text,
    failed_everywhere,
    failed_text,
    fmt,
    key_metric,
    md_table,
    p_better_text,
)
from fogbench.report.spectra import _log_ticks
from fogbench.report.style import COLORS, _color
from fogbench.report.timeseries import LEGEND
from fogbench.report.views import method_entries as _method_entries
from fogbench.report.views import sweep_names as _sweep_names
from fogbench.run.metrics import KEY_METRICS
from fogbench.run.runner import ScenarioResult

# ---------------------------------------------------------------------------------------------
# Monte Carlo: the distributions over replicates
DIST_PANELS_A_ROW = 3      # replicates.png / starts.png: panels a row, more wrap


def _collapse_sweeps(labels: list[str], data: list, plan):
    """A sweep's members as one column: its default setting's values, labelled
    ``<sweep> (<n> settings)``, with the members' medians for a range mark; other labels as
    they are. Returns (labels, data, source labels, member medians or None)."""
    entries = {m: e for e in _method_entries(labels, plan) for m in e["members"]}
    by = dict(zip(labels, data))
    out_l, out_d, src, ranges, done = [], [], [], [], set()
    for lab in labels:
        e = entries.get(lab)
        if e is None or e["group"] is None:
            out_l.append(lab)
            out_d.append(by[lab])
            src.append(lab)
            ranges.append(None)
            continue
        if e["group"] in done:
            continue
        done.add(e["group"])
        out_l.append(f"{e['group']}\n({len(e['members'])} settings)")
        out_d.append(by[e["default"]])
        src.append(e["default"])
        ranges.append([float(np.median(by[m])) for m in e["members"] if by[m].size])
    return out_l, out_d, src, ranges


def _metric_axis(ax, prot, metric: str, title: str) -> None:
    """A protocol panel's y label (the metric with its unit) and title (flagged in-sample)."""
    unit = unit_of(metric)
    ax.set_ylabel(metric if unit == "as the metric" else f"{metric}, {unit}", fontsize=9)
    flag = " (in-sample)" if prot.in_sample else ""
    ax.set_title(f"{prot.name}{flag}: {title}", fontsize=9)


def _share_y(pairs) -> None:
    """Panels ``(ax, metric)`` of one metric and y scale share one y range (the union of
    theirs), so that protocols compare at a glance (switch_on_repeatability's calibrate_once
    and recalibrate had different scales)."""
    groups: dict = {}
    for ax, metric in pairs:
        groups.setdefault((metric, ax.get_yscale()), []).append(ax)
    for used in groups.values():
        if len(used) < 2:
            continue
        lo = min(a.get_ylim()[0] for a in used)
        hi = max(a.get_ylim()[1] for a in used)
        for a in used:
            a.set_ylim(lo, hi)
            _log_ticks(a)


def _fig_distributions(res: ScenarioResult, mc: dict, path: Path, panel) -> bool:
    """One panel per protocol whose key metric ``panel(prot, metric)`` has values, at most
    DIST_PANELS_A_ROW a row: one column per method, the values as jittered points over a box of
    their quartiles (log scale for positive deg/h); a sweep as one column, its default
    setting's values with the range of its members' medians as a bar beside it. ``panel``
    returns (labels, values per label, title, style, extra(ax, i, label)) or None to leave the
    protocol out."""
    panels = []
    for prot in res.plan.protocols:
        metric = key_metric(mc, prot.name, res.plan)
        got = panel(prot, metric) if metric else None
        if got:
            panels.append((prot, metric) + tuple(got))
    if not panels:
        return False
    # ideal-lab twins in the row(s) below their lab protocols, each under its own
    twins = [x for x in panels if getattr(x[0], "twin_of", None)]
    labs = [x for x in panels if x not in twins]
    ncol = min(len(panels), DIST_PANELS_A_ROW)
    if twins and labs and len(labs) <= DIST_PANELS_A_ROW:
        ncol = len(labs)
        order = {x[0].name: i for i, x in enumerate(labs)}
        twins.sort(key=lambda x: order.get(x[0].twin_of, len(order)))
        panels = labs + twins
    nrow = -(-len(panels) // ncol)
    widest = max(len(_collapse_sweeps(p[2], p[3], res.plan)[0]) for p in panels)
    fig, axes = plt.subplots(nrow, ncol, figsize=(ncol * max(3.6, 0.42 * widest + 1.2) + 0.6,
                                                  4.3 * nrow), squeeze=False)
    rng = np.random.default_rng(0)  # horizontal jitter of the points only
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, (prot, metric, labels, data, title, style, extra) in zip(axes.flat, panels):
        shown, data, src, ranges = _collapse_sweeps(labels, data, res.plan)
        ax.boxplot(data, positions=range(len(shown)), widths=0.5, showfliers=False,
                   medianprops={"color": "k"})
        for i, (lab, d) in enumerate(zip(src, data)):
            ax.plot(i + rng.uniform(-style["jitter"], style["jitter"], d.size), d, "o",
                    ms=style["ms"], alpha=style["alpha"],
                    color=_color(lab, labels, res.plan), zorder=3)
            if ranges[i]:
                ax.vlines(i + 0.36, min(ranges[i]), max(ranges[i]), color="0.25", lw=2.2,
                          zorder=4, label="a sweep's members: range of their medians"
                          if i == next(j for j, r in enumerate(ranges) if r) else None)
            if extra is not None:
                extra(ax, i, lab)
        ax.set_xticks(range(len(shown)), shown, rotation=35, ha="right", fontsize=8,
                      rotation_mode="anchor")
        _metric_axis(ax, prot, metric, title)
        if metric.endswith("_dph") and any(d.size for d in data) and \
                all(np.all(d > 0) for d in data if d.size):   # an empty column: failed
            ax.set_yscale("log")
            _log_ticks(ax)      # paper004's axis had two labels, 10^0 and 10^1
        ax.grid(alpha=0.3)
        if any(ranges):
            ax.legend(fontsize=7, loc="best")
    _share_y([(a, x[1]) for a, x in zip(axes.flat, panels)])
    fig.tight_layout()
    files.save_figure(fig, path)
    return True


def fig_replicates(res: ScenarioResult, mc: dict, path: Path) -> bool:
    """Each protocol's key metric over replicates: one column per method (raw and oracle too),
    every replicate a point, a box for the quartiles."""
    if mc["replicates"] < 2:
        return False

    def panel(prot, metric):
        ser = mc["series"].get(prot.name, {}).get(metric, {})
        failed = failed_everywhere(mc, prot.name)
        labels = [lab for lab in ser if any(v is not None for v in ser[lab])]
        labels += [lab for lab in failed if lab not in labels]     # an empty column, last
        data = [np.array([v for v in ser.get(lab, []) if v is not None], dtype=float)
                for lab in labels]

        def says_failed(ax, i, lab):
            if lab in failed:
                ax.text(i, 0.5, f"failed in {failed[lab]['failed']} of "
                        f"{failed[lab]['replicates']}", transform=ax.get_xaxis_transform(),
                        rotation=90, ha="center", va="center", fontsize=7, color="C3")

        return (labels, data, f"{mc['replicates']} replicates",
                {"jitter": 0.15, "ms": 3.5, "alpha": 0.7}, says_failed if failed else None)

    return _fig_distributions(res, mc, path, panel)


def fig_starts(res: ScenarioResult, mc: dict, path: Path) -> bool:
    """The methods that draw random starts (K > 1), start by start: each protocol's key metric
    for every start of every replicate (a point), a box for the quartiles over replicates x
    starts, and the replicate means (the values the claims use) as crosses."""
    ss = mc.get("start_series", {})

    def panel(prot, metric):
        by_label = ss.get(prot.name, {}).get(metric)
        if not by_label:
            return None
        labels = list(by_label)
        pooled = [np.array([x for rep in by_label[lab] for x in rep if x is not None])
                  for lab in labels]
        k = max(len(rep) for lab in labels for rep in by_label[lab])

        def means(ax, i, lab):
            m = [np.mean([x for x in rep if x is not None]) for rep in by_label[lab]
                 if any(x is not None for x in rep)]
            ax.plot(np.full(len(m), i + 0.32), m, "x", ms=4, color="k", zorder=4,
                    label="replicate means (what the claims use)" if i == 0 else None)
            if i == 0:
                ax.legend(fontsize=7, loc="best")

        return (labels, pooled, f"{mc['replicates']} replicates x {k} starts",
                {"jitter": 0.2, "ms": 2, "alpha": 0.35}, means)

    return _fig_distributions(res, mc, path, panel)


def fig_runs(res: ScenarioResult, mc: dict, path: Path) -> bool:
    """Each protocol that scores two or more runs (power-ons), its ideal-lab twins left out:
    the key metric on each run, mean and 95 % t-interval over the replicates, raw, the oracle
    and every method (a sweep: its default setting) joined across the runs; panels of one
    metric on one y range. What switch_on_repeatability is about, calibrate once against
    calibrate at every power-on, showed only as one power-on per figure. None to draw: False."""
    summary = mc.get("summary") or {}
    panels = []
    for prot in res.plan.protocols:
        runs = list((summary.get(prot.name) or {}).keys())
        if getattr(prot, "twin_of", None) or len(runs) < 2:
            continue
        metric = key_metric(mc, prot.name, res.plan)
        if metric:
            panels.append((prot, metric, runs))
    if not panels:
        return False
    fig, axes = plt.subplots(1, len(panels), figsize=(0.9 + 4.6 * len(panels), 4.6),
                             squeeze=False)
    for ax, (prot, metric, runs) in zip(axes[0], panels):
        by_run = summary[prot.name]
        every = list(dict.fromkeys(lab for r in runs for lab in by_run[r]))
        refs = ("raw", "oracle", "oracle_filter")
        labels = [lab for lab in refs if lab in every]
        entries = _method_entries([lab for lab in every if lab not in refs], res.plan)
        labels += [e["default"] for e in entries]
        names = {e["default"]: _sweep_names(e)[0] if e["group"] else e["default"]
                 for e in entries}
        x = np.arange(len(runs))
        width = 0.5 / max(1, len(labels) - 1)
        for i, lab in enumerate(labels):
            sm = [(by_run.get(r, {}).get(lab) or {}).get(metric) or {} for r in runs]
            m = np.array([np.nan if v.get("mean") is None else v["mean"] for v in sm])
            lo = np.array([np.nan if v.get("ci_low") is None else v["ci_low"] for v in sm])
            hi = np.array([np.nan if v.get("ci_high") is None else v["ci_high"] for v in sm])
            if not np.any(np.isfinite(m)):
                continue
            xi = x + (i - (len(labels) - 1) / 2) * width
            ax.errorbar(xi, m, yerr=[m - np.where(np.isfinite(lo), lo, m),
                                     np.where(np.isfinite(hi), hi, m) - m],
                        fmt=":o" if lab == "oracle_filter" else "-o", ms=4, lw=1.0,
                        capsize=3, color=(COLORS["oracle"] if lab == "oracle_filter" else
                                          _color(lab, every, res.plan)),
                        mfc="none" if lab == "raw" else None, label=names.get(lab, lab),
                        gid=f"runs:{prot.name}:{lab}")
        for lab, f in failed_everywhere(mc, prot.name).items():
            if lab in labels:   # nothing to draw: named last in the legend as failed
                ax.errorbar([], [], fmt="x", color="C3", label=f"{names.get(lab, lab)}: "
                            f"failed in {f['failed']} of {f['replicates']}")
        ax.set_xticks(x, runs, rotation=30, ha="right", rotation_mode="anchor", fontsize=8)
        _metric_axis(ax, prot, metric, f"{metric} on each run\n(mean and 95 % interval over "
                                       f"{mc['replicates']} replicates)")
        ax.grid(alpha=0.3)
    # a positive deg/h metric spanning over 20x (paper004: raw at 10 deg/h, the models at 0.3
    # and 0.6) on a log scale, decided over all of its panels so that they share it
    pairs = [(ax, metric) for ax, (_, metric, _) in zip(axes[0], panels)]
    for metric in {m for _, m in pairs}:
        mine = [ax for ax, m in pairs if m == metric]
        ys = [y for ax in mine for c in ax.containers for y in c.lines[0].get_ydata()
              if np.isfinite(y)]
        if metric.endswith("_dph") and ys and min(ys) > 0 and max(ys) / min(ys) > 20:
            for ax in mine:
                ax.set_yscale("log")
                _log_ticks(ax)
    _share_y(pairs)
    axes[0, -1].legend(**LEGEND)
    fig.tight_layout()
    files.save_figure(fig, path)
    return True


def recording_replicates(mc: dict, work=None) -> dict:
    """What the recording shows over replicates: {protocol: {metric: {label: [values]}}}."""
    return mc.get("series", {})


def render_montecarlo(res: ScenarioResult, mc: dict, fig_names: dict) -> str:
    """The report's Monte Carlo section: how the replicates were drawn, then the papers'
    claims, the lab's cost, the rankings, the references, each protocol's table over
    replicates and the figures over replicates, each part present only where it has data."""
    plan = res.plan
    L = _mc_intro(mc)
    if mc["claims"]:
        L += _mc_claims(mc, fig_names)
    twins = [p for p in plan.protocols if getattr(p, "twin_of", None)]
    if mc.get("lab_cost") or any(failed_everywhere(mc, n) for p in twins
                                 for n in (p.name, p.twin_of)):
        L += _mc_lab_cost(mc, twins)
    if mc["rankings"]:
        L += _mc_rankings(mc)
    refs = [pv for pv in plan.paper if pv.segment is None]
    if refs:
        L += _mc_references(refs, plan, mc)
    for prot in plan.protocols:
        L += _mc_protocol_table(prot, plan, mc)
    L += _mc_figure_links(fig_names)
    L += render_bands(res, mc)
    return "\n".join(L)


def _mc_intro(mc: dict) -> list[str]:
    """The section's head: how many replicates and seeds, how each random stream is drawn,
    what the values are, the cost and the failed replicates."""
    R, K = mc["replicates"], mc["method_seeds"]
    cost = mc.get("cost", {})
    L = [f"## Over {R} replicates (Monte Carlo)", "",
         f"{R} replicate(s) of every power-on (requested {mc['replicates_requested']}), "
         f"{K} method seed(s) per fit of a random method, scenario seed {mc['seed']}, on "
         f"{mc['engine']}. Replicate r draws every random stream (switch-on draws, noise, "
         "sensor noise, method starts) from (scenario seed, r, run, stream); the table's motion "
         "is the same in all. Values: mean [95 % t-interval of the mean] over replicates, of "
         "the mean over a protocol's scored runs (per run: `metrics.json`, key `montecarlo`). "
         "The figures and tables below this section show replicate 0 alone.", ""]
    if cost.get("first_run_s"):
        L += [f"Cost: first run {cost['first_run_s']:.1f} s (table simulated); a replicate "
              + (f"{cost['replicate_median_s']:.2f} s (median) = "
                 f"{cost['replicate_over_first']:.2f} of the first run."
                 if cost.get("replicate_median_s") else "–."), ""]
    if mc.get("failed_replicates"):
        L += [f"Failed replicates ({len(mc['failed_replicates'])}): "
              + "; ".join(f"r{f['replicate']}: {f['error']}" for f in mc["failed_replicates"]),
              ""]
    return L


def _mc_claims(mc: dict, fig_names: dict) -> list[str]:
    """The papers' claims, one item each: the claimed quantity over replicates, its verdict,
    how often it held, the oracle's improvement beside it, and its figure."""
    L = ["### The papers' claims", "",
         "Verdict by the claimed quantity's interval over replicates: **agrees** (inside "
         "the claimed range), **disagrees** (outside), **inconclusive** (overlapping), "
         "**untestable** (the claim asks more than the oracle, the best model of the "
         "deterministic error terms, can give here). The oracle's improvement is shown "
         "beside every claim.", ""]
    for i, c in enumerate(mc["claims"]):
        lo = "" if c["min_pct"] is None else f"{c['min_pct']:g}"
        hi = "" if c["max_pct"] is None else f"{c['max_pct']:g}"
        rng = f"{lo}..{hi} %"
        sm, osm = c["summary"], c["oracle_improvement"]
        tag = " (in-sample, the paper's protocol)" if c["in_sample"] else " (held out)"
        held = "–" if c["held"] is None else f"{100 * c['held']:.0f} %"
        first = c["paired"].get("first_better")
        L.append(f"- {c['source']}: \"{c['text']}\" — `{c['protocol']}`{tag}: "
                 f"{c['better']} vs {c['than']} on {c['metric']}: "
                 f"{claim_failed_text(mc, c) or ci_text(sm, '_pct') + ' %'} (claim {rng}): "
                 + verdict_link(c, fig_names.get(("claim", i))) + "; the claim "
                 f"held in {held} of replicates; {c['better']} better than {c['than']} in "
                 f"{'–' if first is None else f'{100 * first:.0f} %'} of replicates. "
                 f"Oracle over {c['than']}: {ci_text(osm, '_pct')} %"
                 + ("" if c["oracle_bounds_claim"] else
                    f" (not a bound here: {c['better']} also filters noise)") + "."
                 + over_seeds_text(c))
        if ("claim", i) in fig_names:
            L += ["", f"  ![claim {i}: {c['better']} over {c['than']}]"
                      f"({fig_names[('claim', i)]})", ""]
    L.append("")
    return L


def _mc_lab_cost(mc: dict, twins: list) -> list[str]:
    """What the lab's references cost: each method's lab fit minus its ideal-lab twin, over
    replicates, as a table; a method that failed in every replicate of either protocol
    (``twins``: the ideal-lab protocols) last, a row saying where."""
    L = ["### What the lab's references cost", "",
         "Each method fitted on what a lab has (protocol `reference = \"lab\"`: the table's "
         "commands, the Earth rate at the believed latitude and heading, gravity through "
         "the commanded attitude; `sim/lab.py`) and on the truth (the ideal lab, protocol "
         "`<name>.ideal`), both scored against the truth on the same power-ons: the lab's "
         "value minus the ideal one, mean [95 % t-interval] over replicates, and the share "
         "of replicates where the lab's fit did worse (for the signed mean error: further from 0).", ""]
    rows = []
    for c in mc["lab_cost"]:
        d, pr = c["paired"]["diff"], c["paired"]
        worse = pr.get("second_better")
        rows.append([f"`{c['protocol']}`", c["method"], c["metric"],
                     ci_text(c["lab"], c["metric"]), ci_text(c["truth"], c["metric"]),
                     ci_text(d, c["metric"]),
                     "–" if worse is None else f"{100 * worse:.0f} %"])
    for ideal in twins:
        lab_f, ideal_f = failed_everywhere(mc, ideal.twin_of), failed_everywhere(mc, ideal.name)
        for m in dict.fromkeys([*lab_f, *ideal_f]):
            rows.append([f"`{ideal.twin_of}`", m, "–",
                         failed_text(lab_f[m]) if m in lab_f else "–",
                         failed_text(ideal_f[m]) if m in ideal_f else "–", "–", "–"])
    L += [md_table(["protocol", "method", "metric", "lab reference", "ideal (truth)",
                    "lab - ideal", "lab worse in"], rows), ""]
    return L


def _mc_rankings(mc: dict) -> list[str]:
    """The papers' tables' orderings: how often each held over replicates, and the most
    frequent ones."""
    L = ["### Rankings against the papers' tables", "",
         "Probability of each ordering over replicates (`<` reads 'better than').", ""]
    for rk in mc["rankings"]:
        top = "; ".join(f"{o['ordering']}: {100 * o['probability']:.0f} %"
                        for o in rk["orderings"][:3])
        L.append(f"- `{rk['protocol']}`, {rk['run']}, {rk['metric']}: the paper's order "
                 f"{' < '.join(rk['paper_order'])} in {100 * rk['p_paper_order']:.0f} % of "
                 f"replicates. Most frequent: {top}.")
    L.append("")
    return L


def _mc_references(refs: list, plan, mc: dict) -> list[str]:
    """Each reference value (``refs``: the plan's whole-run ones) beside ours over
    replicates, per protocol and run; a noise term says whether it was configured and how
    often it was identified."""
    L = ["### Against the references", ""]
    for pv in refs:
        for prot in plan.protocols:
            runs = [pv.run] if pv.run else list(mc["summary"].get(prot.name, {}))
            for run in runs:
                sm = mc["summary"].get(prot.name, {}).get(run, {}).get(pv.method, {}).get(
                    pv.metric)
                allan = pv.metric in ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
                                      "gm_sigma_dph", "gm_tau_s")
                failed = failed_everywhere(mc, prot.name).get(pv.method)
                if failed:
                    ours = failed_text(failed)
                elif sm and sm.get("n"):
                    ours = ci_text({**sm, "n_failed": 0}, pv.metric)
                    total = sm["n"] + (sm.get("n_failed") or 0)
                    if sm.get("n_failed"):
                        ours += (f", identified in {sm['n']} of {total} replicates" if allan
                                 else f", failed in {sm['n_failed']} of {total}")
                else:
                    ours = "not identified" if allan else "not computed"
                if allan and pv.source.startswith("configured") and not failed:
                    ours = f"configured {fmt(pv.value, pv.metric)}, " + (
                        ours if ours == "not identified" else f"identified {ours}")
                L.append(f"- `{prot.name}`, {run}, {pv.method}, {pv.metric}: reference "
                         f"{fmt(pv.value, pv.metric)} ({pv.source}); ours {ours}.")
    L.append("")
    return L


def _mc_protocol_table(prot, plan, mc: dict) -> list[str]:
    """Protocol ``prot``'s key metrics, mean over its scored runs, over replicates, and the
    spread over method seeds inside a replicate (nothing when it has none of the metrics)."""
    po = mc["over_runs"].get(prot.name, {})
    metrics = [m for m in KEY_METRICS if m not in ("fit_time_s",) and any(
        m in po.get(lab, {}) for lab in po)]
    if not metrics:
        return []
    flag = " (IN-SAMPLE)" if prot.in_sample else ""
    failed = failed_everywhere(mc, prot.name)
    # a method that failed in every replicate: last, its first error once, no numbers
    rows = [[lab] + [ci_text(po.get(lab, {}).get(m), m) for m in metrics] for lab in po
            if lab not in failed]
    withheld = mc.get("oracle_filter_withheld", {}).get(prot.name)
    if withheld and "oracle_filter" not in po:   # no value where its noise model does not hold
        reasons = "; ".join(dict.fromkeys(withheld.values()))
        rows.insert(min(2, len(rows)), ["oracle_filter", f"– ({ORACLE_FILTER_NOT} {reasons})"]
                    + ["–"] * (len(metrics) - 1))
    rows += [[lab, failed_text(f)] + ["–"] * (len(metrics) - 1) for lab, f in failed.items()]
    L = [f"### `{prot.name}`{flag}: mean over scored runs, over replicates", "",
         md_table(["method"] + metrics, rows), ""]
    spread = mc.get("seed_spread", {}).get(prot.name, {})
    if spread:
        bits = []
        for run, by_label in spread.items():
            for lab, by_metric in by_label.items():
                km = key_metric(mc, prot.name, plan)
                if km in by_metric:
                    bits.append(f"{lab} on {run}: {fmt(by_metric[km]['mean_std_over_seeds'], km)}")
        if bits:
            L += [f"Spread over the {mc['method_seeds']} method seeds inside a replicate (std of "
                  f"{key_metric(mc, prot.name, plan)}, mean over replicates): "
                  + "; ".join(bits) + ".", ""]
    return L


def _mc_figure_links(fig_names: dict) -> list[str]:
    """The figures over replicates that were drawn: distributions, metric by run, starts."""
    L = []
    if ("replicates",) in fig_names:
        L += [f"![distributions over replicates]({fig_names[('replicates',)]})", ""]
    if ("runs",) in fig_names:
        L += ["Each protocol's key metric run by run (power-on by power-on), over replicates:",
              "", f"![key metric by run]({fig_names[('runs',)]})", ""]
    if ("starts",) in fig_names:
        L += ["The methods that draw random starts, start by start (points: every start of "
              "every replicate; crosses: the replicate means the claims use):", "",
              f"![distributions over method starts]({fig_names[('starts',)]})", ""]
    return L


def over_seeds_text(c: dict) -> str:
    """The claim between two seeded methods over their method starts (empty without seeds)."""
    o = c.get("over_seeds")
    if not o or o.get(c["better"]) is None or o.get(c["than"]) is None:
        return ""
    m = c["metric"]

    def dist(lab):
        d = o[lab]
        return f"{lab} {fmt(d['median'], m)} [{fmt(d['q05'], m)}, {fmt(d['q95'], m)}]"

    k = o.get("seeds_per_replicate")
    p = o["p_better_start"]
    failed = [f"{n} of {o['starts'][lab]} starts of {lab}" for lab, n in
              (o.get("failed_starts") or {}).items() if n]
    left = f" Failed, left out: {', '.join(failed)}." if failed else ""
    ptxt = p_better_text(p)
    return (f" Over method starts ({k if k else 'K'} per replicate; median [5 %, 95 %] of "
            f"{m} over replicates x starts): {dist(c['better'])}, {dist(c['than'])}; a start "
            f"of {c['better']} beats a start of {c['than']} with probability "
            f"{ptxt} (0.5: no difference).{left}")


def render_bands(res: ScenarioResult, mc: dict | None) -> list[str]:
    """For every swept method (``sweep = {...}``): the band of its key metric over the settings
    (best, worst) and where the paper's setting falls, per protocol; a ranking against a paper
    is then stated over a baseline's reasonable settings, not one pick."""
    plan = res.plan
    groups: dict = {}
    for m in plan.methods:
        if m.group:
            groups.setdefault(m.group, []).append(m)
    if not groups:
        return []
    L = ["### Bands over hyperparameter settings (sweeps)", ""]
    for prot in plan.protocols:
        metric = key_metric(mc, prot.name, plan) if mc else next(
            (k for k in ("drift_rms_dph", "bias_stability_100s_dph", "rmse_dph", "std_dps")
             if any(k in m for by in res.metrics["protocols"][prot.name]["runs"].values()
                    for m in by.values() if isinstance(m, dict))), None)
        if metric is None:
            continue
        better_high = metric.endswith("_pct")
        for group, members in groups.items():
            vals = {}
            for m in members:
                if mc:
                    sm = mc["over_runs"].get(prot.name, {}).get(m.label, {}).get(metric)
                    v = sm["mean"] if sm and sm.get("n") else None
                else:
                    v = _mean_runs(res.metrics["protocols"][prot.name], m.label, metric)
                if v is not None:
                    vals[m.label] = v
            if not vals:
                continue
            order = sorted(vals, key=vals.get, reverse=better_high)
            paper = next((m.label for m in members if m.paper_setting), None)
            L.append(f"- `{prot.name}`, {group} over {len(members)} settings, {metric}: best "
                     f"{fmt(vals[order[0]], metric)} (`{order[0]}`), worst "
                     f"{fmt(vals[order[-1]], metric)} (`{order[-1]}`)"
                     + (f"; the default/paper setting `{paper}` gives "
                        f"{fmt(vals[paper], metric)}, rank {order.index(paper) + 1} of "
                        f"{len(order)}" if paper in vals else "") + ".")
    L.append("")
    return L


def _mean_runs(pd: dict, label: str, metric: str):
    vals = [m[label][metric] for m in pd["runs"].values()
            if isinstance(m.get(label), dict) and isinstance(m[label].get(metric), (int, float))]
    return sum(vals) / len(vals) if vals else None


def _insert_mc(text: str, section: str) -> str:
    """Put the Monte Carlo section before the first protocol's single-replicate tables (before
    the set-up when the report opens on the answer)."""
    i = text.find(f"\n{SETUP_HEADING}\n")
    i = text.find("\n## Protocol ") if i < 0 else i
    return text + "\n" + section if i < 0 else text[:i + 1] + section + "\n" + text[i + 1:]
