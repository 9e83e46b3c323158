"""Scalar Kalman filter (and optional RTS smoother) denoiser: the "Kalman" baseline of paper 000.

State choice: the state is the true angular rate, modelled as a random walk (the local-level
model), and every gyro sample measures it plus white noise:

    x_k = x_{k-1} + w_k,   w_k ~ N(0, Q),   Q = RRW^2 / fs          (rate random walk)
    z_k = x_k + v_k,       v_k ~ N(0, R),   R = ARW^2 * fs          (angle random walk)

so F = H = 1. ARW (rad/sqrt(s)) and RRW (rad/s/sqrt(s)) are the rate-independent datasheet
coefficients; the per-sample variances follow from the sample rate of each record filtered, so a
model fitted at one rate filters another correctly. The estimated error is what the filter
removes: ``estimate_error = rate - filtered``, ``compensate = filtered``.

When ARW or RRW is not given, ``fit`` estimates it from the fitting record by the variogram of
the model: for z as above, ``V(m) = mean((z[k+m] - z[k])^2) = 2 R + m Q`` exactly in expectation
(the constant rate cancels in differences), so a least-squares line through V(m), m = 1..m_max,
gives 2R as its intercept and Q as its slope. m_max = min(50, n // 10) (at least 2): long enough
for the slope to resolve Q down to about 1e-3 R on a few thousand samples, short enough that V(m)
stays well estimated. A negative slope (no rate wander detectable, as on a constant-rate table)
gives Q = 0: the filter then becomes the running mean of the record, the best estimate of a
constant. A deterministic drift in the fitting record raises V(m) faster than linearly and is
absorbed into Q, so the filter tracks it.

Initial state: x_0 = z_0 with P_0 = R, which is the exact posterior after the first sample under a
diffuse (uninformative) prior; the filter then runs over z_1..z_{n-1} (``kf.batch_filter``), so the
first sample is neither double-counted nor pulled towards an arbitrary prior.

Speed (the same filter, :func:`local_level_filter`): the covariance of this filter does not
depend on the data, and with Q > 0 it converges geometrically (by (1 - K)^2 per sample) to the
steady state of the Riccati equation (:func:`steady_state_gain`). While P is more than
``CONVERGED`` (relative) from its steady state, filterpy's ``KalmanFilter`` update runs written
for scalars (``_filter_scalar``: its operations in its order over Python floats, about 20
times faster than its 1 x 1 matrices; the transient is about 14 / K samples, 14,000 at a gain of
1e-3); after that the filter is the first-order recursion ``x_k = (1 - K) x_{k-1} + K z_k`` with
the steady gain, run by ``scipy.signal.lfilter`` from the state the transient reached. Measured
on 200,000 samples (fogbench.bench.methods, this 2-core machine, shared): 470 to 2,900 times
filterpy's loop at gains 1e-3 to 1e-1, the same estimates to 1e-13 relative. With Q = 0 the
filter is the running mean (x_k the mean of the samples so far, P_k = P_0 r / (k P_0 + r)): its
closed form. The RTS smoother likewise: filterpy's ``rts_smoother`` written for scalars over the
transient, and in the steady part the
backward recursion ``x^s_k = (1 - C) x_k + C x^s_{k+1}`` (C = P / (P + Q)) by ``lfilter``; with
Q = 0 every smoothed sample is the record's last filtered one (the mean of the whole record).
``engine="filterpy"`` runs filterpy over every sample (the reference the tests compare with).
"""

from __future__ import annotations

import math
import numbers
import warnings

import numpy as np
from filterpy.kalman import KalmanFilter

from .._data import GyroData
from .._estimator import Compensator
from .._registry import register
from ..units import DEG_RT_H, DPS

__all__ = ["KalmanDenoiser", "variogram", "estimate_noise", "steady_state_gain",
           "corner_frequency_hz", "local_level_filter", "STARTS", "ENGINES", "CONVERGED"]

#: How each record compensated starts the filter (see KalmanDenoiser).
STARTS = ("restart", "carry")

