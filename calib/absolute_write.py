"""Writing what a fit on absolute data identified (docs/calibration.md
sections 5 and 6.4): the model TOML with every value, and the URDF with the
geometric errors folded into the joint origins.

``write_model(fit, path)``: every effect of the fitted model with its value
(tracker pose, marker points, per-joint zero offsets, frame errors, joint,
lateral, cubic and dead-zone values, 6x6 link and base springs), the
declared sigma and [gravity], so that ``load_tree_model(path)`` predicts
the points the fit predicts. Values of the effects become known values
(section 5: evaluated, not identified); the tracker and markers keep
theirs as start values.

``write_urdf(fit, path)``: the robot's URDF, read with xml.etree from the
original file, with each joint's origin replaced by

    origin' = origin * Trans(dx, dy, dz) * Rx(drx) Ry(dry) Rz(drz) * Motion(axis, dq)

where dq is the joint's total zero offset (its own plus, for a mimic
follower, its multiplier times its leader's, up the mimic chain);
everything else (inertials, limits, mimic tags, comments) unchanged. The
folded URDF with the written model minus its ``joint_offset`` and
``frame`` effects (``write_model(fit, path, folded_urdf=...)``) predicts the
same points: a joint's compliance sits at its motion, so moving the offset
into the origin commutes with it; its lateral tilts sit before the motion
(docs/calibration.md section 6.12), and the folded model writes them
(``tilts``) turned back by the folded offset, as they were. A 6x6 link spring sits at the joint's origin, before
the frame error and the motion: folding moves it by the frame error and
the offset (a change of second order, error times spring deflection); the
writer says so when it happens.

Both files are written atomically (``stiffkit.io.files``).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Collection
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InputError
from ..io.files import atomic_write_text
from ..robot import catalogue, model_file
from ..robot.effect_values import COMPENSATOR_KEYS
from ..robot.model import SYM
from ..robot.model_bodies import BODY_KINDS, body_table
from ..robot.tree import TreeJoint
from ..robot.tree_lateral import joint_tilts
from ..robot.tree_model import (
    EQ_ITERATIONS,
    FRAME_NAMES,
    LAW_DEADZONE,
    TreeModel,
    rpy_from_matrix,
)

if TYPE_CHECKING:
    from .absolute_fit import AbsoluteFit

__all__ = ["write_model", "write_urdf", "model_text", "model_effects", "folded_origins", "FOLDED_KINDS"]

#: the effect kinds write_urdf folds into the joint origins
FOLDED_KINDS = ("joint_offset", "frame")


def model_text(
    effects: list[dict],
    urdf: str = "robot.urdf",
    base_link: str = "base_link",
    sigma_position: float | None = None,
    gravity: ArrayLike | None = None,
    iterations: int | None = None,
    robot: dict | None = None,
    header: str = "",
    plan: dict | None = None,
) -> str:
    """A model TOML for absolute data (section 6.2): [robot],
    [measurements] kind = "absolute" (and sigma_position when given),
    [gravity] when given, the [plan] table (``stiffkit plan``) when given,
    and the [[effect]] tables; ``header``: comment lines at the top."""
    rob = {k: v for k, v in (robot or {}).items() if k not in ("urdf", "base_link")}
    g: dict = {}
    if gravity is not None:
        g["vector"] = [float(v) for v in gravity]
    if iterations is not None:
        g["iterations"] = int(iterations)
    return model_file.model_text(
        effects,
        {"urdf": str(urdf), "base_link": base_link, **rob},
        kind="absolute",
        sigma_position=sigma_position,
        gravity=g,
        plan=plan,
        header=header,
    )


def _by_target(model: TreeModel, theta: np.ndarray, effect: int) -> dict[str, dict[str, float]]:
    """target -> {parameter suffix: value} of one [[effect]] table, in parameter order."""
    out: dict[str, dict[str, float]] = {}
    for i, p in enumerate(model.params):
        if p.effect == effect:
            out.setdefault(p.target, {})[p.name.rsplit(".", 1)[1]] = float(theta[i])
    return out


def _tau0(model: TreeModel, joint: str) -> float:
    for k, (kind, target) in enumerate(model.blocks):
        if kind == "joint" and target == joint and model.arrays["ktype"][k] == LAW_DEADZONE:
            return float(model.arrays["kw0"][k])
    raise InputError(f"joint_deadzone on {joint!r}: the model has no dead-zone law there")


#: how a written table's note names the parameters the data did not identify
HELD_NOTE = "not identified by the data (held at its start value)"


def _note(keep: dict, extra: list[str]) -> dict:
    """The table's note: the source's own (a model written earlier keeps
    what that fit said of its values) and ``extra``, each said once."""
    parts = [x for x in str(keep.get("note", "")).split("; ") if x] + extra
    return {"note": "; ".join(dict.fromkeys(parts))} if parts else {}


def model_effects(
    model: TreeModel,
    theta: np.ndarray,
    skip: Collection[str] = (),
    std: np.ndarray | None = None,
    groups: list[str] | None = None,
) -> tuple[list[dict], list[str]]:
    """The [[effect]] tables of ``model`` with the values of ``theta``, one
    table per target (a value needs one target), in the order of the model's
    tables; kinds in ``skip`` are left out. Returns the tables and notes:
    a compliance identified below 0 (not physical; the loader refuses it)
    is written as 0 and named, with its standard error ``std`` when given.
    With the fit's ``groups``, a table whose parameters the data did not
    identify (non-identifiable, near-redundant, at bound: held at the start
    value) says so in its ``note``, as does one with a value written as 0."""
    theta = np.asarray(theta, float)
    sd = {p.name: float(std[i]) for i, p in enumerate(model.params)} if std is not None else {}
    unknown = {"non-identifiable", "near-redundant", "at bound"}
    held = {p.name for i, p in enumerate(model.params) if groups is not None and groups[i] in unknown}
    tables: list[dict] = []
    notes: list[str] = []
    for e, src in enumerate(model.effects):
        kind = src["kind"]
        if kind in skip:
            continue
        keep = {k: src[k] for k in ("note",) if k in src}
        if kind == "tracker":
            R, t = model.tracker_pose(theta)
            tab = {"kind": kind, "xyz": [float(v) for v in t], "rpy": [float(v) for v in rpy_from_matrix(R)]}
            if src.get("fixed"):
                tab["fixed"] = True
            tables.append({**tab, **keep})
            continue
        for target, vals in _by_target(model, theta, e).items():
            tab: dict = {"kind": kind}
            said = [n for n in vals if f"{target}.{n}" in held] if kind != "marker" else []
            n_notes = len(notes)
            if kind != "base":
                tab["target"] = target
            if kind == "marker":
                tab["xyz"] = [vals[c] for c in "xyz"]
                if src.get("fixed"):
                    tab["fixed"] = True
            elif kind in ("joint", "lateral"):
                names = ["c"] if kind == "joint" else ["cx", "cy"]
                v = [vals.get(n, 0.0) for n in names]  # a joint may have no cy (section 6.12)
                for n, x in zip(names, v):
                    if x < 0:
                        e = sd.get(f"{target}.{n}", math.nan)
                        pm = f" +- {e:.2g}" if math.isfinite(e) else ""
                        notes.append(
                            f"{target}.{n} identified {x:.4g}{pm} rad/(N m): a compliance is >= 0, written as 0"
                            + (" (within 2 standard errors of 0)" if math.isfinite(e) and -x <= 2 * e else "")
                        )
                v = [max(x, 0.0) for x in v]
                tab["value"] = v[0] if kind == "joint" else v
            elif kind in ("link", "base"):
                C = np.zeros((6, 6))
                for a, b in SYM:
                    C[a, b] = C[b, a] = vals.get(f"c{a + 1}{b + 1}", 0.0)
                tab["value"] = C.tolist()
            elif kind in BODY_KINDS:
                val, clipped = body_table(kind, target, vals)
                tab.update(val)
                notes += clipped
            elif catalogue.KIND[kind].params:  # the key(s) the reader takes the values from (robot/catalogue.py)
                e = catalogue.KIND[kind]
                tab.update(catalogue.value_table(kind, [vals[n] for n in e.names]))
                if kind == "gravity_compensator":  # its geometry, fixed parameters of the model
                    tab.update({k: vals[k] for k in COMPENSATOR_KEYS})
                if e.w0_key:
                    tab[e.w0_key] = _tau0(model, target)
            else:  # pragma: no cover - every kind of ABS_KINDS is handled above
                raise InputError(f"cannot write an effect of kind {kind!r}")
            extra = [f"{HELD_NOTE}: " + ", ".join(said)] if said else []
            extra += notes[n_notes:]
            tables.append({**tab, **_note(keep, extra)})
    return tables, notes


def _relative(target: str | Path, folder: Path) -> str:
    target = Path(target).resolve()
    try:
        return os.path.relpath(target, folder.resolve())
    except ValueError:  # another drive
        return str(target)


def write_model(fit: AbsoluteFit, path: str | Path, folded_urdf: str | Path | None = None) -> list[str]:
    """Write the fitted model (``fit``: an AbsoluteFit) as a model TOML with
    every value. With ``folded_urdf`` (a URDF written by :func:`write_urdf`
    from this fit), the model names that URDF and leaves out the effects
    folded into it. Returns notes (values changed to be loadable)."""
    model: TreeModel = fit.model
    path = Path(path)
    urdf = folded_urdf if folded_urdf is not None else model.tree.urdf
    effects, notes = model_effects(
        model,
        fit.theta,
        FOLDED_KINDS if folded_urdf is not None else (),
        getattr(fit, "std", None),
        getattr(fit, "groups", None),
    )
    _written_tilts(model, fit.theta, effects, folded_urdf is not None)
    sigma = fit.sigma if getattr(fit, "sigma_declared", False) else model.sigma_position
    header = f"# written by stiffkit from the fit of {model.path or 'a model'} on {fit.data.path}"
    robot = dict(model.robot_table)
    if folded_urdf is not None:
        header += f"\n# joint offsets and frame errors are folded into {Path(folded_urdf).name}"
        # the nominal robot stays the one the commands refer to (compensation's targets)
        nominal = Path(model.tree.urdf)
        if isinstance(robot.get("nominal_urdf"), str) and model.path is not None:
            nominal = Path(model.path).parent / robot["nominal_urdf"]
        robot["nominal_urdf"] = _relative(nominal, path.parent)
    text = model_text(
        effects,
        urdf=_relative(urdf, path.parent),
        base_link=model.tree.root,
        sigma_position=sigma,
        gravity=model.gravity,
        iterations=model.iterations if model.iterations != EQ_ITERATIONS else None,
        robot=robot,
        header=header,
        plan=model.plan,
    )
    atomic_write_text(path, text)
    return notes


def _motion(joint: TreeJoint, value: float) -> np.ndarray:
    T = np.eye(4)
    if joint.type == "prismatic":
        T[:3, 3] = joint.axis * value
    else:
        x, y, z = joint.axis
        k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
        T[:3, :3] = np.eye(3) + math.sin(value) * k + (1 - math.cos(value)) * (k @ k)
    return T


def _total_offset(model: TreeModel, val: dict[str, float], j: TreeJoint) -> tuple[float, bool]:
    """A joint's total zero offset (its own plus its multiplier times its
    leader's, up the mimic chain) and whether it has one."""
    dq, name, coef, has = 0.0, j.name, 1.0, False
    while j.moving:
        if f"{name}.dq0" in val:
            dq += coef * val[f"{name}.dq0"]
            has = True
        mimic = model.tree.joint(name).mimic
        if mimic is None:
            break
        coef *= mimic[1]
        name = mimic[0]
    return dq, has


