"""Issue 15, one diagnosis pipeline: the behaviour both observation kinds
share, pinned on each (deflections under known loads: synth kr270, 4
configurations, 36 rows, sigma declared; absolute tracker data: synth
dualarm, 30 postures, two markers, sigma estimated).

- copied rows are not replicates: they never make a verdict (3 distinct
  rows copied 4 times more give "cannot judge", with the minimum), and a
  file of every row twice is judged as the file once;
- too few rows: "cannot judge: N distinct rows", the minimum named
  (ceil((identified parameters + MIN_RESIDUAL_DOF) / coordinates a row));
  the minimum itself is judged, one row fewer is not;
- a missing effect is found and proposed, in the same words;
- nothing in the catalogue fits, in the same words, in the text and JSON;
- the JSON of both kinds carries the same fields of the pipeline.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from stiffkit.calib import diagnosis as D
from stiffkit.calib.dualarm import synth_dualarm
from stiffkit.cli import main

KINDS = ("deflection", "absolute")


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    kr = tmp_path_factory.mktemp("kr")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["synth", "kr270", "--out", str(kr), "--configs", "4", "--seed", "3"]) == 0
    da = tmp_path_factory.mktemp("da")
    synth_dualarm(da, configs=30, seed=3)
    # (model, data, identified parameters of the start model, coordinates a row)
    return {
        "deflection": (kr / "model.toml", kr / "measurements.csv", 6, 3),
        "absolute": (da / "model.toml", da / "measurements.csv", 12, 3),
    }


def lines_of(path):
    return path.read_text().splitlines()


def write(path, lines):
    path.write_text("\n".join(lines) + "\n")
    return path


def run(capsys, *argv):
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_minimum_is_a_closed_form():
    assert D.MIN_RESIDUAL_DOF == 10
    assert D.min_rows(6, 3) == 6  # ceil(16 / 3)
    assert D.min_rows(12, 3) == 8  # ceil(22 / 3)
    assert D.min_rows(7, 6) == 3  # ceil(17 / 6)


@pytest.mark.parametrize("kind", KINDS)
def test_copied_rows_are_never_judged(cases, tmp_path, capsys, kind):
    """3 distinct rows, each copied 4 more times: no verdict from 15 rows
    (before: 'ADEQUATE' on 3 residual dof for deflections, a core error on
    tracker data)."""
    model, meas, p, k = cases[kind]
    m = lines_of(meas)
    f = write(tmp_path / "copies.csv", m[:4] + m[1:4] * 4)
    code, out, err = run(capsys, "diagnose", model, f, "--cv", "3")
    assert code == 2
    assert f"{f}: cannot judge: 3 distinct rows (12 more rows are exact copies" in err
    assert f"a verdict needs at least {D.min_rows(p, k)} distinct rows" in err
    assert "ADEQUATE" not in out.upper()


@pytest.mark.parametrize("kind", KINDS)
def test_too_few_rows_name_the_minimum_and_the_minimum_is_judged(cases, tmp_path, capsys, kind):
    model, meas, p, k = cases[kind]
    need = D.min_rows(p, k)
    m = lines_of(meas)
    few = write(tmp_path / "few.csv", m[:need])  # header + need - 1 rows
    code, out, err = run(capsys, "diagnose", model, few, "--cv", "3")
    assert code == 2, out
    assert f"{few}: cannot judge: {need - 1} distinct rows;" in err
    assert f"a verdict needs at least {need} distinct rows ({p} identified parameters + {D.MIN_RESIDUAL_DOF}" in err
    enough = write(tmp_path / "enough.csv", m[: need + 1])
    js = tmp_path / "d.json"
    code, out, err = run(capsys, "diagnose", model, enough, "--cv", "3", "--json", js)
    assert code == 0, err
    d = json.loads(js.read_text())
    assert d["verdict"] in ("adequate", "inadequate")
    assert d["n_rows_distinct"] == need and d["n_rows_copied"] == 0
    assert d["residual_dof"] >= D.MIN_RESIDUAL_DOF


@pytest.mark.parametrize("kind", KINDS)
def test_every_row_twice_is_judged_as_once(cases, tmp_path, capsys, kind):
    model, meas, _p, _k = cases[kind]
    m = lines_of(meas)
    twice = write(tmp_path / "twice.csv", m + m[1:])
    got = []
    for f in (meas, twice):
        js = tmp_path / f"{f.stem}.json"
        code, _out, err = run(capsys, "diagnose", model, f, "--cv", "3", "--json", js)
        assert code == 0, err
        got.append(json.loads(js.read_text()))
    once, two = got
    assert two["n_rows_copied"] == once["n_rows_distinct"] == len(m) - 1
    assert two["n_rows_distinct"] == once["n_rows_distinct"]
    assert two["verdict"] == once["verdict"] and two["dof"] == once["dof"]
    assert two["sigma_position_m"] == pytest.approx(once["sigma_position_m"], rel=1e-9)
    assert two["rms_position_m"] == pytest.approx(once["rms_position_m"], rel=1e-9)


@pytest.mark.parametrize("kind, want", [("deflection", ("link", "link_3")), ("absolute", ("joint_offset", "all"))])
def test_a_missing_effect_is_found_and_proposed_in_the_same_words(cases, tmp_path, capsys, kind, want):
    """The start models lack the truth's link springs (kr270) and joint
    offsets (dualarm): both propose it as a ready [[effect]] table after
    the same line, and the JSON's proposal is that table."""
    model, meas, _p, _k = cases[kind]
    js = tmp_path / "d.json"
    code, out, err = run(capsys, "diagnose", model, meas, "--cv", "3", "--json", js)
    assert code == 0, err
    d = json.loads(js.read_text())
    assert d["observation_kind"] == kind and d["verdict"] == "inadequate"
    assert "verdict: INADEQUATE" in out.splitlines()
    assert (d["proposal"]["kind"], d["proposal"].get("target")) == want
    head = out.split(D.PROPOSAL_LINE)
    assert len(head) == 2, out
    table = head[1].split("\n[[effect]]\n", 1)[1]
    assert f'kind = "{want[0]}"\ntarget = "{want[1]}"' in table
    assert not d["nothing_fits"] and d["no_proposal_reasons"] == []


