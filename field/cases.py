"""Load cases from CSV files (the input of ``stiffkit field``): the node
positions, one displacement field per case, and the wrench of each case."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_columns

__all__ = ["read_fields", "axis_wrenches", "read_wrenches"]


def read_fields(nodes_path: Path | str, field_paths: Iterable[Path | str]) -> tuple[np.ndarray, np.ndarray]:
    """(nodes (n, 3), displacements (m, n, 3)): NODES.csv with header x,y,z and
    one DISP.csv with header ux,uy,uz per case, same nodes in the same order."""
    nodes = read_columns(nodes_path, ["x", "y", "z"], "node", "position")
    extent = float(np.ptp(nodes, axis=0).max()) if nodes.shape[0] > 1 else 0.0
    disp, names = [], []
    for f in field_paths:
        d = read_columns(f, ["ux", "uy", "uz"], "displacement", "displacement")
        if d.shape != nodes.shape:
            raise InputError(f"{f}: {d.shape[0]} displacement rows for {nodes.shape[0]} nodes in {nodes_path}")
        big = float(np.abs(d).max())
        if extent > 0 and big > 0.1 * extent:
            V.warn(
                f"{f}: displacements up to {big:g} m on a field {extent:g} m across: the fit of a small rigid "
                "motion assumes deflections far below the size of the field (are the files in one unit, SI?)"
            )
        for k, e in enumerate(disp):
            if np.array_equal(d, e):
                same = "the same file" if Path(f).resolve() == Path(names[k]).resolve() else "identical"
                V.warn(
                    f"{f}: load case {len(disp) + 1} has the displacement field of case {k + 1} ({names[k]}; "
                    f"{same}): each case needs its own field, else the compliance's columns repeat and it "
                    "comes out asymmetric and meaningless (a file given twice?)"
                )
                break
        disp.append(d)
        names.append(str(f))
    return nodes, np.array(disp)


def axis_wrenches(loads: npt.ArrayLike, n_cases: int) -> np.ndarray:
    """The paper's six axis-aligned experiments (eq. 3): case j carries only
    component j of ``loads`` (Fx, Fy, Fz, Mx, My, Mz)."""
    if n_cases != 6:
        raise InputError(f"--loads describes six axis-aligned cases, got {n_cases} displacement files")
    return np.diag(np.asarray(loads, dtype=float))


def read_wrenches(path: Path | str, n_cases: int) -> np.ndarray:
    """(m, 6) wrenches, one row per case, from a CSV with header fx,fy,fz,mx,my,mz."""
    w = np.hstack(
        [
            read_columns(path, ["fx", "fy", "fz"], "wrench", "force"),
            read_columns(path, ["mx", "my", "mz"], "wrench", "moment"),
        ]
    )
    if w.shape[0] != n_cases:
        raise InputError(f"{path}: {w.shape[0]} wrenches for {n_cases} load cases")
    return w
