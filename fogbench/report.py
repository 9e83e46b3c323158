"""Run directories: metrics.json, report.md with PNG figures, and the data.

Figures are drawn with matplotlib's Agg backend. Long records are decimated for display only
(the report says so); every metric is computed on the full record.
"""

from __future__ import annotations

import io
import math
import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fogcomp import metrics as M  # noqa: E402
from fogcomp.allan import oadev  # noqa: E402
from fogcomp.units import DPH, DPS  # noqa: E402

from .fmt import KEY_METRICS, fmt, md_table  # noqa: E402
from .io import atomic_write_bytes, atomic_write_text, run_arrays, versions  # noqa: E402
from .outdir import check_out_dir, new_part_dir, replace_dir  # noqa: E402
from .runner import ScenarioResult, TERM_NAMES, thermal_segments, write_metrics  # noqa: E402

__all__ = ["write_run_dir"]

MAX_PLOT_POINTS = 4000
COLORS = {"raw": "0.6", "oracle": "0.2", "truth": "tab:green"}
METHOD_COLORS = ["tab:blue", "tab:orange", "tab:red", "tab:purple", "tab:brown", "tab:pink",
                 "tab:cyan", "tab:olive"]


def _color(label: str, labels: list[str]):
    if label in COLORS:
        return COLORS[label]
    others = [x for x in labels if x not in COLORS]
    return METHOD_COLORS[others.index(label) % len(METHOD_COLORS)] if label in others else None


def _save(fig, path: Path):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def _decimate(t, *ys):
    n = t.size
    step = max(1, int(math.ceil(n / MAX_PLOT_POINTS)))
    return (t[::step],) + tuple(y[::step] for y in ys), step


def _unit(scored) -> tuple[float, str]:
    """Plot rates in deg/s when the table moves, in deg/h when it is static."""
    rng = np.ptp(scored.piece.truth) / DPS
    return (DPS, "deg/s") if rng > 0.01 or abs(np.mean(scored.piece.truth)) > 0.01 * DPS else \
        (DPH, "deg/h")


def fig_timeseries(it, path: Path) -> int:
    u, uname = _unit(it)
    p = it.piece
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True)
    labels = [k for k in it.outputs if k not in ("raw", "oracle")]
    (t, *ys), step = _decimate(p.t - p.t[0], p.truth, *[it.outputs[k] for k in ["raw", "oracle"] + labels])
    truth, raw, oracle, *outs = ys
    ax = axes[0]
    ax.plot(t, raw / u, color=COLORS["raw"], lw=0.6, label="raw")
    for lab, y in zip(labels, outs):
        ax.plot(t, y / u, lw=0.8, label=lab, color=_color(lab, labels))
    ax.plot(t, truth / u, color=COLORS["truth"], lw=1.4, ls="--", label="truth")
    ax.set_ylabel(f"rate, {uname}")
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    ax.set_title(f"{it.protocol} / {it.run}: output and truth")
    ax = axes[1]
    ax.plot(t, (raw - truth) / u, color=COLORS["raw"], lw=0.6, label="raw")
    ax.plot(t, (oracle - truth) / u, color=COLORS["oracle"], lw=0.6, label="oracle")
    for lab, y in zip(labels, outs):
        ax.plot(t, (y - truth) / u, lw=0.8, label=lab, color=_color(lab, labels))
    ax.set_ylabel(f"error vs truth, {uname}")
    ax.set_xlabel("time in the scored piece, s")
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    _save(fig, path)
    return step


def fig_psd(it, path: Path):
    p = it.piece
    fig, ax = plt.subplots(figsize=(8, 4.5))
    nper = min(p.raw.size, 1024)
    for lab, y in it.outputs.items():
        f, s = M.psd(y - np.mean(y), p.fs, nperseg=nper)
        ax.loglog(f[1:], s[1:] / DPS**2, lw=0.9 if lab != "raw" else 0.7,
                  color=_color(lab, list(it.outputs)), label=lab)
    ax.set_xlabel("frequency, Hz")
    ax.set_ylabel("PSD, (deg/s)^2/Hz")
    ax.set_title(f"{it.protocol} / {it.run}: PSD before and after compensation (Welch, mean removed)")
    ax.legend(fontsize=8)
    _save(fig, path)


