"""Plausibility of a URDF's numbers that the library takes silently: link
masses (kg), centres of mass (m, link frame), joint limits, and postures
against those limits.

A URDF is in SI units: a link mass above ``MAX_LINK_MASS`` is very likely
in grams, a centre of mass farther than ``MAX_COM`` from its link frame in
millimetres. Both give one warning naming the link, the value and the fix;
a posture beyond a joint's ``<limit>`` gives one warning per joint naming
the first row, the value and the limit (and how many rows are beyond).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..io import validate as V

__all__ = ["MAX_LINK_MASS", "MAX_COM", "joint_limit", "check_inertials", "limit_warnings"]

#: kg; one link of an industrial robot weighs far less (a 16,000 kg link is a mass in grams)
MAX_LINK_MASS = 2000.0
#: m; a centre of mass this far from its link frame is a length in mm
MAX_COM = 10.0
#: rad or m; a posture this far beyond a limit is beyond it (not round-off of a value at the limit)
LIMIT_TOL = 1e-9


def joint_limit(jtype: str, lo: float | None, hi: float | None) -> tuple[float, float] | None:
    """(lower, upper) of a revolute or prismatic joint's ``<limit>``, or None
    (continuous, fixed, no or incomplete ``<limit>``, non-finite bounds)."""
    if jtype not in ("revolute", "prismatic") or lo is None or hi is None:
        return None
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi or lo == hi == 0.0:
        return None  # lower = upper = 0 is the URDF default of an omitted bound, not a locked joint
    return lo, hi


def check_inertials(
    names: Sequence[str], masses: Sequence[float | None], coms: npt.ArrayLike, path: Path | str
) -> None:
    """Warn (once per file) about a link mass in grams or a centre of mass
    in mm: ``masses`` (kg, None when not given) and ``coms`` (m, (n, 3)) of
    the links ``names`` that have an <inertial>, checked as numbers already."""
    m = np.array([math.nan if v is None else v for v in masses], float)
    d = np.sqrt(np.sum(np.asarray(coms, float).reshape(len(m), 3) ** 2, axis=1))
    for value, limit, key, text in (
        (m, MAX_LINK_MASS, "urdf-mass", _mass_text),
        (d, MAX_COM, "urdf-com", _com_text),
    ):
        over = np.flatnonzero(value > limit)
        if not over.size:
            continue
        top = value[over].max()
        name = max(names[k] for k in over if value[k] == top)
        V.warn(f"{path}: " + text(name, float(top), over.size), key=(key, str(path)))


def _mass_text(name: str, m: float, count: int) -> str:
    more = f" ({count} links above {MAX_LINK_MASS:g} kg)" if count > 1 else ""
    return (
        f"link {name!r} has mass {m:.6g} kg{more}, implausible for one link of a robot: is the mass "
        "in grams? (a URDF mass is in kg: divide by 1000)"
    )


def _com_text(name: str, d: float, count: int) -> str:
    more = f" ({count} links)" if count > 1 else ""
    return (
        f"the centre of mass of link {name!r} is {d:.4g} m from the link frame{more}, implausible "
        "for a robot in metres: is the <inertial> origin in mm? (a URDF is in m: multiply by 0.001)"
    )


def limit_warnings(
    Q: npt.ArrayLike,
    names: Sequence[str],
    limits: Sequence[tuple[float, float] | None],
    lines: Sequence[int],
    path: object,
) -> list[str]:
    """One message per joint whose column of ``Q`` (n, len(names)) leaves
    its URDF ``<limit>``: the first row (its line), the value, the limit,
    and how many rows are beyond."""
    Q = np.atleast_2d(np.asarray(Q, float))
    out = []
    for k, (name, lim) in enumerate(zip(names, limits)):
        if lim is None or k >= Q.shape[1]:
            continue
        lo, hi = lim
        bad = np.flatnonzero((Q[:, k] < lo - LIMIT_TOL) | (Q[:, k] > hi + LIMIT_TOL))
        if not bad.size:
            continue
        i = int(bad[0])
        v = float(Q[i, k])
        side, bound = ("upper", hi) if v > hi else ("lower", lo)
        more = f" ({bad.size} rows beyond it)" if bad.size > 1 else ""
        out.append(
            f"{path}, line {lines[i]}: joint {name!r} = {v:.6g} is beyond its URDF {side} limit {bound:.6g} "
            f"(limits [{lo:.6g}, {hi:.6g}]){more}: a posture the robot cannot take (wrong joint order, "
            "degrees, or an offset?)"
        )
    return out
