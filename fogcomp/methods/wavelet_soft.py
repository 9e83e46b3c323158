"""Soft-threshold wavelet denoising (the "soft-threshold wavelet" baseline of paper 000, Table 1).

The raw rate is decomposed with a discrete wavelet transform, every detail coefficient is shrunk
towards zero by a threshold (soft thresholding), and the signal is rebuilt. What the shrinkage
removes is the estimated error: ``compensate(data) = denoised rate``.

Choices (paper 000 names the method but gives none of its settings):

* wavelet ``"db6"``: the wavelet paper 000 uses for its own trend extraction, so that the WNN and
  this baseline differ in the method and not in the wavelet.
* level: ``pywt.dwt_max_level(n, filter length)`` of the record being denoised (7 for 2,500
  samples, 6 for 1,000, with db6), the deepest level at which no coefficient is made only of
  boundary extension. A deeper level asked for is clamped to it, with a warning.
* mode ``"symmetric"`` (PyWavelets' default): a record with a drift does not wrap round end to
  start as it would with ``"periodization"``; the latter is the orthonormal case the tests check
  against theory.
* noise level sigma from the median absolute value of the finest detail coefficients / 0.6745,
  estimated on each record when it is denoised (so that the threshold follows the record, as in
  the usual VisuShrink recipe); ``fit`` only checks its input and records the fitting record's
  sigma for information (``sigma_``).
* threshold ``"universal"``: ``sigma * sqrt(2 ln n)``, n = record length, the same on every
  level; ``"sure"``: Stein's unbiased risk estimate minimised on each level (MATLAB
  ``thselect(x, 'rigrsure')`` on the coefficients divided by sigma, times sigma, as ``wden``
  with ``'sln'`` does), a threshold per level; or a fixed number in rad/s.

The level decides the result on white noise (what survives is the level-L approximation of
the noise, std ~ sigma / sqrt(2^L)); a scenario should score the levels from 3 to the maximum
as a band rather than one pick. Paper 000's 0.1156 deg/s suggests a shallower split or a SURE
threshold (its settings are not given).
"""

from __future__ import annotations

import math
import numbers
import warnings
from typing import NamedTuple

import numpy as np
import pywt

from .._checks import _mode, _wavelet
from .._data import GyroData
from .._estimator import Compensator
from .._registry import register

__all__ = ["WaveletSoftThreshold", "SoftDenoiseResult", "soft_denoise", "mad_sigma",
           "sure_threshold", "THRESHOLDS"]

#: Named threshold rules (a number is also accepted).
THRESHOLDS = ("universal", "sure")

#: Median of |N(0, 1)|: ``median(|d|) / MAD_GAUSS`` estimates the standard deviation of Gaussian d.
MAD_GAUSS = 0.6744897501960817


class SoftDenoiseResult(NamedTuple):
    """What :func:`soft_denoise` did.

    Attributes
    ----------
    denoised : ndarray, shape (n,)
        The rebuilt signal, same unit as the input (rad/s for a rate).
    sigma : float
        Noise standard deviation estimated from the finest detail coefficients, input unit.
    threshold : float
        The threshold applied to every detail coefficient (the largest of
        ``level_thresholds`` for ``"sure"``), input unit.
    level : int
        Decomposition level used.
    level_thresholds : ndarray, shape (level,)
        Threshold of each detail level, coarsest (D_level) first, finest (D_1) last.
    """

    denoised: np.ndarray
    sigma: float
    threshold: float
    level: int
    level_thresholds: np.ndarray


def sure_threshold(x) -> float:
    """SURE threshold of coefficients of unit noise variance (MATLAB ``rigrsure``).

    For soft thresholding of x_i ~ N(mu_i, 1) at t, Stein's unbiased estimate of the risk is
    ``n - 2 #{abs(x_i) <= t} + sum min(x_i^2, t^2)``; it is minimised over t in ``{abs(x_i)}``.

    Parameters
    ----------
    x : array_like, shape (m,)
        Coefficients divided by the noise standard deviation.

    Returns
    -------
    float
        The threshold, in units of the noise standard deviation.

    References
    ----------
    .. [1] D. L. Donoho and I. M. Johnstone, "Adapting to unknown smoothness via wavelet
       shrinkage", J. Amer. Statist. Assoc. 90(432), 1200-1224, 1995 (SureShrink, eq. 11).
    """
    sx2 = np.sort(np.abs(np.asarray(x, dtype=float))) ** 2
    n = sx2.size
    if n == 0:
        return 0.0
    i = np.arange(1, n + 1)
    risks = (n - 2.0 * i + np.cumsum(sx2) + (n - i) * sx2) / n
    return float(math.sqrt(sx2[int(np.argmin(risks))]))


