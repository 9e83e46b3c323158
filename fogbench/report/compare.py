"""``fogbench compare``: every method of every scenario on one table and one figure.

From run directories (or the suite folder holding them), for every scenario and protocol, every
method (plug-ins included) on the scenario's headline metric: its improvement over the raw
output as a paired interval over replicates (the improvement is computed replicate by replicate
on the same data, so the interval is of the paired difference), the oracle's beside it (and the
filter oracle's where the scenario has one), the method's most frequent rank among the methods
with the probability of that rank over replicates, its failures, and whether it was scored on
the data it was fitted on (a paper's in-sample protocol, flagged).

The headline metric of a scenario is the metric of its first claim (what the scenario is about),
else ``improvement_rmse_pct``. An error metric (deg/s, deg/h: lower is better) is shown as its
improvement over raw, 100 (1 - m / raw) %, taken replicate by replicate; every value is in percent
of the raw output's (positive: better than raw). Intervals: 95 % Student t over replicates (``fogbench.run.stats.summarize``); a
single replicate has none.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from fogbench.run import stats as S

__all__ = ["FORMAT", "collect", "compare_markdown", "write_compare", "compare"]

FORMAT = "fogbench-compare"
TITLE = "# fogbench compare: every method across scenarios"
DEFAULT_METRIC = "improvement_rmse_pct"
REFERENCES = ("raw", "oracle", "oracle_filter")
FLOOR_PCT = -100.0      # the figure shows worse than this as an arrow with its value


class CompareError(ValueError):
    """A run directory that cannot be compared (named with the reason)."""


def _run_dirs(paths) -> list[Path]:
    """The run directories ``paths`` name (a suite folder: every run directory in it), each
    once: the same folder given twice, or a copy of a run under another name (the same
    ``metrics.json``), is refused naming both."""
    import hashlib

    dirs = []
    for p in map(Path, paths):
        if (p / "metrics.json").is_file():
            dirs.append(p)
        elif p.is_dir():
            found = sorted(d for d in p.iterdir() if (d / "metrics.json").is_file())
            if not found:
                raise CompareError(f"{p}: neither a run directory (metrics.json) nor a folder "
                                   "of them")
            dirs += found
        else:
            raise CompareError(f"{p}: no such run directory")
    seen: dict = {}
    for d in dirs:
        try:
            digest = hashlib.sha256((d / "metrics.json").read_bytes()).hexdigest()
        except OSError as exc:
            raise CompareError(f"{d / 'metrics.json'}: cannot be read ({exc.strerror})") from None
        for key in (("path", d.resolve()), ("content", digest)):
            if key in seen:
                how = "given twice" if key[0] == "path" else "the same run as"
                raise CompareError(f"{d}: {how} {seen[key]}" if key[0] == "content" else
                                   f"{d}: {how} (also as {seen[key]}); each run is compared once")
            seen[key] = d
    return dirs


def _check_series(series, path: Path) -> None:
    """``montecarlo.series``: protocol -> metric -> method -> a list of numbers (None where a
    replicate failed), the same count for every method of a metric (a ragged series is named:
    its rows would compare unequal numbers of replicates)."""
    where = f"{path}: key 'montecarlo.series'"
    if not isinstance(series, dict):
        raise CompareError(f"{where}: expected a table (protocol -> metric -> method -> "
                           f"values), got {type(series).__name__}")
    for prot, by_metric in series.items():
        if not isinstance(by_metric, dict):
            raise CompareError(f"{where}[{prot!r}]: expected a table, got "
                               f"{type(by_metric).__name__}")
        for metric, by_label in by_metric.items():
            if not isinstance(by_label, dict):
                raise CompareError(f"{where}[{prot!r}][{metric!r}]: expected a table, got "
                                   f"{type(by_label).__name__}")
            counts = {}
            for label, vals in by_label.items():
                if not isinstance(vals, list) or not all(
                        v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))
                        for v in vals):
                    raise CompareError(f"{where}[{prot!r}][{metric!r}][{label!r}]: expected a "
                                       "list of numbers (null for a failed replicate), got "
                                       f"{str(vals)[:60]}")
                counts[label] = len(vals)
            if len(set(counts.values())) > 1:
                raise CompareError(f"{where}[{prot!r}][{metric!r}]: ragged: its methods have "
                                   f"different numbers of replicates ({counts}); the file was "
                                   "edited or is damaged")


def _check_checksum(doc: dict, path: Path) -> None:
    """The run's own checksum (key ``sha256``, written with the file): a file whose numbers
    were edited is refused naming it; one without a checksum (written before fogbench kept
    one) is read with a warning."""
    from fogbench.console import warn
    from fogbench.run.runner import metrics_sha256

    if "sha256" not in doc:
        warn(f"{path}: no checksum (key 'sha256'; a run written before fogbench kept one, "
             "or the key was removed): its numbers are compared as they are")
    elif doc["sha256"] != metrics_sha256(doc):
        raise CompareError(f"{path}: its content does not match its checksum (key 'sha256'): "
                           "it was edited or damaged after fogbench wrote it; run the scenario "
                           "again to compare it")


def _read_metrics(d: Path) -> dict:
    """A run directory's ``metrics.json``, its shape checked where compare reads it: every
    error names the file and the key."""
    path = d / "metrics.json"
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError) as exc:
        raise CompareError(f"{path}: cannot be read ({exc})") from None
    if not isinstance(doc, dict):
        raise CompareError(f"{path}: expected a JSON object (a run directory's metrics), got "
                           f"{type(doc).__name__}")
    _check_checksum(doc, path)
    prots = doc.get("protocols")
    if not isinstance(prots, dict) or not all(isinstance(v, dict) for v in prots.values()):
        raise CompareError(f"{path}: key 'protocols': expected a table of protocol tables; "
                           "compare reads run directories of fogbench run or suite")
    for key in ("scenario",):
        if key in doc and not isinstance(doc[key], str):
            raise CompareError(f"{path}: key {key!r}: expected a string, got {doc[key]!r}")
    if "methods" in doc and not isinstance(doc["methods"], dict):
        raise CompareError(f"{path}: key 'methods': expected a table, got "
                           f"{type(doc['methods']).__name__}")
    mc = doc.get("montecarlo")
    if mc is not None:
        if not isinstance(mc, dict):
            raise CompareError(f"{path}: key 'montecarlo': expected a table, got "
                               f"{type(mc).__name__}")
        if "series" in mc:
            _check_series(mc["series"], path)
        claims = mc.get("claims")
        if claims is not None and not (isinstance(claims, list) and all(
                isinstance(c, dict) and isinstance(c.get("metric"), str) for c in claims)):
            raise CompareError(f"{path}: key 'montecarlo.claims': expected a list of claims, "
                               "each with its 'metric'")
    return doc


def _values(seq) -> np.ndarray:
    return np.array([np.nan if v is None else float(v) for v in seq], dtype=float)


def _one_replicate(doc: dict, d: Path) -> dict:
    """The series of a single-replicate run (no key 'montecarlo'): per protocol, metric and
    method the mean over its scored runs, as a series of one."""
    prots = doc.get("protocols")
    if not isinstance(prots, dict):
        raise CompareError(f"{d / 'metrics.json'}: no key 'protocols'; compare reads run "
                           "directories of fogbench run or suite")
    out: dict = {}
    for prot, body in prots.items():
        runs = (body or {}).get("runs") or {}
        for run in runs.values():
            for label, m in (run or {}).items():
                if not isinstance(m, dict):
                    continue
                for metric, v in m.items():
                    if isinstance(v, (int, float)) and not isinstance(v, bool):
                        out.setdefault(prot, {}).setdefault(metric, {}).setdefault(
                            label, []).append(float(v))
        labels = {lab for run in runs.values() for lab in (run or {})}
        for metric, by_label in out.get(prot, {}).items():
            for label in labels:       # a method that failed has no numbers: a failure
                vals = by_label.get(label, [])
                by_label[label] = [float(np.mean(vals)) if len(vals) == len(runs) else None]
    return out


def _first_errors(doc: dict, prot: str) -> dict[str, str]:
    """Per method, its first error on ``prot``: ``montecarlo.failed_methods`` where the run
    kept it, else replicate 0's record of a failed scored run (a run written before)."""
    from fogbench.run.aggregate import one_line

    kept = ((doc.get("montecarlo") or {}).get("failed_methods") or {}).get(prot)
    if isinstance(kept, dict):
        return {m: one_line(f.get("first_error")) for m, f in kept.items() if isinstance(f, dict)}
    out: dict = {}
    runs = ((doc.get("protocols") or {}).get(prot) or {}).get("runs") or {}
    for by_label in runs.values():
        for m, rec in (by_label or {}).items():
            if isinstance(rec, dict) and rec.get("status") == "failed" and m not in out:
                out[m] = one_line(rec.get("error"))
    return out


