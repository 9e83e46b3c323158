"""Wavelet neural network (WNN) error compensation of a FOG, after paper 000.

The method, in the paper's order:

1. Trend extraction (paper eq. 3): a Mallat (discrete wavelet) decomposition of the raw rate to
   M levels with Daubechies-6; the approximation C_M is the drift trend, the sum of the
   reconstructed details D_1..D_M is the "error residual". :func:`mallat_split`.
2. A one-hidden-layer network with Morlet activations (eqs. 5-6) maps 5 consecutive raw samples
   to the residual. :func:`wnn_forward`.
3. Full-batch steepest descent on the loss E = e^2/2 (eqs. 7-11) with momentum (eq. 12) and
   learning rates adapted each iteration (eqs. 13-14). :func:`wnn_loss_and_grad`.
4. Compensation: ``compensate = raw - predicted residual``.

Choices where the paper is silent or unclear are documented on :class:`WaveletNeuralNetwork`
and :func:`auto_level`.
"""

from __future__ import annotations

import math
import numbers
import warnings

import numpy as np
import pywt
from scipy import signal

from .._checks import _mode, _wavelet
from .._data import GyroData
from .._estimator import Compensator, DivergenceError
from .._registry import register
from .._checks import _random_state

__all__ = [
    "WaveletNeuralNetwork",
    "mallat_split",
    "auto_level",
    "max_level",
    "morlet",
    "wnn_forward",
    "wnn_loss_and_grad",
]

#: A loss this many times the initial loss counts as diverged (:class:`DivergenceError`).
DIVERGENCE_FACTOR = 1e4


# ---------------------------------------------------------------------------------------------
# Trend extraction
def max_level(n: int, wavelet="db6") -> int:
    """Deepest usable Mallat level for ``n`` samples: ``pywt.dwt_max_level``, at least 1."""
    return max(1, pywt.dwt_max_level(n, _wavelet(wavelet).dec_len))


def _split(x: np.ndarray, w: pywt.Wavelet, level: int, mode: str):
    n = x.shape[0]
    with warnings.catch_warnings():
        # the caller has checked the level; pywt's "Level value of .. is too high" is not news
        warnings.filterwarnings("ignore", message="Level value of", category=UserWarning)
        coeffs = pywt.wavedec(x, w, mode=mode, level=level)
    zeros = [np.zeros_like(c) for c in coeffs]
    trend = pywt.waverec([coeffs[0]] + zeros[1:], w, mode=mode)[:n]
    residual = pywt.waverec([zeros[0]] + coeffs[1:], w, mode=mode)[:n]
    return trend, residual


