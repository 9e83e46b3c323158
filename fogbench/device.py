"""``fogbench device``: device files (one gyro's ``[fog]`` keys, the format of
``sim/presets.toml``) shown, fitted to a user's logs, and checked against a log.

A device file holds exactly the keys of a scenario's ``[fog]`` table (datasheet units in their
names) and ``source``; a scenario runs it with ``[fog] device = "mygyro.toml"``
(:func:`fogbench.scenario.load_device_file` validates it). ``device fit`` writes one: every
value with a comment naming the log and the fit it came from and its interval; every key the
logs could not determine listed in comments with the default the simulator uses and why.
``device check`` simulates the device under a log's own conditions (sample rate, length,
gap-free pieces) over replicates and sets the log's Allan curve with its interval beside the
twin's band.

What a fit determines (``fit_device``):

- static logs: the noise terms of the composite identifier (:mod:`fogcomp.noise`) of the longest
  log; the bias (the logs' mean rate less the Earth rate's projection on the input axis, when
  the latitude is given); with two or more logs of separate power-ons the switch-on bias
  repeatability (their spread less the part each mean's own noise explains);
- an Allan curve (``--curve``): the noise terms only;
- a thermal log (``--thermal``: a constant rate through a chamber program, with the temperature
  sensor): the temperature terms and the coil's lag behind the sensor
  (:mod:`fogbench.device_thermal`), weighted by the noise model of the static logs or curve.

- a multi-position, centrifuge or rate-table log (``--multipos``, with its reference rate
  column): the g and g^2 terms of paper 004 eq. 8 and the scale factor (and its non-linearity
  with the full scale given), each term flagged identifiable from the log's design or not
  (:mod:`fogbench.device_multipos`). Misalignment is not fitted (it needs the reference rates
  about the other axes).
"""

from __future__ import annotations

import json
import math
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fogcomp.units import ARCSEC, DEG_RT_H, DPH, DPH_PER_H, DPH_RT_H, DPS

from .logformats.curve import read_curve
from .logformats.errors import LogError
from .logformats.table import MIN_RECORD_SAMPLES, fmt_number as _fmt_number, read_log
from .outdir import Outputs as _Outputs
from .reallog.allan import _curve_record
from .reallog.calibrate import reference_unit
from .reallog.console import _warnings_as_lines
from .reallog.options import _common, _source

__all__ = ["MARKER", "preset_text", "DeviceFit", "fit_device", "twin_curves", "check_device",
           "add_commands"]

MARKER = "# fogbench device fit"           # first line of a file this command wrote
CHECK_CI = 0.95                            # the log's interval and the twin's band in `check`
MAX_CHECK_REPLICATES = 1000
BAND_HIGH_HZ = 1.0                         # top of the flicker band a fit writes (below)

# identifier term -> (device key, factor from SI, how the value is stated)
_NOISE_KEYS = {
    "N": ("arw_deg_rt_h", DEG_RT_H),
    "B": ("bias_instability_dph", DPH),
    "K": ("rrw_dph_rt_h", DPH_RT_H),
    "Q": ("quantization_arcsec", ARCSEC / math.sqrt(12.0)),   # step q = sqrt(12) Q
    "R": ("rate_ramp_dph_per_h", DPH_PER_H),
}

# the keys a fit can leave undetermined, with the simulator's default and what would give them
_NEEDS = {
    "bias_dph": ("0", "a static log (its mean rate)"),
    "switch_on_bias_dph": ("0 (no switch-on change)", "two or more static logs of separate "
                           "power-ons (--static A.csv --static B.csv ...)"),
    "arw_deg_rt_h": ("0", "a static log or an Allan curve showing a slope -1/2"),
    "bias_instability_dph": ("0", "a static log or an Allan curve showing a flat floor"),
    "rrw_dph_rt_h": ("0", "a longer record (the curve does not rise with slope +1/2)"),
    "quantization_arcsec": ("0", "a record whose shortest averaging times show slope -1"),
    "rate_ramp_dph_per_h": ("0", "a record showing slope +1"),
    "gm_drift_dps": ("0", "a record showing a Gauss-Markov hump"),
    "scale_factor_ppm": ("0", "a rate-table log (--multipos LOG.csv --reference COLUMN)"),
    "sf_nonlinearity_ppm": ("0", "a rate-table log over the range (--multipos, with "
                            "--full-scale-dps)"),
    "g_sens_dph_per_g": ("[0, 0, 0]", "a multi-position log (--multipos LOG.csv --reference "
                         "COLUMN)"),
    "g2_sens_dph_per_g2": ("[0, 0, 0, 0, 0, 0]", "a centrifuge and multi-position log "
                           "(--multipos)"),
    "misalignment_mrad": ("zero", "a rate-table log with the reference rates about the other "
                          "axes (not fitted here: --reference names the input axis's only)"),
    "temp_coeff_dph_per_c": ("0", "a thermal log (--thermal)"),
    "temp_coeff2_dph_per_c2": ("0", "a thermal log (--thermal)"),
    "temp_rate_coeff_dph_per_c_per_min": ("0", "a thermal log with ramps (--thermal)"),
    "temp_cross_coeff_dph_per_c_per_c_per_min": ("0", "a thermal log with ramps (--thermal)"),
    "coil_time_constant_s": ("600", "a thermal log whose sensor the coil lags (--thermal)"),
}


def preset_text(name: str) -> str:
    """A preset of ``sim/presets.toml`` as a device file: its lines, comments (the source of
    every number) included, without the section header."""
    from sim.rig import PRESETS_PATH, load_presets

    if name not in load_presets():
        raise LogError(f"device show: {name!r} is neither a preset ({', '.join(sorted(load_presets()))}) "
                       "nor a device file")
    lines = PRESETS_PATH.read_text().splitlines()
    start = lines.index(f"[{name}]")
    body = []
    for ln in lines[start + 1:]:
        if re.match(r"\s*\[", ln):
            break
        body.append(ln)
    while body and not body[-1].strip():
        body.pop()
    return (f"# preset {name} of sim/presets.toml as a device file ([fog] device = "
            f"\"this file\" in a scenario runs it)\n" + "\n".join(body) + "\n")


# ---------------------------------------------------------------------------------------------
# fit
@dataclass
class Entry:
    """One determined key: its value (datasheet unit), the interval (None: not stated) and where
    it comes from."""

    key: str
    value: object
    low: float | list | None     # a vector key: one bound per component (None: undetermined)
    high: float | list | None
    source: str


