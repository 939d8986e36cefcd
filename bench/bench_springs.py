"""Postures per second of the spring-tree core against numpy, same run.

Two models:
  6R   a KR-270-like serial robot, 6 joint springs + 7 link springs on
       explicit poses (serial VJM, Klimchik et al. eq. 2): tool compliance
       and stiffness with the rank decided per posture;
  SMG  the McGill SMG of Taghvaeipour et al. (eqs. 22-30), MP stiffness.
For each: the Fortran core (one call for all postures: the call alone,
evaluate() with its argument packing, and with the Python that builds the
poses), a straightforward numpy loop over postures, and numpy vectorised over
postures (einsum/batched linalg), both doing the same job as stiffkit: the
6R ones get the same prebuilt poses (compared with evaluate()), the SMG
ones do their own inverse kinematics (compared with evaluate() + pose
building). One thread (OMP_NUM_THREADS=1 via make bench).

    python bench/bench_springs.py [N]        (default N = 100000)
"""
from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import stiffkit as sk  # noqa: E402
from stiffkit.springs import Joint, Spring, evaluate, series  # noqa: E402
from stiffkit.springs import smg  # noqa: E402

N = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1].isdigit() else 100_000
N_LOOP = min(N, 2000)     # the per-posture numpy loop is timed on fewer postures

# ---------------------------------------------------------------- 6R model
# KR-270-like DH (a, alpha, d), m and rad
DH = [(0.35, -np.pi / 2, 0.675), (1.15, 0.0, 0.0), (0.041, -np.pi / 2, 0.0),
      (0.0, np.pi / 2, -1.0), (0.0, -np.pi / 2, 0.0), (0.0, 0.0, -0.215)]
K_JOINT = np.array([2.0e7, 1.5e7, 8.0e6, 1.5e6, 1.2e6, 6.0e5])   # N m/rad


def link_compliances():
    steel = 2.0e11, 0.3
    secs = [("tube", [0.40, 0.34], 0.6), ("tube", [0.30, 0.24], 0.35), ("tube", [0.28, 0.22], 1.15),
            ("tube", [0.22, 0.17], 0.2), ("tube", [0.16, 0.12], 1.0), ("tube", [0.12, 0.09], 0.15),
            ("tube", [0.10, 0.07], 0.2)]
    return [sk.cantilever_compliance(l, *steel, sk.section_properties(s, d, steel[1])) for s, d, l in secs]


def fk(q):
    """Frames of the 6R at postures q (N,6): origins (N,7,3) and rotations (N,7,3,3)."""
    n = q.shape[0]
    R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    p = np.zeros((n, 3))
    Rs, ps = [R.copy()], [p.copy()]
    for j, (a, al, d) in enumerate(DH):
        c, s = np.cos(q[:, j]), np.sin(q[:, j])
        Rz = np.zeros((n, 3, 3))
        Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s, s, c, 1
        Rx = np.array([[1, 0, 0], [0, np.cos(al), -np.sin(al)], [0, np.sin(al), np.cos(al)]])
        p = p + R[:, :, 2] * d                      # along z_{j-1} by d
        R = R @ Rz
        p = p + R[:, :, 0] * a                      # along x_j by a
        R = R @ Rx
        Rs.append(R.copy())
        ps.append(p.copy())
    return np.stack(ps, 1), np.stack(Rs, 1)


def model_6r(q, links):
    """Tree of the 6R: link i ends at frame origin i+1 (link 0: base column)."""
    P, R = fk(q)
    parts = [Spring(links[0], pos=P[:, 1], rot=R[:, 0])]
    for j in range(6):
        parts.append(Joint("revolute", R[:, j, :, 2], P[:, j], compliance=1.0 / K_JOINT[j]))
        end = P[:, j + 1] if j < 5 else P[:, 6] + 0.1 * R[:, 6, :, 2]
        parts.append(Spring(links[j + 1], pos=end, rot=R[:, j + 1]))
    tool = P[:, 6] + 0.25 * R[:, 6, :, 2]
    return series(*parts), tool, P, R


