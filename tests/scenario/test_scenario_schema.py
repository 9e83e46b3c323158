"""The scenario keys' schema (fogbench.scenario.schema), which the reference's tables are made
from, against the loader it records: a value beyond a recorded bound is refused naming its key,
one inside is taken, and a key the schema does not have is refused as unknown."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fogbench.scenario import ScenarioError, load_scenario
from fogbench.scenario.load import RUNNER_SECTIONS
from fogbench.scenario.schema import keys_by_section, section_of

ROOT = Path(__file__).resolve().parents[2]
BASE = """[scenario]
name = "s"
sample_rate_hz = 100.0
[table]
{table}
[fog]
preset = "tactical"
[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "hold"
duration_s = 1.0
"""


@pytest.fixture(scope="module")
def schema():
    paths = sorted((ROOT / "scenarios").glob("*.toml"))
    return keys_by_section(paths)


def test_section_names_drop_the_names_and_indices_errors_carry():
    assert section_of("[[runs]] 'test1' motion[3]") == "[[runs.motion]]"
    assert section_of("[[protocols]] 'held_out' fit[0]") == "[[protocols]] fit / score selection"
    assert section_of("[[methods]][2]") == "[[methods]]"
    assert section_of("[thermal] steps[4]") == "[[thermal.steps]]"


def test_every_table_key_beyond_its_recorded_range_is_refused_and_inside_is_taken(tmp_path,
                                                                                   schema):
    checked = 0
    for key, info in schema["[table]"].items():
        if info.kinds != ["float"] or info.hi is None or info.lo is None:
            continue
        for value, ok in ((info.hi * 1.5 + 1.0, False), ((info.lo + info.hi) / 2, True)):
            p = tmp_path / f"{key}_{ok}.toml"
            p.write_text(BASE.format(table=f"{key} = {value!r}"))
            if ok:
                load_scenario(p, extra_sections=RUNNER_SECTIONS)
            else:
                with pytest.raises(ScenarioError, match=f"key '{key}'"):
                    load_scenario(p, extra_sections=RUNNER_SECTIONS)
        checked += 1
    assert checked >= 8


def test_a_key_the_schema_lacks_is_refused_as_unknown(tmp_path, schema):
    assert "no_such_key_dps" not in schema["[table]"]
    p = tmp_path / "s.toml"
    p.write_text(BASE.format(table="no_such_key_dps = 1.0"))
    with pytest.raises(ScenarioError, match="unknown key"):
        load_scenario(p, extra_sections=RUNNER_SECTIONS)


def test_required_keys_are_recorded_as_required(schema):
    assert schema["[scenario]"]["name"].required
    assert schema["[scenario]"]["sample_rate_hz"].required
    assert not schema["[table]"]["latitude_deg"].required
    assert math.isclose(schema["[table]"]["latitude_deg"].hi, 90.0)
