"""Typed wrappers of the serial-chain and calibration core (``_calib``,
core/sk_api_calib.f90): chain kinematics, the deflection model, weighted
least squares, score tests, tail probabilities, and the Levenberg-Marquardt
iteration by reverse communication (core/sk_lm.f90).

A chain is passed as the dict of Fortran-ordered arrays that
``stiffkit.robot.Chain.core_arrays()`` returns (jrot, jpos, jaxis, qidx,
trot, tpos)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _calib
from .errors import call, check


def chain_poses(chain: dict, q: np.ndarray) -> dict[str, np.ndarray]:
    """Frames at postures q (ndof, N): rf (N, nj, 3, 3), pf (N, nj, 3), rt (N, 3, 3), pt (N, 3)."""
    rf, pf, rt, pt, info = call(_calib.sk_chain_poses, "sk_chain_poses", **chain, q=q)
    check(
        info,
        "chain poses (sk_chain_poses)",
        {2: "postures contain NaN or Inf", 6: "the chain description is inconsistent"},
    )
    return {
        "rf": np.transpose(rf, (3, 2, 0, 1)),
        "pf": np.transpose(pf, (2, 1, 0)),
        "rt": np.transpose(rt, (2, 0, 1)),
        "pt": pt.T.copy(),
    }


def deflection_rows(
    chain: dict, enc: dict, theta: np.ndarray, q: np.ndarray, w: np.ndarray, p: np.ndarray, jac: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """Predicted rows (6, n) of the deflection model and, with ``jac``, their
    Jacobian (6, n, npar) at theta (core/sk_deflect.f90). ``enc`` is the
    encoded model (stype, sidx, tint, tgeo, elem, par; robot/model_core.py);
    q (ndof, n), w (6, n), p (3, n) Fortran-ordered."""
    theta = np.asarray(theta, float)
    n = q.shape[1]
    pred, J, info = call(
        _calib.sk_deflection_rows,
        "sk_deflection_rows",
        n if jac else 0,
        **chain,
        **enc,
        theta=theta,
        q=q,
        w=w,
        p=p,
        want_jac=int(bool(jac)),
    )
    check(
        info,
        "deflection rows (sk_deflection_rows)",
        {6: "the chain, its springs or the model's terms are inconsistent (a bad index or count)"},
    )
    return pred, (J if jac else None)


def deflection_lm(
    chain: dict,
    enc: dict,
    q: np.ndarray,
    w: np.ndarray,
    p: np.ndarray,
    y: np.ndarray,
    wrow: np.ndarray,
    neg: np.ndarray,
    nlmask: np.ndarray,
    inv: np.ndarray,
    theta: np.ndarray,
    maxit: int,
    ftol: float,
    xtol: float,
    gtol: float,
) -> tuple[np.ndarray, int, int]:
    """The nonlinear fit of the deflection model by the core's
    Levenberg-Marquardt in one call (core/sk_deflect_fit.f90): the weighted
    data y (nrows * n,), the row weights wrow (nrows,), the masks (npar,)
    of parameters not excited, nonlinear and compensated joint compliances,
    the start theta. Returns (theta, iterations, reason; LM_REASONS)."""
    th, niter, reason, info = call(
        _calib.sk_deflection_lm,
        "sk_deflection_lm",
        **chain,
        **enc,
        q=q,
        w=w,
        p=p,
        y=np.asarray(y, float),
        wrow=np.asarray(wrow, float),
        neg=np.asarray(neg, np.int32),
        nlmask=np.asarray(nlmask, np.int32),
        inv=np.asarray(inv, np.int32),
        maxit=int(maxit),
        ftol=float(ftol),
        xtol=float(xtol),
        gtol=float(gtol),
        theta=np.array(theta, float),
    )
    check(
        info,
        "deflection fit (sk_deflection_lm)",
        {1: "the data, weights or masks do not match the model", 6: "the model's terms are inconsistent"},
    )
    return th, int(niter), int(reason)


def joint_secant(enc: dict, q: np.ndarray, tau: np.ndarray | None = None) -> np.ndarray:
    """Compliance (ns, N) of every joint spring of a known model at postures
    q (ndof, N): at zero load, or the secant under the torques tau (ns, N)
    (core/sk_deflect.f90)."""
    ns = len(enc["stype"])
    cj, info = call(
        _calib.sk_joint_secant,
        "sk_joint_secant",
        enc["stype"],
        enc["tint"],
        enc["tgeo"],
        enc["par"],
        q,
        np.zeros((ns, q.shape[1]), order="F") if tau is None else np.asfortranarray(tau, float),
        int(tau is not None),
    )
    check(info, "joint compliances (sk_joint_secant)", {6: "the model's terms are inconsistent"})
    return cj


def compensator_h(q: np.ndarray, g: dict) -> np.ndarray:
    """d2V/dq2 per unit k_s of a gravity compensator of geometry g (a, b,
    beta, s0) at joint angles q (docs/calibration.md section 2; core/sk_deflect.f90)."""
    q = np.asarray(q, float)
    h = _calib.sk_compensator_h(q.ravel(), float(g["a"]), float(g["b"]), float(g["beta"]), float(g["s0"]))
    return h.reshape(q.shape)


def wls(a: np.ndarray, y: np.ndarray, rcond: float, gtol: float) -> tuple:
    """Weighted least squares by a scaled rank-revealing SVD with M4a groups.

    Returns (theta, stdu, s, v, rank, group, res)."""
    theta, stdu, s, v, rank, group, res, info = call(_calib.sk_wls, "sk_wls", np.asfortranarray(a), y, rcond, gtol)
    check(info, "weighted least squares (sk_wls)", {8: "fewer observations than parameters"})
    return theta, stdu, s, v, int(rank), group, res


def qr_r(a: np.ndarray) -> np.ndarray:
    """The triangular factor R (n, n) of the QR decomposition of a (m, n):
    R^T R = a^T a. With fewer rows than columns, a is padded with zero rows
    (the same R^T R)."""
    a = np.asarray(a, float)
    m, n = a.shape
    if m < n:
        a = np.vstack([a, np.zeros((n - m, n))])
    r, info = call(_calib.sk_qr_r, "sk_qr_r", np.asfortranarray(a))
    check(info, "QR factor (sk_qr_r)")
    return r


def score(
    a: np.ndarray, r: np.ndarray, z: np.ndarray, cstart: np.ndarray, rcond: float, ztol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Score statistics, degrees of freedom and projected ranks of candidate
    column blocks z[:, cstart[c]-1 : cstart[c+1]-1] against the model a."""
    stat, dof, pr, info = call(
        _calib.sk_score,
        "sk_score",
        np.asfortranarray(a),
        r,
        np.asfortranarray(z),
        np.asarray(cstart, np.int32),
        rcond,
        ztol,
    )
    check(info, "score tests (sk_score)")
    return stat, dof, pr


