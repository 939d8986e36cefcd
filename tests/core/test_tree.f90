!> Unit tests of sk_tree and sk_tree_solve: analytic Jacobians against
!> central differences for every parameter kind (full equilibrium and first
!> order), a pendulum's closed-form equilibrium, gravity torques of a planar
!> arm, noise-free recovery by Levenberg-Marquardt, compensation by Newton,
!> the serial chain through the tree kinematics, and info codes of bad input.
program test_tree
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: rot_exp, rot_log
    use sk_linalg, only: eye, svd, lu_factor, lu_solve
    use sk_tree
    use sk_tree_solve
    use sk_chain, only: chain_frames
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    implicit none (type, external)

    integer, parameter :: cap = 100

    !> A tree under construction (fixed capacity; counts say what is used).
    type :: builder
        integer :: nv = 0, ng = 0, nk = 0, nb = 0, nm = 0, npar = 0, ne = 0, ndof = 0
        integer(ip) :: vparent(cap) = 0, vtype(cap) = 0, qcol(cap) = 0, gvj(cap) = 0, gpar(cap) = 0
        integer(ip) :: ktype(cap) = 0, kvj(6, cap) = 0, kpar(21, cap) = 0, bvj(cap) = 0, tpar(6) = 0
        integer(ip) :: mvj(cap) = 0, mpar(3, cap) = 0
        real(dp) :: vaxis(3, cap) = 0, vrot(3, 3, cap) = 0, vpos(3, cap) = 0, qcoef(cap) = 0, qconst(cap) = 0
        real(dp) :: gcoef(cap) = 0, kw0(cap) = 0, bmass(cap) = 0, bcom(3, cap) = 0, grav(3) = 0, rref(3, 3) = 0
        real(dp) :: theta(cap) = 0, scale(cap) = 0
        !> kind of each parameter, for the messages: 1 tracker, 2 marker,
        !> 3 offset, 4 frame, 5 law
        integer :: pkind(cap) = 0
    end type builder

    call test_pendulum()
    call test_planar_gravity()
    call test_jacobians(100, 'full equilibrium')
    call test_jacobians(1, 'first order')
    call test_warm_start()
    call test_iteration_loads()
    call test_frame_jacobian()
    call test_recovery()
    call test_compensate(7, 1)
    call test_compensate(4, 0)
    call test_chain_is_tree()
    call test_bad_input()
    call test_lu(10)
    call test_lu(50)
    call finish('tree')

