"""The FEA of a link job: mesh, clamp, couple, and solve the six load cases.

Two routes (Pashkevich et al. 2009, s4): ``ccx`` writes six *STATIC steps
and reads the displacements from the .dat file; ``matrix`` lets ccx
assemble K once (*FREQUENCY, SOLVER=MATRIXSTORAGE) and solves all six cases
with one CHOLMOD factorisation in the core, with the same nodal loads as
ccx's *DISTRIBUTING (or the *RIGID BODY constraint eliminated in the core).
Both return the displacement fields of the six cases and the reference
node's own motion, the independent check of the field fit.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
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
from ..meshing import Mesh, MeshError, face_connectivity, mesh_part
from .amplitudes import auto_amplitudes, beam_estimate
from .ccx import (
    ccx_version,
    displacements_from_dat,
    exact_k,
    matrix_shim,
    peak_rss_mb,
    run_ccx,
    write_matrix_deck,
    write_static_deck,
)
from .config import LinkJob, check_extent, check_mesh_size
from .facesets import CadSets, default_reference_point, mesh_set, resolve_job_sets, set_label
from .meshkeys import node_memory_gb

__all__ = ["FeaSolution", "DistributingSupport", "resolve_route", "mesh_job", "support_and_load", "solve_fea"]


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
    field_nodes: np.ndarray | None = None  # [field] region = "faces": the nodes of its faces


def resolve_route(job: LinkJob) -> str:
    """``auto`` is the matrix route (one factorisation for the six cases)."""
    return "matrix" if job.route == "auto" else job.route


def mesh_job(job: LinkJob, cad: CadSets | None = None) -> Mesh:
    """The job's part meshed as its [mesh] table says (refined near the
    reference point and the clamp when ``refine`` is set; at the features,
    the support and the load faces (planes, and the CAD faces of ``cad``)
    when ``features`` is on); a MeshError
    above ``max_nodes``."""
    kw = {}
    if job.refine:
        kw = dict(
            refine=job.refine,
            refine_radius=job.refine_radius,
            refine_points=[[v / job.scale for v in job.reference_point]] if job.reference_point else [],
            refine_planes=[job.support_plane] if job.support_plane else [],
        )
    if job.features:
        kw["features"] = {
            "across": job.across,
            "around": job.around,
            "selected": [p for p in (job.support_plane, job.load_plane) if p],
            "faces": [] if cad is None else sorted(set(cad.ids.get("support", [])) | set(cad.ids.get("load", []))),
            "max_nodes": job.max_nodes,
        }
    mesh = mesh_part(
        job.geometry,
        job.units,
        job.scale,
        order=job.order,
        size=job.size,
        mesher=job.mesher,
        optimize=job.optimize,
        structured=job.structured,
        across_factor=job.across_factor,
        source=f"{job.source}: [mesh] size",
        element=job.element[:3],
        **kw,
    )
    if mesh.n_nodes > job.max_nodes:
        raise MeshError(
            f"{job.source}: the mesh has {mesh.n_nodes} nodes, above [mesh] max_nodes = {job.max_nodes} "
            f"(the memory limit; about {node_memory_gb(mesh.n_nodes):.1f} GB on the matrix route): give a larger "
            "size, fewer elements across or around, or raise max_nodes"
        )
    if "step" in job.geometry:  # a CAD part's size is known once it is read
        extent = mesh.info.get("extent") or list((mesh.bbox()[1] - mesh.bbox()[0]) / job.scale)
        check_extent(max(extent) * job.scale, job.units, f"{job.source}: [geometry] step")
        if not str(job.geometry["step"]).lower().endswith(".msh"):
            check_mesh_size(job.size, job.geometry, job.units, f"{job.source}: [mesh] size", dims=list(extent))
    return mesh


def support_and_load(job: LinkJob, mesh: Mesh, cad: CadSets | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(clamped nodes, loaded nodes, loaded element faces) of the job's
    [support] and [load] sets; MeshError when they touch each other or
    select nodes but no element face."""
    lt = job.load_tolerance if job.load_tolerance is not None else job.plane_tolerance
    fixed, ffaces = mesh_set(job, mesh, "support", cad, job.plane_tolerance)
    load, faces = mesh_set(job, mesh, "load", cad, lt)
    sup_l, load_l = set_label(job, "support"), set_label(job, "load")
    shared = np.intersect1d(fixed, load)
    if shared.size:
        where = ""
        if mesh.surface_tri is not None:
            touched = np.isin(mesh.surface_tri, shared).any(axis=1)
            tags = sorted({int(t) for t in mesh.surface_tag[touched]})
            if tags:
                where = f" (on CAD face(s) {tags})"
        raise MeshError(
            f"{job.source}: {load_l} and {sup_l} share {shared.size} node(s){where}: the load face must not "
            "touch the clamped face"
        )
    if faces.size == 0:
        raise MeshError(
            f"{job.source}: {load_l} selects {load.size} node(s) "
            "but no element face: it touches the part only along an edge or a point"
        )
    if ffaces.size == 0:
        raise MeshError(
            f"{job.source}: {sup_l} selects {fixed.size} "
            "node(s) but no element face: clamping them does not hold the part"
        )
    return fixed, load, faces


