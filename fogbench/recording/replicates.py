"""The Monte Carlo tab: each replicate's metrics on the ``replicate`` timeline, the summary
table, and a dot plot per headline metric."""

from __future__ import annotations

import math

import numpy as np

from fogbench.recording.entities import (
    _GRID,
    _MC_ROW,
    _MC_W,
    LEGEND_CHAR_W,
    REPLICATE_TIMELINE,
    _color,
    _p,
    _Writer,
)
from fogbench.recording.loglog import _decade_label, _decade_step, _nice_ticks
from fogbench.report.fmt import fmt, md_table

__all__ = ["headline_metrics"]


def headline_metrics(plan, metrics) -> list[str]:
    """The metrics of one protocol's replicates that the Monte Carlo tab plots (its headline
    metrics): every metric a claim of the scenario is about, in the order of the claims, where
    the protocol has it; else the one the report's distribution figure shows
    (:func:`fogbench.report.fmt.key_metric`); else the first. ``metrics``: ``{metric: {label:
    values}}``."""
    out: list[str] = []
    for c in getattr(plan, "claims", ()):
        if c.metric in metrics and c.metric not in out:
            out.append(c.metric)
    if not out:
        from fogbench.report.fmt import key_metric

        have = {m: True for m, labs in metrics.items() if "raw" in labs}
        km = key_metric({"over_runs": {"_": {"raw": have}}}, "_", plan)
        out = [km] if km else list(metrics)[:1]
    return out


def _log_mc_plot(w: _Writer, root: str, metric: str, cols: dict, colors) -> None:
    """A dot plot of one metric over the replicates, static 2-D entities under ``root`` (the
    origin of its view): ``cols`` ``{protocol: {label: values}}``, a column (box) per protocol
    side by side on one x scale, a row per label (the union of the protocols' labels, in their
    order, top to bottom) named left of the boxes, a dot per replicate, the 5-95 % range as a
    bar and the median as a tick. The x axis is logarithmic (decades) when every value drawn is
    positive and they span more than a factor 10, else linear. ``{root}/<protocol>/<label>``
    holds the dots at (x, row), x the value (log axis: its log10), under the transform onto its
    box; a label far from all the others (:func:`_off_scale`) has no dots there but a note,
    ``off scale: <median>``, at the box's edge (short: a column of paper002's four is about
    150 px wide in a 1280 px window, some 22 characters)."""
    rr = w.rr
    prots = list(cols)
    labels = list(dict.fromkeys(lab for pr in prots for lab in cols[pr]))
    cells = [(pr, lab, np.asarray(cols[pr][lab], float)) for pr in prots for lab in cols[pr]]
    fin = [v[np.isfinite(v)] for _, _, v in cells]
    off = _off_scale(fin)
    log, lo, hi = _mc_x_range(fin, off)
    box_h = len(labels) * _MC_ROW
    names_w = 0.1 + LEGEND_CHAR_W * max((len(x) for x in labels), default=4)
    gap = 0.15
    notes = {(pr, lab): f"off scale: {fmt(float(np.median(f)), metric)}"
             for (pr, lab, _), f, o in zip(cells, fin, off) if o and f.size}
    box_w = _mc_box_width(prots, notes, box_h, names_w, gap)
    sx = box_w / (hi - lo)
    ticks, tl = _mc_ticks(log, lo, hi, metric, len(prots))
    total_w = len(prots) * box_w + gap * (len(prots) - 1)
    _log_mc_names_and_title(w, root, metric, labels, colors, log, box_h, names_w, total_w)
    for j, pr in enumerate(prots):
        _log_mc_box(w, f"{root}/{rr.escape_entity_path_part(pr)}", pr if len(prots) > 1 else None,
                    j * (box_w + gap) - lo * sx, sx, lo, hi, ticks, tl, box_h)
    for (pr, lab, _), f, o in zip(cells, fin, off):
        path = f"{root}/{rr.escape_entity_path_part(pr)}/{rr.escape_entity_path_part(lab)}"
        _log_mc_dots(w, path, f, labels.index(lab), _color(colors, lab)[:3],
                     prots.index(pr) * (box_w + gap) - lo * sx, sx, log, lo, hi,
                     notes.get((pr, lab)) if o else None)
    w.plot_right[root] = box_h + 0.25                    # the plot's height, scene units
    w.plot_left[root] = -names_w
    w.mc_width[root] = total_w


