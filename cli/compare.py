"""``stiffkit compare``: two fit results side by side (before / after)."""

from __future__ import annotations

import argparse

from ..calib.compare import compare


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "compare",
        help="compare two fit results (JSON of stiffkit fit --json)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example:\n  stiffkit compare j1.json c2.json",
    )
    p.add_argument("a", help="first fit JSON (e.g. before adding an effect)")
    p.add_argument("b", help="second fit JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    print(compare(args.a, args.b, names=(args.a, args.b)))
    return 0
