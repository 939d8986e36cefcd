"""``stiffkit fit``: identify the elastostatic parameters of a robot model.

Reads the model (URDF + TOML effects, docs/calibration.md §2) and the measured
deflections under known wrenches (CSV, docs/calibration.md §3); solves the weighted
least squares by a rank-revealing SVD (klimchik eqs. 7-9, 15-20; nonlinear
effects by Levenberg-Marquardt); prints the residual table of klimchik
Table 2 (MAX and RMS per axis and positional, before and after
compensation) and every parameter with its standard error and group:
identifiable, non-identifiable (does not affect the data) or
semi-identifiable (only a combination with others is determined; the
coupled sets are listed).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..calib.absolute_data import AbsoluteData
from ..calib.absolute_fit import AbsoluteFit, fit_absolute
from ..calib.absolute_plots import absolute_plots
from ..calib.absolute_report import (
    format_absolute,
    format_absolute_parameters,
    load_absolute,
    residual_table,
    written_tree_model,
)
from ..calib.absolute_write import write_model as write_model_absolute
from ..calib.absolute_write import write_urdf
from ..calib.compare import compare
from ..calib.evaluation import (
    check_kind,
    evaluate_absolute,
    evaluate_deflection,
    evaluation_json,
    format_absolute_evaluation,
    format_evaluation,
    overlap_absolute,
    overlap_deflection,
    overlap_warning,
)
from ..calib.fit import FitResult, fit, format_parameters, format_table, write_model
from ..calib.measure import Measurements, read_measurements
from ..calib.plots import fit_plots
from ..calib.reduce import format_reduction, reduce_model, reduced_model
from ..calib.results import written_model
from ..calib.robust import format_checks, robust_fit
from ..errors import InputError
from ..io import validate as V
from ..io.files import check_plots_folder, model_inputs, write_json
from ..robot import catalogue
from ..robot.model import KINDS, Model, load_model
from ..robot.tree_model import model_kind
from . import args as A


def _kinds_text() -> str:
    """The deflection model's kinds (robot/catalogue.py), wrapped to the help's column."""
    lines, line = [], ""
    for k in KINDS:
        word = k if not line else f" | {k}"
        if len(line) + len(word) > 62:
            lines.append(line + " |")
            line = k
        else:
            line += word
    return ("\n" + " " * 15).join(lines + [line])


HELP = """\
inputs:
  MODEL.toml   [robot] urdf/base_link/tool_frame, optional [measurements]
               sigma_position (m), and [[effect]] tables, kind = one of
               {kinds}
  MEAS.csv     config, q1..qN, fx fy fz mx my mz, [px py pz], dx dy dz, [rx ry rz]
               (wrench at the tool-frame origin in base axes; point in tool
               coordinates; deflection in base axes; SI units)

effects (robot/catalogue.py; a parameter is printed as <target>.<name>, e.g. joint_a2.c):
{effects}
  every kind of both data kinds, its parameters and law: docs/calibration.md section 8
  a parameter that the loads do not excite (its joint's torque, or its spring column, below 1e-6 of
  the best-excited of its kind) is non-identifiable: value 0 (a placeholder) and a reason
  any effect with value = ... is known, not identified (docs/calibration.md §5)
  [measurements] sigma_position (m) weights the rows and scales the standard errors
  (else estimated from the residual); sigma_rotation (rad) for rx ry rz rows.

outputs:
  --json OUT.json        residuals, compensated fraction, parameters (docs/calibration.md §4)
  --plots DIR            residual vectors, residual histograms, measured vs predicted
  --write-model OUT.toml the model with every identified value (docs/calibration.md §5),
                         ready for `stiffkit stiffness`
  --compare OLD.json     side-by-side with an earlier fit
  --validate VAL.csv     fit on MEAS.csv, then the errors of the fitted model (the one --write-model
                         writes) on VAL.csv, fresh measurements of the same robot: the tables of
                         `stiffkit evaluate` (JSON key "validation"; plots with prefix validate_);
                         a warning when VAL.csv repeats rows of MEAS.csv
  --robust               check the data first (robust Huber fit; gross errors, unit slips,
                         with the fix) and fit without the rows it lists
  --reduce               model reduction M1-M5 (klimchik Table 1): report, then fit
                         only the selected independent parameters (the others fixed
                         at 0), so every reported parameter is identifiable

