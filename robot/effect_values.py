"""The known values of an ``[[effect]]`` table, checked against the
catalogue's parameter entries (robot/catalogue.py): one check for both
model readers (robot/model.py, deflections; robot/tree_build.py, absolute
data). The key a kind's values sit under, how many there are, their units,
bounds and the quantity that judges their plausibility all come from its
:class:`~stiffkit.robot.catalogue.Kind` entry; every failure names the
effect table (``where``: file, ``[[effect]] #i (kind, target ...)``), the
key, the value and what is wrong with it.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..io import validate as V
from . import catalogue
from .catalogue import Param

__all__ = ["effect_where", "effect_kind", "effect_values", "effect_w0", "compensator_geometry", "nonnegative"]


def effect_where(path: object, i: int, table: dict) -> str:
    """The label of effect table ``i`` in messages: ``m.toml: [[effect]] #3 (joint, target 'elbow')``."""
    return f"{path}: [[effect]] #{i + 1} ({V.shown(table.get('kind', '?'))}" + (
        f", target {table['target']!r})" if "target" in table else ")"
    )


def effect_kind(table: dict, where: str, data: str) -> str:
    """The table's kind, one the catalogue lists for data of kind ``data``,
    with only the keys its entry allows (a typo is an error, not a silent
    default); raises InputError naming ``where``, the word and the choices."""
    kinds = catalogue.kinds(data)
    kind = table.get("kind")
    if not isinstance(kind, str) or kind not in kinds:
        raise InputError(
            f"{where}: unknown kind {kind!r}{V.suggest(kind, kinds)}; choose one of {', '.join(kinds)} ({data} data)"
        )
    allowed = catalogue.KIND[kind].keys[data]
    unknown = sorted(set(table) - allowed - {"kind", "note"})
    if unknown:
        raise InputError(
            f"{where}: unknown key(s) {', '.join(map(V.shown, unknown))} for kind {kind!r}"
            f"{V.suggest(unknown[0], allowed)} (allowed: kind, {', '.join(sorted(allowed))}, note)"
        )
    return kind


def _limits(p: Param) -> dict:
    return {"lo": p.lo if p.lo > -math.inf else None, "hi": p.hi if p.hi < math.inf else None}


def _two_sided(p: Param) -> bool:
    """Bounded on both sides (a mass factor, a centre offset): the message names the bound it passed."""
    return p.lo > -math.inf and p.hi < math.inf


def _unit(p: Param) -> dict:
    return {} if p.quantity else {"unit": p.unit}


def effect_values(table: dict, kind: str, where: str) -> np.ndarray | None:
    """The known values of a table of ``kind`` in its parameters' order
    (None: not given, the parameters are identified). A scalar kind takes
    one number; a list kind one number per parameter (or, when its entry
    says ``broadcast``, one number for all). Raises InputError naming
    ``where``, the key and the value."""
    e = catalogue.KIND[kind]
    key = e.value_key
    if key not in table:
        return None
    v = table[key]
    if e.scalar:
        p = e.params[0]
        if isinstance(v, bool):
            raise InputError(f"{where}: {key} must be a finite number, got {v!r} (a boolean)")
        if not _two_sided(p):
            return np.array([V.number(v, f"{where}: {key}", p.quantity or None, **_limits(p), **_unit(p))])
        x = V.number(v, f"{where}: {key}", p.quantity or None, **_unit(p))
        if not p.lo <= x <= p.hi:
            raise InputError(f"{where}: {key} = {x:g}: a {p.label or p.suffix} must be in [{p.lo:g}, {p.hi:g}]")
        return np.array([x])
    n = len(e.params)
    if e.broadcast and isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v] * n
    if not isinstance(v, list) or len(v) != n:
        units = sorted({p.unit for p in e.params})
        unit = f" ({units[0]})" if len(units) == 1 else ""
        raise InputError(f"{where}: {key} must be [{', '.join(p.label or p.suffix for p in e.params)}]{unit}")
    q = e.params[0].quantity or None
    vals = V.array(v, f"{where}: {key}", (n,), q)
    for k, (x, p) in enumerate(zip(vals, e.params)):
        bad = (p.lo > -math.inf and x < p.lo) or (p.hi < math.inf and x > p.hi)
        if bad and _two_sided(p):
            edge = p.hi if x > p.hi else p.lo
            slip = " (in mm? the file is in m)" if p.unit == "m" else ""
            raise InputError(
                f"{where}: {key}[{k}] = {x:g} {p.unit} ({p.suffix}) is beyond {edge:g} {p.unit}: it must be in "
                f"[{p.lo:g}, {p.hi:g}]{slip}; got {v!r}"
            )
        if bad:
            lo, hi = _limits(p).values()
            need = f">= {lo:g}" if hi is None else (f"<= {hi:g}" if lo is None else f"in [{lo:g}, {hi:g}]")
            raise InputError(f"{where}: {key}[{k}] = {x:g} {p.unit} ({p.suffix}) must be {need}; got {v!r}")
    return vals


def effect_w0(table: dict, kind: str, where: str) -> float | None:
    """The fixed key of a law's block (joint_deadzone's ``tau0``, N m, > 0), None when not given."""
    key = catalogue.KIND[kind].w0_key
    if not key or key not in table:
        return None
    return V.number(table[key], f"{where}: {key}", "moment", lo=0.0, lo_open=True)


#: a gravity_compensator's geometry keys (docs/calibration.md section 2), in the core's slot order
COMPENSATOR_KEYS = ("a", "b", "beta", "s0")


def compensator_geometry(table: dict, where: str) -> dict[str, float]:
    """A gravity_compensator's geometry a, b > 0 (m), beta (rad), s0 >= 0
    (m), for both readers."""
    limits = {
        "a": ("length", {"lo": 0.0, "lo_open": True}),
        "b": ("length", {"lo": 0.0, "lo_open": True}),
        "beta": ("angle", {}),
        "s0": ("length", {"lo": 0.0}),
    }
    out = {}
    for key in COMPENSATOR_KEYS:
        if key not in table:
            raise InputError(f"{where}: missing {key!r}")
        q, lim = limits[key]
        out[key] = V.number(table[key], f"{where}: {key}", q, **lim)
    return out


def nonnegative(kind: str, name: str) -> bool:
    """Whether parameter ``name`` (``<target>.<suffix>``) of an effect of
    ``kind`` is >= 0 by its physics: a catalogue parameter bounded below by
    0 and not above (compliances, a backlash; not the mass factors, bounded
    on both sides), or a diagonal element ``cII`` of a 6-dof spring."""
    tail = name.rsplit(".", 1)[-1]
    e = catalogue.KIND.get(kind)
    if e is None:
        return False
    if e.law == "LAW_SPRING6":
        return len(tail) == 3 and tail[0] == "c" and tail[1] == tail[2]
    return any(p.suffix == tail and p.lo == 0.0 and p.hi == math.inf for p in e.params)
