"""Generalised springs, VJM and parallel robots: closed forms and invariances.

Every test asserts numbers: the tree results against the transfer matrices
of Taghvaeipour et al. eqs. 8, 12, 16, 22, the cantilever of Pashkevich et
al. eq. 22, hand-derived planar K_C, and symmetries the geometry demands.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import stiffkit as sk
from stiffkit.springs import Joint, Spring, evaluate, load_link_compliance, parallel, series, smg, stiffness_indices
from stiffkit.springs import orthoglide as og

E_STEEL, NU = 2.0e11, 0.3


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def T(r):
    """Eq. 8: twist transfer x_B = T(r) x_A, r = B - A."""
    t = np.eye(6)
    t[:3, 3:] = -skew(r)
    return t


def rot6(R):
    b = np.zeros((6, 6))
    b[:3, :3] = b[3:, 3:] = R
    return b


def random_rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


@pytest.fixture
def beam_c():
    sec = sk.section_properties("rectangle", [0.02, 0.03], NU)
    return sk.cantilever_compliance(0.5, E_STEEL, NU, sec)


def relerr(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


class TestSeriesParallel:
    def test_colocated_series_sums_compliances(self, beam_c):
        p = [0.3, -0.1, 0.2]
        res = evaluate(series(Spring(beam_c, pos=p), Spring(2.5 * beam_c, pos=p)), tool=p)
        assert relerr(res.compliance[0], 3.5 * beam_c) < 1e-15
        assert relerr(res.stiffness[0], np.linalg.inv(3.5 * beam_c)) < 1e-9
        assert res.rank[0] == 6

    def test_lever_transforms_by_transfer_matrices(self, beam_c):
        rng = np.random.default_rng(3)
        R = random_rotation(rng)
        a, b = np.array([0.1, 0.2, -0.3]), np.array([0.7, -0.4, 0.5])
        res = evaluate(Spring(beam_c, pos=a, rot=R), tool=b)
        want = T(b - a) @ rot6(R) @ beam_c @ rot6(R).T @ T(b - a).T
        assert relerr(res.compliance[0], want) < 1e-14
        # the same spring given as a stiffness moves as eq. 16: W^T K W, W = T(a - b)
        k = np.linalg.inv(beam_c)
        res_k = evaluate(Spring(k, pos=a, rot=R, kind="stiffness"), tool=b)
        W = T(a - b)
        assert relerr(res_k.stiffness[0], W.T @ rot6(R) @ k @ rot6(R).T @ W) < 1e-14
        assert relerr(res_k.compliance[0], want) < 1e-9

    def test_parallel_identical_springs_double_stiffness(self, beam_c):
        p = [0.5, 0, 0]
        res = evaluate(parallel(Spring(beam_c, pos=p), Spring(beam_c, pos=p)), tool=[0.2, 0.1, 0])
        single = evaluate(Spring(beam_c, pos=p), tool=[0.2, 0.1, 0])
        assert relerr(res.stiffness[0], 2 * single.stiffness[0]) < 1e-12
        assert relerr(res.compliance[0], 0.5 * single.compliance[0]) < 1e-12

    def test_parallel_at_different_points_is_eq16(self, beam_c):
        rng = np.random.default_rng(7)
        R1, R2 = random_rotation(rng), random_rotation(rng)
        p1, p2, o = np.array([0.4, 0, 0]), np.array([0, 0.3, 0.1]), np.array([0.1, 0.1, 0.1])
        res = evaluate(parallel(Spring(beam_c, pos=p1, rot=R1), Spring(beam_c, pos=p2, rot=R2)), tool=o)
        k = np.linalg.inv(beam_c)
        W1, W2 = T(p1 - o), T(p2 - o)
        want = W1.T @ rot6(R1) @ k @ rot6(R1).T @ W1 + W2.T @ rot6(R2) @ k @ rot6(R2).T @ W2
        assert relerr(res.stiffness[0], want) < 1e-9

    @pytest.mark.parametrize("n", [1, 2, 5, 17])
    def test_chain_of_beams_is_the_cantilever(self, n):
        """n beam springs end to end = one cantilever of the total length (eq. 22)."""
        sec = sk.section_properties("rectangle", [0.02, 0.03], NU)
        L = 1.2
        rng = np.random.default_rng(n)
        R = random_rotation(rng)  # the whole beam along R's x axis
        o = np.array([0.3, -0.2, 0.1])
        seg = sk.cantilever_compliance(L / n, E_STEEL, NU, sec)
        chain = series(*[Spring(seg, pos=o + (i + 1) * L / n * R[:, 0], rot=R) for i in range(n)])
        res = evaluate(chain, tool=o + L * R[:, 0], tool_rot=R)
        whole = sk.cantilever_compliance(L, E_STEEL, NU, sec)
        assert relerr(res.compliance[0], whole) < 1e-12

    def test_series_with_a_rigid_spring_keeps_compliance(self, beam_c):
        """A rigid spring (zero compliance) has no stiffness: fine in series."""
        res = evaluate(series(Spring(np.zeros((6, 6)), pos=[1, 0, 0]), Spring(beam_c, pos=[1, 0, 0])), tool=[1, 0, 0])
        assert relerr(res.compliance[0], beam_c) < 1e-15 and res.nrigid[0] == 0

    def test_rigid_spring_alone_reports_six_rigid_wrenches(self):
        res = evaluate(Spring(np.zeros((6, 6))), tool=[1, 0, 0])
        assert res.nrigid[0] == 6 and res.rank[0] == 0
        assert np.all(res.stiffness[0] == 0)


class TestPassiveJointsAndPi:
    def test_flexible_body_behind_a_revolute_joint_loses_one_rank(self, beam_c):
        """s3.2: a passive revolute joint at the first end drops the rank by one."""
        a = np.array([0.0, 0, 0])
        res = evaluate(
            series(Joint("revolute", [0, 0, 1], a, passive=True), Spring(beam_c, pos=[0.5, 0, 0])), tool=[0.5, 0, 0]
        )
        assert res.rank[0] == 5 and res.nfree[0] == 1
        free = res.free_twists(0)[:, 0]
        xi = np.array([0, 0.5, 0, 0, 0, 1.0])  # rotation about z through a, seen at the tool
        assert abs(abs(free @ xi) / np.linalg.norm(free) / np.linalg.norm(xi) - 1) < 1e-12
        assert np.linalg.norm(res.stiffness[0] @ xi) < 1e-9 * np.linalg.norm(res.stiffness[0])

    def test_bordered_system_schur_complement(self, beam_c):
        """Leg stiffness with passive joints = top-left block of the inverse bordered matrix."""
        rng = np.random.default_rng(11)
        springs = [Spring(beam_c, pos=rng.normal(size=3) * 0.3, rot=random_rotation(rng)) for _ in range(3)]
        joints = [Joint("revolute", rng.normal(size=3), rng.normal(size=3) * 0.3, passive=True) for _ in range(2)]
        tool = np.array([0.2, 0.1, -0.1])
        res = evaluate(series(*springs, *joints), tool=tool)
        C = sum(T(tool - s.pos) @ rot6(s.rot) @ s.matrix @ rot6(s.rot).T @ T(tool - s.pos).T for s in springs)
        F = np.array(
            [
                np.concatenate(
                    [np.cross(j.axis / np.linalg.norm(j.axis), tool - j.point), j.axis / np.linalg.norm(j.axis)]
                )
                for j in joints
            ]
        ).T
        M = np.block([[C, F], [F.T, np.zeros((2, 2))]])
        K = np.linalg.inv(M)[:6, :6]
        assert res.rank[0] == 4
        assert relerr(res.stiffness[0], K) < 1e-8

    def test_pi_joint_of_rigid_links_allows_pure_translation(self):
        """Eq. 23 / s3.3: rigid parallelogram links -> one free motion, a pure
        translation normal to the links in the plane of the parallelogram."""
        L, d, n = 0.3, 0.1, np.array([0, 0, 1.0])
        ang = 0.4
        u = np.array([np.cos(ang), np.sin(ang), 0])
        Bp, Bm = np.array([0.0, d / 2, 0]), np.array([0.0, -d / 2, 0])
        Cp, Cm = Bp + L * u, Bm + L * u
        pi = parallel(
            series(Joint("revolute", n, Bp, passive=True), Joint("revolute", n, Cp, passive=True)),
            series(Joint("revolute", n, Bm, passive=True), Joint("revolute", n, Cm, passive=True)),
        )
        res = evaluate(pi, tool=(Cp + Cm) / 2 + [0.05, 0.02, 0.03])
        assert res.nfree[0] == 1 and res.nrigid[0] == 5
        f = res.free_twists(0)[:, 0]
        assert np.linalg.norm(f[3:]) < 1e-12 * np.linalg.norm(f[:3])  # no rotation
        t = f[:3] / np.linalg.norm(f[:3])
        assert abs(abs(t @ np.cross(n, u)) - 1) < 1e-12  # normal to the links, in plane

    def test_pi_joint_of_beams_keeps_the_translation_free(self):
        sec = sk.section_properties("circle", [0.01], 0.33)
        L, d, n = 0.3, 0.1, np.array([0, 0, 1.0])
        c = sk.cantilever_compliance(L, 7e10, 0.33, sec)
        links = []
        for s in (+1, -1):
            B, C = np.array([0, s * d / 2, 0]), np.array([L, s * d / 2, 0])
            links.append(
                series(Joint("revolute", n, B, passive=True), Spring(c, pos=C), Joint("revolute", n, C, passive=True))
            )
        res = evaluate(parallel(*links), tool=[L, 0, 0])
        assert res.rank[0] == 5 and res.nfree[0] == 1 and res.nrigid[0] == 0
        f = res.free_twists(0)[:, 0]
        assert abs(abs(f[1]) / np.linalg.norm(f) - 1) < 1e-12  # translation along y
        # eq. 23 with one passive joint per link (the report's K_l) is of full rank
        res1 = evaluate(
            parallel(
                *[
                    series(Joint("revolute", n, [0, s * d / 2, 0], passive=True), Spring(c, pos=[L, s * d / 2, 0]))
                    for s in (1, -1)
                ]
            ),
            tool=[L, 0, 0],
        )
        assert res1.rank[0] == 6


class TestSerialVJM:
    def test_planar_two_link_arm_against_hand_derived_kc(self):
        """K_C = (J k^-1 J^T)^-1 = J^-T diag(k1, k2) J^-1 for the planar 2R arm."""
        l1, l2, t1, t2, k1, k2 = 0.4, 0.3, 0.3, 0.9, 1.0e4, 5.0e3
        A2 = np.array([l1 * np.cos(t1), l1 * np.sin(t1), 0])
        P = A2 + [l2 * np.cos(t1 + t2), l2 * np.sin(t1 + t2), 0]
        z = [0, 0, 1.0]
        res = evaluate(
            series(Joint("revolute", z, [0, 0, 0], compliance=1 / k1), Joint("revolute", z, A2, compliance=1 / k2)),
            tool=P,
        )
        s1, s12, c1, c12 = np.sin(t1), np.sin(t1 + t2), np.cos(t1), np.cos(t1 + t2)
        J = np.array([[-l1 * s1 - l2 * s12, -l2 * s12], [l1 * c1 + l2 * c12, l2 * c12]])
        Ji = np.array([[J[1, 1], -J[0, 1]], [-J[1, 0], J[0, 0]]]) / (l1 * l2 * np.sin(t2))
        KC = Ji.T @ np.diag([k1, k2]) @ Ji
        assert relerr(np.linalg.inv(res.compliance[0][:2, :2]), KC) < 1e-13
        # two joint springs: two elastic directions, the other four carried rigidly
        assert res.nrigid[0] == 4 and res.rank[0] == 2

        # planar 3R: three elastic directions in the plane; stretched along x,
        # its Jacobian loses rank and a force along the arm is carried rigidly
        def arm3(q):
            pts = np.cumsum([[0, 0, 0]] + [[0.3 * np.cos(a), 0.3 * np.sin(a), 0] for a in np.cumsum(q)], axis=0)
            return evaluate(series(*[Joint("revolute", z, pts[i], compliance=1e-5) for i in range(3)]), tool=pts[3])

        bent, stretched = arm3([0.2, 0.5, -0.3]), arm3([0.0, 0.0, 0.0])
        assert bent.nrigid[0] == 3 and stretched.nrigid[0] == 4
        g = stretched.rigid_wrenches(0)
        fx = np.array([1.0, 0, 0, 0, 0, 0])
        assert np.linalg.norm(g @ np.linalg.lstsq(g, fx, rcond=None)[0] - fx) < 1e-12
        assert np.linalg.norm(bent.rigid_wrenches(0).T @ fx) < 1e-12

    def test_six_joints_and_seven_links_equal_klimchik_eq2(self, beam_c):
        """C = J_theta k^-1 J_theta^T + sum of link compliances moved to the tool."""
        rng = np.random.default_rng(5)
        pts = np.cumsum(rng.normal(size=(7, 3)) * 0.2, axis=0)
        axes = rng.normal(size=(6, 3))
        kj = rng.uniform(1e5, 1e6, 6)
        rots = [random_rotation(rng) for _ in range(7)]
        tool = pts[-1] + [0.1, 0, 0]
        parts = [Spring(beam_c, pos=pts[0], rot=rots[0])]
        for i in range(6):
            parts += [
                Joint("revolute", axes[i], pts[i], compliance=1 / kj[i]),
                Spring(beam_c, pos=pts[i + 1], rot=rots[i + 1]),
            ]
        res = evaluate(series(*parts), tool=tool)
        Jt = np.array(
            [
                np.concatenate([np.cross(a / np.linalg.norm(a), tool - p), a / np.linalg.norm(a)])
                for a, p in zip(axes, pts[:6])
            ]
        ).T
        C = Jt @ np.diag(1 / kj) @ Jt.T + sum(
            T(tool - p) @ rot6(R) @ beam_c @ rot6(R).T @ T(tool - p).T for p, R in zip(pts, rots)
        )
        assert relerr(res.compliance[0], C) < 1e-13
        assert relerr(res.stiffness[0], np.linalg.inv(C)) < 1e-8

    def test_serial_vjm_six_joints_kc_and_wrist_singularity(self):
        """6 joint springs only: K_C = J^-T k J^-1 where J is square and
        regular; at a wrist singularity (axes 4 and 6 aligned) K_C does not
        exist and the rigid wrench is the one with J^T w = 0."""
        from stiffkit.springs import serial_vjm

        kj = np.array([3e6, 2e6, 1e6, 4e5, 3e5, 2e5])
        wc = np.array([0.9, 0.1, 1.2])  # wrist centre

        def chain(q5):
            # wrist: axis 4 along x, axis 5 along y, axis 6 turned by q5 about y
            axes = np.array(
                [[0, 0, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [np.cos(q5), 0, -np.sin(q5)]], float
            )
            pts = np.array([[0, 0, 0.4], [0.1, 0, 0.6], [0.1, 0, 1.2], wc, wc, wc], float)
            return axes, pts

        A0, P0 = chain(0.0)  # axes 4 and 6 both along x: singular
        A1, P1 = chain(0.7)
        tool = wc + [0.2, 0.05, -0.1]
        res = serial_vjm(
            np.stack([A1, A0]),
            np.stack([P1, P0]),
            1 / kj,
            np.zeros((0, 6, 6)),
            np.zeros((2, 0, 3)),
            np.zeros((2, 0, 3, 3)),
            tool,
        )
        J = np.array(
            [np.r_[np.cross(a / np.linalg.norm(a), tool - p), a / np.linalg.norm(a)] for a, p in zip(A1, P1)]
        ).T
        Ji = np.linalg.inv(J)
        assert list(res.stiffness_exists) == [True, False]
        assert relerr(res.stiffness[0], Ji.T @ np.diag(kj) @ Ji) < 1e-9
        J0 = np.array([np.r_[np.cross(a, tool - p), a] for a, p in zip(A0, P0)]).T
        w = res.rigid_wrenches(1)[:, 0]
        assert res.nrigid[1] == 1
        assert np.linalg.norm(J0.T @ w) < 1e-10 * np.linalg.norm(J0) * np.linalg.norm(w)


class TestParallelRobots:
    def test_three_cyclic_legs_give_a_cyclic_stiffness(self, beam_c):
        """Three identical legs related by the 120 deg turn about (1,1,1): the
        platform stiffness commutes with that turn."""
        Pc = np.array([[0, 0, 1.0], [1, 0, 0], [0, 1, 0]])  # e_x -> e_y -> e_z
        rng = np.random.default_rng(2)
        R0 = random_rotation(rng)
        legs = []
        for m in range(3):
            Q = np.linalg.matrix_power(Pc, m)
            p1, p2 = Q @ [-0.4, 0.05, 0], Q @ [-0.1, 0.02, 0.01]
            legs.append(
                series(
                    Spring(beam_c, pos=p1, rot=Q @ R0),
                    Joint("revolute", Q @ [0, 1.0, 0], p1, passive=True),
                    Spring(2 * beam_c, pos=p2, rot=Q @ R0),
                )
            )
        res = evaluate(parallel(*legs), tool=[0, 0, 0])
        K = res.stiffness[0]
        assert res.rank[0] == 6
        assert relerr(rot6(Pc) @ K @ rot6(Pc).T, K) < 1e-12

    def test_orthoglide_isotropic_point_is_symmetric(self):
        res = og.compliance(og.isotropic_point()[None])
        C = res.compliance[0]
        assert res.rank[0] == 6
        Pc = np.array([[0, 0, 1.0], [1, 0, 0], [0, 1, 0]])
        assert relerr(rot6(Pc) @ C @ rot6(Pc).T, C) < 1e-10
        ct, cr = np.diag(C)[:3], np.diag(C)[3:]
        assert np.ptp(ct) < 1e-10 * ct[0] and np.ptp(cr) < 1e-10 * cr[0]
        # translation and rotation decoupled at the isotropic point, translations isotropic
        assert np.abs(C[:3, 3:]).max() < 1e-10 * np.sqrt(ct[0] * cr[0])
        assert np.abs(C[:3, :3] - ct[0] * np.eye(3)).max() < 1e-10 * ct[0]
        # same order as Table 8 (3.02e-4 mm/N, 2.46e-7 rad/(N mm) from FEA)
        assert 1e-4 < ct[0] * 1e3 < 1e-3 and 1e-8 < cr[0] * 1e-3 < 1e-6

    def test_orthoglide_rigid_bars_and_axles_leave_the_feet(self):
        """Rigid bars and axles: at the isotropic point the x force goes through
        the x foot alone (k_tran = foot k11) and a couple about e_z is shared by
        the x foot (about its hinge normal) and the z foot (about its actuator
        axis), the y leg being free about e_z: k_rot = (1/c_nn + 1/c_uu)^-1.
        Distinct diagonal foot entries, so a wrong frame shows."""
        foot = np.diag([2.0e-7, 3.0e-7, 5.0e-7, 1.1e-4, 1.7e-4, 0.6e-4])
        links = {"foot": foot, "axle": np.zeros((6, 6)), "bar": np.zeros((6, 6))}
        res = og.compliance(og.isotropic_point()[None], links)
        C = res.compliance[0]
        assert res.rank[0] == 6
        e = np.eye(3)
        for i in range(3):
            Rf = og.foot_axes(i)
            a = e[(i + 1) % 3]
            cfoot = Rf @ foot[3:, 3:] @ Rf.T  # foot rotational compliance, world axes
            n = np.cross(a, e[i])  # hinge normal at the isotropic point
            assert Rf[:, 0] @ e[i] == 1.0 and abs(Rf[:, 2] @ a) == 1.0
            # the axis about which leg i's foot yields under a couple about n = e_k
            k = int(np.argmax(np.abs(n)))
            j = k  # the leg whose actuator axis is e_k
            Rj = og.foot_axes(j)
            c_uu = (Rj @ foot[3:, 3:] @ Rj.T)[k, k]
            c_nn = cfoot[k, k]
            assert C[3 + k, 3 + k] == pytest.approx(1 / (1 / c_nn + 1 / c_uu), rel=1e-10)
            assert C[i, i] == pytest.approx(foot[0, 0], rel=1e-10)
        # the foot's z (its stiffest rotation, 0.6e-4) is on the R joint's axis: it never shows
        assert_allclose(np.diag(C)[3:], 1 / (1 / 1.1e-4 + 1 / 1.7e-4), rtol=1e-10)

    def test_orthoglide_against_table8(self):
        """Isotropic point with the Table 7 FEA links against Table 8 (FEA,
        parabolic mesh: 3.02e-4 mm/N, 2.46e-7 rad/(N mm)) and, with rigid
        axles, against the paper's lumped model with rigid axis (3.10, 2.31)."""

        def iso(links):
            C = og.compliance(og.isotropic_point()[None], links).compliance[0]
            return C[0, 0] * 1e3 / 1e-4, C[3, 3] * 1e-3 / 1e-7

        fea = og.link_compliances("fea")
        kt, kr = iso(fea)
        ft, fr = og.TABLE8["FEA (parabolic mesh)"]
        assert abs(kt / ft - 1) < 0.10 and abs(kr / fr - 1) < 0.05
        kt, kr = iso(dict(fea, axle=np.zeros((6, 6))))
        rt, rr = og.TABLE8["lump model with 6-dof springs with rigid axis"]
        assert abs(kt / rt - 1) < 0.05 and abs(kr / rr - 1) < 0.05
        # the translational part is the foot along the actuator plus two bars in parallel
        assert kt == pytest.approx((fea["foot"][0, 0] + fea["bar"][0, 0] / 2) * 1e3 / 1e-4, rel=1e-10)

    def test_orthoglide_rank_drop_near_parallel_singularity(self):
        """At P = t(1,1,1), t -> L/sqrt(3), the three bars become parallel: two
        translations normal to them lose their stiffness (det = (s+2t)(s-t)^2)."""
        L = og.OrthoglideGeometry().L
        ts = L / np.sqrt(3) * (1 - np.array([1e-1, 1e-2, 1e-3, 1e-4]))
        res = og.compliance(np.outer(ts, [1, 1, 1]))
        assert np.all(res.nfree == 0) and np.all(np.diff(res.ratio) < 0)
        near = og.compliance([L / np.sqrt(3) * (1 - 1e-9) * np.ones(3)])
        assert near.nfree[0] == 2 and near.rank[0] == 4
        f = near.free_twists(0)
        n = np.ones(3) / np.sqrt(3)
        # the free motions: translations normal to (1,1,1), no rotation
        assert np.abs(n @ f[:3]).max() < 1e-6 * np.abs(f[:3]).max()
        assert np.abs(f[3:]).max() < 1e-4 * np.abs(f[:3]).max() / L

    def test_orthoglide_units_mm_and_m_agree(self):
        """The same robot in mm (compliance in mm/N, rad/(N mm)) gives the same result."""
        g_m, g_mm = og.OrthoglideGeometry(), og.OrthoglideGeometry(L=310.0, d=100.0, r=31.0, cube=200.0)
        # SI -> mm units: x_mm = Dx x, w_mm = Dw w, C_mm = Dx C Dw^-1
        Dx, Dwi = np.diag([1e3, 1e3, 1e3, 1, 1, 1]), np.diag([1, 1, 1, 1e-3, 1e-3, 1e-3])
        links_m = og.link_compliances("beam", g_m)
        links_mm = {k: Dx @ v @ Dwi for k, v in links_m.items()}
        P = np.array([[0.03, -0.05, 0.08], [0.1, 0.1, -0.1]])
        r_m = og.compliance(P, links_m, g_m)
        r_mm = og.compliance(P * 1e3, links_mm, g_mm)
        for i in range(2):
            cm, cmm = r_m.compliance[i], r_mm.compliance[i]
            assert relerr(cmm[:3, :3], cm[:3, :3] * 1e3) < 1e-10
            assert relerr(cmm[3:, 3:], cm[3:, 3:] * 1e-3) < 1e-10
            assert np.abs(cmm[:3, 3:] - cm[:3, 3:]).max() < 1e-10 * np.abs(cm[:3, 3:]).max()
        assert np.all(r_m.ratio == pytest.approx(r_mm.ratio, rel=1e-10))

    def test_smg_tree_equals_eqs_22_to_30(self):
        """The spring tree of the SMG against the report's formulas, term by term."""
        g = smg.SMGGeometry()
        links = smg.smg_links()
        tau, P, theta = smg.trajectory(7, g)
        res = smg.stiffness(P, theta, links, g)
        z = np.array([0, 0, 1.0])

        def condense(K, xi):  # eqs. 29-30 / s3.2: eliminate a passive joint of twist xi
            return K - np.outer(K @ xi, K @ xi) / (xi @ K @ xi)

        for i in range(len(tau)):
            p = P[i]
            Ktot = np.zeros((6, 6))
            for J in (0, 1):
                S, E, W, h = (a[0] for a in smg.limb_points(J, P[i : i + 1], theta[i : i + 1], g))
                n = np.cross(h, z)
                Kpi = []
                for A, B, wid, c in ((S, E, g.h1, links["proximal"]), (E, W, g.h2, links["distal"])):
                    Kp = np.zeros((6, 6))
                    for s in (0.5, -0.5):
                        a, b = A + s * wid * z, B + s * wid * z
                        u = (b - a) / np.linalg.norm(b - a)
                        R = np.stack([u, np.cross(n, u), n], axis=1)
                        Kb = rot6(R) @ np.linalg.inv(c) @ rot6(R).T  # link at its end b
                        Kb = T(a - b).T @ condense(T(b - a).T @ Kb @ T(b - a), np.r_[np.zeros(3), n]) @ T(a - b)
                        W1 = T(b - p)  # eq. 12
                        Kp += W1.T @ Kb @ W1  # eq. 23
                    Kpi.append(Kp)
                KP, KD = Kpi
                Pm = KD + KP  # eq. 21 (W = 1 at p)
                KJ = KD - KD @ np.linalg.solve(Pm, KD)  # eqs. 22, 25
                zeta = np.r_[np.cross(z, p - W), z]  # wrist joint seen at p
                Ktot += condense(KJ, zeta)  # eqs. 26-30
            assert relerr(res.stiffness[i], Ktot) < 1e-8

    def test_link_json_file_is_accepted(self, tmp_path, beam_c):
        import json

        f = tmp_path / "bar.json"
        f.write_text(json.dumps({"compliance": (2 * beam_c).tolist()}))
        assert_allclose(load_link_compliance(f), 2 * beam_c)
        links = og.link_compliances("beam", files={"bar": f})
        assert_allclose(links["bar"], 2 * beam_c)


