"""The Rerun recording of a scenario run (``recording.rrd`` in the run directory).

``write_recording(res, path, replicates=None)`` writes one Rerun recording (application id
``fogbench``, recording id = the scenario name) holding every run of the scenario, with a
blueprint (the viewer's layout) declared in code; ``fogbench view DIR`` opens it (:func:`view`).

All time series are logged in bulk with ``send_columns`` on one timeline, ``sim_time`` (a
duration: the simulated time since the run's power-on, s). The runs of a scenario are separate
power-ons that all start at ``sim_time`` 0, so they share one time base: every time-series view
opens on the whole of the longest run (0 to its end) and their time axes are linked (zooming one
zooms all). In the 3-D view each run has its own table (``/table/<run>``), placed in a row along
the world y axis (0.8 m apart, base labelled with the run name), all moving together as
``sim_time`` plays; the default camera frames every table.

Entity paths (`<run>`: run name; `<protocol>`: protocol name, with `_2`, `_3`... appended when
a protocol scores the same run more than once; `<label>`: `raw`, `oracle` or a method label;
`<term>`: a FOG error term; `<metric>`: a metric name). The table is markdown, as in the README:

| entity path | content |
|---|---|
| `/table` | world frame, z up (static) |
| `/table/<run>` | the run's table, offset 0.8 m per run along world y (static transform) |
| `/table/<run>/base` | base and yoke boxes, labelled with the run name (static) |
| `/table/<run>/tilt` | tilt platform box; pose per sample = truth `tilt_quat` |
| `/table/<run>/turntable` | turntable cylinder (r 0.15 m); pose = `turntable_quat` |
| `/table/<run>/turntable/index_mark` | a mark near the turntable rim, to see it turn (static) |
| `/table/<run>/fog` | FOG case (9 cm cube); pose = `fog_pos`, `fog_quat` |
| `/table/<run>/fog/sensitive_axis` | orange arrow (0.2 m) along the scenario's sensitive axis, FOG frame, drawn from a point 0.11 m beside the case so that it stays apart from the gravity arrow when the two are parallel (static) |
| `/table/<run>/fog/gravity` | green arrow of `Truth.gravity` from the case centre, FOG frame, per sample (Arrows3D vectors column): 1 g *up*, what an accelerometer at rest reads, 0.12 m per g |
| `/runs/<run>/truth/rate` | true inertial rate about the sensitive axis, deg/s |
| `/runs/<run>/fog/raw` | raw FOG output, deg/s |
| `/runs/<run>/fog/compensated/<protocol>/<label>` | output of a scored piece (raw, oracle, each method), deg/s |
| `/runs/<run>/fog/error/<protocol>/<label>` | that output minus the truth, deg/h |
| `/runs/<run>/fog/error_shown/<protocol>/<label>` | the same with what every output keeps alike taken out (`fogbench.views.kept_alike`, as the PNG time series): raw's slow variation about its mean under a wander no method removes, or each curve's moving mean under fast noise every method keeps; each curve less its own mean where every claim on the run scores the std (`fogbench.views.mean_blind`); only for pieces that have such a thing or a sweep (then the errors as they are, the sweep's default named as such); the Overview shows these, the Errors tab the errors as they are, deg/h; a sweep's members other than its default are only in its envelope (next row) |
| `/runs/<run>/fog/error_shown/<protocol>/<sweep> envelope/{low,high}` | a sweep's envelope in the Overview's error view: the lowest and highest of its members' shown errors at each time (their errors as they are where a piece takes nothing out), deg/h |
| `/runs/<run>/fog/error_terms/<term>` | each simulated error term (`FogOutput.terms`), deg/h |
| `/runs/<run>/table/tilt_deg`, `tilt_cmd_deg` | tilt angle and its command, deg |
| `/runs/<run>/table/turn_rate_dps`, `turn_rate_cmd_dps` | turntable rate and its command, deg/s |
| `/runs/<run>/thermal/chamber_c`, `coil_c` | chamber and (true) coil temperature, deg C |
| `/runs/<run>/thermal/housing_c`, `sensor_c` | FOG housing temperature and the temperature sensor's reading (what the compensators get), deg C |
| `/runs/<run>/thermal/coil_rate_c_per_min` | true coil temperature rate, deg C/min |
| `/runs/<run>/thermal/sensor_rate_c_per_min` | temperature rate differenced from the sensor's readings (what the compensators get), deg C/min |
| `/runs/<run>/gravity/x`, `y`, `z` | `Truth.gravity` on the sensor axes, g |
| `/report/metrics` | metrics tables, failed methods, display decimation (markdown, static) |
| `/report/scenario` | the scenario file (markdown with a TOML block, static) |
| `/report/allan/<protocol>/<run>` | a log-log plot (static, 2-D view origin): `axes` (decade grid and labels), `legend` (names in their colours); `axes` and every curve carry the transform from (log10 tau/s, log10 deviation/(deg/h)) onto the plot |
| `/report/allan/<protocol>/<run>/<label>` | overlapping Allan deviation of (output - truth): a line strip of points (log10 tau in s, log10 ADEV in deg/h), static; up to the longest tau with at least 8 non-overlapping clusters |
| `/report/allan/<protocol>/<run>/<label>/ci` | its 68.3 % confidence interval at every tau: one vertical segment per tau, same coordinates |
| `/report/psd/<protocol>/<run>`, `.../<label>` | the same for the Welch PSD of (output - truth), mean removed, averaged in 10 bands a decade (``fogcomp.metrics.psd_bands``, as the PNGs): (log10 f/Hz, log10 PSD/((deg/h)^2/Hz)), and `/ci` its interval per band |
| `/report/{allan,psd}/<protocol>/<run>/<sweep> envelope low`, `... high` | a sweep's members but its default as their lowest and highest curve (every x a member reaches; thin, no intervals); where every output is raw plus a constant (``fogbench.views.offsets_only``) only raw's curve is logged |
| `/replicates/<protocol>/<metric>/<label>` | with Monte Carlo replicates: the metric of each replicate on the sequence timeline `replicate` (points) |
| `/replicates/summary` | the distribution of every replicated metric: median, 5-95 % range, finite replicates, one table per protocol and metric, the headline metrics first (markdown, static) |
| `/report/replicates/<metric>` | a dot plot of a headline metric over the replicates (static, 2-D view origin), a column per protocol: `names` (a row per label, named left of the columns), `title`; `<protocol>/axes` (grid, tick labels, the protocol's name), `<protocol>/<label>` the dots, one per replicate, at (value or its log10, row) under the transform onto the column, `<protocol>/<label>/range` its 5-95 % bar and median tick (`.../off_scale`: the note of a label drawn off scale) |

Scored pieces are logged at their own sample times (``Piece.t``): a subset of the run, and for
smoothed protocols the block means at the blocks' mean times. A method that failed has no
``compensated``/``error``/``allan``/``psd`` entries; the metrics text says so.

Allan deviation and PSD are static line strips in 2-D views with their own decade grid and
labels (Rerun 0.41 has no logarithmic plot axis): they show the moment their tab opens, whatever
timeline is selected. The confidence interval of the Allan deviation is the chi-square interval
(NIST SP 1065 eq. 45) with Greenhall and Riley's equivalent degrees of freedom for the noise type
that leads the curve at each tau (``fogcomp.allan.oadev_ci``: the five-term IEEE 952 model
fitted to the curve picks the type), so the bars widen where bias instability or rate random
walk dominate instead of keeping white noise's width. The PSD's
interval is the chi-square interval with each band's EDF: the Welch EDF of a Hann window at
50 % overlap (Percival and Walden 1993, eq. 292b) times the ordinates the band holds, less
their correlation (``fogcomp.metrics.band_edf``).

Colours (``fogbench.palette``, shared with the PNG figures): the method's colour everywhere (raw
grey, oracle cyan, one hue per method family -- the built-in method a label runs -- and the
members of a family in darker and lighter shades of it; every colour reads on both the light web
theme and the dark native one); a held-out protocol in the full colour, an in-sample one in a
30 % lighter tint with "(in-sample)" in its name. The Allan deviation stops at the longest tau
with at least ``palette.ALLAN_MIN_CLUSTERS`` (8) non-overlapping clusters, as in the PNGs. Series whose values are constant
to rounding (peak to peak below 1e-6 in their display unit) are shown on a fixed range around
their value instead of being autoscaled onto floating-point noise.

Long runs are decimated for display only (every k-th sample): at most ``MAX_SERIES_POINTS`` points
per series per run or piece and ``MAX_POSE_POINTS`` 3-D poses per run; ``/report/metrics`` gives k
for every run and piece. Every metric, Allan deviation and PSD is computed on the full record.

The blueprint (sent with the recording, active and default for the application) opens on tab
"Overview": the 3-D tables and the metrics on the left; on the right the error against truth of
each scored run (one tab per run: raw, oracle and every method of every protocol, deg/h, its
legend above the data) and the temperatures. Further tabs: "Errors" (every scored run side by
side), "Table and chamber" (rate of every run, truth and raw; tilt; turntable rate; gravity; coil
dT/dt; temperatures), "FOG error terms" (a plot per run), "Allan deviation" and "PSD" (a log-log
plot per scored piece), "Monte Carlo" (with replicates) and "Report".

Legends list every line: the members of a sweep share one entry, ``<group> (<n> settings)``, in
their family's hue (a viewer legend merges equal names; the shades tell the members apart), and
in a time series the methods of an in-sample protocol share one, ``<protocol> (in-sample):
every method, lighter`` (a view of a held-out and an in-sample protocol would otherwise list 2 x
the methods, more than a plot holds: the viewer's legend cuts off what does not fit). The
Allan and PSD tabs hold at most ``MAX_LOGLOG_VIEWS`` plots, else a tab per protocol (so that
each plot holds its legend). The log-log plots label at most ``LOGLOG_MAX_LABELS`` decades an
axis (every k-th; the grid keeps every decade) and span at most ``LOGLOG_MAX_DECADES`` decades
in y: lower values (a filtered output's PSD falling towards 0) are drawn on the floor; their
legend is right of the plot.

"Monte Carlo" (with replicates): the summary table (numbers first, the label last, so that long
labels do not push them off the panel) beside one dot plot per headline metric
(:func:`headline_metrics`: the metrics the claims are about, else the report's key metric), a
column per protocol on one x scale: a row per label, a dot per replicate, the 5-95 % bar and
the median tick. The plots
are static 2-D views: they show whatever timeline is selected (time series on the `replicate`
timeline showed nothing while `sim_time`, the default, was selected). A label whose median is
far from all the others (:func:`_off_scale`: paper000's oracle_filter, std 0) gets a note with
its median instead of stretching the axis over the differences the claims are about. Each
replicate's values are also on the sequence timeline `replicate` (`/replicates/...`).
"""