def mad_sigma(d: np.ndarray) -> float:
    """Noise standard deviation from wavelet detail coefficients, ``median(|d|) / 0.6745``.

    Parameters
    ----------
    d : ndarray, shape (m,)
        Finest-level detail coefficients (for an orthonormal wavelet, white noise of standard
        deviation sigma gives coefficients of standard deviation sigma).

    Returns
    -------
    float
        The estimate of sigma, unit of ``d``.

    References
    ----------
    .. [1] D. L. Donoho and I. M. Johnstone, "Ideal spatial adaptation by wavelet shrinkage",
       Biometrika 81(3), 425-455, 1994 (the MAD/0.6745 noise estimate, section 4.2).
    """
    return float(np.median(np.abs(d)) / MAD_GAUSS)


def _check_wavelet(wavelet) -> pywt.Wavelet:
    w = _wavelet(wavelet)
    if not w.orthogonal:
        raise ValueError(f"wavelet: {wavelet!r} is not orthogonal; the MAD noise estimate and "
                         "the universal threshold assume an orthogonal wavelet (db*, sym*, coif*)")
    return w


def _check_threshold(threshold):
    if isinstance(threshold, str):
        if threshold not in THRESHOLDS:
            raise ValueError(f"threshold: expected one of {list(THRESHOLDS)} or a non-negative "
                             f"number in rad/s, got {threshold!r}")
        return threshold
    if (isinstance(threshold, numbers.Real) and not isinstance(threshold, bool)
            and math.isfinite(threshold) and threshold >= 0):
        return float(threshold)
    raise ValueError(f"threshold: expected one of {list(THRESHOLDS)} or a non-negative finite "
                     f"number in rad/s, got {threshold!r}")


def _resolve_level(level, n: int, w: pywt.Wavelet) -> int:
    max_level = pywt.dwt_max_level(n, w.dec_len)
    if level is None:
        if max_level < 1:
            warnings.warn(f"level: a record of {n} samples is too short for a full level of "
                          f"{w.name} (filter length {w.dec_len}); using level 1, whose "
                          "coefficients are all affected by the boundary extension",
                          stacklevel=3)
        return max(1, max_level)
    if isinstance(level, bool) or not isinstance(level, numbers.Integral) or level < 1:
        raise ValueError(f"level: expected None or an integer >= 1, got {level!r}")
    level = int(level)
    if level > max(1, max_level):
        warnings.warn(f"level: {level} is deeper than a record of {n} samples supports with "
                      f"{w.name} (pywt.dwt_max_level = {max_level}); using level "
                      f"{max(1, max_level)} instead", stacklevel=3)
        return max(1, max_level)
    return level


