"""Face selectors of [support], [load] and [field] (docs/link.md).

Each section holds any of these keys, each one selector or a list of them;
all faces they select act as one set (both lug holes, six bolt holes):

- ``plane = "x-min"``: a bounding-box plane (nodes within ``tolerance``);
- ``face = 7``: the CAD face with this id (as ``stiffkit link --list-faces``
  prints it);
- ``cylinder = {axis = [0, 0, 1], point = [380, 0, 0], radius = 5}``: the
  cylindrical faces whose surface lies on this cylinder (``tolerance`` key
  of its own, or the section's);
- ``point = [x, y, z]``: the face through the point (the nearest within
  tolerance);
- ``box = [xmin, ymin, zmin, xmax, ymax, zmax]``: the faces inside the box;
- ``group = "name"``: a named group (a .geo physical group, a STEP label).

:func:`parse_set` checks a section (geometry units kept); :func:`resolve`
turns the CAD selectors into face ids, with an error naming the nearest
candidates when one matches nothing.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..meshing.faces import CadFace

PLANES = ("x-min", "x-max", "y-min", "y-max", "z-min", "z-max")
KINDS = ("plane", "face", "cylinder", "point", "box", "group")
CYLINDER_KEYS = ("axis", "point", "radius", "tolerance")
#: default CAD-selector tolerance, relative to the part's bounding-box diagonal
REL_TOL = 1e-4


@dataclass
class Selector:
    kind: str  # one of KINDS
    value: object  # plane name, face id, {axis, point, radius}, [x, y, z], [6], group name
    tolerance: float | None  # geometry units (None: the default)
    label: str  # "[load] cylinder[2]" for messages

    def key(self) -> list:
        """A JSON-able form (cache keys, reports)."""
        return [self.kind, self.value, self.tolerance]


class SelectorError(InputError):
    """A face selector is malformed or selects nothing."""


def _num(v: object, name: str, lo: float | None = None, lo_open: bool = False) -> float:
    try:
        x = V.number(v, name)
    except InputError as exc:
        raise SelectorError(str(exc)) from None
    if lo is not None and not x > lo:
        raise SelectorError(f"{name} = {v!r} must be positive")
    return x


def _vec(v: object, n: int, name: str) -> list[float]:
    if not isinstance(v, list) or len(v) != n:
        raise SelectorError(f"{name} = {v!r}: {n} numbers")
    return [_num(x, f"{name}[{i}]") for i, x in enumerate(v)]


def _items(tbl: dict, kind: str) -> list:
    """The selectors of one key: a single one or a list of them."""
    v = tbl[kind]
    if kind in ("point", "box"):  # [x, y, z] or [[x, y, z], ...]
        return v if isinstance(v, list) and v and all(isinstance(x, list) for x in v) else [v]
    return v if isinstance(v, list) else [v]


def parse_set(tbl: dict, section: str, path: str) -> tuple[list[Selector], float | None]:
    """The selectors of one section and its ``tolerance`` (geometry units)."""
    tol = None
    if "tolerance" in tbl:
        tol = _num(tbl["tolerance"], f"{path}: [{section}] tolerance", lo=0.0, lo_open=True)
    out: list[Selector] = []
    for kind in KINDS:
        if kind not in tbl:
            continue
        items = _items(tbl, kind)
        if not items:
            raise SelectorError(f"{path}: [{section}] {kind} = []: give at least one")
        for i, item in enumerate(items):
            label = f"{path}: [{section}] {kind}" + (f"[{i + 1}]" if len(items) > 1 else "")
            out.append(_parse_one(kind, item, label, tol))
    return out, tol


def _parse_one(kind: str, v: object, label: str, tol: float | None) -> Selector:
    if kind == "plane":
        if v not in PLANES:
            close = difflib.get_close_matches(str(v), PLANES, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SelectorError(
                f"{label} = {v!r}{hint}: choose one of {', '.join(PLANES)} "
                "(faces that are not bounding-box planes: face, cylinder, point, box or group)"
            )
        return Selector(kind, v, tol, label)
    if kind == "face":
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise SelectorError(f"{label} = {v!r}: a CAD face id, an integer >= 1 (stiffkit link --list-faces)")
        return Selector(kind, int(v), tol, label)
    if kind == "group":
        if not isinstance(v, str) or not v:
            raise SelectorError(f"{label} = {v!r}: the name of a group of faces (a string)")
        return Selector(kind, v, tol, label)
    if kind == "point":
        return Selector(kind, _vec(v, 3, label), tol, label)
    if kind == "box":
        b = _vec(v, 6, label)
        if any(b[i] > b[i + 3] for i in range(3)):
            raise SelectorError(f"{label} = {v!r}: [xmin, ymin, zmin, xmax, ymax, zmax] with each min <= max")
        return Selector(kind, b, tol, label)
    # cylinder
    if not isinstance(v, dict):
        raise SelectorError(f"{label} = {v!r}: a table {{axis = [x, y, z], point = [x, y, z], radius = r}}")
    unknown = sorted(set(v) - set(CYLINDER_KEYS))
    if unknown:
        raise SelectorError(f"{label}: unknown key(s) {', '.join(unknown)}; known: {', '.join(CYLINDER_KEYS)}")
    for k in ("axis", "point", "radius"):
        if k not in v:
            raise SelectorError(f"{label}: {k} is missing (a cylinder is axis, point and radius)")
    axis = _vec(v["axis"], 3, f"{label} axis")
    norm = float(np.linalg.norm(axis))
    if norm == 0:
        raise SelectorError(f"{label} axis = {v['axis']!r}: a direction, not the zero vector")
    value = {
        "axis": [a / norm for a in axis],
        "point": _vec(v["point"], 3, f"{label} point"),
        "radius": _num(v["radius"], f"{label} radius", lo=0.0, lo_open=True),
    }
    ctol = _num(v["tolerance"], f"{label} tolerance", lo=0.0, lo_open=True) if "tolerance" in v else tol
    return Selector(kind, value, ctol, label)


def cad_selectors(sels: list[Selector]) -> list[Selector]:
    return [s for s in sels if s.kind != "plane"]


def planes_of(sels: list[Selector]) -> list[str]:
    return [s.value for s in sels if s.kind == "plane"]


def describe(sels: list[Selector]) -> str:
    """'plane x-min', 'cylinder r = 5 ..., face 7' for reports."""
    parts = []
    for s in sels:
        if s.kind == "cylinder":
            v = s.value
            parts.append(f"cylinder r = {v['radius']:g} through {v['point']} along {[round(a, 6) for a in v['axis']]}")
        else:
            parts.append(f"{s.kind} {s.value!r}")
    return ", ".join(parts)


# ---------------------------------------------------------------- resolution


def _nearest(faces: list[CadFace], score: np.ndarray, units: str, k: int = 3) -> str:
    order = np.argsort(score)[:k]
    return "; ".join(faces[i].describe(units) for i in order)


def _line_distance(p: np.ndarray, q: np.ndarray, a: np.ndarray) -> float:
    """Distance of point p from the line through q along unit a."""
    return float(np.linalg.norm(np.cross(p - q, a)))


def resolve(
    sel: Selector,
    faces: list[CadFace],
    named: dict[str, list[int]],
    dist: np.ndarray | None,
    diag: float,
    units: str,
) -> list[int]:
    """The face ids one CAD selector picks; SelectorError (with the nearest
    candidates) when it picks none. ``dist``: the distances of this
    selector's point to every face (point selectors); ``diag``: the part's
    bounding-box diagonal (geometry units)."""
    tol = sel.tolerance if sel.tolerance is not None else REL_TOL * diag
    ids = [f.id for f in faces]
    if sel.kind == "face":
        if sel.value in ids:
            return [sel.value]
        raise SelectorError(
            f"{sel.label} = {sel.value}: the part has no face {sel.value} (its faces are {min(ids)}..{max(ids)}; "
            "stiffkit link --list-faces PART lists them)"
        )
    if sel.kind == "group":
        if sel.value in named:
            return list(named[sel.value])
        close = difflib.get_close_matches(sel.value, list(named), n=1)
        have = ", ".join(sorted(named)) if named else "none (the file names no faces)"
        raise SelectorError(
            f"{sel.label} = {sel.value!r}{f' (did you mean {close[0]!r}?)' if close else ''}: no such group; "
            f"named groups of the part: {have}"
        )
    if sel.kind == "point":
        assert dist is not None
        j = int(np.argmin(dist))
        if dist[j] <= tol:
            return [faces[j].id]
        near = "; ".join(f"{faces[i].describe(units)} at {dist[i]:.4g} {units}" for i in np.argsort(dist)[:3])
        raise SelectorError(
            f"{sel.label} = {sel.value}: no face passes within the tolerance {tol:.3g} {units} of the point; "
            f"nearest: {near}"
        )
    if sel.kind == "box":
        b = np.asarray(sel.value)
        lo, hi = b[:3] - tol, b[3:] + tol
        hit = [f.id for f in faces if np.all(np.asarray(f.bbox[:3]) >= lo) and np.all(np.asarray(f.bbox[3:]) <= hi)]
        if hit:
            return hit
        c = np.array([f.centre for f in faces])
        gap = np.linalg.norm(np.maximum(0, np.maximum(b[:3] - c, c - b[3:])), axis=1)
        raise SelectorError(
            f"{sel.label} = {sel.value}: no face lies wholly inside the box (tolerance {tol:.3g} {units}); "
            f"nearest: {_nearest(faces, gap, units)}"
        )
    return _resolve_cylinder(sel, faces, tol, diag, units)


def _resolve_cylinder(sel: Selector, faces: list[CadFace], tol: float, diag: float, units: str) -> list[int]:
    v = sel.value
    a, p, r = np.asarray(v["axis"]), np.asarray(v["point"]), v["radius"]
    cyl = [f for f in faces if f.radius is not None]
    what = f"{sel.label} (radius {r:g} {units}, axis {list(np.round(a, 6))} through {p.tolist()})"
    if not cyl:
        raise SelectorError(f"{what}: the part has no cylindrical face")
    same_r = [f for f in cyl if abs(f.radius - r) <= tol]
    if not same_r:
        radii = sorted({round(f.radius, 9) for f in cyl}, key=lambda x: abs(x - r))[:5]
        raise SelectorError(
            f"{what}: radius {r:g} matches no cylindrical face (tolerance {tol:.3g} {units}); "
            f"nearest radii: {', '.join(f'{x:g}' for x in radii)} {units}"
        )
    max_sin = max(tol / diag, 1e-9)
    hit = []
    score = []
    for f in same_r:
        fa, fp = np.asarray(f.axis), np.asarray(f.point)
        sin = float(np.linalg.norm(np.cross(a, fa)))
        off = _line_distance(p, fp, fa)
        score.append(sin * diag + off)
        if sin <= max_sin and off <= tol:
            hit.append(f.id)
    if hit:
        return hit
    raise SelectorError(
        f"{what}: no cylindrical face of that radius lies on this axis (tolerance {tol:.3g} {units}); "
        f"faces of radius {r:g}: " + _nearest(same_r, np.asarray(score), units, k=4)
    )


def coaxial_axis(faces: list[CadFace], diag: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(point, unit axis) when all ``faces`` are cylinders on one axis, else None."""
    if not faces or any(f.radius is None for f in faces):
        return None
    a0, p0 = np.asarray(faces[0].axis), np.asarray(faces[0].point)
    for f in faces[1:]:
        a, p = np.asarray(f.axis), np.asarray(f.point)
        if np.linalg.norm(np.cross(a, a0)) > 1e-6 or _line_distance(p, p0, a0) > 1e-6 * diag:
            return None
    return p0, a0
