"""Writing model files (docs/calibration.md §2, §5): the [robot] and [measurements]
tables and [[effect]] tables, with or without values."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import tomli_w

__all__ = ["model_toml", "effects_toml"]


def model_toml(
    effects: list[dict],
    sigma: float | None = None,
    urdf: str = "robot.urdf",
    tool_frame: str = "tool0",
    sigma_rotation: float | None = None,
) -> str:
    """A model file (docs/calibration.md §2): [robot], optional [measurements] sigmas, the effects."""
    doc = {"robot": {"urdf": urdf, "base_link": "base_link", "tool_frame": tool_frame}}
    meas = {}
    if sigma is not None:
        meas["sigma_position"] = float(sigma)
    if sigma_rotation is not None:
        meas["sigma_rotation"] = float(sigma_rotation)
    if meas:
        doc["measurements"] = meas
    return tomli_w.dumps(doc) + effects_toml(effects)


def effects_toml(effects: Iterable[dict]) -> str:
    """[[effect]] tables, always in the appendable array-of-tables form."""
    return "".join("\n[[effect]]\n" + tomli_w.dumps(_plain(e)) for e in effects)


def _plain(v: object) -> object:
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v
