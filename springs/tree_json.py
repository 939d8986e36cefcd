"""Spring trees from JSON (the input of ``stiffkit robot tree``).

A file describes one mechanism at one posture (SI: m, N, rad)::

    {"tool": [x, y, z],                 point where C and K are wanted
     "tool_axes": [[...],[...],[...]],  optional, columns = result axes
     "lscale": 0.5,                     optional characteristic length
     "tree": NODE}

NODE is ``{"series": [NODE, ...]}``, ``{"parallel": [NODE, ...]}``,
``{"spring": {"compliance" | "stiffness": 6x6 | "file": "link.json",
"pos": [x,y,z], "rot": 3x3}}`` or ``{"joint": {"type", "axis", "point",
"compliance" | "stiffness" | "passive"}}``; a spring ``file`` is a
``stiffkit link`` JSON result, relative to the tree file's folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.linkjson import read_link_compliance
from ..io.tables import read_json
from .tree import Joint, Node, Spring, TreeResult, evaluate, parallel, series

__all__ = ["TreeFile", "parse_node", "load_tree"]


def parse_node(d, base: Path) -> Node:
    """The spring-tree node of one JSON object (files relative to ``base``)."""
    if not isinstance(d, dict) or len(d) != 1:
        raise InputError(f"a tree node is one of {{series|parallel|spring|joint: ...}}, got {d!r:.80}")
    ((key, val),) = d.items()
    if key in ("series", "parallel"):
        if not isinstance(val, list) or not val:
            raise InputError(f"{key}: needs a non-empty list of nodes")
        kids = [parse_node(v, base) for v in val]
        return series(*kids) if key == "series" else parallel(*kids)
    if key == "spring":
        kinds = [k for k in ("compliance", "stiffness", "file") if k in val]
        if len(kinds) != 1:
            raise InputError("spring: give exactly one of compliance, stiffness, file")
        if kinds[0] == "file":
            f = Path(val["file"])
            m, kind = read_link_compliance(f if f.is_absolute() else base / f, "spring"), "compliance"
        else:
            m, kind = np.asarray(val[kinds[0]], dtype=float), kinds[0]
        return Spring(m, pos=val.get("pos", [0, 0, 0]), rot=val.get("rot", np.eye(3)), kind=kind)
    if key == "joint":
        comp = val.get("compliance", 0.0)
        if "stiffness" in val:
            comp = 1.0 / float(val["stiffness"])
        return Joint(
            val.get("type", "revolute"),
            val["axis"],
            val.get("point", [0, 0, 0]),
            compliance=float(comp),
            passive=bool(val.get("passive", False)),
        )
    raise InputError(f"unknown tree node {key!r}: use series, parallel, spring or joint")


@dataclass
class TreeFile:
    """A mechanism read from JSON: its tree, tool point and axes, length scale."""

    path: Path
    tree: Node
    tool: np.ndarray
    tool_axes: np.ndarray | None = None
    lscale: float | None = None

    def evaluate(self, rcond: float = 1e-9) -> TreeResult:
        """Compliance and stiffness at the tool (one core call)."""
        return evaluate(self.tree, tool=self.tool, tool_rot=self.tool_axes, lscale=self.lscale, rcond=rcond)


def load_tree(path) -> TreeFile:
    """Read a tree JSON file; InputError naming the file or the node for bad input."""
    path = Path(path)
    spec = read_json(path, "tree JSON")
    if not isinstance(spec, dict) or "tree" not in spec:
        raise InputError(f"{path}: no 'tree' key (see stiffkit robot tree --help)")
    return TreeFile(
        path=path,
        tree=parse_node(spec["tree"], path.parent),
        tool=np.asarray(spec.get("tool", [0, 0, 0]), dtype=float),
        tool_axes=None if spec.get("tool_axes") is None else np.asarray(spec["tool_axes"], dtype=float),
        lscale=spec.get("lscale"),
    )
