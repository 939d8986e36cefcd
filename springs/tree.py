"""Trees of generalised springs, evaluated in batch by the Fortran core.

Python face of core/sk_springs.f90 (Taghvaeipour et al. 2010 s3; Klimchik
et al. eq. 2). Build a tree from leaves and combinators, then evaluate it at
N postures in one core call::

    from stiffkit.springs import Spring, Joint, series, parallel, evaluate
    arm = series(Joint("revolute", [0, 0, 1], [0, 0, 0], compliance=1e-6),
                 Spring(c_link, pos=[0.5, 0, 0]),
                 Joint("revolute", [0, 0, 1], [0.5, 0, 0], compliance=1e-6),
                 Spring(c_link, pos=[1.0, 0, 0]))
    res = evaluate(arm, tool=[1.0, 0, 0])
    res.compliance[0], res.stiffness[0], res.rank[0]

Conventions (shared with core/sk_spatial.f90): twist (t, phi), wrench
(f, m), 6x6 compliance maps a wrench at the tool point to the twist there.
A leaf is a 6x6 compliance (or stiffness) given in its own axes at its own
point (``rot``: columns are its axes in world coordinates; ``pos``: the
point), like a ``stiffkit link`` result. Poses may be one (3,3)/(3,) for all
postures or an (N,3,3)/(N,3) array, one per posture.

A spring whose stiffness does not exist (rigid directions) and one whose
compliance does not exist (passive joints, mechanisms) are both fine: the
result lists the free twists and the rigid wrenches instead of inverting a
singular matrix, and ``rank`` says how many directions remain elastic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._core import springs as core
from ..errors import InputError
from ..io import validate as V
from ..io.linkjson import check_spring_matrix, read_link_compliance

__all__ = [
    "Spring",
    "Joint",
    "Series",
    "Parallel",
    "series",
    "parallel",
    "evaluate",
    "TreeResult",
    "load_link_compliance",
    "OP_SPRING",
    "OP_JOINT",
    "OP_SERIES",
    "OP_PARALLEL",
]

OP_SPRING, OP_JOINT, OP_SERIES, OP_PARALLEL = 1, 2, 3, 4
_JOINT_TYPES = {"revolute": 1, "prismatic": 2}

#: 6x6 compliance (SI) of a ``stiffkit link`` JSON result (stiffkit.io.linkjson)
load_link_compliance = read_link_compliance


def _as_pose(a: npt.ArrayLike, shape: tuple[int, ...], name: str) -> np.ndarray:
    a = V.array(a, name)
    if a.shape != shape and a.shape[1:] != shape:
        raise InputError(f"{name} must have shape {shape} or (N,) + {shape}, got {a.shape}")
    return a


@dataclass
class Spring:
    """Leaf: a 6x6 compliance (or stiffness) in local axes ``rot`` at point ``pos``."""

    matrix: np.ndarray
    pos: np.ndarray = None
    rot: np.ndarray = None
    kind: str = "compliance"
    name: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("compliance", "stiffness"):
            raise InputError(f"spring {self.name!r}: kind must be 'compliance' or 'stiffness'")
        self.matrix = check_spring_matrix(self.matrix, f"spring {self.name!r}: {self.kind}", error=1e-2)
        self.pos = _as_pose(np.zeros(3) if self.pos is None else self.pos, (3,), "pos")
        self.rot = _as_pose(np.eye(3) if self.rot is None else self.rot, (3, 3), "rot")
        err = np.abs(np.swapaxes(self.rot, -1, -2) @ self.rot - np.eye(3)).max() if self.rot.size else 0.0
        if not err < 1e-6:
            raise InputError(
                f"spring {self.name!r}: rot is not a rotation matrix "
                f"(|R^T R - I| = {err:.1e}); its columns are the spring's axes"
            )


@dataclass
class Joint:
    """Leaf: a one-dof joint, revolute (axis through ``point``) or prismatic.

    ``compliance`` (rad/(N m) or m/N) makes it a rank-1 spring, the
    virtual joint of a VJM; ``passive=True`` makes it free (zero stiffness);
    a locked joint is simply left out.
    """

    type: str
    axis: np.ndarray
    point: np.ndarray = None
    compliance: float = 0.0
    passive: bool = False
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.type, str) or self.type not in _JOINT_TYPES:
            raise InputError(f"joint {self.name!r}: type = {self.type!r} must be revolute or prismatic")
        self.axis = _as_pose(self.axis, (3,), f"joint {self.name!r}: axis")
        self.point = _as_pose(np.zeros(3) if self.point is None else self.point, (3,), f"joint {self.name!r}: point")
        self.compliance = V.number(self.compliance, f"joint {self.name!r}: compliance", lo=0.0)
        if not isinstance(self.passive, (bool, np.bool_)):
            raise InputError(f"joint {self.name!r}: passive = {self.passive!r} must be True or False")


@dataclass
class Series:
    """Serial array (eqs. 17-22): the children carry the same wrench."""

    children: tuple


@dataclass
class Parallel:
    """Parallel array (eq. 16): the children share the same end bodies."""

    children: tuple


Node = Spring | Joint | Series | Parallel


def series(*children: Node) -> Series:
    if not children:
        raise InputError("series() needs at least one child")
    return Series(tuple(children))


def parallel(*children: Node) -> Parallel:
    if not children:
        raise InputError("parallel() needs at least one child")
    return Parallel(tuple(children))


@dataclass(frozen=True)
class TreeResult:
    """Tool compliance and stiffness at N postures.

    compliance : (N,6,6) on the wrenches orthogonal to the free twists;
        the compliance proper exists where ``nfree == 0``.
    stiffness : (N,6,6) on the motions orthogonal to the rigid wrenches;
        the stiffness proper exists where ``nrigid == 0``.
    free : (N,6,6), columns [:nfree] are the free twists (t, phi)
        (motions at zero stiffness: mechanism or singular posture).
    rigid : (N,6,6), columns [:nrigid] are the rigid wrenches (f, m)
        (loads carried with zero deflection: e.g. a serial singularity).
    ratio : (N,) smallest/largest stiffness eigenvalue of the elastic part
        in the scaled space (0 < ratio <= 1; small near a singularity).
    """

    compliance: np.ndarray
    stiffness: np.ndarray
    free: np.ndarray
    nfree: np.ndarray
    rigid: np.ndarray
    nrigid: np.ndarray
    ratio: np.ndarray
    lscale: float

    @property
    def rank(self) -> np.ndarray:
        """Number of elastic directions (6 - nfree - nrigid) per posture."""
        return 6 - self.nfree - self.nrigid

    @property
    def compliance_exists(self) -> np.ndarray:
        """(N,) bool: no free motion, the 6x6 compliance is the compliance proper."""
        return self.nfree == 0

    @property
    def stiffness_exists(self) -> np.ndarray:
        """(N,) bool: no rigid direction, the 6x6 stiffness (K_C) is the stiffness proper."""
        return self.nrigid == 0

    def free_twists(self, i: int = 0) -> np.ndarray:
        return self.free[i, :, : self.nfree[i]]

    def rigid_wrenches(self, i: int = 0) -> np.ndarray:
        return self.rigid[i, :, : self.nrigid[i]]


class _Program:
    def __init__(self) -> None:
        self.prog: list[tuple[int, int]] = []
        self.springs: list[Spring] = []
        self.joints: list[Joint] = []

    def add(self, node: Node) -> None:
        if isinstance(node, Spring):
            self.springs.append(node)
            self.prog.append((OP_SPRING, len(self.springs)))
        elif isinstance(node, Joint):
            self.joints.append(node)
            self.prog.append((OP_JOINT, len(self.joints)))
        elif isinstance(node, (Series, Parallel)):
            if not node.children:
                raise InputError("empty series/parallel")
            for ch in node.children:
                self.add(ch)
            op = OP_SERIES if isinstance(node, Series) else OP_PARALLEL
            self.prog.append((op, len(node.children)))
        else:
            raise InputError(f"not a spring-tree node: {type(node).__name__}")


def _stack(items: Sequence[np.ndarray], shape: tuple[int, ...], n: int) -> np.ndarray:
    """(n, k) + shape array of per-leaf poses, broadcast over postures."""
    out = np.empty((n, len(items)) + shape)
    for i, a in enumerate(items):
        out[:, i] = a
    return out


def _npostures(prog: _Program, tool: npt.ArrayLike) -> int:
    sizes = {np.asarray(tool).shape[0]} if np.asarray(tool).ndim == 2 else set()
    for s in prog.springs:
        if s.pos.ndim == 2:
            sizes.add(s.pos.shape[0])
        if s.rot.ndim == 3:
            sizes.add(s.rot.shape[0])
    for j in prog.joints:
        if j.axis.ndim == 2:
            sizes.add(j.axis.shape[0])
        if j.point.ndim == 2:
            sizes.add(j.point.shape[0])
    if len(sizes) > 1:
        raise InputError(f"pose arrays disagree on the number of postures: {sorted(sizes)}")
    return sizes.pop() if sizes else 1


def _default_lscale(prog: _Program, tool: np.ndarray) -> float:
    pts = [np.reshape(s.pos, (-1, 3)) for s in prog.springs]
    pts += [np.reshape(j.point, (-1, 3)) for j in prog.joints]
    if not pts:
        return 1.0
    d = max(float(np.max(np.linalg.norm(p - np.reshape(tool, (-1, 3))[:1], axis=1))) for p in pts)
    return d if d > 0 else 1.0


def evaluate(
    tree: Node,
    tool: npt.ArrayLike = (0.0, 0.0, 0.0),
    tool_rot: npt.ArrayLike | None = None,
    lscale: float | None = None,
    rcond: float = 1e-9,
) -> TreeResult:
    """Evaluate a spring tree at the tool point for N postures, one core call.

    Parameters
    ----------
    tree : Spring, Joint, Series or Parallel
    tool : (3,) or (N,3) tool point, world coordinates
    tool_rot : None (world axes) or (3,3)/(N,3,3) axes in which results are expressed
    lscale : characteristic length for the rank decisions (default: the
        largest distance from the tool to a spring or joint point; give it
        in the same unit as the positions). Results do not depend on it
        except through which directions count as free/rigid.
    rcond : eigenvalue ratio below which a direction counts as free (or rigid)
    """
    prog = _Program()
    prog.add(tree)
    tool = V.array(tool, "tool")
    if tool.shape[-1:] != (3,) or tool.ndim > 2:
        raise InputError(f"tool must have shape (3,) or (N, 3), got {tool.shape}")
    if tool_rot is not None:
        tool_rot = _as_pose(tool_rot, (3, 3), "tool_rot")
    rcond = V.number(rcond, "rcond", lo=0.0, hi=1.0, hi_open=True)
    n = _npostures(prog, tool)
    if lscale is None:
        lscale = _default_lscale(prog, tool)
    else:
        lscale = V.number(lscale, "lscale", lo=0.0, lo_open=True)
    ns, nj = len(prog.springs), len(prog.joints)
    lmat = np.zeros((6, 6, max(ns, 1)), order="F")
    lkind = np.zeros(max(ns, 1), dtype=np.int32)
    for i, s in enumerate(prog.springs):
        lmat[:, :, i] = s.matrix
        lkind[i] = 0 if s.kind == "compliance" else 1
    # (n, ns, 3, 3) with each rotation transposed is the Fortran (3,3,ns,n) array
    lrot = (
        _stack([np.swapaxes(s.rot, -1, -2) for s in prog.springs], (3, 3), n).T
        if ns
        else np.zeros((3, 3, 1, n), order="F")
    )
    lpos = _stack([s.pos for s in prog.springs], (3,), n).T if ns else np.zeros((3, 1, n), order="F")
    jtype = np.array([_JOINT_TYPES[j.type] for j in prog.joints] or [1], dtype=np.int32)
    jcomp = np.array([j.compliance for j in prog.joints] or [0.0])
    jpas = np.array([int(j.passive) for j in prog.joints] or [0], dtype=np.int32)
    jaxis = _stack([j.axis for j in prog.joints], (3,), n).T if nj else np.zeros((3, 1, n), order="F")
    jpoint = _stack([j.point for j in prog.joints], (3,), n).T if nj else np.zeros((3, 1, n), order="F")
    if nj and np.any(np.linalg.norm(jaxis, axis=0) == 0):
        raise InputError("a joint axis is the zero vector")
    for name, arr in (("spring positions", lpos), ("joint axes", jaxis), ("joint points", jpoint), ("tool", tool)):
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name} contain NaN or Inf")
    tpos = np.broadcast_to(tool, (n, 3)).T
    trot = np.broadcast_to(np.eye(3) if tool_rot is None else np.swapaxes(tool_rot, -1, -2), (n, 3, 3)).T
    progarr = np.asfortranarray(np.array(prog.prog, dtype=np.int32).T)
    c, k, free, nfree, rigid, nrigid, ratio = core.spring_tree(
        progarr, lkind, lmat, lrot, lpos, jtype, jcomp, jpas, jaxis, jpoint, tpos, trot, lscale, rcond
    )
    return TreeResult(
        compliance=c, stiffness=k, free=free, nfree=nfree, rigid=rigid, nrigid=nrigid, ratio=ratio, lscale=float(lscale)
    )
