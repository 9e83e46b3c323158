"""What a fit over a gyro's logs determines (:func:`fit_device`): the noise terms, the bias and
its switch-on repeatability from static logs or an Allan curve, the temperature terms from a
thermal log, the g terms and scale factor from a multi-position log."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fogbench.device.file import _NEEDS, DeviceFit, Entry
from fogcomp.units import ARCSEC, DEG_RT_H, DPH, DPH_PER_H, DPH_RT_H, DPS

__all__ = ["fit_device"]

BAND_HIGH_HZ = 1.0                         # top of the flicker band a fit writes (below)

# identifier term -> (device key, factor from SI, how the value is stated)
_NOISE_KEYS = {
    "N": ("arw_deg_rt_h", DEG_RT_H),
    "B": ("bias_instability_dph", DPH),
    "K": ("rrw_dph_rt_h", DPH_RT_H),
    "Q": ("quantization_arcsec", ARCSEC / math.sqrt(12.0)),   # step q = sqrt(12) Q
    "R": ("rate_ramp_dph_per_h", DPH_PER_H),
}


@dataclass(frozen=True)
class StaticLog:
    """One static record of one gyro axis: rate (rad/s), sample rate (Hz), gap-free pieces."""

    name: str
    rate: np.ndarray
    fs: float
    segments: tuple = ()
    column: str = ""
    #: the mean specific force along the body axes during the log, in g (3,), or None (not
    #: known: no accelerometer columns and no stated attitude)
    f: tuple | None = None
    #: where ``f`` comes from ("its acc_x/y/z columns", "stated: --input-axis up")
    f_source: str = ""
    #: the body axis of its gyro column ("x", "y", "z"; "" unknown)
    axis: str = ""
    #: the temperature sensor's reading at each sample, deg C, or None (not logged)
    temp: np.ndarray | None = None
    temp_source: str = ""


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
               thermal=None, multipos=None, full_scale: float | None = None,
               input_axis: str | None = None) -> DeviceFit:
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
    thermal : fogbench.device.thermal.ThermalLog, optional
        A record at a constant rate through a temperature program: the temperature terms and
        the coil's lag (:func:`fogbench.device.thermal.fit_thermal`, weighted by the noise
        model the static logs or the curve gave; one of them is needed).
    multipos : fogbench.device.multipos.MultiposLog, optional
        A multi-position, centrifuge or rate-table record with its specific force and reference
        rate: the g and g^2 terms and the scale factor
        (:func:`fogbench.device.multipos.fit_multipos`, weighted as the thermal fit).
    full_scale : float, optional
        The gyro's full scale, rad/s (a datasheet's): with it the multi-position fit states the
        scale factor's non-linearity at full scale (``sf_nonlinearity_ppm``).
    input_axis : {"x", "y", "z"}, optional
        The body axis of the logs' gyro column, written as the device's mounting
        (``input_axis``): the g terms' components are along the logs' body axes.

    Each fit takes out what the others explain at each log's own attitude and temperature
    (the simulation adds every term again at a scenario's conditions):

    - with a multi-position log, the static logs' bias is what is left after the fitted g terms
      at each static log's own specific force (:attr:`StaticLog.f`; a static log without one is
      refused), and so is the thermal fit's constant (at :attr:`ThermalLog.f`);
    - with a thermal log, the static logs' bias is what is left after the temperature terms at
      each log's own temperature (:attr:`StaticLog.temp`), so that it refers to the terms'
      reference temperature; static logs without a temperature column are stated as at their
      own unlogged temperature (some with one and some without is refused);
    - the Earth rate's projection (``earth_rate``) is taken out of both.
    """
    from fogcomp.allan import ONE_SIGMA_CI

    ci = ONE_SIGMA_CI if ci is None else ci
    fit = DeviceFit(ci=ci)
    model, pooled, origin = _noise_model(fit, static, curve, ci, min_tau)
    if model is not None:
        _noise_entries(fit, model, origin, curve[3] if curve is not None else
                       max(static, key=lambda s: s.rate.size).fs)
    if input_axis is not None:
        fit.entries.append(Entry("input_axis", input_axis, None, None,
                                 f"the body axis of the logs' gyro column (gyro_{input_axis}), "
                                 "sign +: the gyro reads the rate about +" + input_axis
                                 + "; g_sens_dph_per_g and g2_sens_dph_per_g2 are along the "
                                 "logs' body axes (acc_x, acc_y, acc_z), the axes a scenario's "
                                 "specific force is in"))
    mp = _g_model(static, multipos, model, ci, full_scale) if multipos is not None else None
    mp_name = multipos.name if multipos is not None else None
    th = _thermal_fit(static, thermal, model, ci, mp) if thermal is not None else None
    if static:
        _bias_entries(fit, static, pooled, earth_rate, ci, mp, mp_name,
                      (thermal.name, th) if th is not None else None)
    if thermal is not None:
        _thermal_entries(fit, thermal, th, ci, bool(static), earth_rate, mp, mp_name)
    if multipos is not None:
        _multipos_entries(fit, multipos, ci, mp, full_scale)
    _undetermined(fit)
    return fit


