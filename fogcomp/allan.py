"""Overlapping Allan deviation of a gyro rate signal, its confidence intervals, and the entry to
the identification of its noise terms (:mod:`fogcomp.noise`).

The Allan variance of a rate signal ``y`` sampled every ``tau0 = 1/fs`` seconds, at the averaging
time ``tau = m * tau0``, is computed from the integrated angle ``x`` (``x[0] = 0``,
``x[k] = tau0 * sum(y[:k])``, so ``len(x) = n + 1``) as (IEEE Std 952-1997 Annex C [1]_,
NIST SP 1065 eq. 11 [2]_)::

    avar(tau) = sum_k (x[k+2m] - 2 x[k+m] + x[k])**2 / (2 tau**2 (n + 1 - 2m)),

k = 0 ... n - 2m, which equals half the mean square difference of every pair of adjacent,
overlapping cluster averages of ``m`` samples.

The noise terms (IEEE Std 952 [1]_ and Gauss-Markov [3]_) are identified from the curve by
:func:`fogcomp.noise.identify_noise_model`, the one identifier of the project;
:func:`allan_analysis` computes the curve, its intervals and that identification of a record.

.. rubric:: References

.. [1] IEEE Std 952-1997, "IEEE Standard Specification Format Guide and Test Procedure for
   Single-Axis Interferometric Fiber Optic Gyros", Annex C (Allan variance method).
.. [2] W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065 (2008),
   eq. 11.
.. [3] N. El-Sheimy, H. Hou, X. Niu, "Analysis and modeling of inertial sensors using Allan
   variance", IEEE Trans. Instrum. Meas. 57(1), 140-149 (2008).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from ._checks import _sample_rate, _signal
from ._stats import ONE_SIGMA_CI
from .noise import avar_gm, identify_noise_model

__all__ = [
    "AllanDeviation",
    "oadev",
    "oadev_details",
    "pooled_oadev",
    "NOISE_TERMS",
    "FLICKER_FLOOR_FACTOR",
    "ONE_SIGMA_CI",
    "ALPHA_OF_TERM",
    "edf_greenhall",
    "confidence_interval",
    "AllanCI",
    "oadev_ci",
    "allan_analysis",
]

#: sqrt(2 ln 2 / pi) = 0.6643: the Allan deviation of flicker rate noise of coefficient B is
#: this times B (IEEE Std 952 Table C.1); the bias instability is the curve's floor divided by it.
FLICKER_FLOOR_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)

#: The noise terms, in the order of the columns of the model (slopes -1, -1/2, 0, +1/2, +1 of
#: the Allan deviation in log-log space).
NOISE_TERMS = ("Q", "N", "B", "K", "R")

# Allan-variance basis of each term, as a function of tau (s), for a unit coefficient.
_BASIS = {
    "Q": lambda t: 3.0 / t**2,
    "N": lambda t: 1.0 / t,
    "B": lambda t: FLICKER_FLOOR_FACTOR**2 * np.ones_like(t),
    "K": lambda t: t / 3.0,
    "R": lambda t: t**2 / 2.0,
}


# ---------------------------------------------------------------------------------------------
# Allan deviation
@dataclass(frozen=True)
class AllanDeviation:
    """An overlapping Allan deviation curve with its statistics.

    Attributes
    ----------
    taus : ndarray, shape (k,)
        Averaging times, s (exact multiples ``m / fs``).
    adev : ndarray, shape (k,)
        Overlapping Allan deviation, in the unit of the rate signal (rad/s for a rate in rad/s).
    m : ndarray of int, shape (k,)
        Averaging factors, ``taus = m / fs``.
    n_terms : ndarray of int, shape (k,)
        Number of squared second differences summed at each tau, ``n + 1 - 2 m``.
    adev_err : ndarray, shape (k,)
        One-sigma uncertainty of ``adev``, same unit: ``adev / sqrt(2 (n / m - 1))``, the
        IEEE Std 952 (Annex C.2) estimate from the number ``n / m`` of independent clusters.
        It ignores how the overlapping terms are correlated; for white and random-walk rate
        noise it is right to within about 30 % (too large at long taus for white noise, too
        small at the shortest ones).
    n : int
        Number of rate samples the curve was computed from.
    fs : float
        Sample rate, Hz.
    """

    taus: np.ndarray
    adev: np.ndarray
    m: np.ndarray
    n_terms: np.ndarray
    adev_err: np.ndarray
    n: int
    fs: float


def _check_rate(rate, name: str = "rate", min_len: int = 3) -> np.ndarray:
    return _signal(name, rate, min_len)


def _check_fs(fs) -> float:
    return _sample_rate(fs)


def _averaging_factors(taus, fs: float, n: int) -> np.ndarray:
    """Integer averaging factors m for ``taus`` (None or 'octave': 1, 2, 4, ...)."""
    m_max = (n - 1) // 2          # at least two second differences at the longest tau
    if taus is None or (isinstance(taus, str) and taus == "octave"):
        return 2 ** np.arange(int(math.floor(math.log2(m_max))) + 1)
    if isinstance(taus, str) and taus == "all":
        return np.arange(1, m_max + 1)
    if isinstance(taus, str):
        raise ValueError(f"taus: unknown keyword {taus!r}; expected None, 'octave', 'all' or an "
                         "array of averaging times in s")
    try:
        t = np.asarray(taus, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"taus: cannot be read as a float array ({exc})") from None
    if t.ndim != 1 or t.shape[0] == 0:
        raise ValueError(f"taus: expected a non-empty 1-D array of averaging times in s, got "
                         f"shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise ValueError(f"taus: averaging times must be positive and finite (s), got {t}")
    mf = t * fs
    m = np.rint(mf)
    off = np.abs(mf - m) > 1e-6 * np.maximum(1.0, mf)
    if off.any():
        raise ValueError(f"taus: every averaging time must be a whole multiple of the sample "
                         f"interval 1/fs = {1.0 / fs:g} s; {t[off][0]!r} s is "
                         f"{mf[off][0]:.6g} samples")
    if m.min() < 1:
        raise ValueError(f"taus: the shortest averaging time is one sample interval "
                         f"{1.0 / fs:g} s, got {t.min()!r} s")
    if m.max() > m_max:
        raise ValueError(f"taus: the longest averaging time for {n} samples at {fs:g} Hz is "
                         f"(n-1)//2 = {m_max} samples = {m_max / fs:g} s, got {t.max()!r} s")
    return m.astype(np.int64)


def oadev_details(rate, fs: float, taus=None) -> AllanDeviation:
    """Fully overlapping Allan deviation of a rate signal, with term counts and error bars.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate signal, rad/s (any unit works; ``adev`` comes out in the same unit). At least 3
        finite samples.
    fs : float
        Sample rate, Hz.
    taus : None, 'octave', 'all' or array_like, shape (k,)
        Averaging times, s. None or 'octave' (default): ``m = 1, 2, 4, ... <= (n-1)//2`` samples,
        as ``allantools``' 'octave' (which also keeps only taus with at least two terms). 'all':
        every ``m = 1 ... (n-1)//2`` (slow for long records). An array: each value must be a
        whole number ``m`` of sample intervals with ``1 <= m <= (n-1)//2``; the order is kept.

    Returns
    -------
    AllanDeviation
        ``taus`` (s), ``adev``, ``m``, ``n_terms``, ``adev_err``.

    Notes
    -----
    The angle ``x`` is the cumulative sum of the rate after its mean is removed (a constant rate
    adds a straight line to ``x``, which the second difference cancels exactly, and removing it
    keeps the cumulative sum small and precise). Each tau costs one vectorised pass over ``x``.
    """
    y = _check_rate(rate)
    fs = _check_fs(fs)
    n = y.shape[0]
    m = _averaging_factors(taus, fs, n)
    x = np.empty(n + 1)
    x[0] = 0.0
    np.cumsum(y - y.mean(), out=x[1:])
    x /= fs
    avar = np.empty(m.shape[0])
    buf = np.empty(n + 1)             # two work buffers reused at every tau: no allocation per
    tmp = np.empty(n + 1)             # tau, one pass of each ufunc over memory
    for i, mi in enumerate(m):
        k = n + 1 - 2 * mi
        d, t2 = buf[:k], tmp[:k]
        np.add(x[2 * mi:], x[:k], out=d)
        np.multiply(x[mi:n + 1 - mi], 2.0, out=t2)
        np.subtract(d, t2, out=d)
        avar[i] = np.dot(d, d) / k
    t = m / fs
    n_terms = n + 1 - 2 * m
    avar /= 2.0 * t**2
    adev = np.sqrt(avar)
    return AllanDeviation(taus=t, adev=adev, m=m, n_terms=n_terms,
                          adev_err=adev / np.sqrt(2.0 * (n / m - 1.0)), n=n, fs=fs)


def oadev(rate, fs: float, taus=None) -> tuple[np.ndarray, np.ndarray]:
    """Fully overlapping Allan deviation of a rate signal.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate signal, rad/s. At least 3 finite samples.
    fs : float
        Sample rate, Hz.
    taus : None, 'octave', 'all' or array_like, shape (k,)
        Averaging times, s; see :func:`oadev_details` (default: octave spacing).

    Returns
    -------
    taus : ndarray, shape (k,)
        Averaging times, s.
    adev : ndarray, shape (k,)
        Allan deviation, rad/s (the unit of ``rate``).

    See Also
    --------
    oadev_details : the same curve with the number of terms and error bars.

    References
    ----------
    .. [1] W. J. Riley, NIST SP 1065 (2008), eq. 11; IEEE Std 952-1997 Annex C.
    """
    d = oadev_details(rate, fs, taus)
    return d.taus, d.adev


# ---------------------------------------------------------------------------------------------
# Confidence intervals: equivalent degrees of freedom of the overlapping Allan variance
#: Power-law exponent alpha of the rate noise of each term, S_rate(f) ~ f**alpha (IEEE Std 952
#: Table C.1 with NIST SP 1065 Table 5's naming: white angle = "white PM" alpha = +2, white rate
#: = "white FM" 0, flicker rate = -1, random-walk rate = -2). The rate ramp is a drift, not a
#: power-law noise, and alpha = -3 has no Allan-variance EDF (Greenhall needs alpha + 2d > 1); it
#: is given the nearest admissible value, -2, which has the fewest degrees of freedom (widest
#: interval) of the admissible ones.
ALPHA_OF_TERM = {"Q": 2, "N": 0, "B": -1, "K": -2, "R": -2}

# Greenhall & Riley (2004), Table 2: (a0, a1) of 1/edf = (a0 - a1/r)/r for unmodified
# variances with many terms, by (alpha, d); and Table 3: (b0, b1) of the alpha = +1 correction.
_GR_TABLE2 = {
    (1, 1): (78.6, 25.2), (1, 2): (790.0, 410.0), (1, 3): (9950.0, 6520.0),
    (0, 1): (2.0 / 3.0, 1.0 / 6.0), (0, 2): (2.0 / 3.0, 1.0 / 3.0), (0, 3): (7.0 / 9.0, 0.5),
    (-1, 2): (0.852, 0.375), (-1, 3): (0.997, 0.617),
    (-2, 2): (1.079, 0.368), (-2, 3): (1.033, 0.607),
    (-3, 3): (1.053, 0.553), (-4, 3): (1.302, 0.535),
}
_GR_TABLE3 = {1: (6.0, 4.0), 2: (15.23, 12.0), 3: (47.8, 40.0)}
_GR_JMAX = 100


def _gr_sw(t, alpha: int) -> np.ndarray:
    """Greenhall & Riley (2004) eq. 7: the generalised autocovariance of the phase, up to a
    constant factor that cancels in the EDF."""
    t = np.abs(np.asarray(t, dtype=float))
    if alpha in (2, 0, -2, -4):
        power = {2: 1, 0: 3, -2: 5, -4: 7}[alpha]
        return -t if alpha == 2 else t**power
    power = {1: 2, -1: 4, -3: 6}[alpha]
    out = np.zeros_like(t)
    pos = t > 0
    out[pos] = t[pos] ** power * np.log(t[pos])
    return out


def _gr_sx(t, f: float, alpha: int) -> np.ndarray:
    """Eq. 8: the filter of the (unmodified, F = m) or infinitely fine (F = inf) variance."""
    if math.isinf(f):
        return _gr_sw(t, alpha + 2)
    return f * f * (2.0 * _gr_sw(t, alpha) - _gr_sw(t - 1.0 / f, alpha)
                    - _gr_sw(t + 1.0 / f, alpha))


def _gr_sz(t, f: float, alpha: int, d: int) -> np.ndarray:
    """Eq. 9: the d-th difference, sum over k = -d..d of (-1)^k C(2d, d+k) sx(t + k)."""
    t = np.asarray(t, dtype=float)
    out = np.zeros_like(t)
    for k in range(-d, d + 1):
        out += (-1) ** abs(k) * math.comb(2 * d, d + k) * _gr_sx(t + k, f, alpha)
    return out


def _gr_basic_sum(j_terms: int, m_terms: float, s: float, f: float, alpha: int, d: int) -> float:
    """Eq. 10: sz(0)^2 + (1 - J/M) sz(J/S)^2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz(j/S)^2."""
    j = np.arange(1, int(j_terms), dtype=float)
    sz_j = _gr_sz(j / s, f, alpha, d)
    first = float(_gr_sz(0.0, f, alpha, d)) ** 2
    second = (1.0 - j_terms / m_terms) * float(_gr_sz(j_terms / s, f, alpha, d)) ** 2
    return first + second + float(2.0 * np.sum((1.0 - j / m_terms) * sz_j**2))


def edf_greenhall(alpha: int, m: int, n_phase: int, d: int = 2,
                  overlapping: bool = True) -> float:
    """Equivalent degrees of freedom of an unmodified d-th difference variance estimate.

    Greenhall & Riley's algorithm (2004) for the chi-squared EDF of the Allan (d = 2),
    first-difference (d = 1) or Hadamard (d = 3) variance, fully overlapping or not, for
    power-law noise of exponent ``alpha``; NIST SP 1065 section 5.3 recommends it for the
    overlapping Allan deviation. The same algorithm as ``allantools.ci.edf_greenhall`` (checked
    against it in the tests), with one difference: for white angle noise (alpha = +2) with at most
    ``d`` independent clusters, where allantools raises ``NotImplementedError``, the exact sum
    (eq. 10 with J = M) is used.

    Parameters
    ----------
    alpha : int
        Exponent of the rate (fractional-frequency) noise PSD, S(f) ~ f**alpha, one of
        +2, +1, 0, -1, -2, -3, -4 with ``alpha + 2 d > 1`` (see :data:`ALPHA_OF_TERM`).
    m : int
        Averaging factor, tau = m / fs.
    n_phase : int
        Number of phase (integrated angle) points, ``n + 1`` for ``n`` rate samples.
    d : int, optional
        Order of the difference, 1, 2 (Allan, default) or 3.
    overlapping : bool, optional
        True for the fully overlapping estimator (stride 1 sample), False for stride m.

    Returns
    -------
    float
        The equivalent degrees of freedom.

    References
    ----------
    .. [1] C. A. Greenhall, W. J. Riley, "Uncertainty of stability variances based on finite
       differences", Proc. 35th PTTI Meeting (2003/2004), eqs. 7-13, Tables 2 and 3.
    .. [2] W. J. Riley, NIST SP 1065 (2008), section 5.3.
    """
    # One function on purpose (half of it is this docstring): Greenhall & Riley's
    # algorithm as the paper states it, step after step (the filter length L, the number of
    # summands M, then J and r; then the case of alpha: alpha <= 0, alpha = +1, alpha = +2,
    # each the sum of eq. 10 or a large-M approximation, from Tables 2 and 3 or, for +2, in
    # closed form), so that it reads against the paper and against
    # allantools.ci.edf_greenhall line by line. The helpers above hold eqs. 7-10.
    if isinstance(alpha, bool) or int(alpha) != alpha or int(alpha) not in range(-4, 3):
        raise ValueError(f"alpha: expected an integer from -4 to +2, got {alpha!r}")
    alpha = int(alpha)
    if d not in (1, 2, 3):
        raise ValueError(f"d: expected 1, 2 or 3, got {d!r}")
    if alpha + 2 * d <= 1:
        raise ValueError(f"alpha: the d={d} variance needs alpha + 2d > 1, got alpha={alpha}")
    if int(m) != m or m < 1:
        raise ValueError(f"m: expected a positive integer averaging factor, got {m!r}")
    m = int(m)
    f = float(m)                                   # unmodified variance: F = m
    s = float(m) if overlapping else 1.0           # stride factor
    big_l = m / f + m * d                          # filter length in phase samples
    big_m = 1.0 + math.floor(s * (n_phase - big_l) / m)   # number of summands
    if big_m < 1:
        raise ValueError(f"n_phase: {n_phase} phase points are too few for m={m}, d={d} "
                         f"(need at least {int(big_l) + 1})")
    j = min(big_m, (d + 1) * s)
    r = big_m / s
    if alpha <= 0:
        if j <= _GR_JMAX:
            fp = f if m * (d + 1) <= _GR_JMAX else math.inf
            inv = _gr_basic_sum(j, big_m, s, fp, alpha, d) / (float(_gr_sz(0.0, fp, alpha, d))**2
                                                               * big_m)
        elif r > d + 1:
            a0, a1 = _GR_TABLE2[(alpha, d)]
            inv = (a0 - a1 / r) / r
        else:
            mp = _GR_JMAX / r
            inv = (_gr_basic_sum(_GR_JMAX, _GR_JMAX, mp, math.inf, alpha, d)
                   / (float(_gr_sz(0.0, math.inf, alpha, d))**2 * _GR_JMAX))
        return 1.0 / inv
    if alpha == 1:
        if j <= _GR_JMAX:
            inv = _gr_basic_sum(j, big_m, s, f, 1, d) / (float(_gr_sz(0.0, f, 1, d))**2 * big_m)
        elif r > d + 1:
            a0, a1 = _GR_TABLE2[(1, d)]
            b0, b1 = _GR_TABLE3[d]
            inv = (a0 - a1 / r) / ((b0 + b1 * math.log(m)) ** 2 * r)
        else:
            mp = _GR_JMAX / r
            b0, b1 = _GR_TABLE3[d]
            inv = (_gr_basic_sum(_GR_JMAX, _GR_JMAX, mp, mp, 1, d)
                   / ((b0 + b1 * math.log(m)) ** 2 * _GR_JMAX))
        return 1.0 / inv
    # alpha = +2 (white phase): case 4
    if math.ceil(r) <= d:
        inv = _gr_basic_sum(big_m, big_m, s, f, 2, d) / (float(_gr_sz(0.0, f, 2, d))**2 * big_m)
    else:
        a0 = math.comb(4 * d, 2 * d) / math.comb(2 * d, d) ** 2
        inv = (a0 - (d / 2.0) / r) / big_m
    return 1.0 / inv


def confidence_interval(dev, edf, ci: float = ONE_SIGMA_CI) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided chi-squared confidence interval of a deviation with ``edf`` degrees of freedom.

    NIST SP 1065 eq. 45: ``var_low = edf var / chi2(1 - p, edf)``, ``var_high = edf var /
    chi2(p, edf)``, p = (1 - ci)/2.

    Parameters
    ----------
    dev : float or ndarray, shape (k,)
        The deviation(s), any unit.
    edf : float or ndarray, shape (k,)
        Equivalent degrees of freedom (positive).
    ci : float, optional
        Probability content of the interval, 0 < ci < 1 (default 0.6827, one sigma).

    Returns
    -------
    low, high : ndarray, shape (k,)
        The bounds, in the unit of ``dev``.
    """
    from scipy.stats import chi2

    if not (isinstance(ci, (int, float, np.floating)) and 0.0 < ci < 1.0):
        raise ValueError(f"ci: expected a probability between 0 and 1, got {ci!r}")
    dev = np.asarray(dev, dtype=float)
    edf = np.asarray(edf, dtype=float)
    if np.any(~np.isfinite(edf)) or np.any(edf <= 0):
        raise ValueError("edf: expected positive finite degrees of freedom")
    p = (1.0 - ci) / 2.0
    low = dev * np.sqrt(edf / chi2.ppf(1.0 - p, edf))
    high = dev * np.sqrt(edf / chi2.ppf(p, edf))
    return low, high


