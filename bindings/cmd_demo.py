"""``stiffkit demo``: the main jobs on built-in examples, in three parts
(``--only field|fea|calib`` runs one).

field  The paper's illustrative example without FEA: the 1000 x 10 x 10 mm
       steel cantilever (E = 200 GPa, nu = 0.266), the six load cases of
       s4.2, its tip face as a 11 x 11 node field with FEA-like noise
       (sigma = 5e-5 mm, Table 4) and 5 % gross outliers. Each field is
       fitted (exact estimator: the paper's loads turn the tip by up to
       0.5 deg, where LIN's linearisation residual exceeds the noise), the
       compliance is built with confidence intervals, the zero elements
       are flagged and the result compared with the closed form (eq. 22).
fea    The real pipeline on the same beam: Gmsh meshes it with C3D10
       tetrahedra of 5 mm, CalculiX assembles the stiffness, CHOLMOD solves
       the six load cases, the tip face is fitted, and the compliance is
       compared with eq. 22 (a few seconds; `stiffkit link` runs any
       LINK.toml).
calib  A KR-270-like robot measured under load (synthetic, with a known
       truth): fit the joints-only model (the paper's J1), diagnose, add
       what the diagnosis names, refit, and watch the error fall to the
       noise floor; tables printed, figures in --out.
"""
from __future__ import annotations

import argparse

import numpy as np

from .field import cantilever_compliance, compliance_from_experiments, fit_fields, section_properties
from .synthetic import cantilever_fields, square_grid


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job on a built-in example",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--only", choices=["field", "fea", "calib"], help="run one part of the demo only")
    p.add_argument("--no-fea", action="store_true", help="skip the real FEA run")
    p.add_argument("--size", type=float, default=5.0, help="element size of the FEA demo, mm (default 5)")
    p.add_argument("--out", default="build/demo", help="folder for the calibration demo's data and figures")
    p.set_defaults(func=run)


def field_demo(seed: int = 1) -> dict:
    L, b, E, nu = 1.0, 0.01, 2.0e11, 0.266
    sec = section_properties("square", [b], nu)
    k_true = cantilever_compliance(L, E, nu, sec)
    loads = np.diag([1000.0, 1.0, 1.0, 1.0, 1.0, 1.0])        # paper s4.2
    pts = square_grid(b, 0.001, x=L)                           # tip face, 1 mm step
    ref = np.array([L, 0.0, 0.0])
    sigma = 5e-8                                               # 5e-5 mm (Table 4)
    fields = cantilever_fields(k_true, loads, pts, ref, sigma=sigma, outlier_fraction=0.05, rng=seed)
    print("stiffkit demo: field fit of a noisy cantilever tip (paper s4, synthetic FEA field)")
    print(f"  beam 1000 x 10 x 10 mm, E = {E:.3g} Pa, nu = {nu}; {pts.shape[0]} nodes on the tip face;")
    print(f"  noise sigma = {sigma:.1e} m, 5 % of nodes carry gross outliers (50 sigma)")
    result = {}
    nz = k_true != 0
    for trim in (0.0, 0.1):
        fits = fit_fields(pts, fields, ref, method="exact", trim=trim)
        # 99.9 %: about 3.3 sigma, in the paper's 3-5 sigma range for zero tests (s3.4)
        comp = compliance_from_experiments(loads, fits, confidence=0.999, symmetrize=True)
        err = np.abs(comp.matrix[nz] / k_true[nz] - 1.0).max()
        zeros_ok = int((~comp.significant & ~nz).sum())
        nonzeros_ok = int((comp.significant & nz).sum())
        print(f"\n-- exact fit, trim {trim:.0%}: pooled sigma = {fits[0].sigma:.3e} m")
        print(comp.table())
        print(f"  max error of the 10 non-zero elements vs eq. 22: {100 * err:.4f} %")
        print(f"  zero elements flagged non-significant: {zeros_ok}/26; non-zero significant: {nonzeros_ok}/10")
        result[trim] = (err, zeros_ok, nonzeros_ok)
    return result




def fea_demo(size: float = 5.0) -> dict:
    """The paper's beam through Gmsh + CalculiX + CHOLMOD + field fit."""
    import time

    from .fea.config import paper_beam, parse_link
    from .fea.job import run_link
    cfg = paper_beam(size)
    job = parse_link(cfg, "built-in beam")
    print(f"\nstiffkit demo: FEA of the same beam (Gmsh C3D10 {size:g} mm, CalculiX assembles K, "
          "CHOLMOD solves six load cases, tip-face field fit)")
    t0 = time.perf_counter()
    res = run_link(job, cache_dir=None,
                   progress=lambda m: print(f"  .. {m}", flush=True))
    print(f"  {res.mesh.n_nodes} nodes, {res.mesh.n_elements} elements; mesh {res.timing['mesh']:.1f} s, "
          f"FEA {res.timing['fea']:.1f} s, fit {res.timing['fit']:.3f} s, total {time.perf_counter() - t0:.1f} s")
    print(res.table())
    err = res.closed_form_errors()
    return {"errors": err, "significant": res.compliance.significant, "nodes": res.mesh.n_nodes}


def run(args) -> int:
    if args.only in (None, "field"):
        field_demo(args.seed)
    if args.only in (None, "fea") and not args.no_fea:
        fea_demo(args.size)
    if args.only in (None, "calib"):
        from .calib.demo import calibration_demo
        calibration_demo(args.out, seed=args.seed)
    return 0
