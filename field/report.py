"""The report of fitted load cases (``stiffkit field``): the deflection of
every case, the pooled noise and, with the wrenches, the compliance with
its intervals and zero-element tests (Pashkevich et al. 2009, s3-s4)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..io.files import write_json
from .compliance import Compliance, compliance_from_experiments
from .fit import DOF_NAMES, FieldFit, fit_fields

__all__ = ["FieldReport", "field_report"]


@dataclass
class FieldReport:
    fits: list[FieldFit]
    n_nodes: int
    method: str
    compliance: Compliance | None = None

    def text(self) -> str:
        fits = self.fits
        lines = [
            f"{len(fits)} field(s), {self.n_nodes} nodes, method {self.method}, "
            f"pooled noise sigma = {fits[0].sigma:.3e} m",
            f"{'case':>4s} " + " ".join(f"{n:>13s}" for n in DOF_NAMES) + "   used",
        ]
        for j, fit in enumerate(fits, 1):
            lines.append(f"{j:4d} " + " ".join(f"{v:13.5e}" for v in fit.deflection) + f"  {fit.n_used:5d}")
        if self.compliance is not None:
            lines += ["", self.compliance.table()]
        return "\n".join(lines)

    def to_json(self) -> dict:
        fits = self.fits
        out = {
            "sigma_m": fits[0].sigma,
            "fits": [
                {"t": f.t.tolist(), "phi": f.phi.tolist(), "cov": f.cov.tolist(), "nodes_used": f.n_used} for f in fits
            ],
        }
        comp = self.compliance
        if comp is not None:
            out.update(
                {
                    "compliance": comp.matrix.tolist(),
                    "compliance_std": comp.std.tolist(),
                    "significant": comp.significant.tolist(),
                    "symmetry_error": comp.asymmetry,
                    "stiffness": None if comp.stiffness is None else comp.stiffness.tolist(),
                }
            )
        return out

    def write_json(self, path: Path | str) -> Path:
        return write_json(path, self.to_json())


def field_report(
    nodes: npt.ArrayLike,
    displacements: npt.ArrayLike,
    reference: npt.ArrayLike,
    method: str = "lin",
    trim: float = 0.0,
    wrenches: npt.ArrayLike | None = None,
    confidence: float = 0.99,
    symmetrize: bool = False,
) -> FieldReport:
    """Fit every field (one noise estimate for all, eq. 21 pooled) and, when
    the wrenches of the cases are given, the compliance (eqs. 2-3)."""
    fits = fit_fields(nodes, displacements, reference, method=method, trim=trim, pooled=True)
    comp = None
    if wrenches is not None:
        comp = compliance_from_experiments(wrenches, fits, confidence=confidence, symmetrize=symmetrize)
    return FieldReport(fits=fits, n_nodes=int(np.shape(nodes)[0]), method=method, compliance=comp)
