"""Model reduction M1-M5 (klimchik s3) with a report like the paper's Table 1.

Physical: M1 symmetrisation (36 -> 21 per 6-dof spring), M2 sparsing by the
declared template (eq. 13: beam 8, diagonal 6, full 21), M3 aggregation
(a joint compliance whose parent link carries a spring with the rotation
about the same axis cannot be told apart from it: eliminated).
Algebraic (on the observation matrix of the actual measurements): M4a
partition into G1/G2/G3 by the SVD, M4b elimination of G2, M5a splitting of
G3 into coupled groups, M5b/c selection of an independent subset (greedy,
in order of physical preference: spring diagonals, couplings, joints), the
rest fixed.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..robot.model import SYM, Model
from .fit import coupling_groups, fit, solve_wls

if TYPE_CHECKING:
    from .measure import Measurements


@dataclass
class Reduction:
    rows: list[tuple[str, str, str, int]]  # (approach, step, description, parameters left)
    aggregated: list[str] = field(default_factory=list)
    g1: list[str] = field(default_factory=list)
    g2: list[str] = field(default_factory=list)
    g3: list[str] = field(default_factory=list)
    groups: list[list[str]] = field(default_factory=list)
    selected: list[str] = field(default_factory=list)
    fixed: list[str] = field(default_factory=list)

    def to_json(self) -> dict:
        return {
            "steps": [{"approach": a, "step": s, "description": d, "parameters": n} for a, s, d, n in self.rows],
            "aggregated": self.aggregated,
            "identifiable": self.g1,
            "non_identifiable": self.g2,
            "semi_identifiable": self.g3,
            "coupled_groups": self.groups,
            "selected": self.selected,
            "fixed": self.fixed,
        }


def _preference(name: str) -> int:
    tail = name.rsplit(".", 1)[-1]
    if len(tail) == 3 and tail[0] == "c" and tail[1:].isdigit():  # six-spring element
        return 0 if tail[1] == tail[2] else 1
    if tail == "c":
        return 2
    return 3


def reduce_model(model: Model, meas: Measurements, sigma_position: float | None = None) -> Reduction:
    if not np.any(meas.w):
        raise InputError(
            f"{meas.path}: every row's load (fx fy fz mx my mz) is zero: no spring is loaded, so no "
            f"parameter can be identified and there is nothing to reduce"
        )
    res = fit(model, meas, sigma_position=sigma_position)
    names = res.names
    terms = res.problem.terms
    nj = sum(1 for t in terms if t.kind == "joint" and t.free)
    six = [t for t in terms if t.kind == "six" and t.free]
    other = sum(len(t.names) for t in terms if t.kind not in ("joint", "six") and t.free)
    rows = [
        (
            "",
            "original",
            f"{nj} joints + {len(six)} 6-dof springs (36 per spring)" + (f" + {other} other" if other else ""),
            nj + 36 * len(six) + other,
        ),
        ("physical", "M1 symmetrisation", "21 per 6-dof spring", nj + 21 * len(six) + other),
        (
            "physical",
            "M2 sparsing",
            "templates: " + ", ".join(f"{t.target} {t.template or 'value'}" for t in six)
            if six
            else "no 6-dof springs",
            nj + sum(len(t.elements) for t in six) + other,
        ),
    ]
    # M3: joints whose parent-link spring has the rotation about the same axis
    aggregated = []
    chain = model.chain
    for t in terms:
        if t.kind != "joint" or not t.free:
            continue
        axis = chain.jaxis[t.joint]
        a = int(np.argmax(np.abs(axis)))
        if abs(abs(axis[a]) - 1) > 1e-12:
            continue
        for u in six:
            if u.free and u.spring == (2, t.joint + 1) and SYM.index((3 + a, 3 + a)) in u.elements:
                aggregated.append(t.names[0])
                break
    keep = [i for i, n in enumerate(names) if n not in aggregated]
    rows.append(
        (
            "physical",
            "M3 aggregation",
            f"{len(aggregated)} joint compliance(s) merged into their link springs",
            len(keep),
        )
    )
    A = res.A[:, keep]
    kn = [names[i] for i in keep]
    if not kn:
        return Reduction(rows=rows, aggregated=aggregated)
    _, _, _, v, rank, group, _ = solve_wls(A, res.r)
    g1 = [n for n, g in zip(kn, group) if g == 1]
    g2 = [n for n, g in zip(kn, group) if g == 2]
    g3 = [n for n, g in zip(kn, group) if g == 3]
    rows.append(
        (
            "algebraic",
            "M4a partitioning / M4b elimination",
            f"G1 identifiable {len(g1)}, G2 non-identifiable {len(g2)}, G3 semi-identifiable {len(g3)}",
            len(g1) + len(g3),
        )
    )
    groups = coupling_groups(kn, v, rank, group)
    # M5b/c: independent subset of G1 + G3, preferring spring diagonals
    idx = [i for i, n in enumerate(kn) if n not in g2]
    sub = A[:, idx]
    order = sorted(range(len(idx)), key=lambda k: (kn[idx[k]] not in g1, _preference(kn[idx[k]]), k))
    d = np.linalg.norm(sub, axis=0)
    d[d == 0] = 1
    sel = core.select_independent(sub / d, np.array(order), 1e-6)
    selected = [kn[idx[k]] for k in range(len(idx)) if sel[k]]
    fixed = [kn[idx[k]] for k in range(len(idx)) if not sel[k]]
    rows.append(
        (
            "algebraic",
            "M5a splitting / M5b selection / M5c assigning",
            f"{len(groups)} coupled group(s); {len(selected) - len(g1)} of {len(g3)} semi-identifiable "
            f"selected, {len(fixed)} fixed",
            len(selected),
        )
    )
    return Reduction(
        rows=rows, aggregated=aggregated, g1=g1, g2=g2, g3=g3, groups=groups, selected=selected, fixed=fixed
    )


def format_reduction(r: Reduction) -> str:
    lines = ["model reduction (klimchik Table 1)", f"{'approach':10s} {'step':46s} {'parameters':>10s}  description"]
    for a, s, d, n in r.rows:
        lines.append(f"{a:10s} {s:46s} {n:10d}  {d}")
    if r.aggregated:
        lines.append("M3 merged: " + ", ".join(r.aggregated))
    if r.g2:
        lines.append("G2 (no influence on the data, eliminated): " + ", ".join(r.g2))
    for g in r.groups:
        lines.append("coupled group: " + ", ".join(g))
    if r.fixed:
        lines.append("fixed (M5c): " + ", ".join(r.fixed))
    return "\n".join(lines)


def reduced_model(model: Model, red: Reduction) -> Model:
    """The model with only the parameters M5 selected left free: 6-dof
    springs keep their selected elements, joint compliances not selected
    (merged into their links by M3, or fixed by M5c) are dropped, i.e. fixed
    at 0; joints under a gravity compensator and other kinds are kept whole."""
    keep = set(red.selected)
    comp = {t.joint for t in model.terms if t.kind == "gravity_compensator"}
    terms = []
    for t in model.terms:
        if not t.free or t.kind not in ("joint", "six"):  # every other kind whole
            terms.append(t)
        elif t.kind == "joint":
            if t.names[0] in keep or t.joint in comp:
                terms.append(t)
        else:
            sel = [(e, n) for e, n in zip(t.elements, t.names) if n in keep]
            if sel:
                t2 = copy.copy(t)
                t2.elements = [e for e, _ in sel]
                t2.names = [n for _, n in sel]
                terms.append(t2)
    m = copy.copy(model)
    m.terms = terms
    return m
