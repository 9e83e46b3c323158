"""Scenario files (TOML) loaded into frozen, validated objects in SI units: the whole file, here.

Every key a person writes carries its unit in its name (``rate_dps``, ``arw_deg_rt_h``); the
loader converts once, here. An unknown key, a missing required key, a wrong type or a value out
of range is refused with a :class:`ScenarioError` naming the file, the key and what was expected.
The format is documented in the README ("Scenario files").
"""

from __future__ import annotations

import contextlib

import hashlib
import json
import math
import re
import os
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from fogcomp import units as U
from sim.fog import TERMS, FogParams
from sim.lab import LabKnowledge
from sim.motion import ConstantRate, Hold, Positions, RateSteps, SineRate, positions_move_fits
from sim.rate_table import TableConfig
from sim.rig import PRESETS_PATH, Rig, Run, load_presets
from sim.thermal import (SENSOR_LOCATIONS, TempSensor, ThermalHold, ThermalModel, ThermalProgram,
                         ThermalRamp)

__all__ = ["ScenarioError", "Scenario", "Run", "load_scenario", "load_presets", "PRESETS_PATH",
           "Selection", "Protocol", "MethodSpec", "Bound", "PaperValue", "Claim", "Plan",
           "load_plan", "select_indices", "expand", "claim_name", "apply_overrides", "MapAxis",
           "MapPoint", "MapSpec"]

# Top-level tables of the compensation part (validated by load_plan below); others are refused.
RUNNER_SECTIONS = ("compensation", "protocols", "methods", "bounds", "paper", "claims",
                   "montecarlo", "map", "lab")
MAX_REPLICATES = 10_000


class ScenarioError(ValueError):
    """A scenario file is malformed; the message names the file, the key and what was expected."""


