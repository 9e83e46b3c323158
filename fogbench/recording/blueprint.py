"""The viewer's layout, declared in code and sent with the recording: the Overview, Errors,
Table and chamber, FOG error terms, Allan deviation, PSD, Monte Carlo and Report tabs."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fogbench.recording.entities import (
    _PLOT_H,
    _PLOT_W,
    CONSTANT_PTP,
    LEGEND_HEADROOM,
    MAX_LOGLOG_VIEWS,
    TABLE_SPACING_M,
    TIMELINE,
    _in_sample,
    _p,
    _piece_keys,
    _Writer,
)
from fogbench.recording.replicates import _n_reps
from fogbench.report import palette as PAL
from fogbench.report.views import (
    DWARF,
)


def _y_axis(w: _Writer, paths: list[str], unit: str | None = None):
    """A fixed y range for a view whose series are all constant to rounding, or that span less
    than the palette's least span of ``unit`` (``fogbench.report.palette.MIN_SPAN``: a temperature
    axis spans at least 1 C, as in the PNGs), else None."""
    import rerun.blueprint as rrb

    r = [w.ranges[p] for p in paths if p in w.ranges]
    if not r:
        return None
    lo, hi = min(a for a, _ in r), max(b for _, b in r)
    c = 0.5 * (lo + hi)
    if unit in PAL.MIN_SPAN and hi - lo < PAL.MIN_SPAN[unit]:
        return rrb.ScalarAxis(range=PAL.min_span(lo, hi, unit))
    if hi - lo > max(CONSTANT_PTP, 1e-9 * abs(c)):
        return None
    half = max(1.0, 0.5 * abs(c))
    return rrb.ScalarAxis(range=(c - half, c + half))


# The viewer's "global view" (re_viewer_context::GLOBAL_VIEW_ID, Rerun 0.41): the shared time
# axis of every plot whose TimeAxis link is LinkToGlobal. The Python API does not expose it; its
# TimeAxis is a view property at the blueprint path view/<id>/TimeAxis like any view's. Without
# it the linked plots fall back to their own data range and do not open on the whole run.
_GLOBAL_VIEW_ID = "5c0dca6a-e63f-9cf7-f657-2602590474cc"


def _y_axis_with_headroom(w: _Writer, paths: list[str]):
    """A y range that keeps the upper part of the plot free for the legend (the data in the
    lower half), or the fixed range of constant values."""
    import rerun.blueprint as rrb

    fixed = _y_axis(w, paths)
    r = [w.ranges[p] for p in paths if p in w.ranges]
    if fixed is not None or not r:
        return fixed
    lo, hi = min(a for a, _ in r), max(b for _, b in r)
    span = hi - lo
    return rrb.ScalarAxis(range=(lo - 0.05 * span, hi + LEGEND_HEADROOM * span))


def _shown_path(w: _Writer, path: str) -> str:
    """The Overview's series of an error path: ``.../fog/error_shown/...`` where the piece has
    something every output keeps alike taken out, or a sweep (its default named as such, the
    errors as they are), else the path itself."""
    root, lab = path.rsplit("/", 1)
    if root not in w.shown and root not in w.sweeps:
        return path
    head, key = root.rsplit("/", 1)
    return f"{head[:-len('error')]}error_shown/{key}/{lab}"


def _y_axis_zoomed(w: _Writer, paths: list[str]):
    """The error view's y range zoomed to the methods, raw and oracle in it unless the range
    holding them would span more than DWARF times the methods' (as the PNG's zoom), with the
    legend's headroom above; ``(axis, labels left off the scale)``."""
    def ranges(ps):
        return [w.ranges[x] for x in ps if x in w.ranges]

    refs = [x for x in paths if x.rsplit("/", 1)[1] in ("raw", "oracle")]
    methods = ranges([x for x in paths if x not in refs])
    if not methods:
        return _y_axis_with_headroom(w, paths), []
    lo, hi = min(a for a, _ in methods), max(b for _, b in methods)
    width = max(hi - lo, 1e-300)
    if width < PAL.MIN_SPAN[PAL.ERROR_UNIT]:    # the methods alike: nothing to zoom to
        return _y_axis_with_headroom(w, paths), []
    off = []
    for x in refs:
        rr_ = ranges([x])
        if not rr_:
            continue
        a, b = rr_[0]
        if max(b, hi) - min(a, lo) > DWARF * width:
            off.append(x.rsplit("/", 1)[1])
    keep = [x for x in paths if x.rsplit("/", 1)[1] not in off]
    return _y_axis_with_headroom(w, keep), sorted(set(off))


