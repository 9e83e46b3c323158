"""``fogbench allan LOG --consistency``: the NIS of the filters a log's noise model implies, on
the held-out part of the log, and the inflation factor that makes each consistent
(:func:`fogcomp.consistency.held_out`).

Two filters per gyro channel, both identified on the first part of the log (``--holdout``: the
fraction held out, default 0.5) and run over the rest:

* the identified model (every term a filter can carry: white noise, random walk, ramp, each
  Gauss-Markov term, the flicker as Gauss-Markov terms);
* Kalibr's model (white noise N and bias random walk K only, the values the noise files carry:
  each identified, or its 95 % upper bound where the record does not show it): the filter a
  visual-inertial tool will run.

The known rate: a static log's mean holds the Earth rate's projection and the turn-on bias,
neither known here; the filter's bias state carries the constant from a diffuse prior, so the
NIS does not depend on it beyond the first samples.
"""

from __future__ import annotations

import math

import numpy as np

from fogbench.formats.errors import LogError

__all__ = ["measure", "consistency_json", "lines", "file_notes", "measured_factor", "GRID"]

#: Factors tried (0.5 to 1000, 28 log-spaced).
GRID = np.geomspace(0.5, 1000.0, 28)


def _kalibr_model(nm, fs):
    from fogcomp.consistency import BiasFilterModel

    def value(term):
        t = nm.term(term)
        if t.status == "identified" and t.value is not None:
            return float(t.value)
        return float(t.bound) if t.bound is not None else 0.0

    return BiasFilterModel(fs=fs, N=value("N"), K=value("K"), label="kalibr (N + K)")


def measure(log, chans, holdout: float, path, strict: bool = False) -> dict:
    """{channel name: {"held": HeldOut, "kalibr": InflationResult, "kalibr_model":
    BiasFilterModel}} of each gyro channel of ``log``. A channel the filter cannot be run on
    is {"error": why} with a warning (the Allan analysis is kept), or, ``strict`` (a factor is
    to be written), refused."""
    from fogbench.console import warn
    from fogcomp.consistency import held_out, inflation_factor

    out = {}
    for ch in chans:
        try:
            h = held_out(log.channels[ch], log.fs, split=1.0 - holdout, segments=log.segments,
                         terms=("all",), grid=GRID)
            km = _kalibr_model(h.noise_model, log.fs)
            y = log.channels[ch]
            segs = log.segments or [(0, y.shape[0])]
            pieces = [y[max(a, h.split):b] for a, b in segs if b - max(a, h.split) >= 64]
            kr = inflation_factor(km, pieces, terms="all", grid=GRID)
        except ValueError as exc:
            msg = f"{path}: column {log.sources[ch]!r}: --consistency: {exc}"
            if strict:
                raise LogError(msg + " (--inflate-measured needs a factor for every gyro "
                               "column)") from None
            warn(msg + "; its Allan analysis is kept")
            out[f"{ch}_{log.units[ch]}"] = {"error": str(exc)}
            continue
        out[f"{ch}_{log.units[ch]}"] = {"held": h, "kalibr": kr, "kalibr_model": km}
    return out


def _measured(results: dict) -> dict:
    """The columns whose consistency was measured."""
    return {k: r for k, r in results.items() if "error" not in r}


def _res_json(r) -> dict:
    return {"f_hat": r.f_hat, "f_low": r.f_low, "f_high": r.f_high, "flags": r.flags,
            "binding_block_samples": r.scale_L, "consistent_as_identified": r.consistent_at_1,
            "underconfident_scales_at_f_low": r.underconfident_at_f_low,
            "block_samples": r.L.tolist(), "nis_as_identified": r.nis_at_1.tolist(),
            "nis_band_low": r.band[:, 0].tolist(), "nis_band_high": r.band[:, 1].tolist(),
            "n_innovations": r.n, "method": r.method,
            "block_verdicts": [r.verdict_at(f) for f in (1.0, max(1.0, r.f_low), 10.0)],
            "factor_multiplies": "every coefficient (variances by its square)"}


