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

from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.linkjson import read_link_compliance
from ..io.tables import read_json
from .tree import Joint, Node, Spring, TreeResult, evaluate, parallel, series

__all__ = ["TreeFile", "parse_node", "load_tree"]


_NODE_KEYS = ("series", "parallel", "spring", "joint")
_SPRING_KEYS = ("compliance", "stiffness", "file", "pos", "rot", "name")
_JOINT_KEYS = ("type", "axis", "point", "compliance", "stiffness", "passive", "name")


def _keys(val: object, allowed: Collection[str], where: str) -> dict:
    if not isinstance(val, dict):
        raise InputError(f"{where}: must be an object {{...}}, got {val!r:.60}")
    unknown = sorted(set(val) - set(allowed))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(map(V.shown, unknown))}; allowed: {', '.join(allowed)}")
    return val


def parse_node(d: object, base: Path, where: str = "tree") -> Node:
    """The spring-tree node of one JSON object (files relative to ``base``);
    ``where`` is the node's path in the document, for messages."""
    if not isinstance(d, dict) or len(d) != 1:
        raise InputError(f"{where}: a tree node is one of {{series|parallel|spring|joint: ...}}, got {d!r:.80}")
    ((key, val),) = d.items()
    at = f"{where}.{key}"
    if key in ("series", "parallel"):
        if not isinstance(val, list) or not val:
            raise InputError(f"{at}: needs a non-empty list of nodes")
        kids = [parse_node(v, base, f"{at}[{i}]") for i, v in enumerate(val)]
        return series(*kids) if key == "series" else parallel(*kids)
    if key == "spring":
        val = _keys(val, _SPRING_KEYS, at)
        kinds = [k for k in ("compliance", "stiffness", "file") if k in val]
        if len(kinds) != 1:
            raise InputError(f"{at}: give exactly one of compliance, stiffness, file")
        if kinds[0] == "file":
            if not isinstance(val["file"], str):
                raise InputError(f"{at}: file = {val['file']!r} must be a file name")
            f = Path(val["file"])
            m, kind = read_link_compliance(f if f.is_absolute() else base / f, at), "compliance"
        else:
            m, kind = val[kinds[0]], kinds[0]
        return Spring(
            m,
            pos=V.array(val.get("pos", [0, 0, 0]), f"{at}.pos", (3,), "position"),
            rot=V.array(val.get("rot", np.eye(3)), f"{at}.rot", (3, 3)),
            kind=kind,
            name=str(val.get("name", at)),
        )
    if key == "joint":
        val = _keys(val, _JOINT_KEYS, at)
        if "compliance" in val and "stiffness" in val:
            raise InputError(f"{at}: give compliance or stiffness, not both")
        passive = val.get("passive", False)
        if not isinstance(passive, bool):
            raise InputError(f"{at}: passive = {passive!r} must be true or false")
        comp = 0.0
        if "compliance" in val:
            comp = V.number(val["compliance"], f"{at}.compliance", lo=0.0)
        if "stiffness" in val:
            comp = 1.0 / V.number(val["stiffness"], f"{at}.stiffness", lo=0.0, lo_open=True)
        if "axis" not in val:
            raise InputError(f"{at}: missing 'axis' [x, y, z]")
        jtype = val.get("type", "revolute")
        if not isinstance(jtype, str):
            raise InputError(f"{at}: type = {jtype!r}: revolute or prismatic")
        return Joint(
            jtype,
            V.array(val["axis"], f"{at}.axis", (3,)),
            V.array(val.get("point", [0, 0, 0]), f"{at}.point", (3,), "position"),
            compliance=comp,
            passive=passive,
            name=str(val.get("name", at)),
        )
    raise InputError(f"{where}: unknown tree node {key!r}: use series, parallel, spring or joint")


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


def load_tree(path: Path | str) -> TreeFile:
    """Read a tree JSON file; InputError naming the file or the node for bad input."""
    path = Path(path)
    spec = read_json(path, "tree JSON")
    if not isinstance(spec, dict) or "tree" not in spec:
        raise InputError(f"{path}: no 'tree' key (see stiffkit robot tree --help)")
    unknown = sorted(set(spec) - {"tree", "tool", "tool_axes", "lscale", "note"})
    if unknown:
        names = ", ".join(map(V.shown, unknown))
        raise InputError(f"{path}: unknown key(s) {names}; allowed: tree, tool, tool_axes, lscale, note")
    axes = None
    if spec.get("tool_axes") is not None:
        axes = V.array(spec["tool_axes"], f"{path}: tool_axes", (3, 3))
        err = float(np.abs(axes.T @ axes - np.eye(3)).max())
        if not err < 1e-6:
            raise InputError(f"{path}: tool_axes is not a rotation matrix (|R^T R - I| = {err:.1e})")
    lscale = spec.get("lscale")
    if lscale is not None:
        lscale = V.number(lscale, f"{path}: lscale", "length", lo=0.0, lo_open=True)
    try:
        tree = parse_node(spec["tree"], path.parent, f"{path}: tree")
    except RecursionError:
        raise InputError(f"{path}: the tree is nested too deeply") from None
    return TreeFile(
        path=path,
        tree=tree,
        tool=V.array(spec.get("tool", [0, 0, 0]), f"{path}: tool", (3,), "position"),
        tool_axes=axes,
        lscale=lscale,
    )