#: How the filter is run: the fast path (filterpy over the transient, then the steady-state
#: recursion), or filterpy over every sample.
ENGINES = ("fast", "filterpy")

#: Relative distance of the posterior variance from its steady state below which the fast path
#: switches from filterpy to the steady-state gain (the gain then differs from filterpy's by less
#: than this, relative, and the difference keeps shrinking by (1 - K)^2 per sample).
CONVERGED = 1e-12


def steady_state_gain(q: float, r: float) -> float:
    """Steady-state Kalman gain of the scalar random-walk filter, from the Riccati equation.

    With the prior variance P- = P + q and K = P- / (P- + r), P = (1 - K) P-, the fixed point
    solves P-^2 - q P- - q r = 0: ``P- = (q + sqrt(q^2 + 4 q r)) / 2``.

    Parameters
    ----------
    q, r : float
        Per-sample process and measurement noise variances, (rad/s)^2.

    Returns
    -------
    float
        K in [0, 1] (0 when q = 0: the running mean; 1 when r = 0).
    """
    if r == 0:
        return 1.0
    p_prior = (q + math.sqrt(q * q + 4.0 * q * r)) / 2.0
    return p_prior / (p_prior + r)


def _filterpy(z: np.ndarray, q: float, r: float, x0: float, p0: float):
    """filterpy's KalmanFilter over z from the prior (x0, p0): (x, P) after each sample."""
    kf = KalmanFilter(dim_x=1, dim_z=1)
    kf.F = np.array([[1.0]])
    kf.H = np.array([[1.0]])
    kf.R = np.array([[r]])
    kf.Q = np.array([[q]])
    kf.x = np.array([[x0]])
    kf.P = np.array([[p0]])
    means, covs, _, _ = kf.batch_filter(z)
    return means[:, 0, 0], covs[:, 0, 0]


def _filter_scalar(z: np.ndarray, q: float, r: float, x0: float, p0: float):
    """filterpy's ``KalmanFilter.batch_filter`` for F = H = 1, written for scalars: predict
    (x, P = 1 * ((1 * P) * 1) + Q), then update (S = (1 * P) * 1 + R, K = P * inv(S),
    x + K (z - x), P in Joseph form ((1 - K) P) (1 - K) + (K R) K), the same operations in
    the same order, as a plain loop over Python floats (filterpy's 1 x 1 matrices cost about
    20 times more per sample). Returns (x, P) after each update."""
    xs, ps = [0.0] * len(z), [0.0] * len(z)
    x, p = float(x0), float(p0)
    for k, zk in enumerate(z.tolist()):
        p = 1.0 * (p * 1.0) + q
        si = 1.0 / (p + r)
        g = p * si
        x = x + g * (zk - x)
        i_kh = 1.0 - g
        p = (i_kh * p) * i_kh + (g * r) * g
        xs[k], ps[k] = x, p
    return np.asarray(xs), np.asarray(ps)


def _transient_length(q: float, r: float, p0: float, n: int) -> int:
    """Samples until the posterior variance is within CONVERGED of its steady state (at most n):
    the data-free Riccati recursion in Joseph form, as filterpy runs it."""
    pp = (q + math.sqrt(q * q + 4.0 * q * r)) / 2.0
    p_ss = pp * r / (pp + r)
    p = p0
    for k in range(n):
        if abs(p - p_ss) <= CONVERGED * p_ss:
            return k
        p_prior = p + q
        g = p_prior / (p_prior + r)
        p = (1.0 - g) ** 2 * p_prior + g * g * r
    return n


