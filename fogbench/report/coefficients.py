"""Identified model coefficients against the configured ones (``figures/coefficients__...``)
and their table in the report."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fogbench.outputs import files
from fogbench.report.fmt import (
    fmt,
    md_table,
)
from fogbench.report.style import NOT_IDENTIFIED, _color
from fogbench.report.timeseries import LEGEND
from fogbench.run.runner import TERM_NAMES, ScenarioResult


def _fit_runs(res: ScenarioResult, protocol: str) -> str:
    prot = next((p for p in res.plan.protocols if p.name == protocol), None)
    if prot is None:
        return "?"
    if prot.per_run:
        return "each power-on's own calibration"
    names = list(dict.fromkeys(s.run for s in prot.fit))
    return ("run " if len(names) == 1 else "runs ") + ", ".join(names)


def _coef_rows(res: ScenarioResult, protocol: str) -> list[tuple[str, str, dict]]:
    """(run, label, metrics) of every output of ``protocol`` with fitted coefficients."""
    return [(run, lab, m) for run, by_method in
            res.metrics["protocols"][protocol]["runs"].items()
            for lab, m in by_method.items() if isinstance(m, dict) and "coef_errors_dph" in m]


def none_identified(res: ScenarioResult, protocol: str) -> bool:
    """Whether ``protocol`` has fitted coefficients but no fit identified any one of them by
    itself (``coef_identified`` empty: one static dwell determines one combination of the ten,
    lab_references' bias_lab): a coefficients figure would be all hatching, so none is drawn."""
    rows = _coef_rows(res, protocol)
    return bool(rows) and all(m.get("coef_identified") is not None
                              and not m["coef_identified"] for _, _, m in rows)


def fig_coefficients(res: ScenarioResult, protocol: str, path: Path) -> bool:
    """Identified against true coefficients of the first scored run; coefficients a fit could
    not identify one by one (rank-deficient design) are hatched, clipped to the plot's range
    and labelled instead of drawn at their arbitrary minimum-norm values. Not drawn when no
    coefficient was identified (:func:`none_identified`)."""
    rows = _coef_rows(res, protocol)
    if not rows or none_identified(res, protocol):
        return False
    run0 = rows[0][0]
    true = rows[0][2]["coef_true_dph"]
    labels = list(dict.fromkeys(r[1] for r in rows))
    width = 0.8 / max(1, len(labels))
    ests = {}
    for lab in labels:
        r = next((r for r in rows if r[1] == lab and r[0] == run0), None)
        if r is None:
            continue
        m = r[2]
        ident = m.get("coef_identified")
        ests[lab] = (np.array([m["coef_true_dph"][n] + m["coef_errors_dph"][n]
                               for n in TERM_NAMES]),
                     np.array([ident is None or n in ident for n in TERM_NAMES]))
    tv = np.array([true[n] for n in TERM_NAMES])
    # one panel per unit, each on its own scale (on one axis the g^2 terms were flat bars
    # beside a 7.8 deg/h bias)
    groups = [g for g in COEF_GROUPS if all(i < len(TERM_NAMES) for i in g[1])]
    fig, axs = plt.subplots(1, len(groups), figsize=(11, 4.8), squeeze=False,
                            gridspec_kw={"width_ratios": [len(g[1]) + 0.6 for g in groups],
                                         "wspace": 0.35})
    any_hidden = False
    for ax, (unit, idx) in zip(axs[0], groups):
        idx = np.asarray(idx)
        x = np.arange(idx.size)
        ax.plot(x, tv[idx], "ks", ms=8, label=f"true ({run0})", zorder=5)
        shown = [tv[idx]] + [e[idx][ok[idx]] for e, ok in ests.values()]
        span = max(float(np.max(np.abs(np.concatenate(shown)))), 1e-12) * 1.25
        for i, (lab, (est, ok)) in enumerate(ests.items()):
            c = _color(lab, list(ests), res.plan)
            xi = x + (i - (len(ests) - 1) / 2) * width
            e, k = est[idx], ok[idx]
            ax.bar(xi[k], e[k], width, alpha=0.75, color=c)
            # the legend key apart: with no identified bar there was no patch to take its colour
            ax.bar([np.nan], [np.nan], width, alpha=0.75, color=c, label=lab)
            if (~k).any():
                any_hidden = True
                clip = np.clip(e[~k], -span, span)
                ax.bar(xi[~k], clip, width, color="none", edgecolor=c, hatch="///", lw=0.8)
                for xx, v in zip(xi[~k], clip):
                    ax.text(xx, 0.5 * v, NOT_IDENTIFIED, rotation=90, ha="center",
                            va="center", fontsize=6.5, color=c,
                            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none",
                                  "pad": 0.5})
        ax.set_ylim(-span, span)
        ax.set_xticks(x, [TERM_NAMES[i] for i in idx])
        ax.set_xlim(-0.6, idx.size - 0.4)
        ax.set_ylabel(unit, fontsize=9)
        ax.axhline(0, color="0.7", lw=0.5)
    ax = axs[0, -1]
    if any_hidden:
        ax.bar([np.nan], [np.nan], width, color="none", edgecolor="0.3", hatch="///",
               label=f"{NOT_IDENTIFIED} (arbitrary value, clipped)")
    fig.suptitle(f"{protocol}: coefficients fitted on {_fit_runs(res, protocol)} against the "
                 f"true ones of {run0}\n(terms d0-d9 as in paper 004, Table 1; each unit on "
                 "its own scale)", fontsize=10)
    ax.legend(**LEGEND)         # right of the bars: inside, it covered d5-d7
    files.save_figure(fig, path)
    return True


