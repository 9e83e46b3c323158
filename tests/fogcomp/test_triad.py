"""fogcomp.triad: the triad's cross-axis model fitted by least squares, against records made
here from known matrices (white noise: where ordinary least squares' intervals hold)."""

from __future__ import annotations

import numpy as np
import pytest

from fogcomp.triad import fit_triad, motion_blocks

M_TRUE = np.eye(3) + np.array([[1e-4, 2e-4, -1e-4], [1.5e-4, -5e-5, 1e-4], [-2e-4, 5e-5, 2e-4]])
G_TRUE = np.array([[3.0, -2.0, 5.0], [1.0, 4.0, -3.0], [-2.0, 2.0, 6.0]]) * 1e-6
B_TRUE = np.array([5e-6, -3e-6, 1e-6])


def _record(rng, n=4000, sigma=1e-5):
    w = rng.normal(0, 0.2, (n, 3))                 # rad/s: rotations about every axis
    f = rng.normal(0, 0.6, (n, 3))                 # g: many attitudes
    meas = B_TRUE + w @ M_TRUE.T + f @ G_TRUE.T + rng.normal(0, sigma, (n, 3))
    return meas, w, f


def test_the_fit_recovers_known_matrices_and_its_intervals_cover():
    """Over 200 records the 21 coefficients' 95 % intervals hold the true values about 95 % of
    the time (ordinary least squares on white noise: exact), and ``correct`` inverts the model."""
    rng = np.random.default_rng(7)
    hits, total = 0, 0
    for _ in range(200):
        meas, w, f = _record(rng)
        m = fit_triad(meas, w, f)
        for est, se, true in ((m.bias, m.bias_se, B_TRUE), (m.M, m.M_se, M_TRUE),
                              (m.G, m.G_se, G_TRUE)):
            hits += int(np.sum(np.abs(est - true) <= 1.96 * se))
            total += est.size
    assert 0.93 <= hits / total <= 0.97, hits / total
    meas, w, f = _record(rng, sigma=0.0)
    m = fit_triad(meas, w, f)
    np.testing.assert_allclose(m.correct(meas, f), w, atol=1e-12)
    np.testing.assert_allclose(m.bias_at(meas, w, f), B_TRUE, atol=1e-15)


def test_block_sums_fit_the_same_model():
    rng = np.random.default_rng(8)
    meas, w, f = _record(rng, sigma=0.0)
    blocks = np.repeat(np.arange(400), 10)
    m = fit_triad(meas, w, f, blocks=blocks)
    np.testing.assert_allclose(m.M, M_TRUE, atol=1e-12)
    np.testing.assert_allclose(m.G, G_TRUE, atol=1e-12)


def test_a_record_that_cannot_separate_the_terms_is_refused():
    rng = np.random.default_rng(9)
    meas, w, f = _record(rng)
    f[:] = [0.0, 0.0, 1.0]                          # one attitude: G and the bias inseparable
    with pytest.raises(ValueError, match="rank"):
        fit_triad(meas, w, f)


def test_motion_blocks_join_a_move_and_cut_the_dwells():
    fs = 10.0
    tilt = np.r_[np.zeros(50), np.linspace(0, 1, 20), np.ones(50)]
    turn = np.zeros_like(tilt)
    lab = motion_blocks(tilt, turn, fs, settle_s=1.0, block_s=1.0)
    # the move (samples 51..69, commands changing) widened by 1 s each side is one block
    move = lab[45]
    assert np.all(lab[41:80] == move) and lab[40] != move and lab[80] != move
    # the dwells are cut into 1 s blocks
    assert len(set(lab[:40])) == 4 and len(set(lab[80:])) == 4
