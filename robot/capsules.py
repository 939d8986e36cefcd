"""Collision capsules of a robot (``stiffkit plan``'s candidate postures):
the bounding capsules of the URDF's primitive collision shapes, and the
distances between segments that every collision, floor and line-of-sight
test reduces to, vectorised over postures.

A capsule is a segment (a, b) and a radius r: the points within r of the
segment. Its bounding capsule of a URDF shape, in the shape's frame (z the
axis of a cylinder; the longest side of a box):

- ``<cylinder radius="r" length="L"/>``: segment z in [-L/2, L/2], radius r;
- ``<sphere radius="r"/>``: the centre, radius r;
- ``<box size="sx sy sz"/>``: along the longest side a, segment
  [-s_a/2, s_a/2], radius half the diagonal of the other two sides.

``<mesh>`` shapes have no primitive: the link keeps its capsules along the
kinematic skeleton (robot/plan_candidates.py).

Segment distances: the closest points of two segments (Ericson, Real-Time
Collision Detection, 2005, section 5.1.9: the unconstrained minimum of
|p1 + s d1 - p2 - t d2|, clamped to the segments, s then t), on arrays of
any leading shape.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..field.synthetic import rot_exp

__all__ = ["Capsule", "collision_capsules", "segment_distance", "point_segment_distance"]

#: below this squared length (m^2) a segment is a point
_EPS = 1e-18


@dataclass(frozen=True)
class Capsule:
    """A capsule in a link's frame: segment a -> b (m) and radius r (m);
    ``source`` says where it came from (for messages)."""

    a: tuple[float, float, float]
    b: tuple[float, float, float]
    r: float
    source: str = ""


def _numbers(el: ET.Element, attr: str, n: int, owner: str, path: Path | str) -> np.ndarray:
    raw = el.get(attr)
    try:
        v = np.array([float(x) for x in (raw or "").split()])
    except ValueError:
        v = np.zeros(0)
    if v.shape != (n,) or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise InputError(f'{path}: {owner}: <{el.tag} {attr}="{raw}"> must be {n} positive finite number(s) (m)')
    return v


def _rpy(rpy: np.ndarray) -> np.ndarray:
    """URDF rpy: R = Rz(y) Ry(p) Rx(r)."""
    r, p, y = rpy
    return rot_exp((0.0, 0.0, y)) @ rot_exp((0.0, p, 0.0)) @ rot_exp((r, 0.0, 0.0))


def _origin(el: ET.Element | None) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of a <collision>'s <origin> (its numbers checked by the URDF reader)."""
    if el is None:
        return np.eye(3), np.zeros(3)
    xyz = np.array([float(x) for x in el.get("xyz", "0 0 0").split()])
    rpy = np.array([float(x) for x in el.get("rpy", "0 0 0").split()])
    return _rpy(rpy), xyz


def collision_capsules(link_elements: list[ET.Element], path: Path | str) -> dict[str, list[Capsule]]:
    """link name -> the bounding capsules (link frame) of its primitive
    ``<collision>`` shapes (module docstring); links with none (or meshes
    only) are left out. Raises InputError naming the file and the link for
    a size that is not positive and finite."""
    out: dict[str, list[Capsule]] = {}
    for link in link_elements:
        cols = link.findall("collision")  # the C fast path: linear and cheap for a 100,000-link file
        name = link.get("name", "") if cols else ""
        for k, col in enumerate(cols):
            geom = col.find("geometry")
            shape = None if geom is None else next(iter(geom), None)
            if shape is None or shape.tag not in ("cylinder", "sphere", "box"):
                continue
            owner = f"link {name!r}, <collision> #{k + 1}"
            if shape.tag == "cylinder":
                r = float(_numbers(shape, "radius", 1, owner, path)[0])
                h = float(_numbers(shape, "length", 1, owner, path)[0]) / 2
                axis = np.array([0.0, 0.0, 1.0])
            elif shape.tag == "sphere":
                r, h, axis = float(_numbers(shape, "radius", 1, owner, path)[0]), 0.0, np.zeros(3)
            else:
                size = _numbers(shape, "size", 3, owner, path)
                a = int(np.argmax(size))
                r = 0.5 * float(np.hypot(*np.delete(size, a)))
                h, axis = size[a] / 2, np.eye(3)[a]
            R, t = _origin(col.find("origin"))
            a_, b_ = t - h * (R @ axis), t + h * (R @ axis)
            out.setdefault(name, []).append(Capsule(tuple(a_), tuple(b_), r, f"{shape.tag} of {owner}"))
    return out


def _clamp(x: np.ndarray) -> np.ndarray:
    return np.clip(x, 0.0, 1.0)


def segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Distance between the segments p1-q1 and p2-q2 (arrays (..., 3),
    broadcast); the closest points by Ericson's clamping (module docstring)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    pa, pe = a > _EPS, e > _EPS
    sa, se = np.where(pa, a, 1.0), np.where(pe, e, 1.0)
    denom = a * e - b * b
    parallel = denom <= 1e-12 * np.maximum(a * e, _EPS)
    s = np.where(parallel, 0.0, _clamp((b * f - c * e) / np.where(parallel, 1.0, denom)))
    t = (b * s + f) / se
    # t outside [0, 1]: clamp it and recompute s for the clamped t
    s = np.where(t < 0.0, _clamp(-c / sa), np.where(t > 1.0, _clamp((b - c) / sa), s))
    t = _clamp(t)
    # degenerate segments (points)
    s = np.where(pa, s, 0.0)
    t = np.where(pa, np.where(pe, t, 0.0), np.where(pe, _clamp(f / se), 0.0))
    s = np.where(pa & ~pe, _clamp(-c / sa), s)
    gap = r + s[..., None] * d1 - t[..., None] * d2
    return np.sqrt(np.einsum("...i,...i->...", gap, gap))


def point_segment_distance(x: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance from the points x to the segments p-q (arrays (..., 3), broadcast)."""
    d = q - p
    dd = np.einsum("...i,...i->...", d, d)
    t = _clamp(np.einsum("...i,...i->...", x - p, d) / np.where(dd > _EPS, dd, 1.0))
    gap = x - p - t[..., None] * d
    return np.sqrt(np.einsum("...i,...i->...", gap, gap))