# Names that become parts of paths (scenario, run, protocol, method label): a safe character set.
_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
NAME_RULE = ("1 to 64 characters from A-Z a-z 0-9 _ . -, starting with a letter or digit "
             "(it becomes part of file and folder names)")


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be used as a path component, or None when it can."""
    if not _NAME_RE.fullmatch(name) or name.endswith("."):
        return f"expected {NAME_RULE}, got {name!r}"
    return None


# What a scenario may ask of memory: the runner holds every run's truth, temperatures, FOG output
# and error terms (float64) at once, and scoring copies the selected samples a few times.
MAX_SAMPLES = 50_000_000          # all runs together, at sample_rate_hz
BYTES_PER_SAMPLE = 8 * 70         # truth and table state (~45 columns) + terms and output per axis
MAX_ESTIMATED_BYTES = 8 * 2**30


class _Table:
    """A TOML table being read: tracks which keys were used, so the rest can be refused."""

    #: When a list: every get() appends (key, kind, lo, hi, lo_open, choices) to it, so that the
    #: validator itself declares the keys' schema (:func:`fog_json_schema`).
    recorder: list | None = None

    def __init__(self, data: dict, where: str, file: str):
        if not isinstance(data, dict):
            raise ScenarioError(f"{file}: {where}: expected a table, got {type(data).__name__}")
        self.data, self.where, self.file = data, where, file
        self.used: set[str] = set()

    def err(self, key: str, msg: str) -> ScenarioError:
        return ScenarioError(f"{self.file}: {self.where} key '{key}': {msg}")

    def has(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, kind: str, default: Any = ..., lo=None, hi=None, lo_open=False,
            choices=None):
        """Read ``key`` as ``kind``: 'float', 'int', 'str', 'bool', 'floats', 'strs', 'table',
        'tables'. Ranges are inclusive unless ``lo_open``."""
        if _Table.recorder is not None:
            _Table.recorder.append((key, kind, lo, hi, lo_open, choices))
        self.used.add(key)
        if key not in self.data:
            if default is ...:
                raise self.err(key, "missing (required; expected "
                               f"{_describe(kind, lo, hi, choices, lo_open)})")
            return default
        v = self.data[key]
        if kind == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.err(key, f"expected a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise self.err(key, f"expected a finite number, got {v!r}")
            self._range(key, v, lo, hi, lo_open)
        elif kind == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.err(key, f"expected an integer, got {v!r}")
            self._range(key, v, lo, hi, lo_open)
        elif kind == "str":
            if not isinstance(v, str):
                raise self.err(key, f"expected a string, got {v!r}")
            if choices is not None and v not in choices:
                raise self.err(key, f"expected one of {sorted(choices)}, got {v!r}")
        elif kind == "bool":
            if not isinstance(v, bool):
                raise self.err(key, f"expected true or false, got {v!r}")
        elif kind == "floats":
            if not isinstance(v, list) or not v or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                raise self.err(key, f"expected a non-empty list of numbers, got {v!r}")
            v = [float(x) for x in v]
            for i, x in enumerate(v):
                if not math.isfinite(x):
                    raise self.err(key, f"expected finite numbers, got {x!r} at index {i}")
                self._range(key, x, lo, hi, lo_open)
        elif kind == "ints":
            if not isinstance(v, list) or not all(
                    isinstance(x, int) and not isinstance(x, bool) for x in v):
                raise self.err(key, f"expected a list of integers, got {v!r}")
            for x in v:
                self._range(key, x, lo, hi, lo_open)
        elif kind == "name":
            if not isinstance(v, str):
                raise self.err(key, f"expected a string, got {v!r}")
            msg = name_problem(v)
            if msg:
                raise self.err(key, msg)
        elif kind == "strs":
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise self.err(key, f"expected a list of strings, got {v!r}")
            if choices is not None:
                for x in v:
                    if x not in choices:
                        raise self.err(key, f"expected entries from {sorted(choices)}, got {x!r}")
        elif kind == "table":
            if not isinstance(v, dict):
                raise self.err(key, f"expected a table, got {v!r}")
        elif kind == "tables":
            if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
                raise self.err(key, f"expected an array of tables ([[{key}]]), got {v!r}")
        elif kind == "any":
            pass
        else:  # pragma: no cover
            raise ValueError(kind)
        return v

    def _range(self, key, v, lo, hi, lo_open):
        if lo is not None and (v <= lo if lo_open else v < lo):
            raise self.err(key, f"expected a value {'>' if lo_open else '>='} {lo}, got {v}")
        if hi is not None and v > hi:
            raise self.err(key, f"expected a value <= {hi}, got {v}")

    def done(self):
        extra = sorted(set(self.data) - self.used)
        if extra:
            raise ScenarioError(f"{self.file}: {self.where}: unknown key(s) {extra}; "
                                f"allowed: {sorted(self.used)}")


def _describe(kind, lo, hi, choices, lo_open=False):
    what = {"float": "a number", "int": "an integer", "str": "a string", "bool": "true/false",
            "floats": "a list of numbers", "strs": "a list of strings", "table": "a table",
            "ints": "a list of integers", "name": f"a name ({NAME_RULE})",
            "tables": "an array of tables"}.get(kind, kind)
    if choices:
        what += f" from {sorted(choices)}"
    if lo is not None:
        what += f", {'>' if lo_open else '>='} {lo}"
    if hi is not None:
        what += f", <= {hi}"
    return what


# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scenario:
    """A validated scenario, SI units inside."""

    path: str
    name: str
    description: str
    fs: float
    table: TableConfig
    fog: FogParams
    fog_preset: str | None
    fog_source: str
    axes: tuple[str, ...]
    runs: tuple[Run, ...]
    ambient_c: float = 20.0
    extra: dict = field(default_factory=dict, compare=False)  # sections later stages read
    text: str = ""
    thermal_model: ThermalModel = ThermalModel()
    fog_changed: dict = field(default_factory=dict, compare=False)  # [fog] keys over the preset
    overrides: dict = field(default_factory=dict, compare=False)    # a claim-map point's values

    @property
    def device(self) -> str:
        """The device this scenario runs, as a report names it: the preset and its source, the
        keys the file sets over it and the values a claim-map point sets (never the preset's
        label alone)."""
        if self.fog_preset is None:
            out = "given in the scenario file"
        elif self.fog_preset.startswith("device file "):
            out = f"{self.fog_preset} ({self.fog_source})"
        else:
            out = f"preset `{self.fog_preset}` ({self.fog_source})"
        by_file = {k: v for k, v in self.fog_changed.items()
                   if f"fog.{k}" not in self.overrides}
        if self.fog_preset is not None and by_file:
            out += "; set over it by the scenario file: " + ", ".join(
                f"{k} = {_short(v)}" for k, v in by_file.items())
        if self.overrides:
            out += "; claim-map point: " + ", ".join(
                f"{k} = {_short(v)}" for k, v in self.overrides.items())
        return out

    @property
    def rig(self) -> Rig:
        """The rig part: what ``sim.simulate_run`` needs besides a run."""
        return Rig(fs=self.fs, table=self.table, fog=self.fog, axes=self.axes,
                   ambient_c=self.ambient_c, thermal=self.thermal_model)

    def run(self, name: str) -> Run:
        for r in self.runs:
            if r.name == name:
                return r
        raise KeyError(f"{self.path}: no run named {name!r}; runs: {[r.name for r in self.runs]}")


# Scenario [fog] keys: key -> (FogParams field, factor to SI, kind, lo, hi). The limits are
# physical: beyond them no gyro (MEMS to strategic grade) operates, so a value there is a typo.
_FOG_KEYS = {
    "range_dps": ("range", U.DPS, "float", 0.0, 20_000.0),
    "temp_rate_cooling_ratio": ("temp_rate_cooling_ratio", 1.0, "float", 0.0, 10.0),
    "gm_drift_dps": ("gm_drift", U.DPS, "float", 0.0, 10.0),
    "gm_time_constant_s": ("gm_time_constant", 1.0, "float", 0.0, 1e5),
    "bias_dph": ("bias", U.DPH, "float", -1e5, 1e5),
    "switch_on_bias_dph": ("switch_on_bias_sigma", U.DPH, "float", 0.0, 1e5),
    "arw_deg_rt_h": ("arw", U.DEG_RT_H, "float", 0.0, 100.0),
    "bias_instability_dph": ("bias_instability", U.DPH, "float", 0.0, 1e4),
    "rrw_dph_rt_h": ("rrw", U.DPH_RT_H, "float", 0.0, 1e4),
    "rate_ramp_dph_per_h": ("rate_ramp", U.DPH_PER_H, "float", -1e5, 1e5),
    "quantization_arcsec": ("quantization", U.ARCSEC, "float", 0.0, 3600.0),
    "scale_factor_ppm": ("scale_factor", U.PPM, "float", -1e5, 1e5),
    "sf_nonlinearity_ppm": ("sf_nonlinearity", U.PPM, "float", -1e5, 1e5),
    "sf_temp_coeff_ppm_per_c": ("sf_temp_coeff", U.PPM, "float", -1e4, 1e4),
    "full_scale_dps": ("full_scale", U.DPS, "float", 0.0, 1e5),
    "g_sens_switch_on_dph_per_g": ("g_sens_switch_on_sigma", U.DPH, "float", 0.0, 1e4),
    "g2_sens_switch_on_dph_per_g2": ("g2_sens_switch_on_sigma", U.DPH, "float", 0.0, 1e4),
    "temp_ref_c": ("temp_ref", 1.0, "float", -273.15, 500.0),
    "temp_coeff_dph_per_c": ("temp_coeff", U.DPH, "float", -1e4, 1e4),
    "temp_coeff2_dph_per_c2": ("temp_coeff2", U.DPH, "float", -1e3, 1e3),
    "temp_rate_coeff_dph_per_c_per_min": ("temp_rate_coeff", U.DPH * 60.0, "float", -1e5, 1e5),
    "temp_cross_coeff_dph_per_c_per_c_per_min": ("temp_cross_coeff", U.DPH * 60.0, "float",
                                                 -1e4, 1e4),
}
G_SENS_LIMIT_DPH = 1e4       # deg/h per g (a DTG is ~10, MEMS ~100-1000)
MISALIGNMENT_LIMIT_MRAD = 100.0


def _fog(tbl: _Table, fs: float) -> tuple[FogParams, str | None, str, tuple[str, ...],
                                          ThermalModel]:
    preset_name = tbl.get("preset", "str", None)
    device = tbl.get("device", "str", None)
    values: dict[str, Any] = {}
    source = "given in the scenario file"
    if preset_name is not None and device is not None:
        raise tbl.err("device", "give either preset or device (a device file), not both")
    if preset_name is not None:
        presets = load_presets()
        if preset_name not in presets:
            raise tbl.err("preset", f"expected one of {sorted(presets)}, got {preset_name!r}")
        values.update(presets[preset_name])
        source = values.pop("source", f"preset {preset_name}")
    if device is not None:
        path = Path(tbl.file).parent / device
        if not device.strip():
            raise tbl.err("device", "expected the path of a device file, got an empty string")
        try:
            values.update(load_device_file(path, fs))
        except ScenarioError as exc:   # named from the scenario: which file asked for it
            raise tbl.err("device", f"{device!r} ({path}): {exc}") from None
        source = values.pop("source", f"device file {device}")
        preset_name = f"device file {device}"
    preset_values = dict(values)
    values.update({k: v for k, v in tbl.data.items() if k not in ("preset", "device")})
    # the keys the file sets over its preset (or every key, without one): a report names them
    changed = {k: v for k, v in tbl.data.items()
               if k not in ("preset", "device", "axes", "source") and preset_values.get(k) != v}
    merged = _Table(values, tbl.where, tbl.file)
    merged.used.add("source")
    kw: dict[str, Any] = {}
    for key, (fld, factor, kind, lo, hi) in _FOG_KEYS.items():
        v = merged.get(key, kind, None, lo=lo, hi=hi,
                       lo_open=key in ("range_dps", "gm_time_constant_s"))
        if v is not None:
            kw[fld] = v * factor
    axes = tuple(merged.get("axes", "strs", ["z"], choices={"x", "y", "z"}))
    if not axes or len(set(axes)) != len(axes):
        raise merged.err("axes", f"expected 1 to 3 distinct axes among x, y, z, got {list(axes)}")
    band = merged.get("bias_instability_band_hz", "floats", None, lo=0.0, lo_open=True)
    if band is not None:
        if len(band) != 2 or not band[0] < band[1]:
            raise merged.err("bias_instability_band_hz", f"expected [low, high] with low < high, "
                             f"got {band}")
        if band[1] > fs / 2:
            raise merged.err("bias_instability_band_hz", f"the band's top {band[1]} Hz is above "
                             f"the Nyquist frequency {fs / 2} Hz of sample_rate_hz")
        kw["bi_band"] = tuple(band)
    elif kw.get("bias_instability"):
        kw["bi_band"] = (1e-6, min(0.1, fs / 2))
    per_decade = merged.get("bias_instability_per_decade", "int", None, lo=1, hi=20)
    if per_decade is not None:
        kw["bi_per_decade"] = per_decade
    for key, fld, n in (("g_sens_dph_per_g", "g_sens", 3), ("g2_sens_dph_per_g2", "g2_sens", 6)):
        v = merged.get(key, "any", None)
        if v is None:
            continue
        rows = v if (isinstance(v, list) and v and isinstance(v[0], list)) else [v]
        ok = all(isinstance(r, list) and len(r) == n and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
            and abs(x) <= G_SENS_LIMIT_DPH for x in r) for r in rows)
        if not ok or len(rows) not in (1, len(axes)):
            raise merged.err(key, f"expected a list of {n} numbers (deg/h per g"
                             f"{'^2' if n == 6 else ''}, each finite and within "
                             f"+-{G_SENS_LIMIT_DPH:g}), or one such list per axis "
                             f"({len(axes)}), got {v!r}")
        arr = [[x * U.DPH for x in r] for r in rows]
        kw[fld] = tuple(map(tuple, arr)) if len(arr) > 1 else tuple(arr[0])
    mis = merged.get("misalignment_mrad", "any", None)
    if mis is not None:
        ok = (isinstance(mis, list) and len(mis) == 3 and all(
            isinstance(r, list) and len(r) == 3 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
                and abs(x) <= MISALIGNMENT_LIMIT_MRAD for x in r)
            for r in mis))
        if not ok or any(mis[i][i] != 0 for i in range(3)):
            raise merged.err("misalignment_mrad", f"expected a 3x3 list of lists of finite "
                             f"numbers within +-{MISALIGNMENT_LIMIT_MRAD:g} mrad with a zero "
                             f"diagonal (row a: axis a's sensitivity to x, y, z rates), got {mis!r}")
        kw["misalignment"] = tuple(tuple(x * 1e-3 for x in r) for r in mis)
    disabled = merged.get("disabled_terms", "strs", [], choices=set(TERMS))
    kw["disabled"] = tuple(disabled)
    thermal = _fog_thermal(merged, fs)
    merged.done()
    return FogParams(**kw), preset_name, source, axes, thermal, changed


DEVICE_FILE_REFUSED = ("preset", "device", "axes")   # a scenario's choices, not the device's

# the [fog] keys the validator reads as "any" (checked by hand above): their JSON Schema
_ANY_KEY_SCHEMAS = {
    "g_sens_dph_per_g": {"description": "d1-d3 of paper 004 eq. 8 (fx, fy, fz), deg/h per g",
                         "type": "array", "minItems": 3, "maxItems": 3, "items": {
                             "type": "number", "minimum": -G_SENS_LIMIT_DPH,
                             "maximum": G_SENS_LIMIT_DPH}},
    "g2_sens_dph_per_g2": {"description": "d4-d9 of paper 004 eq. 8 (fx^2, fy^2, fz^2, fx fy, "
                           "fy fz, fx fz), deg/h per g^2", "type": "array", "minItems": 6,
                           "maxItems": 6, "items": {"type": "number",
                                                    "minimum": -G_SENS_LIMIT_DPH,
                                                    "maximum": G_SENS_LIMIT_DPH}},
    "misalignment_mrad": {"description": "3x3, row a: axis a's sensitivity to the x, y, z rates "
                          "(zero diagonal), mrad", "type": "array", "minItems": 3, "maxItems": 3,
                          "items": {"type": "array", "minItems": 3, "maxItems": 3, "items": {
                              "type": "number", "minimum": -MISALIGNMENT_LIMIT_MRAD,
                              "maximum": MISALIGNMENT_LIMIT_MRAD}}},
}


def fog_json_schema() -> dict:
    """JSON Schema (draft 2020-12) of a device file, i.e. of a scenario's [fog] keys, taken from
    the validator itself: :func:`_fog` is run on an empty table with every read recorded (key,
    kind, range, choices), so the schema cannot drift from what a scenario accepts. Checks the
    validator makes beyond one key (a band's order, the flicker band below Nyquist, a zero
    diagonal) are not in it: the loader still has the last word."""
    def reads(fs):
        calls: list = []
        _Table.recorder = calls
        try:
            _fog(_Table({}, "[fog]", "schema"), fs)
        finally:
            _Table.recorder = None
        return calls

    calls = reads(10_000.0)
    # a bound that moves with the sample rate (e.g. a sensor rate at most the scenario's): its
    # limit is the scenario's, not the schema's
    at_fs = {c[0] for c, d in zip(calls, reads(5_000.0)) if c != d}
    props: dict = {"source": {"type": "string", "description": "where the numbers come from"}}
    types = {"float": "number", "int": "integer", "str": "string", "bool": "boolean"}
    for key, kind, lo, hi, lo_open, choices in calls:
        if key in ("preset", "device", "axes") or key in props:
            continue
        if key in _ANY_KEY_SCHEMAS:
            one = dict(_ANY_KEY_SCHEMAS[key])
            if key in ("g_sens_dph_per_g", "g2_sens_dph_per_g2"):   # or one list per axis
                desc = one.pop("description")
                one = {"description": desc + "; or one such list per axis",
                       "oneOf": [one, {"type": "array", "minItems": 1, "maxItems": 3,
                                       "items": dict(one)}]}
            props[key] = one
            continue
        item: dict = {"type": types.get(kind.rstrip("s"), "number")}
        if lo is not None:
            item["exclusiveMinimum" if lo_open else "minimum"] = lo
        if hi is not None and key not in at_fs:
            item["maximum"] = hi
        if key in at_fs:
            item["description"] = "at most the scenario's sample rate (sample_rate_hz)"
        if choices is not None:
            item["enum"] = sorted(choices)
        props[key] = item if kind in types else {"type": "array", "items": item}
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": "fogbench device file ([fog] keys)", "type": "object",
            "additionalProperties": False, "properties": props}


def load_device_file(path, fs: float | None = None) -> dict:
    """The [fog] keys of a device file (``sim/presets.toml``'s format for one device: the keys
    of a scenario's ``[fog]`` table, datasheet units in their names, and ``source``), validated
    as a [fog] table of its own so that an error names the device file and its key. ``fs``: the
    scenario's sample rate (the checks that need it: the flicker band below Nyquist); None
    checks at the highest rate a scenario may have."""
    file = str(path)
    if Path(path).is_dir():
        raise ScenarioError(f"{file}: is a directory, expected a device file (TOML)")
    doc = _read_toml(path)
    for k in DEVICE_FILE_REFUSED:
        if k in doc:
            raise ScenarioError(f"{file}: key '{k}': a device file holds the device's own keys "
                                f"only ({k} is the scenario's choice, in its [fog] table)")
    for k, v in doc.items():
        if isinstance(v, dict):
            raise ScenarioError(f"{file}: [{k}]: a device file has no tables, only the keys of "
                                "a [fog] table")
    if not any(k != "source" for k in doc):
        raise ScenarioError(f"{file}: holds no [fog] keys (an empty device would be a perfect "
                            "gyro); write the device's keys, e.g. with fogbench device fit")
    tbl = _Table(dict(doc), "device file", file)
    tbl.get("source", "str", None)
    _fog(tbl, 10_000.0 if fs is None else fs)
    return doc


_SCENARIO_TABLES = ("scenario", "runs", "table", "fog", "thermal", "protocols", "methods")


def is_device_file(path) -> bool:
    """Whether a TOML file is meant as a device file: it has none of a scenario's (or a map
    file's) tables. A file that does not read is not (its scenario check says why)."""
    try:
        doc = _read_toml(path)
    except ScenarioError:
        return False
    return not any(k in doc for k in _SCENARIO_TABLES)


def _fog_thermal(tbl: _Table, fs: float) -> ThermalModel:
    """The FOG's thermal build and temperature sensor ([fog] keys; defaults: one 600 s coil lag
    behind the chamber, an ideal sensor on the coil)."""
    d, ds = ThermalModel(), TempSensor()
    sensor = TempSensor(
        location=tbl.get("temp_sensor_location", "str", ds.location,
                         choices=set(SENSOR_LOCATIONS)),
        time_constant=tbl.get("temp_sensor_time_constant_s", "float", ds.time_constant, lo=0.0,
                              hi=3600.0),
        noise=tbl.get("temp_sensor_noise_c", "float", ds.noise, lo=0.0, hi=5.0),
        resolution=tbl.get("temp_sensor_resolution_c", "float", ds.resolution, lo=0.0, hi=1.0),
        rate=tbl.get("temp_sensor_rate_hz", "float", ds.rate, lo=0.0, hi=fs),
        rate_window=tbl.get("temp_rate_window_s", "float", ds.rate_window, lo=0.0, hi=3600.0),
    )
    return ThermalModel(
        housing_time_constant=tbl.get("housing_time_constant_s", "float",
                                      d.housing_time_constant, lo=0.0, hi=1e5),
        coil_time_constant=tbl.get("coil_time_constant_s", "float", d.coil_time_constant,
                                   lo=0.0, hi=1e5),
        sensor=sensor)


def _table_cfg(tbl: _Table) -> TableConfig:
    cfg = TableConfig(
        radius=tbl.get("radius_m", "float", 0.0, lo=0.0, hi=0.14),
        height=tbl.get("height_m", "float", 0.06, lo=0.045, hi=0.5),
        latitude=math.radians(tbl.get("latitude_deg", "float", 45.0, lo=-90.0, hi=90.0)),
        heading=math.radians(tbl.get("heading_deg", "float", 0.0, lo=-360.0, hi=360.0)),
        gravity=tbl.get("gravity_mps2", "float", U.G0, lo=9.7, hi=9.84),
        physics_dt=tbl.get("physics_dt_s", "float", 1e-3, lo=1e-5, hi=5e-3),
        tilt_slew=math.radians(tbl.get("tilt_slew_dps", "float", 20.0, lo=0.1, hi=500.0)),
        settle_time=tbl.get("settle_time_s", "float", 5.0, lo=0.5, hi=600.0),
        turn_accel=math.radians(tbl.get("turn_accel_dps2", "float", 200.0, lo=1.0, hi=5000.0)),
        earth_rate=tbl.get("earth_rate", "bool", True),
        # the table's imperfections, default 0 (a perfect table); class values and their
        # sources: sim.lab.CLASS_VALUES (axis verticality 5 arcsec for a navigation-grade
        # turntable, Ruya-T ry119; rate error ~100 ppm, measured, XinLiGH/TurntableSpeedAndPosition)
        turn_axis_error=tbl.get("turn_axis_error_arcsec", "float", 0.0, lo=-3600.0,
                                hi=3600.0) * _ARCSEC,
        level_error=_level(tbl),
        # limit 1e4 ppm (1 %): beyond it no rate table (nor a hobby turntable) is used to
        # calibrate a gyro, so a value there is a typo
        rate_error=tbl.get("rate_error_ppm", "float", 0.0, lo=-1e4, hi=1e4) * 1e-6,
    )
    tbl.done()
    return cfg


_ARCSEC = math.pi / (180.0 * 3600.0)


def _level(tbl: _Table) -> tuple[float, float]:
    v = tbl.get("level_error_arcsec", "floats", [0.0, 0.0], lo=-3600.0, hi=3600.0)
    if len(v) != 2:
        raise tbl.err("level_error_arcsec", f"expected [about x, about y], got {len(v)} values")
    return v[0] * _ARCSEC, v[1] * _ARCSEC


def _thermal(tbl: _Table) -> ThermalProgram:
    start = tbl.get("start_c", "float", lo=-80.0, hi=150.0)
    # the FOG's own lags are [fog] keys; these override them for this set-up (fixture, air flow)
    tau = tbl.get("coil_time_constant_s", "float", None, lo=0.0, hi=1e5)
    tau_h = tbl.get("housing_time_constant_s", "float", None, lo=0.0, hi=1e5)
    steps = []
    for i, st in enumerate(tbl.get("steps", "tables", [])):
        s = _Table(st, f"{tbl.where} steps[{i}]", tbl.file)
        if s.has("hold_s"):
            steps.append(ThermalHold(s.get("hold_s", "float", lo=0.0, lo_open=True)))
        elif s.has("ramp_to_c"):
            steps.append(ThermalRamp(s.get("ramp_to_c", "float", lo=-80.0, hi=150.0),
                                     s.get("rate_c_per_min", "float", lo=0.0, lo_open=True,
                                           hi=30.0) / 60.0))
        else:
            raise s.err("hold_s", "a thermal step needs 'hold_s' (a hold) or 'ramp_to_c' with "
                        "'rate_c_per_min' (a ramp)")
        s.done()
    tbl.done()
    return ThermalProgram(start=start, steps=tuple(steps), coil_time_constant=tau,
                          housing_time_constant=tau_h)


_MOTION_TYPES = ("hold", "rate", "rate_steps", "sine", "positions")


def _motion(tbl: _Table, fs: float):
    kind = tbl.get("type", "str", choices=set(_MOTION_TYPES))
    tilt_deg = tbl.get("tilt_deg", "float", None, lo=-360.0, hi=360.0) if kind != "positions" else None
    tilt = None if tilt_deg is None else math.radians(tilt_deg)
    if kind == "hold":
        seg = Hold(tbl.get("duration_s", "float", lo=0.0, lo_open=True), tilt=tilt)
    elif kind == "rate":
        seg = ConstantRate(tbl.get("duration_s", "float", lo=0.0, lo_open=True),
                           math.radians(tbl.get("rate_dps", "float", lo=-1000.0, hi=1000.0)),
                           tilt=tilt)
    elif kind == "rate_steps":
        seg = RateSteps(tuple(math.radians(r) for r in tbl.get("rates_dps", "floats", lo=-1000.0,
                                                               hi=1000.0)),
                        tbl.get("step_s", "float", lo=0.0, lo_open=True), tilt=tilt)
    elif kind == "sine":
        seg = SineRate(tbl.get("duration_s", "float", lo=0.0, lo_open=True),
                       math.radians(tbl.get("amplitude_dps", "float", lo=0.0, hi=1000.0)),
                       tbl.get("frequency_hz", "float", lo=0.0, lo_open=True, hi=fs / 4),
                       math.radians(tbl.get("offset_dps", "float", 0.0, lo=-1000.0, hi=1000.0)),
                       tilt=tilt)
    else:
        seg = Positions(
            tuple(math.radians(x) for x in tbl.get("tilts_deg", "floats", lo=-360.0, hi=360.0)),
            tuple(math.radians(x) for x in tbl.get("headings_deg", "floats", lo=-720.0,
                                                   hi=720.0)),
            dwell=tbl.get("dwell_s", "float", lo=0.0, lo_open=True),
            move_time=tbl.get("move_s", "float", lo=0.0, lo_open=True),
            max_rate=math.radians(tbl.get("move_rate_dps", "float", 30.0, lo=0.1, hi=1000.0)),
            max_accel=math.radians(tbl.get("move_accel_dps2", "float", 60.0, lo=0.1,
                                           hi=5000.0)),
        )
    tbl.done()
    return seg


def _check_whole_samples(tbl: _Table, seg, fs: float):
    parts = {"hold": [("duration_s", seg.duration)], "rate": [("duration_s", seg.duration)],
             "sine": [("duration_s", seg.duration)],
             "rate_steps": [("step_s", getattr(seg, "step_duration", 0.0))],
             "positions": [("dwell_s", getattr(seg, "dwell", 0.0)),
                           ("move_s", getattr(seg, "move_time", 0.0))]}[seg.kind]
    for key, val in parts:
        n = val * fs
        if not math.isfinite(n) or n > MAX_SAMPLES:
            raise tbl.err(key, f"{val:g} s is {n:g} samples at sample_rate_hz = {fs:g}; the "
                          f"limit is {MAX_SAMPLES:.3g} samples in all")
        if abs(n - round(n)) > 1e-6 * max(1.0, n):
            raise tbl.err(key, f"expected a whole number of samples at sample_rate_hz = {fs:g}, "
                          f"got {val:g} s = {n:g} samples")


def decode_text(raw: bytes, file: str) -> str:
    """A scenario file's text: UTF-8 (TOML's encoding; a leading byte-order mark is accepted).
    Anything else is refused naming the line and column of the first undecodable byte."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise ScenarioError(f"{file}: line {line}, column {col}: not UTF-8 text (byte "
                            f"0x{raw[exc.start]:02x}); save the file as UTF-8") from None


def _check_size(runs: list[Run], fs: float, n_axes: int, file: str) -> None:
    """Refuse, before any simulation, a scenario whose runs cannot fit in memory."""
    per_run = [(r.name, r.duration * fs) for r in runs]
    total = sum(n for _, n in per_run)
    est = total * (BYTES_PER_SAMPLE + 8 * 16 * n_axes)
    if total > MAX_SAMPLES or est > MAX_ESTIMATED_BYTES:
        big = max(per_run, key=lambda x: x[1])
        raise ScenarioError(
            f"{file}: the runs ask for {total:.3g} samples in all (largest: run {big[0]!r}, "
            f"{big[1]:.3g} samples), about {est / 2**30:.3g} GiB of memory; the limit is "
            f"{MAX_SAMPLES:.3g} samples and {MAX_ESTIMATED_BYTES / 2**30:g} GiB: shorten the "
            "runs' duration_s or lower sample_rate_hz")


def _short(v) -> str:
    t = json.dumps(v)
    return t if len(t) <= 80 else t[:77] + "..."


_PROTOCOLS_HEADER = re.compile(r"[ \t]*\[\[[ \t]*protocols[ \t]*\]\][ \t]*(#.*)?")


def _same_doc(a, b) -> bool:
    """Two parsed TOML documents hold the same values (NaN equal to NaN)."""
    return json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)


def _toml_value(v) -> str:
    """A parsed TOML value written back as TOML (inline: tables as { }, on one line)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) \
            else repr(v)
    if isinstance(v, str):   # JSON's escapes are TOML's, but for DEL, which TOML escapes too
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_value(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return v.isoformat()     # a date or a time


def _toml_document(doc: dict) -> str:
    """A parsed TOML document written back as TOML: its top-level tables and arrays of tables
    as headers, every value under them inline."""
    def keys(t):
        return "".join(f"{_toml_value(k)} = {_toml_value(v)}\n" for k, v in t.items())

    out = [keys({k: v for k, v in doc.items() if not isinstance(v, dict)
                 and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))})]
    for k, v in doc.items():
        if isinstance(v, dict):
            out.append(f"\n[{_toml_value(k)}]\n{keys(v)}")
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            out += [f"\n[[{_toml_value(k)}]]\n{keys(x)}" for x in v]
    return "".join(out)


