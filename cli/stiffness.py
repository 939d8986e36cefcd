"""``stiffkit stiffness``: the tool's 6x6 compliance and stiffness of a model with values.

The model TOML (contract s2, s5) gives the robot and every spring's value:
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
import json

import numpy as np

from ..errors import InputError
from ..io.tables import parse_vector, read_columns
from ..robot.indices import stiffness_indices_where
from ..robot.model import load_model

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


def _kappa(C, K, ok, lscale) -> dict:
    """kappa_t, kappa_r (N) of Taghvaeipour et al. 2010 eqs. 31-39 (core/sk_indices.f90):
    one core call for the postures where K exists, NaN elsewhere."""
    idx = stiffness_indices_where(K, ok, lscale)
    return {"kappa_t": idx.kappa_t, "kappa_r": idx.kappa_r}


#: stiffness indices per posture: provider name -> (function(C (N,6,6), K (N,6,6),
#: ok (N,), lscale) -> {index name: (N,) array, NaN where undefined}, unit).
#: Every index a provider returns is printed and written to JSON/NPZ and plotted.
INDICES: dict = {"kappa": (_kappa, "N")}


def index_status(ok, rank) -> list[str]:
    """Per posture: "ok", or why the indices do not exist."""
    return ["ok" if o else f"undefined: no stiffness matrix (compliance rank {int(r)} < 6)" for o, r in zip(ok, rank)]


def compute_indices(C, K, ok, lscale) -> tuple[dict, dict]:
    """({index name: (N,)}, {index name: unit}) of every registered provider."""
    values, units = {}, {}
    for fn, unit in INDICES.values():
        for name, v in fn(C, K, ok, lscale).items():
            values[name] = np.asarray(v, dtype=float)
            units[name] = unit
    return values, units


def register(sub) -> None:
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
    p.add_argument("--lscale", type=float, help="characteristic length of the indices, m (default: the chain's length)")
    p.set_defaults(func=run)


def _null(v: float):
    return None if not np.isfinite(v) else float(v)


def _matrix(a) -> str:
    """A 6x6 matrix as rows of aligned scientific numbers, indented."""
    return "\n".join("  " + " ".join(f"{v: .4e}" for v in row) for row in a)


def run(args) -> int:

    model = load_model(args.model)
    dof = model.chain.dof
    if args.posture:
        Q = parse_vector(args.posture, dof, "--posture")[None]
    else:
        Q = read_columns(args.trajectory, [f"q{i}" for i in range(1, dof + 1)], "trajectory")
    if args.lscale is not None and not (np.isfinite(args.lscale) and args.lscale > 0):
        raise InputError(f"--lscale must be a positive length in m, got {args.lscale}")
    lscale = model.chain.characteristic_length if args.lscale is None else float(args.lscale)
    C, K, rank, ok = model.stiffness(Q)
    indices, units = compute_indices(C, K, ok, lscale)
    status = index_status(ok, rank)
    np.set_printoptions(linewidth=150)
    show = range(min(len(Q), 3))
    for i in show:
        print(f"posture {i + 1}: q = {np.array2string(Q[i], precision=4)}")
        print("  compliance (rows dt, dphi; columns f, m; SI):")
        print(_matrix(C[i]))
        if ok[i]:
            print("  stiffness:")
            print(_matrix(K[i]))
            print("  indices: " + ", ".join(f"{n} = {v[i]:.6g} {units[n]}" for n, v in indices.items()))
        else:
            print(
                f"  stiffness: does not exist (compliance rank {rank[i]} < 6: the model has no "
                f"spring for some tool directions, or the posture is singular)"
            )
            print(f"  indices: {', '.join(indices)} = NaN ({status[i]})")
    if len(Q) > 3:
        print(f"... {len(Q)} postures in all; {int(ok.sum())} with a stiffness matrix")
    if not ok.all():
        bad = np.flatnonzero(~ok) + 1
        print(
            f"indices undefined (NaN, no stiffness matrix) at {bad.size} posture(s): "
            f"{', '.join(map(str, bad[:20]))}{' ...' if bad.size > 20 else ''}"
        )
    print(
        f"indices: Taghvaeipour et al. 2010 eqs. 31-39 with the length scale {lscale:.6g} m "
        f"({'--lscale' if args.lscale is not None else 'the chain length'}); N whatever the unit"
    )
    if args.json:
        out = {
            "postures": [
                {
                    "q": Q[i].tolist(),
                    "compliance": C[i].tolist(),
                    "stiffness": K[i].tolist() if ok[i] else None,
                    "rank": int(rank[i]),
                    "indices": {n: _null(v[i]) for n, v in indices.items()},
                    "indices_status": status[i],
                }
                for i in range(len(Q))
            ],
            "frame": "tool-frame origin, base axes; twist (t, phi), wrench (f, m)",
            "indices_lscale_m": lscale,
            "indices_units": units,
            "indices_note": "null where the stiffness does not exist (see indices_status)",
        }
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1, allow_nan=False)
        print(f"wrote {args.json}")
    if args.npz:
        np.savez(
            args.npz, q=Q, compliance=C, stiffness=K, rank=rank, ok=ok, lscale=lscale, indices_ok=ok.copy(), **indices
        )
        print(f"wrote {args.npz}")
    if args.plot:
        _plot(args.plot, Q, C, ok, indices, units, lscale)
        print(f"wrote {args.plot}")
    return 0


def _plot(path, Q, C, ok, indices, units, lscale) -> None:
    """Principal compliances and the indices along the postures; singular
    postures (no stiffness, indices undefined) marked in grey."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    et = np.linalg.eigvalsh(C[:, :3, :3])
    er = np.linalg.eigvalsh(C[:, 3:, 3:])
    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    x = np.arange(1, len(Q) + 1)
    mk = "." if len(Q) < 50 else None
    for k in range(3):
        ax[0].plot(x, et[:, k] * 1e6, marker=mk, label=f"principal {k + 1}")
        ax[1].plot(x, er[:, k] * 1e6, marker=mk)
    ax[0].set_ylabel("translational compliance (mm/kN)")
    ax[1].set_ylabel("rotational compliance (urad/(N m))")
    for name, v in indices.items():
        ax[2].plot(x, v, marker=mk, label=name)  # NaN leaves a gap
    ax[2].set_yscale("log")
    ax[2].set_ylabel(f"stiffness index ({', '.join(sorted(set(units.values())))}), l = {lscale:.3g} m")
    # runs of consecutive postures without a stiffness, one grey band each
    edges = np.diff(np.r_[0, (~ok).astype(int), 0])
    runs = list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))
    for a in ax:
        a.set_xlabel("posture")
        for b0, b1 in runs:
            a.axvspan(x[b0] - 0.5, x[b1 - 1] + 0.5, color="0.85", lw=0)
    if runs:
        ax[2].plot([], [], color="0.85", lw=6, label="no stiffness (indices undefined)")
    ax[0].legend(fontsize=8)
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
