"""The 6-dof spring's numbers shared by both robot models (robot/model.py,
robot/tree_build.py): the 21 elements of a symmetric 6x6 compliance in the
core's order, the link templates that keep some of them (klimchik M1, M2 /
eq. 13) and the URDF rpy rotation that turns a spring's axes."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import InputError

__all__ = ["TEMPLATES", "AXES", "SYM", "SYM_INDEX", "template_elements", "rpy_matrix"]

TEMPLATES = ("full", "beam", "diagonal")
AXES = "xyz"

#: element (a, b), 0-based a <= b, of the 21 upper-triangle entries (core order)
SYM = [(a, b) for a in range(6) for b in range(a, 6)]
SYM_INDEX = {ab: k for k, ab in enumerate(SYM)}


def template_elements(template: str, axis: int = 0) -> list[int]:
    """Indices (0..20) of the elements a template keeps (M1, M2 / eq. 13).

    ``beam`` along axis a (0, 1, 2): the six diagonal elements plus the two
    bending couplings (translation along b with rotation about c, and c with
    b), b, c the transverse axes in cyclic order.
    """
    if template == "full":
        return list(range(21))
    if template == "diagonal":
        return [SYM_INDEX[(i, i)] for i in range(6)]
    if template == "beam":
        b, c = (axis + 1) % 3, (axis + 2) % 3
        pairs = [(i, i) for i in range(6)] + [(b, 3 + c), (c, 3 + b)]
        return sorted(SYM_INDEX[tuple(sorted(p))] for p in pairs)
    raise InputError(f"unknown template {template!r}; choose one of {', '.join(TEMPLATES)}")


def rpy_matrix(rpy: Sequence[float] | np.ndarray) -> np.ndarray:
    """URDF rpy: R = Rz(y) Ry(p) Rx(r)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )
