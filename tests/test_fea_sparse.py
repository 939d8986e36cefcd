"""The sparse core from Python: CalculiX matrix-file readers (fuzzed: any
text reads or raises InputError), CHOLMOD solves and the rigid coupling on
small systems with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from _profiles import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from stiffkit import InputError, SingularError
from stiffkit._core.sparse import cholmod_solve, distributing_loads, face_weights, read_dofs, read_triplets, rigid_solve


def upper_triplets(K):
    r, c = np.nonzero(np.triu(K))
    return r + 1, c + 1, K[r, c]


def test_cholmod_solve_random_spd():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(40, 40))
    K = A @ A.T + 40 * np.eye(40)
    b = rng.normal(size=(40, 6))
    x, info = cholmod_solve(*upper_triplets(K), b)
    assert np.allclose(K @ x, b, atol=1e-10)
    assert info["factor_nnz"] > 0
    with pytest.raises(SingularError):
        cholmod_solve(*upper_triplets(-K), b)


def test_rigid_solve_on_grounded_springs():
    # three nodes, each tied to ground by springs (kx, ky, kz); coupled
    # rigidly to a reference point: K_ref = sum T_i^T diag(k) T_i
    pts = np.array([[1.0, 0.2, 0.0], [1.0, -0.3, 0.4], [1.0, 0.1, -0.5], [0.5, 0.0, 0.0]])
    k = np.array([3.0, 5.0, 7.0])
    n = 12
    K = np.diag(np.tile(k, 4))
    K[9:, 9:] += 1.0  # a free node, not coupled
    p0 = np.array([1.2, 0.0, 0.1])
    ceq = np.arange(1, 10).reshape(3, 3)
    u, q, _ = rigid_solve(*upper_triplets(K), n, ceq, pts[:3] - p0)
    Kr = np.zeros((6, 6))
    for r in pts[:3] - p0:
        T = np.hstack([np.eye(3), -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])])
        Kr += T.T @ np.diag(k) @ T
    assert np.allclose(q, np.linalg.inv(Kr), rtol=1e-10)
    # coupled nodes move rigidly; the free node does not move
    assert np.allclose(u[9:], 0.0)
    r0 = pts[0] - p0
    assert np.allclose(u[0:3, 3], q[:3, 3] + np.cross(q[3:, 3], r0))


def test_distributing_resultant():
    rng = np.random.default_rng(5)
    pts = rng.normal(size=(12, 3))
    w = rng.uniform(0.1, 1.0, 12)
    p0 = np.array([0.3, -0.2, 1.0])
    g = distributing_loads(pts, w, p0)
    for j in range(6):
        f = g[j].sum(axis=0)
        m = np.cross(pts - p0, g[j]).sum(axis=0)
        assert np.allclose(np.r_[f, m], np.eye(6)[j], atol=1e-12)


def test_face_weights_square():
    x = np.array([[0, 0, 0], [0, 2, 0], [0, 2, 2], [0, 0, 2.0]])
    w, area = face_weights(x, np.array([[1, 2, 3], [1, 3, 4]]))
    assert area == pytest.approx(4.0) and w.sum() == pytest.approx(4.0)


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(InputError, match="missing, unreadable or malformed"):
        read_triplets(tmp_path / "none.sti")
    (tmp_path / "a.dof").write_text("1.1\n1.2\nfoo\n")
    with pytest.raises(InputError, match="a.dof"):
        read_dofs(tmp_path / "a.dof")


LINE = st.one_of(
    st.builds(
        lambda a, b, v: f"{a} {b} {v!r}", st.integers(-3, 50), st.integers(-3, 50), st.floats(allow_nan=False, width=64)
    ),
    st.text(alphabet="0123456789 .-+eE\t", max_size=30),
    st.just(""),
)


@settings(max_examples=examples(150), deadline=None)
@given(st.lists(LINE, max_size=20))
def test_fuzz_triplet_reader(tmp_path_factory, lines):
    p = tmp_path_factory.mktemp("fz") / "k.sti"
    p.write_text("\n".join(lines))
    try:
        rows, cols, vals, neq = read_triplets(p)
    except InputError:
        return
    assert rows.size == cols.size == vals.size >= 1
    assert rows.min() >= 1 and cols.min() >= 1 and max(rows.max(), cols.max()) == neq
