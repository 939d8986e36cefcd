"""Typed wrappers of the generalised-spring and stiffness-index core
(``_springs``, core/sk_api_springs.f90)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import _springs
from .errors import call, check

_TREE_DETAILS = {
    6: "the tree is malformed (empty series/parallel, bad leaf index or joint type) "
    "or lscale <= 0 or rcond outside [0, 1)",
    2: "a spring matrix or joint compliance contains NaN or Inf",
    9: "a spring matrix has a negative eigenvalue or a joint a negative compliance: not a physical spring",
}


def spring_tree(
    prog: np.ndarray,
    lkind: np.ndarray,
    lmat: np.ndarray,
    lrot: np.ndarray,
    lpos: np.ndarray,
    jtype: np.ndarray,
    jcomp: np.ndarray,
    jpassive: np.ndarray,
    jaxis: np.ndarray,
    jpoint: np.ndarray,
    tpos: np.ndarray,
    trot: np.ndarray,
    lscale: float,
    rcond: float,
) -> tuple:
    """Evaluate a postfix spring-tree program at np postures (sk_springs).

    Returns (c, k, free, nfree, rigid, nrigid, ratio) with the 6x6 arrays as
    (np, 6, 6)."""
    c, k, free, nfree, rigid, nrigid, ratio, info = call(
        _springs.sk_spring_tree,
        "evaluate (sk_spring_tree)",
        prog,
        lkind,
        lmat,
        lrot,
        lpos,
        jtype,
        jcomp,
        jpassive,
        jaxis,
        jpoint,
        tpos,
        trot,
        float(lscale),
        float(rcond),
    )
    check(info, "evaluate (sk_spring_tree)", _TREE_DETAILS)
    mv = lambda a: np.moveaxis(a, 2, 0)  # noqa: E731
    return mv(c), mv(k), mv(free), nfree, mv(rigid), nrigid, ratio


def stiffness_indices(k: np.ndarray, lscale: float) -> tuple:
    """kappa_t, kappa_r (N,), lambda_f, lambda_n (N, 3) of N stiffness matrices (N, 6, 6)."""
    kt, kr, lf, ln, info = call(
        _springs.sk_stiffness_indices, "stiffness_indices (sk_stiffness_indices)", np.moveaxis(k, 0, 2), float(lscale)
    )
    check(
        info,
        "stiffness_indices (sk_stiffness_indices)",
        {6: f"lscale must be > 0, got {lscale}", 2: "the stiffness contains NaN or Inf"},
    )
    return kt, kr, lf.T, ln.T


def rotate6(rot: np.ndarray, c: np.ndarray) -> np.ndarray:
    """diag(R,R) c diag(R,R)^T: a 6x6 compliance or stiffness given in a
    frame whose axes are the columns of R, expressed in the outer frame
    (sk_spatial::rotate6). One (3,3) and (6,6), or N of each: (N,3,3), (N,6,6);
    one R may serve N matrices and one matrix N rotations."""
    rot = np.asarray(rot, dtype=float)
    c = np.asarray(c, dtype=float)
    if rot.shape[-2:] != (3, 3) or c.shape[-2:] != (6, 6) or rot.ndim > 3 or c.ndim > 3:
        raise InputError(f"rotate6: rot must be (3,3) or (N,3,3) and c (6,6) or (N,6,6), got {rot.shape}, {c.shape}")
    single = rot.ndim == 2 and c.ndim == 2
    n = max(rot.shape[0] if rot.ndim == 3 else 1, c.shape[0] if c.ndim == 3 else 1)
    try:
        r3 = np.broadcast_to(rot, (n, 3, 3))
        c3 = np.broadcast_to(c, (n, 6, 6))
    except ValueError:
        raise InputError(f"rotate6: {rot.shape[0]} rotations for {c.shape[0]} matrices") from None
    cr, info = call(_springs.sk_rotate6, "rotate6 (sk_rotate6)", np.moveaxis(r3, 0, 2), np.moveaxis(c3, 0, 2))
    check(info, "rotate6 (sk_rotate6)", {2: "a rotation or a 6x6 matrix contains NaN or Inf"})
    cr = np.moveaxis(cr, 2, 0)
    return cr[0] if single else cr


def psd_defect(m: np.ndarray) -> tuple[np.ndarray, float]:
    """How far each 6x6 spring of m (6,6) or (N,6,6) is from positive
    semi-definite, unit-free (sk_small_sym::psd_defect): (dmin (N,), tol);
    dmin < -tol means a negative eigenvalue (not a physical spring)."""
    m = np.asarray(m, dtype=float)
    m3 = m[None] if m.ndim == 2 else m
    if m3.ndim != 3 or m3.shape[1:] != (6, 6):
        raise InputError(f"psd_defect: expected (6,6) or (N,6,6), got {m.shape}")
    dmin, tol = call(_springs.sk_psd_defect, "psd_defect (sk_psd_defect)", np.moveaxis(m3, 0, 2))
    return dmin, float(tol)
