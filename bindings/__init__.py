"""stiffkit: how stiff a robot is, and why it bends the way it does.

Link stiffness from CAD (Gmsh + CalculiX + field fits), manipulator
stiffness (generalised springs, virtual-joint models), calibration and
diagnosis against measurements. The numbers are computed in a Fortran core
(``core/``), wrapped by f2py; this package orchestrates.
"""
from ._errors import (ConvergenceError, DegenerateError, InputError, SingularError,
                      StiffkitError)
from .field import (METHODS, Compliance, FieldFit, beam_stiffness, cantilever_compliance,
                    compliance_from_experiments, fit_field, fit_fields, normal_quantile,
                    section_properties)

# serial robots: stiffness, calibration and diagnosis (contract: the commands
# are callable from Python with the same names)
from .calib import compare, diagnose, fit, load_model  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "StiffkitError", "InputError", "DegenerateError", "SingularError", "ConvergenceError",
    "METHODS", "FieldFit", "Compliance", "fit_field", "fit_fields",
    "compliance_from_experiments", "section_properties", "cantilever_compliance",
    "beam_stiffness", "normal_quantile", "load_model", "fit", "diagnose", "compare", "sweep",
]


def __getattr__(name):
    # stiffkit.sweep (design sweeps on Dask) is imported on first use, so that
    # `import stiffkit` does not import dask; the subpackage is callable
    if name == "sweep":
        import importlib
        return importlib.import_module(".sweep", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
