"""Figures of merit of a (compensated) gyro record.

Every function takes SI inputs (rates in rad/s, times in s, sample rates in Hz) and returns SI
values; :func:`summary` converts to datasheet units for people, and then the unit is in every
key (``std_dph``, ``arw_deg_rt_h``). Functions that return several values return a dict whose
keys carry the unit (``angle_error_final_rad``).

The bias stability (:func:`bias_stability`) is the standard deviation of the smoothed
output [1]_; the noise terms (:func:`noise_terms`) are IEEE Std 952's Allan variance noise
terms [2]_.

.. rubric:: References

.. [1] Qiu et al., "ACO-BP FOG temperature compensation", Electronics Optics & Control 30(7),
   eq. 5 (bias stability of the smoothed output).
.. [2] IEEE Std 952-1997, Annex C (Allan variance noise terms).
"""

from __future__ import annotations

import math

import numpy as np

from ._checks import _signal
from scipy.signal import welch

from .allan import oadev_details
from .units import DEG, DPH, DPS

__all__ = [
    "noise_terms",
    "std",
    "smooth",
    "bias_stability",
    "bias_stability_segments",
    "psd",
    "rmse",
    "integrated_angle_error",
    "coefficient_errors",
    "summary",
    "ALLAN_MIN_DURATION_S",
    "ALLAN_MIN_SAMPLES",
]

_ALLAN_KEYS = ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h", "quantisation_arcsec",
               "rate_ramp_dph_per_h", "bias_instability_floor_dph", "gm_sigma_dph", "gm_tau_s")

#: :func:`summary` reports the Allan noise terms only for records at least this long, s.
ALLAN_MIN_DURATION_S = 100.0
#: ... and with at least this many samples (eight octave averaging times for a five-term fit).
ALLAN_MIN_SAMPLES = 512


# ---------------------------------------------------------------------------------------------
# Input checks


def _positive(name: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
            or not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name}: expected a positive finite number, got {v!r}")
    return float(v)


def _pair(x, truth, min_len: int = 1) -> tuple[np.ndarray, np.ndarray]:
    x = _signal("x", x, min_len)
    truth = _signal("truth", truth, min_len)
    if truth.shape != x.shape:
        raise ValueError(f"truth: shape {truth.shape} must match x {x.shape}")
    return x, truth


def _window_samples(fs: float, window_s: float) -> int:
    w = window_s * fs
    wi = int(round(w))
    if wi < 1 or abs(w - wi) > 1e-6 * max(1.0, w):
        raise ValueError(f"window_s: must be a whole number (>= 1) of samples at fs = {fs:g} Hz, "
                         f"got {window_s!r} s = {w:.6g} samples")
    return wi


# ---------------------------------------------------------------------------------------------
# Scatter
def std(x) -> float:
    """Sample standard deviation (the "precision" of a static record), ddof = 1.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal, any unit (rad/s for a rate); at least 2 samples.

    Returns
    -------
    float
        ``sqrt(sum((x - mean(x))**2) / (n - 1))``, unit of ``x``.

    References
    ----------
    .. [1] Wavelet-neural-network error compensation of a FOG (``seeds/000_6140556fe3a47984``),
       Table 1: precision = standard deviation of the compensated output.
    """
    x = _signal("x", x, min_len=2)
    # Shifted data (x - x[0]): same value in exact arithmetic, exactly 0 for a constant signal
    # and no loss of precision from a large offset.
    return float(np.std(x - x[0], ddof=1))


def smooth(x, fs: float, window_s: float) -> np.ndarray:
    """Means of consecutive, non-overlapping blocks of ``window_s`` seconds.

    An incomplete last block is dropped.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal, any unit (rad/s for a rate).
    fs : float
        Sample rate, Hz.
    window_s : float
        Block length, s; must be a whole number of samples, and the record at least one block.

    Returns
    -------
    ndarray, shape (n // w,)
        Block means, unit of ``x`` (``w = window_s * fs`` samples per block).
    """
    x = _signal("x", x)
    fs = _positive("fs", fs)
    window_s = _positive("window_s", window_s)
    w = _window_samples(fs, window_s)
    nb = x.shape[0] // w
    if nb < 1:
        raise ValueError(f"x: record of {x.shape[0]} samples ({x.shape[0] / fs:g} s) is shorter "
                         f"than one window of {window_s:g} s ({w} samples)")
    return x[:nb * w].reshape(nb, w).mean(axis=1)


