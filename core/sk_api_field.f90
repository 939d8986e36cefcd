!> Entry points of the field-fit / compliance / beam core that f2py wraps
!> (bindings/_field.pyf). Plain external subroutines with explicit-shape
!> arrays of iso_c_binding kinds and an integer `info` (sk_errors); they
!> check nothing the modules do not check and hold no numerics of their own.

!> Fit m experiments that share the node positions p[3,n]: displacement
!> fields d[3,n,m], reference point p0. method: 0 lin, 1 svd+, 2 svd-,
!> 3 svd+-, 4 exact. trim: fraction of nodes dropped (paper s4.5).
!> pooled /= 0: one noise estimate over all experiments (eq. 21 with
!> m(3n - 6) dof) scales every covariance; else each its own.
subroutine sk_fit_fields(n, m, p, d, p0, method, trim, pooled, t, phi, cov, res, used, &
        sigma, nused, niter, sigma_pooled, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors
    use sk_field_fit, only: fit_field
    use sk_linalg, only: all_finite
    implicit none
    integer(c_int), intent(in) :: n, m, method, pooled
    real(c_double), intent(in) :: p(3, n), d(3, n, m), p0(3), trim
    real(c_double), intent(out) :: t(3, m), phi(3, m), cov(6, 6, m), res(3, n, m)
    integer(c_int), intent(out) :: used(n, m), nused(m), niter(m)
    real(c_double), intent(out) :: sigma(m), sigma_pooled
    integer(c_int), intent(out) :: info
    real(c_double) :: ssr(m), dof_all, ssr_all
    logical :: usedl(n)
    integer :: j

    t = 0; phi = 0; cov = 0; res = 0; used = 0; nused = 0; niter = 0
    sigma = 0; sigma_pooled = 0
    if (m < 1) then
        info = sk_err_size
        return
    end if
    do j = 1, m
        call fit_field(p, d(:, :, j), p0, method, trim, t(:, j), phi(:, j), cov(:, :, j), &
                       res(:, :, j), usedl, ssr(j), nused(j), niter(j), info)
        if (info /= sk_ok) return
        used(:, j) = merge(1, 0, usedl)
        if (3*nused(j) - 6 <= 0) then
            info = sk_err_too_few
            return
        end if
        sigma(j) = sqrt(ssr(j)/real(3*nused(j) - 6, c_double))          ! eq. 21
    end do
    ssr_all = sum(ssr)
    dof_all = real(sum(3*nused - 6), c_double)
    sigma_pooled = sqrt(ssr_all/dof_all)                                 ! eq. 21, pooled
    do j = 1, m
        if (pooled /= 0) then
            cov(:, :, j) = sigma_pooled**2*cov(:, :, j)
        else
            cov(:, :, j) = sigma(j)**2*cov(:, :, j)
        end if
    end do
    info = sk_ok
    if (.not. (all_finite(t) .and. all_finite(phi) .and. all_finite(cov) .and. all_finite(sigma) &
               .and. all_finite([sigma_pooled]))) info = sk_err_overflow
end subroutine sk_fit_fields

!> Compliance k[6,6] = X W^+ from wrenches w[6,m] and deflections x[6,m]
!> with covariances cov[6,6,m]; see sk_compliance.
subroutine sk_compliance_matrix(m, w, x, cov, confidence, symmetrize, k, kstd, ci, signif, &
        kstiff, asym, z, stiff_info, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_compliance, only: compliance_from_experiments
    implicit none
    integer(c_int), intent(in) :: m, symmetrize
    real(c_double), intent(in) :: w(6, m), x(6, m), cov(6, 6, m), confidence
    real(c_double), intent(out) :: k(6, 6), kstd(6, 6), ci(6, 6), kstiff(6, 6), asym, z
    integer(c_int), intent(out) :: signif(6, 6), stiff_info, info
    logical :: sig(6, 6)
    call compliance_from_experiments(w, x, cov, confidence, symmetrize /= 0, k, kstd, ci, &
        sig, kstiff, asym, z, stiff_info, info)
    signif = merge(1, 0, sig)
end subroutine sk_compliance_matrix

!> Section properties [A, Iy, Iz, J, kappa_y, kappa_z] (sk_beams).
subroutine sk_section(shape, dims, nu, props, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_beams, only: section_properties
    implicit none
    integer(c_int), intent(in) :: shape
    real(c_double), intent(in) :: dims(2), nu
    real(c_double), intent(out) :: props(6)
    integer(c_int), intent(out) :: info
    call section_properties(shape, dims, nu, props, info)
end subroutine sk_section

!> Cantilever tip compliance (eq. 22), timoshenko /= 0 adds shear.
subroutine sk_cantilever(l, e, g, props, timoshenko, c, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_beams, only: cantilever_compliance
    implicit none
    real(c_double), intent(in) :: l, e, g, props(6)
    integer(c_int), intent(in) :: timoshenko
    real(c_double), intent(out) :: c(6, 6)
    integer(c_int), intent(out) :: info
    call cantilever_compliance(l, e, g, props, timoshenko /= 0, c, info)
end subroutine sk_cantilever

!> 6x6 beam stiffness of Taghvaeipour et al. eq. 24.
subroutine sk_beam_stiffness(l, e, g, props, k, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_beams, only: beam_stiffness_eq24
    implicit none
    real(c_double), intent(in) :: l, e, g, props(6)
    real(c_double), intent(out) :: k(6, 6)
    integer(c_int), intent(out) :: info
    call beam_stiffness_eq24(l, e, g, props, k, info)
end subroutine sk_beam_stiffness

!> Normal quantile (two-sided level), exposed for the Python statistics.
subroutine sk_normal_quantile(level, z)
    use, intrinsic :: iso_c_binding, only: c_double
    use sk_compliance, only: normal_quantile
    implicit none
    real(c_double), intent(in) :: level
    real(c_double), intent(out) :: z
    z = normal_quantile(level)
end subroutine sk_normal_quantile

!> Rigid motion x ~ r p + t of the points p[3,n] onto x[3,n]: the
!> Procrustes solution of Pashkevich et al. eqs. 6-10 with det r = +1 (the
!> closed form of Kabsch / Horn); rms of the remaining distances.
subroutine sk_rigid_transform(n, p, x, r, t, rms, info)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors
    use sk_field_fit, only: fit_rigid, method_svd_pm
    implicit none
    integer(c_int), intent(in) :: n
    real(c_double), intent(in) :: p(3, n), x(3, n)
    real(c_double), intent(out) :: r(3, 3), t(3), rms
    integer(c_int), intent(out) :: info
    real(c_double) :: phi(3), covu(6, 6), res(3, n), ssr
    integer(c_int) :: niter
    r = 0
    t = 0
    rms = 0
    if (n < 3) then
        info = sk_err_size
        return
    end if
    call fit_rigid(p, x - p, method_svd_pm, t, phi, r, covu, res, ssr, niter, info)
    if (info == sk_ok) rms = sqrt(ssr/real(n, c_double))
end subroutine sk_rigid_transform

