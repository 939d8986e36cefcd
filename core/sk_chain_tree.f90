!> A serial chain is a tree: the tree model (sk_tree_model) of a chain
!> (sk_chain's description: jrot, jpos, jaxis, qidx, trot, tpos) with its
!> virtual springs (stype, sidx) as elastic coordinates and their law
!> blocks, so that the deflection model of relative data (sk_deflect) is
!> the core's one robot model with deflection observations (sk_tree_model
!> obs_deflection, obs_rotation), evaluated by sk_tree_jac evaluate.
!>
!> Virtual joints, parent before child: a base spring (stype 3) as six
!> joints at the base origin (prismatic x, y, z, then revolute x, y, z, base
!> axes); for every chain joint k, a spring at F_k (stype 2, sidx k) as six
!> such joints in F_k (the first carries joint k's origin), then joint k
!> (revolute on its q column, its joint spring (stype 1) an elastic
!> coordinate on it; fixed when qidx(k) = 0); the tool frame (a fixed
!> joint); a tool spring (stype 4) as six joints in the tool frame. The
!> last joint is the tool frame after its spring: the load acts there and
!> the point rides on it. At zero deflection the six joints of a spring
!> have the frame of the spring, so their screws are the columns of
!> the columns of the spring's Jacobian J_s (and the generalised forces
!> J_s^T w). The deflection model of relative data (sk_deflect) evaluates
!> it; robot/model_tree.py builds the same tree model in Python for the
!> tool compliance, the springs' Jacobians and compensation.
module sk_chain_tree
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: eye
    use sk_spatial, only: nsym
    use sk_laws, only: law_linear, law_spring6
    use sk_tree_check, only: vj_fixed, vj_revolute, vj_prismatic
    use sk_tree_model, only: tree_model, model_setup
    use sk_chain, only: spring_joint, spring_frame, spring_base, spring_tool, spring_ndof
    implicit none
    private
    public :: chain_tree_model

contains

    !> The tree model m of the chain with its springs; sv(s): the first
    !> virtual joint of spring s (module header); tool: the last joint.
    !> Optional law blocks (all or none): spring s is block s of law
    !> bktype(s) with parameters theta(bkpar(:, s)) and width bkw0(s)
    !> (default: law_linear or law_spring6, every parameter 0), npar the
    !> length of theta, tpar[6] the tracker's parameters and mpar[3] those
    !> of one marker on the tool frame (its point).
    subroutine chain_tree_model(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, ndof, m, sv, tool, info, &
            bktype, bkpar, bkw0, npar, tpar, mpar)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:), ndof
        type(tree_model), intent(out) :: m
        integer, intent(out) :: sv(:), tool
        integer(ip), intent(out) :: info
        integer(ip), intent(in), optional :: bktype(:), bkpar(:, :), npar, tpar(6), mpar(3)
        real(dp), intent(in), optional :: bkw0(:)
        integer(ip), allocatable :: vparent(:), vtype(:), qcol(:), ktype(:), kvj(:, :), kpar(:, :)
        real(dp), allocatable :: vaxis(:, :), vrot(:, :, :), vpos(:, :), qcoef(:), qconst(:), kw0(:)
        integer(ip) :: none(0), nonem(3, 0)
        real(dp) :: noner(0), noner3(3, 0)
        integer :: nj, ns, nv, nk, ne, s, k, v
        nj = size(qidx)
        ns = size(stype)
        nv = nj + 1 + 6*count(stype /= spring_joint)
        nk = ns
        ne = 0
        do s = 1, ns
            ne = ne + spring_ndof(stype(s))
        end do
        allocate(vparent(nv), vtype(nv), qcol(nv), vaxis(3, nv), vrot(3, 3, nv), vpos(3, nv), qcoef(nv), &
            qconst(nv), ktype(nk), kvj(6, nk), kpar(nsym, nk), kw0(nk))
        qcol = 0
        qcoef = 1.0_dp
        qconst = 0.0_dp
        vpos = 0.0_dp
        vaxis = 0.0_dp
        vaxis(1, :) = 1.0_dp
        do v = 1, nv
            vrot(:, :, v) = eye(3)
            vparent(v) = v - 1
        end do
        vtype = vj_fixed
        kvj = 0
        kpar = 0
        kw0 = 1.0_dp
        sv = 0
        v = 0
        do s = 1, ns
            if (stype(s) == spring_base) call six(s)
        end do
        do k = 1, nj
            do s = 1, ns
                if (stype(s) == spring_frame .and. sidx(s) == k) call six(s)
            end do
            v = v + 1
            ! joint k: its origin, unless a spring at F_k carries it already
            if (.not. any(stype == spring_frame .and. sidx == k)) then
                vrot(:, :, v) = jrot(:, :, k)
                vpos(:, v) = jpos(:, k)
            end if
            vaxis(:, v) = jaxis(:, k)
            if (qidx(k) > 0) then
                vtype(v) = vj_revolute
                qcol(v) = qidx(k)
            end if
            do s = 1, ns
                if (stype(s) == spring_joint .and. sidx(s) == k) then
                    sv(s) = v
                    ktype(s) = law_linear
                    kvj(1, s) = v
                end if
            end do
        end do
        v = v + 1
        vrot(:, :, v) = trot
        vpos(:, v) = tpos
        do s = 1, ns
            if (stype(s) == spring_tool) call six(s)
        end do
        tool = v
        if (present(bktype)) then
            ktype = bktype
            kpar = bkpar
            kw0 = bkw0
            call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, none, none, noner, &
                ktype, kvj, kpar, kw0, none, noner, noner3, [0.0_dp, 0.0_dp, 0.0_dp], tpar, eye(3), &
                [int(tool, ip)], reshape(mpar, [3, 1]), ndof, npar, int(ne, ip), info)
            return
        end if
        call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, none, none, noner, &
            ktype, kvj, kpar, kw0, none, noner, noner3, [0.0_dp, 0.0_dp, 0.0_dp], [1, 1, 1, 1, 1, 1], eye(3), &
            none, nonem, ndof, 1_ip, int(ne, ip), info)

    contains

        !> The six joints of 6-dof spring s after joint v (the first takes
        !> joint k's origin for a spring at F_k).
        subroutine six(s)
            integer, intent(in) :: s
            integer :: j
            sv(s) = v + 1
            if (stype(s) == spring_frame) then
                vrot(:, :, v + 1) = jrot(:, :, sidx(s))
                vpos(:, v + 1) = jpos(:, sidx(s))
            end if
            do j = 1, 6
                vtype(v + j) = merge(vj_prismatic, vj_revolute, j <= 3)
                vaxis(:, v + j) = 0.0_dp
                vaxis(mod(j - 1, 3) + 1, v + j) = 1.0_dp
                kvj(j, s) = v + j
            end do
            ktype(s) = law_spring6
            v = v + 6
        end subroutine six
    end subroutine chain_tree_model

end module sk_chain_tree
