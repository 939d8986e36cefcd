"""One FEA-to-compliance job: mesh, six load cases, field fits, compliance.

Pipeline (Pashkevich et al. 2009, s2-s4):

1. mesh the part (Gmsh or TetGen, C3D4/C3D10), clamp the support face, couple
   a reference node to the load face (distributing or rigid);
2. solve the six unit-direction load cases, either as six ccx *STEPs
   (``route = "ccx"``) or by letting ccx assemble K once
   (*FREQUENCY, SOLVER=MATRIXSTORAGE) and solving all six with one CHOLMOD
   factorisation in the core (``route = "matrix"``, the same nodal loads as
   ccx's *DISTRIBUTING);
3. fit the rigid motion (t, phi) of the field nodes near the reference point
   in each case (core field fit), build the compliance with confidence
   intervals and zero-element tests (core), and report beside it the
   reference node's own compliance (work-conjugate face motion, or the
   *RIGID BODY nodes) as an independent check.

FEA results (displacement fields) are cached under a hash of everything
that determines them; fits are recomputed from the cache.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core.sparse import (
    cholmod_solve,
    distributing_loads,
    face_weights,
    read_dofs,
    read_triplets,
    rigid_solve,
    work_conjugate,
)
from ..errors import InputError
from ..field import (
    DOF_NAMES,
    LOAD_NAMES,
    Compliance,
    cantilever_compliance,
    compliance_from_experiments,
    fit_fields,
    section_properties,
)
from ..meshing import Mesh, MeshError, face_connectivity, faces_on_nodes, mesh_part, plane_nodes
from ..version import __version__
from .ccx import ccx_version, displacements_from_dat, peak_rss_mb, run_ccx, write_matrix_deck, write_static_deck
from .config import LinkJob

logger = logging.getLogger(__name__)

CACHE_VERSION = "fea-2"  # bump when the FEA results of a key change
#: deflection ranges the paper recommends for the field fit (s3.5, s4.2)
T_RANGE_M = (1e-4, 1e-3)
PHI_RANGE_RAD = (np.radians(0.01), np.radians(0.2))
#: caps of the automatic amplitudes: rounding down to 1-2-5 keeps the binding
#: deflection within [0.4, 1] x cap, i.e. 0.1-0.25 mm or 0.04-0.1 deg
T_TARGET_M = 2.5e-4
PHI_TARGET_RAD = np.radians(0.1)


# ---------------------------------------------------------------- helpers


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path, text: str) -> None:
    _atomic_write_bytes(Path(path), text.encode())


def _file_digest(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def cache_key(job: LinkJob, route: str) -> str:
    """Hash of everything that determines the six displacement fields."""
    geom = dict(job.geometry)
    if "step" in geom:
        geom = {"cad_sha256": _file_digest(geom["step"]), "suffix": Path(geom["step"]).suffix.lower()}
    key = {
        "v": CACHE_VERSION,
        "geometry": geom,
        "units": job.units,
        "E": job.E,
        "nu": job.nu,
        "density": job.density if route == "matrix" else None,
        "support": job.support_plane,
        "load": job.load_plane,
        "ref": job.reference_point,
        "coupling": job.coupling,
        "amplitudes": job.amplitudes,
        "mesher": job.mesher,
        "order": job.order,
        "size": job.size,
        "refine": job.refine,
        "refine_radius": job.refine_radius,
        "route": route,
        "tol": job.plane_tolerance,
        "optimize": job.optimize,
    }
    if job.structured:  # only then: keys of unstructured runs stay as they were
        key["structured"] = True
        key["across_factor"] = job.across_factor
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]


def beam_estimate(job: LinkJob, mesh: Mesh) -> np.ndarray:
    """First estimate of the compliance for the automatic amplitudes: the
    closed form (eq. 22) for built-in shapes, else a solid rectangular
    cantilever spanning the bounding box along the load plane's axis."""
    cf = job.closed_form_shape()
    if cf is not None:
        L, sec, dims = cf
        return cantilever_compliance(L, job.E, job.nu, section_properties(sec, dims, job.nu))
    lo, hi = mesh.bbox()
    ext = np.maximum(hi - lo, 1e-12)
    a = "xyz".index(job.load_plane[0])
    others = [i for i in range(3) if i != a]
    k_local = cantilever_compliance(
        float(ext[a]), job.E, job.nu, section_properties("rectangle", [ext[others[0]], ext[others[1]]], job.nu)
    )
    R = np.zeros((3, 3))  # columns: global images of local x, y, z
    R[a, 0] = 1.0
    R[others[0], 1] = 1.0
    R[others[1], 2] = 1.0
    T = np.zeros((6, 6))
    T[:3, :3] = R
    T[3:, 3:] = R
    return T @ k_local @ T.T


