"""Gravity parameters of a tree model (docs/calibration.md section 6.8):
the URDF's inertials as guesses that the fit may correct.

Three effect kinds (``[[effect]]`` tables of a model for absolute data):

- ``mass`` (target: a link with mass, or ``all``): ``<link>.mass``, a
  factor on the link's URDF mass (dimensionless, 1 = the URDF).
- ``subtree_mass`` (target: a link): ``<link>.subtree_mass``, one factor
  on the mass of every link of the subtree below and including it; a link
  with its own ``mass`` factor too carries their product.
- ``com`` (target: a link with mass, or ``all``): ``<link>.com_x com_y
  com_z``, an offset (m, the link's frame) of the URDF centre of mass.

They enter the gravity wrench of every elastic effect above the body (the
core's entries ``bpar``, core/sk_tree_grav.f90) and move no point
directly: a model without elastic effects cannot see them, and without a
known payload a factor common to every body is the same as scaling every
compliance (the fit's reduction then names it, ``docs`` 6.8).

Keys: ``value`` (a known factor, or [dx, dy, dz] in m: not identified),
``prior`` (the sigma of a weak prior toward the URDF: factor 1, offset 0;
default MASS_PRIOR, COM_PRIOR; 0 = none). The prior enters the fit as the
rows ``sigma_position / prior * (theta - URDF)``, sigma_position the
declared one or PRIOR_POSITION_SCALE. Bounds: a factor in [0, MASS_MAX]
(the fit does not bound it: a negative one says something else is
missing), an
offset component within COM_MAX m, a prior in [0, MASS_MAX] or
[0, COM_MAX]; the writer clips a fitted value to them and says so.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .catalogue import COM_MAX, MASS_MAX
from .effect_values import effect_values

__all__ = [
    "BODY_KINDS",
    "MASS_PRIOR",
    "COM_PRIOR",
    "body_entries",
    "prior_rows",
    "body_table",
]

BODY_KINDS = ("mass", "subtree_mass", "com")
#: default prior sigmas: a mass factor (dimensionless), a centre offset (m)
MASS_PRIOR, COM_PRIOR = 0.5, 0.05
#: the position sigma (m) that weighs the prior rows when the model declares none
PRIOR_POSITION_SCALE = 1e-4
COM_NAMES = ("com_x", "com_y", "com_z")


def _number(v: object, where: str, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise InputError(f"{where}: {what} must be a finite number, got {v!r}")
    return float(v)


def _prior(table: dict, where: str, default: float, bound: float, unit: str) -> float:
    if "prior" not in table:
        return default
    p = _number(table["prior"], where, "prior")
    if not 0 <= p <= bound:
        raise InputError(f"{where}: prior = {p:g} must be a sigma in [0, {bound:g}] {unit} (0: no prior)")
    return p


def body_entries(b: object, tree: object, by_kind: dict, bodies: list[str], where: str) -> tuple[np.ndarray, dict]:
    """Parameters of the ``mass``, ``subtree_mass`` and ``com`` tables
    (``by_kind[kind]``: (index, table, label)) added to the builder ``b``;
    ``bodies``: the link of each body of the core (its order). Returns the
    core's entries bpar (3, nbp) (body, slot, theta index; 1-based) and
    the priors {parameter name: sigma}."""
    entries: list[tuple[int, int, int]] = []
    priors: dict[str, float] = {}
    mass = {ln: tree.inertials[ln].mass for ln in bodies}
    body_of = {ln: k + 1 for k, ln in enumerate(bodies)}
    for kind in ("mass", "com"):
        # a table naming one link takes precedence over target = "all"
        tables = sorted(by_kind.get(kind, []), key=lambda e: e[1].get("target", "all") == "all")
        alls = [e for e in tables if e[1].get("target", "all") == "all"]
        if len(alls) > 1:
            raise InputError(f"{alls[1][2]}: a second {kind} effect with target 'all' ({alls[0][2]})")
        done: dict[str, str] = {}
        for i, table, w in tables:
            target = table.get("target", "all")
            every = target == "all"
            if every:
                if "value" in table:
                    raise InputError(f"{w}: a {kind} value needs one target link, not 'all'")
                links = [ln for ln in bodies if mass[ln] > 0 and ln not in done]
            else:
                if not isinstance(target, str) or target not in tree.links:
                    raise InputError(f"{w}: target must be a link below {tree.root!r} or 'all'; got {target!r}")
                if mass.get(target, 0.0) <= 0:
                    raise InputError(
                        f"{w}: link {target!r} has no mass in the URDF: a {kind} parameter on it changes nothing"
                    )
                if target in done:
                    raise InputError(f"{w}: link {target!r} already has a {kind} effect ({done[target]})")
                links = [target]
            if kind == "mass":
                sigma = _prior(table, w, MASS_PRIOR, MASS_MAX, "(a factor)")
            else:
                sigma = _prior(table, w, COM_PRIOR, COM_MAX, "m")
            # the known value: the one check of every kind's values, its bounds the catalogue's
            val = effect_values(table, kind, w)
            if val is not None and kind == "mass":
                val = float(val[0])
            for ln in links:
                done[ln] = w
                if kind == "mass":
                    pi = b.add_param(f"{ln}.mass", kind, ln, i, 1.0 if val is None else val, val is None)
                    entries.append((body_of[ln], 1, pi))
                    if val is None and sigma > 0:
                        priors[f"{ln}.mass"] = sigma
                else:
                    for k, n in enumerate(COM_NAMES):
                        pi = b.add_param(f"{ln}.{n}", kind, ln, i, 0.0 if val is None else val[k], val is None)
                        entries.append((body_of[ln], 2 + k, pi))
                        if val is None and sigma > 0:
                            priors[f"{ln}.{n}"] = sigma
    seen: dict[str, str] = {}
    for i, table, w in by_kind.get("subtree_mass", []):
        target = table.get("target")
        if not isinstance(target, str) or target not in tree.links:
            raise InputError(f"{w}: target must be a link below {tree.root!r}; got {target!r}")
        if target in seen:
            raise InputError(f"{w}: link {target!r} already has a subtree_mass effect ({seen[target]})")
        seen[target] = w
        members = [ln for ln in tree.subtree(target) if mass.get(ln, 0.0) > 0]
        if not members:
            raise InputError(f"{w}: no link of the subtree of {target!r} has mass in the URDF")
        sigma = _prior(table, w, MASS_PRIOR, MASS_MAX, "(a factor)")
        val = effect_values(table, "subtree_mass", w)
        val = None if val is None else float(val[0])
        name = f"{target}.subtree_mass"
        pi = b.add_param(name, "subtree_mass", target, i, 1.0 if val is None else val, val is None)
        entries += [(body_of[ln], 1, pi) for ln in members]
        if val is None and sigma > 0:
            priors[name] = sigma
    bpar = np.asfortranarray(np.array(entries, np.int32).reshape(-1, 3).T)
    return bpar, priors


def prior_rows(model: object, free: np.ndarray, sigma_position: float | None = None) -> tuple | None:
    """The prior rows of the fit of ``model``'s parameters ``free``
    (0-based): (indices, centres (the URDF: factor 1, offset 0), sqrt
    weights sigma_position / prior), or None when none has a prior."""
    priors = getattr(model, "priors", None) or {}
    idx = [int(i) for i in free if model.params[i].name in priors]
    if not idx:
        return None
    s = sigma_position or getattr(model, "sigma_position", None) or PRIOR_POSITION_SCALE
    mu = np.array([1.0 if model.params[i].kind != "com" else 0.0 for i in idx])
    sw = np.array([s / priors[model.params[i].name] for i in idx])
    return np.array(idx, int), mu, sw


def body_table(kind: str, target: str, vals: dict[str, float]) -> tuple[dict, list[str]]:
    """The ``value`` of a written ``mass``, ``subtree_mass`` or ``com`` table
    (calib/absolute_write.py) from {parameter suffix: value}, within the
    bounds the loader checks, and notes naming a value clipped to them."""
    notes = []
    if kind == "com":
        v = [vals[n] for n in COM_NAMES]
        c = [min(max(x, -COM_MAX), COM_MAX) for x in v]
        if c != v:
            notes.append(f"{target}.com identified {v} m: beyond {COM_MAX:g} m, written as {c}")
        return {"value": c}, notes
    v = vals[kind]
    c = min(max(v, 0.0), MASS_MAX)
    if c != v:
        notes.append(f"{target}.{kind} identified {v:.4g}: a mass factor is in [0, {MASS_MAX:g}], written as {c:g}")
    return {"value": c}, notes