@pytest.mark.parametrize("kind", KINDS)
def test_the_json_of_both_kinds_has_the_pipeline_fields(cases, tmp_path, capsys, kind):
    model, meas, _p, _k = cases[kind]
    js = tmp_path / "d.json"
    assert run(capsys, "diagnose", model, meas, "--cv", "3", "--json", js)[0] == 0
    d = json.loads(js.read_text())
    for key in D.JSON_FIELDS:
        assert key in d, key
    assert d["observation_kind"] == kind and d["min_residual_dof"] == D.MIN_RESIDUAL_DOF
    assert d["alpha"] == D.ALPHA and d["cv_folds"] == 3
    assert math.isfinite(d["log10_p_value"])


def test_nothing_fits_deflection_in_the_common_words():
    """Drift of the instrument (scenarios 'drift'): no catalogued kind has its shape."""
    from stiffkit.calib.diagnose import diagnose, format_diagnosis
    from stiffkit.calib.scenarios import make_scenario

    sc = make_scenario("drift", seed=1)
    dg = diagnose(sc.model, sc.meas)
    assert dg.nothing_fits and dg.proposal is None and dg.verdict == "inadequate"
    text = format_diagnosis(dg)
    assert D.NOTHING_FITS_LINE in text
    js = json.loads(json.dumps(dg.to_json()))
    assert js["nothing_fits"] is True and js["observation_kind"] == "deflection"