def _with_references(text: str, which: list[int], names: list[str], value: str) -> str:
    """The scenario's text with ``reference = VALUE`` in its protocols numbered ``which``
    (``--reference VALUE``), so that the text, the run folder's scenario.toml, runs again as it
    ran: a line after each one's ``[[protocols]]`` header. A file whose protocols are not
    written under such headers (inline tables) is written out whole, its own text kept below
    as comments. Either is read back and checked to hold the values the run ran."""
    note = f"  # --reference {value}\n"
    try:
        want = tomllib.loads(text)
        for i in which:
            want["protocols"][i]["reference"] = value
    except (tomllib.TOMLDecodeError, KeyError, IndexError, TypeError):
        # the text's protocols are not the run's (not a file as read): say so in a comment
        return text + (f'\n# --reference {value}: reference = "{value}" set in protocols '
                       + ", ".join(json.dumps(n) for n in names) + "\n")

    def holds(new: str) -> bool:
        try:
            return _same_doc(tomllib.loads(new), want)
        except tomllib.TOMLDecodeError:
            return False

    lines = text.splitlines(keepends=True)
    heads = [i for i, ln in enumerate(lines) if _PROTOCOLS_HEADER.fullmatch(ln.rstrip("\r\n"))]
    if len(heads) == len(want["protocols"]):
        for i in sorted(which, reverse=True):
            h = heads[i]
            lines.insert(h + 1, ("" if lines[h].endswith("\n") else "\n")
                         + f'reference = "{value}"' + note)
        new = "".join(lines)
        if holds(new):
            return new
    new = (f"# --reference {value}: reference = \"{value}\" set in protocols "
           + ", ".join(json.dumps(n) for n in names) + "; the file written out whole (its "
           "own text, as given, is below as comments)\n" + _toml_document(want)
           + "\n# the file as given:\n" + "".join(f"# {ln}\n" for ln in text.splitlines()))
    if not holds(new):
        raise ScenarioError(f"--reference {value}: cannot write the scenario with reference = "
                            f"\"{value}\" set in its protocols (please report this file)")
    return new


