"""Synthetic node fields with known answers (paper s3.3, s3.5, s4).

Only data generation lives here (the truth to test against); every
estimate is computed by the core.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt


def cubic_grid(edge: float = 10.0, step: float = 1.0, centre: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Nodes of a cubic field edge^3 with the given step (paper: 10 mm, 1 mm, 1331 nodes)."""
    k = int(round(edge / step)) + 1
    g = (np.arange(k) * step) - edge / 2.0
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]) + np.asarray(centre, float)


def square_grid(edge: float, step: float, x: float = 0.0) -> np.ndarray:
    """Nodes of a square edge x edge field in the plane x = const (paper case 3)."""
    k = int(round(edge / step)) + 1
    g = (np.arange(k) * step) - edge / 2.0
    y, z = np.meshgrid(g, g, indexing="ij")
    return np.column_stack([np.full(y.size, x), y.ravel(), z.ravel()])


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def elementary_rotation(b: float) -> np.ndarray:
    """R = Rz(b) Ry(b) Rx(b): elementary rotations of angle b about x, y, z."""
    return rot_z(b) @ rot_y(b) @ rot_x(b)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle) of a proper rotation, angle < pi."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    v = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = np.linalg.norm(v)
    th = np.arctan2(s, c)
    return v * (th / s) if s > 0 else v


def rot_exp(phi: npt.ArrayLike) -> np.ndarray:
    """Rodrigues' formula."""
    phi = np.asarray(phi, float)
    th = np.linalg.norm(phi)
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if th < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th**2 * K @ K


def rigid_displacements(points: npt.ArrayLike, reference: npt.ArrayLike, t: npt.ArrayLike, R: np.ndarray) -> np.ndarray:
    """Displacements of nodes moved rigidly: p + dp = R (p - p0) + p0 + t."""
    q = np.asarray(points, float) - np.asarray(reference, float)
    return q @ (R.T - np.eye(3)) + np.asarray(t, float)


def cantilever_fields(
    compliance: npt.ArrayLike,
    wrenches: npt.ArrayLike,
    points: npt.ArrayLike,
    reference: npt.ArrayLike,
    sigma: float = 0.0,
    outlier_fraction: float = 0.0,
    outlier_scale: float = 50.0,
    rng: np.random.Generator | int | None = None,
) -> np.ndarray:
    """Displacement fields of m load cases: the rigid motion k W_j of the
    reference point applied to the nodes, plus i.i.d. noise (eq. 18) and,
    optionally, gross outliers on a fraction of the nodes (s3.4)."""
    rng = np.random.default_rng(rng)
    points = np.asarray(points, float)
    n = points.shape[0]
    out = []
    for w in np.asarray(wrenches, float):
        x = np.asarray(compliance) @ w
        d = rigid_displacements(points, reference, x[:3], rot_exp(x[3:]))
        d = d + sigma * rng.standard_normal(d.shape)
        if outlier_fraction > 0:
            idx = rng.choice(n, size=int(round(outlier_fraction * n)), replace=False)
            d[idx] += outlier_scale * sigma * rng.choice([-1.0, 1.0], size=(idx.size, 3))
        out.append(d)
    return np.array(out)
