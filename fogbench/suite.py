"""``fogbench suite``: every scenario, in parallel processes, and the summary reports/README.md."""

from __future__ import annotations

import math
import os
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from .io import atomic_write_text
from .outdir import OutDirError, Terminated, check_out_dir
from .fmt import fmt
from .scenario import RUNNER_SECTIONS, ScenarioError, load_plan, load_scenario

__all__ = ["run_suite", "check_bounds", "summary_markdown"]

SUMMARY_METRICS = ("std_dps", "rmse_dph", "drift_rms_dph", "bias_stability_100s_dph",
                   "angle_error_final_deg", "coef_rms_error_dph", "improvement_rmse_pct",
                   "fit_time_s")


def _one(path: str, out: str, recording: bool, quiet: bool) -> dict:
    """Worker: run one scenario and write its directory. Returns a small status record."""
    from .report import write_run_dir
    from .runner import run_scenario

    name = Path(path).stem
    say = (lambda msg: None) if quiet else (
        lambda msg: print(f"[{name}] {msg}", file=sys.stderr, flush=True))
    t0 = time.monotonic()
    try:
        res = run_scenario(path, progress=say)
        write_run_dir(res, Path(out) / res.scenario.name, recording=recording)
        return {"path": path, "name": res.scenario.name, "ok": True, "metrics": res.metrics,
                "wall_s": time.monotonic() - t0}
    except Exception as exc:  # a broken scenario is reported; the suite goes on
        return {"path": path, "name": name, "ok": False, "wall_s": time.monotonic() - t0,
                "error": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc()}
    except Terminated:
        # the main process is ending the suite: temporary folders are already removed by the
        # unwinding; leave now rather than wait for the pool's next task
        if _IN_WORKER:
            os._exit(143)
        raise


def _values(doc: dict, protocol: str, method: str, metric: str, run: str | None):
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
    """Messages for every metric outside its declared bounds (empty when all hold)."""
    bad = []
    for b in plan.bounds:
        for run, v, why in _values(doc, b.protocol, b.method, b.metric, b.run):
            where = f"{name}: protocol {b.protocol}, run {run}, method {b.method}, {b.metric}"
            if why:
                bad.append(f"{where}: {why}")
            elif (b.lo is not None and v < b.lo) or (b.hi is not None and v > b.hi) or \
                    not math.isfinite(v):
                bad.append(f"{where} = {fmt(v, b.metric)} outside [{fmt(b.lo)}, {fmt(b.hi)}]")
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


def _claims(plan, doc) -> list[str]:
    """Statements comparing the paper's figures with ours, with the numbers."""
    out = []
    groups: dict = {}
    for pv in plan.paper:
        groups.setdefault((pv.metric, pv.run, pv.segment), []).append(pv)
    for prot in plan.protocols:
        pd = doc["protocols"][prot.name]
        tag = "in-sample (paper's protocol)" if prot.in_sample else "held out"
        for (metric, run, segment), pvs in groups.items():
            if segment is not None:
                continue
            runs = [run] if run else list(pd["runs"])
            for r in runs:
                if r not in pd["runs"]:
                    continue
                ours, theirs = {}, {}
                for pv in pvs:
                    m = pd["runs"][r].get(pv.method, {})
                    v = m.get(metric)
                    if isinstance(v, (int, float)):
                        ours[pv.method] = v
                        theirs[pv.method] = pv.value
                if len(ours) < 1:
                    continue
                pairs = ", ".join(f"{k} {fmt(theirs[k], metric)} vs {fmt(ours[k], metric)}"
                                  for k in theirs)
                line = f"`{prot.name}` ({tag}), {r}, {metric} (reference vs ours): {pairs}."
                if len(ours) >= 2:
                    p_order = sorted(theirs, key=theirs.get)
                    o_order = sorted(ours, key=ours.get)
                    verdict = "same ranking" if p_order == o_order else "ranking differs"
                    line += (f" Paper ranks {' < '.join(p_order)}; ours {' < '.join(o_order)}: "
                             f"**{verdict}**.")
                out.append(line)
    return out


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
                       f"{c.than} on {c.metric}: {mean:+.1f} % (claim {rng}): "
                       f"**{'agrees' if ok else 'does not agree'}**. {per}.")
    return out