def load_scenario(path: str | Path, extra_sections: tuple[str, ...] = (),
                  overrides: dict | None = None) -> Scenario:
    """Load and validate a scenario file. Raises ScenarioError naming file, key and expectation.

    ``extra_sections`` names further top-level tables that a later stage validates (they are
    kept, unread, in ``Scenario.extra``); any other unknown table is refused. ``overrides``
    (``{dotted path: value}``, :func:`apply_overrides`) change the file's values before it is
    validated: a point of a claim map is the scenario with its axes' values set (its own
    ``[map]`` left out), validated like any file; its text for digests and reports is the file's
    followed by the overrides.
    """
    path = Path(path)
    file = str(path)
    try:
        if path.is_dir():
            raise ScenarioError(f"{file}: is a directory, expected a scenario file (TOML)")
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{file}: cannot read ({exc.strerror})") from None
    text = decode_text(raw, file)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{file}: not valid TOML ({exc})") from None
    if overrides is not None:  # a point of the claim map (its own [map] left out)
        doc.pop("map", None)
        apply_overrides(doc, overrides, file)
    if overrides:
        text = text + "\n# claim-map point: these values set over the file's\n" + "".join(
            f"# {k} = {json.dumps(v)}\n" for k, v in overrides.items())
    added = [n for n in with_methods() if isinstance(doc.get("methods"), list)
             and n not in {m.get("name") for m in doc["methods"] if isinstance(m, dict)}]
    if added:   # --with-method: part of the text, so digests, --resume and the run folder see it
        doc["methods"].extend({"name": n} for n in added)
        text = text + "\n# --with-method: methods added to the file's\n" + "".join(
            f"[[methods]]\nname = {json.dumps(n)}\n" for n in added)
    ref = reference_override()
    if ref in ("lab", "truth") and isinstance(doc.get("protocols"), list):
        # --reference lab | truth: every protocol that does not say its reference is fitted on
        # the lab's (beside its ideal-lab twin) or on the truth alone; written into the text,
        # like --with-method, so that the run folder's scenario.toml runs again as it ran
        set_ = [i for i, p in enumerate(doc["protocols"])
                if isinstance(p, dict) and "reference" not in p]
        for i in set_:
            doc["protocols"][i]["reference"] = ref
        if set_:
            text = _with_references(text, set_, [str(doc["protocols"][i].get("name"))
                                                 for i in set_], ref)
    top = _Table(doc, "top level", file)
    sc = _Table(top.get("scenario", "table"), "[scenario]", file)
    name = sc.get("name", "name")
    description = sc.get("description", "str", "")
    fs = sc.get("sample_rate_hz", "float", lo=0.0, lo_open=True, hi=10_000.0)
    ambient = sc.get("ambient_c", "float", 20.0, lo=-80.0, hi=150.0)
    sc.done()
    table = _table_cfg(_Table(top.get("table", "table", {}), "[table]", file))
    fog_tbl = _Table(top.get("fog", "table"), "[fog]", file)
    fog, preset, source, axes, thermal_model, changed = _fog(fog_tbl, fs)
    device = fog_tbl.data.get("device")
    if isinstance(device, str):   # the device file's text goes with the scenario's: a digest
        # (--resume), the copy in a run's folder and the report hold what the run ran
        dpath = path.parent / device
        draw = decode_text(dpath.read_bytes(), str(dpath))
        text = text + (f"\n# [fog] device = {json.dumps(device)}: that file's text, as this run "
                       f"read it (sha256 {hashlib.sha256(draw.encode()).hexdigest()}):\n"
                       + "".join(f"#   {ln}\n" for ln in draw.splitlines()))
    default_thermal = None
    if top.has("thermal"):
        default_thermal = _thermal(_Table(top.get("thermal", "table"), "[thermal]", file))
    runs = []
    seen = set()
    run_tables = top.get("runs", "tables")
    if not run_tables:
        raise top.err("runs", "expected at least one [[runs]] table")
    for i, rt in enumerate(run_tables):
        r = _Table(rt, f"[[runs]][{i}]", file)
        rname = r.get("name", "name")
        if rname in seen:
            raise r.err("name", f"run names must be unique; {rname!r} appears twice")
        seen.add(rname)
        r.where = f"[[runs]] '{rname}'"
        seed = r.get("seed", "int", lo=0)
        tilt0 = math.radians(r.get("start_tilt_deg", "float", 0.0, lo=-180.0, hi=180.0))
        segs = []
        for j, mt in enumerate(r.get("motion", "tables")):
            mtab = _Table(mt, f"{r.where} motion[{j}]", file)
            seg = _motion(mtab, fs)
            _check_whole_samples(mtab, seg, fs)
            segs.append(seg)
        if not segs:
            raise r.err("motion", "expected at least one [[runs.motion]] segment")
        tilt = tilt0
        for j, seg in enumerate(segs):
            if isinstance(seg, Positions):
                msg = positions_move_fits(seg, tilt, table.tilt_slew)
                if msg:
                    raise ScenarioError(f"{file}: {r.where} motion[{j}] key 'move_s': {msg}")
                tilt = seg.tilts[-1]
            elif seg.tilt is not None:
                tilt = seg.tilt
        thermal = default_thermal
        if r.has("thermal"):
            thermal = _thermal(_Table(r.get("thermal", "table"), f"{r.where} thermal", file))
        r.done()
        runs.append(Run(rname, seed, tuple(segs), thermal, tilt0))
    _check_size(runs, fs, len(axes), file)
    extra = {}
    for sec in extra_sections:
        if top.has(sec):
            extra[sec] = top.get(sec, "any")
    # every table a scenario may hold is listed when an unknown one is refused, present or not
    top.used |= {"scenario", "table", "fog", "thermal", "runs", *extra_sections}
    top.done()
    return Scenario(path=file, name=name, description=description, fs=fs, table=table, fog=fog,
                    fog_preset=preset, fog_source=source, axes=axes, runs=tuple(runs),
                    ambient_c=ambient, extra=extra, text=text, thermal_model=thermal_model,
                    fog_changed=changed, overrides=dict(overrides or {}))


