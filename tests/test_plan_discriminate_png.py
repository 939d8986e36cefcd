"""stiffkit plan --discriminate --png (issue 19): the figure of a
discrimination plan on both data kinds, and the numbers it plots
(calib.plan.discrimination_numbers) against direct projections with numpy
on the plan's own rows: the smallest noncentrality of the rows measured so
far, of each candidate added alone, of the plan (= its pairs) and of the
random designs the plan is compared with."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _plan_robots import P, tied_tree_files
from test_plan_discriminate_defl import LOADS, scenario_files, smallest_ncp

from stiffkit.calib.diagnose import diagnose
from stiffkit.calib.plan import discrimination_numbers
from stiffkit.calib.scenarios import make_scenario
from stiffkit.cli.app import main

K = 6
PNG = b"\x89PNG\r\n\x1a\n"


def _check_numbers(res: dict, cands: object, seed: int, k: int) -> dict:
    num = discrimination_numbers(res, cands, seed)
    f, jh, n0, nobs = res["rows"]
    ncand = (f.shape[0] - n0) // nobs
    pairs = np.asarray(res["pairs"])
    assert num["plan"] == pytest.approx(res["value"], rel=1e-9)
    assert num["plan"] == pytest.approx(min(pairs[0, 1], pairs[1, 0]), rel=1e-9)
    assert num["plan"] == pytest.approx(smallest_ncp(f, jh, n0, nobs, res["selected"]), rel=1e-7)
    assert num["before"] == pytest.approx(smallest_ncp(f, jh, n0, nobs, []), rel=1e-7, abs=1e-9)
    for c in (0, ncand // 2, ncand - 1):
        assert num["alone"][c] == pytest.approx(smallest_ncp(f, jh, n0, nobs, [c]), rel=1e-7, abs=1e-9)
    rng = np.random.default_rng(seed + 1)
    draws = [np.sort(rng.choice(ncand, k, replace=False)) for _ in range(P.RANDOM_DESIGNS)]
    assert num["random"] == pytest.approx([smallest_ncp(f, jh, n0, nobs, d) for d in draws], rel=1e-7, abs=1e-9)
    assert np.array_equal(num["selected"], res["selected"])
    return num


def test_deflection_discrimination_figure(tmp_path, capsys):
    sc = make_scenario("few_rows", seed=2)
    tie = diagnose(sc.model, sc.meas).ties[0]
    model, meas = scenario_files(tmp_path, sc)
    res, cands, _m = P.discriminate(model, K, meas, tie["candidates"], candidates=40, seed=3)
    num = _check_numbers(res, cands, 3, K)
    # the chosen (posture, load) pairs: their postures and which [plan] load each is under
    assert np.array_equal(num["q"], cands.q[res["posture"]])
    assert np.array_equal(np.asarray(LOADS, float)[num["load_index"]], res["loads"])
    print(
        f"deflection: plan {num['plan']:.4g}, random median {np.median(num['random']):.4g}, before {num['before']:.4g}"
    )
    assert num["plan"] > np.median(num["random"]) and num["plan"] > num["before"]
    png, rep = tmp_path / "disc.png", tmp_path / "disc.json"
    argv = ["plan", str(model), "--measured", str(meas), "--discriminate", ",".join(tie["candidates"])]
    argv += ["--select", str(K), "--candidates", "40", "--seed", "3", "--png", str(png), "--json", str(rep)]
    assert main(argv) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000
    doc = json.loads(rep.read_text())
    assert doc["random"]["median_value"] == pytest.approx(float(np.median(num["random"])), rel=1e-9)
    assert doc["before"] == pytest.approx(num["before"], rel=1e-9, abs=1e-12)
    assert f"median of {P.RANDOM_DESIGNS} random designs of {K}" in out


def test_tracker_discrimination_figure(tmp_path, capsys):
    """The small tree of test_plan.test_cli_discriminate: two link springs tied on 9 postures."""
    model, meas = tied_tree_files(tmp_path)
    tied = ["link:l_link1", "link:trunk_1"]
    res, cands, _m = P.discriminate(model, 5, meas, tied, candidates=60, seed=0)
    num = _check_numbers(res, cands, 0, 5)
    assert np.array_equal(num["q"], cands.q[res["selected"]]) and num["loads"] is None
    png = tmp_path / "disc.png"
    argv = ["plan", str(model), "--select", "5", "--candidates", "60", "--measured", str(meas)]
    assert main([*argv, "--discriminate", ",".join(tied), "--png", str(png)]) == 0, capsys.readouterr().err
    assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000
