"""``device check``: the device simulated at rest under a log's own conditions (sample rate,
length, gap-free pieces) over replicates, its Allan curves set beside the log's.

The verdict is one test of the whole curve (:func:`curve_test`): the log's Allan deviations at
every averaging time are one point in a space of as many dimensions; its distance from the
twins' curves (each averaging time weighted by the twins' spread there) is ranked among the same
distance of each twin from the others. Under the hypothesis that the log is one more draw of the device, the log is
exchangeable with the twins and its rank is uniform, so the p-value is exact at every record
length and device, whatever the curves' distribution (a Monte Carlo test, Barnard 1963; Besag
and Clifford 1989). The per-tau bands stay, to show where the curves part.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fogcomp.units import DPH

__all__ = ["twin_curves", "check_device", "curve_test"]

CHECK_CI = 0.95                            # the log's interval and the twin's band in `check`
MAX_CHECK_REPLICATES = 1000
#: The level of the whole-curve test: the log disagrees with the device when p <= this (with
#: R twins p takes the values k / (R + 1), and P(p <= k / (R + 1)) = k / (R + 1) exactly, so
#: 19 twins give a test of exactly 5 %, 39 twins too).
CHECK_LEVEL = 0.05
#: Shrinkage of the twins' covariance of log Allan deviations towards its diagonal (1: the
#: diagonal alone, each averaging time weighted by the twins' spread there). The covariance of
#: ~16 averaging times estimated from 39 twins is noisy. Measured on 16 h logs at 1 Hz
#: (fogbench.bench.device.check_power, 20 seeds, the same logs and twins for each value):
#: false alarms 2, 1 and 0 of 20 at 0.2, 0.5 and 1; power against a twin missing flicker 20 of
#: 20 at each; missing the rate random walk 2, 4 and 5 of 20. Every value keeps the test exact
#: (the Monte Carlo ranking carries the correlation between averaging times into the p-value);
#: on curves whose correlation is well estimated (8 taus, tests/device) a smaller shrinkage has
#: more power.
COVARIANCE_SHRINKAGE = 1.0


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


def curve_test(log_adev: np.ndarray, twin: np.ndarray,
               shrinkage: float = COVARIANCE_SHRINKAGE) -> dict:
    """A Monte Carlo test of the whole Allan curve of a log against a device's twins.

    Parameters
    ----------
    log_adev : ndarray, shape (T,)
        The log's Allan deviation at T averaging times, rad/s.
    twin : ndarray, shape (R, T)
        The same of R records of the device under the log's conditions.
    shrinkage : float
        Weight of the diagonal in the covariance (0 < shrinkage <= 1).

    Returns
    -------
    dict
        ``statistic``: the log's squared distance from the twins' mean (log Allan deviations,
        weighted by the inverse of the twins' covariance shrunk towards its diagonal: with
        ``shrinkage`` 1, each averaging time by the twins' variance there); ``p_value``: its
        rank, the share of the R + 1 curves (the log's included) whose distance from the
        others is at least the log's; ``taus_used``: where every curve is positive and finite.

    Notes
    -----
    Each of the R + 1 curves is measured against the other R in the same way, so under the
    hypothesis that the log is a draw of the device the R + 1 distances are exchangeable and
    ``P(p_value <= k / (R + 1)) = k / (R + 1)`` exactly.
    """
    X = np.vstack([np.asarray(log_adev, float)[None, :], np.asarray(twin, float)])
    ok = np.all(np.isfinite(X) & (X > 0), axis=0)
    if ok.sum() < 2 or X.shape[0] < 5:
        raise ValueError("the whole-curve test needs at least 2 averaging times where every "
                         "curve is positive and 4 twins")
    X = np.log(X[:, ok])
    n = X.shape[0]
    stats = np.empty(n)
    for i in range(n):
        others = np.delete(X, i, axis=0)
        d = X[i] - others.mean(axis=0)
        S = np.atleast_2d(np.cov(others, rowvar=False))
        S = (1.0 - shrinkage) * S + shrinkage * np.diag(np.diag(S))
        stats[i] = float(d @ np.linalg.solve(S, d))
    p = float(np.sum(stats >= stats[0]) / n)
    return {"statistic": float(stats[0]), "p_value": p, "taus_used": ok,
            "twin_statistics": stats[1:]}


def check_device(curve, twin: np.ndarray, level: float = CHECK_LEVEL) -> dict:
    """The log's Allan curve against the twins': the whole-curve test (:func:`curve_test`,
    ``p_value``, ``agrees`` when p > ``level``), and at each tau whether the log's interval
    (``curve.low``, ``curve.high``) overlaps the twins' central band (the 2.5 and 97.5
    percentiles over replicates), to show where they part."""
    lo, hi = np.percentile(twin, [2.5, 97.5], axis=0)
    agree = (curve.low <= hi) & (curve.high >= lo)
    test = curve_test(curve.adev, twin)
    return {"band_low": lo, "band_high": hi, "median": np.median(twin, axis=0),
            "agree": agree, "share": float(np.mean(agree)), "p_value": test["p_value"],
            "statistic": test["statistic"], "level": level,
            "agrees": test["p_value"] > level}


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
    verdict = "agrees" if res.get("agrees", True) else "DISAGREES"
    ax.set_title(f"{title}\nwhole curve: p = {res['p_value']:.3g}, the {what} {verdict} with "
                 f"the device; per tau: overlap at {res['share']:.0%} of the averaging times")
    ax.legend(fontsize=8)
    fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def _is_check_json(path: Path) -> bool:
    try:
        return json.loads(Path(path).read_text()).get("format") == "fogbench-device-check"
    except (OSError, ValueError, AttributeError):
        return False
