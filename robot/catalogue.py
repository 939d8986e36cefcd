"""The catalogue of effect kinds (docs/calibration.md section 8): one entry
per kind, and everything else derived from it.

An entry says which data kinds the kind applies to (``deflection``:
deflections under known loads, sections 2-5; ``absolute``: tracker
positions, section 6), what its target is, the keys its ``[[effect]]``
table may carry, its parameters (name suffix, unit, bounds, start value),
the core law of its elastic block (tree model, ``LAW_*`` = the core's
``law_*`` codes) and of its term in the serial chain's evaluator
(core/sk_deflect.f90 ``term_*``, robot/model_core.py),
whether it needs a ``joint`` effect on its joint, how the diagnosis
generates its candidates, the key its values are written back under, and
its row of the docs table. The readers (robot/model.py, robot/tree_model.py)
take their kind lists and key tables from here, the diagnoses their
candidates (:func:`candidates`), the writers their value keys
(:func:`value_table`); tests/test_catalogue.py checks the docs table
(:func:`docs_table`) and the law codes against the core.

To add a kind: one :class:`Kind` in ``ENTRIES`` (and, if its law is new,
the law in the core with its ``LAW_*`` code here).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .model import Model
    from .tree_model import TreeModel

__all__ = [
    "DEFLECTION",
    "ABSOLUTE",
    "DATA_KINDS",
    "Param",
    "Kind",
    "ENTRIES",
    "KIND",
    "kinds",
    "keys",
    "entry",
    "candidates",
    "value_table",
    "docs_table",
    "LAWS",
    "DEADZONE_TAU0_FRACTION",
]

DEFLECTION, ABSOLUTE = "deflection", "absolute"
DATA_KINDS = (DEFLECTION, ABSOLUTE)
BOTH = DATA_KINDS

#: the law codes of the tree core's elastic blocks (core/sk_laws.f90 law_*)
LAW_LINEAR, LAW_CUBIC, LAW_DEADZONE, LAW_SPRING6, LAW_HARMONIC, LAW_JOINT = 1, 2, 3, 4, 5, 6
LAWS = {
    "LAW_LINEAR": LAW_LINEAR,
    "LAW_CUBIC": LAW_CUBIC,
    "LAW_DEADZONE": LAW_DEADZONE,
    "LAW_SPRING6": LAW_SPRING6,
    "LAW_HARMONIC": LAW_HARMONIC,
    "LAW_JOINT": LAW_JOINT,
}
#: bounds of the gravity parameters (robot/model_bodies.py): a mass factor in [0, MASS_MAX], a centre
#: offset within COM_MAX m
MASS_MAX, COM_MAX = 100.0, 1.0
_BODY_KEYS = frozenset({"target", "value", "prior"})
#: slots of law_joint's parameters (core/sk_laws.f90 js_*, 1-based): the profile's five, k_s, the
#: compensator's geometry a, b, beta, s0 (fixed parameters)
JS_PROFILE, JS_KS, JS_GEOM = 4, 11, 12
#: default smoothing of joint_deadzone: tau0 = this fraction of the RMS torque about the joint in the data
DEADZONE_TAU0_FRACTION = 0.05

INF = math.inf
C_UNIT = "rad/(N m)"  # m/N on a prismatic joint


@dataclass(frozen=True)
class Param:
    """One parameter of a kind: ``<target>.<suffix>``, its unit, the bounds
    a known value must meet and the start of an identified one."""

    suffix: str
    unit: str
    lo: float = -INF
    hi: float = INF
    default: float = 0.0
    #: the quantity that judges a known value's plausibility (io/validate.py QUANTITIES; "" none)
    quantity: str = ""
    #: its name in messages when not its suffix (point_offset's ``r = [x, y, z]``)
    label: str = ""

    @property
    def text(self) -> str:
        bounds = f" >= {self.lo:g}" if self.lo > -INF and self.hi == INF else ""
        if self.lo > -INF and self.hi < INF:
            bounds = f" in [{self.lo:g}, {self.hi:g}]"
        return f"`{self.suffix}` ({self.unit}{bounds})"


@dataclass(frozen=True)
class Kind:
    """One effect kind (module docstring)."""

    name: str
    data: tuple[str, ...]
    #: what ``target`` names (docs)
    target: str
    #: keys of its [[effect]] table besides ``kind`` and ``note``, per data kind
    keys: dict
    params: tuple[Param, ...]
    formula: str
    #: parameters as the docs say them when they are not a fixed list (templates, tracker)
    params_text: str = ""
    #: the core law of its block on absolute data ("" none)
    law: str = ""
    #: the core's 1-based slots of its parameters in that block (default: 2, 3, ... after the joint's c)
    slots: tuple[int, ...] = ()
    #: serial model: the code of its term in core/sk_deflect.f90 (term_*; 0: none)
    term: int = 0
    #: serial model: a term of the joint's linear compliance c(q) (at zero load)
    compliance: bool = False
    #: serial model: the joint's compliance depends on the posture (compensation takes it per row)
    posture_dependent: bool = False
    #: serial model: a deflection not linear in the joint torque (secant factor in robot/model.py)
    load_nonlinear: bool = False
    #: data kinds in which it needs a ``joint`` effect on the same joint
    needs_joint: tuple[str, ...] = ()
    #: per-joint kind; ``moving``: only on a moving (actuated) joint
    per_joint: bool = False
    moving: bool = True
    #: the key a known value is read from and written back under; ``scalar``: one number, not a list
    value_key: str = "value"
    scalar: bool = False
    #: a fixed key the block takes from the table (joint_deadzone's tau0)
    w0_key: str = ""
    #: a list kind whose table may give one number for all its values (lateral)
    broadcast: bool = False
    #: how its diagnosis candidates are generated: (model, data kind, context) -> [(table, hint)]
    candidates: Callable | None = None
    #: the data kinds on which it is a candidate (of those it applies to)
    candidate_in: tuple[str, ...] = DATA_KINDS
    #: how the candidates are generated (docs)
    candidates_text: str = ""
    #: what its table's other keys mean, for a command's --help (:func:`help_text`)
    usage: str = ""

    @property
    def names(self) -> list[str]:
        return [p.suffix for p in self.params]


# ---------------------------------------------------------------- candidate generators


def _joint_candidates(model: Model | TreeModel, data: str, ctx: dict, kind: Kind) -> list[tuple[dict, str]]:
    """Every joint the kind applies to that lacks it; on absolute data also
    ``all`` when more than one lacks it."""
    if data == DEFLECTION:
        out = []
        for j in model.chain.actuated:
            if model.has(kind.name, j) or (DEFLECTION in kind.needs_joint and not model.has("joint", j)):
                continue
            table = {"kind": kind.name, "target": j}
            if kind.w0_key:
                table[kind.w0_key] = (ctx.get("tau0") or {}).get(j, 1.0)
            out.append((table, ""))
        return out
    tree = model.tree
    have = {(p.kind, p.target) for p in model.params}
    joints = [j for j in tree.joints if j.moving or not kind.moving]
    if kind.name == "lateral":
        joints = [j for j in joints if j.type != "prismatic"]
    missing = [j.name for j in joints if (kind.name, j.name) not in have]
    if ABSOLUTE in kind.needs_joint:
        # a law on the joint's block: only where the joint has a compliance and no other law
        missing = [j for j in missing if ("joint", j) in have and not any((k, j) in have for k in LAW_KINDS)]
        return [({"kind": kind.name, "target": j}, "") for j in missing]
    out = [({"kind": kind.name, "target": "all"}, "")] if len(missing) > 1 else []
    return out + [({"kind": kind.name, "target": j}, "") for j in missing]


def _link_candidates(model: Model | TreeModel, data: str, ctx: dict, kind: Kind) -> list[tuple[dict, str]]:
    if data == DEFLECTION:
        ch = model.chain
        have = {(t.source, t.target, t.template) for t in model.terms if t.kind == "six"}
        out = []
        for link in ch.links:
            if ch.is_tool_spring(link):  # its spring is the tool spring: offered as kind tool
                continue
            for tpl in ("beam", "diagonal", "full"):
                if ("link", link, tpl) not in have:
                    out.append(({"kind": "link", "target": link, "template": tpl}, ""))
        return out
    have = {(p.kind, p.target) for p in model.params}
    return [
        ({"kind": "link", "target": link, "template": "beam"}, "")
        for link in links_carrying_mass(model)
        if ("link", link) not in have
    ]


def _end_candidates(model: Model | TreeModel, data: str, ctx: dict, kind: Kind) -> list[tuple[dict, str]]:
    """The base (and, on deflection data, tool) spring."""
    if data == ABSOLUTE:
        have = {(p.kind, p.target) for p in model.params}
        if ("base", "base") in have or not links_carrying_mass(model):
            return []
        return [({"kind": "base", "template": "full"}, "")]
    ch = model.chain
    have = {(t.source, t.target, t.template) for t in model.terms if t.kind == "six"}
    last = [ln for ln in ch.links if ch.is_tool_spring(ln)]
    out = []
    for tpl in ("diagonal", "full"):
        name = kind.name
        if (name, name, tpl) in have or (name == "tool" and any(("link", ln, tpl) in have for ln in last)):
            continue
        hint = f"the tool spring is also the spring of link {last[0]!r} (same frame)" if name == "tool" and last else ""
        out.append(({"kind": name, "template": tpl}, hint))
    return out


def _offset_candidates(model: Model, data: str, ctx: dict, kind: Kind) -> list[tuple[dict, str]]:
    return [] if any(t.kind == "point_offset" for t in model.terms) else [({"kind": "point_offset"}, "")]


def _body_candidates(model: TreeModel, data: str, ctx: dict, kind: Kind) -> list[tuple[dict, str]]:
    """Mass factors (robot/model_bodies.py): on every link with mass the
    model lacks one on, ``mass`` on ``all``, and ``subtree_mass`` on every
    link whose subtree holds two links with mass or more. Only when the
    model has an elastic effect (else they move nothing); bodies that load
    no elastic effect have zero columns and are listed as non-identifiable
    by the diagnosis."""
    if not getattr(model, "elastic", False):
        return []
    tree = model.tree
    have = {(p.kind, p.target) for p in model.params}
    massive = [ln for ln in tree.links if ln in tree.inertials and tree.inertials[ln].mass > 0 and ln != tree.root]
    missing = [ln for ln in massive if ("mass", ln) not in have]
    out = [{"kind": "mass", "target": "all"}] if len(missing) > 1 else []
    out += [{"kind": "mass", "target": ln} for ln in missing]
    for ln in tree.links:
        if ln != tree.root and ("subtree_mass", ln) not in have:
            if sum(x in massive for x in tree.subtree(ln)) >= 2:
                out.append({"kind": "subtree_mass", "target": ln})
    return [(t, "") for t in out]


def links_carrying_mass(model: TreeModel) -> list[str]:
    """Links with at least one child joint and some mass beyond it."""
    tree = model.tree
    mass_below: dict[str, float] = {ln: 0.0 for ln in tree.links}
    for j in reversed(tree.joints):
        ine = tree.inertials.get(j.child)
        mass_below[j.child] += ine.mass if ine else 0.0
        mass_below[j.parent] += mass_below[j.child]
    return [ln for ln in tree.links if tree.children(ln) and mass_below[ln] > 0 and ln != tree.root]


# ---------------------------------------------------------------- the entries

_SIX_KEYS = frozenset({"target", "template", "axis", "value", "rpy"})
_SIX_PARAMS = "`cIJ`, I <= J over (dx dy dz rx ry rz) (m/N, rad/(N m), 1/N): 21 (`full`), 8 (`beam`), 6 (`diagonal`)"
_JOINTS = "every joint lacking it (absolute: and `all`)"
_SIX_USAGE = (
    "template = full | beam (axis = x | y | z, eq. 13) | diagonal; value = 6 rows of 6 numbers or a link JSON, "
    "rpy = axes turned from the spring frame's"
)

ENTRIES: tuple[Kind, ...] = (
    Kind(
        "tracker",
        (ABSOLUTE,),
        "none",
        {ABSOLUTE: frozenset({"xyz", "rpy", "fixed"})},
        (),
        "T = Trans(x, y, z) R_ref Rx(a1) Ry(a2) Rz(a3): the tracker-from-base transform",
        params_text="`x y z` (m), `a1 a2 a3` (rad)",
        value_key="xyz",
    ),
    Kind(
        "marker",
        (ABSOLUTE,),
        "link",
        {ABSOLUTE: frozenset({"target", "xyz", "fixed"})},
        (Param("x", "m"), Param("y", "m"), Param("z", "m")),
        "the measured point in the link's frame",
        value_key="xyz",
    ),
    Kind(
        "joint_offset",
        (ABSOLUTE,),
        "moving joint or `all`",
        {ABSOLUTE: frozenset({"target", "value"})},
        (Param("dq0", "rad"),),
        "the joint turns by q + dq0",
        per_joint=True,
        scalar=True,
        candidates=_joint_candidates,
        candidates_text=_JOINTS,
    ),
    Kind(
        "frame",
        (ABSOLUTE,),
        "joint or `all`",
        {ABSOLUTE: frozenset({"target", "value"})},
        tuple(Param(n, "m" if n[1] != "r" else "rad") for n in ("dx", "dy", "dz", "drx", "dry", "drz")),
        "T(origin) Trans(dx, dy, dz) Rx(drx) Ry(dry) Rz(drz)",
        per_joint=True,
        moving=False,
        candidates=_joint_candidates,
        candidates_text=_JOINTS,
    ),
    Kind(
        "joint",
        BOTH,
        "actuated joint or `all`",
        {DEFLECTION: frozenset({"target", "value"}), ABSOLUTE: frozenset({"target", "value"})},
        (Param("c", C_UNIT, lo=0.0, quantity="joint_compliance"),),
        "dq = c tau",
        law="LAW_LINEAR",
        term=1,
        compliance=True,
        per_joint=True,
        scalar=True,
        candidates=_joint_candidates,
        candidates_text=_JOINTS,
        usage="rotation about the joint's axis; target = all: one per actuated joint",
    ),
    Kind(
        "joint_profile",
        BOTH,
        "actuated joint",
        {DEFLECTION: frozenset({"target", "value"}), ABSOLUTE: frozenset({"target", "value"})},
        tuple(Param(f"c{m}", C_UNIT) for m in range(5)),
        "c(q) = c0 + c1 cos q + c2 sin q + c3 cos 2q + c4 sin 2q",
        law="LAW_JOINT",
        slots=tuple(range(JS_PROFILE, JS_PROFILE + 5)),
        term=2,
        compliance=True,
        posture_dependent=True,
        needs_joint=(ABSOLUTE,),
        per_joint=True,
        candidates=_joint_candidates,
        candidate_in=(DEFLECTION,),
        candidates_text="deflection data: every actuated joint lacking it",
    ),
    Kind(
        "gravity_compensator",
        BOTH,
        "actuated joint",
        {
            DEFLECTION: frozenset({"target", "a", "b", "beta", "s0", "k_s"}),
            ABSOLUTE: frozenset({"target", "a", "b", "beta", "s0", "k_s"}),
        },
        (Param("k_s", "N/m", lo=0.0, quantity="spring_stiffness"),),
        "stiffness 1/c + k_s (s'^2 + (s - s0) s''), s = sqrt(a^2 + b^2 - 2ab cos(q + beta))",
        law="LAW_JOINT",
        slots=(JS_KS,),
        needs_joint=BOTH,
        term=3,
        posture_dependent=True,
        per_joint=True,
        value_key="k_s",
        scalar=True,
        candidates_text="through its generic form joint_profile (a hint names it)",
        usage="a spring between the bodies of the joint of geometry a, b, beta, s0 (m, m, rad, m)",
    ),
    Kind(
        "lateral",
        (ABSOLUTE,),
        "revolute joint or `all`",
        {ABSOLUTE: frozenset({"target", "value", "tilts"})},
        (Param("cx", C_UNIT, lo=0.0), Param("cy", C_UNIT, lo=0.0)),
        "tilts of the axis before its motion: dphi_x' = cx m_x', dphi_y' = cy m_y'",
        law="LAW_LINEAR",
        per_joint=True,
        broadcast=True,
        candidates=_joint_candidates,
        candidates_text="every revolute joint lacking it, and `all`",
    ),
    Kind(
        "joint_cubic",
        BOTH,
        "actuated joint",
        {DEFLECTION: frozenset({"target", "value"}), ABSOLUTE: frozenset({"target", "value"})},
        (Param("cubic", "rad/(N m)^3"),),
        "dq = c tau + c3 tau^3",
        law="LAW_CUBIC",
        term=4,
        load_nonlinear=True,
        needs_joint=(ABSOLUTE,),
        per_joint=True,
        scalar=True,
        candidates=_joint_candidates,
        candidate_in=(DEFLECTION,),
        candidates_text="deflection data: every actuated joint lacking it",
    ),
    Kind(
        "joint_deadzone",
        BOTH,
        "actuated joint",
        {DEFLECTION: frozenset({"target", "value", "tau0"}), ABSOLUTE: frozenset({"target", "value", "tau0"})},
        (Param("backlash", "rad", lo=0.0),),
        "dq = c tau + b tanh(tau / tau0)",
        law="LAW_DEADZONE",
        term=5,
        load_nonlinear=True,
        needs_joint=(ABSOLUTE,),
        per_joint=True,
        scalar=True,
        w0_key="tau0",
        candidates=_joint_candidates,
        candidate_in=(DEFLECTION,),
        candidates_text=f"deflection data: every actuated joint lacking it (tau0 {DEADZONE_TAU0_FRACTION:.0%} "
        "of the RMS torque)",
        usage=f"backlash +-b; tau0 (N m) defaults to {DEADZONE_TAU0_FRACTION:.0%} of the RMS torque about the joint "
        "in the data (written back)",
    ),
    Kind(
        "joint_harmonic",
        BOTH,
        "actuated joint",
        {DEFLECTION: frozenset({"target", "value"}), ABSOLUTE: frozenset({"target", "value"})},
        (Param("cos1", C_UNIT), Param("sin1", C_UNIT)),
        "dq = (c + c1 cos q + s1 sin q) tau, value = [c1, s1] (cogging, gear eccentricity)",
        law="LAW_HARMONIC",
        term=8,
        compliance=True,
        posture_dependent=True,
        needs_joint=BOTH,
        per_joint=True,
        candidates=_joint_candidates,
        candidates_text="every actuated joint with a `joint` effect and no other law on it",
    ),
    Kind(
        "link",
        BOTH,
        "link",
        {DEFLECTION: _SIX_KEYS, ABSOLUTE: _SIX_KEYS},
        (),
        "6x6 spring: (dt, dphi) = C (f, m) at the link's spring frame",
        params_text=_SIX_PARAMS,
        law="LAW_SPRING6",
        candidates=_link_candidates,
        candidates_text="deflection: every link, templates beam, diagonal, full; "
        "absolute: every link carrying mass, beam",
        usage=_SIX_USAGE + "; the link's spring frame is its distal joint's frame before that joint's motion",
    ),
    Kind(
        "base",
        BOTH,
        "none",
        {DEFLECTION: _SIX_KEYS, ABSOLUTE: _SIX_KEYS - {"target"}},
        (),
        "6x6 spring at the base_link origin",
        params_text=_SIX_PARAMS,
        law="LAW_SPRING6",
        candidates=_end_candidates,
        candidates_text="deflection: diagonal, full; absolute: full (when a link carries mass)",
        usage=_SIX_USAGE,
    ),
    Kind(
        "tool",
        (DEFLECTION,),
        "none",
        {DEFLECTION: _SIX_KEYS},
        (),
        "6x6 spring between the last link and the tool frame",
        params_text=_SIX_PARAMS,
        candidates=_end_candidates,
        candidates_text="diagonal, full",
        usage=_SIX_USAGE,
    ),
    Kind(
        "point_offset",
        (DEFLECTION,),
        "none",
        {DEFLECTION: frozenset({"target", "r"})},
        (Param("rx", "m", quantity="position", label="x"), Param("ry", "m", label="y"), Param("rz", "m", label="z")),
        "the measured points sit at p + r (tool frame)",
        value_key="r",
        term=7,
        candidates=_offset_candidates,
        candidates_text="one, when the model lacks it",
    ),
    Kind(
        "mass",
        (ABSOLUTE,),
        "link with mass or `all`",
        {ABSOLUTE: _BODY_KEYS},
        (Param("mass", "factor", lo=0.0, hi=MASS_MAX, default=1.0, label="mass factor"),),
        "mass = URDF mass * factor",
        scalar=True,
        candidates=_body_candidates,
        candidates_text="every link with mass lacking it, `all`; subtree_mass on subtrees of 2+ massive links",
    ),
    Kind(
        "subtree_mass",
        (ABSOLUTE,),
        "link",
        {ABSOLUTE: _BODY_KEYS},
        (Param("subtree_mass", "factor", lo=0.0, hi=MASS_MAX, default=1.0, label="mass factor"),),
        "every mass of the subtree * factor",
        scalar=True,
        candidates_text="with mass (above)",
    ),
    Kind(
        "com",
        (ABSOLUTE,),
        "link with mass or `all`",
        {ABSOLUTE: _BODY_KEYS},
        tuple(Param(f"com_{a}", "m", lo=-COM_MAX, hi=COM_MAX, label=f"d{a}") for a in "xyz"),
        "centre of mass = URDF centre + (com_x, com_y, com_z)",
    ),
)

KIND: dict[str, Kind] = {e.name: e for e in ENTRIES}
#: serial model: kinds whose joint compliance depends on the posture
POSTURE_DEPENDENT = tuple(e.name for e in ENTRIES if e.posture_dependent)
#: serial model: the term codes of core/sk_deflect.f90 (a 6-dof spring, of any kind, is "six")
TERM_SIX = 6
TERMS = {**{e.name: e.term for e in ENTRIES if e.term}, "six": TERM_SIX}
#: kinds whose law replaces the joint's linear one on absolute data (one per joint)
LAW_KINDS = tuple(e.name for e in ENTRIES if e.per_joint and e.law and e.name != "joint" and ABSOLUTE in e.needs_joint)


def entry(kind: str) -> Kind:
    return KIND[kind]


def kinds(data: str) -> tuple[str, ...]:
    """The kinds a model of data kind ``data`` takes, in catalogue order."""
    return tuple(e.name for e in ENTRIES if data in e.data)


def keys(data: str) -> dict[str, set[str]]:
    """Kind -> the keys its [[effect]] table may carry (besides kind and note)."""
    return {e.name: set(e.keys[data]) for e in ENTRIES if data in e.data}


def law_code(kind: str) -> int:
    return LAWS[KIND[kind].law]


def candidates(model: Model | TreeModel, data: str, tau0: dict | None = None) -> list[tuple[dict, str]]:
    """The diagnosis candidates of ``model`` on data of kind ``data``: every
    catalogued kind on every target the model lacks, in catalogue order, as
    (effect table, hint). ``tau0`` {joint: N m}: the smoothing torque of the
    joint_deadzone candidates (from the data's torque scale)."""
    ctx = {"tau0": tau0}
    out: list[tuple[dict, str]] = []
    for e in ENTRIES:
        if data in e.data and data in e.candidate_in and e.candidates is not None:
            out += e.candidates(model, data, ctx, e)
    return out


def value_table(kind: str, values: list[float] | np.ndarray) -> dict:
    """The key(s) a table of ``kind`` carries its known values under, from
    the values in parameter order (a scalar kind: one number)."""
    e = KIND[kind]
    v = [float(x) for x in values]
    return {e.value_key: v[0] if e.scalar else v}


def docs_table() -> str:
    """The table of kinds in docs/calibration.md section 8 (a test checks it)."""
    rows = [
        "| kind | data | target | parameters | law | candidates |",
        "|---|---|---|---|---|---|",
    ]
    for e in ENTRIES:
        data = ", ".join(e.data)
        params = e.params_text or ", ".join(p.text for p in e.params)
        law = e.formula + (f" (`{e.law}`)" if e.law else "")
        if e.needs_joint:
            law += f"; needs a `joint` effect ({', '.join(e.needs_joint)})"
        rows.append(f"| `{e.name}` | {data} | {e.target} | {params} | {law} | {e.candidates_text or 'none'} |")
    return "\n".join(rows)
