"""What ``stiffkit fit`` prints for absolute data: the point errors before
and after (mean, RMS, max per frame and overall, mm on the terminal), the
cross-validated error, the rows a robust fit set aside, the parameters with
their standard errors and groups, and the parameters the data do not
identify with the reason."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..robot.tree_model import TreeModel, load_tree_model, model_kind, tree_model_from_tables
from .absolute_data import read_absolute
from .absolute_fit import AbsoluteFit, fit_absolute, position_stats

__all__ = ["load_absolute", "format_absolute", "format_absolute_parameters", "fit_absolute_files", "written_tree_model"]

MM = 1e-3


def load_absolute(model_path: str | Path, meas_path: str | Path) -> tuple:
    """The tree model and its measurements (the CSV checked against the
    model's joints and marker frames)."""
    model = load_tree_model(model_path)
    tree = model.tree
    mimic = {j.name: tree.leader(j.name) for j in tree.joints if j.mimic is not None}
    needed = {tree.leader(j.name)[0] for f in model.frames for j in tree.path(f) if j.moving}
    limits = {j.name: j.limit for j in tree.joints}
    data = read_absolute(meas_path, model.actuated, model.frames, mimic, needed, limits)
    return model, data


def fit_absolute_files(model_path: str | Path, meas_path: str | Path, **kw: object) -> AbsoluteFit:
    """``fit_absolute`` of the files (the Python face of ``stiffkit fit``
    on absolute data)."""
    if model_kind(model_path) != "absolute":
        raise ValueError(f"{model_path}: not an absolute-measurement model")
    model, data = load_absolute(model_path, meas_path)
    return fit_absolute(model, data, **kw)


def written_tree_model(fit: AbsoluteFit) -> TreeModel:
    """The model ``write_model(fit, path)`` writes, as a TreeModel (what
    ``stiffkit evaluate`` reads back from that file)."""
    from .absolute_write import model_effects

    m = fit.model
    tables, _notes = model_effects(m, fit.theta, (), fit.std, fit.groups)
    sigma = fit.sigma if fit.sigma_declared else m.sigma_position
    where = str(m.path or "model")
    base = Path(m.path).parent if m.path is not None else Path(".")
    out = tree_model_from_tables(m.tree, tables, m.gravity, m.iterations, where, sigma, base)
    out.path = m.path
    out.robot_table = dict(m.robot_table)
    return out


def _row(label: str, st: dict) -> str:
    return (
        f"{label:34s}{st['mean_position_m'] / MM:9.3f}{st['rms_position_m'] / MM:9.3f}"
        f"{st['max_position_m'] / MM:9.3f}{st['n_points']:8d}"
    )


def format_absolute(fit: AbsoluteFit, label: str = "") -> str:
    """The error table: overall and per frame, before (nominal model with the
    tracker and markers fitted) and after; CV and robust lines."""
    d = fit.data
    before = position_stats(fit.before, d.frame, d.frames)
    use = fit.weight > 0
    after = position_stats(fit.residual[use], d.frame[use], d.frames)
    lines = [f"{'point errors, mm':34s}{'mean':>9s}{'RMS':>9s}{'max':>9s}{'points':>8s}"]
    lines.append(_row("before (nominal, tracker fitted)", before))
    for f, st in before.get("frames", {}).items():
        lines.append(_row(f"  {f}", st))
    lines.append(_row(f"after{(' (' + label + ')') if label else ''}"[:33], after))
    for f, st in after.get("frames", {}).items():
        lines.append(_row(f"  {f}", st))
    if fit.cv is not None:
        cv = fit.cv
        lines.append(_row(f"held out ({cv['folds']}-fold CV by config)", cv))
    if fit.robust is not None and fit.robust["set_aside"]:
        lines.append(f"robust fit: {len(fit.robust['set_aside'])} row(s) set aside (not in 'after'):")
        for r in fit.robust["set_aside"][:20]:
            lines.append(
                f"  line {r['line']}: config {r['config']}, frame {r['frame']}: {r['distance_m'] / MM:.3f} mm "
                f"({r['standardised_residual']:.1f} x the robust scale)"
            )
        if len(fit.robust["set_aside"]) > 20:
            lines.append(f"  ... {len(fit.robust['set_aside']) - 20} more (see --json)")
    floor = fit.sigma * math.sqrt(3) if math.isfinite(fit.sigma) else float("nan")
    sig = "declared" if fit.sigma_declared else "estimated from the residual"
    lines.append(
        f"{d.n} points in {d.n_postures} configurations; {fit.reduction.kept.size} identified parameters of "
        f"{len(fit.model.params)}; sigma {fit.sigma / MM:.4g} mm per coordinate ({sig}; noise floor "
        f"{floor / MM:.4g} mm); {fit.iterations} LM iterations, stopped: {fit.reason}"
    )
    for note in fit.notes:
        lines.append(f"note: {note}")
    return "\n".join(lines)


def format_absolute_parameters(fit: AbsoluteFit) -> str:
    """Every parameter: value, standard error, group; then the tracker pose
    and the parameters the data do not identify, with the reason."""
    lines = [f"{'parameter':28s}{'value':>15s}{'std':>12s}  group"]
    for p in fit.parameters():
        sd = f"{p['std']:12.3e}" if p["std"] is not None else f"{'-':>12s}"
        lines.append(f"{p['name']:28s}{p['value']:15.6e}{sd}  {p['group']}")
    tr = fit.tracker()
    lines.append(
        "tracker pose (base_link in the tracker frame): xyz = ["
        + ", ".join(f"{v:.6f}" for v in tr["xyz"])
        + "] m, rpy = ["
        + ", ".join(f"{v:.6f}" for v in tr["rpy"])
        + "] rad"
    )
    lines += fit.reduction.lines()
    counts = {g: fit.groups.count(g) for g in sorted(set(fit.groups))}
    lines.append("groups: " + ", ".join(f"{n} {g}" for g, n in counts.items()))
    return "\n".join(lines)


def residual_table(fit: AbsoluteFit, top: int = 10) -> str:
    """The worst points after the fit (for a look at the data)."""
    d = np.linalg.norm(fit.residual, axis=1)
    order = np.argsort(-d)[:top]
    out = [f"largest errors after the fit (of {fit.data.n}):"]
    for i in order:
        out.append(
            f"  line {fit.data.lines[i]}: config {fit.data.configs[fit.data.posture[i]]}, "
            f"frame {fit.data.frames[fit.data.frame[i]]}: {d[i] / MM:.3f} mm"
        )
    return "\n".join(out)
