"""Geometry and tetrahedral meshes with Gmsh (OpenCASCADE kernel) and TetGen.

Built-in shapes run along +x from x = 0, centred on y = z = 0 (box, tube,
rod); any CAD file OCC reads (STEP, BREP, IGES) is meshed as it is. Lengths
are in the geometry's own unit (``scale`` converts them to metres); the
returned :class:`~stiffkit.meshing.mesh.Mesh` is in metres and in CalculiX
node order.
"""

from __future__ import annotations

import logging
import signal
import tempfile
import threading
import time
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np

from ..errors import InputError, PlausibilityWarning
from .faces import CadFace, distances, faces_of_model, groups, surface_triangles
from .mesh import PERM_GMSH_HEX20, PERM_GMSH_TET10, Mesh, MeshError, check_geometry
from .refine import (
    estimate_nodes,
    feature_fields,
    hex_mesh,
    plane_surfaces,
    prism_across_factor,
    prism_mesh,
    set_background,
)
from .tetgen_mesh import tetgen_mesh

logger = logging.getLogger(__name__)

CAD_SUFFIXES = {
    ".step": "STEP",
    ".stp": "STEP",
    ".brep": "BREP",
    ".brp": "BREP",
    ".iges": "IGES",
    ".igs": "IGES",
    ".geo": "Gmsh .geo",
    ".msh": "Gmsh .msh",
}
#: geometry unit -> OpenCASCADE target unit of STEP/IGES import
OCC_UNITS = {"mm": "MM", "m": "M", "cm": "CM", "in": "INCH"}


def _python_signals() -> None:
    """Give SIGINT and SIGTERM back to Python: gmsh's initialisation installs
    C handlers for them that end the process at once, so a Ctrl-C or a
    SIGTERM later in the run (while ccx runs) would skip every cleanup."""
    if threading.current_thread() is not threading.main_thread():
        return
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if handler is not None:
            signal.signal(sig, handler)


#: tetrahedra a mesh may have (about 6 per cube of the element size): beyond
#: the warning it takes minutes and gigabytes, beyond the limit more memory
#: than a workstation has
TETS_WARN, TETS_LIMIT = 2.0e6, 3.0e7


def _check_count(volume: float, size: float, units: str, where: str) -> None:
    est = 6.0 * volume / size**3
    if est > TETS_LIMIT:
        raise MeshError(
            f"{where}: element size {size:g} {units} would need about {est:.2g} tetrahedra (the part's volume is "
            f"{volume:.4g} {units}^3); at most {TETS_LIMIT:.0e}: give a larger size"
        )
    if est > TETS_WARN:
        warnings.warn(
            PlausibilityWarning(
                f"{where}: element size {size:g} {units} gives about {est:.2g} tetrahedra: expect a long run and "
                "several GB of memory (is the size in the geometry's unit?)"
            ),
            stacklevel=3,
        )


def _gmsh() -> ModuleType:
    try:
        import gmsh
    except ImportError as exc:  # pragma: no cover - installed by make
        raise InputError(f"the gmsh Python module is not installed ({exc}); run `make install`") from None
    return gmsh


def _add_geometry(gmsh: ModuleType, geometry: dict, units: str) -> None:
    """Add the solid to the current gmsh model (OCC) and synchronise."""
    occ = gmsh.model.occ
    shape = geometry.get("shape")
    if shape == "box":
        L, b, h = geometry["size"]
        occ.addBox(0.0, -b / 2, -h / 2, L, b, h)
    elif shape in ("tube", "rod"):
        L = geometry["length"]
        ro = geometry["outer_diameter"] / 2
        ri = geometry.get("inner_diameter", 0.0) / 2 if shape == "tube" else 0.0
        outer = occ.addCylinder(0.0, 0.0, 0.0, L, 0.0, 0.0, ro)
        if ri > 0:
            inner = occ.addCylinder(0.0, 0.0, 0.0, L, 0.0, 0.0, ri)
            occ.cut([(3, outer)], [(3, inner)])
    elif "step" in geometry:
        path = Path(geometry["step"])
        kind = CAD_SUFFIXES.get(path.suffix.lower())
        if kind is None:
            raise InputError(
                f"{path}: unknown CAD format {path.suffix!r}; use STEP (.step/.stp), BREP (.brep) or IGES (.iges/.igs)"
            )
        if not path.is_file():
            raise InputError(f"{path}: CAD file not found")
        gmsh.option.setString("Geometry.OCCTargetUnit", OCC_UNITS.get(units, "MM"))
        try:
            if kind in ("Gmsh .geo", "Gmsh .msh"):  # its physical groups name faces
                gmsh.merge(str(path))
            else:
                occ.importShapes(str(path))
        except Exception as exc:
            raise MeshError(f"{path}: OpenCASCADE cannot read this {kind} file ({exc})") from None
    else:
        raise InputError("geometry: give `step` (a CAD file) or `shape` = box | tube | rod")
    if not is_msh(geometry):  # a .msh holds discrete entities only
        occ.synchronize()
    vols = gmsh.model.getEntities(3)
    where = geometry.get("step", geometry.get("shape"))
    if not vols:
        nsurf = len(gmsh.model.getEntities(2))
        raise MeshError(
            f"{where}: not a solid: the geometry holds no closed volume "
            f"({nsurf} surface(s)); stiffkit meshes one closed solid"
        )
    if len(vols) > 1:
        raise MeshError(
            f"{where}: {len(vols)} separate solids; stiffkit meshes one closed solid (fuse the bodies in CAD first)"
        )