example (the loop):
  stiffkit synth kr270 --out kr270            # data with hidden effects
  stiffkit fit kr270/model.toml kr270/measurements.csv --json j1.json
  stiffkit diagnose kr270/model.toml kr270/measurements.csv
  # append the suggested [[effect]] to model.toml, then
  stiffkit fit kr270/model.toml kr270/measurements.csv --compare j1.json
  # check the calibration on fresh postures
  stiffkit fit kr270/model.toml kr270/measurements.csv --write-model fitted.toml --validate day2.csv
  stiffkit evaluate fitted.toml day2.csv        # the same errors, later, from the file
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "fit",
        help="identify a robot's elastostatic parameters from measurements",
        description=__doc__,
        epilog=HELP.replace("{kinds}", _kinds_text()).replace("{effects}", A.kinds_help(catalogue.DEFLECTION)),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML")
    p.add_argument("measurements", help="measurement CSV")
    p.add_argument("--json", help="write the results to this JSON file")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    p.add_argument("--write-model", metavar="OUT.toml", help="write the model with identified values")
    p.add_argument(
        "--write-urdf",
        metavar="OUT.urdf",
        help="absolute data: the URDF with the identified joint offsets and frame errors folded into the joint "
        "origins (with --write-model, the model then names it and leaves those effects out)",
    )
    p.add_argument("--compare", metavar="OLD.json", help="print a comparison with an earlier fit")
    p.add_argument(
        "--validate",
        metavar="VAL.csv",
        help="fresh measurements: the errors of the fitted model on them (nothing refitted), as `stiffkit evaluate`",
    )
    p.add_argument(
        "--reduce", action="store_true", help="reduce the model (M1-M5), print Table 1, fit the independent subset"
    )
    p.add_argument(
        "--sigma", type=A.number("--sigma", "sigma_position", lo=0.0, lo_open=True), help="override sigma_position (m)"
    )
    p.add_argument(
        "--robust",
        action="store_true",
        help="check the data (gross errors, unit slips) and fit without the rows listed",
    )
    p.add_argument("--quiet", action="store_true", help="table only, no parameter list")
    p.add_argument(
        "--cv",
        type=A.count("--cv", lo=2),
        metavar="K",
        help="absolute data: K-fold cross-validation with folds by config (a posture's points never split)",
    )
    p.set_defaults(func=run)


def _outputs(args: argparse.Namespace) -> None:
    """Every output path checked before anything runs (not an input, its folder writable, suffixes)."""
    inputs = [*model_inputs(args.model), args.measurements, args.compare, args.validate]
    for opt, path, suffixes in (
        ("--json", args.json, None),
        ("--write-model", args.write_model, (".toml",)),
        ("--write-urdf", args.write_urdf, (".urdf", ".xml")),
    ):
        if path:
            V.output_path(path, opt, inputs, suffixes)
    check_plots_folder(args.plots, "--plots")
    V.distinct_outputs({"--json": args.json, "--write-model": args.write_model, "--write-urdf": args.write_urdf})


@dataclass(frozen=True)
class _DataKind:
    """What ``fit`` does differently on one data kind, as data: the one path
    (:func:`run`: read -> build the model -> fit -> report -> write) calls
    these and has no second body."""

    unit: str  # what a row of the CSV is called in the messages
    refused: tuple[tuple[str, str], ...]  # (option attribute, why it is refused on this kind)
    read: Callable[[str, str], tuple[Any, Any]]  # (MODEL.toml, MEAS.csv) -> (model, data)
    read_more: Callable[[str, Any, str], Any]  # (MODEL.toml, model, VAL.csv) -> data
    fit: Callable[[Any, Any, argparse.Namespace], tuple[Any, dict]]  # -> (result, extra JSON keys)
    n_params: Callable[[Any, Any], int]  # (model, result)
    report: tuple[Callable[[Any], str], ...]  # the table, then the details (not with --quiet)
    plots: Callable[..., list]  # (result or evaluation, DIR, label=...) -> files
    overlap: Callable[[Any, Any], Any]  # (data, validation data) -> repeated rows
    written: Callable[[Any], Any]  # result -> the model --write-model writes
    evaluate: Callable[..., Any]  # (written model, data, sigma_position=) -> evaluation
    format_evaluation: Callable[[Any, str], str]  # (evaluation, sigma_from) -> text
    writers: tuple[tuple[str, Callable[[Any, str, argparse.Namespace], list[str]]], ...]  # (option attr, writer)


def _read_deflection(model_path: str, meas_path: str) -> tuple[Model, Measurements]:
    model = load_model(model_path)
    if not model.effects:
        raise InputError(
            f'{model_path}: the model has no [[effect]] table: nothing to fit (start with kind = "joint", '
            'target = "all"; stiffkit diagnose proposes what to add)'
        )
    return model, read_measurements(meas_path, model.chain.dof)


def _fit_deflection(model: Model, meas: Measurements, args: argparse.Namespace) -> tuple[FitResult, dict]:
    """The fit of deflection data: with --robust the data checks first, with --reduce M1-M5 first."""
    extra: dict = {}
    if args.robust:
        res, checks, _plain = robust_fit(model, meas, sigma_position=args.sigma)
        text = format_checks(checks)
        print(text if text else "data checks: no gross errors, no unit slips")
        if checks.set_aside:
            print(f"fitted without the {len(checks.set_aside)} rows listed")
        print()
        extra["data_checks"] = checks.to_json()
    else:
        res = fit(model, meas, sigma_position=args.sigma)
    if args.reduce:
        red = reduce_model(model, meas, sigma_position=args.sigma)
        print(format_reduction(red))
        print()
        full = res
        res = fit(reduced_model(model, red), meas, sigma_position=args.sigma)
        print(f"reduced model: {len(res.names)} free parameters (of {len(full.names)}); the others fixed at 0")
        extra["reduction"] = red.to_json()
    return res, extra


