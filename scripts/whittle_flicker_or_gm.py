"""Can a record tell a flicker floor from a Gauss-Markov hump? The near-exact likelihood says.

For the two mirror profiles of ``fogbench.bench.noise_select`` (8 h at 10 Hz: white noise +
GM(0.05 deg/h, 500 s), and white noise + flicker 0.037 deg/h), each record's Hann-tapered
periodogram is fitted by the Whittle likelihood (Whittle 1953; the taper against the leakage of
the steep low-frequency spectrum, the ordinates' correlation under it counted by dividing the
log-likelihood by 1 + 2 (4/9 + 1/36) = 1.94, the variance of a mean of Hann-tapered ordinates
of white noise) under two readings, N + B and N + GM, and their difference of negative
log-likelihoods is printed. This uses every frequency of the record, not the Allan variance's
octaves, so it bounds what any Allan-variance selection can do: where it differs by a few
units with the same sign in both profiles, no rule can be right for both.

Written by hand (numpy FFT, scipy optimisers): no maintained library fits these sums of spectra
by Whittle likelihood. ``python scripts/whittle_flicker_or_gm.py [--seeds 10]``; about 2 s per
record.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.optimize import minimize

from fogbench.bench.noise_select import PROFILES, record

HANN_VIF = 1.0 + 2.0 * (4.0 / 9.0 + 1.0 / 36.0)


def periodogram(y, fs):
    """Two-sided density of the Hann-tapered record at the Fourier frequencies 2..n/2-1."""
    y = y - y.mean()
    w = np.hanning(y.size)
    w = w / np.sqrt(np.mean(w ** 2))
    spec = np.abs(np.fft.rfft(y * w)) ** 2 / (y.size * fs)
    f = np.fft.rfftfreq(y.size, 1.0 / fs)
    return f[2:-1], spec[2:-1]


def binned(f, spec, keep=200, width=0.02):
    """The first ``keep`` ordinates alone, then means over bins 2 % wide; weights the number
    of ordinates over the taper's variance factor."""
    fb, sb, mb = list(f[:keep]), list(spec[:keep]), [1.0] * keep
    i = keep
    while i < f.size:
        j = max(i + 1, int(np.searchsorted(f, f[i] * (1 + width))))
        fb.append(f[i:j].mean())
        sb.append(spec[i:j].mean())
        mb.append(j - i)
        i = j
    return np.array(fb), np.array(sb), np.array(mb) / HANN_VIF


def columns(f, fs, linear, ts):
    """Each term's two-sided density at unit variance: N^2, B^2 / (2 pi f) (IEEE Std 952
    Table C.1), and a discrete AR(1) of variance 1 and correlation time T."""
    cols = [np.ones_like(f) if t == "N" else 1.0 / (2 * np.pi * f) for t in linear]
    for T in ts:
        phi = math.exp(-1.0 / (fs * T))
        cols.append((1 - phi ** 2) / (fs * np.abs(1 - phi * np.exp(-2j * np.pi * f / fs)) ** 2))
    return np.column_stack(cols)


def fit(fb, sb, mb, fs, linear, n_gm):
    """The least negative log-likelihood over log-variances (and log T), 10 starts of T."""
    best = math.inf
    grid = np.geomspace(4.0 / fs, 0.3 / fb[0], 10)
    for ts0 in ([()] if n_gm == 0 else [(T,) for T in grid]):
        a0 = columns(fb, fs, linear, ts0)
        x0 = np.log([np.median(sb / a0[:, k]) * 0.3 for k in range(a0.shape[1])] + list(ts0))
        k = len(linear) + n_gm

        def nll(x):
            x = np.clip(x, -200, 200)
            s = columns(fb, fs, linear, np.exp(x[k:])) @ np.exp(x[:k])
            return float(np.sum(mb * (np.log(s) + sb / s)))

        r = minimize(nll, x0, method="L-BFGS-B")
        r = minimize(nll, r.x, method="Nelder-Mead", options={"maxiter": 4000})
        best = min(best, r.fun)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python scripts/whittle_flicker_or_gm.py")
    ap.add_argument("--seeds", type=int, default=10)
    seeds = ap.parse_args(argv).seeds
    profiles = [p for p in PROFILES if p.hours == 8.0]
    for p in profiles:
        diffs = []
        for s in range(1000, 1000 + seeds):
            fb, sb, mb = binned(*periodogram(record(p, s), p.fs))
            diffs.append(fit(fb, sb, mb, p.fs, ("N", "B"), 0)
                         - fit(fb, sb, mb, p.fs, ("N",), 1))
        print(f"{p.name}: -log L(N + B) - (-log L(N + GM)) over {seeds} records: "
              + " ".join(f"{d:+.1f}" for d in diffs)
              + f"  (median {np.median(diffs):+.1f}; > 0: the Gauss-Markov reading fits better; it has "
              "one parameter more)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