from __future__ import annotations

import importlib.util
import math
import os
import shutil
import subprocess
import sys
import warnings
import zlib
from pathlib import Path

import numpy as np

from fogcomp.units import DPH, DPS

from . import palette as PAL
from .fmt import decimation, fmt, md_table, metrics_table
from .views import (
    DWARF,
    kept_alike,
    mean_blind,
    method_entries,
    offsets_only,
    shown_error,
    sweep_names,
)

__all__ = ["write_recording", "view", "blueprint_for", "ReplicatesError", "decimation",
           "MAX_SERIES_POINTS", "MAX_POSE_POINTS", "TIMELINE", "REPLICATE_TIMELINE",
           "APPLICATION_ID", "CONFIDENCE", "headline_metrics", "LOGLOG_MAX_DECADES",
           "LOGLOG_MAX_LABELS"]

APPLICATION_ID = "fogbench"
TIMELINE = "sim_time"
REPLICATE_TIMELINE = "replicate"
MAX_SERIES_POINTS = 10_000
MAX_POSE_POINTS = 5_000
TABLE_SPACING_M = 0.8
GRAVITY_ARROW_M_PER_G = 0.12
AXIS_ARROW_M = 0.2
CONFIDENCE = 0.6826894921370859      # 1 sigma, as allantools' default
CONSTANT_PTP = 1e-6                  # peak to peak below this (display unit): constant
LEGEND_HEADROOM = 1.0                # error views: empty space above the data, times its span
MAX_LOGLOG_VIEWS = 6                 # Allan / PSD plots a tab; more: a tab per protocol
LEGEND_CHAR_W = 0.04                 # 2-D plots: estimated width of a label's character, scene

# geometry of sim/rate_table.xml (half sizes and centres in the body frame, m)
_BASE_BOXES = (((0.35, 0.30, 0.05), (0.0, 0.0, -0.55)),
               ((0.03, 0.08, 0.25), (-0.32, 0.0, -0.25)),
               ((0.03, 0.08, 0.25), (0.32, 0.0, -0.25)))
_TILT_BOX = ((0.28, 0.22, 0.02), (0.0, 0.0, -0.04))
_TURNTABLE = (0.15, 0.03)             # radius, length (MuJoCo half-height 0.015)
_FOG_BOX = (0.045, 0.045, 0.04)

# colours that read on the light web theme and the dark native one (no near-black, no
# near-white): fogbench.palette, shared with the PNG figures (raw grey, oracle cyan, a hue per
# method family, members of a family in shades of it)
_RAW, _ORACLE, _TRUTH = PAL.RAW, PAL.ORACLE, PAL.TRUTH
_PALETTE = list(PAL.FAMILY_HUES.values())
_RUN_PALETTE = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
                (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207)]
_GRID = (128, 128, 128, 110)


def _p(*parts: str) -> str:
    """An entity path from fixed words and names (names are escaped)."""
    import rerun as rr

    return "/" + "/".join(rr.escape_entity_path_part(str(x)) for x in parts)


def _tint(c, f: float) -> tuple:
    """``c`` blended towards white by the fraction ``f``."""
    return PAL._shade(c, f)


# ---------------------------------------------------------------------------------------------
# writing
class _Writer:
    def __init__(self, rec):
        import rerun as rr

        self.rr, self.rec = rr, rec
        self.ranges: dict[str, tuple[float, float]] = {}   # path -> (min, max) of what is shown
        self.plots: dict[str, str] = {}                       # log-log plot root -> note
        self.plot_right: dict[str, float] = {}                # plot root -> right end, scene
        self.plot_left: dict[str, float] = {}                 # Monte Carlo plot -> left end
        self.mc_plots: dict[str, str] = {}                    # headline metric -> plot root
        self.mc_plotted: set[tuple[str, str]] = set()         # (protocol, metric) plotted
        self.mc_width: dict[str, float] = {}                  # Monte Carlo plot -> box width
        self.shown: dict[str, tuple] = {}   # error root -> (kind, k, centre) taken out (views)
        # the Overview's error view draws a sweep as its default setting's line and the
        # envelope of its members: error root -> (members' shown paths not drawn, envelope's)
        self.sweeps: dict[str, tuple[set[str], list[str]]] = {}

    def _time(self, t: np.ndarray, timeline: str = TIMELINE):
        ns = np.round(np.asarray(t, dtype=float) * 1e9).astype(np.int64)
        return self.rr.TimeColumn(timeline, duration=ns.astype("timedelta64[ns]"))

    def series(self, path: str, t, y, name: str, color, width: float | None = None):
        rr = self.rr
        y = np.ascontiguousarray(y, dtype=np.float64)
        fin = y[np.isfinite(y)]
        if fin.size:
            self.ranges[path] = (float(fin.min()), float(fin.max()))
        self.rec.log(path, rr.SeriesLines(names=name, colors=[color],
                                          widths=None if width is None else [width]),
                     static=True)
        self.rec.send_columns(path, indexes=[self._time(t)],
                              columns=rr.Scalars.columns(scalars=y))


def _method_colors(res) -> dict[str, tuple]:
    """label -> colour of raw, oracle and every method: fogbench.palette.plan_styles, the
    colours of the PNG figures."""
    out = {lab: st.color for lab, st in PAL.plan_styles(res.plan).items()}
    out["raw"] = (*PAL.RAW, 150)     # drawn widest, under the methods: half transparent
    return out


def _color(colors: dict, lab: str) -> tuple:
    return colors.get(lab, _PALETTE[zlib.crc32(lab.encode()) % len(_PALETTE)])


def _piece_keys(res) -> list[str]:
    """The protocol part of the entity paths of each scored piece (unique per run)."""
    seen: dict[tuple[str, str], int] = {}
    keys = []
    for it in res.scored:
        k = (it.protocol, it.run)
        seen[k] = seen.get(k, 0) + 1
        keys.append(it.protocol if seen[k] == 1 else f"{it.protocol}_{seen[k]}")
    return keys


def _in_sample(res) -> dict[str, bool]:
    return {p.name: bool(p.in_sample) for p in res.plan.protocols}


