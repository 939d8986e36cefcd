"""``stiffkit field``: deflections from displacement fields you already have.

For users whose FEA runs elsewhere: give the node positions and one
displacement field per load case; get (t, phi) per case with covariances,
the noise estimate, and, with six or more load cases and their wrenches,
the compliance matrix with confidence intervals and zero-element tests.
"""

from __future__ import annotations

import argparse

from ..field.cases import axis_wrenches, read_fields, read_wrenches
from ..field.report import field_report
from ..io import validate as V
from . import args as A

HELP = """\
inputs:
  NODES.csv  header x,y,z: node positions (m), one row per node
  DISP.csv   header ux,uy,uz: displacements of the same nodes, same order,
             one file per load case

loads (for the compliance; needs >= 6 load cases spanning all directions):
  --loads Fx,Fy,Fz,Mx,My,Mz   case j carries only component j of this list
                              (the paper's six axis-aligned experiments, eq. 3)
  --wrenches W.csv            header fx,fy,fz,mx,my,mz, one row per case

method (Pashkevich et al. 2009):
  lin     linearised least squares about the field centroid (eq. 17)
  svd+ svd- svd+-   orthogonal Procrustes, angles by Table 1
  exact   Gauss-Newton on SO(3): no linearisation error at large angles

example:
  stiffkit field nodes.csv fx.csv fy.csv fz.csv mx.csv my.csv mz.csv \\
      --reference 1,0,0 --loads 1000,1,1,1,1,1 --trim 0.1 --json k.json
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "field",
        help="fit node displacement fields; compliance from load cases",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("nodes", help="CSV of node positions (x,y,z)")
    p.add_argument("fields", nargs="+", help="CSV of displacements (ux,uy,uz), one per load case")
    p.add_argument("--reference", required=True, help="reference point x,y,z (m)")
    p.add_argument("--method", default="lin", choices=["lin", "svd+", "svd-", "svd+-", "exact"])
    p.add_argument(
        "--trim",
        type=A.number("--trim", lo=0.0, hi=0.5, hi_open=True),
        default=0.0,
        help="fraction of nodes dropped as outliers, in [0, 0.5)",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument("--loads", help="Fx,Fy,Fz,Mx,My,Mz of six axis-aligned cases")
    g.add_argument("--wrenches", help="CSV of the wrench of each case (fx,fy,fz,mx,my,mz)")
    p.add_argument(
        "--confidence",
        type=A.number("--confidence", lo=0.0, hi=1.0, lo_open=True, hi_open=True),
        default=0.99,
        help="two-sided level of the intervals, in (0, 1) (default 0.99)",
    )
    p.add_argument("--symmetrize", action="store_true", help="report (k + k^T)/2")
    p.add_argument("--json", help="write the results to this JSON file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.json:
        V.output_path(args.json, "--json", [args.nodes, *args.fields, args.wrenches])
    reference = A.vector(args.reference, 3, "--reference (m)", "position")
    nodes, disp = read_fields(args.nodes, args.fields)
    wrenches = None
    if args.loads:
        wrenches = axis_wrenches(A.vector(args.loads, 6, "--loads (N, N m)", "force"), len(args.fields))
    elif args.wrenches:
        wrenches = read_wrenches(args.wrenches, len(args.fields))
    rep = field_report(
        nodes,
        disp,
        reference,
        method=args.method,
        trim=args.trim,
        wrenches=wrenches,
        confidence=args.confidence,
        symmetrize=args.symmetrize,
    )
    print(rep.text())
    if args.json:
        rep.write_json(args.json)
        print(f"wrote {args.json}")
    return 0
