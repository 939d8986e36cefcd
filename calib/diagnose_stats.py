"""Statistics of the deflection diagnosis (``calib.diagnose``): the
adequacy test (chi-square against a declared sigma, or the lack-of-fit F
test against the pure error of replicated rows), the held-out error by
configuration, and the warnings about the tests' power and over-fitting.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .._core import calib as core
from ..errors import InputError
from . import crossval as CV
from .checks import cannot_judge
from .diagnosis import (  # noqa: F401 (the tie rule's pieces, re-exported)
    ALPHA,
    CV_FOLDS,
    LOW_DOF,
    TIE_LOG10,
    ZTOL,
    _cos,
    _cv_better,
    _nested,
    check_residual,
)
from .fit import FitResult, Problem
from .measure import Measurements

__all__ = ["pure_error", "logsf_chi2", "logsf_f", "ALPHA", "CV_FOLDS", "LOW_DOF"]

OVERFIT = 0.8  # an adequate RMS below this fraction of the noise floor: warn
NSIM = 999  # Monte Carlo draws of the max-score test


def pure_error(pb: Problem, meas: Measurements) -> tuple[float, int]:
    """Sum of squares and degrees of freedom of replicated rows (same q, w, p)."""
    key = np.round(np.hstack([meas.q, meas.w, meas.p]), 12)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    y = pb.y[: pb.rows].T  # (n, rows), unweighted
    ss, dof = 0.0, 0
    for g in np.nonzero(counts > 1)[0]:
        rows = y[inv == g]
        ss += float(((rows - rows.mean(axis=0)) ** 2).sum())
        dof += (rows.shape[0] - 1) * pb.rows
    return ss, dof


def logsf_chi2(x: float, k: float) -> float:
    return core.chi2_logsf(x, k)


def logsf_f(f: float, d1: float, d2: float) -> float:
    return core.f_logsf(f, d1, d2)


def _adequacy(
    res: FitResult, pb: Problem, meas: Measurements, copies: int = 0
) -> tuple[str, float, int, float, float, str, float, int | None]:
    """(test, statistic, dof, log p, sigma, source, scale2, d_pe); ``meas``
    holds distinct rows only, ``copies`` rows were exact copies (dropped)."""
    check_residual(meas.path, meas.n, copies, res.nobs, res.rank, pb.rows)
    if pb.sigma_declared:
        stat, dof = res.chi2, res.dof
        return (
            "chi2",
            stat,
            dof,
            (logsf_chi2(stat, dof) if dof > 0 else 0.0),
            float(pb.sigma_position),
            "declared",
            1.0,
            None,
        )
    ss_pe, d_pe = pure_error(pb, meas)
    if d_pe == 0:
        raise cannot_judge(
            meas.path,
            meas.n,
            copies,
            "no [measurements] sigma_position in the model and no replicated rows (same posture, wrench and "
            "point, measured again): the noise level is unknown, so adequacy cannot be tested; declare "
            "sigma_position or repeat measurements",
        )
    s2 = ss_pe / d_pe
    if not s2 > 0:
        raise InputError(
            f"{meas.path}: the replicated rows (same posture, wrench and point) repeat each other exactly "
            f"(pure error 0): they look copied, not measured again, so they tell nothing about the noise; "
            f"declare sigma_position or remove the copies"
        )
    d_lof = res.dof - d_pe
    if d_lof > 0:
        stat = ((res.chi2 - ss_pe) / d_lof) / s2
        dof, log_p = d_lof, logsf_f(stat, d_lof, d_pe)
    else:
        stat, dof, log_p = 0.0, 0, 0.0
    return "lack-of-fit F", stat, dof, log_p, math.sqrt(s2), "pure error", s2, d_pe


def _cv(
    A: np.ndarray,
    r: np.ndarray,
    obs_rows: np.ndarray,
    folds: list[np.ndarray],
    npts: int,
    wp: float,
    labels: Sequence[object],
) -> tuple[float | None, np.ndarray | None]:
    """Held-out positional RMS (m) and the mean squared held-out error of
    each configuration (for paired comparisons); (None, None) when no fold
    can be fitted."""
    e = CV.held_out_residuals(A, r, obs_rows, folds)
    if not np.any(np.isfinite(e)):
        return None, None
    sq = np.sum((e.reshape(-1, npts)[0:3] / wp) ** 2, axis=0)
    _, idx = np.unique(np.asarray(labels, dtype=object).astype(str), return_inverse=True)
    ok = np.isfinite(sq)
    tot = np.bincount(idx[ok], weights=sq[ok], minlength=idx.max() + 1)
    cnt = np.bincount(idx[ok], minlength=idx.max() + 1)
    per = np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)
    return CV.rms_rows(e, npts, coords=(0, 1, 2), scale=1.0 / wp), per
