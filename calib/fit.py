"""Identification of a model's elastostatic parameters from measurements.

The observation basis of every spring comes from the core in one call
(klimchik eqs. 4-5, 12); Python combines it into the columns of the model's
parameters, and the core solves the weighted least squares by a
rank-revealing SVD (eqs. 7-9, 15-20) and partitions the parameters into
identifiable / non-identifiable / semi-identifiable groups (M4a).
Nonlinear effects (gravity compensator, point offset) are identified by
Levenberg-Marquardt on top of the same linear solver.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .._core import calib as core
from .measure import Measurements
from ..robot.model import SPRING_JOINT, Model, compensator_h, profile_basis

GROUP_NAMES = {1: "identifiable", 2: "non-identifiable", 3: "semi-identifiable"}
RCOND = 1e-10      # singular values below RCOND * s_max are zero (unit-norm columns)
GTOL = 1e-6        # M4a: a row of V below this norm counts as zero


class Problem:
    """A model (plus optional extra terms) evaluated on a set of measurements.

    ``evaluate(theta)`` returns the predicted (6, n) rows (point deflection,
    tool rotation) and their Jacobian (6, n, npar) with respect to the free
    parameters of ``terms``. The spring basis is computed by the core once
    per point offset.
    """

    def __init__(self, model: Model, meas: Measurements, extra_terms=(), sigma_position=None,
                 sigma_rotation=None):
        if meas.q.shape[1] != model.chain.dof:
            raise InputError(f"{meas.path}: rows have {meas.q.shape[1]} joint values, the robot has "
                             f"{model.chain.dof}")
        self.model = model
        self.meas = meas
        self.terms = list(model.terms)
        self.extra = list(extra_terms)
        springs = model.springs(self.extra)
        # every actuated joint's spring is available for joint-type candidates
        for k in range(len(model.chain.qidx)):
            if model.chain.qidx[k] > 0 and (SPRING_JOINT, k + 1) not in springs:
                springs.append((SPRING_JOINT, k + 1))
        self.springs = springs
        self.offset = {}
        col = 0
        for sp in springs:
            self.offset[sp] = col
            col += 1 if sp[0] == SPRING_JOINT else 21
        self.nb = col
        self._cache = {}
        sp = sigma_position if sigma_position is not None else model.sigma_position
        sr = sigma_rotation if sigma_rotation is not None else model.sigma_rotation
        self.sigma_declared = sp is not None
        self.sigma_position = sp
        self.rows = 6 if meas.r is not None else 3
        wp = 1.0 / sp if sp else 1.0
        # rotations: declared sigma, else the position sigma per metre
        wr = 1.0 / sr if sr else wp
        self.wrow = np.array([wp] * 3 + [wr] * 3)[: self.rows]
        self.y = meas.d.T if meas.r is None else np.vstack([meas.d.T, meas.r.T])
        self.layout = self._layout(self.terms)

    @staticmethod
    def _layout(terms):
        out, k = {}, 0
        for i, t in enumerate(terms):
            if t.free:
                out[i] = slice(k, k + len(t.names))
                k += len(t.names)
        return out

    @property
    def names(self) -> list[str]:
        return [n for t in self.terms if t.free for n in t.names]

    @property
    def npar(self) -> int:
        return sum(len(t.names) for t in self.terms if t.free)

    def basis(self, r=None):
        """(B (6, n, nb), Rt (n, 3, 3)) at point offset r (tool frame)."""
        if r is not None and not np.any(r):
            r = None
        key = None if r is None else tuple(np.asarray(r, float))
        if key in self._cache:
            return self._cache[key]
        ch = self.model.chain
        p = self.meas.p if r is None else self.meas.p + np.asarray(r, float)
        stype = np.array([s[0] for s in self.springs], np.int32)
        sidx = np.array([s[1] for s in self.springs], np.int32)
        B, Rt = core.spring_basis(self.nb, ch.core_arrays(), stype=stype, sidx=sidx,
                                             q=np.asfortranarray(self.meas.q.T),
                                             w=np.asfortranarray(self.meas.w.T),
                                             p=np.asfortranarray(p.T))
        out = (B, Rt)
        if len(self._cache) > 4:
            self._cache.clear()
        self._cache[key] = out
        return out

    def offset_value(self, theta, terms=None, layout=None):
        terms = self.terms if terms is None else terms
        layout = self.layout if layout is None else layout
        for i, t in enumerate(terms):
            if t.kind == "point_offset":
                return theta[layout[i]] if t.free else t.value
        return None

    def evaluate(self, theta, terms=None, layout=None, jac=True):
        """Predicted rows (6, n) and Jacobian (6, n, npar) at theta."""
        terms = self.terms if terms is None else terms
        layout = self.layout if layout is None else layout
        npar = sum(len(t.names) for t in terms if t.free)
        B, Rt = self.basis(self.offset_value(theta, terms, layout))
        n = self.meas.n
        q = self.meas.q
        pred = np.zeros((6, n))
        J = np.zeros((6, n, npar)) if jac else None
        cb, dl, comp = {}, {}, {}
        for i, t in enumerate(terms):
            val = theta[layout[i]] if t.free else t.value
            if t.kind == "six":
                off = self.offset[t.spring]
                cols = B[:, :, [off + e for e in t.elements]]
                pred += cols @ val
                if t.free and jac:
                    J[:, :, layout[i]] = cols
            elif t.kind in ("joint", "joint_profile"):
                fn = np.ones((n, 1)) if t.kind == "joint" else profile_basis(q[:, t.qcol])
                cb[t.joint] = cb.get(t.joint, 0.0) + fn @ val
                if t.free:
                    dl.setdefault(t.joint, []).append((layout[i], fn))
            elif t.kind == "gravity_compensator":
                comp[t.joint] = (t, val, layout.get(i))
        for j, c in cb.items():
            g = B[:, :, self.offset[(SPRING_JOINT, j + 1)]]
            if j in comp:
                t, ks, sl = comp[j]
                h = compensator_h(q[:, t.qcol], t.geometry)
                den = 1.0 + c * ks[0] * h
                ceff = c / den
                dc = 1.0 / den ** 2
                dk = -c * c * h / den ** 2
                if jac and sl is not None:
                    J[:, :, sl] = (g * dk)[:, :, None]
            else:
                ceff, dc = c, np.ones(n)
            pred += g * ceff
            if jac:
                for sl, fn in dl.get(j, []):
                    J[:, :, sl] = g[:, :, None] * (dc[:, None] * fn)[None]
        if jac:
            for i, t in enumerate(terms):
                if t.kind == "point_offset" and t.free:
                    J[0:3, :, layout[i]] = self.offset_columns(pred, Rt)
        return pred, J

    @staticmethod
    def offset_columns(pred, Rt):
        """d(point deflection)/dr (3, n, 3) = [dphi]x R_tool at the prediction
        (the point deflection is dt + dphi x R_tool (p + r))."""
        dphi = pred[3:6].T                              # (n, 3)
        out = np.empty((3, dphi.shape[0], 3))
        for i in range(3):
            out[:, :, i] = np.cross(dphi, Rt[:, :, i]).T
        return out

    def weighted(self, rows6):
        """Rows (6, n[, k]) -> weighted observation vector/matrix (rows*n[, k])."""
        r = rows6[: self.rows]
        w = self.wrow.reshape((-1,) + (1,) * (r.ndim - 1))
        r = r * w
        return r.reshape((self.rows * r.shape[1],) + r.shape[2:])


@dataclass
class FitResult:
    """Identified parameters, their groups and the residuals."""

    names: list[str]
    values: np.ndarray
    std: np.ndarray                 # NaN where the parameter is not identifiable
    groups: list[str]
    rank: int
    nobs: int
    measured: np.ndarray            # (n, 3) measured point deflections
    predicted: np.ndarray           # (n, 3)
    chi2: float                     # weighted residual sum of squares
    dof: int
    sigma: float                    # sigma used for the standard errors
    sigma_declared: bool
    iterations: int
    converged: bool
    couplings: list[list[str]]
    singular_values: np.ndarray
    problem: Problem = field(repr=False)
    theta: np.ndarray = field(repr=False)
    A: np.ndarray = field(repr=False)          # weighted Jacobian at the solution
    r: np.ndarray = field(repr=False)          # weighted residual
    pred6: np.ndarray = field(repr=False)

    @property
    def residuals(self) -> np.ndarray:
        return self.measured - self.predicted

    @property
    def model(self) -> Model:
        return self.problem.model

    def table(self) -> dict:
        """Residual statistics as in klimchik Table 2 (before / after)."""
        return {"before": error_stats(self.measured), "after": error_stats(self.residuals)}

    @property
    def rms_position(self) -> float:
        return error_stats(self.residuals)["rms_position_m"]

    @property
    def compensated_fraction(self) -> float:
        before = error_stats(self.measured)["rms_position_m"]
        return 1.0 - self.rms_position / before if before > 0 else 0.0

    def parameter(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    def to_json(self) -> dict:
        after = error_stats(self.residuals)
        out = {"rms_position_m": after["rms_position_m"], "max_position_m": after["max_position_m"],
               "axes": after["axes"], "compensated_fraction": self.compensated_fraction,
               "parameters": [{"name": n, "value": float(v),
                               "std": None if not np.isfinite(s) else float(s), "group": g}
                              for n, v, s, g in zip(self.names, self.values, self.std, self.groups)],
               # extensions
               "before": error_stats(self.measured), "rank": self.rank,
               "n_parameters": len(self.names), "n_rows": int(self.measured.shape[0]),
               "n_observations": self.nobs, "chi2": self.chi2, "dof": self.dof,
               "sigma_m": self.sigma if np.isfinite(self.sigma) else None,
               "sigma_declared": self.sigma_declared,
               "iterations": self.iterations, "converged": self.converged,
               "couplings": self.couplings,
               "model": str(self.model.path) if self.model.path else None,
               "measurements": self.problem.meas.path}
        return out


def error_stats(e: np.ndarray) -> dict:
    """MAX and RMS per axis and positional of (n, 3) errors (Table 2)."""
    e = np.asarray(e, float)
    norm = np.linalg.norm(e, axis=1)
    axes = {ax: {"rms_m": float(np.sqrt(np.mean(e[:, i] ** 2))), "max_m": float(np.abs(e[:, i]).max())}
            for i, ax in enumerate("xyz")}
    return {"rms_position_m": float(np.sqrt(np.mean(norm ** 2))), "max_position_m": float(norm.max()),
            "axes": axes}


def equilibrate(A, nonlinear):
    """Column factors that bring the columns of nonlinear parameters (whose
    units differ from compliances by many decades, e.g. k_s in N/m) to the
    largest column norm, so the core's zero-column test (relative to the
    largest column) only flags structural zeros. Returns f (npar,): solve
    with A * f, then theta = theta_f * f."""
    f = np.ones(A.shape[1])
    if A.shape[1] == 0 or not np.any(nonlinear):
        return f
    d = np.linalg.norm(A, axis=0)
    big = d.max() if d.size else 0.0
    for k in np.nonzero(nonlinear)[0]:
        if d[k] > 0 and big > 0:
            f[k] = big / d[k]
    return f


def solve_wls(A, b, rcond=RCOND, gtol=GTOL, scale=None):
    """Core weighted least squares (rows already weighted); ``scale``
    multiplies the columns before the core and the solution after."""
    if A.shape[0] < A.shape[1]:
        raise InputError(f"{A.shape[0]} observations for {A.shape[1]} parameters: fewer rows than "
                         f"parameters (add measurements or remove effects)")
    f = np.ones(A.shape[1]) if scale is None else scale
    theta, stdu, s, v, rank, group, res = core.wls(A * f, b, rcond, gtol)
    return theta * f, stdu * f, s, v, rank, group, res


def coupling_relations(names, v, rank, tol=1e-6) -> list[list[str]]:
    """Sparse linear relations between coupled parameters (eq. 21, core
    null_relations): each is a set of parameters of which only a combination
    is identifiable, e.g. a joint compliance and the link spring's rotation
    about the same axis."""
    n = len(names)
    if rank >= n:
        return []
    if np.shape(v) != (n, n):
        raise ValueError(f"V must be ({n}, {n}), got {np.shape(v)}")
    rel = core.null_relations(v, rank, tol)
    out = []
    for row in rel:
        members = [names[i] for i in np.nonzero(row)[0]]
        if len(members) > 1 and members not in out:
            out.append(members)
    return out


def coupling_groups(names, v, rank, group, tol=1e-6) -> list[list[str]]:
    """M5a: semi-identifiable parameters coupled through the null space, as
    connected groups (unions of overlapping relations)."""
    rels = coupling_relations(names, v, rank, tol)
    groups: list[set] = []
    for r in rels:
        s = set(r)
        merged = [g for g in groups if g & s]
        for g in merged:
            s |= g
            groups.remove(g)
        groups.append(s)
    order = {n: i for i, n in enumerate(names)}
    return [sorted(g, key=order.get) for g in groups if len(g) > 1]


def as_inputs(model, meas):
    """Accept paths as well as loaded objects (Python calls mirror the CLI)."""
    from pathlib import Path

    from .measure import read_measurements
    from ..robot.model import load_model

    if isinstance(model, (str, Path)):
        model = load_model(model)
    if isinstance(meas, (str, Path)):
        meas = read_measurements(meas, model.chain.dof)
    return model, meas


def fit(model: Model, meas: Measurements, sigma_position=None, max_iter: int = 50,
        problem: Problem | None = None, theta0=None) -> FitResult:
    """Identify the free parameters of ``model`` from ``meas`` (contract s4).

    Parameters
    ----------
    model : Model or path of a model TOML
    meas : Measurements or path of a measurement CSV
    sigma_position : overrides the model's [measurements] sigma_position (m)
    max_iter : Levenberg-Marquardt iterations (nonlinear effects only)

    Returns
    -------
    FitResult : values, standard errors (NaN unless identifiable), groups,
        couplings, residuals; ``.table()``, ``.to_json()`` (contract keys).

    Linear models are solved in one weighted least-squares step; models with
    a free gravity compensator or point offset by Levenberg-Marquardt.

    Raises
    ------
    InputError : fewer observations than parameters, inconsistent inputs.
    """
    model, meas = as_inputs(model, meas)
    pb = problem or Problem(model, meas, sigma_position=sigma_position)
    npar = pb.npar
    nobs = pb.rows * meas.n
    if npar > nobs:
        raise InputError(f"{meas.path}: {meas.n} rows give {nobs} observations for {npar} free parameters "
                         f"({', '.join(pb.names[:8])}{', ...' if npar > 8 else ''}): fewer rows than parameters")
    y = pb.weighted(pb.y)
    theta = np.zeros(npar) if theta0 is None else np.array(theta0, float)
    nonlinear = any(t.free and t.nonlinear for t in pb.terms)
    nlmask = np.array([t.nonlinear for t in pb.terms if t.free for _ in t.names], dtype=bool)
    lam, it, converged = 0.0, 0, True
    pred, J = pb.evaluate(theta)
    if npar:
        A = pb.weighted(J)
        b = y - pb.weighted(pred)
        cost = float(b @ b)
        if not nonlinear:
            delta, *_ = solve_wls(A, b)
            theta = theta + delta
            it = 1
        else:
            # compensated joints: iterate on their stiffness 1/c, in which
            # c_eff = 1 / (1/c + k_s h(q)) has a straight valley, not a curved one
            comp = {t.joint for t in pb.terms if t.kind == "gravity_compensator"}
            inv = np.array([t.kind == "joint" and t.joint in comp for t in pb.terms if t.free
                            for _ in t.names], dtype=bool)
            converged = False
            for it in range(1, max_iter + 1):
                use = inv & (theta > 0) if it > 1 else np.zeros(npar, bool)
                Az = A.copy()
                Az[:, use] = A[:, use] * (-theta[use] ** 2)          # d/d(1/c) = -c^2 d/dc
                if lam > 0:
                    d = np.linalg.norm(Az, axis=0)
                    Aa = np.vstack([Az, np.sqrt(lam) * np.diag(d)])
                    ba = np.concatenate([b, np.zeros(npar)])
                else:
                    Aa, ba = Az, b
                dz, *_ = solve_wls(Aa, ba, scale=equilibrate(Az, nlmask | use))
                trial = theta + dz
                zc = 1.0 / theta[use] + dz[use]
                trial[use] = np.where(zc > 0, 1.0 / np.where(zc > 0, zc, 1.0), theta[use] * 10.0)
                delta = trial - theta
                p2, J2 = pb.evaluate(trial)
                b2 = y - pb.weighted(p2)
                c2 = float(b2 @ b2)
                if c2 <= cost:
                    # a relative decrease below 1e-4 is far below one unit of chi2
                    # at any noise level: stop (the noise-free case converges
                    # quadratically down to round-off first)
                    small = cost - c2 <= 1e-4 * cost + 1e-300 or \
                        np.all(np.abs(delta) <= 1e-10 * (np.abs(trial) + 1e-300))
                    theta, pred, J, b, cost = trial, p2, J2, b2, c2
                    A = pb.weighted(J)
                    lam = lam / 10.0 if lam > 1e-12 else 0.0
                    if small:
                        converged = True
                        break
                else:
                    lam = max(lam * 10.0, 1e-6)
                    if lam > 1e12:
                        converged = True   # no further decrease possible
                        break
        pred, J = pb.evaluate(theta)
        A = pb.weighted(J)
        b = y - pb.weighted(pred)
        eq = equilibrate(A, nlmask)
        _, stdu, s, v, rank, group, _ = solve_wls(A, b, scale=eq)
        A = A * eq           # equilibrated: for the score tests of the diagnosis
    else:
        A = np.zeros((nobs, 0))
        b = y - pb.weighted(pred)
        stdu, s, v, rank, group = np.zeros(0), np.zeros(0), np.zeros((0, 0)), 0, np.zeros(0, int)
    chi2 = float(b @ b)
    dof = nobs - rank
    if pb.sigma_declared:
        scale = 1.0
        sigma = float(pb.sigma_position)
    else:
        scale = np.sqrt(chi2 / dof) if dof > 0 else np.nan
        sigma = float(scale)
    names = pb.names
    groups = [GROUP_NAMES.get(int(g), "non-identifiable") for g in group]
    std = np.where(np.asarray(group) == 1, stdu * scale, np.nan)
    couplings = coupling_relations(names, v, rank) if npar else []
    return FitResult(names=names, values=theta, std=std, groups=groups, rank=rank, nobs=nobs,
                     measured=meas.d.copy(), predicted=pred[0:3].T.copy(), chi2=chi2, dof=dof,
                     sigma=sigma, sigma_declared=pb.sigma_declared, iterations=it, converged=converged,
                     couplings=couplings, singular_values=s, problem=pb, theta=theta, A=A, r=b,
                     pred6=pred)


def identified_model(res: FitResult) -> Model:
    """The model with every free parameter set to its identified value."""
    import copy

    m = copy.copy(res.model)
    terms = []
    for i, t in enumerate(res.problem.terms):
        t2 = copy.copy(t)
        if t.free:
            t2.value = res.theta[res.problem.layout[i]].copy()
        terms.append(t2)
    m.terms = terms
    return m


def format_table(res: FitResult, unit: float = 1e-3, label: str = "") -> str:
    """Residual table like klimchik Table 2, in mm."""
    before, after = res.table()["before"], res.table()["after"]
    u = "mm" if unit == 1e-3 else "um" if unit == 1e-6 else "m"
    head = (f"{'':34s}{'x':>15s}{'y':>15s}{'z':>15s}{'positional':>15s}\n"
            f"{'errors, ' + u:34s}" + "".join(f"{'MAX':>7s}{'RMS':>8s}" for _ in range(4)))

    def row(name, st):
        cells = [(st["axes"][a]["max_m"], st["axes"][a]["rms_m"]) for a in "xyz"]
        cells.append((st["max_position_m"], st["rms_position_m"]))
        return f"{name:34s}" + "".join(f"{m / unit:7.3f}{r / unit:8.3f}" for m, r in cells)

    lines = [head, row("deflections without compensation", before),
             row(f"after compensation{(' (' + label + ')') if label else ''}"[:33], after),
             f"compensated fraction {100 * res.compensated_fraction:.1f} %   "
             f"({res.problem.meas.n} rows, {len(res.names)} parameters, rank {res.rank})"]
    return "\n".join(lines)


def format_parameters(res: FitResult) -> str:
    lines = [f"{'parameter':24s}{'value':>14s}{'std':>12s}  group"]
    for n, v, s, g in zip(res.names, res.values, res.std, res.groups):
        sd = f"{s:12.3e}" if np.isfinite(s) else f"{'-':>12s}"
        lines.append(f"{n:24s}{v:14.5e}{sd}  {g}")
    counts = {g: res.groups.count(g) for g in ("identifiable", "semi-identifiable", "non-identifiable")}
    lines.append(f"groups: {counts['identifiable']} identifiable (G1), {counts['semi-identifiable']} "
                 f"semi-identifiable (G3), {counts['non-identifiable']} non-identifiable (G2); rank {res.rank}")
    for c in res.couplings:
        lines.append(f"coupled (only their combination is identifiable): {', '.join(c)}")
    return "\n".join(lines)


def model_tables_with_values(res: FitResult) -> list[dict]:
    """The model's [[effect]] tables with every identified value (contract s5)."""
    from ..robot.model import SYM

    model = identified_model(res)
    out = []
    for i, table in enumerate(model.effects):
        terms = [t for t in model.terms if t.effect == i]
        for t in terms:
            tab = {k: v for k, v in table.items() if k not in ("value", "k_s", "r")}
            if t.kind in ("joint", "joint_profile", "gravity_compensator"):
                tab["target"] = t.target
            if t.kind == "joint":
                tab["value"] = float(t.value[0])
            elif t.kind == "joint_profile":
                tab["value"] = [float(v) for v in t.value]
            elif t.kind == "gravity_compensator":
                tab["k_s"] = float(t.value[0])
            elif t.kind == "point_offset":
                tab["r"] = [float(v) for v in t.value]
            else:
                C = np.zeros((6, 6))
                for e, v in zip(t.elements, t.value):
                    a, b = SYM[e]
                    C[a, b] = C[b, a] = float(v)
                tab["value"] = C.tolist()
                tab.pop("rpy", None)
            out.append(tab)
    return out


def write_model(res: FitResult, path) -> None:
    """Write the identified model (URDF reference, sigma, effects with values)."""
    import os
    from pathlib import Path

    import tomli_w

    path = Path(path)
    model = res.model
    robot = dict(model.robot_table) if model.robot_table else {
        "base_link": model.chain.base_link, "tool_frame": model.chain.tool_frame}
    urdf = Path(model.chain.urdf).resolve()
    try:
        robot["urdf"] = os.path.relpath(urdf, path.resolve().parent)
    except ValueError:
        robot["urdf"] = str(urdf)
    doc = {"robot": robot}
    meas = {}
    if model.sigma_position is not None:
        meas["sigma_position"] = model.sigma_position
    if model.sigma_rotation is not None:
        meas["sigma_rotation"] = model.sigma_rotation
    if meas:
        doc["measurements"] = meas
    from .synth import effects_toml

    head = (f"# identified by stiffkit fit from {res.problem.meas.path}: positional RMS "
            f"{res.rms_position:.4g} m, rank {res.rank} of {len(res.names)} parameters\n"
            f"# non-identifiable and semi-identifiable parameters hold the minimum-norm solution\n")
    path.write_text(head + tomli_w.dumps(doc) + effects_toml(model_tables_with_values(res)))
