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

__all__ = ["KalmanDenoiser", "variogram", "estimate_noise"]


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

    def __init__(self, arw_rad_rt_s=None, rrw_rad_s_rt_s=None, smoother=False):
        self.arw_rad_rt_s = arw_rad_rt_s
        self.rrw_rad_s_rt_s = rrw_rad_s_rt_s
        self.smoother = smoother

    def _fit(self, data: GyroData, error) -> None:
        arw = _check_optional_positive("arw_rad_rt_s", self.arw_rad_rt_s)
        rrw = _check_optional_positive("rrw_rad_s_rt_s", self.rrw_rad_s_rt_s)
        if not isinstance(self.smoother, (bool, np.bool_)):
            raise ValueError(f"smoother: expected True or False, got {self.smoother!r}")
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

    def filtered(self, data: GyroData) -> np.ndarray:
        """The filtered (or smoothed) rate, shape (n,), rad/s."""
        self._check_fitted()
        z = data.rate
        n = z.shape[0]
        r = self.arw_rad_rt_s_ ** 2 * data.fs
        q = self.rrw_rad_s_rt_s_ ** 2 / data.fs
        if n == 1 or r == 0.0:
            return z.copy()
        kf = KalmanFilter(dim_x=1, dim_z=1)
        kf.F = np.array([[1.0]])
        kf.H = np.array([[1.0]])
        kf.R = np.array([[r]])
        kf.Q = np.array([[q]])
        kf.x = np.array([[z[0]]])
        kf.P = np.array([[r]])
        means, covs, _, _ = kf.batch_filter(z[1:])
        xs = np.concatenate([np.array([[[z[0]]]]), means])
        if not self.smoother:
            return xs[:, 0, 0]
        ps = np.concatenate([np.array([[[r]]]), covs])
        xs_s, _, _, _ = kf.rts_smoother(xs, ps)
        return xs_s[:, 0, 0]

    def _estimate(self, data: GyroData) -> np.ndarray:
        return data.rate - self.filtered(data)

    def _state(self):
        info = {"arw_rad_rt_s_": self.arw_rad_rt_s_, "rrw_rad_s_rt_s_": self.rrw_rad_s_rt_s_,
                "fs_": self.fs_}
        return info, {"variogram_": self.variogram_}

    def _restore(self, info, arrays):
        self.arw_rad_rt_s_ = float(info["arw_rad_rt_s_"])
        self.rrw_rad_s_rt_s_ = float(info["rrw_rad_s_rt_s_"])
        self.fs_ = float(info["fs_"])
        self.variogram_ = np.asarray(arrays["variogram_"], dtype=float)
