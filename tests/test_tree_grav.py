"""Gravity parameters of the tree core (core/sk_tree_grav.f90): body mass
factors (per body and shared by a subtree) and centre-of-mass offsets
enter the gravity wrench of every elastic effect; their analytic
Jacobian columns match central differences."""

from __future__ import annotations

import numpy as np
import pytest
from test_tree_core import _packed, arm, evaluate

from stiffkit._core import _tree
from stiffkit._core import errors as _errors


def arm_with_masses():
    """test_tree_core.arm with gravity parameters (entries body, slot,
    theta index; 1-based): theta 14 = mass factor of body 3, 15 = one
    factor of bodies 1 and 2 (a subtree's), 16-18 = the centre offset of
    body 2 (m, its frame), 19-21 = that of body 3, 22 = body 2's own factor
    (times the subtree's)."""
    model, theta = arm()
    entries = [(3, 1, 14), (1, 1, 15), (2, 1, 15), (2, 2, 16), (2, 3, 17), (2, 4, 18)]
    entries += [(3, 2, 19), (3, 3, 20), (3, 4, 21), (2, 1, 22)]
    model["bpar"] = np.asfortranarray(np.array(entries, np.int32).T)
    theta = np.concatenate([theta, [1.2, 0.85, 0.01, -0.02, 0.015, -0.01, 0.005, 0.02, 1.1]])
    return model, theta


@pytest.mark.parametrize("eqit", [1, 100])
def test_mass_and_com_jacobian_matches_central_differences(eqit):
    model, theta = arm_with_masses()
    q = np.random.default_rng(11).uniform(-1.2, 1.2, (3, 6))
    free = np.arange(1, theta.size + 1)
    pred, res, jac, delta, nit, eqinfo, info, _errloc = evaluate(model, theta, q, free, eqit)
    _errors.check(info, "sk_tree_evaluate")
    for k in range(13, theta.size):
        h = 1e-4 if 15 <= k <= 20 else 1e-3
        tp, tm = theta.copy(), theta.copy()
        tp[k] += h
        tm[k] -= h
        fd = (evaluate(model, tp, q, [], eqit)[1] - evaluate(model, tm, q, [], eqit)[1]) / (2 * h)
        if k == 16:  # body 2's offset along joint 2's axis y: no moment about it
            assert np.linalg.norm(fd) < 1e-12 and np.linalg.norm(jac[:, k]) < 1e-15
            continue
        assert np.linalg.norm(fd) > 1e-7  # the parameter moves the marker
        assert np.linalg.norm(fd - jac[:, k]) <= 1e-6 * np.linalg.norm(fd), k


def test_mass_factor_one_is_the_urdf_model():
    """Factors 1 and offsets 0 give the model without gravity parameters;
    a factor scales the body's weight exactly (factor 2 = mass doubled)."""
    model, theta = arm_with_masses()
    q = np.random.default_rng(2).uniform(-1, 1, (3, 4))
    th = theta.copy()
    th[[13, 14, 21]] = 1.0
    th[15:21] = 0.0
    plain = dict(model, bpar=np.zeros((3, 0), np.int32, order="F"))
    np.testing.assert_allclose(evaluate(model, th, q, [])[0], evaluate(plain, theta[:13], q, [])[0], atol=1e-15)
    th[13] = 2.0
    doubled = dict(plain, bmass=np.asfortranarray(plain["bmass"] * [1, 1, 2]))
    np.testing.assert_allclose(evaluate(model, th, q, [])[0], evaluate(doubled, theta[:13], q, [])[0], atol=1e-15)


def test_bad_gravity_parameter_index_is_an_argument_error():
    model, theta = arm_with_masses()
    for row, bad in ((0, 4), (1, 5), (2, theta.size + 1)):  # body, slot, theta index out of range
        m = dict(model, bpar=model["bpar"].copy(order="F"))
        m["bpar"][row, 0] = bad
        assert evaluate(m, theta, np.zeros((3, 2)), [1])[-2] == 6  # info (errloc last)


def test_prior_rows_pull_toward_their_centre():
    """LM with one free mass factor and no data information on it beyond
    the prior: a prior row alone fixes it at its centre; with data from
    factor 1.2 and a weak prior the fit stays at 1.2 to the prior's pull."""
    model, theta = arm_with_masses()
    q = np.random.default_rng(5).uniform(-1.2, 1.2, (3, 20))
    truth = evaluate(model, theta, q, [])[0]
    no = q.shape[1]
    nl = np.zeros(0, np.int32)

    def lm(start, sw):
        return _tree.sk_tree_lm(
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
            free=np.array([14], np.int32),
            ppar=np.array([14], np.int32),
            pmu=np.array([1.0]),
            psw=np.array([sw]),
            eqit=100,
            etol=1e-14,
            maxit=50,
            ftol=1e-15,
            xtol=1e-15,
            gtol=0.0,
        )

    start = theta.copy()
    start[13] = 1.0
    fit, *_rest, info, _errloc = lm(start, 0.0)
    _errors.check(info, "sk_tree_lm")
    assert abs(fit[13] - 1.2) < 1e-8
    jac = evaluate(model, theta, q, [14])[2][:, 0]
    sw = 1e-3 * np.linalg.norm(jac)  # a weak prior: its pull is 1e-6 of the data's
    fit, *_rest, info, _errloc = lm(start, sw)
    # the minimiser of |J (x - 1.2)|^2 + sw^2 (x - 1)^2 (linear near the truth)
    expect = (jac @ jac * 1.2 + sw**2 * 1.0) / (jac @ jac + sw**2)
    assert abs(fit[13] - expect) < 1e-9 and abs(fit[13] - 1.2) > 1e-8


def test_frame_jacobian_of_the_folded_model_takes_the_gravity_parameters_at_theta():
    """The frame pose and Jacobian (computed on the folded model) with
    gravity parameters equal those of the model whose masses and centres
    are written in."""
    model, theta = arm_with_masses()
    q = np.random.default_rng(4).uniform(-1, 1, (3, 5))
    plain = dict(model, bpar=np.zeros((3, 0), np.int32, order="F"))
    plain["bmass"] = np.asfortranarray(model["bmass"] * [0.85, 0.85 * 1.1, 1.2])
    plain["bcom"] = np.asfortranarray(model["bcom"] + np.column_stack([[0, 0, 0], theta[15:18], theta[18:21]]))
    nl = np.zeros(0, np.int32)

    def frames(m, th):
        out = _tree.sk_tree_frame_jacobian(
            *_packed(2, m), theta=th, frame=np.full(5, 4, np.int32), q=np.asfortranarray(q),
            lpost=nl, lvj=nl, lw=np.zeros((6, 0), order="F"), eqit=100, etol=1e-14,
        )  # fmt: skip
        _errors.check(out[-2], "sk_tree_frame_jacobian")
        return out[:3]

    for a, b in zip(frames(model, theta), frames(plain, theta[:13])):
        np.testing.assert_allclose(a, b, atol=1e-14)
