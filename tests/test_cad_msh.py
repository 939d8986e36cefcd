"""A Gmsh .msh as the part (``[geometry] step = "part.msh"``): the mesh is
used as it is, and its physical groups name the faces (``group = "name"``).

Known truths: a box whose end faces are the physical groups "root" and
"tip" (their count and area to 1e-9), the axial compliance L/EA exactly
with distributing support and load, and the same mesh made from the BREP
of the box with face-id selectors (the same numbers)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from stiffkit.fea import parse_link, run_link
from stiffkit.fea.config import ConfigError
from stiffkit.fea.facesets import resolve_job_sets
from stiffkit.meshing import MeshError
from stiffkit.meshing.gmsh_mesh import cad_faces

L = 100.0


def _write(tmp_path, hexa: bool = False) -> tuple[str, str]:
    """part.msh (C3D10, or C3D20R with ``hexa``; groups root, tip, part) and
    part.brep of the same box."""
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addBox(0, -5, -5, L, 10, 10)
        gmsh.model.occ.synchronize()
        brep = tmp_path / "part.brep"
        gmsh.write(str(brep))
        faces = {}
        for _d, tag in gmsh.model.getEntities(2):
            x0, _y0, _z0, x1, _y1, _z1 = gmsh.model.getBoundingBox(2, tag)
            if x1 - x0 < 1e-6:
                faces["root" if x0 < 1 else "tip"] = tag
        for name, tag in faces.items():
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [tag]), name)
        gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, [1]), "part")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 4.0)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 4.0)
        if hexa:
            gmsh.model.mesh.setTransfiniteAutomatic(recombine=True)
            gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
        gmsh.option.setNumber("Mesh.ElementOrder", 2)
        gmsh.model.mesh.generate(3)
        msh = tmp_path / ("hex.msh" if hexa else "part.msh")
        gmsh.write(str(msh))
    finally:
        gmsh.finalize()
    return str(msh), str(brep)


def _link(step: str, support: dict, load: dict, mesh: dict | None = None) -> dict:
    return {
        "geometry": {"step": step, "units": "mm"},
        "material": {"E": 2.0e11, "nu": 0.266},
        "support": {**support, "coupling": "distributing"},
        "load": {**load, "reference_point": [L, 0.0, 0.0], "coupling": "distributing"},
        "mesh": mesh or {},
    }


def test_msh_groups_are_faces(tmp_path):
    msh, _brep = _write(tmp_path)
    faces, named, _d, box = cad_faces({"step": msh}, "mm")
    assert set(named) >= {"root", "tip"}
    by = {f.id: f for f in faces}
    for name, x in (("root", 0.0), ("tip", L)):
        (tag,) = named[name]
        f = by[tag]
        assert f.type == "Plane" and f.area == pytest.approx(100.0, rel=1e-9)
        assert f.centre == pytest.approx([x, 0.0, 0.0], abs=1e-9)
        assert np.abs(f.axis) == pytest.approx([1.0, 0.0, 0.0], abs=1e-12)
    assert box[3] - box[0] == pytest.approx(L, rel=1e-12)
    job = parse_link(_link(msh, {"group": "root"}, {"group": "tip"}), "msh.toml")
    sets = resolve_job_sets(job)
    assert sets.ids["support"] == named["root"] and sets.ids["load"] == named["tip"]


@pytest.mark.skipif(shutil.which("ccx") is None, reason="needs CalculiX ccx")
@pytest.mark.parametrize("hexa", [False, True])
def test_msh_link_matches_the_brep_and_L_over_EA(tmp_path, hexa):
    msh, brep = _write(tmp_path, hexa)
    el = "hex20" if hexa else "tet10"
    r = run_link(parse_link(_link(msh, {"group": "root"}, {"group": "tip"}, {"element": el}), "m.toml"), cache_dir=None)
    assert r.mesh.ccx_type == ("C3D20R" if hexa else "C3D10")
    assert r.solution.stats["load_face_area_m2"] == pytest.approx(1e-4, rel=1e-9)
    k11 = L * 1e-3 / (2.0e11 * 1e-4)
    assert r.compliance.matrix[0, 0] / k11 - 1 == pytest.approx(0.0, abs=1e-7)
    if not hexa:  # the BREP meshed by stiffkit at the same size: the same mesh, the same matrix
        c = _link(brep, {"plane": "x-min"}, {"plane": "x-max"}, {"size": 4.0, "features": False})
        b = run_link(parse_link(c, "b.toml"), cache_dir=None)
        assert b.mesh.n_nodes == r.mesh.n_nodes
        assert np.abs(b.compliance.matrix - r.compliance.matrix).max() <= 1e-9 * np.abs(b.compliance.matrix).max()


def test_msh_bad_inputs(tmp_path):
    msh, _brep = _write(tmp_path)
    with pytest.raises(ConfigError, match=r"\[mesh\] size: \[geometry\] step is a .msh"):
        parse_link(_link(msh, {"group": "root"}, {"group": "tip"}, {"size": 2.0}), "m.toml")
    job = parse_link(_link(msh, {"group": "root"}, {"group": "tip"}, {"element": "hex20"}), "m.toml")
    with pytest.raises(MeshError, match=r'holds C3D10 elements: set \[mesh\] element = "tet10"'):
        run_link(job, cache_dir=None)
    with pytest.raises(ConfigError, match="root"):
        resolve_job_sets(parse_link(_link(msh, {"group": "roots"}, {"group": "tip"}), "m.toml"))
