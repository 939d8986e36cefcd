"""Cross-validation by configuration: K folds in which the points of one
configuration (posture) are never split, and the held-out residuals of a
linear(ised) least-squares problem.

Generic: labels are any per-row configuration names; the problem is
``A x ~ b`` with observations already divided by their sigma and
``obs_rows`` naming the row of each observation (several observations per
row: coordinates). For a nonlinear model, A and b are its Jacobian and
residual at the full-data fit, so that each fold takes one Gauss-Newton
step from there (exact for models linear in their parameters).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import numpy.typing as npt

from .._core import calib as core

__all__ = ["config_folds", "held_out_residuals", "FoldFactors", "rms_rows"]


def config_folds(labels: Iterable[object], k: int = 5) -> list[np.ndarray]:
    """Row indices of the test set of each fold: the configurations, in the
    order they first appear, dealt to min(k, #configurations) folds in
    turn (deterministic; neighbouring configurations land in different
    folds, so a drift along the row order is not a fold)."""
    order: dict[str, list[int]] = {}
    for i, c in enumerate(labels):
        order.setdefault(str(c), []).append(i)
    cfgs = list(order)
    k = max(1, min(int(k), len(cfgs)))
    folds = [[] for _ in range(k)]
    for j, c in enumerate(cfgs):
        folds[j % k].extend(order[c])
    return [np.array(sorted(f), dtype=int) for f in folds if f]


def held_out_residuals(
    A: npt.ArrayLike, b: npt.ArrayLike, obs_rows: npt.ArrayLike, folds: Iterable[np.ndarray], rcond: float = 1e-10
) -> np.ndarray:
    """Residual of every observation predicted by a fit to the other folds
    (the core's weighted least squares, minimum-norm when a fold leaves a
    parameter undetermined). NaN for a fold whose training set has fewer
    observations than parameters."""
    A = np.asarray(A, float)
    b = np.asarray(b, float)
    obs_rows = np.asarray(obs_rows)
    out = np.full(b.shape, np.nan)
    if A.shape[1] == 0:
        return b.copy()
    for f in folds:
        test = np.isin(obs_rows, f)
        train = ~test
        if train.sum() < A.shape[1] or not test.any():
            continue
        x = core.wls(A[train], b[train], rcond, 1e-6)[0]
        out[test] = b[test] - A[test] @ x
    return out


class FoldFactors:
    """Many held-out problems on the same rows and folds at the cost of one
    factorisation per fold: the triangular factor R of the QR decomposition
    of the training rows of [M b] (M: every column any of the problems
    uses). A problem on the columns S of M, right-hand side b + M[:, T] t,
    is then solved on R alone: with M_train = Q R[:, :-1] and b_train =
    Q R[:, -1], |M_S x - b'| = |R_S x - (R[:, -1] + R_T t)| on the
    training rows plus a constant, and R_S has the singular values and the
    column norms of M_S, so the core's scaled minimum-norm solve gives the
    solution of :func:`held_out_residuals` (the same rcond) at the cost of a
    small problem."""

    def __init__(
        self, M: npt.ArrayLike, b: npt.ArrayLike, obs_rows: npt.ArrayLike, folds: Iterable[np.ndarray]
    ) -> None:
        self.M = np.asarray(M, float)
        self.b = np.asarray(b, float)
        obs_rows = np.asarray(obs_rows)
        self.parts: list[tuple[np.ndarray, int, np.ndarray]] = []
        for f in folds:
            test = np.isin(obs_rows, f)
            train = ~test
            if not test.any():
                continue
            R = core.qr_r(np.hstack([self.M[train], self.b[train, None]]))
            self.parts.append((test, int(train.sum()), R))

    def held_out(
        self, cols: npt.ArrayLike, shift_cols: npt.ArrayLike | None = None, shift: npt.ArrayLike | None = None,
        rcond: float = 1e-10,
    ) -> np.ndarray:  # fmt: skip
        """:func:`held_out_residuals` of the columns ``cols`` of M and the
        right-hand side b + M[:, shift_cols] @ shift."""
        cols = np.asarray(cols, int)
        b = self.b
        if shift_cols is not None:
            shift_cols, shift = np.asarray(shift_cols, int), np.asarray(shift, float)
            b = b + self.M[:, shift_cols] @ shift
        out = np.full(b.shape, np.nan)
        if cols.size == 0:
            return b.copy()
        for test, ntrain, R in self.parts:
            if ntrain < cols.size:
                continue
            c = R[:, -1] if shift_cols is None else R[:, -1] + R[:, shift_cols] @ shift
            x = core.wls(R[:, cols], c, rcond, 1e-6)[0]
            out[test] = b[test] - self.M[np.ix_(test, cols)] @ x
        return out


def rms_rows(e: np.ndarray, n_rows: int, coords: Sequence[int] | None = None, scale: float = 1.0) -> float:
    """RMS over rows of the norm of each row's residual (observations laid
    out coordinate-major, e[c * n_rows + i]), using the coordinates
    ``coords`` (default all), times ``scale`` (e.g. sigma, to get metres)."""
    e = np.asarray(e, float).reshape(-1, n_rows)
    if coords is not None:
        e = e[list(coords)]
    return float(np.sqrt(np.nanmean(np.sum(e * e, axis=0))) * scale)
