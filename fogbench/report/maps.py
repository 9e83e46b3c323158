"""The claim maps in a run's report: per claim, a figure of its verdict over the map's points and
the sentence that says where it holds (``fogbench.run.maps``)."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

__all__ = ["render_map", "fig_map", "VERDICT_COLORS", "EXCEEDS_COLOR", "verdict_color",
           "LEGEND"]

#: One colour per verdict (the same in every figure); a disagreement on the good side of the
#: claimed range ("exceeds the claim": the method did better than the paper said) has its own.
VERDICT_COLORS = {"agrees": "#2a9d3f", "disagrees": "#c0392b", "inconclusive": "#e0a800",
                  "untestable": "#7f7f7f"}
EXCEEDS_COLOR = "#3a5fcd"


def verdict_color(v: dict, default: str = "k") -> str:
    """The colour of a verdict ``v`` (a claim or a map point: ``verdict``, and ``side`` or
    ``max_pct`` with ``summary``/``mean``): :data:`EXCEEDS_COLOR` for a disagreement above the
    claimed range, else :data:`VERDICT_COLORS`."""
    if v.get("verdict") == "disagrees":
        side = v.get("side")
        if side is None:
            hi = v.get("max_pct")
            mean = v.get("mean", (v.get("summary") or {}).get("mean"))
            side = "exceeds" if hi is not None and mean is not None and mean > hi else None
        if side == "exceeds":
            return EXCEEDS_COLOR
    return VERDICT_COLORS.get(v.get("verdict"), default)


#: The verdict colours as a legend reads them.
LEGEND = [("agrees", VERDICT_COLORS["agrees"]),
          ("disagrees (falls short of the claim)", VERDICT_COLORS["disagrees"]),
          ("disagrees (exceeds the claim)", EXCEEDS_COLOR),
          ("inconclusive", VERDICT_COLORS["inconclusive"]),
          ("untestable", VERDICT_COLORS["untestable"])]


def _num(v) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:+.1f}"


def _claimed(c: dict) -> str:
    lo, hi = c.get("min_pct"), c.get("max_pct")
    if lo is not None and hi is not None:
        return f"{lo:g} to {hi:g} %"
    return f">= {lo:g} %" if lo is not None else f"<= {hi:g} %"


def _cell(v):
    return None if v is None else (v.get("mean"), v.get("ci_low"), v.get("ci_high"),
                                   v.get("verdict"))


def no_effect_axes(map_doc: dict, k: int) -> list[int]:
    """The axes of a two-axis map along which claim k is the same at every value: along each
    line of the other axis, every point but the scenario's own (its run has the scenario's
    replicates, not the map's) has the same mean, interval and verdict. paper004's
    recal_positions scores the positions runs alone, so the centrifuge spins (an axis that
    changes only the centrifuge runs) left every column of its maps identical. Empty for a
    one-axis map or where a line has fewer than two such points."""
    axes = map_doc["axes"]
    if len(axes) != 2:
        return []
    vals = map_doc["claims"][k]["points"]
    cells = {tuple(p["index"]): (_cell(v), p["base"]) for v, p in zip(vals, map_doc["points"])}
    out = []
    for a in (0, 1):
        lines: dict = {}
        for (i, j), (cell, base) in cells.items():
            if not base:
                lines.setdefault((i, j)[1 - a], []).append(cell)
        if lines and all(len(ln) >= 2 and None not in ln and len(set(ln)) == 1
                         for ln in lines.values()) and \
                len({(i, j)[1 - a] for (i, j) in cells}) == len(lines):
            out.append(a)
    return out


def fig_map(map_doc: dict, k: int, path: Path) -> bool:
    """Claim k's improvement at every point (95 % interval of the mean over replicates),
    coloured by verdict, the claimed range shaded, the oracle's improvement beside each point,
    the scenario's own point marked; two axes: a grid, the verdict as colour and the mean in
    each cell."""
    import matplotlib

    matplotlib.use("Agg")

    from fogbench.outputs import files

    c = map_doc["claims"][k]
    vals = c["points"]
    if not any(v is not None and v.get("mean") is not None for v in vals):
        return False
    if len(map_doc["axes"]) == 1:
        fig, ax = _map_line(c, map_doc["axes"], map_doc["points"])
    else:
        fig, ax = _map_grid(c, *_grid_cells(map_doc, k))
    # wrapped to the figure's width (paper000's claims ran off both sides, into the y label)
    width_in = fig.get_size_inches()[0]
    ax.set_title(textwrap.fill(f"{c['text']} ({c['protocol']}): {_claimed(c)}",
                               max(40, int(width_in * 11))), fontsize=9)
    fig.tight_layout()
    files.save_figure(fig, path)
    return True


def _count_line(point: dict) -> str:
    """A figure's line under a point: its own replicate count (none where unknown)."""
    r = point.get("replicates")
    return "" if r is None else f"\n{r} replicates"


