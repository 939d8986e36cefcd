"""Optimal experiment design: which postures to measure (``stiffkit plan``,
docs/plan.md).

For every candidate (a feasible posture for tracker data; a posture and a
load of the ``[plan]`` table for deflection data) the whitened Jacobian of
the identifiable parameters at the model's current values is computed by
the fit's own evaluators (calib.absolute_fit.predict, calib.problem.Problem)
after the fit's own reduction (absolute_fit.reduce_parameters, calib.reduce),
so that what the fit would not identify is not planned for. The core
(stiffkit._core.design) chooses K candidates by greedy selection and
exchange; plan_setup.py builds its inputs, this module compares the plan with random
feasible designs of the same size (plan_report.py writes what it found).

The task rows: the position of every marker (tracker data; the tracker's
own parameters do not move the robot, their columns are zero) or the
deflection of the tool point under the task load (deflection data) at the
task postures; without a task file, at the candidates themselves (the
sampled workspace).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import design
from ..errors import InputError
from ..io import validate as V
from ..robot.model import Model
from ..robot.plan_candidates import Candidates, plan_settings
from ..robot.tree_model import TreeModel, model_kind
from .measure import read_measurements
from .plan_setup import (  # noqa: F401 - re-exported: the names calib.plan always had
    ASSUMED_SIGMA,
    DEFAULT_CANDIDATES,
    FAILED_SHOWN,
    OTHER_COLUMNS,
    RANDOM_DESIGNS,
    PlanSetup,
    _abs_data,
    _abs_jac,
    _abs_setup,
    _by_posture,
    _defl_meas,
    _defl_rows,
    _defl_setup,
    _distinct,
    _mimics,
    _more,
    _points,
    build_setup,
    load_plan_model,
    read_postures,
    sampled_candidates,
    user_candidates,
)

__all__ = [
    "PlanSetup",
    "PlanResult",
    "plan",
    "choose",
    "build_setup",
    "read_postures",
    "DEFAULT_CANDIDATES",
    "RANDOM_DESIGNS",
]


@dataclass
class PlanResult:
    """What :func:`plan` found (the report's numbers; plan_report.py shows them)."""

    setup: PlanSetup
    k: int
    criterion: str
    selected: np.ndarray  # (k,) 0-based candidates
    value: float
    greedy_value: float
    passes: int
    swaps: int
    random_values: np.ndarray  # (RANDOM_DESIGNS,) the criterion of each random design (+inf: singular)
    task_trace: float
    random_task_traces: np.ndarray
    std: np.ndarray  # (npar,) expected standard deviation of each parameter
    vif: np.ndarray  # (npar,) variance inflation
    corr: np.ndarray  # (npar, npar)
    task_posture_rms: np.ndarray  # (ntp,) expected error per task posture, the plan (m)
    random_posture_rms: np.ndarray  # (ntp,) the same, median over the random designs (m)
    seed: int = 0
    notes: list[str] = field(default_factory=list)
    discrimination: dict | None = None
    #: where the exchange that gave the plan started: "greedy", or "the D plan" (criteria task and A)
    start: str = "greedy"
    #: --measured: the task trace of the rows already measured alone (+inf: they do not identify every parameter)
    measured_task_trace: float | None = None
    #: the design core's numbers of why parameters stay weak (design.weakness: information, task influence, null space)
    weakness: design.Weakness | None = None

    @property
    def task_rms(self) -> float:
        """Expected RMS position error over the task points (m): sqrt(trace / points)."""
        return _rms(self.task_trace, self.setup)

    @property
    def random_task_rms(self) -> float:
        return _rms(float(np.median(self.random_task_traces)), self.setup)

    @property
    def measured_task_rms(self) -> float | None:
        """--measured: the expected task error of the rows already measured alone (m; inf: not identified)."""
        return None if self.measured_task_trace is None else _rms(self.measured_task_trace, self.setup)

    @property
    def ratio(self) -> float:
        """Expected task error of the plan over the median of the random designs."""
        r = self.random_task_rms
        return self.task_rms / r if math.isfinite(r) and r > 0 else 0.0

    @property
    def weak(self) -> list[dict]:
        """The weak parameters and why: not identifiable, correlated (with
        whom) or weakly excited, with the numbers (calib.plan_weak)."""
        from .plan_weak import weak_parameters

        return weak_parameters(self)

    def table(self) -> object:
        """The chosen measurements, the table of POSTURES.csv (``--out``):
        a pandas DataFrame when pandas is installed, else a list of dicts;
        joint values, loads and points as numbers, the columns still to be
        measured (x y z, or dx dy dz) NaN."""
        from .plan_report import postures_table

        return postures_table(self)

    def to_json(self) -> dict:
        """The report as ``--json`` writes it (docs/plan.md section 4)."""
        from .plan_report import plan_json

        return plan_json(self)

    def text(self) -> str:
        """The report as the command prints it."""
        from .plan_report import plan_text

        return plan_text(self)

    def write(self, path: str | Path) -> Path:
        """Write POSTURES.csv (``--out``) to ``path``."""
        from .plan_report import write_postures

        return write_postures(path, self)


def _rms(trace: float, setup: PlanSetup) -> float:
    return math.sqrt(trace / (setup.jt.shape[0] / 3)) if math.isfinite(trace) else math.inf


def _check_k(setup: PlanSetup, k: int) -> int:
    k = V.count(k, "--select", 1)
    ncand = setup.jc.shape[0]
    what = "(posture, load) candidates" if setup.kind == "deflection" else "feasible candidates"
    if k > ncand:
        c = setup.candidates
        raise InputError(f"--select {k}: only {ncand} {what} ({c.summary()}); {_more(c)}")
    known = 0 if setup.m0 is None else int(np.linalg.matrix_rank(setup.m0))
    need = max(0, setup.npar - known)
    if setup.nobs * k < need:
        kmin = math.ceil(need / setup.nobs)
        extra = f" (besides the {known} directions already measured)" if known else ""
        raise InputError(
            f"--select {k}: {k} x {setup.nobs} observations per candidate = {k * setup.nobs} < {need} identifiable "
            f"parameters{extra}: the minimum is --select {kmin}"
        )
    return k


def _posture_rms(setup: PlanSetup, cov: np.ndarray | None) -> np.ndarray:
    ntp = setup.task_q.shape[0]
    if cov is None:
        return np.full(ntp, math.inf)
    var = np.einsum("ij,jk,ik->i", setup.jt, cov, setup.jt)
    tot = np.bincount(setup.task_of, var, ntp)
    pts = np.bincount(setup.task_of, None, ntp) / 3
    return np.sqrt(np.divide(tot, pts, out=np.zeros(ntp), where=pts > 0))


def _cov(setup: PlanSetup, chosen: np.ndarray) -> tuple[np.ndarray | None, design.DesignError | None]:
    """The core's covariance of ``chosen``, or None and the core's error
    (naming the first non-identifiable column) when it is singular."""
    try:
        return design.covariance(setup.jc, chosen, m0=setup.m0), None
    except design.DesignError as exc:
        return None, exc


def choose(
    jc: np.ndarray, k: int, crit: str, m0: np.ndarray | None = None, jt: np.ndarray | None = None
) -> tuple[design.DesignResult, float, str]:
    """The core's selection (greedy then exchange) of ``k`` candidates for
    ``crit``; for task and A also the exchange started from the D plan, the
    better of the two kept (the exchange is a local search: on the brute-force
    problems of tests/test_design_core.py the second start finds the optimum
    in 19 of 20 seeds instead of 17). Returns (the result, the greedy
    selection's value, "greedy" or "the D plan": where the kept exchange started)."""
    res = design.select(jc, k, crit, m0=m0, jt=jt)
    if crit == "D":
        return res, res.greedy_value, "greedy"
    d = design.select(jc, k, "D", m0=m0)
    alt = design.select(jc, k, crit, m0=m0, jt=jt, start=d.selected)
    if alt.value < res.value:
        return alt, res.greedy_value, "the D plan"
    return res, res.greedy_value, "greedy"


def _fit_notes(setup: PlanSetup, k: int) -> list[str]:
    """Deflection data: how ``stiffkit fit`` takes the planned rows. The plan
    is for the parameters the fit's reduction keeps (``fit --reduce``), and
    the fit refuses fewer observations than the model's free parameters."""
    if setup.kind != "deflection":
        return []
    out = []
    if setup.not_planned:
        out.append(
            f"the plan is for the {setup.npar} parameters the fit's reduction keeps: fit the measurements with "
            f"stiffkit fit {getattr(setup.model, 'path', None) or 'MODEL.toml'} MEAS.csv --reduce"
        )
    mobs = setup.measured_observations
    have = mobs + k * setup.nobs
    nfree = setup.free_parameters
    if have < nfree:
        kmin = math.ceil((nfree - mobs) / setup.nobs)
        out.append(
            f"stiffkit fit needs at least as many observations as the model's {nfree} free parameters, and "
            f"{k} x {setup.nobs}"
            + (f" + {mobs} measured" if mobs else "")
            + f" = {have} are fewer: measure at least --select {kmin}, or fix the parameters not planned for "
            "in the model file"
        )
    return out


def plan(
    model: TreeModel | Model | str | Path,
    k: int,
    criterion: str | None = None,
    candidates: int | None = None,
    postures: object = None,
    task: object = None,
    measured: object = None,
    seed: int = 0,
    sigma_position: float | None = None,
    points: object = None,
    setup: PlanSetup | None = None,
) -> PlanResult:
    """Plan ``k`` measurements of ``model`` (a model file or a loaded
    model): the Python face of ``stiffkit plan`` (docs/plan.md).
    ``criterion``: "task" (default with a task file), "D" (default
    without) or "A"; the other arguments as :func:`build_setup` (or a
    ``setup`` already built). Returns a :class:`PlanResult`: ``.table()`` the
    chosen measurements (the rows of POSTURES.csv), ``.write(path)`` that
    file, ``.to_json()`` and ``.text()`` the command's report."""
    crit = criterion or ("task" if (task is not None if setup is None else setup.has_task) else "D")
    if crit not in design.CRITERIA:
        raise InputError(f"--criterion {crit!r}: choose one of {', '.join(design.CRITERIA)}")
    seed = V.count(seed, "seed", 0)
    if setup is None:
        setup = build_setup(model, candidates, postures, task, measured, seed, sigma_position, points)
    k = _check_k(setup, k)
    jt = setup.jt
    res, gvalue, start = choose(setup.jc, k, crit, m0=setup.m0, jt=jt if crit == "task" else None)
    chosen = np.asarray(res.selected, int)
    rng = np.random.default_rng(seed + 1)
    ncand = setup.jc.shape[0]
    draws = [np.sort(rng.choice(ncand, k, replace=False)) for _ in range(RANDOM_DESIGNS)]
    rt = np.array([design.criterion(setup.jc, d, "task", m0=setup.m0, jt=jt) for d in draws])
    rv = rt if crit == "task" else np.array([design.criterion(setup.jc, d, crit, m0=setup.m0) for d in draws])
    trace = float(res.value) if crit == "task" else design.criterion(setup.jc, chosen, "task", m0=setup.m0, jt=jt)
    before = None
    if setup.m0 is not None and setup.measured_rows:
        before = design.criterion(setup.jc, np.zeros(0, int), "task", m0=setup.m0, jt=jt)
    cov, exc = _cov(setup, chosen)
    # the information's diagonal (variance inflation = diag(M^-1) diag(M)), its null space
    weak = design.weakness(setup.jc, chosen, setup.jt, m0=setup.m0)
    info_diag = weak.info
    notes = []
    if cov is None:
        npar = setup.npar
        std = vif = np.full(npar, math.inf)
        corr = np.full((npar, npar), np.nan)
        col = getattr(exc, "column", None)
        which = setup.names[col] if col is not None and 0 <= col < npar else "a parameter"
        notes.append(
            f"the plan leaves {which} non-identifiable (its information matrix is singular): "
            f"plan more than {k} (--select)"
        )
    else:
        std = np.sqrt(np.diag(cov))
        vif = np.diag(cov) * info_diag
        d = np.where(std > 0, std, 1.0)
        corr = cov / np.outer(d, d)
    per = [_posture_rms(setup, _cov(setup, d)[0]) for d in draws]
    notes += _fit_notes(setup, k)
    return PlanResult(
        setup=setup,
        k=k,
        criterion=crit,
        selected=chosen,
        value=float(res.value),
        greedy_value=float(gvalue),
        passes=int(res.passes),
        swaps=int(res.swaps),
        random_values=rv,
        task_trace=trace,
        random_task_traces=rt,
        std=std,
        vif=vif,
        corr=corr,
        task_posture_rms=_posture_rms(setup, cov),
        random_posture_rms=np.median(np.array(per), axis=0),
        seed=seed,
        notes=notes,
        measured_task_trace=before,
        start=start,
        weakness=weak,
    )


def discriminate(
    model: TreeModel | str | Path,
    k: int,
    measured: str | Path,
    tied: list[str] | None = None,
    candidates: int | None = None,
    postures: object = None,
    seed: int = 0,
) -> tuple[dict, Candidates, TreeModel]:
    """``stiffkit plan --discriminate``: the ``k`` feasible postures that best
    tell apart the tied candidate effects ``tied`` (labels kind:target; by
    default the first tie the diagnosis of ``measured`` reports), each fitted
    to the rows measured so far (calib.plan_discriminate). Returns (the
    result of plan_discriminate, the candidates, the model)."""
    from .absolute_report import load_absolute
    from .plan_discriminate import plan_discriminate

    if measured is None:
        raise InputError("--discriminate needs --measured MEAS.csv: the data the tied candidates are fitted to")
    path = model if isinstance(model, (str, Path)) else model.path
    if model_kind(path) != "absolute":
        return _discriminate_deflection(path, k, measured, tied, candidates, postures, seed)
    model, data = load_absolute(path, measured)
    if not tied:
        from .absolute_diagnose import diagnose_absolute

        tied = _first_tie(diagnose_absolute(model.copy(), data), measured)
    settings = plan_settings(model)
    cands = _candidates(model, postures, candidates, seed, settings)
    k = V.count(k, "--select", 1)
    if k > len(cands):
        raise InputError(f"--select {k}: only {len(cands)} feasible candidates ({cands.summary()}); {_more(cands)}")
    return plan_discriminate(model, data, tied, cands, k, settings), cands, model


def _first_tie(dg: object, measured: str | Path) -> dict:
    """The diagnosis's first tie (bare --discriminate), or the error that there is none."""
    if not dg.ties:
        raise InputError(
            f"--discriminate: the diagnosis of {measured} finds no tie to tell apart; name the candidates: "
            "--discriminate kind:target,kind:target"
        )
    return dg.ties[0]


def _candidates(model: object, postures: object, candidates: int | None, seed: int, settings: object) -> Candidates:
    """The user's postures (--from) or sampled feasible ones (--candidates)."""
    if postures is not None:
        return user_candidates(model, postures, settings)
    return sampled_candidates(model, candidates, seed, settings)


def _discriminate_deflection(
    path: str | Path,
    k: int,
    measured: str | Path,
    tied: list[str] | None,
    candidates: int | None,
    postures: object,
    seed: int,
) -> tuple[dict, Candidates, Model]:
    """``discriminate`` on deflection data: the candidates are (posture,
    load) pairs, every candidate posture under every [plan] load, measured
    at the [plan] points (else the measured points; calib.plan_discriminate_defl).
    The result adds ``posture`` (the candidate posture of each pair),
    ``loads`` (each pair's wrench) and ``points``."""
    from .diagnose import diagnose
    from .plan_discriminate_defl import plan_discriminate_deflection

    model = load_plan_model(path)
    meas = read_measurements(measured, model.chain.dof)
    if not tied:
        tied = _first_tie(diagnose(load_plan_model(path), meas), measured)
    settings = plan_settings(model)
    cands = _candidates(model, postures, candidates, seed, settings)
    if cands.loads is None:
        raise InputError(
            f"{model.path or 'model'}: [plan] loads missing: deflection data need the loads you can apply, "
            "e.g. [plan] loads = [[0, 0, -2500, 0, 0, 0], [2500, 0, 0, 0, 0, 0]] (N, N m, at the tool frame)"
        )
    pts, _src = _points(None, cands, meas, measured)
    nl = cands.loads.shape[0]
    posture = np.repeat(np.arange(len(cands)), nl)
    loads = np.tile(cands.loads, (len(cands), 1))
    k = V.count(k, "--select", 1)
    if k > posture.size:
        raise InputError(
            f"--select {k}: only {posture.size} (posture, load) candidates ({cands.summary()}, {nl} loads); "
            f"{_more(cands)}"
        )
    res = plan_discriminate_deflection(model, meas, tied, cands.q[posture], loads, pts, k)
    res.update(posture=posture[res["selected"]], loads=loads[res["selected"]], points=pts)
    return res, cands, model


def _tmin(pairs: np.ndarray) -> float:
    """The smallest noncentrality over the ordered pairs a != b."""
    off = ~np.eye(pairs.shape[0], dtype=bool)
    return float(np.min(pairs[off]))


def discrimination_numbers(res: dict, cands: Candidates, seed: int = 0) -> dict:
    """What a discrimination plan (:func:`discriminate`'s result ``res``)
    achieves, evaluated by the design core (``design.discrimination``) on
    the plan's own rows (``res["rows"]``), in sigma^2 units: ``before`` the
    smallest noncentrality of the rows measured so far; ``alone`` (ncand,)
    that after adding each candidate alone to them; ``plan`` that of the
    plan (``res["value"]``, recomputed); ``random`` (RANDOM_DESIGNS,) that of
    random designs of the same size (seed + 1, as the parameter plans');
    ``selected`` the chosen candidates, ``q`` (k, nq) their postures,
    ``loads`` (k, 6) their loads (deflection data, else None), ``load_index``
    (k,) which row of cands.loads each is (deflection data)."""
    f, jh, n0, nobs = res["rows"]
    ncand = (f.shape[0] - n0) // nobs
    sel = np.asarray(res["selected"], int)
    before, alone = design.discrimination(f, jh, n0, nobs, np.zeros(0, int))
    planned, _ = design.discrimination(f, jh, n0, nobs, sel)
    rng = np.random.default_rng(seed + 1)
    draws = [np.sort(rng.choice(ncand, sel.size, replace=False)) for _ in range(RANDOM_DESIGNS)]
    random = np.array([_tmin(design.discrimination(f, jh, n0, nobs, d)[0]) for d in draws])
    loads = res.get("loads")
    # deflection data: candidate c is posture c // nl under load c % nl of [plan] loads (_discriminate_deflection)
    index = None if loads is None else sel % cands.loads.shape[0]
    return {
        "hypotheses": list(res["hypotheses"]),
        "before": _tmin(before),
        "alone": alone,
        "plan": _tmin(planned),
        "random": random,
        "selected": sel,
        "q": cands.q[res["posture"] if loads is not None else sel],
        "loads": None if loads is None else np.asarray(loads, float),
        "load_index": index,
    }
