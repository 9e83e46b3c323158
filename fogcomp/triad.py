"""A gyro triad's cross-axis model, fitted on a lab's references.

The model (per sample, body axes, SI):

    w_meas = b + M w + G f + noise

with ``b`` the bias (rad/s), ``M`` the 3x3 scale-factor and misalignment matrix (the identity for
a perfect triad: diagonal 1 + scale factor, off-diagonal the misalignments, rad), ``G`` the 3x3
g-sensitivity (rad/s per g), ``w`` the true inertial rate and ``f`` the specific force in g. It
is the linear triad model whose matrices Kalibr and OpenVINS write as ``Tw`` (here ``M``) and
``Tg`` (here ``G``, per g instead of per m/s^2); its form, not an equation of a paper, is what
is used here.

:func:`fit_triad` estimates ``b``, ``M`` and ``G`` from a calibration record (multi-position
dwells for ``b`` and ``G``, rotations about each axis for ``M``) by least squares on the lab's
reference rate and specific force, each gyro's row alone; :meth:`TriadModel.correct` inverts the
model. The standard errors are ordinary least squares' on the row's residuals (white-noise
residuals assumed; exact there, ``tests/fogcomp/test_triad.py``). On the table, with the FOG's
colored noises, the 95 % intervals of M and G held the configured values in 93 % of 180
entries each over 20 power-ons (``python -m fogbench.bench.attitude --triad``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["TriadModel", "fit_triad", "motion_blocks"]


@dataclass(frozen=True)
class TriadModel:
    """b (3,), rad/s; M (3, 3); G (3, 3), rad/s per g; and the standard errors of each (the
    same shapes) from the fit's residuals."""

    bias: np.ndarray
    M: np.ndarray
    G: np.ndarray
    bias_se: np.ndarray
    M_se: np.ndarray
    G_se: np.ndarray

    def correct(self, rate, f, bias=None) -> np.ndarray:
        """The rate the model says was applied, ``M^-1 (w_meas - b - G f)``, shape (n, 3);
        ``bias`` (3,) replaces the fitted one (a bias found at this power-on's alignment)."""
        b = self.bias if bias is None else np.asarray(bias, dtype=float)
        r = np.asarray(rate, dtype=float) - b - np.asarray(f, dtype=float) @ self.G.T
        return np.linalg.solve(self.M, r.T).T

    def bias_at(self, rate, ref_rate, f) -> np.ndarray:
        """The bias of a static stretch given its reference rate and specific force (the model's
        M and G held): the mean of ``w_meas - M w_ref - G f``, shape (3,)."""
        r = (np.asarray(rate, dtype=float) - np.asarray(ref_rate, dtype=float) @ self.M.T
             - np.asarray(f, dtype=float) @ self.G.T)
        return r.mean(axis=0)


def motion_blocks(tilt_cmd, turn_rate_cmd, fs: float, settle_s: float = 2.0,
                  block_s: float = 1.0) -> np.ndarray:
    """Block labels (n,) for :func:`fit_triad` from a table's commands: every stretch where a
    command changes (a tilt move, a turntable rate step), widened by ``settle_s`` on each side,
    is one block; the rest (dwells, rate plateaus) is cut into blocks of ``block_s``. Over a
    move the table starts and ends at rest, so the sums of the reading and of the commanded
    rate over the block differ by the model's terms alone, whatever the servo's lag inside it
    (the integral form of a Ferraris rotation, Ferraris et al. 1995, eqs. 13-14)."""
    tilt = np.asarray(tilt_cmd, dtype=float)
    turn = np.asarray(turn_rate_cmd, dtype=float)
    n = tilt.size
    change = np.zeros(n, dtype=bool)
    change[1:] = (np.diff(tilt) != 0) | (np.diff(turn) != 0)
    k = max(1, int(round(settle_s * fs)))
    idx = np.flatnonzero(change)
    moving = np.zeros(n + 1, dtype=int)
    np.add.at(moving, np.clip(idx - k, 0, n), 1)
    np.add.at(moving, np.clip(idx + k + 1, 0, n), -1)
    moving = np.cumsum(moving)[:n] > 0
    labels = np.empty(n, dtype=int)
    label, i, b = 0, 0, max(1, int(round(block_s * fs)))
    while i < n:
        j = i
        if moving[i]:
            while j < n and moving[j]:
                j += 1
        else:
            while j < n and not moving[j] and j - i < b:
                j += 1
        labels[i:j] = label
        label += 1
        i = j
    return labels


def fit_triad(rate, ref_rate, ref_f, mask=None, blocks=None) -> TriadModel:
    """Least squares of each gyro's reading on [1, the reference rate, the specific force]
    (per sample, or, with ``blocks``, of their sums over each block: :func:`motion_blocks`).

    Parameters
    ----------
    rate : ndarray, shape (n, 3)
        The triad's readings, rad/s.
    ref_rate : ndarray, shape (n, 3)
        The lab's reference rate in body axes, rad/s (the table's commands and the Earth's rate
        at the believed site: ``sim.lab.lab_reference``).
    ref_f : ndarray, shape (n, 3)
        The lab's specific force in body axes, g.
    mask : ndarray of bool, shape (n,), optional
        The samples to fit (default all).
    blocks : ndarray of int, shape (n,), optional
        Block labels: the fit is on each block's sums (a block of N samples weighs N).

    Returns
    -------
    TriadModel
    """
    w = np.asarray(rate, dtype=float)
    R = np.asarray(ref_rate, dtype=float)
    F = np.asarray(ref_f, dtype=float)
    if w.ndim != 2 or w.shape[1] != 3 or R.shape != w.shape or F.shape != w.shape:
        raise ValueError(f"rate, ref_rate and ref_f must each have shape (n, 3); got "
                         f"{w.shape}, {R.shape}, {F.shape}")
    sel = np.ones(w.shape[0], dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    X = np.column_stack([np.ones(int(sel.sum())), R[sel], F[sel]])
    Y = w[sel]
    if blocks is not None:
        lab = np.asarray(blocks)[sel]
        _, inv, counts = np.unique(lab, return_inverse=True, return_counts=True)
        Xs = np.zeros((counts.size, 7))
        Ys = np.zeros((counts.size, 3))
        np.add.at(Xs, inv, X)
        np.add.at(Ys, inv, Y)
        # sums over N samples have N times a sample's variance: divide by sqrt(N) (weights)
        sq = np.sqrt(counts)[:, None]
        X, Y = Xs / sq, Ys / sq
    if np.linalg.matrix_rank(X) < 7:
        raise ValueError("the calibration record does not separate bias, rates and specific "
                         "force (rank < 7): it needs dwells at several attitudes and rotations "
                         "about each axis")
    coef = np.empty((3, 7))
    se = np.empty((3, 7))
    XtX_inv = np.linalg.inv(X.T @ X)
    for i in range(3):
        y = Y[:, i]
        c, *_ = np.linalg.lstsq(X, y, rcond=None)
        res = y - X @ c
        s2 = float(res @ res) / max(1, X.shape[0] - 7)
        coef[i] = c
        se[i] = np.sqrt(np.diag(XtX_inv) * s2)
    return TriadModel(bias=coef[:, 0], M=coef[:, 1:4], G=coef[:, 4:7], bias_se=se[:, 0],
                      M_se=se[:, 1:4], G_se=se[:, 4:7])