def _g_model(static: list, multipos, model, ci: float, full_scale):
    """The multi-position fit of the g terms (:func:`fogbench.device.multipos.fit_multipos`),
    weighted by the noise ``model``; every static log must carry its specific force, so that
    the g terms can be taken out of its bias."""
    from fogbench.device.multipos import fit_multipos

    if model is None:
        raise ValueError("--multipos: the fit weighs the log by the noise model of a static "
                         "log or an Allan curve; give --static or --curve too")
    for log in static:
        if log.f is None:
            raise ValueError(
                f"static log {log.name}: no accelerometer columns (acc_x, acc_y, acc_z) and "
                "no stated attitude, so the multi-position fit's g terms cannot be taken out "
                "of its bias (its mean holds them at its attitude, and the simulation adds "
                "them again); give the log's acc_x/y/z columns, or --input-axis up or down "
                "if its input axis was vertical")
    return fit_multipos(multipos, _thermal_noise(model, multipos.fs), ci, full_scale)


def _thermal_fit(static: list, thermal, model, ci: float, mp) -> dict:
    """The thermal log's fit (:func:`fogbench.device.thermal.fit_thermal`), weighted by the
    noise ``model``; refuses what would leave the bias wrong without a word: static logs some
    with a temperature column and some without, and, with a multi-position fit and no static
    log (the bias then comes from the thermal fit's constant), a thermal log of unknown
    attitude."""
    from fogbench.device.thermal import fit_thermal

    if model is None:
        raise ValueError("--thermal: the fit weighs the thermal log by the noise model of "
                         "a static log or an Allan curve; give --static or --curve too")
    with_t = [s.name for s in static if s.temp is not None]
    if with_t and len(with_t) < len(static):
        raise ValueError(
            "--thermal: static log(s) " + ", ".join(s.name for s in static if s.temp is None)
            + " have no temperature column and " + ", ".join(with_t) + " have one; the bias "
            "is taken to the temperature terms' reference from each log's temperature: give "
            "a temp column in every static log (or in none: the bias is then stated at their "
            "own unlogged temperature)")
    if mp is not None and not static and thermal.f is None:
        raise ValueError(
            f"thermal log {thermal.name}: no accelerometer columns (acc_x, acc_y, acc_z) and "
            "no stated attitude, so the multi-position fit's g terms cannot be taken out of "
            "the bias its constant gives; give the log's acc_x/y/z columns, or --input-axis "
            "up or down if its input axis was vertical")
    return fit_thermal(thermal, _thermal_noise(model, thermal.fs), ci)


def thermal_at(th: dict, temp: np.ndarray, ci: float) -> tuple[float, float]:
    """(the temperature terms' mean over a soaked log at the sensor readings ``temp`` (deg C),
    deg/h; its standard deviation): k1 dT + k2 dT^2 with dT the reading less the reference
    (the rate terms left out: a static log is taken soaked, its coil at the sensor's
    temperature), from the thermal fit's coefficients with their covariance, the coil's lag
    profiled out (:func:`fogbench.device.thermal.combination`); its interval at ``ci`` over
    that level's z gives the standard deviation."""
    from fogbench.device.thermal import combination

    v, lo, hi = combination(th, _soaked(temp), ci)
    return v / DPH, (hi - lo) / 2 / _z(ci) / DPH


