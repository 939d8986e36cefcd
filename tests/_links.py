"""LINK.toml texts shared by the tests that run `stiffkit link` / `sweep`
on a small built-in beam (40 x 10 x 10 mm, clamped at x-min, loaded at x-max)."""

from __future__ import annotations


def small_beam(size: float = 10.0) -> str:
    """The small beam's LINK.toml with linear elements of ``size`` mm."""
    return f"""[geometry]
shape = "box"
size = [40.0, 10.0, 10.0]
units = "mm"
[material]
E = 2.0e11
nu = 0.3
[support]
plane = "x-min"
[load]
plane = "x-max"
reference_point = [40.0, 0.0, 0.0]
[mesh]
order = 1
size = {size!r}
"""
