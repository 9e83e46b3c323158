"""Benchmark: ``fogbench allan``'s deviation computation against allantools on the same data."""

from __future__ import annotations

import statistics
import time

import numpy as np

__all__ = ["bench_allan"]


def bench_allan(n: int = 10**7, repeats: int = 3, fs: float = 100.0) -> None:
    """Time the overlapping Allan deviation with its EDF confidence intervals
    (:func:`fogcomp.allan.oadev_ci`, what ``fogbench allan`` computes per column) against
    ``allantools.oadev`` (octave taus, rate data) on the same ``n`` white-noise samples, in the
    same run; print the medians of ``repeats`` runs, the ratio, and the largest relative
    difference of the two curves.

    Parameters
    ----------
    n : int
        Number of rate samples (default 10^7).
    repeats : int
        Timed runs of each (medians are printed).
    fs : float
        Sample rate, Hz.
    """
    import allantools

    from fogcomp.allan import oadev_ci

    y = np.random.default_rng(0).standard_normal(n)
    ours, theirs = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        c = oadev_ci(y, fs)
        ours.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        taus, ad, _, _ = allantools.oadev(y, rate=fs, data_type="freq", taus="octave")
        theirs.append(time.perf_counter() - t0)
    mo, mt = statistics.median(ours), statistics.median(theirs)
    k = min(len(taus), len(c.taus))
    diff = float(np.max(np.abs(c.adev[:k] / ad[:k] - 1.0)))
    print(f"allan on {n} samples ({len(c.taus)} octave taus), median of {repeats}:")
    print(f"  fogcomp oadev_ci (deviation + EDF intervals): {mo:.3f} s")
    print(f"  allantools.oadev:                            {mt:.3f} s")
    print(f"  ratio fogcomp / allantools:                  {mo / mt:.2f}")
    print(f"  largest relative difference of the curves:   {diff:.1e}")


if __name__ == "__main__":  # pragma: no cover
    bench_allan()
