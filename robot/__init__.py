"""Robot models: kinematic chains read from a URDF, the elastostatic model
(URDF + TOML effects, values or parameters to identify) and its tool
compliance, and the stiffness indices of a tool stiffness.

This stage sits below both ``springs`` and ``calib``: it knows the robot,
not how its parameters are identified."""

from .indices import Indices, stiffness_indices, stiffness_indices_where
from .model import Model, Term, load_model, model_from_tables
from .urdf import Chain, load_chain, urdf_text

__all__ = [
    "Chain",
    "load_chain",
    "urdf_text",
    "Model",
    "Term",
    "load_model",
    "model_from_tables",
    "Indices",
    "stiffness_indices",
    "stiffness_indices_where",
]