@dataclass
class DeviceFit:
    """What a fit determined (``entries``), what it did not (``undetermined``: key -> why) and
    the warnings a reader must see (``notes``)."""

    entries: list = field(default_factory=list)
    undetermined: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    ci: float = 0.683
    inputs: list = field(default_factory=list)
    options: list = field(default_factory=list)   # the fit's command-line options

    def values(self) -> dict:
        return {e.key: e.value for e in self.entries}

    def entry(self, key: str) -> Entry | None:
        return next((e for e in self.entries if e.key == key), None)

    def to_toml(self) -> str:
        out = [MARKER + " (this line lets a later fit with --overwrite replace the file)",
               "# from: " + ", ".join(self.inputs),
               "# options: " + (" ".join(self.options) or "(none)"),
               f"# intervals: {self.ci:.1%} (the identifier's, or over the power-ons)"]
        for n in self.notes:
            out.append(f"# NOTE: {n}")
        out.append(f"source = {json.dumps('fitted by fogbench device fit to ' + ', '.join(self.inputs))}")
        for e in self.entries:
            out.append(f"# {e.key}: {e.source}{_entry_interval(e)}")
            out.append(f"{e.key} = {_toml_value(e.value)}")
        out.append("# Not determined by these logs (the simulator's default applies):")
        for k, why in self.undetermined.items():
            default = _NEEDS.get(k, ("the simulator's (sim.fog.FogParams, sim.thermal)",))[0]
            out.append(f"#   {k}: default {default}; {why}")
        return "\n".join(out) + "\n"


def _entry_interval(e: Entry) -> str:
    """An entry's interval as written after its value ('' when none is stated): one pair, or
    one per component of a vector ('-' for a component the logs do not determine)."""
    if e.low is None:
        return ""
    if isinstance(e.low, (list, tuple)):
        return " [" + "; ".join("-" if a is None else _interval_text(a, b)
                                for a, b in zip(e.low, e.high)) + "]"
    return f" [{_interval_text(e.low, e.high)}]"


def _interval_text(lo: float, hi: float) -> str:
    """Both bounds with the digits that tell them apart (at least 4 significant)."""
    width = abs(hi - lo)
    scale = max(abs(lo), abs(hi))
    digits = 4 if width == 0 or scale == 0 else max(4, int(math.ceil(
        math.log10(scale / width))) + 2)
    return f"{lo:.{min(digits, 12)}g}, {hi:.{min(digits, 12)}g}"


def _toml_value(v) -> str:
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(float(f"{float(v):.6g}"))


@dataclass(frozen=True)
class StaticLog:
    """One static record of one gyro axis: rate (rad/s), sample rate (Hz), gap-free pieces."""

    name: str
    rate: np.ndarray
    fs: float
    segments: tuple = ()
    column: str = ""


def earth_projection(latitude_deg: float, input_axis: str, heading_deg: float = 0.0) -> float:
    """The Earth rate along a gyro's input axis at rest, rad/s: +-Omega sin(latitude) for an
    axis pointing up or down, Omega cos(latitude) cos(heading) for a level axis at a heading from
    north (Titterton & Weston 2004, eq. 3.72)."""
    from sim.earth import earth_rate_world

    # the rig's own Earth rate, in a level frame whose x points along the heading, z up
    w = earth_rate_world(math.radians(latitude_deg), math.radians(heading_deg))
    return float({"up": w[2], "down": -w[2]}.get(input_axis, w[0]))


def fit_device(static: list, curve=None, earth_rate: float | None = None,
               ci: float | None = None, min_tau: float | None = None,
               thermal=None, multipos=None, full_scale: float | None = None) -> DeviceFit:
    """A device file's keys from static logs and/or an Allan curve.

    Parameters
    ----------
    static : list of StaticLog
        Static records of separate power-ons of one gyro axis (may be empty).
    curve : tuple (name, taus, avar, fs, n_samples), optional
        An Allan curve (s, rad^2/s^2) and its record's sample rate and length; its noise terms
        are used instead of the static logs'.
    earth_rate : float, optional
        The Earth rate's projection on the input axis during the static logs, rad/s (None: the
        bias is stated uncorrected).
    ci : float, optional
        Probability content of the intervals (default one sigma, 0.683).
    min_tau : float, optional
        Shortest averaging time the noise terms are fitted on, s (default: every octave from
        one sample): leaves out the averaging times a sensor's own low-pass filter shapes.
    thermal : fogbench.device_thermal.ThermalLog, optional
        A record at a constant rate through a temperature program: the temperature terms and
        the coil's lag (:func:`fogbench.device_thermal.fit_thermal`, weighted by the noise
        model the static logs or the curve gave; one of them is needed).
    multipos : fogbench.device_multipos.MultiposLog, optional
        A multi-position, centrifuge or rate-table record with its specific force and reference
        rate: the g and g^2 terms and the scale factor
        (:func:`fogbench.device_multipos.fit_multipos`, weighted as the thermal fit).
    full_scale : float, optional
        The gyro's full scale, rad/s (a datasheet's): with it the multi-position fit states the
        scale factor's non-linearity at full scale (``sf_nonlinearity_ppm``).
    """
    from scipy.stats import chi2, t as student_t

    from fogcomp.allan import ONE_SIGMA_CI, allan_analysis
    from fogcomp.noise import identify_noise_model

    ci = ONE_SIGMA_CI if ci is None else ci
    fit = DeviceFit(ci=ci)
    model = None
    if curve is not None:
        name, taus, avar, fs, n = curve
        keep = np.ones(len(taus), bool) if min_tau is None else np.asarray(taus) >= min_tau
        if keep.sum() < 3:
            raise ValueError(f"--min-tau-s {min_tau:g}: leaves {int(keep.sum())} averaging "
                             "times of the curve; at least 3 are needed")
        model = identify_noise_model(np.asarray(taus)[keep], np.asarray(avar)[keep], fs, n,
                                     ci=ci)
        origin = f"the Allan curve {name}"
        fit.inputs.append(f"Allan curve {name} ({n} samples at {fs:g} Hz)")
    models = {}
    for log in static:
        col = f", column {log.column}" if log.column else ""
        fit.inputs.append(f"static log {log.name} ({log.rate.size} samples at {log.fs:g} Hz"
                          f"{col})")
    if static:
        longest = max(static, key=lambda s: s.rate.size)
        _, models[longest.name] = allan_analysis(
            longest.rate, longest.fs, _octaves(longest, min_tau), ci=ci,
            segments=list(longest.segments) or None)
        if model is None:
            model, origin = models[longest.name], f"the static log {longest.name}"
    if model is not None:
        _noise_entries(fit, model, origin, curve[3] if curve is not None else static[0].fs)
    # bias and its switch-on repeatability
    if static:
        ref = models[max(static, key=lambda s: s.rate.size).name]
        biases, sig = [], []
        for log in static:
            b = float(np.mean(log.rate)) - (earth_rate or 0.0)
            # the spread of a mean over the record: the model's Allan deviation at its length
            # (exact for white noise; the usual stand-in for the slower terms)
            T = log.rate.size / log.fs
            biases.append(b)
            sig.append(float(ref.model_adev(np.array([T]))[0]))
        corr = (f"less the Earth rate's projection on the input axis "
                f"({earth_rate / DPH:.6g} deg/h)") if earth_rate is not None else \
            "NOT corrected for the Earth rate (give --latitude-deg and --input-axis)"
        k = len(biases)
        b = np.array(biases) / DPH
        s_in = np.array(sig) / DPH
        if k == 1:
            fit.entries.append(Entry("bias_dph", float(b[0]), float(b[0] - s_in[0] * _z(ci)),
                                     float(b[0] + s_in[0] * _z(ci)),
                                     f"mean rate of {static[0].name} {corr}; interval from the "
                                     "noise model's Allan deviation at the record's length"))
            fit.undetermined["switch_on_bias_dph"] = (
                "one power-on: the switch-on repeatability needs static logs of two or more "
                "separate power-ons")
        else:
            mean, sd = float(b.mean()), float(b.std(ddof=1))
            h = float(student_t.ppf(0.5 + ci / 2, k - 1)) * sd / math.sqrt(k)
            fit.entries.append(Entry("bias_dph", mean, mean - h, mean + h,
                                     f"mean of the {k} logs' mean rates {corr}; t-interval over "
                                     "the power-ons"))
            # the spread of the k means, less the part their own noise explains
            excess = max(sd**2 - float(np.mean(s_in**2)), 0.0)
            lo_q, hi_q = chi2.ppf(0.5 + ci / 2, k - 1), chi2.ppf(0.5 - ci / 2, k - 1)
            lo = math.sqrt(max((k - 1) * sd**2 / lo_q - float(np.mean(s_in**2)), 0.0))
            hi = math.sqrt(max((k - 1) * sd**2 / hi_q - float(np.mean(s_in**2)), 0.0))
            fit.entries.append(Entry("switch_on_bias_dph", math.sqrt(excess), lo, hi,
                                     f"spread (sample standard deviation) of the {k} power-ons' "
                                     "biases less their own noise; chi-square interval on "
                                     f"{k - 1} degrees of freedom"))
            if k < 5:
                fit.notes.append(f"{k} power-ons bound the switch-on repeatability poorly: "
                                 f"{math.sqrt(excess):.3g} deg/h, interval [{lo:.3g}, {hi:.3g}] "
                                 "deg/h; log more power-ons")
    if thermal is not None:
        if model is None:
            raise ValueError("--thermal: the fit weighs the thermal log by the noise model of "
                             "a static log or an Allan curve; give --static or --curve too")
        _thermal_entries(fit, thermal, ci, bias_given=bool(static), model=model)
    if multipos is not None:
        if model is None:
            raise ValueError("--multipos: the fit weighs the log by the noise model of a static "
                             "log or an Allan curve; give --static or --curve too")
        _multipos_entries(fit, multipos, ci, model, full_scale)
    for key, (_, why) in _NEEDS.items():
        if fit.entry(key) is None and key not in fit.undetermined:
            fit.undetermined[key] = "needs " + why
    for key in _all_fog_keys():
        if fit.entry(key) is None and key not in fit.undetermined:
            fit.undetermined[key] = "not measured by these logs"
    return fit


