"""Face selectors on Gmsh-made parts with known faces: each selector picks
the faces the CAD has, their count and total area equal to 1e-9 (areas
from OpenCASCADE against the closed forms), and the mesh sets built on them
(docs/link.md, issue 18)."""

from __future__ import annotations

import numpy as np
import pytest
from _cad_parts import PLATE, plate_areas, plate_geo, plate_step

from stiffkit.fea.config import parse_link
from stiffkit.fea.facesets import mesh_set, resolve_job_sets
from stiffkit.fea.solve import mesh_job, support_and_load
from stiffkit.meshing.gmsh_mesh import cad_faces

A = plate_areas()


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    return plate_step(tmp_path_factory.mktemp("plate") / "plate.step")


@pytest.fixture(scope="module")
def plate_g(tmp_path_factory):
    return plate_geo(tmp_path_factory.mktemp("plategeo") / "plate.geo")


def link(part, support, load, field=None, size=10.0):
    cfg = {
        "geometry": {"step": str(part), "units": "mm"},
        "material": {"E": 2.0e11, "nu": 0.3},
        "support": support,
        "load": load,
        "mesh": {"size": size, "features": False},
    }
    if field:
        cfg["field"] = field
    return parse_link(cfg, "sel.toml")


def picked(part, sel):
    """(ids, total CAD area) the [load] selector `sel` picks."""
    job = link(part, {"plane": "x-max"}, sel)
    cad = resolve_job_sets(job)
    faces = cad.by_id(cad.ids["load"])
    return cad.ids["load"], sum(f.area for f in faces), faces


def _id(part, pred):
    faces, *_ = cad_faces({"step": str(part)}, "mm")
    hit = [f.id for f in faces if pred(f)]
    assert len(hit) == 1
    return hit[0]


def test_cylinder_selector_picks_the_bore(plate):
    (x, y), r = PLATE["holes"][0]
    ids, area, faces = picked(plate, {"cylinder": {"axis": [0, 0, 1], "point": [x, y, 0.0], "radius": r}})
    assert len(ids) == 1 and area == pytest.approx(A["hole1"], rel=1e-9)
    assert faces[0].radius == pytest.approx(r, rel=1e-12)
    np.testing.assert_allclose(np.abs(faces[0].axis), [0, 0, 1], atol=1e-12)
    # the axis is a line: any point of it and either direction select the same face
    ids2, *_ = picked(plate, {"cylinder": {"axis": [0, 0, -2], "point": [x, y, 55.0], "radius": r}})
    assert ids2 == ids


def test_two_cylinders_act_as_one_set(plate):
    cyl = [{"axis": [0, 0, 1], "point": [x, y, 0.0], "radius": r} for (x, y), r in PLATE["holes"]]
    ids, area, _ = picked(plate, {"cylinder": cyl})
    assert len(ids) == 2 and area == pytest.approx(A["hole1"] + A["hole2"], rel=1e-9)


def test_face_point_box_selectors(plate):
    top = _id(plate, lambda f: f.type == "Plane" and abs(f.centre[2] - 20) < 1e-9)
    ids, area, _ = picked(plate, {"face": top})
    assert ids == [top] and area == pytest.approx(A["top"], rel=1e-9)
    ids, area, _ = picked(plate, {"point": [0.0, 20.0, 10.0]})  # on the x = 0 end
    assert len(ids) == 1 and area == pytest.approx(A["end_x"], rel=1e-9)
    ids, area, _ = picked(plate, {"point": [[0.0, 20.0, 10.0], [100.0, 5.0, 5.0]]})
    assert len(ids) == 2 and area == pytest.approx(2 * A["end_x"], rel=1e-9)
    # faces wholly inside a slab at y in [0, 0.5]: only the y = 0 side
    ids, area, _ = picked(plate, {"box": [-1.0, -1.0, -1.0, 101.0, 0.5, 21.0]})
    assert len(ids) == 1 and area == pytest.approx(A["side_y"], rel=1e-9)
    # a box around the small hole: its bore only
    ids, area, _ = picked(plate, {"box": [64.0, 14.0, -1.0, 76.0, 26.0, 21.0]})
    assert len(ids) == 1 and area == pytest.approx(A["hole1"], rel=1e-9)


def test_group_selector_from_a_geo_script(plate_g):
    ids, area, _ = picked(plate_g, {"group": "bores"})
    assert len(ids) == 2 and area == pytest.approx(A["hole1"] + A["hole2"], rel=1e-9)
    ids, area, _ = picked(plate_g, {"group": ["small_bore", "end"]})
    assert len(ids) == 2 and area == pytest.approx(A["hole1"] + A["end_x"], rel=1e-9)


def test_mesh_sets_on_cad_faces_and_planes(plate):
    """The mesh set of a flat CAD face has the face's area (flat triangles:
    exact); a plane selector and the CAD face on that plane give the same
    nodes; a bore's set lies on its cylinder."""
    job = link(
        plate,
        {"plane": "x-min"},
        {"cylinder": {"axis": [0, 0, 1], "point": [70.0, 20.0, 0.0], "radius": 5.0}},
        field={"point": [0.0, 20.0, 10.0]},
    )
    cad = resolve_job_sets(job)
    mesh = mesh_job(job)
    fixed, load, faces = support_and_load(job, mesh, cad)
    fnodes, ffaces = mesh_set(job, mesh, "field", cad, None)
    np.testing.assert_array_equal(np.sort(fixed), np.sort(fnodes))
    from stiffkit._core.sparse import face_weights
    from stiffkit.meshing import face_connectivity

    _w, area = face_weights(mesh.nodes, face_connectivity(mesh, ffaces))
    assert area == pytest.approx(A["end_x"] * 1e-6, rel=1e-9)
    r = np.hypot(mesh.nodes[load - 1, 0] - 0.070, mesh.nodes[load - 1, 1] - 0.020)
    np.testing.assert_allclose(r, 0.005, rtol=1e-6)
    _w, area = face_weights(mesh.nodes, face_connectivity(mesh, faces))
    assert area == pytest.approx(A["hole1"] * 1e-6, rel=2e-3)  # curved quadratic faces


def test_the_bored_link_example_selects_its_bores():
    """examples/bored_link.toml: the bearing bore by its .geo group, the
    pin hole by a cylinder; the reference point defaults to the pin axis."""
    from pathlib import Path

    from stiffkit.fea.config import load_link

    job = load_link(Path(__file__).resolve().parents[1] / "examples" / "bored_link.toml")
    assert job.reference_point is None and job.coupling == "rigid"
    cad = resolve_job_sets(job)
    (bore,), (pin,) = cad.by_id(cad.ids["support"]), cad.by_id(cad.ids["load"])
    assert bore.radius == pytest.approx(8.0, rel=1e-12) and bore.area == pytest.approx(2 * np.pi * 8 * 16, rel=1e-9)
    assert pin.radius == pytest.approx(4.0, rel=1e-12) and pin.area == pytest.approx(2 * np.pi * 4 * 16, rel=1e-9)
    np.testing.assert_allclose(pin.point, [140.0, 0.0, 0.0], atol=1e-6)