def _refinement(
    gmsh: ModuleType, size: float, refine: float, radius: float, points: list, planes: list, extra: tuple = ()
) -> None:
    """Background size field: `refine * size` near the given points and
    axis-aligned planes ((axis, value)), growing to `size` at `radius`;
    ``extra``: (field ids, their smallest size) of the features' fields."""
    fields = list(extra[0]) if extra else []
    for expr in [f"Sqrt((x-({p[0]}))^2+(y-({p[1]}))^2+(z-({p[2]}))^2)" for p in points] + [
        f"Fabs({'xyz'[a]}-({v}))" for a, v in planes
    ]:
        f = gmsh.model.mesh.field.add("MathEval")
        gmsh.model.mesh.field.setString(f, "F", expr)
        t = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(t, "InField", f)
        gmsh.model.mesh.field.setNumber(t, "SizeMin", refine * size)
        gmsh.model.mesh.field.setNumber(t, "SizeMax", size)
        gmsh.model.mesh.field.setNumber(t, "DistMin", 0.0)
        gmsh.model.mesh.field.setNumber(t, "DistMax", radius)
        fields.append(t)
    if fields:
        m = gmsh.model.mesh.field.add("Min")
        gmsh.model.mesh.field.setNumbers(m, "FieldsList", fields)
        gmsh.model.mesh.field.setAsBackgroundMesh(m)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMin", min(refine * size, extra[1] if extra else size))


def _structured_box(gmsh: ModuleType, size: float, across_factor: float) -> None:
    """Transfinite (structured) mesh of the box: every edge cut into
    ceil(length / s) equal divisions, s = ``size`` along the box's longest
    side and ``across_factor * size`` along the other two (the section);
    no recombination, so each hex cell is split into six tetrahedra."""
    ext = [hi - lo for lo, hi in zip(*np.split(np.array(gmsh.model.getBoundingBox(-1, -1)), 2))]
    along = int(np.argmax(ext))
    for dim, tag in gmsh.model.getEntities(1):
        lo_hi = np.array(gmsh.model.getBoundingBox(dim, tag))
        d = lo_hi[3:] - lo_hi[:3]
        axis = int(np.argmax(d))
        s = size if axis == along else across_factor * size
        # OCC pads bounding boxes by ~1e-7: a relative tolerance keeps 10 / 5 at 2
        n = max(1, int(np.ceil(d[axis] / s * (1 - 1e-6))))
        gmsh.model.mesh.setTransfiniteCurve(tag, n + 1)
    for _dim, tag in gmsh.model.getEntities(2):
        gmsh.model.mesh.setTransfiniteSurface(tag)
    for _dim, tag in gmsh.model.getEntities(3):
        gmsh.model.mesh.setTransfiniteVolume(tag)


def is_msh(geometry: dict) -> bool:
    """True for a Gmsh .msh given as the part: a mesh, used as it is."""
    return str(geometry.get("step", "")).lower().endswith(".msh")


#: gmsh element type -> (nodes, CalculiX type)
_MSH_SOLIDS = {4: (4, "C3D4"), 11: (10, "C3D10"), 5: (8, "C3D8"), 17: (20, "C3D20R")}