@dataclass(frozen=True)
class AllanCI:
    """An overlapping Allan deviation with chi-squared confidence intervals.

    Attributes
    ----------
    taus : ndarray, shape (k,)
        Averaging times, s.
    adev : ndarray, shape (k,)
        Overlapping Allan deviation, unit of the rate signal (rad/s).
    low, high : ndarray, shape (k,)
        Bounds of the ``ci`` confidence interval, same unit.
    edf : ndarray, shape (k,)
        Equivalent degrees of freedom (Greenhall & Riley 2004).
    alpha : ndarray of int, shape (k,)
        Noise exponent assumed at each tau (:data:`ALPHA_OF_TERM` of the leading term).
    ci : float
        Probability content of the interval.
    m : ndarray of int, shape (k,)
        Averaging factors.
    n : int
        Number of rate samples.
    fs : float
        Sample rate, Hz.
    """

    taus: np.ndarray
    adev: np.ndarray
    low: np.ndarray
    high: np.ndarray
    edf: np.ndarray
    alpha: np.ndarray
    ci: float
    m: np.ndarray
    n: int
    fs: float

    @property
    def sigma(self) -> np.ndarray:
        """Approximate one-sigma uncertainty of ``adev``, shape (k,): half the width of the
        interval scaled to one sigma (a normal approximation of the chi-squared interval)."""
        from scipy.stats import norm

        return (self.high - self.low) / (2.0 * norm.ppf(0.5 + self.ci / 2.0))


