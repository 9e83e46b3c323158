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
"""

from __future__ import annotations

import math
import numbers
import warnings

import numpy as np
from filterpy.kalman import KalmanFilter

from ..base import Compensator, GyroData, register
from ..units import DEG_RT_H, DPS

__all__ = ["KalmanDenoiser", "variogram", "estimate_noise", "steady_state_gain",
           "corner_frequency_hz", "STARTS"]

#: How each record compensated starts the filter (see KalmanDenoiser).
STARTS = ("restart", "carry")


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
                 arw_deg_rt_h=None, rate_walk_dps_rt_s=None, start="restart"):
        self.arw_rad_rt_s = arw_rad_rt_s
        self.rrw_rad_s_rt_s = rrw_rad_s_rt_s
        self.smoother = smoother
        self.arw_deg_rt_h = arw_deg_rt_h
        self.rate_walk_dps_rt_s = rate_walk_dps_rt_s
        self.start = start

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
            self.x_end_, self.p_end_ = float(xs[-1, 0, 0]), float(ps[-1, 0, 0])

    def _run(self, z, fs, start):
        """Forward filter over z; ``start`` None: restart at z_0, else (x, P) to carry."""
        r = self.arw_rad_rt_s_ ** 2 * fs
        q = self.rrw_rad_s_rt_s_ ** 2 / fs
        kf = KalmanFilter(dim_x=1, dim_z=1)
        kf.F = np.array([[1.0]])
        kf.H = np.array([[1.0]])
        kf.R = np.array([[r]])
        kf.Q = np.array([[q]])
        if start is None:                   # the diffuse prior's posterior after z_0
            if z.shape[0] == 1:
                return np.array([[[z[0]]]]), np.array([[[r]]])
            kf.x = np.array([[z[0]]])
            kf.P = np.array([[r]])
            means, covs, _, _ = kf.batch_filter(z[1:])
            return (np.concatenate([np.array([[[z[0]]]]), means]),
                    np.concatenate([np.array([[[r]]]), covs]))
        kf.x = np.array([[start[0]]])
        kf.P = np.array([[start[1]]])
        means, covs, _, _ = kf.batch_filter(z)
        return means, covs

    def filtered(self, data: GyroData) -> np.ndarray:
        """The filtered (or smoothed) rate, shape (n,), rad/s."""
        self._check_fitted()
        z = data.rate
        r = self.arw_rad_rt_s_ ** 2 * data.fs
        if r == 0.0:
            return z.copy()
        start = (self.x_end_, self.p_end_) if self.start == "carry" else None
        xs, ps = self._run(z, data.fs, start)
        if not self.smoother or z.shape[0] == 1:
            return xs[:, 0, 0]
        kf = KalmanFilter(dim_x=1, dim_z=1)
        kf.F = np.array([[1.0]])
        kf.H = np.array([[1.0]])
        kf.R = np.array([[r]])
        kf.Q = np.array([[self.rrw_rad_s_rt_s_ ** 2 / data.fs]])
        xs_s, _, _, _ = kf.rts_smoother(xs, ps)
        return xs_s[:, 0, 0]

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