# =============================================================================================
# The compensation part of a scenario file: protocols, methods, bounds and the papers' figures.
#
#
# ``[[protocols]]`` say which samples fit the methods and which score them. A selection is a run
# name, or a table ``{run = "name", segments = [i, ...], start_s = a, end_s = b, stride = k,
# offset = j, static_only = true, settle_s = s}`` (settle_s: the first s seconds of each
# selected segment left out, a rate table's transients); ``run = "*"`` makes the protocol per-run: each run is fitted on
# its own fit selection and scored on its own score selection (re-calibration at every switch-on).
# Scoring on samples a method was fitted on is refused, unless the protocol says
# ``in_sample = true`` (reproducing a paper's own protocol), and then the scenario must also have a
# held-out protocol, and every report flags the in-sample one.
#
# ``[[methods]]`` name registered fogcomp methods with hyperparameter overrides (``params``).
# ``[[bounds]]`` give the interval a metric must stay in for ``fogbench suite --check``.
# ``[[paper]]`` give a paper's published figure to show beside ours.


METRIC_NAMES = {
    "std_dps", "std_dph", "rmse_dph", "rmse_dps", "bias_stability_100s_dph", "angle_error_final_deg",
    "angle_error_max_deg", "arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
    "bias_instability_floor_dph", "gm_sigma_dph", "gm_tau_s",
    "fit_time_s", "compensate_time_s", "improvement_std_pct", "improvement_rmse_pct",
    "improvement_bias_stability_pct", "coef_rms_error_dph", "drift_rms_dph",
    "improvement_drift_pct", "mean_error_dph", "coef_rms_stderr_dph", "coef_z_rms",
}


@dataclass(frozen=True)
class Selection:
    run: str                      # a run name, or "*" (the run being scored)
    segments: tuple[int, ...] = ()
    start_s: float | None = None
    end_s: float | None = None
    stride: int = 1
    offset: int = 0
    static_only: bool = False
    settle_s: float = 0.0         # left out at the start of each selected segment (transients)

    def describe(self) -> str:
        parts = [self.run]
        if self.segments:
            parts.append(f"segments {list(self.segments)}")
        if self.start_s is not None or self.end_s is not None:
            parts.append(f"{self.start_s or 0:g}..{'' if self.end_s is None else f'{self.end_s:g}'} s")
        if self.stride > 1:
            parts.append(f"every {self.stride}-th sample from #{self.offset}")
        if self.static_only:
            parts.append("static samples only")
        if self.settle_s:
            parts.append(f"the first {self.settle_s:g} s of each segment left out")
        return ", ".join(parts)


@dataclass(frozen=True)
class Protocol:
    name: str
    description: str
    fit: tuple[Selection, ...]
    score: tuple[Selection, ...]
    per_run: bool
    runs: tuple[str, ...]          # the runs a per-run protocol walks through
    in_sample: bool
    skip_s: float
    smooth_s: float | None
    reference: str = "truth"       # what the fit is handed: "truth" (an ideal lab) or "lab"
    twin_of: str | None = None     # the lab protocol this one is the ideal-lab reading of

    @property
    def seed_name(self) -> str:
        """The name random starts derive from: an ideal-lab twin draws its lab protocol's, so
        that the two readings differ by the reference alone."""
        return self.twin_of or self.name


@dataclass(frozen=True)
class MethodSpec:
    name: str
    label: str
    params: dict
    group: str | None = None        # the [[methods]] label a sweep member belongs to
    setting: dict = field(default_factory=dict)   # the swept values of this member
    paper_setting: bool = False     # this member has the paper's (or the default) values
    failed: str | None = None       # a plug-in that cannot run: why (reported, the run goes on)


@dataclass(frozen=True)
class Bound:
    protocol: str
    method: str
    metric: str
    run: str | None
    lo: float | None
    hi: float | None
    note: str
    relative_to: str | None = None  # min/max are ratios to this row's value (e.g. "raw")


@dataclass(frozen=True)
class PaperValue:
    method: str
    metric: str
    run: str | None
    value: float
    source: str
    segment: str | None = None


@dataclass(frozen=True)
class Claim:
    """A paper's claim as a number: ``better`` improves ``metric`` over ``than`` by a percentage
    100 (1 - better / than) inside [min_pct, max_pct] (mean over the scored runs, or ``run``)."""

    text: str
    source: str
    metric: str
    better: str
    than: str
    min_pct: float | None
    max_pct: float | None
    run: str | None = None


#: Longest a method's fit (and, separately, its compensation of one piece) may take, s, before it
#: is stopped and reported as failed ([compensation] fit_timeout_s; fogbench run/suite
#: --fit-timeout-s). The slowest built-in fit of the suite (wnn, paper 003's 13,000 samples) takes
#: about a minute on a laptop core.
DEFAULT_FIT_TIMEOUT_S = 600.0
#: The environment variable ``--fit-timeout-s`` sets: it overrides the file's fit_timeout_s.
FIT_TIMEOUT_ENV = "FOGBENCH_FIT_TIMEOUT_S"
#: The environment variable ``--with-method`` sets (names separated by commas): methods added
#: to every scenario that has [[methods]] (unless it names them already), with their defaults.
WITH_METHODS_ENV = "FOGBENCH_WITH_METHODS"

#: The environment variable ``--reference`` sets: "lab" fits every protocol that does not name
#: its reference on the lab's references (each beside its ideal-lab twin, <name>.ideal).
REFERENCE_ENV = "FOGBENCH_REFERENCE"
_ENV_KEYS = (FIT_TIMEOUT_ENV, WITH_METHODS_ENV, REFERENCE_ENV)


def method_environment() -> dict:
    """The environment variables --with-method, --fit-timeout-s and --reference set here."""
    return {k: os.environ[k] for k in _ENV_KEYS if os.environ.get(k)}


@contextlib.contextmanager
def method_environment_set(env: dict):
    """Exactly ``env`` for those variables while the code inside runs (a replicate on a
    forkserver or Dask worker, which has its own environment; a command's flags), then what was
    there before."""
    keys = _ENV_KEYS
    before = {k: os.environ.get(k) for k in keys}
    for k in keys:
        if env.get(k):
            os.environ[k] = env[k]
        else:
            os.environ.pop(k, None)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def reference_override() -> str | None:
    """``--reference``'s value ("lab" or "truth"), None when not given (``REFERENCE_ENV``)."""
    return os.environ.get(REFERENCE_ENV) or None


def with_methods() -> list[str]:
    """The method names ``--with-method`` adds to every scenario (``WITH_METHODS_ENV``)."""
    return [n for n in os.environ.get(WITH_METHODS_ENV, "").split(",") if n]


@dataclass(frozen=True)
class Plan:
    """A scenario's compensation plan (protocols, methods, bounds, claims, replicates)."""

    protocols: tuple[Protocol, ...]
    methods: tuple[MethodSpec, ...]
    bounds: tuple[Bound, ...]
    paper: tuple[PaperValue, ...]
    axis: str
    ci: bool = False
    notes: tuple[str, ...] = field(default=())
    claims: tuple[Claim, ...] = field(default=())
    replicates: int = 1            # [montecarlo] replicates: power-ons drawn anew per replicate
    method_seeds: int = 1          # [montecarlo] method_seeds: random starts per fit
    mc_seed: int | None = None     # [montecarlo] seed (default: a hash of the scenario name)
    map: "MapSpec | None" = None   # [map]: the claims at other values of open keys
    fit_timeout_s: float = DEFAULT_FIT_TIMEOUT_S   # [compensation]: per fit and per compensate
    lab: "LabKnowledge | None" = None   # [lab]: what the lab believes (protocols reference = "lab")


