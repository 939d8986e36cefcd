!> Entry points of the serial-chain / calibration core that f2py wraps
!> (bindings/calib/_calib.pyf). Plain external subroutines with
!> explicit-shape arrays of iso_c_binding kinds and an integer `info`
!> (sk_errors); the numerics live in sk_chain and sk_calib.

!> Tool compliance and stiffness at np postures q[ndof,np] (sk_chain).
subroutine sk_tool_compliance(nj, ndof, ns, np, jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, &
        cs, cj, q, c, k, rank, kinfo, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_chain, only: tool_compliance_batch
    implicit none
    integer(c_int), intent(in) :: nj, ndof, ns, np
    real(c_double), intent(in) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), trot(3, 3), tpos(3)
    integer(c_int), intent(in) :: qidx(nj), stype(ns), sidx(ns)
    real(c_double), intent(in) :: cs(6, 6, ns), cj(ns, np), q(ndof, np)
    real(c_double), intent(out) :: c(6, 6, np), k(6, 6, np)
    integer(c_int), intent(out) :: rank(np), kinfo(np), info
    call tool_compliance_batch(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, cs, cj, q, c, k, &
        rank, kinfo, info)
end subroutine sk_tool_compliance

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

!> Observation basis[6,nm,nb] of every spring at nm measurement rows (sk_chain).
subroutine sk_spring_basis(nj, ndof, ns, nm, nb, jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, &
        q, w, p, basis, rtool, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_chain, only: spring_basis_batch
    implicit none
    integer(c_int), intent(in) :: nj, ndof, ns, nm, nb
    real(c_double), intent(in) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), trot(3, 3), tpos(3)
    integer(c_int), intent(in) :: qidx(nj), stype(ns), sidx(ns)
    real(c_double), intent(in) :: q(ndof, nm), w(6, nm), p(3, nm)
    real(c_double), intent(out) :: basis(6, nm, nb), rtool(3, 3, nm)
    integer(c_int), intent(out) :: info
    call spring_basis_batch(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q, w, p, basis, &
        rtool, info)
end subroutine sk_spring_basis

!> Jacobians jac[6,nd] of every spring at one posture q[ndof], and the
!> tool frame rt[3,3], pt[3] (sk_chain).
subroutine sk_spring_jacobians(nj, ndof, ns, nd, jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q, &
        jac, rt, pt, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_chain, only: spring_jacobians
    implicit none
    integer(c_int), intent(in) :: nj, ndof, ns, nd
    real(c_double), intent(in) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), trot(3, 3), tpos(3), q(ndof)
    integer(c_int), intent(in) :: qidx(nj), stype(ns), sidx(ns)
    real(c_double), intent(out) :: jac(6, nd), rt(3, 3), pt(3)
    integer(c_int), intent(out) :: info
    call spring_jacobians(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q, jac, rt, pt, info)
end subroutine sk_spring_jacobians

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
    use sk_calib, only: chi2_logsf
    implicit none
    real(c_double), intent(in) :: x, k
    real(c_double), intent(out) :: l
    l = chi2_logsf(x, k)
end subroutine sk_chi2_logsf

!> log of the F(d1, d2) survival function.
subroutine sk_f_logsf(f, d1, d2, l)
    use, intrinsic :: iso_c_binding, only: c_double
    use sk_calib, only: f_logsf
    implicit none
    real(c_double), intent(in) :: f, d1, d2
    real(c_double), intent(out) :: l
    l = f_logsf(f, d1, d2)
end subroutine sk_f_logsf
