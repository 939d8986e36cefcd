"""Shared helpers of the calibration tests: the KR-270-like robot, truths."""

from __future__ import annotations

import numpy as np

from stiffkit.calib import synth as S
from stiffkit.robot.model import model_from_tables

MARKERS = ((0.0, 0.0, 0.25), (0.12, 0.0, 0.2), (0.0, 0.12, 0.2))


def spd(seed, scale_t=3e-8, scale_r=2e-7):
    """A random symmetric positive definite 6x6 compliance, all entries non-zero."""
    rng = np.random.default_rng(seed)
    L = rng.normal(size=(6, 6))
    C = L @ L.T + 3 * np.eye(6)
    s = np.array([scale_t] * 3 + [scale_r] * 3) ** 0.5
    return C * np.outer(s, s) / 6


def joints_truth():
    return [{"kind": "joint", "target": j["name"], "value": c} for j, c in zip(S.KR270_JOINTS, S.KR270_JOINT_C)]


def data(truth, sigma=0.0, seed=0, n_configs=30, loads="random", markers=MARKERS, replicates=1, tmp=None):
    return S.synthesize(
        S.KR270_JOINTS,
        truth,
        n_configs=n_configs,
        sigma=sigma,
        seed=seed,
        ranges=S.KR270_RANGES,
        markers=markers,
        loads=loads,
        replicates=replicates,
        workdir=tmp,
    )


def model(chain, effects, sigma=None):
    return model_from_tables(chain, effects, sigma_position=sigma)


def truth_values(truth_model):
    """{parameter name: true value} of a truth model (all terms known)."""
    out = {}
    for t in truth_model.terms:
        for n, v in zip(t.names, t.value):
            out[n] = float(v)
    return out
