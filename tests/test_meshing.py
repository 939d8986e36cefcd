"""Meshing: CalculiX node order proven geometrically for both meshers,
face selection and its errors. Gmsh and TetGen really run."""

from __future__ import annotations

import numpy as np
import pytest

from stiffkit.meshing import (
    PERM_GMSH_TET10,
    Mesh,
    MeshError,
    check_geometry,
    face_connectivity,
    faces_on_nodes,
    mesh_part,
    midside_errors,
    plane_nodes,
    tet_volumes,
)

BOX = {"shape": "box", "size": [100.0, 10.0, 10.0]}
TUBE = {"shape": "tube", "length": 60.0, "outer_diameter": 20.0, "inner_diameter": 14.0}


@pytest.mark.parametrize("mesher", ["gmsh", "tetgen"])
def test_tet10_node_order_is_calculix(mesher):
    m = mesh_part(BOX, "mm", 1e-3, order=2, size=4.0, mesher=mesher)
    assert m.elements.shape[1] == 10 and m.ccx_type == "C3D10"
    vol = tet_volumes(m.nodes, m.elements)
    assert (vol > 0).all()
    assert vol.sum() == pytest.approx(0.1 * 0.01 * 0.01, rel=1e-9)
    # straight box edges: every mid-side node exactly at its edge midpoint
    assert midside_errors(m.nodes, m.elements).max() < 1e-9
    # every node is used and numbered 1..n
    assert np.array_equal(np.unique(m.elements), np.arange(1, m.n_nodes + 1))


@pytest.mark.parametrize("mesher", ["gmsh", "tetgen"])
def test_tet4_positive_volumes(mesher):
    m = mesh_part(BOX, "mm", 1e-3, order=1, size=4.0, mesher=mesher)
    assert m.elements.shape[1] == 4
    assert (tet_volumes(m.nodes, m.elements) > 0).all()


def test_wrong_permutation_is_caught():
    m = mesh_part(BOX, "mm", 1e-3, order=2, size=5.0)
    undo = np.argsort(PERM_GMSH_TET10)  # back to gmsh's own order
    bad = Mesh(nodes=m.nodes, elements=m.elements[:, undo])
    assert midside_errors(bad.nodes, bad.elements).max() > 0.4
    with pytest.raises(MeshError, match="mid-side"):
        check_geometry(bad)
    flipped = Mesh(nodes=m.nodes, elements=m.elements[:, [1, 0, 2, 3, 4, 6, 5, 8, 7, 9]])
    with pytest.raises(MeshError, match="non-positive volume"):
        check_geometry(flipped)


def test_curved_tube_quadratic_mesh():
    m = mesh_part(TUBE, "mm", 1e-3, order=2, size=3.0)
    st = check_geometry(m)
    area = np.pi / 4 * (0.020**2 - 0.014**2)
    assert st["total_volume"] == pytest.approx(area * 0.060, rel=2e-3)
    assert 0 < st["max_midside_offset"] < 0.25  # mid-nodes on the circles


def test_face_selection_and_faces():
    m = mesh_part(BOX, "mm", 1e-3, order=2, size=5.0)
    tip = plane_nodes(m, "x-max")
    assert np.allclose(m.nodes[tip - 1, 0], 0.1)
    faces = faces_on_nodes(m, tip)
    conn = face_connectivity(m, faces)
    assert conn.shape == (faces.shape[0], 6)
    assert np.isin(conn, tip).all()
    p = m.nodes[conn - 1]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    assert area == pytest.approx(1e-4, rel=1e-9)
    with pytest.raises(Exception, match="choose one of"):
        plane_nodes(m, "x-top")


def test_refinement_adds_nodes_near_the_tip():
    a = mesh_part(BOX, "mm", 1e-3, order=1, size=5.0)
    b = mesh_part(
        BOX,
        "mm",
        1e-3,
        order=1,
        size=5.0,
        refine=0.4,
        refine_radius=20.0,
        refine_points=[[100.0, 0.0, 0.0]],
        refine_planes=["x-min"],
    )
    near = lambda m: int((m.nodes[:, 0] > 0.09).sum())  # noqa: E731
    assert near(b) > 2 * near(a)


def test_not_a_solid_and_missing_file(tmp_path):
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addRectangle(0, 0, 0, 10, 5)
        gmsh.model.occ.synchronize()
        gmsh.write(str(tmp_path / "sheet.step"))
    finally:
        gmsh.finalize()
    with pytest.raises(MeshError, match="not a solid"):
        mesh_part({"step": str(tmp_path / "sheet.step")}, "mm", 1e-3, order=1, size=2.0)
    with pytest.raises(Exception, match="not found"):
        mesh_part({"step": str(tmp_path / "nope.step")}, "mm", 1e-3, order=1, size=2.0)


def test_netgen_optimised_mesh_is_valid():
    m = mesh_part(BOX, "mm", 1e-3, order=2, size=4.0, optimize="netgen")
    st = check_geometry(m)
    assert st["total_volume"] == pytest.approx(1e-5, rel=1e-9)
    assert midside_errors(m.nodes, m.elements).max() < 1e-9
    with pytest.raises(Exception, match="none or netgen"):
        mesh_part(BOX, "mm", 1e-3, order=2, size=4.0, optimize="fast")


def test_structured_box_mesh_is_valid_calculix_c3d10():
    # 100 x 10 x 10 mm, size 5 along, 0.5 x 5 = 2.5 across: 20 x 4 x 4 hex cells of six tets
    m = mesh_part(BOX, "mm", 1e-3, order=2, size=5.0, structured=True, across_factor=0.5)
    assert m.elements.shape == (20 * 4 * 4 * 6, 10) and m.ccx_type == "C3D10"
    assert m.n_nodes == 41 * 9 * 9  # the half-cell grid, nothing else
    st = check_geometry(m)
    assert (tet_volumes(m.nodes, m.elements) > 0).all()
    assert st["total_volume"] == pytest.approx(1e-5, rel=1e-9)
    assert midside_errors(m.nodes, m.elements).max() < 1e-9
    assert np.array_equal(np.unique(m.elements), np.arange(1, m.n_nodes + 1))
    assert m.info["structured"] is True
    # every corner on the regular grid: x in steps of 5 mm, y and z of 2.5 mm
    corners = m.nodes[np.unique(m.elements[:, :4]) - 1] * 1e3
    for axis, step in ((0, 5.0), (1, 2.5), (2, 2.5)):
        v = (corners[:, axis] - corners[:, axis].min()) / step
        assert np.abs(v - np.round(v)).max() < 1e-9
    # the tip face is a structured grid too: its faces are found as usual
    tip = plane_nodes(m, "x-max")
    assert tip.size == 9 * 9 and faces_on_nodes(m, tip).shape[0] == 4 * 4 * 2


def test_structured_only_for_the_box():
    with pytest.raises(Exception, match="structured.*box"):
        mesh_part(TUBE, "mm", 1e-3, order=2, size=3.0, structured=True)
    with pytest.raises(Exception, match="across_factor"):
        mesh_part(BOX, "mm", 1e-3, order=2, size=5.0, structured=True, across_factor=1.5)