def mallat_split(x, wavelet="db6", level=12, mode="symmetric"):
    """Split a signal into its level-M wavelet trend and the residual of all details.

    ``trend`` is the reconstruction of the level-M approximation coefficients alone (every
    detail set to zero), ``residual`` the reconstruction of the details D_1..D_M alone (the
    approximation set to zero). The wavelet transform is linear and perfectly reconstructing,
    so ``trend + residual == x`` to rounding (the reconstruction of an odd-length record has
    one extra sample, which is dropped): within about 1e-15 of max|x| with the "symmetric",
    "periodic" and "periodization" modes; the other modes round worse at the ends (up to
    about 1e-12 relative for "zero", "reflect", "smooth").

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal, any unit (rad/s for a gyro rate).
    wavelet : str, default "db6"
        PyWavelets wavelet name (the paper's Daubechies-6).
    level : int, default 12
        Decomposition level M (the paper's value). A level deeper than
        ``pywt.dwt_max_level(n, filter length)`` (7 for 2,500 samples with db6) is clamped to
        it (at least 1), with a warning: deeper, every coefficient would be made of the
        boundary extension rather than of the data.
    mode : str, default "symmetric"
        PyWavelets signal extension mode. "symmetric" does not wrap a drifting record round
        end to start as "periodization" would.

    Returns
    -------
    trend : ndarray, shape (n,)
        C_M f, unit of ``x``.
    residual : ndarray, shape (n,)
        D_1 f + ... + D_M f, unit of ``x``.

    References
    ----------
    .. [1] Paper 000, section 2, eqs. (1)-(3): C_0 f = C_M f + D_1 f + ... + D_M f.
    .. [2] S. G. Mallat, "A theory for multiresolution signal decomposition: the wavelet
       representation", IEEE Trans. PAMI 11(7), 674-693, 1989.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.shape[0] < 1:
        raise ValueError(f"x: expected a non-empty 1-D array, got shape {x.shape}")
    w = _wavelet(wavelet)
    mode = _mode(mode)
    level = _check_level_int(level)
    lmax = max_level(x.shape[0], w)
    if level > lmax:
        warnings.warn(f"level: M = {level} is deeper than a record of {x.shape[0]} samples "
                      f"supports with {w.name} (pywt.dwt_max_level = "
                      f"{pywt.dwt_max_level(x.shape[0], w.dec_len)}); using M = {lmax} instead",
                      stacklevel=2)
        level = lmax
    return _split(x, w, level, mode)


def _check_level_int(level) -> int:
    if isinstance(level, bool) or not isinstance(level, numbers.Integral) or level < 1:
        raise ValueError(f"level: expected an integer >= 1 or 'auto', got {level!r}")
    return int(level)


def _octave_bands(f: np.ndarray, j_max: int) -> list:
    """The octave bands [2^-(j+1), 2^-j) cycles/sample, j = 1..j_max, of the ascending
    frequencies ``f`` that hold at least ``_MIN_BAND_BINS`` bins, as (j, first, stop) indices."""
    bands = []
    for j in range(1, j_max + 1):
        lo, hi = np.searchsorted(f, [2.0 ** -(j + 1), 2.0 ** -j], side="left")
        if hi - lo >= _MIN_BAND_BINS:
            bands.append((j, int(lo), int(hi)))
    return bands


def _octave_medians(p: np.ndarray, bands: list, j_max: int, j_min: int = 1) -> np.ndarray:
    """Median of ``p`` over each octave band of :func:`_octave_bands`, j = j_min..j_max (NaN
    where a band has too few bins)."""
    out = np.full(j_max - j_min + 1, np.nan)
    for j, lo, hi in bands:
        if j >= j_min:
            out[j - j_min] = np.median(p[lo:hi])
    return out


#: An octave band of the periodogram needs this many bins to take part in the level criterion.
_MIN_BAND_BINS = 4
#: :func:`auto_level` computes the residuals' periodograms this many samples at a time.
_PSD_BATCH = 1 << 22


def _criterion(pr: np.ndarray, bands: list, j_max: int, m: int, floor: float) -> float:
    """:func:`auto_level`'s criterion value at level ``m`` from the residual's periodogram."""
    med = _octave_medians(pr, bands, j_max, j_min=m)
    med = med[np.isfinite(med)]
    if floor > 0:
        return float(med.max()) / floor if med.size else 0.0
    # a noise-free record: any residual power is excess
    return np.inf if med.size and med.max() > 0 else 0.0


def auto_level(x, wavelet="db6", mode="symmetric", psd_ratio=3.0):
    """Choose the Mallat level M by the paper's power-spectral-density criterion.

    The paper raises M (a coarser trend is "more clearly the drift") and checks, on the PSD of
    the residual, that the low-frequency content of the raw signal has been removed (section 2
    and Fig. 3). Read literally this cannot stop: the residual D_1 + ... + D_M covers
    frequencies down to about fs / 2^(M+1), so it regains low frequencies as M grows. What the
    check can mean is: take the deepest M whose residual still holds no low-frequency excess,
    i.e. the coarsest trend that still carries all the drift. Made concrete:

    1. PSD: the periodogram (one Hann-windowed segment of the whole record, mean removed) of
       the raw signal and of the residual at each M, frequency f in cycles/sample.
    2. Noise floor: the median of the raw periodogram over the top octave [1/4, 1/2), where a
       gyro's output is white noise (ARW) and a drift has no power.
    3. For each M, the criterion value is the largest, over the octave bands
       [2^-(j+1), 2^-j) with j >= M (the residual's lowest band, D_M's, and every band below),
       of the median of the residual's periodogram in that band, divided by the noise floor.
       Medians over bands make a spectral line outside the low bands (a high-frequency error
       such as a vibration at fs/4, or its window leakage) count for nothing. For white noise
       the value is about 1 (less where the wavelet filters roll off); a drift whose PSD
       stands above the floor in D_M's band, or leaks into the residual below it, raises it.
    4. M is the largest level, from 1 up to ``pywt.dwt_max_level``, such that the values at
       1..M are all <= ``psd_ratio``. If even M = 1 fails, M = 1 with a warning.

    Parameters
    ----------
    x : array_like, shape (n,)
        Raw signal, any unit (rad/s for a gyro rate).
    wavelet : str, default "db6"
        PyWavelets wavelet name.
    mode : str, default "symmetric"
        PyWavelets signal extension mode.
    psd_ratio : float, default 3.0
        Largest allowed criterion value: how far above the white-noise floor the residual's
        PSD may stand in its low bands. For white noise the value is about 1; 3 leaves room for
        the periodogram's scatter (medians of ten or more chi-square(2) bins, as the deepest
        bands have, rarely reach twice their expectation).

    Returns
    -------
    level : int
        The chosen M, >= 1.
    criterion : ndarray, shape (pywt.dwt_max_level, ) (at least 1)
        The criterion value for M = 1, 2, ... (dimensionless, ratio of PSDs).

    References
    ----------
    .. [1] Paper 000, section 2 (last paragraph) and Fig. 3.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.shape[0] < 8:
        raise ValueError(f"x: expected a 1-D array of at least 8 samples, got shape {x.shape}")
    w = _wavelet(wavelet)
    mode = _mode(mode)
    if not (isinstance(psd_ratio, numbers.Real) and math.isfinite(psd_ratio) and psd_ratio > 0):
        raise ValueError(f"psd_ratio: expected a positive finite number, got {psd_ratio!r}")
    lmax = max_level(x.shape[0], w)
    crit = _level_criteria(x, w, mode, lmax)
    ok = crit <= psd_ratio
    if not ok[0]:
        warnings.warn(f"level: no level separates the trend by the PSD criterion (value "
                      f"{crit[0]:.3g} > psd_ratio = {psd_ratio} already at M = 1); using M = 1",
                      stacklevel=2)
        return 1, crit
    level = int(np.argmin(ok)) if not ok.all() else lmax
    return level, crit


