"""The compliance matrix of a link from m load cases, with its statistics.

Python face of core/sk_compliance.f90 (Pashkevich et al. 2009: k = D W^+,
eqs. 2-3; intervals and zero-element tests from the field covariances).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from .._core import field as core
from ..errors import InputError
from ..io import validate as V
from .fit import DOF_NAMES, LOAD_NAMES, FieldFit

__all__ = ["Compliance", "compliance_from_experiments", "normal_quantile"]


@dataclass(frozen=True)
class Compliance:
    """Compliance matrix k (deflection = k wrench) with its statistics."""

    matrix: np.ndarray  # (6, 6)
    std: np.ndarray  # (6, 6) standard deviation of each element
    ci: np.ndarray  # (6, 6) confidence half-width at `confidence`
    significant: np.ndarray  # (6, 6) bool: interval excludes zero
    stiffness: np.ndarray | None  # k^-1, None where k is singular
    asymmetry: float  # max |k_ij - k_ji| / sqrt(|k_ii k_jj|) before symmetrising
    confidence: float
    z: float
    symmetrized: bool = False
    sigma: float = float("nan")
    extra: dict = field(default_factory=dict)

    def pruned(self) -> np.ndarray:
        """k with non-significant elements set to zero (paper s4.6)."""
        return np.where(self.significant, self.matrix, 0.0)

    def table(self, unit_scale: Sequence[float] | None = None) -> str:
        """Readable table: each element with its +- half-width; zeros marked."""
        lines = [
            f"compliance (rows {', '.join(DOF_NAMES)}; columns {', '.join(LOAD_NAMES)}), "
            f"+- {100 * self.confidence:g} % interval, '0' = not significant"
        ]
        for i in range(6):
            cells = []
            for j in range(6):
                v, h = self.matrix[i, j], self.ci[i, j]
                if self.significant[i, j]:
                    cells.append(f"{v: .5e}±{h:.1e}")
                else:
                    cells.append(f"{'0':>12s} (±{h:.1e})")
            lines.append(f"{DOF_NAMES[i]:5s} " + " ".join(f"{c:>22s}" for c in cells))
        lines.append(f"asymmetry {self.asymmetry:.2e}; {int(self.significant.sum())} of 36 significant")
        return "\n".join(lines)

    __str__ = table

    def __repr__(self) -> str:
        return (
            f"Compliance(significant={int(self.significant.sum())}/36, confidence={self.confidence})\n" + self.table()
        )


def compliance_from_experiments(
    wrenches: npt.ArrayLike,
    fits: Sequence[FieldFit] | np.ndarray,
    confidence: float = 0.99,
    symmetrize: bool = False,
    covariances: npt.ArrayLike | None = None,
) -> Compliance:
    """Compliance k = D W^+ (eq. 2; eq. 3 for six axis loads) with statistics.

    Parameters
    ----------
    wrenches : (m, 6) applied (Fx, Fy, Fz, Mx, My, Mz), m >= 6, spanning R^6
    fits : m FieldFit results, or an (m, 6) array of deflections (t, phi)
        together with ``covariances`` (m, 6, 6)
    confidence : two-sided level of the intervals used for significance
    symmetrize : return (k + k^T)/2 (asymmetry is reported either way)
    """
    w = V.array(wrenches, "wrenches", (None, 6))
    V.number(confidence, "confidence", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    if not isinstance(symmetrize, (bool, np.bool_)):
        raise InputError(f"symmetrize = {symmetrize!r} must be True or False")
    if isinstance(fits, np.ndarray) or covariances is not None:
        x = V.array(fits, "deflections", (None, 6))
        cov = np.zeros((x.shape[0], 6, 6)) if covariances is None else V.array(covariances, "covariances")
        sigma = float("nan")
    else:
        try:
            fits = list(fits)
        except TypeError:
            raise InputError(
                f"fits must be a list of FieldFit results (or an (m, 6) array), got {fits!r:.60}"
            ) from None
        bad = [i for i, f in enumerate(fits) if not isinstance(f, FieldFit)]
        if bad:
            raise InputError(
                f"fits[{bad[0]}] is a {type(fits[bad[0]]).__name__}, not a FieldFit "
                "(pass fit_field results, or an (m, 6) array of deflections with covariances)"
            )
        x = np.array([f.deflection for f in fits]).reshape(-1, 6)
        cov = np.array([f.cov for f in fits]).reshape(-1, 6, 6)
        sigma = float(np.mean([f.sigma for f in fits])) if fits else float("nan")
    if x.shape != w.shape:
        raise InputError(
            f"{x.shape[0] if x.ndim else 0} deflections for {w.shape[0]} wrenches: "
            f"need one (t, phi) per wrench, shape {w.shape}"
        )
    if cov.shape != (w.shape[0], 6, 6):
        raise InputError(f"covariances must have shape ({w.shape[0]}, 6, 6), got {cov.shape}")
    if w.shape[0] < 6:
        raise InputError(f"need at least 6 experiments, got {w.shape[0]}")
    k, kstd, ci, sig, kstiff, asym, z = core.compliance_matrix(w, x, cov, confidence, symmetrize)
    return Compliance(
        matrix=k,
        std=kstd,
        ci=ci,
        significant=sig,
        stiffness=kstiff,
        asymmetry=asym,
        confidence=float(confidence),
        z=z,
        symmetrized=bool(symmetrize),
        sigma=sigma,
    )


def normal_quantile(level: float) -> float:
    """z such that P(|Z| <= z) = level for a standard normal Z."""
    return core.normal_quantile(V.number(level, "level", lo=0.0, hi=1.0, lo_open=True, hi_open=True))
