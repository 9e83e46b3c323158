"""``fogbench suite``: every scenario, in parallel processes, and the summary reports/README.md."""

from __future__ import annotations

import contextlib
import math
import sys
import time
import traceback
from pathlib import Path

from fogbench.console import Progress, warn
from fogbench.outputs.folders import Claim, OutDirError, check_out_dir
from fogbench.report import write_run_dir
from fogbench.report.fmt import (ci_text, failed_everywhere, failed_text, fmt, md_table,
                                  p_better_text)
from fogbench.run.engines import SerialExecutor, check_engine, engine_label, make_executor
from fogbench.run.maps import side
from fogbench.run.montecarlo import ScenarioMC
from fogbench.run.workdir import MonteCarloError
from fogbench.scenario import ScenarioError, claim_name, load_plan, load_scenario
from fogbench.scenario.load import RUNNER_SECTIONS

__all__ = ["run_suite", "check_bounds", "summary_markdown"]

SUMMARY_METRICS = ("std_dps", "rmse_dph", "drift_rms_dph", "bias_stability_100s_dph",
                   "angle_error_final_deg", "angle_error_max_deg", "coef_rms_error_dph",
                   "improvement_rmse_pct", "fit_time_s")


def _values(doc: dict, protocol: str, method: str, metric: str, run: str | None):
    """(run, value, why-missing) of a metric: the mean over replicates when there are several."""
    mc = doc.get("montecarlo")
    if mc:
        for rname, by_label in mc["summary"].get(protocol, {}).items():
            if run is not None and rname != run:
                continue
            sm = by_label.get(method, {}).get(metric)
            if sm is None:
                yield rname, None, ("method not scored" if method not in by_label else
                                    "metric not computed")
            elif not sm.get("n"):
                yield rname, None, "failed in every replicate" if sm.get("n_failed") else \
                    "metric not computed"
            elif sm.get("n_failed"):
                yield rname, None, f"failed in {sm['n_failed']} replicate(s)"
            else:
                yield rname, sm["mean"], None
        return
    prot = doc["protocols"].get(protocol, {})
    for rname, by_method in prot.get("runs", {}).items():
        if run is not None and rname != run:
            continue
        m = by_method.get(method)
        if m is None:
            yield rname, None, "method not scored"
        elif m.get("status") == "failed":
            yield rname, None, f"method failed: {m.get('error')}"
        elif metric not in m or m[metric] is None:
            yield rname, None, "metric not computed"
        else:
            yield rname, m[metric], None


def check_bounds(name: str, plan, doc: dict) -> list[str]:
    """Messages for every metric outside its declared bounds (empty when all hold).

    The value is the mean over replicates (replicate 0's when there is one). A bound with
    ``relative_to`` compares the ratio of the method's value to that row's (e.g. "no worse than
    the raw output": ``relative_to = "raw"``, ``max = 1.0``). A bound on a sweep's label holds
    for every member of the sweep.
    """
    bad = []
    for b in plan.bounds:
        members = [m.label for m in plan.methods if m.group == b.method] or [b.method]
        for method in members:
            ref = {} if b.relative_to is None else {
                run: v for run, v, why in _values(doc, b.protocol, b.relative_to, b.metric, b.run)
                if not why}
            for run, v, why in _values(doc, b.protocol, method, b.metric, b.run):
                where = f"{name}: protocol {b.protocol}, run {run}, method {method}, {b.metric}"
                if why:
                    bad.append(f"{where}: {why}")
                    continue
                what = fmt(v, b.metric)
                if b.relative_to is not None:
                    if not ref.get(run):
                        bad.append(f"{where}: no {b.relative_to} value to compare with")
                        continue
                    v = v / ref[run]
                    what = f"{what} = {v:.3g} x {b.relative_to}"
                if (b.lo is not None and v < b.lo) or (b.hi is not None and v > b.hi) or \
                        not math.isfinite(v):
                    bad.append(f"{where} = {what} outside [{fmt(b.lo)}, {fmt(b.hi)}]"
                               + (f" (ratio to {b.relative_to})" if b.relative_to else ""))
    return bad


def _mean_over_runs(prot: dict, label: str, metric: str):
    vals = []
    for by_method in prot["runs"].values():
        m = by_method.get(label, {})
        if m.get("status") == "failed":
            return "failed"
        v = m.get(metric)
        if isinstance(v, (int, float)) and math.isfinite(v):
            vals.append(v)
    return sum(vals) / len(vals) if vals else None


