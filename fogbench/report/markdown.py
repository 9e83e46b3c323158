"""``report.md`` of one run: the set-up, the per-protocol tables, paper 002's Table 1 by
segment, and the fit notes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fogbench.report.coefficients import _coef_rows, _coef_table, _paper_value, none_identified
from fogbench.report.fmt import (
    fmt,
    md_table,
    metrics_table,
)
from fogbench.report.spectra import shows_time_structure
from fogbench.report.views import SAME_FRACTION, offsets_only
from fogbench.run.runner import ScenarioResult, thermal_segments
from fogcomp import metrics as M
from fogcomp.units import DPH

__all__ = ["raw_segment_stability"]


def render_report(res: ScenarioResult, fig_names: dict, decimation: dict,
                  same: set | None = None) -> str:
    """The report's markdown; ``same``: :func:`same_as_lab` of ``res`` when already known."""
    same = same_as_lab(res) if same is None else same
    L = _report_head(res)
    for prot in res.plan.protocols:
        L += _protocol_section(res, prot, fig_names, decimation, same)
    t1 = _table1_section(res)
    if t1:
        L += [t1, ""]
    fn = fig_names.get(("thermal",))
    if fn:
        L += ["## Temperature and bias", "", f"![thermal]({fn})", ""]
    L += ["## Versions", "", ", ".join(f"{k} {v}" for k, v in res.metrics["versions"].items()),
          ""]
    return "\n".join(L)


def _report_head(res: ScenarioResult) -> list[str]:
    """The report's opening: the scenario, its notes, what the rows and units are, and the
    table of runs (power-ons)."""
    sc, plan, doc = res.scenario, res.plan, res.metrics
    L = [f"# {sc.name}", "", sc.description, "",
         f"Scenario file: `{Path(sc.path).name}`. FOG: {sc.device}; axis `{plan.axis}`; {sc.fs:g} Hz. Wall time {res.wall_s:.1f} s "
         "(simulating every run, fitting and scoring, in one process; it leaves out writing "
         "this report, its figures and the recording, which the suite summary's wall time of "
         "the scenario includes; a method's own fit time is its `fit_time_s`).", ""]
    for note in plan.notes:
        L += [f"> {note}", ""]
    L += ["Rows: `raw` is the FOG output; `oracle` is the raw output minus the true deterministic "
          "error terms (bias, switch-on bias, scale factor, misalignment, g and g^2, temperature, "
          "rate ramp), the floor no model of those terms can beat in expectation (in one "
          "replicate of a record dominated by slow noise the raw output can land closer to the "
          "truth by chance: see the intervals over replicates); each method is fitted on the "
          "protocol's fit samples and scored on its score samples against the simulation's truth.",
          "", "Metric units are in their names: `_dps` deg/s, `_dph` deg/h, `_deg` deg, `_pct` "
          "percent improvement over raw (positive is better), `_s` seconds.", ""]
    runs_tab = [[name, str(r["seed"]), str(r["samples"]), f"{r['duration_s']:g}",
                 f"{r['settled_hold_fast_path_s']:g}"] for name, r in doc["runs"].items()]
    L += ["## Runs (power-ons)", "", md_table(["run", "seed", "samples", "duration, s",
                                            "settled-hold fast path, s"], runs_tab), ""]
    return L


def _protocol_section(res: ScenarioResult, prot, fig_names: dict, decimation: dict,
                      same: set) -> list[str]:
    """One protocol's section: what it fits and scores on, each scored run's table and
    figures, why figures are missing or raw's alone, its coefficients and its fit notes."""
    pd = res.metrics["protocols"][prot.name]
    flag = " — IN-SAMPLE (the paper's own protocol: scored on data it was fitted on)" \
        if prot.in_sample else " — held out"
    L = [f"## Protocol `{prot.name}`{flag}", ""]
    if prot.description:
        L += [prot.description, ""]
    L += [f"Fit on: {'; '.join(s.describe() for s in prot.fit)}. Score on: "
          f"{'; '.join(s.describe() for s in prot.score)}."
          + (f" Per run: {', '.join(prot.runs)}." if prot.per_run else "")
          + (f" Data smoothed by {prot.smooth_s:g} s means before fitting and scoring."
             if prot.smooth_s else "")
          + (f" First {prot.skip_s:g} s of each run left out." if prot.skip_s else ""), ""]
    for run, by_method in pd["runs"].items():
        L += _run_section(res, prot, run, by_method, fig_names, decimation, same)
    L += _figure_caveats(res, prot, fig_names)
    fn = fig_names.get((prot.name, None, "coefficients"))
    nothing = none_identified(res, prot.name)
    if _coef_rows(res, prot.name) and not nothing:
        L += [_coef_table(res, prot.name), ""] + ([f"![coefficients]({fn})", ""] if fn
                                                  else [])
    elif nothing:
        L += [("(No coefficients figure or table: no fit of this protocol identified any "
               "of the ten coefficients by itself; what it determines is a combination of "
               "them, which the bias it books and the errors above show.)"), ""]
    L += [_fit_notes(pd), ""]
    return L


