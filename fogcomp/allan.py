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

from ._checks import _signal

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
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.integer, np.floating)) \
            or not np.isfinite(fs) or fs <= 0:
        raise ValueError(f"fs: sample rate must be a positive finite number in Hz, got {fs!r}")
    return float(fs)


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
    for i, mi in enumerate(m):
        d = x[2 * mi:] - 2.0 * x[mi:n + 1 - mi] + x[:n + 1 - 2 * mi]
        avar[i] = np.dot(d, d) / d.shape[0]
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

    values: dict[str, float | None] = {}
    for j, term in enumerate(NOISE_TERMS):
        if term == "B":
            continue
        lead = share[:, j] >= 0.5
        snr = math.sqrt(float(np.sum((share[lead, j] / rel[lead]) ** 2)))
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
