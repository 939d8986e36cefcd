"""A model evaluated on a set of measurements: the predicted rows and their
Jacobian with respect to the free parameters.

The observation basis of every spring comes from the core in one call
(klimchik eqs. 4-5, 12); this module combines it into the columns of the
model's parameters (joint compliances, profiles, gravity compensators,
6-dof springs, point offset) and, for the load-nonlinear joint kinds, the
joint torque of every row.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..robot.model import (
    LOAD_NONLINEAR,
    SPRING_JOINT,
    Model,
    compensator_h,
    default_tau0,
    load_factor,
    profile_basis,
)
from .measure import Measurements

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..robot.model import Term

__all__ = ["Problem"]


class Problem:
    """A model (plus optional extra terms) evaluated on a set of measurements.

    ``evaluate(theta)`` returns the predicted (6, n) rows (point deflection,
    tool rotation) and their Jacobian (6, n, npar) with respect to the free
    parameters of ``terms``. The spring basis is computed by the core once
    per point offset.
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
        self.offset = {}
        col = 0
        for sp in springs:
            self.offset[sp] = col
            col += 1 if sp[0] == SPRING_JOINT else 21
        self.nb = col
        self._cache = {}
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

    def load_column(self, term: Term, B: np.ndarray | None = None) -> np.ndarray:
        """(6, n) rows of a load-nonlinear joint term per unit of its value."""
        B = self.basis()[0] if B is None else B
        g = B[:, :, self.offset[(SPRING_JOINT, term.joint + 1)]]
        tau0 = self.tau0(term) if term.kind == "joint_deadzone" else None
        return g * load_factor(term.kind, self.torques[:, term.joint], tau0)

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

    def basis(self, r: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(B (6, n, nb), Rt (n, 3, 3)) at point offset r (tool frame)."""
        if r is not None and not np.any(r):
            r = None
        key = None if r is None else tuple(np.asarray(r, float))
        if key in self._cache:
            return self._cache[key]
        ch = self.model.chain
        p = self.meas.p if r is None else self.meas.p + np.asarray(r, float)
        stype = np.array([s[0] for s in self.springs], np.int32)
        sidx = np.array([s[1] for s in self.springs], np.int32)
        B, Rt = core.spring_basis(
            self.nb,
            ch.core_arrays(),
            stype=stype,
            sidx=sidx,
            q=np.asfortranarray(self.meas.q.T),
            w=np.asfortranarray(self.meas.w.T),
            p=np.asfortranarray(p.T),
        )
        out = (B, Rt)
        if len(self._cache) > 4:
            self._cache.clear()
        self._cache[key] = out
        return out

    def offset_value(
        self, theta: np.ndarray, terms: Sequence[Term] | None = None, layout: dict[int, slice] | None = None
    ) -> np.ndarray | None:
        terms = self.terms if terms is None else terms
        layout = self.layout if layout is None else layout
        for i, t in enumerate(terms):
            if t.kind == "point_offset":
                return theta[layout[i]] if t.free else t.value
        return None

    def evaluate(
        self,
        theta: np.ndarray,
        terms: Sequence[Term] | None = None,
        layout: dict[int, slice] | None = None,
        jac: bool = True,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Predicted rows (6, n) and Jacobian (6, n, npar) at theta."""
        terms = self.terms if terms is None else terms
        layout = self.layout if layout is None else layout
        npar = sum(len(t.names) for t in terms if t.free)
        B, Rt = self.basis(self.offset_value(theta, terms, layout))
        n = self.meas.n
        q = self.meas.q
        pred = np.zeros((6, n))
        J = np.zeros((6, n, npar)) if jac else None
        cb, dl, comp = {}, {}, {}
        for i, t in enumerate(terms):
            val = theta[layout[i]] if t.free else t.value
            if t.kind == "six":
                off = self.offset[t.spring]
                cols = B[:, :, [off + e for e in t.elements]]
                pred += cols @ val
                if t.free and jac:
                    J[:, :, layout[i]] = cols
            elif t.kind in ("joint", "joint_profile"):
                fn = np.ones((n, 1)) if t.kind == "joint" else profile_basis(q[:, t.qcol])
                cb[t.joint] = cb.get(t.joint, 0.0) + fn @ val
                if t.free:
                    dl.setdefault(t.joint, []).append((layout[i], fn))
            elif t.kind == "gravity_compensator":
                comp[t.joint] = (t, val, layout.get(i))
            elif t.kind in LOAD_NONLINEAR:
                # linear in its value, nonlinear in the joint torque; added to
                # the joint's deflection after any compensator
                col = self.load_column(t, B)
                pred += col * val[0]
                if t.free and jac:
                    J[:, :, layout[i]] = col[:, :, None]
        for j, c in cb.items():
            g = B[:, :, self.offset[(SPRING_JOINT, j + 1)]]
            if j in comp:
                t, ks, sl = comp[j]
                h = compensator_h(q[:, t.qcol], t.geometry)
                den = 1.0 + c * ks[0] * h
                ceff = c / den
                dc = 1.0 / den**2
                dk = -c * c * h / den**2
                if jac and sl is not None:
                    J[:, :, sl] = (g * dk)[:, :, None]
            else:
                ceff, dc = c, np.ones(n)
            pred += g * ceff
            if jac:
                for sl, fn in dl.get(j, []):
                    J[:, :, sl] = g[:, :, None] * (dc[:, None] * fn)[None]
        if jac:
            for i, t in enumerate(terms):
                if t.kind == "point_offset" and t.free:
                    J[0:3, :, layout[i]] = self.offset_columns(pred, Rt)
        return pred, J

    @staticmethod
    def offset_columns(pred: np.ndarray, Rt: np.ndarray) -> np.ndarray:
        """d(point deflection)/dr (3, n, 3) = [dphi]x R_tool at the prediction
        (the point deflection is dt + dphi x R_tool (p + r))."""
        dphi = pred[3:6].T  # (n, 3)
        out = np.empty((3, dphi.shape[0], 3))
        for i in range(3):
            out[:, :, i] = np.cross(dphi, Rt[:, :, i]).T
        return out

    def weighted(self, rows6: np.ndarray) -> np.ndarray:
        """Rows (6, n[, k]) -> weighted observation vector/matrix (rows*n[, k])."""
        r = rows6[: self.rows]
        w = self.wrow.reshape((-1,) + (1,) * (r.ndim - 1))
        r = r * w
        return r.reshape((self.rows * r.shape[1],) + r.shape[2:])
