"""``stiffkit stiffness``: the tool's 6x6 compliance and stiffness of a model with values.

The model TOML (contract s2, s5) gives the robot and every spring's value:
joint compliances, 6x6 link/base/tool compliances (numbers, or the JSON of
`stiffkit link`, or the output of `stiffkit fit --write-model`). For each
posture: the compliance C = sum_i J_i C_i J_i^T of the tool frame (base
axes, about the tool-frame origin; twist (t, phi) per wrench (f, m)), the
stiffness K = C^-1 where C is positive definite (else its rank and
"singular"), computed in one core call for all postures.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

HELP = """\
examples:
  stiffkit stiffness identified.toml --posture 0,-0.5,0.3,0,1.2,0
  stiffkit stiffness identified.toml --trajectory Q.csv --npz C.npz --plot C.png
  Q.csv: header q1,...,qN, one posture per row (rad)
"""

#: stiffness indices per posture: name -> function(C (N,6,6), K (N,6,6), ok (N,)) -> (N,)
#: The kappa_t, kappa_r indices of Taghvaeipour et al. (issue 5, core/sk_indices.f90)
#: register here; every registered index is printed and written to JSON/NPZ.
INDICES: dict = {}


def register(sub) -> None:
    p = sub.add_parser("stiffness", help="tool compliance and stiffness of a model with values",
                       description=__doc__, epilog=HELP,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model TOML whose effects carry values")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--posture", help="q1,q2,...,qN (rad)")
    g.add_argument("--trajectory", help="CSV with columns q1..qN")
    p.add_argument("--json", help="write compliance, stiffness, rank per posture to JSON")
    p.add_argument("--npz", help="write arrays q, compliance, stiffness, rank, ok to NPZ")
    p.add_argument("--plot", help="PNG of the principal compliances along the postures")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._io import parse_vector, read_columns
    from .calib.model import load_model

    model = load_model(args.model)
    dof = model.chain.dof
    if args.posture:
        Q = parse_vector(args.posture, dof, "--posture")[None]
    else:
        Q = read_columns(args.trajectory, [f"q{i}" for i in range(1, dof + 1)], "trajectory")
    C, K, rank, ok = model.stiffness(Q)
    indices = {name: np.asarray(f(C, K, ok)) for name, f in INDICES.items()}
    np.set_printoptions(linewidth=150)
    show = range(min(len(Q), 3))
    for i in show:
        print(f"posture {i + 1}: q = {np.array2string(Q[i], precision=4)}")
        print("  compliance (rows dt, dphi; columns f, m; SI):")
        print("  " + np.array2string(C[i], precision=4, separator=" ").replace("\n", "\n  "))
        if ok[i]:
            print("  stiffness:")
            print("  " + np.array2string(K[i], precision=4, separator=" ").replace("\n", "\n  "))
        else:
            print(f"  stiffness: does not exist (compliance rank {rank[i]} < 6: the model has no "
                  f"spring for some tool directions)")
        for name, v in indices.items():
            print(f"  {name} = {v[i]:.6g}")
    if len(Q) > 3:
        print(f"... {len(Q)} postures in all; {int(ok.sum())} with a stiffness matrix")
    if not INDICES:
        print("stiffness indices: none registered yet (kappa_t, kappa_r come with the springs module)")
    if args.json:
        out = {"postures": [{"q": Q[i].tolist(), "compliance": C[i].tolist(),
                             "stiffness": K[i].tolist() if ok[i] else None, "rank": int(rank[i]),
                             "indices": {n: float(v[i]) for n, v in indices.items()}}
                            for i in range(len(Q))],
               "frame": "tool-frame origin, base axes; twist (t, phi), wrench (f, m)"}
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
        print(f"wrote {args.json}")
    if args.npz:
        np.savez(args.npz, q=Q, compliance=C, stiffness=K, rank=rank, ok=ok, **indices)
        print(f"wrote {args.npz}")
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        et = np.linalg.eigvalsh(C[:, :3, :3])
        er = np.linalg.eigvalsh(C[:, 3:, 3:])
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        x = np.arange(1, len(Q) + 1)
        for k in range(3):
            ax[0].plot(x, et[:, k] * 1e6, marker="." if len(Q) < 50 else None, label=f"principal {k + 1}")
            ax[1].plot(x, er[:, k] * 1e6, marker="." if len(Q) < 50 else None)
        ax[0].set_ylabel("translational compliance (mm/kN)")
        ax[1].set_ylabel("rotational compliance (urad/(N m))")
        for a in ax:
            a.set_xlabel("posture")
        ax[0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")
    return 0
