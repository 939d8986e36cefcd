"""Link stiffness of three realistic CAD parts (issue 18), figures for the README.

The parts (bench/cad_parts.py, made with Gmsh's OpenCASCADE kernel and
written as STEP): an L-shaped hollow cast arm ending in two bearing
housings, a clevis with a bolted flange and two pin lugs, a tapered box
beam with lightening holes and fillets. The arm is clamped in its first
bearing bore and loaded through a rigid coupling in the second; the clevis
clamped in its six bolt holes and loaded through a rigid pin in its lug
holes; the tapered beam clamped and loaded (distributing) at its end
planes (reference point: the load set's centre on its axis). Meshed with the default feature
refinement (C3D10; ``across`` elements across the thinnest wall, ``around``
around each hole, half the size at the clamp and load faces).

Per part: the default mesh by the matrix route (nodes, wall time, peak
memory), a mesh 1.5 times coarser in every size (the Richardson estimate of
the default mesh's error from the two, as ``[mesh] accuracy`` makes it with
p = 2 assumed), and the six-step ccx route on the default mesh (goal:
matrix route <= 1.5 x one ccx step, i.e. a quarter of the six steps). The
ratio is given three ways: whole runs (wall, meshing included, which the
matrix route pays once and the six steps share), the FEA alone (wall) and
the FEA alone in CPU seconds (this process and ccx; robust on a loaded
machine).

    python bench/bench_cad.py            # the three parts (~10 min on 2 cores)
    python bench/bench_cad.py arm        # one part
    python bench/bench_cad.py across=2   # 2 elements across the walls (default 3): ~1/3 the nodes
    STIFFKIT_EXACT_K=0 python bench/bench_cad.py   # matrix route on ccx's 14-digit text K (default: exact binary)
"""

from __future__ import annotations

import copy
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from cad_parts import PARTS, write_part  # noqa: E402

from stiffkit.fea.accuracy import estimate_error  # noqa: E402
from stiffkit.fea.config import parse_link  # noqa: E402
from stiffkit.fea.job import run_link  # noqa: E402

#: each part's nominal element size (mm)
SIZES = {"arm": 10.0, "clevis": 8.0, "tapered": 10.0}


def link_data(name: str, step: Path, route: str = "matrix", across: int | None = None) -> dict:
    support, load = PARTS[name]
    return {
        "geometry": {"step": str(step), "units": "mm"},
        "material": {"E": 2.0e11, "nu": 0.3, "density": 7850.0},
        "support": dict(support),
        "load": {"amplitudes": "auto", **load},
        "mesh": {"mesher": "gmsh", "order": 2, "size": SIZES[name], **({"across": across} if across else {})},
        "fit": {"method": "lin"},
        "solver": {"route": route},
    }


def cpu_s() -> float:
    """CPU seconds of this process and its finished children (ccx)."""
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + ch.ru_utime + ch.ru_stime


def peak_mb(res) -> float:
    st = res.solution.stats
    return max(float(st.get("ccx_max_rss_mb") or 0.0), float(st.get("python_max_rss_mb") or 0.0))


def _level(job, scale: float, across: int, route: str):
    """The job with every element size scaled by ``scale`` and ``across`` elements across."""
    lj = copy.deepcopy(job)
    lj.size, lj.across, lj.around, lj.route = job.size * scale, across, job.around / scale, route
    return lj


def bench_part(name: str, tmp: Path, across: int | None = None) -> dict:
    step = write_part(name, tmp / f"{name}.step")
    job = parse_link(link_data(name, step, across=across), f"{name}.step")
    n0 = job.across
    coarse = _level(job, 1.5, round(n0 / 1.5), "matrix")
    runs = {}
    cpu = {}
    for label, lj in (("coarse", coarse), ("default", job), ("ccx", _level(job, 1.0, n0, "ccx"))):
        t0, c0 = time.perf_counter(), cpu_s()
        runs[label] = (run_link(lj, cache_dir=None), time.perf_counter() - t0)
        cpu[label] = cpu_s() - c0 - runs[label][0].solution.timing.get("mesh_cpu", 0.0)
    (rc, tc), (rd, td), (rx, tx) = runs["coarse"], runs["default"], runs["ccx"]
    fea_wall = rd.solution.timing["fea"] / (rx.solution.timing["fea"] / 6)
    fea_cpu = cpu["default"] / (cpu["ccx"] / 6)
    est, p, _obs, worst = estimate_error(
        [1.5, 1.0], [rc.compliance.matrix, rd.compliance.matrix], rd.compliance.significant
    )
    feats = rd.mesh.info.get("features", {})
    ka, kb = rd.compliance.matrix, rx.compliance.matrix
    scale = np.sqrt(np.outer(np.abs(np.diag(ka)), np.abs(np.diag(ka))))
    agree = float((np.abs(ka - kb) / scale).max())
    d, dr = np.diag(ka), np.diag(rd.reference_compliance)
    print(
        f"\n{name}: default mesh (size {job.size:g} mm, {n0} across, {job.around} around): "
        f"{rd.mesh.n_nodes} nodes, thinnest wall {feats.get('thinnest_wall')} mm, "
        f"{feats.get('curved_faces_refined')} curved and {feats.get('wall_faces_refined')} wall faces refined\n"
        f"  matrix route {td:.1f} s, peak {peak_mb(rd):.0f} MB; six ccx steps {tx:.1f} s, peak {peak_mb(rx):.0f} MB: "
        f"matrix = {td / (tx / 6):.2f} x one ccx step (goal <= 1.5); routes agree to {agree:.1e}\n"
        f"  without the meshing (the same for both routes): FEA wall {fea_wall:.2f} x, FEA CPU "
        f"{fea_cpu:.2f} x one ccx step ({cpu['default']:.1f} s against {cpu['ccx']:.1f} s / 6)\n"
        f"  estimated error {100 * est:.3f} % ({worst}; Richardson with the coarse mesh: {rc.mesh.n_nodes} nodes, "
        f"{tc:.1f} s, p = {p:.0f} assumed); field fit vs reference node (diagonal) {np.abs(d / dr - 1).max():.2e}",
        flush=True,
    )
    return {
        "name": name,
        "nodes": rd.mesh.n_nodes,
        "seconds": td,
        "mb": peak_mb(rd),
        "estimate": est,
        "ratio": td / (tx / 6),
        "fea_wall": fea_wall,
        "fea_cpu": fea_cpu,
    }


def main(argv: list[str]) -> None:
    names = [a for a in argv if a in PARTS] or list(PARTS)
    across = next((int(a.split("=")[1]) for a in argv if a.startswith("across=")), None)
    with tempfile.TemporaryDirectory(prefix="bench-cad-") as tmp:
        rows = [bench_part(n, Path(tmp), across) for n in names]
    print("\npart      nodes  wall s  peak MB  est. error %  matrix / one ccx step: run, FEA wall, FEA CPU")
    for r in rows:
        print(
            f"{r['name']:8s} {r['nodes']:7d} {r['seconds']:7.1f} {r['mb']:8.0f} {100 * r['estimate']:12.3f} "
            f"{r['ratio']:10.2f} {r['fea_wall']:9.2f} {r['fea_cpu']:8.2f}"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
