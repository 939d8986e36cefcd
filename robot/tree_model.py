"""Models of a robot measured by a tracker (docs/calibration.md section 6):
a URDF tree with geometric and gravity-elastic effects, expanded into the
virtual joints of the core (core/sk_tree.f90).

Every effect becomes virtual joints or parameters of the core's model:

- ``tracker``: the tracker-from-base transform, 6 parameters
  ``tracker.x y z`` (m) and ``tracker.a1 a2 a3`` (rad), with
  ``T = Trans(x, y, z) * R_ref * Rx(a1) Ry(a2) Rz(a3)``; R_ref is the start
  (re-centred by the fit), so the angles stay small.
- ``marker`` (target: a link): the point's coordinates in that link's
  frame, ``marker.<link>.x y z`` (m).
- ``joint_offset`` (target: a moving joint or ``all``): ``<joint>.dq0``
  (rad, m for prismatic); a mimic follower turns by its multiplier times
  its leader's offset too.
- ``frame`` (target: a joint or ``all``): the joint's origin becomes
  ``T(origin) * Trans(dx, dy, dz) * Rx(drx) Ry(dry) Rz(drz)`` (origin
  axes): ``<joint>.dx dy dz drx dry drz``. Each rotation is an exact screw,
  so the analytic derivatives hold at any value.
- ``joint`` (target: a moving joint or ``all``): ``<joint>.c``, the
  deflection about (along) the axis is ``c * tau``, tau the generalised
  gravity force (moment about the axis of the weight beyond the joint and
  the row's payloads).
- ``lateral`` (target: a revolute joint or ``all``): ``<joint>.cx cy``,
  tilts of the joint's axis before its motion (fixed in the parent link),
  driven by the moment components about the tilt axes (section 6.12):
  x' is the common normal of the previous moving joint's axis and this one
  (through its foot on this axis; for parallel axes the perpendicular
  between them, through the origin), y' = z' x x'. Where y' is the previous
  joint's axis line itself (perpendicular axes that meet) its tilt is that
  joint's compliance: ``cy`` is held at 0 (not identified) unless the table
  gives a value. A joint with no moving joint
  above it, or coaxial with it, tilts about the origin frame's axis least
  aligned with z' (made orthogonal) and y' = z' x x'.
- ``joint_cubic`` / ``joint_deadzone`` (target: a joint with a ``joint``
  effect): the law becomes ``c tau + c3 tau^3`` (``<joint>.cubic``) or
  ``c tau + b tanh(tau / tau0)`` (``<joint>.backlash``, ``tau0`` a key in N m;
  default 5 % of the RMS gravity torque about the joint in the data).
- ``link`` (target: a link) and ``base``: 6-dof springs (21, 8 or 6
  parameters ``<link>.cIJ``, templates full / beam / diagonal) driven by
  the transmitted gravity wrench. A link with one child joint carries its
  spring at that joint's origin frame (before the joint's motion, as in
  section 2); a link with several children, or none, at its own frame.

Elastic deflections of a mimic leader do not move its followers (each
virtual joint has its own spring). Values in an effect table are known
values (not identified), except the ``xyz``/``rpy`` of ``tracker`` and
``marker``, which are start values (``fixed = true`` holds them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from .._core import tree as core_tree
from .._core.tree import CoreArrays, PackedTree, pack
from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_toml
from .catalogue import DEADZONE_TAU0_FRACTION, LAW_CUBIC, LAW_DEADZONE, LAW_LINEAR, LAW_SPRING6  # noqa: F401
from .plan_settings import plan_table
from .spring6 import rpy_matrix  # noqa: F401 (re-exported)
from .tree import Tree, load_tree
from .tree_build import FRAME_NAMES, Builder, Param, add_joints, core_arrays, tracker_and_markers
from .tree_effects import ABS_KINDS, KEYS, group_effects, link_springs, per_joint_effects, table_number
from .tree_lateral import duplicated_tilt, joint_tilts, lateral_tilts
from .urdf_read import gc_paused

__all__ = [
    "ABS_KINDS",
    "FRAME_NAMES",
    "KEYS",
    "Param",
    "TreeModel",
    "load_tree_model",
    "tree_model_from_tables",
    "rpy_from_matrix",
    "GRAVITY",
    "model_kind",
    "MEASUREMENT_KINDS",
    "lateral_tilts",
    "duplicated_tilt",
    "joint_tilts",
]

#: [measurements] kind: relative deflections under known loads (section 3) or absolute positions (section 6)
MEASUREMENT_KINDS = ("deflection", "absolute")

GRAVITY = (0.0, 0.0, -9.81)
#: equilibrium: at most this many fixed-point iterations, to this tolerance (m)
EQ_ITERATIONS, EQ_TOL = 100, 1e-9


def rpy_from_matrix(R: np.ndarray) -> np.ndarray:
    """URDF rpy (R = Rz(y) Ry(p) Rx(r)) of a rotation matrix."""
    R = np.asarray(R, float)
    p = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    if abs(R[2, 0]) < 1.0 - 1e-12:
        r = math.atan2(R[2, 1], R[2, 2])
        y = math.atan2(R[1, 0], R[0, 0])
    else:  # gimbal lock: put the whole turn on yaw
        r = 0.0
        y = math.atan2(-R[0, 1], R[1, 1])
    return np.array([r, p, y])


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@dataclass
class TreeModel:
    """A tree model ready for the core: ``arrays`` (the virtual joints,
    elastic blocks, bodies, markers and tracker indices in the core's layout,
    1-based), ``params`` and their start values ``theta0``."""

    tree: Tree
    effects: list[dict]
    params: list[Param]
    arrays: dict[str, np.ndarray]
    ne: int
    frames: list[str]
    vj_of_link: dict[str, int]
    gravity: np.ndarray
    iterations: int
    path: Path | None = None
    sigma_position: float | None = None
    robot_table: dict = field(default_factory=dict)
    #: joint name -> index of its own virtual joint (the joint's motion)
    vj_of_joint: dict[str, int] = field(default_factory=dict)
    #: (block index 0-based) -> (kind, target) for reports
    blocks: list[tuple[str, str]] = field(default_factory=list)
    #: parameter name -> sigma of its prior toward the URDF (model_bodies)
    priors: dict[str, float] = field(default_factory=dict)
    #: the file's optional [plan] table as written (robot/plan_settings.py reads it; the writers keep it)
    plan: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    @property
    def theta0(self) -> np.ndarray:
        return np.array([p.start for p in self.params], dtype=float)

    @property
    def free(self) -> np.ndarray:
        """0-based indices of the parameters to identify."""
        return np.array([i for i, p in enumerate(self.params) if p.free], dtype=int)

    @property
    def actuated(self) -> list[str]:
        return self.tree.actuated

    @property
    def elastic(self) -> bool:
        return self.ne > 0

    @property
    def eqit(self) -> int:
        """The core's equilibrium mode: 0 rigid, 1 first order, >= 2 iterated."""
        return 0 if not self.elastic else self.iterations

    @property
    def packed(self) -> PackedTree:
        """The model as every routine of the tree core takes it (bindings/tree.py
        ``pack``), packed from the current arrays: take it once per batch of
        calls; a change of the arrays (tracker rotation, tau0) needs a new one."""
        return pack(self.ne, self.arrays)

    def compliance(
        self, Q: ArrayLike, frame: str, theta: ArrayLike | None = None, vary: tuple | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(C, K, rank, ok) of link ``frame``'s frame at postures Q (N, dof):
        its compliance C (N, 6, 6; base axes, about the frame's origin) at
        the undeflected pose, every effect's law at zero load (one core call,
        core/sk_tree_point.f90), K = C^-1 where C is positive definite (else
        zeros, ok False) and the rank of C. ``theta``: the parameters
        (default theta0); ``vary``: (parameter indices (nvar,), values (N,
        nvar)) that take a value per posture (a posture-dependent compliance)."""
        if frame not in self.vj_of_link:
            raise InputError(f"unknown frame {frame!r}; links of the model: {', '.join(self.vj_of_link)}")
        Q = np.atleast_2d(V.array(Q, "postures", None, "angle"))
        if Q.ndim != 2 or Q.shape[1] != len(self.actuated) or Q.shape[0] < 1:
            raise InputError(f"postures must have shape (N, {len(self.actuated)}), got {np.shape(Q)}")
        th = self.theta0 if theta is None else V.array(theta, "theta", (len(self.params),))
        C, K, rank, kinfo = core_tree.compliance(self.packed, th, self.vj_of_link[frame], Q, vary)
        return C, K, rank.astype(int), kinfo == 0

    def twists(self, q: ArrayLike, frame: str, theta: ArrayLike | None = None) -> list[np.ndarray]:
        """The twists of link ``frame``'s frame (about its origin, base axes)
        per unit deflection of every elastic block at posture q (dof,),
        undeflected (one core call): one (6, n) array per block (n = 6 for a
        6-dof spring, else 1), in the order of ``blocks``."""
        if frame not in self.vj_of_link:
            raise InputError(f"unknown frame {frame!r}; links of the model: {', '.join(self.vj_of_link)}")
        q = V.array(q, "posture", (len(self.actuated),), "angle")
        th = self.theta0 if theta is None else V.array(theta, "theta", (len(self.params),))
        g = core_tree.twists(self.packed, th, self.vj_of_link[frame], q)
        ends = np.cumsum([6 if k == LAW_SPRING6 else 1 for k in self.arrays["ktype"]])
        return [g[:, e - (6 if k == LAW_SPRING6 else 1) : e] for e, k in zip(ends, self.arrays["ktype"])]

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise InputError(f"the model has no parameter {name!r}") from None

    def has(self, kind: str, target: str | None = None) -> bool:
        return any(p.kind == kind and (target is None or p.target == target) for p in self.params)

    def tracker_pose(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R, t) of the tracker-from-base transform at theta."""
        tp = self.arrays["tpar"] - 1
        t = theta[tp[:3]]
        a = theta[tp[3:]]
        R = self.arrays["rref"] @ _rx(a[0]) @ _ry(a[1]) @ _rz(a[2])
        return R, t

    def copy(self) -> TreeModel:
        """A copy whose arrays can be changed (tracker rotation, tau0) without touching this one."""
        m = TreeModel(**{k: getattr(self, k) for k in self.__dataclass_fields__})
        m.arrays = CoreArrays(
            {k: np.array(v, order="F") for k, v in self.arrays.items()}, labels=getattr(self.arrays, "labels", {})
        )
        return m

    def recentred(self, theta: np.ndarray) -> tuple[TreeModel, np.ndarray]:
        """The same model with the tracker's reference rotation moved to the
        pose at theta (angles back to zero)."""
        R, _t = self.tracker_pose(theta)
        m = self.copy()
        m.arrays["rref"] = np.asfortranarray(R)
        th = np.array(theta, dtype=float)
        th[self.arrays["tpar"][3:] - 1] = 0.0
        return m, th

    def with_tracker(self, R: np.ndarray, t: np.ndarray, theta: np.ndarray | None = None) -> np.ndarray:
        """Set the tracker pose (reference rotation R, translation t);
        returns theta with the tracker's parameters set."""
        self.arrays["rref"] = np.asfortranarray(np.asarray(R, float))
        th = self.theta0 if theta is None else np.array(theta, dtype=float)
        tp = self.arrays["tpar"] - 1
        th[tp[:3]] = t
        th[tp[3:]] = 0.0
        return th

    def set_deadzone_tau0(self, block: int, tau0: float) -> None:
        if not (math.isfinite(tau0) and tau0 > 0):
            raise InputError(f"joint_deadzone on {self.blocks[block][1]!r}: tau0 must be > 0 N m, got {tau0}")
        self.arrays["kw0"] = np.array(self.arrays["kw0"], dtype=float)
        self.arrays["kw0"][block] = tau0


@gc_paused()
def tree_model_from_tables(
    tree: Tree,
    effects: list[dict],
    gravity: ArrayLike = GRAVITY,
    iterations: int = EQ_ITERATIONS,
    where: str = "model",
    sigma_position: float | None = None,
    base_dir: Path = Path("."),
) -> TreeModel:
    """Expand ``effects`` on ``tree`` (see the module docstring); raises
    InputError naming the effect table and the problem. The tables are
    checked first (robot/tree_effects.py), then expanded in the order of
    the parameter vector: tracker and markers, the base spring, the joints
    and link springs, the gravity parameters (robot/tree_build.py)."""
    b = Builder(tree, where)
    by_kind = group_effects(effects, where)
    per_joint = per_joint_effects(tree, by_kind)
    links = link_springs(tree, by_kind)
    obs = tracker_and_markers(b, tree, by_kind, where)
    # the base spring sits before everything
    root_vj = 0
    if by_kind["base"]:
        i, table, w = by_kind["base"][0]
        root_vj = b.spring6(0, "base", "base", i, table, w, 2)
    vj_of_link, vj_of_joint = add_joints(b, tree, per_joint, links, root_vj)
    arrays, ne, grav, priors = core_arrays(b, tree, by_kind, obs, vj_of_link, gravity, where)
    return TreeModel(
        tree=tree,
        effects=list(effects),
        params=b.params,
        arrays=arrays,
        ne=ne,
        frames=obs.frames,
        vj_of_link=vj_of_link,
        gravity=grav,
        iterations=int(iterations),
        sigma_position=sigma_position,
        vj_of_joint=vj_of_joint,
        blocks=b.blocks,
        priors=priors,
    )


def _sigma_position(meas: dict, path: Path) -> float | None:
    """[measurements] sigma_position (m): > 0 and plausible for a tracker, or None."""
    sigma = meas.get("sigma_position")
    if sigma is None:
        return None
    sigma = table_number(sigma, f"{path}: [measurements]", "sigma_position")
    if sigma <= 0:
        raise InputError(f"{path}: [measurements] sigma_position = {sigma} must be > 0 (m)")
    if sigma > 0.05:
        raise InputError(
            f"{path}: [measurements] sigma_position = {sigma} m is implausible for a tracker "
            f"(a value in mm? write {sigma / 1000:g} for {sigma:g} mm)"
        )
    return sigma


def _gravity(doc: dict, path: Path) -> tuple[np.ndarray, int]:
    """The [gravity] table: its vector (m/s^2; about 9.81 long, or zero) and iterations (>= 1)."""
    grav = doc.get("gravity", {})
    if not isinstance(grav, dict):
        raise InputError(f"{path}: [gravity] must be a table")
    unknown = sorted(set(grav) - {"vector", "iterations"})
    if unknown:
        names = ", ".join(map(V.shown, unknown))
        raise InputError(f"{path}: [gravity] has unknown key(s) {names} (allowed: vector, iterations)")
    vector = grav.get("vector", list(GRAVITY))
    g = np.asarray(vector, dtype=float) if isinstance(vector, list) else None
    if g is None or g.shape != (3,) or not np.all(np.isfinite(g)):
        raise InputError(f"{path}: [gravity] vector must be [gx, gy, gz] in m/s^2, got {vector!r}")
    if g.any() and not 0.5 < np.linalg.norm(g) < 30:
        raise InputError(
            f"{path}: [gravity] vector has magnitude {np.linalg.norm(g):g} m/s^2; expected about 9.81 "
            f"(or [0, 0, 0] to switch gravity off)"
        )
    its = grav.get("iterations", EQ_ITERATIONS)
    if isinstance(its, bool) or not isinstance(its, int) or its < 1:
        raise InputError(f"{path}: [gravity] iterations must be an integer >= 1 (1 = first order), got {its!r}")
    return g, its


def load_tree_model(path: str | Path) -> TreeModel:
    """Read a model TOML whose ``[measurements] kind = "absolute"`` (section 6)."""
    path = Path(path)
    doc = read_toml(path, "model")
    robot = doc.get("robot")
    if not isinstance(robot, dict) or not isinstance(robot.get("urdf"), str):
        raise InputError(f'{path}: missing [robot] table with urdf = "robot.urdf"')
    urdf = Path(robot["urdf"])
    urdf = urdf if urdf.is_absolute() else path.parent / urdf
    base = robot.get("base_link", "base_link")
    if not isinstance(base, str):
        raise InputError(f"{path}: [robot] base_link must be a link name")
    tree = load_tree(urdf, base)
    sigma = _sigma_position(doc.get("measurements", {}), path)
    g, its = _gravity(doc, path)
    effects = doc.get("effect", [])
    if not isinstance(effects, list):
        raise InputError(f"{path}: 'effect' must be an array of tables [[effect]]")
    m = tree_model_from_tables(tree, effects, g, its, str(path), sigma, path.parent)
    m.path = path
    m.robot_table = robot
    m.plan = plan_table(doc, path)
    return m


def model_kind(path: str | Path) -> str:
    """The ``[measurements] kind`` of a model file: "deflection" (section 3,
    the default) or "absolute" (section 6)."""
    path = Path(path)
    doc = read_toml(path, "model")
    meas = doc.get("measurements", {})
    kind = meas.get("kind", "deflection") if isinstance(meas, dict) else "deflection"
    if kind not in MEASUREMENT_KINDS:
        raise InputError(
            f"{path}: [measurements] kind = {kind!r}; choose one of {', '.join(repr(k) for k in MEASUREMENT_KINDS)}"
        )
    return kind
