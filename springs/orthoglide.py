"""Orthoglide (3-PRPaR translational parallel robot) as a tree of generalised springs.

Geometry and link data: Pashkevich, Chablat, Wenger 2009 s5 (L = 310 mm,
d = 100 mm, r = 31 mm, 200 mm cubic workspace; Table 7 link compliances;
Table 8 manipulator compliance at the isotropic point). Python builds the
poses of every spring and joint at every posture (vectorised); the core
evaluates all postures in one call.

Leg i (i = x, y, z), actuated along e_i. Axes of the leg: a_i = e_{i+1}
is the axle (and the axis of the two R joints), the parallelogram hinges
are normal to the plane of a_i and the bar. At the tool point P:
  C_i = P - r e_i                    distal R joint (centre of the distal axle)
  B_i = rho_i e_i, |C_i - B_i| = L   proximal R joint on the actuator line
  bars from B_i +- (d/2) a_i to C_i +- (d/2) a_i
so P = 0 is the isotropic point (the three bars along e_x, e_y, e_z,
mutually orthogonal) and the workspace cube is taken centred on it.
The serial chain of a leg, as springs (s) and joints (j):
  [actuator j, elastic or locked] - foot s (at B_i) - R j (a_i at B_i) -
  parallel of two branches { half-axle s - hinge j - bar s - hinge j - half-axle s } -
  R j (a_i at C_i) - platform.
This is the paper's leg with its passive joints; its assumptions beyond the
paper (which gives no frames for Table 7): the foot compliance acts at
B_i in the constant axes (e_i, a_i x e_i, a_i) (``foot_axes``: foot x along
the actuator, foot z along the proximal R joint's axis); bars and half-axles
are cantilevers along their own x (eq. 22, the off-diagonal terms rebuilt
from the diagonal of Table 7, which is consistent with L = 310 mm and
d/2 = 50 mm: k22/k66 = k33/k55 = L^2/3 to 0.3 %), bar z along the hinge
pins, bar y in the parallelogram plane; actuators rigid unless
``actuator_compliance`` is given.

Rotational compliance at the isotropic point (Table 8): why the foot's z is
the R joint's axis. An earlier version put the foot axes as (e_i, a_i,
e_i x a_i), i.e. foot z along the hinge normal n_i, and got k_rot =
1.03e-7 rad/(N mm) against 2.46e-7 (FEA) while k_tran agreed within 8 %.
What decides k_rot: a couple about e_z is carried by the x leg as a couple
about its hinge normal n_x = -e_z (the parallelogram takes it as push-pull
of its bars over the lever d, very stiff, so the foot's rotation about n_x
is what yields) and by the z leg as a torsion about its bar direction
(the bars bend out of plane: soft, with the Table 7 bars it adds little);
the y leg is free about e_z (its R joints). So k_rot is close to the foot's
rotational compliance about the hinge normal, and which Table 7 diagonal
entry that is depends only on the foot's axes. With rigid bars and axles
the model gives exactly k_tran = foot k11 and k_rot = (1/c_nn + 1/c_uu)^-1
(foot about the hinge normal, about the actuator axis), a test checks it.
  The foot's Table 7 pattern is that of a plate with normal z: the two
in-plane translations equal and stiffer (k11 = k22 = 3.45e-4 mm/N), the
out-of-plane translation 5x softer (k33 = 18.1e-4), the two out-of-plane
rotations equal (k44 = k55 = 2.10e-7) and the in-plane rotation, about the
normal, the stiffest (k66 = 0.91e-7). It is not a beam along z (that would
make k33 its tiny axial term, and torsion k66 can not be below bending k44
for an isotropic prismatic beam). An R joint's shaft passes through the
plate that carries its bearing, i.e. along the plate normal: foot z = a_i.
The actuator force along e_i is in-plane (foot x): the translational
results confirm it independently (foot k11 + bars k11/2 = 3.64 beam, 3.00
FEA, against Majou's 3.68 and FEA 3.02; foot k22 along e_i would give 4.4).
With foot z = n_i, the stiffest foot rotation (k66) sat on the axis that
matters and k_rot came out ~k66 (1.03); with foot z = a_i it sits on the
R joint's axis, where it does not matter, and the foot yields with k55
about n_i. Nothing else changed (no number was adjusted); the axle
handedness (a_i = e_{i+1} or e_{i+2}) gives identical isotropic values.
Results at the isotropic point (k_tran 1e-4 mm/N, k_rot 1e-7 rad/(N mm)):
  links "beam" 3.90, 2.01;  links "fea" 3.26, 2.44;  Table 8 FEA (parabolic)
  3.02, 2.46; with rigid axles, links "fea" 3.00, 2.34 against the paper's
  "6-dof springs with rigid axis" 3.10, 2.31.
The remaining k_tran gap (+8 % with FEA links) is the half-axles' bending
under the bar forces (0.26e-4 mm/N; it vanishes with rigid axles). The
paper's whole-robot FEA (3.02) is below its own rigid-axis model (3.10), so
Table 7's axle compliance applied as two 50 mm cantilevers from the R joint
(what the single-beam numbers imply: k22/k66 = (50 mm)^2/3) overstates the
axles' share; Table 7 does not say how the axle was supported, and its FEA
matrices are diagonals only, so this part is left as it is.

Units: SI inside (m, N, rad); Table 7 is in mm and is converted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from .tree import Joint, Parallel, Series, Spring, TreeResult, evaluate, load_link_compliance, parallel, series

__all__ = [
    "OrthoglideGeometry",
    "TABLE7",
    "TABLE8",
    "link_compliances",
    "leg_tree",
    "foot_axes",
    "orthoglide_tree",
    "compliance",
    "workspace_grid",
    "isotropic_point",
]

# Table 7, diagonal compliances k11..k66 in mm/N and rad/(N mm)
TABLE7 = {
    "beam": {
        "foot": [3.45e-4, 3.45e-4, 18.1e-4, 2.10e-7, 2.10e-7, 0.91e-7],
        "axle": [1.34e-6, 2.65e-5, 2.65e-5, 4.29e-8, 3.18e-8, 3.18e-8],
        "bar": [3.75e-5, 4.38e-2, 1.09e-1, 3.96e-6, 3.40e-6, 1.37e-6],
    },
    "fea": {  # parabolic mesh
        "foot": [2.77e-4, 4.15e-4, 19.4e-4, 2.29e-7, 2.30e-7, 0.84e-7],
        "axle": [6.23e-6, 2.83e-5, 2.59e-5, 2.77e-7, 4.84e-7, 1.20e-7],
        "bar": [4.55e-5, 5.08e-2, 2.33e-1, 2.88e-5, 7.19e-6, 1.50e-6],
    },
}
# Table 8: compliance at the isotropic point, (translational 1e-4 mm/N, rotational 1e-7 rad/(N mm))
TABLE8 = {
    "lump model of Majou et al. with additional passive joint": (3.68, 2.77),
    "lump model of Majou et al. without additional passive joint": (3.68, 1.26),
    "overconstrained lump model with 6-dof springs": (2.78, 1.94),
    "extended overconstrained lump model with 6-dof springs": (2.93, 2.02),
    "FEA (linear mesh)": (3.05, 2.05),
    "lump model with 6-dof springs with rigid axis": (3.10, 2.31),
    "FEA (parabolic mesh)": (3.02, 2.46),
}


@dataclass
class OrthoglideGeometry:
    L: float = 0.310  #: parallelogram (bar) length, m
    d: float = 0.100  #: parallelogram width (axle length), m
    r: float = 0.031  #: distance from C_i to the tool point, m
    cube: float = 0.200  #: workspace cube edge, m


def _table_si(diag: npt.ArrayLike) -> np.ndarray:
    """Table 7 diagonal (mm/N, rad/(N mm)) -> SI (m/N, rad/(N m))."""
    d = np.asarray(diag, dtype=float)
    return np.concatenate([d[:3] * 1e-3, d[3:] * 1e3])


def cantilever_from_diagonal(length: float, diag_si: npt.ArrayLike) -> np.ndarray:
    """Eq. 22 cantilever compliance along x with the diagonal given (SI):
    c26 = L c66 / 2 and c35 = -L c55 / 2 (since c66 = L/EIz, c55 = L/EIy)."""
    c = np.diag(np.asarray(diag_si, dtype=float))
    c[1, 5] = c[5, 1] = length * c[5, 5] / 2.0
    c[2, 4] = c[4, 2] = -length * c[4, 4] / 2.0
    return c


def link_compliances(
    source: str = "beam", geometry: OrthoglideGeometry | None = None, files: dict | None = None
) -> dict:
    """Local 6x6 compliances (SI) of foot, half-axle and bar.

    source "beam": Table 7 single-beam approximations, bar and half-axle as
    full eq. 22 cantilevers; "fea": Table 7 FEA (parabolic mesh) diagonals.
    files: {"foot"|"axle"|"bar": path} of ``stiffkit link`` JSON results
    (key "compliance", SI, link axes) that replace the table values.
    """
    g = geometry or OrthoglideGeometry()
    if source not in TABLE7:
        raise InputError(f"link source must be one of {sorted(TABLE7)}, got {source!r}")
    t = {k: _table_si(v) for k, v in TABLE7[source].items()}
    out = {"foot": np.diag(t["foot"])}
    if source == "beam":
        out["axle"] = cantilever_from_diagonal(g.d / 2, t["axle"])
        out["bar"] = cantilever_from_diagonal(g.L, t["bar"])
    else:
        out["axle"] = np.diag(t["axle"])
        out["bar"] = np.diag(t["bar"])
    for name, path in (files or {}).items():
        if name not in out:
            raise InputError(f"unknown Orthoglide link {name!r}: use foot, axle or bar")
        out[name] = load_link_compliance(path, f"{name} link")
    return out


def isotropic_point() -> np.ndarray:
    return np.zeros(3)


def foot_axes(i: int) -> np.ndarray:
    """Axes (columns) of leg i's foot compliance: x = e_i (actuator), y =
    a_i x e_i (the parallelogram hinge normal at the isotropic point), z =
    a_i (the proximal R joint's axis, normal to the foot plate). Constant:
    the foot rides the carriage without turning. See the module docstring."""
    e = np.eye(3)
    ei, ai = e[i], e[(i + 1) % 3]
    return np.stack([ei, np.cross(ai, ei), ai], axis=-1)


def _frame(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N,3,3) rotation with columns x, y, x cross y (inputs unit, orthogonal)."""
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def leg_tree(i: int, P: np.ndarray, links: dict, g: OrthoglideGeometry, actuator_compliance: float = 0.0) -> Series:
    """Spring tree of leg i at tool points P (N,3)."""
    e = np.eye(3)
    ei, ai = e[i], e[(i + 1) % 3]
    n = P.shape[0]
    C = P - g.r * ei
    perp = C - np.outer(C @ ei, ei)
    h2 = g.L**2 - np.sum(perp**2, axis=1)
    if np.any(h2 <= 0):
        raise InputError(f"leg {'xyz'[i]}: tool point out of reach (|P_perp| >= L)")
    rho = C @ ei - np.sqrt(h2)
    B = np.outer(rho, ei)
    u = (C - B) / g.L  # bar direction
    hinge = _unit(np.cross(np.broadcast_to(ai, (n, 3)), u))  # parallelogram hinge axis
    A = np.broadcast_to(ai, (n, 3))
    foot = Spring(links["foot"], pos=B, rot=foot_axes(i), name=f"foot{i}")
    branches = []
    for s in (+1.0, -1.0):
        Bs, Cs = B + s * g.d / 2 * ai, C + s * g.d / 2 * ai
        ax = np.broadcast_to(s * ai, (n, 3))
        rot_ax = _frame(ax, hinge)
        branches.append(
            series(
                Spring(links["axle"], pos=Bs, rot=rot_ax, name="proximal half-axle"),
                Joint("revolute", hinge, Bs, passive=True, name="hinge"),
                Spring(links["bar"], pos=Cs, rot=_frame(u, _unit(np.cross(hinge, u))), name="bar"),
                Joint("revolute", hinge, Cs, passive=True, name="hinge"),
                Spring(links["axle"], pos=Cs, rot=rot_ax, name="distal half-axle"),
            )
        )
    parts = []
    if actuator_compliance > 0:
        parts.append(Joint("prismatic", ei, B, compliance=actuator_compliance, name="actuator"))
    parts += [
        foot,
        Joint("revolute", A, B, passive=True, name="R proximal"),
        parallel(*branches),
        Joint("revolute", A, C, passive=True, name="R distal"),
    ]
    return series(*parts)


def orthoglide_tree(
    P: npt.ArrayLike,
    links: dict | None = None,
    geometry: OrthoglideGeometry | None = None,
    actuator_compliance: float = 0.0,
) -> Parallel:
    """The whole robot: three legs in parallel at the tool point (N,3)."""
    g = geometry or OrthoglideGeometry()
    links = links or link_compliances("beam", g)
    P = np.atleast_2d(np.asarray(P, dtype=float))
    return parallel(*(leg_tree(i, P, links, g, actuator_compliance) for i in range(3)))


def compliance(
    P: npt.ArrayLike,
    links: dict | None = None,
    geometry: OrthoglideGeometry | None = None,
    actuator_compliance: float = 0.0,
    rcond: float = 1e-9,
) -> TreeResult:
    """Tool compliance/stiffness at tool points P (N,3) (m), one core call."""
    g = geometry or OrthoglideGeometry()
    P = np.atleast_2d(np.asarray(P, dtype=float))
    tree = orthoglide_tree(P, links, g, actuator_compliance)
    return evaluate(tree, tool=P, lscale=g.L, rcond=rcond)


def workspace_grid(n: int = 21, geometry: OrthoglideGeometry | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points of the workspace cube (centred on the isotropic point): (xs, grid (n^3,3))."""
    g = geometry or OrthoglideGeometry()
    xs = np.linspace(-g.cube / 2, g.cube / 2, n)
    X, Y, Z = np.meshgrid(xs, xs, xs, indexing="ij")
    return xs, np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