def soft_denoise(x, wavelet="db6", level=None, mode="symmetric",
                 threshold="universal") -> SoftDenoiseResult:
    """Soft-threshold wavelet denoising of one record.

    ``x`` is decomposed to ``level`` levels; every detail coefficient d becomes
    ``sign(d) * max(|d| - t, 0)``; the approximation is kept; the signal is rebuilt and trimmed
    to the input length.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal, any unit (rad/s for a gyro rate).
    wavelet : str
        An orthogonal PyWavelets wavelet name.
    level : int or None
        Decomposition level; None for ``pywt.dwt_max_level(n, filter length)`` (at least 1).
        A deeper level than that is clamped to it, with a warning.
    mode : str
        PyWavelets signal extension mode.
    threshold : "universal", "sure" or float
        ``"universal"``: ``t = sigma * sqrt(2 ln n)`` with sigma from :func:`mad_sigma` of the
        finest details; ``"sure"``: on each level, ``sigma * sure_threshold(d / sigma)``
        (:func:`sure_threshold`); a number: t itself, unit of ``x``.

    Returns
    -------
    SoftDenoiseResult
        The denoised signal, shape (n,), and the sigma, threshold and level used.

    References
    ----------
    .. [1] D. L. Donoho, "De-noising by soft-thresholding", IEEE Trans. Inf. Theory 41(3),
       613-627, 1995 (soft thresholding and the universal threshold sigma sqrt(2 ln n)).
    .. [2] D. L. Donoho and I. M. Johnstone, "Ideal spatial adaptation by wavelet shrinkage",
       Biometrika 81(3), 425-455, 1994.
    .. [3] Paper 000 (fogbench seed 000_6140556fe3a47984, WNN error compensation of a FOG),
       section 4.2 and Table 1: this is its "soft-threshold wavelet" comparison method.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.shape[0] < 2:
        raise ValueError(f"x: expected a 1-D array of at least 2 samples, got shape {x.shape}")
    w = _check_wavelet(wavelet)
    mode = _mode(mode)
    threshold = _check_threshold(threshold)
    n = x.shape[0]
    lev = _resolve_level(level, n, w)
    with warnings.catch_warnings():
        # the level is resolved above; pywt's own "too deep" warning would repeat ours
        warnings.filterwarnings("ignore", message="Level value of", category=UserWarning)
        coeffs = pywt.wavedec(x, w, mode=mode, level=lev)
    sigma = mad_sigma(coeffs[-1])
    if threshold == "universal":
        ts = np.full(lev, sigma * math.sqrt(2.0 * math.log(n)))
    elif threshold == "sure":
        ts = np.array([sigma * sure_threshold(d / sigma) if sigma > 0 else 0.0
                       for d in coeffs[1:]])
    else:
        ts = np.full(lev, float(threshold))
    shrunk = [coeffs[0]] + [pywt.threshold(d, t, mode="soft") for d, t in zip(coeffs[1:], ts)]
    y = pywt.waverec(shrunk, w, mode=mode)[:n]
    return SoftDenoiseResult(y, sigma, float(ts.max()), lev, ts)


@register
class WaveletSoftThreshold(Compensator):
    """Soft-threshold wavelet denoiser; the estimated error is what the shrinkage removes.

    Parameters
    ----------
    wavelet : str, default "db6"
        Orthogonal PyWavelets wavelet (paper 000's wavelet).
    level : int or None, default None
        Decomposition level (any from 1; 3 .. the maximum is the range worth scanning); None
        for ``pywt.dwt_max_level`` of each record denoised.
    mode : str, default "symmetric"
        PyWavelets signal extension mode.
    threshold : "universal", "sure" or float, default "universal"
        ``"universal"`` for ``sigma * sqrt(2 ln n)`` with sigma estimated on each record;
        ``"sure"`` for a SURE (rigrsure) threshold per level; or a fixed threshold, rad/s.

    Attributes
    ----------
    sigma_ : float
        Noise standard deviation of the fitting record's rate, rad/s (information only).
    threshold_fit_ : float
        The threshold the fitting record got, rad/s (information only).
    fs_ : float
        Sample rate of the fitting record, Hz.

    Notes
    -----
    Unsupervised; nothing is learned. ``estimate_error(data) = data.rate - denoised``.

    References
    ----------
    .. [1] D. L. Donoho, "De-noising by soft-thresholding", IEEE Trans. Inf. Theory 41(3),
       613-627, 1995.
    .. [2] Paper 000 (fogbench seed 000_6140556fe3a47984), Table 1, "soft-threshold wavelet".
    """

    name = "wavelet_soft"
    requires = ("rate",)
    supervised = False
    random = False

    def __init__(self, wavelet="db6", level=None, mode="symmetric", threshold="universal"):
        self.wavelet = wavelet
        self.level = level
        self.mode = mode
        self.threshold = threshold

    def _validate(self):
        _check_wavelet(self.wavelet)
        _mode(self.mode)
        _check_threshold(self.threshold)
        if self.level is not None and (isinstance(self.level, bool)
                                       or not isinstance(self.level, numbers.Integral)
                                       or self.level < 1):
            raise ValueError(f"level: expected None or an integer >= 1, got {self.level!r}")

    def _denoise(self, rate: np.ndarray) -> SoftDenoiseResult:
        if rate.shape[0] < 2:
            raise ValueError(f"rate: wavelet denoising needs at least 2 samples, got {rate.shape[0]}")
        return soft_denoise(rate, self.wavelet, self.level, self.mode, self.threshold)

    def _fit(self, data: GyroData, error) -> None:
        self._validate()
        res = self._denoise(data.rate)
        self.sigma_ = res.sigma
        self.threshold_fit_ = res.threshold
        self.fs_ = data.fs

    def _estimate(self, data: GyroData) -> np.ndarray:
        return data.rate - self._denoise(data.rate).denoised

    def _state(self):
        return {"sigma_": self.sigma_, "threshold_fit_": self.threshold_fit_, "fs_": self.fs_}, {}

    def _restore(self, info, arrays):
        self.sigma_ = float(info["sigma_"])
        self.threshold_fit_ = float(info["threshold_fit_"])
        self.fs_ = float(info["fs_"])
