"""Gravity parameters on the synthetic dual-arm robot: URDF masses that
are off, and what mass factors recover (docs/calibration.md 6.8).

    python bench/bench_masses.py          (or: make bench BENCH=masses)
    python bench/bench_masses.py 3        (seeds)

The truth: the dual-arm humanoid of ``stiffkit synth dualarm`` (joint
offsets, frame errors, joint and lateral compliance) whose every link
weighs its URDF mass times a factor drawn in 0.7-1.4; 300 postures, both
hand markers, 0.1 mm noise. The user has the URDF's masses. Fitted: the
truth's kinds on every joint (joint_offset, frame, joint, lateral on
``all``) with the URDF masses, then the same with ``mass`` on ``all``
(default prior); mean and RMS point errors in sample and 5-fold CV by
configuration, against the noise floor sqrt(3) sigma; the first diagnosis
of the model without mass factors says what it proposes.
"""

from __future__ import annotations

import math
import os
import re
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from stiffkit._core import tree as core  # noqa: E402
from stiffkit.calib import dualarm as D  # noqa: E402
from stiffkit.calib.absolute_data import AbsoluteData  # noqa: E402
from stiffkit.calib.absolute_diagnose import diagnose_absolute  # noqa: E402
from stiffkit.calib.absolute_fit import cross_validate, fit_absolute, position_stats  # noqa: E402
from stiffkit.robot.tree import load_tree  # noqa: E402
from stiffkit.robot.tree_model import EQ_TOL, tree_model_from_tables  # noqa: E402

SIGMA, CONFIGS, FOLDS = 1e-4, 300, 5
KINDS = ("joint_offset", "frame", "joint", "lateral")


def scaled_urdf(text: str, rng: np.random.Generator) -> tuple[str, list[float]]:
    """The URDF with every <mass value> times a factor in 0.7-1.4."""
    factors = []

    def one(m: re.Match) -> str:
        f = float(rng.uniform(0.7, 1.4))
        factors.append(f)
        return f'<mass value="{float(m.group(1)) * f!r}"'

    return re.sub(r'<mass value="([^"]+)"', one, text), factors


def measured(model, Q: np.ndarray, rng: np.random.Generator) -> AbsoluteData:
    """Both hand markers at every posture, with Gaussian noise SIGMA."""
    n, nm = Q.shape[0], len(model.frames)
    data = AbsoluteData(
        path="bench_masses.csv",
        joints=model.actuated,
        configs=[f"c{k}" for k in range(n)],
        Q=Q,
        posture=np.repeat(np.arange(n), nm),
        frame=np.tile(np.arange(nm), n),
        frames=list(model.frames),
        xyz=np.zeros((n * nm, 3)),
        weight=np.ones(n * nm),
        lines=np.arange(n * nm) + 2,
    )
    ev = core.evaluate(
        model.packed, model.theta0, Q, None, data.posture, data.frame, data.xyz, data.weight,
        np.zeros(0, int), model.eqit, EQ_TOL,
    )  # fmt: skip
    data.xyz = ev["pred"] + SIGMA * rng.normal(size=ev["pred"].shape)
    return data


def one(seed: int, folder: Path) -> dict:
    rng = np.random.default_rng(seed)
    nominal = folder / "robot.urdf"
    nominal.write_text(D.dualarm_urdf())
    text, factors = scaled_urdf(D.dualarm_urdf(), rng)
    true_urdf = folder / "true.urdf"
    true_urdf.write_text(text)
    effects = D.dualarm_truth(nominal)
    truth = tree_model_from_tables(load_tree(true_urdf), effects, where="truth")
    data = measured(truth, D.dualarm_postures(CONFIGS, rng), rng)
    frames = [e for e in effects if e["kind"] in ("tracker", "marker")]
    frames = [{k: v for k, v in e.items() if k != "value"} for e in frames]
    user = frames + [{"kind": k, "target": "all"} for k in KINDS]
    tree = load_tree(nominal)
    out = {"seed": seed, "factors": (min(factors), max(factors))}
    for label, eff in (("URDF masses", user), ("+ mass all", user + [{"kind": "mass", "target": "all"}])):
        t0 = time.perf_counter()
        model = tree_model_from_tables(tree, eff, where=label, sigma_position=SIGMA)
        fit = fit_absolute(model, data)
        cv = cross_validate(fit.model, data, fit.theta, fit.reduction.kept, fit.weight, FOLDS)
        st = position_stats(fit.residual)
        out[label] = (st["mean_position_m"], st["rms_position_m"], cv["rms_position_m"], time.perf_counter() - t0)
        if label == "URDF masses":
            dg = diagnose_absolute(model, data)
            out["proposal"] = dg.proposal.label if dg.proposal else "none"
        else:
            true_tree = load_tree(true_urdf)
            err = [
                abs(fit.value(f"{ln}.mass") - true_tree.inertials[ln].mass / ine.mass)
                for ln, ine in tree.inertials.items()
                if f"{ln}.mass" in model.names
            ]
            held = [n for n, _w in fit.reduction.dropped + fit.reduction.merged if n.endswith(".mass")]
            out["factor_error"] = (float(np.median(err)), len(held))
    return out


def main(seeds: int) -> None:
    floor = math.sqrt(3) * SIGMA
    print(f"dual-arm robot, {CONFIGS} postures, 2 markers, sigma {SIGMA * 1e3:.2f} mm; floor {floor * 1e3:.4f} mm")
    print(f"{'seed':>4} {'model':14s}{'mean mm':>9}{'RMS mm':>9}{'CV RMS mm':>11}{'RMS/floor':>10}{'s':>7}")
    for seed in range(1, seeds + 1):
        with tempfile.TemporaryDirectory() as tmp:
            r = one(seed, Path(tmp))
        for label in ("URDF masses", "+ mass all"):
            mean, rms, cv, t = r[label]
            print(f"{seed:>4} {label:14s}{mean * 1e3:9.4f}{rms * 1e3:9.4f}{cv * 1e3:11.4f}{rms / floor:10.3f}{t:7.1f}")
        med, held = r["factor_error"]
        print(
            f"     factors drawn {r['factors'][0]:.2f}-{r['factors'][1]:.2f}; diagnosis of the first model proposes "
            f"{r['proposal']}; median |factor - truth| {med:.3f} (held at the URDF: {held})"
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