def local_level_filter(z: np.ndarray, q: float, r: float, x0: float, p0: float,
                       smoother: bool = False, engine: str = "fast"
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The local-level Kalman filter (F = H = 1) over ``z`` from the prior (x0, p0).

    Parameters
    ----------
    z : ndarray, shape (n,)
        Measurements, rad/s.
    q, r : float
        Per-sample process and measurement noise variances, (rad/s)^2; r > 0.
    x0, p0 : float
        Prior mean and variance before z[0].
    smoother : bool
        Return the RTS-smoothed estimates instead of the filtered ones.
    engine : {"fast", "filterpy"}
        The fast path (module notes) or filterpy over every sample.

    Returns
    -------
    x : ndarray, shape (n,)
        Filtered (or smoothed) estimates.
    p : ndarray, shape (n,)
        Posterior variances of the filtered estimates.
    """
    from scipy.signal import lfilter, lfiltic

    z = np.asarray(z, dtype=float)
    n = z.shape[0]
    if engine not in ENGINES:
        raise ValueError(f"engine: expected one of {list(ENGINES)}, got {engine!r}")
    if engine == "filterpy" or n == 0:
        x, p = _filterpy(z, q, r, x0, p0) if n else (np.zeros(0), np.zeros(0))
        if smoother and n > 1:
            x = _rts_filterpy(x, p, q, r)
        return x, p
    if q == 0.0:
        return _running_mean(z, r, x0, p0, smoother)
    L = _transient_length(q, r, p0, n)
    x = np.empty(n)
    p = np.empty(n)
    if L:
        x[:L], p[:L] = _filter_scalar(z[:L], q, r, x0, p0)
    pp = (q + math.sqrt(q * q + 4.0 * q * r)) / 2.0
    g = pp / (pp + r)
    p_ss = (1.0 - g) * pp
    if L < n:
        x_prev = x[L - 1] if L else x0
        b, a = [g], [1.0, -(1.0 - g)]
        x[L:], _ = lfilter(b, a, z[L:], zi=lfiltic(b, a, [x_prev]))
        p[L:] = p_ss
    if not smoother or n == 1:
        return x, p
    return _smooth(x, p, q, L, p_ss), p


def _running_mean(z: np.ndarray, r: float, x0: float, p0: float, smoother: bool
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The local-level filter with q = 0, in closed form: the running mean. With prior weight
    w0 = r / p0 (in samples), x_k is the weighted mean of x0 and z_0..z_k, P_k = r / (w0 + k + 1);
    smoothed, every estimate is the last one."""
    n = z.shape[0]
    k = np.arange(1, n + 1, dtype=float)
    w0 = r / p0 if p0 > 0 else math.inf
    if math.isinf(w0):
        return np.full(n, float(x0)), np.zeros(n)
    x = (w0 * x0 + np.cumsum(z)) / (w0 + k)
    p = r / (w0 + k)
    if smoother:
        x = np.full(n, x[-1])
    return x, p


def _smooth(x: np.ndarray, p: np.ndarray, q: float, L: int, p_ss: float) -> np.ndarray:
    """RTS-smoothed estimates from the filtered ones ``x`` (variances ``p``): over the steady
    part (samples L..) the steady smoother as a backward first-order recursion, over the
    transient (..L) filterpy's smoother."""
    from scipy.signal import lfilter, lfiltic

    n = x.shape[0]
    xs = x.copy()
    if L < n:
        c = p_ss / (p_ss + q)
        # backward over the steady part: xs[n-1] = x[n-1], xs[k] = (1 - c) x[k] + c xs[k+1]
        tail = x[L:][::-1]
        b, a = [1.0 - c], [1.0, -c]
        if tail.size > 1:
            out, _ = lfilter(b, a, tail[1:], zi=lfiltic(b, a, [tail[0]]))
            xs[L:] = np.concatenate([tail[:1], out])[::-1]
    if L:
        # the transient by filterpy's smoother, ending at the steady part's first smoothed
        # sample (filterpy takes its last element as already smoothed)
        m = min(L + 1, n)
        xt = x[:m].copy()
        if m > L:
            xt[-1] = xs[L]   # (the smoothed means depend on the filtered variances alone)
        xs[:m] = _rts_scalar(xt, p[:m], q)
    return xs


def _rts_scalar(x: np.ndarray, p: np.ndarray, q: float) -> np.ndarray:
    """filterpy's ``rts_smoother`` for F = H = 1, written for scalars: the same operations in
    the same order (gain ``P_k inv(P_k + Q)``, ``x_k + gain (xs_{k+1} - x_k)``), as a plain loop
    over Python floats, about 100 times faster than filterpy's 1 x 1 matrices over the
    transient (the smoothed means depend on the filtered means and variances alone)."""
    xs = x.tolist()
    pl = p.tolist()
    for k in range(len(xs) - 2, -1, -1):
        gain = pl[k] * (1.0 / (pl[k] + q))
        xs[k] = xs[k] + gain * (xs[k + 1] - xs[k])
    return np.asarray(xs)


def _rts_filterpy(x: np.ndarray, p: np.ndarray, q: float, r: float) -> np.ndarray:
    kf = KalmanFilter(dim_x=1, dim_z=1)
    kf.F = np.array([[1.0]])
    kf.H = np.array([[1.0]])
    kf.R = np.array([[r]])
    kf.Q = np.array([[q]])
    xs, _, _, _ = kf.rts_smoother(x[:, None, None], p[:, None, None])
    return xs[:, 0, 0]


def corner_frequency_hz(arw_rad_rt_s: float, rrw_rad_s_rt_s: float) -> float:
    """-3 dB corner of the steady-state filter in the continuous limit: ``K / (2 pi N)``.

    The Kalman-Bucy filter of x' = w (PSD K^2), z = x + v (PSD N^2) has the steady-state gain
    K / N (1/s), i.e. it is the first-order low-pass 1 / (1 + s N / K). Valid when the corner
    is far below the sample rate.

    Parameters
    ----------
    arw_rad_rt_s : float
        N, rad/sqrt(s).
    rrw_rad_s_rt_s : float
        K, rad/s/sqrt(s).

    Returns
    -------
    float
        Corner frequency, Hz (inf when N = 0).

    References
    ----------
    .. [1] A. Gelb (ed.), *Applied Optimal Estimation*, MIT Press, 1974, ch. 4 (the
       steady-state Kalman-Bucy filter of a random walk observed in white noise).
    """
    if arw_rad_rt_s == 0:
        return math.inf
    return rrw_rad_s_rt_s / (2.0 * math.pi * arw_rad_rt_s)


def variogram(z: np.ndarray, m_max: int) -> np.ndarray:
    """Empirical variogram ``V(m) = mean((z[k+m] - z[k])^2)`` for m = 1..m_max.

    Parameters
    ----------
    z : ndarray, shape (n,)
        Signal, rad/s. Needs n > m_max.
    m_max : int
        Largest lag, samples.

    Returns
    -------
    ndarray, shape (m_max,)
        V(1)..V(m_max), (rad/s)^2.
    """
    return np.array([np.mean((z[m:] - z[:-m]) ** 2) for m in range(1, m_max + 1)])


def estimate_noise(z: np.ndarray, r: float | None = None,
                   q: float | None = None) -> tuple[float, float, np.ndarray]:
    """Measurement and process noise variances of the local-level model, from a record.

    Fits ``V(m) = 2 R + m Q`` by least squares over m = 1..m_max, m_max = min(50, n // 10),
    at least 2; a value given as ``r`` or ``q`` is held fixed.

    Parameters
    ----------
    z : ndarray, shape (n,)
        Gyro rate, rad/s, n >= 3.
    r, q : float, optional
        Known per-sample measurement / process noise variance, (rad/s)^2.

    Returns
    -------
    r : float
        Per-sample measurement noise variance R, (rad/s)^2, >= 0.
    q : float
        Per-sample process noise variance Q, (rad/s)^2, >= 0 (a negative fit is set to 0).
    v : ndarray, shape (m_max,)
        The variogram used, (rad/s)^2.

    References
    ----------
    .. [1] J. Durbin and S. J. Koopman, "Time Series Analysis by State Space Methods", 2nd ed.,
       Oxford University Press, 2012, ch. 2 (the local level model; its differences have
       variance Q + 2R at lag 1, from which V(m) = 2R + mQ follows).
    """
    n = z.shape[0]
    m_max = max(2, min(50, n // 10))
    if n <= m_max:
        raise ValueError(f"rate: need at least {m_max + 1} samples to estimate the noise "
                         f"variances, got {n}")
    v = variogram(z, m_max)
    m = np.arange(1, m_max + 1, dtype=float)
    if r is None and q is None:
        a = np.column_stack([2.0 * np.ones_like(m), m])
        r_hat, q_hat = np.linalg.lstsq(a, v, rcond=None)[0]
        if r_hat <= 0:
            warnings.warn("kalman: the variogram intercept is not positive (the noise is not "
                          "white plus random walk); using R = V(1)/2 and refitting Q",
                          stacklevel=3)
            r_hat = v[0] / 2.0
            q_hat = float(m @ (v - 2.0 * r_hat) / (m @ m))
    elif r is None:
        q_hat = q
        r_hat = float(np.mean(v - m * q)) / 2.0
    elif q is None:
        r_hat = r
        q_hat = float(m @ (v - 2.0 * r) / (m @ m))
    else:
        r_hat, q_hat = r, q
    return max(float(r_hat), 0.0), max(float(q_hat), 0.0), v


def _check_optional_positive(name, value):
    if value is None:
        return None
    if (isinstance(value, bool) or not isinstance(value, numbers.Real)
            or not math.isfinite(value) or value < 0):
        raise ValueError(f"{name}: expected None or a non-negative finite number, got {value!r}")
    return float(value)


def _one_of(si_name, si, ds_name, ds, factor):
    """The SI value of a quantity given either in SI or in datasheet units (not both)."""
    si = _check_optional_positive(si_name, si)
    ds = _check_optional_positive(ds_name, ds)
    if si is not None and ds is not None:
        raise ValueError(f"{ds_name}: give either {si_name} or {ds_name}, not both")
    return si if ds is None else ds * factor


@register
class KalmanDenoiser(Compensator):
    """Random-walk-rate Kalman filter; the estimated error is what the filter removes.

    Parameters
    ----------
    arw_rad_rt_s : float or None, default None
        Angle random walk N, rad/sqrt(s); the measurement noise variance per sample is
        ``R = N^2 * fs``. None: estimated from the fitting record (see the module notes).
    rrw_rad_s_rt_s : float or None, default None
        Rate random walk K of the state, rad/s/sqrt(s); the process noise variance per sample
        is ``Q = K^2 / fs``. None: estimated from the fitting record. 0 makes the filter the
        running mean of each record.
    smoother : bool, default False
        Also run the Rauch-Tung-Striebel smoother (``kf.rts_smoother``) backwards over each
        record (non-causal; uses the whole record for every sample).
    arw_deg_rt_h : float or None, default None
        The same ARW in datasheet units, deg/sqrt(h) (give this or ``arw_rad_rt_s``, not
        both): the datasheet tuning of R.
    rate_walk_dps_rt_s : float or None, default None
        The same K in deg/s/sqrt(s) (give this or ``rrw_rad_s_rt_s``, not both): Q sized for
        the motion the user expects, not for the gyro's own rate random walk. The true rate
        is then allowed to change by about K sqrt(T) over T seconds, and the steady-state
        filter is a first-order low-pass with its -3 dB corner at ``K / (2 pi N)`` Hz
        (:func:`corner_frequency_hz`; e.g. ARW 0.1 deg/sqrt(h) and K = 1 deg/s/sqrt(s) give
        about 95 Hz, i.e. little filtering; K = 1e-3 gives 0.095 Hz). Choose K = 2 pi f N for
        a wanted bandwidth f.
    start : {"restart", "carry"}, default "restart"
        ``"restart"``: every record compensated starts afresh from its own first sample
        (x_0 = z_0, P_0 = R, see the module notes): the first ``settling_samples()``
        samples are the filter's warm-up, and a score taken over the whole record includes
        it. ``"carry"``: every record starts from the state (x, P) the filter reached at the
        end of the fitting record, as if it followed that record without a restart (no
        warm-up, but a record at another rate starts from the fitting record's rate).
    engine : {"fast", "filterpy"}, default "fast"
        ``"fast"``: filterpy's update as scalars over the filter's transient, then its steady state as a
        first-order recursion, or the running mean's closed form when Q = 0 (the module
        notes; the same estimates to about 1e-12 relative). ``"filterpy"``: filterpy's
        ``KalmanFilter`` and ``rts_smoother`` over every sample (about 50,000 samples/s).

    Attributes
    ----------
    arw_rad_rt_s_ : float
        ARW used, rad/sqrt(s) (as given or estimated).
    rrw_rad_s_rt_s_ : float
        RRW used, rad/s/sqrt(s) (as given or estimated).
    fs_ : float
        Sample rate of the fitting record, Hz.
    variogram_ : ndarray, shape (m_max,)
        Variogram of the fitting record, (rad/s)^2 (empty when both noises were given).
    x_end_, p_end_ : float or None
        Filter state and its variance at the end of the fitting record, rad/s and (rad/s)^2
        (the start of every record with ``start="carry"``; None with ``"restart"``).

    Notes
    -----
    Paper 000 compares against a Kalman filter without giving its model; this is the simplest
    model of a gyro on a constant-rate table (see the module docstring for the choices).

    References
    ----------
    .. [1] R. E. Kalman, "A new approach to linear filtering and prediction problems",
       J. Basic Eng. 82(1), 35-45, 1960.
    .. [2] H. E. Rauch, F. Tung and C. T. Striebel, "Maximum likelihood estimates of linear
       dynamic systems", AIAA J. 3(8), 1445-1450, 1965.
    .. [3] IEEE Std 952-1997, Annex C (ARW N and RRW K: white rate noise of two-sided PSD N^2,
       rate random walk of PSD K^2 / (2 pi f)^2).
    .. [4] Paper 000 (fogbench seed 000_6140556fe3a47984), Table 1, "Kalman".
    """

    name = "kalman"
    requires = ("rate",)
    supervised = False
    random = False

    def __init__(self, arw_rad_rt_s=None, rrw_rad_s_rt_s=None, smoother=False,
                 arw_deg_rt_h=None, rate_walk_dps_rt_s=None, start="restart", engine="fast"):
        self.arw_rad_rt_s = arw_rad_rt_s
        self.rrw_rad_s_rt_s = rrw_rad_s_rt_s
        self.smoother = smoother
        self.arw_deg_rt_h = arw_deg_rt_h
        self.rate_walk_dps_rt_s = rate_walk_dps_rt_s
        self.start = start
        self.engine = engine

    def _validate(self):
        """Check every hyperparameter; returns the given ARW and RRW in SI (or None)."""
        arw = _one_of("arw_rad_rt_s", self.arw_rad_rt_s, "arw_deg_rt_h", self.arw_deg_rt_h,
                      DEG_RT_H)
        rrw = _one_of("rrw_rad_s_rt_s", self.rrw_rad_s_rt_s, "rate_walk_dps_rt_s",
                      self.rate_walk_dps_rt_s, DPS)
        if not isinstance(self.smoother, (bool, np.bool_)):
            raise ValueError(f"smoother: expected True or False, got {self.smoother!r}")
        if not (isinstance(self.start, str) and self.start in STARTS):
            raise ValueError(f"start: expected one of {list(STARTS)}, got {self.start!r}")
        if not (isinstance(self.engine, str) and self.engine in ENGINES):
            raise ValueError(f"engine: expected one of {list(ENGINES)}, got {self.engine!r}")
        return arw, rrw

    def settling_samples(self, fs: float | None = None, tol: float = 0.05) -> int:
        """Samples until a restarted filter's gain is within ``tol`` of its steady state.

        From x_0 = z_0, P_0 = R the gain runs 1/2, 1/3, ... (a running mean) until the process
        noise holds it at :func:`steady_state_gain`; the samples before are the warm-up to
        leave out of a score of the steady filter. With Q = 0 it never settles: returns the
        sample count at which the running mean's gain 1/(k+1) is below 1e-3 (999).

        Parameters
        ----------
        fs : float, optional
            Sample rate, Hz (default: the fitting record's).
        tol : float
            Relative tolerance on the gain.

        Returns
        -------
        int
            Number of samples, >= 1.
        """
        self._check_fitted()
        fs = self.fs_ if fs is None else float(fs)
        r = self.arw_rad_rt_s_ ** 2 * fs
        q = self.rrw_rad_s_rt_s_ ** 2 / fs
        if r == 0:
            return 1
        if q == 0:
            return 999
        k_ss = steady_state_gain(q, r)
        p, k = r, 0
        while True:
            k += 1
            gain = (p + q) / (p + q + r)
            p = (1.0 - gain) * (p + q)
            if abs(gain - k_ss) <= tol * k_ss or k > 10_000_000:
                return k

    def _fit(self, data: GyroData, error) -> None:
        arw, rrw = self._validate()
        fs = data.fs
        if arw is None or rrw is None:
            r_given = None if arw is None else arw ** 2 * fs
            q_given = None if rrw is None else rrw ** 2 / fs
            r, q, v = estimate_noise(data.rate, r_given, q_given)
            arw, rrw = math.sqrt(r / fs), math.sqrt(q * fs)
        else:
            v = np.zeros(0)
        if arw == 0:
            warnings.warn("kalman: the measurement noise is zero (a noise-free record?); the "
                          "filter will pass every rate through unchanged", stacklevel=3)
        self.arw_rad_rt_s_ = arw
        self.rrw_rad_s_rt_s_ = rrw
        self.fs_ = fs
        self.variogram_ = v
        self.x_end_ = self.p_end_ = None
        if self.start == "carry" and arw > 0:
            xs, ps = self._run(data.rate, fs, None)
            self.x_end_, self.p_end_ = float(xs[-1]), float(ps[-1])

    def _run(self, z, fs, start, smoother=False):
        """Filter over z: (x, P) per sample; ``start`` None: restart at z_0, else (x, P) to
        carry. ``smoother``: x smoothed."""
        r = self.arw_rad_rt_s_ ** 2 * fs
        q = self.rrw_rad_s_rt_s_ ** 2 / fs
        if start is None:                   # the diffuse prior's posterior after z_0
            z0 = float(z[0])
            if z.shape[0] == 1:
                return np.array([z0]), np.array([r])
            x, p = local_level_filter(z[1:], q, r, z0, r, smoother=smoother,
                                      engine=self.engine)
            # sample 0: its posterior (z_0, R); smoothed, one more backward RTS step
            x0 = z0 + r / (r + q) * (x[0] - z0) if smoother else z0
            return np.concatenate([[x0], x]), np.concatenate([[r], p])
        return local_level_filter(z, q, r, start[0], start[1], smoother=smoother,
                                  engine=self.engine)

    def filtered(self, data: GyroData) -> np.ndarray:
        """The filtered (or smoothed) rate, shape (n,), rad/s."""
        self._check_fitted()
        z = data.rate
        r = self.arw_rad_rt_s_ ** 2 * data.fs
        if r == 0.0:
            return z.copy()
        start = (self.x_end_, self.p_end_) if self.start == "carry" else None
        x, _ = self._run(z, data.fs, start, smoother=bool(self.smoother))
        return x

    def _estimate(self, data: GyroData) -> np.ndarray:
        return data.rate - self.filtered(data)

    def _state(self):
        info = {"arw_rad_rt_s_": self.arw_rad_rt_s_, "rrw_rad_s_rt_s_": self.rrw_rad_s_rt_s_,
                "fs_": self.fs_, "x_end_": self.x_end_, "p_end_": self.p_end_}
        return info, {"variogram_": self.variogram_}

    def _restore(self, info, arrays):
        self.arw_rad_rt_s_ = float(info["arw_rad_rt_s_"])
        self.rrw_rad_s_rt_s_ = float(info["rrw_rad_s_rt_s_"])
        self.fs_ = float(info["fs_"])
        self.x_end_ = None if info["x_end_"] is None else float(info["x_end_"])
        self.p_end_ = None if info["p_end_"] is None else float(info["p_end_"])
        self.variogram_ = np.asarray(arrays["variogram_"], dtype=float)