class ReplicatesError(ValueError):
    """The ``replicates`` argument of :func:`write_recording` is malformed."""


def _check_replicates(replicates) -> dict:
    """``{protocol: {metric: {label: values}}}`` as float arrays, or a ReplicatesError naming
    the key that is wrong."""
    if replicates is None:
        return {}
    if not isinstance(replicates, dict):
        raise ReplicatesError(f"replicates: expected a dict {{protocol: {{metric: {{label: "
                              f"[values]}}}}}}, got {type(replicates).__name__}")
    out: dict = {}
    for prot, metrics in replicates.items():
        if not isinstance(metrics, dict):
            raise ReplicatesError(f"replicates[{prot!r}]: expected a dict {{metric: {{label: "
                                  f"[values]}}}}, got {type(metrics).__name__}")
        for metric, labels in metrics.items():
            if not isinstance(labels, dict):
                raise ReplicatesError(f"replicates[{prot!r}][{metric!r}]: expected a dict "
                                      f"{{label: [values]}}, got {type(labels).__name__}")
            for lab, vals in labels.items():
                where = f"replicates[{prot!r}][{metric!r}][{lab!r}]"
                try:
                    v = np.array([np.nan if x is None else x for x in vals], dtype=float)
                except (TypeError, ValueError) as exc:
                    raise ReplicatesError(f"{where}: expected a list of numbers (one per "
                                          f"replicate, None for a failed one): {exc}") from None
                if v.ndim != 1:
                    raise ReplicatesError(f"{where}: expected a flat list of numbers, got "
                                          f"shape {v.shape}")
                out.setdefault(str(prot), {}).setdefault(str(metric), {})[str(lab)] = v
    return out


def write_recording(res, path: Path, replicates: dict | None = None) -> None:
    """Write the Rerun recording of a scenario result to ``path``.

    Parameters
    ----------
    res : ScenarioResult
        The result of :func:`fogbench.runner.run_scenario`; with Monte Carlo, one representative
        replicate, shown in full.
    path : path-like
        The ``.rrd`` file to write.
    replicates : dict, optional
        ``{protocol: {metric: {label: values}}}``: each metric (unit in its name) of each label
        (``raw``, ``oracle``, a method) over the replicates, ``values[r]`` that of replicate
        ``r`` (None or NaN for a replicate where it is undefined). Logged on the sequence
        timeline ``replicate`` and summarised (median, 5-95 % range) in ``/replicates/summary``.

    Raises
    ------
    ReplicatesError
        ``replicates`` is malformed (checked before anything is written).

    See the module docstring for the entity paths, timelines and decimation.
    """
    import rerun as rr

    reps = _check_replicates(replicates)
    path = Path(path)
    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=res.scenario.name,
                             send_properties=False)
    # Logged into memory, then written by this process: a file sink writes from Rerun's own
    # thread, where a full disk or a file-size limit is only a line on stderr, never an error.
    mem = rec.memory_recording()
    try:
        w = _log_all(rec, res, reps)
        rec.send_blueprint(_blueprint(res, w, reps), make_active=True, make_default=True)
        rec.flush()
        data = mem.drain_as_bytes()
    finally:
        rec.disconnect()
    from fogcomp._persistence import atomic_write_bytes

    atomic_write_bytes(path, data)


def _log_all(rec, res, reps: dict) -> _Writer:
    """Log everything but the blueprint into ``rec``; the writer knows the ranges logged."""
    import rerun as rr

    sc = res.scenario
    rec.send_recording_name(sc.name)
    w = _Writer(rec)
    colors = _method_colors(res)
    axis = res.plan.axis
    j = sc.axes.index(axis)
    decim = {}
    for i, (name, rd) in enumerate(res.data.items()):
        decim[name] = _log_run(w, name, rd, j, _RUN_PALETTE[i % len(_RUN_PALETTE)])
        _log_table3d(w, name, i, rd, axis)
    piece_decim = []
    ins = _in_sample(res)
    for key, it in zip(_piece_keys(res), res.scored):
        piece_decim.append(_log_piece(w, key, it, colors, ins.get(it.protocol, False),
                                      _legend_names(res), res.plan))
    rec.log("/report/metrics", rr.TextDocument(_metrics_text(res, decim, piece_decim),
                                               media_type="text/markdown"), static=True)
    rec.log("/report/scenario", rr.TextDocument(
        f"# Scenario `{sc.name}`\n\n`{sc.path}`\n\n```toml\n{sc.text}\n```\n",
        media_type="text/markdown"), static=True)
    if reps:
        _log_replicates(w, reps, colors, res.plan)
    return w


def blueprint_for(res, replicates: dict | None = None, active_tab: str = "Overview"):
    """The blueprint :func:`write_recording` sends, opened on the tab ``active_tab``.

    For tools that drive a viewer (``scripts/screenshots.py``): it logs the recording once more
    into memory to know the ranges of the series (about the time of a write).
    """
    import rerun as rr

    reps = _check_replicates(replicates)
    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=res.scenario.name,
                             send_properties=False)
    rec.memory_recording()
    try:
        w = _log_all(rec, res, reps)
    finally:
        rec.disconnect()
    return _blueprint(res, w, reps, active_tab=active_tab)


def _log_run(w: _Writer, name: str, rd, j: int, run_color) -> tuple[int, int]:
    """The time series of one run; returns the (series, pose) decimation factors."""
    tr = rd.truth
    k = decimation(rd.n, MAX_SERIES_POINTS)
    s = slice(None, None, k)
    t = tr.t[s]
    w.series(_p("runs", name, "truth", "rate"), t, rd.truth_axis(j)[s] / DPS,
             f"{name} truth", run_color, width=2.0)
    w.series(_p("runs", name, "fog", "raw"), t, rd.fog.raw[s, j] / DPS,
             f"{name} raw", _tint(run_color, 0.5), width=1.0)
    table = {"tilt_deg": (np.degrees(tr.tilt[s]), "tilt", run_color),
             "tilt_cmd_deg": (np.degrees(tr.tilt_cmd[s]), "tilt command", _tint(run_color, 0.5)),
             "turn_rate_dps": (np.degrees(tr.turn_rate[s]), "turntable rate", run_color),
             "turn_rate_cmd_dps": (np.degrees(tr.turn_rate_cmd[s]), "turntable rate command",
                                   _tint(run_color, 0.5))}
    for leaf, (y, label, c) in table.items():
        w.series(_p("runs", name, "table", leaf), t, y, f"{name} {label}", c)
    th = rd.thermal
    for leaf, y, label, c in (("chamber_c", th.chamber, "chamber", _tint(run_color, 0.5)),
                              ("coil_c", th.coil, "coil", run_color),
                              ("housing_c", th.housing, "housing", _tint(run_color, 0.25)),
                              ("sensor_c", th.sensor, "sensor reading", _tint(run_color, 0.7)),
                              ("coil_rate_c_per_min", th.coil_rate * 60.0, "coil dT/dt",
                               run_color),
                              ("sensor_rate_c_per_min", th.sensor_rate * 60.0,
                               "sensor dT/dt", _tint(run_color, 0.6))):
        if y is not None:
            w.series(_p("runs", name, "thermal", leaf), t, y[s], f"{name} {label}", c)
    for i, (ax, c) in enumerate(zip("xyz", ((214, 39, 40), (44, 160, 44), (31, 119, 180)))):
        w.series(_p("runs", name, "gravity", ax), t, tr.gravity[s, i], f"{name} gravity {ax}", c)
    for i, (term, v) in enumerate(rd.fog.terms.items()):
        w.series(_p("runs", name, "fog", "error_terms", term), t, v[s, j] / DPH, term,
                 (_PALETTE + [_ORACLE, _RAW])[i % (len(_PALETTE) + 2)])
    return k, decimation(rd.n, MAX_POSE_POINTS)


