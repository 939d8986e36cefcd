"""The chain-shaped builder of the one tree model: a serial-chain model
(robot/model.py ``Model``, sections 2-5) as a TreeModel (robot/tree_model.py),
evaluated by the tree core. Model.tool_compliance and compensation
(robot/compensate.py) take it from here."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from . import catalogue
from .model_core import SPRING_BASE, SPRING_FRAME, SPRING_JOINT, SPRING_TOOL
from .tree import Tree, load_tree
from .tree_model import TreeModel, tree_model_from_tables

if TYPE_CHECKING:
    from .model import Model

__all__ = ["ChainTree", "chain_tree_model", "VARYING", "LOAD_NONLINEAR"]

#: joint kinds whose compliance depends on the posture (a per-posture value of the joint's c)
VARYING = catalogue.POSTURE_DEPENDENT
#: joint kinds whose deflection is not linear in the joint torque (the core's cubic, dead-zone laws)
LOAD_NONLINEAR = tuple(e.name for e in catalogue.ENTRIES if e.load_nonlinear)


@dataclass
class ChainTree:
    """A chain model's tree model, the parameters of its posture-dependent
    joint compliances ``varying`` [(theta index, chain joint index)], the
    chain as a tree, and the chain's spring (stype, 1-based joint index) of
    every elastic block of the tree model (``springs``, in block order)."""

    model: TreeModel
    varying: list[tuple[int, int]]
    tree: Tree
    springs: list[tuple[int, int]]


def _known(t: object) -> float:
    """A joint term's known value, 0 while it has none (the tree's place of it)."""
    return 0.0 if t.value is None else float(t.value[0])


def chain_tree_model(model: Model, where: str = "model") -> ChainTree:
    """The tree model of a serial-chain model (sections 2-5), an effect
    without a value yet at 0 (an evaluation checks the values first): the chain from base_link to
    tool_frame alone, no masses, gravity off, first-order equilibrium;
    ``joint`` springs the linear law on the joint's virtual joint (a
    posture-dependent compliance, joint_profile, gravity_compensator or
    joint_harmonic, a placeholder 0 that takes its value per posture:
    ``varying``), joint_cubic / joint_deadzone the core's laws on that
    joint, link / base / tool springs 6-dof spring joints at the frames of
    section 2 (the tool spring: the tool link's own); point_offset concerns
    measured points and is left out."""
    chain = model.chain
    full = load_tree(chain.urdf, chain.base_link)
    # the chain alone, its joints numbered along it (q order), no masses
    path = [replace(j, index=k) for k, j in enumerate(full.path(chain.tool_frame))]
    tree = Tree(full.urdf, chain.base_link, path, [chain.base_link] + [j.child for j in path], {})
    eff: list[dict] = [
        {"kind": "tracker", "fixed": True},
        {"kind": "marker", "target": chain.tool_frame, "fixed": True},
    ]
    linear = {}
    varying = set()
    for t in model.terms:
        if t.kind == "joint":
            linear[t.joint] = linear.get(t.joint, 0.0) + _known(t)
        elif t.kind in VARYING:
            varying.add(t.joint)
    nonlin = {t.joint: t for t in model.terms if t.kind in LOAD_NONLINEAR}
    for j in sorted(set(linear) | varying | set(nonlin)):
        name = chain.joint_names[j]
        # a posture-dependent compliance: a placeholder, the value comes per row
        eff.append({"kind": "joint", "target": name, "value": 0.0 if j in varying else linear.get(j, 0.0)})
        t = nonlin.get(j)
        if t is not None and t.kind == "joint_cubic":
            eff.append({"kind": "joint_cubic", "target": name, "value": _known(t)})
        elif t is not None:
            eff.append(
                {"kind": "joint_deadzone", "target": name, "value": _known(t), "tau0": t.geometry.get("tau0", 1.0)}
            )
    six = model.six_values([t for t in model.terms if t.kind == "six" and t.value is not None])
    for t in model.terms:  # a spring without its value yet: its place (its Jacobian), value 0
        if t.kind == "six" and t.spring not in six:
            six[t.spring] = np.zeros((6, 6))
    for (stype, k), C in six.items():
        if stype == SPRING_BASE:
            eff.append({"kind": "base", "value": C.tolist()})
        elif stype == SPRING_FRAME:
            eff.append({"kind": "link", "target": chain.parents[k - 1], "value": C.tolist()})
        elif stype == SPRING_TOOL:
            eff.append({"kind": "link", "target": chain.tool_frame, "value": C.tolist()})
    tm = tree_model_from_tables(tree, eff, (0.0, 0.0, 0.0), 1, where)
    rows = [(tm.index(f"{chain.joint_names[j]}.c"), j) for j in sorted(varying)]
    spring_of = {("base", "base"): (SPRING_BASE, 0), ("link", chain.tool_frame): (SPRING_TOOL, 0)}
    spring_of.update({("link", p): (SPRING_FRAME, k + 1) for k, p in enumerate(chain.parents)})
    spring_of.update({("joint", n): (SPRING_JOINT, k + 1) for k, n in enumerate(chain.joint_names)})
    return ChainTree(tm, rows, tree, [spring_of[b] for b in tm.blocks])