def fig_allan(it, path: Path) -> bool:
    p = it.piece
    if p.raw.size < 64:
        return False
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for lab, y in it.outputs.items():
        taus, ad = oadev(y - p.truth, p.fs)
        ax.loglog(taus, ad / DPH, lw=1.0 if lab != "raw" else 0.8,
                  color=_color(lab, list(it.outputs)),
                  label=lab, marker="." if lab in ("raw", "oracle") else None)
    ax.set_xlabel("averaging time tau, s")
    ax.set_ylabel("Allan deviation of (output - truth), deg/h")
    ax.set_title(f"{it.protocol} / {it.run}: overlapping Allan deviation")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    _save(fig, path)
    return True


def fig_thermal(res: ScenarioResult, run: str, path: Path) -> bool:
    rd = res.data[run]
    if rd.run.thermal is None or not rd.run.thermal.steps:
        return False
    j = res.scenario.axes.index(res.plan.axis)
    k = max(1, int(round(100.0 * rd.fs)))
    t = M.smooth(rd.truth.t, rd.fs, 100.0) / 3600
    bias = M.smooth(rd.fog.raw[:, j] - rd.truth_axis(j), rd.fs, 100.0) / DPH
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    axes[0].plot(rd.truth.t / 3600, rd.thermal.chamber, label="chamber")
    axes[0].plot(rd.truth.t / 3600, rd.thermal.coil, label="coil")
    axes[0].set_ylabel("temperature, deg C")
    ax2 = axes[0].twinx()
    ax2.plot(rd.truth.t / 3600, rd.thermal.coil_rate * 60, color="tab:red", lw=0.7,
             label="coil dT/dt")
    ax2.set_ylabel("coil dT/dt, deg C/min")
    axes[0].legend(loc="upper left", fontsize=8)
    axes[0].set_title(f"{run}: thermal program (paper 002, Fig. 3)")
    axes[1].plot(t, bias, lw=0.8, color="0.4", label=f"raw bias (100 s means, {k} samples)")
    axes[1].set_ylabel("bias, deg/h")
    axes[1].set_xlabel("time, h")
    axes[1].legend(fontsize=8)
    _save(fig, path)
    return True


def fig_coefficients(res: ScenarioResult, protocol: str, path: Path) -> bool:
    runs = res.metrics["protocols"][protocol]["runs"]
    rows = []
    for run, by_method in runs.items():
        for lab, m in by_method.items():
            if isinstance(m, dict) and "coef_errors_dph" in m:
                rows.append((run, lab, m))
    if not rows:
        return False
    fig, ax = plt.subplots(figsize=(10, 4.5))
    true = rows[0][2]["coef_true_dph"]
    x = np.arange(len(TERM_NAMES))
    ax.plot(x, [true[n] for n in TERM_NAMES], "ks", ms=8, label=f"true ({rows[0][0]})",
            zorder=5)
    labels = sorted({r[1] for r in rows})
    width = 0.8 / max(1, len(labels))
    for i, lab in enumerate(labels):
        r = next(r for r in rows if r[1] == lab and r[0] == rows[0][0])
        est = [r[2]["coef_true_dph"][n] + r[2]["coef_errors_dph"][n] for n in TERM_NAMES]
        ax.bar(x + (i - (len(labels) - 1) / 2) * width, est, width, alpha=0.7, label=lab)
    ax.set_xticks(x, [f"{n}" for n in TERM_NAMES])
    ax.set_ylabel("deg/h (d0), deg/h/g (d1-d3), deg/h/g^2 (d4-d9)")
    ax.set_title(f"{protocol}: identified vs true coefficients, first power-on (paper 004, Table 1)")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.legend(fontsize=8)
    _save(fig, path)
    return True


