!> Argument checks of the kinematic-tree core (sk_tree, sk_tree_solve,
!> sk_api_tree) that say which argument and which index were wrong: every
!> check returns info (sk_errors: size, nonfinite or argument) and
!> loc = [argument code, index] of the first failure (loc = 0 when all is
!> well). The index is 1-based: the virtual joint (vparent .. qconst), the
!> geometric entry (gvj, gpar, gcoef), the block (ktype, kvj, kpar, kw0),
!> the body (bvj, bmass, bcom), the tracker slot (tpar), the marker (mvj,
!> mpar), the parameter (theta), the posture (q, qcmd: its column), the
!> payload (lpost, lvj, lw), the observation (opost .. owt), the position
!> in the free list (free), the row (frame, rtarget, ptarget), the law
!> parameter (prow); 0 when the argument as a whole is wrong (its size,
!> a scalar). The codes are named in bindings/errors.py (TREE_ARGUMENTS),
!> which tests/test_architecture.py keeps in step with this table.
module sk_tree_check
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: eye, all_finite
    use sk_spatial, only: nsym
    use sk_laws, only: law_linear, law_deadzone, law_joint, law_ndof, nlaw
    implicit none
    private
    public :: model_check, inputs_check, observations_check, rows_check, params_check, is_rotation
    !> record the first argument error (shared with the design core's checks)
    public :: fail

    integer, parameter, public :: vj_fixed = 0, vj_revolute = 1, vj_prismatic = 2

    !> argument codes of loc(1)
    integer(ip), parameter, public :: arg_vparent = 1, arg_vtype = 2, arg_vaxis = 3, arg_vrot = 4, &
        arg_vpos = 5, arg_qcol = 6, arg_qcoef = 7, arg_qconst = 8, arg_gvj = 9, arg_gpar = 10, &
        arg_gcoef = 11, arg_ktype = 12, arg_kvj = 13, arg_kpar = 14, arg_kw0 = 15, arg_bvj = 16, &
        arg_bmass = 17, arg_bcom = 18, arg_grav = 19, arg_tpar = 20, arg_rref = 21, arg_mvj = 22, &
        arg_mpar = 23, arg_ne = 24, arg_theta = 25, arg_q = 26, arg_lpost = 27, arg_lvj = 28, &
        arg_lw = 29, arg_opost = 30, arg_omark = 31, arg_oxyz = 32, arg_owt = 33, arg_free = 34, &
        arg_frame = 35, arg_rtarget = 36, arg_ptarget = 37, arg_prow = 38, arg_trow = 39, &
        arg_etol = 40

contains

    pure logical function is_rotation(r)
        real(dp), intent(in) :: r(3, 3)
        is_rotation = maxval(abs(matmul(transpose(r), r) - eye(3))) < 1.0e-9_dp &
            .and. r(1,1)*(r(2,2)*r(3,3) - r(2,3)*r(3,2)) - r(1,2)*(r(2,1)*r(3,3) - r(2,3)*r(3,1)) &
            + r(1,3)*(r(2,1)*r(3,2) - r(2,2)*r(3,1)) > 0.0_dp
    end function is_rotation

    !> Record the first failure only.
    pure subroutine fail(code, arg, idx, info, loc)
        integer(ip), intent(in) :: code, arg
        integer, intent(in) :: idx
        integer(ip), intent(inout) :: info, loc(2)
        if (info /= sk_ok) return
        info = code
        loc = [arg, int(idx, ip)]
    end subroutine fail

    !> Column of a[:, :] holding the first non-finite value (0: none).
    integer function bad_column(a) result(c)
        real(dp), intent(in) :: a(:, :)
        integer :: j
        c = 0
        if (all_finite(a)) return
        do j = 1, size(a, 2)
            if (.not. all_finite(a(:, j))) then
                c = j
                return
            end if
        end do
    end function bad_column

    integer function bad_entry(a) result(c)
        real(dp), intent(in) :: a(:)
        c = bad_column(reshape(a, [1, size(a)]))
    end function bad_entry

    !> The checks of a model description (sk_tree%model_setup; the module
    !> header of sk_api_tree lists the arguments): sizes, finite values,
    !> parent order, joint types, unit axes, rotations, joint coordinates,
    !> indices in range, geometric entries on moving joints, law types,
    !> block coordinates on distinct moving joints, dead-zone widths > 0,
    !> masses >= 0.
    subroutine model_check(vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, &
            ktype, kvj, kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, loc)
        integer(ip), intent(in) :: vparent(:), vtype(:), qcol(:), gvj(:), gpar(:), ktype(:), kvj(:, :), &
            kpar(:, :), bvj(:), tpar(:), mvj(:), mpar(:, :), ndof, npar, ne
        real(dp), intent(in) :: vaxis(:, :), vrot(:, :, :), vpos(:, :), qcoef(:), qconst(:), gcoef(:), &
            kw0(:), bmass(:), bcom(:, :), grav(:), rref(:, :)
        integer(ip), intent(out) :: info, loc(2)
        integer :: nv, ng, nk, nb, nm, v, k, j, n, c
        logical, allocatable :: used(:)
        nv = size(vparent)
        ng = size(gvj)
        nk = size(ktype)
        nb = size(bvj)
        nm = size(mvj)
        info = sk_ok
        loc = 0
        ! sizes
        if (size(vtype) /= nv) call fail(sk_err_size, arg_vtype, 0, info, loc)
        if (any(shape(vaxis) /= [3, nv])) call fail(sk_err_size, arg_vaxis, 0, info, loc)
        if (any(shape(vrot) /= [3, 3, nv])) call fail(sk_err_size, arg_vrot, 0, info, loc)
        if (any(shape(vpos) /= [3, nv])) call fail(sk_err_size, arg_vpos, 0, info, loc)
        if (size(qcol) /= nv) call fail(sk_err_size, arg_qcol, 0, info, loc)
        if (size(qcoef) /= nv) call fail(sk_err_size, arg_qcoef, 0, info, loc)
        if (size(qconst) /= nv) call fail(sk_err_size, arg_qconst, 0, info, loc)
        if (size(gpar) /= ng) call fail(sk_err_size, arg_gpar, 0, info, loc)
        if (size(gcoef) /= ng) call fail(sk_err_size, arg_gcoef, 0, info, loc)
        if (any(shape(kvj) /= [6, nk])) call fail(sk_err_size, arg_kvj, 0, info, loc)
        if (any(shape(kpar) /= [nsym, nk])) call fail(sk_err_size, arg_kpar, 0, info, loc)
        if (size(kw0) /= nk) call fail(sk_err_size, arg_kw0, 0, info, loc)
        if (size(bmass) /= nb) call fail(sk_err_size, arg_bmass, 0, info, loc)
        if (any(shape(bcom) /= [3, nb])) call fail(sk_err_size, arg_bcom, 0, info, loc)
        if (size(grav) /= 3) call fail(sk_err_size, arg_grav, 0, info, loc)
        if (size(tpar) /= 6) call fail(sk_err_size, arg_tpar, 0, info, loc)
        if (any(shape(rref) /= [3, 3])) call fail(sk_err_size, arg_rref, 0, info, loc)
        if (any(shape(mpar) /= [3, nm])) call fail(sk_err_size, arg_mpar, 0, info, loc)
        if (ndof < 0) call fail(sk_err_size, arg_q, 0, info, loc)
        if (npar < 0) call fail(sk_err_size, arg_theta, 0, info, loc)
        if (info /= sk_ok) return
        n = 0
        do k = 1, nk
            n = n + law_ndof(ktype(k))
        end do
        if (n /= ne) call fail(sk_err_size, arg_ne, 0, info, loc)
        ! finite values
        c = bad_column(vaxis)
        if (c > 0) call fail(sk_err_nonfinite, arg_vaxis, c, info, loc)
        c = bad_column(reshape(vrot, [9, nv]))
        if (c > 0) call fail(sk_err_nonfinite, arg_vrot, c, info, loc)
        c = bad_column(vpos)
        if (c > 0) call fail(sk_err_nonfinite, arg_vpos, c, info, loc)
        c = bad_entry(qcoef)
        if (c > 0) call fail(sk_err_nonfinite, arg_qcoef, c, info, loc)
        c = bad_entry(qconst)
        if (c > 0) call fail(sk_err_nonfinite, arg_qconst, c, info, loc)
        c = bad_entry(gcoef)
        if (c > 0) call fail(sk_err_nonfinite, arg_gcoef, c, info, loc)
        c = bad_entry(kw0)
        if (c > 0) call fail(sk_err_nonfinite, arg_kw0, c, info, loc)
        c = bad_entry(bmass)
        if (c > 0) call fail(sk_err_nonfinite, arg_bmass, c, info, loc)
        c = bad_column(bcom)
        if (c > 0) call fail(sk_err_nonfinite, arg_bcom, c, info, loc)
        if (.not. all_finite(grav)) call fail(sk_err_nonfinite, arg_grav, 0, info, loc)
        if (.not. all_finite(rref)) call fail(sk_err_nonfinite, arg_rref, 0, info, loc)
        if (info /= sk_ok) return
        ! values
        do v = 1, nv
            if (vparent(v) < 0 .or. vparent(v) >= v) call fail(sk_err_argument, arg_vparent, v, info, loc)
            if (vtype(v) < vj_fixed .or. vtype(v) > vj_prismatic) call fail(sk_err_argument, arg_vtype, v, info, loc)
            if (info /= sk_ok) return
            if (vtype(v) /= vj_fixed .and. abs(norm2(vaxis(:, v)) - 1.0_dp) > 1.0e-9_dp) &
                call fail(sk_err_argument, arg_vaxis, v, info, loc)
            if (.not. is_rotation(vrot(:, :, v))) call fail(sk_err_argument, arg_vrot, v, info, loc)
            if (qcol(v) < 0 .or. qcol(v) > ndof) call fail(sk_err_argument, arg_qcol, v, info, loc)
            if (info /= sk_ok) return
        end do
        if (.not. is_rotation(rref)) call fail(sk_err_argument, arg_rref, 0, info, loc)
        do k = 1, ng
            if (gvj(k) < 1 .or. gvj(k) > nv) then
                call fail(sk_err_argument, arg_gvj, k, info, loc)
            else if (vtype(gvj(k)) == vj_fixed) then
                call fail(sk_err_argument, arg_gvj, k, info, loc)
            end if
            if (gpar(k) < 1 .or. gpar(k) > npar) call fail(sk_err_argument, arg_gpar, k, info, loc)
        end do
        do k = 1, 6
            if (tpar(k) < 1 .or. tpar(k) > npar) call fail(sk_err_argument, arg_tpar, k, info, loc)
        end do
        do k = 1, nm
            if (mvj(k) < 0 .or. mvj(k) > nv) call fail(sk_err_argument, arg_mvj, k, info, loc)
            if (any(mpar(:, k) < 1) .or. any(mpar(:, k) > npar)) call fail(sk_err_argument, arg_mpar, k, info, loc)
        end do
        do k = 1, nb
            if (bvj(k) < 0 .or. bvj(k) > nv) call fail(sk_err_argument, arg_bvj, k, info, loc)
            if (bmass(k) < 0.0_dp) call fail(sk_err_argument, arg_bmass, k, info, loc)
        end do
        if (info /= sk_ok) return
        allocate(used(nv))
        used = .false.
        do k = 1, nk
            if (ktype(k) < law_linear .or. ktype(k) > nlaw) call fail(sk_err_argument, arg_ktype, k, info, loc)
            if (any(kpar(:, k) < 0) .or. any(kpar(:, k) > npar)) call fail(sk_err_argument, arg_kpar, k, info, loc)
            if ((ktype(k) == law_deadzone .or. ktype(k) == law_joint) .and. .not. kw0(k) > 0.0_dp) &
                call fail(sk_err_argument, arg_kw0, k, info, loc)
            if (info /= sk_ok) return
            do j = 1, law_ndof(ktype(k))
                v = kvj(j, k)
                if (v < 1 .or. v > nv) then
                    call fail(sk_err_argument, arg_kvj, k, info, loc)
                    return
                end if
                ! an elastic coordinate rides on a moving joint that carries no other
                if (vtype(v) == vj_fixed .or. used(v)) call fail(sk_err_argument, arg_kvj, k, info, loc)
                used(v) = .true.
            end do
        end do
    end subroutine model_check

    !> Postures q[ndof,np] and payloads (lpost[nl] into 1..np, lvj[nl] into
    !> 0..nv, lw[6,nl]), theta[npar], etol of a call on a model of nv joints.
    subroutine inputs_check(nv, ndof, npar, theta, q, lpost, lvj, lw, etol, info, loc)
        integer, intent(in) :: nv, ndof, npar
        real(dp), intent(in) :: theta(:), q(:, :), lw(:, :), etol
        integer(ip), intent(in) :: lpost(:), lvj(:)
        integer(ip), intent(out) :: info, loc(2)
        integer :: i, c, nl, np
        info = sk_ok
        loc = 0
        nl = size(lpost)
        np = size(q, 2)
        if (size(theta) /= npar) call fail(sk_err_size, arg_theta, 0, info, loc)
        if (size(q, 1) /= ndof) call fail(sk_err_size, arg_q, 0, info, loc)
        if (size(lvj) /= nl) call fail(sk_err_size, arg_lvj, 0, info, loc)
        if (any(shape(lw) /= [6, nl])) call fail(sk_err_size, arg_lw, 0, info, loc)
        if (info /= sk_ok) return
        c = bad_entry(theta)
        if (c > 0) call fail(sk_err_nonfinite, arg_theta, c, info, loc)
        c = bad_column(q)
        if (c > 0) call fail(sk_err_nonfinite, arg_q, c, info, loc)
        c = bad_column(lw)
        if (c > 0) call fail(sk_err_nonfinite, arg_lw, c, info, loc)
        if (.not. etol == etol) call fail(sk_err_nonfinite, arg_etol, 0, info, loc)
        do i = 1, nl
            if (lpost(i) < 1 .or. lpost(i) > np) call fail(sk_err_argument, arg_lpost, i, info, loc)
            if (lvj(i) < 0 .or. lvj(i) > nv) call fail(sk_err_argument, arg_lvj, i, info, loc)
        end do
    end subroutine inputs_check

    !> Observations (opost[no] into 1..np, omark[no] into 1..nm, oxyz[3,no],
    !> owt[no] >= 0) and the free list (distinct indices into 1..npar).
    subroutine observations_check(np, nm, npar, opost, omark, oxyz, owt, free, info, loc)
        integer, intent(in) :: np, nm, npar
        integer(ip), intent(in) :: opost(:), omark(:), free(:)
        real(dp), intent(in) :: oxyz(:, :), owt(:)
        integer(ip), intent(out) :: info, loc(2)
        integer :: i, c, no
        integer, allocatable :: seen(:)
        info = sk_ok
        loc = 0
        no = size(opost)
        if (size(omark) /= no) call fail(sk_err_size, arg_omark, 0, info, loc)
        if (any(shape(oxyz) /= [3, no])) call fail(sk_err_size, arg_oxyz, 0, info, loc)
        if (size(owt) /= no) call fail(sk_err_size, arg_owt, 0, info, loc)
        if (info /= sk_ok) return
        c = bad_column(oxyz)
        if (c > 0) call fail(sk_err_nonfinite, arg_oxyz, c, info, loc)
        c = bad_entry(owt)
        if (c > 0) call fail(sk_err_nonfinite, arg_owt, c, info, loc)
        do i = 1, no
            if (opost(i) < 1 .or. opost(i) > np) call fail(sk_err_argument, arg_opost, i, info, loc)
            if (omark(i) < 1 .or. omark(i) > nm) call fail(sk_err_argument, arg_omark, i, info, loc)
            if (.not. owt(i) >= 0.0_dp) call fail(sk_err_argument, arg_owt, i, info, loc)
        end do
        if (info /= sk_ok) return
        allocate(seen(npar))
        seen = 0
        do i = 1, size(free)
            if (free(i) < 1 .or. free(i) > npar) then
                call fail(sk_err_argument, arg_free, i, info, loc)
                return
            end if
            if (seen(free(i)) /= 0) call fail(sk_err_argument, arg_free, i, info, loc)
            seen(free(i)) = i
        end do
    end subroutine observations_check

    !> Rows of a frame Jacobian or compensation: frame[n] into 0..nv and,
    !> when given, targets rtarget[3,3,n] (rotations) and ptarget[3,n].
    subroutine rows_check(nv, n, frame, info, loc, rtarget, ptarget)
        integer, intent(in) :: nv, n
        integer(ip), intent(in) :: frame(:)
        integer(ip), intent(out) :: info, loc(2)
        real(dp), intent(in), optional :: rtarget(:, :, :), ptarget(:, :)
        integer :: i, c
        info = sk_ok
        loc = 0
        if (size(frame) /= n) call fail(sk_err_size, arg_frame, 0, info, loc)
        if (present(rtarget)) then
            if (any(shape(rtarget) /= [3, 3, n])) call fail(sk_err_size, arg_rtarget, 0, info, loc)
        end if
        if (present(ptarget)) then
            if (any(shape(ptarget) /= [3, n])) call fail(sk_err_size, arg_ptarget, 0, info, loc)
        end if
        if (info /= sk_ok) return
        if (present(rtarget)) then
            c = bad_column(reshape(rtarget, [9, n]))
            if (c > 0) call fail(sk_err_nonfinite, arg_rtarget, c, info, loc)
        end if
        if (present(ptarget)) then
            c = bad_column(ptarget)
            if (c > 0) call fail(sk_err_nonfinite, arg_ptarget, c, info, loc)
        end if
        do i = 1, n
            if (frame(i) < 0 .or. frame(i) > nv) call fail(sk_err_argument, arg_frame, i, info, loc)
            if (present(rtarget)) then
                if (info == sk_ok .and. .not. is_rotation(rtarget(:, :, i))) &
                    call fail(sk_err_argument, arg_rtarget, i, info, loc)
            end if
        end do
    end subroutine rows_check

    !> Law parameters that take a value per row: prow[npr] into 1..npar,
    !> trow[npr,nr] finite.
    subroutine params_check(npar, prow, trow, info, loc)
        integer, intent(in) :: npar
        integer(ip), intent(in) :: prow(:)
        real(dp), intent(in) :: trow(:, :)
        integer(ip), intent(out) :: info, loc(2)
        integer :: i, c
        info = sk_ok
        loc = 0
        if (size(trow, 1) /= size(prow)) call fail(sk_err_size, arg_trow, 0, info, loc)
        if (info /= sk_ok) return
        c = bad_column(trow)
        if (c > 0) call fail(sk_err_nonfinite, arg_trow, c, info, loc)
        do i = 1, size(prow)
            if (prow(i) < 1 .or. prow(i) > npar) call fail(sk_err_argument, arg_prow, i, info, loc)
        end do
    end subroutine params_check

end module sk_tree_check