def _level_criteria(x: np.ndarray, w, mode: str, lmax: int) -> np.ndarray:
    """The criterion of :func:`auto_level` for M = 1 .. ``lmax``, shape (lmax,): steps 1-3 of
    its description (periodograms, noise floor, the largest band median over the floor)."""
    n = x.shape[0]
    f, px = signal.periodogram(x, fs=1.0, window="hann", detrend="constant")
    top = (f >= 0.25) & (f < 0.5)
    floor = float(np.median(px[top]))
    j_max = max(1, int(math.floor(math.log2(n))))
    bands = _octave_bands(f, j_max)
    crit = np.empty(lmax)
    # the residuals' periodograms, several levels per call (the same numbers as one call per
    # level, in a third of the time on 50,000 samples), at most _PSD_BATCH values per call
    per_call = max(1, _PSD_BATCH // n)
    for m0 in range(1, lmax + 1, per_call):
        levels = range(m0, min(lmax, m0 + per_call - 1) + 1)
        rs = np.stack([_split(x, w, m, mode)[1] for m in levels])
        _, prs = signal.periodogram(rs, fs=1.0, window="hann", detrend="constant", axis=-1)
        for m, pr in zip(levels, prs):
            crit[m - 1] = _criterion(pr, bands, j_max, m, floor)
    return crit


# ---------------------------------------------------------------------------------------------
# The network
def morlet(u, w0=6.0):
    """Real Morlet wavelet ``psi(u) = exp(-u^2/2) cos(w0 u)``.

    The paper writes the complex Morlet ``exp(-u^2/2) exp(j w0 u)`` with w0 = 6; a real-valued
    network uses its real part (as Zhang and Benveniste's wavelet networks do).

    Parameters
    ----------
    u : array_like
        Argument, dimensionless.
    w0 : float, default 6.0
        Centre angular frequency (the paper's 6).

    Returns
    -------
    ndarray
        psi(u), same shape as ``u``.

    References
    ----------
    .. [1] Paper 000, section 3.1 (the Morlet wavelet below eq. 5, w0 = 6).
    """
    u = np.asarray(u, dtype=float)
    return np.exp(-0.5 * u * u) * np.cos(w0 * u)


def wnn_forward(X, W, w_out, a, b, w0=6.0):
    """Output of the wavelet network for a batch of input windows.

    ``h_j = psi((sum_i W_ij X_i - b_j) / a_j)``, ``y = sum_j w_out_j h_j``.

    Parameters
    ----------
    X : ndarray, shape (N, k)
        Input windows (k consecutive normalised samples each), dimensionless.
    W : ndarray, shape (k, l)
        Input-to-hidden weights w_ij.
    w_out : ndarray, shape (l,)
        Hidden-to-output weights w_j.
    a : ndarray, shape (l,)
        Scales (dilations) a_j, non-zero.
    b : ndarray, shape (l,)
        Translations b_j.
    w0 : float
        Morlet centre frequency.

    Returns
    -------
    ndarray, shape (N,)
        Network outputs y, dimensionless (normalised residual).

    References
    ----------
    .. [1] Paper 000, eqs. (5)-(6).
    """
    u = (X @ W - b) / a
    return (np.exp(-0.5 * u * u) * np.cos(w0 * u)) @ w_out


def _forward_series(x, k, W, w_out, a, b, w0, chunk=1 << 14):
    """:func:`wnn_forward` of every full window of the series ``x``, shape (n - k + 1,).

    The same sums, laid out as (hidden, samples) and done chunk by chunk in place, so that a
    million samples do not build a (10^6, l) temporary per operation.
    """
    n_out = x.shape[0] - k + 1
    Wa = (W / a).T                                    # (l, k)
    ba = (b / a)[:, None]
    out = np.empty(n_out)
    for s in range(0, n_out, chunk):
        m = min(chunk, n_out - s)
        u = Wa[:, :1] * x[s:s + m]
        for i in range(1, k):
            u += Wa[:, i:i + 1] * x[s + i:s + i + m]
        u -= ba
        c = np.cos(w0 * u)
        u *= u
        u *= -0.5
        np.exp(u, out=u)
        u *= c
        out[s:s + m] = w_out @ u
    return out


def wnn_loss_and_grad(X, t, W, w_out, a, b, w0=6.0):
    """Batch loss and its analytic gradient.

    ``E = (1/N) sum_n e_n^2 / 2`` with ``e_n = y_n - t_n``: the paper's per-sample
    ``E(n) = e(n)^2 / 2`` (eqs. 7-8) averaged over the batch, so that the learning rates do
    not scale with the number of samples. With ``u = (X W - b) / a`` and
    ``psi'(u) = -exp(-u^2/2) (u cos(w0 u) + w0 sin(w0 u))``, ``g = e w_out psi'(u)``:

    * dE/dw_out_j = mean_n e_n h_nj
    * dE/dW_ij = mean_n X_ni g_nj / a_j
    * dE/db_j = -mean_n g_nj / a_j
    * dE/da_j = -mean_n g_nj u_nj / a_j

    Parameters
    ----------
    X : ndarray, shape (N, k)
        Input windows, dimensionless.
    t : ndarray, shape (N,)
        Targets (normalised residual), dimensionless.
    W, w_out, a, b : ndarray
        Network parameters, shapes (k, l), (l,), (l,), (l,) (see :func:`wnn_forward`).
    w0 : float
        Morlet centre frequency.

    Returns
    -------
    loss : float
        E, dimensionless.
    grads : tuple of ndarray
        (dE/dW, dE/dw_out, dE/da, dE/db), shapes as the parameters.

    References
    ----------
    .. [1] Paper 000, eqs. (7)-(10) (the gradients the steepest-descent steps use).
    """
    n = X.shape[0]
    u = X @ (W / a) - b / a
    g = np.exp(-0.5 * u * u)
    wu = w0 * u
    c = np.cos(wu)
    h = g * c
    e = h @ w_out - t
    loss = 0.5 * float(e @ e) / n
    g_out = (e @ h) / n
    dpsi = u * c
    dpsi += w0 * np.sin(wu)
    dpsi *= g                                       # = -psi'(u)
    gz = dpsi * np.outer(e, -w_out / (a * n))       # (1/n) dE_n/dz_nj, z = X W
    g_w = X.T @ gz
    g_b = -gz.sum(axis=0)
    g_a = -(gz * u).sum(axis=0)
    return loss, (g_w, g_out, g_a, g_b)


#: Windows per chunk of the fast batch loss (:class:`_BatchLoss`): its (hidden, chunk) work
#: arrays, 11 x 1024 float64 (90 kB) each, stay in a core's L2 cache while a dozen ufuncs pass
#: over them. Measured at 50,000 samples: 768 to 2048 alike, 512 and 4096 about 10 % slower.
_CHUNK = 1024


class _BatchLoss:
    """:func:`wnn_loss_and_grad` over the windows of one fitting record, for repeated calls.

    The same loss and gradient, arranged for speed (``tests/fogcomp/methods/test_wnn.py`` compares the
    training it drives with the former, plain implementation, kept there verbatim):

    * The Morlet's cos(w0 u) and sin(w0 u) come from one tangent of the half angle,
      ``tau = tan(w0 u / 2)``: ``cos = (1 - tau^2) / (1 + tau^2)``, ``sin = 2 tau / (1 + tau^2)``.
      numpy's float64 cos and sin are scalar libm loops (about 15 ns a value on the bench
      machine), its tan a SIMD loop on CPUs with AVX-512 (about 1.6 ns; elsewhere one scalar
      tan replaces a scalar cos and sin). The identities are exact and each side rounds to
      within a few units in the last place. With ``rho = exp(-u^2/2) / (1 + tau^2)``:
      ``h = psi(u) = rho (1 - tau^2)`` and ``-psi'(u) = u h + 2 w0 tau rho``.
    * One matrix product per chunk gives ``v = u / (2 w0)`` (the windows carry a row of ones
      for ``-b / a``); ``w0 u / 2`` and ``-u^2 / 2`` are multiples of ``v`` and ``v^2``, and
      ``-psi'(u) / (2 w0) = tau rho + v h`` needs no further scaling.
    * The windows are taken ``_CHUNK`` at a time through work arrays allocated once and
      updated in place, so that the arrays stay in cache and an iteration allocates nothing
      of the record's size.
    * The per-window products are summed by matrix products: ``[X; 1] (e psi')^T`` gives
      dE/dW and dE/db at once, and dE/da follows from them exactly,
      ``sum_n g_nj u_nj = sum_i (W_ij / a_j) sum_n X_ni g_nj - (b_j / a_j) sum_n g_nj``.

    Parameters
    ----------
    Xs : ndarray, shape (k, N)
        Input windows, dimensionless (row i is sample s + i of window s).
    t : ndarray, shape (N,)
        Targets, dimensionless.
    n_hidden : int
        Hidden nodes l.
    w0 : float
        Morlet centre frequency.
    """

    def __init__(self, Xs, t, n_hidden, w0):
        k, n = Xs.shape
        l = int(n_hidden)
        self.k, self.l, self.n, self.w0 = k, l, n, float(w0)
        # the hidden arguments are computed as v = u / scale, so that -psi' / scale =
        # tau rho + v h needs no scaling; with w0 = 0, tau = 0 and scale 1 give -psi' = u h
        self.scale = 2.0 * self.w0 if self.w0 > 0 else 1.0
        m0 = min(_CHUNK, n)
        work = [np.empty((l, m0)) for _ in range(4)] + [np.empty((k + 1, m0))]
        self._chunks = []
        for s in range(0, n, m0):
            m = min(m0, n - s)
            x = np.empty((k + 1, m))                   # the windows [X; 1], contiguous
            x[:k] = Xs[:, s:s + m]
            x[k] = 1.0
            t_s = np.array(t[s:s + m], dtype=float)
            self._chunks.append((x, t_s) + tuple(w if m == m0 else w[:, :m] for w in work))

    def __call__(self, W, w_out, a, b):
        """Loss E and (dE/dW, dE/dw_out, dE/da, dE/db), as :func:`wnn_loss_and_grad`."""
        k, l, n, w0, scale = self.k, self.l, self.n, self.w0, self.scale
        Wa = np.empty((l, k + 1))                       # u = Wa [X; 1]
        np.divide(W, a, out=Wa[:, :k].T)
        np.divide(b, a, out=Wa[:, k])
        np.negative(Wa[:, k], out=Wa[:, k])
        A = Wa / scale                                  # v = u / scale = A [X; 1]
        c_tau = 0.5 * w0 * scale                        # w0 u / 2 = c_tau v
        c_gauss = -0.5 * scale * scale                  # -u^2 / 2 = c_gauss v^2
        loss = 0.0
        g_out = np.zeros(l)
        gxe = np.zeros((k + 1, l))
        matmul, multiply, square, tan, exp = np.matmul, np.multiply, np.square, np.tan, np.exp
        for x, t, v, tau, r, q, xe in self._chunks:
            matmul(A, x, out=v)
            multiply(v, c_tau, out=tau)
            tan(tau, out=tau)                           # tau = tan(w0 u / 2)
            square(v, out=r)
            r *= c_gauss
            exp(r, out=r)                               # exp(-u^2 / 2)
            square(tau, out=q)
            q += 1.0
            r /= q                                      # rho = exp(-u^2 / 2) / (1 + tau^2)
            q -= 2.0
            q *= r                                      # -h = -psi(u) = rho (tau^2 - 1)
            e = w_out @ q
            e += t                                      # -e = t - w_out h
            loss += float(e @ e)
            g_out += q @ e                              # sum_n h e
            tau *= r
            q *= v
            tau -= q                                    # -psi'(u) / scale = tau rho + v h
            multiply(x, e, out=xe)
            gxe += xe @ tau.T                           # sum_n [X; 1] e psi' / scale
        gxe *= w_out * (scale / (a * n))                # dE/dz = psi' e w_out / (a n)
        g_w = gxe[:k]
        g_b = -gxe[k]
        # dE/da_j = -mean_n g_nj u_nj / a_j with u = Wa [X; 1]: from dE/dW and dE/db
        g_a = -(np.einsum("ji,ij->j", Wa[:, :k], g_w) - Wa[:, k] * g_b)
        return 0.5 * loss / n, (g_w, g_out / n, g_a, g_b)


def _loss_grad_t(Xs, t, W, w_out, a, b, w0):
    """:func:`wnn_loss_and_grad` with the windows as ``Xs``, shape (k, N), by
    :class:`_BatchLoss` (tests compare the two)."""
    return _BatchLoss(Xs, t, W.shape[1], w0)(W, w_out, a, b)


# ---------------------------------------------------------------------------------------------
def _positive(name, value, allow_zero=False):
    ok = (isinstance(value, numbers.Real) and not isinstance(value, bool)
          and math.isfinite(value) and (value >= 0 if allow_zero else value > 0))
    if not ok:
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name}: expected a {kind} finite number, got {value!r}")
    return float(value)


