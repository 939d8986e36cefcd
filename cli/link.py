"""``stiffkit link``: a link's compliance matrix from its CAD, by FEA.

Meshes the part (Gmsh or TetGen), clamps the support face, applies six
unit-direction wrenches at the reference point through a coupling to the
load face (CalculiX), fits the rigid motion of the field nodes around the
reference point in each case (Pashkevich et al. 2009, s3-s4) and prints the
compliance with confidence intervals, non-significant elements as '0'.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import InputError
from ..fea.config import UNITS, load_link
from ..fea.job import run_link
from ..io import validate as V
from ..io.files import FIGURE_SUFFIXES, check_folder, link_inputs
from ..meshing.faces import format_faces
from ..meshing.gmsh_mesh import CAD_SUFFIXES, cad_faces
from . import args as A

HELP = """\
LINK.toml (format: docs/link.md; lengths in geometry.units):
  [geometry]  step = "part.step" (STEP/BREP/IGES) or shape = "box" (size = [L, b, h]),
              "tube" (length, outer_diameter, inner_diameter), "rod"; units = "mm"
  [material]  E (Pa), nu, density (kg/m^3, only for the matrix route; default 7850)
  [support]   the clamped set (all its nodes fixed in x, y, z), of face selectors, each
              one or a list (all act as one set):
                plane = "x-min" ...   bounding-box face (nodes within tolerance: default 1e-6
                                      of the bounding-box diagonal)
                face = 7 | [7, 9]     CAD face ids (stiffkit link --list-faces PART.step)
                cylinder = {axis = [0, 0, 1], point = [x, y, z], radius = r, tolerance = t}
                                      the bore or pin hole whose surface lies on this cylinder
                point = [x, y, z]     the face through the point (nearest within tolerance)
                box = [xmin, ymin, zmin, xmax, ymax, zmax]   the faces inside the box
                group = "name"        a .geo/.msh physical group or a STEP face label
                                      ([geometry] step = "part.msh": a mesh used as it is)
              tolerance = default of the CAD selectors: 1e-4 of the bounding-box diagonal
              coupling = "rigid" (default: every node held in x, y, z) | "distributing"
                                      (only the set's weighted mean motion held: the face
                                      free to contract and warp, beam theory's clamp)
  [load]      the same selectors (both lug holes: a list of two cylinders), and
              reference_point = [x, y, z] (default: the load set's centre of area, on its
              axis for coaxial cylinders), coupling = "rigid" (default: *RIGID BODY, a pin
              or shrink fit) | "distributing" (a bearing that lets the bore ovalise),
              amplitudes = "auto" | [Fx, Fy, Fz, Mx, My, Mz] (N, N m)
  [field]     region = "face" (the load set) | "cube" | "layer", size (cube edge / layer
              depth), or face selectors (region = "faces": the nodes of those faces)
  [mesh]      mesher = "gmsh" | "tetgen", order = 1 (C3D4) | 2 (C3D10), size,
              element = "tet10" (default) | "tet4" | "hex20" (C3D20R) | "hex8" (C3D8): hexahedra
              structured on a built-in box, else Gmsh transfinite + recombine (every volume a
              topological hexahedron; an error names the volume that is not),
              refine = 0.5 (size factor near the reference point and the clamp), refine_radius,
              optimize = "none" | "netgen" (Netgen optimiser: better tets, e.g. torsion
              error of the paper's beam at C3D10 2 mm -0.22 % -> -0.15 %)
              structured = false | true (built-in box only, gmsh, no refine/optimize: a
              transfinite mesh, hex cells split into six tets; default false),
              across_factor = 1.0 (structured: element size across the section, i.e. along the
              box's two shorter sides, = across_factor x size; e.g. size = 2, across_factor = 0.9:
              6 elements across the 10 mm section, paper's beam max error 0.08 % vs 0.22 %)
              features = true | false (default true: size fields at holes, fillets, thin walls
              and the support/load faces; a built-in box gets a structured prism mesh instead),
              across = elements across the thinnest wall (default 8 for a box: over its section,
              paper's beam 5 mm max error 0.22 % -> see docs/link.md; 3 for other parts),
              around = 16 (elements around a hole's full circle),
              accuracy = 0.001 (relative: refine every size by 4/3 per level until the Richardson
              estimate of the compliance error is below it; reported with the matrix),
              max_nodes = 300000 (the memory limit, about 8 GB on the matrix route)
  [fit]       method = "lin" | "svd+" | "svd-" | "svd+-" | "exact", trim, confidence, symmetrize,
              pooled (true: one noise estimate for the six fields, paper s3.4; false: each its own)
  [solver]    route = "auto" (= matrix) | "ccx" (six *STEPs) | "matrix" (ccx assembles K once,
              CHOLMOD solves the six cases; distributing or rigid coupling)

outputs:
  the compliance table (SI: m/N, 1/N, rad/(N m)), the reference node's own
  compliance as a check, the closed form (eq. 22) for built-in straight shapes;
  --json OUT.json (contract keys), --vtu OUT.vtu (six displacement fields for
  ParaView; with the clamped, loaded and field nodes marked), --png OUT.png (residual
  histograms, paper Fig. 3), --faces-png OUT.png (the mesh with the selected faces).
  FEA results are cached in --cache (default .stiffkit-cache): a rerun with
  other [field]/[fit] settings reuses them.

examples:
  stiffkit link --list-faces part.step          the CAD faces: id, type, area, centre, axis, radius
  stiffkit link examples/bored_link.toml --png bored.png
  stiffkit link examples/beam.toml --json beam.json
  stiffkit link examples/orthoglide_bar.toml --vtu bar.vtu --png bar.png
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "link",
        help="a link's compliance matrix from its CAD (Gmsh + CalculiX + field fit)",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("link", nargs="?", help="LINK.toml describing the part, loads, mesh and fit")
    p.add_argument(
        "--list-faces",
        metavar="PART",
        help="print the faces of a CAD part (STEP/BREP/IGES/.geo): id, type, area, centre, axis, radius",
    )
    p.add_argument(
        "--units", default="mm", choices=list(UNITS), help="unit of the --list-faces part (default %(default)s)"
    )
    p.add_argument("--json", help="write the results (contract keys) to this JSON file")
    p.add_argument("--vtu", help="write the mesh and the six displacement fields (VTU)")
    p.add_argument("--png", help="write histograms of the fit residuals (PNG)")
    p.add_argument("--faces-png", help="write a picture of the mesh with the clamped and loaded faces (PNG)")
    p.add_argument("--route", choices=["auto", "ccx", "matrix"], help="override [solver] route")
    p.add_argument("--order", type=int, choices=[1, 2], help="override [mesh] order")
    p.add_argument(
        "--size", type=A.number("--size", lo=0.0, lo_open=True), help="override [mesh] size (geometry units)"
    )
    p.add_argument("--cache", default=".stiffkit-cache", help="cache folder (default %(default)s)")
    p.add_argument("--no-cache", action="store_true", help="always run the FEA again")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=run)


def list_faces(part: str, units: str) -> int:
    """``--list-faces``: the CAD faces of a part, as the selectors see them."""
    path = Path(part)
    if path.suffix.lower() not in CAD_SUFFIXES:
        raise InputError(
            f"--list-faces {part}: unknown CAD format {path.suffix!r}; use STEP (.step/.stp), BREP (.brep), "
            "IGES (.iges/.igs) or a Gmsh .geo"
        )
    if not path.is_file():
        raise InputError(f"--list-faces {part}: file not found")
    faces, named, _dist, _box = cad_faces({"step": str(path.resolve())}, units)
    print(f"{part}:")
    print(format_faces(faces, named, units))
    return 0


def run(args: argparse.Namespace) -> int:
    if args.list_faces:
        if args.link:
            raise InputError("--list-faces PART takes no LINK.toml")
        return list_faces(args.list_faces, args.units)
    if not args.link:
        raise InputError("a LINK.toml is required (or --list-faces PART.step)")
    inputs = link_inputs(args.link)
    for opt, path, suffixes in (
        ("--json", args.json, None),
        ("--vtu", args.vtu, (".vtu",)),
        ("--png", args.png, FIGURE_SUFFIXES),
        ("--faces-png", args.faces_png, (".png",)),
    ):
        if path:
            V.output_path(path, opt, inputs, suffixes)
    V.distinct_outputs({"--json": args.json, "--vtu": args.vtu, "--png": args.png, "--faces-png": args.faces_png})
    if not args.no_cache and Path(args.cache).exists() and not Path(args.cache).is_dir():
        raise InputError(f"--cache {args.cache}: a file, not a folder")
    if not args.no_cache:
        check_folder(args.cache, "--cache")
    job = load_link(args.link)
    if args.route:
        job.route = args.route
    job = job.with_mesh(order=args.order, size=args.size)
    say = None if args.quiet else (lambda m: print(f"  .. {m}", file=sys.stderr, flush=True))
    res = run_link(job, cache_dir=None if args.no_cache else args.cache, progress=say)
    print(res.summary(Path(args.link).name))
    print(res.table())
    if args.json:
        res.write_json(args.json)
        print(f"wrote {args.json}")
    if args.vtu:
        print(f"wrote {res.write_vtu(args.vtu)}")
    if args.png:
        print(f"wrote {res.write_residual_png(args.png)}")
    if args.faces_png:
        print(f"wrote {res.write_faces_png(args.faces_png)}")
    return 0