def _nice_floor(v: float) -> float:
    """Largest 1, 2 or 5 x 10^k not above v."""
    e = np.floor(np.log10(v))
    for m in (5.0, 2.0, 1.0):
        if m * 10**e <= v * (1 + 1e-12):
            return float(m * 10**e)
    return float(10**e)


def auto_amplitudes(k_est: np.ndarray) -> np.ndarray:
    """Loads that bring each case's largest deflection to the paper's
    recommended ranges (s3.5: 0.1-1 mm, 0.01-0.2 deg): the largest load of
    the form 1, 2 or 5 x 10^k whose translation stays below 0.25 mm and
    rotation below 0.1 deg; the binding one then lies in 0.1-0.25 mm or
    0.04-0.1 deg."""
    amps = np.zeros(6)
    for j in range(6):
        t = np.abs(k_est[:3, j]).max()
        p = np.abs(k_est[3:, j]).max()
        lim = []
        if t > 0:
            lim.append(T_TARGET_M / t)
        if p > 0:
            lim.append(PHI_TARGET_RAD / p)
        amps[j] = _nice_floor(min(lim)) if lim else 1.0
    return amps


def select_field(job: LinkJob, mesh: Mesh, load_nodes: np.ndarray) -> np.ndarray:
    """1-based node numbers of the field around the reference point (s4.4):
    ``face`` the load face; ``cube`` nodes inside a cube of edge
    ``field.size`` centred on the reference point; ``layer`` nodes within
    ``field.size`` of the load plane."""
    p0 = np.asarray(job.reference_point)
    if job.region == "face":
        sel = np.asarray(load_nodes)
    elif job.region == "cube":
        inside = np.all(np.abs(mesh.nodes - p0) <= job.region_size / 2 * (1 + 1e-9), axis=1)
        sel = np.nonzero(inside)[0] + 1
    else:
        axis = "xyz".index(job.load_plane[0])
        lo, hi = mesh.bbox()
        value = lo[axis] if job.load_plane.endswith("min") else hi[axis]
        sel = np.nonzero(np.abs(mesh.nodes[:, axis] - value) <= job.region_size * (1 + 1e-9))[0] + 1
    if sel.size < 3:
        raise InputError(
            f"{job.source}: [field] region = {job.region!r}"
            f"{'' if job.region == 'face' else f', size = {job.region_size / job.scale:g} {job.units}'}"
            f" selects {sel.size} node(s); the fit needs at least 3 "
            "(enlarge the region or refine the mesh)"
        )
    return sel


# ---------------------------------------------------------------- FEA


@dataclass
class FeaSolution:
    mesh: Mesh
    U: np.ndarray  # (6, n, 3) displacements per load case (amplitudes applied)
    amplitudes: np.ndarray  # (6,)
    ref_motion: np.ndarray  # (6, 6) reference node motion per case (columns)
    load_nodes: np.ndarray
    fixed_nodes: np.ndarray
    route: str
    timing: dict
    stats: dict = field(default_factory=dict)


def _mesh_job(job: LinkJob) -> Mesh:
    kw = {}
    if job.refine:
        kw = dict(
            refine=job.refine,
            refine_radius=job.refine_radius,
            refine_points=[[v / job.scale for v in job.reference_point]],
            refine_planes=[job.support_plane],
        )
    return mesh_part(
        job.geometry,
        job.units,
        job.scale,
        order=job.order,
        size=job.size,
        mesher=job.mesher,
        optimize=job.optimize,
        structured=job.structured,
        across_factor=job.across_factor,
        **kw,
    )


def _faces(job: LinkJob, mesh: Mesh):
    fixed = plane_nodes(mesh, job.support_plane, job.plane_tolerance, f"{job.source}: [support] plane")
    load = plane_nodes(mesh, job.load_plane, job.plane_tolerance, f"{job.source}: [load] plane")
    shared = np.intersect1d(fixed, load)
    if shared.size:
        raise MeshError(
            f"{job.source}: [load] plane {job.load_plane!r} and [support] plane "
            f"{job.support_plane!r} share {shared.size} node(s): the load face must not "
            "touch the clamped face"
        )
    faces = faces_on_nodes(mesh, load)
    if faces.size == 0:
        raise MeshError(
            f"{job.source}: [load] plane {job.load_plane!r} selects {load.size} node(s) "
            "but no element face: it touches the part only along an edge or a point"
        )
    if faces_on_nodes(mesh, fixed).size == 0:
        raise MeshError(
            f"{job.source}: [support] plane {job.support_plane!r} selects {fixed.size} "
            "node(s) but no element face: clamping them does not hold the part"
        )
    return fixed, load, faces