def _with_failed(vals: dict, errors: dict, R: int) -> dict:
    """``vals`` with every method that failed and has no series (an older run left a method
    that failed in every replicate out of ``montecarlo.series``) as a series of R failures."""
    out = dict(vals)
    for m in errors:
        if m not in out and m not in REFERENCES:
            out[m] = np.full(R, np.nan)
    return out


def _headline(doc: dict) -> str:
    claims = (doc.get("montecarlo") or {}).get("claims") or []
    return claims[0]["metric"] if claims else DEFAULT_METRIC


def collect(paths) -> list[dict]:
    """One row per (scenario, protocol, method) of the run directories ``paths``."""
    rows = []
    for d in _run_dirs(paths):
        doc = _read_metrics(d)
        mc = doc.get("montecarlo")
        if not isinstance(mc, dict) or "series" not in mc:
            mc = {"series": _one_replicate(doc, d)}
        metric = _headline(doc)
        better = "higher"
        for prot, by_metric in mc["series"].items():
            series = by_metric.get(metric)
            if not series:
                continue
            in_sample = bool(doc.get("protocols", {}).get(prot, {}).get("in_sample", False))
            vals = {lab: _values(v) for lab, v in series.items()}
            if not metric.endswith("_pct"):
                # an error metric (lower is better): its improvement over raw, replicate by
                # replicate on the same data, 100 (1 - m / raw) %
                if "raw" not in vals:
                    continue
                raw = vals["raw"]
                with np.errstate(divide="ignore", invalid="ignore"):
                    vals = {lab: np.where(raw > 0, 100.0 * (1.0 - v / raw), np.nan)
                            for lab, v in vals.items()}
            errors = _first_errors(doc, prot)
            R = len(next(iter(vals.values()))) if vals else 0
            vals = _with_failed(vals, errors, R)
            methods = [m for m in vals if m not in REFERENCES]
            if not methods:
                continue
            # a method that failed in every replicate: after the others, ranked last
            everywhere = [m for m in methods if not np.any(np.isfinite(vals[m]))]
            methods = [m for m in methods if m not in everywhere] + everywhere
            M = np.column_stack([vals[m] for m in methods])
            sign = -1.0 if better == "higher" else 1.0
            key = np.where(np.isfinite(M), sign * M, np.inf)      # a failure ranks last
            # 1 + the methods strictly better in that replicate: equal values share a rank
            ranks = 1 + np.sum(key[:, None, :] < key[:, :, None], axis=2)
            ranks[:, len(methods) - len(everywhere):] = len(methods)
            refs = {lab: S.summarize(vals[lab]).as_dict() for lab in REFERENCES[1:]
                    if lab in vals}
            for j, m in enumerate(methods):
                counts = np.bincount(ranks[:, j], minlength=len(methods) + 1)
                mode = int(np.argmax(counts))
                name = doc.get("scenario", d.name)
                spec = (doc.get("methods") or {}).get(m) or {}
                rows.append({
                    "scenario": name if d.name == name else f"{name} ({d.name})",
                    "run_dir": str(d),
                    "protocol": prot, "in_sample": in_sample,
                    "ideal_of": doc.get("protocols", {}).get(prot, {}).get("ideal_of"),
                    "group": spec.get("group"),
                    "paper_setting": bool(spec.get("paper_setting")),
                    "metric": metric if metric.endswith("_pct") else
                    f"improvement of {metric} over raw, %",
                    "better": better, "method": m, "replicates": R,
                    "failed": int(np.sum(~np.isfinite(vals[m]))),
                    "first_error": errors.get(m) if np.any(~np.isfinite(vals[m])) else None,
                    "value": S.summarize(vals[m]).as_dict(),
                    "rank": mode, "rank_probability": float(counts[mode] / R),
                    "methods_ranked": len(methods), **{lab: refs[lab] for lab in refs}})
    return rows