def test_nothing_fits_absolute_in_the_common_words(tmp_path):
    """Tracker drift (dualarm 'drift', 1.5 mm at the end) on a model with the
    truth's kinds on every joint and a declared sigma: nothing proposed,
    nothing fits, in the same words as for deflections."""
    from stiffkit.calib.absolute_diagnose import diagnose_absolute, format_absolute_diagnosis
    from stiffkit.calib.absolute_report import load_absolute
    from stiffkit.calib.dualarm import add_hidden_effect

    out = synth_dualarm(tmp_path / "drift", configs=60, seed=11)
    text = (out / "model.toml").read_text()
    text = text.replace('kind = "absolute"\n', 'kind = "absolute"\nsigma_position = 1e-4\n', 1)
    for k in ("frame", "joint", "joint_offset", "lateral"):
        text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
    (out / "model.toml").write_text(text)
    add_hidden_effect(out, "drift", 1.5e-3, 12)
    dg = diagnose_absolute(*load_absolute(out / "model.toml", out / "measurements.csv"))
    assert dg.nothing_fits and dg.proposal is None and dg.verdict == "inadequate"
    assert D.NOTHING_FITS_LINE in format_absolute_diagnosis(dg)
    js = json.loads(json.dumps(dg.to_json()))
    assert js["nothing_fits"] is True and js["observation_kind"] == "absolute"


