"""``[mesh] element = "hex20"`` (C3D20R) and ``"hex8"`` (C3D8).

Known truths: the node order proved by geometry (positive volumes, every
mid-side node at its edge midpoint), the weights of a flat quadrilateral
face in closed form (serendipity: -A/12 at the corners, A/3 at the
mid-sides; bilinear: A/4), a bar's axial compliance L/EA exactly with the
distributing support on any mesh, the two FEA routes against each other,
and the paper's beam against eq. 22 and against tetrahedra."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from stiffkit._core.sparse import face_weights
from stiffkit.fea import parse_link, run_link
from stiffkit.fea.config import ConfigError, paper_beam
from stiffkit.meshing import MeshError, mesh_part
from stiffkit.meshing.mesh import check_geometry, face_connectivity, faces_on_nodes, plane_nodes
from stiffkit.meshing.refine import hex_mesh

needs_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="needs CalculiX ccx")


@pytest.mark.parametrize("order, per", [(1, 8), (2, 20)])
def test_hex_mesh_node_order_and_faces(order, per):
    m = hex_mesh(np.array([0.0, -5, -5]), np.array([40.0, 5, 5]), 10.0, 0.5, order, 1e-3)
    assert m.elements.shape == (4 * 2 * 2, per) and m.ccx_type == ("C3D20R" if order == 2 else "C3D8")
    corners = 5 * 3 * 3
    edges = 4 * 3 * 3 + 5 * 2 * 3 + 5 * 3 * 2  # edges along x, y, z
    assert m.n_nodes == corners + (edges if order == 2 else 0)
    st = check_geometry(m)
    assert st["total_volume"] == pytest.approx(40e-3 * 10e-3 * 10e-3, rel=1e-12)
    # the x-max face: 4 element faces, their nodes on it, area 100 mm^2
    f = faces_on_nodes(m, plane_nodes(m, "x-max"))
    assert f.shape[0] == 4 and set(f[:, 1]) == {4}
    w, area = face_weights(m.nodes, face_connectivity(m, f))
    assert area == pytest.approx(100e-6, rel=1e-12) and w.sum() == pytest.approx(area, rel=1e-12)


def test_quad_face_weights_closed_form():
    x = np.array([[0, 0, 0], [2, 0, 0], [2, 3, 0], [0, 3, 0], [1, 0, 0], [2, 1.5, 0], [1, 3, 0], [0, 1.5, 0]], float)
    w8, a8 = face_weights(x, np.arange(1, 9)[None, :])
    assert a8 == pytest.approx(6.0, rel=1e-14)
    assert np.allclose(w8[:4], -6.0 / 12, rtol=1e-13) and np.allclose(w8[4:], 6.0 / 3, rtol=1e-13)
    w4, a4 = face_weights(x[:4], np.arange(1, 5)[None, :])
    assert a4 == pytest.approx(6.0, rel=1e-14) and np.allclose(w4, 1.5, rtol=1e-13)


L = 200.0  # mm: 10 x 10 mm bar, 5 mm along, 4 across


def _bar(route: str, element: str, load: str = "distributing") -> dict:
    c = paper_beam(5.0, route)
    c["geometry"]["size"] = [L, 10.0, 10.0]
    c["load"].update(reference_point=[L, 0.0, 0.0], coupling=load)
    c["support"]["coupling"] = "distributing"
    c["mesh"].pop("order")
    c["mesh"].update(element=element, features=True, across=4)
    return c


@needs_ccx
@pytest.mark.parametrize("load", ["distributing", "rigid"])
def test_hex20_bar_routes_and_axial_closed_form(tmp_path, load):
    """C3D20R, 3,665 nodes: k11 = L/EA to 1e-7 (distributing support and
    load); the matrix route and ccx's six steps (distributing load written
    as the same nodal forces) agree to 1e-6; bending within 0.1 % of
    Timoshenko (measured +0.05 %, the shear term is 0.19 % of eq. 22)."""
    a = run_link(parse_link(_bar("matrix", "hex20", load)), cache_dir=tmp_path)
    b = run_link(parse_link(_bar("ccx", "hex20", load)), cache_dir=tmp_path)
    assert a.mesh.ccx_type == "C3D20R" and a.mesh.n_nodes == 3665
    ka, kb = a.compliance.matrix, b.compliance.matrix
    assert np.abs(np.diag(ka) / np.diag(kb) - 1).max() <= 1e-6
    e = a.closed_form_errors()
    if load == "distributing":
        assert abs(e[0, 0]) <= 1e-7
    shear = 2 * (1 + 0.266) / (4 * 10 * (1 + 0.266) / (12 + 11 * 0.266)) * (10.0 / L) ** 2
    assert abs(e[1, 1] - shear) <= 1e-3 and abs(e[2, 2] - shear) <= 1e-3
    assert a.to_json()["mesh"]["element_type"] == "C3D20R"


@needs_ccx
def test_hex8_locks_in_bending(tmp_path):
    """C3D8 (full integration) on the same bar: axial exact, bending
    shear-locked (about 10 % too stiff at 4 across): a documented trait."""
    r = run_link(parse_link(_bar("matrix", "hex8")), cache_dir=tmp_path)
    e = r.closed_form_errors()
    assert r.mesh.ccx_type == "C3D8" and abs(e[0, 0]) <= 1e-7
    assert -0.2 < e[1, 1] < -0.02


@needs_ccx
@pytest.mark.slow  # 61k nodes: make test-slow
def test_paper_beam_hex20_against_eq22_and_tet10(tmp_path):
    """examples/beam.toml with element = "hex20" (8 across, 5 mm along:
    61,425 nodes against the tet10 default's 115,889): every non-zero
    element within 0.05 % of eq. 22 (measured max 0.048 %, k44), and within
    0.05 % of the tet10 default (the torsion of both is within the
    couplings' end-zone term; hex20 at 12 across: k44 +0.049 %)."""
    from stiffkit.fea import load_link

    base = load_link(Path(__file__).resolve().parents[1] / "examples" / "beam.toml").raw
    c = {k: dict(v) for k, v in base.items()}
    c["mesh"]["element"] = "hex20"
    r = run_link(parse_link(c, "beam.toml"), cache_dir=tmp_path)
    assert r.mesh.n_nodes == 61425 and r.mesh.ccx_type == "C3D20R"
    e = r.closed_form_errors()
    assert np.nanmax(np.abs(e)) <= 5e-4
    t = run_link(parse_link({k: dict(v) for k, v in base.items()}, "beam.toml"), cache_dir=tmp_path)
    nz = r.closed_form != 0
    assert np.abs(r.compliance.matrix[nz] / t.compliance.matrix[nz] - 1).max() <= 5e-4


def _brep(tmp_path, build) -> str:
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        path = tmp_path / "part.brep"
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return str(path)


def test_cad_box_meshes_with_hexahedra(tmp_path):
    step = _brep(tmp_path, lambda occ: occ.addBox(0, 0, 0, 60, 12, 8))
    m = mesh_part({"step": step}, "mm", 1e-3, order=2, size=4.0, element="hex")
    assert m.ccx_type == "C3D20R" and m.surface_tri.shape[1] == 4
    st = check_geometry(m)
    assert st["total_volume"] == pytest.approx(60e-3 * 12e-3 * 8e-3, rel=1e-12)
    assert st["max_midside_offset"] < 1e-9


@needs_ccx
def test_cad_box_hex20_face_selectors(tmp_path):
    """A CAD box meshed with C3D20R, clamped and loaded through CAD face
    ids (quadrilateral surface elements): k11 = L/EA exactly (distributing
    support and load)."""
    step = _brep(tmp_path, lambda occ: occ.addBox(0, -5, -5, 100, 10, 10))
    c = {
        "geometry": {"step": step, "units": "mm"},
        "material": {"E": 2.0e11, "nu": 0.266},
        "support": {"point": [0.0, 0.0, 0.0], "coupling": "distributing"},
        "load": {"point": [100.0, 0.0, 0.0], "reference_point": [100.0, 0.0, 0.0], "coupling": "distributing"},
        "mesh": {"element": "hex20", "size": 5.0},
    }
    r = run_link(parse_link(c, "box.toml"), cache_dir=tmp_path)
    k11 = 0.1 / (2.0e11 * 1e-4)
    assert r.mesh.ccx_type == "C3D20R"
    assert r.compliance.matrix[0, 0] / k11 - 1 == pytest.approx(0.0, abs=1e-7)
    assert r.solution.stats["load_face_area_m2"] == pytest.approx(1e-4, rel=1e-9)


def test_hex_needs_a_hexahedral_volume(tmp_path):
    def plate_with_hole(occ):
        b = occ.addBox(0.0, -20.0, 0.0, 100.0, 40.0, 4.0)
        h = occ.addCylinder(50.0, 0.0, -1.0, 0.0, 0.0, 6.0, 6.0)
        occ.cut([(3, b)], [(3, h)])

    step = _brep(tmp_path, plate_with_hole)
    with pytest.raises(MeshError, match=r"element = hex needs every volume to be a topological hexahedron.*volume 1"):
        mesh_part({"step": step}, "mm", 1e-3, order=2, size=4.0, element="hex")


@pytest.mark.parametrize(
    "mesh, fragment",
    [
        ({"element": "hex27"}, r"\[mesh\] element = 'hex27'"),
        ({"element": "hex20", "order": 1}, "order = 1 and element = 'hex20' disagree"),
        ({"element": "hex20", "mesher": "tetgen"}, 'element = .hex20. needs mesher = "gmsh"'),
        ({"element": "hex8", "refine": 0.5}, "is structured: no refine"),
    ],
)
def test_bad_element_keys(mesh, fragment):
    c = paper_beam(5.0)
    c["mesh"].pop("order")
    c["mesh"].update(mesh)
    with pytest.raises(ConfigError, match=fragment):
        parse_link(c, "beam.toml")
