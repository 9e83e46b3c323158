"""The ``fogbench`` command line."""

from __future__ import annotations

# The signals' handlers before any other import: Ctrl-C or SIGTERM during the imports ends with
# the one line too (fogbench.signals imports only signal and sys).
from . import signals as _signals

if __name__ in ("__main__", "fogbench.cli"):
    _signals.install()

import argparse  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

# One BLAS thread per process: the bench parallelises over processes (replicates, scenarios);
# threaded BLAS on top of that made the network fits 3-6x slower on a 2-core machine.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

__all__ = ["main"]


def _cmd_simulate(args) -> int:
    from sim.rig import simulate_run

    from .io import versions, write_manifest, write_run
    from .outdir import as_final, check_out_dir, discard_part, new_part_dir, replace_dir
    from .progress import Progress
    from .scenario import RUNNER_SECTIONS, load_plan, load_scenario

    scenario = load_scenario(args.scenario, extra_sections=RUNNER_SECTIONS)
    if scenario.extra:
        load_plan(scenario)  # the whole file is validated, not only the part simulated
    if args.run:
        missing = sorted(set(args.run) - {r.name for r in scenario.runs})
        if missing:
            raise ValueError(f"--run: {args.scenario}: no run named {missing}; runs: "
                             f"{[r.name for r in scenario.runs]}")
    out = check_out_dir(args.out, "simulation")
    tmp = new_part_dir(out, "simulation", {"scenario": scenario.name,
                                           "scenario_file": str(scenario.path),
                                           "fogbench": versions().get("fogbench")})
    try:
        names = []
        for run in scenario.runs:
            if args.run and run.name not in args.run:
                continue
            with Progress(100, f"{scenario.name}/{run.name}", quiet=args.quiet,
                          unit="%") as bar:
                rd = simulate_run(scenario.rig, run, progress=bar.to_fraction)
            write_run(tmp, scenario, rd)
            names.append(run.name)
        write_manifest(tmp, scenario, names)
        replace_dir(tmp, out, "simulation")
    except OSError as exc:
        discard_part(tmp)
        raise as_final(exc, tmp, out) from None
    except BaseException:
        discard_part(tmp)
        raise
    print(f"wrote {len(names)} run(s) of {scenario.name} to {out}")
    return 0


def _engine_options(args) -> dict:
    opts = None
    if getattr(args, "cluster_config", None):
        opts = _cluster_options(args.cluster_config)
    return dict(jobs=args.jobs, scheduler=args.scheduler, cluster=args.cluster,
                cluster_options=opts)


def _engine(args):
    """The executor the flags ask for (``fogbench.executor``)."""
    from .executor import make_executor

    return make_executor(**_engine_options(args))


def _engine_label(args) -> str:
    from .executor import engine_label

    return engine_label(args.jobs, args.scheduler, args.cluster)