def consistency_json(results: dict, holdout: float) -> dict:
    """The ``consistency`` entry of allan.json for each column."""
    out = {}
    for name, r in results.items():
        if "error" in r:
            out[name] = {"holdout_fraction": holdout, "error": r["error"]}
            continue
        h = r["held"]
        out[name] = {"holdout_fraction": holdout, "split_sample": h.split,
                     "n_identified": h.n_fit, "n_held_out": h.n_held,
                     "identified_on_first_part": h.noise_model.spec(),
                     "flicker_as_gm_max_rel_error": h.flicker_error,
                     "filter_states": h.filter_model.matrices()["states"],
                     "identified_model": _res_json(h.inflation["all"]),
                     "kalibr_model": _res_json(r["kalibr"])}
    return out


def _fmt(r) -> str:
    def f(v, flag):
        return f"{flag}{v:.3g}" if flag != ">" else f">{v:.3g}"

    return (f"{f(r.f_hat, r.flags['f_hat'])} [{f(r.f_low, r.flags['f_low'])}, "
            f"{f(r.f_high, r.flags['f_high'])}]")


def lines(results: dict) -> list[str]:
    """The printed table: per column and filter, the factor and its interval, the binding
    block length, and the verdict of the model as identified."""
    out = ["consistency (NIS of the held-out part; factor = smallest inflation of every "
           "coefficient that makes the block NIS consistent, [95 % interval by chi-square "
           "test inversion, Bonferroni over block lengths])"]
    for name, r in results.items():
        if "error" in r:
            out.append(f"  {name:14s} not measured: {r['error']}")
            continue
        h = r["held"]
        fs = h.noise_model.fs
        for label, res in (("identified model", h.inflation["all"]),
                           ("Kalibr N + K", r["kalibr"])):
            verdict = "consistent" if res.consistent_at_1 else "NOT consistent"
            extra = (f"; at the factor, block length(s) {res.underconfident_at_f_low} "
                     "underconfident" if res.underconfident_at_f_low else "")
            out.append(f"  {name:14s} {label:17s} factor {_fmt(res)} (binding block "
                       f"{res.scale_L / fs:.3g} s); as identified: {verdict}{extra}")
            vs = [res.verdict_at(f) for f in (1.0, max(1.0, res.f_low), 10.0)]
            out.append("  " + " " * 32 + "block lengths over / under / inside their band: "
                       + "; ".join(f"x{v['factor']:.3g}: {v['overconfident']} / "
                                   f"{v['underconfident']} / {v['consistent']}" for v in vs)
                       + " (identified, measured, a guessed 10)")
    return out


def measured_factor(results: dict) -> float:
    """The factor written by --inflate-measured: the largest over the columns of the Kalibr
    model's smallest consistent factor (its interval's lower end), at least 1. Refused (a
    LogError naming the column) where a column has none: not measured, not finite, or beyond
    the factor grid (no factor on it makes the filter consistent)."""
    lows = []
    for name, r in results.items():
        if "error" in r:
            raise LogError(f"--inflate-measured: column {name}: no factor was measured "
                           f"({r['error']})")
        k = r["kalibr"]
        if not math.isfinite(k.f_low) or k.flags.get("f_low") == ">":
            raise LogError(f"--inflate-measured: column {name}: no factor up to "
                           f"{GRID[-1]:g} makes Kalibr's N + K filter consistent (lower end "
                           f"{_fmt(k)}); the model's shape is wrong, not only its size: "
                           "write the identified values (leave out --inflate-measured)")
        lows.append(k.f_low)
    return max(1.0, max(lows))


def file_notes(results: dict, holdout: float) -> list[str]:
    """Comment lines of the Kalibr and OpenVINS files."""
    out = [f"consistency measured by fogbench allan --consistency: Kalibr's model (N, K) "
           f"identified on the first {1 - holdout:.0%} of the log, its filter run over the "
           "rest; factor = smallest inflation of N and K",
           "that makes the NIS consistent at every block length (chi-square, 95 %, "
           "Bonferroni); [interval] by test inversion:"]
    for name, r in _measured(results).items():
        out.append(f"  {name}: {_fmt(r['kalibr'])}; identified model (with its "
                   f"Gauss-Markov / flicker states): {_fmt(r['held'].inflation['all'])}")
    if len(_measured(results)) == len(results):
        try:
            out.append(f"  measured factor (the largest over the axes, at least 1): "
                       f"{measured_factor(results):.3g}")
        except LogError as exc:
            out.append(f"  no measured factor: {exc}")
    return out
