"""The FEA demo (the second part of ``stiffkit demo``): the paper's beam
through Gmsh + CalculiX + CHOLMOD + field fit, against eq. 22."""

from __future__ import annotations

import time
from pathlib import Path

from ..errors import InputError
from .config import load_link, paper_beam, parse_link
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


#: the bored link of examples/ (a Gmsh .geo and its LINK.toml)
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def bored_link_demo(out: Path | str, size: float = 4.0) -> dict:
    """examples/bored_link.toml: a link clamped in its bearing bore (a .geo
    physical group) and loaded through a pin hole (a cylinder selector),
    rigid coupling; the compliance beside the single-beam approximation, a
    PNG of the mesh with the selected faces and the VTU in ``out``."""
    toml = EXAMPLES / "bored_link.toml"
    if not toml.is_file():
        raise InputError(f"the bored-link example is not here ({toml}): run the demo from a source checkout")
    job = load_link(toml).with_mesh(size=size)
    print(
        f"\nstiffkit demo: FEA of a bored link (examples/bored_link.toml: clamped in its bearing bore, loaded "
        f"through the pin hole, rigid coupling; Gmsh C3D10 {size:g} mm)"
    )
    t0 = time.perf_counter()
    res = run_link(job, cache_dir=None, progress=lambda m: print(f"  .. {m}", flush=True))
    print(
        f"  {res.mesh.n_nodes} nodes, {res.mesh.n_elements} elements; mesh {res.timing['mesh']:.1f} s, "
        f"FEA {res.timing['fea']:.1f} s, total {time.perf_counter() - t0:.1f} s"
    )
    print(res.table())
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    png = res.write_faces_png(out / "bored_link_faces.png")
    vtu = res.write_vtu(out / "bored_link.vtu")
    print(f"  wrote {png} (mesh, clamped faces blue, loaded faces red) and {vtu}")
    return {"result": res, "png": png, "vtu": vtu}