def _blueprint_class():
    import rerun.blueprint as rrb

    class _Bp(rrb.Blueprint):
        """A blueprint that also sets the global view's time axis (see _GLOBAL_VIEW_ID)."""

        def __init__(self, *parts, global_time_axis=None, **kw):
            super().__init__(*parts, **kw)
            self._global_time_axis = global_time_axis

        def _log_to_stream(self, stream) -> None:
            super()._log_to_stream(stream)
            if self._global_time_axis is not None:
                stream.log(f"view/{_GLOBAL_VIEW_ID}/TimeAxis", self._global_time_axis)

    return _Bp


def _Blueprint(*parts, **kw):
    return _blueprint_class()(*parts, **kw)


def _blueprint(res, w: _Writer, reps: dict | None = None, active_tab: str = "Overview"):
    """The viewer's layout of a result whose entities ``w`` logged: its tabs in order, opened on
    ``active_tab``, every time series on the whole of the longest run, time axes linked."""
    import rerun as rr
    import rerun.blueprint as rrb

    runs = list(res.data)
    t_end = max(float(rd.truth.t[-1]) for rd in res.data.values())
    time_range = rr.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=0.0),
                              end=rrb.TimeRangeBoundary.absolute(seconds=t_end))
    axes = (rrb.TimeAxis(link="LinkToGlobal", view_range=time_range),
            rrb.VisibleTimeRange(TIMELINE, start=rrb.TimeRangeBoundary.infinite(),
                                 end=rrb.TimeRangeBoundary.infinite()))
    keys = _piece_keys(res)
    error_views = _error_paths(res, keys)
    temp = [x for leaf in ("coil_c", "housing_c", "chamber_c", "sensor_c")
            for x in _each(runs, "thermal", leaf)]
    tabs = [_overview_tab(res, w, axes, error_views, temp)]
    if len(error_views) > 1:
        tabs.append(rrb.Grid(*[_plot(w, axes, f"Error vs truth, {r}, deg/h (colours as in "
                                     "Overview)", lst) for r, lst in error_views.items()],
                             grid_columns=2 if len(error_views) > 1 else 1, name="Errors"))
    tabs.append(_table_tab(w, axes, runs, temp))
    terms = [_plot(w, axes, f"FOG error terms, {r}, deg/h",
                   [_p("runs", r, "fog", "error_terms", t) for t in res.data[r].fog.terms],
                   legend=len(runs) <= 2, corner="LeftTop") for r in runs]
    tabs.append(rrb.Grid(*terms, grid_columns=min(len(terms), 3), name="FOG error terms"))
    for kind, title in (("allan", "Allan deviation"), ("psd", "PSD")):
        tabs += _loglog_tab(res, w, keys, kind, title)
    if reps:
        tabs.append(_monte_carlo_tab(w, reps))
    tabs.append(rrb.Horizontal(
        rrb.TextDocumentView(name="Metrics", origin="/report/metrics"),
        rrb.TextDocumentView(name="Scenario", origin="/report/scenario"),
        name="Report"))
    names = [t.name for t in tabs]
    if active_tab not in names:
        raise ValueError(f"active_tab: no tab {active_tab!r}; tabs: {names}")
    return _Blueprint(rrb.Tabs(*tabs, active_tab=names.index(active_tab)),
                      rrb.TimePanel(timeline=TIMELINE), collapse_panels=False,
                      global_time_axis=rrb.TimeAxis(view_range=time_range))


_TEMP_TITLE = "Temperature, deg C: coil (darkest), housing, chamber, sensor reading (lightest)"


def _each(runs: list[str], *leaf: str) -> list[str]:
    """The entity path ``leaf`` of every run, in the runs' order."""
    return [_p("runs", r, *leaf) for r in runs]


def _plot(w: _Writer, axes, name: str, paths, legend=False, corner="RightTop", headroom=False,
          unit=None):
    """A time series view of ``paths`` on the linked time axis and the whole run (``axes``:
    the view's TimeAxis and its visible time range), its y range from :func:`_y_axis`."""
    import rerun.blueprint as rrb

    time_axis, whole = axes
    paths = list(paths)
    return rrb.TimeSeriesView(
        name=name, contents=paths, axis_x=time_axis,
        axis_y=_y_axis_with_headroom(w, paths) if headroom else _y_axis(w, paths, unit),
        time_ranges=[whole],
        plot_legend=rrb.PlotLegend(visible=legend, corner=corner))


def _error_paths(res, keys: list[str]) -> dict[str, list[str]]:
    """The error series of each scored run, ``{run: paths}``: every protocol scoring it, raw
    and oracle once unless they differ between protocols."""
    by_run: dict[str, list[str]] = {}
    seen_ref: dict[str, list] = {}
    for key, it in zip(keys, res.scored):
        lst = by_run.setdefault(it.run, [])
        for lab, out in it.outputs.items():
            if lab in ("raw", "oracle"):
                sig = (lab, it.piece.t.size, float(it.piece.t[0]), float(it.piece.t[-1]),
                       float(np.sum(out)))
                if sig in seen_ref.setdefault(it.run, []):
                    continue
                seen_ref[it.run].append(sig)
            lst.append(_p("runs", it.run, "fog", "error", key, lab))
    return by_run


