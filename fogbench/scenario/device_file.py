"""A scenario's ``[fog]`` table and device files (one gyro's ``[fog]`` keys in a file of their
own, ``sim/presets.toml``'s format), and their JSON Schema taken from the validator."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from fogbench.scenario.device_triad import (
    G_SENS_LIMIT_DPH,
    check_triad_doc,
    is_triad,
    triad_fog,
)
from fogbench.scenario.tables import ScenarioError, _read_toml, _Table
from fogcomp import units as U
from sim.fog import TERMS, FogParams
from sim.rig import load_presets
from sim.thermal import (
    SENSOR_LOCATIONS,
    TempSensor,
    ThermalModel,
)

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
MISALIGNMENT_LIMIT_MRAD = 100.0


def _base(tbl: _Table, fs: float) -> tuple[dict, str | None, str, dict]:
    """The values a ``[fog]`` table starts from and sets over: (every key's value, the preset's
    or device file's name, the numbers' source, the keys the table sets over its base)."""
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
    return values, preset_name, source, changed


def _flicker_band(merged: _Table, kw: dict, fs: float) -> None:
    """``bias_instability_band_hz`` (below Nyquist) and ``bias_instability_per_decade``."""
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


def _g_terms(merged: _Table, kw: dict, axes: tuple[str, ...]) -> None:
    """``g_sens_dph_per_g`` (d1-d3) and ``g2_sens_dph_per_g2`` (d4-d9) of paper 004 eq. 8: one
    list for every axis, or one per axis."""
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


def _misalignment(merged: _Table, kw: dict) -> None:
    """``misalignment_mrad``: 3x3, a zero diagonal."""
    mis = merged.get("misalignment_mrad", "any", None)
    if mis is None:
        return
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


def _mounting(merged: _Table, input_axis: str, axes: tuple[str, ...], kw: dict,
              device: str | None) -> None:
    """A scenario whose sensitive axes are not the device's input axis: refused when the device
    has g terms (their components are along the body axes of the gyro's mounting: on another
    axis they would multiply the wrong components of the specific force), else warned of (the
    noise and the bias do not depend on the mounting)."""
    import warnings

    if axes == (input_axis,):
        return
    g = any(any(x != 0 for x in (v if isinstance(v[0], (int, float)) else
                                 [y for r in v for y in r]))
            for v in (kw.get("g_sens", (0.0,)), kw.get("g2_sens", (0.0,))))
    what = f"{device}'s" if device else "the [fog] table's"
    msg = (f"{what} input_axis = {input_axis!r} (the body axis its gyro was mounted along when "
           f"it was fitted) but the scenario's sensitive axes are axes = {list(axes)}")
    if g:
        raise merged.err("axes", msg + ": its g terms (g_sens_dph_per_g, g2_sens_dph_per_g2) are "
                         f"along the body axes of a gyro on {input_axis}, and would be applied to "
                         f"the wrong components of the specific force; set axes = "
                         f"[\"{input_axis}\"]")
    warnings.warn(f"{merged.file}: [fog]: {msg}; the device has no g terms, so its noise and "
                  f"bias are simulated on {', '.join(axes)} as fitted on {input_axis}",
                  stacklevel=2)


def _fog(tbl: _Table, fs: float, scenario: bool = False
         ) -> tuple[FogParams, str | None, str, tuple[str, ...], ThermalModel]:
    """A ``[fog]`` table (or a device file's keys) at the sample rate ``fs``: (the error
    model's parameters in SI, the preset's or device file's name, the numbers' source, the
    sensitive axes, the thermal build, the keys set over the preset). Every read is recorded
    when :attr:`_Table.recorder` is set, so the validator is the device file's schema.
    ``scenario``: a scenario's table, whose sensitive ``axes`` are checked against the device's
    ``input_axis`` (:func:`_mounting`); a device file alone has no axes to check."""
    values, preset_name, source, changed = _base(tbl, fs)
    if is_triad(values):    # a triad device file: each axis its own keys (device_triad)
        fog, axes, thermal = triad_fog(values, tbl, fs, _fog)
        return fog, preset_name, source, axes, thermal, changed
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
    _flicker_band(merged, kw, fs)
    _g_terms(merged, kw, axes)
    input_axis = merged.get("input_axis", "str", None, choices={"x", "y", "z"})
    if scenario and input_axis is not None:
        _mounting(merged, input_axis, axes, kw, preset_name)
    _misalignment(merged, kw)
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


_DESCRIPTIONS = {
    "input_axis": "the device's mounting: the body axis its gyro column measured (sign +, the "
                  "rate about +axis) in the logs it was fitted to; g_sens_dph_per_g and "
                  "g2_sens_dph_per_g2 are along those logs' body axes (acc_x, acc_y, acc_z). A "
                  "scenario whose axes differ is refused when the device has g terms, warned "
                  "otherwise; absent (older files): not checked",
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
    at_fs = {c.key for c, d in zip(calls, reads(5_000.0)) if c != d}
    props: dict = {"source": {"type": "string", "description": "where the numbers come from"}}
    types = {"float": "number", "int": "integer", "str": "string", "bool": "boolean"}
    for key, kind, lo, hi, lo_open, choices, *_ in calls:
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
        if key in _DESCRIPTIONS:
            item["description"] = _DESCRIPTIONS[key]
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
    checks at the highest rate a scenario may have. A triad device file (tables ``[x]``,
    ``[y]``, ``[z]``, :mod:`fogbench.scenario.device_triad`) has each table validated as one
    gyro's keys, and its matrices and thermal build at the top level."""
    file = str(path)
    doc = _read_toml(path, "device file")
    for k in DEVICE_FILE_REFUSED:
        if k in doc:
            raise ScenarioError(f"{file}: key '{k}': a device file holds the device's own keys "
                                f"only ({k} is the scenario's choice, in its [fog] table)")
    if is_triad(doc):
        check_triad_doc(doc, file)
    for k, v in doc.items():
        if isinstance(v, dict) and not is_triad(doc):
            raise ScenarioError(f"{file}: [{k}]: a device file has no tables, only the keys of "
                                "a [fog] table (or, a triad's, the tables [x], [y], [z])")
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
