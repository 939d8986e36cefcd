!> A tree model with its constant joints folded away (sk_tree_model):
!> joints without a joint or elastic coordinate (fixed ones, frame errors
!> at theta) merged into their children, for the routines that work on a
!> few frames only (the frame Jacobian, compensation).
module sk_tree_fold
    use sk_kinds, only: dp, ip
    use sk_linalg, only: eye
    use sk_rotation, only: rot_exp
    use sk_tree_check, only: vj_revolute, vj_prismatic
    use sk_tree_model, only: tree_model, model_setup, body_effective
    implicit none
    private
    public :: model_fold, fold_for_frames

contains

    !> The model with every joint of constant value folded away: a joint
    !> with no joint coordinate and no elastic coordinate (fixed, or moved
    !> by parameters only, e.g. a frame error, at theta) and not keep(v)
    !> disappears, its transform (with its motion) merged into its
    !> children's origins and its bodies moved to the nearest kept ancestor.
    !> Poses, forces and derivatives w.r.t. q of the kept joints are those
    !> of m (to rounding), at a fraction of the cost when frame errors are
    !> known (compensation). newidx(v): the kept joint's index in mf (0:
    !> folded, or the base). Markers are dropped (mf%nm = 0).
    subroutine model_fold(m, theta, keep, mf, newidx, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        logical, intent(in) :: keep(:)
        type(tree_model), intent(out) :: mf
        integer, intent(out) :: newidx(0:)
        integer(ip), intent(out) :: info
        logical :: kept(m%nv), direct
        real(dp) :: racc(3, 3, 0:m%nv), pacc(3, 0:m%nv), rb(3, 3), pb(3), val, mot(3, 3)
        integer :: anc(0:m%nv), v, p, n, b, k, j, ng
        integer(ip), allocatable :: vparent(:), vtype(:), qcol(:), gvj(:), gpar(:), kvj(:, :), bvj(:), none(:), &
            nomp(:, :)
        real(dp), allocatable :: vaxis(:, :), vrot(:, :, :), vpos(:, :), qcoef(:), qconst(:), gcoef(:), bcom(:, :), &
            bm(:), bc(:, :), dm(:)
        kept = keep .or. m%qcol > 0 .or. m%vel > 0
        n = count(kept)
        allocate(vparent(n), vtype(n), qcol(n), vaxis(3, n), vrot(3, 3, n), vpos(3, n), qcoef(n), qconst(n))
        newidx = 0
        anc(0) = 0
        racc(:, :, 0) = eye(3)
        pacc(:, 0) = 0.0_dp
        n = 0
        do v = 1, m%nv
            p = m%parent(v)
            ! transform from the nearest kept ancestor (after motion) to v before motion
            direct = p == 0
            if (.not. direct) direct = kept(p)
            if (direct) then
                anc(v) = p
                rb = m%rot(:, :, v)
                pb = m%pos(:, v)
            else
                anc(v) = anc(p)
                rb = matmul(racc(:, :, p), m%rot(:, :, v))
                pb = pacc(:, p) + matmul(racc(:, :, p), m%pos(:, v))
            end if
            if (kept(v)) then
                n = n + 1
                newidx(v) = n
                vparent(n) = newidx(anc(v))
                vtype(n) = m%vtype(v)
                vaxis(:, n) = m%axis(:, v)
                vrot(:, :, n) = rb
                vpos(:, n) = pb
                qcol(n) = m%qcol(v)
                qcoef(n) = m%qcoef(v)
                qconst(n) = m%qconst(v)
                racc(:, :, v) = eye(3)
                pacc(:, v) = 0.0_dp
            else
                val = m%qconst(v)
                do k = m%gstart(v), m%gstart(v + 1) - 1
                    val = val + m%gcoef(k)*theta(m%gpar(k))
                end do
                mot = eye(3)
                if (m%vtype(v) == vj_revolute) mot = rot_exp(m%axis(:, v)*val)
                racc(:, :, v) = matmul(rb, mot)
                pacc(:, v) = pb
                if (m%vtype(v) == vj_prismatic) pacc(:, v) = pb + matmul(rb, m%axis(:, v))*val
            end if
        end do
        ! geometric entries of kept joints (joint offsets)
        ng = 0
        do v = 1, m%nv
            if (kept(v)) ng = ng + m%gstart(v + 1) - m%gstart(v)
        end do
        allocate(gvj(ng), gpar(ng), gcoef(ng))
        ng = 0
        do v = 1, m%nv
            if (.not. kept(v)) cycle
            do k = m%gstart(v), m%gstart(v + 1) - 1
                ng = ng + 1
                gvj(ng) = newidx(v)
                gpar(ng) = m%gpar(k)
                gcoef(ng) = m%gcoef(k)
            end do
        end do
        allocate(kvj(6, m%nk))
        kvj = 0
        do k = 1, m%nk
            do j = 1, m%kdim(k)
                kvj(j, k) = newidx(m%evj(m%kfirst(k) + j - 1))
            end do
        end do
        ! bodies at theta's gravity parameters (the folded model has none)
        allocate(bvj(m%nb), bcom(3, m%nb), none(0), nomp(3, 0), bm(m%nb), bc(3, m%nb), dm(m%nbp))
        call body_effective(m, theta, bm, bc, dm)
        do b = 1, m%nb
            v = m%bvj(b)
            bcom(:, b) = bc(:, b)
            bvj(b) = 0
            if (v == 0) cycle
            if (kept(v)) then
                bvj(b) = newidx(v)
            else
                bvj(b) = newidx(anc(v))
                bcom(:, b) = pacc(:, v) + matmul(racc(:, :, v), bc(:, b))
            end if
        end do
        call model_setup(mf, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, &
            m%ktype, kvj, m%kpar, m%kw0, bvj, bm, bcom, m%grav, m%tpar, m%rref, none, nomp, &
            int(m%ndof, ip), int(m%npar, ip), int(m%ne, ip), info)
        mf%lscale = m%lscale
    end subroutine model_fold

    !> model_fold keeping the frames frame(:) and the payload frames lvj(:)
    !> (0 = base), for the routines that work on those frames only.
    subroutine fold_for_frames(m, theta, frame, lvj, mf, newidx, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        integer(ip), intent(in) :: frame(:), lvj(:)
        type(tree_model), intent(out) :: mf
        integer, intent(out) :: newidx(0:)
        integer(ip), intent(out) :: info
        logical :: keep(m%nv)
        integer :: i
        keep = .false.
        do i = 1, size(frame)
            if (frame(i) > 0) keep(frame(i)) = .true.
        end do
        do i = 1, size(lvj)
            if (lvj(i) > 0) keep(lvj(i)) = .true.
        end do
        call model_fold(m, theta, keep, mf, newidx, info)
    end subroutine fold_for_frames

end module sk_tree_fold