def _log_table3d(w: _Writer, name: str, i: int, rd, axis: str) -> None:
    rr, rec = w.rr, w.rec
    tr = rd.truth
    root = _p("table", name)
    rec.log(root, rr.Transform3D(translation=[0.0, i * TABLE_SPACING_M, 0.0]), static=True)
    rec.log(f"{root}/base", rr.Boxes3D(half_sizes=[b[0] for b in _BASE_BOXES],
                                       centers=[b[1] for b in _BASE_BOXES],
                                       colors=[(110, 110, 120)] * 3,
                                       labels=[name, "", ""], show_labels=True,
                                       fill_mode="solid"), static=True)
    rec.log(f"{root}/tilt", rr.Boxes3D(half_sizes=[_TILT_BOX[0]], centers=[_TILT_BOX[1]],
                                       colors=[(170, 170, 185)], fill_mode="solid"), static=True)
    rec.log(f"{root}/turntable", rr.Cylinders3D(radii=[_TURNTABLE[0]], lengths=[_TURNTABLE[1]],
                                                centers=[(0.0, 0.0, 0.0)],
                                                colors=[(200, 200, 210)], fill_mode="solid"),
            static=True)
    rec.log(f"{root}/turntable/index_mark",
            rr.Boxes3D(half_sizes=[(0.025, 0.008, 0.004)], centers=[(0.12, 0.0, 0.019)],
                       colors=[(214, 39, 40)], fill_mode="solid"), static=True)
    rec.log(f"{root}/fog", rr.Boxes3D(half_sizes=[_FOG_BOX], colors=[(31, 119, 180)],
                                      fill_mode="solid"), static=True)
    # the sensitive axis starts at a corner of the case, off the gravity arrow (which starts at
    # the centre): the two stay apart when they are collinear (a level table, axis z)
    ia = "xyz".index(axis)
    e = np.zeros(3)
    e[ia] = AXIS_ARROW_M
    corner = 2.5 * np.array(_FOG_BOX, dtype=float)
    corner[ia] = 0.0
    corner[(ia + 1) % 3] *= -1.0
    rec.log(f"{root}/fog/sensitive_axis",
            rr.Arrows3D(vectors=[e], origins=[corner], colors=[(255, 127, 14)],
                        labels=[f"sensitive axis {axis}"], show_labels=False, radii=[0.005]), static=True)
    rec.log(f"{root}/fog/gravity", rr.Arrows3D.from_fields(
        origins=[(0.0, 0.0, 0.0)], colors=[(44, 160, 44)], labels=["gravity (up, 1 g)"],
        show_labels=False,
        radii=[0.005]), static=True)

    s = slice(None, None, decimation(rd.n, MAX_POSE_POINTS))
    tcol = [w._time(tr.t[s])]
    wxyz_to_xyzw = [1, 2, 3, 0]
    rec.send_columns(f"{root}/tilt", indexes=tcol, columns=rr.Transform3D.columns(
        quaternion=np.ascontiguousarray(tr.tilt_quat[s][:, wxyz_to_xyzw])))
    rec.send_columns(f"{root}/turntable", indexes=tcol, columns=rr.Transform3D.columns(
        quaternion=np.ascontiguousarray(tr.turntable_quat[s][:, wxyz_to_xyzw])))
    rec.send_columns(f"{root}/fog", indexes=tcol, columns=rr.Transform3D.columns(
        translation=np.ascontiguousarray(tr.fog_pos[s]),
        quaternion=np.ascontiguousarray(tr.fog_quat[s][:, wxyz_to_xyzw])))
    rec.send_columns(f"{root}/fog/gravity", indexes=tcol, columns=rr.Arrows3D.columns(
        vectors=np.ascontiguousarray(tr.gravity[s] * GRAVITY_ARROW_M_PER_G)))


def _piece_name(lab: str, in_sample: bool) -> str:
    return f"{lab} (in-sample)" if in_sample and lab not in ("raw", "oracle") else lab


def _legend_names(res) -> dict[str, str]:
    """label -> its name in legends: the members of a sweep share their group's name,
    ``"<group> (<n> settings)"`` (one legend entry: a viewer legend merges equal names), the
    others their label."""
    groups: dict[str, list[str]] = {}
    for m in res.plan.methods:
        if getattr(m, "group", None):
            groups.setdefault(m.group, []).append(m.label)
    return {lab: f"{g} ({len(labs)} settings)" for g, labs in groups.items() for lab in labs}


def _series_name(lab: str, in_sample: bool, protocol: str, names: dict) -> str:
    """The name of a time series of a scored piece (its legend entry): a method of an in-sample
    protocol is one entry for them all, the lighter tints (the legend of a view holding a
    held-out and an in-sample protocol lists each method once)."""
    if in_sample and lab not in ("raw", "oracle"):
        return f"{protocol} (in-sample): every method, lighter"
    return names.get(lab, lab)


def _piece_color(colors, lab: str, in_sample: bool) -> tuple:
    c = _color(colors, lab)
    return PAL.in_sample(c) if in_sample and lab not in ("raw", "oracle") else c


def _log_piece(w: _Writer, key: str, it, colors, in_sample: bool,
               names: dict | None = None, plan=None) -> int:
    """Compensated outputs, errors, Allan deviation and PSD of one scored piece. In the
    Overview's error view (``error_shown``) a sweep is its default setting's line and the
    envelope of its members (the best and the worst at each time), as in the PNGs."""
    from fogcomp import metrics as M
    from fogcomp.allan import oadev_ci

    p = it.piece
    names = names or {}
    k = decimation(p.t.size, MAX_SERIES_POINTS)
    s = slice(None, None, k)
    allan, psd = [], []
    # what every output keeps alike (a wander no method removes), taken out for the Overview's
    # error view as in the PNG time series (fogbench.views.kept_alike)
    errs = {lab: (out - p.truth) / DPH for lab, out in it.outputs.items()}
    kind, trend, kw = kept_alike(errs, [lab for lab in errs if lab not in ("raw", "oracle")])
    centre = mean_blind(plan, it.run)
    if kind is not None or centre:
        w.shown[_p("runs", it.run, "fog", "error", key)] = (kind, kw, centre)
    sweeps = [e for e in method_entries(list(it.outputs), plan) if e["group"]] \
        if plan is not None else []
    members_shown: dict[str, np.ndarray] = {}
    in_envelope = {m for e in sweeps for m in e["members"] if m != e["default"]}
    # where a sweep is its default's line and an envelope, the default is named as such (the
    # Errors tab keeps every member under the sweep's one name)
    as_default = {e["default"]: sweep_names(e)[0] for e in sweeps}
    # outputs that are raw plus a constant: the Allan deviation and PSD of raw alone (every
    # other curve would lie on raw's), as in the PNGs
    spectra = {"raw"} if offsets_only(it) else set(it.outputs)
    for lab, out in it.outputs.items():
        c = _piece_color(colors, lab, in_sample)
        name = _piece_name(as_default.get(lab, names.get(lab, lab)), in_sample)  # Allan, PSD
        sname = _series_name(lab, in_sample, it.protocol, names)  # time series legends
        width = 3.0 if lab == "raw" else 1.5
        w.series(_p("runs", it.run, "fog", "compensated", key, lab), p.t[s], out[s] / DPS,
                 sname, c, width)
        w.series(_p("runs", it.run, "fog", "error", key, lab), p.t[s],
                 (out[s] - p.truth[s]) / DPH, sname, c, width)
        err = errs[lab]
        if kind is not None or centre or sweeps:  # (a sweep's default is named as such)
            shown = shown_error(kind, err, trend, kw, centre)
            members_shown[lab] = shown
            if lab not in in_envelope:
                w.series(_p("runs", it.run, "fog", "error_shown", key, lab), p.t[s], shown[s],
                         _series_name(lab, in_sample, it.protocol, {**names, **as_default}),
                         c, width)
        if lab in spectra and p.raw.size >= 64:
            try:
                # intervals from the EDF of the noise type leading each tau (Greenhall & Riley)
                ad = oadev_ci(err, p.fs, ci=CONFIDENCE)
            except ValueError:  # display only: a curve that cannot be computed is left out
                ad = None
            if ad is not None:
                ok = np.isfinite(ad.adev) & (ad.adev > 0) & np.isfinite(ad.low) & \
                    np.isfinite(ad.high) & PAL.allan_drawn(ad.m, ad.n)   # as the PNG
                if ok.sum() >= 2:
                    allan.append((lab, name, c, ad.taus[ok], ad.adev[ok], ad.low[ok],
                                  ad.high[ok]))
        if lab in spectra and p.raw.size >= 16:
            try:
                # as the PNGs: Welch averaged in log-spaced bands, each with its interval
                f, pxx, edf = M.psd_bands(err, p.fs, per_decade=PAL.PSD_PER_DECADE)
                low, high = M.psd_band_interval(pxx, edf, CONFIDENCE)
            except ValueError:
                f = pxx = low = high = np.zeros(0)
            ok = (f > 0) & np.isfinite(pxx) & (pxx > 0)
            if ok.sum() >= 2:
                psd.append((lab, name, c, f[ok], pxx[ok], low[ok], high[ok]))
    envelope = []
    for e in sweeps:
        stack = np.vstack([members_shown[m][s] for m in e["members"]])
        c, name = _envelope_style(e, colors, in_sample, it.protocol, series=True)
        with warnings.catch_warnings():     # a time no member has: NaN, not drawn
            warnings.simplefilter("ignore", RuntimeWarning)
            ends = {"low": np.nanmin(stack, axis=0), "high": np.nanmax(stack, axis=0)}
        for end, y in ends.items():
            path = _p("runs", it.run, "fog", "error_shown", key, f"{e['group']} {ENVELOPE}", end)
            w.series(path, p.t[s], y, name, c, 1.0)
            envelope.append(path)
    if sweeps:       # the members the Overview leaves to the envelope
        w.sweeps[_p("runs", it.run, "fog", "error", key)] = (
            {_p("runs", it.run, "fog", "error_shown", key, m) for m in in_envelope}, envelope)
    allan, psd = (_sweeps_as_envelopes(curves, sweeps, colors, in_sample, it.protocol)
                  for curves in (allan, psd))
    if allan:
        _loglog(w, _p("report", "allan", key, it.run), allan, "tau, s",
                "Allan deviation of output - truth, deg/h",
                f"bars: {100 * CONFIDENCE:.0f} % interval, EDF of the leading noise type")
    if psd:
        _loglog(w, _p("report", "psd", key, it.run), psd, "frequency, Hz",
                "PSD of output - truth, (deg/h)^2/Hz",
                f"Welch in {PAL.PSD_PER_DECADE} bands a decade; bars: "
                f"{100 * CONFIDENCE:.0f} % interval, EDF of each band")
    return k