def _iv(s: dict | None) -> str:
    if not s or s.get("mean") is None:
        return "–"
    lo, hi = s.get("ci_low"), s.get("ci_high")
    if lo is None or hi is None or not math.isfinite(lo):
        return f"{s['mean']:.3g}"
    return f"{s['mean']:.3g} [{lo:.3g}, {hi:.3g}]"


def _failed_everywhere(r: dict) -> bool:
    return bool(r.get("failed")) and r["failed"] == r.get("replicates")


def _failed_text(r: dict) -> str:
    """``failed in R of R: <first error>`` (the error where the run recorded it)."""
    err = r.get("first_error")
    return f"failed in {r['failed']} of {r['replicates']}" + (f": {err}" if err else "")


def _value_text(r: dict) -> str:
    """A row's improvement: its interval, or for a method that failed in every replicate
    the failure with its first error."""
    return _failed_text(r) if _failed_everywhere(r) else _iv(r["value"])


def compare_markdown(rows: list[dict]) -> str:
    from fogbench.run.runner import ORACLE_FILTER_MAX_SAMPLES

    L = [TITLE, "",
         "Per scenario and protocol, every method on the scenario's headline metric (its first "
         "claim's, else improvement_rmse_pct: percent of the raw output's RMS error removed; an "
         "error metric is shown as its improvement over raw, 100 (1 - m / raw) %, replicate by "
         "replicate; positive is better than raw): the mean over replicates with its 95 % paired "
         "t-interval (the improvement is taken replicate by replicate on the same data), the "
         "oracle's (the true deterministic error removed) and the filter oracle's (the best "
         "estimate given the true noise model; where every scored piece is static, "
         f"contiguous and of at most {ORACLE_FILTER_MAX_SAMPLES:,} samples, else -) beside "
         "it, the "
         "method's most frequent rank among the methods and the share of replicates where it "
         "had that rank, and its failed replicates (a method that failed in every replicate: "
         "\"failed in R of R\" with its first error, ranked last). In-sample: scored on the data it was "
         "fitted on (a paper's protocol, flagged). The figure leaves the ideal-lab twins "
         "(`<name>.ideal`) to this table and draws a sweep as its paper setting's row with the "
         "range of its settings' means.", "",
         "![every method across scenarios](compare.png)", "",
         "| scenario | protocol | metric | method | improvement [95 % CI] | oracle | filter "
         "oracle | rank (P) | failed | in-sample |",
         "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append(f"| {r['scenario']} | {r['protocol']} | {r['metric']} | {r['method']} | "
                 f"{_value_text(r)} | {_iv(r.get('oracle'))} | {_iv(r.get('oracle_filter'))} | "
                 f"{r['rank']} of {r['methods_ranked']} ({r['rank_probability']:.0%}) | "
                 f"{r['failed']} of {r['replicates']} | {'yes' if r['in_sample'] else 'no'} |")
    return "\n".join(L) + "\n"