def _mesh_from_msh(geometry: dict, units: str, scale: float, order: int, element: str) -> Mesh:
    """The mesh of a Gmsh .msh file as it is (no meshing): its solid
    elements (one kind: C3D4, C3D10, C3D8 or C3D20R, matching [mesh]
    element/order), and its surface elements with the entity each lies on
    (the faces its physical groups name)."""
    path = geometry["step"]
    want = {("tet", 1): 4, ("tet", 2): 10, ("hex", 1): 8, ("hex", 2): 20}[element, order]
    gmsh = _gmsh()
    t0 = time.perf_counter()
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    _python_signals()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("msh")
        _add_geometry(gmsh, geometry, units)
        kinds = {int(t) for _d, v in gmsh.model.getEntities(3) for t in gmsh.model.mesh.getElementTypes(3, v)}
        solid = [t for t in kinds if t in _MSH_SOLIDS]
        names = ", ".join(_MSH_SOLIDS[t][1] for t in sorted(solid)) or "none"
        if len(solid) != 1 or kinds - set(solid):
            raise MeshError(
                f"{path}: the .msh must hold one kind of solid element (C3D4, C3D10, C3D8 or C3D20R); it holds "
                f"{names}{' and others' if kinds - set(solid) else ''} (save the volume's physical group, or "
                "Mesh.SaveAll = 1)"
            )
        etype = solid[0]
        if _MSH_SOLIDS[etype][0] != want:
            el = {4: "tet4", 10: "tet10", 8: "hex8", 20: "hex20"}[_MSH_SOLIDS[etype][0]]
            raise MeshError(f'{path}: the .msh holds {_MSH_SOLIDS[etype][1]} elements: set [mesh] element = "{el}"')
        if etype in (5, 17):
            mesh = _collect_hex(gmsh, 2 if etype == 17 else 1, scale)
        else:
            mesh = _collect_gmsh(gmsh, 2 if etype == 11 else 1, scale)
            mesh.surface_tri, mesh.surface_tag = surface_triangles(gmsh)
        if mesh.surface_tri is None or mesh.surface_tri.size == 0:
            warnings.warn(
                f"{path}: the .msh holds no surface elements on the part's boundary: only plane selectors work",
                PlausibilityWarning,
                stacklevel=2,
            )
    finally:
        gmsh.finalize()
    p = mesh.nodes[mesh.elements[:, :2] - 1]
    mesh.size_m = float(np.median(np.linalg.norm(p[:, 1] - p[:, 0], axis=1)))
    mesh.mesher = "gmsh"
    lo, hi = mesh.bbox()
    mesh.info["extent"] = [float(v) for v in (hi - lo) / scale]
    mesh.info["msh"] = str(path)
    mesh.info["time_s"] = time.perf_counter() - t0
    mesh.info.update(check_geometry(mesh))
    return mesh