def _soaked(temp) -> list:
    """The thermal fit's columns [1, dT, dT^2, dT/dt, dT dT/dt] averaged over a soaked log at
    the sensor readings ``temp`` (deg C), its constant left out: [0, mean dT, mean dT^2, 0, 0]."""
    from fogbench.device.thermal import T_REF_C

    d = np.asarray(temp, float) - T_REF_C
    return [0.0, float(np.mean(d)), float(np.mean(d * d)), 0.0, 0.0]


def _undetermined(fit: DeviceFit) -> None:
    """Why every key the fit did not determine is left out: what it needs, or not measured."""
    for key, (_, why) in _NEEDS.items():
        if fit.entry(key) is None and key not in fit.undetermined:
            fit.undetermined[key] = "needs " + why
    for key in _all_fog_keys():
        if fit.entry(key) is None and key not in fit.undetermined:
            fit.undetermined[key] = "not measured by these logs"


def _noise_model(fit: DeviceFit, static: list, curve, ci: float, min_tau):
    """(the noise model the file's terms come from, the static logs' pooled model, where it
    comes from): the curve's, else the static logs' pooled."""
    from fogcomp.noise import identify_noise_model

    model, origin = None, None
    if curve is not None:
        name, taus, avar, fs, n = curve
        keep = np.ones(len(taus), bool) if min_tau is None else np.asarray(taus) >= min_tau
        if keep.sum() < 3:
            raise ValueError(f"--min-tau-s {min_tau:g}: leaves {int(keep.sum())} averaging "
                             "times of the curve; at least 3 are needed")
        model = identify_noise_model(np.asarray(taus)[keep], np.asarray(avar)[keep], fs, n,
                                     ci=ci, alternative=False)
        origin = f"the Allan curve {name}"
        fit.inputs.append(f"Allan curve {name} ({n} samples at {fs:g} Hz)")
    for log in static:
        col = f", column {log.column}" if log.column else ""
        fit.inputs.append(f"static log {log.name} ({log.rate.size} samples at {log.fs:g} Hz"
                          f"{col})")
    pooled = None
    if static:
        pooled, where = _pooled_static_model(fit, static, ci, min_tau)
        if model is None:
            model, origin = pooled, where
    return model, pooled, origin


def _pooled_static_model(fit: DeviceFit, static: list, ci: float, min_tau):
    """The noise model of every static log at the longest one's sample rate, pooled: each
    log's (and each gap-free piece's) second differences computed inside it and their squares
    pooled, so each log weighs by its length and the switch-on bias between power-ons drops out
    (:func:`fogcomp.allan.pooled_oadev`). Returns (model, where it comes from)."""
    from fogcomp.allan import allan_analysis

    fs = max(static, key=lambda s: s.rate.size).fs
    same = [abs(s.fs / fs - 1.0) <= 1e-3 for s in static]    # rates from time columns differ
    pool = [s for s, ok in zip(static, same) if ok]           # in their last digits
    left = [s.name for s, ok in zip(static, same) if not ok]
    segs, off = [], 0
    for s in pool:
        segs += [(off + a, off + b) for a, b in (s.segments or [(0, s.rate.size)])]
        off += s.rate.size
    joined = StaticLog(pool[0].name if len(pool) == 1 else f"the {len(pool)} static logs "
                       "pooled", np.concatenate([s.rate for s in pool]), fs, tuple(segs))
    _, model = allan_analysis(joined.rate, fs, _octaves(joined, min_tau), ci=ci,
                              segments=segs, alternative=False)
    if len(pool) == 1:
        where = f"the static log {pool[0].name}"
    else:
        where = (f"the {len(pool)} static logs pooled ({', '.join(s.name for s in pool)}: "
                 "each log's second differences inside it, so each weighs by its length and "
                 "the switch-on bias between them drops out)")
    if left:
        fit.notes.append(f"static log(s) at another sample rate than {fs:g} Hz left out of the "
                         f"noise fit (used for the bias): {', '.join(left)}")
    return model, where