def oadev_ci(rate, fs: float, taus=None, *, alpha=None, ci: float = ONE_SIGMA_CI) -> AllanCI:
    """Overlapping Allan deviation with confidence intervals from the EDF of its noise type.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate signal, rad/s. At least 3 finite samples.
    fs : float
        Sample rate, Hz.
    taus : None, 'octave', 'all' or array_like, shape (k,)
        Averaging times, s; see :func:`oadev_details`.
    alpha : None, int or array_like of int, shape (k,)
        Noise exponent at each tau (:data:`ALPHA_OF_TERM`). None (default): at each tau, that
        of the term that leads a quick five-term fit of the curve (``_pilot_alpha``) -- the
        noise type is read from the curve's slopes rather than from the lag-1 autocorrelation
        allantools uses. :func:`allan_analysis` uses the identified model's instead.
    ci : float, optional
        Probability content of the intervals (default 0.6827).

    Returns
    -------
    AllanCI

    References
    ----------
    .. [1] W. J. Riley, NIST SP 1065 (2008), sections 5.2-5.3 and eq. 45.
    .. [2] C. A. Greenhall, W. J. Riley, Proc. 35th PTTI (2003), the EDF algorithm.
    """
    d = oadev_details(rate, fs, taus)
    k = d.taus.shape[0]
    if alpha is None:
        alphas = _pilot_alpha(d)
    else:
        alphas = np.broadcast_to(np.asarray(alpha), (k,)).astype(int)
    edf = np.array([edf_greenhall(int(a), int(mi), d.n + 1) for a, mi in zip(alphas, d.m)])
    low, high = confidence_interval(d.adev, edf, ci)
    return AllanCI(taus=d.taus, adev=d.adev, low=low, high=high, edf=edf,
                   alpha=np.asarray(alphas, dtype=int), ci=float(ci), m=d.m, n=d.n, fs=d.fs)


