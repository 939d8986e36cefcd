"""McGill Schoenflies Motion Generator (R-Pi-Pi-R limbs) as generalised springs.

Taghvaeipour, Angeles, Lessard 2010 s4-5: each Pi-joint is a parallel array
of two flexible links, each behind a passive revolute joint (eq. 23); a limb
is the serial array of its proximal and distal Pi-joints (eqs. 22, 25); the
wrist bracket is joined to the moving platform (MP) by a passive revolute
joint of vertical axis, eliminated by eqs. 26-29; the two limbs add up at
the MP (eq. 30). Here the same model is a spring tree
    parallel( series(Pi_P, Pi_D, R_wrist) for each limb ),
    Pi = parallel( series(R(first end), beam spring) for its two links ),
evaluated in batch along the smoothed test trajectory of s5.1 (25 mm up,
300 mm across while the MP turns 180 deg, 25 mm down); the stiffness indices
kappa_t, kappa_r (eqs. 31-39) are then computed along it (Fig. 10).

The report gives neither the dimensions of the SMG nor its link
stiffnesses, so the geometry and the beam sections below are illustrative
(a SCARA-like limb: actuated base joint of vertical axis, both Pi-joints in
the vertical plane of the limb, bars of 350 mm). The numbers therefore show
the computation of Fig. 10, not its values. Link compliances may come from
``stiffkit link`` JSON files instead of the beam approximations.
``pi_joints="both"`` puts a passive joint at both ends of each distal Pi
link (a true parallelogram, whose circular translation is then free); the
proximal Pi-joints stay as in the report, as if their drive locked them
(with both Pi-joints free and only the base joints locked the MP would have
two free motions, which the model then reports).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..field import cantilever_compliance, section_properties
from ..robot.indices import Indices, stiffness_indices
from .tree import Joint, Parallel, Spring, TreeResult, evaluate, load_link_compliance, parallel, series

__all__ = ["SMGGeometry", "smg_links", "trajectory", "limb_points", "smg_tree", "stiffness", "indices_along_trajectory"]


@dataclass
class SMGGeometry:
    base_x: float = 0.20  #: limb base joints at (-base_x, 0, 0) and (+base_x, 0, 0), m
    l1: float = 0.35  #: proximal Pi bar length, m
    l2: float = 0.35  #: distal Pi bar length, m
    h1: float = 0.06  #: proximal Pi width (distance between its bars), m
    h2: float = 0.04  #: distal Pi width, m
    a: float = 0.04  #: wrist joints at P +- R_z(theta) (a, 0, 0), m
    start: tuple = (-0.15, 0.45, -0.25)  #: trajectory start (MP point), m


def smg_links(files: dict | None = None) -> dict:
    """Cantilever compliances (SI, link axes, eq. 22) of the Pi links.

    proximal: CFRP-like tube D 30 / d 26 mm, E = 60 GPa, nu = 0.3;
    distal: aluminium rod D 10 mm, E = 70 GPa, nu = 0.33 (illustrative).
    files: {"proximal"|"distal": path of a ``stiffkit link`` JSON}.
    """
    g = SMGGeometry()
    out = {
        "proximal": cantilever_compliance(g.l1, 60e9, 0.3, section_properties("tube", [0.030, 0.026], 0.3)),
        "distal": cantilever_compliance(g.l2, 70e9, 0.33, section_properties("circle", [0.010], 0.33)),
    }
    for name, path in (files or {}).items():
        if name not in out:
            raise InputError(f"unknown SMG link {name!r}: use proximal or distal")
        out[name] = load_link_compliance(path, f"{name} link")
    return out


def _smooth(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10 - 15 * x + 6 * x * x)


def trajectory(n: int = 401, geometry: SMGGeometry | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smoothed test trajectory: (tau (n,), P (n,3) m, theta (n,) rad).

    25 mm up, 300 mm along x, 25 mm down, the MP turning 180 deg on the
    horizontal stretch; the segments overlap in time, which rounds the
    corners (quintic time laws).
    """
    g = geometry or SMGGeometry()
    tau = np.linspace(0.0, 1.0, n)
    x = g.start[0] + 0.300 * _smooth((tau - 0.15) / 0.70)
    z = g.start[2] + 0.025 * (_smooth(tau / 0.30) - _smooth((tau - 0.70) / 0.30))
    P = np.stack([x, np.full(n, g.start[1]), z], axis=1)
    theta = np.pi * _smooth((tau - 0.15) / 0.70)
    return tau, P, theta