def bias_stability(rate, fs: float, window_s: float = 100.0, scale_factor: float = 1.0) -> float:
    """Bias stability: the standard deviation of the ``window_s``-smoothed output.

    ``B_s = (1/K) * sqrt(sum_i (F_i - F_mean)**2 / (n - 1))``, with ``F_i`` the means of the
    ``n`` non-overlapping blocks of ``window_s`` seconds (:func:`smooth`) and ``K`` the scale
    factor.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Gyro output; rad/s with the default ``scale_factor`` (or raw output units).
    fs : float
        Sample rate, Hz.
    window_s : float, optional
        Smoothing window, s (default 100 s, as in the reference); a whole number of samples.
    scale_factor : float, optional
        Scale factor ``K``, output units per rad/s (default 1: ``rate`` already in rad/s).

    Returns
    -------
    float
        Bias stability, rad/s. Multiply by ``1 / fogcomp.units.DPH`` for deg/h.

    Raises
    ------
    ValueError
        If the record holds fewer than two complete windows.

    References
    ----------
    .. [1] Qiu et al., ACO-BP FOG temperature compensation, Electronics Optics & Control 30(7),
       eq. 5.
    """
    scale_factor = _positive("scale_factor", scale_factor)
    f = smooth(rate, fs, window_s)
    if f.shape[0] < 2:
        raise ValueError(f"rate: bias stability needs at least two complete windows of "
                         f"{window_s:g} s, the record has {f.shape[0]}")
    return std(f) / scale_factor


def bias_stability_segments(rate, fs: float, bounds, window_s: float = 100.0,
                            scale_factor: float = 1.0) -> np.ndarray:
    """Bias stability (:func:`bias_stability`) of each of several segments of a record.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Gyro output, rad/s (with the default ``scale_factor``).
    fs : float
        Sample rate, Hz.
    bounds : sequence of (float, float), length k
        ``(start_s, end_s)`` of each segment, s from the first sample (sample ``i`` is at
        ``i / fs``); a segment holds samples ``round(start_s * fs) <= i < round(end_s * fs)``.
        Segments may overlap.
    window_s : float, optional
        Smoothing window, s (default 100 s).
    scale_factor : float, optional
        Output units per rad/s (default 1).

    Returns
    -------
    ndarray, shape (k,)
        Bias stability of each segment, rad/s.

    References
    ----------
    .. [1] Qiu et al., ACO-BP FOG temperature compensation, Electronics Optics & Control 30(7),
       eq. 5.
    """
    rate = _signal("rate", rate)
    fs = _positive("fs", fs)
    try:
        b = np.asarray(bounds, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bounds: expected a sequence of (start_s, end_s) pairs ({exc})") \
            from None
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] == 0:
        raise ValueError(f"bounds: expected a non-empty sequence of (start_s, end_s) pairs, "
                         f"got shape {b.shape}")
    duration = rate.shape[0] / fs
    out = np.empty(b.shape[0])
    for k, (start, end) in enumerate(b):
        if not (np.isfinite(start) and np.isfinite(end) and 0 <= start < end
                and end <= duration + 0.5 / fs):
            raise ValueError(f"bounds[{k}]: expected 0 <= start_s < end_s <= {duration:g} s "
                             f"(the record length), got ({start!r}, {end!r})")
        i0, i1 = int(round(start * fs)), int(round(end * fs))
        try:
            out[k] = bias_stability(rate[i0:i1], fs, window_s, scale_factor)
        except ValueError as exc:
            raise ValueError(f"bounds[{k}]: segment ({start:g}, {end:g}) s: {exc}") from None
    return out


