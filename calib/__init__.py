"""Robot models from URDF + TOML, elastostatic calibration and model diagnosis.

>>> import stiffkit
>>> m = stiffkit.load_model("examples/kr270/model_values.toml")
>>> C = m.tool_compliance(Q)          # (N, dof) -> (N, 6, 6), one core call
>>> res = stiffkit.calib.fit("model.toml", "measurements.csv")      # same names as the CLI
>>> dg = stiffkit.calib.diagnose("model.toml", "measurements.csv")
>>> print(stiffkit.calib.compare("j1.json", "c2.json"))
>>> pl = stiffkit.plan("model.toml", 12, task="task.csv")       # which postures to measure
"""

from ..robot.model import Model, load_model, model_from_tables
from ..robot.urdf import Chain, load_chain
from .compare import compare
from .diagnose import Candidate, Diagnosis, diagnose, format_diagnosis
from .dualarm import synth_dualarm
from .fit import FitResult, Problem, error_stats, fit, format_parameters, format_table, identified_model, write_model
from .measure import Measurements, read_measurements, write_measurements
from .plan import PlanResult, plan
from .reduce import Reduction, format_reduction, reduce_model
from .synth import kr270_truth, synth_kr270, synthesize, write_synth

__all__ = [
    "Chain",
    "load_chain",
    "Model",
    "load_model",
    "model_from_tables",
    "Measurements",
    "read_measurements",
    "write_measurements",
    "Problem",
    "FitResult",
    "fit",
    "error_stats",
    "format_table",
    "format_parameters",
    "identified_model",
    "diagnose",
    "Diagnosis",
    "Candidate",
    "format_diagnosis",
    "compare",
    "reduce_model",
    "Reduction",
    "format_reduction",
    "synth_kr270",
    "synthesize",
    "write_synth",
    "kr270_truth",
    "synth_dualarm",
    "write_model",
    "plan",
    "PlanResult",
]
