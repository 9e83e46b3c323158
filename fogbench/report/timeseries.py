"""The error over time of one run's piece (``figures/<protocol>__<run>.png``) and its dwells:
where the table holds still, each method's mean error per dwell (``figures/dwells__...``)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fogbench.outputs import files
from fogbench.report import palette as PAL
from fogbench.report.style import COLORS, _decimate, _styles
from fogbench.report.views import DWARF, SAME_FRACTION, mean_blind
from fogbench.report.views import kept_alike as _kept_alike
from fogbench.report.views import method_entries as _method_entries
from fogbench.report.views import moving_mean as _moving_mean
from fogbench.report.views import shown_error as _shown_error
from fogbench.report.views import sweep_names as _sweep_names
from fogcomp.units import DPH, DPS

__all__ = ["dwells", "dwell_means"]

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
    """Widen the y axis to the palette's least span of ``unit`` (fogbench.report.palette.MIN_SPAN)."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(*PAL.min_span(lo, hi, unit))


# ---------------------------------------------------------------------------------------------
# Views that show the effect: sweeps as envelopes, at most MAX_LINES lines a panel,
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
    the time since power-on (s, or h past fogbench.report.palette.HOURS_ABOVE_S).

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
    loud, quiet, methods, big, fixed = _ts_split(entries, cur)
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
        _panel_rate(axes.pop(0), t, truth, raw_out, "raw" in it.outputs, sty,
                    head + "raw output and truth; below, the error against the truth")
        head = ""
    else:
        head += (f"a static record (true rate {float(np.mean(p.truth)) / DPH:.4g} deg/h "
                 "throughout): the error against the truth\n")
    if ref_panel:
        _panel_as_it_is(axes.pop(0), t, errs, step, big, kind, k, centre, sty,
                        head.rstrip("\n") + "; here as it is" if head else None)
        head = ""
    what, note = _zoomed_wording(kind, k, k / p.fs, centre)
    pad = 0.05 * max(width, 1e-12)
    for i, (chunk, is_loud) in enumerate(panels):
        _panel_zoomed(axes[i], t, cur, chunk, is_loud, fixed, under_raw, sty,
                      (lo - pad, hi + pad) if methods else None, what)
        if i == 0:
            axes[i].set_title(head + "methods' error, zoomed to them"
                              + (f" ({', '.join(big)} above: off this scale)" if big else "")
                              + note, fontsize=9)
    fig.axes[-1].set_xlabel(f"time since power-on, {tname}")
    files.save_figure(fig, path)
    return step


def _ts_split(entries: list[dict], cur: dict) -> tuple[list, list, list, list, list]:
    """Which curves go to which panels of :func:`fig_timeseries`: the entries whose errors
    dwarf the rest's (``loud``, panels of their own), the others (``quiet``) and their
    methods, and raw and oracle where they dwarf those methods (``big``: the panel of errors
    as they are alone) or not (``fixed``: beside the methods)."""
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
    return loud, quiet, methods, big, fixed


def _panel_rate(ax, t, truth, raw_out, has_raw: bool, sty: dict, title: str) -> None:
    """fig_timeseries' top panel: the raw output (when there is one) and the truth, deg/s."""
    if has_raw:
        ax.plot(t, raw_out / DPS, label="raw", alpha=0.85, **sty["raw"])
    ax.plot(t, truth / DPS, color=COLORS["truth"], lw=1.4, ls="--", label="truth",
            zorder=10)
    ax.set_ylabel(f"rate, {PAL.RATE_UNIT}", fontsize=9)
    _min_span(ax, PAL.RATE_UNIT)
    ax.legend(**LEGEND)
    ax.set_title(title, fontsize=10)


def _panel_as_it_is(ax, t, errs: dict, step: int, big: list, kind, k: int, centre: bool,
                    sty: dict, title: str | None) -> None:
    """fig_timeseries' panel of errors as they are (raw's, the oracle's where they dwarf the
    methods or the panels below change them) with raw's k-sample moving mean: what the
    panels below take out (kind "trend") or show (kind "fast")."""
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
    if title:
        ax.set_title(title, fontsize=10)


def _zoomed_wording(kind, k: int, dt: float, centre: bool) -> tuple[str, str]:
    """The zoomed panels' y label and the note their title ends with: what the curves are
    (the error, its moving mean, less raw's trend, less its own mean) and why."""
    what = {"trend": "error - raw's trend", "fast": f"error, {k}-sample mean",
            "both": "moving mean - raw's trend"}.get(kind, "error vs truth") \
        + (",\nless its mean" if centre else "")
    note = {"trend": "; raw's slow variation about its mean taken out of every curve: no "
                     "method removes it",
            "fast": f"; {k}-sample ({dt:.3g} s) moving means: every method keeps raw's faster "
                    "noise",
            "both": f"; {k}-sample ({dt:.3g} s) moving means less raw's slow variation: every "
                    "method keeps raw's noise, fast and slow"}.get(kind, "") \
        + ("\neach curve less its own mean (the claims on this run score the std, blind to "
           "it)" if centre else "")
    return what, note


