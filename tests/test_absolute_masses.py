"""Gravity parameters on absolute data (docs/calibration.md section 6.8):
URDF masses off by factors 0.7-1.4 per body are recovered by the fit
(noise-free: to 1e-6), subtree factors and centre offsets too; what the
reduction says about masses and free compliances; the diagnosis proposes
the mass effect and reaches the noise floor; the TOML kinds read, are
checked, and are written back with the same numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_absolute_fit import MARKERS, SMALL_JOINTS, SMALL_LINKS, SMALL_RANGES, TRACKER, rows

import stiffkit
from stiffkit._core import tree as core
from stiffkit.calib import absolute_fit as AF
from stiffkit.calib import dualarm as D
from stiffkit.calib.absolute_diagnose import diagnose_absolute
from stiffkit.calib.absolute_fit import _loads, _marker_index, fit_absolute, predict
from stiffkit.calib.absolute_write import model_effects, write_model
from stiffkit.robot.model_bodies import MASS_PRIOR, prior_rows
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import load_tree_model, tree_model_from_tables

MOVING = [j[0] for j in SMALL_JOINTS if j[1] != "fixed"]
#: the truth's compliances, known to the user's model (values): joint and lateral on every joint
COMPLIANCES = [{"kind": "joint", "target": j, "value": 1e-4 * (1 + 0.1 * k)} for k, j in enumerate(MOVING)]
COMPLIANCES += [{"kind": "lateral", "target": j, "value": [5e-5, 6e-5]} for j in MOVING]
FRAMES = [{"kind": "tracker", **TRACKER}] + [{"kind": "marker", "target": f, "xyz": p} for f, p in MARKERS.items()]


def _tree(tmp, name, links):
    p = tmp / f"{name}.urdf"
    p.write_text(D.dualarm_urdf(SMALL_JOINTS, links, name="small"))
    return load_tree(p)


@pytest.fixture(scope="module")
def masses(tmp_path_factory):
    """The small tree of test_absolute_fit with its true masses (the URDF's
    times a factor in 0.7-1.4 per body), the URDF the user has, and
    noise-free data of the truth at 80 postures."""
    tmp = tmp_path_factory.mktemp("masses")
    rng = np.random.default_rng(5)
    factor = {ln: float(rng.uniform(0.7, 1.4)) for ln in SMALL_LINKS}
    true_links = {ln: (m * factor[ln], c) for ln, (m, c) in SMALL_LINKS.items()}
    truth = tree_model_from_tables(_tree(tmp, "true", true_links), FRAMES + COMPLIANCES, where="truth")
    lo, hi = np.array(SMALL_RANGES).T
    Q = rng.uniform(lo, hi, (80, lo.size))
    data = rows(truth, Q, truth.theta0, etol=1e-14)
    return dict(tmp=tmp, factor=factor, urdf=_tree(tmp, "urdf", SMALL_LINKS), truth=truth, data=data, Q=Q, rng=rng)


def _fit(model, data):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(AF, "EQ_TOL", 1e-14)
        return fit_absolute(model, data)


def test_noise_free_fit_recovers_every_mass_factor(masses):
    user = tree_model_from_tables(
        masses["urdf"], FRAMES + COMPLIANCES + [{"kind": "mass", "target": "all", "prior": 0}], where="user"
    )
    fit = _fit(user, masses["data"])
    assert fit.converged and fit.rms_position < 1e-10
    assert not fit.reduction.dropped and not fit.reduction.merged
    for ln, f in masses["factor"].items():
        assert abs(fit.value(f"{ln}.mass") - f) < 1e-6, ln


def test_subtree_factor_and_centre_offset_are_recovered(masses, tmp_path):
    """The truth: the left arm 1.3 times heavier, the chest's centre 3 cm
    forward, 2 cm left, 1 cm up of the URDF's."""
    links = dict(SMALL_LINKS)
    for ln in ("l1", "l2", "l3"):
        links[ln] = (1.3 * links[ln][0], links[ln][1])
    m, c = links["chest"]
    links["chest"] = (m, tuple(np.add(c, [0.03, 0.02, 0.01])))
    truth = tree_model_from_tables(_tree(tmp_path, "t2", links), FRAMES + COMPLIANCES, where="truth")
    data = rows(truth, masses["Q"], truth.theta0, etol=1e-14)
    eff = [{"kind": "subtree_mass", "target": "l1", "prior": 0}, {"kind": "com", "target": "chest", "prior": 0}]
    user = tree_model_from_tables(masses["urdf"], FRAMES + COMPLIANCES + eff, where="user")
    # the left arm's three bodies share one theta index
    bpar = user.arrays["bpar"]
    assert bpar.shape == (3, 6) and len(set(bpar[2, bpar[1] == 1])) == 1
    fit = _fit(user, data)
    assert fit.rms_position < 1e-10
    assert abs(fit.value("l1.subtree_mass") - 1.3) < 1e-6
    np.testing.assert_allclose([fit.value(f"chest.com_{a}") for a in "xyz"], [0.03, 0.02, 0.01], atol=1e-6)