def _sweeps_as_envelopes(curves: list, sweeps: list, colors, in_sample: bool,
                         protocol: str) -> list:
    """Log-log ``curves`` (label, name, colour, x, y, lo, hi) with each sweep's members but its
    default setting replaced by their envelope, as in the PNGs: two thin lines, the lowest and
    the highest member at every x all of them reach, one legend entry, no interval bars."""
    by_lab = {c[0]: c for c in curves}
    out = list(curves)
    for e in sweeps:
        have = [by_lab[m] for m in e["members"] if m in by_lab]
        if len(have) < 2:
            continue
        xs = have[0][3]
        for c in have[1:]:
            xs = np.union1d(xs, c[3])           # every x a member reaches (the PNG's nanmin)
        ys = np.full((len(have), xs.size), np.nan)
        for row, c in zip(ys, have):
            row[np.searchsorted(xs, c[3])] = c[4]
        color, name = _envelope_style(e, colors, in_sample, protocol, series=False)
        out = [c for c in out if c[0] not in e["members"] or c[0] == e["default"]]
        out += [(f"{e['group']} {ENVELOPE} {end}", name, color, xs, y, None, None)
                for end, y in (("low", np.nanmin(ys, axis=0)), ("high", np.nanmax(ys, axis=0)))]
    return out


ENVELOPE = "envelope"     # a sweep's envelope: paths ``<sweep> envelope/low``, ``.../high``


def _envelope_style(e: dict, colors, in_sample: bool, protocol: str, series: bool):
    """(colour, legend name) of sweep ``e``'s envelope lines: its default's colour, lighter;
    ``"<sweep>: <n> settings, best..worst"``, or, in-sample, a time series' shared in-sample
    name (``series``) or that name marked in-sample (Allan and PSD plots)."""
    color = _tint(_piece_color(colors, e["default"], in_sample), 0.35)
    if in_sample and series:
        return color, _series_name(e["default"], in_sample, protocol, {})
    return color, _piece_name(sweep_names(e)[1], in_sample)


def _decade_label(k: int) -> str:
    return f"{10.0 ** k:g}" if -3 <= k <= 4 else f"1e{k}"


# plot box of the log-log views, scene units of the 2-D view (y grows downwards)
_PLOT_W, _PLOT_H = 1.6, 1.0
#: Most decades a log-log plot's y axis spans: lower values (a filtered output's PSD falling to
#: 1e-13 at high frequencies) are drawn on the axis floor, so the decades that matter stay apart.
LOGLOG_MAX_DECADES = 8
#: Most labelled decades per axis: every k-th decade is labelled (the grid keeps every decade).
LOGLOG_MAX_LABELS = 6


def _decade_step(n_decades: int) -> int:
    """Label every k-th decade: at most ``LOGLOG_MAX_LABELS`` labels on an axis."""
    return max(1, math.ceil((n_decades + 1) / LOGLOG_MAX_LABELS))


def _loglog(w: _Writer, root: str, curves, xlabel: str, ylabel: str, note: str) -> None:
    """A log-log plot as static 2-D entities under ``root`` (the origin of its view).

    ``curves``: (label, name, colour, x, y, lo, hi) with x, y > 0 and optional interval bounds
    lo, hi (arrays like y, or None). The curves, their intervals, the decade grid and its labels
    are logged in (log10 x, log10 y) coordinates under a transform onto the plot box (each such
    child carries it: a view ignores the transform of its own origin); the legend is in the
    box's own units, right of it.
    """
    rr, rec = w.rr, w.rec
    lx = [np.log10(c[3]) for c in curves]
    ly = [np.log10(c[4]) for c in curves] + [np.log10(c[5]) for c in curves if c[5] is not None] \
        + [np.log10(c[6]) for c in curves if c[6] is not None]
    ly = [v[np.isfinite(v)] for v in ly]
    x0 = math.floor(min(v.min() for v in lx))
    x1 = max(math.ceil(max(v.max() for v in lx)), x0 + 1)
    y0 = math.floor(min(v.min() for v in ly if v.size))
    y1 = max(math.ceil(max(v.max() for v in ly if v.size)), y0 + 1)
    y0 = max(y0, y1 - LOGLOG_MAX_DECADES)     # lower values are drawn on the floor
    sx, sy = _PLOT_W / (x1 - x0), _PLOT_H / (y1 - y0)
    tf = rr.Transform3D(translation=[-x0 * sx, _PLOT_H + y0 * sy, 0.0], scale=[sx, -sy, 1.0])
    rec.log(f"{root}/axes", tf, static=True)
    grid = [[(x, y0), (x, y1)] for x in range(x0, x1 + 1)] + \
        [[(x0, y), (x1, y)] for y in range(y0, y1 + 1)]
    rec.log(f"{root}/axes/grid", rr.LineStrips2D(grid, colors=[_GRID],
                                                 radii=rr.Radius.ui_points(0.5),
                                                 draw_order=0.0), static=True)
    # tick labels (centred on their point): x below the box, y left of it, every k-th decade
    # (at most LOGLOG_MAX_LABELS); the axis titles clear of them, x under the x labels, y above
    # the box's top right (the top y label sits at its top left)
    dx, dy = 0.17 / sx, 0.07 / sy   # label offsets: 0.17 and 0.07 plot units, in decades
    kx, ky = _decade_step(x1 - x0), _decade_step(y1 - y0)
    xt = [x for x in range(x0, x1 + 1) if (x - x0) % kx == 0]
    yt = [y for y in range(y1, y0 - 1, -1) if (y1 - y) % ky == 0]
    pos = [(x, y0 - dy) for x in xt] + [(x0 - dx, y) for y in yt]
    labels = [_decade_label(x) for x in xt] + [_decade_label(y) for y in yt]
    pos += [((x0 + x1) / 2.0, y0 - 2.6 * dy), (x0 + 0.55 * (x1 - x0), y1 + 0.13 / sy)]
    labels += [xlabel, ylabel]
    rec.log(f"{root}/axes/labels", rr.Points2D(pos, labels=labels, radii=rr.Radius.ui_points(0.1),
                                               colors=[(128, 128, 128)], show_labels=True,
                                               draw_order=1.0), static=True)
    for i, (lab, name, c, x, y, lo, hi) in enumerate(curves):
        path = f"{root}/{w.rr.escape_entity_path_part(lab)}"
        width = 4.0 if lab == "raw" else 0.75 if lab.endswith((f"{ENVELOPE} low",
                                                              f"{ENVELOPE} high")) else 1.5
        rec.log(path, tf, static=True)
        rec.log(path, rr.LineStrips2D([np.column_stack([np.log10(x),
                                                        np.maximum(np.log10(y), y0)])],
                                      colors=[c], radii=rr.Radius.ui_points(width / 2.0),
                                      labels=[name], show_labels=False,
                                      draw_order=10.0 + i), static=True)
        if lo is not None:
            bars = [[(a, max(np.log10(b), y0)), (a, max(np.log10(d), y0))]
                    for a, b, d in zip(np.log10(x), lo, hi)
                    if b > 0 and np.isfinite(b) and np.isfinite(d)]
            rec.log(f"{path}/ci", rr.LineStrips2D(bars, colors=[c],
                                                  radii=rr.Radius.ui_points(0.75),
                                                  draw_order=10.0 + i), static=True)
    # legend: right of the plot box, the name of each curve in its colour (a label is centred
    # on its point)
    # (one entry per name: the members of a sweep share one, in their family's colour); a
    # label's width is estimated at LEGEND_CHAR_W plot units a character to line them up on
    # their left end
    entries: dict[str, tuple] = {}
    for c in curves:
        entries.setdefault(c[1], c[2][:3])
    step = min(0.12, (_PLOT_H + 0.25) / max(len(entries), 1))
    pts = [(_PLOT_W + 0.1 + 0.5 * LEGEND_CHAR_W * len(n), (i + 0.4) * step)
           for i, n in enumerate(entries)]
    rec.log(f"{root}/legend", rr.Points2D(
        pts, labels=list(entries), colors=list(entries.values()),
        radii=rr.Radius.ui_points(0.1), show_labels=True), static=True)
    w.plots[root] = note
    w.plot_right[root] = _PLOT_W + 0.15 + LEGEND_CHAR_W * max(len(n) for n in entries)


