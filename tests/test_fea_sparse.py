"""The sparse core from Python: CalculiX matrix-file readers (fuzzed: any
text reads or raises InputError), CHOLMOD solves and the rigid coupling on
small systems with known answers."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from _profiles import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from stiffkit import InputError, SingularError
from stiffkit._core.sparse import cholmod_solve, distributing_loads, face_weights, read_dofs, read_triplets, rigid_solve
from stiffkit.fea.ccx import matrix_shim, run_ccx


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


def test_triplet_values_read_exactly(tmp_path):
    # the fast path (ccx's "%.13e": 14 digits, small exponents) and the
    # strtod fallback (long mantissas, large exponents) give Python's float
    rng = np.random.default_rng(11)
    v = np.concatenate([rng.normal(size=300) * 10.0 ** rng.integers(-30, 30, 300), [0.0, -0.0, 1e-300, 5e307]])
    texts = [f"{x:.13e}" for x in v[:200]] + [repr(float(x)) for x in v[200:250]] + [f"{x:.25e}" for x in v[250:]]
    p = tmp_path / "k.sti"
    p.write_text("".join(f"{i + 1} {i + 2} {t}\n" for i, t in enumerate(texts)))
    rows, cols, vals, neq = read_triplets(p)
    assert neq == len(texts) + 1 and (rows == np.arange(1, len(texts) + 1)).all() and (cols == rows + 1).all()
    assert [float(t) for t in texts] == vals.tolist()


def _block_chain(nn, rng):
    """SPD stiffness of a chain of nn 3-dof nodes (3x3 blocks, a grounded
    first node): equal column patterns within each node."""
    K = np.zeros((3 * nn, 3 * nn))
    for i in range(nn - 1):
        A = rng.normal(size=(3, 3))
        k = A @ A.T + 3 * np.eye(3)
        s = slice(3 * i, 3 * i + 6)
        K[s, s] += np.block([[k, -k], [-k, k]])
    K[:3, :3] += 5 * np.eye(3)
    return K


def test_node_graph_ordering_solves_block_matrices():
    # sk_analyze orders the node graph (3 equations a vertex): same answers
    rng = np.random.default_rng(4)
    K = _block_chain(30, rng)
    b = rng.normal(size=(90, 6))
    x, _ = cholmod_solve(*upper_triplets(K), b)
    assert np.allclose(x, np.linalg.solve(K, b), rtol=1e-9, atol=1e-12)
    p0, pts = np.zeros(3), rng.normal(size=(4, 3))
    ceq = np.arange(79, 91).reshape(4, 3)  # the last four nodes, rigidly coupled
    _u, q, _ = rigid_solve(*upper_triplets(K), 90, ceq, pts - p0)
    T = np.zeros((90, 84 - 6 + 6))
    T[:78, :78] = np.eye(78)
    for i, r in enumerate(pts - p0):
        T[78 + 3 * i : 81 + 3 * i, 78:81] = np.eye(3)
        T[78 + 3 * i : 81 + 3 * i, 81:] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    Kr = T.T @ K @ T
    assert np.allclose(q, np.linalg.inv(Kr)[78:, 78:], rtol=1e-8)


def _two_hex_deck(path):
    """Two C3D8 bricks, clamped at x = 0: a MATRIXSTORAGE deck."""
    ids = {(x, y, z): 1 + 4 * x + 2 * y + z for x in range(3) for y in range(2) for z in range(2)}
    lines = ["*NODE, NSET=NALL"] + [f"{n}, {0.01 * x}, {0.01 * y}, {0.01 * z}" for (x, y, z), n in ids.items()]
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=EALL")
    for x in range(2):
        c = [(x, 0, 0), (x + 1, 0, 0), (x + 1, 1, 0), (x, 1, 0), (x, 0, 1), (x + 1, 0, 1), (x + 1, 1, 1), (x, 1, 1)]
        lines.append(f"{x + 1}, " + ", ".join(str(ids[t]) for t in c))
    lines += ["*NSET, NSET=NFIX", ", ".join(str(ids[(0, y, z)]) for y in range(2) for z in range(2))]
    lines += ["*MATERIAL, NAME=M", "*ELASTIC", "2e11, 0.3", "*DENSITY", "7850"]
    lines += ["*SOLID SECTION, ELSET=EALL, MATERIAL=M"]
    lines += ["*BOUNDARY", "NFIX, 1, 3", "*STEP", "*FREQUENCY, SOLVER=MATRIXSTORAGE", "1", "*END STEP"]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.skipif(shutil.which("ccx") is None, reason="needs CalculiX ccx")
def test_matrix_shim_writes_exact_binary_stiffness(tmp_path, monkeypatch):
    # ccx with core/sk_ccxio.c preloaded and STIFFKIT_EXACT_K=1: binary .sti
    # (the text's values to its 14 digits), no mass matrix; without, text
    shim = matrix_shim()
    assert shim is not None
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    run_ccx(_two_hex_deck(tmp_path / "a" / "k.inp"))
    monkeypatch.setenv("STIFFKIT_EXACT_K", "1")
    run_ccx(_two_hex_deck(tmp_path / "b" / "k.inp"), preload=shim)
    text, binary = tmp_path / "a" / "k.sti", tmp_path / "b" / "k.sti"
    assert binary.read_bytes().startswith(b"SKSTI-BINARY-1\n") and not text.read_bytes().startswith(b"SK")
    assert (tmp_path / "b" / "k.mas").stat().st_size == 0 < (tmp_path / "a" / "k.mas").stat().st_size
    rt, ct, vt, nt = read_triplets(text)
    rb, cb, vb, nb = read_triplets(binary)
    assert nt == nb == 24 and (rt == rb).all() and (ct == cb).all()
    assert [float(f"{v:.13e}") for v in vb] == vt.tolist()
    binary.write_bytes(binary.read_bytes()[:-3])  # a truncated record
    with pytest.raises(InputError):
        read_triplets(binary)


@pytest.mark.skipif(shutil.which("ccx") is None, reason="needs CalculiX ccx")
def test_matrix_shim_default_keeps_text_stiffness(tmp_path, monkeypatch):
    # by default the shim only drops the mass matrix: K stays ccx's text
    monkeypatch.delenv("STIFFKIT_EXACT_K", raising=False)
    run_ccx(_two_hex_deck(tmp_path / "k.inp"), preload=matrix_shim())
    assert (tmp_path / "k.mas").stat().st_size == 0
    rows, _c, _v, neq = read_triplets(tmp_path / "k.sti")
    assert neq == 24 and (tmp_path / "k.sti").read_bytes()[:2] == b"1 "
