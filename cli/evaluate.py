"""``stiffkit evaluate``: the errors of a model as it is on measurements.

Nothing is fitted: every parameter takes the value of the model file (one
written by ``stiffkit fit --write-model``, or written by hand). Prints the
error table of ``fit`` (deflection data: MAX and RMS per axis and
positional, klimchik Table 2; absolute data: mean, RMS and max point error
per frame) and the rows with the largest errors; ``--json`` holds the
summary and every row's error, ``--plots`` the figures of ``fit``. Use it
to check a calibration on a second, fresh set of measurements.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..calib.absolute_plots import absolute_plots
from ..calib.absolute_report import load_absolute
from ..calib.evaluation import (
    check_kind,
    evaluate_absolute,
    evaluate_deflection,
    evaluation_json,
    format_absolute_evaluation,
    format_evaluation,
)
from ..calib.measure import read_measurements
from ..calib.plots import fit_plots
from ..errors import InputError
from ..io import validate as V
from ..io.files import write_json
from ..robot.model import load_model
from ..robot.tree_model import model_kind
from . import args as A

HELP = """\
inputs:
  MODEL.toml   a model with values: every [[effect]] with its value (and, for absolute
               data, the tracker's xyz/rpy and every marker's xyz), as written by
               `stiffkit fit MODEL.toml MEAS.csv --write-model FITTED.toml`
  MEAS.csv     measurements of the model's kind: deflections under known loads
               (config, q1..qN, fx..mz, [px py pz], dx dy dz) or, with [measurements]
               kind = "absolute", tracker points (config, joints, frame, x, y, z)

what is printed:
  the error table of `fit` for the model as it is (nothing fitted): deflection data
  against the deflections themselves (no compensation); absolute data against the
  nominal robot (the URDF with the model's tracker and markers); with a declared
  sigma, the RMS against the noise floor; then the rows with the largest errors.
  A model effect without a value is an error (evaluate does not identify anything).

outputs:
  --json OUT.json   summary (the keys of fit's JSON) and "rows": per row its line,
                    config, [frame], measured, predicted, error (m) and its length
  --plots DIR       the figures of fit, for these errors (prefix evaluate_)

examples (validation on fresh data):
  stiffkit fit model.toml day1.csv --write-model fitted.toml
  stiffkit evaluate fitted.toml day2.csv --json day2.json
  stiffkit fit model.toml day1.csv --validate day2.csv     # the same, in one run
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "evaluate",
        help="the errors of a model with values on (fresh) measurements; nothing fitted",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML with values (fit --write-model)")
    p.add_argument("measurements", help="measurement CSV")
    p.add_argument("--json", help="write the errors (summary and per row) to this JSON file")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    p.add_argument(
        "--sigma",
        type=A.number("--sigma", "sigma_position", lo=0.0, lo_open=True),
        help="override sigma_position (m): the noise floor the errors are compared with",
    )
    p.add_argument("--top", type=A.count("--top", lo=0), default=10, help="rows with the largest errors to print")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.json:
        V.output_path(args.json, "--json", [args.model, args.measurements])
    if args.plots and Path(args.plots).exists() and not Path(args.plots).is_dir():
        raise InputError(f"--plots {args.plots}: a file, not a folder")
    kind = model_kind(args.model)
    check_kind(args.model, kind, args.measurements)
    if kind == "absolute":
        model, data = load_absolute(args.model, args.measurements)
        for w in data.warnings:
            V.warn(w, key=("data", w))
        ev = evaluate_absolute(model, data, sigma_position=args.sigma)
        print(f"model {args.model} as it is (nothing fitted) on {data.n} points from {args.measurements}")
        print(format_absolute_evaluation(ev, top=args.top))
        out = evaluation_json(ev)
        files = absolute_plots(ev, args.plots, label="evaluate") if args.plots else []  # type: ignore[arg-type]
    else:
        model = load_model(args.model)
        meas = read_measurements(args.measurements, model.chain.dof)
        res = evaluate_deflection(model, meas, sigma_position=args.sigma)
        print(f"model {args.model} as it is (nothing fitted) on {meas.n} rows from {args.measurements}")
        print(format_evaluation(res, args.model, top=args.top))
        out = evaluation_json(res)
        files = fit_plots(res, args.plots, label="evaluate") if args.plots else []
    for f in files:
        print(f"wrote {f}")
    if args.json:
        write_json(args.json, out)
        print(f"wrote {args.json}")
    return 0
