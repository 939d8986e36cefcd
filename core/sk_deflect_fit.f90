!> The nonlinear fit of the deflection model (relative data with a free
!> gravity compensator or point offset; klimchik eq. 7): the core's
!> Levenberg-Marquardt (sk_lm) around the rows and analytic Jacobian of
!> sk_deflect, in one call.
!>
!> Observations: the weighted rows, component i (1..nrows: dx dy dz, then
!> rx ry rz when rotations are measured) of row m at (i - 1) nm + m, each
!> times wrow(i); the residual is model - data. Columns of parameters the
!> loads do not excite (neg) are zero (the fit reports them
!> non-identifiable).
!>
!> Variables u = z / f, held fixed while sk_lm iterates: z is theta with
!> the compliance c of a compensated joint (inv) replaced by its stiffness
!> 1/c once c > 0 (c_eff = 1 / (1/c + k_s h(q)) has a straight valley in
!> 1/c; d/d(1/c) = -c^2 d/dc); f equilibrates the columns of the nonlinear
!> (nlmask) and reparametrised parameters to the largest column (sk_lm
!> floors its scales relative to the largest column, which must catch
!> structural zeros only). Once a compensated c turns positive, or a column
!> that was zero when they were set (k_s and the offset at theta = 0) is
!> not any more, they are stale: sk_lm starts again in new ones (the
!> restart's first factorisation is not counted twice).
module sk_deflect_fit
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_deflect, only: deflection_rows
    use sk_lm, only: lm_state, lm_start, lm_step, lm_accept, lm_running
    implicit none
    private
    public :: deflection_lm

    !> The variables of one start (module header).
    type :: lm_vars
        logical, allocatable :: use(:), pending(:)
        real(dp), allocatable :: f(:)
    end type lm_vars

contains

    !> Column norms of a(:, :).
    pure function col_norms(a) result(d)
        real(dp), intent(in) :: a(:, :)
        real(dp) :: d(size(a, 2))
        integer :: k
        do k = 1, size(a, 2)
            d(k) = sqrt(sum(a(:, k)**2))
        end do
    end function col_norms

    !> The weighted system at theta: a[nobs,npar] and res[nobs] = model - data.
    pure subroutine weigh(pred, jac, y, wrow, neg, a, res)
        real(dp), intent(in) :: pred(:, :), jac(:, :, :), y(:), wrow(:)
        logical, intent(in) :: neg(:)
        real(dp), intent(out) :: a(:, :), res(:)
        integer :: i, m, k, nm, o
        nm = size(pred, 2)
        do i = 1, size(wrow)
            do m = 1, nm
                o = (i - 1)*nm + m
                res(o) = -(y(o) - pred(i, m)*wrow(i))
                do k = 1, size(jac, 3)
                    a(o, k) = jac(i, m, k)*wrow(i)
                end do
            end do
        end do
        do k = 1, size(neg)
            if (neg(k)) a(:, k) = 0.0_dp
        end do
    end subroutine weigh

    !> The Jacobian w.r.t. theta, a, in the variables v.
    pure subroutine var_jacobian(v, theta, a, az)
        type(lm_vars), intent(in) :: v
        real(dp), intent(in) :: theta(:), a(:, :)
        real(dp), intent(out) :: az(:, :)
        integer :: k
        do k = 1, size(theta)
            if (v%use(k)) then
                az(:, k) = a(:, k)*(-(theta(k)**2))*v%f(k)
            else
                az(:, k) = a(:, k)*v%f(k)
            end if
        end do
    end subroutine var_jacobian

    !> New variables at theta (module header).
    pure subroutine var_set(theta, a, inv, nlmask, v)
        real(dp), intent(in) :: theta(:), a(:, :)
        logical, intent(in) :: inv(:), nlmask(:)
        type(lm_vars), intent(out) :: v
        real(dp) :: az(size(a, 1), size(a, 2)), d(size(a, 2)), big
        integer :: k, n
        n = size(theta)
        allocate(v%use(n), v%pending(n), v%f(n))
        v%use = inv .and. theta > 0.0_dp
        v%f = 1.0_dp
        call var_jacobian(v, theta, a, az)
        d = col_norms(az)
        big = 0.0_dp
        if (n > 0) big = maxval(d)
        do k = 1, n
            if ((nlmask(k) .or. v%use(k)) .and. d(k) > 0.0_dp .and. big > 0.0_dp) v%f(k) = big/d(k)
        end do
        v%pending = (nlmask .or. v%use) .and. d == 0.0_dp
    end subroutine var_set

    !> Fit theta[npar] (in: the start; out: the end) of the model (the
    !> arguments of deflection_rows) to the weighted data y[nrows*nm] with
    !> the row weights wrow[nrows]; neg, nlmask, inv [npar] as in the module
    !> header; at most maxit iterations; ftol, xtol, gtol: sk_lm's.
    !> niter: the iterations used; reason: sk_lm's (lm_running never).
    subroutine deflection_lm(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, &
            q, w, p, y, wrow, neg, nlmask, inv, maxit, ftol, xtol, gtol, theta, niter, reason, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:), tint(:, :), elem(:), maxit
        real(dp), intent(in) :: tgeo(:, :), par(:), q(:, :), w(:, :), p(:, :), y(:), wrow(:), ftol, xtol, gtol
        logical, intent(in) :: neg(:), nlmask(:), inv(:)
        real(dp), intent(inout) :: theta(:)
        integer(ip), intent(out) :: niter, reason, info
        real(dp), allocatable :: pred(:, :), jac(:, :, :), a(:, :), res(:), a2(:, :), res2(:), az(:, :), &
            u(:), du(:), z(:), trial(:), dummy(:, :)
        type(lm_vars) :: v
        type(lm_state) :: st
        integer :: nm, n, nobs
        integer(ip) :: einfo
        logical :: stale, accepted
        nm = size(q, 2)
        n = size(theta)
        nobs = size(wrow)*nm
        niter = 0
        reason = 0
        info = sk_err_size
        if (size(y) /= nobs .or. size(wrow) > 6 .or. size(neg) /= n .or. size(nlmask) /= n .or. size(inv) /= n) &
            return
        allocate(pred(6, nm), jac(6, nm, n), a(nobs, n), res(nobs), a2(nobs, n), res2(nobs), az(nobs, n), &
            u(n), du(n), z(n), trial(n), dummy(1, n))
        dummy = 0.0_dp
        call deflection_rows(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, theta, &
            q, w, p, .true., pred, jac, info)
        if (info /= sk_ok) return
        call weigh(pred, jac, y, wrow, neg, a, res)
        do
            call var_set(theta, a, inv, nlmask, v)
            call var_jacobian(v, theta, a, az)
            call lm_start(st, az, res, maxit - niter, ftol, xtol, gtol, info)
            if (info /= sk_ok) return
            stale = .false.
            do while (st%reason == lm_running .and. .not. stale)
                u = theta
                where (v%use) u = 1.0_dp/theta
                u = u/v%f
                call lm_step(st, u, du, info)
                if (info /= sk_ok) return
                z = (u + du)*v%f
                if (any(v%use .and. z <= 0.0_dp)) then
                    call lm_accept(st, .false., dummy, dummy(:, 1), accepted, info)
                    if (info /= sk_ok) return
                    cycle
                end if
                trial = z
                where (v%use) trial = 1.0_dp/z
                call deflection_rows(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, &
                    trial, q, w, p, .true., pred, jac, einfo)
                if (einfo /= sk_ok) then
                    call lm_accept(st, .false., dummy, dummy(:, 1), accepted, info)
                    if (info /= sk_ok) return
                    cycle
                end if
                call weigh(pred, jac, y, wrow, neg, a2, res2)
                call var_jacobian(v, trial, a2, az)
                call lm_accept(st, .true., az, res2, accepted, info)
                if (info /= sk_ok) return
                if (accepted) then
                    theta = trial
                    a = a2
                    res = res2
                    stale = st%reason == lm_running .and. is_stale(v, theta, a, inv)
                end if
            end do
            niter = niter + st%niter - merge(1, 0, stale)
            if (.not. stale) exit
        end do
        reason = st%reason
        info = sk_ok
    end subroutine deflection_lm

    !> Have the variables gone stale at theta (module header)?
    pure logical function is_stale(v, theta, a, inv)
        type(lm_vars), intent(in) :: v
        real(dp), intent(in) :: theta(:), a(:, :)
        logical, intent(in) :: inv(:)
        is_stale = any(inv .and. theta > 0.0_dp .and. .not. v%use) .or. any(v%pending .and. col_norms(a) > 0.0_dp)
    end function is_stale

end module sk_deflect_fit
