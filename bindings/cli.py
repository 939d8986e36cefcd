"""The ``stiffkit`` command line: one program, one subcommand per job.

Each subcommand lives in its own module that provides ``register(sub)``
(adds its parser and sets ``func``); modules are imported lazily so that
``stiffkit --help`` is fast and a broken optional dependency only affects
its own command.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from ._errors import StiffkitError

# (module, one-line summary); the module's register() builds the parser
COMMANDS = [
    ("stiffkit.cmd_field", "field: fit (t, phi) of node displacement fields; compliance from six load cases"),
    ("stiffkit.cmd_robot", "robot: manipulator stiffness from generalised springs (Orthoglide, SMG, your tree)"),
    ("stiffkit.cmd_stiffness", "stiffness: tool compliance/stiffness of a robot model with values"),
    ("stiffkit.cmd_fit", "fit: identify elastostatic parameters from measured deflections"),
    ("stiffkit.cmd_diagnose", "diagnose: is the residual noise? rank the missing effects"),
    ("stiffkit.cmd_compare", "compare: two fit results side by side"),
    ("stiffkit.cmd_synth", "synth: calibration data with a known truth and hidden effects"),
    ("stiffkit.cmd_link", "link: a link's compliance matrix from its CAD (Gmsh + CalculiX + field fit)"),
    ("stiffkit.cmd_convergence", "convergence: mesh-convergence study of a link (Table 5)"),
    ("stiffkit.cmd_sweep", "sweep: design sweep of a link on Dask (any LINK.toml keys)"),
    ("stiffkit.cmd_demo", "demo: the main job on a built-in example"),
]

EPILOG = """\
examples:
  stiffkit demo                       run the built-in example
  stiffkit link examples/beam.toml --json beam.json
  stiffkit convergence examples/beam.toml --orders 1,2 --sizes 5,3,2 -j 2
  stiffkit sweep examples/beam.toml --vary mesh.size=5,3 --vary material.E=7e10,2e11 --csv s.csv
  stiffkit field nodes.csv disp1.csv ... disp6.csv --reference 1,0,0 --loads 1000,1,1,1,1,1
  stiffkit synth kr270 --out kr270    calibration data of a KR-270-like robot
  stiffkit fit kr270/model.toml kr270/measurements.csv
  stiffkit diagnose kr270/model.toml kr270/measurements.csv
  stiffkit COMMAND --help             what a command does, its inputs and outputs

All files are SI (m, N, N m, rad)."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stiffkit",
        description="How stiff a robot is, and why it bends the way it does.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    from . import __version__
    parser.add_argument("--version", action="version", version=f"stiffkit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for modname, _summary in COMMANDS:
        importlib.import_module(modname).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except StiffkitError as exc:
        print(f"stiffkit {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"stiffkit {args.command}: error: file not found: {exc.filename}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"stiffkit {args.command}: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"stiffkit {args.command}: interrupted", file=sys.stderr)
        return 130
