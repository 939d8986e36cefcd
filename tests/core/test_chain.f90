!> Unit tests of a serial chain's elastostatics on its tree model
!> (sk_chain_tree, the point compliance of sk_tree_point): a planar two-link arm against its hand-derived
!> compliance, the deflection rows' basis (their Jacobian, sk_deflect)
!> against the tool compliance (two code paths of the core), and the tool
!> compliance and the springs' Jacobians against the closed-form J_s of
!> every spring type (sk_spatial's block forms at sk_chain's frames).
program test_chain
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: skew
    use sk_linalg, only: eye
    use sk_spatial, only: sym_index, nsym, revolute_twist, twist_transfer, blockdiag_rot
    use sk_laws, only: law_linear, law_spring6
    use sk_tree_model, only: tree_model
    use sk_tree_point, only: compliance_batch, twists_at
    use sk_chain, only: chain_frames, chain_poses_batch, spring_joint, check_chain
    use sk_chain_tree, only: chain_tree_model
    use sk_deflect, only: deflection_rows
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
    implicit none (type, external)

    call test_planar_two_link()
    call test_basis_matches_compliance()
    call test_block_terms_equal_jacobian_products()
    call finish('chain')

contains

    !> Planar arm: joints about z at the origin and at (l1,0,0) of link 1,
    !> tool at l2 along link 2. Tool twist from joint i: [z x (p - p_i); z].
    subroutine test_planar_two_link()
        real(dp) :: jrot(3, 3, 3), jpos(3, 3), jaxis(3, 3), q(2, 1), cs(6, 6, 2), cj(2, 1)
        real(dp) :: c(6, 6, 1), k(6, 6, 1), ch(6, 6), l1, l2, c1, c2, x, y, x2, y2
        integer(ip) :: qidx(3), stype(2), sidx(2), rank(1), kinfo(1), info
        l1 = 0.7_dp; l2 = 0.4_dp; c1 = 2.0e-6_dp; c2 = 5.0e-6_dp
        jrot = 0
        jrot(:, :, 1) = eye(3); jrot(:, :, 2) = eye(3); jrot(:, :, 3) = eye(3)
        jpos = 0
        jpos(1, 2) = l1
        jpos(1, 3) = l2
        jaxis = 0
        jaxis(3, 1) = 1; jaxis(3, 2) = 1
        qidx = [1, 2, 0]
        q(:, 1) = [0.3_dp, 0.9_dp]
        stype = [1, 1]
        sidx = [1, 2]
        cs = 0
        cj(:, 1) = [c1, c2]
        call tool_compliance_batch(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], stype, sidx, &
            cs, cj, q, c, k, rank, kinfo, info)
        call expect(info == sk_ok, 'planar: info')
        ! hand-derived: joint 1 at origin, joint 2 at (l1 cos q1, l1 sin q1)
        x = l1*cos(q(1, 1)) + l2*cos(q(1, 1) + q(2, 1))
        y = l1*sin(q(1, 1)) + l2*sin(q(1, 1) + q(2, 1))
        x2 = x - l1*cos(q(1, 1))
        y2 = y - l1*sin(q(1, 1))
        ch = 0
        ch(1, 1) = c1*y*y + c2*y2*y2
        ch(1, 2) = -c1*x*y - c2*x2*y2
        ch(2, 1) = ch(1, 2)
        ch(2, 2) = c1*x*x + c2*x2*x2
        ch(1, 6) = -c1*y - c2*y2
        ch(6, 1) = ch(1, 6)
        ch(2, 6) = c1*x + c2*x2
        ch(6, 2) = ch(2, 6)
        ch(6, 6) = c1 + c2
        call expect(maxval(abs(c(:, :, 1) - ch)) < 1e-15_dp, 'planar: compliance equals the hand-derived one')
        call expect(rank(1) == 2 .and. kinfo(1) == sk_err_singular, 'planar: rank 2 (two joints), no stiffness')
        ! a negative joint compliance or an indefinite 6x6 spring is refused
        cj(:, 1) = [c1, -c2]
        call tool_compliance_batch(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], stype, sidx, &
            cs, cj, q, c, k, rank, kinfo, info)
        call expect(info == sk_err_indefinite, 'planar: negative joint compliance refused')
        cj(:, 1) = [c1, c2]
        stype = [1, 3]
        cs(:, :, 2) = eye(6)
        cs(1, 1, 2) = -1
        call tool_compliance_batch(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], stype, sidx, &
            cs, cj, q, c, k, rank, kinfo, info)
        call expect(info == sk_err_indefinite, 'planar: indefinite base spring refused')
        cs(1, 1, 2) = huge(1.0_dp)
        cs(2, 2, 2) = huge(1.0_dp)
        call tool_compliance_batch(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], stype, sidx, &
            cs, cj, q, c, k, rank, kinfo, info)
        call expect(info == sk_err_overflow, 'planar: an overflowed compliance is reported')
    end subroutine test_planar_two_link

    !> A 3R spatial chain with a joint spring, a link spring and a tool
    !> spring: the deflection rows (sk_deflect) and their basis, the
    !> Jacobian times the parameters (linear in them), equal the point
    !> deflection computed from the tool compliance.
    subroutine test_basis_matches_compliance()
        integer, parameter :: nj = 4, nm = 3
        real(dp) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), q(3, nm), w(6, nm), p(3, nm)
        real(dp) :: cs(6, 6, 3), cj(3, nm), c(6, 6, nm), k(6, 6, nm), basis(6, nm, 1 + 21 + 21), rt(3, 3)
        real(dp) :: theta(43), a(6, 6), tw(6), d(3), dpred(6), pred(6, nm), tgeo(5, 3), rf(3, 3, nj), pf(3, nj), pt(3)
        integer(ip) :: qidx(nj), stype(3), sidx(3), rank(nm), kinfo(nm), info, tint(7, 3), elem(42)
        integer :: m, e, i, j, col
        jrot = 0
        do m = 1, nj
            jrot(:, :, m) = eye(3)
        end do
        jpos = reshape([0.0_dp, 0.0_dp, 0.5_dp, 0.1_dp, 0.0_dp, 0.0_dp, 0.8_dp, 0.0_dp, 0.05_dp, &
            0.3_dp, 0.1_dp, 0.0_dp], [3, nj])
        jaxis = reshape([0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, &
            0.0_dp, 0.0_dp, 0.0_dp], [3, nj])
        qidx = [1, 2, 3, 0]
        q = reshape([0.2_dp, -0.4_dp, 0.7_dp, 1.0_dp, 0.3_dp, -0.2_dp, -0.5_dp, 0.1_dp, 1.2_dp], [3, nm])
        w = reshape([100.0_dp, -50.0_dp, 30.0_dp, 5.0_dp, -2.0_dp, 7.0_dp, &
            -20.0_dp, 80.0_dp, -60.0_dp, 1.0_dp, 3.0_dp, -4.0_dp, &
            10.0_dp, 10.0_dp, 90.0_dp, -6.0_dp, 2.0_dp, 1.0_dp], [6, nm])
        p = reshape([0.0_dp, 0.0_dp, 0.1_dp, 0.05_dp, -0.02_dp, 0.2_dp, 0.0_dp, 0.1_dp, 0.0_dp], [3, nm])
        stype = [1, 2, 4]
        sidx = [2, 3, 0]
        ! parameters: joint 2 compliance, link spring at joint 3's frame, tool spring
        theta = 0
        theta(1) = 3.0e-6_dp
        cs = 0
        do e = 1, 21
            call sym_index(e, i, j)
            theta(1 + e) = 1.0e-7_dp*(1.0_dp + 0.1_dp*e)*merge(1.0_dp, 0.2_dp, i == j)
            theta(22 + e) = 2.0e-7_dp*(1.0_dp - 0.03_dp*e)*merge(1.0_dp, 0.1_dp, i == j)
            cs(i, j, 2) = theta(1 + e); cs(j, i, 2) = theta(1 + e)
            cs(i, j, 3) = theta(22 + e); cs(j, i, 3) = theta(22 + e)
            elem(e) = int(e, ip)
            elem(21 + e) = int(e, ip)
        end do
        cj = theta(1)
        call tool_compliance_batch(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], stype, sidx, &
            cs, cj, q, c, k, rank, kinfo, info)
        call expect(info == sk_ok, 'basis: compliance info')
        ! the deflection model's terms: (kind, spring, first value, count, first column, q column, first element)
        tint(:, 1) = [1, 1, 1, 1, 1, 2, 0]
        tint(:, 2) = [6, 2, 2, 21, 2, 0, 1]
        tint(:, 3) = [6, 3, 23, 21, 23, 0, 22]
        tgeo = 0
        call deflection_rows(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], stype, sidx, tint, tgeo, &
            elem, theta, theta, q, w, p, .true., pred, basis, info)
        call expect(info == sk_ok, 'basis: info')
        do m = 1, nm
            call chain_frames(jrot, jpos, jaxis, qidx, eye(3), [0.0_dp, 0.0_dp, 0.0_dp], q(:, m), rf, pf, rt, pt)
            a = c(:, :, m)
            tw = matmul(a, w(:, m))
            d = tw(1:3) + matmul(-skew(matmul(rt, p(:, m))), tw(4:6))
            dpred = 0
            do col = 1, 43
                dpred = dpred + basis(:, m, col)*theta(col)
            end do
            call expect(maxval(abs(dpred(1:3) - d)) < 1e-12_dp*maxval(abs(d)), 'basis: point deflection = (C W) at p')
            call expect(maxval(abs(dpred(4:6) - tw(4:6))) < 1e-12_dp*maxval(abs(tw(4:6))), 'basis: rotation = C W')
            call expect(maxval(abs(pred(:, m) - dpred)) < 1e-12_dp*maxval(abs(dpred)), 'basis: rows = basis theta')
        end do
    end subroutine test_basis_matches_compliance

    !> Every spring type (joint, frame, base, tool) with full 6x6 springs on
    !> a 4R chain with rotated joint origins: the springs' Jacobians (the
    !> chain tree model's screws, sk_tree_point%twists_at) equal the closed forms at sk_chain's frames (joint:
    !> the revolute twist of its axis; F_k: transfer(pt - p_k) blockdiag(R_k);
    !> base: transfer(pt); tool: blockdiag(R_t)), tool_compliance_batch
    !> equals sum J_s C_s J_s^T, and chain_poses_batch equals chain_frames.
    subroutine test_block_terms_equal_jacobian_products()
        integer, parameter :: nj = 5, np = 4, ns = 6
        real(dp) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), q(4, np), trot(3, 3), tpos(3)
        real(dp) :: cs(6, 6, ns), cj(ns, np), c(6, 6, np), k(6, 6, np), ref(6, 6), jac(6, 1 + 1 + 24)
        real(dp) :: rf(3, 3, nj, np), pf(3, nj, np), rtb(3, 3, np), ptb(3, np)
        real(dp) :: rf1(3, 3, nj), pf1(3, nj), rt(3, 3), pt(3), g(6, 6), jcf(6, 1 + 1 + 24)
        integer(ip) :: qidx(nj), stype(ns), sidx(ns), rank(np), kinfo(np), info
        integer :: m, s, col, a, b
        do m = 1, nj
            jrot(:, :, m) = rotz(0.3_dp*m)
            jrot(:, :, m) = matmul(jrot(:, :, m), roty(-0.2_dp*m))
            jpos(:, m) = [0.1_dp*m, -0.05_dp*m, 0.3_dp]
        end do
        jaxis = 0
        jaxis(3, 1) = 1; jaxis(2, 2) = 1; jaxis(2, 3) = 1; jaxis(1, 4) = 1
        qidx = [1, 2, 3, 4, 0]
        trot = roty(0.7_dp)
        tpos = [0.05_dp, 0.02_dp, 0.15_dp]
        do m = 1, np
            q(:, m) = [0.4_dp*m, -0.3_dp + 0.1_dp*m, 0.9_dp - 0.2_dp*m, 1.1_dp*m]
        end do
        stype = [1, 1, 2, 2, 3, 4]
        sidx = [1, 4, 2, 5, 0, 0]
        cs = 0
        do s = 3, ns
            do b = 1, 6
                do a = 1, 6
                    g(a, b) = sin(1.7_dp*a + 0.9_dp*b + s)
                end do
            end do
            cs(:, :, s) = 1.0e-7_dp*(matmul(g, transpose(g)) + 2*eye(6))
        end do
        cj = 0
        cj(1, :) = 2.0e-6_dp
        cj(2, :) = [1.0e-6_dp, 2.0e-6_dp, 3.0e-6_dp, 4.0e-6_dp]
        call tool_compliance_batch(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, cs, cj, q, c, k, &
            rank, kinfo, info)
        call expect(info == sk_ok, 'block terms: info')
        call chain_poses_batch(jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rtb, ptb, info)
        call expect(info == sk_ok, 'poses: info')
        do m = 1, np
            call spring_jacobians(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q(:, m), jac, info)
            call expect(info == sk_ok, 'block terms: jacobians info')
            call chain_frames(jrot, jpos, jaxis, qidx, trot, tpos, q(:, m), rf1, pf1, rt, pt)
            jcf(:, 1) = revolute_twist(matmul(rf1(:, :, 1), jaxis(:, 1)), pf1(:, 1), pt)
            jcf(:, 2) = revolute_twist(matmul(rf1(:, :, 4), jaxis(:, 4)), pf1(:, 4), pt)
            jcf(:, 3:8) = matmul(twist_transfer(pt - pf1(:, 2)), blockdiag_rot(rf1(:, :, 2)))
            jcf(:, 9:14) = matmul(twist_transfer(pt - pf1(:, 5)), blockdiag_rot(rf1(:, :, 5)))
            jcf(:, 15:20) = twist_transfer(pt)
            jcf(:, 21:26) = blockdiag_rot(rt)
            call expect(maxval(abs(jac - jcf)) < 1e-14_dp, 'block terms: spring Jacobians = closed forms')
            ref = cj(1, m)*matmul(jac(:, 1:1), transpose(jac(:, 1:1))) &
                + cj(2, m)*matmul(jac(:, 2:2), transpose(jac(:, 2:2)))
            col = 2
            do s = 3, ns
                ref = ref + matmul(matmul(jac(:, col + 1:col + 6), cs(:, :, s)), transpose(jac(:, col + 1:col + 6)))
                col = col + 6
            end do
            call expect(maxval(abs(c(:, :, m) - ref)) < 1e-13_dp*maxval(abs(ref)), &
                'block terms: tool compliance = sum J C J^T')
            call expect(rank(m) == 6 .and. kinfo(m) == sk_ok, 'block terms: rank 6')
            call expect(maxval(abs(matmul(c(:, :, m), k(:, :, m)) - eye(6))) < 1e-8_dp, 'block terms: K = C^-1')
            call expect(all(rf(:, :, :, m) == rf1) .and. all(pf(:, :, m) == pf1) .and. &
                all(rtb(:, :, m) == rt) .and. all(ptb(:, m) == pt), 'poses: batch = chain_frames')
        end do
        q(2, 3) = ieee_value(1.0_dp, ieee_positive_inf)
        call chain_poses_batch(jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rtb, ptb, info)
        call expect(info == sk_err_nonfinite, 'poses: Inf posture refused')
    end subroutine test_block_terms_equal_jacobian_products

    !> Tool compliance c[6,6,np] = sum_s J_s C_s J_s^T of the chain at np
    !> (the chain's tree model, sk_chain_tree, and its point compliance,
    !> sk_tree_point%compliance_batch, as robot/model.py evaluates it)
    !> postures q[ndof,np] (base axes, about the tool-frame origin): the
    !> tool point's compliance of the chain's tree model, its springs law
    !> blocks whose parameters are each posture's values (joint spring s:
    !> the compliance cj(s, ip); 6-dof spring s: the constant cs[6,6,s]),
    !> with its stiffness k, rank and kinfo (sk_tree_point%compliance_batch,
    !> the one evaluator of a point's compliance). info: sk_ok,
    !> sk_err_argument (check_chain), sk_err_nonfinite, sk_err_indefinite (a
    !> negative joint compliance or an indefinite 6x6 spring: no spring),
    !> sk_err_overflow.
    subroutine tool_compliance_batch(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, cs, cj, &
            q, c, k, rank, kinfo, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:)
        real(dp), intent(in) :: cs(:, :, :), cj(:, :), q(:, :)
        real(dp), intent(out) :: c(:, :, :), k(:, :, :)
        integer(ip), intent(out) :: rank(:), kinfo(:), info
        type(tree_model) :: m
        integer, allocatable :: sv(:)
        integer(ip), allocatable :: bktype(:), bkpar(:, :)
        integer(ip), allocatable :: vidx(:)
        real(dp), allocatable :: theta(:), vval(:, :)
        integer :: s, e, ia, ib, tool, ns, npar, nvar
        c = 0.0_dp
        k = 0.0_dp
        rank = 0
        kinfo = 0
        call check_chain(jaxis, qidx, size(q, 1, kind=ip), stype, sidx, info)
        if (info /= sk_ok) return
        ns = size(stype)
        ! theta of each posture: one slot per joint spring, 21 per 6-dof spring
        allocate(bktype(ns), bkpar(nsym, ns), sv(ns))
        bkpar = 0
        npar = 0
        do s = 1, ns
            if (stype(s) == spring_joint) then
                bktype(s) = law_linear
                bkpar(1, s) = int(npar + 1, ip)
                npar = npar + 1
            else
                bktype(s) = law_spring6
                bkpar(:, s) = [(int(npar + e, ip), e = 1, nsym)]
                npar = npar + nsym
            end if
        end do
        ! the 6-dof springs' values are constant, the joint springs' vary per posture
        allocate(theta(max(npar, 1)), vidx(count(stype == spring_joint)), vval(count(stype == spring_joint), size(q, 2)))
        theta = 0.0_dp
        nvar = 0
        do s = 1, ns
            if (stype(s) == spring_joint) then
                nvar = nvar + 1
                vidx(nvar) = bkpar(1, s)
                vval(nvar, :) = cj(s, :)
            else
                do e = 1, nsym
                    call sym_index(e, ia, ib)
                    theta(bkpar(e, s)) = cs(ia, ib, s)
                end do
            end if
        end do
        call chain_tree_model(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, size(q, 1, kind=ip), m, sv, &
            tool, info, bktype, bkpar, [(1.0_dp, s = 1, ns)], int(max(npar, 1), ip), [1, 1, 1, 1, 1, 1], [1, 1, 1])
        if (info /= sk_ok) return
        call compliance_batch(m, theta, vidx, vval, tool, q, c, k, rank, kinfo, info)
    end subroutine tool_compliance_batch

    !> Jacobians jac[6,nd] of every spring at posture q: the tool point's
    !> twists per elastic coordinate of the chain's tree model.
    subroutine spring_jacobians(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q, jac, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3), q(:)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:)
        real(dp), intent(out) :: jac(:, :)
        integer(ip), intent(out) :: info
        type(tree_model) :: m
        integer :: sv(size(stype)), tool
        call chain_tree_model(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, size(q, kind=ip), m, sv, tool, info)
        if (info /= sk_ok) return
        call twists_at(m, [0.0_dp], tool, q, jac, info)
    end subroutine spring_jacobians

    pure function rotz(t) result(r)
        real(dp), intent(in) :: t
        real(dp) :: r(3, 3)
        r = reshape([cos(t), sin(t), 0.0_dp, -sin(t), cos(t), 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
    end function rotz

    pure function roty(t) result(r)
        real(dp), intent(in) :: t
        real(dp) :: r(3, 3)
        r = reshape([cos(t), 0.0_dp, -sin(t), 0.0_dp, 1.0_dp, 0.0_dp, sin(t), 0.0_dp, cos(t)], [3, 3])
    end function roty

end program test_chain