def _run_section(res: ScenarioResult, prot, run: str, by_method: dict, fig_names: dict,
                 decimation: dict, same: set) -> list[str]:
    """One scored run of a protocol: its metrics beside the references, its per-segment
    table, its figures, and why they are absent or decimated."""
    plan = res.plan

    def cell(lab, met, v):
        pv = _paper_value(plan, lab, met, run)
        return fmt(v, met) + (f" (ref: {fmt(pv.value, met)})" if pv is not None else "")

    L = [f"### {run}", "", metrics_table(by_method, cell), ""]
    refs = sorted({pv.source for pv in plan.paper if pv.run in (None, run)
                   and pv.segment is None})
    if refs:
        L += ["(ref: " + "; ".join(refs) + ")", ""]
    seg = _segment_table(res, prot.name, run)
    if seg:
        L += [seg, ""]
    for kind in ("timeseries", "psd", "allan"):
        fn = fig_names.get((prot.name, run, kind))
        if fn:
            L += [f"![{kind} {run}]({fn})", ""]
    if (prot.name, run) in same:
        L += [f"(No figures of {run} here: every output of `{prot.name}` is "
              f"`{prot.twin_of}`'s to {SAME_FRACTION:g} of its error's span, under a "
              f"pixel; the lab's references and the truth gave the same fits. See "
              f"`{prot.twin_of}`'s figures.)", ""]
    if (prot.name, run) in decimation and decimation[(prot.name, run)] > 1:
        L += [f"(Time series decimated by {decimation[(prot.name, run)]} for display "
              "only; metrics use every sample.)", ""]
    return L


def _figure_caveats(res: ScenarioResult, prot, fig_names: dict) -> list[str]:
    """Why a protocol's runs have no Allan deviation or PSD (stitched dwells) or show raw's
    alone (every output differs from raw by a constant)."""
    L = []
    stitched = [x.run for x in res.scored
                if x.protocol == prot.name and not shows_time_structure(x.piece)]
    if stitched:
        L += [f"(No Allan deviation or PSD figure of {', '.join(stitched)}: each scored "
              "piece is made of separate static dwells, scored by each dwell's mean error, "
              "which neither can show; the dwell-means figures above show it.)", ""]
    constant = list(dict.fromkeys(      # (where those figures were drawn)
        x.run for x in res.scored if x.protocol == prot.name
        and {(prot.name, x.run, "psd"), (prot.name, x.run, "allan")} & set(fig_names)
        and offsets_only(x)))
    if constant:
        L += [(f"(The Allan deviation and PSD of {', '.join(constant)} are raw's alone: "
               "every output differs from raw by a constant (to "
               f"{SAME_FRACTION:g} of raw's error span), which an Allan deviation cannot "
               "see and a PSD removes, so each would lie on raw's curve; the tables show "
               "the constants.)"), ""]
    return L


SEGMENT_METRIC = "bias_stability_100s_dph"


def same_as_lab(res: ScenarioResult) -> set[tuple[str, str]]:
    """(protocol, run) of the ideal-lab twins (``<name>.ideal``) whose every output on that run
    is the lab protocol's to SAME_FRACTION of that output's error span (max - min of output -
    truth): each line would fall on the lab figure's own to under a pixel of any panel that
    holds it (about 1/500 of its height), so the twin's figures are left out. Where the lab's
    references are the truth to the servo's hold (a static table), both fits are the same."""
    twin_of = {p.name: p.twin_of for p in res.plan.protocols if p.twin_of}
    lab = {(it.protocol, it.run): it for it in res.scored}
    out = set()
    for it in res.scored:
        other = lab.get((twin_of.get(it.protocol), it.run))
        if other is None or set(other.outputs) != set(it.outputs) or \
                other.piece.t.size != it.piece.t.size:
            continue
        truth = other.piece.truth
        if all(float(np.max(np.abs(it.outputs[k] - other.outputs[k])))
               <= SAME_FRACTION * float(np.ptp(other.outputs[k] - truth))
               for k in it.outputs):
            out.add((it.protocol, it.run))
    return out


