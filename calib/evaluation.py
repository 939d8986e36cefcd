"""The errors of a model as it is, on measurements it was not fitted to
(``stiffkit evaluate`` and ``stiffkit fit --validate``; docs/calibration.md
section 6.10).

Nothing is fitted: every parameter takes the value the model file gives.
A model of deflections under known loads (section 3) must give a value to
every effect (``fit --write-model`` writes them); a model of absolute data
(section 6) must give every effect's value and the pose of the tracker and
of every marker (their ``xyz``/``rpy``, start values in a fit, are the
values here). The errors are those of ``fit``: per row (measured minus
predicted) and summarised (klimchik Table 2: MAX and RMS per axis and
positional; mean, RMS and max point error per frame for absolute data),
against the same reference as fit's "before": the measured deflections
themselves (no compensation) for deflection data, the nominal robot (the
model's URDF with its tracker and markers, every other effect at 0) for
absolute data.

``overlap``: the rows of a validation set that equal rows of the fitted
set (same postures, loads and measured values): errors on them are not a
validation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..robot.model import Model
from ..robot.tree_model import TreeModel
from .absolute_data import AbsoluteData
from .absolute_fit import position_stats, predict, set_deadzone_scales
from .fit import fit
from .measure import Measurements
from .results import FitResult, error_stats

__all__ = [
    "evaluate_deflection",
    "evaluate_absolute",
    "AbsoluteEvaluation",
    "deflection_rows",
    "format_evaluation",
    "format_absolute_evaluation",
    "evaluation_json",
    "overlap_deflection",
    "overlap_absolute",
    "overlap_warning",
    "check_kind",
    "MM",
]

MM = 1e-3
#: parameter kinds of absolute models whose values are poses (start values in a fit)
POSE_KINDS = ("tracker", "marker")


def _names(names: list[str], k: int = 6) -> str:
    return ", ".join(names[:k]) + (f", ... ({len(names)} in all)" if len(names) > k else "")


def _where(model: Model | TreeModel) -> str:
    return str(model.path) if getattr(model, "path", None) else "model"


def _no_rows(path: str) -> InputError:
    return InputError(f"{path}: no measurement rows (a header only): nothing to evaluate")


def check_kind(model_path: str | Path, kind: str, meas_path: str | Path) -> None:
    """InputError when the measurement file's header is of the other data
    kind than the model's ``[measurements] kind`` (a clearer message than
    the columns it lacks)."""
    try:
        with open(meas_path, encoding="utf-8-sig") as fh:
            head = {h.strip() for h in fh.readline().split(",")}
    except (OSError, UnicodeDecodeError):
        return  # the reader names the problem
    absolute = {"x", "y", "z"} <= head and not {"dx", "dy", "dz"} & head
    deflection = {"dx", "dy", "dz"} <= head and not {"x", "y", "z"} & head
    if kind == "deflection" and absolute:
        raise InputError(
            f"{meas_path}: tracker points (columns x, y, z) but {model_path} is a model of deflections under "
            'known loads (section 3); for absolute data the model says [measurements] kind = "absolute"'
        )
    if kind == "absolute" and deflection:
        raise InputError(
            f"{meas_path}: deflections under loads (columns dx, dy, dz) but {model_path} is a model of absolute "
            'data ([measurements] kind = "absolute"); use a model of deflections (section 2)'
        )


# ------------------------------------------------------------------ deflection data


def evaluate_deflection(model: Model, meas: Measurements, sigma_position: float | None = None) -> FitResult:
    """The errors of ``model`` (every effect with its value) on ``meas``:
    a FitResult with no free parameter (``fit``'s tables, JSON and plots).

    Raises InputError when an effect has no value or there are no rows."""
    missing = [n for t in model.terms if t.free for n in t.names]
    if missing:
        raise InputError(
            f"{_where(model)}: {len(missing)} parameter(s) have no value ({_names(missing)}): evaluate takes the "
            "model as it is; write one with values by `stiffkit fit MODEL.toml MEAS.csv --write-model OUT.toml`"
        )
    if meas.n == 0:
        raise _no_rows(meas.path)
    return fit(model, meas, sigma_position=sigma_position)


def deflection_rows(res: FitResult) -> list[dict]:
    """Per row: line, config, measured and predicted deflection, error (m)
    and its length; the tool rotation's error (rad) when the rows have one."""
    meas = res.problem.meas
    err = res.residuals
    rot = None if meas.r is None else meas.r - res.pred6[3:6].T
    out = []
    for i in range(meas.n):
        row = {
            "line": int(meas.lines[i]),
            "config": meas.config[i],
            "measured_m": [float(v) for v in res.measured[i]],
            "predicted_m": [float(v) for v in res.predicted[i]],
            "error_m": [float(v) for v in err[i]],
            "error_norm_m": float(np.linalg.norm(err[i])),
        }
        if rot is not None:
            row["rotation_error_rad"] = [float(v) for v in rot[i]]
        out.append(row)
    return out


def format_evaluation(res: FitResult, model_path: str, top: int = 10, sigma_from: str = "") -> str:
    """fit's Table 2 for the model as it is, and the rows with the largest
    errors; ``sigma_from`` says where a sigma not in the model came from."""
    from .results import format_table

    meas = res.problem.meas
    n = meas.n
    floor = ""
    if res.sigma_declared and math.isfinite(res.sigma):
        ratio = res.rms_position / (math.sqrt(3) * res.sigma)
        floor = f"; positional RMS {ratio:.3g} x the noise floor sqrt(3) sigma = {math.sqrt(3) * res.sigma / MM:.4g} mm"
        floor += f" ({sigma_from})" if sigma_from else ""
    lines = [
        format_table(
            res,
            label="model",
            footer=f"compensated fraction {100 * res.compensated_fraction:.1f} %   ({n} rows; nothing fitted{floor})",
        )
    ]
    d = np.linalg.norm(res.residuals, axis=1)
    lines.append(f"largest errors of {model_path} (of {n} rows):")
    for i in np.argsort(-d, kind="stable")[:top]:
        lines.append(f"  line {meas.lines[i]}: config {meas.config[i]}: {d[i] / MM:.4g} mm")
    return "\n".join(lines)


# ------------------------------------------------------------------ absolute data


@dataclass
class AbsoluteEvaluation:
    """The errors of a tree model as it is on absolute data: ``residual``
    (measured minus predicted, n x 3), ``before`` (the nominal robot's
    errors), ``predicted``; ``weight`` 0 marks rows left out (the file's
    weight column). Has the attributes ``absolute_plots`` and
    ``residual_table`` read."""

    model: TreeModel
    data: AbsoluteData
    theta: np.ndarray
    predicted: np.ndarray
    residual: np.ndarray
    before: np.ndarray
    weight: np.ndarray
    sigma: float | None

    @property
    def use(self) -> np.ndarray:
        return self.weight > 0

    def stats(self) -> dict:
        u = self.use
        return position_stats(self.residual[u], self.data.frame[u], self.data.frames)

    def stats_before(self) -> dict:
        u = self.use
        return position_stats(self.before[u], self.data.frame[u], self.data.frames)

    def rows(self) -> list[dict]:
        d = self.data
        out = []
        for i in range(d.n):
            out.append(
                {
                    "line": int(d.lines[i]),
                    "config": d.configs[d.posture[i]],
                    "frame": d.frames[d.frame[i]],
                    "measured_m": [float(v) for v in d.xyz[i]],
                    "predicted_m": [float(v) for v in self.predicted[i]],
                    "error_m": [float(v) for v in self.residual[i]],
                    "error_norm_m": float(np.linalg.norm(self.residual[i])),
                    "weight": float(self.weight[i]),
                }
            )
        return out

    def to_json(self, rows: bool = True) -> dict:
        after, before = self.stats(), self.stats_before()
        out = {k: after[k] for k in ("mean_position_m", "rms_position_m", "max_position_m", "axes")}
        out.update(
            kind="absolute",
            frames=after.get("frames", {}),
            before=before,
            compensated_fraction=1.0 - after["rms_position_m"] / before["rms_position_m"]
            if before["rms_position_m"] > 0
            else 0.0,
            n_rows=self.data.n,
            n_used=int(np.sum(self.use)),
            n_postures=self.data.n_postures,
            sigma_m=self.sigma,
            model=str(self.model.path) if self.model.path else None,
            measurements=self.data.path,
        )
        if rows:
            out["rows"] = self.rows()
        return out


def _check_values(model: TreeModel) -> None:
    """Every effect of an absolute model has its value, the tracker and the markers their pose."""
    where = _where(model)
    missing = [p.name for p in model.params if p.free and p.kind not in POSE_KINDS]
    if missing:
        raise InputError(
            f"{where}: {len(missing)} parameter(s) have no value ({_names(missing)}): evaluate takes the model as "
            "it is; write one with values by `stiffkit fit MODEL.toml MEAS.csv --write-model OUT.toml`"
        )
    for e in model.effects:
        kind = e.get("kind")
        if kind == "tracker" and not (e.get("fixed") or "xyz" in e or "rpy" in e):
            raise InputError(
                f"{where}: the tracker effect has no pose (xyz, rpy): evaluate does not fit the tracker; give its "
                "pose (fit --write-model writes it)"
            )
        if kind == "marker" and not (e.get("fixed") or "xyz" in e):
            raise InputError(
                f"{where}: the marker on {e.get('target')!r} has no xyz: evaluate does not fit the markers; give "
                "its coordinates (fit --write-model writes them)"
            )


def evaluate_absolute(model: TreeModel, data: AbsoluteData, sigma_position: float | None = None) -> AbsoluteEvaluation:
    """The errors of ``model`` as it is on ``data`` (module docstring).

    Raises InputError when an effect has no value, the tracker or a marker
    no pose, a frame of the data has no marker, or there is no row."""
    missing = sorted(set(data.frames) - set(model.frames))
    if missing:
        raise InputError(
            f"{data.path}: frame(s) {', '.join(missing)} have no marker in {_where(model)} "
            f"(markers: {', '.join(model.frames)})"
        )
    _check_values(model)
    if data.n == 0 or not np.any(data.weight > 0):
        raise _no_rows(data.path)
    theta = model.theta0
    set_deadzone_scales(model, data, theta)  # tau0 not given: from the data, as fit does
    pred = predict(model, data, theta)["pred"]
    nominal = theta.copy()
    for i, p in enumerate(model.params):
        if p.kind not in POSE_KINDS:
            nominal[i] = 0.0
    before = data.xyz - predict(model, data, nominal)["pred"]
    sigma = sigma_position if sigma_position is not None else model.sigma_position
    resid = data.xyz - pred
    if not np.all(np.isfinite(resid)):
        raise InputError(f"{_where(model)}: the model's prediction is not finite on {data.path} (values too large?)")
    return AbsoluteEvaluation(model, data, theta, pred, resid, before, data.weight.copy(), sigma)


def _row(label: str, st: dict) -> str:
    return (
        f"{label:34s}{st['mean_position_m'] / MM:9.3f}{st['rms_position_m'] / MM:9.3f}"
        f"{st['max_position_m'] / MM:9.3f}{st['n_points']:8d}"
    )


def format_absolute_evaluation(
    ev: AbsoluteEvaluation, top: int = 10, label: str = "model (nothing fitted)", sigma_from: str = "declared"
) -> str:
    """fit's error table (overall and per frame) for the model as it is,
    against the nominal robot, and the rows with the largest errors;
    ``sigma_from`` says where the sigma came from."""
    after, before = ev.stats(), ev.stats_before()
    lines = [f"{'point errors, mm':34s}{'mean':>9s}{'RMS':>9s}{'max':>9s}{'points':>8s}"]
    lines.append(_row("nominal (URDF, tracker, markers)", before))
    for f, st in before.get("frames", {}).items():
        lines.append(_row(f"  {f}", st))
    lines.append(_row(label[:33], after))
    for f, st in after.get("frames", {}).items():
        lines.append(_row(f"  {f}", st))
    tail = f"{ev.data.n} points in {ev.data.n_postures} configurations"
    if int(np.sum(~ev.use)):
        tail += f" ({int(np.sum(~ev.use))} with weight 0 left out)"
    if ev.sigma:
        floor = math.sqrt(3) * ev.sigma
        tail += (
            f"; sigma {ev.sigma / MM:.4g} mm per coordinate ({sigma_from}): "
            f"RMS {after['rms_position_m'] / floor:.3g} x the noise floor sqrt(3) sigma = {floor / MM:.4g} mm"
        )
    lines.append(tail)
    d = np.linalg.norm(ev.residual, axis=1)
    d[~ev.use] = -1.0
    lines.append(f"largest errors (of {ev.data.n}):")
    for i in np.argsort(-d, kind="stable")[: min(top, int(np.sum(ev.use)))]:
        lines.append(
            f"  line {ev.data.lines[i]}: config {ev.data.configs[ev.data.posture[i]]}, "
            f"frame {ev.data.frames[ev.data.frame[i]]}: {d[i] / MM:.4g} mm"
        )
    return "\n".join(lines)


def evaluation_json(res: FitResult | AbsoluteEvaluation, rows: bool = True) -> dict:
    """The evaluation's JSON: the summary keys of fit's JSON (docs/calibration.md §4;
    section 6.4 for absolute data) and, with ``rows``, every row's error."""
    if isinstance(res, AbsoluteEvaluation):
        return res.to_json(rows)
    after = error_stats(res.residuals)
    out = {
        "kind": "deflection",
        "rms_position_m": after["rms_position_m"],
        "max_position_m": after["max_position_m"],
        "axes": after["axes"],
        "compensated_fraction": res.compensated_fraction,
        "before": error_stats(res.measured),
        "n_rows": int(res.measured.shape[0]),
        "chi2": res.chi2,
        "sigma_m": res.sigma if res.sigma_declared else None,
        "model": str(res.model.path) if res.model.path else None,
        "measurements": res.problem.meas.path,
    }
    if rows:
        out["rows"] = deflection_rows(res)
    return out


# ------------------------------------------------------------------ validation rows that are fitted rows


def _common(fitted: np.ndarray, val: np.ndarray) -> np.ndarray:
    """Indices of the rows of ``val`` equal (every number) to a row of ``fitted``."""
    if fitted.size == 0 or val.size == 0:
        return np.zeros(0, int)
    seen = {r.tobytes() for r in np.ascontiguousarray(fitted + 0.0)}
    v = np.ascontiguousarray(val + 0.0)  # + 0.0: -0.0 and 0.0 alike
    return np.array([i for i in range(v.shape[0]) if v[i].tobytes() in seen], int)


def _deflection_key(m: Measurements) -> np.ndarray:
    parts = [m.q, m.w, m.p, m.d] + ([m.r] if m.r is not None else [])
    return np.hstack(parts)


def overlap_deflection(fitted: Measurements, val: Measurements) -> np.ndarray:
    """Rows of ``val`` that are rows of ``fitted`` (indices)."""
    if fitted.q.shape[1] != val.q.shape[1] or (fitted.r is None) != (val.r is None):
        return np.zeros(0, int)
    return _common(_deflection_key(fitted), _deflection_key(val))


def _absolute_key(d: AbsoluteData, frames: list[str]) -> np.ndarray:
    """Per row: the posture's joint values, the frame's index in ``frames`` (-1: none), the point."""
    idx = {f: float(k) for k, f in enumerate(frames)}
    frame = np.array([idx.get(d.frames[k], -1.0) for k in d.frame]).reshape(-1, 1)
    return np.hstack([d.Q[d.posture], frame, d.xyz])


def overlap_absolute(fitted: AbsoluteData, val: AbsoluteData) -> np.ndarray:
    """Rows of ``val`` (same joints, frame and measured point) that are rows of ``fitted``."""
    if list(fitted.joints) != list(val.joints):
        return np.zeros(0, int)
    return _common(_absolute_key(fitted, fitted.frames), _absolute_key(val, fitted.frames))


def overlap_warning(idx: np.ndarray, lines: list[int] | np.ndarray, n: int, val_path: str, fit_path: str) -> str | None:
    """The warning when validation rows are fitted rows (None when none is)."""
    if idx.size == 0:
        return None
    same = Path(val_path).resolve() == Path(fit_path).resolve()
    head = (
        f"{val_path}: the validation file is the fitted file"
        if same
        else f"{val_path}: {idx.size} of {n} validation row(s) equal rows of the fitted {fit_path} "
        f"(lines {', '.join(str(int(lines[i])) for i in idx[:5])}{', ...' if idx.size > 5 else ''})"
    )
    return head + ": errors on fitted rows are not a validation; measure fresh postures"