def _paper_value(plan, method, metric, run, segment=None):
    for pv in plan.paper:
        if pv.method == method and pv.metric == metric and pv.run in (None, run) and \
                pv.segment == segment:
            return pv
    return None


def render_report(res: ScenarioResult, fig_names: dict, decimation: dict) -> str:
    sc, plan, doc = res.scenario, res.plan, res.metrics
    L = [f"# {sc.name}", "", sc.description, "",
         f"Scenario file: `{Path(sc.path).name}`. FOG: preset `{sc.fog_preset}` "
         f"({sc.fog_source}); axis `{plan.axis}`; {sc.fs:g} Hz. Wall time {res.wall_s:.1f} s.", ""]
    for note in plan.notes:
        L += [f"> {note}", ""]
    L += ["Rows: `raw` is the FOG output; `oracle` is the raw output minus the true deterministic "
          "error terms (bias, switch-on bias, scale factor, misalignment, g and g^2, temperature, "
          "rate ramp), the floor no model of those terms can beat; each method is fitted on the "
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
            metrics = [m for m in KEY_METRICS if any(
                isinstance(v, dict) and m in v for v in by_method.values())]
            header = ["method"] + metrics + ["status"]
            rows = []
            for lab, m in by_method.items():
                if m.get("status") == "failed":
                    rows.append([lab] + ["–"] * len(metrics) + [f"FAILED: {m['error']}"])
                    continue
                cells = []
                for met in metrics:
                    c = fmt(m.get(met), met)
                    pv = _paper_value(plan, lab, met, run)
                    if pv is not None:
                        c += f" (ref: {fmt(pv.value, met)})"
                    cells.append(c)
                rows.append([lab] + cells + ["ok"])
            L += [f"### {run}", "", md_table(header, rows), ""]
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
            if (prot.name, run) in decimation and decimation[(prot.name, run)] > 1:
                L += [f"(Time series decimated by {decimation[(prot.name, run)]} for display "
                      "only; metrics use every sample.)", ""]
        fn = fig_names.get((prot.name, None, "coefficients"))
        if fn:
            L += [_coef_table(res, prot.name), "", f"![coefficients]({fn})", ""]
        L += [_fit_notes(pd), ""]
    fn = fig_names.get(("thermal",))
    if fn:
        L += ["## Temperature and bias", "", f"![thermal]({fn})", ""]
    L += ["## Versions", "", ", ".join(f"{k} {v}" for k, v in doc["versions"].items()), ""]
    return "\n".join(L)


def _segment_table(res: ScenarioResult, protocol: str, run: str) -> str:
    item = next((it for it in res.scored if it.protocol == protocol and it.run == run), None)
    if item is None or run not in res.data:
        return ""
    segs = thermal_segments(res.data[run])
    if not segs:
        return ""
    p = item.piece
    rows = []
    labels = list(item.outputs)
    for name, a, b in segs:
        mask = (p.t >= a) & (p.t < b)
        if mask.sum() < 3:
            continue
        cells = [name]
        for lab in labels:
            y = item.outputs[lab][mask]
            try:
                v = (M.std(y) if p.fs <= 0.0100001 else M.bias_stability(y, p.fs, 100.0)) / DPH
            except ValueError:  # a segment shorter than two 100 s windows
                v = None
            pv = _paper_value(res.plan, lab, "bias_stability_100s_dph", run, name)
            cells.append(fmt(v) + (f" ({fmt(pv.value)})" if pv else ""))
        rows.append(cells)
    if not rows:
        return ""
    return ("Bias stability B_s per thermal segment, deg/h (paper 002 eq. 5 on 100 s means; "
            "paper's Table 1/2 value in brackets where given):\n\n"
            + md_table(["segment"] + labels, rows))


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
                bits.append(f"fit {rec['fit_time_s']:.3g} s")
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
                  montecarlo: dict | None = None, work=None) -> Path:
    """Write metrics.json, report.md, figures, data (and recording.rrd) into ``out``.

    Everything is written into a hidden temporary sibling (its marker file first), which then
    replaces ``out``: an interrupted run leaves the previous complete directory, never a
    half-written one, and only an empty directory or a run directory of ours is ever replaced
    (``fogbench.outdir``). A figure that cannot be drawn is left out with a note in the report.
    ``montecarlo`` is the replicate aggregate (``fogbench.montecarlo``; in ``metrics.json`` under
    that key, in the report, in the recording); ``work`` the replicates' work folder, whose files
    move into ``replicates/``.
    """
    out = check_out_dir(out, "run")
    tmp = new_part_dir(out, "run", {"scenario": res.scenario.name,
                                    "scenario_file": str(res.scenario.path),
                                    "fogbench": versions().get("fogbench")})
    try:
        fig_names, decim, notes = {}, {}, []

        def figure(what: str, fn, *args):
            """Draw one figure; a figure that cannot be drawn is noted, never fatal."""
            try:
                return fn(*args)
            except Exception as exc:  # noqa: BLE001 - the run's numbers matter more
                plt.close("all")
                notes.append(f"figure {what} left out: {type(exc).__name__}: {exc}")
                return None

        (tmp / "figures").mkdir()
        for it in res.scored:
            base = f"{it.protocol}__{it.run}"
            key = (it.protocol, it.run)
            if key in decim:
                continue
            decim[key] = figure(f"{base} time series", fig_timeseries, it,
                                tmp / "figures" / f"{base}__timeseries.png") or 1
            figure(f"{base} PSD", fig_psd, it, tmp / "figures" / f"{base}__psd.png")
            for kind in ("timeseries", "psd"):
                if (tmp / "figures" / f"{base}__{kind}.png").exists():
                    fig_names[(it.protocol, it.run, kind)] = f"figures/{base}__{kind}.png"
            if figure(f"{base} Allan", fig_allan, it, tmp / "figures" / f"{base}__allan.png"):
                fig_names[(it.protocol, it.run, "allan")] = f"figures/{base}__allan.png"
        for prot in res.plan.protocols:
            if figure(f"{prot.name} coefficients", fig_coefficients, res, prot.name,
                      tmp / "figures" / f"{prot.name}__coefficients.png"):
                fig_names[(prot.name, None, "coefficients")] = \
                    f"figures/{prot.name}__coefficients.png"
        first = next(iter(res.data))
        if figure("thermal", fig_thermal, res, first, tmp / "figures" / "thermal.png"):
            fig_names[("thermal",)] = "figures/thermal.png"
        if montecarlo is not None:
            if figure("replicate distributions", fig_replicates, res, montecarlo,
                      tmp / "figures" / "replicates.png"):
                fig_names[("replicates",)] = "figures/replicates.png"
        write_metrics(tmp / "metrics.json",
                      res.metrics if montecarlo is None else {**res.metrics,
                                                              "montecarlo": montecarlo})
        text = render_report(res, fig_names, decim)
        if montecarlo is not None:
            text = _insert_mc(text, render_montecarlo(res, montecarlo, fig_names))
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
            work.move_into(tmp)
        replace_dir(tmp, out, "run")
        if work is not None:
            work.remove()
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


