"""The collision skeleton of a robot model for ``stiffkit plan``'s candidate
postures: link frames from the model's own forward kinematics (the tree
core's ``poses`` for a TreeModel, the chain core's for a serial Model),
the capsules around the links and which pairs of them are tested.

Capsules. A link whose URDF has primitive ``<collision>`` shapes carries
their bounding capsules (robot/capsules.py); every other link carries one
capsule per child joint, along the segment from its origin to the child's
origin (the kinematic skeleton), of the link's [plan] radius. Segments of
zero length (coincident joint origins) carry none.

Bodies and pairs. Links joined by fixed joints form one rigid body. Two
capsules are tested against each other only when their bodies differ, are
not joined by one joint (adjacent), and are not joined through bodies so
short that they touch in every posture: the length of the skeleton path
between them (the sum, over the bodies between, of the distance between
the joint where the path enters that body and the one where it leaves) is
at least the sum of the two bodies' largest radii plus the margin (a wrist
of three joints at one point, a shoulder of two close joints). The base
body (the root's) is not tested against the floor: it stands on it.

Markers (tracker data): a marker's own body (its link and the links fixed
to it) does not occlude it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core.tree import poses as tree_poses
from ..errors import InputError
from .plan_settings import PlanSettings

__all__ = ["Skeleton", "skeleton"]

#: postures per call of the forward kinematics (memory: postures x frames x 12 doubles)
CHUNK_DOUBLES = 4_000_000
#: a skeleton segment shorter than this (m) is a point: no capsule
MIN_SEGMENT = 1e-9


@dataclass
class Skeleton:
    """A model's collision description (module docstring).

    links: link names; body (nl,) rigid body of each link; capsules: for
    each, the owning link, either a skeleton segment (link indices ``i0``,
    ``i1``: from link i0's origin to link i1's) or a local capsule (``local``
    index into ``la``, ``lb``: endpoints in the owner's frame); ``radius``
    (nc,); ``pairs`` (npair, 2) the capsule pairs tested; ``floor`` (nc,)
    bool the capsules tested against the floor; markers: link index and
    point (link frame) of each, ``own`` (nm, nc) bool the capsules of the
    marker's own body."""

    model: object
    links: list[str]
    body: np.ndarray
    owner: np.ndarray
    seg: np.ndarray  # (nc, 2) link indices of a skeleton segment, -1 for a local capsule
    local: np.ndarray  # (nc,) index into la/lb, -1 for a skeleton segment
    la: np.ndarray
    lb: np.ndarray
    radius: np.ndarray
    pairs: np.ndarray
    floor: np.ndarray
    marker_link: np.ndarray
    marker_point: np.ndarray
    own: np.ndarray
    labels: list[str]

    def frames(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Link frames (R (N, nl, 3, 3), p (N, nl, 3)), base frame, at postures Q (N, nq)."""
        return _frames(self.model, self.links, Q)

    def world(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Capsule endpoints A, B (N, nc, 3) and marker points (N, nm, 3) at postures Q."""
        R, p = self.frames(Q)
        n, nc = Q.shape[0], self.radius.size
        A, B = np.empty((n, nc, 3)), np.empty((n, nc, 3))
        s = self.seg[:, 0] >= 0
        A[:, s], B[:, s] = p[:, self.seg[s, 0]], p[:, self.seg[s, 1]]
        loc = ~s
        if loc.any():
            own = self.owner[loc]
            A[:, loc] = np.einsum("nkij,kj->nki", R[:, own], self.la[self.local[loc]]) + p[:, own]
            B[:, loc] = np.einsum("nkij,kj->nki", R[:, own], self.lb[self.local[loc]]) + p[:, own]
        ml = self.marker_link
        M = np.einsum("nkij,kj->nki", R[:, ml], self.marker_point) + p[:, ml]
        return A, B, M


def _chunks(n: int, per: int) -> list[slice]:
    step = max(1, CHUNK_DOUBLES // max(per, 1))
    return [slice(k, min(n, k + step)) for k in range(0, n, step)]


def _frames(model: object, links: list[str], Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n, nl = Q.shape[0], len(links)
    R, p = np.empty((n, nl, 3, 3)), np.empty((n, nl, 3))
    if hasattr(model, "tree"):  # TreeModel: the tree core's frames after motion, rigid (no deflection)
        vj = np.array([model.vj_of_link[ln] for ln in links])
        at = vj > 0
        theta, packed = model.theta0, model.packed
        for sl in _chunks(n, 12 * len(model.arrays["vparent"])):
            P = tree_poses(packed, theta, Q[sl], None, 0, 1e-9)
            R[sl][:, at], p[sl][:, at] = P["ra"][:, vj[at] - 1], P["pa"][:, vj[at] - 1]
        R[:, ~at], p[:, ~at] = np.eye(3), 0.0
        return R, p
    chain = model.chain  # serial Model: the chain core's joint frames F_k (before their rotation)
    R[:, 0], p[:, 0] = np.eye(3), 0.0
    nj = len(chain.joint_names)
    for sl in _chunks(n, 12 * (nj + 1)):
        P = chain.poses(Q[sl])
        p[sl, 1:] = P["pf"]  # the child's origin is its joint's (a rotation leaves it in place)
        # a child's axes: the next joint's frame times its origin rotation's inverse; the last, the tool's
        R[sl, 1:nj] = np.einsum("nkij,klj->nkil", P["rf"][:, 1:], chain.jrot[1:])
        R[sl, nj] = P["rt"] @ chain.trot.T
    return R, p


def _kinematic(model: object) -> object:
    """The model as its rigid kinematics sees it: a TreeModel whose dead-zone
    widths are still unset (they come from the data's torques) gets a
    placeholder of 1 N m on a copy; rigid poses do not use it."""
    if not hasattr(model, "tree") or not np.any(np.asarray(model.arrays["kw0"]) <= 0):
        return model
    kin = model.copy()
    kw0 = np.asarray(kin.arrays["kw0"], float)
    kin.arrays["kw0"] = np.where(kw0 > 0, kw0, 1.0)
    return kin


def _joints(model: object) -> list[tuple[str, str, str, str, float]]:
    """(name, type, parent, child, origin length) of every joint of the model's links."""
    if hasattr(model, "tree"):
        return [(j.name, j.type, j.parent, j.child, float(np.linalg.norm(j.origin[:3, 3]))) for j in model.tree.joints]
    c = model.chain
    return [
        (n, t, pa, ch, float(np.linalg.norm(x)))
        for n, t, pa, ch, x in zip(c.joint_names, c.joint_types, c.parents, c.children, c.jpos)
    ]


def _bodies(links: list[str], joints: list[tuple]) -> np.ndarray:
    """Rigid body index of each link (links joined by fixed joints share one)."""
    index = {ln: k for k, ln in enumerate(links)}
    body = np.arange(len(links))
    for _n, t, pa, ch, _len in joints:  # parents before children: a child takes its parent's body
        if t == "fixed":
            body[index[ch]] = body[index[pa]]
    return body


def _path_lengths(solid: list[int], edges: list[tuple[int, int, np.ndarray]]) -> dict[tuple[int, int], float]:
    """(a, b) -> skeleton path length between the bodies ``solid`` (those
    with capsules; a < b, 0 for adjacent ones), through the moving joints
    ``edges`` (body a, body b, joint point at a reference posture)."""
    around: dict[int, list[tuple[int, np.ndarray]]] = {}
    for a, b, x in edges:
        around.setdefault(a, []).append((b, x))
        around.setdefault(b, []).append((a, x))
    wanted = set(solid)
    d: dict[tuple[int, int], float] = {}
    for src in solid:
        stack = [(b, x, 0.0, src) for b, x in around.get(src, ())]
        while stack:
            body, entry, dist, came = stack.pop()
            if body in wanted and src < body:
                d[src, body] = dist
            for nxt, x in around.get(body, ()):
                if nxt != came:
                    stack.append((nxt, x, dist + float(np.linalg.norm(x - entry)), body))
    return d


def skeleton(model: object, settings: PlanSettings, q_ref: np.ndarray) -> Skeleton:
    """The collision skeleton of ``model`` (module docstring); ``q_ref`` a
    posture within the limits (the joint points of the path lengths)."""
    model = _kinematic(model)
    tree = getattr(model, "tree", None)
    links = list(tree.links) if tree is not None else list(model.chain.links)
    shapes = tree.collisions if tree is not None else model.chain.collisions
    index = {ln: k for k, ln in enumerate(links)}
    joints = _joints(model)
    body = _bodies(links, joints)
    owner, seg, local, radius, labels, la, lb = [], [], [], [], [], [], []
    for ln, caps in shapes.items():
        for c in caps:
            owner.append(index[ln])
            seg.append((-1, -1))
            local.append(len(la))
            la.append(c.a)
            lb.append(c.b)
            radius.append(c.r)
            labels.append(f"link {ln!r} ({c.source})")
    for name, t, pa, ch, length in joints:
        if pa in shapes or (length < MIN_SEGMENT and t != "prismatic"):
            continue
        owner.append(index[pa])
        seg.append((index[pa], index[ch]))
        local.append(-1)
        radius.append(settings.radius(pa))
        labels.append(f"link {pa!r} (towards joint {name!r})")
    owner = np.array(owner, int)
    radius = np.array(radius, float)
    _R, p = _frames(model, links, np.atleast_2d(q_ref))
    edges = [(body[index[pa]], body[index[ch]], p[0, index[ch]]) for _n, t, pa, ch, _l in joints if t != "fixed"]
    cb = body[owner] if owner.size else np.zeros(0, int)
    caps_of: dict[int, list[int]] = {}
    for c, bc in enumerate(cb):
        caps_of.setdefault(int(bc), []).append(c)
    rb = {bc: float(radius[cs].max()) for bc, cs in caps_of.items()}
    pairs = [
        (ci, cj)
        for (a, b), d in _path_lengths(sorted(caps_of), edges).items()
        if d > 0 and d >= rb[a] + rb[b] + settings.margin
        for ci in caps_of[a]
        for cj in caps_of[b]
    ]
    pairs = np.array(pairs, int).reshape(-1, 2)
    floor = cb != body[0] if owner.size else np.zeros(0, bool)
    mlink, mpoint = _markers(model, index)
    own = body[mlink][:, None] == cb[None, :] if mlink.size else np.zeros((0, owner.size), bool)
    return Skeleton(
        model=model,
        links=links,
        body=body,
        owner=owner,
        seg=np.array(seg, int).reshape(-1, 2),
        local=np.array(local, int),
        la=np.array(la, float).reshape(-1, 3),
        lb=np.array(lb, float).reshape(-1, 3),
        radius=radius,
        pairs=pairs,
        floor=floor,
        marker_link=mlink,
        marker_point=mpoint,
        own=own,
        labels=labels,
    )


def _markers(model: object, index: dict[str, int]) -> tuple[np.ndarray, np.ndarray]:
    """Link index and point (link frame, the model's start values) of every marker of a TreeModel."""
    if not hasattr(model, "tree"):
        return np.zeros(0, int), np.zeros((0, 3))
    theta = model.theta0
    mpar = np.asarray(model.arrays["mpar"]).reshape(3, -1) - 1
    if mpar.shape[1] != len(model.frames):
        raise InputError("the model's marker parameters do not match its marker frames")
    return np.array([index[f] for f in model.frames], int), theta[mpar].T.copy()
