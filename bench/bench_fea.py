"""FEA benchmarks, figures for the README results section.

1. The paper's best setting, the 1000 x 10 x 10 mm beam with C3D10 of 2 mm:
   max error of the 10 non-zero compliance elements vs eq. 22 (raw and with
   10 % trimming), the element that limits it, and the wall time of the
   whole FEA-to-compliance run by the matrix route (ccx assembles K, CHOLMOD
   solves) vs the six-step ccx route, on the same mesh.
2. Table 5: max error per mesh, C3D4 and C3D10, sizes 5, 3, 2 mm.

    python bench/bench_fea.py            # everything (~10 min, ~2 GB)
    python bench/bench_fea.py quick      # 3 mm instead of 2 mm, Table 5 at 5, 3 mm
    python bench/bench_fea.py fine       # also C3D10 1.5 mm by the matrix route
                                         # (237k nodes, ~2 min, ~4.6 GB)
    python bench/bench_fea.py netgen     # also C3D10 2 mm with [mesh] optimize = "netgen"
    python bench/bench_fea.py structured # also structured C3D10 meshes ([mesh] structured = true):
                                         # 2 mm with 6 elements across (across_factor 0.9) and
                                         # 5 mm along with 6 across (across_factor 0.34)
    python bench/bench_fea.py lengths    # also beams of 250 and 500 mm at 2 mm: which
                                         # errors come from the mesh, which from the clamp
"""

from __future__ import annotations

import concurrent.futures as cf
import copy
import multiprocessing
import sys
import tempfile
import time

import numpy as np

from stiffkit.fea.config import paper_beam, parse_link
from stiffkit.fea.convergence import table
from stiffkit.fea.job import run_link
from stiffkit.sweep.convergence import run_study

BEAM = paper_beam(2.0)
NAMES = [f"k{i + 1}{j + 1}" for i in range(6) for j in range(6)]


def _timed_run(cfg: dict, cache: str):
    t0 = time.perf_counter()
    r = run_link(parse_link(cfg, "bench beam"), cache_dir=cache)
    return r, time.perf_counter() - t0


def best_setting(
    size: float, cache: str, routes=("matrix", "ccx"), optimize: str = "none", across_factor: float | None = None
) -> None:
    print(
        f"-- beam 1000 x 10 x 10 mm, C3D10 {size:g} mm, distributing coupling, tip-face field"
        + (f", mesh optimiser {optimize}" if optimize != "none" else "")
        + (f", structured mesh, {across_factor * size:g} mm across" if across_factor else "")
    )
    res = {}
    ctx = multiprocessing.get_context("spawn")
    for route in routes:
        cfg = copy.deepcopy(BEAM)
        cfg["mesh"]["size"] = size
        cfg["solver"]["route"] = route
        cfg["mesh"]["optimize"] = optimize
        if across_factor:
            cfg["mesh"]["structured"] = True
            cfg["mesh"]["across_factor"] = across_factor
        # a fresh process per route: its peak memory is the route's own
        with cf.ProcessPoolExecutor(1, mp_context=ctx) as pool:
            r, wall = pool.submit(_timed_run, cfg, cache).result()
        res[route] = r
        st = r.solution.stats
        extra = ""
        if route == "matrix":
            t = r.solution.timing
            extra = (
                f" (ccx assembly {t['ccx_assembly']:.1f} s, read {t['matrix_read']:.1f} s, "
                f"CHOLMOD ordering {t['ordering_s']:.1f} s + factor {t['factor_s']:.1f} s + six solves "
                f"{t['solve_s']:.2f} s)"
            )
        print(
            f"  route {route:6s}: {r.mesh.n_nodes} nodes, wall {wall:.1f} s (mesh {r.timing['mesh']:.1f} s, "
            f"FEA {r.timing['fea']:.1f} s){extra}; peak memory ccx {st.get('ccx_max_rss_mb', 0):.0f} MB, "
            f"python (incl. CHOLMOD) {st.get('python_max_rss_mb', 0):.0f} MB"
        )
        for trim in (0.0, 0.1):
            cfg2 = copy.deepcopy(cfg)
            cfg2["fit"]["trim"] = trim
            rr = run_link(parse_link(cfg2, "bench beam"), cache_dir=cache)
            err = rr.closed_form_errors()
            nz = ~np.isnan(err)
            k = int(np.nanargmax(np.abs(err)))
            bend = np.where(np.isin(np.arange(36), [21]), np.nan, np.abs(err).ravel())  # without k44
            zeros = rr.closed_form == 0
            print(
                f"    trim {trim:.0%}: max error of the 10 non-zero elements {100 * np.abs(err[nz]).max():.4f} % "
                f"({NAMES[k]}); without torsion k44 {100 * np.nanmax(bend):.4f} %; zeros flagged "
                f"{int((~rr.compliance.significant & zeros).sum())}/26; sigma {rr.compliance.sigma:.2e} m"
            )
    if len(res) < 2:
        return
    ka, kb = res["matrix"].compliance.matrix, res["ccx"].compliance.matrix
    scale = np.sqrt(np.outer(np.abs(np.diag(ka)), np.abs(np.diag(ka))))
    ta = res["matrix"].timing["mesh"] + res["matrix"].timing["fea"]
    tb = res["ccx"].timing["mesh"] + res["ccx"].timing["fea"]
    print(
        f"  matrix vs ccx route: max |dk_ij| / sqrt(k_ii k_jj) = {(np.abs(ka - kb) / scale).max():.2e}; "
        f"time ratio matrix/ccx = {ta / tb:.2f} ({ta:.1f} s vs {tb:.1f} s)"
    )


