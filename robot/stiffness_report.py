"""The tool compliance and stiffness of a model with values along postures,
with the stiffness indices: the report of ``stiffkit stiffness``.

For each posture: C = sum_i J_i C_i J_i^T at the tool-frame origin in base
axes (Klimchik et al. eq. 2), K = C^-1 where C is positive definite (else
its rank), one core call for all postures; and every registered index
(``INDICES``; kappa_t, kappa_r of Taghvaeipour et al. 2010 eqs. 31-39, one
more core call), NaN where K does not exist, with the reason per posture.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..io.files import atomic_open, write_json
from .indices import stiffness_indices_where
from .model import Model
from .plots import stiffness_png

__all__ = ["INDICES", "index_status", "compute_indices", "StiffnessReport", "stiffness_report"]


def _kappa(C: np.ndarray, K: np.ndarray, ok: np.ndarray, lscale: float) -> dict:
    """kappa_t, kappa_r (N) of Taghvaeipour et al. 2010 eqs. 31-39 (core/sk_indices.f90):
    one core call for the postures where K exists, NaN elsewhere."""
    idx = stiffness_indices_where(K, ok, lscale)
    return {"kappa_t": idx.kappa_t, "kappa_r": idx.kappa_r}


#: stiffness indices per posture: provider name -> (function(C (N,6,6), K (N,6,6),
#: ok (N,), lscale) -> {index name: (N,) array, NaN where undefined}, unit).
#: Every index a provider returns is printed and written to JSON/NPZ and plotted.
INDICES: dict = {"kappa": (_kappa, "N")}


def index_status(ok: Iterable[bool], rank: Iterable[int]) -> list[str]:
    """Per posture: "ok", or why the indices do not exist."""
    return ["ok" if o else f"undefined: no stiffness matrix (compliance rank {int(r)} < 6)" for o, r in zip(ok, rank)]


def compute_indices(C: np.ndarray, K: np.ndarray, ok: np.ndarray, lscale: float) -> tuple[dict, dict]:
    """({index name: (N,)}, {index name: unit}) of every registered provider."""
    values, units = {}, {}
    for fn, unit in INDICES.values():
        for name, v in fn(C, K, ok, lscale).items():
            values[name] = np.asarray(v, dtype=float)
            units[name] = unit
    return values, units


def _null(v: float) -> float | None:
    return None if not np.isfinite(v) else float(v)


def _matrix(a: np.ndarray) -> str:
    """A 6x6 matrix as rows of aligned scientific numbers, indented."""
    return "\n".join("  " + " ".join(f"{v: .4e}" for v in row) for row in a)


@dataclass
class StiffnessReport:
    """C, K, rank and indices of a model at N postures Q (N, dof)."""

    Q: np.ndarray
    C: np.ndarray  # (N, 6, 6)
    K: np.ndarray  # (N, 6, 6), zeros where ok is False
    rank: np.ndarray  # (N,)
    ok: np.ndarray  # (N,) bool: K exists
    indices: dict  # {name: (N,)}
    units: dict  # {name: unit}
    lscale: float
    lscale_given: bool = False  # False: the chain's length

    @property
    def status(self) -> list[str]:
        return index_status(self.ok, self.rank)

    def text(self, shown: int = 3) -> str:
        """The first ``shown`` postures in full, then which postures have no
        stiffness and the length scale of the indices."""
        Q, C, K, ok, rank = self.Q, self.C, self.K, self.ok, self.rank
        status, units = self.status, self.units
        lines = []
        for i in range(min(len(Q), shown)):
            lines.append(f"posture {i + 1}: q = {np.array2string(Q[i], precision=4, max_line_width=150)}")
            lines.append("  compliance (rows dt, dphi; columns f, m; SI):")
            lines.append(_matrix(C[i]))
            if ok[i]:
                lines.append("  stiffness:")
                lines.append(_matrix(K[i]))
                lines.append("  indices: " + ", ".join(f"{n} = {v[i]:.6g} {units[n]}" for n, v in self.indices.items()))
            else:
                lines.append(
                    f"  stiffness: does not exist (compliance rank {rank[i]} < 6: the model has no "
                    f"spring for some tool directions, or the posture is singular)"
                )
                lines.append(f"  indices: {', '.join(self.indices)} = NaN ({status[i]})")
        if len(Q) > shown:
            lines.append(f"... {len(Q)} postures in all; {int(ok.sum())} with a stiffness matrix")
        if not ok.all():
            bad = np.flatnonzero(~ok) + 1
            lines.append(
                f"indices undefined (NaN, no stiffness matrix) at {bad.size} posture(s): "
                f"{', '.join(map(str, bad[:20]))}{' ...' if bad.size > 20 else ''}"
            )
        lines.append(
            f"indices: Taghvaeipour et al. 2010 eqs. 31-39 with the length scale {self.lscale:.6g} m "
            f"({'--lscale' if self.lscale_given else 'the chain length'}); N whatever the unit"
        )
        return "\n".join(lines)

    def to_json(self) -> dict:
        status = self.status
        return {
            "postures": [
                {
                    "q": self.Q[i].tolist(),
                    "compliance": self.C[i].tolist(),
                    "stiffness": self.K[i].tolist() if self.ok[i] else None,
                    "rank": int(self.rank[i]),
                    "indices": {n: _null(v[i]) for n, v in self.indices.items()},
                    "indices_status": status[i],
                }
                for i in range(len(self.Q))
            ],
            "frame": "tool-frame origin, base axes; twist (t, phi), wrench (f, m)",
            "indices_lscale_m": self.lscale,
            "indices_units": self.units,
            "indices_note": "null where the stiffness does not exist (see indices_status)",
        }

    def write_json(self, path: Path | str) -> Path:
        return write_json(path, self.to_json(), allow_nan=False)

    def write_npz(self, path: Path | str) -> Path:
        """Arrays q, compliance, stiffness, rank, ok, lscale, indices_ok and
        one per index; ``.npz`` is appended to a name without it (as numpy does)."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        with atomic_open(path, "wb") as fh:
            np.savez(
                fh,
                q=self.Q,
                compliance=self.C,
                stiffness=self.K,
                rank=self.rank,
                ok=self.ok,
                lscale=self.lscale,
                indices_ok=self.ok.copy(),
                **self.indices,
            )
        return path

    def write_png(self, path: Path | str) -> Path:
        return stiffness_png(path, self.Q, self.C, self.ok, self.indices, self.units, self.lscale)


def stiffness_report(model: Model, Q: npt.ArrayLike, lscale: float | None = None) -> StiffnessReport:
    """C, K, rank (one core call) and the indices (one more) at postures Q
    (N, dof); ``lscale`` (m) defaults to the chain's characteristic length."""
    if lscale is not None and not (np.isfinite(lscale) and lscale > 0):
        raise InputError(f"--lscale must be a positive length in m, got {lscale}")
    scale = model.chain.characteristic_length if lscale is None else float(lscale)
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    C, K, rank, ok = model.stiffness(Q)
    indices, units = compute_indices(C, K, ok, scale)
    return StiffnessReport(
        Q=Q, C=C, K=K, rank=rank, ok=ok, indices=indices, units=units, lscale=scale, lscale_given=lscale is not None
    )