@pytest.mark.parametrize("source", ["declared", "pure error", "residual"])
def test_the_shared_score_test_against_closed_forms(source):
    """score_blocks + fill_scores on random columns: the statistic is the
    residual's squared norm in the candidate's columns projected off the
    model's; the log p is scipy's chi-square or F tail of it."""
    from scipy import stats

    from stiffkit.calib.diagnose_candidates import Candidate

    rng = np.random.default_rng(5)
    n, p = 60, 4
    A = rng.normal(size=(n, p))
    r = rng.normal(size=n)
    r -= A @ np.linalg.lstsq(A, r, rcond=None)[0]  # a fitted residual: orthogonal to A
    blocks = [rng.normal(size=(n, 2)), rng.normal(size=(n, 3)) + r[:, None] * [0.3, 0.0, 0.1]]
    st, dof, pr = D.score_blocks(A, r, blocks)
    rss = float(r @ r)
    noise = D.Noise(0.7, source, n - p, 12 if source == "pure error" else None)
    for k, Z in enumerate(blocks):
        Zp = Z - A @ np.linalg.lstsq(A, Z, rcond=None)[0]
        proj = Zp @ np.linalg.lstsq(Zp, r, rcond=None)[0]
        assert dof[k] == Z.shape[1]
        assert st[k] == pytest.approx(float(proj @ proj), rel=1e-9)
        np.testing.assert_allclose(pr[:, k], proj, atol=1e-12)
        c = Candidate(kind="joint", target="j", effect={})
        D.fill_scores(c, st[k], int(dof[k]), noise, rss)
        d = Z.shape[1]
        if source == "declared":
            want = stats.chi2.logsf(st[k] / 0.7, d)
        elif source == "pure error":
            want = stats.f.logsf(st[k] / 0.7 / d, d, 12)
        else:
            want = stats.f.logsf((st[k] / d) / ((rss - st[k]) / (n - p - d)), d, n - p - d)
        assert c.log_p == pytest.approx(want, rel=1e-8, abs=1e-10)
        assert c.statistic == pytest.approx(st[k] / 0.7, rel=1e-12)
        assert c.explained_fraction == pytest.approx(st[k] / rss, rel=1e-12)
        if source == "residual":
            assert c.excess_fraction is None
        else:
            excess = rss / 0.7 - (n - p)
            assert c.excess_fraction == pytest.approx(max((st[k] / 0.7 - d) / excess, 0.0), rel=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_multiplicity_and_set_aside_rows_on_both_kinds(cases, tmp_path, capsys, kind):
    """Both kinds report the best candidate's p corrected for the number of
    candidates (Bonferroni's bound: min(1, n_tests p_best); deflections also
    the max-score test) and the rows the data checks set aside, as rows and
    file lines: here one row made a gross error (+50 mm in x for deflections
    of a few mm, +0.5 m for tracker points that the start model misses by
    20 mm)."""
    model, meas, _p, _k = cases[kind]
    m = lines_of(meas)
    head = m[0].split(",")
    ix = head.index("dx" if kind == "deflection" else "x")
    row = m[5].split(",")
    row[ix] = repr(float(row[ix]) + (0.05 if kind == "deflection" else 0.5))
    bad = write(tmp_path / "bad.csv", m[:5] + [",".join(row)] + m[6:])
    js = tmp_path / "d.json"
    code, _out, err = run(capsys, "diagnose", model, bad, "--cv", "3", "--json", js)
    assert code == 0, err
    d = json.loads(js.read_text())
    n = d["n_tests"]
    assert n == len(d["candidates"]) > 0
    p0 = d["candidates"][0]["p_value"]
    assert d["bonferroni_p"] == pytest.approx(min(1.0, n * p0), rel=1e-12, abs=1e-300)
    assert d["multiplicity_p"] is not None and str(n) in d["multiplicity_method"]
    aside = d["data_checks"]["set_aside"]
    assert 4 in aside["rows"] and 6 in aside["lines"]  # the sixth line of the file: row index 4


@pytest.mark.parametrize("kind", KINDS)
def test_few_residual_dof_warned_in_the_same_words(cases, tmp_path, capsys, kind):
    """At the minimum of rows both kinds judge, and both warn: 'few residual
    degrees of freedom: D of N observations (P parameters)' with the
    expected RMS sqrt(D / N) x the floor."""
    model, meas, p, k = cases[kind]
    need = D.min_rows(p, k)
    f = write(tmp_path / "enough.csv", lines_of(meas)[: need + 1])
    js = tmp_path / "d.json"
    code, _out, err = run(capsys, "diagnose", model, f, "--cv", "3", "--json", js)
    assert code == 0, err
    d = json.loads(js.read_text())
    dof, nobs = d["residual_dof"], need * k
    assert dof == nobs - p
    want = (
        f"few residual degrees of freedom: {dof} of {nobs} observations ({p} parameters); the tests have "
        f"little power and a fit absorbs part of the noise (expected RMS {math.sqrt(dof / nobs):.2f} x the noise floor)"
    )
    assert any(w.startswith(want) for w in d["warnings"]), d["warnings"]
    assert D.few_dof_warning(D.LOW_DOF, 2 * D.LOW_DOF, 3) is None


@pytest.mark.parametrize("kind", KINDS)
def test_cv_0_is_off_on_both_kinds_and_then_nothing_is_proposed(cases, tmp_path, capsys, kind):
    """Unified rule (issue 15): --cv 0 switches the cross-validation off on
    both kinds (tracker data used to take 5 folds); without the held-out
    check nothing is proposed, the verdict stands (both start models lack
    an effect)."""
    model, meas, _p, _k = cases[kind]
    js = tmp_path / "d.json"
    code, out, err = run(capsys, "diagnose", model, meas, "--cv", "0", "--json", js)
    assert code == 0, err
    d = json.loads(js.read_text())
    assert d["cv_folds"] == 0 and d["cv_rms_position_m"] is None
    # tracker data without a declared sigma: the best candidate's corrected (max-score) test decides
    assert d["verdict"] == "inadequate" and d["best_candidate_inadequate"] is True
    assert d["proposal"] is None and not d["nothing_fits"]
    assert D.NO_HELD_OUT in d["no_proposal_reasons"]
    assert D.PROPOSAL_LINE not in out


def test_the_held_out_check_is_one_rule():
    assert D.CV_GAIN == 0.02
    assert D.lowers_held_out(0.979, 1.0) and not D.lowers_held_out(0.981, 1.0)
    assert not D.lowers_held_out(None, 1.0) and not D.lowers_held_out(0.5, None)
    assert D.folds_of(["a", "b", "c"], 0) == [] and D.folds_of(["a", "a"], 5) == []
    assert [f.tolist() for f in D.folds_of(["a", "b", "a", "c"], 2)] == [[0, 2, 3], [1]]
