"""Kinematic-tree core benchmark: evaluate + analytic Jacobian of tracker
data on a torso + two 7-joint arms (frame errors on every joint, joint and
lateral compliance, masses on every link, full gravity equilibrium), and
the throughput of compensation (Newton on q through the equilibrium) on a
7-joint chain with joint and lateral compliance (and frame errors and joint
offsets, which the core folds into the joint origins), and on a 6-joint one.
Times are wall clock and process CPU time (the machine may be shared).

    python bench/bench_tree.py        (or: make bench BENCH=tree)
"""

from __future__ import annotations

import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from stiffkit._core import _tree  # noqa: E402
from stiffkit._core.tree import pack  # noqa: E402


def _packed(ne, model):
    """The model's arrays packed for the core (bindings/tree.py ``pack``): mi, mr."""
    p = pack(ne, model)
    return p.mi, p.mr


E3 = np.eye(3)


def rot(axis, angle):
    a = np.asarray(axis, float)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


class Tree:
    """Virtual-joint arrays as the Python side builds them from a URDF
    (the expansion of core/sk_tree.f90's header), for the benchmark only."""

    def __init__(self, ndof):
        self.ndof = ndof
        self.v = []  # (parent, type, axis, rot, pos, qcol, qcoef, qconst)
        self.geo = []  # (vj, par, coef)
        self.blocks = []  # (type, vjs, pars)
        self.bodies = []  # (vj, mass, com)
        self.theta = []
        self.kind = []
        self.markers = []  # (vj, pars)
        self.tpar = []

    def par(self, value, kind):
        self.theta.append(value)
        self.kind.append(kind)
        return len(self.theta)

    def vj(self, parent, vtype, axis, r, p, qcol=0, qcoef=0.0, qconst=0.0):
        self.v.append((parent, vtype, np.asarray(axis, float), r, np.asarray(p, float), qcol, qcoef, qconst))
        return len(self.v)

    def joint(self, parent, r, p, axis, qcol, frame=None, clat=None, c=None, offset=None):
        """[origin] -> frame error (3 prismatic, 3 revolute) -> two lateral
        revolutes -> the joint; returns the joint's virtual joint."""
        v = parent
        if frame is not None:
            for j in range(6):
                v = self.vj(v, 2 if j < 3 else 1, E3[j % 3], r, p)
                r, p = E3, np.zeros(3)
                self.geo.append((v, self.par(frame[j], "frame"), 1.0))
        if clat is not None:
            a = np.asarray(axis, float)
            x1 = np.array([0.0, 0, 1]) if abs(a[0]) > 0.9 else np.array([1.0, 0, 0])
            x1 -= x1 @ a * a
            x1 /= np.linalg.norm(x1)
            for x in (x1, np.cross(a, x1)):
                v = self.vj(v, 1, x, r, p)
                r, p = E3, np.zeros(3)
                self.blocks.append((1, [v], [self.par(clat, "law")]))
        v = self.vj(v, 1, axis, r, p, qcol, 1.0, 0.0)
        if c is not None:
            self.blocks.append((1, [v], [self.par(c, "law")]))
        if offset is not None:
            self.geo.append((v, self.par(offset, "offset"), 1.0))
        return v

    def arrays(self):
        nk = len(self.blocks)
        i32 = lambda x: np.asfortranarray(np.asarray(x, np.int32))  # noqa: E731
        f64 = lambda x: np.asfortranarray(np.asarray(x, float))  # noqa: E731
        kvj = np.zeros((6, nk), np.int32)
        kpar = np.zeros((21, nk), np.int32)
        for k, (_, vjs, pars) in enumerate(self.blocks):
            kvj[: len(vjs), k] = vjs
            kpar[: len(pars), k] = pars
        return dict(
            vparent=i32([v[0] for v in self.v]),
            vtype=i32([v[1] for v in self.v]),
            vaxis=f64(np.array([v[2] for v in self.v]).T),
            vrot=f64(np.stack([v[3] for v in self.v], axis=2)),
            vpos=f64(np.array([v[4] for v in self.v]).T),
            qcol=i32([v[5] for v in self.v]),
            qcoef=f64([v[6] for v in self.v]),
            qconst=f64([v[7] for v in self.v]),
            gvj=i32([g[0] for g in self.geo]),
            gpar=i32([g[1] for g in self.geo]),
            gcoef=f64([g[2] for g in self.geo]),
            ktype=i32([b[0] for b in self.blocks]),
            kvj=i32(kvj),
            kpar=i32(kpar),
            kw0=f64(np.ones(nk)),
            bvj=i32([b[0] for b in self.bodies]),
            bmass=f64([b[1] for b in self.bodies]),
            bcom=f64(np.array([b[2] for b in self.bodies]).T.reshape(3, -1)),
            grav=f64([0, 0, -9.81]),
            tpar=i32(self.tpar),
            rref=f64(rot([0, 0, 1], 2.0)),
            mvj=i32([m[0] for m in self.markers]),
            mpar=i32(np.array([m[1] for m in self.markers]).T.reshape(3, -1)),
            bpar=i32(np.zeros((3, 0))),
        ), sum(len(b[1]) for b in self.blocks)