def _mc_x_range(fin: list, off: list[bool]) -> tuple[bool, float, float]:
    """``(log, lo, hi)``: whether the x axis is logarithmic and its ends (log: whole decades
    of log10, at least one; linear: 8 % beyond the values drawn) over the finite values ``fin``
    of the labels drawn on scale."""
    on = [f for f, o in zip(fin, off) if not o]
    allv = np.concatenate(on) if on else np.zeros(0)
    if allv.size == 0:
        allv = np.zeros(1)
    log = bool(np.all(allv > 0) and allv.max() > 10.0 * allv.min())
    xs = np.log10(allv) if log else allv
    lo, hi = float(xs.min()), float(xs.max())
    if log:
        lo, hi = math.floor(lo), max(math.ceil(hi), math.floor(lo) + 1)
    else:
        pad = 0.08 * (hi - lo) if hi > lo else max(0.5 * abs(lo), 1e-9)
        lo, hi = lo - pad, hi + pad
    return log, lo, hi


def _mc_box_width(prots: list[str], notes: dict, box_h: float, names_w: float,
                  gap: float) -> float:
    """The width of each protocol's box: as wide as a plot about twice as wide as tall leaves
    beside the names, and at least as wide as its longest text (an off-scale note, the
    protocol's name under it): paper002's four columns (two protocols and their ideal twins)
    ran notes into the next column."""
    text_w = LEGEND_CHAR_W * max([len(x) for x in notes.values()]
                                 + [len(pr) if len(prots) > 1 else 0 for pr in prots]) + 0.06
    return max(_MC_W / len(prots) + 0.3, text_w,
               (2.0 * (box_h + 0.35) - names_w - gap * (len(prots) - 1)) / len(prots))


def _mc_ticks(log: bool, lo: float, hi: float, metric: str,
              n_prots: int) -> tuple[list[float], list[str]]:
    """The x ticks of a Monte Carlo plot and their labels ("" for a tick left unlabelled):
    every decade of a log axis, a few labelled; else a few nice values."""
    if log:
        k = _decade_step(hi - lo)
        ticks = [float(d) for d in range(int(lo), int(hi) + 1)]
        tl = [_decade_label(int(d)) if (int(d) - int(lo)) % k == 0 else "" for d in ticks]
    else:
        ticks = _nice_ticks(lo, hi, 4 if n_prots > 1 else 5)
        tl = [fmt(t, metric) for t in ticks]
    return ticks, tl


def _log_mc_names_and_title(w: _Writer, root: str, metric: str, labels: list[str], colors,
                            log: bool, box_h: float, names_w: float, total_w: float) -> None:
    """The row names left of the boxes, in the labels' colours, and the title above them."""
    rr, rec = w.rr, w.rec
    rec.log(f"{root}/names", rr.Points2D(
        [(-0.06 - 0.5 * LEGEND_CHAR_W * len(x), (i + 0.5) * _MC_ROW)
         for i, x in enumerate(labels)],
        labels=labels, colors=[_color(colors, x)[:3] for x in labels],
        radii=rr.Radius.ui_points(0.1), show_labels=True), static=True)
    rec.log(f"{root}/title", rr.Points2D(
        [(0.5 * (total_w - names_w), box_h + 0.17)],
        labels=[f"{metric}{' (log scale)' if log else ''}: a dot per replicate, bar 5-95 %, "
                "tick median"], colors=[(128, 128, 128)], radii=rr.Radius.ui_points(0.1),
        show_labels=True), static=True)


