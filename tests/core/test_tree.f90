!> Unit tests of the tree core's model (sk_tree): analytic Jacobians
!> against central differences for every parameter kind (full equilibrium
!> and first order), a pendulum's closed-form equilibrium, gravity torques
!> of a planar arm, warm starts and iteration loads, the serial chain
!> through the tree kinematics, the small LU and info codes of bad input.
!> The test tree: tests/core/tree_builder.f90; LM and compensation:
!> test_tree_solve.f90.
program test_tree
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: rot_exp, rot_log
    use sk_linalg, only: eye, lu_factor, lu_solve
    use sk_tree
    use sk_tree_solve
    use sk_chain, only: chain_frames
    use tree_builder
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    implicit none (type, external)

    call test_pendulum()
    call test_planar_gravity()
    call test_jacobians(100, 'full equilibrium')
    call test_jacobians(1, 'first order')
    call test_warm_start()
    call test_iteration_loads()
    call test_frame_jacobian()
    call test_chain_is_tree()
    call test_bad_input()
    call test_lu(10)
    call test_lu(50)
    call finish('tree')

contains

    !> Pendulum: one revolute about z, a mass m at l along x, gravity -y:
    !> w = -m g l cos(q + delta), delta = c w.
    subroutine test_pendulum()
        type(builder) :: b
        type(tree_model) :: m
        integer :: v, it
        integer(ip) :: info, none(0), nit(1), eqinfo(1)
        real(dp) :: q(1, 1), ra(3, 3, 1, 1), pa(3, 1, 1), wv(1, 1), tauq(1, 1), delta(1, 1), d, c, l, mass, g
        real(dp) :: nol(6, 0)
        c = 2.0e-3_dp
        l = 0.5_dp
        mass = 2.0_dp
        g = 9.81_dp
        b%ndof = 1
        b%grav = [0.0_dp, -g, 0.0_dp]
        call add_tracker(b, [0.0_dp, 0.0_dp, 0.0_dp], [0.0_dp, 0.0_dp, 0.0_dp], eye(3))
        v = add_vj(b, 0, vj_revolute, [0.0_dp, 0.0_dp, 1.0_dp], eye(3), [0.0_dp, 0.0_dp, 0.0_dp], 1, 1.0_dp, 0.0_dp)
        call add_block(b, law_linear, [v], [c], 1.0_dp)
        call add_body(b, v, mass, [l, 0.0_dp, 0.0_dp])
        call setup(b, m, info)
        call expect(info == sk_ok, 'pendulum: setup')
        q = 0.4_dp
        d = 0
        do it = 1, 50                                   ! Newton on d + c m g l cos(q + d) = 0
            d = d - (d + c*mass*g*l*cos(q(1, 1) + d))/(1.0_dp - c*mass*g*l*sin(q(1, 1) + d))
        end do
        call poses_batch(m, b%theta(1:b%npar), q, none, none, nol, 100_ip, 1.0e-15_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        call expect(info == sk_ok, 'pendulum: info')
        call expect(abs(delta(1, 1) - d) < 1.0e-12_dp, 'pendulum: equilibrium = closed-form fixed point')
        call expect(abs(wv(1, 1) + mass*g*l*cos(q(1, 1) + d)) < 1.0e-12_dp, 'pendulum: torque at the deflected pose')
        call poses_batch(m, b%theta(1:b%npar), q, none, none, nol, 1_ip, 1.0e-15_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        call expect(abs(delta(1, 1) + c*mass*g*l*cos(q(1, 1))) < 1.0e-15_dp, 'pendulum: first order = c m g l cos q')
        call expect(abs(pa(1, 1, 1)) < 1.0e-15_dp .and. abs(ra(1, 1, 1, 1) - cos(q(1, 1) + delta(1, 1))) < 1.0e-15_dp, &
            'pendulum: first-order pose deflected')
    end subroutine test_pendulum

    !> Planar 2-link arm about z, gravity -y: tau1 = -g (m1 a1 c1 + m2 (l1 c1 +
    !> a2 c12)), tau2 = -g m2 a2 c12; a payload (f, m) at the tool adds
    !> z . ((p - o_j) x f) + m_z.
    subroutine test_planar_gravity()
        type(builder) :: b
        type(tree_model) :: m
        integer :: v1, v2, vt
        integer(ip) :: info, lpost(1), lvj(1), nit(2), eqinfo(2), none(0)
        real(dp) :: q(2, 2), ra(3, 3, 3, 2), pa(3, 3, 2), wv(3, 2), tauq(2, 2), delta(0, 2), lw(6, 1), nol(6, 0)
        real(dp) :: l1, l2, a1, a2, m1, m2, g, t1, t2, p(3), f(3), mz
        l1 = 0.7_dp; l2 = 0.5_dp; a1 = 0.3_dp; a2 = 0.2_dp; m1 = 8.0_dp; m2 = 3.0_dp; g = 9.81_dp
        b%ndof = 2
        b%grav = [0.0_dp, -g, 0.0_dp]
        call add_tracker(b, [0.0_dp, 0.0_dp, 0.0_dp], [0.0_dp, 0.0_dp, 0.0_dp], eye(3))
        v1 = add_vj(b, 0, vj_revolute, [0.0_dp, 0.0_dp, 1.0_dp], eye(3), [0.0_dp, 0.0_dp, 0.0_dp], 1, 1.0_dp, 0.0_dp)
        v2 = add_vj(b, v1, vj_revolute, [0.0_dp, 0.0_dp, 1.0_dp], eye(3), [l1, 0.0_dp, 0.0_dp], 2, 1.0_dp, 0.0_dp)
        vt = add_vj(b, v2, vj_fixed, [0.0_dp, 0.0_dp, 0.0_dp], eye(3), [l2, 0.0_dp, 0.0_dp], 0, 0.0_dp, 0.0_dp)
        call add_body(b, v1, m1, [a1, 0.0_dp, 0.0_dp])
        call add_body(b, v2, m2, [a2, 0.0_dp, 0.0_dp])
        call setup(b, m, info)
        q(:, 1) = [0.3_dp, -0.8_dp]
        q(:, 2) = [1.2_dp, 0.5_dp]
        call poses_batch(m, b%theta(1:b%npar), q, none, none, nol, 0_ip, 1.0e-9_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        call expect(info == sk_ok, 'planar: info')
        t1 = -g*(m1*a1*cos(q(1, 1)) + m2*(l1*cos(q(1, 1)) + a2*cos(q(1, 1) + q(2, 1))))
        t2 = -g*m2*a2*cos(q(1, 1) + q(2, 1))
        call expect(abs(tauq(1, 1) - t1) < 1.0e-13_dp .and. abs(tauq(2, 1) - t2) < 1.0e-13_dp, &
            'planar: gravity torques = hand formula')
        call expect(abs(wv(1, 1) - t1) < 1.0e-13_dp .and. wv(3, 1) == 0.0_dp, 'planar: joint forces')
        f = [3.0_dp, -40.0_dp, 2.0_dp]
        mz = 1.5_dp
        lpost = 2
        lvj = vt
        lw(:, 1) = [f, 0.2_dp, -0.3_dp, mz]
        call poses_batch(m, b%theta(1:b%npar), q, lpost, lvj, lw, 0_ip, 1.0e-9_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        p = pa(:, vt, 2)
        t1 = -g*(m1*a1*cos(q(1, 2)) + m2*(l1*cos(q(1, 2)) + a2*cos(q(1, 2) + q(2, 2)))) + p(1)*f(2) - p(2)*f(1) + mz
        p = p - pa(:, v2, 2)
        t2 = -g*m2*a2*cos(q(1, 2) + q(2, 2)) + p(1)*f(2) - p(2)*f(1) + mz
        call expect(abs(tauq(1, 2) - t1) < 1.0e-12_dp .and. abs(tauq(2, 2) - t2) < 1.0e-12_dp, &
            'planar: a payload adds its moment')
        t1 = -g*(m1*a1*cos(q(1, 1)) + m2*(l1*cos(q(1, 1)) + a2*cos(q(1, 1) + q(2, 1))))
        call expect(abs(tauq(1, 1) - t1) < 1.0e-13_dp, 'planar: the payload stays in its posture')
    end subroutine test_planar_gravity

    !> Warm start of the equilibrium (evaluate's warm): from the deflections
    !> at a nearby theta, the same points and Jacobian to the tolerance, in
    !> fewer fixed-point steps than from zero; a warm array of the wrong
    !> shape is refused.
    subroutine test_warm_start()
        integer, parameter :: np = 3
        real(dp), parameter :: etol = 1.0e-12_dp
        type(builder) :: b
        type(tree_model) :: m
        type(tree_problem) :: pr
        real(dp) :: q(7, np), t2(cap)
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), pred(:, :), res(:), jac(:, :), delta(:, :)
        real(dp), allocatable :: pw(:, :), rw(:), jw(:, :), dw(:, :), d1(:, :)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:), nit(:), nitw(:), eqinfo(:), free(:)
        integer(ip) :: info
        integer :: k, no
        character(len=160) :: msg
        call build_tree(b, 3.0_dp)
        call setup(b, m, info)
        call observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        no = size(opost)
        allocate(free(b%npar))
        free = [(k, k = 1, b%npar)]
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
        call expect(info == sk_ok, 'warm start: problem')
        allocate(pred(3, no), res(3*no), jac(3*no, b%npar), delta(b%ne, np), nit(np), nitw(np), eqinfo(np), &
            pw(3, no), rw(3*no), jw(3*no, b%npar), dw(b%ne, np), d1(b%ne, np))
        call evaluate(pr, b%theta(1:b%npar), 100_ip, etol, .false., pred, res, jac, d1, nit, eqinfo, info)
        call expect(info == sk_ok, 'warm start: first evaluation')
        ! a nearby theta: every parameter moved by 1 % of its scale
        t2 = b%theta
        do k = 1, b%npar
            t2(k) = t2(k) + 1.0e-2_dp*merge(b%scale(k)*b%theta(k), b%scale(k), b%pkind(k) == 5)
        end do
        call evaluate(pr, t2(1:b%npar), 100_ip, etol, .true., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'warm start: cold evaluation')
        call evaluate(pr, t2(1:b%npar), 100_ip, etol, .true., pw, rw, jw, dw, nitw, eqinfo, info, warm=d1)
        call expect(info == sk_ok, 'warm start: warm evaluation')
        write (msg, '(a, i0, a, i0, a, es9.2, a, es9.2)') 'warm start: steps ', sum(nitw), ' warm vs ', sum(nit), &
            ' cold; points differ by ', maxval(abs(pw - pred)), ', Jacobians by ', maxval(abs(jw - jac))/maxval(abs(jac))
        print '(a)', trim(msg)
        call expect(sum(nitw) < sum(nit), 'warm start: fewer steps than a cold start')
        call expect(maxval(abs(pw - pred)) < 1.0e-10_dp, 'warm start: the same points')
        call expect(maxval(abs(jw - jac)) < 1.0e-6_dp*maxval(abs(jac)), 'warm start: the same Jacobian')
        call evaluate(pr, t2(1:b%npar), 100_ip, etol, .true., pw, rw, jw, dw, nitw, eqinfo, info, warm=d1(:, 1:np - 1))
        call expect(info == sk_err_size, 'warm start: a warm array of the wrong shape is refused')
    end subroutine test_warm_start

    !> The loads an iteration of the equilibrium takes (load_state with
    !> elastic_only: aggregated on the tree of the elastic joints) are the
    !> full loads at the elastic joints, payload included, at a deflected
    !> pose of the tree (branches, 6-dof springs, fixed and frame joints).
    subroutine test_iteration_loads()
        integer, parameter :: np = 2
        type(builder) :: b
        type(tree_model) :: m
        type(tree_state) :: st
        real(dp) :: q(7, np), err, big
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), wv(:), gh(:, :), ghm(:, :)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:)
        integer(ip) :: info
        integer :: e, v, ip0
        integer, allocatable :: lsel(:)
        call build_tree(b, 3.0_dp)
        call setup(b, m, info)
        call expect(info == sk_ok, 'iteration loads: model')
        call observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        call state_init(m, st)
        err = 0.0_dp
        big = 0.0_dp
        do ip0 = 1, np
            lsel = pack([(e, e = 1, size(lpost))], lpost == ip0)
            call posture_values(m, b%theta(1:b%npar), q(:, ip0), st)
            st%delta = [(1.0e-3_dp*sin(real(e + ip0, dp)), e = 1, m%ne)]
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw)
            wv = st%wv
            gh = st%gh
            ghm = st%ghm
            st%wv = 0.0_dp
            st%gh = 0.0_dp
            st%ghm = 0.0_dp
            call load_state(m, st, lsel, lvj, lw, elastic_only=.true.)
            do e = 1, m%ne
                v = m%evj(e)
                err = max(err, abs(st%wv(v) - wv(v)), maxval(abs(st%gh(:, v) - gh(:, v))), &
                    maxval(abs(st%ghm(:, v) - ghm(:, v))))
                big = max(big, abs(wv(v)), maxval(abs(gh(:, v))))
            end do
        end do
        print '(a, es9.2, a, es9.2)', 'iteration loads: largest difference ', err, ' of loads up to ', big
        call expect(size(lpost) > 0 .and. big > 0.0_dp .and. err <= 1.0e-12_dp*big, &
            'iteration loads: the elastic joints'' loads as in full')
    end subroutine test_iteration_loads

    !> Analytic Jacobian of every parameter against central differences of
    !> the full nonlinear evaluation, column by column, relative to the
    !> column's norm. eqit: 100 (equilibrium) or 1 (first order).
    subroutine test_jacobians(eqit, label)
        integer, intent(in) :: eqit
        character(*), intent(in) :: label
        integer, parameter :: np = 3
        type(builder) :: b
        type(tree_model) :: m
        type(tree_problem) :: pr
        real(dp) :: q(7, np), h, err, worst(5), dmax
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), pred(:, :), res(:), jac(:, :), delta(:, :), fd(:)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:), nit(:), eqinfo(:), free(:)
        integer(ip) :: info
        integer :: k, no, c
        character(len=160) :: msg
        call build_tree(b, 3.0_dp)
        call setup(b, m, info)
        call expect(info == sk_ok, 'jacobians: setup')
        call observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        no = size(opost)
        allocate(free(b%npar))
        free = [(k, k = 1, b%npar)]
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
        call expect(info == sk_ok, 'jacobians: problem')
        allocate(pred(3, no), res(3*no), jac(3*no, b%npar), delta(b%ne, np), nit(np), eqinfo(np), fd(3*no))
        call evaluate(pr, b%theta(1:b%npar), int(eqit, ip), 1.0e-14_dp, .true., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'jacobians: evaluate '//label)
        dmax = maxval(abs(delta))
        write (msg, '(a, es9.2, a, i0)') 'jacobians: deflections up to ', dmax, ' rad/m, iterations ', maxval(nit)
        print '(a)', trim(msg)
        call expect(dmax > 2.0e-3_dp, 'jacobians: the equilibrium feedback matters ('//label//')')
        worst = 0
        do k = 1, b%npar
            h = merge(1.0e-2_dp*b%scale(k), 1.0e-4_dp, b%pkind(k) == 5)
            fd = central_difference(pr, b%theta(1:b%npar), k, h, eqit)
            err = norm2(fd - jac(:, k))/norm2(fd)
            c = b%pkind(k)
            worst(c) = max(worst(c), err)
            if (err > 1.0e-7_dp) then
                write (msg, '(a, i0, a, i0, a, es9.2)') 'jacobians: parameter ', k, ' (kind ', c, ') error ', err
                call expect(.false., trim(msg)//' '//label)
            end if
        end do
        write (msg, '(a, 5es9.2)') 'jacobians: worst relative error tracker/marker/offset/frame/law', worst
        print '(a, a, a)', trim(msg), ' ', label
    end subroutine test_jacobians

    !> Derivative of the predicted points w.r.t. theta(k) by the fourth-order
    !> central difference of the full nonlinear evaluation, step h.
    function central_difference(pr, theta, k, h, eqit) result(fd)
        type(tree_problem), intent(in) :: pr
        real(dp), intent(in) :: theta(:), h
        integer, intent(in) :: k, eqit
        real(dp) :: fd(3*pr%nobs), tp(size(theta)), y(3*pr%nobs, -2:2), pred(3, pr%nobs), res(3*pr%nobs), &
            jx(3*pr%nobs, 0), delta(pr%m%ne, pr%np)
        integer(ip) :: nit(pr%np), eqinfo(pr%np), info
        integer :: s
        do s = -2, 2
            if (s == 0) cycle
            tp = theta
            tp(k) = tp(k) + s*h
            call evaluate(pr, tp, int(eqit, ip), 1.0e-15_dp, .false., pred, res, jx, delta, nit, eqinfo, info)
            y(:, s) = reshape(pred, [3*pr%nobs])
        end do
        fd = (8.0_dp*(y(:, 1) - y(:, -1)) - (y(:, 2) - y(:, -2)))/(12.0_dp*h)
    end function central_difference

    !> The frame Jacobian w.r.t. q (through the equilibrium) against central
    !> differences of the pose.
    subroutine test_frame_jacobian()
        type(builder) :: b
        type(tree_model) :: m
        integer, parameter :: n = 2
        real(dp) :: q(7, n), qp(7, n), rf(3, 3, n), pf(3, n), jq(6, 7, n), delta(15, n)
        real(dp) :: rfs(3, 3, n, -2:2), pfs(3, n, -2:2), ws(3, -2:2), jx(6, 7, n), fd(6), h, err
        integer(ip) :: frame(n), nit(n), eqinfo(n), info, lpost(1), lvj(1)
        real(dp) :: lw(6, 1)
        integer :: j, i, s
        call build_tree(b, 1.0_dp)
        call setup(b, m, info)
        call expect(b%ne == 15, 'frame jacobian: 15 elastic coordinates')
        frame = [b%mvj(1), b%mvj(2)]
        q(:, 1) = [0.3_dp, -0.5_dp, 0.8_dp, 0.2_dp, 0.6_dp, -0.4_dp, 1.0_dp]
        q(:, 2) = [-1.0_dp, 0.9_dp, -0.3_dp, 1.2_dp, -0.7_dp, 0.5_dp, -0.2_dp]
        lpost = 2
        lvj = frame(2)
        lw(:, 1) = [0.0_dp, 10.0_dp, -15.0_dp, 0.5_dp, 0.0_dp, -1.0_dp]
        call frame_jacobian_batch(m, b%theta(1:b%npar), frame, q, lpost, lvj, lw, 100_ip, 1.0e-14_dp, rf, pf, jq, &
            delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'frame jacobian: info')
        ! fourth-order central differences of the pose (columns of size
        ! 1e-6 couple the arms through the torso's deflection: compared
        ! with a floor of 1e-3)
        h = 1.0e-4_dp
        err = 0
        do j = 1, 7
            do s = -2, 2
                if (s == 0) cycle
                qp = q
                qp(j, :) = qp(j, :) + s*h
                call frame_jacobian_batch(m, b%theta(1:b%npar), frame, qp, lpost, lvj, lw, 100_ip, 1.0e-15_dp, &
                    rfs(:, :, :, s), pfs(:, :, s), jx, delta, nit, eqinfo, info)
            end do
            do i = 1, n
                ! rotations relative to the centre: rot_log(R(s h) R(0)^T)
                do s = -2, 2
                    if (s == 0) cycle
                    ws(:, s) = rot_log(matmul(rfs(:, :, i, s), transpose(rf(:, :, i))))
                end do
                fd(1:3) = (8*(pfs(:, i, 1) - pfs(:, i, -1)) - (pfs(:, i, 2) - pfs(:, i, -2)))/(12*h)
                fd(4:6) = (8*(ws(:, 1) - ws(:, -1)) - (ws(:, 2) - ws(:, -2)))/(12*h)
                err = max(err, norm2(fd - jq(:, j, i))/max(norm2(fd), 1.0e-3_dp))
            end do
        end do
        print '(a, es9.2)', 'frame jacobian: worst error ', err
        call expect(err < 1.0e-7_dp, 'frame jacobian: total dq Jacobian = central differences')
    end subroutine test_frame_jacobian

    !> A serial chain described as a tree: poses_batch's frames equal
    !> sk_chain's chain_frames (F_k = frame before motion), bit for bit.
    subroutine test_chain_is_tree()
        integer, parameter :: nj = 5
        type(builder) :: b
        type(tree_model) :: m
        real(dp) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), q(4, 1), rf(3, 3, nj), pf(3, nj), rt(3, 3), pt(3)
        real(dp) :: ra(3, 3, nj + 1, 1), pa(3, nj + 1, 1), wv(nj + 1, 1), tauq(4, 1), delta(0, 1), r(3, 3), p(3)
        real(dp) :: nol(6, 0)
        integer(ip) :: qidx(nj), nit(1), eqinfo(1), info, none(0)
        integer :: k, v
        logical :: same
        qidx = [1, 2, 0, 3, 4]
        do k = 1, nj
            jrot(:, :, k) = rpy(0.3_dp*k, -0.2_dp*k, 0.1_dp)
            jpos(:, k) = [0.1_dp*k, -0.05_dp, 0.3_dp]
            jaxis(:, k) = matmul(rot_exp([0.1_dp*k, 0.2_dp, 0.0_dp]), [0.0_dp, 0.0_dp, 1.0_dp])
        end do
        q(:, 1) = [0.4_dp, -1.3_dp, 0.9_dp, 2.1_dp]
        b%ndof = 4
        call add_tracker(b, [0.0_dp, 0.0_dp, 0.0_dp], [0.0_dp, 0.0_dp, 0.0_dp], eye(3))
        v = 0
        do k = 1, nj
            v = add_vj(b, v, merge(vj_revolute, vj_fixed, qidx(k) > 0), jaxis(:, k), jrot(:, :, k), jpos(:, k), &
                int(qidx(k)), 1.0_dp, 0.0_dp)
        end do
        v = add_vj(b, v, vj_fixed, [0.0_dp, 0.0_dp, 0.0_dp], rpy(0.5_dp, 0.1_dp, -0.4_dp), [0.0_dp, 0.1_dp, 0.2_dp], &
            0, 0.0_dp, 0.0_dp)
        call setup(b, m, info)
        call poses_batch(m, b%theta(1:b%npar), q, none, none, nol, 0_ip, 1.0e-9_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        call chain_frames(jrot, jpos, jaxis, qidx, rpy(0.5_dp, 0.1_dp, -0.4_dp), [0.0_dp, 0.1_dp, 0.2_dp], q(:, 1), &
            rf, pf, rt, pt)
        same = all(ra(:, :, nj + 1, 1) == rt) .and. all(pa(:, nj + 1, 1) == pt)
        do k = 1, nj
            ! frame before motion of joint k = parent's frame after motion times the origin
            if (k == 1) then
                r = jrot(:, :, 1)
                p = jpos(:, 1)
            else
                p = pa(:, k - 1, 1) + matmul(ra(:, :, k - 1, 1), jpos(:, k))
                r = matmul(ra(:, :, k - 1, 1), jrot(:, :, k))
            end if
            same = same .and. all(rf(:, :, k) == r) .and. all(pf(:, k) == p)
        end do
        call expect(info == sk_ok .and. same, 'chain: chain_frames = tree kinematics, bit for bit')
    end subroutine test_chain_is_tree

    !> lu_factor / lu_solve (the small in-place elimination below n = 41,
    !> LAPACK above): a x = b and a^T x = b, with pivoting.
    subroutine test_lu(n)
        integer, intent(in) :: n
        real(dp) :: a(n, n), f(n, n), b(n, 3), x(n, 3)
        integer :: ipiv(n), i, j
        integer(ip) :: info
        character(len=60) :: msg
        do j = 1, n
            do i = 1, n
                a(i, j) = sin(1.3_dp*i + 0.7_dp*j*j) + merge(0.5_dp, 0.0_dp, i == n + 1 - j)
            end do
            b(j, :) = [cos(0.3_dp*j), sin(2.0_dp*j), 1.0_dp]
        end do
        f = a
        call lu_factor(f, ipiv, info)
        x = b
        call lu_solve(f, ipiv, x)
        write (msg, '(a, i0)') 'lu: n = ', n
        call expect(info == sk_ok .and. maxval(abs(matmul(a, x) - b)) < 1.0e-10_dp, trim(msg)//', a x = b')
        x = b
        call lu_solve(f, ipiv, x, transposed=.true.)
        call expect(maxval(abs(matmul(transpose(a), x) - b)) < 1.0e-10_dp, trim(msg)//', a^T x = b')
    end subroutine test_lu

    !> Bad input gives info codes: sizes, NaN, parent order, non-unit axis.
    subroutine test_bad_input()
        type(builder) :: b, bad
        type(tree_model) :: m
        type(tree_problem) :: pr
        real(dp) :: q(7, 2), tp(cap)
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), pred(:, :), res(:), jac(:, :), delta(:, :)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:), nit(:), eqinfo(:)
        integer(ip) :: info, none(0)
        call build_tree(b, 1.0_dp)
        bad = b
        bad%ne = b%ne + 1
        call setup(bad, m, info)
        call expect(info == sk_err_size, 'bad input: wrong ne -> size')
        bad = b
        bad%vparent(5) = 5
        call setup(bad, m, info)
        call expect(info == sk_err_argument, 'bad input: parent order -> argument')
        bad = b
        bad%vaxis(:, 3) = 1.01_dp*bad%vaxis(:, 3)
        call setup(bad, m, info)
        call expect(info == sk_err_argument, 'bad input: non-unit axis -> argument')
        bad = b
        bad%vpos(2, 4) = ieee_value(1.0_dp, ieee_quiet_nan)
        call setup(bad, m, info)
        call expect(info == sk_err_nonfinite, 'bad input: NaN origin -> nonfinite')
        bad = b
        bad%kvj(1, 2) = bad%kvj(1, 1)
        call setup(bad, m, info)
        call expect(info == sk_err_argument, 'bad input: two coordinates on one joint -> argument')
        call setup(b, m, info)
        call observations(b, q, 2, lpost, lvj, lw, opost, omark, oxyz, owt)
        omark(1) = 99
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, none, info)
        call expect(info == sk_err_argument, 'bad input: marker out of range -> argument')
        omark(1) = 1
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, [1_ip, 1_ip], info)
        call expect(info == sk_err_argument, 'bad input: duplicate free parameter -> argument')
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, none, info)
        allocate(pred(3, size(opost)), res(3*size(opost)), jac(3*size(opost), 0), delta(b%ne, 2), nit(2), eqinfo(2))
        tp = b%theta
        tp(3) = ieee_value(1.0_dp, ieee_quiet_nan)
        call evaluate(pr, tp(1:b%npar), 100_ip, 1.0e-9_dp, .true., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_err_nonfinite, 'bad input: NaN parameter -> nonfinite')
        call evaluate(pr, tp(1:b%npar - 1), 100_ip, 1.0e-9_dp, .true., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_err_size, 'bad input: short theta -> size')
        ! a compliance so large that the fixed point diverges: reported, not a crash
        tp = b%theta
        tp(b%kpar(1, 1)) = 10.0_dp
        call evaluate(pr, tp(1:b%npar), 50_ip, 1.0e-9_dp, .false., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_err_noconv .and. any(eqinfo == sk_err_noconv), 'bad input: divergent equilibrium -> noconv')
    end subroutine test_bad_input

end program test_tree
