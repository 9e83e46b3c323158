"""``ar_kalman``: an autoregressive model of the gyro's correlated noise and a Kalman filter on
it, as a fogcomp plug-in (entry point ``fogcomp.methods``; ``pip install examples/fogcomp-ar``).

The method paper 000 names as the usual one beside the Kalman filter (its ref. [1]: an ARMA model
of the gyro's random drift, a zero-mean stationary Gaussian series), in the form FOG papers use:
an AR(p) model of the drift as the state of a Kalman filter. Model of a record::

    z_k = L_k + x_k + v_k                 z: the gyro's rate, rad/s
    L_k = L_{k-1} + w_k                   the rate the gyro sees (constant when q_L = 0)
    x_k = phi_1 x_{k-1} + ... + phi_p x_{k-p} + e_k    the correlated drift, AR(p)
    v_k ~ N(0, r)                          white rate noise (angle random walk)

Fit (on the fitting record, no reference: the method sees what a lab sees): the mean is taken
out; r is half the mean squared first difference (the Allan variance at one sample, which white
noise dominates there); the drift's autocovariance is the record's at lags 1..p and its
variance less r at lag 0 (white noise adds only at lag 0), and phi and the driving variance q
solve the Yule-Walker equations on it (Box, Jenkins & Reinsel, *Time Series Analysis*, 4th ed.,
2008, eq. 3.2.7). A model that is not stationary (a root on or outside the unit circle) or has
no variance left for the drift lowers p until one is; p = 0 leaves white noise alone (the filter
is then the running mean).

Compensation (each record anew): the Kalman filter (state [L, x_k, ..., x_{k-p+1}], H = [1, 1,
0, ...]; the level diffuse at the start, the drift at its stationary covariance) run forward
over the record (causal: what a real-time system can do). ``output = "level"`` removes the
drift and the white noise (the estimated error is z - L), ``"signal"`` the white noise only
(z - L - x). The AR coefficients hold at the fitting record's sample rate only: another rate is
refused.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from scipy.linalg import solve_discrete_lyapunov, solve_toeplitz

from fogcomp import Compensator

__all__ = ["ARKalman"]

DPH_RT_H = math.radians(1.0) / 3600.0 / 60.0     # deg/h/sqrt(h) -> rad/s/sqrt(s)
OUTPUTS = ("level", "signal")


class ARKalman(Compensator):
    """AR(p) drift + white noise, filtered by a Kalman filter (module docstring).

    Parameters
    ----------
    order : int
        AR order p, 1 to 10 (default 2, the usual choice for FOG drift).
    output : str
        ``"level"`` (remove drift and white noise) or ``"signal"`` (white noise only).
    level_rrw_dph_rt_h : float
        Random walk of the level L, deg/h/sqrt(h): 0 (default) holds it constant over a
        record; larger lets it follow slow changes of the rate.
    """

    name = "ar_kalman"
    requires = ("rate",)
    supervised = False
    random = False

    def __init__(self, order: int = 2, output: str = "level", level_rrw_dph_rt_h: float = 0.0):
        self.order = order
        self.output = output
        self.level_rrw_dph_rt_h = level_rrw_dph_rt_h

    def _validate(self):
        if isinstance(self.order, bool) or not isinstance(self.order, numbers.Integral) \
                or not 1 <= self.order <= 10:
            raise ValueError(f"order: expected an integer AR order from 1 to 10, got "
                             f"{self.order!r}")
        if not isinstance(self.output, str) or self.output not in OUTPUTS:
            raise ValueError(f"output: expected one of {OUTPUTS}, got {self.output!r}")
        v = self.level_rrw_dph_rt_h
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v) \
                or v < 0:
            raise ValueError(f"level_rrw_dph_rt_h: expected a finite number >= 0 (deg/h/sqrt(h)), "
                             f"got {v!r}")

    # -- fit ---------------------------------------------------------------------------------
    def _fit(self, data, error):
        self.check_params()
        z = data.rate
        n = z.size
        p = int(self.order)
        if n < 20 * (p + 1):
            raise ValueError(f"rate: {n} samples; an AR({p}) fit needs at least {20 * (p + 1)}")
        y = z - z.mean()
        r = 0.5 * float(np.mean(np.diff(y) ** 2))
        gamma = np.array([float(y[: n - k] @ y[k:]) / n for k in range(p + 1)])
        phi, q = np.zeros(0), 0.0
        for order in range(p, 0, -1):
            gx = gamma[: order + 1].copy()
            gx[0] -= r
            if gx[0] <= 0:
                continue
            cand = solve_toeplitz(gx[:order], gx[1:order + 1])
            qc = float(gx[0] - cand @ gx[1:order + 1])
            roots = np.roots(np.concatenate([[1.0], -cand]))
            if qc > 0 and np.all(np.abs(roots) < 1.0 - 1e-9):
                phi, q = cand, qc
                break
        self.fs_ = float(data.fs)
        self.phi_ = phi
        self.q_ = q
        self.r_ = r
        self.ar_order_ = int(phi.size)

    # -- compensate ----------------------------------------------------------------------------
    def _estimate(self, data):
        if abs(data.fs - self.fs_) > 1e-9 * self.fs_:
            raise ValueError(f"fs: the AR model was fitted at {self.fs_:g} Hz; this record is at "
                             f"{data.fs:g} Hz (fit at its rate)")
        z = data.rate
        p = self.ar_order_
        d = 1 + p
        F = np.zeros((d, d))
        F[0, 0] = 1.0
        Q = np.zeros((d, d))
        Q[0, 0] = (self.level_rrw_dph_rt_h * DPH_RT_H) ** 2 / self.fs_
        P = np.zeros((d, d))
        P[0, 0] = 1e6 * (float(np.var(z)) + self.r_)           # the level: diffuse
        if p:
            C = np.zeros((p, p))
            C[0] = self.phi_
            C[1:, :-1] = np.eye(p - 1)
            F[1:, 1:] = C
            Qx = np.zeros((p, p))
            Qx[0, 0] = self.q_
            Q[1:, 1:] = Qx
            P[1:, 1:] = solve_discrete_lyapunov(C, Qx)        # the drift: stationary
        H = np.zeros(d)
        H[0] = 1.0
        if p:
            H[1] = 1.0
        s = np.zeros(d)
        s[0] = z[0]
        level = np.empty(z.size)
        drift = np.empty(z.size)
        r = self.r_
        for k in range(z.size):
            if k:
                s = F @ s
                P = F @ P @ F.T + Q
            ph = P @ H
            gain = ph / (H @ ph + r)
            s = s + gain * (z[k] - H @ s)
            P = P - np.outer(gain, ph)
            level[k] = s[0]
            drift[k] = s[1] if p else 0.0
        return z - level if self.output == "level" else z - level - drift

    # -- persistence ---------------------------------------------------------------------------
    def _state(self):
        return ({"fs_": self.fs_, "q_": self.q_, "r_": self.r_, "ar_order_": self.ar_order_},
                {"phi_": np.asarray(self.phi_, dtype=float)})

    def _restore(self, info, arrays):
        self.fs_ = float(info["fs_"])
        self.q_ = float(info["q_"])
        self.r_ = float(info["r_"])
        self.ar_order_ = int(info["ar_order_"])
        self.phi_ = np.asarray(arrays["phi_"], dtype=float)
        if self.phi_.shape != (self.ar_order_,):
            raise ValueError(f"phi_ has shape {self.phi_.shape}, ar_order_ is {self.ar_order_}")
