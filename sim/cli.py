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
    from .scenario import load_scenario

    scenario = load_scenario(args.scenario, extra_sections=EXTRA_SECTIONS)
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


def _cmd_bench(args) -> int:
    from .bench import main as bench_main

    return bench_main(seconds=args.seconds, repeats=args.repeats)


# Top-level scenario tables read by later stages (the runner).
EXTRA_SECTIONS = ("protocol", "methods", "bounds", "paper")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fogbench", description="FOG error-compensation testbench")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("simulate", help="simulate a scenario's runs and write their data")
    s.add_argument("scenario", help="scenario file (TOML)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--run", action="append", help="only this run (repeatable)")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.set_defaults(func=_cmd_simulate)

    b = sub.add_parser("bench", help="print throughput of the rig and the error model")
    b.add_argument("--seconds", type=float, default=600.0,
                   help="simulated seconds per measurement (default 600)")
    b.add_argument("--repeats", type=int, default=5, help="repeats; medians are quoted")
    b.set_defaults(func=_cmd_bench)
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
    except KeyboardInterrupt:
        print("fogbench: interrupted; files already complete are kept, none is half-written",
              file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
