"""Pieces of the FEA pipeline on their own: Richardson extrapolation,
automatic amplitudes, field regions, LINK.toml checks."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from stiffkit.fea.config import ConfigError, parse_link
from stiffkit.fea.convergence import richardson
from stiffkit.fea.job import auto_amplitudes, beam_estimate, select_field
from stiffkit.meshing import mesh_part, plane_nodes

BASE = {
    "geometry": {"shape": "box", "size": [100.0, 10.0, 10.0], "units": "mm"},
    "material": {"E": 2.0e11, "nu": 0.266},
    "support": {"plane": "x-min"},
    "load": {"plane": "x-max", "reference_point": [100.0, 0.0, 0.0]},
    "mesh": {"size": 5.0},
}


def test_richardson_two_meshes_assumes_p2():
    k0 = np.eye(6)
    vals = np.array([k0 * (1 + 0.01 * hh**2) for hh in (4.0, 2.0)])
    est, p, observed = richardson(np.array([4.0, 2.0]), vals)
    assert not observed and p == 2.0 and np.allclose(est, k0)


@pytest.mark.parametrize("p", [1.0, 2.0, 3.5])
def test_richardson_recovers_limit_and_order(p):
    h = np.array([5.0, 3.0, 2.0])
    k0 = np.arange(1.0, 37.0).reshape(6, 6)
    vals = np.array([k0 * (1 + 0.01 * hh**p) for hh in h])
    est, p_est, observed = richardson(h, vals)
    assert observed and p_est == pytest.approx(p, rel=1e-6)
    assert np.allclose(est, k0, rtol=1e-9)


def test_auto_amplitudes_rule():
    # translation-bound and rotation-bound cases; rounding down to 1-2-5
    k = np.zeros((6, 6))
    k[0, 0] = 1e-9  # 0.25 mm / 1e-9 = 2.5e5 -> 2e5
    k[1, 1], k[5, 1] = 1e-3, 1e-6
    k[2, 2], k[4, 2] = 1e-6, 1.0  # rotation-bound: 0.1 deg / 1 = 1.745e-3 -> 1e-3
    k[3, 3] = 1e-2  # 0.1 deg / 1e-2 = 0.1745 -> 0.1
    k[4, 4] = k[5, 5] = 4e-3
    a = auto_amplitudes(k)
    assert a.tolist() == [2e5, 0.2, 1e-3, 0.1, 0.2, 0.2]


def test_beam_estimate_rotates_to_the_load_axis():
    job = parse_link(copy.deepcopy(BASE))
    m = mesh_part(job.geometry, "mm", 1e-3, order=1, size=5.0)
    kx = beam_estimate(job, m)
    assert kx[0, 0] == pytest.approx(0.1 / (2e11 * 1e-4))
    # the same bar along z, loaded on z-max: axial compliance moves to k33
    m.nodes = m.nodes[:, [1, 2, 0]]  # (x, y, z) -> (y, z, x)
    job2 = parse_link(copy.deepcopy(BASE))
    job2.geometry = {"step": "dummy.step"}  # not a built-in shape: bounding-box estimate
    job2.support_plane, job2.load_plane = "z-min", "z-max"
    kz = beam_estimate(job2, m)
    assert kz[2, 2] == pytest.approx(kx[0, 0], rel=1e-12)
    assert kz[0, 0] == pytest.approx(kx[1, 1], rel=1e-12)


def test_field_regions():
    job = parse_link(copy.deepcopy(BASE))
    m = mesh_part(job.geometry, "mm", 1e-3, order=2, size=2.5)
    tip = plane_nodes(m, "x-max")
    face = select_field(job, m, tip)
    assert np.array_equal(face, tip)
    job.region, job.region_size = "layer", 0.0051
    layer = select_field(job, m, tip)
    assert (m.nodes[layer - 1, 0] >= 0.1 - 0.0051 - 1e-12).all() and layer.size > 2 * tip.size
    job.region, job.region_size = "cube", 0.010
    cube = select_field(job, m, tip)
    assert (np.abs(m.nodes[cube - 1] - [0.1, 0, 0]) <= 0.005 + 1e-12).all()
    job.region_size = 1e-5
    with pytest.raises(Exception, match="selects"):
        select_field(job, m, tip)


@pytest.mark.parametrize(
    "section,key,value,needle",
    [
        ("geometry", "units", "furlong", "units"),
        ("geometry", "size", [100.0, 10.0], "three positive"),
        ("material", "E", -1.0, "positive"),
        ("load", "reference_point", [1.0, 2.0], "three coordinates"),
        ("load", "amplitudes", [1.0, 1.0], "six positive"),
        ("load", "coupling", "glued", "choose one of"),
        ("mesh", "size", 0.0, "positive"),
        ("fit", "trim", 0.6, "fraction"),
        ("fit", "pooled", "yes", "true or false"),
    ],
)
def test_config_errors_name_the_key(section, key, value, needle):
    cfg = copy.deepcopy(BASE)
    cfg.setdefault(section, {})[key] = value
    with pytest.raises(ConfigError) as exc:
        parse_link(cfg, "bad.toml")
    assert "bad.toml" in str(exc.value) and key in str(exc.value) and needle in str(exc.value)


def test_mm_are_converted_at_the_boundary():
    job = parse_link(copy.deepcopy(BASE))
    assert job.reference_point == [0.1, 0.0, 0.0] and job.size_m == pytest.approx(0.005)
    L, sec, dims = job.closed_form_shape()
    assert L == pytest.approx(0.1) and sec == "rectangle" and dims == pytest.approx([0.01, 0.01])


def test_demo_runs_the_fea_beam(capsys):
    from stiffkit.fea.demo import fea_demo

    out = fea_demo(size=5.0)
    err = out["errors"]
    assert abs(err[0, 0]) < 2e-3 and abs(err[1, 1]) < 2e-3 and abs(err[4, 4]) < 2e-3
    assert out["nodes"] > 8000
    text = capsys.readouterr().out
    assert "closed form" in text and "CHOLMOD" in text


@pytest.mark.parametrize(
    "geometry,mesh,needle",
    [
        (
            {"shape": "tube", "length": 100.0, "outer_diameter": 20.0, "inner_diameter": 10.0},
            {"structured": True},
            'only for the built-in [geometry] shape = "box", not tube',
        ),
        (None, {"structured": "yes"}, "true or false"),
        (None, {"structured": True, "mesher": "tetgen"}, 'needs mesher = "gmsh"'),
        (None, {"structured": True, "refine": 0.5}, "refine"),
        (None, {"structured": True, "optimize": "netgen"}, 'optimize = "none"'),
        (None, {"structured": True, "across_factor": 0.0}, "(0, 1]"),
        (None, {"across_factor": 0.5}, "needs structured = true"),
    ],
)
def test_structured_mesh_config_errors(geometry, mesh, needle):
    cfg = copy.deepcopy(BASE)
    if geometry:
        cfg["geometry"] = {**geometry, "units": "mm"}
    cfg["mesh"].update(mesh)
    with pytest.raises(ConfigError) as exc:
        parse_link(cfg, "bad.toml")
    text = str(exc.value)
    assert text.startswith("bad.toml: [mesh] ") and needle in text, text


def test_structured_mesh_step_file_is_refused(tmp_path):
    step = tmp_path / "part.step"
    step.write_text("ISO-10303-21;")  # only its existence is checked here
    cfg = copy.deepcopy(BASE)
    cfg["geometry"] = {"step": "part.step", "units": "mm"}
    cfg["mesh"]["structured"] = True
    with pytest.raises(
        ConfigError,
        match=r"bad.toml: \[mesh\] structured = true is only for the "
        r"built-in .*step = 'part.step'",
    ):
        parse_link(cfg, "bad.toml", tmp_path)


def test_structured_mesh_is_in_the_cache_key():
    from stiffkit.fea.job import cache_key

    base = parse_link(copy.deepcopy(BASE))
    cfg = copy.deepcopy(BASE)
    cfg["mesh"]["structured"] = True
    st = parse_link(cfg)
    cfg["mesh"]["across_factor"] = 0.5
    st2 = parse_link(cfg)
    keys = {cache_key(j, "matrix") for j in (base, st, st2)}
    assert len(keys) == 3
    assert not base.structured and base.across_factor == 1.0
