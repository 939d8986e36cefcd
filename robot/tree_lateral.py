"""The tilt axes of a joint's lateral compliance (docs/calibration.md
sections 6.2 and 6.12): about the common normal of the previous moving
joint's axis and this one, through its foot on this axis, fixed in the
parent link; y' = z' x x'. Used by the tree model (robot/tree_model.py) and
by the writer of folded models (calib/absolute_write.py)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .tree import Tree

__all__ = ["lateral_tilts", "duplicated_tilt", "joint_tilts", "least_aligned", "LINE_TOL", "PARALLEL_TOL"]


def least_aligned(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x', y' perpendicular to the unit joint axis z': x' the axis least aligned with z', made orthogonal."""
    e = np.eye(3)[int(np.argmin(np.abs(axis)))]
    x = e - np.dot(e, axis) * axis
    x /= np.linalg.norm(x)
    return x, np.cross(axis, x)


#: lines closer than this (m) meet; axes closer than this (rad) are parallel
LINE_TOL, PARALLEL_TOL = 1e-6, 1e-3


def lateral_tilts(tree: Tree, jn: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """The tilt axes of joint ``jn``'s lateral compliance: (direction, point)
    in its origin frame, x' then y' (module docstring, section 6.12)."""
    return _tilts(tree, jn)[0]


def duplicated_tilt(tree: Tree, jn: str) -> bool:
    """Whether joint ``jn``'s y' tilt is the previous moving joint's axis line
    (perpendicular axes that meet): its compliance is that joint's."""
    return _tilts(tree, jn)[1]


def _tilts(tree: Tree, jn: str) -> tuple[list[tuple[np.ndarray, np.ndarray]], bool]:
    j = tree.joint(jn)
    z = j.axis / np.linalg.norm(j.axis)
    T = j.origin
    p = tree.parent_joint(j.parent)
    while p is not None and not p.moving:
        T = p.origin @ T
        p = tree.parent_joint(p.parent)
    zero = np.zeros(3)
    if p is None:
        return [(ax, zero) for ax in least_aligned(z)], False
    Ti = np.linalg.inv(T)  # the previous joint's frame (after its motion) in this joint's origin frame
    zp = Ti[:3, :3] @ (p.axis / np.linalg.norm(p.axis))
    op = Ti[:3, 3]
    n = np.cross(zp, z)
    # parallel (a common normal far away means nothing): the perpendicular between the axes
    if np.linalg.norm(n) < PARALLEL_TOL:
        d = -op - np.dot(-op, z) * z
        if np.linalg.norm(d) < LINE_TOL:  # coaxial
            return [(ax, zero) for ax in least_aligned(z)], False
        x = d / np.linalg.norm(d)
        return [(x, zero), (np.cross(z, x), zero)], False
    x = n / np.linalg.norm(n)
    A = np.array([[z @ z, -(z @ zp)], [z @ zp, -(zp @ zp)]])
    s, t = np.linalg.solve(A, [z @ op, zp @ op])
    foot = s * z
    y = np.cross(z, x)
    # y' through the foot is the previous axis line when the axes are perpendicular and meet
    dup = abs(z @ zp) < PARALLEL_TOL and np.linalg.norm(foot - (op + t * zp)) < LINE_TOL
    return [(x, foot), (y, foot)], bool(dup)


def joint_tilts(tree: Tree, jn: str, table: dict, where: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """The lateral tilts of joint ``jn``: the table's ``tilts`` (rows
    [direction, point] in the joint's origin frame, as a folded model is
    written: section 6.12) or :func:`lateral_tilts`."""
    if "tilts" not in table:
        return lateral_tilts(tree, jn)
    if table.get("target", "all") == "all":
        raise InputError(f"{where}: tilts need one target joint, not 'all'")
    rows = table["tilts"]
    if not isinstance(rows, list) or len(rows) != 2:
        raise InputError(f"{where}: tilts must be 2 rows [ax, ay, az, px, py, pz] (x', y'), got {rows!r}")
    z = tree.joint(jn).axis
    out = []
    for k, row in enumerate(rows):
        try:
            v = np.asarray(row, dtype=float)
        except (TypeError, ValueError):
            v = np.zeros(0)
        if v.shape != (6,) or not np.all(np.isfinite(v)):
            raise InputError(f"{where}: tilts row {k + 1} must be 6 finite numbers [ax, ay, az, px, py, pz]: {row!r}")
        a = v[:3]
        if abs(np.linalg.norm(a) - 1) > 1e-6 or abs(a @ z) > 1e-6:
            raise InputError(
                f"{where}: tilts row {k + 1}: the direction must be a unit vector perpendicular to the axis z'"
            )
        out.append((a / np.linalg.norm(a), v[3:]))
    return out