# ---------------------------------------------------------------------------------------------
# The leading noise type at each tau (for the EDF of the intervals)
def _pilot_alpha(d: AllanDeviation) -> np.ndarray:
    """Noise exponent (:data:`ALPHA_OF_TERM`) of the term that leads a quick fit of the five
    IEEE terms at each tau: each Allan variance point weighted by its IEEE Std 952 Annex C.2
    error bar (n/m clusters) over the model, non-negative least squares, four passes. For the
    intervals of a curve only; the terms themselves come from :mod:`fogcomp.noise`."""
    t = d.taus
    if t.shape[0] < 3:
        return np.zeros(t.shape[0], dtype=int)
    avar = d.adev**2
    basis = np.column_stack([_BASIS[term](t) for term in NOISE_TERMS])
    rel = np.sqrt(2.0 / np.maximum(d.n / d.m - 1.0, 1.0))
    scale = avar
    c = np.zeros(len(NOISE_TERMS))
    for _ in range(4):
        sig = rel * scale
        a = basis / sig[:, None]
        norm = np.linalg.norm(a, axis=0)
        c, _ = nnls(a / norm, avar / sig)
        c = c / norm
        model = basis @ c
        if not np.all(model > 0):
            break
        scale = model
    lead = np.argmax(basis * c, axis=1)
    return np.array([ALPHA_OF_TERM[NOISE_TERMS[i]] for i in lead], dtype=int)


