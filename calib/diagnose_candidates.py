"""The catalogue of candidate effects of the deflection diagnosis
(``calib.diagnose``): which effect tables are tried on a model, and the
record of one candidate's scores.

The candidates come from the catalogue of kinds (robot/catalogue.py,
``candidates``); the scoring, ranking and reports take every table alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..robot import catalogue
from ..robot.model import Model

__all__ = ["Candidate", "effect_label", "candidate_tables", "inert_reasons", "ZERO_COLUMN"]

#: a candidate's columns all below this fraction of the largest column of its kind: zero (round-off)
ZERO_COLUMN = 1e-9


@dataclass
class Candidate:
    kind: str
    target: str
    effect: dict
    statistic: float = 0.0
    dof: int = 0
    log_p: float = 0.0
    explained_fraction: float = 0.0
    rms_after_m: float = 0.0
    hint: str = ""
    indistinguishable_from: list[str] = field(default_factory=list)
    #: share of the residual above the noise that it explains, (statistic - dof) / (chi2 - residual
    #: dof), clipped at 0; None when the noise is not known (no declared sigma, no pure error)
    excess_fraction: float | None = None
    cv_rms_position_m: float | None = None  # held-out RMS with it added
    tied_with: list[str] = field(default_factory=list)
    reason: str = ""  # why it is not identifiable (not ranked)

    @property
    def label(self) -> str:
        t = self.effect.get("template")
        return f"{self.kind}:{self.target}" + (f":{t}" if t else "")

    @property
    def family(self) -> tuple[str, str]:
        """Templates of one spring are one family (nested), not rivals."""
        return (self.kind, self.target)

    @property
    def p_value(self) -> float:
        return math.exp(self.log_p) if self.log_p > -745 else 0.0

    def to_json(self) -> dict:
        d = {
            "kind": self.kind,
            "target": self.target,
            "statistic": self.statistic,
            "p_value": self.p_value,
            "explained_fraction": self.explained_fraction,
            "rms_after_m": self.rms_after_m,
            "effect": self.effect,
            "dof": self.dof,
            "log10_p_value": self.log_p / math.log(10),
            "excess_fraction": self.excess_fraction,
            "cv_rms_position_m": self.cv_rms_position_m,
        }
        if self.hint:
            d["hint"] = self.hint
        if self.indistinguishable_from:
            d["indistinguishable_from"] = self.indistinguishable_from
        if self.tied_with:
            d["tied_with"] = self.tied_with
        return d

    def inert_json(self) -> dict:
        """The entry of a non-identifiable candidate: kind, target, effect and why."""
        return {"kind": self.kind, "target": self.target, "effect": self.effect, "reason": self.reason}


def effect_label(effect: dict) -> str:
    """The diagnosis's label of an [[effect]] table, ``kind:target[:template]``
    (:attr:`Candidate.label`; plan --discriminate names tied candidates by it)."""
    return Candidate(kind=effect["kind"], target=effect.get("target", effect["kind"]), effect=effect).label


def candidate_tables(model: Model, tau0: dict | None = None) -> list[tuple[dict, str]]:
    """Every catalogued kind on every target the model does not already have:
    (effect table, hint), from the catalogue (robot/catalogue.py). ``tau0``
    {joint: N m} gives the smoothing torque of the joint_deadzone candidates
    (from the data's torque scale)."""
    return catalogue.candidates(model, catalogue.DEFLECTION, tau0)


def inert_reasons(cands: list[tuple[dict, str]], Z: list[np.ndarray]) -> list[str]:
    """For each candidate, why it cannot move a measured point ("" when it
    can): its weighted columns ``Z[c]`` are zero (every column below
    ZERO_COLUMN of the largest column of the same kind among the
    candidates; e.g. a spring that carries no load in these data)."""
    norms = [np.linalg.norm(z, axis=0) if z.size else np.zeros(0) for z in Z]
    top: dict[str, float] = {}
    for (table, _h), n in zip(cands, norms):
        if n.size:
            top[table["kind"]] = max(top.get(table["kind"], 0.0), float(n.max()))
    out = []
    for (table, _h), n in zip(cands, norms):
        big = top.get(table["kind"], 0.0)
        if n.size == 0 or not big > 0 or float(n.max()) <= ZERO_COLUMN * big:
            out.append("no influence on these data: its columns are zero (it moves no measured point)")
        else:
            out.append("")
    return out