def _cluster_options(path: str) -> dict:
    """The ``[cluster]`` table of a TOML config file (queue, cores, memory, walltime...)."""
    import tomllib

    from .scenario import decode_text

    p = Path(path)
    try:
        text = decode_text(p.read_bytes(), str(p))
        doc = tomllib.loads(text)
    except OSError as exc:
        raise ValueError(f"--cluster-config {path}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"--cluster-config {path}: not valid TOML ({exc})") from None
    if set(doc) != {"cluster"} or not isinstance(doc["cluster"], dict):
        raise ValueError(f"--cluster-config {path}: expected one table [cluster] (queue, cores, "
                         f"memory, walltime, ...), got {sorted(doc)}")
    return doc["cluster"]


def _cmd_run(args) -> int:
    import contextlib

    from .executor import SerialExecutor
    from .montecarlo import ScenarioMC
    from .outdir import check_out_dir
    from .progress import Progress
    from .report import write_run_dir
    from .scenario import RUNNER_SECTIONS, load_plan, load_scenario

    from .scenario import load_map_file, map_file_scenario

    map_file = None
    target = map_file_scenario(args.scenario)   # a map file: its scenario, with its [map]
    if target is not None:
        map_file, args.scenario = args.scenario, str(target)
    sc = load_scenario(args.scenario, extra_sections=RUNNER_SECTIONS)  # refuse bad input first
    plan = load_plan(sc)
    if args.method:
        unknown = sorted(set(args.method) - {m.label for m in plan.methods})
        if unknown:
            raise ValueError(f"--method: {args.scenario}: no method labelled {unknown}; "
                             f"methods: {[m.label for m in plan.methods]}")
    map_spec = None
    if map_file is not None:
        if args.no_map:
            raise ValueError(f"--no-map: {map_file} is a claim map; run its scenario "
                             f"{args.scenario} for the run without one")
        map_spec = load_map_file(map_file, sc, plan)
    name = sc.name
    default_out = (Path("reports") / "maps" / Path(map_file).stem if map_file is not None
                   else Path("reports") / name)
    out = check_out_dir(args.out if args.out is not None else default_out, "run")
    from .executor import check_engine

    check_engine(**_engine_options(args))  # whatever the replicate count: a bad flag is an error
    say = (lambda msg: None) if args.quiet else (
        lambda msg: print(f"[{name}] {msg}", file=sys.stderr, flush=True))
    mc = ScenarioMC(args.scenario, out, replicates=args.replicates,
                    method_seeds=args.method_seeds, methods=args.method, resume=args.resume)
    if map_spec is not None:
        from dataclasses import replace

        mc.plan = replace(mc.plan, map=map_spec)
    mapper = None
    if mc.plan.map is not None and not args.no_map:
        from .maps import MapRun

        try:
            mapper = MapRun(args.scenario, out, mc, replicates=args.map_replicates,
                            method_seeds=args.method_seeds, methods=args.method,
                            resume=args.resume)
        except BaseException:
            mc.work.remove_if_empty()
            raise
    if mc.dropped:
        print(f"fogbench: warning: --resume: {mc.work.path} holds {len(mc.dropped)} "
              f"replicate(s) beyond the {mc.R} asked for (r{mc.dropped[0]}..); the first "
              f"{mc.R} are used, the others are not kept", file=sys.stderr)
    pool_needed = mc.todo or (mapper is not None and mapper.todo)
    engine = _engine(args) if pool_needed else contextlib.nullcontext(SerialExecutor())
    total = mc.R - len(mc.resumed) + (mapper.todo if mapper is not None else 0)
    try:
        with engine as ex, Progress(total, f"{name}: replicates",
                                    quiet=args.quiet or total == 1) as bar:
            cache: dict = {}
            mc.simulate_truths(say, cache=cache)
            if mapper is not None:
                mapper.simulate_truths(say, cache=cache)
            advance = (lambda ok: bar.advance(failed=not ok))
            if isinstance(ex, SerialExecutor):  # replicate 0 first: figures early, bar moving
                mc.run_first(say)
                bar.advance()
                mc.submit(ex, on_done=advance)
                if mapper is not None:
                    mapper.submit(ex, on_done=advance)
            else:  # workers start on 1.. while this process computes 0 in full
                mc.submit(ex, on_done=advance)
                if mapper is not None:
                    mapper.submit(ex, on_done=advance)
                mc.run_first(say)
                bar.advance()
            mc.wait()
            if mapper is not None:
                mapper.wait()
        label = _engine_label(args) if pool_needed else "this process"
        doc = mc.finish(label)
        map_doc = mapper.finish(doc, label) if mapper is not None else None
        write_run_dir(mc.res0, out, recording=not args.no_recording,
                      montecarlo=doc if mc.R > 1 else None, work=mc.work, map_doc=map_doc,
                      map_run=mapper, figures=not args.no_figures)
    except BaseException as exc:
        if mapper is not None:
            mapper.release()
        mc.work.remove_if_empty()
        if mc.work.path.is_dir() and mc.done:
            kept = (f"{len(mc.done)} replicate(s) of {name} are kept in {mc.work.path}; run "
                    "again with --resume to go on")
            if isinstance(exc, Exception):
                exc.add_note(kept)  # printed after the error line: the last line says it
            else:
                print(f"fogbench: {kept}", file=sys.stderr)
        raise
    if mc.failures:
        print(f"fogbench: {len(mc.failures)} of {mc.R} replicates of {name} failed as a whole "
              f"(first: r{mc.failures[0]['replicate']}: {mc.failures[0]['error']}); the report "
              "aggregates the others", file=sys.stderr)
    failed = _failed(mc.res0.metrics)
    print(f"{name}: wrote {out}/report.md, metrics.json"
          + ("" if args.no_recording else ", recording.rrd")
          + (f" ({mc.R} replicates)" if mc.R > 1 else "")
          + (f"; FAILED methods: {', '.join(failed)}" if failed else ""))
    return 1 if mc.failures else 0


def _cmd_check(args) -> int:
    from .scenario import (RUNNER_SECTIONS, ScenarioError, claim_name, is_device_file,
                           load_device_file, load_map_file, load_plan, load_scenario,
                           map_file_scenario)

    bad = 0
    paths = []
    for path in args.scenario:  # a folder: every scenario file in it (as fogbench suite reads)
        if Path(path).is_dir():
            found = sorted(Path(path).glob("*.toml"))   # scenarios/devices/ too, by name
            if not found:
                print(f"fogbench: error: {path}: no scenario file (*.toml) in this folder",
                      file=sys.stderr)
                bad += 1
            paths += [str(f) for f in found]
        else:
            paths.append(path)
    first_file: dict = {}
    for path in paths:  # every file is checked and reported, not only the first bad one
        try:
            target = map_file_scenario(path)
            if target is not None:   # a map file: its scenario and its [map], every point
                sc = load_scenario(target, extra_sections=RUNNER_SECTIONS)
                spec = load_map_file(path, sc, load_plan(sc))
                print(f"{path}: ok: claim map of {target} ({sc.name!r}), "
                      f"{len(spec.points)} point(s) over "
                      f"{', '.join(a.name for a in spec.axes)}")
                continue
            if is_device_file(path):   # a device file ([fog] device = "..." names it)
                vals = load_device_file(path)
                print(f"{path}: ok: device file, {len(set(vals) - {'source'})} key(s)")
                continue
            sc = load_scenario(path, extra_sections=RUNNER_SECTIONS)
            plan = load_plan(sc)
            claim_name(first_file, sc, path)  # as fogbench suite refuses two with one name
        except ScenarioError as exc:
            print(f"fogbench: error: {exc}", file=sys.stderr)
            bad += 1
            continue
        n = sum(r.duration for r in sc.runs) * sc.fs
        print(f"{path}: ok: scenario {sc.name!r}, {len(sc.runs)} run(s), {n:.0f} samples, "
              f"{len(plan.protocols)} protocol(s), {len(plan.methods)} method(s), "
              f"{plan.replicates} replicate(s)"
              + (f"; a claim map of {len(plan.map.points)} point(s)" if plan.map else ""))
    return 2 if bad else 0


def _failed(doc) -> list[str]:
    out = set()
    for prot in doc["protocols"].values():
        for by_method in prot["runs"].values():
            for lab, m in by_method.items():
                if isinstance(m, dict) and m.get("status") == "failed":
                    out.add(lab)
    return sorted(out)


def _cmd_suite(args) -> int:
    from .suite import run_suite

    opts = _cluster_options(args.cluster_config) if args.cluster_config else None
    return run_suite(scenario_dir=Path(args.scenarios), out=Path(args.out), check=args.check,
                     jobs=args.jobs, only_ci=args.ci, recording=not args.no_recording,
                     quiet=args.quiet, names=args.scenario, replicates=args.replicates,
                     method_seeds=args.method_seeds, scheduler=args.scheduler,
                     cluster=args.cluster, cluster_options=opts, resume=args.resume,
                     no_map=args.no_map, map_replicates=args.map_replicates,
                     figures=not args.no_figures)


def _cmd_view(args) -> int:
    from .recording import GRPC_PORT, WEB_BIND, WEB_PORT, view, view_web

    if not args.web:
        given = [f for f, v in (("--bind", args.bind), ("--web-port", args.web_port),
                                ("--grpc-port", args.grpc_port)) if v is not None]
        if given:
            raise ValueError(f"{given[0]}: only with --web")
        return view(Path(args.dir))
    return view_web(Path(args.dir), bind=args.bind or WEB_BIND,
                    web_port=args.web_port or WEB_PORT, grpc_port=args.grpc_port or GRPC_PORT)


def _cmd_bench(args) -> int:
    from .bench import main as bench_main

    return bench_main(seconds=args.seconds, repeats=args.repeats, noise_seeds=args.noise_seeds)




def _number(kind, lo, lo_open=False, hi=None):
    """An argparse type: a finite number of ``kind`` in range; the message names the flag."""
    import math

    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {'an integer' if kind is int else 'a number'}, got {text!r}") from None
        if kind is float and not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
        if (v <= lo) if lo_open else (v < lo):
            raise argparse.ArgumentTypeError(f"expected a value {'>' if lo_open else '>='} "
                                             f"{lo:g}, got {text!r}")
        if hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"expected a value <= {hi:g}, got {text!r}")
        return v

    return parse


