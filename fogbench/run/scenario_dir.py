"""``fogbench run``: one scenario into its run directory. Its replicates (and its claim map's
points) on an engine, replicate 0 in full in this process for the figures and the recording,
then ``metrics.json``, ``report.md`` with its figures and ``recording.rrd``.

Bad input is refused before any work: the scenario file (or map file) whole, the methods asked
for, the output folder (new, empty, or a run folder of ours), the engine's flags. An interrupted
run keeps the replicates it completed in its work folder for ``--resume``.
"""

from __future__ import annotations

import contextlib
import sys
from dataclasses import dataclass, replace
from pathlib import Path

from fogbench.run.engines import Engine, SerialExecutor

__all__ = ["RunOptions", "run_scenario_dir", "failed_methods"]


@dataclass(frozen=True)
class RunOptions:
    """How a scenario is run, as ``fogbench run`` and ``fogbench suite`` are told.

    ``replicates``, ``method_seeds`` and ``map_replicates`` override the file's (None: the
    file's own); ``methods`` keeps only these method labels (None: all); ``resume`` keeps the
    replicates a killed run left; ``no_map`` leaves out the claim map; ``recording`` and
    ``figures`` write ``recording.rrd`` and the PNG figures; ``quiet`` prints no progress."""

    replicates: int | None = None
    method_seeds: int | None = None
    methods: tuple[str, ...] | None = None
    resume: bool = False
    no_map: bool = False
    map_replicates: int | None = None
    recording: bool = True
    figures: bool = True
    quiet: bool = False


def failed_methods(doc: dict) -> list[str]:
    """The labels of the methods that failed somewhere in a run's ``metrics.json``."""
    out = set()
    for prot in doc["protocols"].values():
        for by_method in prot["runs"].values():
            for lab, m in by_method.items():
                if isinstance(m, dict) and m.get("status") == "failed":
                    out.add(lab)
    return sorted(out)


def _load(scenario: str, opts: RunOptions):
    """(scenario path, map file or None, scenario, plan, map spec or None): a map file is read
    as its scenario with its [map]; everything validated before any work."""
    from fogbench.scenario import load_plan, load_scenario
    from fogbench.scenario.load import RUNNER_SECTIONS
    from fogbench.scenario.maps import map_file_scenario
    from fogbench.scenario.plan import load_map_file

    map_file = None
    target = map_file_scenario(scenario)   # a map file: its scenario, with its [map]
    if target is not None:
        map_file, scenario = scenario, str(target)
    sc = load_scenario(scenario, extra_sections=RUNNER_SECTIONS)  # refuse bad input first
    plan = load_plan(sc)
    if opts.methods:
        unknown = sorted(set(opts.methods) - {m.label for m in plan.methods})
        if unknown:
            raise ValueError(f"--method: {scenario}: no method labelled {unknown}; "
                             f"methods: {[m.label for m in plan.methods]}")
    map_spec = None
    if map_file is not None:
        if opts.no_map:
            raise ValueError(f"--no-map: {map_file} is a claim map; run its scenario "
                             f"{scenario} for the run without one")
        map_spec = load_map_file(map_file, sc, plan)
    return scenario, map_file, sc, map_spec


def _prepare(scenario: str, out, map_spec, opts: RunOptions):
    """The scenario's Monte Carlo and its claim map's (None without one), their work folders
    claimed."""
    from fogbench.run.montecarlo import ScenarioMC

    mc = ScenarioMC(scenario, out, replicates=opts.replicates, method_seeds=opts.method_seeds,
                    methods=list(opts.methods) if opts.methods else None, resume=opts.resume)
    if map_spec is not None:
        mc.plan = replace(mc.plan, map=map_spec)
    mapper = None
    if mc.plan.map is not None and not opts.no_map:
        from fogbench.run.maps import MapRun

        try:
            mapper = MapRun(scenario, out, mc, replicates=opts.map_replicates,
                            method_seeds=opts.method_seeds,
                            methods=list(opts.methods) if opts.methods else None,
                            resume=opts.resume)
        except BaseException:
            mc.work.remove_if_empty()
            raise
    return mc, mapper


