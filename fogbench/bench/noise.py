"""Benchmark of the noise identifier (``fogcomp.noise``) on records whose noise is known.

For every preset of ``sim/presets.toml`` (its noise terms, on a record of the length its class
is logged for) and for mixed records (ARW + flicker + RRW; ARW + 1 and 2 Gauss-Markov terms;
quantisation + ARW + RRW), ``seeds`` records each, simulated by the project's FOG error model at
rest: the selected model (what ``fogbench allan`` reports) and the configured model stated
(``model=``), per configured term:

* how often it is identified, the median relative error and the median absolute relative
  error of its estimate, and how often its 68 % interval covers the configured value;
* the precision the record allows: the relative one-sigma of the term under the configured
  model, from the estimator's own covariance (the asymptotic bound of this estimator; no
  Allan-variance fit does better on that record);

and the terms reported that were not configured. Then the time to identify 10^7 samples (the
Allan variance and the identification, one core).

Prints a table; asserts nothing. ``python -m fogbench.bench.noise [--seeds 20]``.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import dataclass

import numpy as np

from fogcomp.allan import allan_analysis
from fogcomp.units import ARCSEC, DEG_RT_H, DPH, DPH_RT_H
from sim.fog import FogParams, simulate_fog


@dataclass(frozen=True)
class Case:
    name: str
    params: FogParams
    fs: float
    hours: float
    source: str

    def configured(self) -> tuple[dict, list]:
        """The configured model in the identifier's terms (SI): the flicker's B, the
        quantisation's Q = q / sqrt(12) (rms of a uniform angle error of one pulse q), the
        Gauss-Markov drift's (sigma, T)."""
        p = self.params
        co = {}
        if p.arw:
            co["N"] = p.arw
        if p.bias_instability:
            co["B"] = p.bias_instability
        if p.rrw:
            co["K"] = p.rrw
        if p.quantization:
            co["Q"] = p.quantization / math.sqrt(12.0)
        if p.rate_ramp:
            co["R"] = p.rate_ramp
        gm = [(p.gm_drift, p.gm_time_constant)] if p.gm_drift else []
        return co, gm


def _noise_only(params: FogParams) -> FogParams:
    return FogParams(arw=params.arw, bias_instability=params.bias_instability,
                     bi_band=params.bi_band, bi_per_decade=params.bi_per_decade,
                     gm_drift=params.gm_drift, gm_time_constant=params.gm_time_constant,
                     rrw=params.rrw, quantization=params.quantization)


def cases() -> list[Case]:
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.tables import _Table

    def preset(name, fs):
        params, *_ = _fog(_Table({"preset": name}, "[fog]", "bench"), fs)
        return _noise_only(params)

    out = [Case("low_grade", preset("low_grade", 100.0), 100.0, 1.0, "preset, 1 h at 100 Hz"),
           Case("mems_adis16405", preset("mems_adis16405", 100.0), 100.0, 10_000 / 3600,
                "preset, 10^6 samples at 100 Hz (the real log's length)"),
           Case("tactical", preset("tactical", 10.0), 10.0, 24.0, "preset, 24 h at 10 Hz"),
           Case("navigation", preset("navigation", 10.0), 10.0, 48.0, "preset, 48 h at 10 Hz"),
           Case("paper002_fog", preset("paper002_fog", 1.0), 1.0, 14.3,
                "preset, 14.3 h at 1 Hz (paper 002's run)"),
           Case("paper004_gyro", preset("paper004_gyro", 10.0), 10.0, 8.0,
                "preset, 8 h at 10 Hz")]
    arw = 0.03 * DEG_RT_H
    out += [
        Case("ARW+flicker+RRW 96 h", FogParams(arw=arw, bias_instability=0.1 * DPH,
                                               bi_band=(1e-6, 0.1), rrw=0.1 * DPH_RT_H),
             10.0, 96.0, "tactical noise, 96 h at 10 Hz"),
        Case("ARW+GM(0.05 deg/h, 500 s)", FogParams(arw=arw, gm_drift=0.05 * DPH,
                                                    gm_time_constant=500.0),
             10.0, 8.0, "a slow drift as in a tactical FOG, 8 h at 10 Hz"),
        Case("ARW+GM(0.5 deg/h, 100 s)", FogParams(arw=arw, gm_drift=0.5 * DPH,
                                                   gm_time_constant=100.0),
             10.0, 4.0, "a Gauss-Markov term above the ARW, 4 h at 10 Hz"),
        Case("Q+ARW+RRW", FogParams(arw=arw, rrw=0.1 * DPH_RT_H, quantization=0.5 * ARCSEC),
             10.0, 24.0, "24 h at 10 Hz"),
    ]
    return out


