"""``fogbench compare DIR ...``: every method of every scenario on one table and one figure
(:func:`fogbench.report.compare.compare`)."""

from __future__ import annotations


def add_parser(sub) -> None:
    c = sub.add_parser("compare", help="every method of every scenario on one table and one "
                       "figure (from run directories or a suite folder)")
    c.add_argument("dirs", nargs="+", help="run directories, or a suite folder (reports)")
    c.add_argument("--out", help="folder for compare.md, compare.json, compare.png (default: "
                   "the suite folder when it is the one argument)")
    c.set_defaults(func=_compare)


def _compare(args) -> int:
    from fogbench.report.compare import compare

    return compare(args.dirs, args.out)
