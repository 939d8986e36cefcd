"""Virtual-joint model of a serial chain as a serial array of generalised springs.

The tool compliance of a serial chain of 1-dof joint springs (rank-1
compliances about/along the joint axes) and 6-dof link springs (6x6
compliances at given poses) is (Klimchik et al. eq. 2; Taghvaeipour et al.
eqs. 17-22 with every spring moved to the tool)

    C = J_theta k_theta^-1 J_theta^T + sum_i T_i C_i T_i^T,   K_C = C^-1.

One implementation, two faces:

* a URDF model's tool compliance (``stiffkit.load_model(...).tool_compliance``)
  is the tool point's compliance of the core's one robot model, the tree
  model of the chain (core/sk_chain_tree.f90, core/sk_tree_point.f90); the
  spring-tree evaluator (core/sk_springs.f90, this module) sums the terms
  J_i C_i J_i^T with core/sk_spatial.f90's block forms (``revolute_twist``,
  ``spring_at``), and tests/test_chain_springs.py checks that the two agree;
* the robot's poses come from one forward kinematics, the tree's
  (sk_chain via ``Chain.poses``), for a URDF robot: :func:`model_tree` /
  :func:`model_vjm` build the serial array of a model's springs on those
  poses.

What the springs face adds, and why :func:`serial_vjm` stays: it is the
generalised-spring serial array on *explicit* poses, not only a URDF chain
of revolute joints with compliances: joints may be prismatic or passive
(free: the chain is a mechanism and the free twists are reported), leaves
may be stiffness matrices, and it nests inside parallel arrays (the legs
of a parallel robot). Where K_C does not exist (a serial singularity, or
too few springs to load every direction) it lists the rigid wrenches,
where Model.tool_compliance gives the rank. Poses are arrays over N
postures, one core call for all of them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..robot.model import SPRING_BASE, SPRING_FRAME, SPRING_JOINT, Model
from .tree import Joint, Series, Spring, TreeResult, evaluate, series

__all__ = ["serial_vjm", "model_tree", "model_vjm"]


def serial_vjm(
    joint_axes: npt.ArrayLike,
    joint_points: npt.ArrayLike,
    joint_compliances: npt.ArrayLike,
    link_compliances: npt.ArrayLike,
    link_points: npt.ArrayLike,
    link_rotations: npt.ArrayLike,
    tool: npt.ArrayLike,
    joint_types: Sequence[str] | None = None,
    tool_rot: npt.ArrayLike | None = None,
    lscale: float | None = None,
    rcond: float = 1e-9,
) -> TreeResult:
    """Tool compliance/stiffness of a serial VJM at N postures.

    Parameters
    ----------
    joint_axes, joint_points : (N, nj, 3) or (nj, 3) joint axes and points (world)
    joint_compliances : (nj,) rad/(N m) (revolute) or m/N (prismatic); 0 = rigid
    link_compliances : (nl, 6, 6) link compliances in link axes at the link's end point
    link_points : (N, nl, 3) or (nl, 3) where each link compliance is defined
    link_rotations : (N, nl, 3, 3) or (nl, 3, 3) link axes (columns) in world
    tool : (N, 3) or (3,) tool point
    joint_types : nj strings ("revolute" default, or "prismatic")
    """
    ja, jp = np.asarray(joint_axes, float), np.asarray(joint_points, float)
    jc = np.atleast_1d(np.asarray(joint_compliances, float))
    lc = np.asarray(link_compliances, float).reshape(-1, 6, 6)
    lp, lr = np.asarray(link_points, float), np.asarray(link_rotations, float)
    nj, nl = jc.size, lc.shape[0]
    if ja.shape[-2:] != (nj, 3) or jp.shape[-2:] != (nj, 3):
        raise InputError(f"joint axes/points must be (N, {nj}, 3) or ({nj}, 3) for {nj} joint compliances")
    if lp.shape[-2:] != (nl, 3) or lr.shape[-3:] != (nl, 3, 3):
        raise InputError(f"link points/rotations must be (N, {nl}, 3)/(N, {nl}, 3, 3) for {nl} links")
    types = joint_types or ["revolute"] * nj
    parts = [Joint(types[j], ja[..., j, :], jp[..., j, :], compliance=float(jc[j])) for j in range(nj)]
    parts += [Spring(lc[i], pos=lp[..., i, :], rot=lr[..., i, :, :]) for i in range(nl)]
    if not parts:
        raise InputError("serial_vjm needs at least one joint or link")
    return evaluate(series(*parts), tool=tool, tool_rot=tool_rot, lscale=lscale, rcond=rcond)


def model_tree(model: Model, Q: npt.ArrayLike) -> tuple[Series, np.ndarray]:
    """The serial array of a URDF model's springs at postures Q (N, dof).

    Poses from the core's forward kinematics (sk_chain via Chain.poses);
    joint springs become revolute Joint leaves about their world axes,
    link springs 6x6 leaves at their joint frames F_k, the base spring at
    the base origin, the tool spring at the tool frame (docs/calibration.md §2).
    Returns (tree, tool (N,3)): evaluate(tree, tool=tool) is the tool
    compliance in base axes about the tool-frame origin, the same as
    model.tool_compliance(Q). Joint compliances must not depend on the
    posture here (joint_profile / gravity_compensator: use the model).
    """
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    chain = model.chain
    poses = chain.poses(Q)
    jc = model.joint_compliances(Q)
    parts = []
    for k in sorted(jc):
        c = jc[k]
        if np.ptp(c) > 1e-12 * np.abs(c).max():
            raise InputError(
                f"joint {chain.joint_names[k]!r}: its compliance depends on the posture; "
                f"the spring tree takes constant joint compliances (use Model.tool_compliance)"
            )
        axis = poses["rf"][:, k] @ chain.jaxis[k]
        parts.append(Joint("revolute", axis, poses["pf"][:, k], compliance=float(c[0]), name=chain.joint_names[k]))
    for (stype, k), C in model.six_values().items():
        if stype == SPRING_FRAME:
            parts.append(
                Spring(
                    C, pos=poses["pf"][:, k - 1], rot=poses["rf"][:, k - 1], name=f"link at {chain.joint_names[k - 1]}"
                )
            )
        elif stype == SPRING_BASE:
            parts.append(Spring(C, name="base"))
        elif stype != SPRING_JOINT:
            parts.append(Spring(C, pos=poses["pt"], rot=poses["rt"], name="tool"))
    if not parts:
        raise InputError("the model has no spring with a value")
    return series(*parts), poses["pt"]


def model_vjm(model: Model, Q: npt.ArrayLike, lscale: float | None = None, rcond: float = 1e-9) -> TreeResult:
    """Tool compliance/stiffness of a URDF model through the spring-tree
    evaluator (one core call): the result Model.tool_compliance gives, plus
    the free twists / rigid wrenches where a matrix does not exist.
    lscale defaults to the chain's characteristic length."""
    tree, tool = model_tree(model, Q)
    lscale = model.chain.characteristic_length if lscale is None else lscale
    return evaluate(tree, tool=tool, lscale=lscale, rcond=rcond)