def test_prior_rows_weigh_the_urdf_by_sigma_position_over_prior(masses):
    user = tree_model_from_tables(
        masses["urdf"],
        FRAMES + COMPLIANCES + [{"kind": "mass", "target": "all"}, {"kind": "com", "target": "l3", "prior": 0.02}],
        where="user",
        sigma_position=2e-4,
    )
    idx, mu, sw = prior_rows(user, user.free)
    names = [user.names[i] for i in idx]
    assert names[-3:] == ["l3.com_x", "l3.com_y", "l3.com_z"] and len(names) == len(SMALL_LINKS) + 3
    np.testing.assert_allclose(mu, [1.0] * len(SMALL_LINKS) + [0.0] * 3)
    np.testing.assert_allclose(sw, [2e-4 / MASS_PRIOR] * len(SMALL_LINKS) + [2e-4 / 0.02] * 3)
    # noise at the declared sigma: the factors that the data determine well stay near the truth
    data = masses["data"]
    noisy = data.subset(np.arange(data.n))
    noisy.xyz = data.xyz + masses["rng"].normal(0, 2e-4, data.xyz.shape)
    fit = fit_absolute(user, noisy)
    for ln in ("chest", "l3", "r3"):
        assert abs(fit.value(f"{ln}.mass") - masses["factor"][ln]) < 0.05, ln


def _payload_rows(model, Q, kg):
    """Noise-free rows of ``model`` with a known payload of ``kg`` at each
    tool on every other posture (frame index = marker)."""
    data = rows(model, Q, model.theta0)
    n = Q.shape[0]
    data.payloads = [(p, f, np.array([0, 0, -9.81 * kg, 0, 0, 0.0])) for p in range(0, n, 2) for f in range(2)]
    ev = core.evaluate(
        model.packed, model.theta0, Q, _loads(model, data), data.posture, _marker_index(model, data),
        data.xyz, data.weight, np.zeros(0, int), model.eqit, 1e-14,
    )  # fmt: skip
    data.xyz = ev["pred"]
    return data


def test_masses_with_free_compliances_identifiable_combinations(masses):
    """Joint and lateral compliances free with a factor on every mass:
    without a payload, the torso's factor duplicates the waist's lateral
    compliance (it loads nothing else) and one more factor is a combination
    of compliances and factors (a common scale); a known payload at both
    tools separates them."""
    eff = FRAMES + [{"kind": k, "target": "all"} for k in ("joint", "lateral")] + [{"kind": "mass", "target": "all"}]
    user = tree_model_from_tables(masses["urdf"], eff, where="user")
    fit = _fit(user, masses["data"])
    held = {n: why for n, why in fit.reduction.dropped + fit.reduction.merged if n.endswith(".mass")}
    assert len(held) == 2 and "waist.cy" in held["torso.mass"]
    other = next(n for n in held if n != "torso.mass")
    assert held[other].startswith("a combination of")
    assert sum(".mass: " in n for n in fit.notes) == 2
    truth = tree_model_from_tables(masses["truth"].tree, FRAMES + COMPLIANCES, where="truth")
    data = _payload_rows(truth, masses["Q"], 4.0)
    fit = _fit(tree_model_from_tables(masses["urdf"], eff, where="user"), data)
    held = [n for n, _w in fit.reduction.dropped + fit.reduction.merged if n.endswith(".mass")]
    assert held == ["torso.mass"]


def test_diagnosis_proposes_the_mass_effect_and_reaches_the_floor(masses):
    sigma = 1e-4
    rng = np.random.default_rng(8)
    data = masses["data"]
    noisy = data.subset(np.arange(data.n))
    noisy.xyz = data.xyz + rng.normal(0, sigma, data.xyz.shape)
    effects = FRAMES + COMPLIANCES
    steps = []
    for _k in range(3):
        model = tree_model_from_tables(masses["urdf"], effects, where="user", sigma_position=sigma)
        dg = diagnose_absolute(model, noisy)
        steps.append(dg)
        if dg.proposal is None:
            break
        effects = effects + [dict(dg.proposal.effect)]
    assert steps[0].verdict == "inadequate" and steps[0].proposal.kind in ("mass", "subtree_mass")
    final = steps[-1]
    floor = math.sqrt(3) * sigma
    assert final.proposal is None and final.verdict == "adequate"
    assert final.fit.rms_position < 1.10 * floor
    assert steps[0].fit.rms_position > 1.5 * floor  # the masses mattered