def _segment_values(res: ScenarioResult, protocol: str, run: str):
    """Bias stability (deg/h) of every output of a scored piece over each thermal segment.

    Returns ``[(segment label, {output label: value or None})]``; empty when the run has no
    thermal program or the protocol does not score it. Paper 002 eq. 5 on 100 s means (on the
    piece's own samples when the protocol already smoothed them to 100 s means).
    """
    item = next((it for it in res.scored if it.protocol == protocol and it.run == run), None)
    if item is None or run not in res.data:
        return []
    p = item.piece
    out = []
    for name, a, b in thermal_segments(res.data[run]):
        mask = (p.t >= a) & (p.t < b)
        if mask.sum() < 3:
            continue
        vals = {}
        for lab, y in item.outputs.items():
            try:
                v = (M.std(y[mask]) if p.fs <= 0.0100001 else
                     M.bias_stability(y[mask], p.fs, 100.0)) / DPH
            except ValueError:  # a segment shorter than two 100 s windows
                v = None
            vals[lab] = v
        out.append((name, vals))
    return out


def _segment_table(res: ScenarioResult, protocol: str, run: str) -> str:
    segs = _segment_values(res, protocol, run)
    if not segs:
        return ""
    labels = list(segs[0][1])
    rows = []
    for name, vals in segs:
        cells = [name]
        for lab in labels:
            pv = _paper_value(res.plan, lab, SEGMENT_METRIC, run, name)
            cells.append(fmt(vals[lab]) + (f" ({fmt(pv.value)})" if pv else ""))
        rows.append(cells)
    return ("Bias stability B_s per thermal segment, deg/h (paper 002 eq. 5 on 100 s means; "
            "paper's Table 1/2 value in brackets where given):\n\n"
            + md_table(["segment"] + labels, rows))


def raw_segment_stability(rd, axis_j: int) -> list[tuple[str, float | None]]:
    """Bias stability of the raw output over each thermal segment of a run (paper 002, eq. 5:
    the standard deviation of the 100 s means), from every sample of the run.

    Parameters
    ----------
    rd : RunData
        The run; its thermal program gives the segments (:func:`thermal_segments`).
    axis_j : int
        Index of the sensitive axis in ``rd.fog.raw``.

    Returns
    -------
    list of (str, float or None)
        Segment label and bias stability, deg/h (None for a segment shorter than two 100 s
        means or past the end of the record).
    """
    out = []
    dur = rd.n / rd.fs
    for name, a, b in thermal_segments(rd):
        b = min(b, dur)
        try:
            v = float(M.bias_stability_segments(rd.fog.raw[:, axis_j], rd.fs, [(a, b)],
                                                100.0)[0]) / DPH if b > a else None
        except ValueError:
            v = None
        out.append((name, v))
    return out


def _kind(segment: str) -> str:
    return segment.split(" ", 1)[0]      # "hold" or "ramp"


def _mean_range(xs: list[float]) -> str:
    if not xs:
        return "–"
    return f"{np.mean(xs):.0f} ({min(xs):.0f}..{max(xs):.0f}, {len(xs)})"


def _table1_section(res: ScenarioResult) -> str:
    """The paper's per-segment raw bias stability (paper 002 Table 1) beside ours, and the
    improvement of every output per segment type (holds, ramps) beside the paper's own."""
    plan = res.plan
    runs = [r for r in res.data if any(pv.method == "raw" and pv.metric == SEGMENT_METRIC
                                       and pv.run == r and pv.segment for pv in plan.paper)]
    if not runs:
        return ""
    j = res.scenario.axes.index(plan.axis)
    ours = {r: dict(raw_segment_stability(res.data[r], j)) for r in runs}
    segs = list(ours[runs[0]])
    L = ["## Uncompensated bias stability per thermal segment (paper's Table 1 reproduced)", "",
         "Bias stability of the raw output, deg/h (paper 002 eq. 5: standard deviation of the "
         "100 s means, over every sample of the segment), ours beside the paper's Table 1 value "
         "(in brackets), with the ratio ours / paper.", ""]
    rows, ratio = _table1_rows(res, runs, segs, ours, j)
    L += [md_table(["segment"] + runs, rows), ""]
    for kind in ("hold", "ramp"):
        if ratio[kind]:
            L.append(f"- {kind}s: ours / paper {np.median(ratio[kind]):.2f} (median; "
                     f"{min(ratio[kind]):.2f}..{max(ratio[kind]):.2f} over "
                     f"{len(ratio[kind])} segments)")
    L.append("")
    L += _improvement_section(res, runs, segs)
    return "\n".join(L)


