"""Typed wrappers of the kinematic-tree core (``_tree``, core/sk_api_tree.f90):
poses and gravity forces, evaluation of absolute measurements with their
analytic Jacobian, Levenberg-Marquardt, frame Jacobians and compensation.

Every routine takes the model packed: ``pack(ne, arrays)`` with ``arrays``
the dict of arrays ``stiffkit.robot.TreeModel.arrays`` holds (the core's
1-based layout; ``TreeModel.packed`` packs its own). Indices given here are
0-based: postures, markers (rows of ``mvj``), free parameters; ``loads`` is
(posture (nl,), virtual joint (nl,) 1-based, wrench (nl, 6)) or None.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError, InputError
from . import _tree
from .calib import LM_REASONS as LM_REASONS  # why LM stopped (core/sk_lm.f90, shared)
from .tree_errors import CoreArrays as CoreArrays  # the model's arrays with labels for messages
from .tree_errors import raise_for

_DETAILS = {
    1: "the tree model's arrays are inconsistent (a parent after its child, an index out of range)",
    2: "the model or the data contain NaN or Inf",
    6: "an argument is out of range (joint type, axis not unit, law type, weight < 0)",
}

#: layout of the packed model (core/sk_tree_pack.f90, which tests/test_tree_pack.py
#: checks against these): version, the counts of the header, the integer
#: and the real arrays in their order
PACK_VERSION = 1
PACK_COUNTS = ("nv", "nk", "ne", "nb", "ng", "nm", "nbp")
PACK_INTS = ("vparent", "vtype", "qcol", "gvj", "gpar", "ktype", "kvj", "kpar", "bvj", "tpar", "mvj", "mpar", "bpar")
PACK_REALS = ("vaxis", "vrot", "vpos", "qcoef", "qconst", "gcoef", "kw0", "bmass", "bcom", "grav", "rref")
PACK_HEADER = 1 + len(PACK_COUNTS) + len(PACK_INTS) + 1 + len(PACK_REALS) + 1


@dataclass(frozen=True)
class PackedTree:
    """A tree model packed for the core: ``mi`` (header: version, counts,
    offsets; then the integer arrays) and ``mr`` (the real arrays), each
    array in Fortran order; ``ne`` its elastic coordinates and ``arrays``
    the arrays it was packed from (their labels name joints and parameters
    in error messages)."""

    mi: np.ndarray
    mr: np.ndarray
    ne: int
    arrays: Mapping


def _flat(a: object, dtype: type) -> np.ndarray:
    return np.asarray(a, dtype=dtype).ravel(order="F")


def pack(ne: int, arrays: Mapping) -> PackedTree:
    """The model of ``arrays`` (a TreeModel's; ``bpar`` may be absent: no
    gravity parameters) with ``ne`` elastic coordinates, packed for the
    core (layout: core/sk_tree_pack.f90). The core checks the arrays
    (sizes, values) and names the argument and index of an error."""
    a = dict(arrays)
    a.setdefault("bpar", np.zeros((3, 0), np.int32))
    counts = {
        "nv": len(a["vparent"]),
        "nk": len(a["ktype"]),
        "ne": int(ne),
        "nb": len(a["bvj"]),
        "ng": len(a["gvj"]),
        "nm": len(a["mvj"]),
        "nbp": np.shape(a["bpar"])[1],
    }
    ints = [_flat(a[k], np.int32) for k in PACK_INTS]
    reals = [_flat(a[k], np.float64) for k in PACK_REALS]
    ioff = PACK_HEADER + 1 + np.concatenate([[0], np.cumsum([x.size for x in ints])])
    roff = 1 + np.concatenate([[0], np.cumsum([x.size for x in reals])])
    header = np.concatenate([[PACK_VERSION], [counts[k] for k in PACK_COUNTS], ioff, roff]).astype(np.int32)
    mi = np.concatenate([header, *ints]).astype(np.int32)
    mr = np.concatenate(reals).astype(np.float64)
    return PackedTree(mi=mi, mr=mr, ne=int(ne), arrays=arrays)


def _i(a: object) -> np.ndarray:
    return np.asfortranarray(np.asarray(a, dtype=np.int32))


def _f(a: object) -> np.ndarray:
    return np.asfortranarray(np.asarray(a, dtype=float))


def _prior(prior: tuple | None) -> dict:
    """Prior rows psw (theta[ppar] - pmu) of the fit: (indices 0-based,
    centres, sqrt weights) or None."""
    if prior is None or len(prior[0]) == 0:
        return {"ppar": _i(np.zeros(0)), "pmu": _f(np.zeros(0)), "psw": _f(np.zeros(0))}
    idx, mu, sw = prior
    return {"ppar": _i(np.asarray(idx) + 1), "pmu": _f(mu), "psw": _f(sw)}


def _loads(loads: tuple | None) -> dict:
    if loads is None or len(loads[0]) == 0:
        return {"lpost": _i(np.zeros(0)), "lvj": _i(np.zeros(0)), "lw": _f(np.zeros((6, 0)))}
    post, vj, w = loads
    return {"lpost": _i(np.asarray(post) + 1), "lvj": _i(vj), "lw": _f(np.asarray(w, float).T)}


def _obs(posture: np.ndarray, marker: np.ndarray, xyz: np.ndarray, weight: np.ndarray) -> dict:
    return {
        "opost": _i(np.asarray(posture) + 1),
        "omark": _i(np.asarray(marker) + 1),
        "oxyz": _f(np.asarray(xyz, float).T),
        "owt": _f(weight),
    }


def _check(info: int, errloc: object, routine: str, given: dict) -> None:
    """Raise for info, naming the argument and index the core located (tree_errors)."""
    raise_for(info, errloc, routine, given, _DETAILS)


def poses(
    model: PackedTree, theta: np.ndarray, q: np.ndarray, loads: tuple | None, eqit: int, etol: float
) -> dict[str, np.ndarray]:
    """Frames after motion ``ra`` (np, nv, 3, 3), ``pa`` (np, nv, 3), generalised
    gravity forces ``wv`` (np, nv) and per joint coordinate ``tauq`` (np, ndof),
    deflections ``delta`` (np, ne), ``nit``, ``eqinfo`` (np,) at postures q (np, ndof)."""
    args = dict(theta=_f(theta), q=_f(np.asarray(q, float).T), **_loads(loads))
    ra, pa, wv, tauq, delta, nit, eqinfo, info, errloc = _tree.sk_tree_poses(
        model.mi, model.mr, **args, eqit=int(eqit), etol=float(etol)
    )
    _check(info, errloc, "tree poses (sk_tree_poses)", dict(args, model=model.arrays, ne=model.ne))
    return {
        "ra": np.transpose(ra, (3, 2, 0, 1)),
        "pa": np.transpose(pa, (2, 1, 0)),
        "wv": wv.T.copy(),
        "tauq": tauq.T.copy(),
        "delta": delta.T.copy(),
        "nit": nit,
        "eqinfo": eqinfo,
    }


def evaluate(
    model: PackedTree,
    theta: np.ndarray,
    q: np.ndarray,
    loads: tuple | None,
    posture: np.ndarray,
    marker: np.ndarray,
    xyz: np.ndarray,
    weight: np.ndarray,
    free: np.ndarray,
    eqit: int,
    etol: float,
) -> dict[str, np.ndarray]:
    """Predicted points ``pred`` (no, 3), weighted residuals ``res`` (3 no,)
    = sqrt(w) (pred - xyz) ordered point by point, their Jacobian ``jac``
    (3 no, nfree) w.r.t. theta[free], ``delta`` (np, ne), ``nit``, ``eqinfo``."""
    free = np.asarray(free, int)
    args = dict(
        theta=_f(theta),
        q=_f(np.asarray(q, float).T),
        **_loads(loads),
        **_obs(posture, marker, xyz, weight),
        free=_i(free + 1),
    )
    pred, res, jac, delta, nit, eqinfo, info, errloc = _tree.sk_tree_evaluate(
        model.mi, model.mr, **args, eqit=int(eqit), etol=float(etol)
    )
    _check(info, errloc, "tree evaluation (sk_tree_evaluate)", dict(args, model=model.arrays, ne=model.ne))
    return {"pred": pred.T.copy(), "res": res, "jac": jac, "delta": delta.T.copy(), "nit": nit, "eqinfo": eqinfo}


def lm(
    model: PackedTree,
    theta0: np.ndarray,
    q: np.ndarray,
    loads: tuple | None,
    posture: np.ndarray,
    marker: np.ndarray,
    xyz: np.ndarray,
    weight: np.ndarray,
    free: np.ndarray,
    eqit: int,
    etol: float,
    maxit: int = 100,
    ftol: float = 1e-12,
    xtol: float = 1e-12,
    gtol: float = 1e-12,
    prior: tuple | None = None,
) -> dict:
    """Levenberg-Marquardt on theta[free] from theta0: ``theta``, ``hist``
    (cost after each accepted step), ``niter``, ``reason`` (LM_REASONS),
    ``converged``, ``jac`` and ``res`` at theta, and ``rref``: the core
    re-centres the tracker rotation after every accepted step, so the
    returned tracker angles are 0 and the tracker's rotation is ``rref``.
    Not converging (reasons 5, 6) is reported, not raised: theta is then
    the best found. ``prior``: (indices 0-based, centres, sqrt weights),
    rows sw (theta[i] - mu) added to the residual (``jac``, ``res`` hold
    the data rows only)."""
    free = np.asarray(free, int)
    if free.size == 0:
        raise InputError("no free parameter to fit")
    args = dict(
        theta0=_f(theta0),
        q=_f(np.asarray(q, float).T),
        **_loads(loads),
        **_obs(posture, marker, xyz, weight),
        free=_i(free + 1),
        **_prior(prior),
    )
    theta, hist, nhist, niter, reason, jac, res, rref, info, errloc = _tree.sk_tree_lm(
        model.mi,
        model.mr,
        **args,
        eqit=int(eqit),
        etol=float(etol),
        maxit=int(maxit),
        ftol=float(ftol),
        xtol=float(xtol),
        gtol=float(gtol),
    )
    if info != 7:
        given = dict(args, model=model.arrays, ne=model.ne, theta=args["theta0"])
        _check(info, errloc, "Levenberg-Marquardt (sk_tree_lm)", given)
    return {
        "theta": theta,
        "hist": hist[:nhist].copy(),
        "niter": int(niter),
        "reason": int(reason),
        "converged": info == 0,
        "jac": jac,
        "res": res,
        "rref": rref,
    }


def compliance(
    model: PackedTree, theta: np.ndarray, frame: int, q: np.ndarray, vary: tuple | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Compliance C (np, 6, 6) of virtual joint ``frame``'s frame (1-based;
    base axes, about its origin) at postures q (np, ndof) with the
    parameters theta (npar,), at the undeflected frames with every law's
    tangent at zero load (core/sk_tree_point.f90); ``vary``: (indices
    (nvar,) 0-based, values (np, nvar)), parameters that take a value per
    posture. Returns C, its stiffness K (np, 6, 6; zero where C is
    singular), rank (np,) and kinfo (np,: 0 where K = C^-1)."""
    q = np.asarray(q, float)
    idx, val = (np.zeros(0, int), np.zeros((len(q), 0))) if vary is None else vary
    if len(idx) == 0:  # f2py takes no empty (0, np) array: parameter 1 varies to its own value
        idx, val = [0], np.full((len(q), 1), float(np.asarray(theta, float).ravel()[0]))
    args = dict(theta=_f(theta), vidx=_i(np.asarray(idx) + 1), vval=_f(np.asarray(val, float).T), q=_f(q.T))
    c, k, rank, kinfo, info, errloc = _tree.sk_tree_compliance(model.mi, model.mr, **args, frame=int(frame))
    _check(info, errloc, "compliance (sk_tree_compliance)", dict(args, model=model.arrays, ne=model.ne))
    return np.transpose(c, (2, 0, 1)), np.transpose(k, (2, 0, 1)), rank, kinfo