def mesh_part(
    geometry: dict,
    units: str,
    scale: float,
    order: int = 2,
    size: float = 5.0,
    mesher: str = "gmsh",
    refine: float | None = None,
    refine_radius: float | None = None,
    refine_points: list | None = None,
    refine_planes: list | None = None,
    workdir: str | Path | None = None,
    tetgen_timeout: float = 600.0,
    optimize: str = "none",
    structured: bool = False,
    across_factor: float = 1.0,
    source: str | None = None,
    features: dict | None = None,
    element: str = "tet",
) -> Mesh:
    """Mesh one solid with quadratic (order 2, C3D10) or linear (order 1,
    C3D4) tetrahedra of about ``size`` (geometry units).

    ``element = "hex"``: hexahedra instead (C3D20R, order 1: C3D8): a
    built-in box structured (as ``structured``/``features`` divide it, else
    ``size`` everywhere); another part through Gmsh's transfinite
    constraints set automatically and recombined, which needs every volume
    to be a topological hexahedron (six four-sided faces): a MeshError
    naming the volume otherwise.

    ``mesher = "tetgen"``: Gmsh writes the surface triangulation, TetGen
    fills the volume (``-pq1.414a<V>Y``, ``-o2`` for quadratic) with a
    volume bound V of a regular tetrahedron of edge ``size``.
    ``refine`` (0-1): element size factor near ``refine_points`` (geometry
    units) and the bounding-box planes ``refine_planes`` (e.g. "x-min"), up
    to ``refine_radius``.
    ``optimize = "netgen"``: Gmsh's Netgen optimiser on the linear tets before
    they are made quadratic (better shapes; on the paper's beam at C3D10
    2 mm it takes the torsion error from -0.22 % to -0.15 %).
    ``structured = True`` (built-in ``box`` only, Gmsh, no refine/optimize):
    a transfinite mesh, hex cells of ``size`` along the longest side and
    ``across_factor * size`` across the section, each split into six tets.
    ``source`` names the job in the messages about the size (e.g. the LINK.toml).
    ``features`` (``across``, ``around``, ``selected``: bounding-box planes,
    ``faces``: CAD face ids, ``max_nodes``): size fields that resolve holes, fillets, thin walls and
    the selected faces (:mod:`.refine`); a built-in box gets a structured
    mesh with ``across`` elements over its section instead.
    """
    if is_msh(geometry):
        return _mesh_from_msh(geometry, units, scale, order, element)
    if optimize not in ("none", "netgen"):
        raise InputError(f"mesh.optimize = {optimize!r}: none or netgen")
    if structured:
        if geometry.get("shape") != "box":
            raise InputError(
                f"mesh.structured = true: only for the built-in shape 'box', not "
                f"{geometry.get('shape', geometry.get('step'))!r}"
            )
        if mesher != "gmsh" or refine or optimize != "none":
            raise InputError("mesh.structured = true: needs mesher = 'gmsh', no refine and optimize = 'none'")
        if not 0 < across_factor <= 1:
            raise InputError(f"mesh.across_factor = {across_factor!r}: a size factor in (0, 1]")
    if order not in (1, 2):
        raise InputError(f"mesh.order = {order!r}: 1 (C3D4) or 2 (C3D10)")
    if not size > 0:
        raise InputError(f"mesh.size = {size!r}: must be positive")
    if mesher not in ("gmsh", "tetgen"):
        raise InputError(f"mesh.mesher = {mesher!r}: gmsh or tetgen")
    if element not in ("tet", "hex"):
        raise InputError(f"mesh.element = {element!r}: tet or hex")
    if element == "hex" and (mesher != "gmsh" or refine or optimize != "none"):
        raise InputError("mesh.element = hex: needs mesher = 'gmsh', no refine and optimize = 'none'")
    gmsh = _gmsh()
    t0 = time.perf_counter()
    # interruptible=False: gmsh would otherwise reset SIGINT to its default
    # while it runs, and Ctrl-C would kill Python without any cleanup
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    _python_signals()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("link")
        _add_geometry(gmsh, geometry, units)
        box = np.array(gmsh.model.getBoundingBox(-1, -1))
        extent = box[3:] - box[:3]  # geometry units (OCC pads by ~1e-7)
        where = source or geometry.get("step", geometry.get("shape"))
        if size > extent.max():
            raise MeshError(
                f"{where}: element size {size:g} {units} is larger than the "
                f"whole part ({' x '.join(f'{e:.4g}' for e in extent)} {units}); give a fraction of its smallest side"
            )
        volume = sum(gmsh.model.occ.getMass(3, tag) for _dim, tag in gmsh.model.getEntities(3))
        _check_count(volume, size, units, where)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", size if not refine else refine * size)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.OptimizeNetgen", 1 if optimize == "netgen" else 0)
        extra: tuple = ()
        prism = bool(features) and _prismatic(geometry, mesher, refine, optimize, structured)
        hexbox = element == "hex" and geometry.get("shape") == "box"
        if prism:
            structured, across_factor = True, prism_across_factor(geometry["size"], size, features["across"])
        elif features and element == "hex":
            pass  # a hexahedral mesh is structured: no size fields
        elif features:
            extra = _feature_fields(gmsh, size, order, features, where)
            if not refine:
                set_background(gmsh, *extra[:2])
        if refine:
            if not 0 < refine < 1:
                raise InputError(f"mesh.refine = {refine!r}: a size factor in (0, 1)")
            lo_hi = gmsh.model.getBoundingBox(-1, -1)
            planes = []
            for name in refine_planes or []:
                axis = "xyz".index(name[0])
                planes.append((axis, lo_hi[axis] if name.endswith("min") else lo_hi[axis + 3]))
            _refinement(gmsh, size, refine, refine_radius or 4 * size, refine_points or [], planes, extra[:2])
        if structured and not prism and not hexbox:
            _structured_box(gmsh, size, across_factor)
        where = geometry.get("step", geometry.get("shape"))
        if hexbox:
            L, b, h = geometry["size"]
            mesh = hex_mesh(
                np.array([0.0, -b / 2, -h / 2]), np.array([L, b / 2, h / 2]), size, across_factor, order, scale
            )
        elif element == "hex":
            mesh = _gmsh_hexahedra(gmsh, order, scale, size, where)
        elif prism:
            L, b, h = geometry["size"]  # exact (OCC pads its bounding box)
            mesh = prism_mesh(
                np.array([0.0, -b / 2, -h / 2]), np.array([L, b / 2, h / 2]), size, across_factor, order, scale
            )
        elif mesher == "gmsh":
            gmsh.option.setNumber("Mesh.ElementOrder", order)
            try:
                gmsh.model.mesh.generate(3)
            except Exception as exc:
                raise MeshError(f"{where}: gmsh cannot mesh it at size {size:g} ({exc})") from None
            if order == 2:
                _untangle_curved(gmsh, where)
            mesh = _collect_gmsh(gmsh, order, scale)
            mesh.surface_tri, mesh.surface_tag = surface_triangles(gmsh)
        else:
            try:
                gmsh.model.mesh.generate(2)
            except Exception as exc:
                raise MeshError(f"{where}: gmsh cannot mesh its surface at size {size:g} ({exc})") from None
            with tempfile.TemporaryDirectory(dir=workdir) as tmp:
                stl = Path(tmp) / "surface.stl"
                gmsh.write(str(stl))
                mesh = tetgen_mesh(stl, order, size, scale, tetgen_timeout)
    finally:
        gmsh.finalize()
    mesh.size_m = size * scale
    mesh.mesher = mesher
    mesh.info["extent"] = [float(e) for e in extent]
    if extra:
        mesh.info["features"] = extra[2]
    elif features:
        mesh.info["features"] = {"prism": True, "across": features["across"]}
    if structured:
        mesh.info["structured"] = True
        mesh.info["across_factor"] = across_factor
    mesh.info["time_s"] = time.perf_counter() - t0
    mesh.info.update(check_geometry(mesh))
    return mesh


