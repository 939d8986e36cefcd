"""A model's terms as the core's arrays (core/sk_deflect.f90): the one
encoding of the deflection model that the core evaluates (rows, Jacobian,
joint compliances) and fits (calib/fit.py).

Each term is one column of ``tint`` (kind, spring, first value, count,
first Jacobian column or 0 when known, q column, first element) and
``tgeo`` (compensator a, b, beta, s0; dead-zone tau0); ``par`` holds the
known values (free ones are read from theta), ``elem`` the kept elements of
the 6-dof springs (1-based, core order).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..errors import InputError
from . import catalogue

if TYPE_CHECKING:
    from .model import Term
    from .urdf import Chain

#: the chain's spring types (core/sk_chain.f90 spring_*; robot.model's names; tests/test_architecture.py checks them)
SPRING_JOINT, SPRING_FRAME, SPRING_BASE, SPRING_TOOL = 1, 2, 3, 4
_LOAD_NONLINEAR = tuple(e.name for e in catalogue.ENTRIES if e.load_nonlinear)
#: the kinds of a joint spring (robot.model.JOINT_KINDS)
JOINT_KINDS = tuple(e.name for e in catalogue.ENTRIES if e.per_joint and catalogue.DEFLECTION in e.data)

#: term kinds of the core (core/sk_deflect.f90 term_*), from the catalogue of kinds
TERM_CODES = catalogue.TERMS


def spring_list(terms: Sequence[Term], springs: Sequence[tuple[int, int]] = ()) -> list[tuple[int, int]]:
    """``springs`` followed by any further spring of ``terms``."""
    out = list(springs)
    for t in terms:
        if t.spring is not None and t.spring not in out:
            out.append(t.spring)
    return out


def encode(
    terms: Sequence[Term],
    layout: dict[int, slice],
    springs: Sequence[tuple[int, int]] = (),
    tau0: Callable[[Term], float] | None = None,
) -> dict[str, np.ndarray]:
    """The core's arrays of ``terms``: free term i takes theta[layout[i]];
    ``tau0(term)`` gives a dead zone's smoothing torque when the term does
    not declare it. Returns the keyword arguments stype, sidx, tint, tgeo,
    elem, par of bindings/calib.py deflection_rows."""
    sp = spring_list(terms, springs)
    index = {s: k + 1 for k, s in enumerate(sp)}
    nt = len(terms)
    tint = np.zeros((7, nt), np.int32, order="F")
    tgeo = np.zeros((5, nt), order="F")
    elem: list[int] = []
    par: list[float] = []
    for i, t in enumerate(terms):
        n = len(t.names) if t.free else len(t.value)
        tint[0, i] = TERM_CODES[t.kind]
        tint[1, i] = index[t.spring] if t.spring is not None else 0
        tint[2, i] = len(par) + 1
        tint[3, i] = n
        tint[4, i] = layout[i].start + 1 if t.free else 0
        tint[5, i] = t.qcol + 1 if t.qcol >= 0 else 0
        par.extend([0.0] * n if t.free else [float(v) for v in t.value])
        if t.kind == "six":
            tint[6, i] = len(elem) + 1
            elem.extend(e + 1 for e in t.elements)
        elif t.kind == "gravity_compensator":
            tgeo[0:4, i] = [t.geometry[k] for k in ("a", "b", "beta", "s0")]
        elif t.kind == "joint_deadzone":
            v = t.geometry.get("tau0")
            tgeo[4, i] = float(v) if v is not None else (tau0(t) if tau0 is not None else 0.0)
    return {
        "stype": np.array([s[0] for s in sp], np.int32),
        "sidx": np.array([s[1] for s in sp], np.int32),
        "tint": tint,
        "tgeo": tgeo,
        "elem": np.array(elem, np.int32),
        "par": np.array(par, float),
    }


def known_joint_compliances(
    chain: Chain, terms: Sequence[Term], Q: np.ndarray, wrench: np.ndarray | None = None
) -> dict[int, np.ndarray]:
    """Compliance of every joint spring at postures Q (N, dof) from the known
    values of the joint kinds among ``terms``, by the core (sk_joint_secant):
    {chain joint index: (N,)} for the joints with a term of their compliance (joint, profile)
    (with ``wrench`` (N, 6) also the load-nonlinear ones: the secant under
    that load). InputError for a term without its value, and for a dead
    zone without a load."""
    joints: list[int] = []
    jterms = []
    for t in terms:
        if t.kind not in JOINT_KINDS:
            continue
        if t.value is None and t.kind == "gravity_compensator":
            raise InputError(f"gravity_compensator on {t.target!r} has no k_s; identify it first")
        if t.value is None:
            raise InputError(
                f"{t.kind if t.kind in _LOAD_NONLINEAR else 'effect ' + (t.source or t.kind)} on {t.target!r} "
                f"has no value; identify it first (stiffkit fit --write-model)"
            )
        if t.kind == "joint_deadzone" and wrench is None:
            raise InputError(
                f"joint_deadzone on {t.target!r}: a joint with a dead zone deflects by an amount "
                f"that depends on the sign and size of the load, so it has no compliance at a "
                f"posture alone; give the load (Model.tool_compliance(Q, wrench=W) is the secant "
                f"compliance under W, whose product with W is the deflection)"
            )
        if (catalogue.KIND[t.kind].compliance or (wrench is not None and t.kind in _LOAD_NONLINEAR)) and (
            t.joint not in joints
        ):
            joints.append(t.joint)
        jterms.append(t)
    enc = encode(jterms, {}, [(SPRING_JOINT, j + 1) for j in joints])
    if not enc["stype"].size:
        return {}
    tau = None
    if wrench is not None:
        tau = np.asfortranarray(chain.joint_torques(Q, wrench)[:, enc["sidx"] - 1].T)
    cjs = core.joint_secant(enc, np.asfortranarray(np.asarray(Q, float).T), tau)
    return {j: cjs[k].copy() for k, j in enumerate(joints)}
