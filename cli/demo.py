"""``stiffkit demo``: the main jobs on built-in examples, in four parts
(``--only field|fea|calib|tracker`` runs one).

field  The paper's illustrative example without FEA: the 1000 x 10 x 10 mm
       steel cantilever (E = 200 GPa, nu = 0.266), the six load cases of
       s4.2, its tip face as a 11 x 11 node field with FEA-like noise
       (sigma = 5e-5 mm, Table 4) and 5 % gross outliers. Each field is
       fitted (exact estimator: the paper's loads turn the tip by up to
       0.5 deg, where LIN's linearisation residual exceeds the noise), the
       compliance is built with confidence intervals, the zero elements
       are flagged and the result compared with the closed form (eq. 22).
fea    The real pipeline on the same beam: Gmsh meshes it with C3D10
       tetrahedra of 5 mm, CalculiX assembles the stiffness, CHOLMOD solves
       the six load cases, the tip face is fitted, and the compliance is
       compared with eq. 22 (a few seconds; `stiffkit link` runs any
       LINK.toml). Then a bored link (examples/bored_link.toml): clamped
       in its bearing bore, loaded through a pin hole (CAD face selectors,
       rigid coupling, C3D10 4 mm), beside a single-beam approximation;
       the mesh with its selected faces (PNG) and the VTU in --out.
calib  A KR-270-like robot measured under load (synthetic, with a known
       truth): fit the joints-only model (the paper's J1), diagnose, add
       what the diagnosis names, refit, and watch the error fall to the
       noise floor; tables printed, figures in --out.
tracker A dual-arm humanoid measured by a laser tracker (synthetic: hidden
       tracker pose, markers, joint offsets, frame errors, joint and lateral
       compliance under its own weight): from the tracker and the hand
       markers only, diagnose, append the proposal, fit, until the error
       reaches the noise floor; then the identified model compensates a
       held-out trajectory of the true robot (error before and after).
       Data, model.toml (as it grew) and error_fall.png in --out/tracker.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..calib.absolute_demo import tracker_demo
from ..calib.demo import calibration_demo
from ..errors import InputError
from ..fea.demo import bored_link_demo, fea_demo
from ..field.demo import field_demo
from . import args as A


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "demo",
        help="run the main job on a built-in example",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--seed", type=A.count("--seed", 0), default=1, help="seed of the random numbers (>= 0)")
    p.add_argument("--only", choices=["field", "fea", "calib", "tracker"], help="run one part of the demo only")
    p.add_argument("--no-fea", action="store_true", help="skip the real FEA run")
    p.add_argument(
        "--size",
        type=A.number("--size", lo=1.0, hi=10.0),
        default=5.0,
        help="element size of the FEA demo, mm, 1-10 (default 5; 1 mm is about a million nodes)",
    )
    p.add_argument("--out", default="build/demo", help="folder for the calibration demo's data and figures")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise InputError(f"--out {args.out}: a file, not a folder")
    if args.only in (None, "field"):
        field_demo(args.seed)
    if args.only in (None, "fea") and not args.no_fea:
        fea_demo(args.size)
        bored_link_demo(args.out)
    if args.only in (None, "calib"):
        calibration_demo(args.out, seed=args.seed)
    if args.only in (None, "tracker"):
        tracker_demo(Path(args.out) / "tracker", seed=args.seed)
    return 0