def _figure_rows(rows: list[dict]) -> list[dict]:
    """The rows the figure draws: ideal-lab twins (``<name>.ideal``, in the table and in each
    report's "What the lab's references cost") left out; a sweep's members as one row, its
    paper (default) setting's, with ``sweep`` the members' (min, max) mean and count."""
    means_of: dict[tuple, list[float]] = {}
    for x in rows:
        if x.get("group") and x["value"].get("mean") is not None:
            means_of.setdefault((x["scenario"], x["protocol"], x["group"]), []).append(
                x["value"]["mean"])
    out, seen = [], {}
    for r in rows:
        if r.get("ideal_of"):
            continue
        g = r.get("group")
        if not g:
            out.append(dict(r))
            continue
        key = (r["scenario"], r["protocol"], g)
        means = means_of.get(key, [])
        if key not in seen:
            seen[key] = len(out)
            out.append({**r, "method": f"{g} ({len(means)} settings)",
                        "sweep": (min(means), max(means)) if means else None})
        if r.get("paper_setting"):
            out[seen[key]].update({k: v for k, v in r.items() if k != "method"},
                                  sweep=out[seen[key]]["sweep"])
    return out


def _short_metric(metric: str) -> str:
    """A row's metric as its label names it: ``improvement_rmse_pct`` -> ``rmse``,
    ``improvement of std_dps over raw, %`` -> ``std_dps``."""
    if metric.startswith("improvement of "):
        return metric[len("improvement of "):].split(" over raw")[0]
    if metric.startswith("improvement_") and metric.endswith("_pct"):
        return metric[len("improvement_"):-len("_pct")]
    return metric


