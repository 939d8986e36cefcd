"""Robot elastostatic models: URDF + TOML effects (docs/calibration.md §2, §5).

A model file names the robot and lists ``[[effect]]`` tables; each effect
expands into *terms* (``joint`` with ``target = "all"`` becomes one term per
actuated joint), each term owns parameters (free, to identify, or known
when the table carries a value) and a virtual spring of the chain.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from .._core import calib as core
from .._core.springs import rotate6
from ..errors import InputError
from ..io import validate as V
from ..io.linkjson import check_spring_matrix, read_link_compliance
from ..io.tables import read_toml
from . import catalogue
from .catalogue import DEADZONE_TAU0_FRACTION
from .effect_values import compensator_geometry, effect_kind, effect_values, effect_w0, effect_where
from .indices import Indices, stiffness_indices_where
from .model_core import SPRING_BASE, SPRING_FRAME, SPRING_JOINT, SPRING_TOOL, known_joint_compliances
from .model_tree import ChainTree, chain_tree_model
from .plan_settings import plan_table
from .spring6 import AXES, SYM, SYM_INDEX, TEMPLATES, rpy_matrix, template_elements  # noqa: F401 (robot.model's names)
from .urdf import Chain, load_chain

KINDS = catalogue.kinds(catalogue.DEFLECTION)
#: kinds that act on one joint's spring (target: a joint name)
JOINT_KINDS = tuple(k for k in KINDS if catalogue.KIND[k].per_joint)
#: joint kinds whose deflection is not linear in the joint torque (docs/calibration.md section 7.1)
LOAD_NONLINEAR = tuple(k for k in KINDS if catalogue.KIND[k].load_nonlinear)
#: joint kinds that need a `joint` effect on the same joint
NEEDS_JOINT = tuple(k for k in KINDS if catalogue.DEFLECTION in catalogue.KIND[k].needs_joint)


@dataclass
class Term:
    """One expanded effect: a spring (or a point offset) with its parameters.

    kind: joint | joint_profile | gravity_compensator | joint_cubic
          | joint_deadzone | six (link/base/tool) | point_offset
    """

    kind: str
    target: str
    effect: int  # index of the [[effect]] table
    names: list[str]
    spring: tuple[int, int] | None  # (stype, 1-based joint index) or None
    elements: list[int] = field(default_factory=list)  # six: kept elements
    value: np.ndarray | None = None  # known values of the parameters
    joint: int = -1  # 0-based chain index (joint kinds)
    qcol: int = -1  # 0-based q column (joint kinds)
    geometry: dict = field(default_factory=dict)  # compensator a, b, beta, s0; deadzone tau0
    template: str = ""
    axis: int = 0
    source: str = ""  # kind as written (link/base/tool)

    @property
    def free(self) -> bool:
        return self.value is None

    @property
    def nonlinear(self) -> bool:
        return self.kind in ("gravity_compensator", "point_offset")


@dataclass
class Model:
    """A robot (chain) and its elastostatic effects."""

    chain: Chain
    effects: list[dict]
    terms: list[Term]
    path: Path | None = None
    sigma_position: float | None = None
    sigma_rotation: float | None = None
    robot_table: dict = field(default_factory=dict)
    #: the file's optional [plan] table as written (robot/plan_settings.py reads it; the writers keep it)
    plan: dict = field(default_factory=dict)
    #: the last tree model built (tree_model) and the terms it was built from
    _tree: tuple | None = field(default=None, init=False, repr=False, compare=False)

    # -- springs --------------------------------------------------------
    def springs(self, extra_terms: Iterable[Term] = ()) -> list[tuple[int, int]]:
        """Distinct springs of the terms (and extra terms), in a stable order:
        every actuated joint's spring first (needed by joint-type terms)."""
        out = []
        for t in list(self.terms) + list(extra_terms):
            if t.spring is not None and t.spring not in out:
                out.append(t.spring)
        return out

    @property
    def parameter_names(self) -> list[str]:
        return [n for t in self.terms if t.free for n in t.names]

    def has(self, kind: str, target: str) -> bool:
        return any(t.kind == kind and t.target == target for t in self.terms)

    # -- evaluation with known values -----------------------------------
    def joint_compliances(
        self, Q: np.ndarray, terms: Iterable[Term] | None = None, wrench: np.ndarray | None = None
    ) -> dict[int, np.ndarray]:
        """Compliance of every joint spring at postures Q (N, dof), from the
        known values of the joint kinds: {chain joint index: (N,)}.

        Without ``wrench`` the compliance at zero load: joint_cubic adds
        nothing there (its tangent at tau = 0) and joint_deadzone has none
        (InputError). With ``wrench`` (N, 6) (tool-frame origin, base axes)
        the secant compliance under that load, dq_j / tau_j, so that the
        tool compliance times the wrench is the deflection."""
        terms = self.terms if terms is None else terms
        c = known_joint_compliances(self.chain, list(terms), Q, wrench)
        for j, cj in c.items():
            bad = ~(cj >= 0)
            if bad.any():
                i = int(np.argmax(bad))
                name = self.chain.joint_names[j]
                kinds = sorted({t.source or t.kind for t in terms if t.joint == j})
                raise InputError(
                    f"{self.path or 'model'}: the compliance of joint {name!r} ({' + '.join(kinds)}) is {cj[i]:.4g} "
                    f"rad/(N m) at posture {i + 1}: a joint compliance must be >= 0 (a negative one is no spring)"
                )
        return c

    def six_values(self, terms: Iterable[Term] | None = None) -> dict[tuple[int, int], np.ndarray]:
        """Summed known 6x6 compliance of each 6-dof spring."""
        terms = self.terms if terms is None else terms
        out = {}
        for t in terms:
            if t.kind == "six":
                if t.value is None:
                    raise InputError(
                        f"effect {t.source} on {t.target!r} has no value; "
                        f"identify it first (stiffkit fit --write-model)"
                    )
                C = np.zeros((6, 6))
                for e, v in zip(t.elements, t.value):
                    a, b = SYM[e]
                    C[a, b] += v
                    if a != b:
                        C[b, a] += v
                out[t.spring] = out.get(t.spring, np.zeros((6, 6))) + C
        return out

    def jacobians(self, q: npt.ArrayLike) -> dict:
        """Jacobians of every spring of the model at posture q (dof,):
        {(stype, joint index): (6, 1) or (6, 6)}; the tool twist per spring
        deflection (base axes, about the tool-frame origin): the tool
        frame's twists per elastic block of the model's TreeModel
        (:meth:`tree_model`, TreeModel.twists)."""
        springs = self.springs()
        if not springs:
            return {}
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.shape != (self.chain.dof,):
            raise InputError(f"posture must have {self.chain.dof} values, got {q.size}")
        ct = self.tree_model()
        g = dict(zip(ct.springs, ct.model.twists(q, self.chain.tool_frame)))
        return {sp: g[sp].copy() for sp in springs}

    def tree_model(self, where: str | None = None) -> ChainTree:
        """The one tree model of this chain model (robot/model_tree.py): the
        TreeModel the tree core evaluates, with the parameters of its
        posture-dependent joint compliances. Its effects must carry values."""
        key = (
            id(self.chain),
            [(t.kind, t.target, t.spring, _values(t.value), sorted(t.geometry.items())) for t in self.terms],
        )
        if self._tree is None or self._tree[0] != key:
            self._tree = (key, chain_tree_model(self, where or str(self.path or "model")))
        return self._tree[1]

    def tool_compliance(
        self, Q: npt.ArrayLike, return_stiffness: bool = False, wrench: npt.ArrayLike | None = None
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Tool-frame compliance (N, 6, 6) at postures Q (N, dof): base axes,
        about the tool-frame origin, sum_i J_i C_i J_i^T, one core call: the
        tool frame's compliance of the model's TreeModel (:meth:`tree_model`,
        TreeModel.compliance), every joint's compliance at the posture a
        parameter of that posture.

        With ``return_stiffness`` also (K (N,6,6), rank (N,), ok (N,) bool):
        K = C^-1 where C is positive definite, else zeros and ok False.
        ``wrench`` (N, 6) (tool-frame origin, base axes): the secant
        compliance under that load for load-nonlinear joints (joint_cubic,
        joint_deadzone; see joint_compliances); without it the compliance at
        zero load.
        """
        Q = np.atleast_2d(V.array(Q, "postures", None, "angle"))
        if Q.ndim != 2 or Q.shape[1] != self.chain.dof or Q.shape[0] < 1:
            raise InputError(f"postures must have shape (N, {self.chain.dof}), got {np.shape(Q)}")
        if wrench is not None:
            wrench = np.atleast_2d(V.array(wrench, "wrench", None, "force"))
            if wrench.shape != (Q.shape[0], 6):
                raise InputError(f"wrench must be an array of shape ({Q.shape[0]}, 6), got {np.shape(wrench)}")
        jc = self.joint_compliances(Q, wrench=wrench)
        self.six_values()  # every 6-dof spring has its value (else a clear error)
        tm = self.tree_model().model
        # each joint's compliance at the posture (its secant under the wrench) is
        # its c; the load-nonlinear laws' own parameters are then 0
        theta = tm.theta0
        names = {n: i for i, n in enumerate(tm.names)}
        for t in self.terms:
            if t.kind in LOAD_NONLINEAR:
                for n in t.names:
                    theta[names[n]] = 0.0
        joints = sorted(jc)
        idx = [names[f"{self.chain.joint_names[j]}.c"] for j in joints]
        vals = np.column_stack([jc[j] for j in joints]) if joints else np.zeros((len(Q), 0))
        C, K, rank, ok = tm.compliance(Q, self.chain.tool_frame, theta, (idx, vals))
        if return_stiffness:
            return C, K, rank, ok
        return C

    def stiffness(self, Q: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(C, K, rank, ok) at postures Q; see tool_compliance."""
        return self.tool_compliance(Q, return_stiffness=True)

    def stiffness_indices(self, Q: npt.ArrayLike, lscale: float | None = None) -> tuple[Indices, np.ndarray]:
        """Stiffness indices kappa_t, kappa_r (N) of the tool stiffness at
        postures Q (Taghvaeipour et al. 2010 eqs. 31-39, core/sk_indices.f90),
        made unit-invariant with the length ``lscale`` (m; default the chain's
        characteristic length). Returns (Indices, ok): NaN where the stiffness
        does not exist (ok False)."""
        if lscale is not None:
            lscale = V.number(lscale, "lscale", "length", lo=0.0, lo_open=True)
        _, K, _, ok = self.stiffness(Q)
        lscale = self.chain.characteristic_length if lscale is None else lscale
        return stiffness_indices_where(K, ok, lscale), ok


def _values(v: np.ndarray | None) -> tuple | None:
    return None if v is None else tuple(np.ravel(v).tolist())


#: the gravity compensator's d2V/dq2 per unit k_s (the law is the core's, core/sk_deflect.f90)
compensator_h = core.compensator_h


def default_tau0(tau: np.ndarray) -> float:
    """Smoothing torque of joint_deadzone chosen from the data: a fraction
    (DEADZONE_TAU0_FRACTION) of the RMS torque about the joint over the rows,
    rounded to 2 significant digits so that it reads well in a model file."""
    rms = float(np.sqrt(np.mean(np.asarray(tau, float) ** 2))) if np.size(tau) else 0.0
    v = DEADZONE_TAU0_FRACTION * rms
    if not v > 0:
        return 1.0
    return float(f"{v:.2g}")


# ---------------------------------------------------------------------------
# reading a model file


def _six_value(table: dict, base_dir: Path, where: str) -> np.ndarray:
    """The known 6x6 compliance of a link/base/tool effect: ``value`` as 6
    rows of 6 numbers or the name of a ``stiffkit link`` JSON result, in the
    spring frame's axes, or in axes turned by ``rpy`` from them. Symmetric
    (a written matrix to 1 %, a link JSON to its FEA noise; symmetrised) and
    positive semi-definite."""
    v = table["value"]
    if isinstance(v, str):
        f = (base_dir / v) if not Path(v).is_absolute() else Path(v)
        C = read_link_compliance(f, where)
    else:
        if not isinstance(v, list):
            raise InputError(f"{where}: value must be 6 rows of 6 numbers or a JSON file name, got {v!r}")
        C = check_spring_matrix(v, f"{where}: value", error=1e-2)
    if "rpy" in table:
        rpy = V.array(table["rpy"], f"{where}: rpy", (3,), "angle")
        C = rotate6(rpy_matrix(rpy), C)
    return C


def _default_axis(chain: Chain, link: str) -> int:
    """Beam axis: the spring-frame axis closest to the segment from the
    link's proximal joint origin to its distal one."""
    stype, k = chain.link_spring(link)
    if stype == SPRING_FRAME:
        seg = chain.jrot[k - 1].T @ chain.jpos[k - 1]
    else:
        seg = chain.trot.T @ chain.tpos
    if np.linalg.norm(seg) == 0:
        return 0
    return int(np.argmax(np.abs(seg)))


def _number(table: dict, key: str, where: str, q: str | None = None, **limits: object) -> float:
    if key not in table:
        raise InputError(f"{where}: missing {key!r}")
    return V.number(table[key], f"{where}: {key}", q, **limits)


_suggest = V.suggest


#: keys an [[effect]] table may carry, per kind (a typo is an error, not a silent default)
KEYS = catalogue.keys(catalogue.DEFLECTION)


def expand_effect(
    chain: Chain, table: dict, i: int, path: Path | str = "model", base_dir: Path = Path(".")
) -> list[Term]:
    """Terms of one [[effect]] table (raises InputError naming the table)."""
    if not isinstance(table, dict):
        raise InputError(f"{path}: [[effect]] #{i + 1} must be a table (kind = ..., target = ...), got {table!r:.60}")
    where = effect_where(path, i, table)
    kind = effect_kind(table, where, catalogue.DEFLECTION)
    target = table.get("target", "all" if kind == "joint" else "")
    if not isinstance(target, str):
        raise InputError(f"{where}: target = {target!r} must be a name (a string)")
    terms = []
    if kind in JOINT_KINDS:
        if kind == "joint" and target == "all":
            joints = chain.actuated
            if "value" in table and (isinstance(table["value"], bool) or not isinstance(table["value"], (int, float))):
                raise InputError(f"{where}: with target = 'all' the value must be one number")
        else:
            if not target:
                raise InputError(f"{where}: missing target (a joint name)")
            k = chain.joint_index(target) if target in chain.joint_names else None
            if k is None:
                raise InputError(f"{where}: unknown joint {target!r}; actuated joints: {', '.join(chain.actuated)}")
            if chain.qidx[k] == 0:
                raise InputError(f"{where}: joint {target!r} is fixed; {kind} needs an actuated joint")
            joints = [target]
        for jn in joints:
            k = chain.joint_index(jn)
            t = Term(
                kind=kind,
                target=jn,
                effect=i,
                names=[],
                spring=(SPRING_JOINT, k + 1),
                joint=k,
                qcol=int(chain.qidx[k]) - 1,
                source=kind,
            )
            # the parameters and known values of every per-joint kind from its catalogue entry
            t.names = [f"{jn}.{n}" for n in catalogue.KIND[kind].names]
            t.value = effect_values(table, kind, where)
            if kind == "joint_deadzone":
                tau0 = effect_w0(table, kind, where)
                if tau0 is not None:
                    t.geometry = {"tau0": tau0}
                elif t.value is not None:
                    raise InputError(f"{where}: a joint_deadzone with a value needs its tau0 (N m) too")
            elif kind == "gravity_compensator":
                t.geometry = compensator_geometry(table, where)
            terms.append(t)
    elif kind in ("link", "base", "tool"):
        if kind == "link":
            if not target:
                raise InputError(f"{where}: missing target (a link name)")
            if target not in chain.links:
                raise InputError(f"{where}: unknown link {target!r}; links of the chain: {', '.join(chain.links)}")
            spring = chain.link_spring(target)
            name = target
        elif kind == "base":
            spring, name = (SPRING_BASE, 0), "base"
        else:
            spring, name = (SPRING_TOOL, 0), "tool"
        template = table.get("template", "full")
        if not isinstance(template, str) or template not in TEMPLATES:
            raise InputError(
                f"{where}: unknown template {template!r}{_suggest(template, TEMPLATES)}; "
                f"choose one of {', '.join(TEMPLATES)}"
            )
        if "axis" in table:
            if table["axis"] not in ("x", "y", "z"):
                raise InputError(f"{where}: axis must be 'x', 'y' or 'z'")
            axis = AXES.index(table["axis"])
        else:
            axis = _default_axis(chain, target) if kind == "link" else 2
        t = Term(kind="six", target=name, effect=i, names=[], spring=spring, template=template, axis=axis, source=kind)
        if "value" in table:
            C = _six_value(table, base_dir, where)
            t.elements = list(range(21))
            t.value = np.array([C[a, b] for a, b in SYM])
        else:
            t.elements = template_elements(template, axis)
        t.names = [f"{name}.c{SYM[e][0] + 1}{SYM[e][1] + 1}" for e in t.elements]
        terms.append(t)
    else:  # point_offset
        t = Term(
            kind="point_offset",
            target="tool",
            effect=i,
            spring=None,
            names=["point_offset.rx", "point_offset.ry", "point_offset.rz"],
            source=kind,
        )
        t.value = effect_values(table, kind, where)
        terms.append(t)
    return terms


def check_terms(terms: list[Term], where: str) -> None:
    seen: dict = {}
    for t in terms:
        key = (t.kind, t.spring if t.kind == "six" else t.target)
        if t.kind == "point_offset":
            continue
        if key in seen:
            u = seen[key]
            same = (
                f"the same spring as #{u.effect + 1} ({u.source} {u.target!r})"
                if t.kind == "six"
                else (f"duplicates #{u.effect + 1}")
            )
            raise InputError(
                f"{where}: [[effect]] #{t.effect + 1} ({t.source or t.kind} on {t.target!r}) is {same}: "
                "one effect per spring (its parameters would be counted twice)"
            )
        seen[key] = t
    needs = [t for t in terms if t.kind in NEEDS_JOINT]
    for t in needs:
        if not any(u.kind == "joint" and u.joint == t.joint for u in terms):
            raise InputError(
                f"{where}: {t.kind} on {t.target!r} needs a 'joint' effect on the same joint (its compliance c_j)"
            )
    if sum(t.kind == "point_offset" for t in terms) > 1:
        raise InputError(f"{where}: more than one point_offset effect")


def load_model(path: Path | str) -> Model:
    """Read a model TOML (docs/calibration.md §2, §5) and its URDF.

    Returns a :class:`Model`; ``model.tool_compliance(Q)`` evaluates a model
    whose effects all carry values.
    """
    if not isinstance(path, (str, Path)):
        raise InputError(f"load_model takes the path of a model TOML, got {type(path).__name__}")
    path = Path(path)
    doc = read_toml(path, "model")
    _known(doc, TOP_KEYS, f"{path}: unknown section(s)")
    robot = doc.get("robot")
    if not isinstance(robot, dict) or "urdf" not in robot:
        raise InputError(f'{path}: missing [robot] table with urdf = "robot.urdf"')
    _known(robot, ROBOT_KEYS, f"{path}: [robot] unknown key(s)")
    for key in ROBOT_KEYS:
        if key in robot and (not isinstance(robot[key], str) or not robot[key].strip()):
            raise InputError(f"{path}: [robot] {key} = {robot[key]!r} must be a name (a non-empty string)")
    base_dir = path.parent
    urdf = Path(robot["urdf"])
    urdf = urdf if urdf.is_absolute() else base_dir / urdf
    chain = load_chain(urdf, robot.get("base_link", "base_link"), robot.get("tool_frame", "tool0"))
    meas = doc.get("measurements", {})
    if not isinstance(meas, dict):
        raise InputError(f"{path}: [measurements] must be a table")
    _known(meas, MEAS_KEYS, f"{path}: [measurements] unknown key(s)")
    if meas.get("kind", "deflection") != "deflection":
        raise InputError(
            f"{path}: [measurements] kind = {meas['kind']!r}: this model reader takes deflections under known "
            'loads (kind = "deflection", docs/calibration.md sections 2-5)'
        )
    sig_p = meas.get("sigma_position")
    sig_r = meas.get("sigma_rotation")
    if sig_p is not None:
        sig_p = V.number(sig_p, f"{path}: [measurements] sigma_position", "sigma_position", lo=0.0, lo_open=True)
    if sig_r is not None:
        sig_r = V.number(sig_r, f"{path}: [measurements] sigma_rotation", "sigma_rotation", lo=0.0, lo_open=True)
    effects = doc.get("effect", [])
    if not isinstance(effects, list):
        raise InputError(f"{path}: 'effect' must be an array of tables [[effect]]")
    terms = []
    for i, table in enumerate(effects):
        terms += expand_effect(chain, table, i, path, base_dir)
    check_terms(terms, str(path))
    return Model(
        chain=chain,
        effects=effects,
        terms=terms,
        path=path,
        sigma_position=None if sig_p is None else float(sig_p),
        sigma_rotation=None if sig_r is None else float(sig_r),
        robot_table=robot,
        plan=plan_table(doc, path),
    )


#: the sections and keys a deflection model file may carry (a typo is an error, not a silent default)
TOP_KEYS = ("robot", "measurements", "effect", "plan")
ROBOT_KEYS = ("urdf", "base_link", "tool_frame")
MEAS_KEYS = ("sigma_position", "sigma_rotation", "kind")


_known = V.known_keys


def model_from_tables(
    chain: Chain,
    effects: list[dict],
    sigma_position: float | None = None,
    sigma_rotation: float | None = None,
    where: str = "model",
) -> Model:
    """A Model from a chain and effect tables (Python API, synth, diagnosis)."""
    terms = []
    for i, table in enumerate(effects):
        terms += expand_effect(chain, table, i, where)
    check_terms(terms, where)
    return Model(
        chain=chain, effects=list(effects), terms=terms, sigma_position=sigma_position, sigma_rotation=sigma_rotation
    )