def lengths(cache: str, size: float = 2.0) -> None:
    """Errors that do not change with the length come from the mesh of the
    section (torsion); errors that scale with 1/L from the clamped root."""
    print(f"-- error vs beam length, C3D10 {size:g} mm (mesh error: constant; root clamp: ~1/L)")
    for L in (250.0, 500.0, 1000.0):
        cfg = copy.deepcopy(BEAM)
        cfg["geometry"]["size"] = [L, 10.0, 10.0]
        cfg["load"]["reference_point"] = [L, 0.0, 0.0]
        cfg["mesh"]["size"] = size
        r = run_link(parse_link(cfg, "bench beam"), cache_dir=cache)
        e = 100 * r.closed_form_errors()
        print(
            f"  L = {L:6.0f} mm: k11 {e[0, 0]:+.4f} %  k22 {e[1, 1]:+.4f} %  k44 {e[3, 3]:+.4f} %  "
            f"k55 {e[4, 4]:+.4f} %  ({r.mesh.n_nodes} nodes)"
        )


def table5(sizes, cache: str, jobs: int) -> None:
    job = parse_link(BEAM, "bench beam")
    study = run_study(job, [1, 2], sizes, cache, jobs=jobs, progress=False)
    print("-- Table 5 (paper: linear 27/20/12 % at 3/2/1 mm; parabolic 3.3/0.19/0.10 % at 5/3/2 mm)")
    print(table(study))


if __name__ == "__main__":
    quick = "quick" in sys.argv[1:]
    with tempfile.TemporaryDirectory(prefix="bench-fea-") as cache:
        best_setting(3.0 if quick else 2.0, cache)
        table5([5.0, 3.0] if quick else [5.0, 3.0, 2.0], cache, jobs=1)
        if "netgen" in sys.argv[1:]:
            best_setting(2.0, cache, routes=("matrix",), optimize="netgen")
        if "structured" in sys.argv[1:]:
            best_setting(2.0, cache, routes=("matrix",), across_factor=0.9)
            best_setting(5.0, cache, routes=("matrix",), across_factor=0.34)
        if "lengths" in sys.argv[1:]:
            lengths(cache)
        if "fine" in sys.argv[1:]:
            best_setting(1.5, cache, routes=("matrix",))
