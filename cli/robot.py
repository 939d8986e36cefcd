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
import json
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.tables import parse_vector
from ..springs import Joint, Spring, evaluate, load_link_compliance, parallel, series, smg, stiffness_indices
from ..springs import orthoglide as og

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


def register(sub) -> None:
    p = sub.add_parser(
        "robot",
        help="manipulator stiffness: Orthoglide, McGill SMG, your spring tree",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    rs = p.add_subparsers(dest="robot", metavar="MODEL")
    o = rs.add_parser(
        "orthoglide",
        help="Orthoglide compliance and workspace map",
        description="Orthoglide (Pashkevich et al. 2009 s5) compliance.",
        epilog=HELP_ORTHOGLIDE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    o.add_argument("--point", default="0,0,0", help="tool point x,y,z in mm (isotropic point 0,0,0)")
    o.add_argument("--links", default="beam", choices=["beam", "fea"], help="Table 7 link data")
    o.add_argument(
        "--link-file",
        action="append",
        default=[],
        metavar="NAME=PATH",
        help="foot|axle|bar compliance from a `stiffkit link` JSON (repeatable)",
    )
    o.add_argument(
        "--actuator-compliance",
        type=float,
        default=0.0,
        help="compliance of each linear actuator along its axis, m/N (default rigid)",
    )
    o.add_argument("--map", type=int, metavar="N", help="workspace map on an N^3 grid")
    o.add_argument("--png", help="PNG of the map slices (with --map)")
    o.add_argument("--json", help="write results to this JSON file")
    o.set_defaults(func=run_orthoglide)

    s = rs.add_parser(
        "smg",
        help="McGill SMG stiffness indices along the test trajectory",
        description="McGill SMG (Taghvaeipour et al. 2010) stiffness indices.",
        epilog=HELP_SMG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    s.add_argument("--postures", type=int, default=401, help="points along the trajectory")
    s.add_argument(
        "--pi-joints",
        default="paper",
        choices=["paper", "both"],
        help="paper: one passive joint per Pi link (eq. 23); both: true distal parallelograms",
    )
    s.add_argument(
        "--link-file",
        action="append",
        default=[],
        metavar="NAME=PATH",
        help="proximal|distal link compliance from a `stiffkit link` JSON",
    )
    s.add_argument("--lscale", type=float, help="characteristic length for the indices, m")
    s.add_argument("--png", help="PNG of kappa_t, kappa_r along the trajectory (Fig. 10)")
    s.add_argument("--json", help="write results to this JSON file")
    s.set_defaults(func=run_smg)

    t = rs.add_parser(
        "tree",
        help="tool stiffness of a JSON tree of springs and joints",
        description="Evaluate a tree of generalised springs and joints.",
        epilog=HELP_TREE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    t.add_argument("tree", help="TREE.json (see below)")
    t.add_argument(
        "--rcond", type=float, default=1e-9, help="eigenvalue ratio below which a direction counts as free or rigid"
    )
    t.add_argument("--json", help="write results to this JSON file")
    t.set_defaults(func=run_tree)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def _link_files(items, allowed) -> dict:
    out = {}
    for it in items:
        if "=" not in it:
            raise InputError(f"--link-file expects NAME=PATH, got {it!r}")
        name, path = it.split("=", 1)
        if name not in allowed:
            raise InputError(f"--link-file: unknown link {name!r}, use one of {', '.join(allowed)}")
        if not Path(path).is_file():
            raise InputError(f"--link-file {name}: no such file {path}")
        out[name] = path
    return out


def _fmt6(c) -> str:
    names = ("tx", "ty", "tz", "phix", "phiy", "phiz")
    lines = ["        " + " ".join(f"{n:>11s}" for n in ("Fx", "Fy", "Fz", "Mx", "My", "Mz"))]
    for i, n in enumerate(names):
        lines.append(f"  {n:>5s} " + " ".join(f"{v:11.3e}" for v in c[i]))
    return "\n".join(lines)


def run_orthoglide(args) -> int:
    g = og.OrthoglideGeometry()
    links = og.link_compliances(args.links, g, _link_files(args.link_file, ("foot", "axle", "bar")))
    P = parse_vector(args.point, 3, "--point") * 1e-3
    res = og.compliance(P[None], links, g, args.actuator_compliance)
    C = res.compliance[0]
    out = {
        "point_m": P.tolist(),
        "links": args.links,
        "rank": int(res.rank[0]),
        "free_twists": res.free_twists(0).T.tolist(),
        "compliance_SI": C.tolist(),
        "stiffness_SI": res.stiffness[0].tolist(),
        "ratio": float(res.ratio[0]),
    }
    print(f"Orthoglide at P = {args.point} mm (links: {args.links}), rank {res.rank[0]}")
    print("compliance (SI: m/N, 1/N, rad/(N m)):")
    print(_fmt6(C))
    if res.nfree[0]:
        print(f"singular posture: {res.nfree[0]} free motion(s) (t [m], phi [rad]):")
        for f in res.free_twists(0).T:
            print("   " + " ".join(f"{v:10.3e}" for v in f))
    iso = og.compliance(og.isotropic_point()[None], links, g, args.actuator_compliance).compliance[0]
    kt, kr = iso[0, 0] * 1e3 / 1e-4, iso[3, 3] * 1e-3 / 1e-7
    print("\nisotropic point vs Pashkevich et al. 2009 Table 8:")
    print(f"  {'model':62s} {'k_tran 1e-4 mm/N':>17s} {'k_rot 1e-7 rad/(N mm)':>22s}")
    for name, (a, b) in og.TABLE8.items():
        print(f"  {name:62s} {a:17.2f} {b:22.2f}")
    print(f"  {'stiffkit spring tree (' + args.links + ' links)':62s} {kt:17.2f} {kr:22.2f}")
    out["isotropic"] = {"k_tran_1e-4_mm_per_N": kt, "k_rot_1e-7_rad_per_N_mm": kr, "table8": og.TABLE8}
    if args.map:
        xs, G = og.workspace_grid(args.map, g)
        m = og.compliance(G, links, g, args.actuator_compliance)
        ct = np.linalg.eigvalsh(m.compliance[:, :3, :3])[:, -1] * 1e3  # mm/N
        cr = np.linalg.eigvalsh(m.compliance[:, 3:, 3:])[:, -1] * 1e-3  # rad/(N mm)
        n = args.map
        ct3, cr3 = ct.reshape(n, n, n), cr.reshape(n, n, n)
        print(
            f"\nworkspace map, {n}^3 = {n**3} postures in one core call: rank 6 at {np.mean(m.rank == 6) * 100:.1f} %"
        )
        print(f"  largest translational compliance: {ct.min():.3e} .. {ct.max():.3e} mm/N")
        print(f"  largest rotational compliance:    {cr.min():.3e} .. {cr.max():.3e} rad/(N mm)")
        out["map"] = {
            "grid_mm": (xs * 1e3).tolist(),
            "ct_max_mm_per_N": ct3.tolist(),
            "cr_max_rad_per_N_mm": cr3.tolist(),
            "rank": m.rank.reshape(n, n, n).tolist(),
        }
        if args.png:
            _orthoglide_png(args.png, xs * 1e3, ct3, cr3)
            print(f"wrote {args.png}")
    elif args.png:
        raise InputError("--png needs --map N")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
        print(f"wrote {args.json}")
    return 0


def _orthoglide_png(path, xs, ct3, cr3) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(xs)
    ks = [0, n // 2, n - 1]
    fig, axs = plt.subplots(2, 3, figsize=(13, 8), constrained_layout=True)
    for row, (field, label) in enumerate(
        (
            (ct3, "log10 largest translational compliance, mm/N"),
            (cr3, "log10 largest rotational compliance, rad/(N mm)"),
        )
    ):
        lf = np.log10(field)
        levels = np.linspace(lf.min(), lf.max(), 25)
        for col, k in enumerate(ks):
            ax = axs[row, col]
            im = ax.contourf(xs, xs, lf[:, :, k].T, levels=levels, cmap="viridis")
            ax.set_title(f"z = {xs[k]:.0f} mm")
            ax.set_xlabel("x, mm")
            ax.set_ylabel("y, mm")
            ax.set_aspect("equal")
        fig.colorbar(im, ax=axs[row, :], label=label)
    fig.suptitle(
        "Orthoglide compliance over the 200 mm cube centred on the isotropic point\n"
        "(the corner -100,-100,-100 mm lies at 79 % of the way to the parallel singularity P = -L/sqrt(6) (1,1,1))"
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_smg(args) -> int:
    g = smg.SMGGeometry()
    links = smg.smg_links(_link_files(args.link_file, ("proximal", "distal")))
    if args.postures < 2:
        raise InputError("--postures must be >= 2")
    tau, P, theta, res, idx = smg.indices_along_trajectory(args.postures, links, g, args.pi_joints, args.lscale)
    print(
        f"McGill SMG, {args.postures} postures along the smoothed test trajectory "
        f"(one core call), Pi-joints: {args.pi_joints}, lscale = {idx.lscale:g} m"
    )
    print(
        f"  rank 6 at {np.mean(res.rank == 6) * 100:.1f} % of postures; "
        f"smallest stiffness eigenvalue ratio {res.ratio.min():.2e}"
    )
    print(
        f"  kappa_t: {idx.kappa_t.min():.4g} .. {idx.kappa_t.max():.4g} N "
        f"(min at tau = {tau[np.argmin(idx.kappa_t)]:.3f})"
    )
    print(
        f"  kappa_r: {idx.kappa_r.min():.4g} .. {idx.kappa_r.max():.4g} N "
        f"(min at tau = {tau[np.argmin(idx.kappa_r)]:.3f})"
    )
    if args.png:
        _smg_png(args.png, tau, P, theta, idx)
        print(f"wrote {args.png}")
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "tau": tau.tolist(),
                    "P_m": P.tolist(),
                    "theta_rad": theta.tolist(),
                    "kappa_t_N": idx.kappa_t.tolist(),
                    "kappa_r_N": idx.kappa_r.tolist(),
                    "rank": res.rank.tolist(),
                    "lscale_m": idx.lscale,
                    "pi_joints": args.pi_joints,
                },
                indent=1,
            )
        )
        print(f"wrote {args.json}")
    return 0


def _smg_png(path, tau, P, theta, idx) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 3, figsize=(15, 4.2), constrained_layout=True)
    axs[0].plot((P[:, 0] - P[0, 0]) * 1e3, (P[:, 2] - P[0, 2]) * 1e3, "k-")
    axs[0].set_xlabel("x, mm")
    axs[0].set_ylabel("z, mm")
    axs[0].set_title("smoothed test trajectory (MP turns 180 deg)")
    axs[1].plot(tau, idx.kappa_t, "b-")
    axs[1].set_title(r"translational index $\kappa_t$")
    axs[2].plot(tau, idx.kappa_r, "r-")
    axs[2].set_title(r"rotational index $\kappa_r$")
    for ax in axs[1:]:
        ax.set_xlabel("normalised time")
        ax.set_ylabel("N")
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"McGill SMG stiffness indices (eqs. 31-39, l = {idx.lscale * 1e3:.0f} mm), cf. Fig. 10")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _node(d, base: Path):
    if not isinstance(d, dict) or len(d) != 1:
        raise InputError(f"a tree node is one of {{series|parallel|spring|joint: ...}}, got {d!r:.80}")
    ((key, val),) = d.items()
    if key in ("series", "parallel"):
        if not isinstance(val, list) or not val:
            raise InputError(f"{key}: needs a non-empty list of nodes")
        kids = [_node(v, base) for v in val]
        return series(*kids) if key == "series" else parallel(*kids)
    if key == "spring":
        kinds = [k for k in ("compliance", "stiffness", "file") if k in val]
        if len(kinds) != 1:
            raise InputError("spring: give exactly one of compliance, stiffness, file")
        if kinds[0] == "file":
            f = Path(val["file"])
            m, kind = load_link_compliance(f if f.is_absolute() else base / f), "compliance"
        else:
            m, kind = np.asarray(val[kinds[0]], dtype=float), kinds[0]
        return Spring(m, pos=val.get("pos", [0, 0, 0]), rot=val.get("rot", np.eye(3)), kind=kind)
    if key == "joint":
        comp = val.get("compliance", 0.0)
        if "stiffness" in val:
            comp = 1.0 / float(val["stiffness"])
        return Joint(
            val.get("type", "revolute"),
            val["axis"],
            val.get("point", [0, 0, 0]),
            compliance=float(comp),
            passive=bool(val.get("passive", False)),
        )
    raise InputError(f"unknown tree node {key!r}: use series, parallel, spring or joint")


def run_tree(args) -> int:
    path = Path(args.tree)
    try:
        spec = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
    if "tree" not in spec:
        raise InputError(f"{path}: no 'tree' key (see stiffkit robot tree --help)")
    tree = _node(spec["tree"], path.parent)
    tool = np.asarray(spec.get("tool", [0, 0, 0]), dtype=float)
    res = evaluate(tree, tool=tool, tool_rot=spec.get("tool_axes"), lscale=spec.get("lscale"), rcond=args.rcond)
    print(
        f"{path}: rank {res.rank[0]} ({res.nfree[0]} free, {res.nrigid[0]} rigid), "
        f"eigenvalue ratio {res.ratio[0]:.3e}, lscale {res.lscale:g} m"
    )
    print("compliance" + (" (on the wrenches the free motions leave)" if res.nfree[0] else "") + ":")
    print(_fmt6(res.compliance[0]))
    print("stiffness" + (" (on the motions the rigid directions leave)" if res.nrigid[0] else "") + ":")
    print(_fmt6(res.stiffness[0]))
    for name, arr in (("free twist (t, phi)", res.free_twists(0)), ("rigid wrench (f, m)", res.rigid_wrenches(0))):
        for v in arr.T:
            print(f"{name}: " + " ".join(f"{x:10.3e}" for x in v))
    out = {
        "rank": int(res.rank[0]),
        "compliance": res.compliance[0].tolist(),
        "stiffness": res.stiffness[0].tolist(),
        "free_twists": res.free_twists(0).T.tolist(),
        "rigid_wrenches": res.rigid_wrenches(0).T.tolist(),
        "ratio": float(res.ratio[0]),
        "lscale": res.lscale,
        "compliance_exists": bool(res.nfree[0] == 0),
        "stiffness_exists": bool(res.nrigid[0] == 0),
    }
    if res.nrigid[0] == 0:
        idx = stiffness_indices(res.stiffness[0], res.lscale)
        out.update(kappa_t=float(idx.kappa_t[0]), kappa_r=float(idx.kappa_r[0]))
        print(f"kappa_t = {idx.kappa_t[0]:.4g} N, kappa_r = {idx.kappa_r[0]:.4g} N (lscale {res.lscale:g} m)")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
        print(f"wrote {args.json}")
    return 0
