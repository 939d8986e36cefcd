"""A model evaluated on a set of measurements: the predicted rows and their
Jacobian with respect to the free parameters.

The core evaluates them in one call (core/sk_deflect.f90: the springs'
observation basis, klimchik eqs. 4-5, 12, the joint laws, the compensator
and point-offset chain rules); this module encodes the model's terms
(robot/model_core.py) and weighs the rows.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..robot.model import SPRING_JOINT, Model, default_tau0
from ..robot.model_core import encode
from .measure import Measurements

if TYPE_CHECKING:
    from ..robot.model import Term

__all__ = ["Problem"]


class Problem:
    """A model (plus optional extra terms) evaluated on a set of measurements.

    ``evaluate(theta)`` returns the predicted (6, n) rows (point deflection,
    tool rotation) and their Jacobian (6, n, npar) with respect to the free
    parameters of ``terms``, one core call.
    """

    def __init__(
        self,
        model: Model,
        meas: Measurements,
        extra_terms: Iterable[Term] = (),
        sigma_position: float | None = None,
        sigma_rotation: float | None = None,
    ) -> None:
        if meas.q.shape[1] != model.chain.dof:
            raise InputError(f"{meas.path}: rows have {meas.q.shape[1]} joint values, the robot has {model.chain.dof}")
        self.model = model
        self.meas = meas
        self.terms = list(model.terms)
        self.extra = list(extra_terms)
        springs = model.springs(self.extra)
        # every actuated joint's spring is available for joint-type candidates
        for k in range(len(model.chain.qidx)):
            if model.chain.qidx[k] > 0 and (SPRING_JOINT, k + 1) not in springs:
                springs.append((SPRING_JOINT, k + 1))
        self.springs = springs
        self.core_rows = (
            np.asfortranarray(meas.q.T),
            np.asfortranarray(meas.w.T),
            np.asfortranarray(meas.p.T),
        )
        sp = sigma_position if sigma_position is not None else model.sigma_position
        sr = sigma_rotation if sigma_rotation is not None else model.sigma_rotation
        self.sigma_declared = sp is not None
        self.sigma_position = sp
        self.rows = 6 if meas.r is not None else 3
        wp = 1.0 / sp if sp else 1.0
        # rotations: declared sigma, else the position sigma per metre
        wr = 1.0 / sr if sr else wp
        self.wrow = np.array([wp] * 3 + [wr] * 3)[: self.rows]
        self.y = meas.d.T if meas.r is None else np.vstack([meas.d.T, meas.r.T])
        self.layout = self._layout(self.terms)
        self._torques = None

    @property
    def torques(self) -> np.ndarray:
        """Torque about every chain joint's axis of each row's wrench (n, nj)."""
        if self._torques is None:
            self._torques = self.model.chain.joint_torques(self.meas.q, self.meas.w)
        return self._torques

    def joint_twists(self) -> np.ndarray:
        """(6, n, nj): the deflection of each row (point displacement, tool
        rotation) per unit rotation of every chain joint about its axis
        (zero for fixed joints); the joint spring's column is this times the
        row's joint torque."""
        ch = self.model.chain
        P = ch.poses(self.meas.q)
        point = P["pt"] + np.einsum("nij,nj->ni", P["rt"], self.meas.p)
        z = np.einsum("nkij,kj->nki", P["rf"], ch.jaxis)  # (n, nj, 3)
        t = np.cross(z, point[:, None, :] - P["pf"])
        return np.concatenate([t, z], axis=2).transpose(2, 0, 1)

    def tau0(self, term: Term) -> float:
        """Smoothing torque of a joint_deadzone term: declared, else chosen
        from these rows (robot.model.default_tau0)."""
        v = term.geometry.get("tau0")
        return float(v) if v is not None else default_tau0(self.torques[:, term.joint])

    @staticmethod
    def _layout(terms: Sequence[Term]) -> dict[int, slice]:
        out, k = {}, 0
        for i, t in enumerate(terms):
            if t.free:
                out[i] = slice(k, k + len(t.names))
                k += len(t.names)
        return out

    @property
    def names(self) -> list[str]:
        return [n for t in self.terms if t.free for n in t.names]

    @property
    def npar(self) -> int:
        return sum(len(t.names) for t in self.terms if t.free)

    def encoded(self, terms: Sequence[Term] | None = None, layout: dict[int, slice] | None = None) -> dict:
        """The core's arrays of ``terms`` (robot/model_core.py), dead zones
        without a declared tau0 taking it from these rows."""
        terms = self.terms if terms is None else terms
        layout = self.layout if layout is None else layout
        return encode(terms, layout, self.springs, self.tau0)

    def evaluate(
        self,
        theta: np.ndarray,
        terms: Sequence[Term] | None = None,
        layout: dict[int, slice] | None = None,
        jac: bool = True,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Predicted rows (6, n) and Jacobian (6, n, npar) at theta (core/sk_deflect.f90)."""
        q, w, p = self.core_rows
        return core.deflection_rows(
            self.model.chain.core_arrays(), self.encoded(terms, layout), np.asarray(theta, float), q, w, p, jac
        )

    def weighted(self, rows6: np.ndarray) -> np.ndarray:
        """Rows (6, n[, k]) -> weighted observation vector/matrix (rows*n[, k])."""
        r = rows6[: self.rows]
        w = self.wrow.reshape((-1,) + (1,) * (r.ndim - 1))
        r = r * w
        return r.reshape((self.rows * r.shape[1],) + r.shape[2:])