def _model_alpha(taus, model) -> np.ndarray:
    """Noise exponent of the identified model's leading term at each tau (a Gauss-Markov term
    is a random walk, -2, below its correlation time and white, 0, above it)."""
    t = np.asarray(taus, dtype=float)
    parts, alphas = [], []
    for term in model.in_model:
        if term.term == "GM":
            parts.append(avar_gm(t, term.tau, model.fs) * term.value**2)
            alphas.append(np.where(t < term.tau, -2, 0))
        else:
            parts.append(_BASIS[term.term](t) * term.value**2)
            alphas.append(np.full(t.shape, ALPHA_OF_TERM[term.term]))
    if not parts:
        return np.zeros(t.shape, dtype=int)
    lead = np.argmax(np.vstack(parts), axis=0)
    return np.vstack(alphas)[lead, np.arange(t.size)].astype(int)


def pooled_oadev(y, fs: float, taus, segments) -> tuple[np.ndarray, np.ndarray]:
    """(averaging factors m, overlapping Allan deviation) of a rate over its gap-free
    ``segments`` [start, stop): each piece's squared second differences computed inside it and
    pooled over the pieces (one piece: :func:`oadev_details`). ``taus`` as there; with several
    pieces, taken on the longest."""
    segs = [(int(a), int(b)) for a, b in segments]
    if len(segs) == 1:
        d = oadev_details(y[segs[0][0]:segs[0][1]], fs, taus)
        return d.m, d.adev
    m_all = _averaging_factors(taus, fs, max(b - a for a, b in segs))
    sums, counts = np.zeros(m_all.size), np.zeros(m_all.size)
    for a, b in segs:
        ok = m_all <= (b - a - 1) // 2
        if ok.any():
            dd = oadev_details(y[a:b], fs, taus=m_all[ok] / fs)
            sums[ok] += dd.adev**2 * dd.n_terms
            counts[ok] += dd.n_terms
    return m_all, np.sqrt(sums / counts)


