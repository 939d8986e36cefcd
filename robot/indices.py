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
import numpy.typing as npt

from .._core import springs as core
from ..errors import InputError

__all__ = ["Indices", "stiffness_indices", "stiffness_indices_where"]


@dataclass(frozen=True)
class Indices:
    """kappa_t, kappa_r (N,) and the eigenvalues (N,3) of G_f^T G_f, G_n^T G_n."""

    kappa_t: np.ndarray
    kappa_r: np.ndarray
    lambda_f: np.ndarray
    lambda_n: np.ndarray
    lscale: float


def stiffness_indices(k: npt.ArrayLike, lscale: float) -> Indices:
    """Indices of one (6,6) or N (N,6,6) stiffness matrices, one core call."""
    k = np.asarray(k, dtype=float)
    single = k.ndim == 2
    k = k[None] if single else k
    if k.shape[1:] != (6, 6):
        raise InputError(f"stiffness must be (6,6) or (N,6,6), got {k.shape}")
    kt, kr, lf, ln = core.stiffness_indices(k, lscale)
    return Indices(kappa_t=kt, kappa_r=kr, lambda_f=lf, lambda_n=ln, lscale=float(lscale))


def stiffness_indices_where(k: npt.ArrayLike, ok: npt.ArrayLike, lscale: float) -> Indices:
    """Indices of N stiffness matrices (N,6,6) where ``ok`` (N,) is True, NaN elsewhere.

    Where the stiffness does not exist (a singular compliance: a serial
    singularity, or too few springs to load every direction) the caller's
    K is a placeholder (zeros); its indices would be garbage, so they are
    NaN. The defined postures go to the core in one call.
    """
    k = np.asarray(k, dtype=float)
    ok = np.asarray(ok, dtype=bool).reshape(-1)
    if k.ndim != 3 or k.shape[1:] != (6, 6) or ok.shape != (k.shape[0],):
        raise InputError(f"stiffness must be (N,6,6) with ok (N,), got {k.shape} and {ok.shape}")
    n = k.shape[0]
    kt, kr = np.full(n, np.nan), np.full(n, np.nan)
    lf, ln = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
    if not (np.isfinite(lscale) and lscale > 0):
        raise InputError(f"lscale must be > 0, got {lscale}")
    if ok.any():
        sub = stiffness_indices(k[ok], lscale)
        kt[ok], kr[ok], lf[ok], ln[ok] = sub.kappa_t, sub.kappa_r, sub.lambda_f, sub.lambda_n
    return Indices(kappa_t=kt, kappa_r=kr, lambda_f=lf, lambda_n=ln, lscale=float(lscale))