def _log_mc_box(w: _Writer, base: str, name: str | None, shift: float, sx: float, lo: float,
                hi: float, ticks: list[float], tl: list[str], box_h: float) -> None:
    """One protocol's box under ``base``: the transform of its x values onto it (``shift``,
    ``sx``), its grid and tick labels, and ``name`` under it (None: one protocol, unnamed)."""
    rr, rec = w.rr, w.rec
    tf = rr.Transform3D(translation=[shift, 0.0, 0.0], scale=[sx, 1.0, 1.0])
    rec.log(f"{base}/axes", tf, static=True)
    rec.log(f"{base}/axes/grid", rr.LineStrips2D(
        [[(t, 0.0), (t, box_h)] for t in ticks]
        + [[(lo, 0.0), (hi, 0.0)], [(lo, box_h), (hi, box_h)]],
        colors=[_GRID], radii=rr.Radius.ui_points(0.5), draw_order=0.0), static=True)
    pos = [(t, box_h + 0.06) for t, x in zip(ticks, tl) if x]
    txt = [x for x in tl if x]
    if name is not None:
        pos.append(((lo + hi) / 2.0, -0.07))
        txt.append(name)
    rec.log(f"{base}/axes/labels", rr.Points2D(
        pos, labels=txt, radii=rr.Radius.ui_points(0.1), colors=[(128, 128, 128)],
        show_labels=True, draw_order=1.0), static=True)


def _log_mc_dots(w: _Writer, path: str, f: np.ndarray, i: int, c, shift: float, sx: float,
                 log: bool, lo: float, hi: float, note: str | None) -> None:
    """One label of one protocol at ``path``, row ``i``: the transform onto its box, and its
    finite values ``f`` as dots, the 5-95 % bar and the median tick; or, off scale, ``note``
    at the box's edge on the median's side."""
    rr, rec = w.rr, w.rec
    y = (i + 0.5) * _MC_ROW
    rec.log(path, rr.Transform3D(translation=[shift, 0.0, 0.0], scale=[sx, 1.0, 1.0]),
            static=True)
    if f.size == 0:
        return
    x = np.log10(f) if log else f
    if note is not None:
        med = float(np.median(f))
        left = (math.log10(med) if log and med > 0 else med) < lo
        rec.log(f"{path}/off_scale", rr.Points2D(
            [(lo + (0.5 * LEGEND_CHAR_W * len(note)) / sx if left
              else hi - (0.5 * LEGEND_CHAR_W * len(note)) / sx, y)],
            labels=[note], colors=[c], radii=rr.Radius.ui_points(0.1),
            show_labels=True, draw_order=20.0), static=True)
        return
    rec.log(path, rr.Points2D(np.column_stack([x, np.full(x.size, y)]), colors=[c],
                              radii=rr.Radius.ui_points(3.0), draw_order=10.0 + i),
            static=True)
    q5, q50, q95 = np.percentile(x, [5, 50, 95])
    rec.log(f"{path}/range", rr.LineStrips2D(
        [[(q5, y), (q95, y)], [(q50, y - 0.4 * _MC_ROW), (q50, y + 0.4 * _MC_ROW)]],
        colors=[c], radii=[rr.Radius.ui_points(1.0), rr.Radius.ui_points(2.0)],
        draw_order=9.0 + i), static=True)


