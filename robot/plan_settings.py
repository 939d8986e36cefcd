"""The optional ``[plan]`` table of a model file (``stiffkit plan``, issue 19):
where the robot may go and what a candidate posture must respect.

```toml
[plan]
limits = { joint_a2 = [-1.2, 0.1] }   # rad (m for prismatic): tightens the URDF's limits
radius = { link_3 = 0.12 }            # m: capsule radius of a link's skeleton (a link with URDF shapes keeps them)
default_radius = 0.05                 # m: every other link
margin = 0.01                         # m: least clearance between capsules (and to the floor)
floor_z = 0.0                         # m, base frame: no capsule below floor_z + margin
tracker = { position = [3.0, 0.0, 1.1], direction = [-1.0, 0.0, -0.2], cone_deg = 40 }  # absolute data
loads = [[0, 0, -2500, 0, 0, 0], [2500, 0, 0, 0, 0, 0]]   # deflection data: N and N m at the tool
points = [[0, 0, 0.25], [0.12, 0, 0.2]]   # deflection data: the points measured on the tool (tool frame, m)
```

``tracker``: base-frame position (m) and viewing direction of the tracker;
a marker is in view when the angle between the direction and the line from
the tracker to the marker is at most ``cone_deg`` (the cone's half-angle,
in (0, 180) degrees). ``loads`` (deflection data): the wrenches the user
can apply (force, moment; tool-frame origin, base axes), each candidate a
(posture, load) pair; ``points`` (deflection data): the points whose
deflection is measured in each, in the tool frame (default: those of
``--measured``, else the tool origin). Every number is checked (finite, in range, units
plausible: a radius or margin of 1 m or more is taken for mm); an error
names the file, the table and the key.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError, StiffkitWarning
from ..io import validate as V

__all__ = ["PlanSettings", "plan_table", "parse_plan", "cone_cos", "PLAN_KEYS"]

#: the keys of [plan]; tracker only for absolute data, loads only for deflection data
PLAN_KEYS = ("limits", "radius", "default_radius", "margin", "floor_z", "tracker", "loads", "points")
TRACKER_KEYS = ("position", "direction", "cone_deg")
DEFAULT_RADIUS, DEFAULT_MARGIN = 0.05, 0.01
#: a capsule radius or margin at least this large (m) is a value in mm
MM_HINT = 1.0


@dataclass
class PlanSettings:
    """What a candidate posture must respect (module docstring); SI."""

    limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    capsule_radius: dict[str, float] = field(default_factory=dict)
    default_radius: float = DEFAULT_RADIUS
    margin: float = DEFAULT_MARGIN
    floor_z: float | None = None
    #: {"position": (3,), "direction": (3,) unit, "cone_deg": float} or None
    tracker: dict | None = None
    loads: list[list[float]] | None = None
    #: (n, 3) the points measured on the tool (deflection data, tool frame, m) or None
    points: np.ndarray | None = None
    #: the model file the settings came from (for messages)
    path: str = ""

    def radius(self, link: str) -> float:
        return self.capsule_radius.get(link, self.default_radius)

    @property
    def where(self) -> str:
        return f"{self.path or 'model'}: [plan]"


def plan_table(doc: dict, path: Path | str) -> dict:
    """The raw [plan] table of a model document ({} when absent), as the
    loaders keep it for the writers; parsed by :func:`parse_plan`."""
    plan = doc.get("plan", {})
    if not isinstance(plan, dict):
        raise InputError(f"{path}: [plan] must be a table, got {plan!r}")
    return plan


def _size(v: object, name: str, lo_open: bool = True) -> float:
    x = V.number(v, name, "length" if lo_open else None, lo=0.0, lo_open=lo_open, unit="m", check_plausible=False)
    if x >= MM_HINT:
        raise InputError(f"{name} = {x:g} m is implausible for a robot's capsule (a value in mm? write {x / 1000:g})")
    return x


def _vector(v: object, name: str, q: str) -> np.ndarray:
    if not isinstance(v, list):
        raise InputError(f"{name} = {v!r} must be a list of 3 numbers")
    return V.array(v, name, (3,), q)


def _limits(table: object, where: str, joints: dict[str, tuple[str, tuple[float, float] | None]]) -> dict:
    if not isinstance(table, dict):
        raise InputError(f"{where} limits must be a table {{joint = [lo, hi]}}, got {table!r}")
    out = {}
    for name, v in table.items():
        key = f"{where} limits.{V.shown(name)}"
        if name not in joints:
            raise InputError(f"{key}: the robot has no moving joint {name!r} (moving joints: {', '.join(joints)})")
        jtype, urdf = joints[name]
        if not isinstance(v, list) or len(v) != 2:
            raise InputError(f"{key} = {v!r} must be [lower, upper]")
        q = "position" if jtype == "prismatic" else "angle"
        lo, hi = (V.number(x, f"{key}[{k}]", q) for k, x in enumerate(v))
        if not lo < hi:
            raise InputError(f"{key} = [{lo:g}, {hi:g}]: the lower limit must be below the upper")
        if urdf is not None and (lo < urdf[0] - 1e-12 or hi > urdf[1] + 1e-12):
            raise InputError(
                f"{key} = [{lo:g}, {hi:g}] is outside the URDF's limits [{urdf[0]:g}, {urdf[1]:g}] of joint "
                f"{name!r}: a [plan] limit can only tighten them"
            )
        out[name] = (lo, hi)
    return out


def _tracker(t: object, where: str) -> dict:
    if not isinstance(t, dict):
        raise InputError(f"{where} tracker must be a table {{position = [x, y, z], direction = [..], cone_deg = ..}}")
    V.known_keys(t, TRACKER_KEYS, f"{where} tracker: unknown key(s)")
    missing = [k for k in TRACKER_KEYS if k not in t]
    if missing:
        raise InputError(
            f"{where} tracker: missing {', '.join(missing)} (position, direction in the base frame, m; "
            "cone_deg the half-angle of the view cone)"
        )
    pos = _vector(t["position"], f"{where} tracker.position", "position")
    d = _vector(t["direction"], f"{where} tracker.direction", None)
    n = float(np.linalg.norm(d))
    if not n > 0:
        raise InputError(f"{where} tracker.direction = {t['direction']!r} must not be zero")
    cone = V.number(
        t["cone_deg"], f"{where} tracker.cone_deg", lo=0.0, hi=180.0, lo_open=True, hi_open=True, unit="deg"
    )
    return {"position": pos, "direction": d / n, "cone_deg": cone}


def _loads(v: object, where: str) -> list[list[float]]:
    if not isinstance(v, list) or not v:
        raise InputError(f"{where} loads must be a list of [fx, fy, fz, mx, my, mz] (N, N m), got {v!r}")
    out = []
    for i, w in enumerate(v):
        key = f"{where} loads[{i}]"
        if not isinstance(w, list) or len(w) != 6:
            raise InputError(f"{key} = {w!r} must be 6 numbers [fx, fy, fz, mx, my, mz] (N, N m)")
        row = [V.number(x, f"{key}[{k}]", "force" if k < 3 else "moment") for k, x in enumerate(w)]
        if not any(row):
            raise InputError(f"{key} is all zero: a load that deflects nothing tells nothing")
        if row in out:
            raise InputError(f"{key} = {w!r} repeats {where} loads[{out.index(row)}]: give each load once")
        out.append(row)
    return out


def _points(v: object, where: str) -> np.ndarray:
    if not isinstance(v, list) or not v or not all(isinstance(x, list) for x in v):
        raise InputError(f"{where} points must be a list of [x, y, z] (tool frame, m), got {v!r}")
    pts = np.array([_vector(x, f"{where} points[{i}]", "position") for i, x in enumerate(v)])
    for i in range(1, len(pts)):
        same = np.flatnonzero(np.all(pts[:i] == pts[i], axis=1))
        if same.size:
            raise InputError(f"{where} points[{i}] = {v[i]!r} repeats points[{int(same[0])}]: give each point once")
    return pts


def parse_plan(table: dict, path: Path | str, model: object) -> PlanSettings:
    """PlanSettings from a [plan] table, checked against ``model`` (a
    TreeModel or a Model: joint names and URDF limits, link names, the data
    kind); InputError naming file, table and key."""
    where = f"{path}: [plan]"
    V.known_keys(table, PLAN_KEYS, f"{where}: unknown key(s)")
    tree = getattr(model, "tree", None)
    absolute = tree is not None
    if absolute:
        joints = {j.name: (j.type, j.limit) for j in tree.joints if j.moving}
        links = list(tree.links)
    else:
        chain = model.chain
        joints = dict(zip(chain.actuated, (("revolute", lim) for lim in chain.limits)))
        links = list(chain.links)
    s = PlanSettings(path=str(path))
    s.limits = _limits(table.get("limits", {}), where, joints)
    radius = table.get("radius", {})
    if not isinstance(radius, dict):
        raise InputError(f"{where} radius must be a table {{link = r}} (m), got {radius!r}")
    for ln, r in radius.items():
        if ln not in links:
            raise InputError(f"{where} radius.{V.shown(ln)}: the robot has no link {ln!r} (links: {', '.join(links)})")
        s.capsule_radius[ln] = _size(r, f"{where} radius.{V.shown(ln)}")
        shapes = (tree.collisions if absolute else model.chain.collisions).get(ln)
        if shapes:
            warnings.warn(
                StiffkitWarning(
                    f"{where} radius.{V.shown(ln)}: link {ln!r} has {len(shapes)} primitive collision shape(s) in the "
                    "URDF; they are its capsules, this radius is not used"
                ),
                stacklevel=3,
            )
    if "default_radius" in table:
        s.default_radius = _size(table["default_radius"], f"{where} default_radius")
    if "margin" in table:
        s.margin = _size(table["margin"], f"{where} margin", lo_open=False)
    if "floor_z" in table:
        s.floor_z = V.number(table["floor_z"], f"{where} floor_z", "position")
    if "tracker" in table:
        if not absolute:
            raise InputError(
                f"{where} tracker: the view test is for absolute (tracker) data; this model is of "
                'deflection data ([measurements] kind = "deflection")'
            )
        s.tracker = _tracker(table["tracker"], where)
    if "loads" in table:
        if absolute:
            raise InputError(
                f"{where} loads: loads are for deflection data; this model is of absolute data "
                "(the robot's own weight loads it)"
            )
        s.loads = _loads(table["loads"], where)
    if "points" in table:
        if absolute:
            raise InputError(
                f"{where} points: points are for deflection data; on absolute data the markers of the model's "
                '[[effect]] kind = "marker" tables are measured'
            )
        s.points = _points(table["points"], where)
    return s


def cone_cos(settings: PlanSettings) -> float:
    """The cosine of the view cone's half-angle (settings with a tracker)."""
    return math.cos(math.radians(settings.tracker["cone_deg"]))