def _start_text(c: dict) -> str:
    """", a start of A beats one of B with probability p [CI]" for two seeded methods."""
    o = c.get("over_seeds")
    if not o:
        return ""
    failed = sum((o.get("failed_starts") or {}).values())
    return (f"; over {o.get('seeds_per_replicate') or 'K'} method starts per replicate, a "
            f"start of {c['better']} beats one of {c['than']} with probability "
            f"{p_better_text(o['p_better_start'])}"
            + (f" ({failed} failed starts left out)" if failed else ""))


def claim_verdicts(plan, doc) -> list[str]:
    """Each numeric claim checked on each protocol: holds or does not, with the numbers."""
    out = []
    for c in plan.claims:
        for pname, pd in doc["protocols"].items():
            pcts = []
            for run, by_method in pd["runs"].items():
                if c.run is not None and run != c.run:
                    continue
                a, b = by_method.get(c.better, {}), by_method.get(c.than, {})
                va, vb = a.get(c.metric), b.get(c.metric)
                if isinstance(va, (int, float)) and isinstance(vb, (int, float)) and vb:
                    pcts.append((run, 100.0 * (1.0 - va / vb), va, vb))
            if not pcts:
                continue
            mean = sum(p[1] for p in pcts) / len(pcts)
            ok = (c.min_pct is None or mean >= c.min_pct) and (c.max_pct is None or
                                                                 mean <= c.max_pct)
            rng = (f"{'' if c.min_pct is None else f'{c.min_pct:g}'}.."
                   f"{'' if c.max_pct is None else f'{c.max_pct:g}'} %")
            per = "; ".join(f"{r}: {fmt(va, c.metric)} vs {fmt(vb, c.metric)} ({p:+.0f} %)"
                            for r, p, va, vb in pcts)
            tag = " (in-sample)" if pd["in_sample"] else ""
            out.append(f"{c.source}: \"{c.text}\" — protocol `{pname}`{tag}: {c.better} vs "
                       f"{c.than} on {c.metric}: {mean:+.1f} % (claim {rng}; this one draw "
                       f"{'within' if ok else 'outside'} it): **inconclusive** (one replicate, "
                       f"no interval: give --replicates). {per}.")
    return out


#: The summary's opening: what it is, where its numbers come from and how to read them.
_SUMMARY_INTRO = (
    "Written by `fogbench suite` (`make run`); the scenario reports it links "
    "(`<scenario>/report.md`, figures, `metrics.json`, `recording.rrd`) are written beside "
    "it by the same command.", "",
    "Each scenario's methods were fitted on some runs and scored on others against the "
    "simulation's truth (see each report for the protocol), over R replicates (power-ons "
    "and method starts drawn anew). Values: mean [95 % t-interval of the mean] over "
    "replicates of the mean over a protocol's scored runs. Rows `raw` (the FOG output) and "
    "`oracle` (raw minus the true deterministic error terms) bracket what compensation of "
    "those terms can do. Units are in the metric names (`_dps` deg/s, `_dph` deg/h, `_deg` "
    "deg, `_pct` percent improvement over raw). In-sample protocols (a paper's own, scored "
    "on fitted data) are flagged.", "")


def _protocol_lines(pname: str, pd: dict, mc: dict | None) -> list[str]:
    """One protocol's table of key metrics (mean [interval] over replicates, or the one draw)."""
    flag = " (IN-SAMPLE, the paper's protocol)" if pd["in_sample"] else " (held out)"
    L = [f"**Protocol `{pname}`{flag}**, scored on {', '.join(pd['runs'])}:", ""]
    if mc:
        po = mc["over_runs"].get(pname, {})
        metrics = [m for m in SUMMARY_METRICS if m != "fit_time_s" and any(
            m in po.get(lab, {}) for lab in po)]
        failed = failed_everywhere(mc, pname)    # last, its first error once, no numbers
        rows = [[lab] + [ci_text(po[lab].get(m), m) for m in metrics] for lab in po
                if lab not in failed]
        rows += [[lab, failed_text(f)] + ["–"] * (len(metrics) - 1) for lab, f in failed.items()]
    else:
        labels = []
        for by_method in pd["runs"].values():
            for lab in by_method:
                if lab not in labels:
                    labels.append(lab)
        metrics = [m for m in SUMMARY_METRICS if m != "fit_time_s" and any(
            isinstance(_mean_over_runs(pd, lab, m), float) for lab in labels)]
        rows = [[lab] + [fmt(_mean_over_runs(pd, lab, m), m) for m in metrics]
                for lab in labels]
    return L + [md_table(["method"] + metrics, rows), ""]