# ---------------------------------------------------------------------------------------------
# Monte Carlo: the distributions over replicates
def _ci_text(sm: dict | None, metric: str) -> str:
    """``mean [lo, hi]`` of a replicate summary, or why there is none."""
    if not sm or not sm.get("n"):
        return "not computed" if not sm or not sm.get("n_failed") else "failed"
    txt = fmt(sm["mean"], metric)
    if sm.get("ci_low") is not None and sm.get("ci_high") is not None:
        txt += f" [{fmt(sm['ci_low'], metric)}, {fmt(sm['ci_high'], metric)}]"
    if sm.get("n_failed"):
        txt += f" ({sm['n_failed']} failed)"
    return txt


def key_metric(mc: dict, protocol: str, plan) -> str | None:
    """The metric a protocol's distribution figure shows: a claim's, else the first key one."""
    have = mc["over_runs"].get(protocol, {}).get("raw", {})
    for c in plan.claims:
        if c.metric in have:
            return c.metric
    for m in ("drift_rms_dph", "bias_stability_100s_dph", "rmse_dph", "coef_rms_error_dph",
              "arw_deg_rt_h", "std_dps"):
        if m in have:
            return m
    return None


def fig_replicates(res: ScenarioResult, mc: dict, path: Path) -> bool:
    """Each protocol's key metric over replicates: one column per method (raw and oracle too),
    every replicate a point, a box for the quartiles."""
    prots = [p for p in res.plan.protocols if key_metric(mc, p.name, res.plan)]
    if not prots or mc["replicates"] < 2:
        return False
    fig, axes = plt.subplots(1, len(prots), figsize=(4.2 * len(prots) + 1.5, 4.2), squeeze=False)
    rng = np.random.default_rng(0)  # horizontal jitter of the points only
    for ax, prot in zip(axes[0], prots):
        metric = key_metric(mc, prot.name, res.plan)
        ser = mc["series"].get(prot.name, {}).get(metric, {})
        labels = [lab for lab in ser if any(v is not None for v in ser[lab])]
        data = [np.array([v for v in ser[lab] if v is not None]) for lab in labels]
        ax.boxplot(data, positions=range(len(labels)), widths=0.5, showfliers=False,
                   medianprops={"color": "k"})
        for i, (lab, d) in enumerate(zip(labels, data)):
            ax.plot(i + rng.uniform(-0.15, 0.15, d.size), d, "o", ms=3.5, alpha=0.7,
                    color=_color(lab, labels) or "tab:blue", zorder=3)
        ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right")
        ax.set_ylabel(metric)
        flag = " (in-sample)" if prot.in_sample else ""
        ax.set_title(f"{prot.name}{flag}: {mc['replicates']} replicates", fontsize=10)
        if metric.endswith("_dph") and all(d.size and np.all(d > 0) for d in data):
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    _save(fig, path)
    return True


