"""Time the noise identifier (fogcomp.noise.identify_noise_model) on the ADIS16405 static log's
three gyro axes and a 6 h record at 100 Hz simulated here (ARW 0.3 deg/sqrt(h), RRW 3
deg/h/sqrt(h), a Gauss-Markov term of 10 deg/h and 300 s; seed 41): CPU time of the
identification alone (the Allan curves are computed first), best of ``--repeats``.

To compare two versions, run it with each on the path and the same options, e.g.::

    PYTHONPATH=../main .venv/bin/python scripts/time_noise_identification.py --out before.json
    PYTHONPATH=. .venv/bin/python scripts/time_noise_identification.py --out after.json
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from fogcomp.allan import pooled_oadev
from fogcomp.noise import identify_noise_model

DEG = math.pi / 180.0


def curves(realdata: Path) -> dict:
    out = {}
    df = pd.read_csv(realdata / "adis16405_static" / "imu1.csv.gz")
    for ax in "xyz":
        y = df[f"gyro_{ax}_dps"].to_numpy() * DEG
        m, adev = pooled_oadev(y, 100.0, None, [(0, y.size)])
        out[f"adis16405_{ax}"] = (m / 100.0, adev**2, 100.0, y.size)
    rng = np.random.default_rng(41)
    fs, n = 100.0, 6 * 3600 * 100
    arw, k = 0.3 * DEG / 60, 3.0 * DEG / 3600 / 60
    sigma, T = 10.0 * DEG / 3600, 300.0
    phi = math.exp(-1 / (fs * T))
    gm = lfilter([1.0], [1, -phi], rng.standard_normal(n) * sigma * math.sqrt(1 - phi**2))
    y = arw * math.sqrt(fs) * rng.standard_normal(n) + \
        np.cumsum(rng.standard_normal(n)) * k / math.sqrt(fs) + gm
    m, adev = pooled_oadev(y, fs, None, [(0, n)])
    out["sim_6h_100hz"] = (m / fs, adev**2, fs, n)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--realdata", type=Path, default=Path("../shared/realdata"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, help="JSON of the times and each model's datasheet")
    a = ap.parse_args()
    times, models = {}, {}
    for name, (t, v, fs, n) in curves(a.realdata).items():
        best = math.inf
        for _ in range(a.repeats):
            t0 = time.process_time()
            model = identify_noise_model(t, v, fs, n)
            best = min(best, time.process_time() - t0)
        times[name], models[name] = best, model.to_datasheet()
        print(f"{name:16s} {best:6.2f} s  {model.spec()}", flush=True)
    print(f"{'total':16s} {sum(times.values()):6.2f} s")
    if a.out:
        a.out.write_text(json.dumps({"times_s": times, "models": models}, indent=1))


if __name__ == "__main__":
    main()
