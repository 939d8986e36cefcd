"""``stiffkit compensate``: joint commands that make the identified robot
reach where the nominal one would (docs/calibration.md section 6.5).

For every row of TARGETS.csv (a joint command q, optionally its frame and
a payload wrench) the command q' for which the identified model (geometry
and elastic deflection at equilibrium, every effect with its value) puts
the frame where the nominal model (the URDF alone) puts it at q: position
and orientation when 6 or more independent joints move the frame (the
least-norm change of q for a redundant chain), the position otherwise.
COMMANDS.csv repeats the input's columns with q' in the joint columns and
adds residual_position_m, residual_rotation_rad, converged (1/0) and mode
(pose/position). Rows that do not converge (a target out of reach, a
singular posture) are flagged there and named in a warning.
"""

from __future__ import annotations

import argparse

from ..robot.compensate import compensate

HELP = """\
inputs:
  MODEL.toml    a model with values: absolute ([measurements] kind = "absolute", section 6,
                e.g. written by `stiffkit fit --write-model`) or relative (sections 2-5)
  TARGETS.csv   one row per command: a column per actuated joint of the URDF (or q1..qN), rad;
                optional frame (a link of the URDF; default: --frame, [robot] tool_frame or the
                model's single marker frame); optional fx fy fz mx my mz (N, N m, all or none):
                a payload at the frame origin, base axes (relative models: the row's wrench at
                the tool frame; the nominal pose is the unloaded one); other columns are copied

outputs:
  --out COMMANDS.csv   the input's columns, joint columns replaced by q', plus
                       residual_position_m, residual_rotation_rad (what is left; for position-only
                       rows the orientation error, which is not compensated), converged, mode

examples:
  stiffkit compensate identified.toml trajectory.csv --out commands.csv
  stiffkit compensate identified.toml targets.csv --out commands.csv --frame right_tcp
  trajectory.csv:  config,joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6
                   p1,0.1,-0.5,0.3,0.0,1.2,0.0
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "compensate",
        help="joint commands that make the identified robot reach the nominal targets",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML with values (absolute or relative)")
    p.add_argument("targets", help="CSV of joint commands (TARGETS.csv)")
    p.add_argument("--out", required=True, metavar="COMMANDS.csv", help="write the compensated commands here")
    p.add_argument("--frame", metavar="F", help="the frame of every row when TARGETS.csv has no frame column")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    rep = compensate(args.model, args.targets, args.out, args.frame)
    print(rep.text())
    return 0
