"""The inputs of an experiment design (``stiffkit plan``): the candidates
(sampled within the limits or the user's own list, read by
:func:`read_postures`), the model's whitened Jacobian of the identifiable
parameters at each candidate and at the task postures, after the fit's own
reduction, for tracker data (:func:`_abs_setup`) and deflection data
(:func:`_defl_setup`), assembled by :func:`build_setup` into a
:class:`PlanSetup`. calib/plan.py chooses from it (module docstring there).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError, StiffkitWarning
from ..io import validate as V
from ..io.tables import read_table
from ..robot.model import Model, load_model
from ..robot.plan_candidates import Candidates, feasible, plan_settings, sample_postures
from ..robot.tree_model import TreeModel, load_tree_model, model_kind
from .absolute_data import AbsoluteData
from .absolute_fit import predict, reduce_parameters, set_deadzone_scales
from .measure import DEFL, POINT, ROT, WRENCH, Measurements, read_measurements
from .problem import Problem
from .reduce import reduce_model

#: candidates sampled when neither --candidates nor --from is given
DEFAULT_CANDIDATES = 2000
#: random feasible designs the plan is compared with (their median)
RANDOM_DESIGNS = 20
#: sigma of a tracker coordinate assumed when the model declares none (m)
ASSUMED_SIGMA = 1.0e-4
#: postures of a --from list left out that the warning names
FAILED_SHOWN = 3
#: columns of a posture file that are not joints
OTHER_COLUMNS = ("config", "frame", "weight", "x", "y", "z", *WRENCH, *POINT, *DEFL, *ROT)


@dataclass
class PlanSetup:
    """The design problem: ``jc`` (ncand, nobs, npar) whitened rows of the
    identifiable parameters ``names``; candidate c is posture ``posture[c]``
    of ``candidates.q`` with load ``loads[c]`` (deflection data); ``jt``
    (nt, npar) task rows (m per unit parameter), row r at task posture
    ``task_of[r]`` of ``task_q``; ``m0`` the information of what was already
    measured (or None); ``not_planned`` (name, why) of the parameters left out."""

    kind: str
    model: object
    names: list[str]
    jc: np.ndarray
    posture: np.ndarray
    loads: np.ndarray | None
    candidates: Candidates
    jt: np.ndarray
    task_q: np.ndarray
    task_of: np.ndarray
    task_source: str
    m0: np.ndarray | None
    measured_rows: int
    sigma: float
    sigma_source: str
    not_planned: list[tuple[str, str]] = field(default_factory=list)
    points: np.ndarray | None = None
    #: the model's free parameters (deflection data: ``stiffkit fit`` needs at least as many observations)
    free_parameters: int = 0
    #: observations of the rows already measured (deflection data: positions, and rotations when measured)
    measured_observations: int = 0
    #: deflection data: where ``points`` come from
    points_source: str = ""

    @property
    def has_task(self) -> bool:
        return not self.task_source.startswith("the candidates")

    @property
    def nobs(self) -> int:
        return int(self.jc.shape[1])

    @property
    def npar(self) -> int:
        return int(self.jc.shape[2])

    @property
    def joint_names(self) -> list[str]:
        return self.candidates.joint_names


# ---------------------------------------------------------------------------- files


def read_postures(
    path: str | Path, joints: list[str], what: str, mimics: dict | None = None, allowed: tuple = OTHER_COLUMNS
) -> tuple[np.ndarray, object]:
    """Joint values (n, nq) of a posture CSV, columns named as ``joints``
    (or q1..qN); other columns must be among ``allowed`` (a column named
    neither is an unknown joint: InputError naming the file and the column).
    Returns (Q, table)."""
    path = Path(path)
    t = read_table(path, what)
    head = t.header
    mimics = mimics or {}
    qnames = [f"q{k + 1}" for k in range(len(joints))]
    for h in head:
        if h in mimics:
            raise InputError(
                f"{path}, line 1: column {h!r} is a mimic joint (it follows {mimics[h]!r}); give only the actuated "
                f"joints ({', '.join(joints)})"
            )
        if h not in joints and h not in qnames and h not in allowed:
            raise InputError(
                f"{path}, line 1, column {h!r}: not a joint of the robot (actuated joints: {', '.join(joints)}; "
                f"other columns read: {', '.join(allowed)})"
            )
    if all(j in head for j in joints):
        cols = list(joints)
    elif all(q in head for q in qnames) and not any(j in head for j in joints):
        cols = qnames
    else:
        missing = [j for j in joints if j not in head]
        raise InputError(
            f"{path}, line 1: missing joint column(s) {', '.join(missing)} (a column per actuated joint, or "
            f"q1..q{len(joints)}; header has: {', '.join(head)})"
        )
    if not len(t):
        raise InputError(f"{path}: no rows")
    return t.numbers(cols, "angle"), t


def user_candidates(model: object, postures: object, settings: object) -> Candidates:
    """``--from``: the user's postures (a CSV path, rows of one posture
    counted once, or an array (m, nq)) through the candidate checks. The
    postures left out are named in one warning (the file's row and line, and
    why); none feasible: InputError naming the first and why."""
    joints = model.actuated if isinstance(model, TreeModel) else model.chain.actuated
    where, lines = "postures", None
    if isinstance(postures, (str, Path)):
        where = str(postures)
        Q, tab = read_postures(postures, joints, "postures", _mimics(model))
        keep = _distinct(Q)
        Q, lines = Q[keep], np.asarray(tab.lines)[keep]
    else:
        Q = np.atleast_2d(np.asarray(postures, float))
    cands = feasible(model, Q, settings, where)

    def at(i: int) -> str:
        return f"row {i + 1}" if lines is None else f"row {lines[i] - 1} (line {lines[i]})"

    failed = sorted(cands.failed.items())
    if not len(cands):
        why = f": {at(failed[0][0])}: {failed[0][1]}" if failed else ""
        raise InputError(f"{where}: no feasible candidate among {Q.shape[0]} postures{why}")
    if failed:
        shown = "; ".join(f"{at(i)}: {w}" for i, w in failed[:FAILED_SHOWN])
        more = f"; ... and {len(failed) - FAILED_SHOWN} more" if len(failed) > FAILED_SHOWN else ""
        warnings.warn(
            StiffkitWarning(f"{where}: {len(failed)} of {Q.shape[0]} postures left out (not feasible): {shown}{more}"),
            stacklevel=3,
        )
    return cands


def sampled_candidates(model: object, candidates: int | None, seed: int, settings: object) -> Candidates:
    """``--candidates N`` (default DEFAULT_CANDIDATES) feasible postures
    sampled with ``seed``; a warning when the tries ran out before N were
    found (the rejections by reason: what to loosen)."""
    n = DEFAULT_CANDIDATES if candidates is None else V.count(candidates, "candidates", 1, 10**6)
    cands = sample_postures(model, n, seed, settings)
    if len(cands) < n:
        warnings.warn(
            StiffkitWarning(
                f"--candidates {n}: only {cands.summary()}: the plan chooses among these; loosen [plan] for more"
            ),
            stacklevel=3,
        )
    return cands


def _more(cands: Candidates) -> str:
    """What gives more candidates: more postures in the user's list, or more sampled."""
    if cands.rows is not None:
        return "add postures to the --from list or loosen [plan]"
    return "sample more (--candidates) or loosen [plan]"


