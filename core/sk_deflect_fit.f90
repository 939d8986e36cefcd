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
!> restart's first factorisation is not counted twice). The loop is the
!> core's one (sk_lm_solve lm_solve); this module is the problem: its
!> variables, evaluation, staleness and restarts.
module sk_deflect_fit
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_deflect, only: deflection_model, deflection_setup, deflection_eval
    use sk_lm_solve, only: lm_problem, lm_solve
    implicit none
    private
    public :: deflection_lm

    !> The variables of one start (module header).
    type :: lm_vars
        logical, allocatable :: use(:), pending(:)
        real(dp), allocatable :: f(:)
    end type lm_vars

    !> deflection_lm's problem for the core's one LM loop (sk_lm_solve):
    !> the model on its rows (sk_deflect deflection_setup, set up once), the
    !> weighted data and masks, the variables v, the accepted theta with its
    !> weighted Jacobian a and residual res, the last trial with a2, res2.
    type, extends(lm_problem) :: defl_fit
        type(deflection_model) :: dm
        real(dp), allocatable :: y(:), wrow(:)
        logical, allocatable :: neg(:), nlmask(:), inv(:)
        real(dp), allocatable :: theta(:), trial(:), pred(:, :), jac(:, :, :), a(:, :), res(:), a2(:, :), res2(:)
        type(lm_vars) :: v
    contains
        procedure :: eval => defl_eval
        procedure :: accepted => defl_accepted
        procedure :: stale => defl_stale
        procedure :: restart => defl_restart
        procedure :: variables => defl_variables
    end type defl_fit

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
        type(defl_fit) :: df
        real(dp), allocatable :: az(:, :), res(:), x(:)
        integer :: nm, n, nobs
        nm = size(q, 2)
        n = size(theta)
        nobs = size(wrow)*nm
        niter = 0
        reason = 0
        info = sk_err_size
        if (size(y) /= nobs .or. size(wrow) > 6 .or. size(neg) /= n .or. size(nlmask) /= n .or. size(inv) /= n) &
            return
        df%y = y
        df%wrow = wrow
        df%neg = neg
        df%nlmask = nlmask
        df%inv = inv
        df%theta = theta
        df%trial = theta
        allocate(df%pred(6, nm), df%jac(6, nm, n), df%a(nobs, n), df%res(nobs), df%a2(nobs, n), df%res2(nobs), &
            az(nobs, n))
        call deflection_setup(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, int(n, ip), &
            q, w, p, df%dm, info)
        if (info /= sk_ok) return
        call deflection_eval(df%dm, theta, .true., df%pred, df%jac, info)
        if (info /= sk_ok) return
        call weigh(df%pred, df%jac, y, wrow, neg, df%a, df%res)
        call var_set(theta, df%a, inv, nlmask, df%v)
        call var_jacobian(df%v, theta, df%a, az)
        res = df%res
        x = df%variables()
        call lm_solve(df, x, az, res, maxit, ftol, xtol, gtol, niter, reason, info)
        theta = df%theta
        if (info /= sk_ok) return
        info = sk_ok
    end subroutine deflection_lm

    !> The variables u = z / f at the accepted theta (module header).
    pure function defl_variables(self) result(u)
        class(defl_fit), intent(in) :: self
        real(dp) :: u(size(self%theta))
        u = self%theta
        where (self%v%use) u = 1.0_dp/self%theta
        u = u/self%v%f
    end function defl_variables

    !> The weighted rows and their Jacobian in the variables at u (a
    !> compensated compliance must stay positive; a failed evaluation is a
    !> rejected trial).
    subroutine defl_eval(self, x, jac, res, ok)
        class(defl_fit), intent(inout) :: self
        real(dp), intent(in) :: x(:)
        real(dp), intent(out) :: jac(:, :), res(:)
        logical, intent(out) :: ok
        real(dp) :: z(size(x))
        integer(ip) :: einfo
        jac = 0.0_dp
        res = 0.0_dp
        z = x*self%v%f
        ok = .not. any(self%v%use .and. z <= 0.0_dp)
        if (.not. ok) return
        self%trial = z
        where (self%v%use) self%trial = 1.0_dp/z
        call deflection_eval(self%dm, self%trial, .true., self%pred, self%jac, einfo)
        ok = einfo == sk_ok
        if (.not. ok) return
        call weigh(self%pred, self%jac, self%y, self%wrow, self%neg, self%a2, self%res2)
        call var_jacobian(self%v, self%trial, self%a2, jac)
        res = self%res2
    end subroutine defl_eval

    !> An accepted trial: theta, its rows; the variables recomputed there.
    subroutine defl_accepted(self, x)
        class(defl_fit), intent(inout) :: self
        real(dp), intent(inout) :: x(:)
        self%theta = self%trial
        self%a = self%a2
        self%res = self%res2
        x = self%variables()
    end subroutine defl_accepted

    !> Stale variables at the accepted theta (module header).
    logical function defl_stale(self)
        class(defl_fit), intent(inout) :: self
        defl_stale = is_stale(self%v, self%theta, self%a, self%inv)
    end function defl_stale

    !> New variables at the accepted theta: x and the Jacobian jac in them.
    subroutine defl_restart(self, x, jac)
        class(defl_fit), intent(inout) :: self
        real(dp), intent(inout) :: x(:), jac(:, :)
        call var_set(self%theta, self%a, self%inv, self%nlmask, self%v)
        call var_jacobian(self%v, self%theta, self%a, jac)
        x = self%variables()
    end subroutine defl_restart

    !> Have the variables gone stale at theta (module header)?
    pure logical function is_stale(v, theta, a, inv)
        type(lm_vars), intent(in) :: v
        real(dp), intent(in) :: theta(:), a(:, :)
        logical, intent(in) :: inv(:)
        is_stale = any(inv .and. theta > 0.0_dp .and. .not. v%use) .or. any(v%pending .and. col_norms(a) > 0.0_dp)
    end function is_stale

end module sk_deflect_fit
