"""``fogbench suite``: every scenario of a folder, and the summary ``reports/README.md``
(:func:`fogbench.run.suite.run_suite`)."""

from __future__ import annotations

from pathlib import Path

from fogbench.cli._common import add_mc_flags, engine, number


def add_parser(sub) -> None:
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
    add_mc_flags(u)
    u.add_argument("--resume", action="store_true",
                   help="keep the replicates a killed suite left and compute only the rest")
    u.add_argument("--no-map", action="store_true",
                   help="leave out the scenarios' claim maps ([map])")
    u.add_argument("--map-replicates", type=number(int, 1, hi=10_000),
                   help="replicates per point of every claim map (overrides [map] replicates)")
    u.set_defaults(func=_suite)


def _suite(args) -> int:
    from fogbench.run.suite import run_suite

    e = engine(args)
    return run_suite(scenario_dir=Path(args.scenarios), out=Path(args.out), check=args.check,
                     jobs=e.jobs, only_ci=args.ci, recording=not args.no_recording,
                     quiet=args.quiet, names=args.scenario, replicates=args.replicates,
                     method_seeds=args.method_seeds, scheduler=e.scheduler, cluster=e.cluster,
                     cluster_options=e.cluster_options, resume=args.resume,
                     no_map=args.no_map, map_replicates=args.map_replicates,
                     figures=not args.no_figures)
