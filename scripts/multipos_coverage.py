"""Coverage of the multi-position fit's 68 % intervals with the TRUE noise model
(fogbench.device.multipos.fit_multipos on fogbench.device.multipos.lab_program), the numbers the
README quotes:

    python scripts/multipos_coverage.py preset tactical 100     # the preset's noise, 100 seeds
    python scripts/multipos_coverage.py flicker 200             # white noise + flicker

Prints, per term of the model, the share of seeds whose interval covers the value of that
power-on (sim.fog's draws), and the mean over the terms."""

from __future__ import annotations

import math
import sys

import numpy as np

from fogbench.bench.noise import _noise_only
from fogbench.device.multipos import TERMS, MultiposLog, fit_multipos, lab_program
from fogbench.scenario.device_file import _fog
from fogbench.scenario.tables import _Table
from fogcomp.units import DPH
from sim.fog import FogParams, simulate_fog


def main(argv) -> int:
    fs = 10.0
    if argv[0] == "preset":
        p, *_ = _fog(_Table({"preset": argv[1]}, "[fog]", "script"), fs)
        noise, seeds = _noise_only(p), int(argv[2])
    else:
        kw = dict(arw=0.03 * math.radians(1) / 60, bias_instability=0.05 * DPH,
                  bi_band=(1e-6, 1.0))
        p = FogParams(**kw, g_sens=(0.1 * DPH,) * 3, scale_factor=1e-4,
                      full_scale=math.radians(490), sf_nonlinearity=5e-5)
        noise, seeds = FogParams(**kw), int(argv[1])
    f, ref, _ = lab_program(fs)
    w = np.zeros((ref.size, 3))
    w[:, 0] = ref
    cover = np.zeros(len(TERMS))
    for seed in range(seeds):
        out = simulate_fog(p, fs, w, f, axes=("x",), seed=777 + seed)
        r = fit_multipos(MultiposLog("s", out.raw[:, 0], ref, f, fs), noise, 0.683, p.full_scale)
        truth = np.concatenate([[np.nan], out.draws["g_sens"][0], out.draws["g2_sens"][0],
                                [p.scale_factor, p.sf_nonlinearity]])
        for j, (name, _) in enumerate(TERMS[1:], start=1):
            v, lo, hi = r[name]
            cover[j] += lo <= truth[j] <= hi
    share = cover[1:] / seeds
    for (name, _), c in zip(TERMS[1:], share):
        print(f"{name:<14} {c:.2f}")
    print(f"mean over the terms: {share.mean():.3f} ({seeds} seeds)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
