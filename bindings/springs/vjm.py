"""Virtual-joint model of a serial chain on explicit poses (Klimchik et al. eq. 2).

The tool compliance of a serial chain of 1-dof joint springs (rank-1
compliances about/along the joint axes) and 6-dof link springs (6x6
compliances at given poses) is

    C = J_theta k_theta^-1 J_theta^T + sum_i T_i C_i T_i^T,   K_C = C^-1,

with J_theta the joint twists seen at the tool and T_i the transfer of link
i's spring to the tool (eqs. 8, 12). K_C exists only where C has full rank;
elsewhere (a serial singularity, or too few springs to load every
direction) the result lists the rigid wrenches instead. Poses come from
the caller (this module does no kinematics): arrays over N postures, one
core call for all of them.
"""
from __future__ import annotations

import numpy as np

from .._errors import InputError
from .tree import Joint, Spring, TreeResult, evaluate, series

__all__ = ["serial_vjm"]


def serial_vjm(joint_axes, joint_points, joint_compliances, link_compliances, link_points,
               link_rotations, tool, joint_types=None, tool_rot=None, lscale=None,
               rcond: float = 1e-9) -> TreeResult:
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