def _off_scale(fin: list) -> list[bool]:
    """Which labels of a Monte Carlo plot are drawn off scale (named with their median, no
    dots), so that the axis spans the labels that are close and their differences show: with
    at least 4 labels, those whose median lies beyond Tukey's far fences (3 interquartile
    ranges outside the quartiles) of the labels' medians and farther from the other labels'
    values than those values span (drawing it would at least halve the scale of the rest); on
    log10 of the values when all are positive."""
    med = np.array([np.median(f) if f.size else np.nan for f in fin])
    ok = np.isfinite(med)
    if ok.sum() < 4:
        return [False] * len(fin)
    pos = bool(all(np.all(f > 0) for f in fin if f.size))
    tr = (lambda a: np.log10(a)) if pos else (lambda a: a)
    m = tr(np.where(ok, med, 1.0))
    q1, q3 = np.percentile(m[ok], [25, 75])
    iqr = q3 - q1
    if not iqr > 0:
        return [False] * len(fin)
    cand = [bool(k and (x < q1 - 3.0 * iqr or x > q3 + 3.0 * iqr)) for k, x in zip(ok, m)]
    rest = [tr(f) for f, c in zip(fin, cand) if f.size and not c]
    if not rest:
        return [False] * len(fin)
    lo, hi = min(float(r.min()) for r in rest), max(float(r.max()) for r in rest)
    return [c and max(lo - x, x - hi) > (hi - lo) for c, x in zip(cand, m)]


def _log_replicates(w: _Writer, reps: dict, colors, plan=None) -> None:
    rr, rec = w.rr, w.rec
    # one plot per headline metric, a column per protocol that has it
    by_metric: dict[str, dict] = {}
    for prot, metrics in reps.items():
        for metric in headline_metrics(plan, metrics):
            by_metric.setdefault(metric, {})[prot] = metrics[metric]
    for metric, cols in by_metric.items():
        root = _p("report", "replicates", metric)
        _log_mc_plot(w, root, metric, cols, colors)
        w.mc_plots[metric] = root
        for prot in cols:
            w.mc_plotted.add((prot, metric))
    rows = []
    for prot, metrics in reps.items():
        for metric, labels in metrics.items():
            for lab, v in labels.items():
                path = _p("replicates", prot, metric, lab)
                rec.log(path, rr.SeriesPoints(names=lab, colors=[_color(colors, lab)],
                                              markers=["circle"], marker_sizes=[3.0]),
                        static=True)
                idx = np.flatnonzero(np.isfinite(v))
                if idx.size:
                    rec.send_columns(path, indexes=[rr.TimeColumn(REPLICATE_TIMELINE,
                                                                  sequence=idx)],
                                     columns=rr.Scalars.columns(scalars=v[idx]))
                f = v[np.isfinite(v)]
                if f.size:
                    q = np.percentile(f, [50, 5, 95])
                    row = [fmt(float(q[0]), metric),
                           f"{fmt(float(q[1]), metric)} to {fmt(float(q[2]), metric)}",
                           f"{f.size}/{v.size}", lab]
                else:
                    row = ["–", "–", f"0/{v.size}", lab]
                rows.append((prot, metric, row))
    # one table per protocol and metric, the headline metrics (those plotted) first; the
    # numbers first, the label last: long labels do not push the numbers off the panel
    head = ["median", "5-95 %", "finite", "label"]
    text = ["# Monte Carlo: the distribution over replicates", "",
            "Every other tab shows one representative replicate in full. Here: the headline "
            "metrics (those the claims are about) over the replicates, a plot each, and every "
            "metric's median and 5-95 % range below (each replicate's value is also on the "
            f"`{REPLICATE_TIMELINE}` timeline, entities `/replicates/...`).", ""]
    order = [(prot, m) for prot, metrics in reps.items() for m in headline_metrics(plan, metrics)]
    order += [(prot, m) for prot, metrics in reps.items() for m in metrics
              if (prot, m) not in order]
    for prot, metric in order:
        star = " (plotted)" if (prot, metric) in w.mc_plotted else ""
        text += [f"### `{prot}`: `{metric}`{star}", "",
                 md_table(head, [r for p_, m_, r in rows if (p_, m_) == (prot, metric)]), ""]
    rec.log("/replicates/summary", rr.TextDocument("\n".join(text), media_type="text/markdown"),
            static=True)


def _n_reps(reps: dict) -> int:
    return max((len(v) for m in reps.values() for labs in m.values() for v in labs.values()),
               default=0)
