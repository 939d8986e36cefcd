"""The kinematic-tree core through its Python contract (bindings/_tree.pyf).

The Fortran tests (tests/core/test_tree.f90) check the numerics in depth;
these prove the Python path: argument order, hidden sizes, 1-based indices,
Fortran-ordered outputs and the mapping of ``info`` to exceptions.
"""

from __future__ import annotations

import numpy as np
import pytest

import stiffkit
from stiffkit._core import _tree
from stiffkit._core import errors as _errors
from stiffkit._core.tree import pack


def rot(axis, angle):
    """Rotation matrix about a unit axis."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]], float)
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def arm():
    """A 3R arm (z, y, y) with a fixed tool, joint compliance on joints 2
    and 3 (linear and cubic), masses, a tracker and one marker on the tool.
    Parameters: tracker 0-5, marker 6-8, joint-2 offset 9, c2 10, c3 11,
    c3' 12 (cubic)."""
    z, y = np.array([0.0, 0, 1]), np.array([0.0, 1, 0])
    m = dict(
        vparent=[0, 1, 2, 3],
        vtype=[1, 1, 1, 0],
        vaxis=np.column_stack([z, y, y, np.zeros(3)]),
        vrot=np.stack([rot(y, 0.1), np.eye(3), rot(z, -0.2), np.eye(3)], axis=2),
        vpos=np.column_stack([[0, 0, 0.4], [0.05, 0, 0.3], [0.6, 0, 0], [0.5, 0, 0.02]]),
        qcol=[1, 2, 3, 0],
        qcoef=[1.0, 1, 1, 0],
        qconst=[0.0, 0, 0, 0],
        gvj=[2],
        gpar=[10],
        gcoef=[1.0],
        ktype=[1, 2],
        kvj=np.zeros((6, 2), int),
        kpar=np.zeros((21, 2), int),
        kw0=[1.0, 1.0],
        bvj=[1, 2, 3],
        bmass=[10.0, 8.0, 5.0],
        bcom=np.column_stack([[0, 0, 0.1], [0.3, 0, 0], [0.25, 0.02, 0]]),
        grav=[0, 0, -9.81],
        tpar=[1, 2, 3, 4, 5, 6],
        rref=rot(z, 1.0),
        mvj=[4],
        mpar=np.array([[7], [8], [9]]),
        bpar=np.zeros((3, 0), int),  # no gravity parameters (core/sk_tree_grav.f90)
    )
    m["kvj"][0] = [2, 3]
    m["kpar"][0] = [11, 12]
    m["kpar"][1, 1] = 13
    theta = np.array([1.5, -0.5, 0.2, 0.05, -0.1, 0.2, 0.03, 0.01, -0.02, 0.01, 5e-5, 6e-5, 3e-8])
    arrays = {
        k: (
            np.asfortranarray(v, dtype=np.int32)
            if np.asarray(v).dtype.kind == "i"
            else np.asfortranarray(v, dtype=float)
        )
        for k, v in m.items()
    }
    return arrays, theta


def _packed(ne, model):
    """The model's arrays packed for the core (bindings/tree.py ``pack``): mi, mr."""
    p = pack(ne, model)
    return p.mi, p.mr


def evaluate(model, theta, q, free, eqit=100):
    no = q.shape[1]
    nl = np.zeros(0, np.int32)
    out = _tree.sk_tree_evaluate(
        *_packed(2, model),
        theta=theta,
        q=np.asfortranarray(q),
        lpost=nl,
        lvj=nl,
        lw=np.zeros((6, 0), order="F"),
        opost=np.arange(1, no + 1, dtype=np.int32),
        omark=np.ones(no, np.int32),
        oxyz=np.zeros((3, no), order="F"),
        owt=np.ones(no),
        free=np.asarray(free, np.int32),
        eqit=eqit,
        etol=1e-15,
    )
    return out


def test_jacobian_matches_central_differences():
    model, theta = arm()
    rng = np.random.default_rng(7)
    q = rng.uniform(-1.2, 1.2, (3, 6))
    free = np.arange(1, theta.size + 1)
    pred, res, jac, delta, nit, eqinfo, info, _errloc = evaluate(model, theta, q, free)
    _errors.check(info, "sk_tree_evaluate")
    assert np.all(eqinfo == 0) and np.max(np.abs(delta)) > 1e-3  # deflections matter
    np.testing.assert_allclose(res, pred.T.ravel())  # weights 1, measured 0
    for k in range(theta.size):
        h = 1e-2 * abs(theta[k]) if k >= 10 else 1e-5
        tp, tm = theta.copy(), theta.copy()
        tp[k] += h
        tm[k] -= h
        fd = (evaluate(model, tp, q, [])[1] - evaluate(model, tm, q, [])[1]) / (2 * h)
        assert np.linalg.norm(fd - jac[:, k]) <= 1e-6 * np.linalg.norm(fd), k


def test_bad_input_maps_to_input_error():
    model, theta = arm()
    model["vparent"] = np.array([0, 1, 3, 2], np.int32)  # parent after its child
    *_out, info, errloc = evaluate(model, theta, np.zeros((3, 2)), [1])
    assert info == 6
    assert list(errloc) == [1, 3]  # vparent of virtual joint 3
    with pytest.raises(stiffkit.InputError, match="sk_tree_evaluate"):
        _errors.check(info, "sk_tree_evaluate")


def test_lm_recovers_tracker_and_compliance():
    model, theta = arm()
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.2, 1.2, (3, 25))
    truth = evaluate(model, theta, q, [])[0]
    no = q.shape[1]
    nl = np.zeros(0, np.int32)
    free = np.array([1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12], np.int32)
    start = theta.copy()
    start[:3] += [0.01, -0.02, 0.01]
    start[3:6] += 0.02
    start[10:12] *= 1.3
    out = _tree.sk_tree_lm(
        *_packed(2, model),
        theta0=start,
        q=np.asfortranarray(q),
        lpost=nl,
        lvj=nl,
        lw=np.zeros((6, 0), order="F"),
        opost=np.arange(1, no + 1, dtype=np.int32),
        omark=np.ones(no, np.int32),
        oxyz=np.asfortranarray(truth),
        owt=np.ones(no),
        free=free,
        ppar=nl,
        pmu=np.zeros(0),
        psw=np.zeros(0),
        eqit=100,
        etol=1e-14,
        maxit=50,
        ftol=1e-14,
        xtol=1e-14,
        gtol=0.0,
    )
    fit, hist, nhist, niter, reason, jac, res, rref, info, _errloc = out
    _errors.check(info, "sk_tree_lm")
    assert hist[nhist - 1] < 1e-24 and np.all(np.diff(hist[:nhist]) <= 0)
    # the tracker rotation comes back re-centred: rref * Rx Ry Rz of the truth
    a = theta[3:6]
    rx, ry, rz = (rot(np.eye(3)[k], a[k]) for k in range(3))
    np.testing.assert_allclose(rref, model["rref"] @ rx @ ry @ rz, atol=1e-9)
    np.testing.assert_allclose(fit[[0, 1, 2, 6, 7, 8]], theta[[0, 1, 2, 6, 7, 8]], atol=1e-9)
    np.testing.assert_allclose(fit[10:12], theta[10:12], rtol=1e-7)
