"""``stiffkit convergence``: a mesh-convergence study of one link (Table 5).

Runs the LINK.toml job for every element order and size given, in parallel
(-j: a local Dask cluster of N run slots; --scheduler: a Dask cluster), each
in a process of its own and through the cache (an interrupted study resumes
where it stopped), and prints per run: nodes, the largest relative error of the
significant compliance elements (vs the closed form when the shape has one,
else vs a Richardson extrapolation of the finest meshes), the element that
limits it, wall time and peak memory. A PNG plots error and time vs size.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from ..errors import InputError
from ..fea.config import load_link
from ..fea.convergence import plot, table, to_json
from ..io import validate as V
from ..io.files import FIGURE_SUFFIXES, link_inputs, write_json
from ..sweep.convergence import run_study
from ..sweep.runner import check_address
from ..sweep.study import parse_memory

HELP = """\
examples:
  stiffkit convergence examples/beam.toml --orders 1,2 --sizes 5,3,2 -j 2
  stiffkit convergence examples/orthoglide_axle.toml --orders 2 --sizes 6,4,3 --png axle.png

Sizes are in the geometry units of LINK.toml. Wall time includes meshing,
the FEA and the fit; runs taken from the cache report the time and memory
of their original run (use another --cache folder to run them again).
Memory: peak resident size of the run's processes (ccx; Python with CHOLMOD).
A run starts only when its memory (estimated from its node count) fits
beside the running ones (--memory, default 90 % of the available memory).
An interrupted study (Ctrl-C) resumes from the runs already finished.
Runs run on the same machinery as `stiffkit sweep` (see its --help for
--scheduler); a run that fails is listed with its reason, the others finish,
and the exit status is 3.
"""


def _list(text: str, kind: Callable[[str], object], what: str) -> list:
    try:
        vals = [kind(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise InputError(f"{what}: {text!r} is not a comma-separated list") from None
    if not vals:
        raise InputError(f"{what}: empty list")
    return vals


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "convergence",
        help="mesh-convergence study of a link (orders x sizes)",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("link", help="LINK.toml of the part")
    p.add_argument("--orders", default="1,2", help="element orders, e.g. 1,2 (default %(default)s)")
    p.add_argument("--sizes", default="5,3,2", help="element sizes in geometry units (default %(default)s)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("-j", "--jobs", type=int, help="runs in parallel on this machine (default 1)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--memory", help="memory the local runs may use, e.g. 8G (default 90 %% of what is free)")
    p.add_argument("--cache", default=".stiffkit-cache", help="cache folder (default %(default)s)")
    p.add_argument("--json", help="write the study to this JSON file")
    p.add_argument("--png", default="convergence.png", help="plot file (default %(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    inputs = link_inputs(args.link)
    if args.json:
        V.output_path(args.json, "--json", inputs)
    if args.png:
        V.output_path(args.png, "--png", inputs, FIGURE_SUFFIXES)
    V.distinct_outputs({"--json": args.json, "--png": args.png})

    job = load_link(args.link)
    orders = _list(args.orders, int, "--orders")
    sizes = _list(args.sizes, float, "--sizes")
    if any(o not in (1, 2) for o in orders):
        raise InputError(f"--orders {args.orders}: orders are 1 (C3D4) and 2 (C3D10)")
    if any(not (s > 0 and s < float("inf")) for s in sizes):
        raise InputError(f"--sizes {args.sizes}: sizes must be positive")
    if args.jobs is not None and args.jobs < 1:
        raise InputError(f"-j {args.jobs}: at least 1")
    if args.scheduler:
        check_address(args.scheduler)

    study = run_study(
        job,
        orders,
        sizes,
        args.cache,
        jobs=args.jobs or 1,
        progress=not args.quiet,
        scheduler=args.scheduler,
        memory_mb=parse_memory(args.memory),
    )
    print(table(study))
    if args.json:
        write_json(args.json, to_json(study))
        print(f"wrote {args.json}")
    if args.png and study["records"]:
        print(f"wrote {plot(study, args.png)}")
    return 3 if study["failed"] else 0
