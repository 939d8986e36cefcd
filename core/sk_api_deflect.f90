!> Entry points of the deflection model (relative data) that f2py wraps
!> (bindings/_calib.pyf): the predicted rows and their Jacobian, the joint
!> compliances of a known model (sk_deflect), the compensator's h (sk_laws).

!> Rows pred[6,nm] and, when want_jac /= 0, jac[6,nm,npar] of the terms
!> (tint[7,nt], tgeo[5,nt], elem[ne], par[npall]) at theta[npar] (sk_deflect).
subroutine sk_deflection_rows(nj, ndof, ns, nt, ne, npall, npar, nm, njac, jrot, jpos, jaxis, qidx, trot, tpos, &
        stype, sidx, tint, tgeo, elem, par, theta, q, w, p, want_jac, pred, jac, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_deflect, only: deflection_rows
    implicit none
    integer(c_int), intent(in) :: nj, ndof, ns, nt, ne, npall, npar, nm, njac, want_jac
    real(c_double), intent(in) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), trot(3, 3), tpos(3)
    integer(c_int), intent(in) :: qidx(nj), stype(ns), sidx(ns), tint(7, nt), elem(ne)
    real(c_double), intent(in) :: tgeo(5, nt), par(npall), theta(npar), q(ndof, nm), w(6, nm), p(3, nm)
    real(c_double), intent(out) :: pred(6, nm), jac(6, njac, npar)
    integer(c_int), intent(out) :: info
    call deflection_rows(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, theta, &
        q, w, p, want_jac /= 0, pred, jac, info)
end subroutine sk_deflection_rows

!> Compliance cj[ns,np] of every joint spring at postures q[ndof,np] of a
!> known model; with_load /= 0: the secant under the torques tau[ns,np].
subroutine sk_joint_secant(ns, nt, npall, ndof, np, stype, tint, tgeo, par, q, tau, with_load, cj, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_deflect, only: joint_secant
    implicit none
    integer(c_int), intent(in) :: ns, nt, npall, ndof, np, with_load
    integer(c_int), intent(in) :: stype(ns), tint(7, nt)
    real(c_double), intent(in) :: tgeo(5, nt), par(npall), q(ndof, np), tau(ns, np)
    real(c_double), intent(out) :: cj(ns, np)
    integer(c_int), intent(out) :: info
    call joint_secant(stype, tint, tgeo, par, q, tau, with_load /= 0, cj, info)
end subroutine sk_joint_secant

!> The gravity compensator's d2V/dq2 per unit k_s, h[n] at q[n] (sk_laws).
subroutine sk_compensator_h(n, q, a, b, beta, s0, h)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_laws, only: compensator_h
    implicit none
    integer(c_int), intent(in) :: n
    real(c_double), intent(in) :: q(n), a, b, beta, s0
    real(c_double), intent(out) :: h(n)
    h = compensator_h(q, a, b, beta, s0)
end subroutine sk_compensator_h

!> The nonlinear fit of the deflection model by the core's
!> Levenberg-Marquardt (sk_deflect_fit): theta[npar] in the start, out the
!> end; y[nobs] (nobs = nrows nm) the weighted data, wrow[nrows] the row
!> weights; neg, nlmask, inv[npar] (0/1) the parameters not excited, the
!> nonlinear ones and the compensated joint compliances.
subroutine sk_deflection_lm(nj, ndof, ns, nt, ne, npall, npar, nm, nobs, nrows, jrot, jpos, jaxis, qidx, trot, &
        tpos, stype, sidx, tint, tgeo, elem, par, q, w, p, y, wrow, neg, nlmask, inv, maxit, ftol, xtol, gtol, &
        theta, niter, reason, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_deflect_fit, only: deflection_lm
    implicit none
    integer(c_int), intent(in) :: nj, ndof, ns, nt, ne, npall, npar, nm, nobs, nrows, maxit
    real(c_double), intent(in) :: jrot(3, 3, nj), jpos(3, nj), jaxis(3, nj), trot(3, 3), tpos(3)
    integer(c_int), intent(in) :: qidx(nj), stype(ns), sidx(ns), tint(7, nt), elem(ne)
    real(c_double), intent(in) :: tgeo(5, nt), par(npall), q(ndof, nm), w(6, nm), p(3, nm), y(nobs), wrow(nrows)
    integer(c_int), intent(in) :: neg(npar), nlmask(npar), inv(npar)
    real(c_double), intent(in) :: ftol, xtol, gtol
    real(c_double), intent(inout) :: theta(npar)
    integer(c_int), intent(out) :: niter, reason, info
    call deflection_lm(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, q, w, p, y, &
        wrow, neg /= 0, nlmask /= 0, inv /= 0, maxit, ftol, xtol, gtol, theta, niter, reason, info)
end subroutine sk_deflection_lm
