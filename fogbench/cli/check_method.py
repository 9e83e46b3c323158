"""``fogbench check-method NAME``: :func:`fogcomp.check_method` on a method, rule by rule."""

from __future__ import annotations

import sys

from fogbench.cli._common import number


def add_parser(sub) -> None:
    k = sub.add_parser("check-method", help="run fogcomp.check_method on a method: the "
                       "contract every compensator keeps, rule by rule")
    k.add_argument("method", help="a method name, an entry-point plug-in or module:Class")
    k.add_argument("--probe-samples", type=number(int, 100, hi=10_000_000), default=100_000,
                   help="length of the probe record (default 100000)")
    k.add_argument("--rule-timeout-s", type=number(float, 0.01, hi=86_400.0), default=300.0,
                   help="a rule not finished after this many seconds fails, and the rules "
                   "after it are not run (a hanging method); default 300")
    k.add_argument("--quiet", action="store_true", help="print the result only at the end, not "
                   "each rule as it ends")
    k.set_defaults(func=_check_method)


def _check_method(args) -> int:
    import fogcomp

    try:
        fogcomp.get_method(args.method)
    except KeyError as exc:          # unknown name, or a plug-in that does not import
        raise ValueError(f"check-method: {exc.args[0]}") from None
    from fogcomp.conformance import RULES

    def say(r):
        print(f"  [{RULES.index(r.rule) + 1}/{len(RULES)}] {r.line()}", file=sys.stderr,
              flush=True)

    report = fogcomp.check_method(args.method, probe_samples=args.probe_samples,
                                  timeout_s=args.rule_timeout_s,
                                  progress=None if args.quiet else say)
    print(report)
    return 0 if report.ok else 1