def _warned(data: AbsoluteData) -> AbsoluteData:
    for w in data.warnings:  # stderr, one line each, like every command's warnings
        V.warn(w, key=("data", w))
    return data


def _read_absolute(model_path: str, meas_path: str) -> tuple[Any, AbsoluteData]:
    model, data = load_absolute(model_path, meas_path)
    return model, _warned(data)


def _fit_absolute(model: Any, data: AbsoluteData, args: argparse.Namespace) -> tuple[AbsoluteFit, dict]:
    return fit_absolute(model, data, sigma_position=args.sigma, cv=args.cv or 0, robust=args.robust), {}


DATA_KINDS: dict[str, _DataKind] = {
    "deflection": _DataKind(
        unit="rows",
        refused=(
            (
                "write_urdf",
                "--write-urdf: a model of deflections under known loads (section 3) has no geometric effects to "
                'fold into a URDF; it is for absolute data ([measurements] kind = "absolute")',
            ),
            (
                "cv",
                "--cv: cross-validation of a fit is for absolute data; `stiffkit diagnose --cv K` "
                "cross-validates deflection data",
            ),
        ),
        read=_read_deflection,
        read_more=lambda _path, model, val: read_measurements(val, model.chain.dof),
        fit=_fit_deflection,
        n_params=lambda _model, res: len(res.names),
        report=(format_table, format_parameters),
        plots=fit_plots,
        overlap=overlap_deflection,
        written=written_model,
        evaluate=evaluate_deflection,
        format_evaluation=lambda ev, frm: format_evaluation(ev, "the fitted model", top=5, sigma_from=frm),
        writers=(("write_model", lambda res, path, _args: write_model(res, path)),),
    ),
    "absolute": _DataKind(
        unit="points",
        refused=(),
        read=_read_absolute,
        read_more=lambda path, _model, val: _warned(load_absolute(path, val)[1]),
        fit=_fit_absolute,
        n_params=lambda model, _res: len(model.params),
        report=(format_absolute, format_absolute_parameters, residual_table),
        plots=absolute_plots,
        overlap=overlap_absolute,
        written=written_tree_model,
        evaluate=evaluate_absolute,
        format_evaluation=lambda ev, frm: format_absolute_evaluation(ev, top=5, label="fitted model", sigma_from=frm),
        writers=(
            ("write_urdf", lambda res, path, _args: write_urdf(res, path)),
            ("write_model", lambda res, path, args: write_model_absolute(res, path, folded_urdf=args.write_urdf)),
        ),
    ),
}


def run(args: argparse.Namespace) -> int:
    """The one path of both data kinds: read -> build the model -> fit -> report -> write."""
    _outputs(args)
    kind = model_kind(args.model)
    for path in (args.measurements, args.validate):
        if path:
            check_kind(args.model, kind, path)
    dk = DATA_KINDS[kind]
    for opt, why in dk.refused:
        if getattr(args, opt) not in (None, False):
            raise InputError(why)
    model, data = dk.read(args.model, args.measurements)
    val = dk.read_more(args.model, model, args.validate) if args.validate else None
    res, extra = dk.fit(model, data, args)
    print(
        f"model {args.model}: {len(model.effects)} effect(s), {dk.n_params(model, res)} parameters; "
        f"{data.n} {dk.unit} from {args.measurements}"
    )
    table, *details = dk.report
    print(table(res))
    if not args.quiet:
        for part in details:
            print()
            print(part(res))
    out = {**res.to_json(), **extra}
    if args.plots:
        for f in dk.plots(res, args.plots):
            print(f"wrote {f}")
    if val is not None:
        out["validation"] = _validate(dk, res, data, val, args)
    for opt, writer in dk.writers:
        path = getattr(args, opt)
        if path:
            for note in writer(res, path, args):
                print(f"note: {note}")
            print(f"wrote {path}")
    if args.json:
        write_json(args.json, out)
        print(f"wrote {args.json}")
    if args.compare:
        print()
        print(compare(args.compare, out, names=("before", "now")))
    return 0


def _validate(dk: _DataKind, res: Any, data: Any, val: Any, args: argparse.Namespace) -> dict:
    """The fitted model as --write-model writes it, evaluated on the validation data (nothing refitted)."""
    warn = overlap_warning(dk.overlap(data, val), val.lines, val.n, args.validate, args.measurements)
    if warn:
        V.warn(warn)
    # the noise floor: the declared sigma, else the fit's estimate
    sig = args.sigma if args.sigma is not None else res.sigma
    ev = dk.evaluate(dk.written(res), val, sigma_position=sig if np.isfinite(sig) else None)
    print()
    print(f"validation: the fitted model (as --write-model writes it) on {val.n} {dk.unit} from {args.validate}")
    frm = "declared" if res.sigma_declared or args.sigma is not None else "the fit's estimate"
    print(dk.format_evaluation(ev, frm))
    if args.plots:
        for f in dk.plots(ev, args.plots, label="validate"):
            print(f"wrote {f}")
    return evaluation_json(ev)