def _run_replicates(mc, mapper, engine: Engine, name: str, opts: RunOptions) -> str:
    """Every replicate and map point to do, on the engine (replicate 0 in this process);
    returns the engine's label for the report."""
    from fogbench.console import Progress

    say = (lambda msg: None) if opts.quiet else (
        lambda msg: print(f"[{name}] {msg}", file=sys.stderr, flush=True))
    pool_needed = mc.todo or (mapper is not None and mapper.todo)
    ctx = engine.executor() if pool_needed else contextlib.nullcontext(SerialExecutor())
    total = mc.R - len(mc.resumed) + (mapper.todo if mapper is not None else 0)
    with ctx as ex, Progress(total, f"{name}: replicates",
                             quiet=opts.quiet or total == 1) as bar:
        cache: dict = {}
        mc.simulate_truths(say, cache=cache)
        if mapper is not None:
            mapper.simulate_truths(say, cache=cache)

        def advance(ok):
            bar.advance(failed=not ok)

        def submit():
            mc.submit(ex, on_done=advance)
            if mapper is not None:
                mapper.submit(ex, on_done=advance)

        if isinstance(ex, SerialExecutor):  # replicate 0 first: figures early, bar moving
            mc.run_first(say)
            bar.advance()
            submit()
        else:  # workers start on 1.. while this process computes 0 in full
            submit()
            mc.run_first(say)
            bar.advance()
        mc.wait()
        if mapper is not None:
            mapper.wait()
    return engine.label if pool_needed else "this process"


def _kept(mc, mapper, name: str) -> str | None:
    """What a failed or interrupted run leaves for ``--resume``: every work folder (the
    scenario's, each claim-map point's) that holds replicates, named; None when none does."""
    works = [mc.work] + ([m.work for m in mapper.mcs.values()] if mapper is not None else [])
    held = [(w.path, len(list(w.path.glob("r*.json")))) for w in works if w.path.is_dir()]
    held = [(p, k) for p, k in held if k]
    if not held:
        return None
    where = "; ".join(f"{k} in {p}" for p, k in held)
    return (f"replicates of {name} are kept ({where}); run again with --resume to go on, or "
            "remove those folders")


def run_scenario_dir(scenario: str, out: str | Path | None = None,
                     opts: RunOptions = RunOptions(), engine: Engine = Engine()) -> int:
    """Run ``scenario`` (a scenario file or a map file) into ``out`` (default
    ``reports/<name>``, or ``reports/maps/<map file>``) and return the exit status: 0, or 1
    when replicates failed as a whole (the report aggregates the others)."""
    from fogbench.outputs.folders import check_out_dir
    from fogbench.report import write_run_dir

    scenario, map_file, sc, map_spec = _load(scenario, opts)
    name = sc.name
    default_out = (Path("reports") / "maps" / Path(map_file).stem if map_file is not None
                   else Path("reports") / name)
    out = check_out_dir(out if out is not None else default_out, "run")
    engine.check()  # whatever the replicate count: a bad flag is an error
    mc, mapper = _prepare(scenario, out, map_spec, opts)
    if mc.dropped:
        print(f"fogbench: warning: --resume: {mc.work.path} holds {len(mc.dropped)} "
              f"replicate(s) beyond the {mc.R} asked for (r{mc.dropped[0]}..); the first "
              f"{mc.R} are used, the others are not kept", file=sys.stderr)
    try:
        label = _run_replicates(mc, mapper, engine, name, opts)
        doc = mc.finish(label)
        map_doc = mapper.finish(doc, label) if mapper is not None else None
        write_run_dir(mc.res0, out, recording=opts.recording,
                      montecarlo=doc if mc.R > 1 else None, work=mc.work, map_doc=map_doc,
                      map_run=mapper, figures=opts.figures)
    except BaseException as exc:
        if mapper is not None:
            mapper.release()
        mc.work.remove_if_empty()
        kept = _kept(mc, mapper, name)
        if kept:
            if isinstance(exc, Exception):
                exc.add_note(kept)  # printed after the error line: the last line says it
            else:
                print(f"fogbench: {kept}", file=sys.stderr)
        raise
    if mc.failures:
        print(f"fogbench: {len(mc.failures)} of {mc.R} replicates of {name} failed as a whole "
              f"(first: r{mc.failures[0]['replicate']}: {mc.failures[0]['error']}); the report "
              "aggregates the others", file=sys.stderr)
    failed = failed_methods(mc.res0.metrics)
    print(f"{name}: wrote {out}/report.md, metrics.json"
          + ("" if not opts.recording else ", recording.rrd")
          + (f" ({mc.R} replicates)" if mc.R > 1 else "")
          + (f"; FAILED methods: {', '.join(failed)}" if failed else ""))
    return 1 if mc.failures else 0