def solve_fea(job: LinkJob, workdir: Path, route: str, progress=None) -> FeaSolution:
    """Mesh and solve the six load cases (no cache)."""
    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    across = (
        f", across {job.across_factor * job.size:g} {job.units}" if job.structured and job.across_factor != 1 else ""
    )
    say(
        f"meshing ({job.mesher}{', structured' if job.structured else ''}, order {job.order}, "
        f"size {job.size:g} {job.units}{across})"
    )
    mesh = _mesh_job(job)
    t_mesh = time.perf_counter() - t0
    say(f"mesh: {mesh.n_nodes} nodes, {mesh.n_elements} {mesh.ccx_type} elements")
    fixed, load, faces = _faces(job, mesh)
    conn = face_connectivity(mesh, faces)
    w, area = face_weights(mesh.nodes, conn)
    coupled = np.nonzero(w > 0)[0] + 1
    p0 = np.asarray(job.reference_point)
    g = distributing_loads(mesh.nodes[coupled - 1], w[coupled - 1], p0)
    t1 = time.perf_counter()
    stats = {
        "load_face_area_m2": area,
        "load_face_nodes": int(load.size),
        "support_nodes": int(fixed.size),
        "coupled_nodes": int(coupled.size),
    }
    workdir.mkdir(parents=True, exist_ok=True)
    if route == "matrix":
        deck = write_matrix_deck(workdir / "kmatrix.inp", mesh, job.E, job.nu, job.density, fixed)
        say(f"ccx: assembling K ({mesh.n_nodes * 3} dofs, MATRIXSTORAGE)")
        run = run_ccx(deck, job.ccx_timeout)
        t_ccx = time.perf_counter()
        rows, cols, vals, neq = read_triplets(workdir / "kmatrix.sti")
        node, direction = read_dofs(workdir / "kmatrix.dof")
        if node.size != neq:
            raise InputError(f"{workdir / 'kmatrix.dof'}: {node.size} equations for a {neq}-row matrix")
        t_read = time.perf_counter()
        eq = -np.ones((mesh.n_nodes + 1, 3), dtype=np.int64)
        eq[node, direction - 1] = np.arange(neq)
        Uunit = np.zeros((6, mesh.n_nodes, 3))
        if job.coupling == "distributing":
            B = np.zeros((neq, 6))
            idx = eq[coupled]  # (nf, 3)
            for j in range(6):
                ok = idx >= 0
                np.add.at(B[:, j], idx[ok], g[j][ok])
            say(f"CHOLMOD: factor K ({neq} equations, {vals.size} stored entries), six solves")
            X, ctime = cholmod_solve(rows, cols, vals, B)
            for j in range(6):
                Uunit[j, node - 1, direction - 1] = X[:, j]
            unit_ref = work_conjugate(g, Uunit[:, coupled - 1]).T  # (6 dof, 6 cases)
        else:
            say(f"CHOLMOD: factor T^T K T ({neq} equations, rigid face of {load.size} nodes), six solves")
            X, unit_ref, ctime = rigid_solve(rows, cols, vals, neq, eq[load] + 1, mesh.nodes[load - 1] - p0)
            for j in range(6):
                Uunit[j, node - 1, direction - 1] = X[:, j]
        for name in ("kmatrix.sti", "kmatrix.mas"):
            (workdir / name).unlink(missing_ok=True)
        amps = auto_amplitudes(unit_ref) if job.amplitudes == "auto" else np.asarray(job.amplitudes, dtype=float)
        U = Uunit * amps[:, None, None]
        ref = unit_ref * amps[None, :]
        timing = {
            "mesh": t_mesh,
            "fea": time.perf_counter() - t1,
            "ccx_assembly": t_ccx - t1,
            "matrix_read": t_read - t_ccx,
            **ctime,
        }
        stats.update({"equations": int(neq), "stored_entries": int(vals.size), "ccx_max_rss_mb": run.max_rss_mb})
    else:
        amps = (
            auto_amplitudes(beam_estimate(job, mesh))
            if job.amplitudes == "auto"
            else np.asarray(job.amplitudes, dtype=float)
        )
        deck = write_static_deck(
            workdir / "sixcases.inp", mesh, job.E, job.nu, fixed, faces, load, p0, job.coupling, amps
        )
        say(f"ccx: six load cases ({mesh.n_nodes * 3} dofs, {job.coupling} coupling)")
        run = run_ccx(deck.path, job.ccx_timeout, progress=progress)
        U, ref = displacements_from_dat(workdir / "sixcases.dat", mesh.n_nodes, deck)
        if job.coupling == "distributing":
            # ccx's *DISTRIBUTING gives the reference node no solved motion:
            # use the work-conjugate motion of the coupled face instead
            ref = work_conjugate(g, U[:, coupled - 1]).T
        (workdir / "sixcases.frd").unlink(missing_ok=True)
        timing = {"mesh": t_mesh, "fea": time.perf_counter() - t1, "ccx": run.seconds}
        stats.update({"ccx_max_rss_mb": run.max_rss_mb})
    stats["python_max_rss_mb"] = peak_rss_mb()
    stats["ccx_version"] = ccx_version()
    return FeaSolution(
        mesh=mesh,
        U=U,
        amplitudes=amps,
        ref_motion=ref,
        load_nodes=load,
        fixed_nodes=fixed,
        route=route,
        timing=timing,
        stats=stats,
    )


