"""Data checks, robust fit, cross-validation and the max-score test on
generic inputs (no robot, no Problem): what another calibration (e.g.
absolute tracker data) would call."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stiffkit._core import calib as core
from stiffkit.calib import checks as C
from stiffkit.calib import crossval as CV


def _rows(n=240, k=3, seed=0):
    rng = np.random.default_rng(seed)
    labels = [f"c{i // 8}" for i in range(n)]  # 30 configurations of 8 rows
    return rng, rng.normal(size=(n, k)), labels


def test_gross_rows_found_and_nothing_else():
    rng, r, labels = _rows()
    bad = [5, 77, 130, 131, 200]  # 130 and 131 share a configuration, not a load
    r[bad] += 40 * rng.normal(size=(len(bad), 3))
    flags = C.outlier_rows(r, sigma=1.0, labels=labels)
    assert sorted(f.row for f in flags) == bad
    assert all(f.log10_p < math.log10(0.01 / len(r)) for f in flags)
    # in metres with a sigma: the same rows
    assert sorted(f.row for f in C.outlier_rows(r * 2e-5, sigma=2e-5, labels=labels)) == bad


def test_model_error_spread_over_rows_is_not_a_gross_error():
    """A missing effect raises whole configurations: they stand out from the
    noise but not from their own configuration, and the rows of one load
    share the same residual vector."""
    rng, r, labels = _rows()
    for c in range(30):
        r[8 * c : 8 * c + 8] += rng.normal(scale=3.0) * 6 * rng.normal(size=3)
    groups = [f"{labels[i]}|{i // 4}" for i in range(len(r))]  # two loads of four markers
    assert C.outlier_rows(r, labels=labels, groups=groups) == []
    offs = C.outlying_configs(r, labels)
    assert offs and all(o.log10_p < math.log10(0.01 / 30) for o in offs)


def test_unit_slip_of_the_measurement_and_of_the_load():
    rng = np.random.default_rng(1)
    n = 90
    labels = [f"c{i // 9}" for i in range(n)]
    pred = rng.normal(size=(n, 3)) * 2e-3
    meas = pred + 2e-5 * rng.normal(size=(n, 3))
    load = np.full(n, 2500.0)
    meas[18:27] *= 1e3  # c2 in mm
    slips = C.unit_slips(meas, pred, labels, sigma=2e-5, load=load)
    assert [(s.config, s.factor, s.quantity) for s in slips] == [("c2", 1e3, "measured")]
    assert "mm instead of m" in slips[0].meaning and "divide" in slips[0].fix
    assert slips[0].misfit_removed > 0.999
    # the load of c5 recorded in kN: the prediction is 1000 x too small, the load 1000 x smaller
    meas2 = pred + 2e-5 * rng.normal(size=(n, 3))
    pred2, load2 = pred.copy(), load.copy()
    pred2[45:54] /= 1e3
    load2[45:54] /= 1e3
    slips = C.unit_slips(meas2, pred2, labels, sigma=2e-5, load=load2)
    assert [(s.config, s.quantity) for s in slips] == [("c5", "load")]
    assert "multiply the load" in slips[0].fix
    # rotations in degrees
    rot = C.unit_slips(meas2 * np.where(np.arange(n)[:, None] < 9, 180 / np.pi, 1.0), meas2, labels, sigma=2e-5,
                       factors=C.ANGLE_FACTORS)  # fmt: skip
    assert [(s.config, round(s.factor, 3)) for s in rot] == [("c0", round(180 / np.pi, 3))]
    assert C.unit_slips(meas2, pred, labels, sigma=2e-5, load=load) == []


def test_joint_values_in_degrees():
    q = np.zeros((6, 3))
    q[3:, 1] = 45.0
    out = C.angle_units(q, ["a"] * 3 + ["b"] * 3)
    assert [(o["config"], o["columns"]) for o in out] == [("b", ["q2"])]


@pytest.mark.parametrize("kind", ["huber", "cauchy"])
def test_irls_is_not_pulled_by_gross_rows(kind):
    """A straight line through 3-coordinate rows (one weight per row) with
    5 % gross rows: the robust fit recovers the line to the noise, the plain
    fit does not."""
    rng = np.random.default_rng(2)
    n = 100
    t = np.linspace(-1, 1, n)
    A = np.zeros((3 * n, 2))
    for c in range(3):
        A[c * n : (c + 1) * n] = np.column_stack([np.ones(n), (c + 1) * t])
    x_true = np.array([0.3, -1.2])
    b = A @ x_true + rng.normal(size=3 * n)
    rows = np.tile(np.arange(n), 3)
    for i in (10, 40, 41, 90, 95):
        b[rows == i] += 60.0
    x_plain = np.linalg.lstsq(A, b, rcond=None)[0]
    x, w, e, scale = C.irls(A, b, rows, n, kind=kind)
    assert np.abs(x - x_true).max() < 0.3 < np.abs(x_plain - x_true).max()
    assert w[[10, 40, 41, 90, 95]].max() < 0.1 < 0.5 < np.median(w)
    assert 0.9 < scale < 1.3


def test_folds_never_split_a_configuration_and_held_out_is_exact():
    rng = np.random.default_rng(3)
    labels = [f"c{i // 3}" for i in range(36)]
    folds = CV.config_folds(labels, 5)
    assert len(folds) == 5 and sorted(np.concatenate(folds)) == list(range(36))
    for f in folds:
        cfgs = {labels[i] for i in f}
        assert {i for i in range(36) if labels[i] in cfgs} == set(f)
    assert len(CV.config_folds(labels[:6], 5)) == 2  # two configurations: leave one out
    A = rng.normal(size=(72, 4))  # two coordinates per row
    b = rng.normal(size=72)
    rows = np.tile(np.arange(36), 2)
    e = CV.held_out_residuals(A, b, rows, folds)
    for f in folds:
        test = np.isin(rows, f)
        x = np.linalg.lstsq(A[~test], b[~test], rcond=None)[0]
        np.testing.assert_allclose(e[test], b[test] - A[test] @ x, atol=1e-12)
    assert CV.rms_rows(e, 36) == pytest.approx(np.sqrt(np.mean(e.reshape(2, 36) ** 2) * 2))


def test_fold_factors_give_the_held_out_residuals_of_every_column_subset():
    """One factorisation per fold of [M b] (crossval.FoldFactors) gives the
    held-out residuals of any subset of M's columns and of a right-hand side
    shifted by some columns, as a fit of each fold on those columns does:
    including a rank-deficient subset (the minimum-norm solution) and a fold
    with fewer training rows than columns (NaN)."""
    rng = np.random.default_rng(5)
    labels = [f"c{i // 3}" for i in range(60)]
    folds = CV.config_folds(labels, 4)
    rows = np.repeat(np.arange(60), 3)
    M = rng.normal(size=(180, 9)) * np.array([1.0, 1e3, 1e-3, 1, 1, 1, 1, 1, 1])  # unequal scales
    M[:, 8] = M[:, 0] - 2.0 * M[:, 3]  # a dependent column
    b = rng.normal(size=180)
    ff = CV.FoldFactors(M, b, rows, folds)
    for cols, sh, t in [
        (np.arange(8), None, None),
        (np.array([1, 2, 5]), None, None),
        (np.array([0, 3, 8, 4]), None, None),  # rank 3 of 4
        (np.array([0, 2, 6]), np.array([4, 7]), np.array([0.3, -2.0])),
        (np.zeros(0, int), np.array([1]), np.array([1e-3])),
    ]:
        rhs = b if sh is None else b + M[:, sh] @ t
        np.testing.assert_allclose(ff.held_out(cols, sh, t), CV.held_out_residuals(M[:, cols], rhs, rows, folds),
                                   rtol=1e-9, atol=1e-11)  # fmt: skip
    few = CV.FoldFactors(M[:12], b[:12], rows[:12], [np.array([0]), np.array([1, 2, 3])])
    e = few.held_out(np.arange(6))
    assert np.isnan(e[3:]).all() and np.isfinite(e[:3]).all()  # 9 rows train the first fold, 3 the second
    np.testing.assert_allclose(e, CV.held_out_residuals(M[:12, :6], b[:12], rows[:12], [[0], [1, 2, 3]]), atol=1e-11)


def test_max_score_between_best_p_and_bonferroni():
    """The corrected p of the best of m candidates lies between its own p and
    m times it; duplicating every candidate changes nothing."""
    rng = np.random.default_rng(4)
    n = 120
    a = rng.normal(size=(n, 3))
    z = rng.normal(size=(n, 12))
    cs = np.array([1, 3, 5, 7, 9, 11, 13], np.int32)  # six candidates of two columns
    lobs = math.log(1e-3)
    p = core.max_score(a, z, cs, 1e-10, 1e-6, lobs, 0, 4000, 1)
    se = math.sqrt(6e-3 / 4000)  # Monte Carlo error near the bounds
    assert 1e-3 < p < 6e-3 + 3 * se
    p2 = core.max_score(a, np.hstack([z, z]), np.concatenate([cs, cs[1:] + 12]).astype(np.int32), 1e-10, 1e-6, lobs,
                        0, 4000, 1)  # fmt: skip
    assert abs(p2 - p) < 4 * math.sqrt(p * (1 - p) / 4000)


@pytest.mark.parametrize("m, n", [(9, 4), (4, 4), (3, 6)])
def test_core_qr_factor_is_triangular_with_the_gram_matrix(m, n):
    """calib.crossval.FoldFactors' factor: R upper triangular (n, n) with
    R^T R = A^T A, also for fewer rows than columns (zero rows added)."""
    from stiffkit._core import calib as core

    A = np.random.default_rng(m * 10 + n).normal(size=(m, n))
    R = core.qr_r(A)
    assert R.shape == (n, n) and np.all(np.tril(R, -1) == 0)
    np.testing.assert_allclose(R.T @ R, A.T @ A, atol=1e-12)
