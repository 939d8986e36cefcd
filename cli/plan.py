"""``stiffkit plan``: which postures to measure (docs/plan.md).

Chooses K measurements among feasible candidates (postures sampled within
the joint limits, or your own list, kept when the robot clears itself and
the floor and, for tracker data, when the tracker sees every marker; for
deflection data, each posture under each load of the model's [plan] loads)
so that the calibration identifies the model's parameters best: by default
the expected position error after calibration at your task postures
(--task), else the D criterion. The plan is compared with the median of 20
random feasible designs of the same size; the report gives the expected
standard deviation of every parameter, the weak ones and why, and the
expected task error.
"""

from __future__ import annotations

import argparse

from ..errors import InputError
from ..io import validate as V
from ..io.files import FIGURE_SUFFIXES, model_inputs
from . import args as A

HELP = """\
inputs:
  MODEL.toml     a model whose parameters are to be identified (absolute: [measurements] kind = "absolute";
                 deflection: the loads you can apply in [plan] loads = [[fx, fy, fz, mx, my, mz], ...]);
                 its optional [plan] table also sets limits, capsule radius, margin, floor_z, tracker,
                 and (deflection data) the points measured on the tool: points = [[x, y, z], ...]
  --from P.csv   your own candidate postures: a column per actuated joint (or q1..qN), other columns
                 (config, frame, x, y, z, fx..mz, ...) ignored; rows of one posture count once; the
                 postures that fail a check are left out, named in a warning
  --task T.csv   the postures where the robot works: a column per actuated joint (optional frame: that
                 marker only; deflection data: optional fx..mz, the task load, else every [plan] load)
  --measured M.csv   rows already measured (the fit's measurement file): plan what adds most to them

outputs:
  POSTURES.csv   tracker data: config, the joint names, frame, x, y, z (empty: fill in what the tracker
                 measures, then `stiffkit fit MODEL.toml POSTURES.csv`; `stiffkit compensate` reads it too);
                 deflection data: config, q1..qN, fx..mz, px..pz, dx, dy, dz (the measurement file's columns)
  --json         the report; --png  expected error per task posture (plan vs random) and the chosen postures
                 (--discriminate: how each candidate and the plan tell the tied effects apart, against random designs)

examples:
  stiffkit synth dualarm --out da
  stiffkit plan da/model.toml --select 40 --task da/targets.csv --out postures.csv --png plan.png
  stiffkit plan kr/model.toml --select 12 --candidates 5000 --criterion D --json plan.json
  stiffkit plan da/model.toml --select 10 --measured da/measurements.csv --from my_postures.csv
  stiffkit plan da/model.toml --select 10 --measured da/measurements.csv --discriminate link:l_link1,link:trunk_1
  stiffkit plan kr/model.toml --select 18 --measured kr/m.csv --discriminate link:link_3:diagonal,link:link_4:beam
                 (deflection data: the (posture, load) pairs, loads from [plan] loads; named by diagnose on a tie)
  task.csv:  joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6
             0.1,-0.6,0.4,0.0,1.1,0.0
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "plan",
        help="which postures to measure: an optimal calibration experiment",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML (its parameters are what the plan identifies)")
    p.add_argument("--select", type=A.count("--select", lo=1), required=True, metavar="K", help="measurements to plan")
    src = p.add_mutually_exclusive_group()
    src.add_argument(
        "--candidates",
        type=A.count("--candidates", lo=1, hi=10**6),
        metavar="N",
        help="feasible postures to sample (default 2000)",
    )
    src.add_argument("--from", dest="postures", metavar="POSTURES.csv", help="candidate postures of your own")
    p.add_argument("--task", metavar="TASK.csv", help="the postures where the robot works (criterion task)")
    p.add_argument(
        "--criterion", choices=("task", "D", "A"), help="task (default with --task), D (default without) or A"
    )
    p.add_argument("--measured", metavar="MEAS.csv", help="rows already measured: plan the ones that add most")
    p.add_argument(
        "--sigma", type=A.number("--sigma", "sigma_position", lo=0.0, lo_open=True), help="override sigma_position (m)"
    )
    p.add_argument(
        "--discriminate",
        nargs="?",
        const="",
        metavar="A,B",
        help="the postures (deflection data: posture, load pairs) that best tell tied candidate effects apart "
        "(labels kind:target[:template]; "
        "default: the first tie the diagnosis of --measured reports); needs --measured",
    )
    p.add_argument("--out", metavar="POSTURES.csv", help="write the chosen postures here")
    p.add_argument("--json", metavar="OUT", help="write the report to this JSON file")
    p.add_argument("--png", metavar="OUT", help="write the figure here")
    p.add_argument("--seed", type=A.count("--seed", lo=0), default=0, help="seed of the sampling and random designs")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..calib.plan import plan
    from ..calib.plan_report import plan_json, plan_text, write_postures

    inputs = [*model_inputs(args.model), *(f for f in (args.postures, args.task, args.measured) if f)]
    for opt, suffixes in (("out", None), ("json", None), ("png", FIGURE_SUFFIXES)):
        if getattr(args, opt):
            V.output_path(getattr(args, opt), f"--{opt}", inputs, suffixes)
    if args.discriminate is not None:
        return run_discriminate(args)
    res = plan(
        args.model,
        args.select,
        criterion=args.criterion,
        candidates=args.candidates,
        postures=args.postures,
        task=args.task,
        measured=args.measured,
        seed=args.seed,
        sigma_position=args.sigma,
    )
    print(plan_text(res))
    if args.out:
        print(f"wrote {write_postures(args.out, res)}")
    if args.json:
        from ..io.files import write_json

        print(f"wrote {write_json(args.json, plan_json(res))}")
    if args.png:
        from ..calib.plan_plots import plan_figure

        print(f"wrote {plan_figure(res, args.png)}")
    return 0


def run_discriminate(args: argparse.Namespace) -> int:
    """``--discriminate``: T-optimal postures between tied candidates (calib/plan_discriminate.py)."""
    import numpy as np

    from ..calib.plan import discriminate, discrimination_numbers
    from ..calib.plan_report import _labels, absolute_postures_text, deflection_postures_text
    from ..io.files import atomic_write_text, write_json

    if args.task or args.criterion:
        raise InputError("--discriminate: --task and --criterion belong to the parameter plans, not here")
    tied = [t.strip() for t in args.discriminate.split(",") if t.strip()] or None
    res, cands, model = discriminate(
        args.model, args.select, args.measured, tied, args.candidates, args.postures, args.seed
    )
    defl = "loads" in res
    Q = cands.q[res["posture"] if defl else res["selected"]]
    names = res["hypotheses"]
    print(
        f"stiffkit plan --discriminate: {args.select} of {len(cands)} candidates ({cands.summary()}) to tell apart "
        f"{', '.join(names)}"
    )
    print(f"smallest noncentrality between the hypotheses: {res['value']:.4g} (sigma^2 units; > ~10: told apart)")
    w = max(len(n) for n in names)
    for a, row in zip(names, res["pairs"]):
        print(f"  {a:{w}s} " + " ".join(f"{v:10.4g}" for v in row))
    num = discrimination_numbers(res, cands, args.seed)
    rmed = float(np.median(num["random"]))
    print(
        f"  the rows measured so far: {num['before']:.4g}; median of {num['random'].size} random designs of "
        f"{args.select}: {rmed:.4g}" + (f" (the plan: {res['value'] / rmed:.3g} x)" if rmed > 0 else "")
    )
    if args.out:
        if defl:
            text = deflection_postures_text(Q, res["loads"], res["points"])
        else:
            text = absolute_postures_text(Q, cands.joint_names, model.frames)
        print(f"wrote {atomic_write_text(args.out, text)}")
    if args.json:
        doc = {
            "command": "plan",
            "discriminate": True,
            "select": args.select,
            "hypotheses": names,
            "value": res["value"],
            "pairs": res["pairs"],
            "sigma_position_m": res["sigma_position_m"],
            "before": num["before"],
            "random": {"designs": int(num["random"].size), "seed": args.seed + 1, "median_value": rmed},
            # as the parameter plan's: the config label of POSTURES.csv, the candidate, the joint values
            "selected": [
                {"config": label, "candidate": int(c), "q": dict(zip(cands.joint_names, map(float, q)))}
                for label, c, q in zip(_labels(len(Q)), res["selected"], Q)
            ],
        }
        if defl:  # the wrench of each chosen (posture, load) pair
            for d, w in zip(doc["selected"], res["loads"]):
                d["load"] = [float(v) for v in w]
        print(f"wrote {write_json(args.json, doc)}")
    if args.png:
        from ..calib.plan_plots import discrimination_figure

        print(f"wrote {discrimination_figure(res, cands, args.png, args.seed)}")
    return 0
