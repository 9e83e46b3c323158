"""Run directories: metrics.json, report.md with PNG figures, and the data.

Figures are drawn with matplotlib's Agg backend. Long records are decimated for display only
(the report says so); every metric is computed on the full record.
"""

from __future__ import annotations

import dataclasses
import io
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fogcomp import metrics as M  # noqa: E402
from fogcomp.allan import oadev_ci  # noqa: E402
from fogcomp.units import DPH, DPS  # noqa: E402

from .fmt import (key_metric, KEY_METRICS, ci_text, decimation, fmt, md_table,  # noqa: E402
                  metrics_table, p_better_text)
from .io import atomic_write_bytes, atomic_write_text, run_arrays, save_figure as _save, versions  # noqa: E402
from . import palette as PAL  # noqa: E402
from .views import (DWARF, SAME_FRACTION, kept_alike as _kept_alike,  # noqa: E402
                    mean_blind, method_entries as _method_entries,
                    moving_mean as _moving_mean, offsets_only, shown_error as _shown_error, sweep_names as _sweep_names)
from .claim_figures import (SETUP_HEADING, draw_claim_figures, open_on_answer,  # noqa: E402
                            takeaway, unit_of, verdict_link)
from .outdir import as_final, check_out_dir, discard_part, new_part_dir, replace_dir  # noqa: E402
from .runner import ScenarioResult, TERM_NAMES, thermal_segments, write_metrics  # noqa: E402

__all__ = ["write_run_dir", "dwells", "dwell_means", "raw_segment_stability"]

MAX_PLOT_POINTS = 4000
PSD_DECADES_BELOW_RAW = 6      # PSD axis: at most this many decades below the raw/oracle floor
PSD_MAX_DECADES = 10           # ... and never more than this many decades in all
# colours, line styles and units: fogbench.palette, shared with the recording
COLORS = {"raw": PAL.mpl(PAL.RAW), "oracle": PAL.mpl(PAL.ORACLE), "truth": PAL.mpl(PAL.TRUTH)}
NOT_IDENTIFIED = "not identified"


def _color(label: str, labels: list[str], plan=None):
    """The colour of ``label`` (matplotlib floats): its method family's shade
    (:func:`fogbench.palette.plan_styles` of the scenario's plan; without a plan every label is
    its own family)."""
    if label in ("raw", "oracle", "truth"):
        return COLORS[label]
    return PAL.mpl(PAL.rgb(PAL.plan_styles(plan, labels), label))


def _styles(labels: list[str], widest: float = 3.2, thinnest: float = 1.0,
            markers: bool = False, dashed_raw: bool = True, plan=None) -> dict[str, dict]:
    """Line properties of every output, so that none hides another.

    Curves are stacked oracle (bottom), raw, then the methods in their order; each is drawn
    narrower than every curve below it, so where two curves coincide (raw and oracle at short
    taus, two identical least-squares models) the upper one runs inside the lower one and both
    stay visible. Raw is also dashed (the oracle shows between its dashes) and, with
    ``markers``, carries open circles where oracle has filled dots.

    Colours and the line styles of the members of a method family come from
    :func:`fogbench.palette.plan_styles` (``plan``: the scenario's; None: every label its own
    family).

    Returns
    -------
    dict
        label -> keyword arguments for ``Axes.plot`` (color, lw, ls, zorder, and marker keys).
    """
    order = [x for x in ("oracle", "raw") if x in labels] + \
        [x for x in labels if x not in ("oracle", "raw")]
    pal = PAL.plan_styles(plan, labels)
    n = len(order)
    out = {}
    for i, lab in enumerate(order):
        lw = widest - (widest - thinnest) * (i / (n - 1) if n > 1 else 0.0)
        ps = pal.get(lab)
        st = {"color": PAL.mpl(PAL.rgb(pal, lab)), "lw": lw,
              "ls": ps.dash if ps is not None and lab not in ("raw", "oracle") else "-",
              "zorder": 2.0 + 0.1 * i}
        if lab == "raw" and dashed_raw:
            st["ls"] = (0, (4, 2))
        if markers and lab == "raw":
            st.update(marker="o", ms=6, mfc="none", mew=1.0)
        elif markers and lab == "oracle":
            st.update(marker="o", ms=3.5)
        out[lab] = st
    return out


def _decimate(t, *ys):
    step = decimation(t.size, MAX_PLOT_POINTS)
    return (t[::step],) + tuple(y[::step] for y in ys), step


DWELL_TRUTH_PTP = 0.01 * DPH   # true rate within this of its median: a static dwell