def skew_b(v):
    s = np.zeros(v.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def transfer_b(r):
    t = np.broadcast_to(np.eye(6), r.shape[:-1] + (6, 6)).copy()
    t[..., :3, 3:] = -skew_b(r)
    return t


def rot6_b(R):
    b = np.zeros(R.shape[:-2] + (6, 6))
    b[..., :3, :3] = R
    b[..., 3:, 3:] = R
    return b


def numpy_6r_loop(Pall, Rall, links):
    """Straightforward numpy: one posture at a time (VJM sum, then eigh for K)."""
    out = []
    for i in range(Pall.shape[0]):
        P, R = Pall[i], Rall[i]
        tool = P[6] + 0.25 * R[6, :, 2]
        C = np.zeros((6, 6))
        ends = [P[1]] + [P[j + 1] if j < 5 else P[6] + 0.1 * R[6, :, 2] for j in range(6)]
        frames = [R[0]] + [R[j + 1] for j in range(6)]
        for c, e, Rl in zip(links, ends, frames):
            T = transfer_b(tool - e)
            B = rot6_b(Rl)
            C += T @ B @ c @ B.T @ T.T
        for j in range(6):
            u = R[j, :, 2]
            xi = np.concatenate([np.cross(u, tool - P[j]), u])
            C += np.outer(xi, xi) / K_JOINT[j]
        w, v = np.linalg.eigh(C)
        K = (v / w) @ v.T
        out.append((C, K))
    return out


def numpy_6r_vec(P, R, links):
    """numpy vectorised over postures."""
    tool = P[:, 6] + 0.25 * R[:, 6, :, 2]
    ends = [P[:, 1]] + [P[:, j + 1] if j < 5 else P[:, 6] + 0.1 * R[:, 6, :, 2] for j in range(6)]
    frames = [R[:, 0]] + [R[:, j + 1] for j in range(6)]
    C = np.zeros((P.shape[0], 6, 6))
    for c, e, Rl in zip(links, ends, frames):
        M = transfer_b(tool - e) @ rot6_b(Rl)
        C += M @ c @ np.swapaxes(M, -1, -2)
    for j in range(6):
        u = R[:, j, :, 2]
        xi = np.concatenate([np.cross(u, tool - P[:, j]), u], axis=1)
        C += xi[:, :, None] * xi[:, None, :] / K_JOINT[j]
    w, v = np.linalg.eigh(C)
    K = (v / w[:, None, :]) @ np.swapaxes(v, -1, -2)
    return C, K


# ---------------------------------------------------------------- SMG model
def numpy_smg_vec(P, theta, links, g):
    """Eqs. 22-30 vectorised over postures (links condensed, eq. 23, 25, 29-30)."""
    z = np.array([0, 0, 1.0])

    def condense(K, xi):
        Kx = np.einsum("nij,nj->ni", K, xi)
        return K - Kx[:, :, None] * Kx[:, None, :] / np.einsum("ni,ni->n", xi, Kx)[:, None, None]

    Ktot = np.zeros((P.shape[0], 6, 6))
    for J in (0, 1):
        S, E, W, h = smg.limb_points(J, P, theta, g)
        n = np.cross(h, z)
        Kpi = []
        for A, B, wid, c in ((S, E, g.h1, links["proximal"]), (E, W, g.h2, links["distal"])):
            Kp = np.zeros_like(Ktot)
            kloc = np.linalg.inv(c)
            for s in (0.5, -0.5):
                a, b = A + s * wid * z, B + s * wid * z
                u = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
                Rl = np.stack([u, np.cross(n, u), n], axis=-1)
                Wb = transfer_b(b - P)                       # twist at P -> twist at b
                Kb = rot6_b(Rl) @ kloc @ np.swapaxes(rot6_b(Rl), -1, -2)
                Kb = np.swapaxes(Wb, -1, -2) @ Kb @ Wb
                xi = np.concatenate([np.cross(n, P - a), n], axis=1)
                Kp += condense(Kb, xi)
            Kpi.append(Kp)
        KP, KD = Kpi
        KJ = KD - KD @ np.linalg.solve(KD + KP, KD)
        zeta = np.concatenate([np.cross(z, P - W), np.broadcast_to(z, P.shape)], axis=1)
        Ktot += condense(KJ, zeta)
    return Ktot


class _CoreTimer:
    """Times the f2py call itself inside evaluate() (the rest is argument packing)."""

    def __init__(self):
        from stiffkit.springs import tree
        self.mod, self.orig, self.t = tree._springs, tree._springs.sk_spring_tree, 0.0

    def __enter__(self):
        def timed(*a):
            t0 = time.perf_counter()
            out = self.orig(*a)
            self.t = time.perf_counter() - t0
            return out
        self.mod.sk_spring_tree = timed
        return self

    def __exit__(self, *exc):
        self.mod.sk_spring_tree = self.orig


def timeit(f, reps=3):
    best = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def row(name, n, t, ref=None):
    rate = n / t
    extra = f"   x{ref / rate:8.1f} slower than stiffkit" if ref else ""
    print(f"  {name:44s} {n:8d} postures {t:9.4f} s {rate:12.0f} /s{extra}")
    return rate


def main():
    rng = np.random.default_rng(0)
    links = link_compliances()
    q = rng.uniform(-np.pi, np.pi, (N, 6))
    print(f"6R (6 joint + 7 link springs), N = {N}")
    t_build, (tree, tool, Pf, Rf) = timeit(lambda: model_6r(q, links), 1)
    with _CoreTimer() as ct:
        t_core, res = timeit(lambda: evaluate(tree, tool=tool, lscale=1.0), 3)
    row("Fortran core call alone", N, ct.t)
    r_core = row("evaluate() on prebuilt poses (one core call)", N, t_core)
    row("evaluate() + Python pose building (FK)", N, t_core + t_build)
    t_vec, (Cv, Kv) = timeit(lambda: numpy_6r_vec(Pf, Rf, links), 1)
    r_vec = row("numpy vectorised, same prebuilt poses", N, t_vec, r_core)
    t_loop, out = timeit(lambda: numpy_6r_loop(Pf[:N_LOOP], Rf[:N_LOOP], links), 1)
    r_loop = row("numpy loop over postures, same poses", N_LOOP, t_loop, r_core)
    err = np.abs(res.compliance - Cv).max() / np.abs(Cv).max()
    errk = np.max(np.abs(res.stiffness - Kv).max(axis=(1, 2)) / np.abs(Kv).max(axis=(1, 2)))
    print(f"  agreement core vs numpy: compliance {err:.1e}, stiffness {errk:.1e} (relative); "
          f"rank 6 at {np.mean(res.rank == 6) * 100:.1f} % of postures")
    print(f"  speed-up: x{r_core / r_loop:.0f} vs numpy loop, x{r_core / r_vec:.1f} vs numpy vectorised")

    g = smg.SMGGeometry()
    sl = smg.smg_links()
    tau, P, theta = smg.trajectory(N, g)
    print(f"\nMcGill SMG (2 limbs x 2 Pi-joints x 2 links, 3 passive joints per limb), N = {N}")
    t_build, tree = timeit(lambda: smg.smg_tree(P, theta, sl, g), 1)
    with _CoreTimer() as ct:
        t_core, res = timeit(lambda: evaluate(tree, tool=P, lscale=g.l1), 3)
    row("Fortran core call alone", N, ct.t)
    r_core = row("evaluate() on prebuilt poses (one core call)", N, t_core)
    row("evaluate() + Python pose building", N, t_core + t_build)
    r_core = N / (t_core + t_build)          # numpy below does its own inverse kinematics
    t_vec, Kv = timeit(lambda: numpy_smg_vec(P, theta, sl, g), 1)
    r_vec = row("numpy vectorised (eqs. 22-30, with IK)", N, t_vec, r_core)
    m = min(N, N_LOOP)
    t_loop, _ = timeit(lambda: [numpy_smg_vec(P[i:i + 1], theta[i:i + 1], sl, g) for i in range(m)], 1)
    r_loop = row("numpy loop over postures (eqs. 22-30, with IK)", m, t_loop, r_core)
    err = np.max(np.abs(res.stiffness - Kv).max(axis=(1, 2)) / np.abs(Kv).max(axis=(1, 2)))
    print(f"  agreement core vs numpy eqs. 22-30: stiffness {err:.1e} (relative)")
    print(f"  speed-up: x{r_core / r_loop:.0f} vs numpy loop, x{r_core / r_vec:.1f} vs numpy vectorised")


if __name__ == "__main__":
    main()
