"""Meshing of link CAD with Gmsh and TetGen, in CalculiX's node order."""

from .gmsh_mesh import mesh_part
from .mesh import (
    CCX_TET_FACES,
    PERM_GMSH_TET10,
    PERM_TETGEN_TET10,
    PLANES,
    Mesh,
    MeshError,
    check_geometry,
    face_connectivity,
    faces_on_nodes,
    midside_errors,
    plane_nodes,
    tet_volumes,
)

__all__ = [
    "mesh_part",
    "Mesh",
    "MeshError",
    "check_geometry",
    "plane_nodes",
    "faces_on_nodes",
    "face_connectivity",
    "tet_volumes",
    "midside_errors",
    "PERM_GMSH_TET10",
    "PERM_TETGEN_TET10",
    "CCX_TET_FACES",
    "PLANES",
]
