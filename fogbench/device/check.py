"""``device check``: the device simulated at rest under a log's own conditions (sample rate,
length, gap-free pieces) over replicates, its Allan curves set beside the log's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fogcomp.units import DPH

__all__ = ["twin_curves", "check_device"]

CHECK_CI = 0.95                            # the log's interval and the twin's band in `check`
MAX_CHECK_REPLICATES = 1000


# ---------------------------------------------------------------------------------------------
# check
def twin_curves(params, fs: float, segments, taus, replicates: int, seed: int = 0,
                progress=None) -> np.ndarray:
    """Allan deviations (rad/s) at ``taus`` of ``replicates`` records of the device at rest,
    each with the gap-free pieces [start, stop) of the log (every piece its own power-on draw
    of the noise, as a log split at its gaps pools them)."""
    from fogcomp.allan import pooled_oadev
    from sim.fog import simulate_fog

    segs = [(int(a), int(b)) for a, b in segments]
    n = segs[-1][1]
    out = np.empty((replicates, len(taus)))
    for r in range(replicates):
        y = np.zeros(n)
        for i, (a, b) in enumerate(segs):
            z = np.zeros((b - a, 3))
            y[a:b] = simulate_fog(params, fs, z, z, axes=("z",),
                                  seed=seed + 1000 * r + i).raw[:, 0]
        _, adev = pooled_oadev(y, fs, np.asarray(taus), segs)
        out[r] = adev
        if progress is not None:
            progress(r + 1)
    return out


def check_device(curve, twin: np.ndarray) -> dict:
    """Where the log's Allan curve and the twin's agree: at each tau, whether the log's
    interval (``curve.low``, ``curve.high``) overlaps the twin's central band (the 2.5 and 97.5
    percentiles over replicates); the share of taus where it does."""
    lo, hi = np.percentile(twin, [2.5, 97.5], axis=0)
    agree = (curve.low <= hi) & (curve.high >= lo)
    return {"band_low": lo, "band_high": hi, "median": np.median(twin, axis=0),
            "agree": agree, "share": float(np.mean(agree))}


def _plot_check(tmp: str, title: str, curve, res: dict, interval: str, what: str = "log") -> None:
    """Top: the record's Allan curve and interval, the twin's median and band; bottom: both
    divided by the twin's median (where a few per cent decide the overlap)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, med = curve.taus, res["median"]
    fig, (ax, rx) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True,
                                 gridspec_kw={"height_ratios": [3, 1.4]})
    for a_, scale in ((ax, DPH), (rx, med)):
        a_.fill_between(t, res["band_low"] / scale, res["band_high"] / scale, color="C1",
                        alpha=0.3, label="twin: 95 % band over replicates")
        a_.plot(t, med / scale, color="C1", lw=1, label="twin: median")
        a_.fill_between(t, curve.low / scale, curve.high / scale, color="k", alpha=0.15,
                        label=f"{what}: {interval}")
        a_.plot(t, curve.adev / scale, "k.-", lw=1, label=what)
        bad = ~res["agree"]
        if bad.any():
            a_.plot(t[bad], (curve.adev / scale)[bad], "rx", ms=8, label="no overlap")
        a_.set_xscale("log")
        a_.grid(True, which="both", alpha=0.3)
    ax.set_yscale("log")
    ax.set_ylabel("Allan deviation, deg/h")
    rx.set_ylabel("/ twin median")
    rx.set_xlabel("averaging time tau, s")
    ax.set_title(f"{title}\nagree within their intervals at {res['share']:.0%} of the "
                 "averaging times")
    ax.legend(fontsize=8)
    fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def _is_check_json(path: Path) -> bool:
    try:
        return json.loads(Path(path).read_text()).get("format") == "fogbench-device-check"
    except (OSError, ValueError, AttributeError):
        return False