class TestIndices:
    def test_closed_form_and_unit_invariance(self):
        rng = np.random.default_rng(9)
        A = rng.normal(size=(6, 6))
        K = A @ A.T * np.diag([1e6, 1e6, 1e6, 1e2, 1e2, 1e2]) ** 0.5 @ np.eye(6)
        K = 0.5 * (K + K.T) + 6 * np.eye(6)
        l = 0.35
        idx = stiffness_indices(K, l)
        k11, k12, k22 = K[:3, :3], K[:3, 3:], K[3:, 3:]
        kt = np.sqrt((l**2 * np.sum(k11**2) + np.sum(k12**2)) / 3)
        kr = np.sqrt((np.sum(k12**2) + np.sum(k22**2) / l**2) / 3)
        assert idx.kappa_t[0] == pytest.approx(kt, rel=1e-12)
        assert idx.kappa_r[0] == pytest.approx(kr, rel=1e-12)
        # mm: K11 in N/mm, K12 in N, K22 in N mm, l in mm
        Kmm = K.copy()
        Kmm[:3, :3] *= 1e-3
        Kmm[3:, 3:] *= 1e3
        idx_mm = stiffness_indices(Kmm, l * 1e3)
        assert idx_mm.kappa_t[0] == pytest.approx(idx.kappa_t[0], rel=1e-12)
        assert idx_mm.kappa_r[0] == pytest.approx(idx.kappa_r[0], rel=1e-12)
        assert_allclose(idx_mm.lambda_f, idx.lambda_f, rtol=1e-10)
        # the literal formula (l = 1 in the input unit) is not invariant
        assert stiffness_indices(Kmm, 1.0).kappa_t[0] != pytest.approx(stiffness_indices(K, 1.0).kappa_t[0], rel=1e-3)

    def test_smg_indices_in_mm_equal_indices_in_m(self):
        tau, P, theta, res, idx = smg.indices_along_trajectory(21)
        Kmm = res.stiffness.copy()
        Kmm[:, :3, :3] *= 1e-3
        Kmm[:, 3:, 3:] *= 1e3
        idx_mm = stiffness_indices(Kmm, smg.SMGGeometry().l1 * 1e3)
        assert_allclose(idx_mm.kappa_t, idx.kappa_t, rtol=1e-12)
        assert_allclose(idx_mm.kappa_r, idx.kappa_r, rtol=1e-12)
        assert np.all(res.rank == 6)


class TestErrors:
    def test_bad_inputs_raise(self, beam_c):
        with pytest.raises(sk.InputError):
            Spring(np.ones((5, 5)))
        with pytest.raises(sk.InputError):
            Joint("helical", [0, 0, 1])
        with pytest.raises(sk.InputError):
            evaluate(Spring(beam_c), lscale=-1.0)
        with pytest.raises(sk.InputError):
            og.compliance([[0.0, 0.4, 0.0]])  # out of reach
        with pytest.raises(sk.InputError, match="rotation"):
            Spring(beam_c, rot=2 * np.eye(3))
        with pytest.raises(sk.InputError, match="NaN"):
            evaluate(Spring(beam_c), tool=[np.nan, 0, 0])
        with pytest.raises(sk.InputError, match="postures"):
            evaluate(series(Spring(beam_c, pos=np.zeros((3, 3))), Spring(beam_c, pos=np.zeros((4, 3)))))
