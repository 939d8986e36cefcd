"""``stiffkit stiffness``: the tool's 6x6 compliance and stiffness of a model with values.

The model TOML (docs/calibration.md §2, §5) gives the robot and every spring's value:
joint compliances, 6x6 link/base/tool compliances (numbers, or the JSON of
`stiffkit link`, or the output of `stiffkit fit --write-model`). For each
posture: the compliance C = sum_i J_i C_i J_i^T of the tool frame (base
axes, about the tool-frame origin; twist (t, phi) per wrench (f, m)), the
stiffness K = C^-1 where C is positive definite (else its rank and
"singular"), computed in one core call for all postures, and the stiffness
indices kappa_t, kappa_r of Taghvaeipour et al. 2010 (eqs. 31-39; one more
core call for all postures), in N, made independent of the unit of length
with a characteristic length (--lscale, default the chain's length: the sum
of its joint offsets). Where K does not exist the indices are NaN (null in
JSON) and the posture's index status says why.
"""

from __future__ import annotations

import argparse

from ..io import validate as V
from ..io.files import FIGURE_SUFFIXES, model_inputs
from ..io.tables import read_columns
from ..robot.model import load_model
from ..robot.stiffness_report import INDICES, compute_indices, index_status, stiffness_report
from . import args as A

__all__ = ["register", "run", "INDICES", "compute_indices", "index_status"]  # the index registry lives in robot

HELP = """\
examples:
  stiffkit stiffness identified.toml --posture 0,-0.5,0.3,0,1.2,0
  stiffkit stiffness identified.toml --trajectory Q.csv --npz C.npz --plot C.png
  Q.csv: header q1,...,qN, one posture per row (rad)

indices: kappa_t, kappa_r in N (eqs. 31-39 with G_f = [l K11 S_s, K12 S_theta],
G_n = [K12^T H_s, K22/l H_theta]); the same robot entered in another unit of
length gives the same numbers when l is given in that unit (the default, the
chain length, follows the URDF). --lscale 1 is the paper's literal formula in SI.
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "stiffness",
        help="tool compliance and stiffness of a model with values",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML whose effects carry values")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--posture", help="q1,q2,...,qN (rad)")
    g.add_argument("--trajectory", help="CSV with columns q1..qN")
    p.add_argument("--json", help="write compliance, stiffness, rank, indices per posture to JSON")
    p.add_argument(
        "--npz", help="write arrays q, compliance, stiffness, rank, ok, kappa_t, kappa_r, indices_ok, lscale to NPZ"
    )
    p.add_argument("--plot", help="PNG of the principal compliances and the indices along the postures")
    p.add_argument(
        "--lscale",
        type=A.number("--lscale", "length", lo=0.0, lo_open=True),
        help="characteristic length of the indices, m (default: the chain's length)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    inputs = [*model_inputs(args.model), args.trajectory]
    for opt, path, suffixes in (
        ("--json", args.json, None),
        ("--npz", args.npz, None),
        ("--plot", args.plot, FIGURE_SUFFIXES),
    ):
        if path:
            V.output_path(path, opt, inputs, suffixes)
    npz = args.npz if not args.npz or args.npz.endswith(".npz") else args.npz + ".npz"
    V.distinct_outputs({"--json": args.json, "--npz": npz, "--plot": args.plot})
    model = load_model(args.model)
    dof = model.chain.dof
    if args.posture:
        Q = A.vector(args.posture, dof, f"--posture (q1..q{dof}, rad)", "angle")[None]
    else:
        Q = read_columns(args.trajectory, [f"q{i}" for i in range(1, dof + 1)], "trajectory", "angle")
    rep = stiffness_report(model, Q, args.lscale)
    print(rep.text())
    if args.json:
        rep.write_json(args.json)
        print(f"wrote {args.json}")
    if args.npz:
        print(f"wrote {rep.write_npz(args.npz)}")
    if args.plot:
        rep.write_png(args.plot)
        print(f"wrote {args.plot}")
    return 0
