"""The catalogue of candidate effects of the absolute diagnosis
(``calib.absolute_diagnose``), and which of them can act on the measured
points at all.

A candidate is an ``[[effect]]`` table the model lacks: every per-joint kind
(JOINT_KINDS) on every joint it applies to and on ``all``, a link spring on
every link that carries mass beyond it, the base spring. To add a kind:
give it a candidate generator in the catalogue (robot/catalogue.py); if its effect moves
links directly (not only through the weights), say which in
:func:`moved_links` (a kind it does not know is judged by its columns
only); if its size has a physical bound, give PLAUSIBLE_SIZE an entry.

A candidate that cannot move any measured point is *inert*: listed with the
reason, never scored, ranked or proposed (:func:`inert_reason`):

- structurally: its effect moves no link that carries a marker (a joint or
  a link spring on a branch without a marker, e.g. a head, a gripper's
  mimic fingers; it can only shift where a weight sits);
- numerically: its Jacobian columns are zero (below 1e-9 of the largest
  column of its kind, the reduction's rule), or, for kinds with a plausible
  size, an effect of that size moves no point by as much as the noise
  sigma in any row;
- or it duplicates an earlier candidate of its kind (the same column space:
  two coaxial joints at one point, a coupled joint written as two mimics):
  :func:`duplicate_of`.
"""

from __future__ import annotations

import math

import numpy as np

from ..robot import catalogue
from ..robot.tree_model import TreeModel, tree_model_from_tables

__all__ = ["absolute_candidates", "moved_links", "inert_reason", "JOINT_KINDS", "PLAUSIBLE_SIZE"]

#: per joint kinds, and the template of link / base springs among the candidates
JOINT_KINDS = ("joint_offset", "frame", "joint", "lateral")
SPRING_TEMPLATE = "beam"
#: the largest plausible size of one parameter of a kind (rad for angles, m for
#: lengths): a candidate whose effect at this size stays below the noise in every
#: row cannot be seen. Kinds without an entry (compliances) are judged by the
#: structure and by zero columns only.
PLAUSIBLE_SIZE = {
    "joint_offset": {"dq0": 0.1},
    "frame": {"dx": 0.01, "dy": 0.01, "dz": 0.01, "drx": 0.1, "dry": 0.1, "drz": 0.1},
}
#: a column below this fraction of the largest column of its kind is zero (round-off)
ZERO_COLUMN = 1e-9


def absolute_candidates(model: TreeModel) -> list[dict]:
    """Effect tables of every catalogued kind on every target the model
    lacks, the per-joint kinds also on ``all`` (robot/catalogue.py)."""
    return [table for table, _hint in catalogue.candidates(model, catalogue.ABSOLUTE)]


def _subtree(model: TreeModel, link: str) -> set[str]:
    """``link`` and every link below it."""
    out, todo = set(), [link]
    while todo:
        ln = todo.pop()
        out.add(ln)
        todo += [j.child for j in model.tree.children(ln)]
    return out


#: kinds whose target is a joint and whose effect moves the links below it (robot/catalogue.py)
JOINT_TARGET_KINDS = tuple(e.name for e in catalogue.ENTRIES if e.per_joint and catalogue.ABSOLUTE in e.data)


def moved_links(model: TreeModel, cand: dict) -> set[str] | None:
    """The links whose pose the candidate's effect changes directly (not
    through the weights it shifts): below the joint for the per-joint kinds
    (every target's union for ``all``); below the spring for a link spring
    (a link with one child joint carries it at that joint's origin, any
    other at its own frame); every link for the base spring. None for a
    kind this does not know (e.g. one that acts through the weights, such
    as a mass): it is then judged by its columns only."""
    tree = model.tree
    kind = cand["kind"]
    target = cand.get("target", kind)
    if kind not in JOINT_TARGET_KINDS + ("link", "base"):
        return None
    if kind == "base":
        return set(tree.links)
    if kind == "link":
        kids = tree.children(target)
        if len(kids) == 1:
            return _subtree(model, kids[0].child)
        return _subtree(model, target)
    joints = [j for j in tree.joints if target == "all" or j.name == target]
    out: set[str] = set()
    for j in joints:
        out |= _subtree(model, j.child)
    return out


