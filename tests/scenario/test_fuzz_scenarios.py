"""A fuzzer for the scenario loader: mutants of valid scenario files are either loaded
or refused with exit status 2 and one line naming the file; never a traceback, and nothing is
written anywhere (``fogbench check``); the slow variant also simulates the loadable mutants of a
small scenario into a scratch ``--out`` and checks nothing lands outside it."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from helpers import SMALL_SCENARIO, run_cli

ROOT = Path(__file__).resolve().parents[2]
SEEDS = {p.name: p.read_text() for p in sorted((ROOT / "scenarios").glob("*.toml"))}
SEEDS["small.toml"] = SMALL_SCENARIO

KEY_LINE = re.compile(r'^(\s*)([A-Za-z0-9_]+)(\s*=\s*)(.+)$')
BAD_SCALARS = ["nan", "inf", "-inf", "1e308", "-1e308", "-1", "0", "1e12", "-0.0", '"ten"',
               "true", "[]", "{}", "[1, 2]", '""', "2.5", "123456789012345678"]
BAD_IN_LIST = ["nan", "inf", "-1e300", '"x"', "true", "0.5", "[]"]
PATHLIKE = ['"../x"', '""', '"."', '".."', '"a/b"', '"/etc/passwd"', '"con:"', '"x\\u0000y"',
            '"~"', '"' + "a" * 200 + '"', '"bad name"']


def _cli(args: list[str]) -> tuple[int, str]:
    code, _, err = run_cli(*args)
    return code, err


@st.composite
def mutants(draw) -> bytes:
    name = draw(st.sampled_from(sorted(SEEDS)))
    lines = SEEDS[name].splitlines()
    for _ in range(draw(st.integers(1, 3))):
        keyed = [i for i, ln in enumerate(lines) if KEY_LINE.match(ln)]
        kind = draw(st.sampled_from(["delete", "scalar", "in_list", "name", "truncate", "bytes",
                                     "dup_table"]))
        if kind in ("delete", "scalar", "in_list", "name") and keyed:
            i = draw(st.sampled_from(keyed))
            m = KEY_LINE.match(lines[i])
            if m is None:
                continue
            indent, key, eq, value = m.groups()
            if kind == "delete":
                lines[i] = ""
            elif kind == "scalar":
                lines[i] = f"{indent}{key}{eq}{draw(st.sampled_from(BAD_SCALARS))}"
            elif kind == "in_list":
                if value.startswith("["):
                    bad = draw(st.sampled_from(BAD_IN_LIST))
                    lines[i] = f"{indent}{key}{eq}[{bad}, " + value[1:]
            else:
                key = draw(st.sampled_from([key, "name", "label"]))
                lines[i] = f"{indent}{key}{eq}{draw(st.sampled_from(PATHLIKE))}"
        elif kind == "dup_table":
            hdr = [i for i, ln in enumerate(lines) if ln.startswith("[") and not ln.startswith("[[")]
            if hdr:
                lines.append(lines[draw(st.sampled_from(hdr))])
        text = "\n".join(lines).encode()
        if kind == "truncate":
            cut = draw(st.integers(0, len(text)))
            lines = text[:cut].decode("utf-8", "ignore").split("\n")
        elif kind == "bytes":
            pos = draw(st.integers(0, len(text)))
            junk = draw(st.binary(min_size=1, max_size=4))
            return text[:pos] + junk + text[pos:]
    return "\n".join(lines).encode()


def _files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def _with_devices(folder: Path) -> None:
    """The device files scenarios name (``[fog] device = "devices/..."``) beside the copies."""
    import shutil

    if not (folder / "devices").exists():
        shutil.copytree(ROOT / "scenarios" / "devices", folder / "devices")


def check_mutant(data: bytes, tmp: Path, simulate: bool = False) -> int:
    _with_devices(tmp)
    p = tmp / "mutant.toml"
    p.write_bytes(data)
    before = _files(tmp)
    code, err = _cli(["check", str(p)])
    assert code in (0, 2), err
    assert "Traceback" not in err
    if code == 2:
        lines = err.strip("\n").split("\n")
        assert len(lines) == 1, err
        assert lines[0].startswith(f"fogbench: error: {p}"), err
    assert _files(tmp) == before  # check writes nothing
    if simulate and code == 0:
        out = tmp / "scratch"
        code, err = _cli(["simulate", str(p), "--out", str(out), "--quiet"])
        assert code in (0, 2) and "Traceback" not in err, err
        assert {f for f in _files(tmp) - before if not f.startswith("scratch")} == set()
        if out.exists():
            import shutil

            shutil.rmtree(out)
    return code


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=mutants())
def test_mutated_scenarios_load_or_are_refused_in_one_line(tmp_path, data):
    assert check_mutant(data, tmp_path) in (0, 2)


@pytest.mark.slow
@settings(max_examples=600, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=mutants())
def test_mutated_scenarios_many_examples_and_simulation(tmp_path, data):
    assert check_mutant(data, tmp_path, simulate=b'name = "tiny"' in data) in (0, 2)


def test_the_fuzzer_reaches_refusals_and_loads():
    """The mutation strategy is not vacuous: the seeds load and a known mutant is refused."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        _with_devices(Path(d))
        for name, text in SEEDS.items():
            p = Path(d) / name
            p.write_text(text)
            assert _cli(["check", str(p)])[0] == 0, name
        p = Path(d) / "bad.toml"
        p.write_text(SMALL_SCENARIO.replace("sample_rate_hz = 10.0", "sample_rate_hz = nan"))
        code, err = _cli(["check", str(p)])
        assert code == 2 and "sample_rate_hz" in err
    assert os.path.isdir(ROOT / "scenarios")
