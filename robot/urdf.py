"""A serial chain read from a URDF (robot/tree.py reads it), as the arrays the core wants.

Convention (docs/calibration.md §1): a child frame is ``T_parent * T(origin xyz rpy) *
Rot(axis, q)``. Fixed joints are kept in the chain (they carry the frames
of the link springs); revolute (and continuous) joints are the actuated
ones, numbered q1..qN along the chain.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from .._core import calib as core
from ..errors import InputError
from ..field.synthetic import rot_exp
from .tree import _name_list, load_tree, parse_urdf

ACTUATED = ("revolute", "continuous")


@dataclass
class Chain:
    """Joints from ``base_link`` to ``tool_frame``.

    Attributes
    ----------
    joint_names, joint_types : every joint of the chain (fixed included)
    parents, children : their parent / child link names
    jrot (nj, 3, 3), jpos (nj, 3) : origin rotation and translation of each
        joint in its parent frame
    jaxis (nj, 3) : unit axis in the joint frame (zero for fixed joints)
    qidx (nj,) : 1-based index of the joint coordinate, 0 for fixed
    trot, tpos : tool frame in the last child frame (identity: the tool
        frame is the last link of the chain)
    """

    joint_names: list[str]
    joint_types: list[str]
    parents: list[str]
    children: list[str]
    jrot: np.ndarray
    jpos: np.ndarray
    jaxis: np.ndarray
    qidx: np.ndarray
    base_link: str
    tool_frame: str
    urdf: str = ""
    trot: np.ndarray = field(default_factory=lambda: np.eye(3))
    tpos: np.ndarray = field(default_factory=lambda: np.zeros(3))
    limits: list = field(default_factory=list)  # (lower, upper) or None per actuated joint (q order)
    collisions: dict = field(default_factory=dict)  # link -> capsules of its primitive <collision> shapes

    @property
    def dof(self) -> int:
        return int((self.qidx > 0).sum())

    @property
    def actuated(self) -> list[str]:
        """Names of the actuated joints in q order."""
        return [n for n, k in zip(self.joint_names, self.qidx) if k > 0]

    @property
    def links(self) -> list[str]:
        """Links of the chain from base_link to the tool frame."""
        return [self.base_link] + list(self.children)

    @property
    def characteristic_length(self) -> float:
        """The chain's length scale (m): the sum of the joint-origin offsets
        and the tool offset along the chain, an upper bound of the reach that
        does not depend on the posture. The default length of the stiffness
        indices (it scales with the robot, so the indices do not depend on
        the unit of length)."""
        total = float(np.linalg.norm(self.jpos, axis=1).sum() + np.linalg.norm(self.tpos))
        return total if total > 0 else 1.0

    def joint_index(self, name: str) -> int:
        """0-based index in the chain of the joint called ``name``."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise InputError(
                f"unknown joint {name!r}; the chain {self.base_link} -> {self.tool_frame} "
                f"has joints {', '.join(self.joint_names)}"
            ) from None

    def link_spring(self, link: str) -> tuple[int, int]:
        """(stype, 1-based joint index) of the 6-dof spring of ``link``: at
        the frame of the joint whose parent is this link (before its
        rotation); for the last link, the tool frame (stype 4)."""
        if link not in self.links:
            raise InputError(
                f"unknown link {link!r}; the chain {self.base_link} -> {self.tool_frame} "
                f"has links {', '.join(self.links)}"
            )
        if link in self.parents:
            return 2, self.parents.index(link) + 1
        return 4, 0

    def is_tool_spring(self, link: str) -> bool:
        """True when the spring of ``link`` sits at the tool frame (the last
        link, or the parent of a last fixed joint with the tool at its
        frame): then it is the ``tool`` spring."""
        stype, k = self.link_spring(link)
        if stype == 4:
            return True
        return (
            k == len(self.joint_names)
            and self.qidx[k - 1] == 0
            and np.allclose(self.trot, np.eye(3))
            and not np.any(self.tpos)
        )

    def core_arrays(self) -> dict:
        """The chain as Fortran-ordered arrays for the core."""
        nj = len(self.joint_names)
        return dict(
            jrot=np.asfortranarray(np.transpose(self.jrot, (1, 2, 0))) if nj else np.zeros((3, 3, 1), order="F"),
            jpos=np.asfortranarray(self.jpos.T) if nj else np.zeros((3, 1), order="F"),
            jaxis=np.asfortranarray(self.jaxis.T) if nj else np.zeros((3, 1), order="F"),
            qidx=np.asarray(self.qidx, dtype=np.int32) if nj else np.zeros(1, np.int32),
            trot=np.asfortranarray(self.trot),
            tpos=np.asarray(self.tpos, float),
        )

    def poses(self, Q: npt.ArrayLike) -> dict:
        """Frames of the chain at postures Q (N, dof), computed by the core's
        forward kinematics (sk_chain, one call): ``rf`` (N, nj, 3, 3), ``pf``
        (N, nj, 3) every joint frame F_k before its rotation, ``rt`` (N, 3, 3),
        ``pt`` (N, 3) the tool frame; base axes and coordinates."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        if Q.ndim != 2 or Q.shape[1] != self.dof:
            raise InputError(f"postures must have shape (N, {self.dof}), got {np.shape(Q)}")
        return core.chain_poses(self.core_arrays(), np.asfortranarray(Q.T))

    def joint_torques(self, Q: npt.ArrayLike, W: npt.ArrayLike) -> np.ndarray:
        """Torque (N m) about every joint's axis (N, nj; 0 for fixed joints)
        of the wrenches W (N, 6) (force, moment at the tool-frame origin, base
        axes) at postures Q (N, dof): tau_k = z_k . (m + (p_tool - p_k) x f),
        the load component that twists joint k (klimchik eq. 12: J_k^T W)."""
        W = np.atleast_2d(np.asarray(W, dtype=float))
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        if W.shape != (Q.shape[0], 6):
            raise InputError(f"wrenches must have shape ({Q.shape[0]}, 6), got {W.shape}")
        # rows share postures (several loads and markers each): frames once per posture
        Qu, inv = np.unique(Q, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        P = self.poses(Qu)
        axes = np.einsum("nkij,kj->nki", P["rf"], self.jaxis)[inv]
        lever = (P["pt"][:, None, :] - P["pf"])[inv]
        moment = W[:, None, 3:] + np.cross(lever, W[:, None, :3])
        return np.einsum("nki,nki->nk", axes, moment)

    def forward(self, q: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Tool frame (R (3,3), p (3,)) at posture q (the core's forward
        kinematics, as every other pose of the chain)."""
        P = self.poses(np.asarray(q, float).reshape(1, -1))
        return P["rt"][0], P["pt"][0]


