"""Overlapping Allan deviation of a gyro rate signal and identification of its noise terms.

The Allan variance of a rate signal ``y`` sampled every ``tau0 = 1/fs`` seconds, at the averaging
time ``tau = m * tau0``, is computed from the integrated angle ``x`` (``x[0] = 0``,
``x[k] = tau0 * sum(y[:k])``, so ``len(x) = n + 1``) as (IEEE Std 952-1997 Annex C, NIST SP 1065
eq. 11)::

    avar(tau) = sum_k (x[k+2m] - 2 x[k+m] + x[k])**2 / (2 tau**2 (n + 1 - 2m)),

k = 0 ... n - 2m, which equals half the mean square difference of every pair of adjacent,
overlapping cluster averages of ``m`` samples.

The noise model fitted by :func:`identify_noise` is the IEEE Std 952 sum of independent terms::

    avar(tau) = 3 Q**2 / tau**2           quantisation          Q   rad
              + N**2 / tau                angle random walk     N   rad/sqrt(s)
              + (2 ln 2 / pi) B**2        bias instability      B   rad/s
              + K**2 tau / 3              rate random walk      K   rad/s/sqrt(s)
              + R**2 tau**2 / 2           rate ramp             R   rad/s^2

References
----------
.. [1] IEEE Std 952-1997, "IEEE Standard Specification Format Guide and Test Procedure for
   Single-Axis Interferometric Fiber Optic Gyros", Annex C (Allan variance method).
.. [2] W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065 (2008), eq. 11.
.. [3] N. El-Sheimy, H. Hou, X. Niu, "Analysis and modeling of inertial sensors using Allan
   variance", IEEE Trans. Instrum. Meas. 57(1), 140-149 (2008).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import nnls

from ._checks import _sample_rate, _signal

from .units import ARCSEC, DEG_RT_H, DPH, DPH_PER_H, DPH_RT_H

__all__ = [
    "AllanDeviation",
    "NoiseParams",
    "oadev",
    "oadev_details",
    "identify_noise",
    "allan_report",
    "NOISE_TERMS",
    "FLICKER_FLOOR_FACTOR",
    "ONE_SIGMA_CI",
    "ALPHA_OF_TERM",
    "edf_greenhall",
    "confidence_interval",
    "AllanCI",
    "oadev_ci",
    "NoiseTerm",
    "NoiseIdentification",
    "identify_noise_terms",
    "noise_model_adev",
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

# (SI -> datasheet divisor, datasheet key) of each term.
_DATASHEET = {
    "N": (DEG_RT_H, "arw_deg_rt_h"),
    "B": (DPH, "bias_instability_dph"),
    "K": (DPH_RT_H, "rrw_dph_rt_h"),
    "Q": (ARCSEC, "quantisation_arcsec"),
    "R": (DPH_PER_H, "rate_ramp_dph_per_h"),
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
# Noise identification
@dataclass(frozen=True)
class NoiseParams:
    """IEEE Std 952 noise coefficients identified from an Allan deviation curve, in SI units.

    A term that the curve does not show (see :func:`identify_noise`) is None.

    Attributes
    ----------
    Q : float or None
        Quantisation noise, rad (datasheet: arcsec). Allan variance ``3 Q**2 / tau**2``.
    N : float or None
        Angle random walk, rad/sqrt(s) (datasheet: deg/sqrt(h)); the -1/2 slope line read at
        tau = 1 s.
    B : float or None
        Bias instability, rad/s (datasheet: deg/h): the floor of the Allan deviation divided by
        ``sqrt(2 ln 2 / pi) = 0.664``.
    K : float or None
        Rate random walk, rad/s/sqrt(s) (datasheet: deg/h/sqrt(h)); the +1/2 slope line read at
        tau = 3 s.
    R : float or None
        Rate ramp, rad/s^2 (datasheet: deg/h/h); the +1 slope line read at tau = sqrt(2) s.
    B_tau : float or None
        Averaging time of the floor that gave ``B``, s.
    fit : dict of str to float
        The five coefficients (keys ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"``, SI units as
        above) of the weighted non-negative least-squares fit of the full model, detected or
        not. ``fit["B"]`` is the flicker coefficient of that fit, not the floor reading ``B``.
    """

    Q: float | None
    N: float | None
    B: float | None
    K: float | None
    R: float | None
    B_tau: float | None = None
    fit: dict = field(default_factory=dict)

    @property
    def detected(self) -> dict[str, bool]:
        """``{term: True if the curve shows it}`` for the terms ``Q, N, B, K, R``."""
        return {t: getattr(self, t) is not None for t in NOISE_TERMS}

    def to_datasheet(self) -> dict[str, float | None]:
        """The coefficients in datasheet units, the unit in every key; None where not detected.

        Keys: ``arw_deg_rt_h``, ``bias_instability_dph``, ``rrw_dph_rt_h``,
        ``quantisation_arcsec``, ``rate_ramp_dph_per_h``, ``bias_instability_tau_s``.
        """
        out: dict[str, float | None] = {}
        for term in ("N", "B", "K", "Q", "R"):
            unit, key = _DATASHEET[term]
            v = getattr(self, term)
            out[key] = None if v is None else float(v / unit)
        out["bias_instability_tau_s"] = None if self.B_tau is None else float(self.B_tau)
        return out


def _check_curve(taus, adev, adev_err):
    arrays = {}
    for name, v in (("taus", taus), ("adev", adev)):
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: cannot be read as a float array ({exc})") from None
        if a.ndim != 1:
            raise ValueError(f"{name}: expected a 1-D array, got shape {a.shape}")
        bad = ~(np.isfinite(a) & (a > 0))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{name}: expected positive finite values, got {a[i]} at index {i}"
                             + (" (a constant signal has no noise to identify)"
                                if name == "adev" and a[i] == 0 else ""))
        arrays[name] = a
    t, a = arrays["taus"], arrays["adev"]
    if a.shape != t.shape:
        raise ValueError(f"adev: shape {a.shape} must match taus {t.shape}")
    if t.shape[0] < 3:
        raise ValueError(f"taus: expected at least 3 averaging times to fit, got {t.shape[0]}")
    if np.unique(t).shape[0] != t.shape[0]:
        raise ValueError("taus: averaging times must be distinct")
    e = None
    if adev_err is not None:
        try:
            e = np.asarray(adev_err, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"adev_err: cannot be read as a float array ({exc})") from None
        if e.shape != t.shape:
            raise ValueError(f"adev_err: shape {e.shape} must match taus {t.shape}")
        if not np.all(np.isfinite(e)) or np.any(e < 0):
            raise ValueError("adev_err: expected non-negative finite uncertainties")
    order = np.argsort(t)
    return t[order], a[order], (None if e is None else e[order])


def _fit_model(basis: np.ndarray, avar: np.ndarray, rel: np.ndarray, iterations: int = 4):
    """Weighted NNLS of ``avar ~ basis @ c``, each point weighted by 1 / (rel * model).

    The first pass scales by the measured variance; later passes by the fitted model, so that a
    point that happens to fall low does not gain weight (which would bias the fit low).
    """
    scale = avar
    for _ in range(iterations):
        sig = rel * scale
        a = basis / sig[:, None]
        norm = np.linalg.norm(a, axis=0)
        c, _ = nnls(a / norm, avar / sig)
        c = c / norm
        model = basis @ c
        if not np.all(model > 0):
            break
        scale = model
    return c


@dataclass
class _CurveFit:
    """The weighted fit of the five-term Allan variance model to a curve, shared by
    :func:`identify_noise` and :func:`identify_noise_terms` (which differ only in what they
    report). ``rel``: relative error of each variance point; ``share``: each term's part of
    the fitted variance at each tau; ``fit``: the fitted coefficients, rad/s units."""

    t: np.ndarray
    a: np.ndarray
    e: np.ndarray | None
    avar: np.ndarray
    adev_rel: np.ndarray
    rel: np.ndarray
    basis: np.ndarray
    c: np.ndarray
    model: np.ndarray
    share: np.ndarray
    fit: dict

    def lead_snr(self, j: int):
        """Where term j leads the model (share >= 1/2) and its significance there, sigma."""
        lead = self.share[:, j] >= 0.5
        snr = math.sqrt(float(np.sum((self.share[lead, j] / self.rel[lead]) ** 2)))
        return lead, snr


def _fit_curve(taus, adev, adev_err, model_error, min_snr, floor_max_rel_err) -> _CurveFit:
    t, a, e = _check_curve(taus, adev, adev_err)
    for name, v in (("model_error", model_error), ("min_snr", min_snr),
                    ("floor_max_rel_err", floor_max_rel_err)):
        if not (isinstance(v, (int, float, np.integer, np.floating)) and np.isfinite(v) and v > 0):
            raise ValueError(f"{name}: expected a positive finite number, got {v!r}")
    avar = a**2
    adev_rel = np.zeros_like(a) if e is None else e / a
    rel = np.sqrt((2.0 * adev_rel) ** 2 + model_error**2)     # relative error of the variance
    basis = np.column_stack([_BASIS[term](t) for term in NOISE_TERMS])
    c = _fit_model(basis, avar, rel)
    model = basis @ c
    share = basis * c / model[:, None]
    fit = {term: float(math.sqrt(c[j])) for j, term in enumerate(NOISE_TERMS)}
    return _CurveFit(t, a, e, avar, adev_rel, rel, basis, c, model, share, fit)


def identify_noise(taus, adev, adev_err=None, *, model_error: float = 0.1,
                   min_snr: float = 3.0, floor_max_rel_err: float = 0.25) -> NoiseParams:
    """Identify the IEEE Std 952 noise terms from an Allan deviation curve.

    Method: a weighted non-negative least-squares fit (:func:`scipy.optimize.nnls`) of the full
    five-term model to the Allan *variance*,
    ``sigma^2(tau) = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2``, gives
    Q, N, K and R; the bias instability B is the datasheet reading, the floor (minimum) of the
    curve divided by 0.664.

    Why a full-model fit rather than reading fixed-slope lines through hand-picked regions: it
    uses every point with its statistical weight, needs no choice of region (so it runs
    unattended on any log), and separates terms where they overlap (a -1/2 line read at 1 s
    also contains the flicker and quantisation contributions there; the fit does not). The
    coefficients are non-negative by construction. Each point's weight is the inverse of its
    relative uncertainty, the statistical one (``adev_err``) combined in quadrature with a
    ``model_error`` floor: real curves depart from the five-term model by a few per cent
    (anti-alias filters, vibration lines, correlated noise), and without the floor the few
    very precise short-tau points would decide the whole fit. B is taken from the floor
    because that is the convention of datasheets and of IEEE Std 952 and does not depend on
    the flicker noise being exactly flat.

    Detection (a term not detected is None in the result):

    * Q, N, K, R: the term must be the leading one (at least half of the fitted variance) at
      some tau, which is the condition for its slope to show on the curve, and over those taus
      its contribution must stand out of the points' uncertainty:
      ``sqrt(sum((share / rel_err)**2)) >= min_snr``.
    * B: the floor is the minimum over the points whose Allan deviation is known to
      ``floor_max_rel_err`` or better (all points when ``adev_err`` is None). It counts when it
      is not the first point (a curve that only rises has no floor) and the fitted Q and N
      lines explain at most half of the measured variance there (otherwise the "floor" is just
      where a falling white-noise curve ends).

    Known limits: terms of neighbouring slopes can share a stretch of curve (K and R on a
    curve that rises over only a few octaves, each then too weak to count); where a falling
    and a rising line cross with no flat part between them, half the variance is white noise
    and the floor is read or not depending on the noise; that reading, like every floor
    reading, is an upper bound on the flicker coefficient (the fit's own flicker coefficient
    is in ``NoiseParams.fit["B"]``).

    Parameters
    ----------
    taus : array_like, shape (k,)
        Averaging times, s, distinct, at least 3 (any order).
    adev : array_like, shape (k,)
        Allan deviation at ``taus``, rad/s (positive).
    adev_err : array_like, shape (k,), optional
        One-sigma uncertainty of ``adev``, rad/s, e.g. :attr:`AllanDeviation.adev_err`. Without
        it every point gets the same relative weight (``model_error``), the significance test
        reduces to the dominance test (with the default settings), and the floor is searched
        over all points.
    model_error : float, optional
        Relative uncertainty of the Allan variance attributed to model mismatch, added in
        quadrature to the statistical one (default 0.1, i.e. 5 % in deviation). Must be > 0.
    min_snr : float, optional
        Significance a term needs, in standard deviations (default 3).
    floor_max_rel_err : float, optional
        Largest relative uncertainty of ``adev`` at which a point may set the floor (default
        0.25, i.e. at least about 9 independent clusters).

    Returns
    -------
    NoiseParams
        Coefficients in SI units; see :meth:`NoiseParams.to_datasheet`.

    References
    ----------
    .. [1] IEEE Std 952-1997, Annex C, Table C.1 (model terms and the 0.664 factor).
    .. [2] N. El-Sheimy, H. Hou, X. Niu, IEEE Trans. Instrum. Meas. 57(1), 140-149 (2008)
       (least-squares fit of the Allan variance model, cluster-count error bars).
    """
    f = _fit_curve(taus, adev, adev_err, model_error, min_snr, floor_max_rel_err)
    t, a, avar, adev_rel, basis, c, fit = f.t, f.a, f.avar, f.adev_rel, f.basis, f.c, f.fit
    values: dict[str, float | None] = {}
    for j, term in enumerate(NOISE_TERMS):
        if term == "B":
            continue
        lead, snr = f.lead_snr(j)
        values[term] = fit[term] if (lead.any() and snr >= min_snr) else None

    reliable = adev_rel <= floor_max_rel_err
    b = b_tau = None
    if reliable.any():
        idx = np.flatnonzero(reliable)
        i = int(idx[np.argmin(a[idx])])
        falling = basis[i, 0] * c[0] + basis[i, 1] * c[1]          # Q and N lines at the floor
        if i > 0 and falling <= 0.5 * avar[i]:
            b, b_tau = float(a[i] / FLICKER_FLOOR_FACTOR), float(t[i])
    return NoiseParams(Q=values["Q"], N=values["N"], B=b, K=values["K"], R=values["R"],
                       B_tau=b_tau, fit=fit)


def allan_report(rate, fs: float, taus=None) -> tuple[np.ndarray, np.ndarray, NoiseParams]:
    """Allan deviation of a rate record and its identified noise terms.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate signal, rad/s.
    fs : float
        Sample rate, Hz.
    taus : None, 'octave', 'all' or array_like, optional
        Averaging times, s; see :func:`oadev_details` (default: octave spacing).

    Returns
    -------
    taus : ndarray, shape (k,)
        Averaging times, s.
    adev : ndarray, shape (k,)
        Overlapping Allan deviation, rad/s.
    params : NoiseParams
        From :func:`identify_noise` with the IEEE Std 952 error bars of the curve.
    """
    d = oadev_details(rate, fs, taus)
    return d.taus, d.adev, identify_noise(d.taus, d.adev, d.adev_err)


# ---------------------------------------------------------------------------------------------
# Confidence intervals: equivalent degrees of freedom of the overlapping Allan variance
#: Probability content of a one-sigma interval, erf(1/sqrt(2)) = 0.6827.
ONE_SIGMA_CI = math.erf(1.0 / math.sqrt(2.0))

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
        of the term that leads the five-term model fitted to the curve
        (:func:`identify_noise_terms` with the IEEE 952 error bars) -- the noise type is
        identified from the curve's slopes rather than from the lag-1 autocorrelation
        allantools uses, because for a gyro the terms are the quantities wanted anyway.
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
        if k >= 3:
            alphas = identify_noise_terms(d.taus, d.adev, d.adev_err).alpha(d.taus)
        else:
            alphas = np.zeros(k, dtype=int)
    else:
        alphas = np.broadcast_to(np.asarray(alpha), (k,)).astype(int)
    edf = np.array([edf_greenhall(int(a), int(mi), d.n + 1) for a, mi in zip(alphas, d.m)])
    low, high = confidence_interval(d.adev, edf, ci)
    return AllanCI(taus=d.taus, adev=d.adev, low=low, high=high, edf=edf,
                   alpha=np.asarray(alphas, dtype=int), ci=float(ci), m=d.m, n=d.n, fs=d.fs)


# ---------------------------------------------------------------------------------------------
# Noise identification with uncertainties and reasons
_TERM_NAMES = {"Q": "quantisation", "N": "angle random walk", "B": "bias instability",
               "K": "rate random walk", "R": "rate ramp"}


@dataclass(frozen=True)
class NoiseTerm:
    """One IEEE Std 952 noise term as identified from an Allan deviation curve.

    Attributes
    ----------
    term : str
        ``"Q"``, ``"N"``, ``"B"``, ``"K"`` or ``"R"`` (see :class:`NoiseParams` for SI units).
    status : str
        ``"identified"``, ``"upper bound"`` (only B: the curve has no floor inside its
        reliable part; ``value`` is then an upper bound) or ``"not identified"``.
    value : float or None
        The coefficient, SI unit; None when not identified.
    sigma : float or None
        Its one-sigma uncertainty, SI unit (None when not identified or for an upper bound).
    reason : str
        Why it is (not) identified, in words, with the taus involved.
    tau_range : tuple of float or None
        (first, last) tau, s, where the term leads the fitted model (for B: the floor's tau).
    """

    term: str
    status: str
    value: float | None
    sigma: float | None
    reason: str
    tau_range: tuple[float, float] | None = None

    @property
    def name(self) -> str:
        """The term's name in words (``"angle random walk"``)."""
        return _TERM_NAMES[self.term]

    def to_datasheet(self) -> dict:
        """This term in datasheet units: ``{key: value, key + "_sigma": sigma, "status": ...,
        "reason": ..., "tau_range_s": [..]}`` with ``key`` e.g. ``arw_deg_rt_h``."""
        unit, key = _DATASHEET[self.term]
        return {
            key: None if self.value is None else float(self.value / unit),
            f"{key}_sigma": None if self.sigma is None else float(self.sigma / unit),
            "status": self.status,
            "reason": self.reason,
            "tau_range_s": None if self.tau_range is None else [float(t) for t in self.tau_range],
        }


@dataclass(frozen=True)
class NoiseIdentification:
    """Result of :func:`identify_noise_terms`.

    Attributes
    ----------
    terms : dict of str to NoiseTerm
        Keys ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"``.
    fit : dict of str to float
        Coefficients of the weighted non-negative least-squares fit of the five-term model, SI
        units (``fit["B"]`` is the fit's flicker coefficient, not the floor reading).
    fit_sigma : dict of str to float or None
        Their one-sigma uncertainties (None for a coefficient fitted as zero).
    chi2_red : float
        Reduced chi-squared of the fit with the weights used (model error included); the
        uncertainties are scaled up by ``sqrt(chi2_red)`` when it exceeds 1.
    """

    terms: dict
    fit: dict
    fit_sigma: dict
    chi2_red: float

    def model_adev(self, taus) -> np.ndarray:
        """The fitted five-term model's Allan deviation at ``taus`` (s), shape (k,), SI unit."""
        return noise_model_adev(taus, self.fit)

    def alpha(self, taus) -> np.ndarray:
        """Noise exponent of the leading fitted term at each of ``taus``, shape (k,), int."""
        t = np.asarray(taus, dtype=float)
        contrib = np.column_stack([_BASIS[term](t) * self.fit[term] ** 2 for term in NOISE_TERMS])
        lead = np.argmax(contrib, axis=1)
        return np.array([ALPHA_OF_TERM[NOISE_TERMS[i]] for i in lead], dtype=int)

    @property
    def params(self) -> NoiseParams:
        """The identified terms as a :class:`NoiseParams` (upper bounds left out)."""
        v = {t: (x.value if x.status == "identified" else None) for t, x in self.terms.items()}
        b = self.terms["B"]
        return NoiseParams(Q=v["Q"], N=v["N"], B=v["B"], K=v["K"], R=v["R"],
                           B_tau=b.tau_range[0] if b.status == "identified" else None,
                           fit=dict(self.fit))

    def to_datasheet(self) -> dict:
        """``{term name: NoiseTerm.to_datasheet()}`` plus the fit, in datasheet units."""
        out = {_TERM_NAMES[t].replace(" ", "_"): self.terms[t].to_datasheet()
               for t in ("Q", "N", "B", "K", "R")}
        out["model_fit"] = {
            _DATASHEET[t][1]: float(self.fit[t] / _DATASHEET[t][0]) for t in NOISE_TERMS}
        out["model_fit_sigma"] = {
            _DATASHEET[t][1]: (None if self.fit_sigma[t] is None
                               else float(self.fit_sigma[t] / _DATASHEET[t][0]))
            for t in NOISE_TERMS}
        out["model_fit_chi2_red"] = float(self.chi2_red)
        return out


def noise_model_adev(taus, coefficients: dict) -> np.ndarray:
    """Allan deviation of the IEEE Std 952 five-term model.

    Parameters
    ----------
    taus : array_like, shape (k,)
        Averaging times, s.
    coefficients : dict
        ``{"Q": rad, "N": rad/sqrt(s), "B": rad/s, "K": rad/s/sqrt(s), "R": rad/s^2}``; missing
        or None terms count as zero.

    Returns
    -------
    ndarray, shape (k,)
        The model's Allan deviation, rad/s.
    """
    t = np.asarray(taus, dtype=float)
    avar = np.zeros_like(t)
    for term in NOISE_TERMS:
        c = coefficients.get(term)
        if c is not None:
            avar = avar + _BASIS[term](t) * float(c) ** 2
    return np.sqrt(avar)


def identify_noise_terms(taus, adev, adev_err=None, *, adev_low=None, adev_high=None,
                         ci: float = 0.95, model_error: float = 0.1, min_snr: float = 3.0,
                         floor_max_rel_err: float = 0.25) -> NoiseIdentification:
    """Identify the five IEEE Std 952 noise terms of an Allan deviation curve, each with its
    uncertainty, or say why it is not identified.

    The fit and the detection rules are those of :func:`identify_noise` (a weighted
    non-negative least-squares fit of the full model to the Allan variance; a term counts when
    it leads the model somewhere and stands out of the points' uncertainty by ``min_snr``; B is
    the floor reading divided by 0.664), so both give the same Q, N, K, R. B differs in one
    case: a minimum that lies inside the reliable part of the curve (the curve turns up after
    it) counts as the floor even where white noise still makes most of its variance, as a
    datasheet reads it (the share is given in the reason). In addition:

    * Uncertainties of Q, N, K, R: the linearised covariance of the weighted fit over the terms
      it kept, scaled by the reduced chi-squared when that exceeds 1 (the curve departs from the
      model more than its error bars say), propagated to the square root. Octave-spaced
      overlapping deviations are positively correlated between neighbouring taus; the
      covariance ignores that, so treat these as lower bounds of the true scatter.
    * Uncertainty of B: that of the floor point (``adev_err``, or the interval) divided by 0.664.
    * When the curve falls as white noise up to its longest reliable tau, B is reported as an
      ``"upper bound"``, the floor point's value plus two sigma, divided by 0.664.

    Parameters
    ----------
    taus : array_like, shape (k,)
        Averaging times, s, distinct, at least 3.
    adev : array_like, shape (k,)
        Allan deviation, rad/s (positive).
    adev_err : array_like, shape (k,), optional
        One-sigma uncertainty of ``adev``, rad/s.
    adev_low, adev_high : array_like, shape (k,), optional
        Instead of ``adev_err``: the bounds of a ``ci`` confidence interval (e.g. as published
        with a curve), rad/s; ``adev_err`` is taken as their half-distance over the normal
        quantile of ``ci``. A lower bound may be negative (normal-approximation intervals).
    ci : float, optional
        Probability content of ``adev_low``/``adev_high`` (default 0.95).
    model_error, min_snr, floor_max_rel_err : float, optional
        See :func:`identify_noise`.

    Returns
    -------
    NoiseIdentification

    References
    ----------
    .. [1] IEEE Std 952-1997, Annex C, Table C.1.
    .. [2] N. El-Sheimy, H. Hou, X. Niu, IEEE Trans. Instrum. Meas. 57(1), 140-149 (2008).
    """
    from scipy.stats import norm

    if (adev_low is None) != (adev_high is None):
        raise ValueError("adev_low, adev_high: give both bounds of the interval or neither")
    if adev_low is not None:
        if adev_err is not None:
            raise ValueError("adev_err: give either adev_err or adev_low/adev_high, not both")
        if not (isinstance(ci, (int, float, np.floating)) and 0.0 < ci < 1.0):
            raise ValueError(f"ci: expected a probability between 0 and 1, got {ci!r}")
        try:
            lo = np.asarray(adev_low, dtype=float)
            hi = np.asarray(adev_high, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"adev_low, adev_high: cannot be read as float arrays ({exc})") \
                from None
        if lo.shape != hi.shape:
            raise ValueError(f"adev_low: shape {lo.shape} must match adev_high {hi.shape}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError("adev_low, adev_high: expected finite bounds")
        if np.any(hi < lo):
            i = int(np.flatnonzero(hi < lo)[0])
            raise ValueError(f"adev_high: below adev_low at index {i} ({hi[i]} < {lo[i]})")
        adev_err = (hi - lo) / (2.0 * norm.ppf(0.5 + ci / 2.0))
    f = _fit_curve(taus, adev, adev_err, model_error, min_snr, floor_max_rel_err)
    t, a, e, avar, adev_rel, rel = f.t, f.a, f.e, f.avar, f.adev_rel, f.rel
    basis, c, model, share, fit = f.basis, f.c, f.model, f.share, f.fit

    # Covariance of the kept variance coefficients (weights 1/(rel * model), as in the fit).
    sig = rel * model
    active = np.flatnonzero(c > 0)
    resid = (avar - model) / sig
    dof = t.shape[0] - active.shape[0]
    chi2_red = float(np.sum(resid**2) / dof) if dof > 0 else float("nan")
    fit_sigma: dict[str, float | None] = {term: None for term in NOISE_TERMS}
    if active.shape[0]:
        aw = basis[:, active] / sig[:, None]
        norm_c = np.linalg.norm(aw, axis=0)
        cov = np.linalg.pinv((aw / norm_c).T @ (aw / norm_c)) / np.outer(norm_c, norm_c)
        if np.isfinite(chi2_red) and chi2_red > 1.0:
            cov = cov * chi2_red
        for k, j in enumerate(active):
            sc = math.sqrt(max(float(cov[k, k]), 0.0))
            fit_sigma[NOISE_TERMS[j]] = sc / (2.0 * math.sqrt(c[j]))

    terms: dict[str, NoiseTerm] = {}
    for j, term in enumerate(NOISE_TERMS):
        if term == "B":
            continue
        lead, snr = f.lead_snr(j)
        if lead.any() and snr >= min_snr:
            rng = (float(t[lead][0]), float(t[lead][-1]))
            terms[term] = NoiseTerm(term, "identified", fit[term], fit_sigma[term],
                                    f"leads the fitted model at tau {rng[0]:g} ... {rng[1]:g} s "
                                    f"({snr:.0f} sigma)", rng)
        elif lead.any():
            rng = (float(t[lead][0]), float(t[lead][-1]))
            terms[term] = NoiseTerm(term, "not identified", None, None,
                                    f"leads at tau {rng[0]:g} ... {rng[1]:g} s but stands out of "
                                    f"the curve's uncertainty by only {snr:.1f} sigma "
                                    f"(< {min_snr:g})", rng)
        else:
            i = int(np.argmax(share[:, j]))
            terms[term] = NoiseTerm(term, "not identified", None, None,
                                    "never the leading term of the fitted model (at most "
                                    f"{100 * share[i, j]:.0f} % of the variance, at tau "
                                    f"{t[i]:g} s)")

    reliable = adev_rel <= floor_max_rel_err
    if not reliable.any():
        terms["B"] = NoiseTerm("B", "not identified", None, None,
                               f"no point of the curve is known to {floor_max_rel_err:.0%} "
                               "or better")
    else:
        idx = np.flatnonzero(reliable)
        i = int(idx[np.argmin(a[idx])])
        falling = basis[i, 0] * c[0] + basis[i, 1] * c[1]
        err_i = 0.0 if e is None else float(e[i])
        if i == 0:
            terms["B"] = NoiseTerm("B", "not identified", None, None,
                                   f"the curve's minimum is its first point (tau {t[0]:g} s): "
                                   "it only rises, there is no floor")
        elif falling <= 0.5 * avar[i] or i < idx[-1]:
            white = 100.0 * falling / avar[i]
            terms["B"] = NoiseTerm("B", "identified", float(a[i] / FLICKER_FLOOR_FACTOR),
                                   err_i / FLICKER_FLOOR_FACTOR,
                                   f"floor (minimum) of the curve at tau {t[i]:g} s, divided by "
                                   f"0.664; the fitted Q and N lines make {white:.0f} % of the "
                                   "variance there (a floor reading bounds the flicker "
                                   "coefficient from above; the fit's own is "
                                   f"{fit['B']:.3g} rad/s)", (float(t[i]), float(t[i])))
        else:
            last = float(t[idx[-1]])
            terms["B"] = NoiseTerm("B", "upper bound",
                                   float((a[i] + 2.0 * err_i) / FLICKER_FLOOR_FACTOR), None,
                                   f"no floor: the curve still falls as white/quantisation "
                                   f"noise at its lowest reliable point (tau {t[i]:g} s; "
                                   f"reliable up to {last:g} s); bias instability <= "
                                   "(that point + 2 sigma) / 0.664",
                                   (float(t[i]), float(t[i])))
    terms = {k: terms[k] for k in NOISE_TERMS}
    return NoiseIdentification(terms=terms, fit=fit, fit_sigma=fit_sigma, chi2_red=chi2_red)


def allan_analysis(rate, fs: float, taus=None, *, ci: float = ONE_SIGMA_CI, **identify_options
                   ) -> tuple[AllanCI, NoiseIdentification]:
    """Overlapping Allan deviation with EDF confidence intervals and the identified noise terms.

    Steps: :func:`oadev_details`; a first identification with the IEEE 952 error bars gives the
    leading noise type at each tau; :func:`edf_greenhall` and :func:`confidence_interval` give
    the intervals; the final identification uses them (:func:`identify_noise_terms`).

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate signal, rad/s.
    fs : float
        Sample rate, Hz.
    taus : None, 'octave', 'all' or array_like, shape (k,)
        Averaging times, s (default octave).
    ci : float, optional
        Probability content of the intervals (default 0.6827).
    **identify_options
        ``model_error``, ``min_snr``, ``floor_max_rel_err`` of :func:`identify_noise_terms`.

    Returns
    -------
    curve : AllanCI
    identification : NoiseIdentification
    """
    curve = oadev_ci(rate, fs, taus, ci=ci)
    if curve.taus.shape[0] < 3:
        raise ValueError(f"rate: {curve.n} samples give only {curve.taus.shape[0]} octave "
                         "averaging times; at least 3 are needed to identify noise terms "
                         "(record at least 8 samples, in practice thousands)")
    ident = identify_noise_terms(curve.taus, curve.adev, adev_low=curve.low,
                                 adev_high=curve.high, ci=curve.ci, **identify_options)
    return curve, ident