def allan_analysis(rate, fs: float, taus=None, *, ci: float = ONE_SIGMA_CI, model=None,
                   segments=None, **identify_options):
    """Overlapping Allan deviation with EDF confidence intervals and the identified noise model.

    Steps: :func:`oadev_details` (pooled over gap-free ``segments`` when given);
    :func:`fogcomp.noise.identify_noise_model` on the Allan variance (its own covariance of the
    estimates, exact for the model); the intervals of the curve from the equivalent degrees of
    freedom (:func:`edf_greenhall`) of the identified model's leading term at each tau.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate signal, rad/s.
    fs : float
        Sample rate, Hz.
    taus : None, 'octave' or array_like, shape (k,)
        Averaging times, s (default octave).
    ci : float, optional
        Probability content of the intervals, of the curve and of the terms (default 0.6827).
    model : str, optional
        A stated model (``"N + B + K"``); default: selected
        (:func:`fogcomp.noise.identify_noise_model`).
    segments : list of (int, int), optional
        Sample ranges [start, stop) of gap-free pieces of ``rate``: each piece's second
        differences are computed inside it and the squared ones pooled; the EDF of the
        pieces add.
    **identify_options
        ``alpha``, ``max_gm``, ``model_error``, ``record_length`` of
        :func:`fogcomp.noise.identify_noise_model`.

    Returns
    -------
    curve : AllanCI
    model : fogcomp.noise.NoiseModel
    """
    y = _check_rate(rate)
    fs = _check_fs(fs)
    segs = [(0, y.shape[0])] if segments is None else [(int(a), int(b)) for a, b in segments]
    # A piece of fewer than 3 samples holds no second difference at any averaging time: it
    # adds nothing to the curve or its degrees of freedom, and is left out here.
    segs = [(a, b) for a, b in segs if b - a >= 3] or segs
    lengths = [b - a for a, b in segs]
    longest = max(lengths)
    if longest < 8:
        raise ValueError(f"rate: {longest} samples give fewer than 3 octave averaging times; at "
                         "least 3 are needed to identify noise terms (record at least 8 "
                         "samples, in practice thousands)")
    m_all, adev = pooled_oadev(y, fs, taus, segs)
    t = m_all / fs
    if t.shape[0] < 3:
        raise ValueError(f"rate: {longest} samples give only {t.shape[0]} averaging times; at "
                         "least 3 are needed to identify noise terms")
    nm = identify_noise_model(t, adev**2, fs, tuple(lengths) if len(segs) > 1 else longest,
                              model=model, ci=ci, **identify_options)
    alphas = _model_alpha(t, nm)
    edf = np.zeros(t.shape[0])
    for n_seg in lengths:
        for i, (a, mi) in enumerate(zip(alphas, m_all)):
            if mi <= (n_seg - 1) // 2:
                edf[i] += edf_greenhall(int(a), int(mi), n_seg + 1)
    low, high = confidence_interval(adev, edf, ci)
    curve = AllanCI(taus=t, adev=adev, low=low, high=high, edf=edf, alpha=alphas, ci=float(ci),
                    m=m_all, n=int(sum(lengths)), fs=fs)
    return curve, nm