def _gmsh_hexahedra(gmsh: ModuleType, order: int, scale: float, size: float, where: object) -> Mesh:
    """Hexahedra of a CAD part: Gmsh's automatic transfinite constraints
    (every volume a topological hexahedron), recombined, 20-node serendipity
    elements for order 2; a MeshError naming each volume it cannot take."""
    bad = []
    for _dim, vol in gmsh.model.getEntities(3):
        _up, faces = gmsh.model.getAdjacencies(3, vol)
        sides = [len(gmsh.model.getAdjacencies(2, int(f))[1]) for f in faces]
        if len(faces) != 6 or any(n != 4 for n in sides):
            bad.append(f"volume {vol} ({len(faces)} faces with {sorted(set(sides))} edges)")
    if bad:
        raise MeshError(
            f"{where}: [mesh] element = hex needs every volume to be a topological hexahedron (six faces of "
            f"four edges, e.g. a box or a swept quadrilateral) so that Gmsh can mesh it transfinite and "
            f'recombine it: {", ".join(bad)} is not; use tetrahedra (element = "tet10") or split the part'
        )
    gmsh.model.mesh.setTransfiniteAutomatic(recombine=True)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
    gmsh.option.setNumber("Mesh.ElementOrder", order)
    try:
        gmsh.model.mesh.generate(3)
    except Exception as exc:
        raise MeshError(f"{where}: gmsh cannot mesh it with hexahedra at size {size:g} ({exc})") from None
    etype = 17 if order == 2 else 5
    other = [vol for _dim, vol in gmsh.model.getEntities(3) if set(gmsh.model.mesh.getElementTypes(3, vol)) - {etype}]
    if other:
        raise MeshError(f"{where}: gmsh left elements other than hexahedra in volume(s) {other}")
    return _collect_hex(gmsh, order, scale)


def _collect_hex(gmsh: ModuleType, order: int, scale: float) -> Mesh:
    """The hexahedra (C3D8, C3D20R in ccx order) of the current gmsh mesh
    and its quadrilateral surfaces."""
    etype = 17 if order == 2 else 5
    _tags, enodes = gmsh.model.mesh.getElementsByType(etype)
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    conn = np.asarray(enodes, dtype=np.int64).reshape(-1, 20 if order == 2 else 8)
    used = np.unique(conn)
    lookup = np.zeros(int(max(ntags.max(), used.max())) + 1, dtype=np.int64)
    lookup[used] = np.arange(1, used.size + 1)
    xyz = np.zeros((int(ntags.max()) + 1, 3))
    xyz[ntags] = np.asarray(coords).reshape(-1, 3)
    elements = lookup[conn]
    if order == 2:
        elements = elements[:, PERM_GMSH_HEX20]
    mesh = Mesh(nodes=xyz[used] * scale, elements=elements.astype(np.int64), mesher="gmsh")
    mesh.surface_tri, mesh.surface_tag = surface_triangles(gmsh, corners=4)
    return mesh