def _map_line(c: dict, axes: list[dict], pts: list[dict]):
    """A one-axis map of claim ``c``: each point's mean and interval coloured by verdict, the
    oracle's improvement as a tick beside it, the claimed range shaded; the legend lists the
    verdicts drawn. Returns the figure and its axes."""
    import matplotlib.pyplot as plt

    vals = c["points"]
    used = set()        # the verdict colours (and the oracle) drawn: the legend lists those
    fig, ax = plt.subplots(figsize=(max(5.0, 1.3 * len(pts) + 2.5), 4.2))
    x = np.arange(len(pts))
    lo, hi = c.get("min_pct"), c.get("max_pct")
    ax.axhspan(-1e9 if lo is None else lo, 1e9 if hi is None else hi, color="#2a9d3f",
               alpha=0.12, label=f"claimed: {_claimed(c)}")
    for i, (v, p) in enumerate(zip(vals, pts)):
        if v is None or v.get("mean") is None:
            continue
        col = verdict_color({**v, "max_pct": v.get("max_pct", c.get("max_pct"))})
        used.add(col)
        err = [[v["mean"] - (v["ci_low"] if v["ci_low"] is not None else v["mean"])],
               [(v["ci_high"] if v["ci_high"] is not None else v["mean"]) - v["mean"]]]
        ax.errorbar([i], [v["mean"]], yerr=err, fmt="o", color=col, ms=7 if p["base"] else 5,
                    capsize=4, mec="k" if p["base"] else col)
        if v.get("oracle_mean") is not None and v.get("oracle_bounds"):
            ax.plot([i + 0.18], [v["oracle_mean"]], marker="_", ms=12, mew=2, color="0.45")
            used.add("oracle")
    ax.set_xticks(x)
    ax.set_xticklabels([p["labels"][0] + ("\n(the scenario)" if p["base"] else "")
                        + _count_line(p) for p in pts], fontsize=8)
    ax.set_xlabel(axes[0]["name"])
    ys = [y for v in vals if v for y in (v.get("ci_low"), v.get("ci_high"), v.get("mean"),
                                         v.get("oracle_mean") if v.get("oracle_bounds")
                                         else None) if y is not None]
    ys += [b for b in (lo, hi) if b is not None]
    pad = 0.1 * (max(ys) - min(ys) + 1.0)
    ax.set_ylim(min(ys) - pad, max(ys) + pad)
    ax.set_xlim(-0.6, len(pts) - 0.4)
    ax.set_ylabel(textwrap.fill(f"improvement of {c['better']} over {c['than']}, % "
                                f"({c['metric']})", 42), fontsize=8)
    handles = [plt.Line2D([], [], marker="o", ls="none", color=col, label=v)
               for v, col in LEGEND if col in used]
    if "oracle" in used:
        handles.append(plt.Line2D([], [], marker="_", ms=12, mew=2, ls="none",
                                  color="0.45", label="oracle"))
    ax.legend(handles=[*ax.get_legend_handles_labels()[0], *handles], fontsize=7,
              loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, axis="y", alpha=0.3)
    return fig, ax


