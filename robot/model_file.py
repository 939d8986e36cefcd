"""Writing model files of both data kinds (docs/calibration.md §2, §5, §6.2):
the [robot], [measurements], [gravity] and [plan] tables and the [[effect]]
tables, with or without values, by the one TOML writer (stiffkit.io.tomlw).
Every writer of a model file (synth, ``fit --write-model`` of both kinds,
the dual-arm data) goes through :func:`model_text`; the values of each
kind are written under the keys the catalogue names (robot/catalogue.py
``value_table``)."""

from __future__ import annotations

from collections.abc import Iterable

from ..io import tomlw

__all__ = ["model_text", "model_toml", "effects_toml"]


def model_text(
    effects: Iterable[dict],
    robot: dict,
    kind: str | None = None,
    sigma_position: float | None = None,
    sigma_rotation: float | None = None,
    gravity: dict | None = None,
    plan: dict | None = None,
    header: str = "",
) -> str:
    """A model file: ``header`` (comment lines), [robot], [measurements]
    (``kind`` and the sigmas that are given; none: no table), [gravity] and
    [plan] when given, then the [[effect]] tables."""
    doc: dict = {"robot": dict(robot)}
    meas: dict = {}
    if kind is not None:
        meas["kind"] = kind
    if sigma_position is not None:
        meas["sigma_position"] = float(sigma_position)
    if sigma_rotation is not None:
        meas["sigma_rotation"] = float(sigma_rotation)
    if meas:
        doc["measurements"] = meas
    if gravity:
        doc["gravity"] = dict(gravity)
    if plan:
        doc["plan"] = plan
    return tomlw.dumps(doc, header) + effects_toml(effects)


def model_toml(
    effects: list[dict],
    sigma: float | None = None,
    urdf: str = "robot.urdf",
    tool_frame: str = "tool0",
    sigma_rotation: float | None = None,
) -> str:
    """A model file (docs/calibration.md §2): [robot], optional [measurements] sigmas, the effects."""
    robot = {"urdf": urdf, "base_link": "base_link", "tool_frame": tool_frame}
    return model_text(effects, robot, sigma_position=sigma, sigma_rotation=sigma_rotation)


def effects_toml(effects: Iterable[dict]) -> str:
    """[[effect]] tables, always in the appendable array-of-tables form
    (stiffkit.io.tomlw: every number exactly)."""
    return tomlw.effect_tables(effects)
