"""The ``fogbench`` command line."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

__all__ = ["main"]


class Progress:
    """A one-line progress indicator on stderr (plain lines when stderr is not a terminal)."""

    def __init__(self, label: str, quiet: bool = False):
        self.label, self.quiet = label, quiet
        self.tty = sys.stderr.isatty()
        self.t0 = time.monotonic()
        self.last = -1.0

    def __call__(self, fraction: float):
        if self.quiet:
            return
        pct = 100.0 * fraction
        if self.tty:
            sys.stderr.write(f"\r{self.label}: {pct:5.1f} %  ({time.monotonic() - self.t0:.1f} s)")
            if fraction >= 1.0:
                sys.stderr.write("\n")
            sys.stderr.flush()
        elif pct - self.last >= 25.0 or fraction >= 1.0:
            print(f"{self.label}: {pct:.0f} % ({time.monotonic() - self.t0:.1f} s)",
                  file=sys.stderr, flush=True)
            self.last = pct


def _cmd_simulate(args) -> int:
    from .io import write_manifest, write_run
    from .rig import simulate_run
    from .scenario import RUNNER_SECTIONS, load_scenario

    scenario = load_scenario(args.scenario, extra_sections=RUNNER_SECTIONS)
    out = Path(args.out)
    names = []
    for run in scenario.runs:
        if args.run and run.name not in args.run:
            continue
        rd = simulate_run(scenario, run, progress=Progress(f"{scenario.name}/{run.name}",
                                                           args.quiet))
        write_run(out, scenario, rd)
        names.append(run.name)
    if args.run:
        missing = sorted(set(args.run) - set(names))
        if missing:
            raise SystemExit(f"fogbench: {args.scenario}: no run named {missing}; runs: "
                             f"{[r.name for r in scenario.runs]}")
    write_manifest(out, scenario, names)
    print(f"wrote {len(names)} run(s) of {scenario.name} to {out}")
    return 0


def _cmd_run(args) -> int:
    from .report import write_run_dir
    from .runner import run_scenario

    name = Path(args.scenario).stem
    out = Path(args.out) if args.out else Path("reports") / name
    say = (lambda msg: None) if args.quiet else (
        lambda msg: print(f"[{name}] {msg}", file=sys.stderr, flush=True))
    res = run_scenario(args.scenario, progress=say, methods=args.method)
    write_run_dir(res, out, recording=not args.no_recording)
    failed = _failed(res.metrics)
    print(f"{name}: wrote {out}/report.md, metrics.json"
          + ("" if args.no_recording else ", recording.rrd")
          + (f"; FAILED methods: {', '.join(failed)}" if failed else ""))
    return 0


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

    return run_suite(scenario_dir=Path(args.scenarios), out=Path(args.out), check=args.check,
                     jobs=args.jobs, only_ci=args.ci, recording=not args.no_recording,
                     quiet=args.quiet, names=args.scenario)


def _cmd_view(args) -> int:
    from .recording import view

    return view(Path(args.dir))


def _cmd_bench(args) -> int:
    from .bench import main as bench_main

    return bench_main(seconds=args.seconds, repeats=args.repeats)




def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fogbench", description="FOG error-compensation testbench")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("simulate", help="simulate a scenario's runs and write their data")
    s.add_argument("scenario", help="scenario file (TOML)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--run", action="append", help="only this run (repeatable)")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.set_defaults(func=_cmd_simulate)

    r = sub.add_parser("run", help="simulate a scenario, fit and score its methods, write a report")
    r.add_argument("scenario", help="scenario file (TOML)")
    r.add_argument("--out", help="run directory (default reports/<scenario name>)")
    r.add_argument("--method", action="append", help="only this method label (repeatable)")
    r.add_argument("--no-recording", action="store_true", help="do not write recording.rrd")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    r.set_defaults(func=_cmd_run)

    u = sub.add_parser("suite", help="run every scenario and write reports/README.md")
    u.add_argument("--scenarios", default="scenarios", help="scenario folder (default scenarios)")
    u.add_argument("--out", default="reports", help="reports folder (default reports)")
    u.add_argument("--check", action="store_true",
                   help="exit 1 when a metric leaves the bounds its scenario file declares")
    u.add_argument("--jobs", type=int, default=2, help="parallel processes (default 2)")
    u.add_argument("--ci", action="store_true",
                   help="only the scenarios marked ci = true (the CI subset)")
    u.add_argument("--scenario", action="append", help="only this scenario name (repeatable)")
    u.add_argument("--no-recording", action="store_true", help="do not write recordings")
    u.add_argument("--quiet", action="store_true", help="no progress on stderr")
    u.set_defaults(func=_cmd_suite)

    v = sub.add_parser("view", help="open a run directory's recording in the Rerun viewer")
    v.add_argument("dir", help="run directory (holding recording.rrd)")
    v.set_defaults(func=_cmd_view)

    b = sub.add_parser("bench", help="print throughput of the rig and the error model")
    b.add_argument("--seconds", type=float, default=600.0,
                   help="simulated seconds per measurement (default 600)")
    b.add_argument("--repeats", type=int, default=5, help="repeats; medians are quoted")
    b.set_defaults(func=_cmd_bench)
    __import__("fogbench.reallog").reallog.add_commands(sub)  # h13 local wiring, see report
    return p


def main(argv=None) -> int:
    from .scenario import ScenarioError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ScenarioError as exc:
        print(f"fogbench: error: {exc}", file=sys.stderr)
        return 2
    except (ValueError, FileNotFoundError) as exc:
        print(f"fogbench: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fogbench: interrupted; files already complete are kept, none is half-written",
              file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