def _bias_entries(fit: DeviceFit, static: list, ref, earth_rate, ci: float, mp=None,
                  mp_name: str | None = None, thermal=None) -> None:
    """The bias (each log's mean rate less the Earth rate's projection, with a multi-position
    fit ``mp`` less its g terms at the log's specific force, with a thermal fit ``thermal``
    (name, result) less its temperature terms at the log's temperature) and, with two or more
    power-ons, its switch-on repeatability (their spread less what each mean's own noise
    explains: ``ref``'s Allan deviation at the record's length)."""
    from scipy.stats import t as student_t

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
    sys_sd = 0.0           # the other fits' part of the bias's uncertainty, deg/h (common)
    if mp is not None:
        g, g_sd, text = _g_correction(fit, static, mp, mp_name)
        biases = [b - gi for b, gi in zip(biases, g)]
        sys_sd, corr = g_sd, corr + text
    if thermal is not None and all(log.temp is not None for log in static):
        t_corr, t_sd, text = _t_correction(fit, static, thermal, ci)
        biases = [b - ti for b, ti in zip(biases, t_corr)]
        sys_sd, corr = math.hypot(sys_sd, t_sd), corr + text
    elif thermal is not None:
        from fogbench.device.thermal import T_REF_C

        fit.notes.append(f"bias_dph is the static logs' mean at their own (unlogged) "
                         f"temperature, not taken to the temperature terms' reference "
                         f"{T_REF_C:g} deg C (give the static logs a temp column)")
    k = len(biases)
    b = np.array(biases) / DPH
    s_in = np.array(sig) / DPH
    if k == 1:
        h = _z(ci) * math.hypot(s_in[0], sys_sd)
        fit.entries.append(Entry("bias_dph", float(b[0]), float(b[0] - h), float(b[0] + h),
                                 f"mean rate of {static[0].name} {corr}; interval from the "
                                 "noise model's Allan deviation at the record's length"))
        fit.undetermined["switch_on_bias_dph"] = (
            "one power-on: the switch-on repeatability needs static logs of two or more "
            "separate power-ons")
        return
    mean, sd = float(b.mean()), float(b.std(ddof=1))
    h = float(student_t.ppf(0.5 + ci / 2, k - 1)) * sd / math.sqrt(k)
    h = math.hypot(h, _z(ci) * sys_sd)    # the other fits' error is common to every log
    fit.entries.append(Entry("bias_dph", mean, mean - h, mean + h,
                             f"mean of the {k} logs' mean rates {corr}; t-interval over "
                             "the power-ons"))
    _switch_on_entry(fit, sd, s_in, k, ci)


def _g_correction(fit: DeviceFit, static: list, mp, mp_name):
    """(the g terms at each static log's specific force, rad/s; their common standard
    deviation, deg/h; the bias source's words) and the note that says it."""
    from fogbench.device.multipos import g_terms_at

    g, g_sd = g_terms_at(mp, np.array([log.f for log in static]))
    g_sd /= DPH
    text = (f", less the g terms fitted to {mp_name} at each log's specific force ("
            + "; ".join(f"{log.name}: f = [{', '.join(f'{x:.3g}' for x in log.f)}] g from "
                        f"{log.f_source}, {gi / DPH:.4g} deg/h"
                        for log, gi in zip(static, g))
            + "; their uncertainty added to the interval)")
    fit.notes.append(
        f"bias_dph is corrected for the g terms: the static logs' mean rate held "
        f"{float(np.mean(g)) / DPH:.4g} deg/h of the g terms fitted to {mp_name} at their "
        f"attitudes (taken out, with +-{g_sd:.3g} deg/h (1 sigma) of the g terms' own "
        "uncertainty added to its interval); the simulation adds the g terms at the "
        "scenario's specific force")
    return g, g_sd, text


