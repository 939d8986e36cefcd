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
import xml.etree.ElementTree as ET
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


def check_inertials(root: ET.Element, path: Path | str) -> None:
    """Warn (once per file) about a link mass in grams or a centre of mass
    in mm; the numbers were checked as numbers already."""
    heavy, far = [], []
    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        name = link.get("name")
        mass = inertial.find("mass")
        try:
            m = float(mass.get("value")) if mass is not None else math.nan
        except (TypeError, ValueError):
            m = math.nan
        if m > MAX_LINK_MASS:
            heavy.append((m, name))
        org = inertial.find("origin")
        try:
            xyz = [float(v) for v in org.get("xyz", "").split()] if org is not None else []
        except ValueError:
            xyz = []
        d = math.sqrt(sum(v * v for v in xyz)) if len(xyz) == 3 else 0.0
        if d > MAX_COM:
            far.append((d, name))
    if heavy:
        m, name = max(heavy)
        more = f" ({len(heavy)} links above {MAX_LINK_MASS:g} kg)" if len(heavy) > 1 else ""
        V.warn(
            f"{path}: link {name!r} has mass {m:.6g} kg{more}, implausible for one link of a robot: is the mass "
            "in grams? (a URDF mass is in kg: divide by 1000)",
            key=("urdf-mass", str(path)),
        )
    if far:
        d, name = max(far)
        more = f" ({len(far)} links)" if len(far) > 1 else ""
        V.warn(
            f"{path}: the centre of mass of link {name!r} is {d:.4g} m from the link frame{more}, implausible "
            "for a robot in metres: is the <inertial> origin in mm? (a URDF is in m: multiply by 0.001)",
            key=("urdf-com", str(path)),
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