contains

    ! ------------------------------------------------------------ building

    integer function add_vj(b, parent, vtype, axis, rot, pos, qcol, qcoef, qconst) result(v)
        type(builder), intent(inout) :: b
        integer, intent(in) :: parent, vtype, qcol
        real(dp), intent(in) :: axis(3), rot(3, 3), pos(3), qcoef, qconst
        b%nv = b%nv + 1
        v = b%nv
        b%vparent(v) = parent
        b%vtype(v) = vtype
        b%vaxis(:, v) = axis
        b%vrot(:, :, v) = rot
        b%vpos(:, v) = pos
        b%qcol(v) = qcol
        b%qcoef(v) = qcoef
        b%qconst(v) = qconst
    end function add_vj

    integer function add_par(b, value, kind, scale) result(k)
        type(builder), intent(inout) :: b
        real(dp), intent(in) :: value, scale
        integer, intent(in) :: kind
        b%npar = b%npar + 1
        k = b%npar
        b%theta(k) = value
        b%pkind(k) = kind
        b%scale(k) = scale
    end function add_par

    subroutine add_geo(b, v, k, coef)
        type(builder), intent(inout) :: b
        integer, intent(in) :: v, k
        real(dp), intent(in) :: coef
        b%ng = b%ng + 1
        b%gvj(b%ng) = v
        b%gpar(b%ng) = k
        b%gcoef(b%ng) = coef
    end subroutine add_geo

    !> A law block on joints vjs with parameter values pv (one parameter each).
    subroutine add_block(b, ktype, vjs, pv, w0)
        type(builder), intent(inout) :: b
        integer, intent(in) :: ktype, vjs(:)
        real(dp), intent(in) :: pv(:), w0
        integer :: j
        b%nk = b%nk + 1
        b%ktype(b%nk) = ktype
        b%kvj(1:size(vjs), b%nk) = vjs
        do j = 1, size(pv)
            b%kpar(j, b%nk) = add_par(b, pv(j), 5, abs(pv(j)))
        end do
        b%kw0(b%nk) = w0
        b%ne = b%ne + size(vjs)
    end subroutine add_block

    subroutine add_body(b, v, mass, com)
        type(builder), intent(inout) :: b
        integer, intent(in) :: v
        real(dp), intent(in) :: mass, com(3)
        b%nb = b%nb + 1
        b%bvj(b%nb) = v
        b%bmass(b%nb) = mass
        b%bcom(:, b%nb) = com
    end subroutine add_body

    subroutine add_marker(b, v, p)
        type(builder), intent(inout) :: b
        integer, intent(in) :: v
        real(dp), intent(in) :: p(3)
        integer :: j
        b%nm = b%nm + 1
        b%mvj(b%nm) = v
        do j = 1, 3
            b%mpar(j, b%nm) = add_par(b, p(j), 2, 1.0_dp)
        end do
    end subroutine add_marker

    !> A URDF joint expanded much as the Python side does: [origin] -> optional
    !> 6-dof spring (3 prismatic x y z, 3 revolute x y z; compliance c6) ->
    !> optional frame error (same screws, parameters fr) -> optional two
    !> lateral revolutes (compliances clat) -> the joint itself (revolute
    !> about axis on column qcol, or fixed when qcol < 0); robot/tree_model.py
    !> puts the lateral revolutes after the joint's motion instead, which
    !> these tests of the numerics do not depend on. Returns the joint's
    !> virtual joint. ljoint: law of the joint (0 none).
    integer function add_joint(b, parent, rot, pos, axis, qcol, qcoef, qconst, c6, fr, clat, ljoint, lpar, w0) &
            result(v)
        type(builder), intent(inout) :: b
        integer, intent(in) :: parent, qcol, ljoint
        real(dp), intent(in) :: rot(3, 3), pos(3), axis(3), qcoef, qconst
        real(dp), intent(in), optional :: c6(21), fr(6), clat(2), lpar(:), w0
        real(dp) :: r(3, 3), p(3), e(3, 3), x1(3), x2(3)
        integer :: j, vs(6), k
        r = rot
        p = pos
        e = eye(3)
        v = parent
        if (present(c6)) then
            do j = 1, 6
                vs(j) = add_vj(b, v, merge(vj_prismatic, vj_revolute, j <= 3), e(:, mod(j - 1, 3) + 1), r, p, &
                    0, 0.0_dp, 0.0_dp)
                v = vs(j)
                r = eye(3)
                p = 0
            end do
            call add_block(b, law_spring6, vs, c6, 1.0_dp)
        end if
        if (present(fr)) then
            do j = 1, 6
                v = add_vj(b, v, merge(vj_prismatic, vj_revolute, j <= 3), e(:, mod(j - 1, 3) + 1), r, p, &
                    0, 0.0_dp, 0.0_dp)
                r = eye(3)
                p = 0
                k = add_par(b, fr(j), 4, 1.0_dp)
                call add_geo(b, v, k, 1.0_dp)
            end do
        end if
        if (present(clat)) then
            ! two unit vectors perpendicular to the axis
            x1 = merge([0.0_dp, 0.0_dp, 1.0_dp], [1.0_dp, 0.0_dp, 0.0_dp], abs(axis(1)) > 0.9_dp)
            x1 = x1 - dot_product(x1, axis)*axis
            x1 = x1/norm2(x1)
            x2 = [axis(2)*x1(3) - axis(3)*x1(2), axis(3)*x1(1) - axis(1)*x1(3), axis(1)*x1(2) - axis(2)*x1(1)]
            v = add_vj(b, v, vj_revolute, x1, r, p, 0, 0.0_dp, 0.0_dp)
            call add_block(b, law_linear, [v], [clat(1)], 1.0_dp)
            r = eye(3)
            p = 0
            v = add_vj(b, v, vj_revolute, x2, r, p, 0, 0.0_dp, 0.0_dp)
            call add_block(b, law_linear, [v], [clat(2)], 1.0_dp)
        end if
        if (qcol < 0) then
            v = add_vj(b, v, vj_fixed, [0.0_dp, 0.0_dp, 0.0_dp], r, p, 0, 0.0_dp, 0.0_dp)
        else
            v = add_vj(b, v, vj_revolute, axis, r, p, qcol, qcoef, qconst)
            if (ljoint > 0) call add_block(b, ljoint, [v], lpar, merge(w0, 1.0_dp, present(w0)))
        end if
    end function add_joint

    subroutine add_tracker(b, t, a, rref)
        type(builder), intent(inout) :: b
        real(dp), intent(in) :: t(3), a(3), rref(3, 3)
        integer :: j
        do j = 1, 3
            b%tpar(j) = add_par(b, t(j), 1, 1.0_dp)
        end do
        do j = 1, 3
            b%tpar(3 + j) = add_par(b, a(j), 1, 1.0_dp)
        end do
        b%rref = rref
    end subroutine add_tracker

    subroutine setup(b, m, info)
        type(builder), intent(in) :: b
        type(tree_model), intent(out) :: m
        integer(ip), intent(out) :: info
        call model_setup(m, b%vparent(1:b%nv), b%vtype(1:b%nv), b%vaxis(:, 1:b%nv), b%vrot(:, :, 1:b%nv), &
            b%vpos(:, 1:b%nv), b%qcol(1:b%nv), b%qcoef(1:b%nv), b%qconst(1:b%nv), b%gvj(1:b%ng), &
            b%gpar(1:b%ng), b%gcoef(1:b%ng), b%ktype(1:b%nk), b%kvj(:, 1:b%nk), b%kpar(:, 1:b%nk), &
            b%kw0(1:b%nk), b%bvj(1:b%nb), b%bmass(1:b%nb), b%bcom(:, 1:b%nb), b%grav, b%tpar, b%rref, &
            b%mvj(1:b%nm), b%mpar(:, 1:b%nm), int(b%ndof, ip), int(b%npar, ip), int(b%ne, ip), info)
    end subroutine setup

    pure function rpy(r, p, y) result(m)
        real(dp), intent(in) :: r, p, y
        real(dp) :: m(3, 3)
        m = matmul(rot_exp([0.0_dp, 0.0_dp, y]), matmul(rot_exp([0.0_dp, p, 0.0_dp]), rot_exp([r, 0.0_dp, 0.0_dp])))
    end function rpy

    !> The test tree: a torso (revolute z, lateral compliance, linear joint
    !> law) and two arms; left: L1 (y, offset), L2 (z, frame error, cubic
    !> law), L3 (y, dead zone), fixed tool; right: a 6-dof link spring at R1's
    !> origin, R1 (y), R2 (z, offset leader, linear), R3 (y, mimic of R2 with
    !> multiplier -1 and offset 0.2, linear), R4 (x, linear), fixed tool.
    !> Masses on the torso and on every arm link; markers on both tools and
    !> the torso. Joint columns: T L1 L2 L3 R1 R2 R4.
    subroutine build_tree(b, scale_c)
        type(builder), intent(out) :: b
        real(dp), intent(in) :: scale_c
        real(dp) :: c6(21), z3(3), ax(3), ay(3), az(3)
        integer :: t, l1, l2, l3, lt, r1, r2, r3, r4, rtool, k, j, i, kk
        z3 = 0
        ax = [1.0_dp, 0.0_dp, 0.0_dp]
        ay = [0.0_dp, 1.0_dp, 0.0_dp]
        az = [0.0_dp, 0.0_dp, 1.0_dp]
        b%ndof = 7
        b%grav = [0.0_dp, 0.0_dp, -9.81_dp]
        call add_tracker(b, [2.0_dp, -1.0_dp, 0.5_dp], [0.1_dp, -0.2_dp, 0.3_dp], rpy(0.2_dp, -0.1_dp, 2.5_dp))
        t = add_joint(b, 0, rpy(0.01_dp, -0.02_dp, 0.0_dp), [0.0_dp, 0.0_dp, 0.4_dp], az, 1, 1.0_dp, 0.0_dp, &
            clat=scale_c*[1.0e-5_dp, 1.5e-5_dp], ljoint=law_linear, lpar=[scale_c*2.0e-5_dp])
        call add_body(b, t, 20.0_dp, [0.02_dp, 0.0_dp, 0.3_dp])
        ! left arm
        l1 = add_joint(b, t, rpy(0.3_dp, 0.0_dp, 0.1_dp), [0.0_dp, 0.2_dp, 0.5_dp], ay, 2, 1.0_dp, 0.0_dp, &
            ljoint=law_linear, lpar=[scale_c*3.0e-5_dp])
        k = add_par(b, 0.02_dp, 3, 1.0_dp)
        call add_geo(b, l1, k, 1.0_dp)
        call add_body(b, l1, 5.0_dp, [0.15_dp, 0.01_dp, 0.0_dp])
        l2 = add_joint(b, l1, rpy(0.0_dp, 0.2_dp, 0.0_dp), [0.3_dp, 0.0_dp, 0.0_dp], az, 3, 1.0_dp, 0.0_dp, &
            fr=[1.0e-3_dp, -2.0e-3_dp, 1.5e-3_dp, 2.0e-3_dp, -1.0e-3_dp, 3.0e-3_dp], &
            ljoint=law_cubic, lpar=scale_c*[2.0e-5_dp, 2.0e-8_dp])
        call add_body(b, l2, 4.0_dp, [0.17_dp, 0.0_dp, 0.02_dp])
        l3 = add_joint(b, l2, eye(3), [0.35_dp, 0.0_dp, 0.0_dp], ay, 4, 1.0_dp, 0.0_dp, &
            ljoint=law_deadzone, lpar=scale_c*[2.0e-5_dp, 5.0e-4_dp], w0=3.0_dp)
        call add_body(b, l3, 2.0_dp, [0.05_dp, 0.0_dp, 0.01_dp])
        lt = add_joint(b, l3, rpy(0.1_dp, 0.2_dp, 0.3_dp), [0.1_dp, 0.0_dp, 0.02_dp], az, -1, 0.0_dp, 0.0_dp, &
            ljoint=0)
        ! right arm: a full 6-dof link spring at R1's origin
        kk = 0
        do i = 1, 6
            do j = i, 6
                kk = kk + 1
                if (i == j) then
                    c6(kk) = merge(1.0e-6_dp, 2.0e-5_dp, i <= 3)
                else
                    c6(kk) = merge(1.0e-7_dp, 1.0e-6_dp, j <= 3)*(1.0_dp + 0.1_dp*kk)*merge(1, -1, mod(kk, 2) == 0)
                    if (i <= 3 .and. j > 3) c6(kk) = 2.0e-7_dp*(1.0_dp + 0.05_dp*kk)
                end if
            end do
        end do
        r1 = add_joint(b, t, rpy(-0.3_dp, 0.0_dp, -0.1_dp), [0.0_dp, -0.2_dp, 0.5_dp], ay, 5, 1.0_dp, 0.0_dp, &
            c6=scale_c*c6, ljoint=0)
        call add_body(b, r1, 5.0_dp, [0.15_dp, -0.01_dp, 0.0_dp])
        r2 = add_joint(b, r1, eye(3), [0.3_dp, 0.0_dp, 0.0_dp], az, 6, 1.0_dp, 0.0_dp, &
            ljoint=law_linear, lpar=[scale_c*2.5e-5_dp])
        call add_body(b, r2, 3.0_dp, [0.15_dp, 0.0_dp, 0.0_dp])
        r3 = add_joint(b, r2, eye(3), [0.3_dp, 0.0_dp, 0.0_dp], ay, 6, -1.0_dp, 0.2_dp, &
            ljoint=law_linear, lpar=[scale_c*3.0e-5_dp])
        k = add_par(b, -0.015_dp, 3, 1.0_dp)
        call add_geo(b, r2, k, 1.0_dp)
        call add_geo(b, r3, k, -1.0_dp)
        call add_body(b, r3, 2.0_dp, [0.12_dp, 0.0_dp, 0.01_dp])
        r4 = add_joint(b, r3, eye(3), [0.25_dp, 0.0_dp, 0.0_dp], ax, 7, 1.0_dp, 0.0_dp, &
            ljoint=law_linear, lpar=[scale_c*4.0e-5_dp])
        call add_body(b, r4, 1.5_dp, [0.05_dp, 0.08_dp, 0.05_dp])
        rtool = add_joint(b, r4, eye(3), [0.12_dp, 0.0_dp, 0.0_dp], az, -1, 0.0_dp, 0.0_dp, ljoint=0)
        call add_marker(b, lt, [0.05_dp, 0.01_dp, 0.02_dp])
        call add_marker(b, rtool, [0.03_dp, -0.02_dp, 0.01_dp])
        call add_marker(b, t, [0.1_dp, 0.05_dp, 0.6_dp])
    end subroutine build_tree

    !> Observations: every marker at every posture; one payload on the left tool.
    subroutine observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        type(builder), intent(in) :: b
        integer, intent(in) :: np
        real(dp), intent(out) :: q(:, :)
        integer(ip), allocatable, intent(out) :: lpost(:), lvj(:), opost(:), omark(:)
        real(dp), allocatable, intent(out) :: lw(:, :), oxyz(:, :), owt(:)
        integer :: i, j, k
        do i = 1, np
            do j = 1, b%ndof
                q(j, i) = 1.1_dp*sin(1.3_dp*i + 0.7_dp*j*j) + 0.2_dp*cos(2.1_dp*i*j)
            end do
        end do
        allocate(lpost(1), lvj(1), lw(6, 1))
        lpost(1) = 2
        lvj(1) = b%mvj(1)
        lw(:, 1) = [5.0_dp, -3.0_dp, -20.0_dp, 1.0_dp, -0.5_dp, 0.7_dp]
        allocate(opost(np*b%nm), omark(np*b%nm), oxyz(3, np*b%nm), owt(np*b%nm))
        k = 0
        do i = 1, np
            do j = 1, b%nm
                k = k + 1
                opost(k) = i
                omark(k) = j
                oxyz(:, k) = 0
                owt(k) = 1.0_dp
            end do
        end do
    end subroutine observations

    ! ------------------------------------------------------------ tests

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

    !> Noise-free data of the test tree at 40 postures; LM from a perturbed
    !> start recovers tracker, markers, joint offsets, the frame error of L2
    !> and the joint and lateral compliances to 1e-8 (relative to their
    !> scale: 1 for geometry, their value for compliances).
    subroutine test_recovery()
        integer, parameter :: np = 40, maxit = 50
        type(builder) :: b
        type(tree_model) :: m
        type(tree_problem) :: pr
        real(dp) :: q(7, np), theta0(cap), thetaf(cap), hist(maxit + 1), worst, e, rfit(3, 3), rtrue(3, 3), tt(3), &
            tw(3, 3)
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), pred(:, :), res(:), jac(:, :), delta(:, :)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:), nit(:), eqinfo(:), free(:)
        integer(ip) :: info, nhist, niter, reason, none(0)
        integer :: k, no, nf
        logical :: pick(cap)
        character(len=160) :: msg
        call build_tree(b, 1.0_dp)
        call setup(b, m, info)
        call observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        no = size(opost)
        ! the truth: measurements from the model itself
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, none, info)
        allocate(pred(3, no), res(3*no), delta(b%ne, np), nit(np), eqinfo(np), jac(3*no, 0))
        call evaluate(pr, b%theta(1:b%npar), 100_ip, 1.0e-13_dp, .false., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'recovery: truth')
        oxyz = pred
        ! free: all but the torso's offset-like tracker coupling (none here),
        ! the 6-dof spring, the cubic c3 and the dead zone's law
        pick = .false.
        pick(1:b%npar) = b%pkind(1:b%npar) <= 4
        do k = 1, b%nk
            if (b%ktype(k) == law_linear) pick(b%kpar(1, k)) = .true.
        end do
        nf = count(pick)
        allocate(free(nf))
        free = pack([(k, k = 1, cap)], pick)
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
        call expect(info == sk_ok, 'recovery: problem')
        theta0 = b%theta
        do k = 1, nf
            select case (b%pkind(free(k)))
            case (1)
                theta0(free(k)) = theta0(free(k)) + 0.01_dp*(1 + mod(k, 3))
            case (2)
                theta0(free(k)) = theta0(free(k)) + 5.0e-3_dp*merge(1, -1, mod(k, 2) == 0)
            case (3)
                theta0(free(k)) = theta0(free(k)) + 0.01_dp
            case (4)
                theta0(free(k)) = theta0(free(k)) - 1.0e-3_dp
            case default
                theta0(free(k)) = theta0(free(k))*1.3_dp
            end select
        end do
        deallocate(jac)
        allocate(jac(3*no, nf))
        call tree_lm(pr, theta0(1:b%npar), 100_ip, 1.0e-13_dp, int(maxit, ip), 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, &
            thetaf(1:b%npar), hist, nhist, niter, reason, jac, res, rfit, info)
        write (msg, '(a, i0, a, i0, a, i0, a, es9.2, a, es9.2)') 'recovery: ', nf, ' free, info ', info, &
            ', reason ', reason, ', cost ', hist(1), ' -> ', hist(nhist)
        print '(a, a, i0)', trim(msg), ', iterations ', niter
        call expect(info == sk_ok, 'recovery: LM converged')
        ! the fit re-centres the tracker rotation into rfit (its angles 0)
        call tracker_pose(m, b%theta(1:b%npar), rtrue, tt, tw)
        worst = maxval(abs(rfit - rtrue))
        call expect(worst < 1.0e-8_dp .and. all(thetaf(b%tpar(4:6)) == 0.0_dp), 'recovery: tracker rotation')
        do k = 1, nf
            if (any(b%tpar(4:6) == free(k))) cycle
            e = abs(thetaf(free(k)) - b%theta(free(k)))/b%scale(free(k))
            worst = max(worst, e)
            if (e > 1.0e-8_dp) then
                write (msg, '(a, i0, a, i0, a, es9.2)') 'recovery: parameter ', free(k), ' kind ', &
                    b%pkind(free(k)), ' error ', e
                call expect(.false., trim(msg))
            end if
        end do
        print '(a, es9.2)', 'recovery: worst relative parameter error ', worst
        call expect(all(hist(2:nhist) <= hist(1:nhist - 1)), 'recovery: cost history decreases')
    end subroutine test_recovery

    !> Compensation on an n-joint chain with offsets, frame errors, joint and
    !> lateral compliance and masses: targets from the nominal (rigid, no
    !> errors) model; the compensated command puts the identified model's
    !> tool on them to 1e-12 (full6 = 1: pose; 0: position), and the change
    !> of q is least-norm (orthogonal to the Jacobian's null space).
    subroutine test_compensate(nj, full6)
        integer, intent(in) :: nj, full6
        integer, parameter :: nr = 20
        type(builder) :: b
        type(tree_model) :: m
        real(dp) :: q(nj, nr), qout(nj, nr), resp(nr), resr(nr), rt(3, 3, nr), pt(3, nr), jq(6, nj, nr)
        real(dp) :: rf(3, 3, nr), pf(3, nr), delta(3*nj, nr), theta0(cap), axis(3), err, opt
        real(dp), allocatable :: u(:, :), s(:), vt(:, :), ra(:, :, :, :), pa(:, :, :), wv(:, :), tauq(:, :)
        real(dp) :: nol(6, 0)
        integer(ip) :: frame(nr), nit(nr), rinfo(nr), eqinfo(nr), info, none(0)
        integer :: j, v, i, k, nrow
        character(len=160) :: msg
        b%ndof = nj
        b%grav = [0.0_dp, 0.0_dp, -9.81_dp]
        call add_tracker(b, [0.0_dp, 0.0_dp, 0.0_dp], [0.0_dp, 0.0_dp, 0.0_dp], eye(3))
        v = 0
        do j = 1, nj
            axis = merge([0.0_dp, 0.0_dp, 1.0_dp], [0.0_dp, 1.0_dp, 0.0_dp], mod(j, 2) == 1)
            v = add_joint(b, v, rpy(0.1_dp*j, -0.05_dp*j, 0.2_dp), [0.05_dp, 0.02_dp*j, merge(0.3_dp, 0.1_dp, j <= 3)], &
                axis, j, 1.0_dp, 0.0_dp, fr=1.0e-3_dp*[1.0_dp, -0.5_dp, 0.3_dp, 0.8_dp, -0.6_dp, 1.0_dp]*mod(j, 3), &
                clat=[8.0e-6_dp, 5.0e-6_dp], ljoint=law_linear, lpar=[2.0e-5_dp])
            k = add_par(b, 0.01_dp*(-1)**j, 3, 1.0_dp)
            call add_geo(b, v, k, 1.0_dp)
            call add_body(b, v, 12.0_dp - j, [0.1_dp, 0.0_dp, 0.05_dp])
        end do
        v = add_joint(b, v, eye(3), [0.0_dp, 0.0_dp, 0.15_dp], axis, -1, 0.0_dp, 0.0_dp, ljoint=0)
        call setup(b, m, info)
        call expect(info == sk_ok, 'compensate: setup')
        frame = v
        do i = 1, nr
            do j = 1, nj
                q(j, i) = 1.2_dp*sin(0.7_dp*i + 1.9_dp*j) + 0.3_dp
            end do
        end do
        ! nominal targets: no geometric errors, rigid
        theta0 = 0
        call frame_jacobian_batch(m, theta0(1:b%npar), frame, q, none, none, nol, 0_ip, 1.0e-12_dp, rt, pt, jq, &
            delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'compensate: nominal poses')
        call compensate_batch(m, b%theta(1:b%npar), frame, q, rt, pt, none, none, nol, int(full6, ip), 100_ip, &
            1.0e-14_dp, 20_ip, 1.0e-12_dp, 1.0e-12_dp, qout, resp, resr, nit, rinfo, info)
        call expect(info == sk_ok, 'compensate: info')
        write (msg, '(a, i0, a, i0, a, es9.2, a, es9.2, a, i0)') 'compensate: ', nj, ' joints, full6 ', full6, &
            ': max residual ', maxval(resp), ' m, ', maxval(resr), ' rad, Newton steps <= ', maxval(nit)
        print '(a)', trim(msg)
        call expect(all(rinfo == sk_ok), 'compensate: every row converged')
        call expect(maxval(resp) < 1.0e-12_dp, 'compensate: position residual < 1e-12 m')
        if (full6 == 1) call expect(maxval(resr) < 1.0e-12_dp, 'compensate: rotation residual < 1e-12 rad')
        call expect(maxval(abs(qout - q)) > 1.0e-3_dp, 'compensate: the command moved')
        ! independent check of the pose reached, and least-norm optimality
        call frame_jacobian_batch(m, b%theta(1:b%npar), frame, qout, none, none, nol, 100_ip, 1.0e-14_dp, rf, pf, jq, &
            delta, nit, eqinfo, info)
        err = maxval(norm2(pf - pt, dim=1))
        call expect(err < 2.0e-12_dp, 'compensate: the identified model reaches the target')
        ! the same through poses_batch, on the model as given (no folding)
        allocate(ra(3, 3, b%nv, nr), pa(3, b%nv, nr), wv(b%nv, nr), tauq(nj, nr))
        call poses_batch(m, b%theta(1:b%npar), qout, none, none, nol, 100_ip, 1.0e-14_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        err = maxval(norm2(pa(:, v, :) - pt, dim=1))
        call expect(info == sk_ok .and. err < 2.0e-12_dp, 'compensate: target reached (unfolded model)')
        err = 0
        do i = 1, nr
            err = max(err, maxval(abs(ra(:, :, v, i) - rf(:, :, i))))
        end do
        call expect(err < 1.0e-14_dp .and. maxval(abs(pa(:, v, :) - pf)) < 1.0e-14_dp, &
            'compensate: folded and unfolded model agree')
        nrow = merge(6, 3, full6 == 1)
        allocate(u(nrow, nrow), s(nrow), vt(nrow, nj))
        opt = 0
        do i = 1, nr
            call svd(jq(1:nrow, :, i), u, s, vt, info)
            ! (q' - q) has no component in the null space: it lies in the row space
            opt = max(opt, norm2((qout(:, i) - q(:, i)) - matmul(transpose(vt), &
                matmul(vt, qout(:, i) - q(:, i))))/norm2(qout(:, i) - q(:, i)))
        end do
        print '(a, es9.2)', 'compensate: null-space part of the change of q (relative) ', opt
        call expect(opt < 1.0e-6_dp, 'compensate: least-norm change of q')
    end subroutine test_compensate

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