def _claim_line(c: dict) -> str:
    """One claim's verdict over replicates, with its interval, the oracle's and the starts'."""
    lo = "" if c["min_pct"] is None else f"{c['min_pct']:g}"
    hi = "" if c["max_pct"] is None else f"{c['max_pct']:g}"
    tag = " (in-sample)" if c["in_sample"] else ""
    held = "–" if c["held"] is None else f"{100 * c['held']:.0f} %"
    return (f"- {c['source']}: \"{c['text']}\" — `{c['protocol']}`{tag}: "
            f"{c['better']} vs {c['than']} on {c['metric']}: "
            f"{ci_text(c['summary'], '_pct')} % (claim {lo}..{hi} %): "
            f"**{c['verdict']}**"
            + (f" ({side(c)} the claim)" if side(c) else "")
            + f" (held in {held} of replicates; oracle "
            f"{ci_text(c['oracle_improvement'], '_pct')} %"
            + ("" if c["oracle_bounds_claim"] else ", not a bound for a filter")
            + (" (the filter oracle)" if c.get("oracle") == "oracle_filter"
               else "")
            + ")" + _start_text(c) + ".")


def _map_lines(name: str, mp: dict) -> list[str]:
    """The claim maps of a scenario: each claim's sentence over the map's points."""
    from fogbench.report.maps import replicates_text

    L = [f"Claim maps ({'; '.join(a['name'] for a in mp['axes'])}; "
         f"{replicates_text(mp)}):", ""]
    for c in mp["claims"]:
        tag = " (in-sample)" if c["in_sample"] else ""
        L.append(f"- \"{c['text']}\" — `{c['protocol']}`{tag}: {c['sentence']}.")
    if not mp["claims"]:
        L.append(f"- no claims to map; the metrics at every point: "
                 f"[its report]({name}/report.md#metrics-at-every-point).")
    L.append("")
    return L


def _ranking_lines(rankings: list[dict]) -> list[str]:
    """How often the replicates order the methods as the paper's table does."""
    L = ["Rankings against the paper's table:", ""]
    for rk in rankings:
        top = rk["orderings"][0] if rk["orderings"] else None
        L.append(f"- `{rk['protocol']}`, {rk['run']}, {rk['metric']}: the paper's "
                 f"order {' < '.join(rk['paper_order'])} in "
                 f"{100 * rk['p_paper_order']:.0f} % of replicates"
                 + (f"; most frequent {top['ordering']} "
                    f"({100 * top['probability']:.0f} %)" if top else "") + ".")
    L.append("")
    return L


#: The attitude-level metric the methods are also ordered by (issue 42): the largest angle the
#: output minus the truth accumulates about the gyro's input axis over a scored run.
ATTITUDE_METRIC = "angle_error_max_deg"


def _attitude_order_lines(mc: dict, plan) -> list[str]:
    """Per protocol, the methods (raw and oracle included) ordered by the mean over replicates of
    the scenario's rate metric (its first claim's, else ``rmse_dph``; best first: the largest
    first for an improvement in %) and by the attitude metric, with the places that change.
    Methods without both metrics over every scored run (a mean over fewer runs is not
    comparable) are left out and named."""
    rate = next((c.metric for c in plan.claims if c.metric != ATTITUDE_METRIC), "rmse_dph")
    sign = -1.0 if rate.endswith("_pct") else 1.0
    L = []
    for pname, po in mc["over_runs"].items():
        means, partial = {}, []
        for lab, by_metric in po.items():
            a, b = by_metric.get(rate) or {}, by_metric.get(ATTITUDE_METRIC) or {}
            if a.get("n") and b.get("n"):
                if a.get("runs") or b.get("runs"):
                    partial.append(lab)
                else:
                    means[lab] = (sign * a["mean"], b["mean"])
        if len(means) < 2:
            continue
        by_rate = sorted(means, key=lambda k: means[k][0])
        by_att = sorted(means, key=lambda k: means[k][1])
        moved = [f"{lab} {by_rate.index(lab) + 1} -> {by_att.index(lab) + 1}"
                 for lab in by_rate if by_rate.index(lab) != by_att.index(lab)]
        L.append(f"- `{pname}`: by {rate}: {', '.join(by_rate)}; by {ATTITUDE_METRIC}: "
                 f"{', '.join(by_att)}" + (f" (places changed: {', '.join(moved)})" if moved
                                            else " (the same order)")
                 + (f"; not ranked (scored on fewer runs): {', '.join(partial)}" if partial
                    else "") + ".")
    if not L:
        return []
    return (["Ranking by rate and by attitude, best first (means over replicates; each "
             "method's interval is in the table above, and an order between overlapping "
             "intervals is no verdict):", ""] + L + [""])