def _written_tilts(model: TreeModel, theta: np.ndarray, tables: list[dict], folded: bool) -> None:
    """Each lateral table of a folded model (or of a model whose tables had
    them) gets its tilts (section 6.12) as they were, in the folded origin
    frame (turned back by the folded zero offset): the written model
    predicts what the fit predicted."""
    if not folded and not any("tilts" in e for e in model.effects):
        return
    val = {p.name: float(theta[i]) for i, p in enumerate(model.params)}
    for tab in tables:
        if tab["kind"] != "lateral":
            continue
        j = model.tree.joint(tab["target"])
        src = model.effects[next(p.effect for p in model.params if p.kind == "lateral" and p.target == j.name)]
        back = _motion(j, -_total_offset(model, val, j)[0] if folded else 0.0)[:3, :3]
        tilts = joint_tilts(model.tree, j.name, {**src, "target": j.name}, "lateral")
        tab["tilts"] = [[float(x) for x in np.concatenate([back @ a, back @ p])] for a, p in tilts]


def folded_origins(model: TreeModel, theta: np.ndarray) -> dict[str, np.ndarray]:
    """joint name -> its new origin (4, 4) for every joint with a frame
    error or a (total) zero offset other than 0 (module docstring)."""
    theta = np.asarray(theta, float)
    val = {p.name: float(theta[i]) for i, p in enumerate(model.params)}
    out = {}
    for j in model.tree.joints:
        frame = [val.get(f"{j.name}.{n}") for n in FRAME_NAMES]
        dq, has = _total_offset(model, val, j)
        if (not has or dq == 0.0) and (frame[0] is None or not any(frame)):
            continue  # nothing to fold: the origin stays as written
        T = j.origin.copy()
        if frame[0] is not None:
            F = np.eye(4)
            F[:3, 3] = frame[:3]
            c = [math.cos(a) for a in frame[3:]]
            s = [math.sin(a) for a in frame[3:]]
            rx = np.array([[1, 0, 0], [0, c[0], -s[0]], [0, s[0], c[0]]])
            ry = np.array([[c[1], 0, s[1]], [0, 1, 0], [-s[1], 0, c[1]]])
            rz = np.array([[c[2], -s[2], 0], [s[2], c[2], 0], [0, 0, 1]])
            F[:3, :3] = rx @ ry @ rz
            T = T @ F
        if has:
            T = T @ _motion(j, dq)
        out[j.name] = T
    return out