def _figure(rows: list[dict], path: str) -> None:
    """The methods' improvement over raw with its interval, a row each (ideal twins left
    out, a sweep as one row with its members' range), a band per scenario; filled: held out,
    hollow: in-sample; black tick: the oracle, grey: the filter oracle."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fogbench.outputs import files

    rows = _figure_rows(rows)
    n = max(len(rows), 1)
    fig, ax = plt.subplots(figsize=(9.0, 1.6 + 0.2 * n))
    y = np.arange(len(rows))[::-1]
    labels = []
    last = None
    color = "#1f4e79"
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    for yi, r in zip(y, rows):
        group = (r["scenario"], r["protocol"])
        if scenarios.index(r["scenario"]) % 2 == 0:       # every other scenario shaded
            ax.axhspan(yi - 0.5, yi + 0.5, color="0.93", lw=0, zorder=0)
        # the first row of a protocol names its metric: the scenarios' headline metrics differ
        labels.append(f"{r['scenario']} / {r['protocol']} [{_short_metric(r['metric'])}]: "
                      f"{r['method']}" if group != last else r["method"])
        last = group
        _draw_row(ax, yi, r, color)
    ax.axvline(0.0, color="0.6", lw=0.8)
    left, right = ax.get_xlim()
    ax.set_xlim(max(left, FLOOR_PCT - 5.0), max(right, 5.0))
    ax.set_ylim(-0.6, len(rows) - 0.4)
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=6)
    ax.set_xlabel("improvement over raw, % of the metric in [ ] (each scenario's headline "
                  "metric): mean and 95 % interval over replicates", fontsize=8)
    handles = _legend_handles(rows, color)
    ax.legend(handles=handles, fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0),
              ncol=3, frameon=False)
    ax.set_title("Every method across scenarios (ideal-lab twins and sweep settings: "
                 "compare.md)", fontsize=9, pad=34)
    fig.tight_layout()
    files.save_figure(fig, path)
    plt.close(fig)


def _draw_row(ax, yi: float, r: dict, color) -> None:
    """One row of the figure at height ``yi``: the method's mean and interval (a marker at the
    floor when far worse than raw), its sweep's range, the oracles' ticks, and its failures."""
    v = r["value"]
    face = "white" if r["in_sample"] else color
    if v.get("mean") is not None and v["mean"] < FLOOR_PCT:   # far worse than raw
        ax.plot(FLOOR_PCT, yi, "<", color=color, mfc=face, ms=5)
        ax.annotate(f"{v['mean']:.3g}", (FLOOR_PCT, yi), xytext=(6, 0),
                    textcoords="offset points", fontsize=6, va="center")
    elif v.get("mean") is not None:
        lo = v.get("ci_low") if v.get("ci_low") is not None else v["mean"]
        hi = v.get("ci_high") if v.get("ci_high") is not None else v["mean"]
        ax.errorbar(v["mean"], yi, xerr=[[v["mean"] - max(lo, FLOOR_PCT)],
                                         [hi - v["mean"]]], fmt="o", color=color,
                    mfc=face, ms=4, capsize=2, zorder=3)
    if r.get("sweep"):
        a, b = r["sweep"]
        ax.plot([max(a, FLOOR_PCT), b], [yi - 0.3, yi - 0.3], color="0.45", lw=2.0,
                solid_capstyle="butt", zorder=2)
    for lab, c in (("oracle", "black"), ("oracle_filter", "0.55")):
        o = r.get(lab)
        if o and o.get("mean") is not None and o["mean"] >= FLOOR_PCT:
            ax.plot(o["mean"], yi, "|", color=c, ms=9, mew=1.6, zorder=2.5)
    if _failed_everywhere(r):     # no value to draw: a cross at 0 and why, on its row
        ax.plot(0.0, yi, "x", color="C3", ms=6, mew=1.5, zorder=3)
        ax.annotate(_failed_text(r)[:90], (0.0, yi), xytext=(6, 0),
                    textcoords="offset points", fontsize=6, va="center", color="C3")
    elif r["failed"]:
        ax.annotate(f"{r['failed']} failed", (1.0, yi), xycoords=("axes fraction", "data"),
                    fontsize=6, ha="right", va="center", color="C1")


def _legend_handles(rows: list[dict], color) -> list:
    """The legend's entries (the failed-everywhere cross only when a row has one)."""
    from matplotlib.lines import Line2D

    from fogbench.run.runner import ORACLE_FILTER_MAX_SAMPLES

    handles = [Line2D([], [], marker="o", color=color, ls="", label="held out"),
               Line2D([], [], marker="o", color=color, mfc="white", ls="",
                      label="in-sample (fitted on what it is scored on)"),
               Line2D([], [], marker="|", color="black", ls="", ms=9, mew=1.6,
                      label="oracle (true deterministic terms removed)"),
               Line2D([], [], marker="|", color="0.55", ls="", ms=9, mew=1.6,
                      label="filter oracle (best given the true noise model; where every "
                            "scored piece is static, contiguous, of <= "
                            f"{ORACLE_FILTER_MAX_SAMPLES:,} samples and its noise model holds)"),
               Line2D([], [], color="0.45", lw=2.0,
                      label="a sweep: its settings' means, min to max")]
    if any(_failed_everywhere(r) for r in rows):
        handles.append(Line2D([], [], marker="x", color="C3", ls="", mew=1.5,
                              label="failed in every replicate (no value; at 0, its first "
                                    "error)"))
    return handles


