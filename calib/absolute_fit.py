"""Identification on absolute measurements (docs/calibration.md section 6.4):
geometry and gravity elasticity of a tree model from tracker data.

The steps:
1. Start: the tracker pose by a closed-form point-set fit (Procrustes /
   Kabsch, core/sk_field_fit.f90) of the nominal model's points onto the
   measured ones, unless the model gives one; the other parameters at
   their start values.
2. Reduction: the columns of the analytic Jacobian at the start, scaled to
   unit norm, are taken in a preference order (tracker, markers, joint
   offsets, frame errors, elastic parameters) and kept when their part
   orthogonal to the columns already kept is long enough
   (core/sk_calib.f90 select_independent). A dropped column is named with
   the parameters it duplicates (its least-squares combination of the kept
   columns, largest contributions first): non-identifiable when the
   orthogonal part is at round-off, near-redundant (merged into those
   parameters) when it is below ``MERGE_TOL``.
3. Levenberg-Marquardt on the kept parameters in the core
   (core/sk_tree_solve.f90), then a second run from the re-centred
   tracker rotation.
4. Standard errors from the scaled rank-revealing SVD of the weighted
   Jacobian (klimchik eqs. 7-9, 15-20), with the declared sigma or the
   residual's estimate.
Options: K-fold cross-validation with folds by configuration (the points of
one posture never split), and a robust fit (Huber weights on the points'
standardised distances, then the rows beyond the 99.9 % quantile set aside).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._core import calib as core_calib
from .._core import field as core_field
from .._core import tree as core
from ..errors import InputError
from ..robot.effect_values import nonnegative
from ..robot.model_bodies import prior_rows
from ..robot.tree_model import ABS_KINDS, DEADZONE_TAU0_FRACTION, EQ_TOL, LAW_DEADZONE, TreeModel, rpy_from_matrix
from .absolute_data import AbsoluteData
from .absolute_masses import gravity_notes, gravity_start
from .crossval import config_folds

__all__ = ["AbsoluteFit", "Reduction", "fit_absolute", "position_stats", "predict", "DROP_TOL", "MERGE_TOL"]

#: a scaled column whose part orthogonal to the kept ones is shorter than this is non-identifiable
DROP_TOL = 1e-7
#: ... and shorter than this, near-redundant (merged into the parameters it nearly duplicates)
MERGE_TOL = 1e-4
#: order in which kinds are kept when columns are dependent (the catalogue's
#: order: geometry before elasticity, simple laws before refined ones)
PREFERENCE = ABS_KINDS
#: standardised distance beyond which a robust fit sets a row aside: sqrt of chi2_3 at 99.9 %
SET_ASIDE = math.sqrt(16.266)
#: Huber's constant on the standardised distance: sqrt of chi2_3 at 95 %
HUBER = math.sqrt(7.815)
#: median of a chi distribution with 3 degrees of freedom (distance of a 3-D Gaussian point, unit sigma)
CHI3_MEDIAN = math.sqrt(2.366)


@dataclass
class Reduction:
    """Which parameters the data identify (``kept``, indices into the
    model's parameters) and which not, each with the reason in words."""

    kept: np.ndarray
    dropped: list[tuple[str, str]] = field(default_factory=list)
    merged: list[tuple[str, str]] = field(default_factory=list)
    bounded: list[tuple[str, str]] = field(default_factory=list)

    def lines(self) -> list[str]:
        out = [f"not identifiable, held at its start value: {n}: {why}" for n, why in self.dropped]
        out += [f"near-redundant, merged (held at its start value): {n}: {why}" for n, why in self.merged]
        out += [f"at its bound: {n}: {why}" for n, why in self.bounded]
        return out


def position_stats(e: np.ndarray, frames: np.ndarray | None = None, names: list[str] | None = None) -> dict:
    """Euclidean point errors (n, 3): mean, RMS, max (m), per axis RMS and
    max (klimchik Table 2), and per frame when ``frames`` is given."""
    e = np.asarray(e, float)
    d = np.linalg.norm(e, axis=1)
    out = {
        "mean_position_m": float(d.mean()) if d.size else 0.0,
        "rms_position_m": float(np.sqrt(np.mean(d**2))) if d.size else 0.0,
        "max_position_m": float(d.max()) if d.size else 0.0,
        "axes": {
            ax: {"rms_m": float(np.sqrt(np.mean(e[:, i] ** 2))), "max_m": float(np.abs(e[:, i]).max())}
            for i, ax in enumerate("xyz")
        }
        if d.size
        else {},
        "n_points": int(d.size),
    }
    if frames is not None and names is not None:
        out["frames"] = {
            n: {
                "mean_position_m": float(d[frames == k].mean()),
                "rms_position_m": float(np.sqrt(np.mean(d[frames == k] ** 2))),
                "max_position_m": float(d[frames == k].max()),
                "n_points": int(np.sum(frames == k)),
            }
            for k, n in enumerate(names)
            if np.any(frames == k)
        }
    return out


def _loads(model: TreeModel, data: AbsoluteData) -> tuple | None:
    if not data.payloads:
        return None
    mvj = model.arrays["mvj"]
    return (
        np.array([p for p, _f, _w in data.payloads]),
        np.array([mvj[f] for _p, f, _w in data.payloads]),
        np.array([w for _p, _f, w in data.payloads]),
    )


def _marker_index(model: TreeModel, data: AbsoluteData) -> np.ndarray:
    """Row -> marker index of the model (the data's frames are the model's)."""
    lut = np.array([model.frames.index(f) for f in data.frames], int)
    return lut[data.frame]


def predict(
    model: TreeModel,
    data: AbsoluteData,
    theta: np.ndarray,
    free: np.ndarray | None = None,
    weight: np.ndarray | None = None,
) -> dict:
    """The core's evaluation of ``data`` at theta: ``pred`` (n, 3), weighted
    residuals ``res`` and, for ``free``, their Jacobian ``jac``."""
    free = np.zeros(0, int) if free is None else np.asarray(free, int)
    weight = data.weight if weight is None else weight
    return core.evaluate(*_observations(model, data, theta), weight, free, model.eqit, EQ_TOL)


def _observations(model: TreeModel, data: AbsoluteData, theta: np.ndarray) -> tuple:
    """The leading arguments of the core's evaluate and lm: the model,
    theta, and the data's postures, loads and observed points."""
    return (
        model.packed,
        theta,
        data.Q,
        _loads(model, data),
        data.posture,
        _marker_index(model, data),
        data.xyz,
    )


def set_deadzone_scales(model: TreeModel, data: AbsoluteData, theta: np.ndarray) -> None:
    """tau0 of every dead-zone joint without one: a fraction of the RMS
    gravity torque about that joint over the data's postures."""
    kw0 = model.arrays["kw0"]
    todo = [k for k in range(len(kw0)) if model.arrays["ktype"][k] == LAW_DEADZONE and not kw0[k] > 0]
    if not todo:
        return
    # the torques at zero deflection do not depend on tau0; the core refuses a dead zone without one
    arrays = {**model.arrays, "kw0": np.where(np.isin(np.arange(len(kw0)), todo), 1.0, kw0)}
    P = core.poses(core.pack(model.ne, arrays), theta, data.Q, _loads(model, data), 1 if model.eqit else 0, EQ_TOL)
    for k in todo:
        vj = model.arrays["kvj"][0, k]
        rms = float(np.sqrt(np.mean(P["wv"][:, vj - 1] ** 2)))
        model.set_deadzone_tau0(k, DEADZONE_TAU0_FRACTION * rms if rms > 0 else 1.0)


def tracker_start(model: TreeModel, data: AbsoluteData, theta: np.ndarray) -> np.ndarray:
    """theta with the tracker pose from the Procrustes fit of the model's
    base-frame points onto the measured points (when the model gives no
    start pose). Raises InputError when no rigid motion matches them."""
    table = next(e for e in model.effects if e.get("kind") == "tracker")
    if "xyz" in table or "rpy" in table:
        return theta
    th = model.with_tracker(np.eye(3), np.zeros(3), theta)
    use = data.weight > 0  # rows set aside (a unit slip) play no part
    base = predict(model, data, th)["pred"][use]
    xyz = data.xyz[use]
    if base.shape[0] < 3:
        raise InputError(f"{data.path}: {base.shape[0]} measured point(s); the tracker pose needs at least 3")
    R, t = core_field.rigid_transform(base, xyz)
    # a few gross errors must not spoil the start: refit without the points far off
    for _ in range(3):
        d = np.linalg.norm(base @ R.T + t - xyz, axis=1)
        keep = d <= max(5.0 * float(np.median(d)), 1e-3)
        if keep.all() or keep.sum() < max(3, 0.5 * keep.size):
            break
        R, t = core_field.rigid_transform(base[keep], xyz[keep])
    th = model.with_tracker(R, t, th)
    rms = float(np.sqrt(np.median(np.sum((base @ R.T + t - xyz) ** 2, axis=1))))
    reach = float(np.sqrt(np.mean(np.sum((base - base.mean(axis=0)) ** 2, axis=1)))) or 1.0
    if not math.isfinite(rms) or rms > 0.25 * reach:
        spread = float(np.sqrt(np.mean(np.sum((xyz - xyz.mean(axis=0)) ** 2, axis=1))))
        ratio = spread / reach
        unit = ""
        if 300 < ratio < 3000:
            unit = f" The measured points spread {ratio:.0f} times wider than the model's: in mm? (files are in m)"
        raise InputError(
            f"{data.path}: the tracker start failed: the best rigid motion of the nominal model's points onto "
            f"the measured ones leaves a median distance of {rms * 1e3:.4g} mm ({rms / reach:.3g} times the points' "
            f"spread).{unit} "
            f"Check the units (m, rad), the joint columns and the frame names, or give the tracker a start pose "
            f"(xyz, rpy in the tracker effect)"
        )
    return th


def reduce_parameters(model: TreeModel, jac: np.ndarray, free: np.ndarray) -> Reduction:
    """The rank-revealing reduction of the free parameters (module docstring).

    A column is negligible when it is below 1e-9 of the largest column of
    its kind (the data's scale for that kind of parameter, not rounding);
    the others are scaled to unit norm and taken in the preference order."""
    names = model.names
    A = np.asarray(jac, float)
    norms = np.linalg.norm(A, axis=0)
    kinds = [model.params[i].kind for i in free]
    biggest = {k: max(norms[c] for c in range(len(free)) if kinds[c] == k) for k in set(kinds)}
    zero = np.array([norms[c] <= 1e-9 * biggest[kinds[c]] for c in range(len(free))], dtype=bool)
    kind_rank = {k: i for i, k in enumerate(PREFERENCE)}
    order = sorted(range(len(free)), key=lambda c: (kind_rank.get(kinds[c], 99), c))
    scaled = np.where(zero, 0.0, A / np.where(norms > 0, norms, 1.0))
    keep_loose = core_calib.select_independent(scaled, np.array(order), MERGE_TOL) & ~zero
    keep_tight = core_calib.select_independent(scaled, np.array(order), DROP_TOL) & ~zero
    red = Reduction(kept=free[keep_loose])
    kept_cols = np.flatnonzero(keep_loose)
    dep = np.flatnonzero(~keep_loose & ~zero)
    # one least-squares solve for every dependent column (one per column costs minutes on big trees)
    coef = np.linalg.lstsq(scaled[:, kept_cols], scaled[:, dep], rcond=None)[0] if kept_cols.size and dep.size else None
    kept_names = [names[free[k]] for k in kept_cols]
    for c in np.flatnonzero(~keep_loose):
        name = names[free[c]]
        if zero[c]:
            red.dropped.append((name, "the measurements do not depend on it (its column is zero)"))
            continue
        k = int(np.searchsorted(dep, c))
        why = _duplicates(scaled, c, kept_cols, kept_names, None if coef is None else coef[:, k])
        (red.merged if keep_tight[c] else red.dropped).append((name, why))
    return red


def _nonnegative(p: object) -> bool:
    """Parameters that are >= 0 by their physics, from the catalogue's
    bounds (robot/effect_values.py ``nonnegative``): joint and lateral
    compliances, the backlash of a dead zone, the diagonal of 6-dof springs."""
    return nonnegative(p.kind, p.name)


def _duplicates(A: np.ndarray, c: int, kept: np.ndarray, kept_names: list[str], coef: np.ndarray | None = None) -> str:
    """Words for a dependent column: the kept parameters whose combination
    (``coef``, the least-squares one when not given) reproduces it, largest
    contributions first."""
    if kept.size == 0:
        return "no other parameter is identified"
    if coef is None:
        coef, *_ = np.linalg.lstsq(A[:, kept], A[:, c], rcond=None)
    share = np.abs(coef) * np.linalg.norm(A[:, kept], axis=0)
    total = share.sum()
    if total == 0:
        return "its column is negligible"
    top = np.argsort(share)[::-1]
    main = [kept_names[k] for k in top if share[k] >= 0.15 * total][:4]
    if len(main) == 1 and share[top[0]] > 0.9 * total:
        return f"duplicates {main[0]}"
    return "a combination of " + ", ".join(main) + (" and others" if len(main) < np.sum(share > 1e-3 * total) else "")


@dataclass
class AbsoluteFit:
    """A fit on absolute data: the identified theta, the reduction, the
    residuals before (nominal model, tracker fitted) and after, statistics."""

    model: TreeModel
    data: AbsoluteData
    theta: np.ndarray
    reduction: Reduction
    std: np.ndarray
    groups: list[str]
    residual: np.ndarray
    before: np.ndarray
    sigma: float
    sigma_declared: bool
    chi2: float
    dof: int
    iterations: int
    converged: bool
    reason: str
    weight: np.ndarray
    cv: dict | None = None
    robust: dict | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def rms_position(self) -> float:
        return position_stats(self.residual)["rms_position_m"]

    def value(self, name: str) -> float:
        return float(self.theta[self.model.index(name)])

    def tracker(self) -> dict:
        R, t = self.model.tracker_pose(self.theta)
        return {"xyz": [float(v) for v in t], "rpy": [float(v) for v in rpy_from_matrix(R)]}

    def parameters(self) -> list[dict]:
        out = []
        for i, p in enumerate(self.model.params):
            s = self.std[i]
            out.append(
                {
                    "name": p.name,
                    "value": float(self.theta[i]),
                    "std": None if not np.isfinite(s) else float(s),
                    "group": self.groups[i],
                    "kind": p.kind,
                    "target": p.target,
                }
            )
        return out

    def to_json(self) -> dict:
        after = position_stats(self.residual, self.data.frame, self.data.frames)
        before = position_stats(self.before, self.data.frame, self.data.frames)
        out = {k: after[k] for k in ("mean_position_m", "rms_position_m", "max_position_m", "axes")}
        out["compensated_fraction"] = (
            1.0 - after["rms_position_m"] / before["rms_position_m"] if before["rms_position_m"] > 0 else 0.0
        )
        out["parameters"] = self.parameters()
        out.update(
            kind="absolute",
            frames=after.get("frames", {}),
            before=before,
            tracker=self.tracker(),
            n_rows=self.data.n,
            n_postures=self.data.n_postures,
            n_parameters=int(len(self.model.params)),
            n_identified=int(self.reduction.kept.size),
            chi2=self.chi2,
            dof=self.dof,
            sigma_m=self.sigma if math.isfinite(self.sigma) else None,
            sigma_declared=self.sigma_declared,
            iterations=self.iterations,
            converged=self.converged,
            stop_reason=self.reason,
            dropped=[{"name": n, "reason": r} for n, r in self.reduction.dropped],
            merged=[{"name": n, "reason": r} for n, r in self.reduction.merged],
            at_bound=[{"name": n, "reason": r} for n, r in self.reduction.bounded],
            model=str(self.model.path) if self.model.path else None,
            measurements=self.data.path,
            notes=self.notes,
        )
        if self.cv is not None:
            out["cv"] = self.cv
        if self.robust is not None:
            out["robust"] = self.robust
        return out


def _solve(
    model: TreeModel,
    data: AbsoluteData,
    theta: np.ndarray,
    free: np.ndarray,
    weight: np.ndarray,
    maxit: int,
    eqit: int | None = None,
) -> tuple[TreeModel, dict]:
    """LM from theta (``eqit`` overrides the model's equilibrium mode); the
    model returned carries the re-centred tracker rotation."""
    eqit = model.eqit if eqit is None else eqit
    prior = prior_rows(model, free)  # weak priors of the gravity parameters toward the URDF
    r = core.lm(*_observations(model, data, theta), weight, free, eqit, EQ_TOL, maxit=maxit, prior=prior)
    m = model.copy()
    m.arrays["rref"] = np.asfortranarray(r["rref"])
    return m, r


def fit_absolute(
    model: TreeModel,
    data: AbsoluteData,
    sigma_position: float | None = None,
    cv: int = 0,
    robust: bool = False,
    maxit: int = 200,
) -> AbsoluteFit:
    """Identify ``model``'s free parameters from ``data`` (module docstring)."""
    if sigma_position is not None and not (math.isfinite(sigma_position) and sigma_position > 0):
        raise InputError(f"sigma_position must be a positive length in m, got {sigma_position}")
    missing = sorted(set(data.frames) - set(model.frames))
    if missing:
        raise InputError(f"{data.path}: frame(s) {', '.join(missing)} have no marker in the model")
    if cv:
        _check_folds(data, cv)  # before the fit, not after it
    theta = model.theta0
    set_deadzone_scales(model, data, theta)
    theta = tracker_start(model, data, theta)
    free = model.free
    if free.size == 0:
        raise InputError(
            f"{model.path or 'model'}: every parameter is fixed; nothing to identify (the errors of a model as it "
            "is, on these or fresh data: stiffkit evaluate MODEL.toml MEAS.csv)"
        )
    w = data.weight.copy()
    # the nominal model with the tracker (and markers) fitted: the error "before"
    # and a generic point for the reduction (a marker start on a joint axis would
    # hide that joint's parameters)
    frames_only = np.array([i for i in free if model.params[i].kind in ("tracker", "marker")], dtype=int)
    if frames_only.size > data.xyz.size:
        need = -(-frames_only.size // 3)
        raise InputError(
            f"{data.path}: {data.xyz.size // 3} point(s) give {data.xyz.size} coordinates, fewer than the "
            f"{frames_only.size} parameters of the tracker and markers alone; measure at least {need} points"
        )
    if frames_only.size:
        # the start only: the rigid model is enough and much cheaper than the equilibrium
        model, sol0 = _solve(model, data, theta, frames_only, w, maxit, eqit=0)
        theta = sol0["theta"]
    ev = predict(model, data, theta, free, w)
    before = data.xyz - ev["pred"]
    # masses act through the compliances: fit those first when they start at zero
    model, theta, ev = gravity_start(
        model, theta, free, ev, reduce_parameters,
        lambda m, t, f: _solve(m, data, t, f, w, maxit), lambda m, t: predict(m, data, t, free, w),
    )  # fmt: skip
    red = reduce_parameters(model, ev["jac"], free)
    nobs = 3 * int(np.sum(w > 0))
    if red.kept.size > nobs:
        raise InputError(
            f"{data.path}: {nobs} observed coordinates for {red.kept.size} identifiable parameters: add postures"
        )
    robust_info = None
    if robust:
        model, sol, w, robust_info = _robust(model, data, theta, red.kept, w, maxit)
    else:
        model, sol = _solve(model, data, theta, red.kept, w, maxit)
    theta = sol["theta"]
    # compliances cannot be negative: one identified below 0 (a weakly determined
    # direction) is held at 0 and the others fitted again (an active set), so the
    # model written from this fit is the model fitted
    for _ in range(5):
        neg = [i for i in red.kept if _nonnegative(model.params[i]) and theta[i] < 0]
        if not neg:
            break
        for i in neg:
            red.bounded.append((model.names[i], f"identified {theta[i]:.4g} < 0: held at 0 (a compliance is >= 0)"))
        theta = theta.copy()
        theta[neg] = 0.0
        red.kept = np.array([i for i in red.kept if i not in neg], dtype=int)
        model, sol = _solve(model, data, theta, red.kept, w, maxit)
        theta = sol["theta"]
    ev = predict(model, data, theta, red.kept, w)
    resid = data.xyz - ev["pred"]
    chi2 = float(ev["res"] @ ev["res"])
    # standard errors and groups: the scaled rank-revealing SVD of the weighted Jacobian
    _t, stdu, _s, _v, rank, group, _r = core_calib.wls(ev["jac"], ev["res"], 1e-10, 1e-6)
    nobs = 3 * int(np.sum(w > 0))
    dof = nobs - rank
    declared = sigma_position if sigma_position is not None else model.sigma_position
    if declared is not None:
        sigma, scale = float(declared), float(declared)
        chi2 = chi2 / declared**2
    else:
        sigma = math.sqrt(chi2 / dof) if dof > 0 else float("nan")
        scale = sigma
    std = np.full(len(model.params), np.nan)
    groups = ["fixed" if not p.free else "non-identifiable" for p in model.params]
    gname = {1: "identifiable", 2: "non-identifiable", 3: "semi-identifiable"}
    for k, i in enumerate(red.kept):
        groups[i] = gname.get(int(group[k]), "non-identifiable")
        if group[k] == 1:
            std[i] = stdu[k] * scale
    for n, _why in red.merged:
        groups[model.index(n)] = "near-redundant"
    for n, _why in red.bounded:
        groups[model.index(n)] = "at bound"
    fit = AbsoluteFit(
        model=model,
        data=data,
        theta=theta,
        reduction=red,
        std=std,
        groups=groups,
        residual=resid,
        before=before,
        sigma=sigma,
        sigma_declared=declared is not None,
        chi2=chi2,
        dof=int(dof),
        iterations=sol["niter"],
        converged=sol["converged"],
        reason=core.LM_REASONS.get(sol["reason"], "?"),
        weight=w,
        robust=robust_info,
    )
    fit.notes += gravity_notes(model, red.dropped, red.merged)
    if not sol["converged"]:
        fit.notes.append(f"the fit did not converge: {fit.reason}; the values are the best found")
    if cv:
        fit.cv = cross_validate(model, data, theta, red.kept, w, cv, maxit)
    return fit


def huber_fit(
    model: TreeModel, data: AbsoluteData, theta: np.ndarray, free: np.ndarray, w0: np.ndarray, maxit: int
) -> tuple[TreeModel, dict, np.ndarray]:
    """Iteratively reweighted LM: Huber weights on the points' standardised
    distances (scale from their median). Returns (model, solution, weights)."""
    w = w0.copy()
    m, sol = _solve(model, data, theta, free, w, maxit)
    for _ in range(8):
        d = np.linalg.norm(data.xyz - predict(m, data, sol["theta"])["pred"], axis=1)
        s = float(np.median(d[w0 > 0])) / CHI3_MEDIAN
        if not s > 0:
            break
        u = d / s
        w_new = w0 * np.where(u <= HUBER, 1.0, HUBER / np.maximum(u, 1e-300))
        if np.allclose(w_new, w, rtol=1e-3, atol=1e-6):
            break
        w = w_new
        m, sol = _solve(m, data, sol["theta"], free, w, maxit)
    return m, sol, w


def _robust(
    model: TreeModel, data: AbsoluteData, theta: np.ndarray, free: np.ndarray, w0: np.ndarray, maxit: int
) -> tuple[TreeModel, dict, np.ndarray, dict]:
    """The Huber fit (:func:`huber_fit`), then the rows beyond SET_ASIDE
    get weight 0 and the fit is repeated."""
    m, sol, _w = huber_fit(model, data, theta, free, w0, maxit)
    d = np.linalg.norm(data.xyz - predict(m, data, sol["theta"])["pred"], axis=1)
    s = float(np.median(d[w0 > 0])) / CHI3_MEDIAN
    u = d / s if s > 0 else np.zeros_like(d)
    aside = np.flatnonzero((u > SET_ASIDE) & (w0 > 0))
    w = w0.copy()
    w[aside] = 0.0
    m, sol = _solve(m, data, sol["theta"], free, w, maxit)
    info = {
        "method": "Huber weights, then rows beyond the 99.9 % quantile set aside",
        "scale_m": s,
        "set_aside": [
            {
                "line": int(data.lines[i]),
                "config": data.configs[data.posture[i]],
                "frame": data.frames[data.frame[i]],
                "standardised_residual": float(u[i]),
                "distance_m": float(d[i]),
            }
            for i in aside
        ],
    }
    return m, sol, w, info


def _check_folds(data: AbsoluteData, k: object) -> None:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 2:
        raise InputError(f"--cv needs a whole number of folds >= 2, got {k!r}")
    if data.n_postures < k:
        raise InputError(
            f"{data.path}: {data.n_postures} configurations for {k} cross-validation folds "
            "(folds hold whole configurations: give at least one per fold)"
        )


def cross_validate(
    model: TreeModel,
    data: AbsoluteData,
    theta: np.ndarray,
    free: np.ndarray,
    weight: np.ndarray,
    k: int,
    maxit: int = 200,
) -> dict:
    """K-fold cross-validation by configuration (crossval.config_folds: the
    configurations dealt to the folds in turn): each fold's postures are
    predicted by the model fitted on the others, from the full fit's values."""
    _check_folds(data, k)
    labels = [data.configs[p] for p in data.posture]
    folds = config_folds(labels, k)
    held = np.full((data.n, 3), np.nan)
    for rows in folds:
        test = np.zeros(data.n, bool)
        test[rows] = True
        train = ~test & (weight > 0)
        if not np.any(test) or not np.any(train):
            continue
        dtr = data.subset(train)
        _m, sol = _solve(model, dtr, theta, free, weight[train], maxit)
        dte = data.subset(test)
        held[test] = dte.xyz - predict(_m, dte, sol["theta"])["pred"]
    ok = np.all(np.isfinite(held), axis=1) & (weight > 0)
    st = position_stats(held[ok], data.frame[ok], data.frames)
    return {
        "folds": k,
        "mean_position_m": st["mean_position_m"],
        "rms_position_m": st["rms_position_m"],
        "max_position_m": st["max_position_m"],
        "frames": st.get("frames", {}),
        "n_points": st["n_points"],
    }