#: The coefficient figure's panels: (unit, indices into TERM_NAMES).
COEF_GROUPS = (("d0, deg/h", (0,)), ("d1-d3, deg/h/g", (1, 2, 3)),
               ("d4-d9, deg/h/g^2", (4, 5, 6, 7, 8, 9)))


def _paper_value(plan, method, metric, run, segment=None):
    for pv in plan.paper:
        if pv.method == method and pv.metric == metric and pv.run in (None, run) and \
                pv.segment == segment:
            return pv
    return None


def _coef_table(res: ScenarioResult, protocol: str) -> str:
    runs = res.metrics["protocols"][protocol]["runs"]
    fits = res.metrics["protocols"][protocol]["fits"]
    out = []
    for lab, recs in fits.items():
        for i, rec in enumerate(recs):
            if rec.get("status") != "ok" or not rec.get("coefficients"):
                continue
            run = list(runs)[i] if i < len(runs) else "?"
            m = runs.get(run, {}).get(lab, {})
            if "coef_true_dph" not in m:
                continue
            true = m["coef_true_dph"]
            ident = rec.get("identifiability") or {}
            se = ident.get("stderr_dph", {})
            rows = []
            for n in TERM_NAMES:
                est = true[n] + m["coef_errors_dph"][n]
                s = se.get(n)
                rows.append([n, fmt(true[n]), fmt(est), "not identified" if n in se and s is None
                             else (fmt(s) if s is not None else "–")])
            out.append(f"**{lab}, {run}** (rank {ident.get('rank', '?')} of "
                       f"{ident.get('n_terms', '?')}, condition {fmt(ident.get('condition'))}):\n\n"
                       + md_table(["coef", "true", "estimated", "std error"], rows))
            if ident.get("summary"):
                out.append("\n".join(f"- {s}" for s in ident["summary"]))
            break  # the first power-on; all are in metrics.json
    if not out:
        return ""
    return ("Identified coefficients against the true ones of the power-on (d0 deg/h, d1-d3 "
            "deg/h/g, d4-d9 deg/h/g^2; paper 004 Table 1 layout):\n\n" + "\n\n".join(out))
