"""Postures per second of the core against numpy, same run (benchmark).

Two models:
  6R   the KR-270-like serial robot (examples/kr270/robot.urdf) with 6 joint
       + 7 link springs (base_link, link_1 .. link_6: tube cantilevers), a
       model TOML with values read by stiffkit.load_model: tool compliance
       and stiffness with the rank decided per posture,
       load_model(...).tool_compliance(Q) / .stiffness(Q), one core call
       (the chain's tree model, sk_chain_tree + sk_tree_point: forward
       kinematics, klimchik eq. 2, Cholesky inverse);
       also the same model through the spring-tree evaluator (model_vjm:
       poses from sk_chain, sk_springs serial array);
  SMG  the McGill SMG of Taghvaeipour et al. (eqs. 22-30), MP stiffness.
For each: the Fortran core (one call for all postures), a straightforward
numpy loop over postures and numpy vectorised over postures
(einsum/batched linalg), doing the same job from the same inputs: for the
6R the numpy codes do their own forward kinematics from the URDF chain
arrays, then eq. 2 and K = C^-1; the SMG ones do their own inverse
kinematics (compared with evaluate() + pose building). Goal:
>= 1e5 postures/s on one core for the 6R and >= 50x numpy. One thread
(OMP_NUM_THREADS=1 via make bench).

    python bench/bench_springs.py [N]        (default N = 100000)
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import stiffkit as sk  # noqa: E402
from stiffkit.calib import synth as S  # noqa: E402
from stiffkit.springs import (  # noqa: E402
    evaluate,
    model_vjm,
    smg,  # noqa: E402
)

N = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1].isdigit() else 100_000
N_LOOP = min(N, 2000)  # the per-posture numpy loop is timed on fewer postures
URDF = Path(__file__).resolve().parent.parent / "examples" / "kr270" / "robot.urdf"

# ---------------------------------------------------------------- 6R model
#: link springs: (link, length m, outer/inner diameter m, beam axis in the spring frame)
LINKS = [
    ("base_link", 0.675, 0.50, 0.42, "z"),
    ("link_1", 0.35, 0.45, 0.38, "x"),
    ("link_2", 1.15, 0.30, 0.26, "x"),
    ("link_3", 0.60, 0.22, 0.18, "x"),
    ("link_4", 0.60, 0.18, 0.15, "x"),
    ("link_5", 0.10, 0.16, 0.12, "x"),
    ("link_6", 0.115, 0.14, 0.10, "x"),
]


def kr270_effects() -> list[dict]:
    """6 joint + 7 link springs with values (cast aluminium tubes, E = 70 GPa)."""
    eff = [{"kind": "joint", "target": j["name"], "value": c} for j, c in zip(S.KR270_JOINTS, S.KR270_JOINT_C)]
    for link, length, do, di, axis in LINKS:
        e = {"kind": "link", "target": link, "value": S.beam_compliance(length, 7.0e10, 0.33, do, di).tolist()}
        if axis == "z":
            e["rpy"] = [0.0, -np.pi / 2, 0.0]  # beam x -> frame z
        eff.append(e)
    return eff


def write_kr270(d: Path) -> Path:
    path = d / "kr270_6j7l.toml"
    path.write_text(S.model_toml(kr270_effects(), urdf=str(URDF)))
    return path


def _rodrigues(u, q):
    """(N,3,3) rotations about the unit axis u by angles q (N,)."""
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def _skew(v):
    s = np.zeros(v.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def numpy_inputs(model):
    """What the numpy codes need: chain arrays, joint compliances, 6x6 springs."""
    ch = model.chain
    jc = {k: float(v[0]) for k, v in model.joint_compliances(np.zeros((1, ch.dof))).items()}
    six = {k - 1: C for (st, k), C in model.six_values().items()}
    return ch, jc, six


def numpy_6r_loop(Q, model):
    """Straightforward numpy, one posture at a time: URDF forward kinematics,
    klimchik eq. 2 (J_i C_i J_i^T), K = C^-1."""
    ch, jc, six = numpy_inputs(model)
    out_c, out_k = [], []
    for q in Q:
        R, p, F = np.eye(3), np.zeros(3), []
        for k in range(len(ch.joint_names)):
            p = p + R @ ch.jpos[k]
            R = R @ ch.jrot[k]
            F.append((R, p))
            if ch.qidx[k] > 0:
                R = R @ _rodrigues(ch.jaxis[k], np.array([q[ch.qidx[k] - 1]]))[0]
        pt = p + R @ ch.tpos
        C = np.zeros((6, 6))
        for k, c in jc.items():
            u = F[k][0] @ ch.jaxis[k]
            xi = np.concatenate([np.cross(u, pt - F[k][1]), u])
            C += c * np.outer(xi, xi)
        for k, Cs in six.items():
            Rk, pk = F[k]
            J = np.eye(6)
            J[:3, 3:] = -_skew(pt - pk)
            B = np.zeros((6, 6))
            B[:3, :3] = B[3:, 3:] = Rk
            J = J @ B
            C += J @ Cs @ J.T
        out_c.append(C)
        out_k.append(np.linalg.inv(C))
    return np.array(out_c), np.array(out_k)


def numpy_6r_vec(Q, model):
    """numpy vectorised over postures (batched matmuls, einsum, batched inv)."""
    ch, jc, six = numpy_inputs(model)
    n = Q.shape[0]
    R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    p = np.zeros((n, 3))
    F = []
    for k in range(len(ch.joint_names)):
        p = p + R @ ch.jpos[k]
        R = R @ ch.jrot[k]
        F.append((R, p))
        if ch.qidx[k] > 0:
            R = R @ _rodrigues(ch.jaxis[k], Q[:, ch.qidx[k] - 1])
    pt = p + R @ ch.tpos
    C = np.zeros((n, 6, 6))
    for k, c in jc.items():
        u = F[k][0] @ ch.jaxis[k]
        xi = np.concatenate([np.cross(u, pt - F[k][1]), u], axis=1)
        C += c * xi[:, :, None] * xi[:, None, :]
    for k, Cs in six.items():
        Rk, pk = F[k]
        J = np.broadcast_to(np.eye(6), (n, 6, 6)).copy()
        J[:, :3, 3:] = -_skew(pt - pk)
        B = np.zeros((n, 6, 6))
        B[:, :3, :3] = B[:, 3:, 3:] = Rk
        J = J @ B
        C += J @ Cs @ np.swapaxes(J, -1, -2)
    return C, np.linalg.inv(C)


def transfer_b(r):
    t = np.broadcast_to(np.eye(6), r.shape[:-1] + (6, 6)).copy()
    t[..., :3, 3:] = -_skew(r)
    return t


def rot6_b(R):
    b = np.zeros(R.shape[:-2] + (6, 6))
    b[..., :3, :3] = R
    b[..., 3:, 3:] = R
    return b


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
                Wb = transfer_b(b - P)  # twist at P -> twist at b
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
        from stiffkit._core import springs as core

        self.mod, self.orig, self.t = core._springs, core._springs.sk_spring_tree, 0.0

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
    Q = S.random_postures(N, S.KR270_RANGES, rng)
    with tempfile.TemporaryDirectory() as d:
        model = sk.load_model(write_kr270(Path(d)))
    print(f"6R KR-270-like, {len(model.springs())} springs (6 joint + 7 link), load_model(...), N = {N}")
    t_c, C = timeit(lambda: model.tool_compliance(Q), 5)
    r_c = row("load_model(...).tool_compliance(Q), one core call", N, t_c)
    t_s, (C2, K, rank, ok) = timeit(lambda: model.stiffness(Q), 5)
    r_core = row("load_model(...).stiffness(Q) (C, K, rank)", N, t_s)
    t_t, res = timeit(lambda: model_vjm(model, Q), 3)
    row("same model, spring-tree evaluator (model_vjm)", N, t_t)
    t_vec, (Cv, Kv) = timeit(lambda: numpy_6r_vec(Q, model), 1)
    r_vec = row("numpy vectorised (FK + eq. 2 + inv)", N, t_vec, r_c)
    t_loop, (Cl, Kl) = timeit(lambda: numpy_6r_loop(Q[:N_LOOP], model), 1)
    r_loop = row("numpy loop over postures (FK + eq. 2 + inv)", N_LOOP, t_loop, r_c)
    err = np.abs(C - Cv).max() / np.abs(Cv).max()
    errl = np.abs(C[:N_LOOP] - Cl).max() / np.abs(Cl).max()
    errk = np.max(np.abs(K - Kv).max(axis=(1, 2)) / np.abs(Kv).max(axis=(1, 2)))
    errt = np.abs(res.compliance - C).max() / np.abs(C).max()
    print(
        f"  agreement: compliance core vs numpy {err:.1e} (vectorised), {errl:.1e} (loop); stiffness "
        f"{errk:.1e}; chain vs spring tree {errt:.1e} (relative); rank 6 at {np.mean(ok) * 100:.1f} %"
    )
    print(
        f"  speed-up of tool_compliance: x{r_c / r_loop:.0f} vs numpy loop, x{r_c / r_vec:.1f} vs numpy "
        f"vectorised; goal >= 1e5 postures/s: {'met' if r_c >= 1e5 else 'NOT met'} ({r_c:.3g}/s), "
        f">= 50x numpy loop: {'met' if r_c / r_loop >= 50 else 'NOT met'}"
    )
    print(f"  with K and rank (stiffness): {r_core:.3g}/s, x{r_core / r_loop:.0f} vs numpy loop")

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
    r_core = N / (t_core + t_build)  # numpy below does its own inverse kinematics
    t_vec, Kv = timeit(lambda: numpy_smg_vec(P, theta, sl, g), 1)
    r_vec = row("numpy vectorised (eqs. 22-30, with IK)", N, t_vec, r_core)
    m = min(N, N_LOOP)
    t_loop, _ = timeit(lambda: [numpy_smg_vec(P[i : i + 1], theta[i : i + 1], sl, g) for i in range(m)], 1)
    r_loop = row("numpy loop over postures (eqs. 22-30, with IK)", m, t_loop, r_core)
    err = np.max(np.abs(res.stiffness - Kv).max(axis=(1, 2)) / np.abs(Kv).max(axis=(1, 2)))
    print(f"  agreement core vs numpy eqs. 22-30: stiffness {err:.1e} (relative)")
    print(f"  speed-up: x{r_core / r_loop:.0f} vs numpy loop, x{r_core / r_vec:.1f} vs numpy vectorised")


if __name__ == "__main__":
    main()