def _save_solution(path: Path, sol: FeaSolution) -> None:
    import io

    buf = io.BytesIO()
    meta = {
        "route": sol.route,
        "timing": sol.timing,
        "stats": sol.stats,
        "mesher": sol.mesh.mesher,
        "size_m": sol.mesh.size_m,
        "mesh_info": sol.mesh.info,
    }
    np.savez(
        buf,
        nodes=sol.mesh.nodes,
        elements=sol.mesh.elements,
        U=sol.U,
        amplitudes=sol.amplitudes,
        ref=sol.ref_motion,
        load=sol.load_nodes,
        fixed=sol.fixed_nodes,
        meta=np.array(json.dumps(meta)),
    )
    _atomic_write_bytes(path, buf.getvalue())


def _load_solution(path: Path) -> FeaSolution | None:
    try:
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            mesh = Mesh(
                nodes=z["nodes"],
                elements=z["elements"],
                mesher=meta["mesher"],
                size_m=meta["size_m"],
                info=meta.get("mesh_info", {}),
            )
            return FeaSolution(
                mesh=mesh,
                U=z["U"],
                amplitudes=z["amplitudes"],
                ref_motion=z["ref"],
                load_nodes=z["load"],
                fixed_nodes=z["fixed"],
                route=meta["route"],
                timing=meta["timing"],
                stats=meta["stats"],
            )
    except (OSError, KeyError, ValueError, json.JSONDecodeError) as exc:
        logger.warning("ignoring unreadable cache entry %s (%s)", path, exc)
        return None


def resolve_route(job: LinkJob) -> str:
    """``auto`` is the matrix route (one factorisation for the six cases)."""
    return "matrix" if job.route == "auto" else job.route


def fea_cached(
    job: LinkJob, cache_dir: Path | None, route: str | None = None, progress=None, workdir: Path | None = None
) -> tuple[FeaSolution, bool, str]:
    """FEA solution from the cache when present, else solved and stored."""
    route = route or resolve_route(job)
    key = cache_key(job, route)
    entry = cache_dir / f"{key}.npz" if cache_dir else None
    if entry is not None and entry.is_file():
        sol = _load_solution(entry)
        if sol is not None:
            return sol, True, key
    own = workdir is None
    if own:
        base = cache_dir if cache_dir is not None and cache_dir.exists() else None
        workdir = Path(tempfile.mkdtemp(prefix=f"run-{key}-", dir=base))
    sol = solve_fea(job, workdir, route, progress)
    if own:  # on failure the folder stays for inspection
        shutil.rmtree(workdir, ignore_errors=True)
    if entry is not None:
        _save_solution(entry, sol)
    return sol, False, key


# ---------------------------------------------------------------- results