def neighbour_correlation(
    x: np.ndarray,
    e: np.ndarray,
    w: np.ndarray,
    group: np.ndarray,
    cls: np.ndarray,
    nperm: int = 999,
    seed: int = 12345,
) -> tuple[float, float, np.ndarray]:
    """Is the residual ``e`` (n, k) a function of ``x`` (n, d), or noise?
    (rho, p-value, nn): rho, the correlation of every point's residual with
    that of its nearest point by x among the points of the same class
    ``cls`` (n,) and another ``group`` (n,) (weights ``w`` > 0 only); the
    p-value of ``nperm`` random pairings; nn (n,) the neighbour of each
    point (-1: none)."""
    x = np.asarray(x, float)
    e = np.asarray(e, float)
    rho, pval, nn, info = _calib.sk_neighbour_correlation(
        np.asfortranarray(x.T),
        np.asfortranarray(e.T),
        np.asarray(w, float),
        np.asarray(group, np.int32),
        np.asarray(cls, np.int32) + 1,
        int(nperm),
        int(seed),
    )
    check(info, "neighbour correlation (sk_neighbour_correlation)", {6: "nperm must be >= 1", 8: "too few points"})
    return float(rho), float(pval), nn.astype(int) - 1


def max_score(
    a: np.ndarray,
    z: np.ndarray,
    cstart: np.ndarray,
    rcond: float,
    ztol: float,
    lobs: float,
    dpe: int = 0,
    nsim: int = 999,
    seed: int = 12345,
) -> float:
    """Multiplicity-corrected p-value of the best of the candidate blocks of
    ``score``: the probability under the model (unit Gaussian noise) that
    some candidate reaches a log p-value <= ``lobs``, by ``nsim`` Monte
    Carlo draws on the candidates' projected spaces (chi-square tests, or F
    tests against ``dpe`` pure-error degrees of freedom)."""
    pval, info = _calib.sk_max_score(
        np.asfortranarray(a),
        np.asfortranarray(z),
        np.asarray(cstart, np.int32),
        rcond,
        ztol,
        float(lobs),
        int(dpe),
        int(nsim),
        int(seed),
    )
    check(info, "max-score test (sk_max_score)", {6: "nsim must be >= 1 and dpe >= 0"})
    return float(pval)


def null_relations(v: np.ndarray, nrank: int, tol: float) -> np.ndarray:
    """Sparse relations (p - nrank, p) spanning the null space of V (eq. 21)."""
    rel, info = call(_calib.sk_null_relations, "sk_null_relations", np.asfortranarray(v), int(nrank), tol)
    check(info, "coupling relations (sk_null_relations)")
    return rel


def select_independent(a: np.ndarray, order: np.ndarray, tol: float) -> np.ndarray:
    """Columns of a (in the preference order, 0-based) kept as independent: bool (p,)."""
    sel, info = call(_calib.sk_select, "sk_select", np.asfortranarray(a), np.asarray(order, np.int32) + 1, tol)
    check(info, "independent subset (sk_select)")
    return sel.astype(bool)


