"""``stiffkit robot``: manipulator stiffness from generalised springs.

Three jobs, all evaluated by the Fortran core in one call for every posture:
  orthoglide  the 3-PRPaR Orthoglide (Pashkevich et al. 2009 s5): compliance
              at a point, at the isotropic point against the paper's Table 8,
              and a map over the 200 mm workspace cube (PNG slices);
  smg         the McGill SMG (Taghvaeipour et al. 2010): stiffness indices
              kappa_t, kappa_r along the smoothed test trajectory (Fig. 10);
  tree        your own mechanism: a JSON tree of springs and joints at given
              poses -> tool compliance, stiffness, free and rigid directions.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.files import FIGURE_SUFFIXES
from ..springs.reports import OrthoglideReport, SMGReport, TreeReport, orthoglide_report, smg_report, tree_report
from . import args as A

#: the largest workspace map: N^3 postures in one core call, about 6 KB each
#: (61^3 = 227,000 postures, 1.3 GB); and the most SMG postures (4 KB each)
MAP_MAX = 61
POSTURES_MAX = 200_000

HELP_ORTHOGLIDE = """\
model (see stiffkit/springs/orthoglide.py): three PRPaR legs, L = 310 mm,
d = 100 mm, r = 31 mm; each leg is foot - R - parallelogram (two bars and
four half-axles with four hinges) - R, the passive joints eliminated exactly
(no singular matrix is inverted); the legs add up at the tool point.
Link compliances: --links beam (default: Table 7 single-beam approximations,
bars and axles as full cantilevers, eq. 22) or fea (Table 7 FEA diagonals);
--link-file NAME=PATH replaces foot, axle or bar by a `stiffkit link` JSON.

outputs:
  the 6x6 compliance at --point (mm, default the isotropic point 0,0,0),
  its translational/rotational parts next to Table 8 of the paper,
  with --map: the workspace cube on an n^3 grid, slices z = -100, 0, 100 mm
  of the largest translational (mm/N) and rotational (rad/(N mm))
  compliance eigenvalue, written to --png.
  Singular postures are reported as free directions (rank < 6).

examples:
  stiffkit robot orthoglide
  stiffkit robot orthoglide --point 50,-20,80 --json c.json
  stiffkit robot orthoglide --map 21 --png orthoglide_map.png
"""

HELP_SMG = """\
model (see stiffkit/springs/smg.py): two R-Pi-Pi-R limbs; each Pi-joint is two
beam links behind passive revolute joints (eq. 23), limbs are serial arrays
(eqs. 22, 25), wrist joints eliminated (eqs. 26-29), limbs summed (eq. 30).
The report gives no dimensions or link data: geometry and sections are
illustrative, so the curves show the computation of Fig. 10, not its values.
--link-file proximal=PATH / distal=PATH takes `stiffkit link` JSON results.

indices (eqs. 31-39): kappa_t, kappa_r in N, made unit-invariant with the
characteristic length --lscale (default: the proximal bar length, 350 mm);
--lscale 1 is the report's literal formula in SI units (then the numbers
would change if the same robot were entered in mm).

examples:
  stiffkit robot smg --png smg_indices.png
  stiffkit robot smg --postures 100000 --json smg.json
"""

HELP_TREE = """\
TREE.json describes one mechanism at one posture (SI: m, N, rad):
  {"tool": [x, y, z],                          point where C and K are wanted
   "tool_axes": [[...],[...],[...]],           optional, columns = result axes
   "lscale": 0.5,                              optional characteristic length
   "tree": NODE}
NODE is one of
  {"series": [NODE, ...]}                      same wrench through all
  {"parallel": [NODE, ...]}                    same end bodies
  {"spring": {"compliance": 6x6 | "stiffness": 6x6 | "file": "link.json",
              "pos": [x,y,z], "rot": 3x3 (columns = spring axes)}}
  {"joint": {"type": "revolute"|"prismatic", "axis": [..], "point": [..],
             "compliance": c | "stiffness": k | "passive": true}}
A spring matrix is given at its own point in its own axes (as `stiffkit link`
writes it). Results: compliance (exists when there are no free twists),
stiffness (exists when there are no rigid wrenches), their rank, the free
twists (t, phi) and rigid wrenches (f, m), and kappa_t, kappa_r.