def recording_replicates(mc: dict, work=None) -> dict:
    """What the recording shows over replicates: {protocol: {metric: {label: [values]}}}."""
    return mc.get("series", {})


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
        for c in mc["claims"]:
            lo = "" if c["min_pct"] is None else f"{c['min_pct']:g}"
            hi = "" if c["max_pct"] is None else f"{c['max_pct']:g}"
            rng = f"{lo}..{hi} %"
            sm, osm = c["summary"], c["oracle_improvement"]
            tag = " (in-sample, the paper's protocol)" if c["in_sample"] else " (held out)"
            held = "–" if c["held"] is None else f"{100 * c['held']:.0f} %"
            first = c["paired"].get("first_better")
            L.append(f"- {c['source']}: \"{c['text']}\" — `{c['protocol']}`{tag}: "
                     f"{c['better']} vs {c['than']} on {c['metric']}: "
                     f"{_ci_text(sm, '_pct')} % (claim {rng}): **{c['verdict']}**; the claim "
                     f"held in {held} of replicates; {c['better']} better than {c['than']} in "
                     f"{'–' if first is None else f'{100 * first:.0f} %'} of replicates. "
                     f"Oracle over {c['than']}: {_ci_text(osm, '_pct')} %"
                     + ("" if c["oracle_bounds_claim"] else
                        f" (not a bound here: {c['better']} also filters noise)") + ".")
        L.append("")
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
                    ours = (_ci_text(sm, pv.metric) if sm and sm.get("n") else
                            "not identified" if pv.metric in ("arw_deg_rt_h",
                                                              "bias_instability_dph",
                                                              "rrw_dph_rt_h") else "not computed")
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
        rows = [[lab] + [_ci_text(po.get(lab, {}).get(m), m) for m in metrics] for lab in po]
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
    return "\n".join(L)


def _insert_mc(text: str, section: str) -> str:
    """Put the Monte Carlo section before the first protocol's single-replicate tables."""
    i = text.find("\n## Protocol ")
    return text + "\n" + section if i < 0 else text[:i + 1] + section + "\n" + text[i + 1:]
