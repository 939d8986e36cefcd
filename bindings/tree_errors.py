"""Messages for the argument errors of the kinematic-tree core: the core
returns ``errloc = [argument, index]`` (core/sk_tree_check.f90) and this
module says which argument and which element (virtual joint, entry, block,
parameter, posture, payload, observation, row), what the element is in the
user's model (the labels a tree model attaches to its arrays: the URDF joint
or effect of a virtual joint, the parameter names) and what is wrong with
its value, e.g. ``virtual joint 3 (URDF joint 'torso_fixed'): axis not unit
(norm 1.2)``.
"""

from __future__ import annotations

import numpy as np

from .errors import TREE_ARGUMENTS, check, located

__all__ = ["CoreArrays", "raise_for"]

SIZE, NONFINITE, ARGUMENT = 1, 2, 6


class CoreArrays(dict):
    """The arrays of a tree model, passed to the core as keywords, with
    ``labels`` for messages: ``vj`` (what each virtual joint is, e.g. "URDF
    joint 'elbow'"), ``param`` (parameter names), ``block`` (what each
    elastic block is), ``marker`` and ``body`` (their frames or links)."""

    def __init__(self, *args: object, labels: dict[str, list[str]] | None = None, **kw: object) -> None:
        super().__init__(*args, **kw)
        self.labels = labels or {}

    def copy(self) -> CoreArrays:
        return CoreArrays(self, labels=self.labels)


def _label(given: dict, kind: str, k: int) -> str:
    labels = getattr(given.get("model"), "labels", {}).get(kind, [])
    return f" ({labels[k - 1]})" if 0 < k <= len(labels) else ""


def _col(a: object, k: int) -> np.ndarray:
    a = np.asarray(a)
    return a[..., k - 1] if a.ndim > 1 else a[k - 1 : k]


def _vj(given: dict, v: int) -> str:
    return f"virtual joint {v}{_label(given, 'vj', v)}"


def _problem(arg: str, k: int, given: dict) -> str:  # noqa: C901 - one case per argument, read as a table
    """What is wrong with element k (1-based) of argument ``arg`` (an argument error)."""
    m = given.get("model", {})
    nv = len(m.get("vparent", ()))
    npar = len(given.get("theta", ()))
    if arg == "vparent":
        return f"parent {int(m['vparent'][k - 1])} is not a virtual joint before it (0..{k - 1})"
    if arg == "vtype":
        return f"type {int(m['vtype'][k - 1])} is not 0 (fixed), 1 (revolute) or 2 (prismatic)"
    if arg == "vaxis":
        return f"axis not unit (norm {np.linalg.norm(_col(m['vaxis'], k)):.12g})"
    if arg == "vrot":
        return "origin rotation is not a rotation matrix (orthonormal, determinant +1)"
    if arg == "qcol":
        return f"joint coordinate {int(m['qcol'][k - 1])} is not in 0..{np.shape(given.get('q', np.zeros((0, 0))))[0]}"
    if arg == "gvj":
        v = int(m["gvj"][k - 1])
        p = int(m["gpar"][k - 1])
        what = f"parameter {p}{_label(given, 'param', p)} moves "
        if not 1 <= v <= nv:
            return what + f"virtual joint {v}, not in 1..{nv}"
        return what + f"{_vj(given, v)}, which is fixed (a geometric parameter moves a moving joint)"
    if arg == "gpar":
        return f"parameter index {int(m['gpar'][k - 1])} is not in 1..{npar}"
    if arg == "ktype":
        return f"law type {int(m['ktype'][k - 1])} is not 1 (linear), 2 (cubic), 3 (dead zone) or 4 (6-dof spring)"
    if arg == "kvj":
        vjs = [int(v) for v in np.asarray(m["kvj"])[:, k - 1] if v != 0]
        return (
            f"its coordinates ride on virtual joint(s) {', '.join(map(str, vjs))}: each must be a moving "
            f"joint in 1..{nv} that carries no other elastic coordinate"
        )
    if arg == "kpar":
        return f"a parameter index is not in 0..{npar}"
    if arg == "kw0":
        return f"dead-zone width tau0 = {float(m['kw0'][k - 1]):g} must be > 0"
    if arg == "bvj":
        return f"its frame {int(m['bvj'][k - 1])} is not in 0..{nv}"
    if arg == "bmass":
        return f"mass {float(m['bmass'][k - 1]):g} kg is negative"
    if arg == "tpar":
        return f"parameter index {int(m['tpar'][k - 1])} is not in 1..{npar}"
    if arg == "rref":
        return "the tracker's reference rotation is not a rotation matrix"
    if arg == "mvj":
        return f"its frame {int(m['mvj'][k - 1])} is not in 0..{nv}"
    if arg == "mpar":
        return f"a parameter index is not in 1..{npar}"
    if arg in ("lpost", "opost"):
        n = np.shape(given.get("q", np.zeros((0, 0))))[1]
        return f"posture {int(given[arg][k - 1])} is not in 1..{n}"
    if arg == "lvj":
        return f"frame {int(given['lvj'][k - 1])} is not in 0..{nv}"
    if arg == "omark":
        return f"marker {int(given['omark'][k - 1])} is not in 1..{len(m.get('mvj', ()))}"
    if arg == "owt":
        return f"weight {float(given['owt'][k - 1]):g} is negative"
    if arg == "free":
        p = int(given["free"][k - 1])
        if not 1 <= p <= npar:
            return f"parameter index {p} is not in 1..{npar}"
        return f"parameter {p}{_label(given, 'param', p)} is listed twice"
    if arg == "frame":
        return f"frame {int(given['frame'][k - 1])} is not in 0..{nv}"
    if arg == "rtarget":
        return "the target orientation is not a rotation matrix"
    if arg == "prow":
        return f"parameter index {int(given['prow'][k - 1])} is not in 1..{npar}"
    return "out of range"