def _untangle_curved(gmsh: ModuleType, where: object) -> None:
    """Quadratic tets curved onto a small hole can fold (negative Jacobian:
    ccx stops with 'nonpositive jacobian'): when any does, run Gmsh's
    high-order optimiser; MeshError if some stay folded. Meshes without a
    folded element are left as they are."""
    tags, _nodes = gmsh.model.mesh.getElementsByType(11)
    if len(tags) == 0:
        return
    q = np.asarray(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    if (q > 0).all():
        return
    bad = int((q <= 0).sum())
    gmsh.model.mesh.optimize("HighOrder")
    q = np.asarray(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    if (q <= 0).any():
        raise MeshError(
            f"{where}: {int((q <= 0).sum())} curved quadratic element(s) stay folded after Gmsh's high-order "
            "optimiser: give a smaller element size near the small holes"
        )
    logger.info("%s: %d folded curved element(s) untangled by gmsh's high-order optimiser", where, bad)


def cad_faces(
    geometry: dict, units: str, points: list | None = None
) -> tuple[list[CadFace], dict[str, list[int]], np.ndarray, list[float]]:
    """The faces of the part (see :mod:`~stiffkit.meshing.faces`) without
    meshing it: (faces, named groups, distances of ``points`` to each face,
    bounding box xmin..zmax), lengths in the geometry's unit. MeshError for
    a file with no solid or several."""
    gmsh = _gmsh()
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    _python_signals()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("faces")
        _add_geometry(gmsh, geometry, units)
        faces = faces_of_model(gmsh)
        named = groups(gmsh)
        dist = distances(gmsh, points or [], faces)
        box = [float(v) for v in gmsh.model.getBoundingBox(-1, -1)]
    finally:
        gmsh.finalize()
    return faces, named, dist, box


def _prismatic(geometry: dict, mesher: str, refine: float | None, optimize: str, structured: bool) -> bool:
    """A built-in box meshed by Gmsh without other size controls: structured."""
    return geometry.get("shape") == "box" and mesher == "gmsh" and not refine and optimize == "none" and not structured


def _feature_fields(gmsh: ModuleType, size: float, order: int, features: dict, where: str) -> tuple:
    """(field ids, smallest size, summary) of the features' size fields; a
    MeshError before meshing when they would need more than ``max_nodes``."""
    # curved quadratic elements at small holes can fold (ccx: nonpositive jacobian): let Gmsh untangle them
    gmsh.option.setNumber("Mesh.HighOrderOptimize", 1)
    selected = {t for p in features.get("selected", ()) for t in plane_surfaces(gmsh, p)}
    selected = sorted(selected | set(features.get("faces", ())))  # CAD face ids of the selectors
    fields, info = feature_fields(gmsh, size, features["across"], features["around"], selected)
    est = estimate_nodes(info, size, order)
    info["nodes_estimate"] = est
    limit = features.get("max_nodes")
    if limit and est > limit:
        raise MeshError(
            f"{where}: resolving the part's features (thinnest wall {info['thinnest_wall']:.4g}, "
            f"{info['across']} elements across; {info['around']} around each hole; smallest size "
            f"{info['smallest_size']:.3g}) needs about {est:.3g} nodes, above [mesh] max_nodes = {limit:g}: "
            "give a larger size, fewer elements across or around, or raise max_nodes"
        )
    return fields, info["smallest_size"], info


def _collect_gmsh(gmsh: ModuleType, order: int, scale: float) -> Mesh:
    etype = 11 if order == 2 else 4
    _tags, enodes = gmsh.model.mesh.getElementsByType(etype)
    if len(enodes) == 0:
        raise MeshError("gmsh produced no tetrahedra for this geometry")
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    conn = np.asarray(enodes, dtype=np.int64).reshape(-1, 10 if order == 2 else 4)
    used = np.unique(conn)
    lookup = np.zeros(int(max(ntags.max(), used.max())) + 1, dtype=np.int64)
    lookup[used] = np.arange(1, used.size + 1)
    xyz = np.zeros((int(ntags.max()) + 1, 3))
    xyz[ntags] = np.asarray(coords).reshape(-1, 3)
    nodes = xyz[used] * scale
    elements = lookup[conn]
    if order == 2:
        elements = elements[:, PERM_GMSH_TET10]
    return Mesh(nodes=nodes, elements=elements.astype(np.int64), mesher="gmsh")
