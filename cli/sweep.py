"""``stiffkit sweep``: a design sweep of a link on Dask.

Runs LINK.toml once for every combination of the values given with --vary
(the Cartesian product, or side by side with --zip), each run one Dask task
in a process of its own, and gathers one table: per run the varied values,
status (a failed run keeps its one-line reason and does not stop the
others), nodes, wall time, peak memory, the compliance k11..k66 with the
half-widths of its confidence intervals, and the largest error against the
closed form where the shape has one.
"""

from __future__ import annotations

import argparse

from ..sweep.study import command

HELP = """\
keys (dotted paths into LINK.toml; checked before anything runs):
  section.key            material.E, material.nu, mesh.size, mesh.order, mesh.mesher,
                         fit.method, solver.route, support.tolerance, geometry.step, ...
  section.key.N          element N of a list: geometry.size.0 (a box's length),
                         load.reference_point.0; or a whole list: geometry.size=[100,5,5],[200,5,5]
  geometry.wall          wall of a tube (inner_diameter = outer_diameter - 2 wall)
  One --vary is one axis; several KEY=VALUES in one --vary (separated by spaces)
  move together, e.g. a length and the reference point at the tip:
      --vary "geometry.size.0=100,200 load.reference_point.0=100,200"

where runs go:
  default        a local Dask cluster: as many run slots as cores, and a run starts
                 only when its memory (estimated from its node count before it
                 starts) fits beside the running ones within 90 % of the available
                 memory (--memory to set it): two 4 GB runs do not start together
                 on an 8 GB machine
  -j N           N run slots on this machine
  --scheduler A  a running cluster (dask scheduler; dask worker A --resources
                 MEMORY=<bytes>, stiffkit installed on the workers)

the cache:
  FEA results are cached in --cache (default .stiffkit-cache) under a hash of
  their inputs; give a folder every worker reaches. A finished run is never
  computed again, so an interrupted sweep (Ctrl-C) resumes where it stopped,
  and runs that differ only in [fit] share one FEA. Cached runs report the
  wall time and memory of their original run.

outputs:
  a summary table on stdout; --csv and --json: every column (run, the varied
  keys, status, reason, cached, nodes, elements, element, route, wall_s,
  memory_mb, memory_est_mb, sigma_m, cf_kind, cf_max_error, cf_worst,
  k11..k66, k11_ci..k66_ci, cache_key, host, task_s, start_s, end_s; SI
  units); --png: result columns (--y, default the compliance diagonal,
  cf_max_error and wall_s) against a varied key (--x, default the first), one
  line per combination of the other varied keys.
  The same table from Python: stiffkit.sweep("LINK.toml", vary={"mesh.size": [5, 3]}).

exit status:
  0  every run finished
  3  some runs failed (they are in the table with their reason); the others finished
  2  bad input (a --vary key or value, a LINK.toml error, -j 0, ...): nothing ran;
     or no scheduler answers at --scheduler
  130 interrupted (Ctrl-C): the cluster is closed, finished runs stay in the cache

examples:
  stiffkit sweep examples/beam.toml --vary mesh.size=5,3,2 --vary mesh.order=1,2 --csv s.csv --png s.png
  stiffkit sweep beam.toml --vary "geometry.size.0=100,200 load.reference_point.0=100,200" \\
      --vary material.E=7e10,2e11 -j 2 --json s.json
  stiffkit sweep tube.toml --vary geometry.wall=2,3,4 --vary material.E=7e10,2e11 --zip
  stiffkit sweep beam.toml --vary mesh.size=3,2,1.5 --scheduler tcp://cluster:8786 --cache /shared/cache
  stiffkit sweep beam.toml --vary fit.method=lin,exact,svd+- --dry-run
"""


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sweep",
        help="design sweep of a link on Dask (any LINK.toml keys)",
        description=__doc__,
        epilog=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("link", help="LINK.toml of the part")
    p.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=V1,V2,...",
        help="values of a LINK.toml key (repeat for more axes)",
    )
    p.add_argument("--zip", action="store_true", help="runs side by side instead of the Cartesian product")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786")
    where.add_argument("-j", "--jobs", type=int, help="run slots of the local cluster (default: the cores)")
    p.add_argument("--memory", help="memory the local cluster may use, e.g. 8G (default 90 %% of what is free)")
    p.add_argument("--cache", default=".stiffkit-cache", help="cache folder (default %(default)s)")
    p.add_argument("--json", help="write the table and the sweep to this JSON file")
    p.add_argument("--csv", help="write the table to this CSV file")
    p.add_argument("--png", help="plot results against a varied key")
    p.add_argument("--x", help="varied key on the plot's x axis (default: the first)")
    p.add_argument("--y", help="result columns to plot, e.g. k11,k44,cf_max_error")
    p.add_argument("--dry-run", action="store_true", help="list the runs and their estimates; run nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:

    return command(
        args.link,
        args.vary,
        zip=args.zip,
        scheduler=args.scheduler,
        jobs=args.jobs,
        memory=args.memory,
        cache=args.cache,
        json_out=args.json,
        csv_out=args.csv,
        png_out=args.png,
        x=args.x,
        y=args.y,
        quiet=args.quiet,
        dry_run=args.dry_run,
    )
