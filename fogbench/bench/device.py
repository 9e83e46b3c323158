"""Device-file round trip (``fogbench bench``, or ``python -m fogbench.bench.device``).

For every preset of ``sim/presets.toml``: simulate the logs a lab would take of it (eight static
power-ons, one long log and seven short ones, at the preset's class sample rate, and one
multi-position, centrifuge and rate-table program, :func:`fogbench.device.multipos.lab_program`,
60 s per part), fit a device file from them (:func:`fogbench.device.fit_device`, 68 % intervals)
and compare it with the preset, over 20 seeds. Per key: in how many seeds the fit determined it,
and in how many of those its interval covers the configured value (a term the preset does not
have counts as configured 0, so a spurious one is a miss). The g terms are compared with that
power-on's values (the preset's plus its switch-on draw, paper004_gyro's 0.3 deg/h/g: one
multi-position log measures its own power-on, not the spread). The issue's criterion: at least
60 %. The thermal keys: ``tests/device/test_device.py`` (their fit is slower).

The joint round trip of one gyro's static, thermal and multi-position logs:
:mod:`fogbench.bench.joint`.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, replace

import numpy as np

from fogcomp.units import DPH
from sim.fog import FogParams, simulate_fog

__all__ = ["CASES", "round_trip", "twin_in_band", "check_power", "run"]


@dataclass(frozen=True)
class RoundTrip:
    preset: str
    fs: float
    hours: float        # the long log; the seven others an eighth of it


CASES = [RoundTrip("low_grade", 100.0, 0.5), RoundTrip("mems_adis16405", 100.0, 1.0),
         RoundTrip("tactical", 10.0, 6.0), RoundTrip("navigation", 10.0, 12.0),
         RoundTrip("paper002_fog", 1.0, 14.3), RoundTrip("paper004_gyro", 10.0, 6.0)]

NOISE_KEYS = ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h", "quantization_arcsec",
              "rate_ramp_dph_per_h", "gm_drift_dps", "gm_time_constant_s", "bias_dph",
              "switch_on_bias_dph")
G_KEYS = tuple(f"g_sens_dph_per_g[{i}]" for i in range(3)) + tuple(
    f"g2_sens_dph_per_g2[{i}]" for i in range(6)) + ("scale_factor_ppm", "sf_nonlinearity_ppm")
KEYS = NOISE_KEYS + G_KEYS


def _device(name: str, fs: float) -> tuple[FogParams, dict]:
    from fogbench.bench.noise import _noise_only
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table
    from sim.rig import load_presets

    preset, *_ = _fog(_Table({"preset": name}, "[fog]", "bench"), fs)
    p = load_presets()[name]
    truth = {k: float(p.get(k, 0.0)) for k in NOISE_KEYS + ("scale_factor_ppm",
                                                           "sf_nonlinearity_ppm")}
    if not p.get("gm_drift_dps"):
        truth["gm_time_constant_s"] = None      # no Gauss-Markov term: no correlation time
    params = replace(_noise_only(preset), bias=preset.bias,
                     switch_on_bias_sigma=preset.switch_on_bias_sigma)
    return params, truth


def _multipos(name: str, fs: float, seed: int):
    """A lab's multi-position program of the preset (the whole error model at the reference
    temperature) and that power-on's g terms, deg/h per g and g^2: (MultiposLog, truth)."""
    from fogbench.device.multipos import MultiposLog, lab_program
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table

    preset, *_ = _fog(_Table({"preset": name}, "[fog]", "bench"), fs)
    f, ref, _ = lab_program(fs)
    w = np.zeros((ref.size, 3))
    w[:, 0] = ref
    out = simulate_fog(preset, fs, w, f, axes=("x",), seed=seed)
    truth = {f"g_sens_dph_per_g[{i}]": float(v) / DPH for i, v in enumerate(out.draws["g_sens"][0])}
    truth.update({f"g2_sens_dph_per_g2[{i}]": float(v) / DPH
                  for i, v in enumerate(out.draws["g2_sens"][0])})
    return MultiposLog("multipos", out.raw[:, 0], ref, f, fs), truth, preset.full_scale


