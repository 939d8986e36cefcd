"""Robot models from URDF + TOML, elastostatic calibration and model diagnosis.

    >>> import stiffkit
    >>> m = stiffkit.load_model("examples/kr270/model_values.toml")
    >>> C = m.tool_compliance(Q)          # (N, dof) -> (N, 6, 6), one core call
    >>> res = stiffkit.calib.fit(model, stiffkit.calib.read_measurements(csv, model.chain.dof))
"""
from .fit import FitResult, Problem, error_stats, fit, format_parameters, format_table, identified_model
from .measure import Measurements, read_measurements, write_measurements
from .model import Model, load_model, model_from_tables
from .robot import Chain, load_chain

__all__ = ["Chain", "load_chain", "Model", "load_model", "model_from_tables", "Measurements",
           "read_measurements", "write_measurements", "Problem", "FitResult", "fit", "error_stats",
           "format_table", "format_parameters", "identified_model"]
