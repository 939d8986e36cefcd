"""``stiffkit synth``: measurement data with a known truth and hidden effects.

Writes robot.urdf, model.toml (the effects to identify, without values),
truth.toml (the truth, with values) and measurements.csv into --out.

ROBOT is ``kr270`` (a built-in KR-270-like 6R robot: approximate KUKA
KR 270 R2700 datasheet dimensions; joint compliances of klimchik's
magnitude; aluminium-tube links 2-4; a gravity compensator on A2), a truth
model TOML whose effects carry values (its URDF is copied), or ``dualarm``:
a humanoid upper body (torso with a coupled pitch, two 7-joint arms)
measured by a laser tracker (docs/calibration.md section 6): absolute
positions of a reflector on each hand, the truth's zero offsets, frame
errors, joint and lateral compliances under the robot's weight hidden in
them; model.toml holds only the tracker and the two markers, and
targets.csv a held-out trajectory for ``stiffkit compensate``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..calib import dualarm as DA
from ..calib import synth as S
from ..errors import InputError
from ..io.files import model_inputs
from ..robot.model import load_model
from . import args as A

HELP = """\
examples:
  stiffkit synth kr270 --out kr270                  # joints-only model.toml (the paper's J1)
  stiffkit synth kr270 --out g --loads gravity      # forces along -z only
  stiffkit synth kr270 --out o --offset 0.01,0,0.02 # plus an unknown marker offset
  stiffkit synth truth.toml --out d --configs 50 --sigma 1e-5
  stiffkit synth dualarm --out da                   # tracker data of a dual-arm robot
  stiffkit synth dualarm --out dg --truth geometric --configs 200 --seed 7

loads:   random = 2.5 kN in a random direction plus moments up to 300 N m;
         gravity = a weight (0, 0, -F) hung 0.2 m along the tool z axis.
markers: points on the tool (tool frame), each measured for every load.
dualarm: 400 postures, sigma 1e-4 m by default; --loads, --markers, --force,
         --moment, --replicates, --fit and the kr270 options do not apply.
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "synth",
        help="synthetic calibration data with a known truth",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("robot", help="kr270, dualarm or a truth model TOML with values")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the files of an earlier synth in --out (refused otherwise; --force is the load's magnitude)",
    )
    p.add_argument(
        "--configs",
        type=A.count("--configs", 1, S.MAX_ROWS),
        default=None,
        help=f"number of robot configurations (default 30; dualarm {DA.DEFAULT_CONFIGS})",
    )
    p.add_argument("--loads", choices=["random", "gravity"], default="random")
    p.add_argument(
        "--loads-per-config", type=A.count("--loads-per-config", 1, 1000), default=3, help="wrenches per configuration"
    )
    p.add_argument(
        "--force", type=A.number("--force", "force", lo=0.0, lo_open=True), default=2500.0, help="force magnitude (N)"
    )
    p.add_argument(
        "--moment", type=A.number("--moment", "moment", lo=0.0), default=300.0, help="moment bound (N m), random loads"
    )
    p.add_argument("--markers", type=int, default=3, choices=[1, 2, 3, 4], help="points on the tool")
    p.add_argument(
        "--sigma",
        type=A.number("--sigma", "sigma_position", lo=0.0),
        default=None,
        help=f"noise std of each coordinate (m; default 2e-5, dualarm {DA.DEFAULT_SIGMA:g}); "
        "0: noise-free data (then not declared in model.toml)",
    )
    p.add_argument(
        "--replicates", type=A.count("--replicates", 1, 100), default=1, help="repeat each measurement (pure error)"
    )
    p.add_argument("--no-sigma", action="store_true", help="do not declare sigma_position in model.toml")
    p.add_argument("--seed", type=A.count("--seed", 0), default=1, help="seed of the random numbers (>= 0)")
    p.add_argument("--no-compensator", action="store_true", help="kr270: no gravity compensator")
    p.add_argument("--no-links", action="store_true", help="kr270: rigid links")
    p.add_argument("--offset", help="kr270: unknown marker offset r = x,y,z (m, tool frame)")
    p.add_argument(
        "--fit",
        choices=["joints", "truth"],
        default="joints",
        help="effects of model.toml: joints only (J1) or the truth's effects",
    )
    p.add_argument("--truth", choices=DA.TRUTHS, default="full", help="dualarm: the truth's effects (geometric: rigid)")
    p.add_argument(
        "--targets",
        type=A.count("--targets", 1, 10**5),
        default=DA.DEFAULT_TARGETS,
        help="dualarm: postures of the held-out trajectory (targets.csv)",
    )
    p.set_defaults(func=run)


MARKERS = [(0.0, 0.0, 0.25), (0.12, 0.0, 0.2), (0.0, 0.12, 0.2), (-0.1, -0.1, 0.22)]


def run(args: argparse.Namespace) -> int:
    # a truth model and its nominal URDF are inputs; its URDF is copied, and
    # left alone when it is the robot.urdf of --out already
    truth_inputs = [] if args.robot in ("kr270", "dualarm") else model_inputs(args.robot)
    truth_inputs = truth_inputs[:1] + truth_inputs[2:]
    files = DA.OUTPUT_FILES if args.robot == "dualarm" else S.OUTPUT_FILES
    S.check_out_folder(args.out, files, args.overwrite, truth_inputs)
    if args.robot == "dualarm":
        configs = DA.DEFAULT_CONFIGS if args.configs is None else args.configs
        out = DA.synth_dualarm(
            args.out,
            configs=configs,
            seed=args.seed,
            sigma=DA.DEFAULT_SIGMA if args.sigma is None else args.sigma,
            truth=args.truth,
            targets=args.targets,
        )
        print(DA.summary(out, configs, args.targets))
        return 0
    args.configs = 30 if args.configs is None else args.configs
    args.sigma = 2e-5 if args.sigma is None else args.sigma
    n = args.configs * args.loads_per_config * args.markers * args.replicates
    if n > S.MAX_ROWS:
        raise InputError(f"--configs x --loads-per-config x --markers x --replicates = {n} rows; at most {S.MAX_ROWS}")
    out = Path(args.out)
    kw = dict(
        n_configs=args.configs,
        loads=args.loads,
        loads_per_config=args.loads_per_config,
        markers=MARKERS[: args.markers],
        sigma=args.sigma,
        replicates=args.replicates,
        force=args.force,
        moment=args.moment,
        seed=args.seed,
    )
    if args.robot == "kr270":
        offset = A.vector(args.offset, 3, "--offset (m)", "position") if args.offset else None
        truth = S.kr270_truth(links=not args.no_links, compensator=not args.no_compensator, offset=offset)
        joints = S.KR270_JOINTS
        kw["ranges"] = S.KR270_RANGES
    else:
        path = Path(args.robot)
        if not path.is_file():
            raise InputError(f"{path}: no such truth model (give kr270 or a TOML with values)")
        m = load_model(path)  # checks the file
        truth = m.effects
        for t in m.terms:
            if t.free:
                raise InputError(f"{path}: effect {t.source} on {t.target!r} has no value; a truth needs values")
        joints = Path(m.chain.urdf)
        kw["tool_frame"] = m.chain.tool_frame
    fit_effects = [{"kind": "joint", "target": "all"}] if args.fit == "joints" else S.strip_values(truth)
    out = S.write_synth(args.out, joints, truth, fit_effects, declare_sigma=not args.no_sigma, **kw)
    print(f"wrote {out}/robot.urdf, model.toml ({args.fit}), truth.toml, measurements.csv ({n} rows)")
    return 0
