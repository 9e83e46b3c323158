"""``fogbench check-method NAME``: :func:`fogcomp.check_method` on a method, rule by rule."""

from __future__ import annotations

from fogbench.cli._common import number


def add_parser(sub) -> None:
    k = sub.add_parser("check-method", help="run fogcomp.check_method on a method: the "
                       "contract every compensator keeps, rule by rule")
    k.add_argument("method", help="a method name, an entry-point plug-in or module:Class")
    k.add_argument("--probe-samples", type=number(int, 100, hi=10_000_000), default=100_000,
                   help="length of the probe record (default 100000)")
    k.set_defaults(func=_check_method)


def _check_method(args) -> int:
    import fogcomp

    try:
        fogcomp.get_method(args.method)
    except KeyError as exc:          # unknown name, or a plug-in that does not import
        raise ValueError(f"check-method: {exc.args[0]}") from None
    report = fogcomp.check_method(args.method, probe_samples=args.probe_samples)
    print(report)
    return 0 if report.ok else 1
