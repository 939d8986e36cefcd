"""An independent "hand calibration" of a tree robot measured by a tracker
(issue 16 item 5, docs/calibration.md section 6.12), written with numpy
only: its own forward kinematics, gravity moments, equilibrium and
Levenberg-Marquardt, nothing from the core. It serves two roles:

- a simulator of a truth (joint offsets, frame errors, joint and lateral
  compliance) in either lateral convention: ``"turning"`` (stiffkit's
  before issue 16 item 5: x', y' of the joint frame after the motion) or
  ``"normal"`` (the tilt of a joint's axis about the common normal with the
  previous moving joint's axis, through its foot on this axis, fixed in the
  parent link: the careful calibrator's convention);
- the hand reference: a minimal parameter set chosen by rule (tracker,
  markers, joint offsets, per joint the two translations and two rotations
  of the origin perpendicular to its axis, the joint compliance, one
  lateral compliance about the common normal, both for a joint with no
  moving joint above it, none for a joint coaxial with the previous one),
  exact dependencies removed by a rank check (Gram-Schmidt), fitted by a
  damped Gauss-Newton with a finite-difference Jacobian.
"""

from __future__ import annotations

import numpy as np

G = np.array([0.0, 0.0, -9.81])


def rot(axis: np.ndarray, ang: np.ndarray) -> np.ndarray:
    """Rotations (..., 3, 3) about the unit ``axis`` (3,) by ``ang`` (...)."""
    a = np.asarray(axis, float)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    s, c = np.sin(ang)[..., None, None], np.cos(ang)[..., None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def _least_aligned(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = e - (e @ z) * z
    x /= np.linalg.norm(x)
    return x, np.cross(z, x)


class HandModel:
    """Parameters ``names`` (kind, joint or frame, index); ``predict(theta, Q)``."""

    def __init__(self, tree, frames, lateral="normal", hand=True, eqit=100, second=False):
        self.tree, self.frames, self.lateral, self.eqit = tree, list(frames), lateral, eqit
        self.joints = list(tree.joints)
        self.qcol = {n: k for k, n in enumerate(tree.actuated)}
        # bodies beyond each joint
        self.beyond = {j.name: self._subtree(j.child) for j in self.joints}
        self.lat_dirs = {j.name: self._lat_dirs(j, second, hand) for j in self.joints if j.moving}
        self.names: list[tuple] = [("tr", "", k) for k in range(6)]
        self.names += [("mk", f, k) for f in frames for k in range(3)]
        for j in self.joints:
            if not j.moving:
                continue
            self.names.append(("dq0", j.name, 0))
            fr = range(6) if not hand else [k for k in range(6) if abs(j.axis[k % 3]) < 0.5]
            self.names += [("fr", j.name, k) for k in fr]
            self.names.append(("c", j.name, 0))
            self.names += [("lat", j.name, k) for k in range(len(self.lat_dirs[j.name]))]
        self.index = {n: i for i, n in enumerate(self.names)}

    def _subtree(self, link):
        out, todo = [], [link]
        while todo:
            ln = todo.pop()
            if ln in self.tree.inertials:
                out.append(ln)
            todo += [k.child for k in self.tree.children(ln)]
        return out

    def _prev(self, j):
        """The nearest moving joint above j and the transform from its frame
        (after its motion) to j's origin frame (the fixed joints between)."""
        T = j.origin
        p = self.tree.parent_joint(j.parent)
        while p is not None and not p.moving:
            T = p.origin @ T
            p = self.tree.parent_joint(p.parent)
        return p, T

    def _lat_dirs(self, j, second, hand):
        """(axis, point) of each lateral tilt, in j's origin frame (normal) or joint frame (turning)."""
        z = j.axis
        if self.lateral == "turning":
            x, y = _least_aligned(z)
            return [(x, np.zeros(3)), (y, np.zeros(3))]
        p, T = self._prev(j)
        if p is None:
            x, y = _least_aligned(z)
            return [(x, np.zeros(3)), (y, np.zeros(3))]
        Tinv = np.linalg.inv(T)  # p's frame -> j's origin frame: p's axis line in j's frame
        zp = Tinv[:3, :3] @ p.axis
        op = Tinv[:3, 3]
        n = np.cross(zp, z)
        if np.linalg.norm(n) < 1e-9:  # parallel: the perpendicular from p's axis to j's
            d = -op - ((-op) @ z) * z
            if np.linalg.norm(d) < 1e-9:  # coaxial: the hand keeps the previous joint's
                return [] if hand else [(a, np.zeros(3)) for a in _least_aligned(z)]
            n = d / np.linalg.norm(d)
            foot = np.zeros(3)
        else:
            n /= np.linalg.norm(n)
            # foot on j's axis (through 0 along z) of the common normal with p's axis
            A = np.array([[z @ z, -(z @ zp)], [z @ zp, -(zp @ zp)]])
            s, _t = np.linalg.solve(A, [z @ op, zp @ op])
            foot = s * z
        out = [(n, foot)]
        if second:
            out.append((np.cross(z, n), foot))
        return out

    def _pose(self, theta, Q, defl):
        """Link transforms (P, 4, 4) and the frames where each elastic dof acts."""
        P = Q.shape[0]
        T = {self.tree.root: np.broadcast_to(np.eye(4), (P, 4, 4)).copy()}
        at = {}
        ix = self.index
        for j in self.joints:
            E = np.eye(4)
            d = [theta[ix[("fr", j.name, k)]] if ("fr", j.name, k) in ix else 0.0 for k in range(6)]
            E[:3, 3] = d[:3]
            E[:3, :3] = rot(np.eye(3)[0], np.array(d[3])) @ rot(np.eye(3)[1], np.array(d[4]))
            E[:3, :3] = E[:3, :3] @ rot(np.eye(3)[2], np.array(d[5]))
            at[("fr", j.name, 0)] = (T[j.parent] @ j.origin, None, None)
            A = T[j.parent] @ (j.origin @ E)
            if not j.moving:
                T[j.child] = A
                continue
            dirs = self.lat_dirs[j.name]
            if self.lateral == "normal":
                for k, (n, foot) in enumerate(dirs):
                    at[("lat", j.name, k)] = (A.copy(), n, foot)
                    M = np.broadcast_to(np.eye(4), (P, 4, 4)).copy()
                    M[:, :3, :3] = rot(n, defl.get(("lat", j.name, k), np.zeros(P)))
                    M[:, :3, 3] = foot - np.einsum("pij,j->pi", M[:, :3, :3], foot)
                    A = A @ M
            lead, mult, off = self.tree.leader(j.name)
            q = mult * Q[:, self.qcol[lead]] + off
            name, coef = j.name, 1.0
            while True:
                if ("dq0", name, 0) in ix:
                    q = q + coef * theta[ix[("dq0", name, 0)]]
                mim = self.tree.joint(name).mimic
                if mim is None:
                    break
                coef *= mim[1]
                name = mim[0]
            at[("c", j.name, 0)] = (A.copy(), j.axis, np.zeros(3))
            M = np.broadcast_to(np.eye(4), (P, 4, 4)).copy()
            M[:, :3, :3] = rot(j.axis, q + defl.get(("c", j.name, 0), 0.0))
            A = A @ M
            if self.lateral == "turning":
                for k, (n, foot) in enumerate(dirs):
                    at[("lat", j.name, k)] = (A.copy(), n, foot)
                    M = np.broadcast_to(np.eye(4), (P, 4, 4)).copy()
                    M[:, :3, :3] = rot(n, defl.get(("lat", j.name, k), np.zeros(P)))
                    A = A @ M
            T[j.child] = A
        return T, at

    def _moments(self, T, at, joint_of):
        """Generalised gravity force of every elastic dof: its axis (world) . the moment
        about its point of the weights beyond its joint."""
        com = {
            ln: np.einsum("pij,j->pi", T[ln][:, :3, :3], self.tree.inertials[ln].com) + T[ln][:, :3, 3]
            for ln in T
            if ln in self.tree.inertials
        }
        out = {}
        for key, (A, n, foot) in at.items():
            o = np.einsum("pij,j->pi", A[:, :3, :3], foot) + A[:, :3, 3]
            a = A[:, :3, :3] @ n
            M = sum(np.cross(com[ln] - o, self.tree.inertials[ln].mass * G) for ln in self.beyond[key[1]])
            out[key] = np.einsum("pi,pi->p", a, M)
        return out

    def predict(self, theta, Q, R0=None):
        """Tracker-frame marker points (P, nf, 3)."""
        return self._solve(theta, Q, np.eye(3) if R0 is None else R0)[0]

    def _solve(self, theta, Q, R0, defl0=None):
        ix = self.index
        comp = {n: theta[i] for n, i in ix.items() if n[0] in ("c", "lat")}
        defl: dict = dict(defl0 or {})  # a warm start of the equilibrium
        for _ in range(max(self.eqit, 1)):
            T, at = self._pose(theta, Q, defl)
            if not comp:
                break
            tau = self._moments(T, {n: at[n] for n in comp}, None)
            new = {k: comp[k] * tau[k] for k in comp}
            step = max((np.abs(new[k] - defl.get(k, 0.0)).max() for k in new), default=0.0)
            defl = new
            if self.eqit <= 1 or step < 1e-11:
                T, at = self._pose(theta, Q, defl)
                break
        R = R0 @ rot(np.eye(3)[0], theta[0]) @ rot(np.eye(3)[1], theta[1]) @ rot(np.eye(3)[2], theta[2])
        t = theta[3:6]
        pts = []
        for f in self.frames:
            m = np.array([theta[ix[("mk", f, k)]] for k in range(3)])
            p = np.einsum("pij,j->pi", T[f][:, :3, :3], m) + T[f][:, :3, 3]
            pts.append(p @ R.T + t)
        return np.stack(pts, axis=1), T, at, R, defl

    def jacobian(self, theta, Q, free, R0):
        """Points (P*nf*3,) and their Jacobian for ``free``: every parameter is a
        small screw at its place in the chain (the change of the gravity moments
        it causes is left out: second order, the step still goes downhill)."""
        y, T, at, R, defl = self._solve(theta, Q, R0)
        P, nf = Q.shape[0], len(self.frames)
        pw = {f: np.einsum("ij,pj->pi", R.T, y[:, k] - theta[3:6]) for k, f in enumerate(self.frames)}
        down = {f: {j.name for j in self.tree.path(f)} for f in self.frames}
        J = np.zeros((P, nf, 3, len(free)))
        taus = self._moments(T, {n: at[n] for n in at if n[0] in ("c", "lat")}, None)
        for c, i in enumerate(free):
            kind, tgt, k = self.names[i]
            if kind == "tr":
                J[:, :, :, c] = np.cross(R0 @ np.eye(3)[k], y - theta[3:6]) if k < 3 else np.eye(3)[k - 3]
                continue
            if kind == "mk":
                f = self.frames.index(tgt)
                J[:, f, :, c] = R @ T[tgt][:, :3, :3] @ np.eye(3)[k]
                continue
            screws = []  # (omega (P,3) or None, v (P,3) or None, point (P,3), joint)
            if kind == "dq0":
                for j in self.joints:
                    if not j.moving:
                        continue
                    name, coef = j.name, 1.0
                    while name != tgt and self.tree.joint(name).mimic is not None:
                        coef *= self.tree.joint(name).mimic[1]
                        name = self.tree.joint(name).mimic[0]
                    if name == tgt:
                        A, n, foot = at[("c", j.name, 0)]
                        screws.append((coef * (A[:, :3, :3] @ n), None, A[:, :3, 3], j.name))
            elif kind == "fr":
                B = at[("fr", tgt, 0)][0]
                e = B[:, :3, :3] @ np.eye(3)[k % 3]
                screws.append((None, e, None, tgt) if k < 3 else (e, None, B[:, :3, 3], tgt))
            else:
                A, n, foot = at[(kind, tgt, k)]
                tau = taus[(kind, tgt, k)]
                o = np.einsum("pij,j->pi", A[:, :3, :3], foot) + A[:, :3, 3]
                screws.append(((A[:, :3, :3] @ n) * tau[:, None], None, o, tgt))
            for om, v, o, jn in screws:
                for fk, f in enumerate(self.frames):
                    if jn not in down[f]:
                        continue
                    d = np.cross(om, pw[f] - o) if om is not None else v
                    J[:, fk, :, c] += d @ R.T
        return y.ravel(), J.reshape(P * nf * 3, len(free))


def _steps(names):
    return np.array([1e-8 if n[0] in ("c", "lat") else 1e-7 for n in names])


def jacobian(model, theta, Q, free, R0):
    return model.jacobian(theta, Q, free, R0)


def fd_jacobian(model, theta, Q, free, R0):
    """Forward differences of the converged equilibrium (each from the
    base point's deflections): the exact derivative, to polish a fit and to
    check ``HandModel.jacobian``."""
    y0, _T, _at, _R, defl = model._solve(theta, Q, R0)
    h = _steps([model.names[i] for i in free])
    J = np.empty((y0.size, len(free)))
    for k, i in enumerate(free):
        th = theta.copy()
        th[i] += h[k]
        J[:, k] = (model._solve(th, Q, R0, defl)[0].ravel() - y0.ravel()) / h[k]
    return y0.ravel(), J


def kabsch(a, b):
    """R, t minimising |R a + t - b| (rows are points)."""
    ca, cb = a.mean(0), b.mean(0)
    U, _s, Vt = np.linalg.svd((a - ca).T @ (b - cb))
    D = np.diag([1, 1, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    return R, cb - R @ ca


def independent(J, order, kinds, tol=1e-6):
    """Gram-Schmidt in ``order``: the columns kept (relative orthogonal part >
    tol), none below 1e-9 of the largest of its kind (the data do not depend on it)."""
    Q, keep = [], []
    norms = np.linalg.norm(J, axis=0)
    top = {k: max(norms[i] for i in range(len(kinds)) if kinds[i] == k) for k in set(kinds)}
    for k in order:
        if norms[k] <= 1e-9 * top[kinds[k]]:
            continue
        v = J[:, k] / norms[k]
        for q in Q:
            v = v - (q @ v) * q
        for q in Q:
            v = v - (q @ v) * q
        if np.linalg.norm(v) > tol:
            Q.append(v / np.linalg.norm(v))
            keep.append(k)
    return sorted(keep)


def fit(model, Q, xyz, theta0, free=None, maxit=30, nonneg=True, polish=0):
    """Levenberg-Marquardt on ``free`` (when None the rank check picks them);
    with ``nonneg``, a compliance identified below 0 is held at 0 and the
    others fitted again (as a careful calibrator, and stiffkit, do). The
    screw Jacobian leaves out the change of the gravity moments, so its fixed
    point is near, not at, the least-squares one: ``polish`` more iterations
    with the exact (finite-difference) Jacobian. Returns theta, R0, free."""
    theta, R0, free = _lm(model, Q, xyz, theta0, free, maxit)
    for _ in range(5 if nonneg else 0):
        neg = [i for i in free if model.names[i][0] in ("c", "lat") and theta[i] < 0]
        if not neg:
            break
        theta[neg] = 0.0
        free = np.array([i for i in free if i not in neg], int)
        theta, R0, free = _lm(model, Q, xyz, theta, free, maxit, R0)
    if polish:
        theta, R0, free = _lm(model, Q, xyz, theta, free, polish, R0, fd_jacobian)
    return theta, R0, free


def _lm(model, Q, xyz, theta0, free, maxit, R0=None, jac=jacobian):
    """Levenberg-Marquardt from theta0 (the tracker from a point-set fit unless R0 is given)."""
    P = Q.shape[0]
    theta = theta0.copy()
    if R0 is None:
        theta[:6] = 0.0  # the tracker from the point-set fit
        R0, t = kabsch(model.predict(theta, Q).reshape(-1, 3), xyz.reshape(-1, 3))
        theta[:3] = 0.0
        theta[3:6] = t
    if free is None:
        allp = np.arange(len(model.names))
        _y, J = jacobian(model, theta, Q, allp, R0)
        kind = {"tr": 0, "mk": 1, "dq0": 2, "fr": 3, "c": 4, "lat": 5}
        order = sorted(allp, key=lambda i: (kind[model.names[i][0]], i))
        free = np.array(independent(J, order, [model.names[i][0] for i in allp]), int)
    lam = 1e-3
    y, J = jac(model, theta, Q, free, R0)
    r = y - xyz.reshape(P * len(model.frames) * 3)
    cost = r @ r
    for _ in range(maxit):
        s = np.linalg.norm(J, axis=0)
        s[s == 0] = 1.0
        Js = J / s
        A, g = Js.T @ Js, Js.T @ r
        dx = -np.linalg.solve(A + lam * np.diag(np.diag(A)), g) / s
        th = theta.copy()
        th[free] += dx
        r2 = model.predict(th, Q, R0).ravel() - xyz.ravel()
        if r2 @ r2 < cost:
            # re-centre the tracker rotation
            R0 = R0 @ rot(np.eye(3)[0], th[0]) @ rot(np.eye(3)[1], th[1]) @ rot(np.eye(3)[2], th[2])
            th[:3] = 0.0
            done = cost - r2 @ r2 < 1e-10 * cost
            theta, cost, lam = th, r2 @ r2, max(lam / 5, 1e-9)
            if done:
                break
            y, J = jac(model, theta, Q, free, R0)
            r = y - xyz.ravel()
        else:
            lam *= 10
            if lam > 1e8:
                break
    return theta, R0, free


def errors(model, theta, R0, Q, xyz):
    """Point distances (P * nf,)."""
    return np.linalg.norm(model.predict(theta, Q, R0) - xyz, axis=2).ravel()


def cross_validate(model, Q, xyz, theta, free, k=5, polish=0):
    """K-fold by posture (posture p in fold p mod k, as stiffkit's config_folds deals them)."""
    d = np.zeros((Q.shape[0], xyz.shape[1]))
    for f in range(k):
        test = np.arange(Q.shape[0]) % k == f
        th, R0, _ = fit(model, Q[~test], xyz[~test], theta, free, maxit=15, nonneg=False, polish=polish)
        d[test] = np.linalg.norm(model.predict(th, Q[test], R0) - xyz[test], axis=2)
    return d.ravel()


def start(model, markers):
    """Zero parameters with the markers' drawing values."""
    th = np.zeros(len(model.names))
    for f, p in markers.items():
        for k in range(3):
            th[model.index[("mk", f, k)]] = p[k]
    return th


def normal_truth(tree, effects):
    """The simulator (lateral about the common normal, fixed in the parent)
    and its theta, R0 for a dual-arm truth's [[effect]] tables: the tracker,
    markers, offsets, frame errors of moving joints and joint compliances
    from ``effects``; each joint's tilt about the common normal the first
    value of calib.dualarm.LATERAL_C (the first joint: both)."""
    from stiffkit.calib import dualarm as D
    from stiffkit.robot.tree_model import rpy_matrix

    sim = HandModel(tree, list(D.MARKERS), lateral="normal", hand=False)
    th = np.zeros(len(sim.names))
    tr = effects[0]
    R0 = rpy_matrix(np.array(tr["rpy"]))
    th[3:6] = tr["xyz"]
    for e in effects[1:]:
        kind, j, v = e["kind"], e["target"], e.get("value")
        if kind == "marker":
            for k in range(3):
                th[sim.index[("mk", j, k)]] = e["xyz"][k]
        elif kind == "joint_offset":
            th[sim.index[("dq0", j, 0)]] = v
        elif kind == "frame" and tree.joint(j).moving:
            for k in range(6):
                th[sim.index[("fr", j, k)]] = v[k]
        elif kind == "joint":
            th[sim.index[("c", j, 0)]] = v
    for j in tree.joints:
        if j.moving:
            for k in range(len(sim.lat_dirs[j.name])):
                th[sim.index[("lat", j.name, k)]] = D.LATERAL_C[D._suffix(j.name)][k]
    return sim, th, R0


def normal_truth_points(tree, effects, Q, seed, sigma=1e-4):
    """Noisy points (P, nf, 3) of the truth "normal" (:func:`normal_truth`) at postures Q."""
    sim, th, R0 = normal_truth(tree, effects)
    rng = np.random.default_rng(seed)
    y = sim.predict(th, Q, R0)
    return y + sigma * rng.normal(size=y.shape)