def _thermal_noise(model, fs: float):
    """FogParams of the noise a thermal fit weighs by: the identified terms at their values
    and the terms the record only bounds at their 95 % upper bounds (a rate random walk a
    short static log cannot show still wanders through a long thermal run: leaving it out
    would make the temperature terms' intervals far too narrow)."""
    from sim.fog import FogParams

    def val(term):
        t = model.term(term)
        if t.status == "identified":
            return t.value
        return t.bound if t.status == "upper bound" and t.bound is not None else 0.0

    kw = dict(arw=val("N"), bias_instability=val("B"), rrw=val("K"),
              quantization=val("Q") * math.sqrt(12.0), bi_band=(1e-6, min(BAND_HIGH_HZ, fs / 2)))
    gms = sorted((t for t in model.gm_terms if t.status == "identified"), key=lambda t: -t.value)
    if gms:
        kw.update(gm_drift=gms[0].value, gm_time_constant=gms[0].tau)
    return FogParams(**kw)


def _thermal_entries(fit: DeviceFit, log, ci: float, bias_given: bool, model) -> None:
    from .device_thermal import KEYS, RATE_WINDOW_S, T_REF_C, fit_thermal

    col = f", column {log.column}" if log.column else ""
    fit.inputs.append(f"thermal log {log.name} ({log.rate.size} samples at {log.fs:g} Hz"
                      f"{col}; {np.min(log.temp):.3g} to {np.max(log.temp):.3g} deg C)")
    noise = _thermal_noise(model, log.fs)
    th = fit_thermal(log, noise, ci)
    tau, lo, hi, bounded = th["lag"]
    lo95, hi95, bounded95 = th["lag95"]
    how = (f"generalised least squares on {th['block_s']:g} s means of {log.name} (bias + T + T^2 + "
           "dT/dt + T dT/dt of the coil), weighted by the fitted noise model (terms the "
           "record only bounds at their 95 % bounds); interval the union over the coil lags "
           f"the residual allows, both at (1 + {ci:.3g}) / 2 so that they hold together at "
           f"{ci:.3g} at least")
    fit.entries.append(Entry("temp_ref_c", T_REF_C, None, None,
                             "chosen: the temperature terms' reference"))
    for key, _ in KEYS:
        v, a, b = th[key]
        fit.entries.append(Entry(key, v, a, b, how))
    if bias_given:
        v, a, b = th["bias_at_ref_dph"]
        fit.notes.append(f"bias_dph is the static logs' mean at their own (unlogged) "
                         f"temperature; the temperature terms refer to {T_REF_C:g} deg C, where "
                         f"the thermal fit's constant is {v:.4g} [{a:.4g}, {b:.4g}] deg/h (its "
                         "rate, the Earth rate included)")
    else:
        v, a, b = th["bias_at_ref_dph"]
        fit.entries.append(Entry("bias_dph", v, a, b, f"the thermal fit's constant at "
                                 f"{T_REF_C:g} deg C ({log.name}; its rate, Earth rate "
                                 "included, is taken as the reference)"))
    if lo95 == 0.0 and hi95 <= RATE_WINDOW_S:
        fit.entries.append(Entry("temp_sensor_location", "coil", None, None,
                                 f"the residual of {log.name} rejects (at 95 %) every lag "
                                 f"between sensor and coil beyond {hi95:.3g} s (no lag the "
                                 "record can tell from none)"))
        fit.undetermined["coil_time_constant_s"] = (
            "the sensor reads the coil: its lag behind the chamber does not enter the terms")
    elif bounded95 and lo95 > 0.0:
        fit.entries.append(Entry("temp_sensor_location", "housing", None, None,
                                 f"the coil lags the sensor in {log.name} (no lag rejected at "
                                 "95 %; the lag below)"))
        fit.entries.append(Entry("coil_time_constant_s", tau, lo, hi,
                                 "the coil's first-order lag behind the sensor with the "
                                 "smallest generalised residual; chi-square profile interval"))
        fit.undetermined["housing_time_constant_s"] = (
            "the housing's lag behind the chamber: the log holds no chamber temperature")
    else:
        fit.undetermined["coil_time_constant_s"] = (
            f"{log.name} does not tell where the sensor is (the coil's lag behind it: best "
            f"{tau:.3g} s, {lo:.3g} to {hi:.3g} s in the {ci:.0%} profile, {lo95:.3g} to "
            f"{hi95:.3g} s at 95 %); the temperature terms' intervals cover every lag of the "
            f"{(1 + ci) / 2:.0%} profile")
    fit.notes.append(f"thermal fit of {log.name}: generalised residual chi-square per degree "
                     f"of freedom {th['chi2_per_dof']:.3g} (about 1 when the noise model and "
                     "the temperature model explain the record)")