def _table1_rows(res: ScenarioResult, runs: list[str], segs: list[str], ours: dict,
                 j: int) -> tuple[list, dict]:
    """Table 1's rows (each segment, then the whole run: ours, the paper's value and the
    ratio, per run) and the ratios ours / paper by segment type."""
    plan = res.plan
    rows, ratio = [], {"hold": [], "ramp": []}
    for seg in segs + ["whole run"]:
        cells = [seg]
        for r in runs:
            if seg == "whole run":
                try:
                    v = M.bias_stability(res.data[r].fog.raw[:, j], res.data[r].fs, 100.0) / DPH
                except ValueError:
                    v = None
                pv = _paper_value(plan, "raw", SEGMENT_METRIC, r, None)
            else:
                v = ours[r].get(seg)
                pv = _paper_value(plan, "raw", SEGMENT_METRIC, r, seg)
            c = fmt(v)
            if pv is not None:
                c += f" ({fmt(pv.value)})"
                if v is not None and pv.value:
                    c += f" x{v / pv.value:.2f}"
                    if seg != "whole run":
                        ratio[_kind(seg)].append(v / pv.value)
            cells.append(c)
        rows.append(cells)
    return rows, ratio


def _improvement_section(res: ScenarioResult, runs: list[str], segs: list[str]) -> list[str]:
    """The improvement per segment type: ours (each protocol) and the paper's (Table 2 vs
    Table 1), averaged over the hold and over the ramp segments."""
    plan = res.plan
    L = ["### Improvement per segment type", "",
         "Improvement of the bias stability over the raw output in each segment, "
         "100 (1 - B_method / B_raw), averaged over the hold and over the ramp segments of the "
         "scored runs: mean (min..max, number of segments), percent. The paper's columns use its "
         "Table 2 (compensated) against its Table 1 (raw). Paper 002 (section 3.3) reports that "
         "compensation changes the hold segments little (the output is already stable there) "
         "and the ramp segments a lot; these are the numbers of that statement here. One "
         "realisation per run: no interval here.", ""]
    for prot in plan.protocols:
        imp: dict[str, dict[str, list]] = {}
        for r in runs:
            for seg, vals in _segment_values(res, prot.name, r):
                braw = vals.get("raw")
                if not braw:
                    continue
                for lab, v in vals.items():
                    if lab == "raw" or v is None:
                        continue
                    imp.setdefault(lab, {"hold": [], "ramp": []})[_kind(seg)].append(
                        100.0 * (1.0 - v / braw))
        if not imp:
            continue
        rows = []
        for lab, by in imp.items():
            paper = {"hold": [], "ramp": []}
            for r in runs:
                for seg in segs:
                    pm = _paper_value(plan, lab, SEGMENT_METRIC, r, seg)
                    pr = _paper_value(plan, "raw", SEGMENT_METRIC, r, seg)
                    if pm is not None and pr is not None and pr.value:
                        paper[_kind(seg)].append(100.0 * (1.0 - pm.value / pr.value))
            rows.append([lab, _mean_range(by["hold"]), _mean_range(by["ramp"]),
                         _mean_range(paper["hold"]), _mean_range(paper["ramp"])])
        L += [f"Protocol `{prot.name}`:", "",
              md_table(["output", "holds, ours", "ramps, ours", "holds, paper", "ramps, paper"],
                       rows), ""]
    return L


def _fit_notes(pd: dict) -> str:
    lines = ["Fits:"]
    for lab, recs in pd["fits"].items():
        for rec in recs[:1]:
            bits = [f"`{lab}`: {rec.get('status')}"]
            if rec.get("fit_time_s") is not None:
                bits.append(f"fit time {rec['fit_time_s']:.3g} s (the method's fit alone)")
            for k in ("level", "n_iter", "n_epochs", "initial_loss"):
                if k in rec:
                    bits.append(f"{k} {fmt(rec[k])}")
            if rec.get("warnings"):
                bits.append("warnings: " + "; ".join(w[:160] for w in rec["warnings"][:3]))
            if rec.get("error"):
                bits.append(f"error: {rec['error']}")
            lines.append("- " + ", ".join(bits) + (f" (first of {len(recs)} fits)"
                                                   if len(recs) > 1 else ""))
    return "\n".join(lines)
