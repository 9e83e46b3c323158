"""``fogbench simulate SCENARIO --out DIR``: a scenario's runs simulated and written as data
(:func:`fogbench.run.simulate.simulate_to_dir`)."""

from __future__ import annotations


def add_parser(sub) -> None:
    s = sub.add_parser("simulate", help="simulate a scenario's runs and write their data")
    s.add_argument("scenario", help="scenario file (TOML)")
    s.add_argument("--out", required=True,
                   help="output directory (new, empty, or one that fogbench simulate wrote)")
    s.add_argument("--run", action="append", help="only this run (repeatable)")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.set_defaults(func=_simulate)


def _simulate(args) -> int:
    from fogbench.run.simulate import simulate_to_dir

    name, runs, out = simulate_to_dir(args.scenario, args.out, runs=args.run, quiet=args.quiet)
    print(f"wrote {len(runs)} run(s) of {name} to {out}")
    return 0