@dataclass
class LinkResult:
    job: LinkJob
    solution: FeaSolution
    compliance: Compliance
    fits: list
    field_nodes: np.ndarray
    reference_compliance: np.ndarray
    closed_form: np.ndarray | None
    timing: dict
    cached: bool
    key: str

    @property
    def mesh(self) -> Mesh:
        return self.solution.mesh

    def deflections(self) -> np.ndarray:
        """(6 cases, 6) fitted (t, phi) of each load case."""
        return np.array([f.deflection for f in self.fits])

    def closed_form_errors(self) -> np.ndarray | None:
        """Relative error of every element against the closed form (nan where it is zero)."""
        if self.closed_form is None:
            return None
        cf = self.closed_form
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(cf != 0, self.compliance.matrix / cf - 1.0, np.nan)

    def to_json(self) -> dict:
        c = self.compliance
        sol = self.solution
        out = {
            "compliance": c.matrix.tolist(),
            "stiffness": None if c.stiffness is None else c.stiffness.tolist(),
            "compliance_std": c.std.tolist(),
            "compliance_ci": c.ci.tolist(),
            "significant": c.significant.tolist(),
            "symmetry_error": c.asymmetry,
            "sigma_m": c.sigma,
            "nodes_fitted": int(min(f.n_used for f in self.fits)),
            "nodes_trimmed": int(max(f.nodes_used.size - f.n_used for f in self.fits)),
            "reference_node_compliance": self.reference_compliance.tolist(),
            "mesh": {
                "nodes": self.mesh.n_nodes,
                "elements": self.mesh.n_elements,
                "order": self.mesh.order,
                "size_m": self.mesh.size_m,
                "mesher": self.mesh.mesher,
                "element_type": self.mesh.ccx_type,
            },
            "timing_s": {
                "mesh": self.timing["mesh"],
                "fea": self.timing["fea"],
                "fit": self.timing["fit"],
                **{k: v for k, v in sol.timing.items() if k not in ("mesh", "fea")},
            },
            "amplitudes": sol.amplitudes.tolist(),
            "deflections": self.deflections().tolist(),
            "route": sol.route,
            "coupling": self.job.coupling,
            "boundary_condition": f"nodes of {self.job.support_plane} clamped in x, y, z; "
            f"loads at the reference point through a {self.job.coupling} "
            f"coupling to {self.job.load_plane}",
            "field": {"region": self.job.region, "size_m": self.job.region_size, "nodes": int(self.field_nodes.size)},
            "fit": {
                "method": self.job.method,
                "trim": self.job.trim,
                "confidence": self.job.confidence,
                "symmetrized": self.job.symmetrize,
            },
            "stats": sol.stats,
            "cached": self.cached,
            "cache_key": self.key,
            "stiffkit_version": __version__,
            "source": self.job.source,
        }
        if self.closed_form is not None:
            err = self.closed_form_errors()
            out["closed_form"] = {
                "kind": "single-beam approximation"
                if self.job.approximation
                else "Euler-Bernoulli cantilever (eq. 22)",
                "compliance": self.closed_form.tolist(),
                "relative_error": [[None if np.isnan(v) else float(v) for v in row] for row in err],
                "max_abs_relative_error": float(np.nanmax(np.abs(err))),
            }
        return out

    def table(self) -> str:
        c = self.compliance
        lines = [c.table()]
        lines.append(
            "reference node ("
            + ("work-conjugate face motion" if self.job.coupling == "distributing" else "*RIGID BODY nodes")
            + ") vs field fit, diagonal:"
        )
        for i in range(6):
            rc = self.reference_compliance[i, i]
            lines.append(
                f"  k{i + 1}{i + 1}  fit {c.matrix[i, i]: .6e}   reference node {rc: .6e}   "
                f"({100 * (c.matrix[i, i] / rc - 1) if rc else float('nan'):+.4f} %)"
            )
        if self.closed_form is not None:
            err = self.closed_form_errors()
            lines.append(
                (
                    "single-beam approximation ([approximation], eq. 22)"
                    if self.job.approximation
                    else "closed form (eq. 22, Euler-Bernoulli cantilever)"
                )
                + ": relative error of the FE result for the non-zero elements"
            )
            for i in range(6):
                for j in range(6):
                    if self.closed_form[i, j] != 0 and (i <= j):
                        ref = "beam" if self.job.approximation else "closed form"
                        lines.append(
                            f"  k{i + 1}{j + 1}  {c.matrix[i, j]: .6e}  {ref} "
                            f"{self.closed_form[i, j]: .6e}  error {100 * err[i, j]:+.4f} %"
                        )
            zeros = self.closed_form == 0
            lines.append(
                f"  zero elements flagged non-significant: {int((~c.significant & zeros).sum())}/{int(zeros.sum())}"
            )
        d = self.deflections()
        lines.append(
            "load cases: "
            + ", ".join(
                f"{LOAD_NAMES[j]}={self.solution.amplitudes[j]:.3g}"
                f" (|t|={1e3 * np.abs(d[j, :3]).max():.3g} mm, "
                f"|phi|={np.degrees(np.abs(d[j, 3:]).max()):.3g} deg)"
                for j in range(6)
            )
        )
        return "\n".join(lines)

    def write_vtu(self, path) -> Path:
        """Mesh with the six displacement fields (ParaView, via meshio)."""
        import meshio

        path = Path(path)
        cells = [("tetra10" if self.mesh.order == 2 else "tetra", self.mesh.elements - 1)]
        data = {f"u_{LOAD_NAMES[j]}": self.solution.U[j] for j in range(6)}
        fld = np.zeros(self.mesh.n_nodes)
        fld[self.field_nodes - 1] = 1.0
        data["field_node"] = fld
        m = meshio.Mesh(self.mesh.nodes, cells, point_data=data)
        tmp = path.with_name(path.name + ".tmp.vtu")
        meshio.write(tmp, m, file_format="vtu")
        os.replace(tmp, path)
        return path

    def write_residual_png(self, path) -> Path:
        """Histograms of the fit residuals per load case (paper Fig. 3)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        path = Path(path)
        fig, axes = plt.subplots(2, 3, figsize=(11, 6))
        for j, ax in enumerate(axes.ravel()):
            r = self.fits[j].residuals[self.fits[j].nodes_used] * 1e3
            for k, name in enumerate("xyz"):
                ax.hist(r[:, k], bins=30, alpha=0.5, label=f"r{name}")
            ax.set_title(f"{LOAD_NAMES[j]} = {self.solution.amplitudes[j]:.3g}")
            ax.set_xlabel("residual, mm")
        axes[0, 0].legend()
        fig.suptitle(
            f"field-fit residuals ({self.job.region}, {self.fits[0].n_used} nodes, "
            f"{self.mesh.ccx_type} {1e3 * self.mesh.size_m:g} mm)"
        )
        fig.tight_layout()
        tmp = path.with_name(path.name + ".tmp.png")
        fig.savefig(tmp, dpi=90, format="png")
        plt.close(fig)
        os.replace(tmp, path)
        return path


def fit_solution(job: LinkJob, sol: FeaSolution) -> tuple:
    t0 = time.perf_counter()
    field_nodes = select_field(job, sol.mesh, sol.load_nodes)
    pts = sol.mesh.nodes[field_nodes - 1]
    fits = fit_fields(
        pts, sol.U[:, field_nodes - 1], job.reference_point, method=job.method, trim=job.trim, pooled=job.pooled
    )
    comp = compliance_from_experiments(
        np.diag(sol.amplitudes), fits, confidence=job.confidence, symmetrize=job.symmetrize
    )
    ref_c = sol.ref_motion / sol.amplitudes[None, :]
    return field_nodes, fits, comp, ref_c, time.perf_counter() - t0


def closed_form(job: LinkJob) -> np.ndarray | None:
    cf = job.closed_form_shape()
    if cf is None:
        return None
    L, sec, dims = cf
    return cantilever_compliance(L, job.E, job.nu, section_properties(sec, dims, job.nu))


def run_link(job: LinkJob, cache_dir=None, route: str | None = None, progress=None, workdir=None) -> LinkResult:
    """Run (or resume from the cache) one LINK job and fit its compliance."""
    cache_dir = Path(cache_dir) if cache_dir else None
    if cache_dir:
        cache_dir.mkdir(parents=True, exist_ok=True)
    sol, cached, key = fea_cached(job, cache_dir, route, progress, Path(workdir) if workdir else None)
    field_nodes, fits, comp, ref_c, t_fit = fit_solution(job, sol)
    timing = {"mesh": sol.timing["mesh"], "fea": sol.timing["fea"], "fit": t_fit}
    return LinkResult(
        job=job,
        solution=sol,
        compliance=comp,
        fits=fits,
        field_nodes=field_nodes,
        reference_compliance=ref_c,
        closed_form=closed_form(job),
        timing=timing,
        cached=cached,
        key=key,
    )


__all__ = [
    "run_link",
    "LinkResult",
    "FeaSolution",
    "solve_fea",
    "auto_amplitudes",
    "beam_estimate",
    "select_field",
    "cache_key",
    "atomic_write_text",
    "resolve_route",
    "closed_form",
    "DOF_NAMES",
    "LOAD_NAMES",
    "T_RANGE_M",
    "PHI_RANGE_RAD",
]