def _rot_axis(axis: npt.ArrayLike, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    return rot_exp(np.asarray(axis, float) * angle)


def load_chain(urdf_path: str | Path, base_link: str = "base_link", tool_frame: str = "tool0") -> Chain:
    """Parse ``urdf_path`` and extract the chain base_link -> tool_frame.

    The URDF is read and checked as a tree (robot/tree.py: duplicate names,
    loops, broken references, masses); raises InputError naming the file
    when a link is missing, when the tool frame is not reached from
    base_link, or when a joint on the chain is not revolute, continuous or
    fixed (prismatic and mimic joints belong to tree models, section 6).
    """
    path = Path(urdf_path)
    urdf = parse_urdf(path)
    links = set(urdf.link_map)
    for name, what in ((base_link, "base_link"), (tool_frame, "tool_frame")):
        if name not in links:
            raise InputError(f"{path}: {what} {name!r} is not a link of the URDF (links: {_name_list(sorted(links))})")
    tree = load_tree(path, base_link, urdf=urdf)
    if tool_frame not in tree.links:
        raise InputError(f"{path}: {tool_frame!r} is not connected to {base_link!r} by a chain of joints")
    joints = tree.path(tool_frame)
    if not joints:
        raise InputError(f"{path}: tool_frame {tool_frame!r} is the base link: no chain")
    qidx, nq = [], 0
    for j in joints:
        if j.type not in ACTUATED + ("fixed",):
            raise InputError(
                f"{path}: joint {j.name!r} on the chain is {j.type!r}; "
                f"only revolute, continuous and fixed joints are supported"
            )
        if j.mimic is not None:
            raise InputError(
                f"{path}: joint {j.name!r} on the chain mimics {j.mimic[0]!r}; a serial-chain model takes "
                f"independent joints (use absolute measurements, section 6, for coupled joints)"
            )
        nq += j.type in ACTUATED
        qidx.append(nq if j.type in ACTUATED else 0)
    if nq == 0:
        raise InputError(f"{path}: no revolute joint between {base_link!r} and {tool_frame!r}")
    return Chain(
        joint_names=[j.name for j in joints],
        joint_types=[j.type for j in joints],
        parents=[j.parent for j in joints],
        children=[j.child for j in joints],
        jrot=np.array([j.origin[:3, :3] for j in joints]),
        jpos=np.array([j.origin[:3, 3] for j in joints]),
        jaxis=np.array([j.axis for j in joints]),
        qidx=np.array(qidx, dtype=np.int32),
        base_link=base_link,
        tool_frame=tool_frame,
        urdf=str(path),
        limits=[j.limit for j in joints if j.type in ACTUATED],
        collisions={ln: c for ln, c in tree.collisions.items() if ln == base_link or ln in {j.child for j in joints}},
    )


def urdf_text(name: str, joints: list[dict]) -> str:
    """A URDF document for a chain: joints = [{name, type, parent, child,
    xyz, rpy, axis}] (used by the synthetic-data generator)."""
    links = []
    for j in joints:
        for ln in (j["parent"], j["child"]):
            if ln not in links:
                links.append(ln)
    out = ['<?xml version="1.0"?>', f'<robot name="{name}">']
    for ln in links:
        out.append(f'  <link name="{ln}"/>')
    for j in joints:
        xyz = " ".join(f"{v:.17g}" for v in j.get("xyz", (0, 0, 0)))
        rpy = " ".join(f"{v:.17g}" for v in j.get("rpy", (0, 0, 0)))
        out.append(f'  <joint name="{j["name"]}" type="{j["type"]}">')
        out.append(f'    <parent link="{j["parent"]}"/>')
        out.append(f'    <child link="{j["child"]}"/>')
        out.append(f'    <origin xyz="{xyz}" rpy="{rpy}"/>')
        if j["type"] != "fixed":
            ax = " ".join(f"{v:.17g}" for v in j.get("axis", (0, 0, 1)))
            out.append(f'    <axis xyz="{ax}"/>')
            out.append('    <limit lower="-6.2832" upper="6.2832" effort="1000" velocity="1"/>')
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"
