"""Closed forms of straight beams: section properties, the cantilever tip
compliance (Pashkevich et al. 2009 eq. 22, optionally Timoshenko) and the
6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24 (core/sk_beams.f90).
"""

from __future__ import annotations

import numpy as np

from .._core import field as core
from ..errors import InputError

__all__ = ["section_properties", "cantilever_compliance", "beam_stiffness"]

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
        raise InputError(
            f"unknown section {shape!r} with dims {dims}: use square [a], rectangle [b, h], tube [D, d] or circle [D]"
        )
    props = core.section(_SECTIONS[shape], np.array(dims), nu)
    return dict(zip(("A", "Iy", "Iz", "J", "kappa_y", "kappa_z"), props.tolist()))


def _props(section: dict) -> np.ndarray:
    return np.array([section[k] for k in ("A", "Iy", "Iz", "J", "kappa_y", "kappa_z")])


def cantilever_compliance(length: float, E: float, nu: float, section: dict, timoshenko: bool = False) -> np.ndarray:
    """Tip compliance of a cantilever along x (paper eq. 22), 6x6."""
    G = E / (2.0 * (1.0 + nu))
    return core.cantilever(length, E, G, _props(section), timoshenko)


def beam_stiffness(length: float, E: float, nu: float, section: dict) -> np.ndarray:
    """6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24."""
    G = E / (2.0 * (1.0 + nu))
    return core.beam_stiffness(length, E, G, _props(section))
