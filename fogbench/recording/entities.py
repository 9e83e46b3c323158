"""What the parts of the recording share: its application id and timelines, the table's
geometry, entity paths, the names and colours of raw, oracle, truth and the methods (from
:mod:`fogbench.report.palette`, as the PNG figures), and the writer that logs with them."""

from __future__ import annotations

import zlib

import numpy as np

from fogbench.report import palette as PAL
from fogbench.report.views import (
    sweep_names,
)

__all__ = ["MAX_SERIES_POINTS", "MAX_POSE_POINTS", "TIMELINE", "REPLICATE_TIMELINE", "APPLICATION_ID", "CONFIDENCE"]

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
# near-white): fogbench.report.palette, shared with the PNG figures (raw grey, oracle cyan, a hue per
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
    """label -> colour of raw, oracle and every method: fogbench.report.palette.plan_styles, the
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


ENVELOPE = "envelope"     # a sweep's envelope: paths ``<sweep> envelope/low``, ``.../high``


def _envelope_style(e: dict, colors, in_sample: bool, protocol: str, series: bool):
    """(colour, legend name) of sweep ``e``'s envelope lines: its default's colour, lighter;
    ``"<sweep>: <n> settings, best..worst"``, or, in-sample, a time series' shared in-sample
    name (``series``) or that name marked in-sample (Allan and PSD plots)."""
    color = _tint(_piece_color(colors, e["default"], in_sample), 0.35)
    if in_sample and series:
        return color, _series_name(e["default"], in_sample, protocol, {})
    return color, _piece_name(sweep_names(e)[1], in_sample)


# plot box of the log-log views, scene units of the 2-D view (y grows downwards)
_PLOT_W, _PLOT_H = 1.6, 1.0


# Monte Carlo plots: data box width and row height, scene units (y grows downwards)
_MC_W, _MC_ROW = 1.2, 0.1
