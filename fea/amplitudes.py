"""Load amplitudes of a link job and the closed forms they start from.

The six load cases are scaled so that each case's largest deflection falls
in the ranges the paper recommends for the field fit (Pashkevich et al.
2009, s3.5, s4.2: 0.1-1 mm, 0.01-0.2 deg). The first estimate of the
compliance is the closed form (eq. 22) for built-in straight shapes, else a
solid rectangular cantilever spanning the bounding box.
"""

from __future__ import annotations

import numpy as np

from .._core.springs import rotate6
from ..field import cantilever_compliance, section_properties
from ..meshing import Mesh
from .config import LinkJob

__all__ = [
    "T_RANGE_M",
    "PHI_RANGE_RAD",
    "T_TARGET_M",
    "PHI_TARGET_RAD",
    "closed_form",
    "beam_estimate",
    "auto_amplitudes",
]

#: deflection ranges the paper recommends for the field fit (s3.5, s4.2)
T_RANGE_M = (1e-4, 1e-3)
PHI_RANGE_RAD = (np.radians(0.01), np.radians(0.2))
#: caps of the automatic amplitudes: rounding down to 1-2-5 keeps the binding
#: deflection within [0.4, 1] x cap, i.e. 0.1-0.25 mm or 0.04-0.1 deg
T_TARGET_M = 2.5e-4
PHI_TARGET_RAD = np.radians(0.1)


def closed_form(job: LinkJob) -> np.ndarray | None:
    """Eq. 22 compliance of the job's built-in straight shape (or of its
    ``[approximation]``), None when it has none."""
    cf = job.closed_form_shape()
    if cf is None:
        return None
    L, sec, dims = cf
    return cantilever_compliance(L, job.E, job.nu, section_properties(sec, dims, job.nu))


def beam_estimate(job: LinkJob, mesh: Mesh) -> np.ndarray:
    """First estimate of the compliance for the automatic amplitudes: the
    closed form (eq. 22) for built-in shapes, else a solid rectangular
    cantilever spanning the bounding box along the load plane's axis."""
    cf = closed_form(job)
    if cf is not None:
        return cf
    lo, hi = mesh.bbox()
    ext = np.maximum(hi - lo, 1e-12)
    # the load plane's axis, else the part's longest side
    a = "xyz".index(job.load_plane[0]) if job.load_plane else int(np.argmax(ext))
    others = [i for i in range(3) if i != a]
    k_local = cantilever_compliance(
        float(ext[a]), job.E, job.nu, section_properties("rectangle", [ext[others[0]], ext[others[1]]], job.nu)
    )
    R = np.zeros((3, 3))  # columns: global images of local x, y, z
    R[a, 0] = 1.0
    R[others[0], 1] = 1.0
    R[others[1], 2] = 1.0
    return rotate6(R, k_local)


def _nice_floor(v: float) -> float:
    """Largest 1, 2 or 5 x 10^k not above v."""
    e = np.floor(np.log10(v))
    for m in (5.0, 2.0, 1.0):
        if m * 10**e <= v * (1 + 1e-12):
            return float(m * 10**e)
    return float(10**e)


def auto_amplitudes(k_est: np.ndarray) -> np.ndarray:
    """Loads that bring each case's largest deflection to the paper's
    recommended ranges (s3.5: 0.1-1 mm, 0.01-0.2 deg): the largest load of
    the form 1, 2 or 5 x 10^k whose translation stays below 0.25 mm and
    rotation below 0.1 deg; the binding one then lies in 0.1-0.25 mm or
    0.04-0.1 deg."""
    amps = np.zeros(6)
    for j in range(6):
        t = np.abs(k_est[:3, j]).max()
        p = np.abs(k_est[3:, j]).max()
        lim = []
        if t > 0:
            lim.append(T_TARGET_M / t)
        if p > 0:
            lim.append(PHI_TARGET_RAD / p)
        amps[j] = _nice_floor(min(lim)) if lim else 1.0
    return amps