def _two_gm(seed: int, n: int, fs: float):
    """ARW 0.03 deg/sqrt(h) + GM(0.1 deg/h, 20 s) + GM(0.05 deg/h, 2000 s): the error model
    holds one Gauss-Markov drift, so the second comes from a second draw of it."""
    a = simulate_fog(FogParams(arw=0.03 * DEG_RT_H, gm_drift=0.1 * DPH, gm_time_constant=20.0),
                     fs, np.zeros((n, 3)), np.zeros((n, 3)), seed=seed).raw[:, 0]
    b = simulate_fog(FogParams(gm_drift=0.05 * DPH, gm_time_constant=2000.0), fs,
                     np.zeros((n, 3)), np.zeros((n, 3)), seed=seed + 10**6).raw[:, 0]
    return a + b


def predicted_precision(case_co: dict, gm: list, fs: float, n: int) -> dict:
    """Relative one-sigma of each configured term's coefficient (its square root) under the
    configured model, from the estimator's covariance of a record of n samples."""
    import fogcomp.noise as NZ
    from fogcomp.noise import _fit

    m = 2 ** np.arange(int(math.floor(math.log2((n - 1) // 2))) + 1)
    t = m / fs
    v = NZ.avar_model(t, case_co, gm, fs)
    pb = _fit._Problem(t, v, m, (n,), fs, 0.001)
    pb.set_weights(case_co, gm)
    spec = _fit._Spec(tuple(k for k in NZ.LINEAR_TERMS if k in case_co),
                    tuple(T for _, T in gm))
    coef = np.array([case_co[k] ** 2 for k in spec.linear] + [s**2 for s, _ in gm])
    cov = _fit._param_cov(pb, _fit._Fit(spec, coef, 0.0))
    out = {}
    for i, k in enumerate(spec.linear):
        out[k] = math.sqrt(cov[i, i]) / coef[i] / 2
    nl = len(spec.linear)
    for g in range(len(gm)):
        out[f"GM{g}"] = math.sqrt(cov[nl + g, nl + g]) / coef[nl + g] / 2
        out[f"T{g}"] = math.sqrt(cov[nl + len(gm) + g, nl + len(gm) + g])
    return out


def _term_rows(models, co, gm, identified_only: bool):
    """Per configured term: (label, identified count, errors, coverages); the errors of the
    records where it was identified only (``identified_only``: the selected model's reading),
    or of every estimate (the stated model's)."""
    rows = []
    for k, want in co.items():
        vals = [m.term(k) for m in models]
        est = [t for t in vals if t.value is not None
               and (t.status == "identified" or not identified_only)]
        err = [t.value / want - 1 for t in est]
        # a term the record does not show has its bound, no interval: [0, bound] then
        cover = [(t.low if t.low is not None else 0.0) <= want <=
                 (t.high if t.high is not None else t.bound if t.status == "upper bound"
                  and t.bound is not None else math.inf) for t in est]
        rows.append((k, sum(t.status == "identified" for t in vals), err, cover))
    for g, (sigma, T) in enumerate(gm):
        found = [min(m.gm_terms, key=lambda x: abs(math.log(x.tau / T))) if m.gm_terms else None
                 for m in models]
        est = [x for x in found if x is not None]
        rows.append((f"GM{g} sigma", len(est), [x.value / sigma - 1 for x in est],
                     [(x.low or 0.0) <= sigma <= (x.high or x.bound or math.inf)
                      for x in est]))
        rows.append((f"GM{g} tau", len(est), [x.tau / T - 1 for x in est],
                     [(x.tau_low or 0.0) <= T <= (x.tau_high or math.inf) for x in est]))
    return rows


def _fmt(v, pct=True) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{100 * v:+.1f}" if pct else f"{v:.2f}"


def run(seeds: int = 20, time_1e7: bool = True) -> None:
    print(f"Noise identification (fogcomp.noise), {seeds} records per case, simulated at rest "
          "by sim.fog; selected = the model fogbench allan reports, stated = the configured "
          "model given as model=; err = estimate / configured - 1 (median, median of |err|; "
          "for the selected model over the records where the term was identified), "
          "cover = share of records whose 68 % interval holds the configured value; "
          "bound = the record's own limit: the term's relative one-sigma under the configured "
          "model (this estimator's covariance)")
    head = (f"  {'case / term':34s} {'ident':>6s} {'sel err%':>9s} {'|err|%':>7s} {'cover':>6s}"
            f" {'stated err%':>12s} {'|err|%':>7s} {'cover':>6s} {'bound%':>7s}")
    all_cases = cases() + [None]
    for case in all_cases:
        if case is None:
            name, fs, hours = "ARW+GM(0.1, 20 s)+GM(0.05, 2000 s)", 10.0, 12.0
            co = {"N": 0.03 * DEG_RT_H}
            gm = [(0.1 * DPH, 20.0), (0.05 * DPH, 2000.0)]
            make = (lambda s, n: _two_gm(s, n, fs))
            src = "two drifts a decade apart, 12 h at 10 Hz"
        else:
            name, fs, hours, src = case.name, case.fs, case.hours, case.source
            co, gm = case.configured()
            p = case.params
            make = (lambda s, n, p=p, fs=fs: simulate_fog(p, fs, np.zeros((n, 3)),
                                                         np.zeros((n, 3)), seed=s).raw[:, 0])
        n = int(round(hours * 3600 * fs))
        stated = " + ".join([k for k in ("Q", "N", "B", "K", "R") if k in co] + ["GM"] * len(gm))
        sel, sta, extra, t_id = [], [], 0, []
        for s in range(seeds):
            y = make(1000 + s, n)
            t0 = time.perf_counter()
            _, m = allan_analysis(y, fs, record_length=False, alternative=False)
            t_id.append(time.perf_counter() - t0)
            sel.append(m)
            sta.append(allan_analysis(y, fs, model=stated, record_length=False)[1])
            extra += sum(1 for t in m.identified if t.term not in co and t.term != "GM")
            extra += max(0, len(m.gm_terms) - len(gm))
        bound = predicted_precision(co, gm, fs, n)
        print(f"\n{name} ({src}; {n} samples; configured {stated}; identification "
              f"{statistics.median(t_id):.2f} s median)")
        print(head)
        rows_sel = _term_rows(sel, co, gm, identified_only=True)
        rows_sta = {r[0]: r for r in _term_rows(sta, co, gm, identified_only=False)}
        for label, ident, err, cover in rows_sel:
            s_lab, _, s_err, s_cov = rows_sta[label]
            key = label if label in bound else ("GM" + label[2] if "sigma" in label else
                                                "T" + label[2])
            b = bound.get(key)
            med = statistics.median(err) if err else None
            mad = statistics.median([abs(e) for e in err]) if err else None
            smed = statistics.median(s_err) if s_err else None
            smad = statistics.median([abs(e) for e in s_err]) if s_err else None
            cov_s = f"{np.mean(cover):.2f}" if cover else "-"
            cov_t = f"{np.mean(s_cov):.2f}" if s_cov else "-"
            bstr = f"{100 * b:.1f}" if b is not None else "-"
            print(f"  {label:34s} {ident:3d}/{seeds:<2d} {_fmt(med):>9s} "
                  f"{_fmt(mad).lstrip('+'):>7s} {cov_s:>6s} {_fmt(smed):>12s} "
                  f"{_fmt(smad).lstrip('+'):>7s} {cov_t:>6s} {bstr:>7s}")
        print(f"  terms reported that were not configured: {extra} in {seeds} records")
    if time_1e7:
        bench_1e7()


def bench_1e7(repeats: int = 3) -> None:
    """Time to identify 10^7 samples (100 Hz, tactical noise: 27.8 h), one core: the octave
    Allan variance and the identification, medians of ``repeats``."""
    n, fs = 10**7, 100.0
    p = FogParams(arw=0.03 * DEG_RT_H, bias_instability=0.1 * DPH, bi_band=(1e-6, 0.1),
                  rrw=0.1 * DPH_RT_H, quantization=0.5 * ARCSEC)
    y = simulate_fog(p, fs, np.zeros((n, 3)), np.zeros((n, 3)), seed=3).raw[:, 0]
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        _, m = allan_analysis(y, fs)
        times.append(time.perf_counter() - t0)
    print(f"\nIdentification of 10^7 samples (tactical noise with quantisation, 100 Hz): "
          f"{statistics.median(times):.2f} s median of {repeats} (min {min(times):.2f}, max "
          f"{max(times):.2f}); aim: under 10 s on one core; model {m.spec()}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m fogbench.bench.noise")
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args(argv)
    run(seeds=args.seeds)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