def _segment_bounds(run: Run, fs: float) -> list[tuple[int, int]]:
    out, a = [], 0
    for seg in run.motion:
        n = int(round(seg.duration * fs))
        out.append((a, a + n))
        a += n
    return out


def select_indices(sel: Selection, run: Run, fs: float, skip_s: float,
                   table_rate: np.ndarray | None = None) -> np.ndarray:
    """Sample indices of ``run`` picked by ``sel`` (before smoothing)."""
    n = int(round(run.duration * fs))
    mask = np.zeros(n, dtype=bool)
    if sel.segments:
        bounds = _segment_bounds(run, fs)
        for i in sel.segments:
            a, b = bounds[i]
            mask[min(b, a + int(round(sel.settle_s * fs))):b] = True
    else:
        mask[:] = True
    t = np.arange(n) / fs
    if sel.start_s is not None:
        mask &= t >= sel.start_s - 1e-9
    if sel.end_s is not None:
        mask &= t < sel.end_s - 1e-9
    mask &= t >= skip_s - 1e-9
    if sel.static_only:
        if table_rate is None:
            raise ValueError("static_only needs the table's rate")
        mask &= np.linalg.norm(table_rate, axis=1) < 1e-4
    idx = np.flatnonzero(mask)
    if sel.stride > 1:
        idx = idx[sel.offset::sel.stride]
    return idx


def stride_blocks(prot_smooth_s, fs):
    """Samples per stride step: with smoothing a stride picks smoothed blocks, not samples."""
    return 1 if not prot_smooth_s else int(round(prot_smooth_s * fs))


def _selection(v, where: str, file: str, run_names: set[str], runs: dict[str, Run],
               allow_star: bool) -> Selection:
    if isinstance(v, str):
        v = {"run": v}
    t = _Table(v, where, file)
    run = t.get("run", "str")
    if run == "*":
        if not allow_star:
            raise t.err("run", "'*' (each run) is allowed only when every selection of the "
                        "protocol uses it")
    elif run not in run_names:
        raise t.err("run", f"expected one of the scenario's runs {sorted(run_names)}, got {run!r}")
    segs = tuple(t.get("segments", "ints", [], lo=0))
    nseg = min(len(r.motion) for r in runs.values()) if run == "*" else len(runs[run].motion)
    for s in segs:
        if s >= nseg or s != int(s):
            raise t.err("segments", f"expected segment indices 0..{nseg - 1}, got {list(segs)}")
    sel = Selection(
        run=run, segments=segs,
        start_s=t.get("start_s", "float", None, lo=0.0),
        end_s=t.get("end_s", "float", None, lo=0.0, lo_open=True),
        stride=t.get("stride", "int", 1, lo=1),
        offset=t.get("offset", "int", 0, lo=0),
        static_only=t.get("static_only", "bool", False),
        settle_s=t.get("settle_s", "float", 0.0, lo=0.0, hi=1e6),
    )
    if sel.settle_s and not sel.segments:
        raise t.err("settle_s", "leaves out the start of each selected segment: give "
                    "'segments' too")
    if sel.offset >= sel.stride and sel.stride > 1:
        raise t.err("offset", f"expected 0 <= offset < stride = {sel.stride}, got {sel.offset}")
    t.done()
    return sel


_WARNED: set = set()


def _plugin_warning(file, label: str, why: str) -> None:
    import sys

    if (str(file), label) in _WARNED:       # once per process (load_plan runs per replicate)
        return
    _WARNED.add((str(file), label))
    print(f"fogbench: warning: {file}: method {label!r} will be reported as failed: {why}",
          file=sys.stderr)


def load_plan(sc: Scenario) -> Plan:
    """Validate the scenario's [[protocols]], [[methods]], [[bounds]] and [[paper]] tables.

    A method name is a built-in, an entry point of the group ``fogcomp.methods`` or
    ``module:Class`` of an installed module (its code runs: the scenario names it). Unknown
    names and bad hyperparameters are refused naming the key; a plug-in that is installed but
    does not import, is no usable method, or whose constructor raises is kept with ``failed``
    set (the run reports it as failed and goes on)."""
    from fogcomp import PluginError, get_method, make_method

    file = sc.path
    extra = _Table(dict(sc.extra), "top level", file)
    runs = {r.name: r for r in sc.runs}
    names = set(runs)

    opts = _Table(extra.get("compensation", "table", {}), "[compensation]", file)
    axis = opts.get("axis", "str", sc.axes[0], choices=set(sc.axes))
    ci = opts.get("ci", "bool", False)
    notes = tuple(opts.get("notes", "strs", []))
    fit_timeout_s = opts.get("fit_timeout_s", "float", DEFAULT_FIT_TIMEOUT_S, lo=0.0,
                             hi=86_400.0, lo_open=True)
    if os.environ.get(FIT_TIMEOUT_ENV):
        try:
            fit_timeout_s = float(os.environ[FIT_TIMEOUT_ENV])
        except ValueError:
            fit_timeout_s = math.nan
        if not 0.0 < fit_timeout_s <= 86_400.0:
            raise ScenarioError(f"environment variable {FIT_TIMEOUT_ENV} (--fit-timeout-s): "
                                "expected seconds in (0, 86400], got "
                                f"{os.environ[FIT_TIMEOUT_ENV]!r}")
    opts.done()

    protocols = []
    ptabs = extra.get("protocols", "tables")
    if not ptabs:
        raise extra.err("protocols", "expected at least one [[protocols]] table")
    for i, pt in enumerate(ptabs):
        t = _Table(pt, f"[[protocols]][{i}]", file)
        pname = t.get("name", "name")
        t.where = f"[[protocols]] '{pname}'"
        fit_raw = t.get("fit", "any")
        score_raw = t.get("score", "any")
        for key, val in (("fit", fit_raw), ("score", score_raw)):
            if not isinstance(val, list) or not val:
                raise t.err(key, "expected a non-empty list of selections (run names or tables)")
        star = [(s == "*" or (isinstance(s, dict) and s.get("run") == "*"))
                for s in fit_raw + score_raw]
        per_run = all(star)
        fit = tuple(_selection(s, f"{t.where} fit[{j}]", file, names, runs, per_run)
                    for j, s in enumerate(fit_raw))
        score = tuple(_selection(s, f"{t.where} score[{j}]", file, names, runs, per_run)
                      for j, s in enumerate(score_raw))
        prot_runs = tuple(t.get("runs", "strs", sorted(names) if per_run else [], choices=names))
        if prot_runs and not per_run:
            raise t.err("runs", "only a per-run protocol (run = '*') takes 'runs'")
        prot = Protocol(
            name=pname, description=t.get("description", "str", ""), fit=fit, score=score,
            per_run=per_run, runs=tuple(r for r in [x.name for x in sc.runs] if r in prot_runs),
            in_sample=t.get("in_sample", "bool", False),
            skip_s=t.get("skip_s", "float", 0.0, lo=0.0),
            smooth_s=t.get("smooth_s", "float", None, lo=0.0, lo_open=True),
            reference=t.get("reference", "str", None, choices={"truth", "lab"}),
        )
        if prot.smooth_s is not None:
            k = prot.smooth_s * sc.fs
            if abs(k - round(k)) > 1e-9 or round(k) < 1:
                raise t.err("smooth_s", f"expected a whole number of samples at "
                            f"{sc.fs:g} Hz, got {prot.smooth_s:g} s")
        t.done()
        _check_overlap(prot, sc, file)
        protocols.append(prot)
    if any(p.in_sample for p in protocols) and all(p.in_sample for p in protocols):
        raise extra.err("protocols", "an in_sample protocol must stand beside a held-out one "
                        "(in_sample = false) in the same scenario")

    methods = []
    for i, mt in enumerate(extra.get("methods", "tables")):
        t = _Table(mt, f"[[methods]][{i}]", file)
        mname = t.get("name", "str")
        params = dict(t.get("params", "table", {}))
        label = t.get("label", "name", mname.rpartition(":")[2] if ":" in mname else mname)
        try:
            cls = get_method(mname)
        except PluginError as exc:      # installed but unusable: reported as failed, run goes on
            msg = name_problem(label)
            if msg:
                raise t.err("label", msg) from None
            t.get("sweep", "table", None)
            t.done()
            _plugin_warning(file, label, str(exc))
            methods.append(MethodSpec(mname, label, params, failed=str(exc)))
            continue
        except KeyError as exc:
            raise t.err("name", exc.args[0]) from None
        builtin = cls.__module__.startswith("fogcomp.")
        sweep = t.get("sweep", "table", None)
        members = [({}, True)]
        if sweep is not None:
            members = _sweep_members(t, mname, params, sweep)
        for setting, paper in members:
            # "default" in a sweep: the constructor's default (which TOML cannot write: None)
            full = {**params, **{k: v for k, v in setting.items() if v != SWEEP_DEFAULT}}
            failed = None
            try:
                make_method(mname, **full).check_params()
            except (TypeError, ValueError) as exc:
                what = f"method {label!r}" + (f" with {setting}" if setting else "")
                raise t.err("sweep" if setting else "params", f"{what}: {exc}") from None
            except Exception as exc:  # noqa: BLE001 (a plug-in's constructor may do anything)
                if builtin:
                    raise
                failed = (f"method {mname!r}: its constructor or check_params raised "
                          f"{type(exc).__name__}: {exc}")
                _plugin_warning(file, label, failed)
            mlabel = label if not setting else label + "." + ".".join(
                f"{k}-{v}" for k, v in setting.items())
            msg = name_problem(mlabel)
            if msg:
                raise t.err("sweep", f"member label {msg}")
            methods.append(MethodSpec(mname, mlabel, full, group=label if sweep else None,
                                      setting=setting, paper_setting=paper, failed=failed))
        t.done()
    if not methods:
        raise extra.err("methods", "expected at least one [[methods]] table")
    labels = [m.label for m in methods]
    if len(set(labels)) != len(labels):
        raise extra.err("methods", f"method labels must be unique (give 'label'); got {labels}")
    # A protocol that does not name its reference models a lab's calibration when a method of
    # the scenario is supervised (handed a reference rate, and gravity if it wants it): it is
    # fitted on what a lab has (reference = "lab", sim/lab.py), never on the truth. Where no
    # method is handed a reference, the reference changes nothing and "truth" stands (no twin).
    supervised = any(m.failed is None and get_method(m.name).supervised for m in methods)
    protocols = [p if p.reference is not None else
                 replace(p, reference="lab" if supervised else "truth") for p in protocols]
    # every protocol fitted on the lab's references is also run on the truth (the ideal lab),
    # beside it, named <name>.ideal: the paired difference is what the lab's references cost
    for p in protocols:
        if p.reference == "lab" and name_problem(f"{p.name}.ideal"):
            raise extra.err("protocols", f"protocol {p.name!r} has reference = \"lab\": its twin "
                            f"'{p.name}.ideal' must also be a name: {name_problem(p.name + '.ideal')}")
    protocols += [replace(p, name=f"{p.name}.ideal", reference="truth", twin_of=p.name,
                          description=f"{p.description} (ideal lab: fitted on the truth)".strip())
                  for p in protocols if p.reference == "lab"]
    if len({p.name for p in protocols}) != len(protocols):
        raise extra.err("protocols", "protocol names must be unique (a protocol with reference "
                        "= \"lab\" adds <name>.ideal)")

    known_methods = set(labels) | {"raw", "oracle"}
    bound_methods = known_methods | {m.group for m in methods if m.group}  # a group: each member
    pnames = {p.name for p in protocols}
    bounds = []
    for i, bt in enumerate(extra.get("bounds", "tables", [])):
        t = _Table(bt, f"[[bounds]][{i}]", file)
        b = Bound(protocol=t.get("protocol", "str", choices=pnames),
                  method=t.get("method", "str", choices=bound_methods),
                  metric=t.get("metric", "str", choices=METRIC_NAMES),
                  run=t.get("run", "str", None, choices=names),
                  lo=t.get("min", "float", None), hi=t.get("max", "float", None),
                  note=t.get("note", "str", ""),
                  relative_to=t.get("relative_to", "str", None, choices=known_methods))
        if b.lo is None and b.hi is None:
            raise t.err("max", "a bound needs 'min', 'max' or both")
        if b.lo is not None and b.hi is not None and not b.lo <= b.hi:
            raise t.err("max", f"expected min <= max, got min = {b.lo}, max = {b.hi}")
        t.done()
        bounds.append(b)

    paper = []
    for i, pt in enumerate(extra.get("paper", "tables", [])):
        t = _Table(pt, f"[[paper]][{i}]", file)
        paper.append(PaperValue(method=t.get("method", "str", choices=known_methods),
                                metric=t.get("metric", "str", choices=METRIC_NAMES),
                                run=t.get("run", "str", None, choices=names),
                                value=t.get("value", "float"), source=t.get("source", "str"),
                                segment=t.get("segment", "str", None)))
        t.done()

    claims = []
    for i, ct in enumerate(extra.get("claims", "tables", [])):
        t = _Table(ct, f"[[claims]][{i}]", file)
        c = Claim(text=t.get("text", "str"), source=t.get("source", "str"),
                  metric=t.get("metric", "str", choices=METRIC_NAMES),
                  better=t.get("better", "str", choices=known_methods),
                  than=t.get("than", "str", choices=known_methods),
                  min_pct=t.get("min_pct", "float", None), max_pct=t.get("max_pct", "float", None),
                  run=t.get("run", "str", None, choices=names))
        if c.min_pct is None and c.max_pct is None:
            raise t.err("min_pct", "a claim needs 'min_pct', 'max_pct' or both")
        t.done()
        claims.append(c)
    mc = _Table(extra.get("montecarlo", "table", {}), "[montecarlo]", file)
    replicates = mc.get("replicates", "int", 1, lo=1, hi=MAX_REPLICATES)
    method_seeds = mc.get("method_seeds", "int", 1, lo=1, hi=1000)
    mc_seed = mc.get("seed", "int", None, lo=0, hi=2**63 - 1)
    mc.done()
    lab = _lab_knowledge(_Table(extra.get("lab", "table", {}), "[lab]", file))
    if lab is not None and not any(p.reference == "lab" for p in protocols):
        raise extra.err("lab", "no protocol has reference = \"lab\": the [lab] keys would "
                        "change nothing")
    extra.used.add("map")
    extra.done()
    plan = Plan(tuple(protocols), tuple(methods), tuple(bounds), tuple(paper), axis, ci, notes,
                tuple(claims), replicates, method_seeds, mc_seed, fit_timeout_s=fit_timeout_s,
                lab=lab)
    spec = _load_map(extra, sc, plan)
    return replace(plan, map=spec) if spec is not None else plan