def round_trip(case: RoundTrip, seeds: int = 20, logs: int = 8) -> dict:
    """{key: (seeds determined, seeds covered)} over ``seeds`` seeds of one preset."""
    from fogbench.device.fit import StaticLog
    from fogbench.device import fit_device

    params, truth = _device(case.preset, case.fs)
    n = int(case.hours * 3600 * case.fs)
    z_long, z_short = np.zeros((n, 3)), np.zeros((n // 8, 3))
    out: dict[str, list[int]] = {}
    for seed in range(seeds):
        recs = []
        for k in range(logs):
            z = z_long if k == 0 else z_short
            y = simulate_fog(params, case.fs, z, z, axes=("z",), seed=1000 * seed + k).raw[:, 0]
            recs.append(StaticLog(f"s{k}", y, case.fs, f=(0.0, 0.0, 0.0),
                                  f_source="zero specific force (simulated so)"))
        mlog, gtruth, full_scale = _multipos(case.preset, case.fs, 1000 * seed + 999)
        fit = fit_device(recs, multipos=mlog, full_scale=full_scale)
        known = {**truth, **gtruth}
        for e in fit.entries:
            if e.low is None:
                continue
            parts = ([(f"{e.key}[{i}]", v, a, b) for i, (v, a, b) in
                      enumerate(zip(e.value, e.low, e.high))] if isinstance(e.low, list)
                     else [(e.key, e.value, e.low, e.high)])
            for key, _, lo, hi in parts:
                if (lo is None and hi is None) or key not in known:
                    continue
                c = out.setdefault(key, [0, 0])
                c[0] += 1
                tv = known[key]
                c[1] += int(tv is not None and (lo is None or lo <= tv)
                            and (hi is None or tv <= hi))
    return {k: tuple(v) for k, v in out.items()}


def twin_in_band(case: RoundTrip, seed: int = 0, replicates: int = 20) -> float:
    """The share of octave averaging times (of the long log) where the median Allan deviation
    of the fitted device's twin lies inside the preset's band (2.5-97.5 percentiles over
    ``replicates`` records of the preset): one seed's fit."""
    from fogbench.device.fit import StaticLog
    from fogbench.device.file import _device_from_values
    from fogbench.device import fit_device, twin_curves
    from fogcomp.allan import oadev

    params, _ = _device(case.preset, case.fs)
    n = int(case.hours * 3600 * case.fs)
    z_long, z_short = np.zeros((n, 3)), np.zeros((n // 8, 3))
    recs = [StaticLog(f"s{k}", simulate_fog(params, case.fs, z_long if k == 0 else z_short,
                                            z_long if k == 0 else z_short, axes=("z",),
                                            seed=1000 * seed + k).raw[:, 0], case.fs)
            for k in range(8)]
    fit = fit_device(recs)
    taus, _ = oadev(recs[0].rate, case.fs)
    preset = twin_curves(params, case.fs, [(0, n)], taus, replicates, seed=10**6)
    twin = twin_curves(_device_from_values(fit.values(), case.fs), case.fs, [(0, n)], taus,
                       replicates, seed=2 * 10**6)
    lo, hi = np.percentile(preset, [2.5, 97.5], axis=0)
    med = np.median(twin, axis=0)
    return float(np.mean((med >= lo) & (med <= hi)))


#: The device ``device check`` is measured on: the tactical preset's white noise, flicker and
#: rate random walk (sim/presets.toml), plus a Gauss-Markov drift (0.05 deg/h, 500 s), logged
#: at rest for 16 h at 1 Hz (the long-tau terms a check must see; 1 Hz keeps 20 x 157 records
#: of 16 h to minutes).
CHECK_DEVICE = {"preset": "tactical", "gm_drift_dps": 0.05 / 3600.0, "gm_time_constant_s": 500.0}
#: The twins of the check: the device itself (its false alarms) and the device with one of its
#: noise terms missing (the power to see it is missing).
CHECK_TWINS = (("the device itself", {}), ("no flicker", {"bias_instability_dph": 0.0}),
               ("no rate random walk", {"rrw_dph_rt_h": 0.0}),
               ("no Gauss-Markov term", {"gm_drift_dps": 0.0}))


def check_power(seeds: int = 20, hours: float = 16.0, fs: float = 1.0, replicates: int = 39,
                level: float = 0.05, twins=None) -> dict:
    """``device check``'s whole-curve test on ``seeds`` logs of :data:`CHECK_DEVICE`, against
    each twin of :data:`CHECK_TWINS` (or those named in ``twins``): in how many seeds it finds
    the log and the twin disagree (p <= ``level``). Against the device itself that is the false-alarm rate (exactly
    the level by construction, measured here); against a twin missing a term, the power."""
    from fogbench.device.twin import curve_test, twin_curves
    from fogbench.device.file import _device_from_values
    from sim.rig import load_presets

    base = {k: v for k, v in load_presets()["tactical"].items() if k != "source"}
    base.update({k: v for k, v in CHECK_DEVICE.items() if k != "preset"})
    n = int(hours * 3600 * fs)
    m = 2 ** np.arange(int(np.log2((n - 1) // 2)) + 1)
    taus = m / fs
    device = _device_from_values(base, fs)
    models = {name: _device_from_values({**base, **change}, fs) for name, change in CHECK_TWINS
              if twins is None or name in twins}
    out = {name: 0 for name in models}
    for seed in range(seeds):       # a new log and new twins each time: independent trials
        log = twin_curves(device, fs, [(0, n)], taus, 1, seed=seed)[0]
        for j, (name, model) in enumerate(models.items()):
            twins = twin_curves(model, fs, [(0, n)], taus, replicates,
                                seed=10**7 + 10**5 * (len(models) * seed + j))
            out[name] += int(curve_test(log, twins)["p_value"] <= level)
    return out


def _binomial_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Clopper-Pearson interval of a proportion k of n."""
    from scipy.stats import beta

    a = (1 - level) / 2
    return (0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1)),
            1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k)))


def run(seeds: int = 20) -> None:
    res = check_power(seeds)
    print(f"device check's whole-curve test at the 5 % level: {seeds} logs of 16 h at 1 Hz "
          "of the tactical preset with a Gauss-Markov drift (0.05 deg/h, 500 s), each against "
          "39 twins; how often the log and the twin are found to disagree")
    for name, k in res.items():
        what = "false alarms" if name == "the device itself" else "power"
        print(f"  twin: {name:<22} {k:>3} of {seeds}  ({what} {k / seeds:.0%})")
    # 20 logs measure a false-alarm rate to about +-5 points; 400 to about +-1
    many = 20 * seeds
    k = check_power(many, twins=("the device itself",))["the device itself"]
    lo, hi = _binomial_interval(k, many)
    print(f"  twin: the device itself, {many} more logs: false alarms {k} of {many} "
          f"({k / many:.1%}, 95 % interval {lo:.1%} to {hi:.1%}; nominal 5 %)")
    print()
    print(f"Device-file round trip: {seeds} seeds per preset, 8 static power-ons each (one "
          "long log, seven an eighth of it) and a multi-position/centrifuge/rate-table "
          "program; per key: determined in how many seeds, its 68 % interval covering the "
          "preset's value (the g terms: that power-on's) in how many of those")
    print(f"{'preset':<16} {'long log':>9} {'key':<24} {'determined':>10} {'covered':>8} "
          f"{'share':>6}")
    for case in CASES:
        res = round_trip(case, seeds)
        for k in KEYS:
            if k not in res:
                continue
            d, c = res[k]
            print(f"{case.preset:<16} {case.hours:>7.3g} h {k:<24} {d:>10} {c:>8} "
                  f"{c / d:>6.0%}")
        print(f"{case.preset:<16} {case.hours:>7.3g} h the twin's median Allan deviation "
              f"inside the preset's 95 % band at {twin_in_band(case):.0%} of the averaging "
              "times (seed 0's fit, 20 records each)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m fogbench.bench.device")
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args(argv)
    run(seeds=args.seeds)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
