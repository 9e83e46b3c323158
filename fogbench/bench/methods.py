"""Throughput of every registered fogcomp method (prints figures; asserts nothing about speed).

For each method, with its default hyperparameters (a seed where it needs one):

* fit time on 2,500 and on 50,000 samples of a synthetic record carrying every input a method
  may need (rate, g, temperature, temperature rate), medians over ``repeats`` fits;
* compensation rate, samples per second, on 1,000,000 samples (200,000 for the per-sample
  Python Kalman filter, whose rate does not depend on the length), median over ``repeats``;
* the same for the readings that are not the defaults (:data:`READINGS`: Levenberg-Marquardt,
  float64 gradient descent, online WNN on 2,500 samples only).

The synthetic record (seeded, so every run sees the same numbers): a rate of -60 deg/s with a
0.05 Hz sine of 1 deg/s, g on a slowly turning unit vector scaled by 1 +- 0.2 (a centrifuge-like
spread so that every g^2 term is identified), a chamber temperature sweeping -40 .. 60 C, and an
error of 5 deg/h + g and g^2 terms + temperature terms + white noise of 1e-4 rad/s. The figures
are the speed of the code on this machine, not of a method on a particular gyro.

Run: ``OPENBLAS_NUM_THREADS=1 python -m fogbench.bench.methods`` (or ``main(repeats)`` from
Python). On a shared two-core machine, numpy's multi-threaded BLAS on these small matrices
made the network fits 3-6 times slower than one thread (bp at 50,000 samples: 13.6 s against
2.9 s in the same hour); the variable must be set before numpy is imported.
``python -m fogbench.bench.methods --starts 20`` also runs :func:`compare_starts`: the ant colony
against random search with the same number of loss evaluations and against one random start,
over seeds, under both training functions.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
import warnings

import numpy as np

import fogcomp
from fogcomp import GyroData
from fogcomp.units import DPH, DPS

__all__ = ["main", "synthetic_record", "bench_method", "compare_starts"]

FIT_SIZES = (2_500, 50_000)
COMP_SIZE = 1_000_000
#: Methods that run a per-sample Python loop at compensation; timed on fewer samples.
SLOW_COMP = {"kalman": 200_000}


def synthetic_record(n: int, fs: float = 1.0, seed: int = 0):
    """A record with every input (see the module docstring).

    Parameters
    ----------
    n : int
        Samples.
    fs : float
        Sample rate, Hz.
    seed : int
        Seed of the noise and of the g directions.

    Returns
    -------
    data : GyroData
        rate (n,) rad/s, g (n, 3) in g, temp (n,) degC, temp_rate (n,) degC/s.
    truth : ndarray, shape (n,)
        The applied rate, rad/s.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    truth = -60.0 * DPS + 1.0 * DPS * np.sin(2 * np.pi * 0.05 * t)
    phase = 2 * np.pi * np.arange(n) / max(n, 1)
    g = np.column_stack([np.cos(7 * phase), np.sin(7 * phase) * np.cos(3 * phase),
                         np.sin(7 * phase) * np.sin(3 * phase)])
    g *= (1.0 + 0.2 * np.sin(11 * phase))[:, None]
    temp = 10.0 + 50.0 * np.sin(2 * phase)
    temp_rate = np.gradient(temp, t) if n > 1 else np.zeros(n)
    err = (5.0 + 2.0 * g[:, 0] - 0.5 * g[:, 2] ** 2 + 0.01 * (temp - 20.0)
           + 30.0 * temp_rate) * DPH
    rate = truth + err + 1e-4 * rng.standard_normal(n)
    return GyroData(rate=rate, fs=fs, g=g, temp=temp, temp_rate=temp_rate), truth


#: Readings that are not the default, timed beside the defaults: (label, method, params,
#: fit sizes). Online WNN is a per-sample Python loop, timed on 2,500 samples only.
READINGS = (
    ("bp lm", "bp", {"training": "lm"}, FIT_SIZES),
    ("aco_bp lm", "aco_bp", {"training": "lm"}, FIT_SIZES),
    ("bp float64", "bp", {"precision": "float64"}, FIT_SIZES),
    ("wnn online", "wnn", {"training": "online"}, (2_500,)),
)


def _make(name: str, **params):
    m = fogcomp.make_method(name, **params)
    if m.random:
        m.random_state = 1
    return m


