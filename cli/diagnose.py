"""``stiffkit diagnose``: is what the model leaves noise? If not, what is missing?

Fits the model, then
  0. checks the data before blaming the model: a robust fit (IRLS, Huber
     weights) lists rows whose residual is a gross error (Bonferroni over
     the rows, standing out from their configuration), configurations
     recorded in the wrong unit (mm or um for m, degrees for radians, a
     load in kN) with the fix, and configurations off as a whole. Gross
     errors and unit slips are set aside for the rest; when the model then
     fits the rest to the noise, no effect is proposed, and it says so;
  1. tests adequacy: chi-square of the weighted residual against the
     declared sigma_position (or, without it, the lack-of-fit F test against
     the pure error of replicated rows), and beside it the best candidate's
     score test corrected for having looked at every candidate (max-score
     test, Monte Carlo in the core): a weak effect the omnibus test dilutes
     still raises the alarm;
  2. scores every candidate effect the model lacks (every kind of the
     contract on every target, and the extensions joint_cubic, dq = c tau +
     c3 tau^3, and joint_deadzone, dq = c tau + b tanh(tau / tau0), for
     joints whose deflection is not linear in the load) by a score test: the
     candidate's columns are projected off the model's, the rank left is its
     degrees of freedom (zero: already spanned, reported as
     non-identifiable). Ranked by the statistic against its dof (log
     p-value), with the share of the residual (and of its excess above the
     noise) it explains, the RMS it would leave and, for the leaders, the
     held-out RMS (cross-validation by configuration);
  3. reports honestly: candidates whose explained parts coincide are
     indistinguishable; rivals within 1 in log10 p of the leader (or better
     on held-out configurations) are undecidable together, with the posture
     and load that would separate them; few residual degrees of freedom and
     an 'adequate' below 0.8 x the noise floor are warned about; when the
     best candidate explains well under half of the excess residual,
     nothing in the catalogue fits, and the residual's shape is shown
     (against each joint's torque and angle, the row order, the
     configurations; --plots draws them).
Every effect already in the model is also tested without
it (backward steps: its values against the noise, the held-out error
without it); one that no longer earns its place is proposed for removal
before any addition (--prune: only these steps, the verdict from the
adequacy test).
A ready [[effect]] table is proposed only when the model is inadequate, the
leader is not tied, something fits, and it lowers the held-out error.
Nonlinear candidates are linearised at the current fit; a gravity
compensator is proposed through its generic form joint_profile, with a hint
when a compensator's shape reproduces the profile found.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..calib.absolute_plots import absolute_plots
from ..calib.absolute_report import format_absolute
from ..calib.diagnosis_files import diagnose_files, format_report
from ..calib.fit import format_table
from ..calib.plots import candidates_plot, fit_plots, residual_plots
from ..errors import InputError
from ..io import validate as V
from ..io.files import check_plots_folder, model_inputs, write_json
from ..robot import catalogue
from ..robot.tree_model import model_kind
from . import args as A

HELP = """\
JSON (--json): the contract keys (verdict, sigma_position_m, rms_position_m,
candidates[kind, target, statistic, p_value, explained_fraction, rms_after_m,
effect]) and the extensions: data_checks {outliers, unit_slips, angle_units,
outlying_configurations, set_aside}, verdict_all_rows, multiplicity_p,
bonferroni_p, omnibus_inadequate, cv_rms_position_m (model and per candidate),
ties [{candidates, separate_by}], nothing_fits, proposal (the [[effect]] table
or null), no_proposal_reasons, warnings, residual_map, residual_shapes,
non_identifiable_candidates [{kind, target, effect, reason}]; per candidate
excess_fraction (the share of the residual above the noise it explains,
null when the noise is unknown); backward_steps
[{effect_index, effect, statistic, dof, log10_p_value, max_abs_value,
rms_without_m, cv_rms_position_m_without, remove, why}], removal (or null),
prune.

extension kinds (docs/calibration.md s7), also usable in MODEL.toml:
  joint_cubic     dq = c tau + c3 tau^3, tau the torque of the row's wrench about the joint
                  (hardening c3 < 0, softening c3 > 0) -> J.cubic, value = c3
  joint_deadzone  dq = c tau + b tanh(tau / tau0), backlash +-b (rad) -> J.backlash, value = b;
                  tau0 (N m) defaults to 5 % of the RMS torque about the joint in the data

