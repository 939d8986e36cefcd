"""Stiffness performance indices kappa_t, kappa_r (Taghvaeipour et al. 2010 s5).

Python face of core/sk_indices.f90. The paper's eqs. 34-39 mix N/m with N
(and N with N m), so as printed the indices change with the unit of length;
with a characteristic length ``lscale`` (same unit as the stiffness) the
translation is made dimensionless and the moment equation divided by it,
and both indices come out in N whatever the unit. ``lscale=1`` (in the
caller's unit) is the literal formula.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _springs
from .._errors import InputError, check

__all__ = ["Indices", "stiffness_indices"]


@dataclass(frozen=True)
class Indices:
    """kappa_t, kappa_r (N,) and the eigenvalues (N,3) of G_f^T G_f, G_n^T G_n."""

    kappa_t: np.ndarray
    kappa_r: np.ndarray
    lambda_f: np.ndarray
    lambda_n: np.ndarray
    lscale: float


def stiffness_indices(k, lscale: float) -> Indices:
    """Indices of one (6,6) or N (N,6,6) stiffness matrices, one core call."""
    k = np.asarray(k, dtype=float)
    single = k.ndim == 2
    k = k[None] if single else k
    if k.shape[1:] != (6, 6):
        raise InputError(f"stiffness must be (6,6) or (N,6,6), got {k.shape}")
    kt, kr, lf, ln, info = _springs.sk_stiffness_indices(np.moveaxis(k, 0, 2), float(lscale))
    check(info, "stiffness_indices (sk_stiffness_indices)",
          {6: f"lscale must be > 0, got {lscale}", 2: "the stiffness contains NaN or Inf"})
    return Indices(kappa_t=kt, kappa_r=kr, lambda_f=lf.T, lambda_n=ln.T, lscale=float(lscale))