def bench_method(name: str, repeats: int = 3, params: dict | None = None,
                 sizes=FIT_SIZES) -> dict:
    """Median fit times (s) at each of ``sizes`` and the compensation rate (samples/s)."""
    out = {"name": name}
    model = None
    params = params or {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for n in sizes:
            data, truth = synthetic_record(n)
            times = []
            for _ in range(repeats):
                m = _make(name, **params)
                t0 = time.perf_counter()
                m.fit(data, truth)
                times.append(time.perf_counter() - t0)
                model = m
            out[f"fit_s_{n}"] = statistics.median(times)
        nc = SLOW_COMP.get(name, COMP_SIZE)
        data, _ = synthetic_record(nc, seed=1)
        rates = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            model.compensate(data)
            rates.append(nc / (time.perf_counter() - t0))
        out["comp_per_s"] = statistics.median(rates)
        out["comp_n"] = nc
    return out


def _q(a) -> str:
    a = np.asarray(a)
    return f"{np.median(a):.4g} [{a.min():.4g}, {a.max():.4g}]"


def _shupe_like_dph(T, Tdot):
    """Smooth nonlinear bias law, deg/h (T in degC, Tdot in degC/s)."""
    return 10.0 * Tdot + 0.05 * (T - 20.0) ** 2 / 1000.0 + 0.05 * np.tanh((T - 10.0) / 20.0)


def _thermal_record(n: int, seed: int):
    """Chamber sweep -40 .. 60 C and back with holds (1 Hz), error = the law + white noise."""
    t = np.arange(n, dtype=float)
    temp = 10.0 + 50.0 * np.clip(1.6 * np.sin(2 * np.pi * t / n), -1, 1)
    temp_rate = np.gradient(temp, t)
    truth = np.zeros(n)
    err = (_shupe_like_dph(temp, temp_rate)
           + 0.01 * np.random.default_rng(seed).standard_normal(n)) * DPH
    return GyroData(rate=truth + err, fs=1.0, temp=temp, temp_rate=temp_rate), truth


def compare_starts(seeds: int = 20, n: int = 2500) -> dict:
    """ACO start vs random search (same 500 evaluations) vs one random start, over seeds.

    Fitted on a thermal record of ``n`` samples at 1 Hz whose error is a smooth nonlinear
    law of T and dT/dt (a Shupe term, a parabola and a tanh step, tenths of deg/h) plus white
    noise of 0.01 deg/h, held out on the same profile with fresh noise (RMSE against the law). For each start
    and each training (``"gd"``, ``"lm"``): the normalised MSE at the start, after training,
    and the held-out RMSE against the true error (deg/h), median [min, max] over method seeds
    0 .. seeds-1, and in how many seeds the colony's start beat random search's.

    Returns
    -------
    dict
        ``{(training, start): {"start_mse": array, "end_mse": array, "held_out_dph": array}}``
        with start in "aco", "random_search", "random_start".
    """
    fit, truth = _thermal_record(n, seed=0)
    test, test_truth = _thermal_record(n, seed=1)
    true_err = _shupe_like_dph(test.temp, test.temp_rate) * DPH
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for training in ("gd", "lm"):
            for start, name, kw in (("aco", "aco_bp", {}),
                                    ("random_search", "aco_bp", {"search": "random"}),
                                    ("random_start", "bp", {})):
                rows = {"start_mse": [], "end_mse": [], "held_out_dph": []}
                for seed in range(seeds):
                    m = fogcomp.make_method(name, training=training, random_state=seed, **kw)
                    m.fit(fit, truth)
                    rows["start_mse"].append(m.initial_loss_)
                    rows["end_mse"].append(m.loss_curve_[-1])
                    rows["held_out_dph"].append(
                        float(np.sqrt(np.mean((m.estimate_error(test) - true_err) ** 2)) / DPH))
                out[(training, start)] = {k: np.asarray(v) for k, v in rows.items()}
    print(f"\nstarts of the 2-9-1 network, {seeds} method seeds, fit on {n:,} samples "
          "(median [min, max]):")
    print(f"{'training':<9}{'start':<15}{'start MSE':>30}{'end MSE':>34}"
          f"{'held-out RMSE (deg/h)':>34}")
    for (training, start), r in out.items():
        print(f"{training:<9}{start:<15}{_q(r['start_mse']):>30}{_q(r['end_mse']):>34}"
              f"{_q(r['held_out_dph']):>34}")
    for training in ("gd", "lm"):
        a, rs = out[(training, "aco")], out[(training, "random_search")]
        print(f"{training}: ACO start below random search in "
              f"{int(np.sum(a['start_mse'] < rs['start_mse']))}/{seeds} seeds; end MSE below "
              f"in {int(np.sum(a['end_mse'] < rs['end_mse']))}/{seeds}; held out below in "
              f"{int(np.sum(a['held_out_dph'] < rs['held_out_dph']))}/{seeds}")
    return out


def bench_kalman_engines(repeats: int = 3, n_filterpy: int = 200_000,
                         n_fast: int = 200_000, gains=(1e-1, 1e-3)) -> dict:
    """The local-level filter on filterpy's full per-sample loop against the fast path
    (filterpy's update as scalars over the transient, then the steady-state recursion;
    :mod:`fogcomp.methods.kalman`), samples/s, medians of ``repeats``, and their ratio (the
    aim: >= 200 x filterpy), at a high and a low steady gain (a diffuse prior: the transient
    about 14 / gain samples, all of the fast path's time at the low gain). Also the RTS
    smoother on both."""
    from fogcomp.methods.kalman import local_level_filter

    rng = np.random.default_rng(0)
    r = 1.0
    out = {}
    for gain in gains:
        pp = gain * r / (1.0 - gain)
        q = pp * pp / (pp + r)                     # the process noise of that steady gain
        for smoother in (False, True):
            rates = {}
            for engine, n in (("filterpy", n_filterpy), ("fast", n_fast)):
                z = np.cumsum(rng.normal(0.0, math.sqrt(q), n)) + rng.normal(0.0, 1.0, n)
                times = []
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    local_level_filter(z, q, r, 0.0, 1e6, smoother=smoother, engine=engine)
                    times.append(time.perf_counter() - t0)
                rates[engine] = n / statistics.median(times)
            label = f"{'RTS smoother' if smoother else 'filter'}, gain {gain:g}"
            print(f"  kalman {label:<24} filterpy {rates['filterpy'] / 1e6:8.3f} M samples/s "
                  f"({n_filterpy:,}), fast path {rates['fast'] / 1e6:8.2f} M samples/s "
                  f"({n_fast:,}): ratio {rates['fast'] / rates['filterpy']:,.0f} x", flush=True)
            out[label] = rates
    print("  aim: fast path >= 200 x filterpy at every gain", flush=True)
    return out


def main(repeats: int = 3, methods: list[str] | None = None, quick: bool = False) -> int:
    """Print the table; returns 0 (exit status). ``quick``: filterpy's loop on 20,000 samples
    (its rate does not depend on the length), the fits on 2,500 samples only, no other
    readings."""
    if not methods or "kalman" in methods:
        print(f"Kalman engines (local-level filter, medians of {repeats}):", flush=True)
        bench_kalman_engines(repeats, n_filterpy=20_000 if quick else 200_000)
        print()
    names = methods or fogcomp.available_methods()
    print(f"fogcomp methods, default hyperparameters, medians of {repeats} "
          f"(fit on synthetic records; compensation on {COMP_SIZE:,} samples, "
          f"kalman on {SLOW_COMP['kalman']:,})", flush=True)
    hdr = (f"{'method':<14}{'fit 2,500 (s)':>15}{'fit 50,000 (s)':>16}"
           f"{'compensate (M samples/s)':>26}")
    print(hdr)
    print("-" * len(hdr), flush=True)
    for name in names:
        r = bench_method(name, repeats, sizes=(2500,) if quick else FIT_SIZES)
        big = f"{r['fit_s_50000']:>16.3f}" if "fit_s_50000" in r else f"{'not timed':>16}"
        print(f"{name:<14}{r['fit_s_2500']:>15.3f}{big}{r['comp_per_s'] / 1e6:>26.2f}",
              flush=True)
    readings = [] if quick else [rd for rd in READINGS if not methods or rd[1] in methods]
    if readings:
        print("\nother readings (not the defaults):")
        print(hdr)
        print("-" * len(hdr), flush=True)
    for label, name, params, sizes in readings:
        r = bench_method(name, repeats, params, sizes)
        big = f"{r['fit_s_50000']:>16.3f}" if "fit_s_50000" in r else f"{'not timed':>16}"
        print(f"{label:<14}{r['fit_s_2500']:>15.3f}{big}{r['comp_per_s'] / 1e6:>26.2f}",
              flush=True)
    return 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--method", action="append", help="only this method (repeatable)")
    p.add_argument("--starts", type=int, default=0, metavar="SEEDS",
                   help="also compare ACO / random-search / random starts over SEEDS seeds")
    a = p.parse_args()
    status = main(a.repeats, a.method)
    if a.starts:
        compare_starts(a.starts)
    sys.exit(status)