@dataclass
class DistributingSupport:
    """``[support] coupling = "distributing"``: the support set's
    work-conjugate rigid motion G^T u (the weighted mean translation and
    rotation that ccx's *DISTRIBUTING uses) is held at zero; the set itself
    is free to contract and warp, as beam theory's clamp is (eq. 22 holds
    the root section's resultant motion, not every point of it).

    Solved as: the part held statically determinately at three of the
    set's nodes (``held``: 3 + 2 + 1 dofs, no reaction for a balanced
    load), the load wrench balanced by its reaction -g[j] spread over the
    set like a distributing load, and the rigid motion G^T u subtracted
    afterwards (exactly the constraint G^T u = 0, since G^T of a rigid
    motion is that motion)."""

    nodes: np.ndarray  # (ns,) 1-based nodes of the set with weight
    g: np.ndarray  # (6, ns, 3) nodal forces of the six unit wrenches at the reference point
    held: list  # [(node, (dofs...))]: the statically determinate hold

    @classmethod
    def of(cls, job: LinkJob, mesh: Mesh, cad: CadSets | None, p0: np.ndarray) -> DistributingSupport:
        _n, sfaces = mesh_set(job, mesh, "support", cad, job.plane_tolerance)
        w, _area = face_weights(mesh.nodes, face_connectivity(mesh, sfaces))
        nodes = np.nonzero(w != 0)[0] + 1
        x = mesh.nodes[nodes - 1]
        g = distributing_loads(x, w[nodes - 1], p0)
        c = (w[nodes - 1, None] * x).sum(axis=0) / w[nodes - 1].sum()
        a = int(np.argmin(np.linalg.norm(x - c, axis=1)))
        b = int(np.argmax(np.linalg.norm(x - x[a], axis=1)))
        d = x[b] - x[a]
        i = int(np.argmax(np.abs(d)))
        e = np.cross(d / np.linalg.norm(d), x - x[a])  # motion of each node under a unit rotation about AB
        cn = int(np.argmax(np.abs(e).max(axis=1)))
        held = [
            (int(nodes[a]), (1, 2, 3)),
            (int(nodes[b]), tuple(k + 1 for k in range(3) if k != i)),
            (int(nodes[cn]), (int(np.argmax(np.abs(e[cn]))) + 1,)),
        ]
        return cls(nodes=nodes, g=g, held=held)

    def hold(self, mesh: Mesh, U: np.ndarray, ref: np.ndarray, p0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The fields U (6, n, 3) and the reference motion ref (6, 6) less
        the support set's work-conjugate rigid motion of each case."""
        m = work_conjugate(self.g, U[:, self.nodes - 1])  # (6 cases, 6)
        r = mesh.nodes - np.asarray(p0)
        U = np.stack([U[j] - m[j, :3] - np.cross(m[j, 3:], r) for j in range(6)])
        return U, ref - m.T


def _amplitudes(job: LinkJob, estimate: Callable[[], np.ndarray]) -> np.ndarray:
    """The [load] amplitudes, or the automatic ones from ``estimate()``."""
    return auto_amplitudes(estimate()) if job.amplitudes == "auto" else np.asarray(job.amplitudes, dtype=float)


def _discard(path: Path) -> None:
    """Let ccx write ``path`` into /dev/null (without the preload shim):
    MATRIXSTORAGE always writes the mass matrix too (as large as K, unused
    here), so the work folder's
    ``kmatrix.mas`` becomes a link to /dev/null (a stale file of an earlier
    run is removed first). Where links are refused, ccx writes the file."""
    try:
        if path.is_symlink() or path.is_file():
            path.unlink()
        path.symlink_to(os.devnull)
    except OSError:
        pass


def _solve_matrix(
    job: LinkJob,
    mesh: Mesh,
    workdir: Path,
    fixed: np.ndarray,
    load: np.ndarray,
    coupled: np.ndarray,
    g: np.ndarray,
    say: Callable[[str], None],
    support: DistributingSupport | None = None,
) -> tuple:
    """Matrix route: ccx assembles K, the core factorises it once (CHOLMOD)
    and solves the six unit cases; returns (U, ref, amplitudes, timing, stats)
    with the route's own timings."""
    t1 = time.perf_counter()
    p0 = np.asarray(job.reference_point)
    held = None if support is None else support.held
    deck = write_matrix_deck(workdir / "kmatrix.inp", mesh, job.E, job.nu, job.density, fixed, held=held)
    shim = matrix_shim()
    if shim is None:
        _discard(workdir / "kmatrix.mas")
    exact = exact_k()
    say(f"ccx: assembling K ({mesh.n_nodes * 3} dofs, MATRIXSTORAGE{', exact binary K' if exact else ', text K'})")
    run = run_ccx(deck, job.ccx_timeout, preload=shim, env={"STIFFKIT_EXACT_K": "1" if exact else "0"})
    t_ccx = time.perf_counter()
    rows, cols, vals, neq = read_triplets(workdir / "kmatrix.sti")
    node, direction = read_dofs(workdir / "kmatrix.dof")
    if node.size != neq:
        raise InputError(f"{workdir / 'kmatrix.dof'}: {node.size} equations for a {neq}-row matrix")
    t_read = time.perf_counter()
    eq = -np.ones((mesh.n_nodes + 1, 3), dtype=np.int64)
    eq[node, direction - 1] = np.arange(neq)
    Uunit = np.zeros((6, mesh.n_nodes, 3))
    B = np.zeros((neq, 6))
    if support is not None:  # the support's distributed reaction
        sidx = eq[support.nodes]
        for j in range(6):
            ok = sidx >= 0
            np.add.at(B[:, j], sidx[ok], -support.g[j][ok])
    if job.coupling == "distributing":
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
        X, unit_ref, ctime = rigid_solve(
            rows, cols, vals, neq, eq[load] + 1, mesh.nodes[load - 1] - p0, None if support is None else B
        )
        for j in range(6):
            Uunit[j, node - 1, direction - 1] = X[:, j]
    if support is not None:
        Uunit, unit_ref = support.hold(mesh, Uunit, unit_ref, p0)
    for name in ("kmatrix.sti", "kmatrix.mas"):
        (workdir / name).unlink(missing_ok=True)
    amps = _amplitudes(job, lambda: unit_ref)
    timing = {"ccx_assembly": t_ccx - t1, "matrix_read": t_read - t_ccx, **ctime}
    stats = {"equations": int(neq), "stored_entries": int(vals.size), "ccx_max_rss_mb": run.max_rss_mb}
    return Uunit * amps[:, None, None], unit_ref * amps[None, :], amps, timing, stats


def _solve_ccx(
    job: LinkJob,
    mesh: Mesh,
    workdir: Path,
    fixed: np.ndarray,
    load: np.ndarray,
    faces: np.ndarray,
    coupled: np.ndarray,
    g: np.ndarray,
    say: Callable[[str], None],
    progress: Callable[[str], None] | None,
    support: DistributingSupport | None = None,
) -> tuple:
    """Six-step route: ccx solves the six scaled cases; returns (U, ref,
    amplitudes, timing, stats) with the route's own timings."""
    p0 = np.asarray(job.reference_point)
    amps = _amplitudes(job, lambda: beam_estimate(job, mesh))
    deck = write_static_deck(
        workdir / "sixcases.inp",
        mesh,
        job.E,
        job.nu,
        fixed,
        faces,
        load,
        p0,
        job.coupling,
        amps,
        held=None if support is None else support.held,
        support_loads=None if support is None else (support.nodes, support.g),
        load_forces=(coupled, g) if mesh.is_hex else None,
    )
    say(f"ccx: six load cases ({mesh.n_nodes * 3} dofs, {job.coupling} coupling)")
    run = run_ccx(deck.path, job.ccx_timeout, progress=progress)
    U, ref = displacements_from_dat(workdir / "sixcases.dat", mesh.n_nodes, deck)
    if job.coupling == "distributing":
        # ccx's *DISTRIBUTING gives the reference node no solved motion:
        # use the work-conjugate motion of the coupled face instead
        ref = work_conjugate(g, U[:, coupled - 1]).T
    if support is not None:
        U, ref = support.hold(mesh, U, ref, p0)
    (workdir / "sixcases.frd").unlink(missing_ok=True)
    timing = {"ccx": run.seconds}
    return U, ref, amps, timing, {"ccx_max_rss_mb": run.max_rss_mb}


def solve_fea(job: LinkJob, workdir: Path, route: str, progress: Callable[[str], None] | None = None) -> FeaSolution:
    """Mesh and solve the six load cases (no cache)."""
    say = progress or (lambda msg: None)
    t0, c0 = time.perf_counter(), time.process_time()
    across = (
        f", across {job.across_factor * job.size:g} {job.units}" if job.structured and job.across_factor != 1 else ""
    )
    say(
        f"meshing ({job.mesher}{', structured' if job.structured else ''}, order {job.order}, "
        f"size {job.size:g} {job.units}{across})"
    )
    cad = resolve_job_sets(job)
    mesh = mesh_job(job, cad)
    t_mesh, c_mesh = time.perf_counter() - t0, time.process_time() - c0
    say(f"mesh: {mesh.n_nodes} nodes, {mesh.n_elements} {mesh.ccx_type} elements")
    fixed, load, faces = support_and_load(job, mesh, cad)
    conn = face_connectivity(mesh, faces)
    w, area = face_weights(mesh.nodes, conn)
    coupled = np.nonzero(w != 0)[0] + 1  # quadratic quadrilaterals: corners weigh < 0
    if job.reference_point is None:
        p0 = default_reference_point(job, mesh, cad, w)
        job = dataclasses.replace(job, reference_point=[float(v) for v in p0])
        say(f"reference point: the load set's centre, [{', '.join(f'{v / job.scale:.6g}' for v in p0)}] {job.units}")
    field_nodes = None
    if job.region == "faces":
        field_nodes, _f = mesh_set(job, mesh, "field", cad, job.plane_tolerance)
    g = distributing_loads(mesh.nodes[coupled - 1], w[coupled - 1], np.asarray(job.reference_point))
    t1 = time.perf_counter()
    stats = {
        "load_face_area_m2": area,
        "load_face_nodes": int(load.size),
        "support_nodes": int(fixed.size),
        "coupled_nodes": int(coupled.size),
        "reference_point_m": list(job.reference_point),
    }
    if cad is not None:
        stats["cad_faces"] = {sec: ids for sec, ids in cad.ids.items() if ids}
    support = None
    if job.support_coupling == "distributing":
        support = DistributingSupport.of(job, mesh, cad, np.asarray(job.reference_point))
        stats["support_coupled_nodes"] = int(support.nodes.size)
        stats["support_held"] = support.held
    if route == "matrix":
        stats["exact_k"] = exact_k()
    workdir.mkdir(parents=True, exist_ok=True)
    if route == "matrix":
        U, ref, amps, timing, more = _solve_matrix(job, mesh, workdir, fixed, load, coupled, g, say, support)
    else:
        U, ref, amps, timing, more = _solve_ccx(
            job, mesh, workdir, fixed, load, faces, coupled, g, say, progress, support
        )
    timing = {"mesh": t_mesh, "mesh_cpu": c_mesh, "fea": time.perf_counter() - t1, **timing}
    stats.update(more)
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
        field_nodes=field_nodes,
    )
