"""The temperature terms of a device file from a thermal log (``fogbench device fit
--thermal``): a gyro at a constant rate through a chamber program, its temperature sensor
logged beside it.

Model (``sim.fog``): rate = b + k1 dT + k2 dT^2 + (k3 + k4 dT) dTc/dt + noise, dT = Tc - T_ref,
Tc the coil temperature. The coil is taken to lag the sensor by a first-order lag of time
constant tau (``sim.thermal``: the coil lags the housing; tau = 0 when the sensor is on the
coil), chosen on a grid by the smallest generalised residual.

Why generalised least squares: in a thermal run the slow noise terms (flicker, a rate random
walk) have the same time scales as the temperature program, so ordinary least squares (even
with Newey-West intervals) trades them against the temperature terms and states intervals far
too narrow (measured on the tactical preset: the T coefficient's 68 % interval covered the truth
in 1-2 of 5 runs). Here the residual's covariance is the noise model's: the one identified from
the static logs or the Allan curve given with the thermal log. The
estimate is weighted by its inverse (10 s means, a Cholesky solve), and its covariance
(X' C^-1 X)^-1 is exact when the noise model is; it is scaled up by the residual's chi-square
per degree of freedom when that exceeds 1 (a misfit the noise model does not explain). The lag
is a nuisance a record may hardly determine: each coefficient's interval (and that of any
combination of them, such as the terms at a static log's temperature) is its profile-likelihood
interval with the lag profiled out (:func:`combination`: every value whose best residual over
the lags stays within the chi-square quantile of one degree of freedom). Measured on 10 seeds
of the thermal runs of ``tests/device/test_device.py``: the 68 % intervals covered the
tactical preset's four coefficients in 10, 10, 9 and 8 seeds and paper002_fog's in 10 of 10,
at 1/8 (tactical) and 1/2 (paper002_fog) of the width of the union of each lag's interval at
(1 + ci) / 2 (Bonferroni) used before, which covered 10 of 10 everywhere. The coil is taken to start at the sensor's temperature
(the FOG soaked when the log starts); a design the program cannot separate (a single ramp:
dT and dT/dt move together) is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fogcomp.units import DPH

__all__ = ["ThermalLog", "fit_thermal", "BLOCK_S", "LAG_GRID_S", "KEYS"]

BLOCK_S = 10.0                 # the fit works on 10 s means (longer past MAX_BLOCKS blocks)
RATE_WINDOW_S = 60.0           # dT/dt of a sensor on the coil: differenced over +-30 s
LAG_GRID_S = np.concatenate([[0.0], np.geomspace(10.0, 2e4, 67)])
KEYS = (("temp_coeff_dph_per_c", DPH), ("temp_coeff2_dph_per_c2", DPH),
        ("temp_rate_coeff_dph_per_c_per_min", DPH * 60.0),
        ("temp_cross_coeff_dph_per_c_per_c_per_min", DPH * 60.0))
T_REF_C = 20.0
MAX_BLOCKS = 3000              # longer logs get longer blocks (the covariance is m x m)
MAX_CONDITION = 100.0          # a design more collinear than this is refused (below)


@dataclass(frozen=True)
class ThermalLog:
    """A record of one gyro axis at a constant rate through a temperature program: rate
    (rad/s), the temperature sensor's reading (deg C) at each sample, sample rate (Hz), and
    its attitude where known."""

    name: str
    rate: np.ndarray
    temp: np.ndarray
    fs: float
    column: str = ""
    #: the mean specific force along the body axes during the log, in g (3,), or None (its
    #: attitude is not known: no accelerometer columns and no stated attitude)
    f: tuple | None = None
    f_source: str = ""


def _blocks(x: np.ndarray, k: int) -> np.ndarray:
    m = x.size // k
    return x[:m * k].reshape(m, k).mean(axis=1)


def design(Tb: np.ndarray, h: float, tau: float, t_ref: float = T_REF_C) -> np.ndarray:
    """Columns [1, dT, dT^2, r, dT r] for a coil lagging the sensor means ``Tb`` (spacing h, s)
    by ``tau`` (0: the sensor is on the coil; r differenced over +-30 s)."""
    from sim.thermal import _lag

    if tau <= 0.0:
        w = max(1, int(round(RATE_WINDOW_S / h / 2.0)))
        k = np.arange(Tb.size)
        hi, lo = np.minimum(k + w, Tb.size - 1), np.maximum(k - w, 0)
        coil, rate = Tb, (Tb[hi] - Tb[lo]) / ((hi - lo) * h)
    else:
        coil = _lag(Tb, h, tau, float(Tb[0]))
        rate = (Tb - coil) / tau
    d = coil - t_ref
    return np.column_stack([np.ones_like(d), d, d * d, rate, d * rate])


def block_covariance(noise, fs: float, k: int, m: int) -> np.ndarray:
    """Covariance (rad/s)^2 of m consecutive means of k samples of the noise ``noise``
    (FogParams: white, flicker and Gauss-Markov terms as ``fogbench.run.runner.
    noise_autocovariance``; the rate random walk K as K^2 min(t_i, t_j) at the blocks'
    centres)."""
    from scipy.linalg import toeplitz
    from scipy.signal import fftconvolve

    from fogbench.run.runner import noise_autocovariance

    g = noise_autocovariance(noise, fs, m * k + k)
    # cb[j] = sum_d (k - |d|) g(|j k + d|) / k^2: the autocovariance at every lag x from
    # -(k-1) on, correlated with the triangle (k - |d|), read at x = j k
    gs = g[np.abs(np.arange(-(k - 1), m * k + k - 1))]
    tri = (k - np.abs(np.arange(-(k - 1), k))).astype(float)
    conv = fftconvolve(gs, tri, mode="valid")
    cb = conv[np.arange(m) * k] / float(k * k)
    C = toeplitz(cb)
    if noise.rrw:
        # a random walk K: cov of block means K^2 min(t_i, t_j) at the centres, less K^2 h/6
        # on the diagonal (the walk inside a block)
        t = (np.arange(m) + 0.5) * k / fs
        C += noise.rrw ** 2 * np.minimum(t[:, None], t[None, :])
        C[np.diag_indices_from(C)] -= noise.rrw ** 2 * (k / fs) / 6.0
    return C


def fit_thermal(log: ThermalLog, noise, ci: float) -> dict:
    """GLS fit of the temperature terms (module docstring). ``noise``: FogParams of the noise
    terms. Returns {key: (value, low, high)} in device units, ``bias_at_ref_dph``, and
    ``lag``: (tau, low, high, bounded) with the profile interval of the coil's lag, ``lag95`` the
    same interval at 95 % (low, high, bounded: where the sensor is decided); ``region_fits``:
    the coefficients, (X'C^-1X)^-1 and the residual at each lag of the region, the best one's
    place and the residual's scale, for :func:`combination`."""
    from scipy.linalg import solve_triangular
    from scipy.stats import chi2

    k = max(1, int(round(BLOCK_S * log.fs)), math.ceil(log.rate.size / MAX_BLOCKS))
    h = k / log.fs
    if not (np.all(np.isfinite(log.rate)) and np.all(np.isfinite(log.temp))):
        raise ValueError(f"{log.name}: the rate or the temperature holds NaN or infinite values")
    yb, Tb = _blocks(log.rate, k), _blocks(log.temp, k)
    if yb.size < 30:
        raise ValueError(f"{log.name}: {yb.size} blocks of {h:g} s; the thermal fit needs at "
                         "least 30 (5 minutes)")
    if np.ptp(Tb) < 1.0:
        raise ValueError(f"{log.name}: the temperature spans {np.ptp(Tb):.3g} deg C; the "
                         "thermal fit needs a program over several degrees")
    C = block_covariance(noise, log.fs, k, yb.size)
    C[np.diag_indices_from(C)] *= 1.0 + 1e-10          # keeps the Cholesky factor positive
    L = np.linalg.cholesky(C)
    wy = solve_triangular(L, yb, lower=True, check_finite=False)
    whitened: dict[float, np.ndarray] = {}

    def white(taus):
        """The whitened designs L^-1 X(tau): one triangular solve per 64 lags (a matrix
        right-hand side, BLAS 3) instead of one per lag, each computed once."""
        new = [float(t) for t in taus if float(t) not in whitened]
        for c in range(0, len(new), 64):
            chunk = new[c:c + 64]
            X = [design(Tb, h, t) for t in chunk]
            W = solve_triangular(L, np.concatenate(X, axis=1), lower=True, check_finite=False)
            p = X[0].shape[1]
            for j, t in enumerate(chunk):
                whitened[t] = W[:, p * j:p * (j + 1)]
        return [whitened[float(t)] for t in taus]

    def profile(grid):
        out = []
        for wX in white(grid):
            beta, *_ = np.linalg.lstsq(wX, wy, rcond=None)
            out.append(float(np.sum((wy - wX @ beta) ** 2)))
        return np.array(out)

    def region(grid, chi, level=ci):
        i = int(np.argmin(chi))
        inside = (chi - chi[i]) / max(chi[i] / dof, 1.0) <= chi2.ppf(level, 1)
        lo_i = hi_i = i
        while lo_i > 0 and inside[lo_i - 1]:
            lo_i -= 1
        while hi_i < grid.size - 1 and inside[hi_i + 1]:
            hi_i += 1
        return i, lo_i, hi_i

    dof = yb.size - 6                  # five coefficients and the lag
    joint = 0.5 * (1.0 + ci)           # the lag region kept: wider than any interval at ci needs
    chi = profile(LAG_GRID_S)
    grid = _refined_lag_grid(*region(LAG_GRID_S, chi, joint)[1:])
    chi = profile(grid)
    i, lo_i, hi_i = region(grid, chi, joint)
    (wX,) = white([grid[i]])
    # collinearity of the weighted columns scaled to unit length: about 3 for the holds and
    # ramps both ways of tests/device/test_device.py, 600 to 1e15 for a single ramp
    if np.linalg.cond(wX / np.linalg.norm(wX, axis=0)) > MAX_CONDITION:
        raise ValueError(f"{log.name}: the temperature program cannot separate the terms (T, "
                         "T^2, dT/dt, T dT/dt: a single ramp moves T and dT/dt together); "
                         "record holds and ramps both ways")
    out = {"chi2_per_dof": chi[i] / dof, "block_s": h,
           "region_fits": _region_fits(white, wy, grid, (lo_i, i, hi_i),
                                       max(chi[i] / dof, 1.0))}
    for j, (key, unit) in enumerate((("bias_at_ref_dph", DPH),) + KEYS):
        out[key] = tuple(x / unit for x in combination(out, np.eye(5)[j], ci))
    _, lo_c, hi_c = region(grid, chi, ci)      # the lag's own interval, at ci
    out["lag"] = (float(grid[i]), float(grid[lo_c]), float(grid[hi_c]), hi_c < grid.size - 1)
    _, lo95, hi95 = region(grid, chi, 0.95)     # where the sensor is: decided at 95 %
    out["lag95"] = (float(grid[lo95]), float(grid[hi95]), hi95 < grid.size - 1)
    return out


def combination(res: dict, c, level: float) -> tuple[float, float, float]:
    """(value, low, high) of c . beta, a linear combination of the coefficients [bias, dT,
    dT^2, dT/dt, dT dT/dt] (rad/s per unit of each column), from :func:`fit_thermal`'s result:
    its value at the best lag and its profile-likelihood interval at ``level`` with the lag
    profiled out: every value v whose smallest generalised residual over the lags, with
    c . beta held at v, exceeds the best by at most chi2(level, 1 dof) times the residual's
    scale (for one lag, the residual grows by (v - c . beta)^2 / c'(X'C^-1X)^-1 c). A lag the
    record hardly allows then widens the interval only as far as it allows, where the union
    of per-lag intervals (the coefficients' own, above) takes every lag of the region at
    full width. Needs ``level`` no higher than (1 + ci) / 2 of the fit (the region kept)."""
    from scipy.stats import chi2

    r = res["region_fits"]
    fits, scale = r["fits"], r["scale"]
    c = np.asarray(c, float)
    q = float(chi2.ppf(level, 1)) * scale
    chi_min = min(f[2] for f in fits)
    lo, hi = math.inf, -math.inf
    for beta, inv, chi_j in fits:
        room = q - (chi_j - chi_min)
        if room < 0.0:
            continue
        v, half = float(c @ beta), math.sqrt(max(float(c @ inv @ c), 0.0) * room)
        lo, hi = min(lo, v - half), max(hi, v + half)
    return float(c @ fits[r["best"]][0]), lo, hi


def _refined_lag_grid(lo_i: int, hi_i: int) -> np.ndarray:
    """The coarse lag grid refined between the coarse points that bracket the region
    ``[lo_i, hi_i]`` of the coarse profile (a step of 1.2 % in tau)."""
    coarse = LAG_GRID_S
    a, b = coarse[max(lo_i - 1, 0)], coarse[min(hi_i + 1, coarse.size - 1)]
    fine = np.concatenate([[0.0] if a == 0.0 else [],
                           np.geomspace(max(a, LAG_GRID_S[1]), b, max(8, int(
                               math.log(b / max(a, LAG_GRID_S[1])) / 0.012)))])
    return np.unique(np.concatenate([coarse, fine]))


def _region_fits(white, wy, grid, where, scale: float) -> dict:
    """The generalised least-squares fit at every lag of the region the residual does not
    reject at (1 + ci) / 2 (a wider region than any interval at ci needs): the coefficients,
    (X'C^-1X)^-1 and the residual at each, the best lag's place and the residual's scale.
    ``where``: (first lag of the region, best lag, last lag), indices into ``grid``."""
    lo_i, i, hi_i = where
    fits = []
    for j in range(lo_i, hi_i + 1):
        (wX,) = white([grid[j]])
        beta, *_ = np.linalg.lstsq(wX, wy, rcond=None)
        fits.append((beta, np.linalg.inv(wX.T @ wX), float(np.sum((wy - wX @ beta) ** 2))))
    return {"fits": fits, "best": i - lo_i, "scale": scale}
