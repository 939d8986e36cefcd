!> The test tree builder of the tree core's unit tests (test_tree,
!> test_tree_solve): a tree under construction with fixed capacity, its
!> virtual joints, law blocks, bodies, markers and tracker added one by one,
!> the model set-up from it, the two-arm test tree and its observations.
module tree_builder
    use sk_kinds, only: dp, ip
    use sk_rotation, only: rot_exp
    use sk_linalg, only: eye
    use sk_tree
    implicit none (type, external)
    private
    public :: cap, builder, add_vj, add_par, add_geo, add_block, add_body, add_marker, add_joint, add_tracker
    public :: setup, rpy, build_tree, observations

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

contains

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

end module tree_builder