def twists(model: PackedTree, theta: np.ndarray, frame: int, q: np.ndarray) -> np.ndarray:
    """Twists g (6, ne) of virtual joint ``frame``'s frame (1-based; about its
    origin, base axes) per unit elastic coordinate at posture q (ndof,),
    undeflected (core/sk_tree_point.f90): the columns of every spring's
    Jacobian, in the blocks' order."""
    args = dict(theta=_f(theta), q=_f(np.asarray(q, float).ravel()))
    g, info, errloc = _tree.sk_tree_twists(model.mi, model.mr, **args, frame=int(frame))
    _check(info, errloc, "twists (sk_tree_twists)", dict(args, model=model.arrays, ne=model.ne))
    return g


def frame_jacobian(
    model: PackedTree,
    theta: np.ndarray,
    frame: np.ndarray,
    q: np.ndarray,
    loads: tuple | None,
    eqit: int,
    etol: float,
) -> dict[str, np.ndarray]:
    """Pose (``R`` (np, 3, 3), ``p`` (np, 3), base) of virtual joint frame[i]
    (1-based) at postures q (np, ndof), at equilibrium, and its total Jacobian
    ``J`` (np, 6, ndof) w.r.t. q (origin velocity, angular velocity)."""
    args = dict(theta=_f(theta), frame=_i(frame), q=_f(np.asarray(q, float).T), **_loads(loads))
    rf, pf, jq, delta, nit, eqinfo, info, errloc = _tree.sk_tree_frame_jacobian(
        model.mi, model.mr, **args, eqit=int(eqit), etol=float(etol)
    )
    _check(info, errloc, "frame Jacobian (sk_tree_frame_jacobian)", dict(args, model=model.arrays, ne=model.ne))
    return {
        "R": np.transpose(rf, (2, 0, 1)),
        "p": pf.T.copy(),
        "J": np.transpose(jq, (2, 0, 1)),
        "delta": delta.T.copy(),
        "nit": nit,
        "eqinfo": eqinfo,
    }


