!> Entry points of the serial-chain / calibration core that f2py wraps
!> (bindings/calib/_calib.pyf). Plain external subroutines with
!> explicit-shape arrays of iso_c_binding kinds and an integer `info`
!> (sk_errors); the numerics live in sk_chain, sk_chain_tree and sk_calib.

!> Poses of every joint frame F_k and of the tool at np postures (sk_chain).
subroutine sk_chain_poses(nj, ndof, np, jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rt, pt, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_chain, only: chain_poses_batch
    implicit none
    integer(c_int), intent(in) :: nj, ndof, np
    real(c_double), intent(in) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), trot(3, 3), tpos(3)
    integer(c_int), intent(in) :: qidx(nj)
    real(c_double), intent(in) :: q(ndof, np)
    real(c_double), intent(out) :: rf(3, 3, nj, np), pf(3, nj, np), rt(3, 3, np), pt(3, np)
    integer(c_int), intent(out) :: info
    call chain_poses_batch(jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rt, pt, info)
end subroutine sk_chain_poses

!> Weighted least squares with groups (sk_calib%wls_svd).
subroutine sk_wls(n, p, a, y, rcond, gtol, theta, stdu, s, v, rank, group, res, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_calib, only: wls_svd
    implicit none
    integer(c_int), intent(in) :: n, p
    real(c_double), intent(in) :: a(n, p), y(n), rcond, gtol
    real(c_double), intent(out) :: theta(p), stdu(p), s(p), v(p, p), res(n)
    integer(c_int), intent(out) :: rank, group(p), info
    call wls_svd(a, y, rcond, gtol, theta, stdu, s, v, rank, group, res, info)
end subroutine sk_wls

!> The triangular factor r[n,n] of the QR decomposition of a[m,n], m >= n
!> (sk_linalg%qr_triangle; r^T r = a^T a).
subroutine sk_qr_r(m, n, a, r, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_linalg, only: qr_triangle
    implicit none
    integer(c_int), intent(in) :: m, n
    real(c_double), intent(in) :: a(m, n)
    real(c_double), intent(out) :: r(n, n)
    integer(c_int), intent(out) :: info
    call qr_triangle(a, r, info)
end subroutine sk_qr_r

!> Score tests of candidates z(:, cstart(c):cstart(c+1)-1) (sk_calib%score_tests).
subroutine sk_score(n, p, nz, nc1, a, r, z, cstart, rcond, ztol, stat, dof, pr, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_calib, only: score_tests
    implicit none
    integer(c_int), intent(in) :: n, p, nz, nc1
    real(c_double), intent(in) :: a(n, p), r(n), z(n, nz), rcond, ztol
    integer(c_int), intent(in) :: cstart(nc1)
    real(c_double), intent(out) :: stat(nc1 - 1), pr(n, nc1 - 1)
    integer(c_int), intent(out) :: dof(nc1 - 1), info
    call score_tests(a, r, z, cstart, rcond, ztol, stat, dof, pr, info)
end subroutine sk_score

!> Multiplicity-corrected test of the best candidate (sk_calib%max_score_test).
subroutine sk_max_score(n, p, nz, nc1, a, z, cstart, rcond, ztol, lobs, dpe, nsim, seed, pval, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_calib, only: max_score_test
    implicit none
    integer(c_int), intent(in) :: n, p, nz, nc1, dpe, nsim, seed
    real(c_double), intent(in) :: a(n, p), z(n, nz), rcond, ztol, lobs
    integer(c_int), intent(in) :: cstart(nc1)
    real(c_double), intent(out) :: pval
    integer(c_int), intent(out) :: info
    call max_score_test(a, z, cstart, rcond, ztol, lobs, dpe, nsim, seed, pval, info)
end subroutine sk_max_score

!> Neighbour correlation of residuals, a permutation test of structure
!> (sk_neighbours%neighbour_correlation).
subroutine sk_neighbour_correlation(d, k, n, x, e, w, grp, cls, nperm, seed, rho, pval, nn, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_neighbours, only: neighbour_correlation
    implicit none
    integer(c_int), intent(in) :: d, k, n, nperm, seed
    real(c_double), intent(in) :: x(d, n), e(k, n), w(n)
    integer(c_int), intent(in) :: grp(n), cls(n)
    real(c_double), intent(out) :: rho, pval
    integer(c_int), intent(out) :: nn(n), info
    call neighbour_correlation(x, e, w, grp, cls, nperm, seed, rho, pval, nn, info)
end subroutine sk_neighbour_correlation

!> Sparse relations between coupled parameters (sk_calib%null_relations).
subroutine sk_null_relations(p, nr, v, nrank, tol, rel, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_calib, only: null_relations
    implicit none
    integer(c_int), intent(in) :: p, nr, nrank
    real(c_double), intent(in) :: v(p, p), tol
    real(c_double), intent(out) :: rel(nr, p)
    integer(c_int), intent(out) :: info
    call null_relations(v, nrank, tol, rel, info)
end subroutine sk_null_relations

!> Greedy independent columns in a preferred order (sk_calib%select_independent).
subroutine sk_select(n, p, a, order, tol, selected, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_calib, only: select_independent
    implicit none
    integer(c_int), intent(in) :: n, p
    real(c_double), intent(in) :: a(n, p), tol
    integer(c_int), intent(in) :: order(p)
    integer(c_int), intent(out) :: selected(p), info
    call select_independent(a, order, tol, selected, info)
end subroutine sk_select

!> log of the chi-square survival function.
subroutine sk_chi2_logsf(x, k, l)
    use, intrinsic :: iso_c_binding, only: c_double
    use sk_tails, only: chi2_logsf
    implicit none
    real(c_double), intent(in) :: x, k
    real(c_double), intent(out) :: l
    l = chi2_logsf(x, k)
end subroutine sk_chi2_logsf

!> log of the F(d1, d2) survival function.
subroutine sk_f_logsf(f, d1, d2, l)
    use, intrinsic :: iso_c_binding, only: c_double
    use sk_tails, only: f_logsf
    implicit none
    real(c_double), intent(in) :: f, d1, d2
    real(c_double), intent(out) :: l
    l = f_logsf(f, d1, d2)
end subroutine sk_f_logsf

!> Levenberg-Marquardt by reverse communication (sk_lm), start: the
!> Jacobian jac[m,n] and residual res[m] (model - data) at the start, the
!> most iterations and the tolerances. Returns the state rstate[nrs]
!> (nrs = 9 + n (n + 3)) and istate[6], which the caller passes back to
!> sk_lm_step and sk_lm_accept unchanged, and reason (0: step on; 1-6:
!> stopped, sk_lm).
subroutine sk_lm_start(m, n, nrs, jac, res, maxit, ftol, xtol, gtol, rstate, istate, reason, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_lm, only: lm_state, lm_start, lm_save, lm_nint
    implicit none
    integer(c_int), intent(in) :: m, n, nrs, maxit
    real(c_double), intent(in) :: jac(m, n), res(m), ftol, xtol, gtol
    real(c_double), intent(out) :: rstate(nrs)
    integer(c_int), intent(out) :: istate(lm_nint), reason, info
    type(lm_state) :: st
    rstate = 0.0_c_double
    istate = 0
    reason = 0
    call lm_start(st, jac, res, maxit, ftol, xtol, gtol, info)
    if (info /= sk_ok) return
    call lm_save(st, rstate, istate, info)
    reason = st%reason
end subroutine sk_lm_start

!> Levenberg-Marquardt by reverse communication (sk_lm), step: the trial
!> step dx[n] from the current point x[n] (in the variables of the
!> Jacobian columns); the caller evaluates the model at x + dx and calls
!> sk_lm_accept. rstate, istate: updated.
subroutine sk_lm_step(n, nrs, rstate, istate, x, dx, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_lm, only: lm_state, lm_step, lm_save, lm_load, lm_nint
    implicit none
    integer(c_int), intent(in) :: n, nrs
    real(c_double), intent(inout) :: rstate(nrs)
    integer(c_int), intent(inout) :: istate(lm_nint)
    real(c_double), intent(in) :: x(n)
    real(c_double), intent(out) :: dx(n)
    integer(c_int), intent(out) :: info
    type(lm_state) :: st
    dx = 0.0_c_double
    call lm_load(st, rstate, istate, info)
    if (info /= sk_ok) return
    call lm_step(st, x, dx, info)
    if (info /= sk_ok) return
    call lm_save(st, rstate, istate, info)
end subroutine sk_lm_step

!> Levenberg-Marquardt by reverse communication (sk_lm), verdict on the
!> trial: ok = 1 with the Jacobian jac[m,n] and residual res[m] there, 0
!> when the trial could not be evaluated (outside the model's domain).
!> accepted = 1: the caller moves to the trial; reason: 0 step on, 1-6
!> stopped; niter: iterations so far. rstate, istate: updated.
subroutine sk_lm_accept(m, n, nrs, rstate, istate, ok, jac, res, accepted, reason, niter, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_lm, only: lm_state, lm_accept, lm_save, lm_load, lm_nint
    implicit none
    integer(c_int), intent(in) :: m, n, nrs, ok
    real(c_double), intent(inout) :: rstate(nrs)
    integer(c_int), intent(inout) :: istate(lm_nint)
    real(c_double), intent(in) :: jac(m, n), res(m)
    integer(c_int), intent(out) :: accepted, reason, niter, info
    type(lm_state) :: st
    logical :: acc
    integer(c_int) :: sinfo
    accepted = 0
    reason = 0
    niter = 0
    call lm_load(st, rstate, istate, info)
    if (info /= sk_ok) return
    call lm_accept(st, ok /= 0, jac, res, acc, info)
    accepted = merge(1, 0, acc)
    reason = st%reason
    niter = st%niter
    call lm_save(st, rstate, istate, sinfo)
    if (info == sk_ok) info = sinfo
end subroutine sk_lm_accept