def _scenario_lines(r: dict, plans: dict) -> list[str]:
    """One scenario's section: its tables, claims, maps, rankings and notes (or its failure)."""
    name = r["name"]
    if not r["ok"]:
        return [f"## {name}: FAILED", "", "```", r["error"], "```", ""]
    doc, plan = r["metrics"], plans[name]
    mc = doc.get("montecarlo")
    R = mc["replicates"] if mc else 1
    L = [f"## [{name}]({name}/report.md)", "", doc["description"], "",
         f"{R} replicate(s)" + (f", {mc['method_seeds']} method seed(s) per fit"
                                if mc and mc["method_seeds"] > 1 else "") + ".", ""]
    for pname, pd in doc["protocols"].items():
        L += _protocol_lines(pname, pd, mc)
    if mc:
        if mc["claims"]:
            L += ["Claims:", ""] + [_claim_line(c) for c in mc["claims"]] + [""]
        if doc.get("map"):
            L += _map_lines(name, doc["map"])
        if mc["rankings"]:
            L += _ranking_lines(mc["rankings"])
        L += _attitude_order_lines(mc, plan)
    else:
        verdicts = claim_verdicts(plan, doc)
        if verdicts:
            L += ["Claims (one replicate: no interval):", ""] + [f"- {v}" for v in verdicts]
            L.append("")
    for note in plan.notes:
        L += [f"> {note}", ""]
    return L


def summary_markdown(results: list[dict], plans: dict, out: Path, violations: list[str]) -> str:
    """The suite's summary: per scenario and protocol, every method's key metrics as mean and
    interval over replicates, the claims' verdicts and the rankings. Nothing in it depends on
    the machine or the day (no dates, no wall times), so a re-run leaves it unchanged."""
    L = [SUMMARY_TITLE, "", *_SUMMARY_INTRO]
    for r in sorted(results, key=lambda r: r["name"]):
        L += _scenario_lines(r, plans)
    L += ["## Bounds check", ""]
    L += (["Every declared bound holds."] if not violations else
          ["Outside bounds:", ""] + [f"- {v}" for v in violations])
    L.append("")
    return "\n".join(L)


SUMMARY_TITLE = "# fogbench suite: summary"


def _summary_path(out: Path, partial: bool) -> Path:
    readme = Path(out) / ("README.partial.md" if partial else "README.md")
    if readme.exists():
        try:
            first = readme.read_text(errors="replace").splitlines()[:1]
        except OSError as exc:
            raise OutDirError(f"--out {out}: cannot read {readme} ({exc.strerror})") from None
        if first != [SUMMARY_TITLE]:
            raise OutDirError(f"--out {out}: {readme} exists and is not a fogbench suite summary "
                              f"(its first line is not {SUMMARY_TITLE!r}); it was left "
                              "untouched. Give another --out folder")
    return readme


def _write_summary(readme: Path, text: str) -> None:
    """The summary put in place only over a summary of ours (checked again now: a file of
    the user's saved there while the suite ran is left as it is, and the suite fails)."""
    from fogbench.outputs.folders import Outputs

    def ours(p: Path) -> bool:
        try:
            return p.read_text(errors="replace").splitlines()[:1] == [SUMMARY_TITLE]
        except OSError:
            return False

    out = Outputs(True, "suite")
    out.target(readme, recognise=ours, what="suite summary")
    try:
        out.write_text(readme, text)
        out.commit()
    finally:
        out.discard()


