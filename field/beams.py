"""Closed forms of straight beams: section properties, the cantilever tip
compliance (Pashkevich et al. 2009 eq. 22, optionally Timoshenko) and the
6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24 (core/sk_beams.f90).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._core import field as core
from ..errors import InputError
from ..io import validate as V

__all__ = ["section_properties", "cantilever_compliance", "beam_stiffness"]

_SECTIONS = {"rectangle": 1, "square": 1, "tube": 2, "circle": 2}


def section_properties(shape: str, dims: npt.ArrayLike, nu: float = 0.3) -> dict:
    """Section properties of a straight beam along x.

    shape ``"square"`` (dims = [a]), ``"rectangle"`` ([b along y, h along z]),
    ``"tube"`` ([outer D, inner d]) or ``"circle"`` ([D]). Returns a dict
    with A, Iy, Iz, J (torsion constant), kappa_y, kappa_z (Cowper).
    """
    want = {"square": 1, "circle": 1, "rectangle": 2, "tube": 2}  # sizes per shape
    if not isinstance(shape, str) or shape not in want:
        raise InputError(f"unknown section {shape!r}: use square [a], rectangle [b, h], tube [D, d] or circle [D]")
    dims = list(np.atleast_1d(V.array(dims, f"{shape} section dims")))
    if len(dims) != want[shape]:
        raise InputError(
            f"a {shape} section takes {want[shape]} size(s) "
            f"({ {'square': '[a]', 'circle': '[D]', 'rectangle': '[b, h]', 'tube': '[D, d]'}[shape] }), got {dims}"
        )
    for k, v in enumerate(dims):
        V.number(v, f"{shape} section dims[{k}]", lo=0.0, lo_open=not (shape == "tube" and k == 1))
    V.number(nu, "nu (Poisson's ratio)", lo=-1.0, hi=0.5, lo_open=True, hi_open=True)
    if shape == "square":
        dims = [dims[0], dims[0]]
    elif shape == "circle":
        dims = [dims[0], 0.0]
    props = core.section(_SECTIONS[shape], np.array(dims), nu)
    return dict(zip(("A", "Iy", "Iz", "J", "kappa_y", "kappa_z"), props.tolist()))


_PROPS = ("A", "Iy", "Iz", "J", "kappa_y", "kappa_z")


def _props(section: dict) -> np.ndarray:
    if not isinstance(section, dict):
        raise InputError(f"section must be the dict of section_properties(), got {type(section).__name__}")
    missing = [k for k in _PROPS if k not in section]
    if missing:
        raise InputError(f"section lacks {', '.join(missing)} (build it with section_properties())")
    return np.array([V.number(section[k], f"section[{k!r}]", lo=0.0, lo_open=True) for k in _PROPS])


def _beam(length: float, E: float, nu: float) -> tuple[float, float, float]:
    """(length, E, G) checked: positive, finite, nu in (-1, 0.5). The beam
    formulas are unit-agnostic (any consistent units), so no plausibility."""
    length = V.number(length, "length", lo=0.0, lo_open=True)
    E = V.number(E, "E", lo=0.0, lo_open=True)
    nu = V.number(nu, "nu (Poisson's ratio)", lo=-1.0, hi=0.5, lo_open=True, hi_open=True)
    return length, E, E / (2.0 * (1.0 + nu))


def cantilever_compliance(length: float, E: float, nu: float, section: dict, timoshenko: bool = False) -> np.ndarray:
    """Tip compliance of a cantilever along x (paper eq. 22), 6x6."""
    length, E, G = _beam(length, E, nu)
    return core.cantilever(length, E, G, _props(section), bool(timoshenko))


def beam_stiffness(length: float, E: float, nu: float, section: dict) -> np.ndarray:
    """6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24."""
    length, E, G = _beam(length, E, nu)
    return core.beam_stiffness(length, E, G, _props(section))
