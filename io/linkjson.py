"""The reader of ``stiffkit link`` JSON results (docs/link.md), for every
stage that takes a link's compliance from a file: the spring trees and
parallel robots (``springs``) and the robot model's ``value = "link.json"``
(``robot``)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .tables import matrix6, read_json

__all__ = ["read_link_compliance"]


def read_link_compliance(path, where: str = "") -> np.ndarray:
    """The 6x6 compliance (SI; the link's own axes, at its reference point)
    under the key "compliance" of a ``stiffkit link`` JSON file.

    Raises InputError naming ``where`` (the caller's context, if any) and the
    file for a missing or unreadable file, invalid JSON, a missing key, a
    shape other than 6x6 or a NaN/Inf.
    """
    data = read_json(path, "`stiffkit link` JSON", where)
    at = f"{where}: {path}" if where else str(path)
    if not isinstance(data, dict) or "compliance" not in data:
        raise InputError(f"{at}: no 'compliance' key (expected a `stiffkit link` JSON result)")
    return matrix6(data["compliance"], f"{at}: 'compliance'")
