!> Entry points of the springs / parallel-robot / indices core that f2py
!> wraps (bindings/springs/_springs.pyf). Plain external subroutines with
!> explicit-shape arrays of iso_c_binding kinds and an integer `info`.

!> Spring tree (postfix program prog[2,nops]) at np postures; see
!> sk_springs::spring_tree_batch for every argument.
subroutine sk_spring_tree(nops, ns, nj, np, prog, lkind, lmat, lrot, lpos, jtype, jcomp, &
        jpassive, jaxis, jpoint, tpos, trot, lscale, rcond, c, k, free, nfree, rigid, nrigid, &
        ratio, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_springs, only: spring_tree_batch
    implicit none
    integer(c_int), intent(in) :: nops, ns, nj, np
    integer(c_int), intent(in) :: prog(2, nops), lkind(ns), jtype(nj), jpassive(nj)
    real(c_double), intent(in) :: lmat(6, 6, ns), lrot(3, 3, ns, np), lpos(3, ns, np)
    real(c_double), intent(in) :: jcomp(nj), jaxis(3, nj, np), jpoint(3, nj, np)
    real(c_double), intent(in) :: tpos(3, np), trot(3, 3, np), lscale, rcond
    real(c_double), intent(out) :: c(6, 6, np), k(6, 6, np), free(6, 6, np), rigid(6, 6, np)
    real(c_double), intent(out) :: ratio(np)
    integer(c_int), intent(out) :: nfree(np), nrigid(np), info
    call spring_tree_batch(prog, lkind, lmat, lrot, lpos, jtype, jcomp, jpassive, jaxis, &
        jpoint, tpos, trot, lscale, rcond, c, k, free, nfree, rigid, nrigid, ratio, info)
end subroutine sk_spring_tree

!> Stiffness indices kappa_t, kappa_r (eqs. 31-39, length scale lscale)
!> of np stiffness matrices k[6,6,np].
subroutine sk_stiffness_indices(np, k, lscale, kt, kr, lamf, lamn, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_indices, only: stiffness_indices
    implicit none
    integer(c_int), intent(in) :: np
    real(c_double), intent(in) :: k(6, 6, np), lscale
    real(c_double), intent(out) :: kt(np), kr(np), lamf(3, np), lamn(3, np)
    integer(c_int), intent(out) :: info
    integer :: i
    info = sk_ok
    do i = 1, np
        call stiffness_indices(k(:, :, i), lscale, kt(i), kr(i), lamf(:, i), lamn(:, i), info)
        if (info /= sk_ok) return
    end do
end subroutine sk_stiffness_indices

!> Compliances (or stiffnesses) c[6,6,n], each given in a frame whose axes
!> are the columns of rot[3,3,n], expressed in the outer frame:
!> diag(R,R) c diag(R,R)^T (sk_spatial::rotate6).
subroutine sk_rotate6(n, rot, c, cr, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok, sk_err_nonfinite
    use sk_linalg, only: all_finite
    use sk_spatial, only: rotate6
    implicit none
    integer(c_int), intent(in) :: n
    real(c_double), intent(in) :: rot(3, 3, n), c(6, 6, n)
    real(c_double), intent(out) :: cr(6, 6, n)
    integer(c_int), intent(out) :: info
    integer :: i
    cr = 0.0_c_double
    if (.not. (all_finite(rot) .and. all_finite(c))) then
        info = sk_err_nonfinite
        return
    end if
    do i = 1, n
        cr(:, :, i) = rotate6(rot(:, :, i), c(:, :, i))
    end do
    info = sk_ok
end subroutine sk_rotate6

!> How far each of n 6x6 springs m[6,6,n] (compliance or stiffness) is
!> from positive semi-definite, unit-free (sk_linalg::psd_defect): dmin(i)
!> < -tol means spring i has a negative eigenvalue. tol is psd_tol.
subroutine sk_psd_defect(n, m, dmin, tol)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_small_sym, only: psd_defect, psd_tol
    use sk_linalg, only: all_finite
    implicit none
    integer(c_int), intent(in) :: n
    real(c_double), intent(in) :: m(6, 6, n)
    real(c_double), intent(out) :: dmin(n), tol
    integer :: i
    tol = psd_tol
    do i = 1, n
        if (all_finite(m(:, :, i))) then
            dmin(i) = psd_defect(6, m(:, :, i))
        else
            dmin(i) = -huge(1.0_c_double)
        end if
    end do
end subroutine sk_psd_defect