def _table_camera(res):
    """The 3-D view of the rate tables, its camera framing their row (0.8 m apart along y, each
    about 0.7 x 0.6 x 0.6 m)."""
    import rerun.blueprint as rrb

    n_tables = len(res.data)
    mid_y = 0.5 * (n_tables - 1) * TABLE_SPACING_M
    span = (n_tables - 1) * TABLE_SPACING_M + 0.8
    dist = 0.75 * span + 1.4
    eye = rrb.EyeControls3D(position=(dist * 0.8, mid_y - dist * 0.45, 0.2 + dist * 0.5),
                            look_target=(0.0, mid_y, -0.25), eye_up=(0.0, 0.0, 1.0))
    return rrb.Spatial3DView(
        name=f"Rate tables (3-D): orange = sensitive axis {res.plan.axis}, green = gravity (1 g up)",
        origin="/table", eye_controls=eye)


def _shown_what(w: _Writer, lst: list[str]) -> tuple[str, bool]:
    """The start of the title of a run's Overview error view, saying what was taken out of the
    errors ``lst`` shows, and whether anything was."""
    kinds = list(dict.fromkeys(w.shown[x.rsplit("/", 1)[0]] for x in lst
                               if x.rsplit("/", 1)[0] in w.shown))
    kinds_k = sorted({(kd, k) for kd, k, _ in kinds if kd is not None})
    what = ("Error less raw's slow variation (no method removes it)"
            if kinds_k and all(kd == "trend" for kd, _ in kinds_k) else
            f"Error, {kinds_k[0][1]}-sample moving mean (every method keeps raw's fast "
            "noise)" if len(kinds_k) == 1 and kinds_k[0][0] == "fast" else
            f"Error, {kinds_k[0][1]}-sample moving mean less raw's slow variation (every "
            "method keeps raw's noise, fast and slow)"
            if len(kinds_k) == 1 and kinds_k[0][0] == "both" else
            "Error (less what every method keeps alike)" if kinds_k else "Error vs truth")
    if kinds and all(c for _, _, c in kinds):    # (one run: all alike, mean_blind)
        what += ", each less its mean (the claims score the std, blind to it)"
    return what, bool(kinds)


def _overview_error_view(w: _Writer, axes, r: str, lst: list[str], n_views: int):
    """The Overview's error view of run ``r`` (one of ``n_views``): what every output keeps
    alike taken out (as the PNG time series), zoomed to the methods; the errors as they are
    in the Errors tab."""
    import rerun.blueprint as rrb

    time_axis, whole = axes
    shown = [_shown_path(w, x) for x in lst]
    for root in dict.fromkeys(x.rsplit("/", 1)[0] for x in lst):
        if root in w.sweeps:      # a sweep: its default's line and its members' envelope
            skip, envelope = w.sweeps[root]
            shown = [x for x in shown if x not in skip] + envelope
    what, taken_out = _shown_what(w, lst)
    axis, off = _y_axis_zoomed(w, shown)
    note = f"; {' and '.join(off)} off this scale" if off else ""
    plain = "; as they are: tab Errors" if (taken_out or off) and n_views > 1 else \
        "; as they are: drag to zoom out" if taken_out or off else ""
    return rrb.TimeSeriesView(
        name=f"{what}, {r}, deg/h{note}{plain}", contents=shown, axis_x=time_axis,
        axis_y=axis, time_ranges=[whole],
        plot_legend=rrb.PlotLegend(visible=True, corner="RightTop"))


def _overview_tab(res, w: _Writer, axes, error_views: dict, temp: list[str]):
    """The Overview: the rate tables in 3-D and the metrics on the left, each run's error view
    (a tab each) and the temperatures on the right."""
    import rerun.blueprint as rrb

    table3d = _table_camera(res)
    err_tabs = [_overview_error_view(w, axes, r, lst, len(error_views))
                for r, lst in error_views.items()]
    return rrb.Horizontal(
        rrb.Vertical(table3d, rrb.TextDocumentView(name="Metrics", origin="/report/metrics"),
                     row_shares=[3, 2]),
        rrb.Vertical(
            rrb.Tabs(*err_tabs, name="Error vs truth") if len(err_tabs) > 1 else err_tabs[0],
            _plot(w, axes, _TEMP_TITLE, temp, unit="deg C"),
            row_shares=[5, 2]),
        column_shares=[2, 3], name="Overview")


