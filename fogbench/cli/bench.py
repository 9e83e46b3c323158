"""``fogbench bench``: throughput and accuracy figures (:func:`fogbench.bench.main`)."""

from __future__ import annotations

from fogbench.cli._common import number


def add_parser(sub) -> None:
    b = sub.add_parser("bench", help="print throughput of the rig and the error model")
    b.add_argument("--seconds", type=number(float, 1.0, hi=86400.0), default=600.0,
                   help="simulated seconds per measurement, 1 to 86400 (default 600)")
    b.add_argument("--repeats", type=number(int, 1, hi=1000), default=5,
                   help="repeats; medians are quoted (default 5)")
    b.add_argument("--noise-seeds", type=number(int, 1, hi=1000), default=20,
                   help="records per case of the noise identifier's table (default 20)")
    b.add_argument("--quick", action="store_true",
                   help="every speed ratio on short records, no accuracy tables (a few "
                        "minutes; its own record lengths and 3 repeats: --seconds, --repeats "
                        "and --noise-seeds apply to the whole bench; that takes an hour or "
                        "more)")
    b.set_defaults(func=_bench)


def _bench(args) -> int:
    from fogbench.bench import main

    return main(seconds=args.seconds, repeats=args.repeats, noise_seeds=args.noise_seeds,
                quick=args.quick)
