"""The core's rotation of a 6x6 compliance (sk_spatial::rotate6 through
stiffkit._core.springs.rotate6), used by the robot model (``rpy``) and the
FEA amplitude estimate."""

from __future__ import annotations

import numpy as np
import pytest

from stiffkit import InputError
from stiffkit._core.springs import rotate6
from stiffkit.robot.model import rpy_matrix


def _blockdiag(R):
    return np.kron(np.eye(2), R)


def test_rotate6_is_blockdiag_congruence():
    rng = np.random.default_rng(3)
    R = rpy_matrix(rng.uniform(-3, 3, 3))
    C = rng.normal(size=(6, 6))  # not symmetric: every block is rotated
    np.testing.assert_allclose(rotate6(R, C), _blockdiag(R) @ C @ _blockdiag(R).T, rtol=0, atol=1e-14)


def test_rotate6_batches_and_broadcasts():
    rng = np.random.default_rng(4)
    Rs = np.array([rpy_matrix(rng.uniform(-3, 3, 3)) for _ in range(5)])
    Cs = rng.normal(size=(5, 6, 6))
    want = np.array([_blockdiag(R) @ C @ _blockdiag(R).T for R, C in zip(Rs, Cs)])
    np.testing.assert_allclose(rotate6(Rs, Cs), want, rtol=0, atol=1e-14)
    assert rotate6(Rs, Cs[0]).shape == (5, 6, 6) and rotate6(Rs[0], Cs).shape == (5, 6, 6)
    # a rotation and back is the identity map
    np.testing.assert_allclose(rotate6(Rs[0].T, rotate6(Rs[0], Cs[0])), Cs[0], rtol=0, atol=1e-14)


def test_rotate6_rejects_bad_input():
    with pytest.raises(InputError, match="NaN or Inf"):
        rotate6(np.eye(3), np.full((6, 6), np.nan))
    with pytest.raises(InputError, match="rot must be"):
        rotate6(np.eye(4), np.eye(6))
    with pytest.raises(InputError, match="rotations for"):
        rotate6(np.stack([np.eye(3)] * 2), np.stack([np.eye(6)] * 3))
