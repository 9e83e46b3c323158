"""Benchmarks of the real-log commands: ``fogbench allan``'s deviation computation against
allantools on the same data, and ``fogbench compensate``'s CSV writing against pandas'
``to_csv``."""

from __future__ import annotations

import statistics
import time

import numpy as np

__all__ = ["bench_allan", "bench_compensate_write"]


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


def bench_compensate_write(n: int = 10**6, repeats: int = 3) -> None:
    """Time how ``fogbench compensate`` writes its output (:func:`fogbench.logs.compensate._write_csv`:
    pyarrow, gzip level 1) against the writer it replaced (pandas ``to_csv`` with
    ``float_format="%.10g"``, gzip at pandas' default level) on the same frame shaped as the
    ADIS16405 log plus three compensated columns (10 float columns), for ``.csv`` and
    ``.csv.gz``, in the same run; print medians, ratios and file sizes.

    Parameters
    ----------
    n : int
        Rows (default 10^6, the ADIS16405 log).
    repeats : int
        Timed runs of each (medians are printed).
    """
    import os
    import tempfile

    import pandas as pd

    from fogbench.logs.compensate import _significant, _write_csv

    rng = np.random.default_rng(0)
    cols = {"time_s": np.round(np.arange(n) / 100.0, 2)}
    for k in ("gyro_x_dps", "gyro_y_dps", "gyro_z_dps"):
        cols[k] = np.round(rng.standard_normal(n) * 0.3, 2)
    for k in ("accel_x_g", "accel_y_g", "accel_z_g"):
        cols[k] = np.round(rng.standard_normal(n) * 0.003 - (k == "accel_z_g"), 5)
    for k in ("gyro_x_comp_dps", "gyro_y_comp_dps", "gyro_z_comp_dps"):
        cols[k] = _significant(rng.standard_normal(n) * 0.3)
    frame = pd.DataFrame(cols)
    print(f"compensate output, {n} rows x {frame.shape[1]} columns, median of {repeats}:")
    with tempfile.TemporaryDirectory() as d:
        for suffix in (".csv", ".csv.gz"):
            gz = suffix.endswith(".gz")
            old_p, new_p = os.path.join(d, "old" + suffix), os.path.join(d, "new" + suffix)
            old, new = [], []
            for _ in range(repeats):
                t0 = time.perf_counter()
                frame.to_csv(old_p, index=False, float_format="%.10g",
                             compression="gzip" if gz else None)
                old.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                _write_csv(frame, new_p, gz=gz)
                new.append(time.perf_counter() - t0)
            mo, mn = statistics.median(old), statistics.median(new)
            print(f"  {suffix:8s} pandas to_csv %.10g: {mo:7.2f} s, "
                  f"{os.path.getsize(old_p) / 1e6:6.1f} MB"
                  f" | fogbench: {mn:6.2f} s, {os.path.getsize(new_p) / 1e6:6.1f} MB"
                  f" | ratio {mn / mo:.2f}")


if __name__ == "__main__":  # pragma: no cover
    bench_allan()
    bench_compensate_write()