example: a beam behind a passive hinge (rank 5)
  {"tool": [0.5, 0, 0], "tree": {"series": [
     {"joint": {"type": "revolute", "axis": [0,0,1], "point": [0,0,0], "passive": true}},
     {"spring": {"file": "beam.json", "pos": [0.5, 0, 0]}}]}}
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "robot",
        help="manipulator stiffness: Orthoglide, McGill SMG, your spring tree",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    rs = p.add_subparsers(dest="robot", metavar="MODEL")
    o = _command(
        rs,
        "orthoglide",
        "Orthoglide compliance and workspace map",
        "Orthoglide (Pashkevich et al. 2009 s5) compliance.",
        HELP_ORTHOGLIDE,
    )
    o.add_argument("--point", default="0,0,0", help="tool point x,y,z in mm (isotropic point 0,0,0)")
    o.add_argument("--links", default="beam", choices=["beam", "fea"], help="Table 7 link data")
    _add_link_file(o, "foot|axle|bar compliance from a `stiffkit link` JSON (repeatable)")
    o.add_argument(
        "--actuator-compliance",
        type=A.number("--actuator-compliance", "linear_compliance", lo=0.0),
        default=0.0,
        help="compliance of each linear actuator along its axis, m/N (default rigid)",
    )
    o.add_argument(
        "--map",
        type=A.count("--map", 2, MAP_MAX),
        metavar="N",
        help=f"workspace map on an N^3 grid (2 <= N <= {MAP_MAX}; memory ~6 KB per posture)",
    )
    o.add_argument("--png", help="PNG of the map slices (with --map)")
    o.add_argument("--json", help="write results to this JSON file")
    o.set_defaults(func=run_orthoglide)

    s = _command(
        rs,
        "smg",
        "McGill SMG stiffness indices along the test trajectory",
        "McGill SMG (Taghvaeipour et al. 2010) stiffness indices.",
        HELP_SMG,
    )
    s.add_argument(
        "--postures",
        type=A.count("--postures", 2, POSTURES_MAX),
        default=401,
        help=f"points along the trajectory (2-{POSTURES_MAX}; memory ~4 KB per posture)",
    )
    s.add_argument(
        "--pi-joints",
        default="paper",
        choices=["paper", "both"],
        help="paper: one passive joint per Pi link (eq. 23); both: true distal parallelograms",
    )
    _add_link_file(s, "proximal|distal link compliance from a `stiffkit link` JSON")
    s.add_argument(
        "--lscale",
        type=A.number("--lscale", "length", lo=0.0, lo_open=True),
        help="characteristic length for the indices, m",
    )
    s.add_argument("--png", help="PNG of kappa_t, kappa_r along the trajectory (Fig. 10)")
    s.add_argument("--json", help="write results to this JSON file")
    s.set_defaults(func=run_smg)

    t = _command(
        rs,
        "tree",
        "tool stiffness of a JSON tree of springs and joints",
        "Evaluate a tree of generalised springs and joints.",
        HELP_TREE,
    )
    t.add_argument("tree", help="TREE.json (see below)")
    t.add_argument(
        "--rcond",
        type=A.number("--rcond", lo=0.0, hi=1.0, hi_open=True),
        default=1e-9,
        help="eigenvalue ratio below which a direction counts as free or rigid, in [0, 1)",
    )
    t.add_argument("--json", help="write results to this JSON file")
    t.set_defaults(func=run_tree)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def _command(
    rs: argparse._SubParsersAction[argparse.ArgumentParser], name: str, help: str, description: str, epilog: str
) -> argparse.ArgumentParser:
    return rs.add_parser(
        name, help=help, description=description, epilog=epilog, formatter_class=argparse.RawDescriptionHelpFormatter
    )


def _add_link_file(parser: argparse.ArgumentParser, text: str) -> None:
    parser.add_argument("--link-file", action="append", default=[], metavar="NAME=PATH", help=text)


def _link_files(items: Iterable[str]) -> dict:
    """--link-file NAME=PATH (repeatable) -> {NAME: PATH}; the model checks the names."""
    out = {}
    for it in items:
        name, eq, path = it.partition("=")
        if not eq or not name or not path:
            raise InputError(f"--link-file expects NAME=PATH, got {it!r}")
        if name in out:
            raise InputError(f"--link-file {it}: {name!r} is given twice")
        out[name] = path
    return out


def _check_outputs(args: argparse.Namespace, inputs: Iterable[Path | str | None] = ()) -> None:
    """Output names checked before the work: files, not folders, not an
    input, not the same file twice, a figure suffix for --png."""
    png = getattr(args, "png", None)
    if png:
        V.output_path(png, "--png", inputs, FIGURE_SUFFIXES)
    if args.json:
        V.output_path(args.json, "--json", inputs)
    V.distinct_outputs({"--png": png, "--json": args.json})


def _write_files(rep: OrthoglideReport | SMGReport | TreeReport, args: argparse.Namespace) -> None:
    """The files asked for (--png, --json), each announced once written."""
    if getattr(args, "png", None):
        rep.write_png(args.png)
        print(f"wrote {args.png}")
    if args.json:
        rep.write_json(args.json)
        print(f"wrote {args.json}")


def run_orthoglide(args: argparse.Namespace) -> int:
    if args.png and not args.map:
        raise InputError("--png needs --map N")
    files = _link_files(args.link_file)
    _check_outputs(args, files.values())
    point = A.vector(args.point, 3, "--point (mm)")
    if np.abs(point).max() > 1e4:
        raise InputError(f"--point {args.point}: the Orthoglide's workspace is a 200 mm cube about 0,0,0 (mm)")
    rep = orthoglide_report(
        point,
        args.links,
        files,
        args.actuator_compliance,
        args.map,
    )
    print(rep.text())
    _write_files(rep, args)
    return 0


def run_smg(args: argparse.Namespace) -> int:
    files = _link_files(args.link_file)
    _check_outputs(args, files.values())
    rep = smg_report(args.postures, files, args.pi_joints, args.lscale)
    print(rep.text())
    _write_files(rep, args)
    return 0


def run_tree(args: argparse.Namespace) -> int:
    _check_outputs(args, [args.tree])
    rep = tree_report(args.tree, args.rcond)
    print(rep.text())
    _write_files(rep, args)
    return 0
