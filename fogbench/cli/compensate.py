"""``fogbench compensate MODEL LOG --out CSV``: a model from ``fogbench calibrate`` applied to
a log (:func:`fogbench.logs.compensate.compensate`)."""

from __future__ import annotations

from fogbench.cli._common import add_log_flags, options
from fogbench.console import warnings_as_lines


def add_parser(sub) -> None:
    m = sub.add_parser("compensate", help="apply a model from fogbench calibrate to a log")
    m.add_argument("model", help="MODEL(.json) written by fogbench calibrate")
    m.add_argument("log", help="log CSV")
    m.add_argument("--out", required=True, help="output CSV (.csv or .csv.gz)")
    m.add_argument("--overwrite", action="store_true", help="replace a CSV written by an "
                   "earlier fogbench compensate (recognised by its _comp_/_cal_ columns; "
                   "nothing else, never an input)")
    add_log_flags(m)
    m.set_defaults(func=warnings_as_lines(_compensate))


def _compensate(args) -> int:
    from fogbench.logs.compensate import CompensateOptions, compensate

    return compensate(options(CompensateOptions, args))
