"""Typed wrappers of the field-fit, compliance and beam core (``_field``,
core/sk_api_field.f90): arrays in the core's layout, ``info`` mapped to
exceptions naming the routine."""

from __future__ import annotations

import numpy as np

from . import _field
from .errors import call, check

_FIT_DETAILS = {
    1: "need at least 3 nodes, with displacements of the same shape as the points",
    6: "method must be one of lin, svd+, svd-, svd+-, exact and trim in [0, 0.5)",
    8: "trimming leaves fewer than 3 nodes",
    7: "the exact fit did not converge (a rotation near 180 degrees, or values too large)",
}


def fit_fields(p: np.ndarray, d: np.ndarray, p0: np.ndarray, method: int, trim: float, pooled: bool) -> tuple:
    """Rigid motions of m fields: p (3, n), d (3, n, m) Fortran-ordered.

    Returns (t (3,m), phi (3,m), cov (6,6,m), res (3,n,m), used (n,m) bool,
    sigma (m,), niter (m,), sigma_pooled)."""
    t, phi, cov, res, used, sigma, _nused, niter, sigma_pooled, info = call(
        _field.sk_fit_fields, "fit_field (sk_fit_fields)", p, d, p0, int(method), float(trim), int(bool(pooled))
    )
    check(info, "fit_field (sk_fit_fields)", _FIT_DETAILS)
    return t, phi, cov, res, used != 0, sigma, niter, float(sigma_pooled)


def compliance_matrix(w: np.ndarray, x: np.ndarray, cov: np.ndarray, confidence: float, symmetrize: bool) -> tuple:
    """k = D W^+ with statistics: w (m,6), x (m,6), cov (m,6,6).

    Returns (k, kstd, ci, significant bool, stiffness or None, asymmetry, z)."""
    k, kstd, ci, sig, kstiff, asym, z, stiff_info, info = call(
        _field.sk_compliance_matrix,
        "compliance_from_experiments (sk_compliance_matrix)",
        np.asfortranarray(w.T),
        np.asfortranarray(x.T),
        np.asfortranarray(cov.transpose(1, 2, 0)),
        float(confidence),
        int(bool(symmetrize)),
    )
    check(
        info,
        "compliance_from_experiments (sk_compliance_matrix)",
        {
            5: "the wrenches do not span all six directions (W is rank deficient)",
            6: f"confidence must lie in (0, 1), got {confidence}",
        },
    )
    return k, kstd, ci, sig.astype(bool), (kstiff if stiff_info == 0 else None), float(asym), float(z)


def section(shape: int, dims: np.ndarray, nu: float) -> np.ndarray:
    """(A, Iy, Iz, J, kappa_y, kappa_z) of a section (shape 1 rectangle, 2 tube)."""
    props, info = call(
        _field.sk_section, "section_properties (sk_section)", int(shape), np.asarray(dims, float), float(nu)
    )
    check(
        info,
        "section_properties (sk_section)",
        {6: f"section dims {list(dims)} or nu {nu} out of range (positive sizes, inner < outer, -1 < nu < 0.5)"},
    )
    return props


def cantilever(length: float, e: float, g: float, props: np.ndarray, timoshenko: bool) -> np.ndarray:
    """6x6 tip compliance of a cantilever along x (eq. 22)."""
    c, info = call(
        _field.sk_cantilever,
        "cantilever_compliance (sk_cantilever)",
        float(length),
        float(e),
        float(g),
        np.asarray(props, float),
        int(bool(timoshenko)),
    )
    check(info, "cantilever_compliance (sk_cantilever)", {6: "length, E, G and section must be positive"})
    return c


def beam_stiffness(length: float, e: float, g: float, props: np.ndarray) -> np.ndarray:
    """6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24."""
    k, info = call(
        _field.sk_beam_stiffness,
        "beam_stiffness (sk_beam_stiffness)",
        float(length),
        float(e),
        float(g),
        np.asarray(props, float),
    )
    check(info, "beam_stiffness (sk_beam_stiffness)", {6: "length, E, G and section must be positive"})
    return k


def normal_quantile(level: float) -> float:
    """z such that P(|Z| <= z) = level for a standard normal Z."""
    return float(call(_field.sk_normal_quantile, "normal_quantile (sk_normal_quantile)", float(level)))


def rigid_transform(p: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of the rigid motion x ~ R p + t of the points p (n, 3) onto x
    (n, 3): Procrustes with det R = +1 (Kabsch / Horn)."""
    r, t, _rms, info = call(
        _field.sk_rigid_transform,
        "rigid_transform (sk_rigid_transform)",
        np.asfortranarray(np.asarray(p, float).T),
        np.asfortranarray(np.asarray(x, float).T),
    )
    check(
        info,
        "rigid_transform (sk_rigid_transform)",
        {
            1: "need at least 3 points in both sets",
            3: "the points are collinear or coincident",
            2: "the points contain NaN or Inf",
        },
    )
    return r, t
