"""Generalised springs, virtual-joint models of serial and parallel robots, stiffness indices.

Build a tree of springs and joints (``Spring``, ``Joint``, ``series``,
``parallel``), evaluate it at N postures in one Fortran call
(``evaluate``), get the tool compliance/stiffness with the free and rigid
directions reported where one of them does not exist; ``stiffness_indices``
gives kappa_t, kappa_r. Example models: ``stiffkit.springs.orthoglide``,
``stiffkit.springs.smg``.
"""

from ..robot.indices import Indices, stiffness_indices, stiffness_indices_where
from .tree import Joint, Parallel, Series, Spring, TreeResult, evaluate, load_link_compliance, parallel, series
from .vjm import model_tree, model_vjm, serial_vjm

__all__ = [
    "Spring",
    "Joint",
    "Series",
    "Parallel",
    "series",
    "parallel",
    "evaluate",
    "TreeResult",
    "load_link_compliance",
    "Indices",
    "stiffness_indices",
    "stiffness_indices_where",
    "serial_vjm",
    "model_tree",
    "model_vjm",
]
