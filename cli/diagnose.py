"""``stiffkit diagnose``: is what the model leaves noise? If not, what is missing?

Fits the model, then
  1. tests adequacy: chi-square of the weighted residual against the
     declared sigma_position (or, without it, the lack-of-fit F test against
     the pure error of replicated rows);
  2. scores every candidate effect the model lacks (every kind of the
     contract on every target) by a score test: the candidate's columns are
     projected off the model's, the rank left is its degrees of freedom
     (zero: already spanned, reported as non-identifiable). Ranked by the
     statistic against its dof (log p-value), with the fraction of the
     residual it explains and the RMS it would leave;
  3. flags candidates that explain the same residual: the data cannot tell
     them apart.
Nonlinear candidates are linearised at the current fit; a gravity
compensator is proposed through its generic form joint_profile, with a hint.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..calib.diagnose import diagnose, format_diagnosis
from ..calib.fit import format_table
from ..calib.measure import read_measurements
from ..calib.plots import candidates_plot, fit_plots
from ..errors import InputError
from ..robot.model import KINDS, load_model

HELP = """\
example:
  stiffkit diagnose kr270/model.toml kr270/measurements.csv --json d.json
  # then append the suggested [[effect]] table to model.toml and fit again
"""


def register(sub) -> None:
    p = sub.add_parser(
        "diagnose",
        help="test the model against the noise; rank the missing effects",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="model TOML")
    p.add_argument("measurements", help="measurement CSV")
    p.add_argument("--json", help="write the diagnosis to this JSON file")
    p.add_argument("--alpha", type=float, default=0.01, help="significance level of the adequacy test")
    p.add_argument("--sigma", type=float, help="override sigma_position (m)")
    p.add_argument("--top", type=int, default=10, help="candidates to print")
    p.add_argument("--plots", metavar="DIR", help="PNGs: the candidates, and the fit's residual figures")
    p.add_argument(
        "--kinds", help="comma-separated candidate kinds to score (default: every kind), e.g. joint,link,point_offset"
    )
    p.set_defaults(func=run)


def run(args) -> int:

    model = load_model(args.model)
    meas = read_measurements(args.measurements, model.chain.dof)
    kinds = None
    if args.kinds:
        kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
        bad = [k for k in kinds if k not in KINDS]
        if bad:
            raise InputError(f"--kinds: unknown kind(s) {', '.join(bad)}; choose from {', '.join(KINDS)}")
    dg = diagnose(model, meas, sigma_position=args.sigma, alpha=args.alpha, kinds=kinds)
    print(format_table(dg.fit))
    print()
    print(format_diagnosis(dg, top=args.top))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(dg.to_json(), fh, indent=1)
        print(f"wrote {args.json}")
    if args.plots:
        Path(args.plots).mkdir(parents=True, exist_ok=True)
        files = fit_plots(dg.fit, args.plots, label="diagnose")
        if dg.candidates:
            files.append(candidates_plot(dg, Path(args.plots) / "diagnose_candidates.png"))
        for f in files:
            print(f"wrote {f}")
    return 0