def _grid_cells(map_doc: dict, k: int) -> tuple[list, list, list, list]:
    """The cells of claim k's two-axis map, as (values, points, axes, the axes it does not
    see): an axis the claim does not see becomes one line of cells, named as having no effect."""
    # an axis the claim does not see (every value the same) is drawn as one line of
    # cells: at a value other than the scenario's own (whose cell holds the scenario's run,
    # its own replicates, not the map's numbers), the scenario's run noted in its row
    vals, pts = map_doc["claims"][k]["points"], map_doc["points"]
    same = no_effect_axes(map_doc, k)
    base_v, base_p = next(((v, p) for v, p in zip(vals, pts) if p["base"]), (None, None))
    pick = {a: next((p["index"][a] for p in pts if not p["base"] and (
        base_p is None or p["index"][a] != base_p["index"][a])), 0) for a in same}
    keep = [v_p for v_p in zip(vals, pts)
            if all(v_p[1]["index"][a] == pick[a] for a in same)]
    vals, pts = [v for v, _ in keep], [dict(p) for _, p in keep]
    for p in pts:
        if same and base_p is not None and base_v is not None and all(
                p["index"][a] == base_p["index"][a] for a in (0, 1) if a not in same):
            own = (f" ({base_p['replicates']} replicates)"
                   if base_p.get("replicates") is not None else "")
            p["scenario_note"] = (f"\nthe scenario's run{own}:\n{_num(base_v['mean'])} % "
                                  f"[{_num(base_v['ci_low'])}, {_num(base_v['ci_high'])}]")
        p["index"] = [0 if a in same else p["index"][a] for a in (0, 1)]
    axes = [dict(a, labels=[f"any of its {len(a['labels'])} values"],
                 name=f"{a['name']}: no effect on this claim")
            if i in same else a for i, a in enumerate(map_doc["axes"])]
    return vals, pts, axes, same


def _map_grid(c: dict, vals: list, pts: list, axes: list[dict], same: list):
    """A two-axis map of claim ``c`` (cells and ``same`` from :func:`_grid_cells`): each cell coloured by
    its verdict, holding its mean, interval and the oracle's improvement. Returns the figure
    and its axes."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgb

    used = set()        # the verdict colours drawn: the legend lists those
    na, nb = len(axes[0]["labels"]), len(axes[1]["labels"])
    fig, ax = plt.subplots(figsize=(max(6.0 if same else 5.0, 1.6 * nb + 3),
                                    max(3.0, 1.0 * na + 1.8)))
    img = np.ones((na, nb, 3))
    for v, p in zip(vals, pts):
        i, j = p["index"]
        if v is not None:
            col = verdict_color({**v, "max_pct": c.get("max_pct")}, "#ffffff")
            used.add(col)
            img[i, j] = to_rgb(col)
            txt = f"{_num(v['mean'])} %\n[{_num(v['ci_low'])}, {_num(v['ci_high'])}]"
            if v.get("oracle_mean") is not None and v.get("oracle_bounds"):
                txt += f"\noracle {_num(v['oracle_mean'])} %"
            txt += _count_line(p)
            ax.text(j, i, txt + ("\n(the scenario)" if p["base"] else "")
                    + p.get("scenario_note", ""), ha="center",
                    va="center", fontsize=7, color="black",
                    fontweight="bold" if p["base"] else "normal")
    ax.imshow(img, aspect="auto", alpha=0.45)
    ax.set_xticks(range(nb))
    ax.set_xticklabels(axes[1]["labels"], fontsize=8)
    ax.set_yticks(range(na))
    ax.set_yticklabels(axes[0]["labels"], fontsize=8)
    ax.set_xlabel(axes[1]["name"])
    ax.set_ylabel(axes[0]["name"])
    handles = [plt.Line2D([], [], marker="s", ls="none", color=col, label=v)
               for v, col in LEGEND if col in used]
    ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig, ax


def labels_text(labels) -> str:
    """An axis's labels as one unambiguous line: each quoted, separated by "; " (a label may
    hold a comma: "wander, 0.5 s")."""
    return "; ".join(f'"{x}"' for x in labels)


def _value_text(v) -> str:
    """A value a point sets, as the map file writes it (TOML): 0.79, "sine", {type = ...}."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return f"{v:g}" if float(f"{v:g}") == v else repr(v)
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_value_text(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value_text(x) for x in v) + "]"
    return str(v)


def set_text(point: dict) -> str:
    """What a point sets, in the map file's keys and their units ("fog.arw_deg_rt_h = 0.79;
    fog.gm_drift_dps = 0"); the scenario's own point sets nothing over it."""
    sets = point.get("set") or {}
    if not sets:
        return "nothing: the scenario's own values" if point.get("base") else "nothing"
    return "; ".join(f"{k} = {_value_text(v)}" for k, v in sets.items())


def _replicates(map_doc: dict, point: dict):
    """A point's own replicate count (the scenario's own point has the scenario's)."""
    r = point.get("replicates")
    return map_doc.get("replicates_per_point") if r is None else r