def arm(t, parent, col0, side, with_offsets=True):
    v = parent
    rng = np.random.default_rng(col0)
    for j in range(7):
        axis = [0.0, 0, 1] if j % 2 == 0 else [0.0, 1, 0]
        r = rot([1, 0, 0], side * 0.2) if j == 0 else rot([0, 0, 1], 0.05 * j)
        p = [0.0, side * 0.2, 0.5] if j == 0 else [0.08 if j % 2 else 0.0, 0.0, 0.3 if j < 4 else 0.12]
        v = t.joint(
            v,
            r,
            p,
            axis,
            col0 + j,
            frame=rng.normal(0, 1e-3, 6),
            clat=1e-5,
            c=2e-5,
            offset=0.01 * rng.normal() if with_offsets else None,
        )
        t.bodies.append((v, 8.0 - j, np.array([0.02, 0.0, 0.1])))
    return v


def tracker_tree():
    t = Tree(15)
    t.tpar = [t.par(x, "tracker") for x in (2.0, -1.0, 0.4, 0.01, -0.02, 0.03)]
    torso = t.joint(0, E3, [0, 0, 0.3], [0, 0, 1], 1, frame=np.zeros(6), clat=5e-6, c=1e-5)
    t.bodies.append((torso, 25.0, np.array([0.0, 0.0, 0.3])))
    for side, col0 in ((1, 2), (-1, 9)):
        tool = arm(t, torso, col0, side)
        t.markers.append((tool, [t.par(x, "marker") for x in (0.02, 0.01, 0.1)]))
    return t


def bench_evaluate(npost=1000, reps=3):
    t = tracker_tree()
    model, ne = t.arrays()
    theta = np.asarray(t.theta, float)
    kinds = np.array(t.kind)
    rng = np.random.default_rng(1)
    q = np.asfortranarray(rng.uniform(-1.5, 1.5, (t.ndof, npost)))
    nm = len(t.markers)
    opost = np.repeat(np.arange(1, npost + 1, dtype=np.int32), nm)
    omark = np.tile(np.arange(1, nm + 1, dtype=np.int32), npost)
    no = opost.size
    common = dict(
        theta=theta,
        q=q,
        lpost=np.zeros(0, np.int32),
        lvj=np.zeros(0, np.int32),
        lw=np.zeros((6, 0), order="F"),
        opost=opost,
        omark=omark,
        oxyz=np.zeros((3, no), order="F"),
        owt=np.ones(no),
    )
    all_par = np.arange(1, theta.size + 1, dtype=np.int32)
    # ~100 free: tracker, markers, offsets, compliances and the first 29 frame parameters
    frames = all_par[kinds == "frame"]
    free100 = np.sort(np.concatenate([all_par[kinds != "frame"], frames[: 100 - np.sum(kinds != "frame")]]))
    print(
        f"tree: {len(t.v)} virtual joints, {ne} elastic coordinates, {theta.size} parameters, "
        f"{npost} postures x {nm} markers = {no} points"
    )
    print(
        f"{'equilibrium':>12s} {'free':>5s} {'time (s)':>9s} {'CPU (s)':>8s} {'per posture (us)':>17s}"
        f" {'iterations':>11s}"
    )
    for eqit, label in ((100, "iterated"), (1, "first order")):
        for free in (free100, all_par, np.zeros(0, np.int32)):
            ts, cs = [], []
            for _ in range(reps):
                t0 = time.perf_counter()
                c0 = time.process_time()
                out = _tree.sk_tree_evaluate(*_packed(ne, model), **common, free=free, eqit=eqit, etol=1e-9)
                cs.append(time.process_time() - c0)
                ts.append(time.perf_counter() - t0)
            pred, res, jac, delta, nit, eqinfo, info, _errloc = out
            assert info == 0, info
            print(
                f"{label:>12s} {free.size:5d} {min(ts):9.3f} {min(cs):8.3f} {1e6 * min(ts) / npost:17.0f} "
                f"{np.mean(nit):11.1f}",
                flush=True,
            )
    print(f"deflections up to {1e3 * np.max(np.abs(delta)):.2f} mrad/mm")


