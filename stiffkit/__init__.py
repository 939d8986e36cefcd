"""stiffkit: how stiff a robot is, and why it bends the way it does.

Link stiffness from CAD (Gmsh + CalculiX + field fits), manipulator
stiffness (generalised springs, virtual-joint models), calibration and
diagnosis against measurements. The numbers are computed in a Fortran core
(``core/``), wrapped by f2py (``stiffkit._core``); the subpackages follow the
pipeline: ``meshing`` -> ``fea`` -> ``field`` -> ``robot`` -> ``springs`` /
``calib``, and ``cli`` is the command line. The commands of the calibration
contract are callable from Python with the same names (``fit``,
``diagnose``, ``compare``, ``compensate``, ``plan``, ``load_model``).
"""

from .calib import compare, diagnose, fit, plan
from .errors import (
    ConvergenceError,
    DegenerateError,
    InputError,
    PlausibilityWarning,
    SingularError,
    StiffkitError,
    StiffkitWarning,
)
from .field import (
    METHODS,
    Compliance,
    FieldFit,
    beam_stiffness,
    cantilever_compliance,
    compliance_from_experiments,
    fit_field,
    fit_fields,
    normal_quantile,
    section_properties,
)
from .robot import load_model
from .robot.compensate import compensate
from .version import __version__

__all__ = [
    "StiffkitError",
    "InputError",
    "DegenerateError",
    "SingularError",
    "ConvergenceError",
    "StiffkitWarning",
    "PlausibilityWarning",
    "METHODS",
    "FieldFit",
    "Compliance",
    "fit_field",
    "fit_fields",
    "compliance_from_experiments",
    "section_properties",
    "cantilever_compliance",
    "beam_stiffness",
    "normal_quantile",
    "load_model",
    "compensate",
    "fit",
    "diagnose",
    "compare",
    "plan",
    "sweep",
    "__version__",
]


def __getattr__(name: str) -> object:
    # stiffkit.sweep (design sweeps on Dask) is imported on first use, so that
    # `import stiffkit` does not import dask
    if name == "sweep":
        import importlib

        return importlib.import_module(".sweep", __name__)
    raise AttributeError(f"module 'stiffkit' has no attribute {name!r}")