def _ours(folder: Path) -> bool:
    """Whether ``folder``'s compare outputs, if any, are this command's (else refuse)."""
    j, md = folder / "compare.json", folder / "compare.md"
    if j.exists():
        try:
            if json.loads(j.read_text()).get("format") != FORMAT:
                return False
        except (OSError, ValueError, AttributeError):
            return False
    if md.exists():
        try:
            if md.read_text(errors="replace").splitlines()[:1] != [TITLE]:
                return False
        except OSError:
            return False
    if (folder / "compare.png").exists() and not j.exists():
        return False
    return True


def write_compare(paths, out: Path) -> Path:
    """Write ``out/compare.md``, ``compare.json`` and ``compare.png``, all three or none;
    replaces only files this command wrote. Returns the Markdown's path."""
    from fogbench.outputs.folders import Outputs

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise CompareError(f"--out {out}: not a folder")
    if out.is_dir() and not _ours(out):
        raise CompareError(f"--out {out}: compare.md, compare.json or compare.png there were "
                           "not written by fogbench compare; left untouched")
    rows = collect(paths)
    if not rows:
        raise CompareError("compare: no method with replicates on its scenario's headline "
                           "metric in " + ", ".join(map(str, paths)))
    files_ = Outputs(True, "compare")
    names = {n: files_.target(out / n, recognise=lambda p: _ours(p.parent))
             for n in ("compare.png", "compare.json", "compare.md")}
    try:
        files_.write(names["compare.png"], lambda tmp: _figure(rows, tmp))
        files_.write_text(names["compare.json"], json.dumps(
            {"format": FORMAT, "version": 1, "rows": rows}, indent=1, allow_nan=False))
        files_.write_text(names["compare.md"], compare_markdown(rows))
        files_.commit()
    finally:
        files_.discard()
    return names["compare.md"]


def compare(dirs: list[str], out: str | Path | None = None) -> int:
    """``fogbench compare``: the run directories (or one suite folder) ``dirs`` on one table
    and one figure in ``out`` (default: the suite folder when it is the one argument)."""
    _run_dirs(dirs)                  # every argument checked before anything else
    out = Path(out) if out else None
    if out is None:
        if len(dirs) == 1 and Path(dirs[0]).is_dir() and not \
                (Path(dirs[0]) / "metrics.json").exists():
            out = Path(dirs[0])
        else:
            raise CompareError("compare: give --out DIR (the folder for compare.md, .json, "
                               ".png) unless the one argument is a suite folder")
    md = write_compare(dirs, out)
    print(f"compare: wrote {md}, {out / 'compare.json'}, {out / 'compare.png'}")
    return 0
