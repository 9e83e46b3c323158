"""Temperature compensation of the FOG bias: polynomial, BP network and ACO-BP network.

The Shupe effect makes the bias of a fiber coil depend on its temperature T and on the rate of
change dT/dt (paper [1]_, eq. 1). Three estimators of ``bias = f(T, dT/dt)``, all supervised
(they learn ``error = rate - reference_rate`` in rad/s from a thermal-chamber record):

``poly_temp``
    ``y = k1 + k2 T + k3 dT/dt`` by least squares (paper eq. 7).
``bp``
    A 2-9-1 back-propagation network (eqs. 2-4) trained by full-batch gradient descent from
    random initial weights (MATLAB's ``tansig``/``purelin`` network and ``traingd`` [3]_).
``aco_bp``
    The same network, its 37 initial weights and thresholds chosen by an ant colony
    optimisation (section 2.2, in the MAX-MIN form [2]_), then trained as ``bp``;
    ``search="random"`` replaces the colony by a random search with the same number of loss
    evaluations (the fair control).

.. rubric:: References

.. [1] Qiu Haitao, Xu Mengtong, Liu Wei, Ma Haibin, "Research on temperature compensation method
   of fiber optic gyroscope based on ACO-BP neural network", Electronics Optics & Control 30(7),
   2023, 78-81, 118 (fogbench seed 002). Eq. 1 Shupe error; eqs. 2-4 BP network and its error;
   eq. 5 bias stability; eq. 6 hidden size; eq. 7 polynomial model; section 2.2 ACO steps;
   section 3.2 parameters (9 hidden nodes, learning rate 0.1, goal 1e-5, 1,000 epochs,
   10 ants, evaporation coefficient 0.9).
.. [2] T. Stuetzle, H. H. Hoos, "MAX-MIN Ant System", Future Generation Computer Systems 16(8),
   2000, 889-914: pheromone bounds tau_min, tau_max (eq. 11 there) and iteration/global-best
   deposit.
.. [3] M. T. Hagan, H. B. Demuth, M. H. Beale, *Neural Network Design*, 1996, ch. 11-12 (the
   MATLAB ``tansig``/``purelin`` network, ``mapminmax`` normalisation and ``traingd``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dgesv as _dgesv

from .._data import GyroData
from .._estimator import Compensator, DivergenceError
from .._registry import register
from ..units import DPH
from .._checks import _random_state
from .flnn import (DEFAULT_RCOND, _restore_ident, _state_with_ident, _warn,
                   lstsq_identify)

__all__ = ["PolyTemp", "Bp", "AcoBp", "ConvergenceWarning", "TrainingRangeWarning", "train_lm",
           "random_search", "net_forward", "net_loss_grad", "n_params"]

#: A loss larger than this multiple of the starting loss counts as exploding.
_EXPLODE = 1e6


class ConvergenceWarning(UserWarning):
    """Training stopped at its epoch limit before reaching the error goal."""


class TrainingRangeWarning(UserWarning):
    """Inputs far outside the range the network was trained on (extrapolation)."""


def _is_num(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) \
        and bool(np.isfinite(v))


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


#: Training functions of :class:`Bp` and :class:`AcoBp`.
TRAININGS = ("gd", "lm")
#: Start searches of :class:`AcoBp`.
SEARCHES = ("aco", "random")
#: Arithmetic of the gradient-descent training and of the start searches.
PRECISIONS = ("float32", "float64")


# ---------------------------------------------------------------------------------------------
@register
class PolyTemp(Compensator):
    """Bias as a linear function of temperature and temperature rate (paper eq. 7).

    ``error = k1 + k2 T + k3 dT/dt``, fitted by least squares (SVD of the column-scaled design,
    :func:`fogcomp.methods.flnn.lstsq_identify`). A record that does not vary T and dT/dt
    independently (a constant temperature, a single constant ramp) leaves the design
    rank-deficient: the fit then warns and returns the minimum-norm solution.

    Parameters
    ----------
    rcond : float, default 1e-4
        Relative singular-value threshold for the numerical rank.

    Attributes
    ----------
    coef_ : ndarray, shape (3,)
        k1 in rad/s, k2 in rad/s/degC, k3 in rad/s/(degC/s).
    identifiability_ : fogcomp.methods.flnn.Identifiability
        Rank, conditioning, standard errors.

    References
    ----------
    .. [1] Qiu et al. 2023 (fogbench seed 002), eq. 7.
    """

    name = "poly_temp"
    requires = ("temp", "temp_rate")
    supervised = True
    coef_names = ("k1", "k2", "k3")

    def __init__(self, rcond: float = DEFAULT_RCOND):
        self.rcond = rcond

    @staticmethod
    def _design(data: GyroData) -> np.ndarray:
        return np.column_stack([np.ones(len(data)), data.temp, data.temp_rate])

    def _validate(self) -> None:
        if not (_is_num(self.rcond) and self.rcond > 0):
            raise ValueError(f"rcond: must be a positive finite number, got {self.rcond!r}")

    def _fit(self, data, error):
        self._validate()
        self.coef_, self.identifiability_ = lstsq_identify(
            self._design(data), error, self.coef_names, rcond=float(self.rcond), label=self.name)

    def _estimate(self, data):
        return self._design(data) @ self.coef_

    def coef_dph(self) -> dict:
        """``{"k1_dph", "k2_dph_per_c", "k3_dph_per_c_per_s"}``: deg/h, deg/h/C, deg/h/(C/s)."""
        self._check_fitted()
        return {k: float(v / DPH) for k, v in
                zip(("k1_dph", "k2_dph_per_c", "k3_dph_per_c_per_s"), self.coef_)}

    def _state(self):
        return _state_with_ident(self.identifiability_, {}, {"coef": self.coef_})

    def _restore(self, info, arrays):
        self.coef_ = np.asarray(arrays["coef"], dtype=float)
        self.identifiability_ = _restore_ident(info, arrays)


# ---------------------------------------------------------------------------------------------
# The 2-H-1 network: parameters packed in one vector theta of length 4 H + 1,
# [W1 (H x 2, row-major: hidden j, input i), b1 (H), W2 (H), b2 (1)].
def n_params(hidden_size: int, n_inputs: int = 2) -> int:
    """Weights plus thresholds of an ``n_inputs``-``hidden_size``-1 network (37 for 2-9-1)."""
    return hidden_size * n_inputs + hidden_size + hidden_size + 1


def _unpack(theta: np.ndarray, H: int, m: int = 2):
    """Split ``theta``, shape (..., P), into W1 (..., H, m), b1 (..., H), W2 (..., H), b2 (...)."""
    W1 = theta[..., :H * m].reshape(theta.shape[:-1] + (H, m))
    b1 = theta[..., H * m:H * m + H]
    W2 = theta[..., H * m + H:H * m + 2 * H]
    b2 = theta[..., -1]
    return W1, b1, W2, b2


def net_forward(theta: np.ndarray, x: np.ndarray, hidden_size: int) -> np.ndarray:
    """Output of one or several networks (paper eqs. 2-3, f1 = tanh, f2 = identity).

    Parameters
    ----------
    theta : ndarray, shape (P,) or (A, P)
        Packed parameters of one network, or of A networks (the ants of the colony).
    x : ndarray, shape (n, 2)
        Normalised inputs.
    hidden_size : int
        H.

    Returns
    -------
    ndarray, shape (n,) or (A, n)
        Normalised outputs.

    References
    ----------
    Qiu et al. 2023 (fogbench seed 002), eqs. 2-3.
    """
    W1, b1, W2, b2 = _unpack(np.asarray(theta, dtype=float), hidden_size, x.shape[1])
    if W1.ndim == 2:
        h = np.tanh(x @ W1.T + b1)
        return h @ W2 + b2
    h = np.tanh(np.einsum("ni,ahi->anh", x, W1) + b1[:, None, :])
    return np.einsum("anh,ah->an", h, W2) + b2[:, None]


def net_loss_grad(theta: np.ndarray, x: np.ndarray, t: np.ndarray, hidden_size: int):
    """MSE of one network and its gradient by back-propagation.

    The loss is ``mean((y - t)^2)``: paper eq. 4 (half the summed squared error) averaged over the
    samples and doubled, the ``mse`` performance that MATLAB's ``traingd`` descends, so that the
    learning rate does not depend on the number of samples.

    Parameters
    ----------
    theta : ndarray, shape (P,)
        Packed parameters.
    x : ndarray, shape (n, 2)
        Normalised inputs.
    t : ndarray, shape (n,)
        Normalised targets.
    hidden_size : int
        H.

    Returns
    -------
    loss : float
        Normalised MSE.
    grad : ndarray, shape (P,)
        d loss / d theta.

    References
    ----------
    Qiu et al. 2023 (fogbench seed 002), eq. 4 (error) and section 2.1 (negative-gradient
    back-propagation); Hagan, Demuth & Beale 1996, ch. 11 (the back-propagation recursion).
    """
    return _loss_grad_t(np.asarray(theta, dtype=float), np.ascontiguousarray(x.T), t,
                        hidden_size)


def _hidden_t(theta, xT, H):
    """Hidden outputs in the (H, n) layout (fast for tall data) and the unpacked parameters."""
    m = xT.shape[0]
    W1 = theta[:H * m].reshape(H, m)
    b1 = theta[H * m:H * m + H]
    W2 = theta[H * m + H:H * m + 2 * H]
    z = W1 @ xT
    z += b1[:, None]
    return np.tanh(z, out=z), W1, W2, theta[-1]


def _loss_grad_t(theta, xT, t, H):
    """:func:`net_loss_grad` with inputs as ``xT``, shape (2, n): the same arithmetic, laid out
    so that every array operation runs along the n samples (5x faster on 50,000 samples).
    With float32 ``xT`` and ``t`` the network runs in float32 (the loss is summed in float64);
    the gradient comes back in that precision."""
    h, W1, W2, b2 = _hidden_t(theta.astype(xT.dtype, copy=False), xT, H)
    e = W2 @ h
    e += b2 - t
    n = t.size
    e64 = e if e.dtype == np.float64 else e.astype(np.float64)
    loss = float(e64 @ e64) / n
    dy = e * (2.0 / n)
    gW2 = h @ dy
    gb2 = dy.sum()
    h *= h
    np.subtract(1.0, h, out=h)                      # 1 - tanh^2
    h *= dy                                         # (1 - h^2) dy, shape (H, n)
    gW1 = (h @ xT.T) * W2[:, None]
    gb1 = h.sum(axis=1) * W2
    return loss, np.concatenate([gW1.ravel(), gb1, gW2, [gb2]])


def _train_gd_many(thetas, x, t, H: int, lr: float, goal: float, max_epochs: int, dtype):
    """K gradient descents on the same data as one array program: per start ``(theta,
    losses, stop, diverged_at)``, each what :meth:`Bp._train`'s loop gives from its row of
    ``thetas`` (K, P): the same epochs, the same stop at the goal or the epoch limit, the same
    divergence check (``diverged_at``: that epoch, losses ending with the bad MSE; else None).
    The network runs in ``dtype`` over the starts still descending; each start's MSE is
    summed in float64 as in :func:`_loss_grad_t`. Differs from the one-start loop only in the
    order float32 sums run (a batched product instead of a matrix-vector one)."""
    xT = np.ascontiguousarray(np.asarray(x).T, dtype=dtype)
    t = np.asarray(t, dtype=dtype)
    theta = np.array(thetas, dtype=float, ndmin=2)
    K, P = theta.shape
    m, n = xT.shape
    iw, ib, iv = H * m, H * m + H, H * m + 2 * H
    losses: list[list[float]] = [[] for _ in range(K)]
    result: list = [None] * K
    live = np.arange(K)
    for epoch in range(int(max_epochs) + 1):
        th = theta[live].astype(dtype)
        h = th[:, :iw].reshape(-1, H, m) @ xT                 # (A, H, n)
        h += th[:, iw:ib, None]
        np.tanh(h, out=h)
        W2 = th[:, ib:iv]
        e = (W2[:, None, :] @ h)[:, 0, :]                      # (A, n)
        e += th[:, -1:] - t
        e64 = e.astype(np.float64)
        dy = e * (2.0 / n)
        gW2 = (h @ dy[:, :, None])[:, :, 0]
        gb2 = dy.sum(axis=1)
        h *= h
        np.subtract(1.0, h, out=h)
        h *= dy[:, None, :]
        gW1 = (h @ xT.T) * W2[:, :, None]
        gb1 = h.sum(axis=2) * W2
        grad = np.concatenate([gW1.reshape(len(live), -1), gb1, gW2, gb2[:, None]], axis=1)
        keep = []
        for a, k in enumerate(live):
            loss = float(e64[a] @ e64[a]) / n
            if not np.isfinite(loss) or (losses[k] and loss > _EXPLODE * losses[k][0]):
                result[k] = (theta[k].copy(), losses[k] + [loss], "diverged", epoch)
                continue
            losses[k].append(loss)
            if loss <= goal or epoch == max_epochs:
                result[k] = (theta[k].copy(), losses[k], "goal" if loss <= goal else "epochs",
                             None)
                continue
            keep.append(a)
        if not keep:
            break
        keep = np.asarray(keep)
        with np.errstate(over="ignore", invalid="ignore"):
            theta[live[keep]] = theta[live[keep]] - lr * grad[keep]
        live = live[keep]
    return result


#: MATLAB ``trainlm`` defaults (Neural Network Toolbox): initial mu, its decrease and increase
#: factors, the mu at which training stops, and the gradient norm at which it stops.
LM_MU, LM_MU_DEC, LM_MU_INC, LM_MU_MAX, LM_MIN_GRAD = 1e-3, 0.1, 10.0, 1e10, 1e-7


def train_lm(theta, x, t, hidden_size, max_epochs=1000, goal=1e-5):
    """Levenberg-Marquardt training of the network, as MATLAB's ``trainlm``.

    Each epoch: with the Jacobian J of the outputs and the error e = y - t, try
    ``dtheta = -(J^T J + mu I)^-1 J^T e``; accept it and divide mu by 10 if the MSE fell,
    otherwise multiply mu by 10 and try again. Stops at ``max_epochs``, at the MSE ``goal``,
    when the gradient norm ``2 |J^T e| / n`` falls below 1e-7 or when mu exceeds 1e10
    (trainlm's defaults; trainlm also stops on validation failures, which needs a data split
    the paper does not describe: not done here).

    Parameters
    ----------
    theta : ndarray, shape (P,)
        Starting parameters (packed as :func:`net_forward`).
    x : ndarray, shape (n, 2)
        Normalised inputs.
    t : ndarray, shape (n,)
        Normalised targets.
    hidden_size : int
        H.
    max_epochs : int
        Accepted steps at most (MATLAB ``epochs``).
    goal : float
        Stop when the MSE is at or below this.

    Returns
    -------
    theta : ndarray, shape (P,)
        Trained parameters.
    losses : ndarray, shape (epochs + 1,)
        MSE at the start and after each accepted step.
    stop : str
        Why training stopped: "goal", "epochs", "min_grad" or "mu_max".

    References
    ----------
    .. [1] M. T. Hagan and M. B. Menhaj, "Training feedforward networks with the Marquardt
       algorithm", IEEE Trans. Neural Networks 5(6), 989-993, 1994 (the algorithm of trainlm).
    .. [2] Qiu et al. 2023 (fogbench seed 002), section 3.2 (epochs 1000, goal 1e-5).
    """
    H = int(hidden_size)
    xT = np.ascontiguousarray(np.asarray(x, dtype=float).T)
    m, n = xT.shape
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float).copy()
    P = theta.size
    # J^T, shape (P, n), filled in place each epoch from the hidden outputs the accepted step
    # already computed (one tanh per trial step, none for the Jacobian); J^T J is most of an
    # epoch's cost (37 x 37 x n multiply-adds).
    JT = np.empty((P, n))
    JT[-1] = 1.0                                     # dy/db2
    diag = np.arange(P) * (P + 1)
    h = _hidden_t(theta, xT, H)[0]
    e = _lm_error(theta, h, t, H, m)
    loss = float(e @ e) / n
    losses = [loss]
    stop = "epochs"
    mu = LM_MU
    for _ in range(int(max_epochs)):
        if loss <= goal:
            stop = "goal"
            break
        _fill_jacobian_t(JT, theta, h, xT, H)
        JtJ = JT @ JT.T
        Jte = JT @ e
        if 2.0 * math.sqrt(float(Jte @ Jte)) / n < LM_MIN_GRAD:
            stop = "min_grad"
            break
        cand, h2, e2, loss2, mu = _lm_trial(theta, JtJ, Jte, diag, mu, loss, xT, t, H)
        if mu > LM_MU_MAX:
            stop = "mu_max"
            break
        theta, h, e, loss = cand, h2, e2, loss2
        mu *= LM_MU_DEC
        losses.append(loss)
    else:
        if loss <= goal:
            stop = "goal"
    return theta, np.asarray(losses), stop


def _lm_error(theta, h, t, H: int, m: int) -> np.ndarray:
    """The network's output minus the target, ``W2 h + b2 - t``, shape (n,), from the hidden
    outputs ``h`` (H, n)."""
    ib, iv = H * m + H, H * m + 2 * H
    e = theta[ib:iv] @ h
    e += theta[-1] - t
    return e


def _fill_jacobian_t(JT, theta, h, xT, H: int) -> None:
    """J^T (P, n) of the outputs at ``theta``, written in place (its last row, dy/db2 = 1, is
    set once): dy/dW1[j, i] = (1 - h_j^2) W2_j x_i, dy/db1[j] = (1 - h_j^2) W2_j, dy/dW2 = h."""
    m, n = xT.shape
    iw, ib, iv = H * m, H * m + H, H * m + 2 * H     # ends of W1, b1, W2 in theta
    JW1 = JT[:iw].reshape(H, m, n)
    Jb1, JW2 = JT[iw:ib], JT[ib:iv]
    np.multiply(h, h, out=Jb1)
    np.subtract(1.0, Jb1, out=Jb1)
    Jb1 *= theta[ib:iv, None]
    np.multiply(Jb1[:, None, :], xT[None, :, :], out=JW1)
    JW2[:] = h


def _lm_trial(theta, JtJ, Jte, diag, mu: float, loss: float, xT, t, H: int):
    """The step ``-(J^T J + mu I)^-1 J^T e`` with the first mu, raised tenfold after each
    failure, that lowers the MSE: (parameters, hidden outputs, errors, MSE, mu). When mu passes
    ``LM_MU_MAX`` first, the returned mu says so (the rest is then meaningless)."""
    n = xT.shape[1]
    cand = h2 = e2 = loss2 = None
    while True:
        A = JtJ.copy()
        A.flat[diag] += mu
        # LAPACK's LU solve, as numpy.linalg.solve, without its per-call checks (a third
        # of an epoch on a few hundred samples); info > 0: singular, raise mu
        step, info = _dgesv(A, Jte, overwrite_a=1)[2:]
        if info == 0:
            cand = theta - step
            h2 = _hidden_t(cand, xT, H)[0]
            e2 = _lm_error(cand, h2, t, H, xT.shape[0])
            loss2 = float(e2 @ e2) / n
            if np.isfinite(loss2) and loss2 < loss:
                return cand, h2, e2, loss2, mu
        mu *= LM_MU_INC
        if mu > LM_MU_MAX:
            return cand, h2, e2, loss2, mu


def _forward_chunked(theta, x, H, chunk=1 << 15):
    """:func:`net_forward` of one network, in the (H, n) layout and in chunks (long records)."""
    xT = np.ascontiguousarray(x.T)
    out = np.empty(x.shape[0])
    for s in range(0, x.shape[0], chunk):
        h, _, W2, b2 = _hidden_t(theta, xT[:, s:s + chunk], H)
        out[s:s + chunk] = W2 @ h + b2
    return out


class _MinMax:
    """MATLAB ``mapminmax``: map each column's training range linearly onto [-1, 1].

    A constant column (zero range) is mapped to 0 (its half-range is taken as 1).
    """

    def __init__(self, center: np.ndarray, half: np.ndarray):
        self.center = np.asarray(center, dtype=float)
        self.half = np.asarray(half, dtype=float)

    @classmethod
    def fit(cls, v: np.ndarray) -> "_MinMax":
        lo, hi = v.min(axis=0), v.max(axis=0)
        half = (hi - lo) / 2.0
        half = np.where(half > 0, half, 1.0)
        return cls((hi + lo) / 2.0, half)

    def forward(self, v):
        return (v - self.center) / self.half

    def inverse(self, v):
        return v * self.half + self.center


@register
class Bp(Compensator):
    """Bias = BP network(T, dT/dt): a 2-9-1 network trained by full-batch gradient descent.

    Network (paper eqs. 2-3): inputs x = (T, dT/dt), hidden layer ``y_j = f1(sum_i v_ij x_i)``,
    output ``W = f2(sum_j W_j y_j)``, each sum with a threshold (bias). The paper leaves f1, f2
    generic; here f1 = tanh (MATLAB ``tansig``) and f2 = identity (``purelin``), the MATLAB
    defaults such a study uses and the standard choice for regression: tanh is zero-centred like
    the [-1, 1]-normalised inputs, and a linear output can reach any target value.

    Normalisation: inputs and output are mapped from their training range onto [-1, 1]
    (MATLAB ``mapminmax``); the statistics are stored and reused at estimate time.

    Training, two readings of paper section 3.2 ("learning rate 0.1, error goal 1e-5, at most
    1,000 epochs"), chosen by ``training``:

    * ``"gd"`` (default): full-batch steepest descent on the MSE in normalised units (MATLAB
      ``traingd``), learning rate 0.1, stopping at the error goal 1e-5 (on that normalised
      MSE) or after 1,000 epochs. The paper's "learning rate 0.1" is a parameter of gradient
      descent, which is why this is the default.
    * ``"lm"``: Levenberg-Marquardt (:func:`train_lm`, MATLAB ``trainlm``, the default
      training function of the ``newff`` networks whose other defaults the paper's settings
      match): epochs 1000, goal 1e-5, mu from 1e-3 (x0.1 on success, x10 on failure, stop
      above 1e10); ``learning_rate`` is not used. Under LM the start decides which minimum is
      reached, the mechanism paper 002 claims for its ant colony. A fit takes 3 times as long
      as gradient descent on 516 samples, 16 times on 50,000 (measured; per epoch J^T J over
      the samples and a 37 x 37 solve; both run their 1,000 epochs on noisy data).

    Initial weights and thresholds uniform in
    ``(-init_scale, init_scale)`` = (-1, 1) from the seeded generator (MATLAB ``rands``), the
    same box the ACO of :class:`AcoBp` searches, so the two starts compare like for like.

    Hidden size 9: paper eq. 6, ``N = sqrt(m + n) + a`` with m = 2 inputs, n = 1 output and
    a = 1 ... 10 gives 3 ... 12; the paper found 9 best.

    Parameters
    ----------
    hidden_size : int, default 9
        Number of hidden nodes (paper eq. 6 and section 3.2).
    learning_rate : float, default 0.1
        Gradient-descent step (section 3.2); unused with ``training="lm"``.
    goal : float, default 1e-5
        Stop when the normalised MSE is at or below this (section 3.2).
    max_epochs : int, default 1000
        Epoch limit (section 3.2); reaching it before the goal warns (:class:`ConvergenceWarning`).
    init_scale : float, default 1.0
        Initial parameters uniform in (-init_scale, init_scale).
    training : {"gd", "lm"}, default "gd"
        Gradient descent (``traingd``) or Levenberg-Marquardt (``trainlm``); see above.
    precision : {"float32", "float64"}, default "float32"
        Arithmetic of the network during gradient descent and the start searches (ACO, random
        search): the weights are kept and updated in float64, the outputs, errors and
        gradients over the samples are computed in float32 (numpy's float32 tanh is about 5
        times faster here) and the MSE is summed in float64. ``"float64"`` is MATLAB's double
        throughout. Both train to the same loss curve within float32 rounding (tests); the
        Levenberg-Marquardt training and the fitted model's compensation are float64 always.
    random_state : int, numpy Generator or None
        Seed (required).

    Attributes
    ----------
    params_ : ndarray, shape (4 * hidden_size + 1,)
        Trained weights and thresholds, packed [W1 (H x 2), b1 (H), W2 (H), b2].
    x_center_, x_half_ : ndarray, shape (2,)
        Input normalisation: ``(x - center) / half``; T in degC, dT/dt in degC/s.
    y_center_, y_half_ : float
        Output normalisation, rad/s.
    initial_loss_ : float
        Normalised MSE at the start of gradient descent.
    loss_curve_ : ndarray, shape (``n_epochs_`` + 1,)
        Normalised MSE at the start and after each epoch.
    n_epochs_ : int
        Number of gradient (or accepted LM) steps taken.
    stop_reason_ : str
        "goal", "epochs", or for LM "min_grad" / "mu_max".

    References
    ----------
    .. [1] Qiu et al. 2023 (fogbench seed 002): eq. 1 (why T and dT/dt), eqs. 2-4 (network and
       error), eq. 6 (hidden size), section 3.2 (training parameters).
    .. [2] Hagan, Demuth & Beale 1996 (tansig/purelin, mapminmax, traingd).
    """

    name = "bp"
    requires = ("temp", "temp_rate")
    supervised = True
    random = True

    def __init__(self, hidden_size: int = 9, learning_rate: float = 0.1, goal: float = 1e-5,
                 max_epochs: int = 1000, init_scale: float = 1.0, training: str = "gd",
                 precision: str = "float32", random_state=None):
        self.hidden_size = hidden_size
        self.learning_rate = learning_rate
        self.goal = goal
        self.max_epochs = max_epochs
        self.init_scale = init_scale
        self.training = training
        self.precision = precision
        self.random_state = random_state

    # -- helpers ---------------------------------------------------------------------------------
    def _validate(self) -> None:
        if not (_is_int(self.hidden_size) and self.hidden_size >= 1):
            raise ValueError(f"hidden_size: must be an integer >= 1, got {self.hidden_size!r}")
        if not (_is_num(self.learning_rate) and self.learning_rate > 0):
            raise ValueError(f"learning_rate: must be a positive finite number, got "
                             f"{self.learning_rate!r}")
        if not (_is_num(self.goal) and self.goal >= 0):
            raise ValueError(f"goal: must be a finite number >= 0, got {self.goal!r}")
        if not (_is_int(self.max_epochs) and self.max_epochs >= 0):
            raise ValueError(f"max_epochs: must be an integer >= 0, got {self.max_epochs!r}")
        if not (_is_num(self.init_scale) and self.init_scale > 0):
            raise ValueError(f"init_scale: must be a positive finite number, got "
                             f"{self.init_scale!r}")
        if not (isinstance(self.training, str) and self.training in TRAININGS):
            raise ValueError(f"training: expected one of {list(TRAININGS)}, got "
                             f"{self.training!r}")
        if not (isinstance(self.precision, str) and self.precision in PRECISIONS):
            raise ValueError(f"precision: expected one of {list(PRECISIONS)}, got "
                             f"{self.precision!r}")
        _random_state(self.random_state)

    @staticmethod
    def _inputs(data: GyroData) -> np.ndarray:
        return np.column_stack([data.temp, data.temp_rate])

    def _prepare(self, data: GyroData, error: np.ndarray):
        x = self._inputs(data)
        xs = _MinMax.fit(x)
        const = [nm for nm, lo, hi in zip(("temp", "temp_rate"), x.min(0), x.max(0)) if lo == hi]
        if const:
            _warn(f"{self.name}: input(s) {', '.join(const)} constant over the fitting "
                  "data; the network cannot learn their effect", UserWarning)
        ys = _MinMax.fit(error[:, None])
        self.x_center_, self.x_half_ = xs.center, xs.half
        self.y_center_, self.y_half_ = float(ys.center[0]), float(ys.half[0])
        return xs.forward(x), ys.forward(error[:, None])[:, 0]

    def _initial_params(self, x, t, rng):
        return rng.uniform(-self.init_scale, self.init_scale, n_params(self.hidden_size))

    def _train(self, theta: np.ndarray, x: np.ndarray, t: np.ndarray) -> None:
        """Train from ``theta`` (``training``: traingd or trainlm); sets learned attributes."""
        if self.training == "lm":
            with np.errstate(over="ignore", invalid="ignore"):
                theta, losses, stop = train_lm(theta, x, t, self.hidden_size,
                                               self.max_epochs, self.goal)
            if not np.all(np.isfinite(theta)):
                raise DivergenceError(f"{self.name}: Levenberg-Marquardt produced non-finite "
                                      "weights")
            self._set_trained(theta, list(losses), stop)
            return
        H = self.hidden_size
        lr = float(self.learning_rate)
        dt = self._dtype()
        xT = np.ascontiguousarray(x.T, dtype=dt)
        t = np.asarray(t, dtype=dt)
        losses = []
        for epoch in range(self.max_epochs + 1):
            loss, grad = _loss_grad_t(theta, xT, t, H)
            if not np.isfinite(loss) or (losses and loss > _EXPLODE * losses[0]):
                raise DivergenceError(self._diverged(epoch, loss, losses))
            losses.append(loss)
            if loss <= self.goal or epoch == self.max_epochs:
                break
            with np.errstate(over="ignore", invalid="ignore"):
                theta = theta - lr * grad
        self._set_trained(theta, losses, "goal" if losses[-1] <= self.goal else "epochs")

    def _diverged(self, epoch: int, loss: float, losses: list) -> str:
        return (f"{self.name}: gradient descent diverged at epoch {epoch} (MSE {loss:.3g}, "
                f"initial {losses[0] if losses else float('nan'):.3g}); lower learning_rate "
                f"(now {self.learning_rate!r})")

    def _same_but_seed(self, other) -> bool:
        keys = [k for k in self.get_params() if k != "random_state"]
        return type(other) is type(self) and all(
            repr(getattr(self, k)) == repr(getattr(other, k)) for k in keys)

    @classmethod
    def fit_starts(cls, models: list, data: GyroData, reference_rate=None) -> list:
        """Gradient-descent starts trained together (issue 43): each start's checks,
        normalisation and initial weights (its ant colony or random search) as in ``fit``,
        then the K descents as one array program (``_train_gd_many``: the same epochs,
        stops and divergence checks as each start's own loop, to float32 rounding), then each
        start's learned attributes and warnings. Levenberg-Marquardt starts, starts whose
        settings differ beyond their seed, and a subclass with its own training or
        preparation (a plug-in's), are fitted one by one (an LM epoch is most of its
        cost in its own 37 x 37 normal matrix: batching did not make it faster, measured)."""
        import warnings

        first = models[0] if models else None
        own = first is not None and all(getattr(type(first), f) is getattr(Bp, f) for f in (
            "_fit", "_train", "_prepare", "_set_trained", "_inputs"))
        if (len(models) < 2 or not own or first.training != "gd"
                or not all(first._same_but_seed(m) for m in models)):
            return super().fit_starts(models, data, reference_rate)
        out: list = [None] * len(models)
        ready = []          # (index, initial weights, warnings so far); x, t: the same data
        for i, model in enumerate(models):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    error = model._error_of(data, reference_rate)
                    model._validate()
                    rng = model._rng()
                    x, t = model._prepare(data, error)
                    theta0 = model._initial_params(x, t, rng)
                except Exception as exc:   # noqa: BLE001 - each start's failure is its own
                    out[i] = (exc, list(caught))
                    continue
            ready.append((i, theta0, list(caught)))
        if not ready:
            return out
        results = _train_gd_many(np.array([r[1] for r in ready]), x, t, first.hidden_size,
                                 float(first.learning_rate), first.goal, first.max_epochs,
                                 first._dtype())
        for (i, _, earlier), (theta, losses, stop, bad) in zip(ready, results):
            model = models[i]
            if bad is not None:     # losses ends with the MSE that diverged
                out[i] = (DivergenceError(model._diverged(bad, losses[-1], losses[:-1])),
                          earlier)
                continue
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                model._set_trained(theta, losses, stop)
                model.fitted_ = True
            out[i] = (None, earlier + list(caught))
        return out

    def _dtype(self):
        return np.float32 if self.precision == "float32" else np.float64

    def _set_trained(self, theta, losses, stop):
        self.params_ = theta
        self.loss_curve_ = np.asarray(losses)
        self.initial_loss_ = float(losses[0])
        self.n_epochs_ = len(losses) - 1
        self.stop_reason_ = stop
        if losses[-1] > self.goal:
            _warn(f"{self.name}: error goal {self.goal:g} not reached in {self.n_epochs_} "
                  f"epochs (normalised MSE {losses[-1]:.3g}; stopped on {stop})",
                  ConvergenceWarning)

    # -- Compensator -----------------------------------------------------------------------------
    def _fit(self, data, error):
        self._validate()
        rng = self._rng()
        x, t = self._prepare(data, error)
        theta0 = self._initial_params(x, t, rng)
        self._train(theta0, x, t)

    def _estimate(self, data):
        x = (self._inputs(data) - self.x_center_) / self.x_half_
        if np.any(np.abs(x) > 1.5):
            _warn(f"{self.name}: inputs reach {np.abs(x).max():.3g} half-ranges from the "
                  "centre of the training range (trained on [-1, 1]); extrapolating",
                  TrainingRangeWarning)
        return _forward_chunked(self.params_, x, self.hidden_size) * self.y_half_ + self.y_center_

    def _state(self):
        info = {"initial_loss_": self.initial_loss_, "n_epochs_": self.n_epochs_,
                "y_center_": self.y_center_, "y_half_": self.y_half_,
                "stop_reason_": self.stop_reason_}
        arrays = {"params": self.params_, "loss_curve": self.loss_curve_,
                  "x_center": self.x_center_, "x_half": self.x_half_}
        return info, arrays

    def _restore(self, info, arrays):
        self.params_ = np.asarray(arrays["params"], dtype=float)
        self.loss_curve_ = np.asarray(arrays["loss_curve"], dtype=float)
        self.x_center_ = np.asarray(arrays["x_center"], dtype=float)
        self.x_half_ = np.asarray(arrays["x_half"], dtype=float)
        self.initial_loss_ = float(info["initial_loss_"])
        self.n_epochs_ = int(info["n_epochs_"])
        self.y_center_ = float(info["y_center_"])
        self.y_half_ = float(info["y_half_"])
        self.stop_reason_ = str(info["stop_reason_"])


# ---------------------------------------------------------------------------------------------
# Ant colony optimisation over a discretised parameter box
def aco_sample(tau: np.ndarray, alpha: float, n_ants: int, rng: np.random.Generator) -> np.ndarray:
    """Each ant picks, for every parameter, one candidate value with probability
    ``tau[j, k]^alpha / sum_k tau[j, k]^alpha`` (the state-transition probability).

    Parameters
    ----------
    tau : ndarray, shape (P, K)
        Pheromone on candidate k of parameter j (> 0).
    alpha : float
        Pheromone exponent.
    n_ants : int
        Number of ants A.
    rng : numpy Generator

    Returns
    -------
    ndarray of int, shape (A, P)
        The candidate index each ant chose for each parameter.

    References
    ----------
    Qiu et al. 2023 (fogbench seed 002), section 2.2 step 5 (state-transition probability);
    Stuetzle & Hoos 2000, eq. 1 there (with no heuristic term).
    """
    prob = tau ** alpha
    cum = np.cumsum(prob, axis=1)
    cum /= cum[:, -1:]
    u = rng.random((n_ants, tau.shape[0]))
    return np.minimum((u[:, :, None] >= cum[None, :, :]).sum(axis=-1), tau.shape[1] - 1)


def aco_update(tau: np.ndarray, rho: float, paths: list, deposits: list,
               tau_min: float, tau_max: float) -> np.ndarray:
    """Evaporate and deposit: ``tau <- clip((1 - rho) tau + sum of deposits, tau_min, tau_max)``.

    Parameters
    ----------
    tau : ndarray, shape (P, K)
        Pheromone before the update.
    rho : float
        Evaporation ("volatilisation") coefficient, the fraction of pheromone that evaporates each
        iteration (paper section 3.2: 0.9).
    paths : list of ndarray of int, each shape (P,)
        The candidate index chosen per parameter by each depositing ant.
    deposits : list of float
        The amount each depositing ant lays on each of its chosen edges.
    tau_min, tau_max : float
        MAX-MIN bounds.

    Returns
    -------
    ndarray, shape (P, K)
        Pheromone after the update (a new array).

    References
    ----------
    Qiu et al. 2023 (fogbench seed 002), section 2.2 step 4 and section 3.2 (rho);
    Stuetzle & Hoos 2000, eqs. 4-5 and 11 there (update, bounds).
    """
    new = (1.0 - rho) * tau
    rows = np.arange(tau.shape[0])
    for path, dep in zip(paths, deposits):
        new[rows, path] += dep
    return np.clip(new, tau_min, tau_max)


def _batch_mse(thetas: np.ndarray, xT: np.ndarray, t: np.ndarray, H: int) -> np.ndarray:
    """MSE of A networks at once, shape (A,); ``thetas`` (A, P), ``xT`` (2, n). The networks
    run in the precision of ``xT`` (float32 or float64); the squares are summed in float64."""
    m = xT.shape[0]
    W1, b1, W2, b2 = _unpack(thetas.astype(xT.dtype, copy=False), H, m)
    z = W1 @ xT                                        # (A, H, n)
    z += b1[:, :, None]
    np.tanh(z, out=z)
    y = (W2[:, None, :] @ z)[:, 0, :] + b2[:, None]    # (A, n)
    y -= t
    y = y.astype(np.float64, copy=False)
    return np.einsum("an,an->a", y, y) / t.size


def random_search(x, t, hidden_size, batch, n_batches, scale, rng, dtype=np.float64):
    """Best of ``batch * n_batches`` networks drawn uniformly in ``(-scale, scale)``.

    The control for the ant colony: the same number of loss evaluations, no pheromone.

    Parameters
    ----------
    x : ndarray, shape (n, 2)
        Normalised inputs.
    t : ndarray, shape (n,)
        Normalised targets.
    hidden_size : int
        H.
    batch, n_batches : int
        Draws per batch (the colony's ants) and batches (its iterations).
    scale : float
        Half-width of the box.
    rng : numpy Generator
    dtype : numpy dtype
        Arithmetic of the networks' outputs (float32 or float64).

    Returns
    -------
    theta : ndarray, shape (P,)
        The best network drawn.
    curve : ndarray, shape (n_batches,)
        Best MSE after each batch.
    """
    xT = np.ascontiguousarray(np.asarray(x).T, dtype=dtype)
    t = np.asarray(t, dtype=dtype)
    P = n_params(hidden_size)
    best, best_loss, curve = None, np.inf, []
    for _ in range(int(n_batches)):
        th = rng.uniform(-scale, scale, (int(batch), P))
        losses = _batch_mse(th, xT, t, hidden_size)
        if not np.all(np.isfinite(losses)):
            raise DivergenceError("random_search: non-finite loss")
        i = int(np.argmin(losses))
        if losses[i] < best_loss:
            best, best_loss = th[i].copy(), float(losses[i])
        curve.append(best_loss)
    return best, np.asarray(curve)


@register
class AcoBp(Bp):
    """BP network whose initial weights and thresholds are chosen by ant colony optimisation.

    The network, normalisation and gradient-descent training are those of :class:`Bp`; only the
    starting point differs (paper section 2.2, Fig. 2). The ACO is a pheromone-table ant system
    for continuous parameters, in the MAX-MIN form [2]_:

    1. Each of the P = 4 H + 1 = 37 parameters gets ``n_candidates`` (K = 20) candidate values,
       evenly spaced over ``[-init_scale, init_scale]``; pheromone ``tau[j, k] = 1`` on every
       candidate at the start.
    2. Each of the 10 ants builds a network by picking, for every parameter j, candidate k with
       probability ``tau[j, k]^alpha / sum_k tau[j, k]^alpha`` (``aco_sample``; there is no
       heuristic information for a weight, so the pheromone alone drives the choice).
    3. Each ant's network is scored by its MSE on the (normalised) training data.
    4. Pheromone update (``aco_update``): evaporation ``tau <- (1 - rho) tau`` with
       rho = 0.9, then the iteration-best and the global-best ants deposit ``L_ref / L`` on the
       candidates they chose (L their MSE, L_ref the MSE of the all-zero network, so better ants
       deposit more), then ``tau`` is clipped to ``[tau_min, tau_max]`` with
       ``tau_max = 2 q_gb / rho`` (the steady state of a candidate both ants keep choosing) and
       ``tau_min`` from the MAX-MIN rule with ``p_best`` (eq. 11 of [2]_), so that no candidate's
       probability reaches zero and the search keeps exploring.
    5. Repeat ``aco_iter`` times; the global-best network is the starting point of BP.

    ``search="random"`` (the control the paper does not run): ``n_ants * aco_iter`` networks
    drawn uniformly from the same box, the best one starts BP (:func:`random_search`). The
    same number of loss evaluations as the colony, so a comparison of the two measures what
    the pheromone adds.

    What rho means: the paper calls rho = 0.9 the pheromone "volatilisation coefficient" and says
    that too small a rho makes the colony converge too fast onto one path, too large a rho makes
    it ignore useful information. That is the behaviour of the evaporated fraction, so the update
    is ``tau <- (1 - rho) tau + deposit`` (a small rho keeps old pheromone and lets it pile up on
    early paths; a large rho forgets). With rho = 0.9 each iteration keeps 10 % of the old
    pheromone: the colony is steered mostly by the latest best ants.

    Parameters
    ----------
    hidden_size, learning_rate, goal, max_epochs, init_scale, training, precision, random_state
        As :class:`Bp`. ``init_scale`` is also the half-width of the ACO's search box.
    n_ants : int, default 10
        Ants per iteration (paper section 3.2).
    rho : float, default 0.9
        Evaporation coefficient in (0, 1] (paper section 3.2).
    aco_iter : int, default 50
        ACO iterations (the paper does not give the number).
    n_candidates : int, default 20
        Candidate values per parameter (K >= 2).
    aco_alpha : float, default 1.0
        Pheromone exponent of the transition probability.
    p_best : float, default 0.05
        MAX-MIN parameter setting tau_min ([2]_ eq. 11), in (0, 1).
    search : {"aco", "random"}, default "aco"
        The start search: the ant colony (paper) or random search with the same budget.

    Attributes
    ----------
    As :class:`Bp`, plus
    aco_best_loss_curve_ : ndarray, shape (aco_iter,)
        Best normalised MSE found after each iteration (of the colony, or of each batch of
        ``n_ants`` random draws); its last value is ``initial_loss_``.
    aco_params_ : ndarray, shape (4 * hidden_size + 1,)
        The best network found, the starting point of training.

    References
    ----------
    .. [1] Qiu et al. 2023 (fogbench seed 002): section 2.2 (ACO steps, Fig. 2), section 3.2
       (10 ants, rho = 0.9), eqs. 2-4 (network).
    .. [2] Stuetzle & Hoos 2000, MAX-MIN Ant System, FGCS 16(8): 889-914.
    """

    name = "aco_bp"

    def __init__(self, hidden_size: int = 9, learning_rate: float = 0.1, goal: float = 1e-5,
                 max_epochs: int = 1000, init_scale: float = 1.0, training: str = "gd",
                 n_ants: int = 10, rho: float = 0.9, aco_iter: int = 50, n_candidates: int = 20,
                 aco_alpha: float = 1.0, p_best: float = 0.05, search: str = "aco",
                 precision: str = "float32", random_state=None):
        super().__init__(hidden_size=hidden_size, learning_rate=learning_rate, goal=goal,
                         max_epochs=max_epochs, init_scale=init_scale, training=training,
                         precision=precision, random_state=random_state)
        self.search = search
        self.n_ants = n_ants
        self.rho = rho
        self.aco_iter = aco_iter
        self.n_candidates = n_candidates
        self.aco_alpha = aco_alpha
        self.p_best = p_best

    def _validate(self) -> None:
        super()._validate()
        for nm, lo in (("n_ants", 1), ("aco_iter", 1), ("n_candidates", 2)):
            v = getattr(self, nm)
            if not (_is_int(v) and v >= lo):
                raise ValueError(f"{nm}: must be an integer >= {lo}, got {v!r}")
        if not (_is_num(self.rho) and 0 < self.rho <= 1):
            raise ValueError(f"rho: evaporation coefficient must be in (0, 1], got {self.rho!r}")
        if not (_is_num(self.aco_alpha) and self.aco_alpha > 0):
            raise ValueError(f"aco_alpha: must be a positive finite number, got {self.aco_alpha!r}")
        if not (_is_num(self.p_best) and 0 < self.p_best < 1):
            raise ValueError(f"p_best: must be in (0, 1), got {self.p_best!r}")
        if not (isinstance(self.search, str) and self.search in SEARCHES):
            raise ValueError(f"search: expected one of {list(SEARCHES)}, got {self.search!r}")

    def _initial_params(self, x, t, rng):
        if self.search == "random":
            theta, curve = random_search(x, t, self.hidden_size, self.n_ants, self.aco_iter,
                                         self.init_scale, rng, dtype=self._dtype())
            self.aco_best_loss_curve_ = curve
            self.aco_params_ = theta
            return theta.copy()
        H = self.hidden_size
        xT = np.ascontiguousarray(x.T, dtype=self._dtype())
        tt = np.asarray(t, dtype=self._dtype())
        P = n_params(H)
        K = self.n_candidates
        values = np.linspace(-self.init_scale, self.init_scale, K)
        tau = np.ones((P, K))
        l_ref = max(float(t @ t / t.size), np.finfo(float).tiny)
        p_dec = self.p_best ** (1.0 / P)
        avg = max(K / 2.0, 2.0)
        best_idx, best_loss = None, np.inf
        curve = []
        for _ in range(self.aco_iter):
            idx = aco_sample(tau, self.aco_alpha, self.n_ants, rng)
            losses = _batch_mse(values[idx], xT, tt, H)
            if not np.all(np.isfinite(losses)):
                raise DivergenceError(f"{self.name}: non-finite loss in the ant colony")
            ib = int(np.argmin(losses))
            if losses[ib] < best_loss:
                best_idx, best_loss = idx[ib].copy(), float(losses[ib])
            curve.append(best_loss)
            q_ib = l_ref / max(float(losses[ib]), 1e-300)
            q_gb = l_ref / max(best_loss, 1e-300)
            tau_max = 2.0 * q_gb / self.rho
            tau_min = tau_max * (1.0 - p_dec) / ((avg - 1.0) * p_dec)
            tau = aco_update(tau, self.rho, [idx[ib], best_idx], [q_ib, q_gb], tau_min, tau_max)
        self.aco_best_loss_curve_ = np.asarray(curve)
        self.aco_params_ = values[best_idx]
        return self.aco_params_.copy()

    def _state(self):
        info, arrays = super()._state()
        arrays = dict(arrays, aco_best_loss_curve=self.aco_best_loss_curve_,
                      aco_params=self.aco_params_)
        return info, arrays

    def _restore(self, info, arrays):
        super()._restore(info, arrays)
        self.aco_best_loss_curve_ = np.asarray(arrays["aco_best_loss_curve"], dtype=float)
        self.aco_params_ = np.asarray(arrays["aco_params"], dtype=float)