def _panel_zoomed(ax, t, cur: dict, chunk: list[dict], is_loud: bool, fixed: list,
                  under_raw: dict, sty: dict, ylim: tuple | None, what: str) -> None:
    """One of fig_timeseries' methods' panels: raw and oracle where they do not dwarf the
    methods, then the chunk's methods and sweeps, on the shared zoom ``ylim`` (a loud chunk:
    on its own range, titled as off the scale above)."""
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
    elif ylim is not None:
        ax.set_ylim(*ylim)
    _min_span(ax, PAL.ERROR_UNIT)
    # two lines: "error, 10-sample mean, deg/h" on one ran into the next panel's label
    ax.set_ylabel(f"{what},\n{PAL.ERROR_UNIT}", fontsize=9)
    ax.legend(**LEGEND)


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
    err, sem, less_oracle = _dwell_errors(it, methods, bars)

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
        """One label's dwell means on ``ax``: markers with their bars, or joined by a line."""
        kw = dict(color=sty[lab]["color"], zorder=sty[lab]["zorder"],
                  marker={"raw": "D", "oracle": "s"}.get(lab) or
                  DWELL_MARKERS[member.get(lab, 0) % len(DWELL_MARKERS)],
                  mfc="none" if lab == "raw" else sty[lab]["color"], label=lab)
        if bars:
            ax.errorbar(x + dx, y, yerr=se, ms=4, capsize=2, elinewidth=0.8, ls="none", **kw)
        else:
            ax.plot(x, y, ms=2.5, lw=0.8, alpha=0.9, **kw)

    _panel_dwell_rates(axes[0], it, x, truth_mean, draw, bars)
    _panel_dwell_refs(axes[1], err, sem, draw, bars)
    pad = 0.08 * max(hi - lo, 1e-12)
    ylim = (min(lo, o_lo if oracle_in else lo) - pad, max(hi, o_hi if oracle_in else hi) + pad)
    for ax, chunk in zip(axes[2:], panels):
        _panel_dwell_methods(ax, chunk, err, sem, draw, bars, oracle_in, less_oracle, ylim)
    if len(axes) > 2:
        axes[2].set_title(
            "methods' dwell-mean error less the oracle's: the deterministic error each leaves, "
            "without the noise they share, zoomed to them" if less_oracle else
            "methods' dwell-mean error, zoomed to them"
            + ("" if oracle_in or "oracle" not in err else
               " (the oracle, above, is off this scale)"), fontsize=9)
    axes[-1].set_xlabel("dwell (position) number, in time order")
    files.save_figure(fig, path)


def _dwell_errors(it, methods: list[str], bars: bool) -> tuple[dict, dict, bool]:
    """Each output's dwell-mean error and its standard error, deg/h, and whether the methods'
    are drawn less the oracle's (beyond DWELL_BARS_MAX dwells, with an oracle)."""
    p = it.piece
    err, sem = {}, {}
    for lab in it.outputs:
        _, e, se = dwell_means(p.t, it.outputs[lab] - p.truth, p.fs)
        err[lab], sem[lab] = e / DPH, se / DPH
    # beyond DWELL_BARS_MAX dwells the methods' noisy means tangle (thermal_with_motion's 133):
    # their panels draw each method's dwell mean less the oracle's, the deterministic error it
    # leaves, which holds no noise for a model of the terms (method - oracle = true terms -
    # the method's estimate; a denoiser's difference also holds the noise it took out)
    less_oracle = not bars and "oracle" in err and bool(methods)
    if less_oracle:
        err = {lab: (e - err["oracle"] if lab in methods else e) for lab, e in err.items()}
    return err, sem, less_oracle


def _panel_dwell_rates(ax, it, x, truth_mean, draw, bars: bool) -> None:
    """fig_dwells' top panel: the true rate of each dwell (the positions) and raw's dwell
    means, deg/h."""
    p = it.piece
    k = truth_mean.size
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


def _panel_dwell_refs(ax, err: dict, sem: dict, draw, bars: bool) -> None:
    """fig_dwells' second panel: raw's and the oracle's dwell-mean errors, side by side."""
    refs = [lab for lab in ("raw", "oracle") if lab in err]
    width = 0.3 if bars else 0.0
    for i, lab in enumerate(refs):
        draw(ax, lab, err[lab], sem[lab], (i - (len(refs) - 1) / 2) * width)
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.set_ylabel("dwell mean error,\ndeg/h", fontsize=9)
    ax.legend(**LEGEND)


def _panel_dwell_methods(ax, chunk: list[dict], err: dict, sem: dict, draw, bars: bool,
                         oracle_in: bool, less_oracle: bool, ylim: tuple) -> None:
    """One of fig_dwells' methods' panels: the chunk's dwell-mean errors side by side (the
    oracle first when it is in), on the shared zoom ``ylim``; less the oracle's, the oracle
    is the zero line."""
    shown = (["oracle"] if oracle_in else []) + [m for e in chunk for m in e["members"]]
    width = 0.7 / max(1, len(shown)) if bars else 0.0
    for i, lab in enumerate(shown):
        draw(ax, lab, err[lab], sem[lab], (i - (len(shown) - 1) / 2) * width)
    if less_oracle:
        ax.axhline(0.0, color=COLORS["oracle"], lw=1.2, zorder=1.5,
                   label="oracle (0: what is taken out)")
    else:
        ax.axhline(0.0, color="0.7", lw=0.5)
    ax.set_ylim(*ylim)
    ax.set_ylabel("dwell mean error\n- oracle's, deg/h" if less_oracle else
                  "dwell mean error,\ndeg/h", fontsize=9)
    ax.legend(**LEGEND)