def replicates_text(map_doc: dict) -> str:
    """How many replicates are behind the map's numbers: "20 replicates per point", or, where
    the scenario's own point has its own count, "20 replicates per point, the scenario's own
    point its 3"."""
    r = map_doc["replicates_per_point"]
    base = next((p for p in map_doc["points"] if p["base"]), None)
    own = None if base is None else _replicates(map_doc, base)
    return f"{r} replicates per point" + (
        f", the scenario's own point its {own}" if own is not None and own != r else "")


def render_map(map_doc: dict, fig_names: dict) -> str:
    """The report's "Claim maps" section."""
    from fogbench.report.fmt import md_table

    reps = replicates_text(map_doc) + ", the scenario's own seeds"
    L = ["## Claim maps", "",
         "Each claim at every point of the scenario's map: the scenario with the values each "
         f"point sets ({reps}; the point marked \"the scenario\" is this report's own run). "
         "Mean improvement [95 % interval], the verdict, and the oracle's improvement where it "
         "bounds the claim (the oracle of the deterministic terms for a model of them; the "
         "filter oracle, the best estimate given the true noise model, for a filter).", ""]
    for a in map_doc["axes"]:
        L.append(f"- axis **{a['name']}** ({len(a['labels'])} values): "
                 f"{labels_text(a['labels'])}. Range from: {a.get('source', '')}")
    L.append("")
    L += ["What each point sets (the map file's keys, in their units) and the replicates "
          "behind its numbers:", "",
          md_table(["point", "sets", "replicates"],
                   [[p["label"] + (" (the scenario)" if p["base"] else ""), set_text(p),
                     str(_replicates(map_doc, p))] for p in map_doc["points"]]), ""]
    for k, c in enumerate(map_doc["claims"]):
        flag = " (IN-SAMPLE)" if c.get("in_sample") else ""
        L += [f"### {c['text']} (`{c['protocol']}`{flag})", "",
              f"Claimed {_claimed(c)} ({c['source']}). **{c['sentence'][0].upper()}"
              f"{c['sentence'][1:]}.**", ""]
        fig = fig_names.get(("map", k))
        if fig:
            L += [f"![claim map]({fig})", ""]
        for a in no_effect_axes(map_doc, k):
            ax = map_doc["axes"][a]
            L += [f"**{ax['name']}** does not change this claim: at every value "
                  f"({labels_text(ax['labels'])}) each point the map ran has the same "
                  "improvement, interval and verdict (the protocol does not score what that "
                  "axis changes), so the figure draws one line of cells for it: the map's "
                  "numbers" + (", with the scenario's own run (its own replicates) noted in "
                               "its cell" if any(p["base"] for p in map_doc["points"])
                               else "") + ".", ""]
        rows = []
        for v, p in zip(c["points"], map_doc["points"]):
            label = p["label"] + (" (the scenario)" if p["base"] else "")
            n = str(_replicates(map_doc, p))
            if v is None:
                rows.append([label, n, "-", "not run", "-"])
                continue
            verdict = v["verdict"] + (f" ({v['side'].removesuffix(' of')})" if v.get("side")
                                      else "")
            oracle = (f"{_num(v['oracle_mean'])} [{_num(v['oracle_ci_low'])}, "
                      f"{_num(v['oracle_ci_high'])}]" if v.get("oracle_mean") is not None
                      and v.get("oracle_bounds") else "-")
            rows.append([label, n, f"{_num(v['mean'])} [{_num(v['ci_low'])}, "
                                   f"{_num(v['ci_high'])}] %", verdict, oracle])
        L += [md_table(["point", "replicates", "improvement", "verdict", "oracle"], rows), ""]
    if map_doc.get("metrics"):
        L += ["### Metrics at every point", "",
              "Mean [95 % interval] over replicates of the mean over the protocol's scored runs "
              "(units in the metric names).", ""]
        head = ["point", "replicates"] + [f"{m['protocol']}: {m['method']} {m['metric']}"
                                          for m in map_doc["metrics"]]
        rows = []
        for i, p in enumerate(map_doc["points"]):
            row = [p["label"] + (" (the scenario)" if p["base"] else ""),
                   str(_replicates(map_doc, p))]
            for m in map_doc["metrics"]:
                v = m["points"][i]
                row.append("-" if not v or v.get("mean") is None else
                           f"{_g(v['mean'])} [{_g(v['ci_low'])}, {_g(v['ci_high'])}]")
            rows.append(row)
        L += [md_table(head, rows), ""]
    return "\n".join(L)


def _g(v) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.3g}"
