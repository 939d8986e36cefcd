"""The ``[[effect]]`` tables of a tree model (docs/calibration.md section
6), read and checked before anything is built: grouped by kind with their
keys checked against the catalogue (robot/catalogue.py), the per-joint
effects assigned to their joints (a table naming a joint over one for
``all``), the link springs to their links. Every failure names the effect
table (``[[effect]] #3 (joint, target 'elbow')``) and the problem.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from . import catalogue
from .effect_values import effect_kind, effect_where
from .tree import Tree

__all__ = [
    "ABS_KINDS",
    "KEYS",
    "Effect",
    "group_effects",
    "joint_targets",
    "link_springs",
    "per_joint_effects",
    "table_number",
    "table_vector",
]

ABS_KINDS = catalogue.kinds(catalogue.ABSOLUTE)  # the gravity parameters last: the reduction keeps compliances first
KEYS = catalogue.keys(catalogue.ABSOLUTE)

#: one effect table: (its index among the [[effect]] tables, the table, its label for messages)
Effect = tuple[int, dict, str]


def table_vector(table: dict, key: str, n: int, where: str) -> np.ndarray:
    """``table[key]`` as n finite numbers."""
    try:
        v = np.asarray(table[key], dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {key} must be a list of {n} numbers, got {table[key]!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InputError(f"{where}: {key} must be {n} finite numbers, got {table[key]!r}")
    return v


def table_number(v: object, where: str, what: str) -> float:
    """``v`` as a finite number (not a boolean)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise InputError(f"{where}: {what} must be a finite number, got {v!r}")
    return float(v)


def group_effects(effects: list[dict], where: str) -> dict[str, list[Effect]]:
    """The effect tables by kind (every kind of absolute data a key, in
    the file's order), each of a known kind with known keys; at most one
    tracker and one base."""
    by_kind: dict[str, list[Effect]] = {k: [] for k in ABS_KINDS}
    for i, table in enumerate(effects):
        if not isinstance(table, dict):
            raise InputError(f"{where}: [[effect]] #{i + 1} is not a table")
        w = effect_where(where, i, table)
        by_kind[effect_kind(table, w, catalogue.ABSOLUTE)].append((i, table, w))
    if len(by_kind["tracker"]) > 1:
        raise InputError(f"{where}: more than one tracker effect")
    if len(by_kind["base"]) > 1:
        raise InputError(f"{where}: more than one base effect")
    return by_kind


def joint_targets(tree: Tree, table: dict, where: str, kind: str, moving_only: bool) -> list[str]:
    """The joints a per-joint table names: its ``target`` or every (moving) joint for ``all``."""
    target = table.get("target", "all")
    if not isinstance(target, str) or not target:
        raise InputError(f"{where}: target must be a joint name or 'all'")
    if target == "all":
        return [j.name for j in tree.joints if (j.moving or not moving_only)]
    j = tree.joint(target)
    if moving_only and not j.moving:
        raise InputError(f"{where}: joint {target!r} is fixed; {kind} needs a moving joint")
    return [target]


def per_joint_effects(tree: Tree, by_kind: dict[str, list[Effect]]) -> dict[str, dict[str, Effect]]:
    """Which joint gets which per-joint effect: {joint: {kind: effect}},
    one of each kind per joint. A table naming one joint takes precedence
    over target = "all" (which then means every other joint); two tables
    naming one joint, or two "all", are an error; a law (joint_cubic, ...)
    needs the joint's ``joint`` effect, and one law per joint."""
    per_joint: dict[str, dict[str, Effect]] = {}
    for kind, moving in ((e.name, e.moving) for e in catalogue.ENTRIES if e.per_joint and catalogue.ABSOLUTE in e.data):
        tables = sorted(by_kind[kind], key=lambda e: e[1].get("target", "all") == "all")
        alls = [e for e in tables if e[1].get("target", "all") == "all"]
        if len(alls) > 1:
            raise InputError(f"{alls[1][2]}: a second {kind} effect with target 'all' ({alls[0][2]})")
        for i, table, w in tables:
            every = table.get("target", "all") == "all"
            for jn in joint_targets(tree, table, w, kind, moving):
                if kind == "lateral" and tree.joint(jn).type == "prismatic":
                    if every:
                        continue
                    raise InputError(f"{w}: lateral compliance needs a revolute joint; {jn!r} is prismatic")
                slot = per_joint.setdefault(jn, {})
                if kind in slot:
                    if every:
                        continue
                    raise InputError(f"{w}: joint {jn!r} already has a {kind} effect ({slot[kind][2]})")
                slot[kind] = (i, table, w)
    for jn, slot in per_joint.items():
        for nl in catalogue.LAW_KINDS:
            if nl in slot and "joint" not in slot:
                raise InputError(f"{slot[nl][2]}: {nl} on {jn!r} needs a 'joint' effect on the same joint (its c)")
        laws = [k for k in catalogue.LAW_KINDS if k in slot]
        if len(laws) > 1:  # one law per joint's block
            raise InputError(f"{slot[laws[1]][2]}: joint {jn!r} has both {laws[0]} and {laws[1]}")
    return per_joint


def link_springs(tree: Tree, by_kind: dict[str, list[Effect]]) -> dict[str, Effect]:
    """The ``link`` tables by their link (one spring per link)."""
    links: dict[str, Effect] = {}
    for i, table, w in by_kind["link"]:
        target = table.get("target")
        if not isinstance(target, str) or target not in tree.links:
            raise InputError(f"{w}: target must be a link below {tree.root!r}; got {target!r}")
        if target in links:
            raise InputError(f"{w}: link {target!r} already has a spring ({links[target][2]})")
        links[target] = (i, table, w)
    return links