def inert_reason(model: TreeModel, cand: dict) -> str:
    """Why the candidate cannot move a measured point by its structure
    ("" when it can, or when its kind is not judged by its structure)."""
    moved = moved_links(model, cand)
    if moved is None or moved & set(model.frames):
        return ""
    kind, target = cand["kind"], cand.get("target", cand["kind"])
    where = f"below {'link' if kind == 'link' else 'joint'} {target!r}"
    if kind == "base":
        where = "anywhere"
    return f"moves no marker: no measured frame {where} (it could only shift where a weight sits)"


def numerical_inert(model: TreeModel, cols: np.ndarray, Jc: np.ndarray, biggest: dict, sigma: float) -> str:
    """Why the candidate whose parameters are ``cols`` (indices into
    ``model.params``; ``Jc`` their columns of the weighted Jacobian,
    observations in units of the weighted residual) cannot move a measured
    point ("" when it can): zero columns (``biggest``: the largest column
    norm of each kind), or below the noise ``sigma`` in every row at the
    plausible size of its parameters."""
    if cols.size == 0:
        return "no parameter left to add"
    norms = np.linalg.norm(Jc, axis=0)
    kinds = [model.params[i].kind for i in cols]
    if all(n <= ZERO_COLUMN * biggest.get(k, 0.0) for n, k in zip(norms, kinds)):
        return "the measurements do not depend on it (its Jacobian columns are zero)"
    sizes = [PLAUSIBLE_SIZE.get(k, {}).get(model.params[i].name.rsplit(".", 1)[-1]) for i, k in zip(cols, kinds)]
    if all(s is not None for s in sizes) and math.isfinite(sigma) and sigma > 0:
        # the largest displacement of one point (3 coordinates) any one parameter makes at that size
        d = np.abs(Jc) * np.array(sizes)[None, :]
        per_point = np.sqrt(np.add.reduceat(d**2, np.arange(0, d.shape[0], 3), axis=0)) if d.shape[0] else d
        top = float(per_point.max()) if per_point.size else 0.0
        if top < sigma:
            return (
                f"below the noise: at its plausible size ({', '.join(f'{s:g}' for s in dict.fromkeys(sizes))}) "
                f"it moves no point by more than {top / sigma:.2g} sigma"
            )
    return ""


def extended_model(model: TreeModel, cands: list[dict]) -> TreeModel:
    """The model with every candidate's effect added (at zero): per joint
    effects once per joint (the ``all`` candidates are unions of them)."""
    extra, seen = [], set()
    for c in cands:
        if c.get("target") == "all":
            continue
        key = (c["kind"], c.get("target", c["kind"]))
        if key not in seen:
            seen.add(key)
            extra.append(dict(c))
    ext = tree_model_from_tables(
        model.tree, list(model.effects) + extra, model.gravity, model.iterations, "diagnosis", model.sigma_position
    )
    ext.arrays["rref"] = np.asfortranarray(model.arrays["rref"])
    return ext


def params_of(model: TreeModel, cand: dict) -> list[int]:
    """Indices of the free parameters of ``model`` that the candidate adds."""
    kind = cand["kind"]
    target = cand.get("target", kind)
    kinds = {"base": ("base",), "link": ("link",)}.get(kind, (kind,))
    return [
        i for i, p in enumerate(model.params) if p.kind in kinds and (target == "all" or p.target == target) and p.free
    ]


#: two candidates whose column spaces agree to this (1 - cosine of the largest principal angle) are one
DUPLICATE_TOL = 1e-9


def duplicate_of(blocks: list[np.ndarray]) -> list[int]:
    """For each block of columns (one candidate's, same kind), the index of
    an earlier block with the same column space (the same effect on every
    measured point: e.g. two coaxial joints at one point, a coupled joint
    written as two ``<mimic>`` joints), or -1."""
    bases = []
    for Z in blocks:
        if Z.size == 0:
            bases.append(np.zeros((Z.shape[0], 0)))
            continue
        n = np.linalg.norm(Z, axis=0)
        U, s, _ = np.linalg.svd(Z / np.where(n > 0, n, 1.0), full_matrices=False)
        bases.append(U[:, s > 1e-8 * max(s.max(), 1e-300)])
    out = []
    for b, Qb in enumerate(bases):
        dup = -1
        for a in range(b):
            Qa = bases[a]
            if out[a] == -1 and Qa.shape[1] == Qb.shape[1] > 0:
                # the smallest cosine of the principal angles between the two spaces
                cos = np.linalg.svd(Qa.T @ Qb, compute_uv=False)
                if cos.min() > 1.0 - DUPLICATE_TOL:
                    dup = a
                    break
        out.append(dup)
    return out