{catalogue}
plots (--plots DIR): candidates; residual vectors, histograms, measured vs
predicted; residual vs joint angle, vs joint torque, per configuration, along
the row order.

example:
  stiffkit diagnose kr270/model.toml kr270/measurements.csv --json d.json --plots figs
  # then append the suggested [[effect]] table to model.toml and fit again
"""


def _catalogue_text() -> str:
    """The kinds scored as candidates on each data kind (robot/catalogue.py)."""
    lines = ["candidates (every kind, its parameters and law: docs/calibration.md s8):"]
    for data in catalogue.DATA_KINDS:
        names = [e.name for e in catalogue.ENTRIES if data in e.data and data in e.candidate_in and e.candidates]
        lines.append(f"  {data + ' data:':17s}" + ", ".join(names))
    return "\n".join(lines) + "\n"


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "diagnose",
        help="test the model against the noise; rank the missing effects",
        description=__doc__,
        epilog=HELP.replace("{catalogue}", _catalogue_text()),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML")
    p.add_argument("measurements", help="measurement CSV")
    p.add_argument("--json", help="write the diagnosis to this JSON file")
    p.add_argument(
        "--alpha",
        type=A.number("--alpha", lo=0.0, hi=0.5, lo_open=True),
        default=0.01,
        help="significance level of the adequacy test, in (0, 0.5] (default 0.01)",
    )
    p.add_argument(
        "--sigma", type=A.number("--sigma", "sigma_position", lo=0.0, lo_open=True), help="override sigma_position (m)"
    )
    p.add_argument("--top", type=A.count("--top", lo=1), default=10, help="candidates to print")
    p.add_argument(
        "--plots", metavar="DIR", help="PNGs: the candidates, the fit's residual figures, where the residual lives"
    )
    p.add_argument("--no-checks", action="store_true", help="skip the data checks (robust fit, gross errors, units)")
    p.add_argument(
        "--cv",
        type=A.count("--cv", lo=0),
        default=5,
        metavar="K",
        help="folds of the cross-validation by configuration (0: off; a proposal needs its held-out check, so "
        "nothing is then proposed)",
    )
    p.add_argument(
        "--prune",
        action="store_true",
        help="backward steps only: test every effect of the model without it (its values against the noise, "
        "the held-out error without it) and propose removing one that no longer earns its place, no addition; "
        "the verdict is the adequacy test's",
    )
    p.add_argument(
        "--kinds", help="comma-separated candidate kinds to score (default: every kind), e.g. joint,link,point_offset"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Both observation kinds through one pipeline (calib/diagnosis.py)."""
    if args.json:
        V.output_path(args.json, "--json", [*model_inputs(args.model), args.measurements])
    check_plots_folder(args.plots, "--plots")
    if args.cv == 1:
        raise InputError("--cv 1: cross-validation needs at least 2 folds (0 switches it off)")
    absolute = model_kind(args.model) == "absolute"
    kinds = None
    if args.kinds:
        known = catalogue.kinds(catalogue.ABSOLUTE if absolute else catalogue.DEFLECTION)
        kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
        bad = [k for k in kinds if k not in known]
        if bad:
            raise InputError(f"--kinds: unknown kind(s) {', '.join(bad)}; choose from {', '.join(known)}")
    dg, kind = diagnose_files(
        args.model,
        args.measurements,
        sigma_position=args.sigma,
        alpha=args.alpha,
        kinds=kinds,
        checks=not args.no_checks,
        cv_folds=args.cv,  # 0: off, both kinds (then nothing is proposed: calib.diagnosis.folds_of)
        prune=args.prune,
    )
    if kind == "absolute":
        print(format_absolute(dg.fit))
    else:
        print(format_table(dg.fit_all if dg.fit_all is not None else dg.fit))
    print()
    print(format_report(dg, kind, top=args.top))
    if args.json:
        write_json(args.json, dg.to_json())
        print(f"wrote {args.json}")
    if args.plots:
        for f in _plots(dg, kind, args.plots):
            print(f"wrote {f}")
    return 0


def _plots(dg: object, kind: str, folder: str) -> list:
    if kind == "absolute":
        return absolute_plots(dg.fit, folder, label="diagnose")
    Path(folder).mkdir(parents=True, exist_ok=True)
    files = fit_plots(dg.fit, folder, label="diagnose")
    if dg.candidates:
        files.append(candidates_plot(dg, Path(folder) / "diagnose_candidates.png"))
    return files + residual_plots(dg, folder, label="diagnose")
