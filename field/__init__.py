"""Deflections from node displacement fields and the compliance of a link
(Pashkevich et al. 2009, sections 2-4): field fits (LIN, SVD, exact),
the compliance matrix with its statistics, and beam closed forms."""

from .beams import beam_stiffness, cantilever_compliance, section_properties
from .compliance import Compliance, compliance_from_experiments, normal_quantile
from .fit import DOF_NAMES, LOAD_NAMES, METHODS, FieldFit, fit_field, fit_fields

__all__ = [
    "METHODS",
    "DOF_NAMES",
    "LOAD_NAMES",
    "FieldFit",
    "fit_field",
    "fit_fields",
    "Compliance",
    "compliance_from_experiments",
    "normal_quantile",
    "section_properties",
    "cantilever_compliance",
    "beam_stiffness",
]
