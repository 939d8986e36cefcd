"""The FEA demo (the second part of ``stiffkit demo``): the paper's beam
through Gmsh + CalculiX + CHOLMOD + field fit, against eq. 22."""

from __future__ import annotations

import time

from .config import paper_beam, parse_link
from .job import run_link


def fea_demo(size: float = 5.0) -> dict:
    """The paper's beam through Gmsh + CalculiX + CHOLMOD + field fit."""
    cfg = paper_beam(size)
    job = parse_link(cfg, "built-in beam")
    print(
        f"\nstiffkit demo: FEA of the same beam (Gmsh C3D10 {size:g} mm, CalculiX assembles K, "
        "CHOLMOD solves six load cases, tip-face field fit)"
    )
    t0 = time.perf_counter()
    res = run_link(job, cache_dir=None, progress=lambda m: print(f"  .. {m}", flush=True))
    print(
        f"  {res.mesh.n_nodes} nodes, {res.mesh.n_elements} elements; mesh {res.timing['mesh']:.1f} s, "
        f"FEA {res.timing['fea']:.1f} s, fit {res.timing['fit']:.3f} s, total {time.perf_counter() - t0:.1f} s"
    )
    print(res.table())
    err = res.closed_form_errors()
    return {"errors": err, "significant": res.compliance.significant, "nodes": res.mesh.n_nodes}
