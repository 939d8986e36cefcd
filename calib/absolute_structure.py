"""The residual's structure on absolute data, when no catalogued effect is
proposed (``calib.absolute_diagnose``): is what the model leaves a function
of the posture, or of the order of measurement (drift), rather than noise?
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core_calib
from ..errors import StiffkitError
from ..robot.tree_model import TreeModel
from .absolute_data import AbsoluteData
from .absolute_fit import AbsoluteFit

if TYPE_CHECKING:
    from .absolute_diagnose_report import AbsoluteDiagnosis

__all__ = ["residual_structure", "structure_verdict", "STRUCTURE_ALPHA", "STRUCTURE_PERMUTATIONS", "PATH_GAP"]

#: the residual's structure (when nothing is proposed): two neighbour-correlation permutation
#: tests (neighbouring postures, configurations measured one after the other), each at half
#: this level
STRUCTURE_ALPHA = 0.01
STRUCTURE_PERMUTATIONS = 999
#: consecutive configurations closer in posture than this many times the nearest other posture:
#: the order test cannot tell drift from a posture effect
PATH_GAP = 1.5


def residual_structure(data: AbsoluteData, residual: np.ndarray, w: np.ndarray, model: TreeModel) -> dict:
    """Is what the model leaves a function of the posture, or of the order
    of measurement (drift), rather than noise? Two permutation tests of the
    neighbour correlation (core sk_neighbours neighbour_correlation): each
    point's error against that of the same marker in the nearest other
    posture (distance over the joints that move that marker), and in the
    configuration measured just before or after it (the file's order)."""
    tree = model.tree
    x = np.zeros((data.n, len(data.joints)))
    for fi, frame in enumerate(data.frames):
        moving = {tree.leader(j.name)[0] for j in tree.path(frame) if j.moving}
        mask = np.array([j in moving for j in data.joints], float)
        rows = data.frame == fi
        x[rows] = data.Q[data.posture[rows]] * mask
    out: dict = {"permutations": STRUCTURE_PERMUTATIONS, "alpha": STRUCTURE_ALPHA}
    gap = {}
    for key, coords in (("posture", x), ("order", data.posture[:, None].astype(float))):
        try:
            rho, pval, nn = core_calib.neighbour_correlation(
                coords, residual, w, data.posture, data.frame, STRUCTURE_PERMUTATIONS
            )
        except StiffkitError:  # too few points with a neighbour: no test
            continue
        out[key] = {"neighbour_correlation": rho, "p_value": pval}
        has = nn >= 0
        # how far apart in posture the neighbours of this test are (rad, over the marker's joints)
        gap[key] = float(np.median(np.linalg.norm(x[has] - x[nn[has]], axis=1))) if has.any() else float("nan")
    if "order" in out and "posture" in out:
        # measured along a path, consecutive configurations are near in posture too: the
        # order test then also sees effects of the posture
        ratio = gap["order"] / gap["posture"] if gap["posture"] > 0 else None
        out["order"]["posture_gap_ratio"] = ratio if ratio is not None and math.isfinite(ratio) else None
    return out


def structure_verdict(
    dg: AbsoluteDiagnosis,
    data: AbsoluteData,
    fit: AbsoluteFit,
    w: np.ndarray,
    checked: bool = True,
    decide: bool = True,
) -> None:
    """No candidate proposed: say whether the residual is still structured
    and what the structure suggests; when it ``decide``s (no declared
    sigma: the verdict) a structured residual is inadequate and, when the
    candidates were ``checked`` (scored and held out), nothing in the
    catalogue fits."""
    st = residual_structure(data, fit.residual, w, fit.model)
    dg.residual_structure = st
    found = {
        k: v
        for k, v in st.items()
        if isinstance(v, dict) and v["p_value"] < STRUCTURE_ALPHA / 2 and v["neighbour_correlation"] > 0
    }
    if not found:
        return
    if decide:
        dg.nothing_fits = checked
        dg.verdict = "inadequate"
    checked = checked and dg.nothing_fits
    rms = fit.rms_position * 1e3
    if "posture" in found:
        v = found["posture"]
        dg.reasons.append(
            ("nothing in the catalogue fits, yet " if checked else "")
            + f"the residual ({rms:.3g} mm RMS) is not noise: the errors of "
            f"neighbouring postures are alike (correlation {v['neighbour_correlation']:.2f}, p = {v['p_value']:.2g} "
            f"by {st['permutations']} permutations). An effect that varies with the posture is missing that no "
            "catalogued kind describes (e.g. a transmission error cyclic in a joint angle, a deformation of "
            "another law); its shape against each joint's angle and gravity torque: stiffkit fit --plots"
        )
    if "order" in found:
        v = found["order"]
        text = (
            f"the errors of configurations measured one after the other are alike (correlation "
            f"{v['neighbour_correlation']:.2f}, p = {v['p_value']:.2g}): drift during the measurement "
            "(temperature, the tracker's own drift)? Check against reference points measured at the start "
            "and the end; the residual against the row order: stiffkit fit --plots"
        )
        if v.get("posture_gap_ratio") is not None and v["posture_gap_ratio"] < PATH_GAP:
            text += (
                "; but consecutive configurations are also near in posture here (measured along a path): "
                "drift and an effect of the posture cannot be told apart by these data (measure in a "
                "shuffled order, or repeat a few postures at the start and the end)"
            )
        dg.reasons.append(text)