def summary_markdown(results: list[dict], plans: dict, out: Path, violations: list[str]) -> str:
    import datetime

    from .io import versions

    v = versions()
    L = [SUMMARY_TITLE, "",
         f"Written by `fogbench suite` (`make run`) on {datetime.date.today().isoformat()} with "
         f"fogbench {v['fogbench']}, mujoco {v['mujoco']}, numpy {v['numpy']}; the scenario "
         "reports it links (`<scenario>/report.md`, figures, `metrics.json`, `recording.rrd`) are "
         "written beside it by the same command and are not kept in git.", "",
         "Each scenario's methods were fitted on some runs and scored on others against the "
         "simulation's truth (see each report for the protocol). Rows `raw` (the FOG output) and "
         "`oracle` (raw minus the true deterministic error terms) bracket what compensation can "
         "do. Values are means over the scored runs of a protocol; metric units are in the names "
         "(`_dps` deg/s, `_dph` deg/h, `_deg` deg, `_pct` percent improvement over raw, `_s` "
         "seconds). In-sample protocols (a paper's own, scored on fitted data) are flagged.", ""]
    for r in sorted(results, key=lambda r: r["name"]):
        name = r["name"]
        if not r["ok"]:
            L += [f"## {name}: FAILED", "", "```", r["error"], "```", ""]
            continue
        doc, plan = r["metrics"], plans[name]
        L += [f"## [{name}]({name}/report.md)", "", doc["description"], "",
              f"Wall time {r['wall_s']:.1f} s.", ""]
        for pname, pd in doc["protocols"].items():
            labels = []
            for by_method in pd["runs"].values():
                for lab in by_method:
                    if lab not in labels:
                        labels.append(lab)
            metrics = [m for m in SUMMARY_METRICS if any(
                isinstance(_mean_over_runs(pd, lab, m), float) for lab in labels)]
            flag = " (IN-SAMPLE, the paper's protocol)" if pd["in_sample"] else " (held out)"
            L += [f"**Protocol `{pname}`{flag}**, scored on {', '.join(pd['runs'])}:", ""]
            L += ["| method | " + " | ".join(metrics) + " |", "|---|" + "---|" * len(metrics)]
            for lab in labels:
                cells = [fmt(_mean_over_runs(pd, lab, m), m) for m in metrics]
                L.append(f"| {lab} | " + " | ".join(cells) + " |")
            L.append("")
        verdicts = claim_verdicts(plan, doc)
        if verdicts:
            L += ["Claims:", ""] + [f"- {v}" for v in verdicts] + [""]
        claims = _claims(plan, doc)
        if claims:
            srcs = sorted({pv.source.split(",")[0] for pv in plan.paper})
            L += [f"Against the reference figures ({'; '.join(srcs)}):", ""] + \
                 [f"- {c}" for c in claims] + [""]
        for note in plan.notes:
            L += [f"> {note}", ""]
    L += ["## Bounds check", ""]
    L += (["Every declared bound holds."] if not violations else
          ["Outside bounds:", ""] + [f"- {v}" for v in violations])
    L.append("")
    return "\n".join(L)


SUMMARY_TITLE = "# fogbench suite: summary"
_IN_WORKER = False


def _worker_init() -> None:
    """In a worker: Ctrl-C is the main process's to handle (no tracebacks from every worker);
    SIGTERM (sent by the main process when interrupted) unwinds so temporary folders go."""
    import signal

    from .outdir import install_sigterm

    global _IN_WORKER
    _IN_WORKER = True
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    install_sigterm()


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the workers now (SIGTERM, then SIGKILL)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # no public handle
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=10)
        if proc.is_alive():
            proc.kill()
            proc.join(timeout=5)


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


def run_suite(scenario_dir: Path, out: Path, check: bool = False, jobs: int = 2,
              only_ci: bool = False, recording: bool = True, quiet: bool = False,
              names: list[str] | None = None) -> int:
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
                print(f"fogbench: warning: skipped: {exc}", file=sys.stderr)
                continue
            results.append({"path": str(p), "name": p.stem, "ok": False, "wall_s": 0.0,
                            "error": str(exc)})
            print(f"fogbench: error: {exc}", file=sys.stderr)
            continue
        if sc.name in first_file:
            raise ScenarioError(f"{p}: [scenario] key 'name': {sc.name!r} is also the name of "
                                f"{first_file[sc.name]}; scenario names must be unique in a "
                                "suite (each names its report folder)")
        first_file[sc.name] = p
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
    t0 = time.monotonic()
    if not quiet:
        print(f"fogbench suite: {len(chosen)} scenario(s), {jobs} process(es)", file=sys.stderr)
    if jobs <= 1 or len(chosen) <= 1:
        for p in chosen:
            results.append(_one(p, str(out), recording, quiet))
            _report_done(results[-1], quiet)
    else:
        pool = ProcessPoolExecutor(max_workers=jobs, initializer=_worker_init)
        try:
            futs = [pool.submit(_one, p, str(out), recording, quiet) for p in chosen]
            for f in as_completed(futs):
                results.append(f.result())
                _report_done(results[-1], quiet)
        except BaseException:
            _stop_pool(pool)
            raise
        pool.shutdown(wait=True)
    violations = []
    for r in results:
        if r["ok"]:
            violations += check_bounds(r["name"], plans[r["name"]], r["metrics"])
        else:
            violations.append(f"{r['name']}: scenario failed: {r['error']}")
    summary = summary_markdown(results, plans, out, violations)
    atomic_write_text(readme, summary)
    print(f"fogbench suite: {sum(r['ok'] for r in results)}/{len(results)} scenario(s) ran in "
          f"{time.monotonic() - t0:.1f} s; summary in {readme}")
    for v in violations:
        print(f"fogbench: bound: {v}", file=sys.stderr)
    if check and violations:
        return 1
    return 0 if all(r["ok"] for r in results) else 1


def _report_done(r: dict, quiet: bool):
    if r["ok"]:
        print(f"  done {r['name']} ({r['wall_s']:.1f} s)", file=sys.stderr, flush=True)
    else:
        print(f"  FAILED {r['name']}: {r['error']}", file=sys.stderr, flush=True)
