"""Rigid motion (t, phi) of a node displacement field about a reference point.

Python face of core/sk_field_fit.f90 (Pashkevich et al. 2009, section 3:
LIN eq. 17, SVD eqs. 6-10 with Table 1, noise eq. 21, covariance eq. 20).
Arrays are normalised once here and handed to the core, which does the
numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._core import field as core
from ..errors import InputError
from ..io import validate as V

__all__ = ["METHODS", "DOF_NAMES", "LOAD_NAMES", "FieldFit", "fit_field", "fit_fields"]

#: method name -> core code
METHODS = {"lin": 0, "svd+": 1, "svd-": 2, "svd+-": 3, "svd±": 3, "exact": 4}

DOF_NAMES = ("tx", "ty", "tz", "phix", "phiy", "phiz")
LOAD_NAMES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


@dataclass(slots=True)
class FieldFit:
    """Rigid motion (t, phi) of a node field about a reference point.

    Attributes
    ----------
    t : (3,) translation of the reference point
    phi : (3,) rotation vector (small-angle components for lin/svd*)
    sigma : noise estimate of this field, eq. 21 (or the pooled one)
    residuals : (n, 3) residual of every node against the fit
    cov : (6, 6) covariance of (t, phi), eq. 20 moved to the reference point
    nodes_used : (n,) bool, False for nodes removed by trimming
    """

    t: np.ndarray
    phi: np.ndarray
    sigma: float
    residuals: np.ndarray
    cov: np.ndarray
    nodes_used: np.ndarray
    method: str
    iterations: int = 0
    sigma_own: float = float("nan")

    @property
    def cov_t(self) -> np.ndarray:
        return self.cov[:3, :3]

    @property
    def cov_phi(self) -> np.ndarray:
        return self.cov[3:, 3:]

    @property
    def deflection(self) -> np.ndarray:
        """(6,) vector (t, phi)."""
        return np.concatenate([self.t, self.phi])

    @property
    def n_used(self) -> int:
        return int(self.nodes_used.sum())

    def __repr__(self) -> str:
        sd = np.sqrt(np.diag(self.cov))
        rows = [f"FieldFit(method={self.method!r}, nodes={self.n_used}/{self.nodes_used.size}, sigma={self.sigma:.4g})"]
        for name, v, s in zip(DOF_NAMES, self.deflection, sd):
            rows.append(f"  {name:5s} {v: .9e} +- {s:.3e}")
        return "\n".join(rows)


def _points(points: npt.ArrayLike, name: str = "points") -> np.ndarray:
    """(n, 3) finite floats in any one unit (the fit does not depend on it)."""
    return V.array(points, name, (None, 3))


def _method_code(method: str, trim: float) -> int:
    if not isinstance(method, str) or method not in METHODS:
        raise InputError(f"unknown method {method!r}; choose one of lin, svd+, svd-, svd+-, exact")
    V.number(trim, "trim", lo=0.0, hi=0.5, hi_open=True)
    return METHODS[method]


def _reference(reference: npt.ArrayLike) -> np.ndarray:
    ref = V.array(reference, "reference").reshape(-1)
    if ref.shape != (3,):
        raise InputError(f"reference must be a point (3,), got shape {np.shape(reference)}")
    return ref


def _fit(p: np.ndarray, d_f: np.ndarray, ref: np.ndarray, method: str, trim: float, pooled: bool) -> list[FieldFit]:
    """Core call on p (n,3) and d_f (3,n,m) Fortran-ordered; results are
    views into the arrays the core filled (no copies)."""
    t, phi, cov, res, used, sigma, niter, sigma_pooled = core.fit_fields(
        p.T, d_f, ref, _method_code(method, trim), trim, pooled
    )
    return [
        FieldFit(
            t[:, j],
            phi[:, j],
            float(sigma_pooled if pooled else sigma[j]),
            res[:, :, j].T,
            cov[:, :, j],
            used[:, j],
            method,
            int(niter[j]),
            float(sigma[j]),
        )
        for j in range(d_f.shape[2])
    ]


def fit_fields(
    points: npt.ArrayLike,
    displacements: npt.ArrayLike,
    reference: npt.ArrayLike,
    method: str = "lin",
    trim: float = 0.0,
    pooled: bool = True,
) -> list[FieldFit]:
    """Fit m displacement fields (m, n, 3) that share node positions (n, 3).

    With ``pooled`` the noise is estimated once over all fields (paper
    s3.4: squared residuals aggregated, m(3n - 6) degrees of freedom) and
    scales every covariance. One core call for all m fields.
    """
    p = _points(points)
    if not isinstance(pooled, (bool, np.bool_)):
        raise InputError(f"pooled = {pooled!r} must be True or False")
    d = V.array(displacements, "displacements")
    if d.ndim != 3 or d.shape[1:] != p.shape or d.shape[0] < 1:
        raise InputError(f"displacements must have shape (m, {p.shape[0]}, 3) to match points {p.shape}, got {d.shape}")
    # (n,3) C-order -> (3,n) F-order without copy; (m,n,3) -> (3,n,m)
    return _fit(
        np.ascontiguousarray(p), np.asfortranarray(d.transpose(2, 1, 0)), _reference(reference), method, trim, pooled
    )


def fit_field(
    points: npt.ArrayLike,
    displacements: npt.ArrayLike,
    reference: npt.ArrayLike,
    method: str = "lin",
    trim: float = 0.0,
) -> FieldFit:
    """Rigid motion of one displacement field about ``reference``.

    Parameters
    ----------
    points : (n, 3) node positions before loading
    displacements : (n, 3) node displacements
    reference : (3,) the point whose translation t is returned
    method : ``"lin"`` (eq. 17), ``"svd+"``, ``"svd-"``, ``"svd+-"`` (eqs. 6-10,
        Table 1) or ``"exact"`` (Gauss-Newton on SO(3); phi = log R)
    trim : fraction of nodes with the largest residual dropped before a refit

    Raises
    ------
    InputError, DegenerateError : bad shapes, NaN/Inf, fewer than 3 nodes,
        collinear or coincident nodes.
    """
    p = np.ascontiguousarray(_points(points))
    d = np.ascontiguousarray(_points(displacements, "displacements"))
    if d.shape != p.shape:
        raise InputError(f"displacements {d.shape} must match points {p.shape}")
    return _fit(p, d.T[:, :, None], _reference(reference), method, trim, False)[0]