def _mc_flags(p) -> None:
    """Flags of the Monte Carlo and where it runs (``run`` and ``suite``)."""
    p.add_argument("--replicates", type=_number(int, 1, hi=10_000),
                   help="replicates R (overrides the file's [montecarlo] replicates)")
    p.add_argument("--method-seeds", type=_number(int, 1, hi=1000),
                   help="random starts per fit of a random method (overrides method_seeds)")
    p.add_argument("--jobs", type=_number(int, 1, hi=256), default=None,
                   help="local worker processes (default: the machine's cores)")
    p.add_argument("--scheduler", help="a running Dask scheduler, tcp://HOST:PORT "
                   "(pip install 'fogbench[distributed]'; workers need fogbench installed)")
    p.add_argument("--cluster", choices=("slurm", "pbs"),
                   help="start Dask workers as batch jobs (dask-jobqueue); see --cluster-config")
    p.add_argument("--cluster-config",
                   help="TOML file with a [cluster] table: queue, cores, memory, walltime, ...")
    p.add_argument("--fit-timeout-s", type=_number(float, 0.001, hi=86_400.0),
                   help="stop a method's fit (or its compensation of a piece) after this many "
                   "seconds and report it as failed (overrides [compensation] fit_timeout_s; "
                   "default 600)")
    p.add_argument("--with-method", action="append", metavar="NAME",
                   help="add this method (a built-in, an entry-point plug-in or module:Class; "
                   "its defaults) to every scenario's [[methods]] (repeatable); it is written "
                   "into the run folder's scenario.toml")
    p.add_argument("--reference", choices=("truth", "lab"), default=None,
                   help="lab: fit every protocol that does not name its reference on the lab's "
                   "references (the table's commands, the nominal Earth rate), each beside its "
                   "ideal-lab twin <name>.ideal fitted on the truth; written into the run "
                   "folder's scenario.toml (default: each file's own, truth when unsaid)")