def _t_correction(fit: DeviceFit, static: list, thermal, ci: float):
    """(the temperature terms at each static log's temperature, rad/s; their common standard
    deviation, deg/h; the bias source's words) and the note that says it."""
    from fogbench.device.thermal import T_REF_C, combination

    name, th = thermal
    parts = [thermal_at(th, log.temp, ci) for log in static]
    t_corr = [v * DPH for v, _ in parts]
    # the bias is the logs' mean: its error from the terms is that of their mean correction,
    # the columns averaged over the logs (the coefficients' correlation kept)
    _, lo, hi = combination(th, list(np.mean([_soaked(log.temp) for log in static], axis=0)),
                            ci)
    t_sd = (hi - lo) / 2 / _z(ci) / DPH
    text = (f", less the temperature terms fitted to {name} at each log's mean temperature ("
            + "; ".join(f"{log.name}: {float(np.mean(log.temp)):.3g} deg C from "
                        f"{log.temp_source or 'its temp column'}, {v:.4g} deg/h"
                        for log, (v, _) in zip(static, parts))
            + f"), so that it refers to {T_REF_C:g} deg C")
    fit.notes.append(
        f"bias_dph refers to {T_REF_C:g} deg C: the temperature terms fitted to {name} "
        f"explained {float(np.mean([v for v, _ in parts])):.4g} deg/h of the static logs' "
        f"mean rate at their temperatures (taken out, with +-{t_sd:.3g} deg/h (1 sigma) of "
        "their uncertainty added to its interval)")
    return t_corr, t_sd, text


def _switch_on_entry(fit: DeviceFit, sd: float, s_in: np.ndarray, k: int, ci: float) -> None:
    """The switch-on repeatability: the spread ``sd`` of the ``k`` power-ons' biases less what
    their own noise ``s_in`` explains (deg/h), with its chi-square interval."""
    from scipy.stats import chi2

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
    # the error model (sim.fog.FogParams) holds one Gauss-Markov term: the largest sigma, as
    # the device file does (_noise_entries, GM_RULE)
    gms = sorted((t for t in model.gm_terms if t.status == "identified"), key=lambda t: -t.value)
    if gms:
        kw.update(gm_drift=gms[0].value, gm_time_constant=gms[0].tau)
    return FogParams(**kw)


def _thermal_entries(fit: DeviceFit, log, th: dict, ci: float, bias_given: bool,
                     earth_rate=None, mp=None, mp_name: str | None = None) -> None:
    from fogbench.device.thermal import KEYS, RATE_WINDOW_S, T_REF_C

    col = f", column {log.column}" if log.column else ""
    fit.inputs.append(f"thermal log {log.name} ({log.rate.size} samples at {log.fs:g} Hz"
                      f"{col}; {np.min(log.temp):.3g} to {np.max(log.temp):.3g} deg C)")
    tau, lo, hi, bounded = th["lag"]
    lo95, hi95, bounded95 = th["lag95"]
    how = (f"generalised least squares on {th['block_s']:g} s means of {log.name} (bias + T + T^2 + "
           "dT/dt + T dT/dt of the coil), weighted by the fitted noise model (terms the "
           "record only bounds at their 95 % bounds); profile-likelihood interval with the "
           "coil's lag profiled out")
    fit.entries.append(Entry("temp_ref_c", T_REF_C, None, None,
                             "chosen: the temperature terms' reference"))
    for key, _ in KEYS:
        v, a, b = th[key]
        fit.entries.append(Entry(key, v, a, b, how))
    v, a, b, what = _thermal_constant(log, th, ci, earth_rate, mp, mp_name)
    if bias_given:
        fit.notes.append(f"the thermal fit's constant at {T_REF_C:g} deg C ({what}): {v:.4g} "
                         f"[{a:.4g}, {b:.4g}] deg/h, to compare with bias_dph (another "
                         "power-on: they differ by the switch-on bias)")
    else:
        fit.entries.append(Entry("bias_dph", v, a, b, f"the thermal fit's constant at "
                                 f"{T_REF_C:g} deg C ({log.name}; {what})"))
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


