"""Diagnosis on absolute data (docs/calibration.md 6.4) and the whole loop
through the command line: synth dualarm -> diagnose / append / fit ->
fit --write-model -> compensate, against the known truth."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from stiffkit._core import tree as core
from stiffkit.calib.absolute_diagnose import diagnose_absolute, format_absolute_diagnosis
from stiffkit.calib.absolute_report import load_absolute
from stiffkit.calib.diagnose import effect_toml
from stiffkit.calib.dualarm import add_hidden_effect, synth_dualarm
from stiffkit.cli import main
from stiffkit.robot.tree_model import EQ_TOL, load_tree_model

TRUTH_KINDS = {"tracker", "marker", "joint_offset", "frame", "joint", "lateral"}


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    """The diagnose loop from the frames-only model on the synthetic dual-arm
    data (400 postures, 0.1 mm noise): every step's diagnosis and the model
    file as it grew."""
    out = tmp_path_factory.mktemp("dualarm")
    synth_dualarm(out, configs=400, seed=3)
    steps = []
    for _k in range(7):
        model, data = load_absolute(out / "model.toml", out / "measurements.csv")
        dg = diagnose_absolute(model, data)
        steps.append(dg)
        if dg.proposal is None:
            break
        text = (out / "model.toml").read_text().rstrip() + "\n\n" + effect_toml(dg.proposal.effect) + "\n"
        (out / "model.toml").write_text(text)
    return out, steps


def test_loop_reaches_the_noise_floor_with_the_truths_effects_only(loop):
    out, steps = loop
    added = [dg.proposal.effect for dg in steps if dg.proposal is not None]
    assert 1 <= len(added) <= 6
    # nothing the truth lacks is ever added
    assert {e["kind"] for e in added} <= TRUTH_KINDS
    # joint offsets before the frame errors that contain them
    kinds = [e["kind"] for e in added]
    assert kinds.index("joint_offset") < kinds.index("frame")
    final = steps[-1]
    floor = math.sqrt(3) * 1e-4
    rms = final.fit.rms_position
    assert rms < 1.10 * floor, f"final RMS {rms:.3e} m, floor {floor:.3e} m"
    assert final.cv_rms_position_m < 1.10 * rms
    assert final.verdict == "adequate" and final.proposal is None
    # the error falls at every step
    errs = [dg.fit.rms_position for dg in steps]
    assert all(b < a for a, b in zip(errs, errs[1:]))
    # the story of a real humanoid: ~20 mm with the frames only
    assert 0.012 < errs[0] < 0.03


def test_diagnosis_json_and_no_false_proposal_at_the_end(loop, tmp_path):
    out, _steps = loop
    js = tmp_path / "dg.json"
    assert main(["diagnose", str(out / "model.toml"), str(out / "measurements.csv"), "--json", str(js)]) == 0
    d = json.loads(js.read_text())
    for key in ("verdict", "sigma_position_m", "rms_position_m", "candidates"):
        assert key in d
    assert d["verdict"] == "adequate" and d["proposal"] is None
    assert d["sigma_source"].startswith("estimated")
    # what is left is noise: no structure in posture nor in the order of measurement
    assert d["nothing_fits"] is False
    st = d["residual_structure"]
    assert st["posture"]["p_value"] > 0.005 and st["order"]["p_value"] > 0.005
    best = d["candidates"][0]
    assert {"kind", "target", "statistic", "p_value", "explained_fraction", "rms_after_m", "effect"} <= set(best)
    # the leftover candidates fit noise: none lowers the held-out error
    assert all(
        c["cv_rms_position_m"] is None or c["cv_rms_position_m"] > 0.98 * d["cv_rms_position_m"]
        for c in d["candidates"]
    )


def test_gross_errors_are_named_before_the_effects(loop, tmp_path):
    """Five rows with a 5 mm blunder in the final data: listed as gross errors,
    set aside, and no effect proposed."""
    out, _steps = loop
    rows = list(csv.reader((out / "measurements.csv").read_text().splitlines()))
    head, body = rows[0], rows[1:]
    ix = head.index("x")
    bad = [7, 101, 333, 512, 640]
    for i in bad:
        body[i][ix] = repr(float(body[i][ix]) + 0.005)
    meas = tmp_path / "m.csv"
    meas.write_text("\n".join(",".join(r) for r in [head] + body) + "\n")
    model, data = load_absolute(out / "model.toml", meas)
    dg = diagnose_absolute(model, data)
    lines = sorted(o["line"] for o in dg.data_checks["outliers"])
    assert lines == [i + 2 for i in bad]
    assert dg.proposal is None
    assert dg.fit.rms_position < 1.1 * math.sqrt(3) * 1e-4


def test_fit_write_model_then_compensate_reaches_the_targets(loop, tmp_path):
    """The identified model compensates the held-out trajectory: the true
    robot lands within 2x the noise floor of the nominal targets (RMS), and
    the Newton solve leaves below 1e-9 m."""
    out, _steps = loop
    ident = tmp_path / "identified.toml"
    urdf = tmp_path / "identified.urdf"
    assert (
        main(
            [
                "fit",
                str(out / "model.toml"),
                str(out / "measurements.csv"),
                "--quiet",
                "--write-model",
                str(ident),
                "--write-urdf",
                str(urdf),
            ]
        )
        == 0
    )
    cmds = tmp_path / "commands.csv"
    assert main(["compensate", str(ident), str(out / "targets.csv"), "--out", str(cmds)]) == 0
    rows = list(csv.DictReader(cmds.read_text().splitlines()))
    truth = load_tree_model(out / "truth.toml")
    joints = truth.actuated
    Qc = np.array([[float(r[j]) for j in joints] for r in rows])
    frames = [r["frame"] for r in rows]
    assert max(float(r["residual_position_m"]) for r in rows) < 1e-9
    tg = list(csv.DictReader((out / "targets.csv").read_text().splitlines()))
    Q0 = np.array([[float(r[j]) for j in joints] for r in tg])
    vj = np.array([truth.vj_of_link[f] for f in frames]) - 1
    idx = np.arange(len(rows))
    true_at = core.poses(truth.packed, truth.theta0, Qc, None, truth.eqit, EQ_TOL)["pa"][idx, vj]
    nominal = load_tree_model(out / "model.toml")  # frames only: its rigid URDF is the nominal model
    nom_vj = np.array([nominal.vj_of_link[f] for f in frames]) - 1
    targets = core.poses(nominal.packed, nominal.theta0, Q0, None, 0, EQ_TOL)["pa"][idx, nom_vj]
    err = np.linalg.norm(true_at - targets, axis=1)
    floor = math.sqrt(3) * 1e-4
    assert math.sqrt(np.mean(err**2)) < 2 * floor


def test_a_configuration_in_mm_is_named_and_set_aside(loop, tmp_path):
    out, _steps = loop
    rows = list(csv.reader((out / "measurements.csv").read_text().splitlines()))
    head, body = rows[0], rows[1:]
    ix = head.index("x")
    label = body[40][0]
    for r in body:
        if r[0] == label:
            for k in range(3):
                r[ix + k] = repr(1000 * float(r[ix + k]))
    meas = tmp_path / "m.csv"
    meas.write_text("\n".join(",".join(r) for r in [head] + body) + "\n")
    model, data = load_absolute(out / "model.toml", meas)
    assert any(label in w and "recorded in mm" in w and "divide by 1000" in w for w in data.warnings)
    dg = diagnose_absolute(model, data)
    assert [s["config"] for s in dg.data_checks["unit_slips"]] == [label]
    assert dg.proposal is None
    assert dg.fit.rms_position < 1.1 * math.sqrt(3) * 1e-4


def _with_hidden_effect(out, kind: str, amount: float, seed: int):
    """The dual-arm data with an effect outside the catalogue
    (calib.dualarm.add_hidden_effect); the model: the truth's kinds on
    every joint, values to identify."""
    text = (out / "model.toml").read_text()
    for k in sorted(TRUTH_KINDS - {"tracker", "marker"}):
        text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
    (out / "model.toml").write_text(text)
    add_hidden_effect(out, kind, amount, seed)
    return load_absolute(out / "model.toml", out / "measurements.csv")


@pytest.mark.parametrize(
    "kind, amount, reason",
    [("cyclic", 3e-3, "errors of neighbouring postures are alike"), ("drift", 8e-4, "drift during the measurement")],
)
def test_an_effect_outside_the_catalogue_is_said_plainly(tmp_path, kind, amount, reason):
    """An effect no catalogued kind describes (issue 9's nothing-fits, on
    absolute data without a declared sigma): no proposal that does not
    lower the held-out error, the verdict inadequate, the residual's
    structure named (posture or order of measurement), in the text and the
    JSON."""
    out = synth_dualarm(tmp_path / kind, configs=300, seed=11)
    model, data = _with_hidden_effect(out, kind, amount, seed=12)
    # a catalogued effect may absorb part of it (a proposal that lowers the
    # held-out error): the user adds it; within three steps nothing fits
    for _step in range(4):
        dg = diagnose_absolute(model, data)
        if dg.proposal is None:
            break
        text = (out / "model.toml").read_text().rstrip() + "\n\n" + effect_toml(dg.proposal.effect) + "\n"
        (out / "model.toml").write_text(text)
        model, data = load_absolute(out / "model.toml", out / "measurements.csv")
    assert dg.proposal is None and dg.verdict == "inadequate" and dg.nothing_fits
    assert dg.fit.rms_position > 1.3 * math.sqrt(3) * 1e-4  # the effect is there to see
    key, other = ("posture", "order") if kind == "cyclic" else ("order", "posture")
    st = dg.residual_structure
    assert st[key]["p_value"] < 0.005 and st[key]["neighbour_correlation"] > 0.05
    assert st[other]["p_value"] > 0.005
    assert any(reason in r for r in dg.reasons)
    # postures in a random order: consecutive ones are not neighbours in posture
    assert not any("cannot be told apart" in r for r in dg.reasons)
    text = format_absolute_diagnosis(dg)
    assert "NOTHING IN THE CATALOGUE FITS" in text and reason in text
    js = json.loads(json.dumps(dg.to_json()))
    assert js["nothing_fits"] is True and js["verdict"] == "inadequate"
