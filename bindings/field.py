"""Deflections from a node displacement field, and the compliance matrix.

Python face of core/sk_field_fit.f90, core/sk_compliance.f90 and
core/sk_beams.f90 (Pashkevich et al. 2009, sections 2-4). Arrays are
normalised once here and handed to the Fortran core, which does the numbers.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from . import _field
from ._errors import InputError, check

__all__ = [
    "METHODS", "FieldFit", "Compliance", "fit_field", "fit_fields",
    "compliance_from_experiments", "section_properties", "cantilever_compliance",
    "beam_stiffness", "normal_quantile",
]

#: method name -> core code
METHODS = {"lin": 0, "svd+": 1, "svd-": 2, "svd+-": 3, "svd±": 3, "exact": 4}

_FIT_DETAILS = {
    1: "need at least 3 nodes, with displacements of the same shape as the points",
    6: "method must be one of lin, svd+, svd-, svd+-, exact and trim in [0, 0.5)",
    8: "trimming leaves fewer than 3 nodes",
}

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
        rows = [f"FieldFit(method={self.method!r}, nodes={self.n_used}/{self.nodes_used.size}, "
                f"sigma={self.sigma:.4g})"]
        for name, v, s in zip(DOF_NAMES, self.deflection, sd):
            rows.append(f"  {name:5s} {v: .9e} +- {s:.3e}")
        return "\n".join(rows)


def _points(points, name="points") -> np.ndarray:
    a = np.asarray(points, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"{name} must have shape (n, 3), got {a.shape}")
    return a


def _method_code(method: str, trim: float) -> int:
    try:
        code = METHODS[method]
    except KeyError:
        raise InputError(f"unknown method {method!r}; choose one of lin, svd+, svd-, svd+-, exact") from None
    if not 0.0 <= trim < 0.5:
        raise InputError(f"trim must be a fraction in [0, 0.5), got {trim}")
    return code


def _reference(reference) -> np.ndarray:
    ref = np.asarray(reference, dtype=float).reshape(-1)
    if ref.shape != (3,):
        raise InputError(f"reference must be a point (3,), got shape {np.shape(reference)}")
    return ref


def _fit(p, d_f, ref, method, trim, pooled) -> list[FieldFit]:
    """Core call on p (n,3) and d_f (3,n,m) Fortran-ordered; results are
    views into the arrays the core filled (no copies)."""
    t, phi, cov, res, used, sigma, _nused, niter, sigma_pooled, info = _field.sk_fit_fields(
        p.T, d_f, ref, _method_code(method, trim), float(trim), int(bool(pooled)))
    check(info, "fit_field (sk_fit_fields)", _FIT_DETAILS)
    used = used != 0
    return [FieldFit(t[:, j], phi[:, j], float(sigma_pooled if pooled else sigma[j]),
                     res[:, :, j].T, cov[:, :, j], used[:, j], method, int(niter[j]),
                     float(sigma[j]))
            for j in range(d_f.shape[2])]


def fit_fields(points, displacements, reference, method: str = "lin", trim: float = 0.0,
               pooled: bool = True) -> list[FieldFit]:
    """Fit m displacement fields (m, n, 3) that share node positions (n, 3).

    With ``pooled`` the noise is estimated once over all fields (paper
    s3.4: squared residuals aggregated, m(3n - 6) degrees of freedom) and
    scales every covariance. One core call for all m fields.
    """
    p = _points(points)
    d = np.asarray(displacements, dtype=float)
    if d.ndim != 3 or d.shape[1:] != p.shape:
        raise InputError(f"displacements must have shape (m, {p.shape[0]}, 3) to match points "
                         f"{p.shape}, got {d.shape}")
    # (n,3) C-order -> (3,n) F-order without copy; (m,n,3) -> (3,n,m)
    return _fit(np.ascontiguousarray(p), np.asfortranarray(d.transpose(2, 1, 0)),
                _reference(reference), method, trim, pooled)


def fit_field(points, displacements, reference, method: str = "lin", trim: float = 0.0) -> FieldFit:
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


@dataclass(frozen=True)
class Compliance:
    """Compliance matrix k (deflection = k wrench) with its statistics."""

    matrix: np.ndarray          # (6, 6)
    std: np.ndarray             # (6, 6) standard deviation of each element
    ci: np.ndarray              # (6, 6) confidence half-width at `confidence`
    significant: np.ndarray     # (6, 6) bool: interval excludes zero
    stiffness: np.ndarray | None  # k^-1, None where k is singular
    asymmetry: float            # max |k_ij - k_ji| / sqrt(|k_ii k_jj|) before symmetrising
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
        lines = [f"compliance (rows {', '.join(DOF_NAMES)}; columns {', '.join(LOAD_NAMES)}), "
                 f"+- {100 * self.confidence:g} % interval, '0' = not significant"]
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
        return f"Compliance(significant={int(self.significant.sum())}/36, confidence={self.confidence})\n" + self.table()


def compliance_from_experiments(wrenches, fits, confidence: float = 0.99,
                                symmetrize: bool = False, covariances=None) -> Compliance:
    """Compliance k = D W^+ (eq. 2; eq. 3 for six axis loads) with statistics.

    Parameters
    ----------
    wrenches : (m, 6) applied (Fx, Fy, Fz, Mx, My, Mz), m >= 6, spanning R^6
    fits : m FieldFit results, or an (m, 6) array of deflections (t, phi)
        together with ``covariances`` (m, 6, 6)
    confidence : two-sided level of the intervals used for significance
    symmetrize : return (k + k^T)/2 (asymmetry is reported either way)
    """
    w = np.asarray(wrenches, dtype=float)
    if w.ndim != 2 or w.shape[1] != 6:
        raise InputError(f"wrenches must have shape (m, 6), got {w.shape}")
    if isinstance(fits, np.ndarray) or covariances is not None:
        x = np.asarray(fits, dtype=float)
        cov = (np.zeros((x.shape[0], 6, 6)) if covariances is None
               else np.asarray(covariances, dtype=float))
        sigma = float("nan")
    else:
        fits = list(fits)
        x = np.array([f.deflection for f in fits])
        cov = np.array([f.cov for f in fits])
        sigma = float(np.mean([f.sigma for f in fits])) if fits else float("nan")
    if x.shape != w.shape:
        raise InputError(f"{x.shape[0] if x.ndim else 0} deflections for {w.shape[0]} wrenches: "
                         f"need one (t, phi) per wrench, shape {w.shape}")
    if cov.shape != (w.shape[0], 6, 6):
        raise InputError(f"covariances must have shape ({w.shape[0]}, 6, 6), got {cov.shape}")
    if w.shape[0] < 6:
        raise InputError(f"need at least 6 experiments, got {w.shape[0]}")
    k, kstd, ci, sig, kstiff, asym, z, stiff_info, info = _field.sk_compliance_matrix(
        np.asfortranarray(w.T), np.asfortranarray(x.T), np.asfortranarray(cov.transpose(1, 2, 0)),
        float(confidence), int(bool(symmetrize)))
    check(info, "compliance_from_experiments (sk_compliance_matrix)",
          {5: "the wrenches do not span all six directions (W is rank deficient)",
           6: f"confidence must lie in (0, 1), got {confidence}"})
    return Compliance(matrix=k, std=kstd, ci=ci, significant=sig.astype(bool),
                      stiffness=kstiff if stiff_info == 0 else None, asymmetry=float(asym),
                      confidence=float(confidence), z=float(z), symmetrized=bool(symmetrize),
                      sigma=sigma)


_SECTIONS = {"rectangle": 1, "square": 1, "tube": 2, "circle": 2}


def section_properties(shape: str, dims, nu: float = 0.3) -> dict:
    """Section properties of a straight beam along x.

    shape ``"square"`` (dims = [a]), ``"rectangle"`` ([b along y, h along z]),
    ``"tube"`` ([outer D, inner d]) or ``"circle"`` ([D]). Returns a dict
    with A, Iy, Iz, J (torsion constant), kappa_y, kappa_z (Cowper).
    """
    dims = list(np.atleast_1d(np.asarray(dims, dtype=float)))
    if shape == "square":
        dims = [dims[0], dims[0]]
    elif shape == "circle":
        dims = [dims[0], 0.0]
    if shape not in _SECTIONS or len(dims) != 2:
        raise InputError(f"unknown section {shape!r} with dims {dims}: use square [a], "
                         "rectangle [b, h], tube [D, d] or circle [D]")
    props, info = _field.sk_section(_SECTIONS[shape], np.array(dims), float(nu))
    check(info, "section_properties (sk_section)",
          {6: f"section dims {dims} or nu {nu} out of range (positive sizes, inner < outer, -1 < nu < 0.5)"})
    return dict(zip(("A", "Iy", "Iz", "J", "kappa_y", "kappa_z"), props.tolist()))


def _props(section: dict) -> np.ndarray:
    return np.array([section[k] for k in ("A", "Iy", "Iz", "J", "kappa_y", "kappa_z")])


def cantilever_compliance(length: float, E: float, nu: float, section: dict,
                          timoshenko: bool = False) -> np.ndarray:
    """Tip compliance of a cantilever along x (paper eq. 22), 6x6."""
    G = E / (2.0 * (1.0 + nu))
    c, info = _field.sk_cantilever(float(length), float(E), G, _props(section), int(timoshenko))
    check(info, "cantilever_compliance (sk_cantilever)", {6: "length, E, G and section must be positive"})
    return c


def beam_stiffness(length: float, E: float, nu: float, section: dict) -> np.ndarray:
    """6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24."""
    G = E / (2.0 * (1.0 + nu))
    k, info = _field.sk_beam_stiffness(float(length), float(E), G, _props(section))
    check(info, "beam_stiffness (sk_beam_stiffness)", {6: "length, E, G and section must be positive"})
    return k


def normal_quantile(level: float) -> float:
    """z such that P(|Z| <= z) = level for a standard normal Z."""
    return float(_field.sk_normal_quantile(float(level)))