def limb_points(
    J: int, P: np.ndarray, theta: np.ndarray, g: SMGGeometry
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Shoulder S, elbow E, wrist W (N,3) and the limb's horizontal direction h."""
    sgn = -1.0 if J == 0 else 1.0
    n = P.shape[0]
    S = np.tile([sgn * g.base_x, 0.0, 0.0], (n, 1))
    W = P + g.a * sgn * np.stack([np.cos(theta), np.sin(theta), np.zeros(n)], axis=1)
    dv = W - S
    rho = np.hypot(dv[:, 0], dv[:, 1])
    D = np.hypot(rho, dv[:, 2])
    if np.any(D >= g.l1 + g.l2) or np.any(D <= abs(g.l1 - g.l2)) or np.any(rho == 0):
        raise InputError(f"limb {'I' if J == 0 else 'II'}: MP point out of reach")
    h = np.stack([dv[:, 0] / rho, dv[:, 1] / rho, np.zeros(n)], axis=1)
    beta1 = np.arctan2(dv[:, 2], rho) + np.arccos((g.l1**2 + D**2 - g.l2**2) / (2 * g.l1 * D))
    E = S + g.l1 * (np.cos(beta1)[:, None] * h + np.sin(beta1)[:, None] * np.array([0, 0, 1.0]))
    return S, E, W, h


def _pi_joint(
    A: np.ndarray, Bp: np.ndarray, h: np.ndarray, width: float, c_link: np.ndarray, both_ends: bool
) -> Parallel:
    """Pi-joint between points A (first end) and Bp: two links at +-width/2 (vertical)."""
    z = np.array([0.0, 0.0, 1.0])
    n = np.cross(h, z)  # hinge axis, normal to the limb plane
    links = []
    for s in (+0.5, -0.5):
        a, b = A + s * width * z, Bp + s * width * z
        u = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
        rot = np.stack([u, np.cross(n, u), n], axis=-1)
        parts = [Joint("revolute", n, a, passive=True, name="Pi hinge"), Spring(c_link, pos=b, rot=rot, name="Pi link")]
        if both_ends:
            parts.append(Joint("revolute", n, b, passive=True, name="Pi hinge"))
        links.append(series(*parts))
    return parallel(*links)


def smg_tree(
    P: npt.ArrayLike,
    theta: npt.ArrayLike,
    links: dict | None = None,
    geometry: SMGGeometry | None = None,
    pi_joints: str = "paper",
) -> Parallel:
    """Spring tree of the SMG at MP points P (N,3) and MP angles theta (N,)."""
    if pi_joints not in ("paper", "both"):
        raise InputError("pi_joints must be 'paper' (one passive joint per link, eq. 23) or 'both'")
    g = geometry or SMGGeometry()
    links = links or smg_links()
    P = np.atleast_2d(np.asarray(P, dtype=float))
    theta = np.broadcast_to(np.asarray(theta, dtype=float), (P.shape[0],))
    limbs = []
    for J in (0, 1):
        S, E, W, h = limb_points(J, P, theta, g)
        both = pi_joints == "both"
        limbs.append(
            series(
                _pi_joint(S, E, h, g.h1, links["proximal"], False),
                _pi_joint(E, W, h, g.h2, links["distal"], both),
                Joint("revolute", [0, 0, 1.0], W, passive=True, name="wrist"),
            )
        )
    return parallel(*limbs)


def stiffness(
    P: npt.ArrayLike,
    theta: npt.ArrayLike,
    links: dict | None = None,
    geometry: SMGGeometry | None = None,
    pi_joints: str = "paper",
    rcond: float = 1e-9,
) -> TreeResult:
    """MP stiffness at N postures, world axes, at the MP point (one core call)."""
    g = geometry or SMGGeometry()
    P = np.atleast_2d(np.asarray(P, dtype=float))
    return evaluate(smg_tree(P, theta, links, g, pi_joints), tool=P, lscale=g.l1, rcond=rcond)


def indices_along_trajectory(
    n: int = 401,
    links: dict | None = None,
    geometry: SMGGeometry | None = None,
    pi_joints: str = "paper",
    lscale: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, TreeResult, Indices]:
    """(tau, P, theta, TreeResult, Indices) along the smoothed test trajectory."""
    g = geometry or SMGGeometry()
    tau, P, theta = trajectory(n, g)
    res = stiffness(P, theta, links, g, pi_joints)
    idx: Indices = stiffness_indices(res.stiffness, g.l1 if lscale is None else lscale)
    return tau, P, theta, res, idx
