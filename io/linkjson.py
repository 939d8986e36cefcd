"""The reader of ``stiffkit link`` JSON results (docs/link.md), for every
stage that takes a link's compliance from a file: the spring trees and
parallel robots (``springs``) and the robot model's ``value = "link.json"``
(``robot``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["read_link_compliance"]

EXPECTED = "expected a `stiffkit link` JSON result"


def read_link_compliance(path, where: str = "") -> np.ndarray:
    """The 6x6 compliance (SI; the link's own axes, at its reference point)
    under the key "compliance" of a ``stiffkit link`` JSON file.

    Raises InputError naming ``where`` (the caller's context, if any) and the
    file for a missing or unreadable file, invalid JSON, a missing key, a
    shape other than 6x6 or a NaN/Inf.
    """
    path = Path(path)
    at = f"{where}: {path}" if where else str(path)
    if not path.is_file():
        raise InputError(f"{at}: no such file ({EXPECTED})")
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{at}: cannot read it as JSON ({exc})") from None
    if not isinstance(data, dict) or "compliance" not in data:
        raise InputError(f"{at}: no 'compliance' key ({EXPECTED})")
    try:
        c = np.asarray(data["compliance"], dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{at}: 'compliance' must be 6 rows of 6 numbers") from None
    if c.shape != (6, 6):
        raise InputError(f"{at}: 'compliance' must be 6x6, got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise InputError(f"{at}: 'compliance' contains NaN or Inf")
    return c