def _write_compare(out: Path, names: list[str]) -> Path | None:
    """``fogbench compare`` over this suite's run folders; a failure is said, not fatal (the
    summary is written either way)."""
    from fogbench.report.compare import write_compare

    dirs = [Path(out) / n for n in names if (Path(out) / n / "metrics.json").is_file()]
    if not dirs:
        return None
    try:
        return write_compare(dirs, out)
    except Exception as exc:
        warn(f"compare: {exc}")
        return None


def run_suite(scenario_dir: Path, out: Path, check: bool = False, jobs: int | None = None,
              only_ci: bool = False, recording: bool = True, quiet: bool = False,
              names: list[str] | None = None, replicates: int | None = None,
              method_seeds: int | None = None, scheduler: str | None = None,
              cluster: str | None = None, cluster_options: dict | None = None,
              resume: bool = False, no_map: bool = False,
              map_replicates: int | None = None, figures: bool = True) -> int:
    """Run every scenario of ``scenario_dir`` with its replicates on one executor and write
    ``out/<scenario>/`` and the summary ``out/README.md``. Returns the exit status."""
    scenario_dir = Path(scenario_dir)
    if not scenario_dir.is_dir():
        raise OutDirError(f"--scenarios {scenario_dir}: not a folder")
    paths = sorted(scenario_dir.glob("*.toml"))
    if not paths:
        print(f"fogbench: error: no scenario files (*.toml) in {scenario_dir}", file=sys.stderr)
        return 2
    plans, chosen, results, first_file = {}, [], [], {}
    for p in paths:
        try:
            sc = load_scenario(p, extra_sections=RUNNER_SECTIONS)
            plan = load_plan(sc)
        except ScenarioError as exc:
            if names and p.stem not in names:
                # a broken file the user did not ask for: say so, and go on with the others
                warn(f"skipped: {exc}")
                continue
            results.append({"path": str(p), "name": p.stem, "ok": False, "wall_s": 0.0,
                            "error": str(exc)})
            print(f"fogbench: error: {exc}", file=sys.stderr)
            continue
        claim_name(first_file, sc, p)
        if only_ci and not plan.ci:
            continue
        if names and sc.name not in names:
            continue
        plans[sc.name] = plan
        chosen.append(str(p))
    if names:
        missing = sorted(set(names) - set(plans))
        if missing:
            print(f"fogbench: error: no scenario named {missing} in {scenario_dir}",
                  file=sys.stderr)
            return 2
    if not chosen:
        if results:  # every scenario file was refused: nothing to run, nothing written
            return 2
        print(f"fogbench: error: no scenario to run in {scenario_dir}"
              + (" (none is marked ci = true)" if only_ci else ""), file=sys.stderr)
        return 2
    # every output place is checked before any work: nothing of the user's is ever replaced
    readme = _summary_path(out, partial=bool(only_ci or names))
    for name in plans:
        check_out_dir(Path(out) / name, "run", flag=f"--out {out}: folder {name}")
    check_engine(jobs, scheduler, cluster, cluster_options)  # even when no pool is needed
    # the reports folder is this suite's until it ends: a second suite into it is refused at
    # once, before it could write its summary over this one's
    claim = Claim(Path(out), lambda p: OutDirError(
        f"--out {out}: another fogbench suite is writing into {p}; wait for it or give "
        "another --out"))
    created = claim.acquire()
    try:
        return _suite_body(plans, chosen, first_file, results, out, readme, check, jobs,
                           recording, quiet, replicates, method_seeds, scheduler, cluster,
                           cluster_options, resume, no_map, map_replicates, figures)
    finally:
        claim.release()
        if created and not any(Path(out).iterdir()):
            claim.remove()      # nothing was written: no empty folder left behind


def _open_mc(p: str, run_dir: Path, replicates, method_seeds, resume: bool) -> ScenarioMC:
    """A scenario's replicates, resumed when asked (with nothing left over: started afresh)."""
    try:
        return ScenarioMC(p, run_dir, replicates=replicates, method_seeds=method_seeds,
                          resume=resume)
    except MonteCarloError as exc:
        if not (resume and "nothing to resume" in str(exc)):
            raise
        # --resume on a suite: a scenario with nothing left over starts afresh
        return ScenarioMC(p, run_dir, replicates=replicates, method_seeds=method_seeds,
                          resume=False)


