"""Where the residual lives: the shapes a missing effect leaves in the
residual, so that a user can see it and name it when no catalogued effect
fits.

Each *feature* is a block of columns scored like a candidate effect (the
core's score test: projected off the model, the part of the residual in
that space, its degrees of freedom), with the fraction of the excess
residual (above the noise) it takes:

- ``torque about J``: the joint's rotation as a free piecewise-linear
  function of its torque tau (hardening, softening, dead zone, saturation);
- ``angle of J``: the joint's compliance as a free piecewise-linear
  function of its angle q (compensators, gear eccentricity, cable drag);
- ``row order``: a translation of the measured points drifting along the
  row order (thermal drift of the tracker, a creeping fixture);
- ``configuration``: a translation offset per configuration that does not
  scale with the load (a posture measured against a wrong reference).

For the plots, every row's residual is also expressed as the rotation of
each joint that would best explain it (dq_j = J_j . r / |J_j|^2, point
part; NaN for a point on the joint's axis), against the joint's angle and
torque.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .._core import calib as core

if TYPE_CHECKING:
    from .problem import Problem

__all__ = ["Feature", "features", "score_features", "joint_residuals", "binned"]

KNOTS = 6  # hat functions per piecewise-linear shape


class Feature:
    def __init__(self, name: str, kind: str, target: str, cols: np.ndarray) -> None:
        self.name = name
        self.kind = kind  # torque | angle | order | configuration
        self.target = target
        self.cols = cols  # (6, n, m) per unit coefficient
        self.statistic = 0.0
        self.dof = 0
        self.log_p = 0.0
        self.excess_fraction = 0.0

    def to_json(self) -> dict:
        return {
            "feature": self.name,
            "kind": self.kind,
            "target": self.target,
            "dof": self.dof,
            "statistic": self.statistic,
            "log10_p_value": self.log_p / np.log(10),
            "excess_fraction": self.excess_fraction,
        }


def hats(x: np.ndarray, k: int = KNOTS) -> np.ndarray:
    """(n, k) piecewise-linear hat functions on knots at quantiles of x."""
    x = np.asarray(x, float)
    knots = np.unique(np.quantile(x, np.linspace(0, 1, k)))
    if knots.size < 2:
        return np.ones((x.size, 1))
    out = np.zeros((x.size, knots.size))
    for i in range(knots.size):
        e = np.zeros(knots.size)
        e[i] = 1.0
        out[:, i] = np.interp(x, knots, e)
    return out


def features(pb: Problem, order: npt.ArrayLike | None = None) -> list[Feature]:
    """The feature blocks of a Problem's rows (see the module text);
    ``order`` (n,) is the time order of the rows (default: as given)."""
    meas = pb.meas
    n = meas.n
    ch = pb.model.chain
    tw = pb.joint_twists()
    tau = pb.torques
    out = []
    scale_t = np.sqrt(np.mean(tau**2, axis=0)) if n else np.zeros(tau.shape[1])
    big = scale_t.max() if scale_t.size else 0.0
    for j, name in enumerate(ch.joint_names):
        if ch.qidx[j] == 0 or not scale_t[j] > 1e-9 * big:
            continue
        Jt = tw[:, :, j]  # (6, n)
        Ht = hats(tau[:, j])
        out.append(Feature(f"torque about {name}", "torque", name, Jt[:, :, None] * Ht[None]))
        q = meas.q[:, int(ch.qidx[j]) - 1]
        if np.ptp(q) > 1e-6:
            Hq = hats(q)
            out.append(Feature(f"angle of {name}", "angle", name, (Jt * tau[:, j])[:, :, None] * Hq[None]))
    t = np.arange(n, dtype=float) if order is None else np.asarray(order, float)
    Ho = hats(t)
    cols = np.zeros((6, n, 3 * Ho.shape[1]))
    for a in range(3):
        cols[a, :, a * Ho.shape[1] : (a + 1) * Ho.shape[1]] = Ho
    out.append(Feature("row order (drift)", "order", "rows", cols))
    labels = list(dict.fromkeys(meas.config))
    if 1 < len(labels) < n:
        idx = {c: i for i, c in enumerate(labels)}
        cols = np.zeros((6, n, 3 * len(labels)))
        for i, c in enumerate(meas.config):
            for a in range(3):
                cols[a, i, 3 * idx[c] + a] = 1.0
        out.append(Feature("configuration offsets (no load)", "configuration", "configurations", cols))
    return out


def score_features(
    pb: Problem, A: np.ndarray, r: np.ndarray, feats: list[Feature], scale2: float, excess: float, ztol: float = 1e-6
) -> list[Feature]:
    """Score every feature against the model (A, weighted residual r) in
    one core call; fill statistic, dof, log p (chi-square, statistic over
    scale2) and the fraction of the excess it takes. Best first."""
    if not feats:
        return []
    Z, cstart = [], [1]
    for f in feats:
        c = pb.weighted(f.cols)
        Z.append(c)
        cstart.append(cstart[-1] + c.shape[1])
    A = A if A.shape[1] else np.zeros((A.shape[0], 1))
    stat, dof, _ = core.score(A, r, np.hstack(Z), np.array(cstart, np.int32), 1e-10, ztol)
    for f, s, d in zip(feats, stat, dof):
        f.statistic = float(s / scale2)
        f.dof = int(d)
        f.log_p = core.chi2_logsf(f.statistic, f.dof) if d > 0 else 0.0
        f.excess_fraction = float((f.statistic - f.dof) / excess) if excess > 0 and d > 0 else 0.0
    return sorted([f for f in feats if f.dof > 0], key=lambda f: f.log_p)


def joint_residuals(pb: Problem, residuals: np.ndarray) -> dict:
    """Per actuated joint: the joint rotation that best explains each row's
    point residual (n,), with the rows' angles and torques:
    {joint: {"q": (n,), "tau": (n,), "dq": (n,)}}."""
    ch = pb.model.chain
    tw = pb.joint_twists()
    out = {}
    for j, name in enumerate(ch.joint_names):
        if ch.qidx[j] == 0:
            continue
        Jp = tw[0:3, :, j].T  # (n, 3)
        nn = np.sum(Jp * Jp, axis=1)
        # a point (almost) on the joint's axis does not see its rotation: no estimate
        ok = nn > 1e-4 * float(np.median(nn)) if np.any(nn > 0) else np.zeros(nn.shape, bool)
        dq = np.where(ok, np.sum(Jp * residuals, axis=1) / np.where(ok, nn, 1.0), np.nan)
        out[name] = {"q": pb.meas.q[:, int(ch.qidx[j]) - 1], "tau": pb.torques[:, j], "dq": dq}
    return out


def binned(x: npt.ArrayLike, y: npt.ArrayLike, bins: int = 8) -> dict:
    """Mean and standard error of y in bins of x (equal counts)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size == 0:
        return {"x": [], "mean": [], "sem": []}
    edges = np.unique(np.quantile(x, np.linspace(0, 1, bins + 1)))
    xs, ms, ss = [], [], []
    for a, b in zip(edges[:-1], edges[1:]):
        sel = (x >= a) & (x <= b)
        if sel.sum() == 0:
            continue
        xs.append(float(x[sel].mean()))
        ms.append(float(y[sel].mean()))
        ss.append(float(y[sel].std(ddof=1) / np.sqrt(sel.sum())) if sel.sum() > 1 else 0.0)
    return {"x": xs, "mean": ms, "sem": ss}