def chain7(nj=7):
    t = Tree(nj)
    t.tpar = [t.par(0.0, "tracker") for _ in range(6)]
    v = 0
    rng = np.random.default_rng(3)
    for j in range(nj):
        axis = [0.0, 0, 1] if j % 2 == 0 else [0.0, 1, 0]
        p = [0.0, 0.0, 0.34] if j == 0 else [0.0, 0.0, 0.2 if j < 5 else 0.1]
        v = t.joint(
            v,
            rot([0, 0, 1], 0.1 * j),
            p,
            axis,
            j + 1,
            frame=rng.normal(0, 1e-3, 6),
            clat=1e-5,
            c=2e-5,
            offset=0.01 * rng.normal(),
        )
        t.bodies.append((v, 6.0 - 0.5 * j, np.array([0.0, 0.02, 0.1])))
    tool = t.vj(v, 0, [0, 0, 0], E3, [0, 0, 0.1])
    t.markers.append((tool, [t.par(0.0, "marker") for _ in range(3)]))
    return t, tool


def bench_compensate(nrows=5000, nj=7):
    t, tool = chain7(nj)
    model, ne = t.arrays()
    theta = np.asarray(t.theta, float)
    rng = np.random.default_rng(5)
    q = np.asfortranarray(rng.uniform(-1.2, 1.2, (nj, nrows)))
    frame = np.full(nrows, tool, np.int32)
    none = dict(lpost=np.zeros(0, np.int32), lvj=np.zeros(0, np.int32), lw=np.zeros((6, 0), order="F"))
    # targets: the nominal model (no geometric errors, rigid)
    rt, pt, jq, delta, nit, eqinfo, info, _errloc = _tree.sk_tree_frame_jacobian(
        *_packed(ne, model), theta=np.zeros_like(theta), frame=frame, q=q, **none, eqit=0, etol=1e-9
    )
    assert info == 0
    print(f"compensation: {nj}-joint chain, {len(t.v)} virtual joints, {ne} elastic coordinates, {nrows} rows")
    print(
        f"{'mode':>22s} {'rows/s':>9s} {'rows/s CPU':>11s} {'converged':>10s} {'max |dp| (m)':>13s}"
        f" {'max |dphi| (rad)':>17s} {'Newton steps':>13s}"
    )
    for full6, label in ((1, "position + orientation"), (0, "position only")):
        ts, cs = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            c0 = time.process_time()
            qout, resp, resr, nit, rinfo, info, _errloc = _tree.sk_tree_compensate(
                *_packed(ne, model),
                theta=theta,
                frame=frame,
                qcmd=q,
                rtarget=rt,
                ptarget=pt,
                **none,
                prow=np.zeros(0, np.int32),
                trow=np.zeros(0),
                full6=full6,
                eqit=100,
                etol=1e-13,
                maxit=30,
                ptol=1e-12,
                rtol=1e-12,
            )
            cs.append(time.process_time() - c0)
            ts.append(time.perf_counter() - t0)
        assert info == 0, info
        ok = rinfo == 0
        print(
            f"{label:>22s} {nrows / min(ts):9.0f} {nrows / min(cs):11.0f} {np.mean(ok):10.2%} {resp[ok].max():13.1e}"
            f" {resr[ok].max() if full6 else float('nan'):17.1e} {np.mean(nit):13.1f}",
            flush=True,
        )


def main():
    bench_evaluate()
    print()
    bench_compensate(nj=7)
    bench_compensate(nj=6)


if __name__ == "__main__":
    main()
