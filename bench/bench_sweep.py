"""Sweep benchmark (stiffkit sweep on Dask), figures for the README.

A sweep of 8 runs of the paper's beam (1000 x 10 x 10 mm) at C3D10 3 mm
(40k nodes each; 4 Young's moduli x 2 Poisson ratios, so that every run is
a distinct FEA), each time into a fresh cache:

1. wall time of the whole sweep with 1 and with 2 run slots (LocalCluster;
   goal on 2 cores: >= 1.7x when memory allows);
2. the overhead the machinery adds per run: (sweep wall time at 1 slot - the
   sum of the runs' own mesh + FEA + fit time) / runs, cluster start, a
   fresh process per run, scheduling and gathering included (goal < 0.5 s);
   and Dask's own scheduling cost per task (100 empty tasks on the same kind
   of cluster).

    python bench/bench_sweep.py           # C3D10 3 mm (~5 min)
    python bench/bench_sweep.py quick     # C3D10 5 mm (~1 min)
    python bench/bench_sweep.py repeat=2  # 1, 2, 1, 2 slots: on a shared machine, the best of each

The CPU time of the runs (their processes and ccx, from getrusage of this
process's children) tells whether two runs side by side slow each other
down, or whether other jobs on the machine took the second core.
"""

from __future__ import annotations

import os
import resource
import sys
import tempfile
import time

from stiffkit.fea.config import paper_beam
from stiffkit.sweep.study import run_sweep

VARY = {"material.E": [1.9e11, 2.0e11, 2.1e11, 2.2e11], "material.nu": [0.266, 0.3]}


def sweep(size: float, slots: int) -> dict:
    link = paper_beam(size)
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as cache:
        load = os.getloadavg()[0]
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        res = run_sweep(link, VARY, jobs=slots, cache=cache)
        wall = time.perf_counter() - t0
        ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)  # launchers reaped at the cluster's close
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    rows = res.rows
    assert all(r["status"] == "ok" and not r["cached"] for r in rows), [r["reason"] for r in rows]
    own = sum(r["wall_s"] for r in rows)
    span = max(r["end_s"] for r in rows) - min(r["start_s"] for r in rows)
    return {
        "wall": wall,
        "own": own,
        "n": len(rows),
        "nodes": rows[0]["nodes"],
        "cpu": cpu,
        "load": (load, os.getloadavg()[0]),
        "busy": sum(r["task_s"] for r in rows) / span,
        "mem": max(r["memory_mb"] for r in rows),
        "est": rows[0]["memory_est_mb"],
        "task_over": sum(r["task_s"] - r["wall_s"] for r in rows) / len(rows),
    }


def dask_overhead(n: int = 100) -> float:
    from distributed import Client, LocalCluster

    from stiffkit.sweep.runner import RESOURCE

    with (
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None, resources={RESOURCE: 1e9}
        ) as lc,
        Client(lc, set_as_default=False) as cl,
    ):
        cl.gather([cl.submit(int, 0, pure=False, resources={RESOURCE: 1e6})])
        t0 = time.perf_counter()
        futs = [cl.submit(int, i, pure=False, resources={RESOURCE: 1e6}) for i in range(n)]
        cl.gather(futs)
        return (time.perf_counter() - t0) / n


def main() -> None:
    quick = "quick" in sys.argv[1:]
    repeat = next((int(a.split("=")[1]) for a in sys.argv[1:] if a.startswith("repeat=")), 1)
    size = 5.0 if quick else 3.0
    print(
        f"-- sweep of 8 runs: beam 1000 x 10 x 10 mm, C3D10 {size:g} mm, matrix route, "
        f"{os.cpu_count()} cores; fresh cache each time"
    )
    res = {1: [], 2: []}
    for _ in range(repeat):
        for slots in (1, 2):
            r = sweep(size, slots)
            res[slots].append(r)
            print(
                f"  {slots} run slot{'s' if slots > 1 else ' '}: wall {r['wall']:6.1f} s for {r['n']} runs "
                f"({r['nodes']} nodes each, peak {r['mem']:.0f} MB, estimated {r['est']:.0f} MB); "
                f"runs' own time {r['own']:.1f} s; CPU {r['cpu']:.1f} s ({r['cpu'] / r['n']:.1f} s per run, "
                f"{r['cpu'] / r['wall']:.2f} cores on average; {r['busy']:.2f} runs in flight); "
                f"load average {r['load'][0]:.1f} before, "
                f"{r['load'][1]:.1f} after",
                flush=True,
            )
    one = min(res[1], key=lambda r: r["wall"])
    two = min(res[2], key=lambda r: r["wall"])
    print(
        f"  speed-up 2 slots vs 1: {one['wall'] / two['wall']:.2f}x (goal >= 1.7x); CPU time per run "
        f"at 2 slots / at 1 slot: {two['cpu'] / one['cpu']:.2f}"
    )
    print(
        f"  overhead per run at 1 slot: {(one['wall'] - one['own']) / one['n']:.2f} s "
        f"((sweep wall - runs' own time) / runs; goal < 0.5 s); of which process start, "
        f"cache write and result per task: {one['task_over']:.2f} s"
    )
    print(f"  Dask scheduling per task (100 empty tasks, same cluster kind): {1e3 * dask_overhead():.1f} ms")


if __name__ == "__main__":
    main()
