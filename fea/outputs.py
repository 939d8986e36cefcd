"""The results of a link job: the compliance with its checks, as a table,
JSON (docs/link.md), VTU (the six displacement fields for ParaView) and PNG
(histograms of the fit residuals, paper Fig. 3)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..field import LOAD_NAMES, Compliance
from ..io.files import atomic_path, pyplot, save_figure, write_json
from ..meshing import Mesh
from ..version import __version__
from .config import LinkJob
from .facesets import set_label
from .solve import FeaSolution

__all__ = ["LinkResult"]


def _plain(d: object) -> object:
    """A JSON-ready copy: no NaN or Infinity (None instead), numpy scalars as floats."""
    if isinstance(d, dict):
        return {k: _plain(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_plain(v) for v in d]
    if isinstance(d, (bool, int, str)) or d is None:
        return d
    v = float(d)
    return v if np.isfinite(v) else None


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
    accuracy: dict | None = None  # [mesh] accuracy: the levels and the Richardson estimate (fea.accuracy)

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

    def reference_difference(self) -> np.ndarray:
        """(6,) relative difference of the fitted diagonal from the reference
        node's (fit / reference - 1; 0 where the reference is 0)."""
        fit, ref = np.diag(self.compliance.matrix), np.diag(self.reference_compliance)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(ref != 0, fit / ref - 1.0, 0.0)

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
            "reference_node_difference": self.reference_difference().tolist(),
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
            "support_coupling": self.job.support_coupling,
            "boundary_condition": (
                f"nodes of {set_label(self.job, 'support')} clamped in x, y, z; "
                if self.job.support_coupling == "rigid"
                else f"{set_label(self.job, 'support')} held through a distributing coupling (its work-conjugate "
                "rigid motion fixed, the face free to contract and warp); "
            )
            + f"loads at the reference point through a {self.job.coupling} "
            f"coupling to {set_label(self.job, 'load')}",
            "reference_point_m": list(self.job.reference_point),
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
        if self.mesh.info.get("features"):
            out["mesh"]["features"] = _plain(self.mesh.info["features"])
        if self.accuracy is not None:
            out["accuracy"] = _plain(self.accuracy)
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

    def summary(self, name: str | None = None) -> str:
        """Two lines: what was meshed and solved (and whether it came from
        the cache), the field and its noise; then the time of each stage."""
        job, m = self.job, self.mesh
        return (
            f"{name or Path(job.source).name}: {m.n_nodes} nodes, {m.n_elements} {m.ccx_type} "
            f"({m.mesher}, {job.size:g} {job.units}), route {self.solution.route}"
            f"{' (cached)' if self.cached else ''}; field {job.region}: {self.field_nodes.size} nodes; "
            f"sigma = {self.compliance.sigma:.3e} m\n"
            f"time: mesh {self.timing['mesh']:.1f} s, FEA {self.timing['fea']:.1f} s, fit {self.timing['fit']:.3f} s"
            + (
                ""
                if self.accuracy is None
                else f"\naccuracy: estimated error {100 * self.accuracy['estimate']:.3g} % "
                f"({self.accuracy['worst']}; Richardson, p = {self.accuracy['p']:.2f}"
                f"{' observed' if self.accuracy['p_observed'] else ' assumed'}) after "
                f"{len(self.accuracy['levels'])} meshes, target {100 * self.accuracy['target']:g} %"
            )
        )

    def write_json(self, path: Path | str) -> Path:
        """The results under the contract keys (docs/link.md), atomically."""
        return write_json(path, self.to_json())

    def write_vtu(self, path: Path | str) -> Path:
        """Mesh with the six displacement fields (ParaView, via meshio)."""
        import meshio

        path = Path(path)
        kind = {4: "tetra", 10: "tetra10", 8: "hexahedron", 20: "hexahedron20"}[self.mesh.elements.shape[1]]
        cells = [(kind, self.mesh.elements - 1)]
        data = {f"u_{LOAD_NAMES[j]}": self.solution.U[j] for j in range(6)}
        fld = np.zeros(self.mesh.n_nodes)
        fld[self.field_nodes - 1] = 1.0
        data["field_node"] = fld
        for name, nodes in (("support_node", self.solution.fixed_nodes), ("load_node", self.solution.load_nodes)):
            mark = np.zeros(self.mesh.n_nodes)
            mark[np.asarray(nodes) - 1] = 1.0
            data[name] = mark
        m = meshio.Mesh(self.mesh.nodes, cells, point_data=data)
        with atomic_path(path) as tmp:
            meshio.write(tmp, m, file_format="vtu")
        return path

    def write_faces_png(self, path: Path | str) -> Path:
        """The mesh with the clamped (blue) and loaded (red) faces (PNG)."""
        from .faceplot import write_faces_png

        sol = self.solution
        return write_faces_png(
            path,
            self.mesh,
            sol.fixed_nodes,
            sol.load_nodes,
            self.job.reference_point,
            title=f"{Path(self.job.source).name}: {self.mesh.n_nodes} nodes, {self.job.coupling} coupling\n"
            f"blue: clamped {set_label(self.job, 'support')}\nred: loaded {set_label(self.job, 'load')}; "
            "x: reference point",
            scale=1.0 / self.job.scale,
            units=self.job.units,
        )

    def write_residual_png(self, path: Path | str) -> Path:
        """Histograms of the fit residuals per load case (paper Fig. 3)."""
        plt = pyplot()
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
        try:
            save_figure(fig, path, dpi=90, format="png")
        finally:
            plt.close(fig)
        return path