def _multipos_entries(fit: DeviceFit, log, ci: float, model, full_scale) -> None:
    from .device_multipos import TERMS, fit_multipos

    col = f", column {log.column}" if log.column else ""
    fit.inputs.append(f"multi-position log {log.name} ({log.rate.size} samples at {log.fs:g} Hz"
                      f"{col})")
    res = fit_multipos(log, _thermal_noise(model, log.fs), ci, full_scale)
    how = (f"generalised least squares on {res['block_s']:g} s means of {log.name} (rate less "
           "the reference = constant + g terms of paper 004 eq. 8 + scale factor + "
           "non-linearity), weighted by the fitted noise model (terms the record only bounds "
           "at their 95 % bounds)")
    missing = [name for name, _ in TERMS if res[name] is None]
    vectors: dict = {}
    for name, target in TERMS:
        if target is None:
            continue
        key, idx = target
        v = res[name]
        if idx is None:                               # a scalar key
            if v is None:
                fit.undetermined[key] = f"not identifiable from {log.name} (its design)"
            elif key == "sf_nonlinearity_ppm" and full_scale is None:
                fit.undetermined[key] = ("fitted but not stated: give --full-scale-dps (the "
                                         "non-linearity is stated at full scale)")
            else:
                fit.entries.append(Entry(key, v[0] * 1e6, v[1] * 1e6, v[2] * 1e6, how))
                if key == "sf_nonlinearity_ppm":
                    fit.entries.append(Entry("full_scale_dps", full_scale / DPS, None, None,
                                             "given (--full-scale-dps): the full scale the "
                                             "non-linearity is stated at"))
            continue
        n = 3 if key == "g_sens_dph_per_g" else 6
        vec = vectors.setdefault(key, ([0.0] * n, [None] * n, [None] * n, []))
        if v is None:
            vec[3].append(name)
        else:
            vec[0][idx], vec[1][idx], vec[2][idx] = (x / DPH for x in v)
    for key, (val, lo, hi, undetermined) in vectors.items():
        if len(undetermined) == len(val):
            fit.undetermined[key] = f"not identifiable from {log.name} (its design)"
            continue
        src = how + "; components in the log's body axes (acc_x, acc_y, acc_z)"
        if undetermined:
            src += (f"; {', '.join(undetermined)} not identifiable from this log's attitudes "
                    "(written 0)")
        fit.entries.append(Entry(key, val, lo, hi, src))
    if missing:
        fit.notes.append(f"{log.name}: not identifiable from its attitudes and rates: "
                         f"{', '.join(missing)} (fx^2 + fy^2 + fz^2 = 1 g^2 in every static "
                         "position: the squares and the constant separate only on a "
                         "centrifuge; the cross terms need positions between the axes)")
    if res["constant"] is not None:
        v, a, b = (x / DPH for x in res["constant"])
        fit.notes.append(f"the multi-position fit's constant (the bias in that power-on, with "
                         f"what of the Earth rate the reference leaves out): {v:.4g} "
                         f"[{a:.4g}, {b:.4g}] deg/h")
    fit.notes.append(f"multi-position fit of {log.name}: generalised residual chi-square per "
                     f"degree of freedom {res['chi2_per_dof']:.3g} over {res['blocks']} "
                     "means (about 1 when the noise model and the g model explain the record)")


def _all_fog_keys() -> list:
    """Every key of a [fog] table a device file may hold (the scenario's validation)."""
    from .scenario import fog_json_schema

    return [k for k in fog_json_schema()["properties"] if k != "source"]


