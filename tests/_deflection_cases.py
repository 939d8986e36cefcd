"""The relative-data (deflection) cases of tests/test_deflection_reference.py:
every feature of the deflection model (joint, joint_profile, gravity
compensator, point offset, link/base/tool templates, joint_cubic,
joint_deadzone, rotation rows, M1-M5 reduction, the KR-270 example and the
demo), each evaluated and fitted. ``compute(name)`` returns the numbers the
reference stores (tests/data/deflection_reference.json.gz, written by
tests/data/make_deflection_reference.py with the code of the day it was
made); the test recomputes them with today's code.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from stiffkit.calib import synth as S
from stiffkit.calib.fit import fit
from stiffkit.calib.measure import read_measurements
from stiffkit.calib.problem import Problem
from stiffkit.calib.reduce import reduce_model, reduced_model
from stiffkit.robot.model import load_model, model_from_tables

ROOT = Path(__file__).resolve().parents[1]
MARKERS = ((0.0, 0.0, 0.25), (0.12, 0.0, 0.2))


def _joints():
    return [{"kind": "joint", "target": j["name"], "value": c} for j, c in zip(S.KR270_JOINTS, S.KR270_JOINT_C)]


def _data(truth, seed, n_configs=8, loads_per_config=2, sigma=1e-6, sigma_rotation=None, loads="random"):
    return S.synthesize(
        S.KR270_JOINTS,
        truth,
        n_configs=n_configs,
        loads_per_config=loads_per_config,
        sigma=sigma,
        sigma_rotation=sigma_rotation,
        seed=seed,
        ranges=S.KR270_RANGES,
        markers=MARKERS,
        loads=loads,
    )


def _theta_probe(pb: Problem, seed: int) -> np.ndarray:
    """A point away from zero where every term is inside its domain:
    compliances of the magnitude of the truth, k_s and offsets too."""
    rng = np.random.default_rng(seed)
    out = []
    for t in pb.terms:
        if not t.free:
            continue
        for n in t.names:
            if n.endswith(".k_s"):
                out.append(4e7 * (1 + 0.2 * rng.random()))
            elif n.startswith("point_offset"):
                out.append(0.02 * rng.normal())
            elif t.kind == "six":
                out.append(1e-9 * (1 + rng.random()) if n[-1] == n[-2] else 1e-10 * rng.normal())
            elif t.kind == "joint_cubic":
                out.append(-1e-15 * (1 + rng.random()))
            elif t.kind == "joint_deadzone":
                out.append(1e-4 * (1 + rng.random()))
            elif t.kind == "joint_profile":
                out.append(1e-7 * (1 + rng.random()) if n.endswith("c0") else 1e-8 * rng.normal())
            else:
                out.append(5e-7 * (1 + rng.random()))
    return np.array(out)


def _evaluated(pb: Problem, seed: int) -> dict:
    z = np.zeros(pb.npar)
    th = _theta_probe(pb, seed)
    p0, J0 = pb.evaluate(z)
    pt, Jt = pb.evaluate(th)
    return {"names": pb.names, "theta_probe": th, "pred0": p0, "jac0": J0, "pred": pt, "jac": Jt}


def _fitted(res) -> dict:
    ident = np.array([g == "identifiable" for g in res.groups], bool)
    return {
        "fit_names": res.names,
        "fit_values": res.values,
        "fit_identifiable": ident,
        "fit_std": np.where(ident, res.std, 0.0),
        "fit_chi2": res.chi2,
        "fit_rank": res.rank,
        "fit_iterations": res.iterations,
        "fit_pred6": res.pred6,
    }


def _case(truth, effects, seed, sigma_rotation=None, loads="random", **kw):
    chain, tm, meas = _data(truth, seed, sigma_rotation=sigma_rotation, loads=loads, **kw)
    out = {}
    ptruth, _ = Problem(tm, meas).evaluate(np.zeros(0), jac=False)
    out["truth_pred"] = ptruth
    m = model_from_tables(chain, effects, sigma_position=1e-6, sigma_rotation=sigma_rotation)
    pb = Problem(m, meas)
    out.update(_evaluated(pb, seed))
    out.update(_fitted(fit(m, meas)))
    return out


def _links(templates):
    return [{"kind": "link", "target": ln, "template": tp} for ln, tp in templates]


def case_links_templates():
    """Joints + link_2 full, link_3 beam (x), link_4 diagonal, tool beam (z),
    with rotation rows."""
    eff = (
        [{"kind": "joint", "target": "all"}]
        + _links([("link_2", "full"), ("link_3", "beam"), ("link_4", "diagonal")])
        + [{"kind": "tool", "template": "beam", "axis": "z"}, {"kind": "base", "template": "diagonal"}]
    )
    return _case(S.kr270_truth(compensator=False), eff, seed=11, sigma_rotation=1e-6)


def case_compensator():
    """Joints + a gravity compensator on A2: the nonlinear (LM) fit."""
    eff = [
        {"kind": "joint", "target": "all"},
        {
            "kind": "gravity_compensator",
            "target": "joint_a2",
            **{k: S.KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")},
        },
    ]
    return _case(S.kr270_truth(links=False, compensator=True), eff, seed=12)


def case_compensator_links():
    """The demo's final model kind: joints, links 2-4 beam, compensator."""
    eff = (
        [{"kind": "joint", "target": "all"}]
        + _links([("link_2", "beam"), ("link_3", "beam"), ("link_4", "beam")])
        + [
            {
                "kind": "gravity_compensator",
                "target": "joint_a2",
                **{k: S.KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")},
            }
        ]
    )
    return _case(S.kr270_truth(compensator=True), eff, seed=13, n_configs=12, loads_per_config=3)


def case_joint_profile():
    prof = {"kind": "joint_profile", "target": "joint_a2", "value": [2e-7, 3e-8, -2e-8, 1e-8, 5e-9]}
    truth = [e for e in _joints() if e["target"] != "joint_a2"] + [prof]
    eff = [{"kind": "joint", "target": j["name"]} for j in S.KR270_JOINTS[:6] if j["name"] != "joint_a2"]
    eff.append({"kind": "joint_profile", "target": "joint_a2"})
    return _case(truth, eff, seed=14)


def case_point_offset():
    truth = _joints() + [{"kind": "point_offset", "r": [0.01, -0.02, 0.03]}]
    eff = [{"kind": "joint", "target": "all"}, {"kind": "point_offset"}]
    return _case(truth, eff, seed=15, sigma_rotation=1e-6)


def case_point_offset_known():
    """A known point offset with free links (the offset moves the basis)."""
    truth = S.kr270_truth(compensator=False, offset=[0.02, 0.0, -0.01])
    eff = (
        [{"kind": "joint", "target": "all"}]
        + _links([("link_3", "beam")])
        + [{"kind": "point_offset", "r": [0.02, 0.0, -0.01]}]
    )
    return _case(truth, eff, seed=16)


def case_cubic_deadzone():
    nl = [
        {"kind": "joint_cubic", "target": "joint_a2", "value": -2e-15},
        {"kind": "joint_deadzone", "target": "joint_a4", "value": 2e-4, "tau0": 15.0},
        {"kind": "joint_deadzone", "target": "joint_a5", "value": 1e-4, "tau0": 8.0},
    ]
    eff = [
        {"kind": "joint", "target": "all"},
        {"kind": "joint_cubic", "target": "joint_a2"},
        {"kind": "joint_deadzone", "target": "joint_a4"},  # tau0 from the data
        {"kind": "joint_deadzone", "target": "joint_a5", "tau0": 8.0},
        {"kind": "joint_cubic", "target": "joint_a5"},
    ]
    return _case(_joints() + nl, eff, seed=17, n_configs=10, loads_per_config=3)


def case_known_values():
    """A model whose every effect is known (a cubic and a compensator among
    them): the predictions and the tool compliance (secant under the rows'
    wrenches)."""
    truth = S.kr270_truth(compensator=True, offset=[0.0, 0.01, 0.0]) + [
        {"kind": "joint_cubic", "target": "joint_a3", "value": -1e-15},
        {"kind": "joint_profile", "target": "joint_a1", "value": [1e-8, 2e-9, 0.0, -1e-9, 3e-9]},
    ]
    chain, tm, meas = _data(truth, 18)
    pred, _ = Problem(tm, meas).evaluate(np.zeros(0), jac=False)
    return {"truth_pred": pred, "tool_compliance": tm.tool_compliance(meas.q, wrench=meas.w)}


def case_reduction():
    """M1-M5 on the complete KR-270 model under gravity loading (klimchik
    Table 1), then the fit of the reduced model."""
    chain, tm, meas = _data(S.kr270_truth(), seed=1, n_configs=30, loads_per_config=3, sigma=2e-5, loads="gravity")
    links = ["base_link"] + [f"link_{i}" for i in range(1, 7)]
    m = model_from_tables(
        chain,
        [{"kind": "joint", "target": "all"}] + _links([(ln, "beam") for ln in links]),
        sigma_position=2e-5,
    )
    red = reduce_model(m, meas)
    res = fit(reduced_model(m, red), meas)
    out = {
        "counts": np.array([r[3] for r in red.rows]),
        "aggregated": red.aggregated,
        "g1": red.g1,
        "g2": red.g2,
        "g3": red.g3,
        "selected": red.selected,
    }
    out.update(_fitted(res))
    return out


def case_kr270_example():
    """examples/kr270: model.toml (J1) and model_values.toml fitted on its
    measurements; truth.toml evaluated on them."""
    ex = ROOT / "examples" / "kr270"
    m = load_model(ex / "model.toml")
    meas = read_measurements(ex / "measurements.csv", m.chain.dof)
    out = {}
    pb = Problem(m, meas)
    out.update(_evaluated(pb, 19))
    out.update(_fitted(fit(m, meas)))
    tm = load_model(ex / "truth.toml")
    out["truth_pred"] = Problem(tm, meas).evaluate(np.zeros(0), jac=False)[0]
    mv = load_model(ex / "model_values.toml")
    try:
        out["values_pred"] = Problem(mv, meas).evaluate(np.zeros(Problem(mv, meas).npar), jac=False)[0]
    except Exception as exc:  # noqa: BLE001 - recorded as text: the same failure must come back
        out["values_pred_error"] = type(exc).__name__
    return out


def case_demo():
    """The error fall of ``stiffkit demo`` (no plots): per model the label,
    the parameters, the rank and the MAX/RMS position errors."""
    import tempfile

    from stiffkit.calib.demo import calibration_demo

    with tempfile.TemporaryDirectory() as d:
        r = calibration_demo(out=d, plots=False, verbose=False)
    return {
        "labels": [s[0] for s in r["steps"]],
        "npar": np.array([s[2] for s in r["steps"]]),
        "rank": np.array([s[3] for s in r["steps"]]),
        "verdicts": [s[4] for s in r["steps"]],
        "max_position": np.array([s[1]["max_position_m"] for s in r["steps"]]),
        "rms_position": np.array([s[1]["rms_position_m"] for s in r["steps"]]),
    }


CASES = {
    "links_templates": case_links_templates,
    "compensator": case_compensator,
    "compensator_links": case_compensator_links,
    "joint_profile": case_joint_profile,
    "point_offset": case_point_offset,
    "point_offset_known": case_point_offset_known,
    "cubic_deadzone": case_cubic_deadzone,
    "known_values": case_known_values,
    "reduction": case_reduction,
    "kr270_example": case_kr270_example,
    "demo": case_demo,
}


def compute(name: str) -> dict:
    return CASES[name]()


def encode(v):
    """JSON form of a case value: arrays as {shape, data}."""
    if isinstance(v, np.ndarray):
        return {"shape": list(v.shape), "data": v.ravel().tolist(), "dtype": v.dtype.kind}
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


def decode(v):
    if isinstance(v, dict) and "shape" in v:
        return np.array(v["data"], dtype=bool if v.get("dtype") == "b" else float).reshape(v["shape"])
    return v