def _what(arg: str, what: str, k: int, given: dict) -> str:
    """The element named: 'virtual joint 3 (URDF joint ...)' or 'argument q'."""
    if not what or k == 0:
        return f"argument {arg}"
    if what == "virtual joint":
        return _vj(given, k)
    if what == "parameter":
        return f"parameter {k}{_label(given, 'param', k)}"
    if what == "elastic block":
        return f"elastic block {k}{_label(given, 'block', k)}"
    if what == "marker":
        return f"marker {k}{_label(given, 'marker', k)}"
    if what == "body":
        return f"body {k}{_label(given, 'body', k)}"
    if what == "posture" and "ptarget" in given:
        what = "row"
    return f"{what} {k} ({arg})"


def raise_for(info: int, errloc: object, routine: str, given: dict, details: dict[int, str] | None = None) -> None:
    """Raise for ``info`` (bindings.errors.check), with the argument and
    index of ``errloc`` in the message when the core located the error.
    ``given``: what the call passed (``model``: the CoreArrays; ``theta``,
    ``q``, observations, ... by their core names; ``ndof``)."""
    info = int(info)
    if info == 0:
        return
    loc = [int(x) for x in np.asarray(errloc).ravel()[:2]] if errloc is not None else [0, 0]
    if info not in (SIZE, NONFINITE, ARGUMENT) or loc[0] not in TREE_ARGUMENTS:
        check(info, routine, details)
        return
    arg, what = TREE_ARGUMENTS[loc[0]]
    k = loc[1]
    where = _what(arg, what, k, given)
    if info == SIZE:
        shape = np.shape(given.get(arg, given.get("model", {}).get(arg, ())))
        problem = f"size {shape} does not fit the other arguments"
        if arg == "ne":
            problem = f"ne = {given.get('ne')} is not the number of elastic coordinates of the blocks"
    elif info == NONFINITE:
        problem = "not a finite number (NaN or Inf)"
    else:
        try:
            problem = _problem(arg, k, given)
        except (KeyError, IndexError, TypeError, ValueError):  # the arrays do not say more
            problem = "out of range"
    raise located(routine, info, where, problem)
