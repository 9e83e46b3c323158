"""Values set over a parsed scenario by dotted paths (``fog.arw_deg_rt_h``,
``runs.test_m60.motion.0.rate_dps``): how a claim map's point changes its scenario."""

from __future__ import annotations

from fogbench.scenario.tables import ScenarioError

__all__ = ["apply_overrides"]

# ---------------------------------------------------------------------------------------------
# Claim maps: the scenario at other values of keys the papers leave open
_NAMED_ARRAYS = {"runs": "name", "protocols": "name", "methods": "label"}


def _resolve(doc, path: str, file: str) -> list:
    """Every (container, key) a dotted ``path`` names in a parsed scenario: tables by key, the
    arrays of tables ``runs`` and ``protocols`` by their element's ``name`` and ``methods`` by
    its ``label`` (or ``name``), any list by an integer index, and ``*`` for every element of
    an array (``runs.*.motion.0.rate_dps``: that key of every run)."""
    parts = path.split(".")
    if len(parts) < 2 or not all(parts):
        raise ScenarioError(f"{file}: [map] set {path!r}: expected a dotted path such as "
                            "'fog.arw_deg_rt_h' or 'runs.test_m60.motion.0.rate_dps'")

    def step(cur, i):
        part, where = parts[i], ".".join(parts[:i + 1])
        if isinstance(cur, list):
            if part == "*":
                return list(cur)
            if i > 0 and parts[i - 1] in _NAMED_ARRAYS and not part.isdigit():
                field_ = _NAMED_ARRAYS[parts[i - 1]]
                hits = [x for x in cur if isinstance(x, dict) and
                        (x.get(field_) == part or x.get("name") == part)]
                if len(hits) != 1:
                    raise ScenarioError(f"{file}: [map] set {path!r}: no single "
                                        f"[[{parts[i - 1]}]] with {field_} {part!r}")
                return hits
            if not part.isdigit() or int(part) >= len(cur):
                raise ScenarioError(f"{file}: [map] set {path!r}: {where!r} is not an index of "
                                    f"a list of {len(cur)}")
            return [cur[int(part)]]
        if isinstance(cur, dict):
            if part not in cur:
                if i == 0:
                    cur[part] = {}
                else:
                    raise ScenarioError(f"{file}: [map] set {path!r}: the file has no "
                                        f"{where!r}")
            return [cur[part]]
        raise ScenarioError(f"{file}: [map] set {path!r}: "
                            f"{'.'.join(parts[:i])!r} is a value, not a table")

    curs = [doc]
    for i in range(len(parts) - 1):
        curs = [c for cur in curs for c in step(cur, i)]
    last, out = parts[-1], []
    for cur in curs:
        if isinstance(cur, list):
            if last == "*":
                out += [(cur, j) for j in range(len(cur))]
                continue
            if not last.isdigit() or int(last) >= len(cur):
                raise ScenarioError(f"{file}: [map] set {path!r}: {last!r} is not an index of "
                                    f"a list of {len(cur)}")
            out.append((cur, int(last)))
        elif isinstance(cur, dict):
            out.append((cur, last))
        else:
            raise ScenarioError(f"{file}: [map] set {path!r}: "
                                f"{'.'.join(parts[:-1])!r} is a value, not a table")
    if not out:
        raise ScenarioError(f"{file}: [map] set {path!r}: names nothing (an empty array)")
    return out


def apply_overrides(doc: dict, overrides: dict, file: str) -> None:
    """Set each dotted path of ``overrides`` in the parsed scenario ``doc`` (in place); a value
    None removes the key (the preset's or the default value then applies)."""
    import copy

    for path, value in overrides.items():
        for container, key in _resolve(doc, path, file):
            if value is None:
                if isinstance(container, dict):
                    container.pop(key, None)
                continue
            container[key] = copy.deepcopy(value)