def _table_tab(w: _Writer, axes, runs: list[str], temp: list[str]):
    """The Table and chamber tab: every run's rate, tilt, turntable, gravity, dT/dt and
    temperatures."""
    import rerun.blueprint as rrb

    rate = [x for r in runs for x in (_p("runs", r, "truth", "rate"), _p("runs", r, "fog", "raw"))]
    return rrb.Grid(
        _plot(w, axes, "Rate about the sensitive axis, deg/s (truth dark, raw light, a colour "
              "per run)", rate),
        _plot(w, axes, "Tilt (dark) and its command (light), deg",
              _each(runs, "table", "tilt_deg") + _each(runs, "table", "tilt_cmd_deg")),
        _plot(w, axes, "Turntable rate (dark) and its command (light), deg/s",
              _each(runs, "table", "turn_rate_dps") + _each(runs, "table", "turn_rate_cmd_dps")),
        _plot(w, axes, "Gravity on the sensor axes (x red, y green, z blue), g",
              [_p("runs", r, "gravity", a) for r in runs for a in "xyz"]),
        _plot(w, axes, "dT/dt, deg C/min: coil (dark), differenced from the sensor (light)",
              _each(runs, "thermal", "coil_rate_c_per_min")
              + _each(runs, "thermal", "sensor_rate_c_per_min"), unit="deg C/min"),
        _plot(w, axes, _TEMP_TITLE, temp, unit="deg C"),
        grid_columns=2, name="Table and chamber")


def _loglog_tab(res, w: _Writer, keys: list[str], kind: str, title: str) -> list:
    """The Allan deviation or PSD tab (``kind`` "allan" or "psd"), a plot per scored piece
    drawn; [] when none is."""
    import rerun.blueprint as rrb

    views = []
    for key, it in zip(keys, res.scored):
        root = _p("report", kind, key, it.run)
        if root not in w.plots:
            continue
        views.append((key, rrb.Spatial2DView(
            name=f"{title}: {key} / {it.run}" + (" (in-sample)" if _in_sample(res).get(
                it.protocol) else "") + f"; {w.plots[root]}",
            origin=root,
            visual_bounds=rrb.VisualBounds2D(
                x_range=(-0.35, max(_PLOT_W + 0.8, w.plot_right.get(root, 0.0))),
                y_range=(-0.22, _PLOT_H + 0.32)))))
    # at most MAX_LOGLOG_VIEWS plots a tab (paper002's 12 plots of about 110 px could not
    # hold their legends): more go in a tab per protocol
    prots = list(dict.fromkeys(k for k, _ in views))
    if len(views) > MAX_LOGLOG_VIEWS and len(prots) > 1:
        return [rrb.Tabs(*[rrb.Grid(*[v for k, v in views if k == pk],
                                    grid_columns=min(sum(k == pk for k, _ in views), 2),
                                    name=pk) for pk in prots], name=title)]
    if views:
        return [rrb.Grid(*[v for _, v in views], grid_columns=min(len(views), 2), name=title)]
    return []


def _monte_carlo_tab(w: _Writer, reps: dict):
    """The Monte Carlo tab: the summary over the replicates beside one static dot plot per
    headline metric of each protocol (it shows whatever timeline is selected: a time series on
    the replicate timeline blanked with sim_time selected)."""
    import rerun.blueprint as rrb

    views = []
    for metric, root in w.mc_plots.items():
        h = w.plot_right[root]
        prots = [p_ for p_, m_ in sorted(w.mc_plotted) if m_ == metric]
        views.append(rrb.Spatial2DView(
            name=f"{metric} over {_n_reps(reps)} replicates"
                 + (f", {prots[0]}" if len(prots) == 1 else ", a column per protocol"),
            origin=root,
            visual_bounds=rrb.VisualBounds2D(
                x_range=(min(w.plot_left[root], -0.6), w.mc_width[root] + 0.1),
                y_range=(-0.14, h + 0.02))))
    return rrb.Horizontal(
        rrb.TextDocumentView(name="Distribution over replicates", origin="/replicates/summary"),
        rrb.Vertical(*views) if len(views) > 1 else views[0],
        column_shares=[2, 3], name="Monte Carlo")


# ---------------------------------------------------------------------------------------------
# fogbench view DIR
def _how_to(rrd: Path, display: bool = True) -> str:
    web = (f"`fogbench view {rrd.parent} --web` serves it to a browser on this machine "
           "(127.0.0.1; from another one, tunnel its ports: `ssh -L 9090:localhost:9090 -L "
           "9876:localhost:9876 HOST`)")
    native = f"`rerun {rrd}` opens a native viewer (it needs a display)"
    first, second = (native, web) if display else (web, native)
    return (f"To open the recording: {first}; {second}. The viewer ships with rerun-sdk: "
            "`pip install rerun-sdk==0.41.*` (the recording's version).")