def _lab_knowledge(t: _Table):
    """[lab]: what the lab believes of its table and site (``sim.lab.LabKnowledge``), as errors
    against the truth; None when the section is absent (protocols with reference = "lab" then
    use a lab that knows its site and table exactly, but still only their commands)."""
    if not t.data:
        t.done()
        return None
    arcsec = _ARCSEC
    lab = LabKnowledge(
        latitude_error=math.radians(t.get("latitude_error_deg", "float", 0.0, lo=-10.0, hi=10.0)),
        heading_error=math.radians(t.get("heading_error_deg", "float", 0.0, lo=-10.0, hi=10.0)),
        tilt_zero_error=t.get("tilt_zero_error_arcsec", "float", 0.0, lo=-3600.0,
                              hi=3600.0) * arcsec,
        radius_error=t.get("radius_error_mm", "float", 0.0, lo=-100.0, hi=100.0) * 1e-3,
        encoder_resolution=t.get("encoder_resolution_arcsec", "float", 0.0, lo=0.0,
                                 hi=3600.0) * arcsec,
        rate_source=t.get("rate_source", "str", "command", choices={"command", "encoder"}),
        # the accelerometer triad (gravity_source = "accelerometer"), defaults 0; class values
        # and sources in sim.lab.CLASS_VALUES (tactical MEMS: Xsens MTi-1, 0.03 mg bias
        # instability, 120 ug/sqrt(Hz)). Limits: 1e5 ug (0.1 g, beyond a MEMS part's raw
        # offset, BMI160 +-60 mg), 1e5 ppm (10 %), 1e4 ug/sqrt(Hz) (MEMS parts: 75-160).
        gravity_source=t.get("gravity_source", "str", "command",
                             choices={"command", "accelerometer"}),
        acc_bias=tuple(v * 1e-6 * U.G0 for v in _triple(t, "acc_bias_ug", 1e5)),
        acc_scale_factor=tuple(v * 1e-6 for v in _triple(t, "acc_scale_factor_ppm", 1e5)),
        acc_noise_density=t.get("acc_noise_ug_rt_hz", "float", 0.0, lo=0.0, hi=1e4)
        * 1e-6 * U.G0)
    if lab.encoder_resolution and lab.rate_source != "encoder":
        raise t.err("encoder_resolution_arcsec", "applies only with rate_source = \"encoder\" "
                    "(the commanded rate has no encoder steps)")
    if lab.gravity_source != "accelerometer":
        for key in ("acc_bias_ug", "acc_scale_factor_ppm", "acc_noise_ug_rt_hz"):
            if t.has(key):
                raise t.err(key, "applies only with gravity_source = \"accelerometer\" (the "
                            "commanded attitude has no accelerometer)")
    t.done()
    return lab


def _triple(t: _Table, key: str, limit: float) -> tuple[float, float, float]:
    """A per-axis key: one number (every axis) or [x, y, z], each within +-limit."""
    if isinstance(t.data.get(key), list):
        v = t.get(key, "floats", lo=-limit, hi=limit)
        if len(v) != 3:
            raise t.err(key, f"expected one number or [x, y, z], got {len(v)} values")
        return v[0], v[1], v[2]
    v = t.get(key, "float", 0.0, lo=-limit, hi=limit)
    return v, v, v


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


@dataclass(frozen=True)
class MapAxis:
    """One axis of a claim map: its points, each a label and the values it sets."""

    name: str
    source: str
    labels: tuple[str, ...]
    sets: tuple[dict, ...]
    numeric: tuple[float, ...] | None = None   # a value per point, for a numeric x axis


@dataclass(frozen=True)
class MapPoint:
    """A point of the map: one point of each axis, the values they set together."""

    index: tuple[int, ...]
    labels: tuple[str, ...]
    overrides: dict
    is_base: bool

    @property
    def label(self) -> str:
        return ", ".join(self.labels)


@dataclass(frozen=True)
class MapSpec:
    """A scenario's ``[map]``: one or two axes, the replicates (and method starts) per point,
    the metrics shown at every point beside the claims."""

    axes: tuple[MapAxis, ...]
    replicates: int | None
    points: tuple[MapPoint, ...]
    method_seeds: int | None = None
    metrics: tuple[tuple[str, str, str], ...] = ()   # (protocol, method label, metric)


MAX_MAP_POINTS = 25


def _read_toml(path) -> dict:
    file = str(path)
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{file}: cannot read ({exc.strerror})") from None
    try:
        return tomllib.loads(decode_text(raw, file))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{file}: not valid TOML ({exc})") from None


def map_file_scenario(path) -> Path | None:
    """The scenario a map file names (``scenario = "../paper004_flnn.toml"``, relative to the
    map file), or None when ``path`` is a scenario file (its ``[scenario]`` is a table)."""
    if Path(path).is_dir():
        return None
    try:
        doc = _read_toml(path)
    except ScenarioError:
        return None      # load_scenario names the problem
    v = doc.get("scenario")
    if not isinstance(v, str):
        return None
    target = Path(os.path.normpath(Path(path).parent / v))
    if not target.is_file():
        raise ScenarioError(f"{path}: key 'scenario': {v!r} ({target}) is not a file; a map "
                            "file names its scenario relative to itself")
    return target


