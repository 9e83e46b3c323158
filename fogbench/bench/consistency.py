"""Benchmark of the filter consistency tests (:mod:`fogcomp.consistency`) on records whose noise
and bias are known.

The record of the ``static_gm`` example (its FOG: ARW 0.03 deg/sqrt(h) and a Gauss-Markov drift
of 0.5 deg/h, 100 s; 4 h at 10 Hz), ``seeds`` power-ons simulated at rest by the project's FOG
error model (``sim.fog``), whose Gauss-Markov term is the true bias. On each, the bias filter of:

* the true model (the configured terms);
* the identified model (``fogcomp.allan.allan_analysis`` of that record, as ``fogbench allan``
  identifies it);
* the true model missing its Gauss-Markov term (white noise and an unknown constant);
* the identified model inflated by a guessed 10 (every coefficient; variances x 100);
* on the second half of each record: the model identified on the first half, as identified,
  inflated by the factor measured by the NIS of its filter on that second half
  (``fogbench allan --consistency``'s procedure), and by a guessed 10.

Per model: the share of records whose time-averaged NEES of the bias lies inside its
chi-square band (goal 95 % for the true and identified models), the share flagged
overconfident (goal >= 90 % for the model missing a term), each with its Clopper-Pearson 95 %
interval, and the mean coverage of the filter's 1-sigma and 2-sigma bands (68.3 %, 95.4 % for
a consistent filter) with t-intervals over the records.

Prints a table; asserts nothing. ``python -m fogbench.bench.consistency [--seeds 20]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fogcomp.units import DEG_RT_H, DPH

FS = 10.0
HOURS = 4.0
ARW = 0.03 * DEG_RT_H
GM_SIGMA = 0.5 * DPH
GM_T = 100.0


def _records(seeds: int, n: int):
    from sim.fog import FogParams, simulate_fog

    p = FogParams(arw=ARW, gm_drift=GM_SIGMA, gm_time_constant=GM_T)
    z, truth = [], []
    for s in range(seeds):
        o = simulate_fog(p, FS, np.zeros((n, 3)), np.zeros((n, 3)), seed=44_000 + s)
        z.append(o.raw[:, 0])
        truth.append(o.terms["gm_drift"][:, 0])
    return np.array(z), np.array(truth)


def measure(seeds: int = 20, hours: float = HOURS) -> dict:
    """{model label: summary (fogcomp.consistency.summarise_nees)} and timings."""
    from fogcomp.allan import allan_analysis
    from fogcomp.consistency import (BiasFilterModel, from_noise_model, nees_test, run_filter,
                                     summarise_nees, track_indices)

    n = int(round(hours * 3600 * FS))
    t0 = time.perf_counter()
    z, truth = _records(seeds, n)
    t_sim = time.perf_counter() - t0
    true = BiasFilterModel(fs=FS, N=ARW, gm=((GM_SIGMA, GM_T),), label="true")
    t0 = time.perf_counter()
    ident, specs = [], []
    for y in z:
        _, nm = allan_analysis(y, FS, record_length=False, alternative=False)
        ident.append(from_noise_model(nm))
        specs.append(nm.spec())
    t_id = time.perf_counter() - t0
    groups = {"true model": [true] * seeds, "identified model": ident,
              "missing the GM term": [true.without_gm()] * seeds,
              "identified x10 (guessed)": [m.inflated(10.0) for m in ident]}
    members = sum(groups.values(), [])
    t0 = time.perf_counter()
    run = run_filter(members, np.vstack([z] * len(groups)), track=track_indices(n, 200))
    res = nees_test(run, np.vstack([truth] * len(groups)))
    t_f = time.perf_counter() - t0
    out = {}
    for g, label in enumerate(groups):
        sl = slice(g * seeds, (g + 1) * seeds)
        from fogcomp.consistency import NeesResult

        part = NeesResult(nees=res.nees[sl], low=res.low[sl], high=res.high[sl],
                          nu=res.nu[sl], verdict=res.verdict[sl], cover1=res.cover1[sl],
                          cover2=res.cover2[sl])
        out[label] = summarise_nees(part)
    from collections import Counter

    t0 = time.perf_counter()
    held, factors = _held_out(z, truth)
    t_h = time.perf_counter() - t0
    out.update(held)
    return {"models": out, "n": n, "seeds": seeds, "identified_specs": Counter(specs),
            "factors": factors,
            "seconds": {"simulate": t_sim, "identify": t_id, "filter+nees": t_f,
                        "held-out": t_h}}


def _held_out(z, truth):
    """The measured factor on simulated records, checked against the truth: each record's
    first half identified, the factor measured by the NIS of its filter on the second half
    (:func:`fogcomp.consistency.inflation_factors`), then the NEES on the second half of the
    model as identified, inflated as measured (``max(1, f_low)``) and by a guessed 10."""
    from fogcomp.allan import allan_analysis
    from fogcomp.consistency import (NeesResult, from_noise_model, inflation_factors,
                                     nees_test, run_filter, summarise_nees, track_indices)

    seeds, n = z.shape
    h = n // 2
    models = [from_noise_model(allan_analysis(y[:h], FS, record_length=False,
                                              alternative=False)[1]) for y in z]
    res = inflation_factors(models, z[:, h:], grid=np.geomspace(0.5, 20.0, 14))
    f = np.array([max(1.0, r.f_low) for r in res])
    groups = {"held-out half: identified on the first": models,
              "held-out half: inflated as measured": [m.inflated(fi)
                                                      for m, fi in zip(models, f)],
              "held-out half: guessed 10": [m.inflated(10.0) for m in models]}
    run = run_filter(sum(groups.values(), []), np.vstack([z[:, h:]] * 3),
                     track=track_indices(n - h, 200))
    nr = nees_test(run, np.vstack([truth[:, h:]] * 3))
    out = {}
    for g, label in enumerate(groups):
        sl = slice(g * seeds, (g + 1) * seeds)
        out[label] = summarise_nees(NeesResult(
            nees=nr.nees[sl], low=nr.low[sl], high=nr.high[sl], nu=nr.nu[sl],
            verdict=nr.verdict[sl], cover1=nr.cover1[sl], cover2=nr.cover2[sl]))
    return out, {"f_low": [r.f_low for r in res], "f_hat": [r.f_hat for r in res],
                 "applied": f.tolist()}


def _pct(x):
    return f"{100 * x:5.1f}"


def run(seeds: int = 20, hours: float = HOURS) -> dict:
    print(f"Filter consistency (fogcomp.consistency): the static_gm example's FOG (ARW 0.03 "
          f"deg/sqrt(h), Gauss-Markov 0.5 deg/h, 100 s), {hours:g} h at {FS:g} Hz, {seeds} "
          "records simulated at rest by sim.fog; NEES of the bias, time-averaged over 200 "
          "times after 10 % burn-in, its 95 % band from the error's exact autocorrelation "
          "(scaled chi-square); [ ] Clopper-Pearson 95 % (shares), t 95 % (coverage)", flush=True)
    m = measure(seeds, hours)
    head = (f"  {'filter model':40s} {'in band %':>22s} {'overconfident %':>22s} "
            f"{'1-sigma cover %':>22s} {'2-sigma cover %':>22s} {'median NEES':>11s}")
    print(head)
    for label, s in m["models"].items():
        lo, hi = s["in_band_ci"]
        olo, ohi = s["overconfident_ci"]
        c1, c1l, c1h = s["cover1"]
        c2, c2l, c2h = s["cover2"]
        print(f"  {label:40s} {_pct(s['in_band'])} [{_pct(lo)}, {_pct(hi)}] "
              f"{_pct(s['overconfident'])} [{_pct(olo)}, {_pct(ohi)}] "
              f"{_pct(c1)} [{_pct(c1l)}, {_pct(c1h)}] {_pct(c2)} [{_pct(c2l)}, {_pct(c2h)}] "
              f"{s['median_nees']:11.3g}")
    print("  goals: in band 95 % for the true and identified models; overconfident >= 90 % "
          "for the model missing the GM term")
    fl = np.array(m["factors"]["f_low"])
    print(f"  measured factor on the held-out halves (smallest consistent, f_low): median "
          f"{np.median(fl):.3g}, range {fl.min():.3g} to {fl.max():.3g}; at most 1 (no "
          f"inflation needed) in {int(np.sum(fl <= 1.0))} of {fl.size}")
    print("  identified models: " + ", ".join(f"{k} x{v}" for k, v in
                                             m["identified_specs"].most_common()))
    sec = m["seconds"]
    print(f"  time: simulate {sec['simulate']:.1f} s, identify {sec['identify']:.1f} s, "
          f"filter and NEES {sec['filter+nees']:.1f} s ({m['n']} samples x "
          f"{4 * seeds} filters), held-out factors and NEES {sec['held-out']:.1f} s")
    return m


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--hours", type=float, default=HOURS)
    a = ap.parse_args(argv)
    run(a.seeds, a.hours)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