def _cmd_check_method(args) -> int:
    import fogcomp

    try:
        fogcomp.get_method(args.method)
    except KeyError as exc:          # unknown name, or a plug-in that does not import
        raise ValueError(f"check-method: {exc.args[0]}") from None
    report = fogcomp.check_method(args.method, probe_samples=args.probe_samples)
    print(report)
    return 0 if report.ok else 1


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fogbench", description="FOG error-compensation testbench")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("simulate", help="simulate a scenario's runs and write their data")
    s.add_argument("scenario", help="scenario file (TOML)")
    s.add_argument("--out", required=True,
                   help="output directory (new, empty, or one that fogbench simulate wrote)")
    s.add_argument("--run", action="append", help="only this run (repeatable)")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.set_defaults(func=_cmd_simulate)

    r = sub.add_parser("run", help="simulate a scenario, fit and score its methods, write a report")
    r.add_argument("scenario", help="scenario file (TOML)")
    r.add_argument("--out", help="run directory (default reports/<scenario name>); new, empty, "
                   "or one that fogbench run wrote: nothing else is ever replaced")
    r.add_argument("--method", action="append", help="only this method label (repeatable)")
    r.add_argument("--no-recording", action="store_true", help="do not write recording.rrd")
    r.add_argument("--no-figures", action="store_true",
                   help="draw no figures: the numbers, report and bounds only (a quick check)")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    _mc_flags(r)
    r.add_argument("--resume", action="store_true",
                   help="keep the replicates a killed run left (same scenario file and fogbench "
                        "version) and compute only the rest")
    r.add_argument("--no-map", action="store_true",
                   help="leave out the scenario's claim map ([map]: the claims at other values "
                        "of the keys the papers leave open)")
    r.add_argument("--map-replicates", type=_number(int, 1, hi=10_000),
                   help="replicates per point of the claim map (overrides [map] replicates)")
    r.set_defaults(func=_cmd_run)

    c = sub.add_parser("check", help="validate scenario files (nothing is simulated or written)")
    c.add_argument("scenario", nargs="+",
                   help="scenario file(s) (TOML), or a folder: every *.toml in it")
    c.set_defaults(func=_cmd_check)

    u = sub.add_parser("suite", help="run every scenario and write reports/README.md")
    u.add_argument("--scenarios", default="scenarios", help="scenario folder (default scenarios)")
    u.add_argument("--out", default="reports", help="reports folder (default reports)")
    u.add_argument("--check", action="store_true",
                   help="exit 1 when a metric leaves the bounds its scenario file declares")
    u.add_argument("--ci", action="store_true",
                   help="only the scenarios marked ci = true (the CI subset)")
    u.add_argument("--scenario", action="append", help="only this scenario name (repeatable)")
    u.add_argument("--no-recording", action="store_true", help="do not write recordings")
    u.add_argument("--no-figures", action="store_true",
                   help="draw no figures in the run folders: the numbers, reports and bounds "
                        "only (a quick check; compare.png is still drawn)")
    u.add_argument("--quiet", action="store_true", help="no progress on stderr")
    _mc_flags(u)
    u.add_argument("--resume", action="store_true",
                   help="keep the replicates a killed suite left and compute only the rest")
    u.add_argument("--no-map", action="store_true",
                   help="leave out the scenarios' claim maps ([map])")
    u.add_argument("--map-replicates", type=_number(int, 1, hi=10_000),
                   help="replicates per point of every claim map (overrides [map] replicates)")
    u.set_defaults(func=_cmd_suite)

    v = sub.add_parser("view", help="open a run directory's recording in the Rerun viewer")
    v.add_argument("dir", help="run directory (holding recording.rrd)")
    v.add_argument("--web", action="store_true", help="serve it to a browser (Rerun's web "
                   "viewer) instead of opening a native window; listens on 127.0.0.1 only "
                   "unless --bind says otherwise")
    v.add_argument("--bind", default=None, help="--web: the address to listen on, or a host "
                   "name (resolved to its address) (default 127.0.0.1, this machine; only "
                   "0.0.0.0 or :: serves every network interface)")
    v.add_argument("--web-port", type=_number(int, 1, hi=65535), default=None,
                   help="--web: the web viewer's HTTP port (default 9090)")
    v.add_argument("--grpc-port", type=_number(int, 1, hi=65535), default=None,
                   help="--web: the viewer's gRPC port (default 9876)")
    v.set_defaults(func=_cmd_view)

    b = sub.add_parser("bench", help="print throughput of the rig and the error model")
    b.add_argument("--seconds", type=_number(float, 1.0, hi=86400.0), default=600.0,
                   help="simulated seconds per measurement, 1 to 86400 (default 600)")
    b.add_argument("--repeats", type=_number(int, 1, hi=1000), default=5,
                   help="repeats; medians are quoted (default 5)")
    b.add_argument("--noise-seeds", type=_number(int, 1, hi=1000), default=20,
                   help="records per case of the noise identifier's table (default 20)")
    b.set_defaults(func=_cmd_bench)
    k = sub.add_parser("check-method", help="run fogcomp.check_method on a method: the "
                       "contract every compensator keeps, rule by rule")
    k.add_argument("method", help="a method name, an entry-point plug-in or module:Class")
    k.add_argument("--probe-samples", type=_number(int, 100, hi=10_000_000), default=100_000,
                   help="length of the probe record (default 100000)")
    k.set_defaults(func=_cmd_check_method)
    from .reallog import add_commands

    add_commands(sub)  # allan, calibrate, compensate: a user's own recorded logs
    from .device import add_commands as add_device_commands

    add_device_commands(sub)  # device show, fit, check: a device file from a user's logs
    from .compare import add_command as add_compare

    add_compare(sub)  # compare: every method across scenarios
    return p


