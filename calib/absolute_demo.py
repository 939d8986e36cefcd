"""The tracker-calibration demo (the last part of ``stiffkit demo``): the
user's loop on a synthetic dual-arm humanoid measured by a laser tracker.

1. ``stiffkit synth dualarm`` writes the robot, its hidden truth (tracker
   pose, markers, joint offsets, frame errors, joint and lateral compliance
   under gravity), the measurements and a held-out test trajectory.
2. Starting from the tracker and the two hand markers only, the loop runs
   ``diagnose``, appends the proposed ``[[effect]]`` to model.toml, and fits
   again, until the diagnosis proposes nothing (at most ``MAX_STEPS``).
   Each step's mean / RMS / max point error and its cross-validated RMS go
   into a table and a figure, with the noise floor.
3. The identified model (``fit --write-model``) compensates the test
   trajectory: the simulated true robot is commanded with the nominal and
   with the compensated joint values, and the error of its hand frames
   against the nominal targets is shown before and after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._core import tree as core
from ..io.files import atomic_write_text, pyplot, save_figure
from ..robot.compensate import load_compensation_model, read_targets
from ..robot.tree_model import EQ_TOL, TreeModel, load_tree_model
from .absolute_diagnose import diagnose_absolute
from .absolute_fit import fit_absolute, position_stats
from .absolute_report import load_absolute
from .absolute_write import write_model
from .diagnose import effect_toml
from .dualarm import synth_dualarm

__all__ = ["tracker_demo", "MAX_STEPS"]

MAX_STEPS = 6
MM = 1e-3


@dataclass
class Step:
    label: str
    parameters: int
    identified: int
    mean: float
    rms: float
    max: float
    cv: float


def _row(s: Step) -> str:
    return (
        f"{s.label[:30]:30s}{s.identified:>5d}/{s.parameters:<5d}{s.mean / MM:8.3f}{s.rms / MM:8.3f}"
        f"{s.max / MM:8.3f}{s.cv / MM:9.3f}"
    )


def _points(m: TreeModel, Q: np.ndarray, frames: list[str], rigid: bool = False) -> np.ndarray:
    """Positions (n, 3) of the rows' frames (base axes) of the model ``m`` with
    its values, at the commands Q (at equilibrium unless ``rigid``)."""
    P = core.poses(m.packed, m.theta0, Q, None, 0 if rigid else m.eqit, EQ_TOL)
    vj = np.array([m.vj_of_link[f] for f in frames]) - 1
    return P["pa"][np.arange(Q.shape[0]), vj]


def tracker_demo(out: str | Path = "build/demo/tracker", configs: int = 300, seed: int = 1) -> dict:
    """Run the demo in the folder ``out`` (module docstring); returns the
    steps and the compensation figures."""
    out = Path(out)
    synth_dualarm(out, configs=configs, seed=seed)
    model_path = out / "model.toml"
    meas_path = out / "measurements.csv"
    print(
        f"\nstiffkit demo: tracker calibration of a dual-arm humanoid (synthetic, {configs} postures, "
        f"two hand markers, 0.1 mm noise; the truth is hidden in {out / 'truth.toml'})"
    )
    steps: list[Step] = []
    added: list[str] = ["tracker + markers"]
    floor = float("nan")
    for k in range(MAX_STEPS + 1):
        model, data = load_absolute(model_path, meas_path)
        dg = diagnose_absolute(model, data)
        fit = dg.fit
        st = position_stats(fit.residual[fit.weight > 0])
        steps.append(
            Step(
                added[-1],
                len(fit.model.params),
                int(fit.reduction.kept.size),
                st["mean_position_m"],
                st["rms_position_m"],
                st["max_position_m"],
                dg.cv_rms_position_m or float("nan"),
            )
        )
        floor = dg.floor
        print(f"  step {k}: {_row(steps[-1])}   verdict {dg.verdict}")
        if dg.proposal is None or k == MAX_STEPS:
            break
        eff = dg.proposal.effect
        print(f"    diagnosis proposes {dg.proposal.label}: appended to {model_path.name}")
        atomic_write_text(model_path, model_path.read_text().rstrip() + "\n\n" + effect_toml(eff) + "\n")
        added.append(f"+ {eff['kind']} ({eff.get('target', eff['kind'])})")
    print(f"\n{'model':30s}{'kept/params':>11s}{'mean':>8s}{'RMS':>8s}{'max':>8s}{'CV RMS':>9s}   (mm)")
    for s in steps:
        print(_row(s))
    print(f"{'noise floor (sqrt(3) sigma)':30s}{'':11s}{'':8s}{floor / MM:8.3f}")
    fig_path = out / "error_fall.png"
    _plot(steps, floor, fig_path)
    print(f"  figure: {fig_path}")
    # identified model -> compensation of the held-out trajectory on the true robot
    model, data = load_absolute(model_path, meas_path)
    fit = fit_absolute(model, data)
    identified = out / "identified.toml"
    write_model(fit, identified)
    cm = load_compensation_model(identified)
    tg = read_targets(out / "targets.csv", cm)
    res = cm.compensate(tg.Q, tg.frames, tg.wrench, check_plausible=False)
    nominal = _points(cm.nominal, tg.Q, tg.frames, rigid=True)
    truth = load_tree_model(out / "truth.toml")  # the simulated true robot
    before = np.linalg.norm(_points(truth, tg.Q, tg.frames) - nominal, axis=1)
    after = np.linalg.norm(_points(truth, res.q, tg.frames) - nominal, axis=1)
    print(
        f"\ncompensation of the test trajectory ({tg.Q.shape[0]} rows, {len(set(tg.frames))} hand frames; "
        f"the true robot against the nominal targets):"
    )
    print(
        f"  commanded nominal q:     mean {before.mean() / MM:7.3f}  RMS {_rms(before) / MM:7.3f}  "
        f"max {before.max() / MM:7.3f} mm"
    )
    print(
        f"  commanded compensated q: mean {after.mean() / MM:7.3f}  RMS {_rms(after) / MM:7.3f}  "
        f"max {after.max() / MM:7.3f} mm   (Newton residual <= {res.resp.max():.1e} m, "
        f"{int(res.converged.sum())}/{res.n} converged)"
    )
    return {
        "steps": steps,
        "floor": floor,
        "compensation_before_m": before,
        "compensation_after_m": after,
        "figure": fig_path,
    }


def _rms(d: np.ndarray) -> float:
    return float(math.sqrt(np.mean(d**2))) if d.size else 0.0


def _plot(steps: list[Step], floor: float, path: Path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    x = np.arange(len(steps))
    for attr, mk, lab in (
        ("rms", "o-", "RMS"),
        ("cv", "s--", "held-out RMS (5-fold CV)"),
        ("max", "^:", "max"),
        ("mean", "v-", "mean"),
    ):
        ax.plot(x, [getattr(s, attr) / MM for s in steps], mk, label=lab)
    ax.axhline(floor / MM, color="k", lw=0.8, ls="--", label="noise floor")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels([s.label.replace("+ ", "+\n") for s in steps], fontsize=8)
    ax.set_ylabel("point error, mm")
    ax.set_title("tracker calibration of the dual-arm robot: each step adds what the diagnosis proposes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