def _int_at_least(name, value, low):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name}: expected an integer >= {low}, got {value!r}")
    return int(value)


def _choice(name, value, options):
    if not (isinstance(value, str) and value in options):
        raise ValueError(f"{name}: expected one of {list(options)}, got {value!r}")
    return value


#: Readings of the input normalisation at compensation (see WaveletNeuralNetwork).
NORMALIZATIONS = ("fit", "record")
#: Readings of the training loop (see WaveletNeuralNetwork).
TRAININGS = ("batch", "online")


@register
class WaveletNeuralNetwork(Compensator):
    """Wavelet neural network compensation (paper 000): predict the wavelet residual, subtract it.

    Parameters
    ----------
    n_hidden : int, default 11
        Hidden (Morlet) nodes l. The paper does not give l; 11 = 2k + 1 for k = 5 inputs
        (the Kolmogorov / Hecht-Nielsen rule for one hidden layer). On the narrowband test
        error of ``tests/fogcomp/methods/test_wnn.py`` (5 records), 6 nodes left about 20 % more error std,
        16 or 24 nodes about 10 % less at 2-3 times the training time.
    n_inputs : int, default 5
        Consecutive raw samples per input window, k (paper: x_n .. x_n+4).
    target_offset : int, default 0
        Index in the window of the sample whose residual is the target: the output for
        sample t uses samples t - target_offset .. t - target_offset + k - 1. 0 is the paper's
        reading ("inputs x_n .. x_n+4, output y_n"); k - 1 is causal; (k - 1) // 2 centred.
    level : int or "auto", default "auto"
        Mallat level M of the trend. The paper used 12 on its record; 12 is tied to that
        record's length and rate, and a 2,500-sample record supports only 7 levels of db6, so
        the default applies the paper's own PSD criterion (:func:`auto_level`) instead. An
        integer deeper than the fitting record supports is clamped, with a warning.
    wavelet : str, default "db6"
        Wavelet of the trend extraction (paper: Daubechies order 6).
    mode : str, default "symmetric"
        PyWavelets extension mode of the trend extraction.
    psd_ratio : float, default 3.0
        Threshold of the automatic level criterion (see :func:`auto_level`).
    w0 : float, default 6.0
        Morlet centre frequency (paper: 6).
    eta1 : float, default 0.05
        Initial learning rate of the weights w_ij, w_j (paper's eta1; value not given).
    eta2 : float, default 0.05
        Initial learning rate of the scales and translations a_j, b_j (paper's eta2; not given).
    eta3 : float, default 0.5
        Momentum factor (paper's eta3; not given). Defaults chosen by trial on the test
        processes of ``tests/fogcomp/methods/test_wnn.py``: over eta1 = eta2 in {0.01, 0.05, 0.2} and
        eta3 in {0, 0.5, 0.9}, momentum 0.5 was the most reliable; with the adaptive rule the
        initial rate matters little (0.05 and 0.2 were alike).
    lr_inc, lr_dec : float, default 1.05, 0.7
        Factors applied to eta1 and eta2 after an iteration in which the loss fell / rose
        (paper eqs. 13-14; also MATLAB traingdx's defaults).
    max_iter : int, default 200
        Training iterations (paper: 200), full passes over the fitting windows.
    normalization : {"fit", "record"}, default "fit"
        Which statistics standardise the input of a record being compensated (the paper trains
        on raw samples and says nothing about scaling; both readings are offered):

        * ``"fit"``: the fitting record's mean and standard deviation, for every record (a
          fitted model applied unchanged). A record at another rate is then far outside the
          range the network was trained on.
        * ``"record"``: each record's own mean and standard deviation; the predicted residual
          is scaled back with the fitting record's residual scale times (record std / fitting
          std). Training is identical under both readings; only compensation differs.
    training : {"batch", "online"}, default "batch"
        ``"batch"``: each iteration is one steepest-descent step on the mean of the per-sample
        loss (eq. 8) over all windows. ``"online"``: each iteration is a pass over the windows
        in order with one update per sample (eqs. 9-12 applied to E(n) of that sample, the
        literal reading of eq. 8), 2,500 x 200 = 500,000 updates for the paper's record;
        eta1, eta2 adapt once per pass (eqs. 13-14) on the pass's accumulated absolute error
        (the quantity of the paper's Fig. 4). A per-sample Python loop: about 10^5 updates/s,
        i.e. ~5 s on 2,500 samples and ~100 s on 50,000 with the default 200 passes.
    random_state : int, numpy Generator or None
        Seed of the initial weights. Required (None raises at ``fit``).

    Attributes
    ----------
    level_ : int
        Mallat level used.
    level_criterion_ : ndarray, shape (L,)
        Criterion value per level 1..L when ``level="auto"`` (see :func:`auto_level`);
        empty otherwise.
    x_mean_, x_scale_ : float
        Mean and standard deviation of the fitting record's raw rate, rad/s; inputs are
        ``(rate - x_mean_) / x_scale_``.
    y_mean_, y_scale_ : float
        Mean and standard deviation of the fitting record's residual, rad/s; the network
        predicts ``(residual - y_mean_) / y_scale_``.
    input_weights_ : ndarray, shape (n_inputs, n_hidden)
        w_ij.
    output_weights_ : ndarray, shape (n_hidden,)
        w_j.
    scales_ : ndarray, shape (n_hidden,)
        a_j.
    translations_ : ndarray, shape (n_hidden,)
        b_j.
    loss_curve_ : ndarray, shape (max_iter + 1,)
        Batch loss E (normalised units) of the initial network and after each iteration.
    n_iter_ : int
        Iterations run.
    fs_ : float
        Sample rate of the fitting record, Hz.

    Notes
    -----
    *Normalisation.* Inputs and target are standardised with the fitting record's statistics
    (stored above) for training. With ``normalization="fit"`` a record at another turntable
    rate is far outside the range the network was trained on (at -30 deg/s after fitting at
    -60 deg/s, the inputs are shifted by 30 deg/s divided by the fitting record's standard
    deviation). With ``"record"`` every record is standardised by its own statistics.

    *What it does to real motion* (``tests/fogcomp/methods/test_wnn.py``, measured): the target residual of a
    constant-rate record is close to ``x_n - (the record's level)``, which the network learns
    as a function of x_n. On a record compensated with ``"record"`` normalisation, the output
    is then close to the record's own mean for every sample: a block mean over the record. A
    rate step or a slow sine inside the record is flattened towards the record's mean. With
    ``"fit"`` normalisation samples within a few standard deviations of the fitting rate are
    pulled to the fitting record's level, and motion far from it passes unchanged (the Morlet
    units are zero there).

    *What it can learn.* With ``target_offset`` inside the window the target sample is an
    input, and on a constant-rate record the residual is close to ``x_n - (the record's mean
    rate)``: the network can learn the fitting rate itself. On white noise of 0.1 deg/s at
    -60 deg/s it then outputs about -60 deg/s for any input near it (output std 0.004 deg/s
    on fresh samples at -60 deg/s, but -59.99 deg/s for a true -59.9 deg/s), and at -30 or
    -90 deg/s its Morlet units are far outside their support and it removes almost nothing.
    A small output std at the fitting rate is therefore not, by itself, evidence of an error
    model; compare against the reference rate.

    *Ends.* Training uses only full windows (n - k + 1 of them). To give one output per sample,
    ``estimate_error`` extends the normalised record at both ends by half-sample symmetric
    reflection (``numpy.pad(mode="symmetric")``): ``target_offset`` samples before and
    k - 1 - target_offset after.

    *Training.* Full batch: each iteration is one steepest-descent step on the mean loss over
    all windows (the paper's per-sample loss, eq. 8, averaged), with the momentum of eq. 12;
    eta1 and eta2 are multiplied by ``lr_inc`` when the loss fell from the previous iteration,
    by ``lr_dec`` when it rose (eqs. 13-14). There is no step rejection or stopping rule (the
    paper states none). A non-finite loss or one above ``DIVERGENCE_FACTOR`` times the initial
    loss raises :class:`~fogcomp.DivergenceError`.

    *Initialisation* (the paper gives none): w_ij uniform in +-0.3/sqrt(k), b_j uniform in
    +-1, a_j = 3, w_j uniform in +-1/sqrt(l): with standardised inputs the hidden arguments
    u = (z - b)/a start well inside the Morlet's central lobe (``abs(u) < ~0.5``), where the
    units are smooth; started with a_j = 1 they sit on the oscillating flanks and the network,
    after 200 iterations, generalised 1.5-10 times worse to fresh samples in our trials.

    References
    ----------
    .. [1] Paper 000: section 2 (trend extraction, eq. 3), section 3 (network eqs. 5-6, loss
       eqs. 7-8, steepest descent eqs. 9-11, momentum eq. 12, adaptive rates eqs. 13-14),
       section 4 (2,500 training samples, 200 iterations, M = 12).
    .. [2] Q. Zhang and A. Benveniste, "Wavelet networks", IEEE Trans. Neural Networks 3(6),
       889-898, 1992 (the paper's ref. [9]).
    """

    name = "wnn"
    requires = ("rate",)
    supervised = False
    random = True

    def __init__(self, n_hidden=11, n_inputs=5, target_offset=0, level="auto", wavelet="db6",
                 mode="symmetric", psd_ratio=3.0, w0=6.0, eta1=0.05, eta2=0.05, eta3=0.5,
                 lr_inc=1.05, lr_dec=0.7, max_iter=200, normalization="fit", training="batch",
                 random_state=None):
        self.n_hidden = n_hidden
        self.n_inputs = n_inputs
        self.target_offset = target_offset
        self.level = level
        self.wavelet = wavelet
        self.mode = mode
        self.psd_ratio = psd_ratio
        self.w0 = w0
        self.eta1 = eta1
        self.eta2 = eta2
        self.eta3 = eta3
        self.lr_inc = lr_inc
        self.lr_dec = lr_dec
        self.max_iter = max_iter
        self.normalization = normalization
        self.training = training
        self.random_state = random_state

    # -- validation ----------------------------------------------------------------------------
    def _validate(self):
        k = _int_at_least("n_inputs", self.n_inputs, 1)
        _int_at_least("n_hidden", self.n_hidden, 1)
        off = _int_at_least("target_offset", self.target_offset, 0)
        if off > k - 1:
            raise ValueError(f"target_offset: must be in 0..n_inputs-1 = 0..{k - 1}, got {off}")
        if not (isinstance(self.level, str) and self.level == "auto"):
            _check_level_int(self.level)
        _wavelet(self.wavelet)
        _mode(self.mode)
        _positive("psd_ratio", self.psd_ratio)
        _positive("w0", self.w0, allow_zero=True)
        _positive("eta1", self.eta1, allow_zero=True)
        _positive("eta2", self.eta2, allow_zero=True)
        eta3 = _positive("eta3", self.eta3, allow_zero=True)
        if eta3 >= 1:
            raise ValueError(f"eta3: the momentum factor must be in [0, 1), got {eta3!r}")
        if _positive("lr_inc", self.lr_inc) < 1:
            raise ValueError(f"lr_inc: expected >= 1, got {self.lr_inc!r}")
        if _positive("lr_dec", self.lr_dec) > 1:
            raise ValueError(f"lr_dec: expected in (0, 1], got {self.lr_dec!r}")
        _int_at_least("max_iter", self.max_iter, 0)
        _choice("normalization", self.normalization, NORMALIZATIONS)
        _choice("training", self.training, TRAININGS)
        _random_state(self.random_state)

    # -- fitting ---------------------------------------------------------------------------------
    def _fit(self, data: GyroData, error) -> None:
        self._validate()
        rng = self._rng()
        x = data.rate
        n = x.shape[0]
        k, l, off = int(self.n_inputs), int(self.n_hidden), int(self.target_offset)
        if n < max(k + 1, 8):
            raise ValueError(f"rate: the WNN needs at least {max(k + 1, 8)} samples to fit, "
                             f"got {n}")
        # 1. trend extraction (eq. 3)
        if isinstance(self.level, str):
            level, crit = auto_level(x, self.wavelet, self.mode, self.psd_ratio)
        else:
            level, crit = self.level, np.zeros(0)
        _, resid = mallat_split(x, self.wavelet, level, self.mode)  # warns if clamped
        level = min(level, max_level(n, self.wavelet))
        # 2. normalisation with the fitting record's statistics
        x_mean, x_scale = float(np.mean(x)), float(np.std(x))
        if x_scale == 0.0:
            warnings.warn("rate: the fitting record is constant; the residual is zero and the "
                          "network learns nothing", stacklevel=3)
            x_scale = 1.0
        y_mean, y_scale = float(np.mean(resid)), float(np.std(resid))
        if y_scale == 0.0:
            y_scale = 1.0
        xn = (x - x_mean) / x_scale
        yn = (resid - y_mean) / y_scale
        N = n - k + 1
        Xs = np.stack([xn[i:i + N] for i in range(k)])   # (k, N): row i is x_(s+i)
        t = yn[off:off + N]                             # target: residual at s + off
        # 3. initial weights (see Notes)
        W = rng.uniform(-1.0, 1.0, (k, l)) * (0.3 / math.sqrt(k))
        b = rng.uniform(-1.0, 1.0, l)
        a = np.full(l, 3.0)
        w_out = rng.uniform(-1.0, 1.0, l) / math.sqrt(l)
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is checked in _train
            if self.training == "online":
                params, losses = self._train_online(Xs, t, [W, w_out, a, b])
            else:
                params, losses = self._train(Xs, t, [W, w_out, a, b])
        self.level_ = int(level)
        self.level_criterion_ = np.asarray(crit, dtype=float)
        self.x_mean_, self.x_scale_ = x_mean, x_scale
        self.y_mean_, self.y_scale_ = y_mean, y_scale
        self.input_weights_, self.output_weights_, self.scales_, self.translations_ = params
        self.loss_curve_ = losses
        self.n_iter_ = losses.shape[0] - 1
        self.fs_ = data.fs

    def _train(self, Xs, t, params):
        """Steepest descent with momentum and adaptive rates (eqs. 9-14); see class Notes.
        ``Xs``: the windows, shape (k, N)."""
        eta1, eta2, eta3 = float(self.eta1), float(self.eta2), float(self.eta3)
        w0 = float(self.w0)
        max_iter = int(self.max_iter)
        prev = [p.copy() for p in params]            # theta_(k-1); no momentum at k = 0
        losses = np.empty(max_iter + 1)
        loss_grad = _BatchLoss(Xs, t, params[0].shape[1], w0)
        for it in range(max_iter + 1):
            loss, grads = loss_grad(*params)
            losses[it] = loss
            if not math.isfinite(loss) or loss > DIVERGENCE_FACTOR * max(losses[0], 1e-300):
                raise DivergenceError(
                    f"{self.name}: training diverged at iteration {it} (loss {loss:.3g}, "
                    f"initial {losses[0]:.3g}); lower eta1/eta2/eta3")
            if it == max_iter:
                break
            if it > 0:                                 # eqs. 13-14
                if loss < losses[it - 1]:
                    eta1 *= self.lr_inc
                    eta2 *= self.lr_inc
                elif loss > losses[it - 1]:
                    eta1 *= self.lr_dec
                    eta2 *= self.lr_dec
            rates = (eta1, eta1, eta2, eta2)           # W, w_out: eta1 (eq. 9); a, b: eta2 (eq. 10)
            new = [p - r * g + eta3 * (p - q)          # eqs. 11-12
                   for p, r, g, q in zip(params, rates, grads, prev)]
            prev, params = params, new
        return params, losses

    def _train_online(self, Xs, t, params):
        """Per-sample steepest descent with momentum (eqs. 9-12 on E(n), eq. 8), rates adapted
        per pass on the accumulated absolute error (eqs. 13-14, Fig. 4)."""
        eta1, eta2, eta3 = float(self.eta1), float(self.eta2), float(self.eta3)
        w0 = float(self.w0)
        max_iter = int(self.max_iter)
        k, l = params[0].shape
        X = np.ascontiguousarray(Xs.T)
        # one flat vector [W (k*l), w_out (l), a (l), b (l)] with views, so that a step is
        # two array operations; the change of the last step carries the momentum (eq. 12)
        theta = np.concatenate([p.ravel() for p in params])
        W = theta[:k * l].reshape(k, l)
        w_out = theta[k * l:k * l + l]
        a = theta[k * l + l:k * l + 2 * l]
        b = theta[k * l + 2 * l:]
        grad = np.empty_like(theta)
        gW = grad[:k * l].reshape(k, l)
        rate = np.empty_like(theta)
        delta = np.zeros_like(theta)
        losses = np.empty(max_iter + 1)
        batch_loss = _BatchLoss(Xs, t, l, w0)
        losses[0] = batch_loss(W, w_out, a, b)[0]
        prev_abs = None
        exp, cos, sin, outer = np.exp, np.cos, np.sin, np.outer
        for it in range(max_iter):
            rate[:k * l + l] = eta1                        # W, w_out: eta1 (eq. 9)
            rate[k * l + l:] = eta2                        # a, b: eta2 (eq. 10)
            acc = 0.0
            for x, tn in zip(X, t):
                u = (x @ W - b) / a
                g = exp(-0.5 * u * u)
                wu = w0 * u
                c = cos(wu)
                h = g * c
                e = float(h @ w_out) - tn
                acc += abs(e)
                gz = g * (u * c + w0 * sin(wu)) * (-e) * w_out / a
                outer(x, gz, out=gW)
                grad[k * l:k * l + l] = e * h
                grad[k * l + l:k * l + 2 * l] = -gz * u
                grad[k * l + 2 * l:] = -gz
                delta *= eta3                              # eqs. 11-12
                delta -= rate * grad
                theta += delta
            loss = batch_loss(W, w_out, a, b)[0]
            losses[it + 1] = loss
            if not math.isfinite(loss) or loss > DIVERGENCE_FACTOR * max(losses[0], 1e-300):
                raise DivergenceError(
                    f"{self.name}: online training diverged in pass {it + 1} (loss {loss:.3g}, "
                    f"initial {losses[0]:.3g}); lower eta1/eta2/eta3")
            if prev_abs is not None:                      # eqs. 13-14
                if acc < prev_abs:
                    eta1 *= self.lr_inc
                    eta2 *= self.lr_inc
                elif acc > prev_abs:
                    eta1 *= self.lr_dec
                    eta2 *= self.lr_dec
            prev_abs = acc
        return [W.copy(), w_out.copy(), a.copy(), b.copy()], losses

    # -- compensation --------------------------------------------------------------------------
    def predict_residual(self, data: GyroData) -> np.ndarray:
        """The network's predicted error residual, shape (n,), rad/s."""
        self._check_fitted()
        if data.fs != self.fs_:
            warnings.warn(f"{self.name}: fitted at {self.fs_} Hz, applied at {data.fs} Hz; the "
                          "input window now spans a different time", stacklevel=3)
        k, off = int(self.n_inputs), int(self.target_offset)
        if self.normalization == "record":
            x_mean, x_scale = float(np.mean(data.rate)), float(np.std(data.rate))
            if x_scale == 0.0:
                x_scale = self.x_scale_
            y_scale = self.y_scale_ * x_scale / self.x_scale_
        else:
            x_mean, x_scale, y_scale = self.x_mean_, self.x_scale_, self.y_scale_
        xn = (data.rate - x_mean) / x_scale
        xp = np.pad(xn, (off, k - 1 - off), mode="symmetric")
        y = _forward_series(xp, k, self.input_weights_, self.output_weights_, self.scales_,
                            self.translations_, float(self.w0))
        return y * y_scale + self.y_mean_

    def _estimate(self, data: GyroData) -> np.ndarray:
        return self.predict_residual(data)

    # -- persistence -----------------------------------------------------------------------------
    _SCALARS = ("x_mean_", "x_scale_", "y_mean_", "y_scale_", "fs_")
    _ARRAYS = ("input_weights_", "output_weights_", "scales_", "translations_", "loss_curve_",
               "level_criterion_")

    def _state(self):
        info = {"level_": self.level_, "n_iter_": self.n_iter_}
        arrays = {name: getattr(self, name) for name in self._ARRAYS}
        # scalars as float64 arrays: bit-exact through the npz
        arrays["scalars_"] = np.array([getattr(self, s) for s in self._SCALARS], dtype=float)
        return info, arrays

    def _restore(self, info, arrays):
        self.level_ = int(info["level_"])
        self.n_iter_ = int(info["n_iter_"])
        for name in self._ARRAYS:
            setattr(self, name, np.asarray(arrays[name], dtype=float))
        scal = np.asarray(arrays["scalars_"], dtype=float)
        if scal.shape != (len(self._SCALARS),):
            raise ValueError(f"scalars_: expected shape ({len(self._SCALARS)},), got {scal.shape}")
        for s, v in zip(self._SCALARS, scal):
            setattr(self, s, float(v))
