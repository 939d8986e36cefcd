"""Reports of the parallel-robot and spring-tree jobs of ``stiffkit robot``:
what is printed, what goes to JSON and what is plotted.

Each builder evaluates its model in one core call per set of postures and
returns a report whose ``text()`` is the printed summary, ``to_json()`` the
results (SI), and ``write_json`` / ``write_png`` the files.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..io.files import write_json
from ..robot.indices import Indices, stiffness_indices
from . import orthoglide as og
from . import smg
from .plots import orthoglide_map_png, smg_indices_png
from .tree import TreeResult
from .tree_json import TreeFile, load_tree

__all__ = [
    "format6",
    "OrthoglideMap",
    "OrthoglideReport",
    "orthoglide_report",
    "SMGReport",
    "smg_report",
    "TreeReport",
    "tree_report",
]


def format6(c: np.ndarray) -> str:
    """A 6x6 compliance or stiffness with its row (twist) and column (wrench) names."""
    names = ("tx", "ty", "tz", "phix", "phiy", "phiz")
    lines = ["        " + " ".join(f"{n:>11s}" for n in ("Fx", "Fy", "Fz", "Mx", "My", "Mz"))]
    for i, n in enumerate(names):
        lines.append(f"  {n:>5s} " + " ".join(f"{v:11.3e}" for v in c[i]))
    return "\n".join(lines)


def _vectors(rows: Iterable[Iterable[float]]) -> list[str]:
    return ["   " + " ".join(f"{v:10.3e}" for v in f) for f in rows]


# ------------------------------------------------------------------ Orthoglide


@dataclass
class OrthoglideMap:
    """Largest compliance eigenvalues over the workspace cube (n^3 grid)."""

    xs_mm: np.ndarray  # (n,) grid coordinates
    ct_max: np.ndarray  # (n, n, n) largest translational compliance, mm/N
    cr_max: np.ndarray  # (n, n, n) largest rotational compliance, rad/(N mm)
    rank: np.ndarray  # (n, n, n)

    @classmethod
    def of(cls, xs_m: np.ndarray, res: TreeResult) -> OrthoglideMap:
        n = xs_m.size
        # principal compliances: eigenvalues of the translational and rotational blocks
        ct = np.linalg.eigvalsh(res.compliance[:, :3, :3])[:, -1] * 1e3  # mm/N
        cr = np.linalg.eigvalsh(res.compliance[:, 3:, 3:])[:, -1] * 1e-3  # rad/(N mm)
        return cls(xs_m * 1e3, ct.reshape(n, n, n), cr.reshape(n, n, n), res.rank.reshape(n, n, n))

    def text(self) -> str:
        n = self.xs_mm.size
        ct, cr = self.ct_max, self.cr_max
        return (
            f"\nworkspace map, {n}^3 = {n**3} postures in one core call: "
            f"rank 6 at {np.mean(self.rank == 6) * 100:.1f} %\n"
            f"  largest translational compliance: {ct.min():.3e} .. {ct.max():.3e} mm/N\n"
            f"  largest rotational compliance:    {cr.min():.3e} .. {cr.max():.3e} rad/(N mm)"
        )

    def to_json(self) -> dict:
        return {
            "grid_mm": self.xs_mm.tolist(),
            "ct_max_mm_per_N": self.ct_max.tolist(),
            "cr_max_rad_per_N_mm": self.cr_max.tolist(),
            "rank": self.rank.tolist(),
        }


@dataclass
class OrthoglideReport:
    """The Orthoglide at one tool point, at the isotropic point against
    Table 8, and optionally over the workspace cube."""

    point_m: np.ndarray
    links: str
    result: TreeResult  # at point_m
    isotropic: np.ndarray  # 6x6 compliance at the isotropic point
    map: OrthoglideMap | None = None

    @property
    def table8(self) -> tuple[float, float]:
        """(k_tran 1e-4 mm/N, k_rot 1e-7 rad/(N mm)) at the isotropic point."""
        return self.isotropic[0, 0] * 1e3 / 1e-4, self.isotropic[3, 3] * 1e-3 / 1e-7

    def text(self) -> str:
        res = self.result
        point = ",".join(f"{v:g}" for v in self.point_m * 1e3)
        lines = [
            f"Orthoglide at P = {point} mm (links: {self.links}), rank {res.rank[0]}",
            "compliance (SI: m/N, 1/N, rad/(N m)):",
            format6(res.compliance[0]),
        ]
        if res.nfree[0]:
            lines.append(f"singular posture: {res.nfree[0]} free motion(s) (t [m], phi [rad]):")
            lines += _vectors(res.free_twists(0).T)
        kt, kr = self.table8
        lines.append("\nisotropic point vs Pashkevich et al. 2009 Table 8:")
        lines.append(f"  {'model':62s} {'k_tran 1e-4 mm/N':>17s} {'k_rot 1e-7 rad/(N mm)':>22s}")
        for name, (a, b) in og.TABLE8.items():
            lines.append(f"  {name:62s} {a:17.2f} {b:22.2f}")
        lines.append(f"  {'stiffkit spring tree (' + self.links + ' links)':62s} {kt:17.2f} {kr:22.2f}")
        if self.map is not None:
            lines.append(self.map.text())
        return "\n".join(lines)

    def to_json(self) -> dict:
        res = self.result
        kt, kr = self.table8
        out = {
            "point_m": self.point_m.tolist(),
            "links": self.links,
            "rank": int(res.rank[0]),
            "free_twists": res.free_twists(0).T.tolist(),
            "compliance_SI": res.compliance[0].tolist(),
            "stiffness_SI": res.stiffness[0].tolist(),
            "ratio": float(res.ratio[0]),
            "isotropic": {"k_tran_1e-4_mm_per_N": kt, "k_rot_1e-7_rad_per_N_mm": kr, "table8": og.TABLE8},
        }
        if self.map is not None:
            out["map"] = self.map.to_json()
        return out

    def write_json(self, path: Path | str) -> Path:
        return write_json(path, self.to_json())

    def write_png(self, path: Path | str) -> Path:
        """Slices of the workspace map (needs the map)."""
        if self.map is None:
            raise InputError("the Orthoglide PNG shows the workspace map: compute it first (--map N)")
        return orthoglide_map_png(path, self.map.xs_mm, self.map.ct_max, self.map.cr_max)


def orthoglide_report(
    point_mm: npt.ArrayLike = (0.0, 0.0, 0.0),
    links: str = "beam",
    link_files: dict | None = None,
    actuator_compliance: float = 0.0,
    map_n: int | None = None,
) -> OrthoglideReport:
    """The Orthoglide's compliance at ``point_mm`` and at the isotropic point
    (links: Table 7 ``beam`` or ``fea``, or ``stiffkit link`` JSON files
    {foot|axle|bar: path}); with ``map_n`` also over an n^3 workspace grid."""
    g = og.OrthoglideGeometry()
    lc = og.link_compliances(links, g, link_files)
    P = np.asarray(point_mm, dtype=float) * 1e-3
    res = og.compliance(P[None], lc, g, actuator_compliance)
    iso = og.compliance(og.isotropic_point()[None], lc, g, actuator_compliance).compliance[0]
    wmap = None
    if map_n:
        xs, G = og.workspace_grid(map_n, g)
        wmap = OrthoglideMap.of(xs, og.compliance(G, lc, g, actuator_compliance))
    return OrthoglideReport(point_m=P, links=links, result=res, isotropic=iso, map=wmap)


# ------------------------------------------------------------------ McGill SMG


@dataclass
class SMGReport:
    """Stiffness indices of the McGill SMG along its test trajectory."""

    tau: np.ndarray
    P: np.ndarray
    theta: np.ndarray
    result: TreeResult
    indices: Indices
    pi_joints: str

    def text(self) -> str:
        res, idx, tau = self.result, self.indices, self.tau
        return "\n".join(
            [
                f"McGill SMG, {tau.size} postures along the smoothed test trajectory "
                f"(one core call), Pi-joints: {self.pi_joints}, lscale = {idx.lscale:g} m",
                f"  rank 6 at {np.mean(res.rank == 6) * 100:.1f} % of postures; "
                f"smallest stiffness eigenvalue ratio {res.ratio.min():.2e}",
                f"  kappa_t: {idx.kappa_t.min():.4g} .. {idx.kappa_t.max():.4g} N "
                f"(min at tau = {tau[np.argmin(idx.kappa_t)]:.3f})",
                f"  kappa_r: {idx.kappa_r.min():.4g} .. {idx.kappa_r.max():.4g} N "
                f"(min at tau = {tau[np.argmin(idx.kappa_r)]:.3f})",
            ]
        )

    def to_json(self) -> dict:
        idx = self.indices
        return {
            "tau": self.tau.tolist(),
            "P_m": self.P.tolist(),
            "theta_rad": self.theta.tolist(),
            "kappa_t_N": idx.kappa_t.tolist(),
            "kappa_r_N": idx.kappa_r.tolist(),
            "rank": self.result.rank.tolist(),
            "lscale_m": idx.lscale,
            "pi_joints": self.pi_joints,
        }

    def write_json(self, path: Path | str) -> Path:
        return write_json(path, self.to_json())

    def write_png(self, path: Path | str) -> Path:
        return smg_indices_png(path, self.tau, self.P, self.theta, self.indices)


def smg_report(
    postures: int = 401, link_files: dict | None = None, pi_joints: str = "paper", lscale: float | None = None
) -> SMGReport:
    """kappa_t, kappa_r at ``postures`` points of the smoothed test trajectory
    (links: the illustrative beams, or ``stiffkit link`` JSON files
    {proximal|distal: path})."""
    if postures < 2:
        raise InputError("--postures must be >= 2")
    links = smg.smg_links(link_files)
    tau, P, theta, res, idx = smg.indices_along_trajectory(postures, links, smg.SMGGeometry(), pi_joints, lscale)
    return SMGReport(tau=tau, P=P, theta=theta, result=res, indices=idx, pi_joints=pi_joints)


# ------------------------------------------------------------------ your tree


@dataclass
class TreeReport:
    """A JSON spring tree evaluated at its tool: C, K, ranks, free and rigid
    directions, and the indices where the stiffness exists."""

    source: TreeFile
    result: TreeResult
    indices: Indices | None

    def text(self) -> str:
        res = self.result
        lines = [
            f"{self.source.path}: rank {res.rank[0]} ({res.nfree[0]} free, {res.nrigid[0]} rigid), "
            f"eigenvalue ratio {res.ratio[0]:.3e}, lscale {res.lscale:g} m",
            "compliance" + (" (on the wrenches the free motions leave)" if res.nfree[0] else "") + ":",
            format6(res.compliance[0]),
            "stiffness" + (" (on the motions the rigid directions leave)" if res.nrigid[0] else "") + ":",
            format6(res.stiffness[0]),
        ]
        for name, arr in (("free twist (t, phi)", res.free_twists(0)), ("rigid wrench (f, m)", res.rigid_wrenches(0))):
            lines += [f"{name}: " + " ".join(f"{x:10.3e}" for x in v) for v in arr.T]
        if self.indices is not None:
            idx = self.indices
            lines.append(
                f"kappa_t = {idx.kappa_t[0]:.4g} N, kappa_r = {idx.kappa_r[0]:.4g} N (lscale {res.lscale:g} m)"
            )
        return "\n".join(lines)

    def to_json(self) -> dict:
        res = self.result
        out = {
            "rank": int(res.rank[0]),
            "compliance": res.compliance[0].tolist(),
            "stiffness": res.stiffness[0].tolist(),
            "free_twists": res.free_twists(0).T.tolist(),
            "rigid_wrenches": res.rigid_wrenches(0).T.tolist(),
            "ratio": float(res.ratio[0]),
            "lscale": res.lscale,
            "compliance_exists": bool(res.nfree[0] == 0),
            "stiffness_exists": bool(res.nrigid[0] == 0),
        }
        if self.indices is not None:
            out.update(kappa_t=float(self.indices.kappa_t[0]), kappa_r=float(self.indices.kappa_r[0]))
        return out

    def write_json(self, path: Path | str) -> Path:
        return write_json(path, self.to_json())


def tree_report(path: Path | str, rcond: float = 1e-9) -> TreeReport:
    """Read a tree JSON file (springs/tree_json.py) and evaluate it at its tool."""
    src = load_tree(path)
    res = src.evaluate(rcond)
    idx = stiffness_indices(res.stiffness[0], res.lscale) if res.nrigid[0] == 0 else None
    return TreeReport(source=src, result=res, indices=idx)