def psd(x, fs: float, nperseg: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectral density by Welch's method (Hann window, 50 % overlap).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal, rad/s (any unit ``u`` gives ``u**2/Hz``); at least 2 samples.
    fs : float
        Sample rate, Hz.
    nperseg : int, optional
        Segment length, samples, ``2 <= nperseg <= n``. Default: the largest power of two not
        above ``n / 8`` (about 15 averaged segments), at least 256, at most ``n``.

    Returns
    -------
    f : ndarray, shape (nperseg // 2 + 1,)
        Frequencies, Hz, 0 ... fs/2.
    pxx : ndarray, shape (nperseg // 2 + 1,)
        PSD, (rad/s)^2/Hz, one-sided (``sum(pxx) * (f[1] - f[0])`` is the variance). White
        noise of variance ``s**2`` gives ``2 s**2 / fs``.
    """
    x = _signal("x", x, min_len=2)
    fs = _positive("fs", fs)
    n = x.shape[0]
    if nperseg is None:
        nperseg = min(n, max(256, 2 ** int(math.floor(math.log2(max(n / 8, 1))))))
    elif isinstance(nperseg, bool) or not isinstance(nperseg, (int, np.integer)) \
            or not 2 <= nperseg <= n:
        raise ValueError(f"nperseg: expected an integer between 2 and len(x) = {n}, "
                         f"got {nperseg!r}")
    f, pxx = welch(x, fs=fs, window="hann", nperseg=int(nperseg), noverlap=int(nperseg) // 2,
                   detrend="constant", return_onesided=True, scaling="density")
    return f, pxx


#: correlation of two Welch (Hann window) PSD ordinates 1 and 2 frequency bins apart, for a
#: spectrum flat across them: |rho_DFT|^2, where rho_DFT is the normalised Fourier coefficient of
#: the squared Hann window w^2 = 3/8 - cos/2 + cos(2 .)/8 at lag 1 (-1/4 / 3/8 = -2/3) and lag 2
#: (1/16 / 3/8 = 1/6) (Percival and Walden 1993, section 6.6, eq. 231 for the DFT covariance)
HANN_BIN_CORR = (4.0 / 9.0, 1.0 / 36.0)


def welch_edf(n: int, nperseg: int) -> float:
    """Equivalent degrees of freedom of one ordinate of :func:`psd` (Hann, 50 % overlap):
    ``K = (n - nperseg) // (nperseg // 2) + 1`` segments, adjacent ones correlated by 0.167
    (Welch 1967, Table 1); ``2 K / (1 + 2 (1 - 1/K) 0.167^2)`` (Percival and Walden 1993,
    eq. 292b)."""
    step = max(nperseg // 2, 1)
    k = max((n - nperseg) // step + 1, 1)
    return 2.0 * k / (1.0 + 2.0 * (1.0 - 1.0 / k) * 0.167**2) if k > 1 else 2.0


def band_edf(edf_one: float, m: int) -> float:
    """EDF of the mean of ``m`` adjacent Welch ordinates of EDF ``edf_one``: the variance of the
    mean is ``var / m^2 (m + 2 sum_j (m - j) rho_j)`` with rho_j = HANN_BIN_CORR."""
    m = int(m)
    if m < 1:
        raise ValueError(f"m: expected at least 1 ordinate, got {m}")
    c = m + sum(2.0 * max(m - j, 0) * r for j, r in enumerate(HANN_BIN_CORR, start=1))
    return edf_one * m * m / c


def psd_bands(x, fs: float, per_decade: int = 10, segments: int = 8):
    """PSD averaged over log-spaced frequency bands, with each band's degrees of freedom.

    A Welch PSD (:func:`psd`, Hann, 50 % overlap) on segments of the largest power of two not
    above ``n / (segments / 2 + 0.5)`` samples (``segments`` half-overlapping segments, the
    lowest frequency about ``segments / 2`` over the record length), its ordinates between DC
    and Nyquist (both left out: 1 dof each) averaged in bands ``per_decade`` to a decade. At low
    frequency a band holds one ordinate (EDF of the Welch average, about 1.9 ``segments``); at
    high frequency many (EDF growing with their number, :func:`band_edf`): the spectrum reads
    evenly on a log axis instead of a 1/f-dense scatter.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (unit ``u`` gives ``u**2/Hz``); at least 16 samples.
    fs : float
        Sample rate, Hz.
    per_decade : int
        Bands per decade of frequency (edges at 10^(k / per_decade) times the lowest).
    segments : int
        Half-overlapping Welch segments over the record (at least 1).

    Returns
    -------
    f : ndarray, shape (b,)
        Each band's mean frequency, Hz.
    pxx : ndarray, shape (b,)
        Each band's mean PSD, ``u**2/Hz``.
    edf : ndarray, shape (b,)
        Each band's equivalent degrees of freedom; ``pxx * edf / chi2(edf)`` is the interval.
    """
    x = _signal("x", x, min_len=16)
    fs = _positive("fs", fs)
    if isinstance(per_decade, bool) or not isinstance(per_decade, (int, np.integer)) or \
            per_decade < 1:
        raise ValueError(f"per_decade: expected a positive integer, got {per_decade!r}")
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) or segments < 1:
        raise ValueError(f"segments: expected a positive integer, got {segments!r}")
    n = x.shape[0]
    nper = 2 ** math.floor(math.log2(n / (segments / 2.0 + 0.5)))
    nper = int(min(max(nper, 16), n))
    f, pxx = psd(x - np.mean(x), fs, nperseg=nper)
    f, pxx = f[1:-1], pxx[1:-1]
    edf_one = welch_edf(n, nper)
    k = np.floor(per_decade * np.log10(f / f[0]) + 1e-9).astype(int)
    out_f, out_p, out_e = [], [], []
    for b in np.unique(k):
        sel = k == b
        out_f.append(float(np.mean(f[sel])))
        out_p.append(float(np.mean(pxx[sel])))
        out_e.append(band_edf(edf_one, int(np.count_nonzero(sel))))
    return np.array(out_f), np.array(out_p), np.array(out_e)


def psd_band_interval(pxx, edf, confidence: float = 0.6826894921370859):
    """Two-sided chi-square interval of band PSD values ``pxx`` of ``edf`` degrees of freedom
    (:func:`psd_bands`): ``(pxx edf / chi2(1 - a/2, edf), pxx edf / chi2(a/2, edf))``, ``a`` =
    1 - confidence (Percival and Walden 1993, eq. 255a)."""
    from scipy.stats import chi2

    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence: expected a level in (0, 1), got {confidence!r}")
    pxx, edf = np.asarray(pxx, dtype=float), np.asarray(edf, dtype=float)
    a = 1.0 - confidence
    return pxx * edf / chi2.ppf(1.0 - a / 2.0, edf), pxx * edf / chi2.ppf(a / 2.0, edf)


# ---------------------------------------------------------------------------------------------
# Against a reference
def rmse(x, truth) -> float:
    """Root mean square of ``x - truth``.

    Parameters
    ----------
    x : array_like, shape (n,)
        Estimate, e.g. compensated rate, rad/s.
    truth : array_like, shape (n,)
        Reference, same unit.

    Returns
    -------
    float
        ``sqrt(mean((x - truth)**2))``, unit of ``x``.
    """
    x, truth = _pair(x, truth)
    e = x - truth
    return float(math.sqrt(np.dot(e, e) / e.shape[0]))


def integrated_angle_error(x, truth, fs: float) -> dict[str, float]:
    """Angle error accumulated by integrating ``x - truth``.

    The angle after ``k`` samples is ``sum(x[:k] - truth[:k]) / fs`` (rectangle rule, the
    same integration as the Allan deviation uses).

    Parameters
    ----------
    x : array_like, shape (n,)
        Rate estimate, rad/s.
    truth : array_like, shape (n,)
        Reference rate, rad/s.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    dict
        ``angle_error_final_rad``: the signed error at the end of the record, rad;
        ``angle_error_max_rad``: the largest absolute error along the record, rad.
    """
    x, truth = _pair(x, truth)
    fs = _positive("fs", fs)
    angle = np.cumsum(x - truth) / fs
    return {"angle_error_final_rad": float(angle[-1]),
            "angle_error_max_rad": float(np.max(np.abs(angle)))}


def coefficient_errors(estimated: dict, true: dict) -> dict[str, dict]:
    """Errors of estimated model coefficients against the true ones, key by key.

    Parameters
    ----------
    estimated : dict of str to float or array_like
        Estimated coefficients; the unit of each is in its key (``"arw_deg_rt_h"``).
    true : dict of str to float or array_like
        True coefficients, the same keys and shapes.

    Returns
    -------
    dict of str to dict
        For each key: ``error`` (estimated - true, in the key's unit), ``abs_error``
        (``|error|``), ``rel_error`` (``|error| / |true|``, dimensionless; None where the true
        value is 0). Scalars come back as floats, arrays as arrays.

    Raises
    ------
    ValueError
        If a key of ``estimated`` is not in ``true`` (unknown) or a key of ``true`` is missing
        from ``estimated``, if shapes differ, or a value is not finite.
    """
    if not isinstance(estimated, dict):
        raise ValueError(f"estimated: expected a dict of coefficients, got "
                         f"{type(estimated).__name__}")
    if not isinstance(true, dict):
        raise ValueError(f"true: expected a dict of coefficients, got {type(true).__name__}")
    unknown = sorted(set(estimated) - set(true), key=str)
    if unknown:
        raise ValueError(f"estimated: unknown key(s) {unknown}, not in true; known: "
                         f"{sorted(true, key=str)}")
    missing = sorted(set(true) - set(estimated), key=str)
    if missing:
        raise ValueError(f"estimated: missing key(s) {missing} that true has")
    out: dict[str, dict] = {}
    for key in true:
        vals = []
        for name, d in (("estimated", estimated), ("true", true)):
            try:
                v = np.asarray(d[key], dtype=float)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{name}[{key!r}]: cannot be read as a number ({exc})") from None
            if not np.all(np.isfinite(v)):
                raise ValueError(f"{name}[{key!r}]: expected finite values, got {d[key]!r}")
            vals.append(v)
        est, tru = vals
        if est.shape != tru.shape:
            raise ValueError(f"estimated[{key!r}]: shape {est.shape} must match true "
                             f"{tru.shape}")
        err = est - tru
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(err) / np.abs(tru)
        if err.ndim == 0:
            out[key] = {"error": float(err), "abs_error": float(abs(err)),
                        "rel_error": None if tru == 0 else float(rel)}
        else:
            out[key] = {"error": err, "abs_error": np.abs(err),
                        "rel_error": None if np.any(tru == 0) else rel}
    return out


# ---------------------------------------------------------------------------------------------
def summary(compensated, fs: float, truth=None) -> dict[str, float | None]:
    """Key figures of merit of a compensated gyro record, in datasheet units.

    The noise figures (std, bias stability, Allan terms) are taken of the error
    ``compensated - truth`` when ``truth`` is given (so that the applied motion does not count
    as noise), else of ``compensated`` itself (which should then be a static record).

    Parameters
    ----------
    compensated : array_like, shape (n,)
        Compensated rate, rad/s; at least 2 samples.
    fs : float
        Sample rate, Hz.
    truth : array_like, shape (n,), optional
        The rate truly applied, rad/s. Without it, the truth-based figures are left out.

    Returns
    -------
    dict
        Always: ``duration_s``, ``std_dps``, ``std_dph``.
        When the record holds at least two 100 s windows: ``bias_stability_100s_dph``
        (:func:`bias_stability`; the window is 100 s rounded to a whole number of samples).
        With ``truth``: ``mean_error_dph``, ``rmse_dps``, ``rmse_dph``, ``angle_error_final_deg``,
        ``angle_error_max_deg``.
        When the record lasts at least ``ALLAN_MIN_DURATION_S`` (100 s) and holds at least
        ``ALLAN_MIN_SAMPLES`` (512) samples: ``arw_deg_rt_h``, ``bias_instability_dph``,
        ``rrw_dph_rt_h``, ``quantisation_arcsec``, ``rate_ramp_dph_per_h`` from
        :func:`noise_terms` (the noise model identified by :mod:`fogcomp.noise`, None for a
        term not identified) and ``bias_instability_floor_dph``, the IEEE Std 952 datasheet
        reading beside it (the curve's minimum / 0.664); all None for an error that is exactly
        constant. Below 100 s the longest averaging time with a
        usable error bar (about a ninth of the record) is about 10 s, too short to show the
        bias-instability floor of a FOG, and the whole fit would rest on a handful of points.
    """
    x = _signal("compensated", compensated, min_len=2)
    fs = _positive("fs", fs)
    n = x.shape[0]
    out: dict[str, float | None] = {"duration_s": n / fs}
    if truth is not None:
        t = _signal("truth", truth, min_len=2)
        if t.shape != x.shape:
            raise ValueError(f"truth: shape {t.shape} must match compensated {x.shape}")
        err = x - t
    else:
        err = x
    s = std(err)
    out["std_dps"] = s / DPS
    out["std_dph"] = s / DPH
    w = max(1, int(round(100.0 * fs)))           # 100 s to the nearest whole sample
    if n // w >= 2:
        out["bias_stability_100s_dph"] = bias_stability(err, fs, w / fs) / DPH
    if truth is not None:
        out["mean_error_dph"] = float(np.mean(err)) / DPH
        r = rmse(x, t)
        out["rmse_dps"] = r / DPS
        out["rmse_dph"] = r / DPH
        ang = integrated_angle_error(x, t, fs)
        out["angle_error_final_deg"] = ang["angle_error_final_rad"] / DEG
        out["angle_error_max_deg"] = ang["angle_error_max_rad"] / DEG
    if n / fs >= ALLAN_MIN_DURATION_S and n >= ALLAN_MIN_SAMPLES:
        out.update(noise_terms(err, fs))
    return out


def noise_terms(rate, fs: float) -> dict:
    """The noise terms of a record in datasheet units, as every report of the bench states them.

    The one identifier of the project (:func:`fogcomp.noise.identify_noise_model` on the octave
    Allan variance, terms selected): ``arw_deg_rt_h``, ``bias_instability_dph``,
    ``rrw_dph_rt_h``, ``quantisation_arcsec``, ``rate_ramp_dph_per_h`` (None where a term is not
    identified), ``bias_instability_floor_dph``, the IEEE Std 952 datasheet reading (the
    Allan deviation's minimum / 0.664) beside the fitted flicker coefficient, and
    ``gm_sigma_dph``, ``gm_tau_s`` of the strongest identified Gauss-Markov term. All None for
    a record that is exactly constant.

    Parameters
    ----------
    rate : array_like, shape (n,)
        Rate, rad/s (e.g. a compensated output minus the truth).
    fs : float
        Sample rate, Hz.
    """
    from .noise import identify_noise_model

    x = _signal("rate", rate, min_len=8)
    fs = _positive("fs", fs)
    d = None if np.ptp(x) == 0 else oadev_details(x, fs)
    if d is None or not np.all(d.adev > 0) or d.taus.shape[0] < 3:
        return {k: None for k in _ALLAN_KEYS}
    nm = identify_noise_model(d.taus, d.adev**2, fs, x.shape[0], record_length=False,
                              alternative=False)
    out = nm.datasheet_values()
    fr = nm.floor_reading.get("value")
    out["bias_instability_floor_dph"] = None if fr is None else float(fr / DPH)
    gms = [t for t in nm.identified if t.term == "GM"]
    if gms:  # the strongest identified Gauss-Markov term
        g = max(gms, key=lambda t: t.value)
        out["gm_sigma_dph"], out["gm_tau_s"] = float(g.value / DPH), float(g.tau)
    else:
        out["gm_sigma_dph"] = out["gm_tau_s"] = None
    return out