def chi2_logsf(x: float, k: float) -> float:
    """log P(chi2_k > x)."""
    return float(call(_calib.sk_chi2_logsf, "sk_chi2_logsf", float(x), float(k)))


def f_logsf(f: float, d1: float, d2: float) -> float:
    """log P(F(d1, d2) > f)."""
    return float(call(_calib.sk_f_logsf, "sk_f_logsf", float(f), float(d1), float(d2)))


#: why the Levenberg-Marquardt iteration stopped (core/sk_lm.f90; every fit of
#: the core shares it: sk_lm_start and the tree model's sk_tree_lm)
LM_REASONS = {
    1: "the relative decrease of the cost fell below ftol",
    2: "the step fell below xtol",
    3: "the gradient is orthogonal to the residual (gtol)",
    4: "the residual is zero",
    5: "the iteration limit was reached",
    6: "no step decreases the cost (lambda above 1e16)",
}
#: the reasons that mean convergence (the others: iteration limit, no decrease found)
LM_CONVERGED = frozenset((1, 2, 3, 4))

_LM_STATE = (
    "the iteration has stopped, the calls are out of order (step, accept, step, ...), "
    "or the state is not one that sk_lm_start returned"
)


@dataclass
class LMState:
    """The core's Levenberg-Marquardt state between the calls of the reverse
    communication: ``rstate`` and ``istate`` go back to the core unchanged
    (the wrappers replace them); ``n`` unknowns; ``reason`` 0 while the
    iteration runs, else a key of LM_REASONS; ``niter`` iterations so far
    (points at which a step was computed)."""

    rstate: np.ndarray
    istate: np.ndarray
    n: int
    reason: int = 0
    niter: int = 0

    @property
    def running(self) -> bool:
        return self.reason == 0

    @property
    def converged(self) -> bool:
        return self.reason in LM_CONVERGED


def lm_start(jac: np.ndarray, res: np.ndarray, maxit: int, ftol: float, xtol: float, gtol: float) -> LMState:
    """Start the core's Levenberg-Marquardt iteration (core/sk_lm.f90) at a
    point with Jacobian ``jac`` (m, n) and residual ``res`` (m,), the model
    minus the data (the cost is |res|^2 / 2), in the variables the caller
    iterates on. Then, while ``state.running``: ``dx = lm_step(state, x)``,
    evaluate the model at x + dx, ``lm_accept(state, jac, res)``; move to
    x + dx when it returns True. To change its variables the caller starts
    again."""
    jac = np.asfortranarray(jac, dtype=float)
    rstate, istate, reason, info = call(
        _calib.sk_lm_start,
        "sk_lm_start",
        jac,
        np.asarray(res, dtype=float),
        int(maxit),
        float(ftol),
        float(xtol),
        float(gtol),
    )
    check(
        info,
        "Levenberg-Marquardt start (sk_lm_start)",
        {1: "the residual and the Jacobian have different numbers of rows", 6: "maxit and the tolerances must be >= 0"},
    )
    return LMState(rstate, istate, jac.shape[1], int(reason), 0)


def lm_step(state: LMState, x: np.ndarray) -> np.ndarray:
    """The trial step dx (n,) from the current point ``x`` (n,): the damped
    least-squares step at the core's current lambda."""
    rstate, istate, dx, info = call(
        _calib.sk_lm_step, "sk_lm_step", state.rstate, state.istate, np.asarray(x, dtype=float)
    )
    check(info, "Levenberg-Marquardt step (sk_lm_step)", {1: f"x must have {state.n} values", 6: _LM_STATE})
    state.rstate, state.istate = rstate, istate
    return dx


def lm_accept(state: LMState, jac: np.ndarray | None, res: np.ndarray | None, ok: bool = True) -> bool:
    """The core's verdict on the last trial, given the Jacobian ``jac`` and
    residual ``res`` there (``ok=False``, jac and res None: the trial could
    not be evaluated, e.g. it lies outside the model's domain). True: the
    caller moves to the trial. ``state.reason`` and ``state.niter`` are
    updated."""
    if not ok or jac is None or res is None:
        ok, jac, res = False, np.zeros((1, state.n)), np.zeros(1)  # not read
    rstate, istate, accepted, reason, niter, info = call(
        _calib.sk_lm_accept,
        "sk_lm_accept",
        state.rstate,
        state.istate,
        int(bool(ok)),
        np.asfortranarray(jac, dtype=float),
        np.asarray(res, dtype=float),
    )
    check(
        info,
        "Levenberg-Marquardt verdict (sk_lm_accept)",
        {1: f"the Jacobian must have {state.n} columns and as many rows as the residual", 6: _LM_STATE},
    )
    state.rstate, state.istate, state.reason, state.niter = rstate, istate, int(reason), int(niter)
    return bool(accepted)
