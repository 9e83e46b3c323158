"""A method's ``sweep = {key = [values]}``: one member per combination of its hyperparameters,
and which member is the paper's (the method's defaults)."""

from __future__ import annotations

from fogbench.scenario.tables import _Table

MAX_SWEEP = 64


#: A sweep value that stands for the method's default of that hyperparameter (for defaults TOML
#: cannot write, such as ``level = None``: the deepest level the record allows).
SWEEP_DEFAULT = "default"


def _sweep_members(t: _Table, mname: str, params: dict, sweep: dict) -> list[tuple[dict, bool]]:
    """Every combination of a ``sweep = {key = [values]}`` table, and which one is the paper's
    setting (the method's defaults; ``"default"`` names a default explicitly)."""
    import itertools

    from fogcomp import get_method

    defaults = get_method(mname)().get_params()
    keys = list(sweep)
    for k in keys:
        v = sweep[k]
        if k not in defaults:
            raise t.err("sweep", f"{k!r} is not a hyperparameter of {mname}; it has "
                        f"{sorted(defaults)}")
        if not isinstance(v, list) or not v or len(set(map(repr, v))) != len(v):
            raise t.err("sweep", f"{k}: expected a non-empty list of distinct values, got {v!r}")
        if k in params:
            raise t.err("sweep", f"{k} is both in params and swept; give it in one place")
        if SWEEP_DEFAULT in v and defaults[k] in v:
            raise t.err("sweep", f"{k}: {SWEEP_DEFAULT!r} and {defaults[k]!r} are the same "
                        "setting (the default); give one")
    combos = list(itertools.product(*(sweep[k] for k in keys)))
    if len(combos) > MAX_SWEEP:
        raise t.err("sweep", f"{len(combos)} combinations; at most {MAX_SWEEP}")
    paper = {k: defaults[k] for k in keys}

    def is_paper(c):
        return all(v == SWEEP_DEFAULT or v == paper[k] for k, v in zip(keys, c))

    return [(dict(zip(keys, c)), is_paper(c)) for c in combos]
