"""The reader of ``stiffkit link`` JSON results (docs/link.md), for every
stage that takes a link's compliance from a file: the spring trees and
parallel robots (``springs``) and the robot model's ``value = "link.json"``
(``robot``).

A compliance from FEA is symmetric only to the noise of its field fits (the
default link job does not symmetrise it): the reader returns (C + C^T)/2,
silently when every |c_ij - c_ji| is within three standard deviations of
the elements (``compliance_std`` of the file) or the asymmetry is at
round-off level, with a warning when it exceeds that noise, and refuses a
matrix asymmetric by more than 10 % (not a compliance). A matrix with a
negative eigenvalue is refused too (not a spring).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from .._core.springs import psd_defect
from ..errors import InputError
from . import validate as V
from .tables import matrix6, read_json

__all__ = ["read_link_compliance", "check_spring_matrix"]

#: relative asymmetry of a link compliance refused outright
ASYMMETRY_ERROR = 0.1


def check_spring_matrix(
    m: npt.ArrayLike, name: str, noise: np.ndarray | None = None, silent: float = 1e-9, error: float = ASYMMETRY_ERROR
) -> np.ndarray:
    """A 6x6 compliance or stiffness as a spring: finite, symmetric (see the
    module docstring; returned symmetrised) and positive semi-definite."""
    m = matrix6(m, name)
    sym, _asym = V.symmetric6(m, name, silent=silent, error=error, noise=noise)
    dmin, tol = psd_defect(sym)
    if dmin[0] < -tol:
        raise InputError(
            f"{name} has a negative eigenvalue (smallest eigenvalue of the normalised matrix {dmin[0]:.3g}): "
            "not a compliance or stiffness (a spring cannot return energy)"
        )
    return sym


def read_link_compliance(path: Path | str, where: str = "") -> np.ndarray:
    """The 6x6 compliance (SI; the link's own axes, at its reference point)
    under the key "compliance" of a ``stiffkit link`` JSON file, symmetrised.

    Raises InputError naming ``where`` (the caller's context, if any) and the
    file for a missing or unreadable file, invalid JSON, a missing key, a
    shape other than 6x6, a NaN/Inf, an asymmetry beyond the FEA noise by
    far, or a negative eigenvalue.
    """
    data = read_json(path, "`stiffkit link` JSON", where)
    at = f"{where}: {path}" if where else str(path)
    if not isinstance(data, dict) or "compliance" not in data:
        raise InputError(f"{at}: no 'compliance' key (expected a `stiffkit link` JSON result)")
    noise = None
    if "compliance_std" in data:
        try:
            noise = matrix6(data["compliance_std"], f"{at}: 'compliance_std'")
        except InputError:
            noise = None  # an optional key: without it only round-off is silent
    return check_spring_matrix(data["compliance"], f"{at}: 'compliance'", noise=noise)
