"""Log-log plots drawn as 2-D line strips with their own decade grid and labels (Rerun 0.41 has
no logarithmic plot axis): the Allan deviation and the PSD."""

from __future__ import annotations

import math

import numpy as np

from fogbench.recording.entities import _GRID, _PLOT_H, _PLOT_W, ENVELOPE, LEGEND_CHAR_W, _Writer

__all__ = ["LOGLOG_MAX_DECADES", "LOGLOG_MAX_LABELS"]


def _decade_label(k: int) -> str:
    return f"{10.0 ** k:g}" if -3 <= k <= 4 else f"1e{k}"


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


def _nice_ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    """About ``n`` round numbers (1, 2 or 5 times a power of ten apart) within [lo, hi]."""
    if not hi > lo:
        return [lo]
    raw = (hi - lo) / n
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(k * mag for k in (1.0, 2.0, 5.0, 10.0) if k * mag >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    return [first + i * step for i in range(int((hi - first) / step + 1e-9) + 1)]
