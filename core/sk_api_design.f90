!> Entry points of the experiment-design core that f2py wraps
!> (bindings/_design.pyf): plain external subroutines with explicit-shape
!> arrays of iso_c_binding kinds, an integer `info` (sk_errors) and
!> errloc[2] = [argument code, index] of an argument error (the codes of
!> sk_design, darg_*); the numerics live in sk_design, whose header defines
!> the criteria and the scaling.
!>
!> Shared arguments: jc[npar,nobs,ncand] (candidate c's whitened rows
!> J_c^T, i.e. the Python array (ncand, nobs, npar) in C order), m0[npar,npar]
!> (prior information, symmetric PSD; zeros for none), jt[npar,nt] (the
!> task rows Jt^T; nt = 0 unless crit = 3), crit (1 D, 2 A, 3 task).
!> Candidate indices are 1-based.

!> Greedy + exchange selection of k candidates (sk_design%design_select):
!> sel[k], value (huge when M stays singular: singular = 1), gvalue (the
!> greedy selection's), path[k] (with the ridge when ridged = 1), passes, swaps,
!> scale[npar].
subroutine sk_design_select(npar, nobs, ncand, nt, nst, jc, k, crit, m0, jt, max_passes, start, sel, value, &
        gvalue, path, passes, swaps, scale, singular, ridged, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok, sk_err_argument
    use sk_design, only: design_check, design_select, darg_k, darg_max_passes
    implicit none
    integer(c_int), intent(in) :: npar, nobs, ncand, nt, nst, k, crit, max_passes, start(nst)
    real(c_double), intent(in) :: jc(npar, nobs, ncand), m0(npar, npar), jt(npar, nt)
    integer(c_int), intent(out) :: sel(k), passes, swaps, singular, ridged, info, errloc(2)
    real(c_double), intent(out) :: value, gvalue, path(k), scale(npar)
    sel = 0
    path = 0
    scale = 0
    value = 0
    gvalue = 0
    passes = 0
    swaps = 0
    singular = 0
    ridged = 0
    call design_check(jc, m0, jt, crit, start, info, errloc)
    if (info /= sk_ok) return
    if (k < 1 .or. k > ncand .or. (nst /= 0 .and. nst /= k)) then
        info = sk_err_argument
        errloc = [darg_k, 0_c_int]
        return
    end if
    if (max_passes < 0) then
        info = sk_err_argument
        errloc = [darg_max_passes, 0_c_int]
        return
    end if
    call design_select(jc, k, crit, m0, jt, max_passes, sel, value, gvalue, path, passes, swaps, scale, singular, &
        ridged, info, start)
end subroutine sk_design_select

!> Direct criterion of chosen[nch] (Cholesky from scratch): value (huge and
!> bad = the first non-identifiable column when M is singular), scale[npar].
subroutine sk_design_criterion(npar, nobs, ncand, nt, nch, jc, chosen, crit, m0, jt, value, bad, scale, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_design, only: design_check, criterion_direct
    implicit none
    integer(c_int), intent(in) :: npar, nobs, ncand, nt, nch, chosen(nch), crit
    real(c_double), intent(in) :: jc(npar, nobs, ncand), m0(npar, npar), jt(npar, nt)
    real(c_double), intent(out) :: value, scale(npar)
    integer(c_int), intent(out) :: bad, info, errloc(2)
    integer :: b
    value = 0
    scale = 0
    bad = 0
    call design_check(jc, m0, jt, crit, chosen, info, errloc)
    if (info /= sk_ok) return
    call criterion_direct(jc, m0, jt, chosen, crit, value, b, scale)
    bad = int(b, c_int)
end subroutine sk_design_criterion

!> Covariance cov[npar,npar] = M^-1 of chosen[nch] in the caller's units;
!> info = sk_err_singular and bad = the first non-identifiable column when
!> M is singular.
subroutine sk_design_covariance(npar, nobs, ncand, nch, jc, chosen, m0, cov, bad, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok, sk_err_singular
    use sk_design, only: design_check, design_covariance, crit_d
    implicit none
    integer(c_int), intent(in) :: npar, nobs, ncand, nch, chosen(nch)
    real(c_double), intent(in) :: jc(npar, nobs, ncand), m0(npar, npar)
    real(c_double), intent(out) :: cov(npar, npar)
    integer(c_int), intent(out) :: bad, info, errloc(2)
    real(c_double) :: jt0(npar, 0)
    integer :: b
    cov = 0
    bad = 0
    call design_check(jc, m0, jt0, crit_d, chosen, info, errloc)
    if (info /= sk_ok) return
    call design_covariance(jc, m0, chosen, cov, b)
    bad = int(b, c_int)
    if (b > 0) info = sk_err_singular
end subroutine sk_design_covariance

!> T-optimal selection of k candidates (sk_design_disc%disc_select):
!> f[nrow,nh] whitened predictions, jall[nrow,ptot] the hypotheses'
!> whitened Jacobians side by side (hypothesis h: columns hoff(h)+1 ..
!> hoff(h+1), hoff[nh+1]), the first n0 rows existing data, then ncand
!> blocks of nobs rows. sel[k], value (the smallest noncentrality), gvalue
!> (the greedy selection's), pairs[nh,nh] (data of a fitted by b), passes,
!> swaps.
subroutine sk_design_discriminate(nrow, nh, ptot, nh1, f, jall, hoff, n0, nobs, k, max_passes, sel, value, gvalue, &
        pairs, passes, swaps, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_design_disc, only: disc_check, disc_select
    implicit none
    integer(c_int), intent(in) :: nrow, nh, ptot, nh1, hoff(nh1), n0, nobs, k, max_passes
    real(c_double), intent(in) :: f(nrow, nh), jall(nrow, ptot)
    integer(c_int), intent(out) :: sel(k), passes, swaps, info, errloc(2)
    real(c_double), intent(out) :: value, gvalue, pairs(nh, nh)
    sel = 0
    value = 0
    gvalue = 0
    pairs = 0
    passes = 0
    swaps = 0
    call disc_check(f, jall, hoff, n0, nobs, k, max_passes, info, errloc)
    if (info /= sk_ok) return
    call disc_select(f, jall, hoff, n0, nobs, k, max_passes, sel, value, gvalue, pairs, passes, swaps, info)
end subroutine sk_design_discriminate

!> Why each parameter of chosen[nch] stays weak (sk_design_weak%design_weakness):
!> info_d[npar] the information's diagonal, pool[npar] that of all candidates, task[npar] the task influence
!> (jt[npar,nt]: the task rows), ev[npar] the eigenvalues of the
!> unit-diagonal information, nnull and proj[npar,npar] its null space.
subroutine sk_design_weakness(npar, nobs, ncand, nt, nch, jc, chosen, m0, jt, info_d, pool, task, ev, nnull, proj, &
        info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_design, only: design_check, crit_task
    use sk_design_weak, only: design_weakness
    implicit none
    integer(c_int), intent(in) :: npar, nobs, ncand, nt, nch, chosen(nch)
    real(c_double), intent(in) :: jc(npar, nobs, ncand), m0(npar, npar), jt(npar, nt)
    real(c_double), intent(out) :: info_d(npar), pool(npar), task(npar), ev(npar), proj(npar, npar)
    integer(c_int), intent(out) :: nnull, info, errloc(2)
    info_d = 0
    pool = 0
    task = 0
    ev = 0
    proj = 0
    nnull = 0
    call design_check(jc, m0, jt, crit_task, chosen, info, errloc)
    if (info /= sk_ok) return
    call design_weakness(jc, m0, jt, chosen, info_d, pool, task, ev, nnull, proj, info)
end subroutine sk_design_weakness

!> Evaluation of a discrimination design (sk_design_disc, as disc_select
!> evaluates its own: columns of jall scaled to unit norm): with the existing
!> n0 rows and the candidates sel[nsel] (1-based; nsel may be 0),
!> pairs[nh,nh] the noncentralities over those rows (disc_pairs) and
!> tc[ncand] the smallest noncentrality after adding each other candidate
!> alone (disc_evaluate; -huge for the candidates in sel). f, jall, hoff,
!> n0, nobs as sk_design_discriminate.
subroutine sk_design_disc_evaluate(nrow, nh, ptot, nh1, ncand, nsel, f, jall, hoff, n0, nobs, sel, pairs, tc, &
        info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok, sk_err_argument
    use sk_design_base, only: fail, darg_chosen, darg_nobs
    use sk_design_disc, only: disc_check, disc_pairs, disc_evaluate, rows_of, unit_columns
    implicit none
    integer(c_int), intent(in) :: nrow, nh, ptot, nh1, ncand, nsel, hoff(nh1), n0, nobs, sel(nsel)
    real(c_double), intent(in) :: f(nrow, nh), jall(nrow, ptot)
    real(c_double), intent(out) :: pairs(nh, nh), tc(ncand)
    integer(c_int), intent(out) :: info, errloc(2)
    real(c_double) :: tnow
    logical :: skip(ncand)
    integer :: i
    pairs = 0
    tc = 0
    call disc_check(f, jall, hoff, n0, nobs, 1_c_int, 0_c_int, info, errloc)
    if (info /= sk_ok) return
    if (ncand * nobs /= nrow - n0) then
        call fail(sk_err_argument, darg_nobs, 0, info, errloc)
        return
    end if
    skip = .false.
    do i = 1, nsel
        if (sel(i) < 1 .or. sel(i) > ncand) then
            call fail(sk_err_argument, darg_chosen, i, info, errloc)
            return
        end if
        if (skip(sel(i))) then
            call fail(sk_err_argument, darg_chosen, i, info, errloc)
            return
        end if
        skip(sel(i)) = .true.
    end do
    associate (js => unit_columns(jall))
        call disc_pairs(f, js, hoff, rows_of(n0, nobs, sel), pairs, info)
        if (info /= sk_ok) return
        call disc_evaluate(f, js, hoff, n0, nobs, rows_of(n0, nobs, sel), skip, tc, tnow, info)
    end associate
end subroutine sk_design_disc_evaluate