def _open_map(p: str, run_dir: Path, mc: ScenarioMC, map_replicates, method_seeds,
              resume: bool):
    """A scenario's claim map, resumed when asked (with nothing left over: started afresh)."""
    from fogbench.run.maps import MapRun

    try:
        return MapRun(p, run_dir, mc, replicates=map_replicates, method_seeds=method_seeds,
                      resume=resume)
    except MonteCarloError as exc:
        if not (resume and "nothing to resume" in str(exc)):
            raise
        return MapRun(p, run_dir, mc, replicates=map_replicates, method_seeds=method_seeds)


def _open_scenarios(chosen, first_file, out, results, replicates, method_seeds, resume,
                    no_map, map_replicates) -> tuple[dict, dict]:
    """(name -> ScenarioMC, name -> MapRun) of the chosen files; one refused is a failed result."""
    mcs: dict = {}
    maps: dict = {}
    for p in chosen:
        name = next(n for n, f in first_file.items() if str(f) == p)
        try:
            mcs[name] = _open_mc(p, Path(out) / name, replicates, method_seeds, resume)
            if mcs[name].plan.map is not None and not no_map:
                maps[name] = _open_map(p, Path(out) / name, mcs[name], map_replicates,
                                       method_seeds, resume)
        except (MonteCarloError, OutDirError) as exc:
            if name in mcs:
                mcs.pop(name).work.remove_if_empty()
            results.append({"path": p, "name": name, "ok": False, "wall_s": 0.0,
                            "error": str(exc)})
            print(f"fogbench: {name} is not run: {exc}", file=sys.stderr)
    return mcs, maps


def _say_kept(kept: dict) -> None:
    """Name the scenarios whose stored replicates a --resume would go on from."""
    print(f"fogbench: replicates kept for {', '.join(f'{n} ({k})' for n, k in kept.items())}"
          "; run the suite again with --resume to go on", file=sys.stderr)


def _run_scenarios(mcs: dict, maps: dict, out, results: list, jobs, scheduler, cluster,
                   cluster_options, recording: bool, quiet: bool, figures: bool) -> None:
    """Every replicate and map point on one executor; empty work folders go, maps released."""
    total = sum(len(m.todo) + 1 for m in mcs.values()) + sum(m.todo for m in maps.values())
    if not quiet:
        print(f"fogbench suite: {len(mcs)} scenario(s), "
              f"{total} replicate(s) in all, on {engine_label(jobs, scheduler, cluster)}",
              file=sys.stderr)
    need_pool = any(m.todo for m in mcs.values()) or any(m.todo for m in maps.values())
    engine = make_executor(jobs=jobs, scheduler=scheduler, cluster=cluster,
                           cluster_options=cluster_options) if need_pool else \
        contextlib.nullcontext(SerialExecutor())
    try:
        _run_all(mcs, engine, total, quiet, out, recording, results,
                 engine_label(jobs, scheduler, cluster) if need_pool else "this process", maps,
                 figures)
    except BaseException:
        kept = {n: len(m.done) for n, m in mcs.items() if m.done}
        if kept:
            _say_kept(kept)
        for m in mcs.values():
            m.work.remove_if_empty()
        for m in maps.values():
            m.release()
        raise
    for m in mcs.values():  # a failed scenario's empty work folder goes; its claim is released
        m.work.remove_if_empty()
    for m in maps.values():
        m.release()


def _violations(results: list, plans: dict) -> list[str]:
    """Every bound left, every replicate that failed as a whole, every scenario that failed."""
    violations = []
    for r in results:
        if r["ok"]:
            violations += check_bounds(r["name"], plans[r["name"]], r["metrics"])
            if r.get("replicate_failures"):
                f = r["replicate_failures"]
                violations.append(f"{r['name']}: {len(f)} replicate(s) failed as a whole "
                                  f"(first: r{f[0]['replicate']}: {f[0]['error']})")
        else:
            violations.append(f"{r['name']}: scenario failed: {r['error']}")
    return violations


def _summary_text(results: list, plans: dict, out, violations: list[str]) -> str:
    """The summary, and below it a link to the cross-scenario comparison (written here)."""
    summary = summary_markdown(results, plans, out, violations)
    compared = _write_compare(out, [r["name"] for r in results if r["ok"]])
    if compared:
        summary += ("\n## Every method across scenarios\n\n"
                    f"[{compared.name}]({compared.name}): every method (plug-ins included) of "
                    "every scenario on its headline metric, improvement over raw with its "
                    "paired interval over replicates, the oracle beside it, rank with its "
                    "probability, failures, in-sample flagged (`fogbench compare`).\n")
    return summary