def _fmt(v: ArrayLike) -> str:
    return " ".join(repr(float(x)) for x in v)


def write_urdf(fit: AbsoluteFit, path: str | Path) -> list[str]:
    """Write the robot's URDF with the fit's zero offsets and frame errors
    folded into the joint origins (module docstring). Returns notes."""
    model: TreeModel = fit.model
    src = Path(model.tree.urdf)
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    try:
        doc = ET.parse(src, parser=parser)
    except (OSError, ET.ParseError) as exc:
        raise InputError(f"{src}: cannot read the URDF to fold the fit into it ({exc})") from None
    root = doc.getroot()
    origins = folded_origins(model, fit.theta)
    notes = []
    springs = {p.target for p in model.params if p.kind == "link"}
    for el in root.findall("joint"):
        name = el.get("name")
        if name not in origins:
            continue
        T = origins[name]
        org = el.find("origin")
        if org is None:
            org = ET.SubElement(el, "origin")
        org.set("xyz", _fmt(T[:3, 3]))
        org.set("rpy", _fmt(rpy_from_matrix(T[:3, :3])))
        j = model.tree.joint(name)
        if j.parent in springs and len(model.tree.children(j.parent)) == 1:
            notes.append(
                f"joint {name!r}: the link spring of {j.parent!r} sits at this joint's origin; folding moves it "
                "by the frame error and zero offset (a change of second order)"
            )
    text = ET.tostring(root, encoding="unicode")
    atomic_write_text(path, '<?xml version="1.0"?>\n' + text + "\n")
    return notes