def _distinct(Q: np.ndarray) -> np.ndarray:
    """Indices of the first row of each distinct posture (rows of one posture repeat per marker or load)."""
    _u, first = np.unique(np.round(Q, 12), axis=0, return_index=True)
    return np.sort(first)


def _by_posture(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the distinct postures of Q's rows in the order they first appear,
    the index among them of each row): rows of one posture (one per marker
    or per load) are one task posture."""
    _u, first, inv = np.unique(np.round(Q, 12), axis=0, return_index=True, return_inverse=True)
    rank = np.argsort(np.argsort(first))
    return Q[np.sort(first)], rank[np.ravel(inv)]


def _mimics(model: object) -> dict:
    tree = getattr(model, "tree", None)
    return {} if tree is None else {j.name: tree.leader(j.name)[0] for j in tree.joints if j.mimic is not None}


def load_plan_model(path: str | Path) -> TreeModel | Model:
    """The model of a model file, by its [measurements] kind."""
    return load_tree_model(path) if model_kind(path) == "absolute" else load_model(path)


# ---------------------------------------------------------------------------- absolute data


def _abs_data(model: TreeModel, Q: np.ndarray, frames: np.ndarray | None = None, path: str = "plan") -> AbsoluteData:
    """Rows at the postures Q: every marker of each posture, or ``frames`` (one per posture row)."""
    n, nf = Q.shape[0], len(model.frames)
    if frames is None:
        posture, frame = np.repeat(np.arange(n), nf), np.tile(np.arange(nf), n)
    else:
        posture, frame = np.arange(n), np.asarray(frames, int)
    return AbsoluteData(
        path=path,
        joints=list(model.actuated),
        configs=[f"c{k + 1}" for k in range(n)],
        Q=np.asarray(Q, float),
        posture=posture,
        frame=frame,
        frames=list(model.frames),
        xyz=np.zeros((posture.size, 3)),
        weight=np.ones(posture.size),
        lines=np.arange(posture.size) + 2,
    )


def _abs_jac(model: TreeModel, data: AbsoluteData, theta: np.ndarray, free: np.ndarray) -> np.ndarray:
    return np.asarray(predict(model, data, theta, free)["jac"], float)


def _abs_setup(model: TreeModel, cands: Candidates, task: object, measured: object, sigma: float) -> dict:
    from .absolute_data import read_absolute

    model = model.copy()
    theta = model.theta0
    free = model.free
    if free.size == 0:
        raise InputError(f"{model.path or 'model'}: every parameter is fixed; nothing to plan for")
    data = _abs_data(model, cands.q)
    set_deadzone_scales(model, data, theta)
    J = _abs_jac(model, data, theta, free) / sigma
    Jm, nmeas = np.zeros((0, free.size)), 0
    if measured is not None:
        tree = model.tree
        needed = {tree.leader(j.name)[0] for f in model.frames for j in tree.path(f) if j.moving}
        mdata = read_absolute(measured, model.actuated, model.frames, _mimics(model), needed)
        w = np.repeat(mdata.weight, 3)
        Jm = _abs_jac(model, mdata, theta, free) * np.sqrt(w)[:, None] / sigma
        nmeas = int(np.sum(mdata.weight > 0))
    red = reduce_parameters(model, np.vstack([Jm, J]), free)
    cols = np.searchsorted(free, red.kept)
    names = [model.names[i] for i in red.kept]
    nobs = 3 * len(model.frames)
    jc = J[:, cols].reshape(len(cands), nobs, cols.size)
    m0 = None
    if measured is not None:
        m0 = Jm[:, cols].T @ Jm[:, cols]
    prior = [(k, model.priors[n]) for k, n in enumerate(names) if n in model.priors]
    if prior:  # the fit's weak priors of the gravity parameters toward the URDF
        m0 = np.zeros((cols.size, cols.size)) if m0 is None else m0
        for k, s in prior:
            m0[k, k] += 1.0 / s**2
    if task is None:
        tq, tdata, source = cands.q, data, "the candidates (no --task: the sampled workspace)"
    else:
        tq, ttab = read_postures(task, model.actuated, "task", _mimics(model), ("config", "frame"))
        frames = None
        if ttab.has("frame"):
            frames = []
            for name, line in zip(ttab.text("frame"), ttab.lines):
                if name not in model.frames:
                    raise InputError(
                        f"{task}, line {line}, field 'frame': {name!r} has no marker in the model "
                        f"(markers: {', '.join(model.frames)})"
                    )
                frames.append(model.frames.index(name))
        tdata, source = _abs_data(model, tq, frames, str(task)), str(task)
    jt = _abs_jac(model, tdata, theta, red.kept)
    tracker = [k for k, i in enumerate(red.kept) if model.params[i].kind == "tracker"]
    jt[:, tracker] = 0.0  # the tracker's pose does not move the robot
    not_planned = red.dropped + red.merged
    tq, of = _by_posture(tq)
    return dict(
        names=names, jc=jc, posture=np.arange(len(cands)), loads=None, jt=jt, task_q=tq,
        task_of=np.repeat(of[tdata.posture], 3), task_source=source, m0=m0, measured_rows=nmeas,
        not_planned=not_planned,
    )  # fmt: skip


# ---------------------------------------------------------------------------- deflection data


def _defl_meas(Q: np.ndarray, W: np.ndarray, points: np.ndarray, path: str) -> Measurements:
    """Rows: each (posture, load) pair at every point (pairs major)."""
    npt = points.shape[0]
    n = Q.shape[0] * npt
    return Measurements(
        q=np.repeat(Q, npt, axis=0),
        w=np.repeat(W, npt, axis=0),
        p=np.tile(points, (Q.shape[0], 1)),
        d=np.zeros((n, 3)),
        r=None,
        config=[f"c{k // npt + 1}" for k in range(n)],
        lines=list(range(2, n + 2)),
        path=path,
    )


def _defl_rows(model: Model, meas: Measurements, names: list[str], sigma: float) -> np.ndarray:
    """(n, 3, npar) whitened position rows of the parameters ``names``."""
    pb = Problem(model, meas, sigma_position=sigma)
    _pred, J = pb.evaluate(np.zeros(pb.npar))
    cols = [pb.names.index(n) for n in names]
    return J[:3][:, :, cols].transpose(1, 0, 2) / sigma


def _points(points: object, cands: Candidates, mmeas: Measurements | None, measured: object) -> tuple[np.ndarray, str]:
    """The points measured on the tool in each candidate (tool frame, m) and
    where they come from: ``points`` (the API), else [plan] points, else the
    distinct points of the rows already measured, else the tool origin."""
    if points is not None:
        return V.array(points, "points", (None, 3), "position"), "given"
    s = cands.settings
    if s is not None and s.points is not None:
        return np.array(s.points, float), f"{s.where} points"
    if mmeas is not None:
        _u, first = np.unique(mmeas.p, axis=0, return_index=True)
        return mmeas.p[np.sort(first)], f"the points of {measured}"
    return np.zeros((1, 3)), "the tool origin (no [plan] points)"


def _defl_setup(model: Model, cands: Candidates, task: object, measured: object, sigma: float, points: object) -> dict:
    nonlinear = [t.kind for t in model.terms if t.free and t.nonlinear]
    if nonlinear:
        raise InputError(
            f"{model.path or 'model'}: a free {nonlinear[0]} is nonlinear: its rows depend on values the plan does "
            "not have; fix its value (or remove it) to plan for the linear parameters"
        )
    if cands.loads is None:
        raise InputError(
            f"{model.path or 'model'}: [plan] loads missing: deflection data need the loads you can apply, "
            "e.g. [plan] loads = [[0, 0, -2500, 0, 0, 0], [2500, 0, 0, 0, 0, 0]] (N, N m, at the tool frame)"
        )
    mmeas = read_measurements(measured, model.chain.dof) if measured is not None else None
    pts, psource = _points(points, cands, mmeas, measured)
    nl, npt = cands.loads.shape[0], pts.shape[0]
    posture = np.repeat(np.arange(len(cands)), nl)
    loads = np.tile(cands.loads, (len(cands), 1))
    cmeas = _defl_meas(cands.q[posture], loads, pts, "plan candidates")
    both = cmeas
    if mmeas is not None:
        both = _defl_meas(np.vstack([mmeas.q, cmeas.q]), np.vstack([mmeas.w, cmeas.w]), np.zeros((1, 3)), "plan")
        both.p = np.vstack([mmeas.p, cmeas.p])
    nfree, nrows = len(model.parameter_names), 3 * both.n
    if nrows < nfree:  # the fit's reduction is a fit of every free parameter to all the rows
        src = "the --from postures" if cands.rows is not None else "the sampled postures"
        had = f" and {mmeas.n} measured rows" if mmeas is not None else ""
        raise InputError(
            f"{model.path or 'model'}: {len(cands)} candidate postures x {nl} [plan] loads x {npt} point(s){had} "
            f"give {nrows} observations for the model's {nfree} free parameters: too few to tell which are "
            f"identifiable; give more postures ({src}) or loads"
        )
    red = reduce_model(model, both, sigma_position=sigma)
    names = list(red.selected)
    if not names:
        raise InputError(f"{model.path or 'model'}: no parameter is identifiable from these candidates")
    jc = _defl_rows(model, cmeas, names, sigma).reshape(posture.size, 3 * npt, len(names))
    m0, nmeas, mobs = None, 0, 0
    if mmeas is not None:
        pb = Problem(model, mmeas, sigma_position=sigma)
        _p, J = pb.evaluate(np.zeros(pb.npar))
        A = pb.weighted(J[:, :, [pb.names.index(n) for n in names]])
        m0, nmeas, mobs = A.T @ A, mmeas.n, pb.rows * mmeas.n
    if task is None:
        tq, tw, source = cands.q[posture], loads, "the candidates (no --task: the sampled workspace)"
        t_of = posture
    else:
        q, ttab = read_postures(task, model.chain.actuated, "task", None, ("config", *WRENCH))
        if ttab.has("fx") or any(ttab.has(c) for c in WRENCH):
            ttab.require(WRENCH, " (a task load: all of fx fy fz mx my mz, or none: every [plan] load)")
            tq, tw = q, np.hstack([ttab.numbers(WRENCH[:3], "force"), ttab.numbers(WRENCH[3:], "moment")])
            t_of = np.arange(q.shape[0])
        else:
            t_of = np.repeat(np.arange(q.shape[0]), nl)
            tq, tw = q[t_of], np.tile(cands.loads, (q.shape[0], 1))
        source = str(task)
    tmeas = _defl_meas(tq, tw, np.zeros((1, 3)), "task")
    jt = (_defl_rows(model, tmeas, names, sigma) * sigma).reshape(-1, len(names))
    task_q = cands.q
    if task is not None:  # rows of one task posture (under several loads) count as one posture
        task_q, of = _by_posture(q)
        t_of = of[t_of]
    not_planned = [(n, "no influence on the data (G2)") for n in red.g2]
    not_planned += [(n, "merged into its link spring (M3)") for n in red.aggregated]
    not_planned += [(n, "coupled with the selected parameters (M5c: fixed)") for n in red.fixed]
    return dict(
        names=names, jc=jc, posture=posture, loads=loads, jt=jt, task_q=task_q, task_of=np.repeat(t_of, 3),
        task_source=source, m0=m0, measured_rows=nmeas, not_planned=not_planned, points=pts,
        free_parameters=len(model.parameter_names), measured_observations=mobs, points_source=psource,
    )  # fmt: skip


# ---------------------------------------------------------------------------- the plan


def build_setup(
    model: TreeModel | Model | str | Path,
    candidates: int | None = None,
    postures: object = None,
    task: object = None,
    measured: object = None,
    seed: int = 0,
    sigma_position: float | None = None,
    points: object = None,
) -> PlanSetup:
    """The design problem of ``model`` (module docstring): ``candidates``
    postures sampled with ``seed``, or ``postures`` (a CSV path or an array
    (m, nq)) checked by the same rules; ``task`` a TASK.csv; ``measured`` a
    measurement CSV of rows already measured; ``points`` (deflection data)
    the point offsets measured in each posture (tool frame, m; default the
    tool origin)."""
    if isinstance(model, (str, Path)):
        model = load_plan_model(model)
    settings = plan_settings(model)
    absolute = isinstance(model, TreeModel)
    if postures is not None:
        cands = user_candidates(model, postures, settings)
    else:
        cands = sampled_candidates(model, candidates, seed, settings)
    if sigma_position is not None:
        sigma, source = V.number(sigma_position, "sigma_position", "sigma_position", lo=0.0, lo_open=True), "given"
    elif model.sigma_position:
        sigma, source = float(model.sigma_position), "the model's [measurements] sigma_position"
    else:
        sigma, source = ASSUMED_SIGMA, "assumed: the model declares no sigma_position; the errors scale with it"
    if absolute:
        parts = _abs_setup(model, cands, task, measured, sigma)
    else:
        parts = _defl_setup(model, cands, task, measured, sigma, points)
    return PlanSetup(
        kind="absolute" if absolute else "deflection",
        model=model,
        candidates=cands,
        sigma=sigma,
        sigma_source=source,
        **parts,
    )