def dwells(t: np.ndarray, fs: float) -> list[slice]:
    """The blocks of consecutive samples of a piece, split where the time jumps by more than
    1.5 sample intervals (the gaps a multi-position test leaves between its dwells).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times, s.
    fs : float
        Sample rate of the piece, Hz.
    """
    cuts = [0] + list(np.flatnonzero(np.diff(t) > 1.5 / fs) + 1) + [t.size]
    return [slice(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def dwell_means(t: np.ndarray, y: np.ndarray, fs: float):
    """Per-dwell mean, its standard error and mid time of a piece made of static dwells.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times, s.
    y : ndarray, shape (n,)
        Rate (any unit; the mean and standard error come out in it).
    fs : float
        Sample rate, Hz.

    Returns
    -------
    t_mid, mean, sem : ndarray, shape (k,)
        Mid time of each of the k dwells (s), mean of ``y`` over it and the standard error of
        that mean, ``std(ddof=1) / sqrt(samples)`` (0 for a dwell of one sample). The standard
        error treats the samples as independent: for correlated noise it is a lower bound.
    """
    blocks = dwells(t, fs)
    t_mid = np.array([0.5 * (t[b][0] + t[b][-1]) for b in blocks])
    mean = np.array([np.mean(y[b]) for b in blocks])
    sem = np.array([np.std(y[b], ddof=1) / math.sqrt(y[b].size) if y[b].size > 1 else 0.0
                    for b in blocks])
    return t_mid, mean, sem


def _is_dwell_piece(p) -> bool:
    """A piece of at least two static dwells separated by gaps (a multi-position test): in each
    block at least 80 % of the samples have the true rate within DWELL_TRUTH_PTP of the block's
    median (the first samples of a dwell may still carry the table's settling)."""
    blocks = dwells(p.t, p.fs)
    return len(blocks) >= 2 and all(
        np.mean(np.abs(p.truth[b] - np.median(p.truth[b])) < DWELL_TRUTH_PTP) >= 0.8
        for b in blocks)


def _min_span(ax, unit: str) -> None:
    """Widen the y axis to the palette's least span of ``unit`` (fogbench.palette.MIN_SPAN)."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(*PAL.min_span(lo, hi, unit))


# ---------------------------------------------------------------------------------------------
# Views that show the effect (issue 26): sweeps as envelopes, at most MAX_LINES lines a panel,
# raw in its own panel when it dwarfs the methods, what every output keeps alike taken out
MAX_LINES = 8        # lines in one panel at most; more methods are split over more panels
TS_METHOD_LINES = 4  # a time series panel: at most this many methods' (noisy) traces beside
#                      raw and oracle, whole families together
LEGEND = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "fontsize": 8,
          "borderaxespad": 0.0}      # right of the data


def _chunks(entries: list[dict], capacity: int, plan=None) -> list[list[dict]]:
    """``entries`` (in family order) split into panels of at most ``capacity`` lines: each
    family whole into the first panel it fits in (first fit), a family larger than a panel
    split over panels of its own."""
    if not entries:
        return [[]]
    capacity = max(1, capacity)
    pal = PAL.plan_styles(plan, [e["default"] for e in entries])
    fams: list[list[dict]] = []
    for e in entries:
        f = pal[e["default"]].family
        if fams and pal[fams[-1][0]["default"]].family == f:
            fams[-1].append(e)
        else:
            fams.append([e])
    out: list[list[dict]] = []
    for fam in fams:
        while fam:
            room = next((c for c in out if len(c) + len(fam) <= capacity), None)
            if room is not None:        # the first panel it fits in whole
                room += fam
                fam = []
            else:
                out.append(fam[:capacity])
                fam = fam[capacity:]
    return out


def _draw_entry(ax, x, curves: dict, e: dict, sty: dict, **kw):
    """One entry on ``ax``: a method's line, or a sweep's envelope (at every x the best and the
    worst of its members' ``curves``, filled, ``gid`` ``envelope:<group>``) with its default
    setting's line. Returns the lines drawn."""
    d = e["default"]
    st = {**sty[d], **kw}
    if e["group"] is None:
        return ax.plot(x, curves[d], label=d, **st)
    stack = np.vstack([curves[m] for m in e["members"]])
    import warnings

    with warnings.catch_warnings():     # a tau no member reaches: NaN, not drawn
        warnings.simplefilter("ignore", RuntimeWarning)
        lo, hi = np.nanmin(stack, axis=0), np.nanmax(stack, axis=0)
    default_name, envelope_name = _sweep_names(e)
    ax.fill_between(x, lo, hi, color=st["color"], alpha=0.3, lw=0, zorder=1.5,
                    gid=f"envelope:{e['group']}", label=envelope_name)
    st["ls"] = "-"
    return ax.plot(x, curves[d], label=default_name, **st)


def _span(curves) -> tuple[float, float]:
    vals = [np.asarray(c)[np.isfinite(c)] for c in curves]
    vals = [v for v in vals if v.size]
    if not vals:
        return 0.0, 0.0
    return min(float(v.min()) for v in vals), max(float(v.max()) for v in vals)


def _dwarfing_entries(entries: list[dict], cur: dict) -> list[dict]:
    """The entries (methods, sweeps) whose errors dwarf the rest's: the fewest widest entries
    whose removal leaves the span of all more than DWARF times the span of those left (a family
    of filters that lag together, kalman and kalman_rts, goes out together), each of them
    spanning more than twice what is left; at least one entry is always left, none goes out
    when no such set exists."""
    def span(es):
        a, b = _span([cur[m] for e in es for m in e["members"]])
        return b - a

    if len(entries) < 2:
        return []
    whole = span(entries)
    order = sorted(entries, key=lambda e: span([e]), reverse=True)
    for k in range(1, len(order)):
        rest = max(span(order[k:]), 1e-300)
        # and a gap: each entry taken out spans at least twice what is left (else, with
        # entries of similar sizes, the last one alone would always be "dwarfed")
        if whole > DWARF * rest and span([order[k - 1]]) > 2.0 * rest \
                and rest > 1e-6 * whole:    # (a numerically constant rest: nothing to zoom to)
            return order[:k]
    return []


def fig_timeseries(it, path: Path, plan=None) -> int:
    """The error of every output against the truth (deg/h) where the methods differ, against
    the time since power-on (s, or h past fogbench.palette.HOURS_ABOVE_S).

    Panels, top to bottom: raw output and truth (deg/s); raw's error as it is (and the
    oracle's when it dwarfs the methods), with its moving mean, when it dwarfs the methods'
    errors (an axis holding both would span more than DWARF times the methods' errors) or when
    something every output keeps alike is taken out below (:func:`_kept_alike`); then the
    methods' errors, zoomed to them (raw and oracle beside them where they do not dwarf them),
    at most TS_METHOD_LINES methods a panel, whole families together (more methods: more
    panels, one y range), a sweep as its envelope with the default setting's line."""
    if _is_dwell_piece(it.piece):
        fig_dwells(it, path, plan=plan)
        return 1
    p = it.piece
    ts, tname = PAL.time_unit(float(p.t[-1]))
    labels = list(it.outputs)
    entries = _method_entries(labels, plan)
    methods = [m for e in entries for m in e["members"]]
    errs = {lab: (it.outputs[lab] - p.truth) / DPH for lab in labels}
    kind, trend, k = _kept_alike(errs, methods)
    centre = mean_blind(plan, it.run)
    shown = {lab: _shown_error(kind, e, trend, k, centre) for lab, e in errs.items()}
    (t, truth, raw_out, *dec), step = _decimate(p.t / ts, p.truth, p.raw,
                                                *[shown[lab] for lab in labels])
    cur = dict(zip(labels, dec))
    # a method whose error dwarfs the others' (dynamic_rates' Kalman filters smoothing away a
    # 5 Hz sine: +-5000 deg/h against the denoisers' +-300) gets panels of its own, so that
    # the zoom holds the rest
    loud = _dwarfing_entries(entries, cur)
    quiet = [e for e in entries if e not in loud]
    methods = [m for e in quiet for m in e["members"]]
    lo, hi = _span([cur[m] for m in methods])
    width = hi - lo

    def dwarfs(lab):        # the axis holding it and the methods spans DWARF x the methods'
        a, b = _span([cur[lab]])   # (methods within the unit's minimum span of each other,
        #                            bias_lab's three equal bias fits: nothing to zoom to)
        return bool(methods) and width >= PAL.MIN_SPAN[PAL.ERROR_UNIT] and \
            max(b, hi) - min(a, lo) > DWARF * max(width, 1e-300)

    big = [lab for lab in ("raw", "oracle") if lab in cur and dwarfs(lab)]
    fixed = [lab for lab in ("raw", "oracle") if lab in cur and lab not in big]
    lo, hi = _span([cur[m] for m in methods + fixed])   # the zoom: methods, and raw/oracle
    width = hi - lo                                      # where they do not dwarf them
    ref_panel = bool(big) or kind is not None or centre
    # the oracle where it lies on raw (the true terms a constant, taken out with the mean)
    under_raw = {"oracle": "oracle (on raw here)"} if {"raw", "oracle"} <= set(fixed) and \
        np.max(np.abs(cur["oracle"] - cur["raw"])) <= SAME_FRACTION * max(width, 1e-300) else {}
    cap = min(TS_METHOD_LINES, MAX_LINES - len(fixed))
    panels = [(c, False) for c in _chunks(quiet, cap, plan)] + \
        ([(c, True) for c in _chunks(loud, cap, plan)] if loud else [])
    # a static piece (the true rate constant): a rate panel in deg/s would show a flat line
    # over noise of a few deg/h; the title gives the true rate and the error panels start
    static = bool(p.truth.size) and float(np.ptp(p.truth)) <= DWELL_TRUTH_PTP
    n_ax = int(not static) + int(ref_panel) + len(panels)
    fig, axes = plt.subplots(n_ax, 1, figsize=(10.5, 2.1 + 2.3 * (n_ax - 1)), sharex=True,
                             squeeze=False)
    if centre:          # the methods' panel's title runs to two lines
        fig.subplots_adjust(hspace=0.35)
    axes = list(axes[:, 0])
    sty = _styles(labels, widest=1.6, thinnest=0.8, dashed_raw=False, plan=plan)
    head = f"{it.protocol} / {it.run}: "
    if not static:
        ax = axes.pop(0)
        if "raw" in it.outputs:
            ax.plot(t, raw_out / DPS, label="raw", alpha=0.85, **sty["raw"])
        ax.plot(t, truth / DPS, color=COLORS["truth"], lw=1.4, ls="--", label="truth",
                zorder=10)
        ax.set_ylabel(f"rate, {PAL.RATE_UNIT}", fontsize=9)
        _min_span(ax, PAL.RATE_UNIT)
        ax.legend(**LEGEND)
        ax.set_title(head + "raw output and truth; below, the error against the truth",
                     fontsize=10)
        head = ""
    else:
        head += (f"a static record (true rate {float(np.mean(p.truth)) / DPH:.4g} deg/h "
                 "throughout): the error against the truth\n")
    if ref_panel:
        ax = axes.pop(0)
        # the errors as they are, and raw's k-sample moving mean: what the panels below take
        # out (kind "trend") or show (kind "fast")
        for lab in ("oracle", "raw"):
            if lab in big or (lab == "raw" and (kind is not None or centre)) or \
                    (lab == "oracle" and centre):
                ax.plot(t, errs[lab][::step], label=f"{lab}", alpha=0.85, **sty[lab])
        if kind is not None and "raw" in errs:
            ax.plot(t, _moving_mean(errs["raw"], k)[::step], color="black", lw=1.2, zorder=9,
                    label=f"raw's {k}-sample moving mean"
                          + {"trend": "; less its mean, taken out below",
                             "both": "; the panels below draw each curve's, less this "
                                     "about its mean"}.get(
                                 kind, "; the panels below draw each curve's"))
        ax.set_ylabel(f"error, {PAL.ERROR_UNIT}", fontsize=9)
        _min_span(ax, PAL.ERROR_UNIT)
        ax.legend(**LEGEND)
        if head:
            ax.set_title(head.rstrip("\n") + "; here as it is", fontsize=10)
            head = ""
    pad = 0.05 * max(width, 1e-12)
    what = {"trend": "error - raw's trend", "fast": f"error, {k}-sample mean",
            "both": "moving mean - raw's trend"}.get(kind, "error vs truth") \
        + (",\nless its mean" if centre else "")
    dt = k / p.fs
    note = {"trend": "; raw's slow variation about its mean taken out of every curve: no "
                     "method removes it",
            "fast": f"; {k}-sample ({dt:.3g} s) moving means: every method keeps raw's faster "
                    "noise",
            "both": f"; {k}-sample ({dt:.3g} s) moving means less raw's slow variation: every "
                    "method keeps raw's noise, fast and slow"}.get(kind, "") \
        + ("\neach curve less its own mean (the claims on this run score the std, blind to "
           "it)" if centre else "")
    for i, (chunk, is_loud) in enumerate(panels):
        ax = axes[i]
        for lab in fixed:
            ax.plot(t, cur[lab], label=under_raw.get(lab, lab), alpha=0.85, **sty[lab])
        for e in chunk:
            _draw_entry(ax, t, cur, e, sty, alpha=0.9)
        if is_loud:
            a, b = _span([cur[m] for e in chunk for m in e["members"]] +
                         [cur[lab] for lab in fixed])
            ax.set_ylim(a - 0.05 * (b - a), b + 0.05 * (b - a))
            ax.set_title("off the scale above: " + ", ".join(
                m for e in chunk for m in e["members"]), fontsize=9)
        elif methods:
            ax.set_ylim(lo - pad, hi + pad)
        _min_span(ax, PAL.ERROR_UNIT)
        # two lines: "error, 10-sample mean, deg/h" on one ran into the next panel's label
        ax.set_ylabel(f"{what},\n{PAL.ERROR_UNIT}", fontsize=9)
        ax.legend(**LEGEND)
        if i == 0:
            ax.set_title(head + "methods' error, zoomed to them"
                         + (f" ({', '.join(big)} above: off this scale)" if big else "")
                         + note, fontsize=9)
    fig.axes[-1].set_xlabel(f"time since power-on, {tname}")
    _save(fig, path)
    return step


DWELL_BARS_MAX = 40      # dwells: above this many, means as lines without error bars
DWELL_MARKERS = ("o", "^", "v", "P", "X", "h")   # a family's members, in member order


def fig_dwells(it, path: Path, plan=None) -> None:
    """A multi-position test, per dwell in time order, deg/h: the raw dwell means over the true
    rate (the positions); raw's and the oracle's dwell-mean error; then the methods'
    dwell-mean errors zoomed to them (the oracle beside them unless it dwarfs them), at most
    TS_METHOD_LINES methods a panel, whole families together. Up to DWELL_BARS_MAX dwells
    each mean has its standard error as a bar; beyond that the means are joined by lines and
    the methods' panels draw each method's dwell means less the oracle's (the oracle the zero
    line): for a model of the deterministic terms, the error it leaves without the noise all
    outputs share (a denoiser's difference also holds the noise it took out). The
    members of a method family share its hue and differ in marker (DWELL_MARKERS): paper004's
    flnn_recorded and flnn_shuffled were two dark greens of one dot."""
    p = it.piece
    labels = list(it.outputs)
    entries = _method_entries(labels, plan)
    methods = [m for e in entries for m in e["members"]]
    sty = _styles(labels, widest=1.6, thinnest=0.8, dashed_raw=False, plan=plan)
    member = {lab: st.member for lab, st in PAL.plan_styles(plan, labels).items()}
    _, truth_mean, _ = dwell_means(p.t, p.truth, p.fs)
    k = truth_mean.size
    x = np.arange(1, k + 1)
    bars = k <= DWELL_BARS_MAX
    err, sem = {}, {}
    for lab in labels:
        _, e, se = dwell_means(p.t, it.outputs[lab] - p.truth, p.fs)
        err[lab], sem[lab] = e / DPH, se / DPH
    # beyond DWELL_BARS_MAX dwells the methods' noisy means tangle (thermal_with_motion's 133):
    # their panels draw each method's dwell mean less the oracle's, the deterministic error it
    # leaves, which holds no noise for a model of the terms (method - oracle = true terms -
    # the method's estimate; a denoiser's difference also holds the noise it took out)
    less_oracle = not bars and "oracle" in err and bool(methods)
    if less_oracle:
        err = {lab: (e - err["oracle"] if lab in methods else e) for lab, e in err.items()}

    def reach(lab):     # what a label's marks reach: its means and, with bars, their ends
        return [err[lab] - sem[lab], err[lab] + sem[lab]] if bars else [err[lab]]

    lo, hi = _span([y for m in methods for y in reach(m)])
    o_lo, o_hi = _span(reach("oracle")) if "oracle" in err else (lo, hi)
    oracle_in = not less_oracle and "oracle" in err and bool(methods) and \
        max(o_hi, hi) - min(o_lo, lo) <= DWARF * max(hi - lo, 1e-300)
    panels = _chunks(entries, TS_METHOD_LINES, plan) if methods else []
    n_ax = 2 + len(panels)
    fig, axes = plt.subplots(n_ax, 1, figsize=(10.5, 1.2 + 2.4 * n_ax), sharex=True,
                             squeeze=False)
    axes = list(axes[:, 0])

    def draw(ax, lab, y, se, dx=0.0):
        kw = dict(color=sty[lab]["color"], zorder=sty[lab]["zorder"],
                  marker={"raw": "D", "oracle": "s"}.get(lab) or
                  DWELL_MARKERS[member.get(lab, 0) % len(DWELL_MARKERS)],
                  mfc="none" if lab == "raw" else sty[lab]["color"], label=lab)
        if bars:
            ax.errorbar(x + dx, y, yerr=se, ms=4, capsize=2, elinewidth=0.8, ls="none", **kw)
        else:
            ax.plot(x, y, ms=2.5, lw=0.8, alpha=0.9, **kw)

    ax = axes[0]
    ax.plot(x, truth_mean / DPH, "_", color=COLORS["truth"], ms=max(4, min(18, 500 // k)),
            mew=2, label="truth", zorder=10)
    if "raw" in it.outputs:
        _, raw_mean, raw_sem = dwell_means(p.t, it.outputs["raw"], p.fs)
        draw(ax, "raw", raw_mean / DPH, raw_sem / DPH)
    ax.set_ylabel("dwell mean rate,\ndeg/h", fontsize=9)
    ax.set_title(f"{it.protocol} / {it.run}: each static dwell's mean ({k} dwells; "
                 + ("bars: standard error of the mean)" if bars else
                    f"more than {DWELL_BARS_MAX}: means joined, no bars)"), fontsize=10)
    ax.legend(**LEGEND)
    ax = axes[1]
    refs = [lab for lab in ("raw", "oracle") if lab in err]
    width = 0.3 if bars else 0.0
    for i, lab in enumerate(refs):
        draw(ax, lab, err[lab], sem[lab], (i - (len(refs) - 1) / 2) * width)
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.set_ylabel("dwell mean error,\ndeg/h", fontsize=9)
    ax.legend(**LEGEND)
    pad = 0.08 * max(hi - lo, 1e-12)
    for ax, chunk in zip(axes[2:], panels):
        shown = (["oracle"] if oracle_in else []) + [m for e in chunk for m in e["members"]]
        width = 0.7 / max(1, len(shown)) if bars else 0.0
        for i, lab in enumerate(shown):
            draw(ax, lab, err[lab], sem[lab], (i - (len(shown) - 1) / 2) * width)
        if less_oracle:
            ax.axhline(0.0, color=COLORS["oracle"], lw=1.2, zorder=1.5,
                       label="oracle (0: what is taken out)")
        else:
            ax.axhline(0.0, color="0.7", lw=0.5)
        ax.set_ylim(min(lo, o_lo if oracle_in else lo) - pad,
                    max(hi, o_hi if oracle_in else hi) + pad)
        ax.set_ylabel("dwell mean error\n- oracle's, deg/h" if less_oracle else
                      "dwell mean error,\ndeg/h", fontsize=9)
        ax.legend(**LEGEND)
    if len(axes) > 2:
        axes[2].set_title(
            "methods' dwell-mean error less the oracle's: the deterministic error each leaves, "
            "without the noise they share, zoomed to them" if less_oracle else
            "methods' dwell-mean error, zoomed to them"
            + ("" if oracle_in or "oracle" not in err else
               " (the oracle, above, is off this scale)"), fontsize=9)
    axes[-1].set_xlabel("dwell (position) number, in time order")
    _save(fig, path)


def _psd_ylim(curves: dict[str, np.ndarray]) -> tuple[float, float]:
    """The PSD range that matters: from PSD_DECADES_BELOW_RAW decades below the lowest raw or
    oracle value (a compensator removing more than that is off the scale anyway) up to the top,
    never more than PSD_MAX_DECADES decades; a curve that falls to numerical zero (a smoother's
    output) does not stretch the axis."""
    pos = {k: v[np.isfinite(v) & (v > 0)] for k, v in curves.items()}
    top = max(float(np.max(v)) for v in pos.values() if v.size) * 2.0
    refs = [float(np.min(pos[k])) for k in ("raw", "oracle") if k in pos and pos[k].size]
    low = min(float(np.min(v)) for v in pos.values() if v.size) / 2.0
    if refs:
        low = max(low, min(refs) * 10.0 ** -PSD_DECADES_BELOW_RAW)
    low = max(low, top * 10.0 ** -PSD_MAX_DECADES)
    return low, top


def _log_ticks(ax) -> None:
    """Tick labels of a log-log panel that never collide: minor ticks unlabelled (matplotlib
    labels them on an axis spanning about a decade, where paper002's PSD printed 3x10^-4 into
    4x10^-4); an axis spanning under LOG_LABEL_DECADES decades gets majors at 1, 2 and 5 per
    decade instead, so that it keeps at least two labels."""
    from matplotlib import ticker

    for axis, lim in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        lo, hi = sorted(lim)
        if axis.get_scale() != "log" or not lo > 0:
            continue
        if math.log10(hi / lo) < LOG_LABEL_DECADES:
            axis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(ticker.LogFormatterSciNotation(   # every major labelled
            labelOnlyBase=False, minor_thresholds=(math.inf, math.inf)))
        axis.set_minor_formatter(ticker.NullFormatter())


LOG_LABEL_DECADES = 2.0


def fig_psd(it, path: Path, plan=None):
    """PSD of each output's error against the truth (mean removed), (deg/h)^2/Hz, averaged in
    fogbench.palette.PSD_PER_DECADE log-spaced bands (fogcomp.metrics.psd_bands: Welch, Hann, 8 half-overlapping
    segments), with each band's one-sigma chi-square interval from its EDF as a band around raw,
    oracle and each method's (default) line; a sweep as the envelope of its members' spectra
    with its default's line, at most MAX_LINES lines a panel (raw and oracle in each)."""
    p = it.piece
    labels = list(it.outputs)
    sty = _styles(labels, markers=True, plan=plan)
    curves, ints = {}, {}
    for lab, y in it.outputs.items():
        e = (y - p.truth) / DPH
        f, s, edf = M.psd_bands(e, p.fs, per_decade=PAL.PSD_PER_DECADE)
        curves[lab] = s
        ints[lab] = M.psd_band_interval(s, edf, ALLAN_CI)
    lo, hi = _psd_ylim(curves)
    fixed = [lab for lab in ("raw", "oracle") if lab in labels]
    panels = _chunks(_method_entries(labels, plan), MAX_LINES - len(fixed), plan)
    fig, axes = plt.subplots(len(panels), 1, figsize=(9.2, 0.8 + 3.9 * len(panels)),
                             sharex=True, sharey=True, squeeze=False)
    shown = {lab: np.where(s > 0, s, np.nan) for lab, s in curves.items()}

    def band(ax, lab):
        low, high = ints[lab]
        ax.fill_between(f, np.maximum(low, lo), high, color=sty[lab]["color"], alpha=0.13,
                        lw=0, zorder=1.0)

    for ax, chunk in zip(axes[:, 0], panels):
        ax.set_xscale("log")
        ax.set_yscale("log")
        for lab in fixed:
            ax.plot(f, shown[lab], **sty[lab], label=lab)
            band(ax, lab)
        for e in chunk:
            below = any(bool(np.any(curves[m] < lo)) for m in e["members"])
            for ln in _draw_entry(ax, f, shown, e, sty):
                if below:
                    ln.set_label(ln.get_label() + " (falls below the axis)")
            band(ax, e["default"])
        ax.set_ylim(lo, hi)
        ax.set_ylabel(f"PSD of output - truth, {PAL.PSD_UNIT}", fontsize=9)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(**LEGEND)
    for ax in axes[:, 0]:
        _log_ticks(ax)
    axes[-1, 0].set_xlabel("frequency, Hz")
    axes[0, 0].set_title(f"{it.protocol} / {it.run}: PSD of the error (Welch, 8 segments, mean "
                         f"removed), averaged in {PAL.PSD_PER_DECADE} bands a decade\n"
                         f"bands: {100 * ALLAN_CI:.0f} % interval (chi-square, EDF of each "
                         "band: the Welch average's times the ordinates it holds)", fontsize=9)
    _save(fig, path)


ALLAN_CI = 0.6826894921370859      # one sigma, as the recording's bars
ALLAN_DECADES_BELOW_RAW = 3         # Allan figure: its axis stops this far below raw / oracle


def _has_noise_model(p) -> bool:
    """The bench identifies the noise terms of this piece (fogbench.runner.score's rule: a
    contiguous record of at least 1000 s and 512 samples at 1 Hz or more)."""
    return (p.raw.size / p.fs >= 1000.0 and p.raw.size >= 512 and p.fs >= 1.0
            and not np.any(np.diff(p.t) > 1.5 / p.fs))


def _noise_model(err, fs: float):
    """The noise model the bench identifies from an error record (fogcomp.metrics.noise_terms:
    identify_noise_model on the octave Allan variance), or None."""
    from fogcomp.allan import oadev_details
    from fogcomp.noise import identify_noise_model

    if np.ptp(err) == 0:
        return None
    d = oadev_details(err, fs)
    if not np.all(d.adev > 0) or d.taus.shape[0] < 3:
        return None
    return identify_noise_model(d.taus, d.adev**2, fs, err.shape[0], record_length=False)


def fig_allan(it, path: Path, plan=None) -> bool:
    """Overlapping Allan deviation of each output's error against the truth, deg/h, with its
    one-sigma chi-square interval as a band (EDF of the noise type leading each tau,
    fogcomp.allan.oadev_ci), drawn up to the longest tau with at least
    fogbench.palette.ALLAN_MIN_CLUSTERS non-overlapping clusters; over raw and oracle the noise
    model the bench identified (dotted) where it identifies one. A sweep: the envelope of its
    members' curves and its default's line with its band; at most MAX_LINES lines a panel."""
    p = it.piece
    if p.raw.size < 64:
        return False
    labels = list(it.outputs)
    sty = _styles(labels, markers=True, plan=plan)
    cut = None
    ads, keeps = {}, {}
    for lab, y in it.outputs.items():
        ad = oadev_ci(y - p.truth, p.fs, ci=ALLAN_CI)
        keep = PAL.allan_drawn(ad.m, ad.n) & np.isfinite(ad.adev) & (ad.adev > 0)
        cut = ad.taus[keep][-1] if keep.any() else cut
        ads[lab], keeps[lab] = ad, keep
    models = []
    if _has_noise_model(p):
        for lab in ("raw", "oracle"):
            if lab in it.outputs:
                nm = _noise_model(it.outputs[lab] - p.truth, p.fs)
                if nm is not None and nm.in_model:
                    models.append((lab, nm))
    fixed = [lab for lab in ("raw", "oracle") if lab in labels]
    panels = _chunks(_method_entries(labels, plan), MAX_LINES - len(fixed) - len(models), plan)
    fig, axes = plt.subplots(len(panels), 1, figsize=(9.2, 0.8 + 4.0 * len(panels)),
                             sharex=True, sharey=True, squeeze=False)
    last = max((int(np.flatnonzero(k)[-1]) for k in keeps.values() if k.any()), default=0)
    taus = ads[labels[0]].taus[:last + 1]      # one record length: every output's taus
    shown = {lab: np.where(keeps[lab], ads[lab].adev / DPH, np.nan)[:last + 1]
             for lab in labels}

    # the axis stops ALLAN_DECADES_BELOW_RAW decades below raw's and the oracle's lowest
    # (static_allan's wavelet_soft, a smoother, ran to 2e-6 deg/h and squeezed raw into the top
    # two of seven decades); a curve below is named so
    refs = [float(np.nanmin(shown[lab])) for lab in fixed if np.any(np.isfinite(shown[lab]))]
    floor = min(refs) * 10.0 ** -ALLAN_DECADES_BELOW_RAW if refs else None
    if floor is not None and not any(np.nanmin(v) < floor for v in shown.values()
                                     if np.any(np.isfinite(v))):
        floor = None

    def band(ax, lab):
        ad, keep = ads[lab], keeps[lab]
        ax.fill_between(ad.taus[keep], ad.low[keep] / DPH, ad.high[keep] / DPH,
                        color=sty[lab]["color"], alpha=0.13, lw=0, zorder=1.0)

    for ax, chunk in zip(axes[:, 0], panels):
        ax.set_xscale("log")
        ax.set_yscale("log")
        for lab in fixed:
            ax.plot(taus, shown[lab], label=lab, **sty[lab])
            band(ax, lab)
        for e in chunk:
            below = floor is not None and any(
                bool(np.nanmin(shown[m]) < floor) for m in e["members"]
                if np.any(np.isfinite(shown[m])))
            for ln in _draw_entry(ax, taus, shown, e, sty):
                if below:
                    ln.set_label(ln.get_label() + " (falls below the axis)")
            band(ax, e["default"])
        for lab, nm in models:
            tt = np.geomspace(1.0 / p.fs, cut or p.raw.size / p.fs / PAL.ALLAN_MIN_CLUSTERS, 60)
            ax.plot(tt, nm.model_adev(tt) / DPH, color=sty[lab]["color"], lw=1.0, ls=":",
                    zorder=9.0, label=f"{lab}: identified model {nm.spec()}")
        ax.set_ylabel(f"Allan deviation of (output - truth), {PAL.ERROR_UNIT}", fontsize=9)
        if floor is not None:
            ax.set_ylim(bottom=floor)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(**LEGEND)
    for ax in axes[:, 0]:
        _log_ticks(ax)
    axes[-1, 0].set_xlabel("averaging time tau, s")
    axes[0, 0].set_title(f"{it.protocol} / {it.run}: overlapping Allan deviation\n"
                         f"bands: {100 * ALLAN_CI:.0f} % interval (chi-square, EDF of the leading "
                         f"noise type); drawn while >= {PAL.ALLAN_MIN_CLUSTERS} non-overlapping "
                         "clusters remain", fontsize=9)
    _save(fig, path)
    return True


def shows_time_structure(p) -> bool:
    """Whether a scored piece gets Allan deviation and PSD figures: only a contiguous record.

    The rule: a piece of separate static dwells (samples joined across gaps, a multi-position
    test) is scored by the mean error of each dwell (``drift_rms_dph``: a constant bias, a
    g-dependent drift at each position), and the bench computes no noise metric on it
    (fogbench.runner.score: ARW, bias instability, 100 s bias stability only on a contiguous
    record). An Allan deviation or a PSD of stitched dwells cannot show a per-dwell constant
    (the PSD removes the mean; within a dwell a constant has no Allan deviation) and measures
    the jumps at the joins instead, so neither is drawn; the dwell-means figure shows the
    effect."""
    return not np.any(np.diff(p.t) > 1.5 / p.fs)


def thermal_run(res: ScenarioResult) -> str:
    """The run ``thermal.png`` shows: the first scored run with a thermal program (the run the
    verdicts are about), else the first run."""
    for it in res.scored:
        for run in it.run.split("+"):
            rd = res.data.get(run)
            if rd is not None and rd.run.thermal is not None and rd.run.thermal.steps:
                return run
    return next(iter(res.data))


STEADY_FRACTION = 0.1    # thermal.png's loop: |dT/dt| below this fraction of the run's largest
#                          (100 s means) is "steady", neither heating nor cooling


def fig_thermal(res: ScenarioResult, run: str, path: Path) -> bool:
    """The thermal run ``run``: top left, the chamber program, the FOG's node temperatures and
    the sensor reading, with the coil's dT/dt; bottom left, the raw bias (raw output less the
    truth, 100 s means, deg/h) against time; bottom right, the same bias against the
    temperature a lab reads (the sensor, 100 s means; the true coil temperature where the run
    has no sensor), each point coloured by the coil's dT/dt: heating, cooling or steady
    (|dT/dt| under STEADY_FRACTION of the run's largest). The loop this draws is the part of
    the bias a model in temperature alone cannot fit: the Shupe term in dT/dt (the heating and
    cooling branches sit apart by about twice its coefficient times the ramp rate) and the
    sensor's lag behind the coil."""
    rd = res.data[run]
    if rd.run.thermal is None or not rd.run.thermal.steps:
        return False
    j = res.scenario.axes.index(res.plan.axis)
    k = max(1, int(round(100.0 * rd.fs)))
    ts, tname = PAL.time_unit(float(rd.truth.t[-1]))
    t = M.smooth(rd.truth.t, rd.fs, 100.0) / ts
    bias = M.smooth(rd.fog.raw[:, j] - rd.truth_axis(j), rd.fs, 100.0) / DPH
    th = rd.thermal
    th_h = rd.truth.t / ts
    fig = plt.figure(figsize=(13.5, 6.5))
    gs = fig.add_gridspec(2, 2, width_ratios=(2.3, 1.0), wspace=0.22, hspace=0.12)
    ax = fig.add_subplot(gs[0, 0])
    ax_b = fig.add_subplot(gs[1, 0], sharex=ax)
    ax_l = fig.add_subplot(gs[1, 1], sharey=ax_b)
    ax_key = fig.add_subplot(gs[0, 1])
    ax_key.axis("off")
    ax.plot(th_h, th.chamber, color="tab:blue", lw=1.4, label="chamber")
    if th.housing is not None and not np.array_equal(th.housing, th.chamber):
        ax.plot(th_h, th.housing, color="tab:purple", lw=2.6, alpha=0.6, label="housing")
    ax.plot(th_h, th.coil, color="tab:orange", lw=1.6, label="coil (true)")
    has_sensor = th.sensor is not None and not np.array_equal(th.sensor, th.coil)
    if has_sensor:
        ax.plot(th_h, th.sensor, color="black", lw=0.8, ls=":", label="sensor reading")
    ax.set_ylabel("temperature, deg C")
    _min_span(ax, "deg C")
    ax.tick_params(labelbottom=False)
    ax2 = ax.twinx()
    ax2.plot(th_h, th.coil_rate * 60, color="tab:red", lw=0.8, label="coil dT/dt (right axis)")
    ax2.set_ylabel("coil dT/dt, deg C/min")
    _min_span(ax2, "deg C/min")
    scored = sorted({it.protocol for it in getattr(res, "scored", ()) if run in it.run.split("+")})
    ax.set_title(f"{run}" + (f" (scored by {', '.join(scored)})" if scored else "")
                 + ": chamber program, FOG temperatures and raw bias", fontsize=10)
    ax_b.plot(t, bias, lw=0.8, color="0.4",
              label=f"raw output - truth (100 s means of {k} samples)")
    ax_b.set_ylabel(f"bias, {PAL.ERROR_UNIT}")
    _min_span(ax_b, PAL.ERROR_UNIT)
    ax_b.set_xlabel(f"time since power-on, {tname}")
    # the loop: bias against the temperature a lab reads, by the direction of the coil's drift
    temp = M.smooth(th.sensor if has_sensor else th.coil, rd.fs, 100.0)
    rate = M.smooth(th.coil_rate * 60.0, rd.fs, 100.0)
    steady = STEADY_FRACTION * max(float(np.max(np.abs(rate))), 1e-12)
    ax_l.plot(temp, bias, color="0.75", lw=0.6, zorder=1)
    for name, sel, c in (("heating", rate > steady, "tab:red"),
                         ("cooling", rate < -steady, "tab:blue"),
                         ("steady", np.abs(rate) <= steady, "0.45")):
        if np.any(sel):
            ax_l.plot(temp[sel], bias[sel], "o", ms=3, color=c, zorder=2, gid=f"loop:{name}",
                      label=f"bias vs temperature, {name}"
                            + (f" (|dT/dt| <= {steady:.2g} deg C/min)" if name == "steady"
                               else ""))
    # beside it, the simulation's own thermal term (its truth: the temperature law and the
    # Shupe term in dT/dt), where the bias carries more (thermal_with_motion's g terms by
    # position scatter the raw points about it)
    terms = getattr(rd.fog, "terms", None) or {}
    if "temperature" in terms:
        th_term = M.smooth(terms["temperature"][:, j], rd.fs, 100.0) / DPH
        rest = float(np.mean(bias - th_term))
        ax_l.plot(temp, th_term + rest, color="black", lw=1.2, zorder=3, gid="loop:true_term",
                  label="the simulated thermal term alone (the truth; 100 s means), plus "
                        f"the rest's mean ({rest:.3g} {PAL.ERROR_UNIT})")
    ax_l.set_xlabel("sensor reading, deg C (100 s means)" if has_sensor
                    else "coil temperature (true), deg C (100 s means)")
    lo, hi = PAL.min_span(*ax_l.get_xlim(), "deg C")
    ax_l.set_xlim(lo, hi)
    ax_l.tick_params(labelleft=False)
    ax_l.set_title("the same bias against temperature", fontsize=9)
    handles = []
    labels = []
    for a in (ax, ax2, ax_b, ax_l):
        h, lab = a.get_legend_handles_labels()
        handles += h
        labels += lab
    ax_key.legend(handles, labels, loc="upper left", fontsize=8, frameon=False)
    _save(fig, path)
    return True


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
    _save(fig, path)
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


def render_report(res: ScenarioResult, fig_names: dict, decimation: dict,
                  same: set | None = None) -> str:
    """The report's markdown; ``same``: :func:`same_as_lab` of ``res`` when already known."""
    sc, plan, doc = res.scenario, res.plan, res.metrics
    same = same_as_lab(res) if same is None else same
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
    for prot in plan.protocols:
        pd = doc["protocols"][prot.name]
        flag = " — IN-SAMPLE (the paper's own protocol: scored on data it was fitted on)" \
            if prot.in_sample else " — held out"
        L += [f"## Protocol `{prot.name}`{flag}", ""]
        if prot.description:
            L += [prot.description, ""]
        L += [f"Fit on: {'; '.join(s.describe() for s in prot.fit)}. Score on: "
              f"{'; '.join(s.describe() for s in prot.score)}."
              + (f" Per run: {', '.join(prot.runs)}." if prot.per_run else "")
              + (f" Data smoothed by {prot.smooth_s:g} s means before fitting and scoring."
                 if prot.smooth_s else "")
              + (f" First {prot.skip_s:g} s of each run left out." if prot.skip_s else ""), ""]
        for run, by_method in pd["runs"].items():
            def cell(lab, met, v, _run=run):
                pv = _paper_value(plan, lab, met, _run)
                return fmt(v, met) + (f" (ref: {fmt(pv.value, met)})" if pv is not None else "")

            L += [f"### {run}", "", metrics_table(by_method, cell), ""]
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
    t1 = _table1_section(res)
    if t1:
        L += [t1, ""]
    fn = fig_names.get(("thermal",))
    if fn:
        L += ["## Temperature and bias", "", f"![thermal]({fn})", ""]
    L += ["## Versions", "", ", ".join(f"{k} {v}" for k, v in doc["versions"].items()), ""]
    return "\n".join(L)


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
    L += [md_table(["segment"] + runs, rows), ""]
    for kind in ("hold", "ramp"):
        if ratio[kind]:
            L.append(f"- {kind}s: ours / paper {np.median(ratio[kind]):.2f} (median; "
                     f"{min(ratio[kind]):.2f}..{max(ratio[kind]):.2f} over "
                     f"{len(ratio[kind])} segments)")
    L.append("")
    # improvement per segment type: ours (each protocol) and the paper's (Table 2 vs Table 1)
    L += ["### Improvement per segment type", "",
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
    return "\n".join(L)


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


def write_run_dir(res: ScenarioResult, out: Path, recording: bool = True, save_data: bool = True,
                  montecarlo: dict | None = None, work=None, map_doc: dict | None = None,
                  map_run=None, figures: bool = True) -> Path:
    """Write metrics.json, report.md, figures, data (and recording.rrd) into ``out``.

    Everything is written into a hidden temporary sibling (its marker file first), which then
    replaces ``out``: an interrupted run leaves the previous complete directory, never a
    half-written one, and only an empty directory or a run directory of ours is ever replaced
    (``fogbench.outdir``). A figure that cannot be drawn is left out with a note in the report.
    ``montecarlo`` is the replicate aggregate (``fogbench.montecarlo``; in ``metrics.json`` under
    that key, in the report, in the recording); ``work`` the replicates' work folder, whose files
    are copied into ``replicates/`` and which is removed once the directory is in place.
    ``map_doc`` is the claim map (``fogbench.maps``; in ``metrics.json`` under ``"map"``, a
    section and one figure per claim in the report), ``map_run`` its points, whose replicates
    are copied into ``map/point<i>/replicates/``. ``figures=False`` draws none (a bounds check
    that needs only the numbers; the report says so).
    """
    out = check_out_dir(out, "run")
    tmp = new_part_dir(out, "run", {"scenario": res.scenario.name,
                                    "scenario_file": str(res.scenario.path),
                                    "fogbench": versions().get("fogbench")})
    try:
        fig_names, decim = {}, {}
        notes = [] if figures else ["figures: none drawn (--no-figures)"]

        def figure(what: str, fn, *args):
            """Draw one figure; a figure that cannot be drawn is noted, never fatal. A figure
            that cannot be written (a full disk, a file-size limit) or memory running out is
            an error of the whole command: nothing is put in place."""
            if not figures:
                return None
            try:
                return fn(*args)
            except (OSError, MemoryError):
                plt.close("all")
                raise
            except Exception as exc:  # noqa: BLE001 - the run's numbers matter more
                plt.close("all")
                notes.append(f"figure {what} left out: {type(exc).__name__}: {exc}")
                return None

        if figures:
            (tmp / "figures").mkdir()
        same = same_as_lab(res)
        for it in res.scored:
            base = f"{it.protocol}__{it.run}"
            key = (it.protocol, it.run)
            if key in decim or key in same:
                continue
            decim[key] = figure(f"{base} time series", fig_timeseries, it,
                                tmp / "figures" / f"{base}__timeseries.png", res.plan) or 1
            if (tmp / "figures" / f"{base}__timeseries.png").exists():
                fig_names[(it.protocol, it.run, "timeseries")] = f"figures/{base}__timeseries.png"
            if not shows_time_structure(it.piece):
                continue        # no Allan deviation or PSD of stitched dwells (the rule above)
            if offsets_only(it):  # the others would lie on raw's curve: raw (its noise) alone
                it = dataclasses.replace(it, outputs={"raw": it.outputs["raw"]})
            figure(f"{base} PSD", fig_psd, it, tmp / "figures" / f"{base}__psd.png", res.plan)
            if (tmp / "figures" / f"{base}__psd.png").exists():
                fig_names[(it.protocol, it.run, "psd")] = f"figures/{base}__psd.png"
            if figure(f"{base} Allan", fig_allan, it, tmp / "figures" / f"{base}__allan.png",
                      res.plan):
                fig_names[(it.protocol, it.run, "allan")] = f"figures/{base}__allan.png"
        for prot in res.plan.protocols:
            if figure(f"{prot.name} coefficients", fig_coefficients, res, prot.name,
                      tmp / "figures" / f"{prot.name}__coefficients.png"):
                fig_names[(prot.name, None, "coefficients")] = \
                    f"figures/{prot.name}__coefficients.png"
        if figure("thermal", fig_thermal, res, thermal_run(res), tmp / "figures" / "thermal.png"):
            fig_names[("thermal",)] = "figures/thermal.png"
        if montecarlo is not None:
            if figure("replicate distributions", fig_replicates, res, montecarlo,
                      tmp / "figures" / "replicates.png"):
                fig_names[("replicates",)] = "figures/replicates.png"
            if figure("start distributions", fig_starts, res, montecarlo,
                      tmp / "figures" / "starts.png"):
                fig_names[("starts",)] = "figures/starts.png"
            if figure("metric by run", fig_runs, res, montecarlo, tmp / "figures" / "runs.png"):
                fig_names[("runs",)] = "figures/runs.png"
            fig_names.update(draw_claim_figures(montecarlo, tmp / "figures", figure))
        if map_doc is not None:
            from .map_report import fig_map

            for k in range(len(map_doc["claims"])):
                name = f"figures/map__{k}.png"
                if figure(f"claim map {k}", fig_map, map_doc, k, tmp / name):
                    fig_names[("map", k)] = name
        doc = res.metrics if montecarlo is None else {**res.metrics, "montecarlo": montecarlo}
        if map_doc is not None:
            doc = {**doc, "map": map_doc}
        write_metrics(tmp / "metrics.json", doc)
        text = render_report(res, fig_names, decim, same)
        if montecarlo is not None:
            # the answer first: takeaway, verdicts, evidence; then the set-up
            text = open_on_answer(text, render_montecarlo(res, montecarlo, fig_names),
                                  montecarlo, fig_names, res.plan)
        else:
            bands = render_bands(res, None)
            if bands:
                text = _insert_mc(text, "\n".join(bands))
        if map_doc is not None:
            from .map_report import render_map

            text = _insert_mc(text, render_map(map_doc, fig_names))
        if notes:
            text += "\n## Left out\n\n" + "\n".join(f"- {n}" for n in notes) + "\n"
        atomic_write_text(tmp / "report.md", text)
        atomic_write_text(tmp / "scenario.toml", res.scenario.text)
        if save_data:
            (tmp / "data").mkdir()
            for name, rd in res.data.items():
                buf = io.BytesIO()
                np.savez_compressed(buf, **run_arrays(rd))
                atomic_write_bytes(tmp / "data" / f"{name}.npz", buf.getvalue())
            for it in res.scored:
                buf = io.BytesIO()
                np.savez_compressed(buf, t_s=it.piece.t, truth_rps=it.piece.truth,
                                    **{f"{k}_rps": v for k, v in it.outputs.items()})
                atomic_write_bytes(tmp / "data" / f"scored__{it.protocol}__{it.run}.npz",
                                   buf.getvalue())
        if recording:
            from .recording import write_recording

            write_recording(res, tmp / "recording.rrd",
                            replicates=None if montecarlo is None else
                            recording_replicates(montecarlo, work))
        if work is not None:
            work.copy_into(tmp, keep=list(range(montecarlo["replicates_requested"]))
                           if montecarlo else [0])
        if map_run is not None:
            map_run.copy_into(tmp)
        replace_dir(tmp, out, "run")
        if work is not None:
            work.remove()  # only now: until the run directory is in place it is the only copy
        if map_run is not None:
            map_run.remove()
    except OSError as exc:
        discard_part(tmp)
        raise as_final(exc, tmp, out) from None  # the file as the user will look for it
    except BaseException:
        discard_part(tmp)
        raise
    return out


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
        if metric.endswith("_dph") and all(d.size and np.all(d > 0) for d in data):
            ax.set_yscale("log")
            _log_ticks(ax)      # paper004's axis had two labels, 10^0 and 10^1
        ax.grid(alpha=0.3)
        if any(ranges):
            ax.legend(fontsize=7, loc="best")
    _share_y([(a, x[1]) for a, x in zip(axes.flat, panels)])
    fig.tight_layout()
    _save(fig, path)
    return True


def fig_replicates(res: ScenarioResult, mc: dict, path: Path) -> bool:
    """Each protocol's key metric over replicates: one column per method (raw and oracle too),
    every replicate a point, a box for the quartiles."""
    if mc["replicates"] < 2:
        return False

    def panel(prot, metric):
        ser = mc["series"].get(prot.name, {}).get(metric, {})
        labels = [lab for lab in ser if any(v is not None for v in ser[lab])]
        data = [np.array([v for v in ser[lab] if v is not None]) for lab in labels]
        return (labels, data, f"{mc['replicates']} replicates",
                {"jitter": 0.15, "ms": 3.5, "alpha": 0.7}, None)

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
    _save(fig, path)
    return True


def recording_replicates(mc: dict, work=None) -> dict:
    """What the recording shows over replicates: {protocol: {metric: {label: [values]}}}."""
    return mc.get("series", {})


def _with_takeaway(text: str, mc: dict) -> str:
    line = takeaway(mc)
    if line is None:
        return text
    head, sep, rest = text.partition("\n\n")
    return f"{head}{sep}{line}\n\n{rest}"


def render_montecarlo(res: ScenarioResult, mc: dict, fig_names: dict) -> str:
    plan = res.plan
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
    if mc["claims"]:
        L += ["### The papers' claims", "",
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
                     f"{ci_text(sm, '_pct')} % (claim {rng}): "
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
    if mc.get("lab_cost"):
        L += ["### What the lab's references cost", "",
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
        L += [md_table(["protocol", "method", "metric", "lab reference", "ideal (truth)",
                        "lab - ideal", "lab worse in"], rows), ""]
    if mc["rankings"]:
        L += ["### Rankings against the papers' tables", "",
              "Probability of each ordering over replicates (`<` reads 'better than').", ""]
        for rk in mc["rankings"]:
            top = "; ".join(f"{o['ordering']}: {100 * o['probability']:.0f} %"
                            for o in rk["orderings"][:3])
            L.append(f"- `{rk['protocol']}`, {rk['run']}, {rk['metric']}: the paper's order "
                     f"{' < '.join(rk['paper_order'])} in {100 * rk['p_paper_order']:.0f} % of "
                     f"replicates. Most frequent: {top}.")
        L.append("")
    refs = [pv for pv in plan.paper if pv.segment is None]
    if refs:
        L += ["### Against the references", ""]
        for pv in refs:
            for prot in plan.protocols:
                runs = [pv.run] if pv.run else list(mc["summary"].get(prot.name, {}))
                for run in runs:
                    sm = mc["summary"].get(prot.name, {}).get(run, {}).get(pv.method, {}).get(
                        pv.metric)
                    allan = pv.metric in ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
                                          "gm_sigma_dph", "gm_tau_s")
                    if sm and sm.get("n"):
                        ours = ci_text({**sm, "n_failed": 0}, pv.metric)
                        total = sm["n"] + (sm.get("n_failed") or 0)
                        if sm.get("n_failed"):
                            ours += (f", identified in {sm['n']} of {total} replicates" if allan
                                     else f", failed in {sm['n_failed']} of {total}")
                    else:
                        ours = "not identified" if allan else "not computed"
                    if allan and pv.source.startswith("configured"):
                        ours = f"configured {fmt(pv.value, pv.metric)}, " + (
                            ours if ours == "not identified" else f"identified {ours}")
                    L.append(f"- `{prot.name}`, {run}, {pv.method}, {pv.metric}: reference "
                             f"{fmt(pv.value, pv.metric)} ({pv.source}); ours {ours}.")
        L.append("")
    for prot in plan.protocols:
        po = mc["over_runs"].get(prot.name, {})
        metrics = [m for m in KEY_METRICS if m not in ("fit_time_s",) and any(
            m in po.get(lab, {}) for lab in po)]
        if not metrics:
            continue
        flag = " (IN-SAMPLE)" if prot.in_sample else ""
        rows = [[lab] + [ci_text(po.get(lab, {}).get(m), m) for m in metrics] for lab in po]
        L += [f"### `{prot.name}`{flag}: mean over scored runs, over replicates", "",
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
                L += [f"Spread over the {K} method seeds inside a replicate (std of "
                      f"{key_metric(mc, prot.name, plan)}, mean over replicates): "
                      + "; ".join(bits) + ".", ""]
    if ("replicates",) in fig_names:
        L += [f"![distributions over replicates]({fig_names[('replicates',)]})", ""]
    if ("runs",) in fig_names:
        L += ["Each protocol's key metric run by run (power-on by power-on), over replicates:",
              "", f"![key metric by run]({fig_names[('runs',)]})", ""]
    if ("starts",) in fig_names:
        L += ["The methods that draw random starts, start by start (points: every start of "
              "every replicate; crosses: the replicate means the claims use):", "",
              f"![distributions over method starts]({fig_names[('starts',)]})", ""]
    L += render_bands(res, mc)
    return "\n".join(L)


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
