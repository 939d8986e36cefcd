"""The plan a diagnosis suggests on a tie: the ``stiffkit plan
--discriminate`` command that picks the postures (and loads) telling tied
candidates apart (calib/plan_discriminate.py, plan_discriminate_defl.py),
for both data kinds' diagnoses and their reports."""

from __future__ import annotations

import shlex

__all__ = ["PLAN_SELECT", "plan_command"]

#: the postures suggested to tell tied candidates apart: as many again as measured, within these bounds
PLAN_SELECT = (5, 30)


def plan_command(model_path: object, meas_path: object, n_postures: int, tied: object = None) -> tuple[str, int]:
    """The command that plans the postures telling tied candidates apart
    (``stiffkit plan --discriminate``, calib/plan_discriminate.py) and the
    K it suggests: as many postures again as measured, within PLAN_SELECT.
    ``tied``: the labels of the tie (kind:target...), named after
    --discriminate (without them the command takes the diagnosis's first tie)."""
    k = min(max(int(n_postures), PLAN_SELECT[0]), PLAN_SELECT[1])
    model = shlex.quote(str(model_path)) if model_path else "MODEL.toml"
    meas = shlex.quote(str(meas_path)) if meas_path else "MEAS.csv"
    which = f" {shlex.quote(','.join(map(str, tied)))}" if tied else ""
    return f"stiffkit plan {model} --discriminate{which} --measured {meas} --select {k}", k