def _octaves(log: StaticLog, min_tau: float | None):
    """Octave averaging times of a log from ``min_tau`` on (None: the default, every octave)."""
    if min_tau is None:
        return None
    n = max(b - a for a, b in log.segments) if log.segments else log.rate.size
    m = 2 ** np.arange(int(math.floor(math.log2(max((n - 1) // 2, 1)))) + 1)
    t = m / log.fs
    t = t[t >= min_tau * (1 - 1e-9)]
    if t.size < 3:
        raise ValueError(f"--min-tau-s {min_tau:g}: leaves {t.size} octave averaging times of "
                         f"{log.name}; at least 3 are needed")
    return t


def _z(ci: float) -> float:
    from scipy.stats import norm

    return float(norm.ppf(0.5 + ci / 2))


def _noise_entries(fit: DeviceFit, model, origin: str, fs: float) -> None:
    for term, (key, unit) in _NOISE_KEYS.items():
        t = model.term(term)
        if t.status == "identified":
            fit.entries.append(Entry(key, t.value / unit, t.low / unit, t.high / unit,
                                     f"{t.name} of {origin} (fogcomp.noise, {t.reason})"))
            if term == "B":
                top = min(BAND_HIGH_HZ, fs / 2)
                fit.entries.append(Entry(
                    "bias_instability_band_hz", [1e-6, top], None, None,
                    f"chosen: the flicker spread over 1e-6 to {top:g} Hz, flat over every "
                    "averaging time the record shows"))
            if term == "R":
                fit.notes.append("rate_ramp_dph_per_h: the Allan variance holds R^2; its sign "
                                 "is not known from the curve (positive written)")
        elif t.status == "upper bound" and t.bound is not None:
            fit.undetermined[key] = (f"not identified in {origin}: at most "
                                     f"{t.bound / unit:.3g} (95 % upper bound)")
    gms = sorted((t for t in model.gm_terms if t.status == "identified"),
                 key=lambda t: -t.value)
    if gms:
        g = gms[0]
        fit.entries.append(Entry("gm_drift_dps", g.value / DPS, g.low / DPS, g.high / DPS,
                                 f"the strongest Gauss-Markov term of {origin}"))
        fit.entries.append(Entry("gm_time_constant_s", g.tau, g.tau_low, g.tau_high,
                                 "its correlation time"))
        for other in gms[1:]:
            fit.notes.append(f"{origin} shows a further Gauss-Markov term ({other.value / DPH:.3g} "
                             f"deg/h, {other.tau:.3g} s); the error model holds one, so it is "
                             "left out of this file")


# ---------------------------------------------------------------------------------------------
# check
def twin_curves(params, fs: float, segments, taus, replicates: int, seed: int = 0,
                progress=None) -> np.ndarray:
    """Allan deviations (rad/s) at ``taus`` of ``replicates`` records of the device at rest,
    each with the gap-free pieces [start, stop) of the log (every piece its own power-on draw
    of the noise, as a log split at its gaps pools them)."""
    from fogcomp.allan import pooled_oadev
    from sim.fog import simulate_fog

    segs = [(int(a), int(b)) for a, b in segments]
    n = segs[-1][1]
    out = np.empty((replicates, len(taus)))
    for r in range(replicates):
        y = np.zeros(n)
        for i, (a, b) in enumerate(segs):
            z = np.zeros((b - a, 3))
            y[a:b] = simulate_fog(params, fs, z, z, axes=("z",),
                                  seed=seed + 1000 * r + i).raw[:, 0]
        _, adev = pooled_oadev(y, fs, np.asarray(taus), segs)
        out[r] = adev
        if progress is not None:
            progress(r + 1)
    return out


def check_device(curve, twin: np.ndarray) -> dict:
    """Where the log's Allan curve and the twin's agree: at each tau, whether the log's
    interval (``curve.low``, ``curve.high``) overlaps the twin's central band (the 2.5 and 97.5
    percentiles over replicates); the share of taus where it does."""
    lo, hi = np.percentile(twin, [2.5, 97.5], axis=0)
    agree = (curve.low <= hi) & (curve.high >= lo)
    return {"band_low": lo, "band_high": hi, "median": np.median(twin, axis=0),
            "agree": agree, "share": float(np.mean(agree))}


def _plot_check(tmp: str, title: str, curve, res: dict, interval: str, what: str = "log") -> None:
    """Top: the record's Allan curve and interval, the twin's median and band; bottom: both
    divided by the twin's median (where a few per cent decide the overlap)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, med = curve.taus, res["median"]
    fig, (ax, rx) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True,
                                 gridspec_kw={"height_ratios": [3, 1.4]})
    for a_, scale in ((ax, DPH), (rx, med)):
        a_.fill_between(t, res["band_low"] / scale, res["band_high"] / scale, color="C1",
                        alpha=0.3, label="twin: 95 % band over replicates")
        a_.plot(t, med / scale, color="C1", lw=1, label="twin: median")
        a_.fill_between(t, curve.low / scale, curve.high / scale, color="k", alpha=0.15,
                        label=f"{what}: {interval}")
        a_.plot(t, curve.adev / scale, "k.-", lw=1, label=what)
        bad = ~res["agree"]
        if bad.any():
            a_.plot(t[bad], (curve.adev / scale)[bad], "rx", ms=8, label="no overlap")
        a_.set_xscale("log")
        a_.grid(True, which="both", alpha=0.3)
    ax.set_yscale("log")
    ax.set_ylabel("Allan deviation, deg/h")
    rx.set_ylabel("/ twin median")
    rx.set_xlabel("averaging time tau, s")
    ax.set_title(f"{title}\nagree within their intervals at {res['share']:.0%} of the "
                 "averaging times")
    ax.legend(fontsize=8)
    fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# command line
def _is_device_file(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(len(MARKER)) == MARKER.encode()
    except OSError:
        return False


def _is_check_json(path: Path) -> bool:
    try:
        return json.loads(Path(path).read_text()).get("format") == "fogbench-device-check"
    except (OSError, ValueError, AttributeError):
        return False


def _channel(log, axis: str | None, path) -> str:
    gyros = sorted(c for c in log.channels if c.startswith("gyro_"))
    if axis is not None:
        ch = f"gyro_{axis}"
        if ch not in log.channels:
            raise LogError(f"{path}: no {ch} column (it has {', '.join(gyros)})")
        return ch
    if len(gyros) != 1:
        raise LogError(f"{path}: {len(gyros)} gyro columns ({', '.join(gyros)}): a device file "
                       "is one gyro; choose it with --axis x, y or z")
    return gyros[0]


def _read_static(path, args) -> tuple[StaticLog, object]:
    chans = [f"gyro_{args.axis}"] if args.axis else ["gyro_*"]
    log = read_log(path, **_source(args), mapping=args.column, channels=chans, fs=args.fs, gaps=args.gaps,
                   time_tolerance=args.time_tolerance, min_samples=MIN_RECORD_SAMPLES)
    ch = _channel(log, args.axis, path)
    if log.units[ch] == "au":
        raise LogError(f"{path}: column {log.sources[ch]!r} is in raw counts (au); a device "
                       "file needs a rate unit (dps, rps, dph)")
    v = log.channels[ch]
    if np.ptp(v) == 0:
        raise LogError(f"{path}: column {log.sources[ch]!r} is constant: a stuck channel has no "
                       "noise to fit")
    return StaticLog(str(path), v, log.fs, tuple(log.segments), log.sources[ch]), log


def _read_thermal(path, args):
    from .device_thermal import ThermalLog

    chans = [f"gyro_{args.axis}" if args.axis else "gyro_*", "temp"]
    log = read_log(path, **_source(args), mapping=args.column, channels=chans, fs=args.fs, gaps="refuse",
                   time_tolerance=args.time_tolerance, min_samples=MIN_RECORD_SAMPLES)
    ch = _channel(log, args.axis, path)
    if log.units[ch] == "au":
        raise LogError(f"{path}: column {log.sources[ch]!r} is in raw counts (au); a device "
                       "file needs a rate unit (dps, rps, dph)")
    return ThermalLog(str(path), log.channels[ch], log.channels["temp"], log.fs,
                      log.sources[ch]), log


def _check_reference_flag(reference):
    """--reference names a column with a rate unit (checked before any log is read)."""
    if not reference:
        raise LogError("--multipos: give --reference COLUMN, the log's reference rate about the "
                       "input axis with its unit (e.g. ref_dps: the table's rate plus the Earth "
                       "rate's projection)")
    reference_unit(reference)


def _read_multipos(path, args):
    from fogcomp.units import G0

    from .device_multipos import MultiposLog
    from .reallog.calibrate import reference_rate

    _check_reference_flag(args.reference)
    chans = [f"gyro_{args.axis}" if args.axis else "gyro_*", "acc_x", "acc_y", "acc_z"]
    log = read_log(path, **_source(args), mapping=args.column, channels=chans, fs=args.fs, gaps="refuse",
                   time_tolerance=args.time_tolerance, min_samples=MIN_RECORD_SAMPLES)
    ch = _channel(log, args.axis, path)
    for c in [ch] + [f"acc_{a}" for a in "xyz"]:
        if log.units[c] == "au":
            raise LogError(f"{path}: column {log.sources[c]!r} is in raw counts (au); the "
                           "multi-position fit needs physical units")
    ref = reference_rate(path, log, args.reference)
    f = np.column_stack([log.channels[f"acc_{a}"] for a in "xyz"]) / G0
    return MultiposLog(str(path), log.channels[ch], ref, f, log.fs, log.sources[ch]), log


def _read_curve_axis(args):
    """(axis, (taus, adev, low, high), sample rate, samples) of ``--curve``: the axis
    ``--axis`` names, or the curve's only one."""
    curves, _, header = read_curve(args.curve, args.curve_ci, with_header=True)
    fs, samples = _curve_record(args.curve, header, args.fs, args.samples)
    if len(curves) != 1 and args.axis is None:
        raise LogError(f"{args.curve}: {len(curves)} axes ({', '.join(curves)}); choose one "
                       "with --axis")
    ax = args.axis if args.axis is not None else next(iter(curves))
    if ax not in curves:
        raise LogError(f"{args.curve}: no axis {ax!r} (it has {', '.join(curves)})")
    return ax, curves[ax], fs, samples


def _cmd_fit(args) -> int:
    from fogcomp.allan import ONE_SIGMA_CI

    if not args.static and not args.curve:
        raise LogError("device fit: give at least one --static LOG.csv or --curve CURVE.csv "
                       "(with --thermal or --multipos too: those fits need their noise model)")
    ci = ONE_SIGMA_CI if args.ci is None else args.ci
    if not (0 < ci < 1):
        raise LogError(f"--ci: expected a probability between 0 and 1, got {_fmt_number(ci)}")
    if args.latitude_deg is not None:
        if not (-90 <= args.latitude_deg <= 90):
            raise LogError(f"--latitude-deg: expected -90 to 90, got "
                           f"{_fmt_number(args.latitude_deg)}")
        if args.input_axis is None:
            raise LogError("--latitude-deg: give --input-axis up, down or level (the Earth "
                           "rate's projection on the gyro depends on it)")
        if args.input_axis == "level" and args.heading_deg is None:
            raise LogError("--input-axis level: give --heading-deg (the input axis's heading "
                           "from north)")
        if args.heading_deg is not None:
            if args.input_axis != "level":
                raise LogError("--heading-deg: only with --input-axis level (a vertical axis "
                               "has no heading)")
            if not (math.isfinite(args.heading_deg) and -360 <= args.heading_deg <= 360):
                raise LogError(f"--heading-deg: expected -360 to 360, got "
                               f"{_fmt_number(args.heading_deg)}")
    elif args.input_axis is not None or args.heading_deg is not None:
        raise LogError("--input-axis/--heading-deg: only with --latitude-deg")
    if not args.curve:
        for flag, v in (("--samples", args.samples), ("--curve-ci", args.curve_ci)):
            if v is not None:
                raise LogError(f"{flag}: only with --curve")
    seen = {}
    for p in args.static:   # the same log twice is not two power-ons
        key = str(Path(p).resolve())
        if key in seen:
            raise LogError(f"--static {p}: given twice (also as {seen[key]}); each static log "
                           "is one power-on")
        seen[key] = p
    if args.min_tau_s is not None and not (args.min_tau_s > 0 and math.isfinite(args.min_tau_s)):
        raise LogError(f"--min-tau-s: expected a positive number of seconds, got "
                       f"{_fmt_number(args.min_tau_s)}")
    if args.reference and not args.multipos:
        raise LogError("--reference: only with --multipos")
    if args.multipos:
        _check_reference_flag(args.reference)
    if args.full_scale_dps is not None:
        if not args.multipos:
            raise LogError("--full-scale-dps: only with --multipos")
        if not (math.isfinite(args.full_scale_dps) and 0 < args.full_scale_dps <= 1e5):
            raise LogError(f"--full-scale-dps: expected a full scale in deg/s (0 to 1e5), got "
                           f"{_fmt_number(args.full_scale_dps)}")
    inputs = [Path(p) for p in args.static] + ([Path(args.curve)] if args.curve else []) + \
        ([Path(args.thermal)] if args.thermal else []) + \
        ([Path(args.multipos)] if args.multipos else [])
    out = _Outputs(args.overwrite, "device fit")
    target = out.target(Path(args.out), tuple(inputs), recognise=_is_device_file,
                        what="device file")
    if target.suffix != ".toml":
        raise LogError(f"--out {target}: a device file ends in .toml")
    statics = []
    for p in args.static:
        s, log = _read_static(p, args)
        print(log.describe(), file=sys.stderr)
        statics.append(s)
    if len({s.fs for s in statics}) > 1:
        raise LogError("--static: the logs have different sample rates (" + ", ".join(
            f"{s.name}: {s.fs:g} Hz" for s in statics) + "); a device file is fitted at one")
    curve = None
    if args.curve:
        ax, (t, a, _, _), fs, samples = _read_curve_axis(args)
        curve = (f"{args.curve} (axis {ax})", t, a**2, fs, samples)
    thermal = None
    if args.thermal:
        thermal, tlog = _read_thermal(args.thermal, args)
        print(tlog.describe(), file=sys.stderr)
    multipos = None
    if args.multipos:
        multipos, mlog = _read_multipos(args.multipos, args)
        print(mlog.describe(), file=sys.stderr)
    full_scale = None if args.full_scale_dps is None else args.full_scale_dps * DPS
    earth = None
    if args.latitude_deg is not None:
        earth = earth_projection(args.latitude_deg, args.input_axis, args.heading_deg or 0.0)
    try:
        fit = fit_device(statics, curve, earth, ci, args.min_tau_s, thermal, multipos,
                         full_scale)
    except ValueError as exc:
        raise LogError(f"device fit: {exc}") from None
    opts = [f"--axis {args.axis}"] if args.axis else []
    opts += [f"{flag} {v}" for flag, v in (
        ("--min-tau-s", args.min_tau_s), ("--latitude-deg", args.latitude_deg),
        ("--input-axis", args.input_axis), ("--heading-deg", args.heading_deg),
        ("--ci", args.ci), ("--gaps", args.gaps if args.gaps != "refuse" else None),
        ("--fs", args.fs), ("--samples", args.samples), ("--curve-ci", args.curve_ci),
        ("--reference", args.reference), ("--full-scale-dps", args.full_scale_dps))
        if v is not None]
    opts += [f"--column {c}" for c in (args.column or [])]
    fit.options = opts
    text = fit.to_toml()
    from .scenario import ScenarioError, load_device_file

    try:
        out.write_text(target, text)
        tmp = out.pending[-1][0]
        try:   # what was written reads back as a device file (the scenario's checks)
            load_device_file(tmp)
        except ScenarioError as exc:
            raise LogError(f"device fit: a fitted value is out of the range a device file "
                           f"allows ({str(exc).replace(tmp, str(target))}); check the log's "
                           "units (the column's unit suffix) and sample rate") from None
        out.commit()
    finally:
        out.discard()
    for e in fit.entries:
        print(f"{e.key:<36} {_toml_value(e.value):>14} {_entry_interval(e)}")
    for k, why in fit.undetermined.items():
        print(f"{k:<36} {'-':>14}  {why}")
    for n in fit.notes:
        print(f"note: {n}")
    print(f"wrote {target}")
    return 0


def _device_from_values(values: dict, fs: float):
    """FogParams of a device file's keys (datasheet units) at sample rate ``fs``."""
    from .scenario import _fog, _Table

    params, *_ = _fog(_Table(dict(values), "device", "fitted device"), fs)
    return params


def _device_params(path, fs: float):
    from .scenario import ScenarioError, load_device_file

    try:
        doc = load_device_file(path, fs)
    except ScenarioError as exc:
        raise LogError(str(exc)) from None
    return _device_from_values(doc, fs), doc


def _cmd_check(args) -> int:
    from fogcomp.allan import allan_analysis

    if not 0 <= args.seed < 2**31:
        raise LogError(f"--seed: expected a whole number from 0 to 2^31 - 1, got {args.seed}")
    if not 5 <= args.replicates <= MAX_CHECK_REPLICATES:
        raise LogError(f"--replicates: expected 5 (the fewest for a 95 % band) to "
                       f"{MAX_CHECK_REPLICATES}, got {args.replicates}")
    from .scenario import ScenarioError, load_device_file

    try:
        load_device_file(args.device)    # the device file first, before the log is read
    except ScenarioError as exc:
        raise LogError(str(exc)) from None
    if (args.log is None) == (args.curve is None):
        raise LogError("device check: give either LOG.csv or --curve CURVE.csv")
    src = Path(args.log if args.log is not None else args.curve)
    out = _Outputs(args.overwrite, "device check")
    targets = None
    if args.out:
        targets = out.folder(Path(args.out), (Path(args.device), src),
                             marker="device_check.json", recognise=_is_check_json,
                             members=[("device_check.png", lambda p: p.suffix == ".png")])
    if args.log is not None:
        s, log = _read_static(args.log, args)
        print(log.describe(), file=sys.stderr)
        fs, segments, n = s.fs, list(s.segments), int(s.rate.size)
        curve, _ = allan_analysis(s.rate, s.fs, ci=CHECK_CI, segments=segments)
        interval = f"{CHECK_CI:.0%} interval (EDF)"
    else:
        _, (t, a, lo, hi), fs, n = _read_curve_axis(args)
        if lo is None:
            raise LogError(f"{args.curve}: no interval columns (adev_ci_low_/high_<unit>): "
                           "the check compares intervals")
        m = np.rint(np.asarray(t) * fs)
        if np.any(np.abs(m - np.asarray(t) * fs) > 1e-6 * m) or np.any(m > (n - 1) // 2):
            raise LogError(f"{args.curve}: its averaging times are not whole numbers of "
                           f"samples at {fs:g} Hz within {n} samples (--fs, --samples)")
        from types import SimpleNamespace

        curve = SimpleNamespace(taus=np.asarray(t), adev=np.asarray(a), low=np.asarray(lo),
                                high=np.asarray(hi))
        segments = [(0, n)]
        interval = f"{args.curve_ci:.0%} interval (given)"
    params, _ = _device_params(args.device, fs)
    from .progress import Progress

    with Progress(args.replicates, "twin") as bar:
        twin = twin_curves(params, fs, segments, curve.taus, args.replicates,
                           seed=args.seed, progress=lambda r: bar.advance())
    if not np.all(np.isfinite(twin)) or np.all(twin == 0):
        raise LogError(f"{args.device}: the device's twin at rest has no noise (every Allan "
                       "deviation zero or undefined): a device file without noise terms has "
                       "nothing to compare with a log")
    res = check_device(curve, twin)
    doc = {"format": "fogbench-device-check", "version": 1, "device": str(args.device),
           "log" if args.log is not None else "curve": str(src), "fs_hz": fs,
           "n_samples": n, "replicates": args.replicates, "interval": interval,
           "tau_s": curve.taus.tolist(), "log_adev_dph": (curve.adev / DPH).tolist(),
           "log_low_dph": (curve.low / DPH).tolist(), "log_high_dph": (curve.high / DPH).tolist(),
           "twin_median_dph": (res["median"] / DPH).tolist(),
           "twin_low_dph": (res["band_low"] / DPH).tolist(),
           "twin_high_dph": (res["band_high"] / DPH).tolist(),
           "agree": [bool(x) for x in res["agree"]], "share_agree": res["share"]}
    what = "log" if args.log is not None else "curve"
    print(f"{'tau_s':>10} {what + ' deg/h':>12} {what + ' interval':>23} "
          f"{'twin 95 % band':>23}  agree")
    for i, t in enumerate(curve.taus):
        print(f"{t:10.4g} {curve.adev[i] / DPH:12.4g} [{curve.low[i] / DPH:9.4g}, "
              f"{curve.high[i] / DPH:9.4g}] [{res['band_low'][i] / DPH:9.4g}, "
              f"{res['band_high'][i] / DPH:9.4g}]  {'yes' if res['agree'][i] else 'NO'}")
    print(f"the {what}'s Allan deviation and the twin's agree within their intervals at "
          f"{res['share']:.0%} of the averaging times ({int(res['agree'].sum())} of "
          f"{res['agree'].size})")
    if targets is not None:
        try:
            out.write_text(targets["device_check.json"], json.dumps(doc, indent=2))
            out.write(targets["device_check.png"], lambda tmp: _plot_check(
                tmp, f"{Path(args.device).name} against {src.name}", curve, res, interval,
                "log" if args.log is not None else "curve"))
            out.commit()
        finally:
            out.discard()
        print(f"wrote {targets['device_check.json']} and {targets['device_check.png']}")
    return 0


def _cmd_schema(args) -> int:
    from .scenario import fog_json_schema

    print(json.dumps(fog_json_schema(), indent=2))
    return 0


def _cmd_show(args) -> int:
    p = Path(args.name)
    is_file = p.suffix == ".toml" or p.exists()
    files = _noise_file_targets(args)
    if is_file:
        from .scenario import ScenarioError, load_device_file

        try:
            doc = load_device_file(p)
        except ScenarioError as exc:
            raise LogError(str(exc)) from None
        text = p.read_text(encoding="utf-8-sig")
    else:
        text = preset_text(args.name)
        doc = {"preset": args.name}
    if not files:
        sys.stdout.write(text)
        return 0
    _write_noise_files(files, args, doc, str(args.name))
    return 0


def _noise_file_targets(args) -> list:
    """--kalibr / --openvins of ``device show``: checked before any work; needs --rate-hz."""
    from .reallog.allan import _tool_targets

    if not (args.kalibr or args.openvins):
        if args.rate_hz is not None:
            raise LogError("--rate-hz: only with --kalibr or --openvins (the update_rate "
                           "written there)")
        return []
    if args.rate_hz is None or not (math.isfinite(args.rate_hz) and args.rate_hz > 0):
        raise LogError("--kalibr/--openvins: give --rate-hz, the rate your IMU runs at (Kalibr's "
                       "update_rate; a device file has no sample rate)")
    args.log = args.curve = None
    args._outputs = _Outputs(getattr(args, "overwrite", False), "device show")
    return _tool_targets(args._outputs, args)


def _write_noise_files(files, args, doc: dict, source: str) -> None:
    """The device's white rate noise (arw) and rate random walk (rrw), SI from the validated
    [fog] keys, as Kalibr's gyroscope entries; the accelerometer entries left to fill in (a
    device file describes a gyro)."""
    from .kalibr import TEXTS, NoiseValue
    from .scenario import ScenarioError, _fog, _Table

    try:
        params = _fog(_Table(dict(doc), "device file", source), args.rate_hz)[0]
    except ScenarioError as exc:
        raise LogError(str(exc)) from None
    values = {}
    for term, attr, key in (("N", "arw", "arw_deg_rt_h"), ("K", "rrw", "rrw_dph_rt_h")):
        v = float(getattr(params, attr))
        values["gyroscope", term] = (NoiseValue(v, f"the device's {key}", "the gyro", {})
                                     if v > 0 else f"the device has no {key} (0); fill it in")
    for term in ("N", "K"):
        values["accelerometer", term] = ("a device file describes a gyro, not an "
                                         "accelerometer; fill it in")
    out = args._outputs
    try:
        for kind, path in files:
            out.write_text(path, TEXTS[kind](values, args.rate_hz, source, topic=args.imu_topic,
                                             inflate_density=args.inflate_density,
                                             inflate_walk=args.inflate_walk,
                                             command="device show"))
        out.commit()
    finally:
        out.discard()
    for _, path in files:
        print(f"wrote {path} (gyroscope entries; fill in the accelerometer_* keys)")


def add_commands(subparsers) -> None:
    """Add ``device show|schema|fit|check`` to a ``fogbench`` argparse subparsers object."""
    d = subparsers.add_parser("device", help="device files: show a preset as one, fit one to "
                              "your logs, check one against a log")
    sub = d.add_subparsers(dest="device_command", required=True)
    s = sub.add_parser("show", help="print a preset (or a device file, validated) as a device "
                       "file")
    s.add_argument("name", help="a preset of sim/presets.toml, or a device file")
    s.add_argument("--kalibr", metavar="IMU.yaml", help="write the device's noise as Kalibr's "
                   "imu.yaml instead (gyroscope noise density and random walk, SI)")
    s.add_argument("--openvins", metavar="kalibr_imu_chain.yaml", help="the same as OpenVINS' "
                   "kalibr_imu_chain.yaml")
    s.add_argument("--rate-hz", type=float, help="with --kalibr/--openvins: the IMU's rate, "
                   "Hz (update_rate)")
    s.add_argument("--imu-topic", default="/imu0", help="rostopic written (default /imu0)")
    s.add_argument("--inflate-density", type=float, default=1.0, help="multiply the noise "
                   "density by this factor (default 1; stated in the file)")
    s.add_argument("--inflate-walk", type=float, default=1.0, help="multiply the random walk "
                   "by this factor (default 1; stated in the file)")
    s.add_argument("--overwrite", action="store_true", help="replace a file an earlier "
                   "--kalibr/--openvins wrote (nothing else)")
    s.set_defaults(func=_warnings_as_lines(_cmd_show))
    j = sub.add_parser("schema", help="print the JSON Schema of a device file (the [fog] keys), "
                       "for an editor to complete and check them")
    j.set_defaults(func=_cmd_schema)

    f = sub.add_parser("fit", help="fit a device file to static, thermal, multi-position logs "
                       "and/or an Allan curve")
    f.add_argument("--static", action="append", default=[], metavar="LOG.csv",
                   help="a static log of one power-on (repeatable: several power-ons give the "
                        "switch-on repeatability)")
    f.add_argument("--curve", help="an Allan curve (tau_s, adev_<unit>; as fogbench allan "
                   "--curve reads it)")
    f.add_argument("--thermal", metavar="LOG.csv", help="a log at a constant rate through a "
                   "temperature program, with its temperature sensor (temp_c): the "
                   "temperature terms and the coil's lag (needs --static or --curve)")
    f.add_argument("--multipos", metavar="LOG.csv", help="a multi-position, centrifuge or "
                   "rate-table log: gyro, acc_x/y/z (specific force in the body axes) and a "
                   "reference rate column (--reference): the g and g^2 terms and the scale "
                   "factor; with --static or --curve for the noise model")
    f.add_argument("--reference", metavar="COLUMN", help="--multipos: the column of the "
                   "reference rate about the input axis, with its unit (e.g. ref_dps)")
    f.add_argument("--full-scale-dps", type=float, help="--multipos: the gyro's full scale, "
                   "deg/s (datasheet), at which the scale factor's non-linearity is stated")
    f.add_argument("--curve-ci", type=float, help="--curve: probability content of its "
                   "interval columns (e.g. 0.95); the fit uses its own covariance, not them")
    f.add_argument("--samples", type=int, help="--curve: samples of its record (default: its "
                   "first line's n_samples=)")
    f.add_argument("--axis", choices=("x", "y", "z"), help="the gyro axis (column gyro_<axis>) "
                   "when the log has several")
    f.add_argument("--latitude-deg", type=float, help="latitude of the static logs, deg: the "
                   "bias is corrected for the Earth rate")
    f.add_argument("--input-axis", choices=("up", "down", "level"), help="the gyro's input "
                   "axis during the static logs (with --latitude-deg)")
    f.add_argument("--heading-deg", type=float, help="--input-axis level: its heading from "
                   "north, deg")
    f.add_argument("--ci", type=float, help="probability content of the intervals (default "
                   "0.683)")
    f.add_argument("--min-tau-s", type=float, help="fit the noise terms on averaging times "
                   "from this on, s (leaves out those the sensor's own low-pass filter shapes)")
    f.add_argument("--out", required=True, help="the device file to write (.toml)")
    f.add_argument("--overwrite", action="store_true", help="replace a device file written by "
                   "an earlier fogbench device fit (recognised by its first line; nothing else)")
    _common(f)
    f.set_defaults(func=_warnings_as_lines(_cmd_fit))

    c = sub.add_parser("check", help="simulate a device under a log's conditions and compare "
                       "the Allan curves")
    c.add_argument("device", help="device file (.toml)")
    c.add_argument("log", nargs="?", help="static log CSV")
    c.add_argument("--curve", help="an Allan curve with interval columns instead of a log "
                   "(its record's rate and length from its first line, --fs, --samples)")
    c.add_argument("--curve-ci", type=float, help="--curve: probability content of its "
                   "interval columns (e.g. 0.95)")
    c.add_argument("--samples", type=int, help="--curve: samples of its record")
    c.add_argument("--axis", choices=("x", "y", "z"), help="the gyro axis of the log")
    c.add_argument("--replicates", type=int, default=20, help="simulated records (default 20)")
    c.add_argument("--seed", type=int, default=0, help="first seed of the twin's records")
    c.add_argument("--out", help="folder for device_check.json and device_check.png")
    c.add_argument("--overwrite", action="store_true", help="replace the outputs of an earlier "
                   "fogbench device check in --out")
    _common(c)
    c.set_defaults(func=_warnings_as_lines(_cmd_check))
