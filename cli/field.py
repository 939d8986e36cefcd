"""``stiffkit field``: deflections from displacement fields you already have.

For users whose FEA runs elsewhere: give the node positions and one
displacement field per load case; get (t, phi) per case with covariances,
the noise estimate, and, with six or more load cases and their wrenches,
the compliance matrix with confidence intervals and zero-element tests.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from ..errors import InputError
from ..field import DOF_NAMES, compliance_from_experiments, fit_fields
from ..io.tables import parse_vector, read_columns

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


def register(sub) -> None:
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
    p.add_argument("--trim", type=float, default=0.0, help="fraction of nodes dropped as outliers (0-0.5)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--loads", help="Fx,Fy,Fz,Mx,My,Mz of six axis-aligned cases")
    g.add_argument("--wrenches", help="CSV of the wrench of each case (fx,fy,fz,mx,my,mz)")
    p.add_argument("--confidence", type=float, default=0.99)
    p.add_argument("--symmetrize", action="store_true", help="report (k + k^T)/2")
    p.add_argument("--json", help="write the results to this JSON file")
    p.set_defaults(func=run)


def run(args) -> int:
    nodes = read_columns(args.nodes, ["x", "y", "z"], "node")
    disp = []
    for f in args.fields:
        d = read_columns(f, ["ux", "uy", "uz"], "displacement")
        if d.shape != nodes.shape:
            raise InputError(f"{f}: {d.shape[0]} displacement rows for {nodes.shape[0]} nodes in {args.nodes}")
        disp.append(d)
    ref = parse_vector(args.reference, 3, "--reference")
    fits = fit_fields(nodes, np.array(disp), ref, method=args.method, trim=args.trim, pooled=True)
    print(
        f"{len(fits)} field(s), {nodes.shape[0]} nodes, method {args.method}, "
        f"pooled noise sigma = {fits[0].sigma:.3e} m"
    )
    print(f"{'case':>4s} " + " ".join(f"{n:>13s}" for n in DOF_NAMES) + "   used")
    for j, fit in enumerate(fits, 1):
        print(f"{j:4d} " + " ".join(f"{v:13.5e}" for v in fit.deflection) + f"  {fit.n_used:5d}")
    out = {
        "sigma_m": fits[0].sigma,
        "fits": [
            {"t": f.t.tolist(), "phi": f.phi.tolist(), "cov": f.cov.tolist(), "nodes_used": f.n_used} for f in fits
        ],
    }
    wrenches = None
    if args.loads:
        loads = parse_vector(args.loads, 6, "--loads")
        if len(fits) != 6:
            raise InputError(f"--loads describes six axis-aligned cases, got {len(fits)} displacement files")
        wrenches = np.diag(loads)
    elif args.wrenches:
        wrenches = read_columns(args.wrenches, ["fx", "fy", "fz", "mx", "my", "mz"], "wrench")
        if wrenches.shape[0] != len(fits):
            raise InputError(f"{args.wrenches}: {wrenches.shape[0]} wrenches for {len(fits)} load cases")
    if wrenches is not None:
        comp = compliance_from_experiments(wrenches, fits, confidence=args.confidence, symmetrize=args.symmetrize)
        print()
        print(comp.table())
        out.update(
            {
                "compliance": comp.matrix.tolist(),
                "compliance_std": comp.std.tolist(),
                "significant": comp.significant.tolist(),
                "symmetry_error": comp.asymmetry,
                "stiffness": None if comp.stiffness is None else comp.stiffness.tolist(),
            }
        )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
        print(f"wrote {args.json}")
    return 0
