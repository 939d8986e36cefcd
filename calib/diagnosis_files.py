"""The one path of ``stiffkit diagnose`` (issue 15): read a model file and
its data, diagnose with the adapter of its observation kind
(``calib.diagnose`` for deflections under known loads,
``calib.absolute_diagnose`` for absolute tracker positions; their shared
stages and rules in ``calib.diagnosis``), and the text of either.
"""

from __future__ import annotations

from pathlib import Path

from ..robot.model import load_model
from ..robot.tree_model import model_kind
from .absolute_diagnose import diagnose_absolute
from .absolute_diagnose_report import format_absolute_diagnosis
from .absolute_report import load_absolute
from .diagnose import diagnose
from .diagnose_report import format_diagnosis
from .measure import read_measurements

__all__ = ["diagnose_files", "format_report"]


def diagnose_files(model: str | Path, measurements: str | Path, **kw: object) -> tuple[object, str]:
    """Read a model file and its data, diagnose with the adapter of its
    observation kind (``[measurements] kind``): (the diagnosis, the kind,
    "deflection" or "absolute"). ``kw``: sigma_position, alpha, checks,
    cv_folds, prune, kinds (the candidate kinds to score)."""
    if model_kind(model) == "absolute":
        tm, data = load_absolute(model, measurements)
        return diagnose_absolute(tm, data, **kw), "absolute"  # type: ignore[arg-type]
    m = load_model(model)
    return diagnose(m, read_measurements(measurements, m.chain.dof), **kw), "deflection"  # type: ignore[arg-type]


def format_report(dg: object, kind: str, top: int = 10) -> str:
    """The text of a diagnosis of either kind."""
    if kind == "absolute":
        return format_absolute_diagnosis(dg, top=top)  # type: ignore[arg-type]
    return format_diagnosis(dg, top=top)  # type: ignore[arg-type]
