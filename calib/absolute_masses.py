"""Gravity parameters in the fit on absolute data (docs/calibration.md
section 6.8; the kinds are robot/model_bodies.py's).

A mass factor or a centre offset acts through the compliances only (its
Jacobian column is the compliance times the change of the gravity
wrench): at compliances of zero, the start of every elastic effect the
user has not valued, its column is zero and the reduction would drop it.
So when a model has free gravity parameters and free compliances, the
compliances are fitted first with the gravity parameters at the URDF's
values (``gravity_start``), and the reduction of the whole set is taken
there. What it finds is then the identifiability of the combinations:
without a known payload, scaling every mass that loads a compliance by s
and that compliance by 1/s leaves every deflection as it was, so one
factor per such group is "a combination of" the compliances and the other
factors (``gravity_notes`` says so, with the names); a payload of known
weight separates them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..robot.model_bodies import BODY_KINDS
from ..robot.tree_model import TreeModel

__all__ = ["gravity_start", "gravity_notes"]

#: the compliance kinds whose columns are zero at a zero start (their values scale the deflections)
ELASTIC_KINDS = ("joint", "lateral", "link", "base")


def gravity_start(
    model: TreeModel,
    theta: np.ndarray,
    free: np.ndarray,
    ev: dict,
    reduce: Callable,
    solve: Callable,
    evaluate: Callable,
) -> tuple[TreeModel, np.ndarray, dict]:
    """(model, theta, evaluation) at which the fit takes its reduction: the
    compliances fitted with the gravity parameters held at the URDF's
    values when both are free and the compliances start at zero, else the
    arguments as they are. The fit's tools: ``reduce(model, jac, free)``
    (its reduction), ``solve(model, theta, free) -> (model, solution)``
    and ``evaluate(model, theta)`` (``ev``: its value at theta)."""
    grav = [i for i in free if model.params[i].kind in BODY_KINDS]
    zero_elastic = [i for i in free if model.params[i].kind in ELASTIC_KINDS and theta[i] == 0.0]
    if not grav or not zero_elastic:
        return model, theta, ev
    rest = np.array([i for i in free if model.params[i].kind not in BODY_KINDS], dtype=int)
    cols = np.flatnonzero(np.isin(free, rest))
    red = reduce(model, ev["jac"][:, cols], rest)
    if red.kept.size == 0:
        return model, theta, ev
    model, sol = solve(model, theta, red.kept)
    theta = sol["theta"]
    # a compliance below 0 at this start would turn the gravity columns around: start it at 0
    for i in red.kept:
        if model.params[i].kind in ELASTIC_KINDS and theta[i] < 0:
            theta[i] = 0.0
    return model, theta, evaluate(model, theta)


def gravity_notes(model: TreeModel, dropped: list, merged: list) -> list[str]:
    """Plain words for the gravity parameters the reduction did not keep:
    the ones no measurement depends on (no elastic effect above them) and
    the ones that are a combination of compliances and other factors."""
    notes = []
    for name, why in list(dropped) + list(merged):
        p = model.params[model.index(name)]
        if p.kind not in BODY_KINDS:
            continue
        if "column is zero" in why:
            notes.append(
                f"{name}: no elastic effect of the model carries this weight (or it moves no marker): held at "
                f"its URDF value"
            )
        else:
            notes.append(
                f"{name}: {why}: masses and compliances act as products (without a known payload one factor "
                f"per loaded group is not separable): held at its URDF value"
            )
    return notes