def _thermal_constant(log, th: dict, ci: float, earth_rate, mp, mp_name):
    """(value, low, high, what it is) of the thermal fit's constant, deg/h, less the Earth rate's
    projection (when given) and the g terms at the thermal log's attitude (with a
    multi-position fit; their uncertainty widens the interval)."""
    v, a, b = th["bias_at_ref_dph"]
    what = []
    if earth_rate is not None:
        e = earth_rate / DPH
        v, a, b = v - e, a - e, b - e
        what.append(f"less the Earth rate's projection ({e:.6g} deg/h, the attitude "
                    "--input-axis states)")
    else:
        what.append("the Earth rate included: NOT corrected (give --latitude-deg and "
                    "--input-axis)")
    if mp is not None and log.f is not None:
        from fogbench.device.multipos import g_terms_at

        g, g_sd = g_terms_at(mp, np.array([log.f]))
        g, g_sd = float(g[0]) / DPH, g_sd / DPH
        zg = _z(ci) * g_sd                 # each side widened, the profile's shape kept
        v, a, b = v - g, v - g - math.hypot(v - a, zg), v - g + math.hypot(b - v, zg)
        what.append(f"less the g terms fitted to {mp_name} at its specific force "
                    f"[{', '.join(f'{x:.3g}' for x in log.f)}] g from {log.f_source} "
                    f"({g:.4g} deg/h, their uncertainty added to the interval)")
    elif mp is not None:
        what.append("the g terms at its unknown attitude included: NOT corrected (give it "
                    "acc_x/y/z columns)")
    return v, a, b, "; ".join(what)


def _multipos_entries(fit: DeviceFit, log, ci: float, res: dict, full_scale) -> None:
    from fogbench.device.multipos import SF_EXCITATION, TERMS

    col = f", column {log.column}" if log.column else ""
    fit.inputs.append(f"multi-position log {log.name} ({log.rate.size} samples at {log.fs:g} Hz"
                      f"{col})")
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
            if v is None and not res["scale_factor_excited"]:
                fit.undetermined[key] = (f"not fitted: {log.name}'s reference rate stays within "
                                         f"{SF_EXCITATION:g} Earth rates (the Earth rate alone "
                                         "does not excite it); a rate-table log gives it")
            elif v is None:
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
                         + "; ".join(_why_not(t, res["confounded"].get(t, []))
                                     for t in missing if t not in ("scale factor",
                                                                   "non-linearity")
                                     or res["scale_factor_excited"]))
    if res["constant"] is not None:
        v, a, b = (x / DPH for x in res["constant"])
        fit.notes.append(f"the multi-position fit's constant (the bias in that power-on, with "
                         f"what of the Earth rate the reference leaves out): {v:.4g} "
                         f"[{a:.4g}, {b:.4g}] deg/h")
    fit.notes.append(f"multi-position fit of {log.name}: generalised residual chi-square per "
                     f"degree of freedom {res['chi2_per_dof']:.3g} over {res['blocks']} "
                     "means (about 1 when the noise model and the g model explain the record)")


def _why_not(term: str, partners: list[str]) -> str:
    """Why a multi-position term is not identifiable: the columns it cannot be told apart from
    in the log's design, or that the design does not excite it at all."""
    if not partners:
        return f"{term} (not excited: its column is zero in every position)"
    squares = {"constant", "fx^2", "fy^2", "fz^2"}
    why = (" (fx^2 + fy^2 + fz^2 = 1 g^2 in every static position: the squares and the "
           "constant separate only on a centrifuge)" if {term, *partners} <= squares else "")
    return f"{term} (confounded with {', '.join(partners)}{why})"


def _all_fog_keys() -> list:
    """Every key of a [fog] table a device file may hold (the scenario's validation)."""
    from fogbench.scenario.device_file import fog_json_schema

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


#: Which Gauss-Markov term a device file takes when the record shows several: the file's
#: error model (``sim.fog.FogParams``: ``gm_drift_dps``, ``gm_time_constant_s``) holds one.
GM_RULE = ("the device file's error model holds one Gauss-Markov term (gm_drift_dps, "
           "gm_time_constant_s): it takes the one of largest sigma, the others are listed here")


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
        fit.entries.append(Entry("gm_drift_dps", g.value / DPS, g.low / DPS,
                                 None if g.high is None else g.high / DPS,
                                 f"the Gauss-Markov term of {origin} of largest sigma"
                                 + (f" ({GM_RULE})" if len(gms) > 1 else "")))
        fit.entries.append(Entry("gm_time_constant_s", g.tau, g.tau_low, g.tau_high,
                                 "its correlation time"))
        if len(gms) > 1:
            fit.notes.append(f"{origin} shows {len(gms)} Gauss-Markov terms; {GM_RULE}; left "
                             "out: " + "; ".join(f"{o.value / DPH:.3g} deg/h, tau {o.tau:.3g} "
                                                 "s" for o in gms[1:]))