def test_written_model_reads_back_with_the_same_numbers(masses, tmp_path):
    eff = [
        {"kind": "mass", "target": "all", "prior": 0},
        {"kind": "subtree_mass", "target": "r1", "value": 1.25},
        {"kind": "com", "target": "l3", "value": [0.01, -0.02, 0.003]},
    ]
    user = tree_model_from_tables(masses["urdf"], FRAMES + COMPLIANCES + eff, where="user")
    fit = _fit(user, masses["data"])
    path = tmp_path / "fitted.toml"
    write_model(fit, path)
    back = load_tree_model(path)
    assert back.names == user.names
    np.testing.assert_array_equal(back.theta0[len(FRAMES) * 3 :], fit.theta[len(FRAMES) * 3 :])
    ref = predict(fit.model, masses["data"], fit.theta)["pred"]
    np.testing.assert_allclose(predict(back, masses["data"], back.theta0)["pred"], ref, atol=1e-12)
    tables, _notes = model_effects(back, back.theta0)
    again = {(t["kind"], t.get("target")): t.get("value") for t in tables}
    assert again[("subtree_mass", "r1")] == 1.25 and again[("com", "l3")] == [0.01, -0.02, 0.003]
    assert again[("mass", "l2")] == fit.value("l2.mass")


@pytest.mark.parametrize(
    "table, fragment",
    [
        ({"kind": "mass", "target": "nowhere"}, "target must be a link"),
        ({"kind": "mass", "target": "l_tcp"}, "has no mass in the URDF"),
        ({"kind": "mass", "target": "l1", "value": -0.5}, "a mass factor must be in [0, 100]"),
        ({"kind": "mass", "target": "l1", "value": True}, "value must be a finite number"),
        ({"kind": "mass", "target": "all", "value": 1.1}, "needs one target link"),
        ({"kind": "mass", "target": "l1", "prior": -0.1}, "prior = -0.1 must be a sigma in [0, 100]"),
        ({"kind": "com", "target": "l1", "value": [30, 0, 0]}, "beyond 1 m"),
        ({"kind": "com", "target": "l1", "value": [0.1, 0]}, "value must be [dx, dy, dz] (m)"),
        ({"kind": "com", "target": "l1", "prior": 2.0}, "must be a sigma in [0, 1] m"),
        ({"kind": "subtree_mass", "target": "l_tcp"}, "no link of the subtree of 'l_tcp' has mass"),
        ({"kind": "mass", "target": "l1", "scale": 2}, "unknown key(s) scale"),
    ],
)
def test_bad_gravity_parameter_tables(masses, table, fragment):
    with pytest.raises(stiffkit.InputError) as e:
        tree_model_from_tables(masses["urdf"], FRAMES + COMPLIANCES + [table], where="model.toml")
    assert fragment in str(e.value) and "model.toml: [[effect]] #" in str(e.value)


def test_two_mass_effects_on_one_link_are_refused(masses):
    twice = [{"kind": "mass", "target": "l1"}, {"kind": "mass", "target": "l1", "value": 1.1}]
    with pytest.raises(stiffkit.InputError, match="link 'l1' already has a mass effect"):
        tree_model_from_tables(masses["urdf"], FRAMES + twice, where="model.toml")
    # one link named and 'all': the named one takes its link, 'all' the others
    m = tree_model_from_tables(
        masses["urdf"], FRAMES + [{"kind": "mass", "target": "all"}, twice[1]], where="model.toml"
    )
    assert m.theta0[m.index("l1.mass")] == 1.1 and not m.params[m.index("l1.mass")].free
    assert m.params[m.index("l2.mass")].free


def test_a_fitted_factor_out_of_bounds_is_written_clipped_and_named(masses):
    model = tree_model_from_tables(
        masses["urdf"], FRAMES + [{"kind": "mass", "target": "l2"}, {"kind": "com", "target": "l3"}], where="m"
    )
    theta = model.theta0.copy()
    theta[model.index("l2.mass")] = -0.4
    theta[model.index("l3.com_y")] = 1.5
    tables, notes = model_effects(model, theta)
    got = {t["kind"]: t["value"] for t in tables if t["kind"] in ("mass", "com")}
    assert got == {"mass": 0.0, "com": [0.0, 1.0, 0.0]}
    assert any("l2.mass identified -0.4" in n and "written as 0" in n for n in notes)
    assert any("l3.com identified" in n for n in notes)
    tree_model_from_tables(masses["urdf"], tables, where="written")  # reads back