_INTERRUPTED = "fogbench: interrupted; files already complete are kept, none is half-written"
_TERMINATED = ("fogbench: terminated (SIGTERM); files already complete are kept, none is "
               "half-written")


def _error_line(exc: BaseException, text: str) -> None:
    """The one error line, then the notes an exception carries (e.g. where resumable work was
    kept), so that the last line says what is left."""
    print(f"fogbench: error: {text}", file=sys.stderr)
    for note in getattr(exc, "__notes__", ()):
        print(f"fogbench: {note}", file=sys.stderr)


def _os_error_text(exc: OSError) -> str:
    where = exc.filename if getattr(exc, "filename", None) else None
    text = exc.strerror or str(exc) or type(exc).__name__
    return f"{text} ({where})" if where else text


def _method_environment(args) -> dict:
    """--fit-timeout-s, --with-method and --reference as the environment the scenario loader
    reads (so that worker processes see them too; each flag given wins over the variable
    inherited); a --with-method name that is unknown is refused here."""
    import fogcomp

    from .scenario import FIT_TIMEOUT_ENV, REFERENCE_ENV, WITH_METHODS_ENV

    env = {}
    if getattr(args, "fit_timeout_s", None) is not None:
        env[FIT_TIMEOUT_ENV] = repr(args.fit_timeout_s)
    if args.command in ("run", "suite") and args.reference is not None:
        # "truth" too: the flag given wins over a FOGBENCH_REFERENCE inherited from the shell
        # (device fit's and calibrate's --reference name a log's column: not this)
        env[REFERENCE_ENV] = args.reference
    names = getattr(args, "with_method", None) or []
    for n in names:
        try:
            fogcomp.get_method(n)
        except fogcomp.PluginError:
            pass                 # installed but broken: the run reports it as failed
        except KeyError as exc:
            raise ValueError(f"--with-method: {exc.args[0]}") from None
    if names:
        env[WITH_METHODS_ENV] = ",".join(dict.fromkeys(names))
    return env


