"""Python face of the sparse core (core/sk_ccxread.c, sk_cholmod.c,
sk_sparse.f90, sk_coupling.f90): CalculiX matrix files, one CHOLMOD
factorisation for several load cases, and the distributing coupling of a
reference point."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from . import _sparse
from .errors import call, check

_IO = {
    31: "file missing, unreadable or malformed (expected 'row col value' / 'node.direction' lines)",
    1: "the file's entry count changed while reading, or sizes are inconsistent",
}


def read_triplets(path: Path | str) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """rows, cols (1-based, upper triangle), values and the equation count
    of a CalculiX .sti/.mas file."""
    path = str(Path(path))
    nnz, neq, info = call(_sparse.sk_triplet_count, "sk_triplet_count", path)
    check(info, f"read_triplets (sk_triplet_count) {path}", _IO)
    if nnz < 1:
        raise InputError(f"read_triplets: {path} holds no matrix entries")
    rows, cols, vals, info = call(_sparse.sk_triplet_read, "sk_triplet_read", path, nnz)
    check(info, f"read_triplets (sk_triplet_read) {path}", _IO)
    return rows, cols, vals, int(neq)


def read_dofs(path: Path | str) -> tuple[np.ndarray, np.ndarray]:
    """node and direction (1-3) of every equation of a CalculiX .dof file."""
    path = str(Path(path))
    neq, info = call(_sparse.sk_dof_count, "sk_dof_count", path)
    check(info, f"read_dofs (sk_dof_count) {path}", _IO)
    if neq < 1:
        raise InputError(f"read_dofs: {path} lists no equations")
    node, direction, info = call(_sparse.sk_dof_read, "sk_dof_read", path, neq)
    check(info, f"read_dofs (sk_dof_read) {path}", _IO)
    return node, direction


def cholmod_solve(
    rows: npt.ArrayLike, cols: npt.ArrayLike, vals: npt.ArrayLike, b: npt.ArrayLike
) -> tuple[np.ndarray, dict]:
    """x = K^-1 b for every column of b (n, nrhs), one factorisation."""
    b = np.asfortranarray(np.atleast_2d(np.asarray(b, dtype=float).T).T)
    x, times, lnz, info = call(
        _sparse.sk_sparse_solve,
        "sk_sparse_solve",
        np.asarray(rows, dtype=np.int32),
        np.asarray(cols, dtype=np.int32),
        np.asarray(vals, dtype=float),
        b,
    )
    check(
        info,
        "cholmod_solve (sk_sparse_solve)",
        {
            5: "the stiffness matrix is not positive definite: the part is not held "
            "(support selects too few nodes, or the mesh has loose pieces)",
            1: "triplets out of range (row > col or index > n)",
        },
    )
    return x, {
        "ordering_s": float(times[0]),
        "factor_s": float(times[1]),
        "solve_s": float(times[2]),
        "factor_nnz": float(lnz),
    }


def rigid_solve(
    rows: npt.ArrayLike,
    cols: npt.ArrayLike,
    vals: npt.ArrayLike,
    n: int,
    ceq: npt.ArrayLike,
    offsets: npt.ArrayLike,
    loads: npt.ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Rigid coupling on the assembled K (one CHOLMOD factorisation of
    T^T K T): ``ceq`` (nc, 3) 1-based equations of the coupled nodes (0 =
    constrained), ``offsets`` (nc, 3) node - reference point; ``loads``
    (n, 6): further nodal loads of each case (default none). Returns u
    (n, 6): every equation under the six unit wrenches (plus ``loads``),
    q (6, 6): the reference-point motion, and timings."""
    b = np.zeros((int(n), 6)) if loads is None else np.asarray(loads, dtype=float)
    if b.shape != (int(n), 6):
        raise InputError(f"rigid_solve: loads of shape {b.shape}, expected ({int(n)}, 6)")
    u, q, times, lnz, info = call(
        _sparse.sk_rigid_solve,
        "sk_rigid_solve",
        int(n),
        np.asarray(rows, dtype=np.int32),
        np.asarray(cols, dtype=np.int32),
        np.asarray(vals, dtype=float),
        np.asfortranarray(np.asarray(ceq, np.int32).T),
        np.asfortranarray(np.asarray(offsets, float).T),
        np.asfortranarray(b),
    )
    check(
        info,
        "rigid_solve (sk_rigid_solve)",
        {
            5: "the rigidly coupled stiffness matrix is not positive definite: the part is not held",
            1: "coupled equations out of range or listed twice",
            8: "fewer than 3 coupled nodes",
        },
    )
    return (
        u,
        q,
        {
            "ordering_s": float(times[0]),
            "factor_s": float(times[1]),
            "solve_s": float(times[2]),
            "factor_nnz": float(lnz),
        },
    )


def face_weights(nodes: np.ndarray, face_conn: np.ndarray) -> tuple[np.ndarray, float]:
    """Weights of every node (integrals of the face shape functions over the
    faces (nf, 3|6), 1-based node numbers) and the faces' total area."""
    w, area, info = call(
        _sparse.sk_face_weights,
        "sk_face_weights",
        np.asfortranarray(np.asarray(nodes, float).T),
        np.asfortranarray(np.asarray(face_conn, np.int32).T),
    )
    check(info, "face_weights (sk_face_weights)")
    return w, float(area)


def distributing_loads(points: np.ndarray, weights: np.ndarray, reference: npt.ArrayLike) -> np.ndarray:
    """(6, nf, 3) nodal forces of the six unit wrenches at ``reference``
    spread like CalculiX's *DISTRIBUTING over ``points`` (nf, 3)."""
    g, info = call(
        _sparse.sk_distributing_loads,
        "sk_distributing_loads",
        np.asfortranarray(np.asarray(points, float).T),
        np.asarray(weights, float),
        np.asarray(reference, float),
    )
    check(
        info,
        "distributing_loads (sk_distributing_loads)",
        {
            3: "the coupled face nodes are collinear: a moment cannot be spread over them",
            8: "fewer than 3 weighted nodes on the load face",
        },
    )
    return np.transpose(g, (2, 1, 0))


def work_conjugate(g: np.ndarray, u: np.ndarray) -> np.ndarray:
    """(m, 6) reference motions G^T u of fields u (m, nf, 3), g (6, nf, 3)."""
    x, info = call(
        _sparse.sk_work_conjugate,
        "sk_work_conjugate",
        np.asfortranarray(np.transpose(g, (2, 1, 0))),
        np.asfortranarray(np.transpose(u, (2, 1, 0))),
    )
    check(info, "work_conjugate (sk_work_conjugate)")
    return x.T
