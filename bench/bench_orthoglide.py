"""The paper's Table 7 shape for approximate Orthoglide links (s5): the
diagonal compliance of each link by its single-beam approximation and by
the FEA pipeline (C3D10, distributing coupling, tip-face field fit).

    python bench/bench_orthoglide.py        (the CAD: examples/orthoglide/make_cad.py)

Units as in the paper: k11-k33 in mm/N, k44-k66 in rad/(N mm). The parts are
approximations of the prototype's links (no drawings in the paper), so the
numbers show the method, not the prototype.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from stiffkit.fea.config import load_link
from stiffkit.fea.job import run_link

ROOT = Path(__file__).resolve().parents[1] / "examples"
LINKS = [
    ("Foot", "orthoglide_foot.toml"),
    ("Parallelogram axle", "orthoglide_axle.toml"),
    ("Parallelogram bar", "orthoglide_bar.toml"),
]
SCALE = np.array([1e3, 1e3, 1e3, 1e-3, 1e-3, 1e-3])  # SI -> mm/N, rad/(N mm)


def row(name, d):
    return f"  {name:40s}" + "".join(f"{v:11.3e}" for v in d * SCALE)


def main():
    print(f"  {'method':40s}" + "".join(f"{h:>11s}" for h in ("k11 mm/N", "k22 mm/N", "k33 mm/N", "k44", "k55", "k66")))
    with tempfile.TemporaryDirectory(prefix="bench-og-") as cache:
        for title, toml in LINKS:
            job = load_link(ROOT / toml)
            t0 = time.perf_counter()
            r = run_link(job, cache_dir=cache)
            print(f"{title} ({toml}, {r.mesh.n_nodes} nodes, {time.perf_counter() - t0:.0f} s)")
            print(row("Single-beam approximation", np.diag(r.closed_form)))
            print(row(f"FEA-based (C3D10 {job.size:g} mm, field fit)", np.diag(r.compliance.matrix)))
            print(row("FEA reference node (work-conjugate)", np.diag(r.reference_compliance)))


if __name__ == "__main__":
    main()