def main(argv=None) -> int:
    from .signals import Terminated

    _signals.install()
    import signal as _signal

    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        from .scenario import method_environment, method_environment_set

        # read by load_scenario/load_plan here (and sent with each replicate to its worker)
        with method_environment_set({**method_environment(), **_method_environment(args)}):
            code = args.func(args)
    except ValueError as exc:  # ScenarioError, LogError, EngineError, ...: bad input
        _error_line(exc, str(exc))
        code = 2
    except FileNotFoundError as exc:
        _error_line(exc, _os_error_text(exc))
        code = 2
    except RecursionError:  # a JSON or TOML input nested thousands of levels deep
        print("fogbench: error: an input file is nested too deeply to be read (thousands of "
              "levels of brackets); it is not a file fogbench writes or reads", file=sys.stderr)
        code = 2
    except BrokenPipeError:  # `fogbench allan ... | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:  # a full disk, a permission: one line naming the file, not a traceback
        _error_line(exc, _os_error_text(exc))
        code = 1
    except KeyboardInterrupt:
        code = None
    except Terminated:
        code = None
    except Exception:
        # a signal that surfaced as another exception (mujoco's import turns an interrupt
        # during its initialisation into ImportError): the signal's ending, not a traceback
        if not _signals.received():
            raise
        code = None
    # The work is over: a signal from now on stays pending (and is answered here, not by a
    # silent death while the interpreter shuts down); one that arrived on the way, even one
    # whose exception was swallowed in a callback, still ends the command.
    old_mask = _signals.block()
    sig = _signals.received() or _signals.pending()
    _signals.consume()
    if argv is not None:  # called in a process that goes on (tests, scripts): as it was
        _signals.unblock(old_mask)
    if sig is not None or code is None:
        term = sig == _signal.SIGTERM
        print(_TERMINATED if term else _INTERRUPTED, file=sys.stderr)
        return 143 if term else 130
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