def headline_metrics(plan, metrics) -> list[str]:
    """The metrics of one protocol's replicates that the Monte Carlo tab plots (its headline
    metrics): every metric a claim of the scenario is about, in the order of the claims, where
    the protocol has it; else the one the report's distribution figure shows
    (:func:`fogbench.fmt.key_metric`); else the first. ``metrics``: ``{metric: {label:
    values}}``."""
    out: list[str] = []
    for c in getattr(plan, "claims", ()):
        if c.metric in metrics and c.metric not in out:
            out.append(c.metric)
    if not out:
        from .fmt import key_metric

        have = {m: True for m, labs in metrics.items() if "raw" in labs}
        km = key_metric({"over_runs": {"_": {"raw": have}}}, "_", plan)
        out = [km] if km else list(metrics)[:1]
    return out


def _nice_ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    """About ``n`` round numbers (1, 2 or 5 times a power of ten apart) within [lo, hi]."""
    if not hi > lo:
        return [lo]
    raw = (hi - lo) / n
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(k * mag for k in (1.0, 2.0, 5.0, 10.0) if k * mag >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    return [first + i * step for i in range(int((hi - first) / step + 1e-9) + 1)]


# Monte Carlo plots: data box width and row height, scene units (y grows downwards)
_MC_W, _MC_ROW = 1.2, 0.1


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
    rr, rec = w.rr, w.rec
    prots = list(cols)
    labels = list(dict.fromkeys(lab for pr in prots for lab in cols[pr]))
    cells = [(pr, lab, np.asarray(cols[pr][lab], float)) for pr in prots for lab in cols[pr]]
    fin = [v[np.isfinite(v)] for _, _, v in cells]
    off = _off_scale(fin)
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
    n = len(labels)
    box_h = n * _MC_ROW
    names_w = 0.1 + LEGEND_CHAR_W * max((len(x) for x in labels), default=4)
    gap = 0.15
    notes = {(pr, lab): f"off scale: {fmt(float(np.median(f)), metric)}"
             for (pr, lab, _), f, o in zip(cells, fin, off) if o and f.size}
    # the boxes as wide as a plot about twice as wide as tall leaves beside the names, and
    # each at least as wide as its longest text (an off-scale note, the protocol's name under
    # it): paper002's four columns (two protocols and their ideal twins) ran notes into the
    # next column
    text_w = LEGEND_CHAR_W * max([len(x) for x in notes.values()]
                                 + [len(pr) if len(prots) > 1 else 0 for pr in prots]) + 0.06
    box_w = max(_MC_W / len(prots) + 0.3, text_w,
                (2.0 * (box_h + 0.35) - names_w - gap * (len(prots) - 1)) / len(prots))
    sx = box_w / (hi - lo)
    if log:
        k = _decade_step(hi - lo)
        ticks = [float(d) for d in range(int(lo), int(hi) + 1)]
        tl = [_decade_label(int(d)) if (int(d) - int(lo)) % k == 0 else "" for d in ticks]
    else:
        ticks = _nice_ticks(lo, hi, 4 if len(prots) > 1 else 5)
        tl = [fmt(t, metric) for t in ticks]
    rec.log(f"{root}/names", rr.Points2D(
        [(-0.06 - 0.5 * LEGEND_CHAR_W * len(x), (i + 0.5) * _MC_ROW)
         for i, x in enumerate(labels)],
        labels=labels, colors=[_color(colors, x)[:3] for x in labels],
        radii=rr.Radius.ui_points(0.1), show_labels=True), static=True)
    total_w = len(prots) * box_w + gap * (len(prots) - 1)
    rec.log(f"{root}/title", rr.Points2D(
        [(0.5 * (total_w - names_w), box_h + 0.17)],
        labels=[f"{metric}{' (log scale)' if log else ''}: a dot per replicate, bar 5-95 %, "
                "tick median"], colors=[(128, 128, 128)], radii=rr.Radius.ui_points(0.1),
        show_labels=True), static=True)
    for j, pr in enumerate(prots):
        x0 = j * (box_w + gap)
        base = f"{root}/{rr.escape_entity_path_part(pr)}"
        tf = rr.Transform3D(translation=[x0 - lo * sx, 0.0, 0.0], scale=[sx, 1.0, 1.0])
        rec.log(f"{base}/axes", tf, static=True)
        rec.log(f"{base}/axes/grid", rr.LineStrips2D(
            [[(t, 0.0), (t, box_h)] for t in ticks]
            + [[(lo, 0.0), (hi, 0.0)], [(lo, box_h), (hi, box_h)]],
            colors=[_GRID], radii=rr.Radius.ui_points(0.5), draw_order=0.0), static=True)
        pos = [(t, box_h + 0.06) for t, x in zip(ticks, tl) if x]
        txt = [x for x in tl if x]
        if len(prots) > 1:
            pos.append(((lo + hi) / 2.0, -0.07))
            txt.append(pr)
        rec.log(f"{base}/axes/labels", rr.Points2D(
            pos, labels=txt, radii=rr.Radius.ui_points(0.1), colors=[(128, 128, 128)],
            show_labels=True, draw_order=1.0), static=True)
    for (pr, lab, v), f, o in zip(cells, fin, off):
        i = labels.index(lab)
        j = prots.index(pr)
        c = _color(colors, lab)[:3]
        y = (i + 0.5) * _MC_ROW
        path = f"{root}/{rr.escape_entity_path_part(pr)}/{rr.escape_entity_path_part(lab)}"
        rec.log(path, rr.Transform3D(translation=[j * (box_w + gap) - lo * sx, 0.0, 0.0],
                                     scale=[sx, 1.0, 1.0]), static=True)
        if f.size == 0:
            continue
        x = np.log10(f) if log else f
        if o:
            med = float(np.median(f))
            left = (math.log10(med) if log and med > 0 else med) < lo
            note = notes[(pr, lab)]
            rec.log(f"{path}/off_scale", rr.Points2D(
                [(lo + (0.5 * LEGEND_CHAR_W * len(note)) / sx if left
                  else hi - (0.5 * LEGEND_CHAR_W * len(note)) / sx, y)],
                labels=[note], colors=[c], radii=rr.Radius.ui_points(0.1),
                show_labels=True, draw_order=20.0), static=True)
            continue
        rec.log(path, rr.Points2D(np.column_stack([x, np.full(x.size, y)]), colors=[c],
                                  radii=rr.Radius.ui_points(3.0), draw_order=10.0 + i),
                static=True)
        q5, q50, q95 = np.percentile(x, [5, 50, 95])
        rec.log(f"{path}/range", rr.LineStrips2D(
            [[(q5, y), (q95, y)], [(q50, y - 0.4 * _MC_ROW), (q50, y + 0.4 * _MC_ROW)]],
            colors=[c], radii=[rr.Radius.ui_points(1.0), rr.Radius.ui_points(2.0)],
            draw_order=9.0 + i), static=True)
    w.plot_right[root] = box_h + 0.25                    # the plot's height, scene units
    w.plot_left[root] = -names_w
    w.mc_width[root] = total_w


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


def _metrics_text(res, decim: dict, piece_decim: list[int]) -> str:
    sc, plan = res.scenario, res.plan
    L = [f"# {sc.name}", "", sc.description, "",
         f"Axis `{plan.axis}`, {sc.fs:g} Hz, FOG: {sc.device}. "
         f"Wall time {res.wall_s:.1f} s.", "",
         "Metric units are in their names: `_dps` deg/s, `_dph` deg/h, `_deg` deg, `_pct` "
         "percent improvement over raw, `_s` seconds. Every metric uses every sample.", "",
         "## Display decimation", "",
         f"Series are decimated for display only (every k-th sample; at most "
         f"{MAX_SERIES_POINTS:,} points per series per run or piece, {MAX_POSE_POINTS:,} 3-D "
         "poses per run).", "",
         md_table(["run", "samples", "series decimation k", "3-D pose decimation k"],
                   [[name, str(rd.n), str(decim[name][0]), str(decim[name][1])]
                    for name, rd in res.data.items()]), ""]
    keys = _piece_keys(res)
    L += [md_table(["protocol (entity name)", "run", "piece samples", "fs, Hz", "decimation k"],
                    [[key, it.run, str(it.piece.t.size), f"{it.piece.fs:g}", str(k)]
                     for key, it, k in zip(keys, res.scored, piece_decim)]), ""]
    failed = []
    prots = {p.name: p for p in plan.protocols}
    for key, it in zip(keys, res.scored):
        prot = prots.get(it.protocol)
        flag = " (IN-SAMPLE)" if prot is not None and prot.in_sample else " (held out)"
        L += [f"## `{key}`{flag} / `{it.run}`", ""]
        failed += [(key, it.run, lab, m.get("error", "")) for lab, m in it.metrics.items()
                   if m.get("status") == "failed"]
        L += [metrics_table(it.metrics), ""]
    if failed:
        L += ["## Failed methods", "",
              "These have no `compensated` or `error` series in this recording:", ""]
        L += [f"- `{lab}` in `{key}` / `{run}`: {err}" for key, run, lab, err in failed]
        L += [""]
    L += ["## Viewer", "",
          f"Time series are on the `{TIMELINE}` timeline (simulated time since power-on, s; "
          "every run starts at 0); every plot opens on the whole of the longest run and their "
          "time axes are linked. Errors are output minus truth in deg/h: raw grey, oracle cyan, "
          "one colour per method; an in-sample protocol is drawn in a lighter tint and named "
          "`(in-sample)`. Tabs `Allan deviation` and `PSD` hold log-log plots (decade grid, "
          f"tau in s, deviation in deg/h) with {100 * CONFIDENCE:.0f} % intervals. A plot whose "
          f"values are constant to within {CONSTANT_PTP:g} (its unit) is shown on a fixed range "
          "around the value.", ""]
    return "\n".join(L)


def _y_axis(w: _Writer, paths: list[str], unit: str | None = None):
    """A fixed y range for a view whose series are all constant to rounding, or that span less
    than the palette's least span of ``unit`` (``fogbench.palette.MIN_SPAN``: a temperature
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
    import rerun as rr
    import rerun.blueprint as rrb

    runs = list(res.data)
    t_end = max(float(rd.truth.t[-1]) for rd in res.data.values())
    time_range = rr.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=0.0),
                              end=rrb.TimeRangeBoundary.absolute(seconds=t_end))
    time_axis = rrb.TimeAxis(link="LinkToGlobal", view_range=time_range)
    whole = rrb.VisibleTimeRange(TIMELINE, start=rrb.TimeRangeBoundary.infinite(),
                                 end=rrb.TimeRangeBoundary.infinite())

    def plot(name, paths, legend=False, corner="RightTop", headroom=False, unit=None):
        paths = list(paths)
        return rrb.TimeSeriesView(
            name=name, contents=paths, axis_x=time_axis,
            axis_y=_y_axis_with_headroom(w, paths) if headroom else _y_axis(w, paths, unit),
            time_ranges=[whole],
            plot_legend=rrb.PlotLegend(visible=legend, corner=corner))

    def each(*leaf):
        return [_p("runs", r, *leaf) for r in runs]

    # the error views: one per scored run, every protocol scoring it, raw and oracle once unless
    # they differ between protocols
    keys = _piece_keys(res)
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
    error_views = {r: lst for r, lst in by_run.items()}

    rate = [x for r in runs for x in (_p("runs", r, "truth", "rate"), _p("runs", r, "fog", "raw"))]
    temp = each("thermal", "coil_c") + each("thermal", "housing_c") + \
        each("thermal", "chamber_c") + each("thermal", "sensor_c")
    temp_title = ("Temperature, deg C: coil (darkest), housing, chamber, sensor reading "
                  "(lightest)")
    n_tables = len(runs)
    # a camera that frames the row of tables (0.8 m apart along y, each about 0.7 x 0.6 x 0.6 m)
    mid_y = 0.5 * (n_tables - 1) * TABLE_SPACING_M
    span = (n_tables - 1) * TABLE_SPACING_M + 0.8
    dist = 0.75 * span + 1.4
    eye = rrb.EyeControls3D(position=(dist * 0.8, mid_y - dist * 0.45, 0.2 + dist * 0.5),
                            look_target=(0.0, mid_y, -0.25), eye_up=(0.0, 0.0, 1.0))
    table3d = rrb.Spatial3DView(
        name=f"Rate tables (3-D): orange = sensitive axis {res.plan.axis}, green = gravity (1 g up)",
        origin="/table", eye_controls=eye)
    err_tabs = []
    for r, lst in error_views.items():
        # the Overview: what every output keeps alike taken out (as the PNG time series), zoomed
        # to the methods; the errors as they are in the Errors tab
        shown = [_shown_path(w, x) for x in lst]
        for root in dict.fromkeys(x.rsplit("/", 1)[0] for x in lst):
            if root in w.sweeps:      # a sweep: its default's line and its members' envelope
                skip, envelope = w.sweeps[root]
                shown = [x for x in shown if x not in skip] + envelope
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
        axis, off = _y_axis_zoomed(w, shown)
        note = f"; {' and '.join(off)} off this scale" if off else ""
        plain = "; as they are: tab Errors" if (kinds or off) and len(error_views) > 1 else \
            "; as they are: drag to zoom out" if kinds or off else ""
        err_tabs.append(rrb.TimeSeriesView(
            name=f"{what}, {r}, deg/h{note}{plain}", contents=shown, axis_x=time_axis,
            axis_y=axis, time_ranges=[whole],
            plot_legend=rrb.PlotLegend(visible=True, corner="RightTop")))
    overview = rrb.Horizontal(
        rrb.Vertical(table3d, rrb.TextDocumentView(name="Metrics", origin="/report/metrics"),
                     row_shares=[3, 2]),
        rrb.Vertical(
            rrb.Tabs(*err_tabs, name="Error vs truth") if len(err_tabs) > 1 else err_tabs[0],
            plot(temp_title, temp, unit="deg C"),
            row_shares=[5, 2]),
        column_shares=[2, 3], name="Overview")
    tabs = [overview]
    if len(error_views) > 1:
        tabs.append(rrb.Grid(*[plot(f"Error vs truth, {r}, deg/h (colours as in Overview)", lst)
                               for r, lst in error_views.items()],
                             grid_columns=2 if len(error_views) > 1 else 1, name="Errors"))
    tabs.append(rrb.Grid(
        plot("Rate about the sensitive axis, deg/s (truth dark, raw light, a colour per run)",
             rate),
        plot("Tilt (dark) and its command (light), deg",
             each("table", "tilt_deg") + each("table", "tilt_cmd_deg")),
        plot("Turntable rate (dark) and its command (light), deg/s",
             each("table", "turn_rate_dps") + each("table", "turn_rate_cmd_dps")),
        plot("Gravity on the sensor axes (x red, y green, z blue), g",
             [_p("runs", r, "gravity", a) for r in runs for a in "xyz"]),
        plot("dT/dt, deg C/min: coil (dark), differenced from the sensor (light)",
             each("thermal", "coil_rate_c_per_min") + each("thermal", "sensor_rate_c_per_min"),
             unit="deg C/min"),
        plot(temp_title, temp, unit="deg C"),
        grid_columns=2, name="Table and chamber"))
    terms = []
    for r in runs:
        paths = [_p("runs", r, "fog", "error_terms", t) for t in res.data[r].fog.terms]
        terms.append(plot(f"FOG error terms, {r}, deg/h", paths, legend=len(runs) <= 2,
                          corner="LeftTop"))
    tabs.append(rrb.Grid(*terms, grid_columns=min(len(terms), 3), name="FOG error terms"))
    for kind, title in (("allan", "Allan deviation"), ("psd", "PSD")):
        views = [(key, rrb.Spatial2DView(
            name=f"{title}: {key} / {it.run}" + (" (in-sample)" if _in_sample(res).get(
                it.protocol) else "") + f"; {w.plots[_p('report', kind, key, it.run)]}",
            origin=_p("report", kind, key, it.run),
            visual_bounds=rrb.VisualBounds2D(
                x_range=(-0.35, max(_PLOT_W + 0.8,
                                    w.plot_right.get(_p("report", kind, key, it.run), 0.0))),
                y_range=(-0.22, _PLOT_H + 0.32))))
            for key, it in zip(keys, res.scored)
            if _p("report", kind, key, it.run) in w.plots]
        # at most MAX_LOGLOG_VIEWS plots a tab (paper002's 12 plots of about 110 px could not
        # hold their legends): more go in a tab per protocol
        prots = list(dict.fromkeys(k for k, _ in views))
        if len(views) > MAX_LOGLOG_VIEWS and len(prots) > 1:
            tabs.append(rrb.Tabs(*[rrb.Grid(*[v for k, v in views if k == pk],
                                            grid_columns=min(sum(k == pk for k, _ in views), 2),
                                            name=pk) for pk in prots], name=title))
        elif views:
            tabs.append(rrb.Grid(*[v for _, v in views], grid_columns=min(len(views), 2),
                                 name=title))
    if reps:
        # one static dot plot per headline metric of each protocol: it shows whatever timeline
        # is selected (a time series on the replicate timeline blanked with sim_time selected)
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
        tabs.append(rrb.Horizontal(
            rrb.TextDocumentView(name="Distribution over replicates",
                                 origin="/replicates/summary"),
            rrb.Vertical(*views) if len(views) > 1 else views[0],
            column_shares=[2, 3], name="Monte Carlo"))
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


#: Where ``fogbench view --web`` listens unless ``--bind`` says otherwise: this machine only
#: (rerun's own default, 0.0.0.0, serves the recording to the whole network).
WEB_BIND = "127.0.0.1"
WEB_PORT = 9090
GRPC_PORT = 9876


def _recording_and_viewer(run_dir: Path):
    """(recording path, viewer command); (None, None) when there is no recording and (path,
    None) when no viewer is installed, each said on stderr."""
    rrd = Path(run_dir) / "recording.rrd"
    if not rrd.is_file():
        print(f"fogbench view: no recording at {rrd} (written by `fogbench run` unless "
              "--no-recording)", file=sys.stderr)
        return None, None
    cmd = _viewer_command()
    if cmd is None:
        print(f"fogbench view: no Rerun viewer found. {_how_to(rrd, _has_display())}",
              file=sys.stderr)
    return rrd, cmd


def bind_address(bind: str) -> tuple[str, str]:
    """``--bind``'s address (rerun wants an IP address: a host name is resolved, its first IPv4
    address taken if it has one) and what listening on it opens the recording to. A name that
    does not resolve is a ValueError (one line)."""
    import ipaddress
    import socket

    try:
        addr = ipaddress.ip_address(bind)
        text = bind                          # an address: handed to rerun as written
    except ValueError:
        try:
            found = [a[4][0] for a in socket.getaddrinfo(bind, None, proto=socket.IPPROTO_TCP)
                     if a[0] in (socket.AF_INET, socket.AF_INET6)]
        except (socket.gaierror, ValueError) as exc:   # ValueError: a NUL, a bad IDNA label
            raise ValueError(f"--bind {bind!r}: not an IP address, and the name does not "
                             f"resolve ({getattr(exc, 'strerror', None) or exc})") from None
        if not found:
            raise ValueError(f"--bind {bind!r}: not an IP address, and the name resolves to "
                             "no IPv4 or IPv6 address") from None
        text = next((a for a in found if ":" not in a), found[0])
        addr = ipaddress.ip_address(text.split("%")[0])
    if addr.is_unspecified:
        scope = "EVERY network interface: anyone who can reach this machine can open it"
    elif addr.is_loopback:
        scope = "this machine only"
    else:
        scope = f"the interface with that address: anyone who can reach {addr} can open it"
    return text, scope


def view_web(run_dir: Path, bind: str = WEB_BIND, web_port: int = WEB_PORT,
             grpc_port: int = GRPC_PORT) -> int:
    """Serve ``run_dir/recording.rrd`` to a browser (Rerun's web viewer) until Ctrl-C; says
    where it listens. 2: no recording; 1: no viewer installed or it failed. ``bind`` is an IP
    address or a host name (resolved here: rerun wants an address); one that does not resolve
    is a ValueError."""
    addr, scope = bind_address(bind)
    rrd, cmd = _recording_and_viewer(run_dir)
    if cmd is None:
        return 2 if rrd is None else 1
    host = f"[{addr}]" if ":" in addr else addr
    named = f"{addr}, {bind}" if addr != bind else addr
    print(f"fogbench view: serving {rrd} at http://{host}:{web_port} (listening on {named}, "
          f"{scope}; gRPC port {grpc_port}); Ctrl-C stops it", flush=True)
    try:
        proc = subprocess.Popen([*cmd, str(rrd), "--web-viewer", "--bind", addr,
                                 "--web-viewer-port", str(web_port), "--port", str(grpc_port)],
                                stdin=subprocess.DEVNULL)
    except OSError as exc:
        print(f"fogbench view: cannot start {cmd[0]}: {exc}", file=sys.stderr)
        return 1
    try:
        rc = proc.wait()
    except BaseException:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
        raise
    if rc != 0:
        print(f"fogbench view: the web viewer exited with status {rc} (is port {web_port} or "
              f"{grpc_port} in use? --web-port and --grpc-port choose others)", file=sys.stderr)
        return 1
    return 0


def _viewer_command() -> list[str] | None:
    """How to start the Rerun viewer of the installed rerun-sdk, or None."""
    spec = importlib.util.find_spec("rerun_cli")
    if spec is not None and spec.origin:
        exe = Path(spec.origin).with_name("rerun.exe" if os.name == "nt" else "rerun")
        if exe.is_file() and os.access(exe, os.X_OK):
            return [str(exe)]  # the binary bundled with this rerun-sdk: same version
    venv = Path(sys.executable).with_name("rerun")
    if venv.is_file() and os.access(venv, os.X_OK):
        return [str(venv)]
    found = shutil.which("rerun")
    return [found] if found else None


def _has_display() -> bool:
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def view(run_dir: Path) -> int:
    """Open ``run_dir/recording.rrd`` in the Rerun viewer.

    Returns 0 when the viewer was started or the file was handed to a viewer already running
    (a message says which), 2 when there is no recording, 1 when no viewer can be started here
    (no viewer installed, no display, or the viewer failed at once): a message then says how to
    open the file.
    """
    rrd, cmd = _recording_and_viewer(run_dir)
    if cmd is None:
        return 2 if rrd is None else 1
    if not _has_display():
        print(f"fogbench view: no display (DISPLAY and WAYLAND_DISPLAY unset). "
              f"{_how_to(rrd, False)}", file=sys.stderr)
        return 1
    try:
        proc = subprocess.Popen([*cmd, str(rrd)], stdin=subprocess.DEVNULL,
                                start_new_session=True)
    except OSError as exc:
        print(f"fogbench view: cannot start {cmd[0]}: {exc}. {_how_to(rrd)}", file=sys.stderr)
        return 1
    try:
        rc = proc.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        print(f"fogbench view: opened {rrd} in the Rerun viewer")
        return 0
    if rc == 0:
        # the rerun binary hands a file to a viewer already listening on its port (9876) and
        # exits at once with status 0; a viewer it started itself keeps running
        print(f"fogbench view: handed {rrd} to a Rerun viewer that was already running (the "
              "new viewer process exited at once); look for the recording in that viewer's "
              f"window, or run `rerun --new {rrd}` for a viewer of its own")
        return 0
    print(f"fogbench view: the viewer exited with status {rc}. {_how_to(rrd)}", file=sys.stderr)
    return 1