def compensate(
    model: PackedTree,
    theta: np.ndarray,
    frame: np.ndarray,
    qcmd: np.ndarray,
    rtarget: np.ndarray,
    ptarget: np.ndarray,
    loads: tuple | None,
    full6: bool,
    eqit: int,
    etol: float,
    maxit: int = 50,
    ptol: float = 1e-12,
    rtol: float = 1e-12,
    row_params: tuple | None = None,
) -> dict[str, np.ndarray]:
    """Joint commands ``q`` (nr, ndof) that put virtual joint frame[i] (1-based)
    at (rtarget[i], ptarget[i]) (base axes): the pose when ``full6``, else
    the position; ``resp`` (m), ``resr`` (rad) left, ``nit``, ``rinfo`` per row.
    ``row_params``: (indices (k,) 0-based into theta, values (nr, k)), law
    parameters that take a value per row (a posture-dependent compliance)."""
    nr = np.shape(qcmd)[0]
    if row_params is None:
        prow, trow = np.zeros(0, np.int32), np.zeros(0)
    else:
        prow = _i(np.asarray(row_params[0]) + 1)
        trow = _f(np.asarray(row_params[1], float).reshape(nr, prow.size).ravel())
    args = dict(
        theta=_f(theta),
        frame=_i(frame),
        qcmd=_f(np.asarray(qcmd, float).T),
        rtarget=_f(np.transpose(np.asarray(rtarget, float), (1, 2, 0))),
        ptarget=_f(np.asarray(ptarget, float).T),
        **_loads(loads),
        prow=prow,
        trow=trow,
    )
    qout, resp, resr, nit, rinfo, info, errloc = _tree.sk_tree_compensate(
        model.mi,
        model.mr,
        **args,
        full6=int(bool(full6)),
        eqit=int(eqit),
        etol=float(etol),
        maxit=int(maxit),
        ptol=float(ptol),
        rtol=float(rtol),
    )
    if info == 7:
        raise ConvergenceError("compensation (sk_tree_compensate): the Newton iteration did not converge")
    _check(
        info, errloc, "compensation (sk_tree_compensate)", dict(args, model=model.arrays, ne=model.ne, q=args["qcmd"])
    )
    return {"q": qout.T.copy(), "resp": resp, "resr": resr, "nit": nit, "rinfo": rinfo}
