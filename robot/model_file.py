"""Writing model files (docs/calibration.md §2, §5): the [robot] and [measurements]
tables and [[effect]] tables, with or without values, by the one TOML
writer (stiffkit.io.tomlw)."""

from __future__ import annotations

from collections.abc import Iterable

from ..io import tomlw

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
    return tomlw.dumps(doc) + effects_toml(effects)


def effects_toml(effects: Iterable[dict]) -> str:
    """[[effect]] tables, always in the appendable array-of-tables form
    (stiffkit.io.tomlw: every number exactly)."""
    return tomlw.effect_tables(effects)