def _suite_body(plans, chosen, first_file, results, out, readme, check, jobs, recording,
                quiet, replicates, method_seeds, scheduler, cluster, cluster_options,
                resume, no_map, map_replicates, figures=True) -> int:
    """The suite once its outputs are checked and its folder claimed: run, summarise, check."""
    t0 = time.monotonic()
    mcs, maps = _open_scenarios(chosen, first_file, out, results, replicates, method_seeds,
                                resume, no_map, map_replicates)
    _run_scenarios(mcs, maps, out, results, jobs, scheduler, cluster, cluster_options,
                   recording, quiet, figures)
    violations = _violations(results, plans)
    _write_summary(readme, _summary_text(results, plans, out, violations))
    print(f"fogbench suite: {sum(r['ok'] for r in results)}/{len(results)} scenario(s) ran in "
          f"{time.monotonic() - t0:.1f} s; summary in {readme}")
    for v in violations:
        print(f"fogbench: bound: {v}", file=sys.stderr)
    kept = {n: len(list(m.work.path.glob("r*.json"))) for n, m in mcs.items()
            if m.work.path.is_dir()}
    kept = {n: k for n, k in kept.items() if k}
    if kept:  # a scenario that failed after its replicates were stored: the last line says so
        _say_kept(kept)
    if check and violations:
        return 1
    return 0 if all(r["ok"] and not r.get("replicate_failures") for r in results) else 1


def _run_all(mcs: dict, engine, total: int, quiet: bool, out, recording: bool,
             results: list, label: str, maps: dict | None = None,
             figures: bool = True) -> None:
    """Every scenario's replicates on one executor: the tables first, all replicates submitted
    (each stored as it completes), then scenario by scenario its replicate 0 in full here, the
    wait for its others, and its run directory."""
    maps = maps or {}
    with engine as ex, Progress(total, "suite", quiet=quiet) as bar:
        for name, m in mcs.items():
            try:
                cache: dict = {}
                say = None if quiet else (
                    lambda msg, _n=name: print(f"[{_n}] {msg}", file=sys.stderr, flush=True))
                m.simulate_truths(say, cache=cache)
                m.submit(ex, on_done=lambda ok: bar.advance(failed=not ok))
                if name in maps:
                    maps[name].simulate_truths(say, cache=cache)
                    maps[name].submit(ex, on_done=lambda ok: bar.advance(failed=not ok))
            except Exception:  # reported when its replicate 0 runs (and fails the same way)
                continue
        for name, m in mcs.items():
            t1 = time.monotonic()
            say = (lambda msg, _n=name: None) if quiet else (
                lambda msg, _n=name: print(f"[{_n}] {msg}", file=sys.stderr, flush=True))
            try:
                m.run_first(say)
                bar.advance()
                m.wait()
                if m.failures and len(m.failures) == len(m.todo) and m.todo:
                    raise MonteCarloError(f"every replicate but 0 failed (first: "
                                          f"{m.failures[0]['error']})")
                doc = m.finish(label)
                map_doc = None
                if name in maps:
                    maps[name].wait()
                    map_doc = maps[name].finish(doc, label)
                write_run_dir(m.res0, Path(out) / name, recording=recording,
                              montecarlo=doc if m.R > 1 else None, work=m.work,
                              map_doc=map_doc, map_run=maps.get(name), figures=figures)
                metrics = {**m.res0.metrics, **({"montecarlo": doc} if m.R > 1 else {}),
                           **({"map": map_doc} if map_doc else {})}
                results.append({"path": m.path, "name": name, "ok": True,
                                "metrics": metrics, "wall_s": time.monotonic() - t1,
                                "replicate_failures": m.failures})
            except Exception as exc:  # a broken scenario is reported; the suite goes on
                results.append({"path": m.path, "name": name, "ok": False,
                                "wall_s": time.monotonic() - t1,
                                "error": f"{type(exc).__name__}: {exc}",
                                "traceback": traceback.format_exc()})
            m.res0 = None  # its arrays are written; free them before the next scenario
            _report_done(results[-1], quiet)


def _report_done(r: dict, quiet: bool):
    if r["ok"]:
        print(f"  done {r['name']} ({r['wall_s']:.1f} s)", file=sys.stderr, flush=True)
    else:
        print(f"  FAILED {r['name']}: {r['error']}", file=sys.stderr, flush=True)
