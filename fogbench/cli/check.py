"""``fogbench check FILE|FOLDER ...``: scenario, map and device files validated, nothing run
(:func:`fogbench.scenario.check.check_files`)."""

from __future__ import annotations

import sys


def add_parser(sub) -> None:
    c = sub.add_parser("check", help="validate scenario files (nothing is simulated or written)")
    c.add_argument("scenario", nargs="+",
                   help="scenario file(s) (TOML), or a folder: every .toml file in it")
    c.set_defaults(func=_check)


def _check(args) -> int:
    from fogbench.scenario.check import check_files

    bad = 0
    for ok, line in check_files(args.scenario):
        if ok:
            print(line)
        else:
            print(f"fogbench: error: {line}", file=sys.stderr)
            bad += 1
    return 2 if bad else 0
