"""``fogbench run SCENARIO``: a scenario (or a claim-map file) into its run directory
(:func:`fogbench.run.scenario_dir.run_scenario_dir`)."""

from __future__ import annotations

from fogbench.cli._common import add_mc_flags, engine, number


def add_parser(sub) -> None:
    r = sub.add_parser("run", help="simulate a scenario, fit and score its methods, write a report")
    r.add_argument("scenario", help="scenario file (TOML)")
    r.add_argument("--out", help="run directory (default reports/<scenario name>); new, empty, "
                   "or one that fogbench run wrote: nothing else is ever replaced")
    r.add_argument("--method", action="append", help="only this method label (repeatable)")
    r.add_argument("--no-recording", action="store_true", help="do not write recording.rrd")
    r.add_argument("--no-figures", action="store_true",
                   help="draw no figures: the numbers, report and bounds only (a quick check)")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_mc_flags(r)
    r.add_argument("--resume", action="store_true",
                   help="keep the replicates a killed run left (same scenario file and fogbench "
                        "version) and compute only the rest")
    r.add_argument("--no-map", action="store_true",
                   help="leave out the scenario's claim map ([map]: the claims at other values "
                        "of the keys the papers leave open)")
    r.add_argument("--map-replicates", type=number(int, 1, hi=10_000),
                   help="replicates per point of the claim map (overrides [map] replicates)")
    r.set_defaults(func=_run)


def _run(args) -> int:
    from fogbench.run.scenario_dir import RunOptions, run_scenario_dir

    opts = RunOptions(replicates=args.replicates, method_seeds=args.method_seeds,
                      methods=tuple(args.method) if args.method else None, resume=args.resume,
                      no_map=args.no_map, map_replicates=args.map_replicates,
                      recording=not args.no_recording, figures=not args.no_figures,
                      quiet=args.quiet)
    return run_scenario_dir(args.scenario, args.out, opts, engine(args))