def load_map_file(path, sc: "Scenario", plan: "Plan") -> MapSpec:
    """A map file: ``scenario = "<its scenario file, relative to the map file>"`` and one
    ``[map]`` table, as a scenario's, that replaces the scenario's own (a denser map of the same
    scenario: ``fogbench run scenarios/maps/paper004_flnn.toml``)."""
    file = str(path)
    top = _Table(_read_toml(path), "top level", file)
    top.get("scenario", "str")
    if not top.has("map"):
        raise ScenarioError(f"{file}: a map file holds its scenario's path and one [map] "
                            "table (with its [[map.axes]]); this one has no [map]")
    top.used.add("map")
    top.done()
    return _load_map(top, sc, plan, where=file)


def _load_map(extra: "_Table", sc: "Scenario", plan: "Plan",
              where: str | None = None) -> MapSpec | None:
    """``[map]``: ``replicates`` (per point; default the scenario's), ``method_seeds``,
    ``metrics`` (``"protocol.method.metric"`` shown at every point) and one or two
    ``[[map.axes]]``, each ``name``, ``source`` (where its range comes from) and either ``key``
    with ``values`` (and optional ``labels``) or ``points``, an array of tables ``{label, set =
    {"dotted.path" = value, ...}, unset = ["dotted.path", ...]}`` (``unset``: keys the point
    removes, e.g. ``fog.preset`` where it names a device file). Every point is validated as a
    scenario of its own.
    ``where``: the file errors name (a map file; default the scenario)."""
    import itertools

    if not extra.has("map"):
        return None
    file = sc.path
    where = where or file
    mt = _Table(extra.get("map", "table"), "[map]", where)
    replicates = mt.get("replicates", "int", None, lo=1, hi=MAX_REPLICATES)
    method_seeds = mt.get("method_seeds", "int", None, lo=1, hi=1000)
    metrics = []
    for m in mt.get("metrics", "strs", []):
        bits = m.split(".")
        if len(bits) != 3 or not all(bits):
            raise mt.err("metrics", f"{m!r}: expected 'protocol.method.metric', e.g. "
                         "'held_out.kalman.std_dps'")
        metrics.append(tuple(bits))
    protocols = {p.name for p in plan.protocols}
    labels_ = {m.label for m in plan.methods} | {"raw", "oracle", "oracle_filter"}
    for prot, meth, metric in metrics:
        what = f"{prot}.{meth}.{metric}"
        if prot not in protocols:
            raise mt.err("metrics", f"{what!r}: no protocol {prot!r}; protocols: "
                         f"{sorted(protocols)}")
        if meth not in labels_:
            raise mt.err("metrics", f"{what!r}: no method labelled {meth!r}; methods: "
                         f"{sorted(labels_)}")
        if metric not in METRIC_NAMES:
            raise mt.err("metrics", f"{what!r}: {metric!r} is not a metric; metrics: "
                         f"{sorted(METRIC_NAMES)}")
    axes = []
    for i, at in enumerate(mt.get("axes", "tables")):
        t = _Table(at, f"[[map.axes]][{i}]", where)
        name = t.get("name", "str")
        t.where = f"[[map.axes]] '{name}'"
        source = t.get("source", "str")
        if t.has("key") == t.has("points"):
            raise t.err("key", "give either key and values, or points")
        labels, sets, numeric = [], [], None
        if t.has("key"):
            key = t.get("key", "str")
            values = t.get("values", "any")
            if not isinstance(values, list) or not values:
                raise t.err("values", f"expected a non-empty list of values, got {values!r}")
            given = t.get("labels", "strs", None)
            if given is not None and len(given) != len(values):
                raise t.err("labels", f"expected {len(values)} labels, one per value")
            for j, v in enumerate(values):
                labels.append(given[j] if given else f"{key.split('.')[-1]} = {v}")
                sets.append({key: v})
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
                numeric = tuple(float(v) for v in values)
        else:
            for j, pt in enumerate(t.get("points", "tables")):
                p = _Table(pt, f"{t.where} points[{j}]", where)
                labels.append(p.get("label", "str"))
                st = dict(p.get("set", "table", {}))
                for path in p.get("unset", "strs", []):   # keys the point removes
                    if path in st:
                        raise p.err("unset", f"{path!r} is also in set")
                    st[path] = None
                sets.append(st)
                p.done()
        t.done()
        if len(set(labels)) != len(labels):
            raise ScenarioError(f"{where}: {t.where}: point labels must be unique, got {labels}")
        axes.append(MapAxis(name, source, tuple(labels), tuple(sets), numeric))
    if not 1 <= len(axes) <= 2:
        raise mt.err("axes", f"expected one or two [[map.axes]], got {len(axes)}")
    mt.done()
    points = []
    for combo in itertools.product(*(range(len(a.labels)) for a in axes)):
        over: dict = {}
        for a, k in zip(axes, combo):
            for path, v in a.sets[k].items():
                if path in over and over[path] != v:
                    raise ScenarioError(f"{where}: [map]: axes set {path!r} twice, to "
                                        f"{over[path]!r} and {v!r}")
                over[path] = v
        points.append((combo, over))
    if len(points) > MAX_MAP_POINTS:
        raise mt.err("axes", f"{len(points)} points; at most {MAX_MAP_POINTS}")
    out = []
    own = _fingerprint(sc)
    for combo, over in points:  # every point is a scenario: validated now, before any work
        labels = tuple(a.labels[k] for a, k in zip(axes, combo))
        try:
            psc = load_scenario(file, extra_sections=RUNNER_SECTIONS, overrides=over)
            load_plan(psc)
        except ScenarioError as exc:
            msg = str(exc).removeprefix(f"{file}: ")
            raise ScenarioError(f"{where}: [map] point {', '.join(labels)!r}: {msg}") from None
        # the point that runs the file as written (its values set to what the file, or its
        # preset, already has) is the scenario itself
        out.append(MapPoint(tuple(combo), labels, over, _fingerprint(psc) == own))
    return MapSpec(tuple(axes), replicates, tuple(out), method_seeds, tuple(metrics))


def _fingerprint(sc: "Scenario") -> str:
    """Everything a run of ``sc`` depends on (not its text): equal for two files that run
    the same."""
    extra = {k: v for k, v in sc.extra.items() if k != "map"}
    return repr((sc.fs, sc.table, sc.fog, sc.fog_preset, sc.axes, sc.runs, sc.ambient_c,
                 sc.thermal_model)) + json.dumps(extra, sort_keys=True, default=repr)


def claim_name(first_file: dict, sc: Scenario, path) -> None:
    """Record that ``path`` holds scenario ``sc``; refuse a name another file in the same set
    already has (each scenario names its report folder)."""
    if sc.name in first_file:
        raise ScenarioError(f"{path}: [scenario] key 'name': {sc.name!r} is also the name of "
                            f"{first_file[sc.name]}; scenario names must be unique in a suite "
                            "(each names its report folder)")
    first_file[sc.name] = path


def expand(prot: Protocol, sc: Scenario) -> list[tuple[list[Selection], list[Selection]]]:
    """(fit selections, score selections) pairs with '*' resolved to run names."""
    if not prot.per_run:
        return [(list(prot.fit), list(prot.score))]
    out = []
    for rname in prot.runs:
        sub = lambda s: replace(s, run=rname)  # noqa: E731
        out.append(([sub(s) for s in prot.fit], [sub(s) for s in prot.score]))
    return out


def _selected_samples(s: Selection, prot: Protocol, run: Run, fs: float) -> np.ndarray:
    """Raw sample indices a selection touches (a stride over smoothed blocks keeps whole
    blocks). static_only can only shrink a selection, so it is left out (conservative)."""
    k = stride_blocks(prot.smooth_s, fs)
    if k == 1:
        return select_indices(replace(s, static_only=False), run, fs, prot.skip_s)
    idx = select_indices(replace(s, static_only=False, stride=1, offset=0), run, fs,
                         prot.skip_s)
    if s.stride == 1:
        return idx
    parts = [p for p in np.split(idx, np.flatnonzero(np.diff(idx) != 1) + 1) if p.size >= k]
    blocks = [p[i * k:(i + 1) * k] for p in parts for i in range(p.size // k)]
    keep = blocks[s.offset::s.stride]
    return np.concatenate(keep) if keep else idx[:0]


def _check_overlap(prot: Protocol, sc: Scenario, file: str):
    runs = {r.name: r for r in sc.runs}
    for fit, score in expand(prot, sc):
        fit_idx: dict[str, set] = {}
        for s in fit:
            idx = _selected_samples(s, prot, runs[s.run], sc.fs)
            if idx.size == 0:
                raise ScenarioError(f"{file}: [[protocols]] '{prot.name}' fit selection "
                                    f"({s.describe()}) selects no samples")
            fit_idx.setdefault(s.run, set()).update(idx.tolist())
        for s in score:
            idx = _selected_samples(s, prot, runs[s.run], sc.fs)
            if idx.size == 0:
                raise ScenarioError(f"{file}: [[protocols]] '{prot.name}' score selection "
                                    f"({s.describe()}) selects no samples")
            shared = fit_idx.get(s.run, set()).intersection(idx.tolist())
            if shared and not prot.in_sample:
                raise ScenarioError(
                    f"{file}: [[protocols]] '{prot.name}' key 'score': run {s.run!r} is scored on "
                    f"{len(shared)} samples it was fitted on; scoring on fitted data is refused "
                    "(set in_sample = true only to reproduce a paper's own protocol, beside a "
                    "held-out one)")


def positions_of(run: Run) -> list[int]:
    """Indices of a run's multi-position segments (used by reports)."""
    return [i for i, s in enumerate(run.motion) if isinstance(s, Positions)]
