!> Unit tests of sk_lm, the Levenberg-Marquardt iteration by reverse
!> communication: Rosenbrock's valley and exponential fits converge to their
!> known minima (the noisy one checked against an independent line search);
!> a column that is zero (always, or only at the start) does not stall the
!> iteration; every stopping reason is reached when it should be; the
!> flattened state (lm_save / lm_load, and the entry points of sk_api_calib
!> that the Python fit drives) reproduces the iterates bit for bit; calls
!> out of order and foreign states are refused.
program test_lm
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_lm
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    implicit none (type, external)

    interface
        subroutine sk_lm_start(m, n, nrs, jac, res, maxit, ftol, xtol, gtol, rstate, istate, reason, info)
            use, intrinsic :: iso_c_binding, only: c_double, c_int
            implicit none
            integer(c_int), intent(in) :: m, n, nrs, maxit
            real(c_double), intent(in) :: jac(m, n), res(m), ftol, xtol, gtol
            real(c_double), intent(out) :: rstate(nrs)
            integer(c_int), intent(out) :: istate(6), reason, info
        end subroutine sk_lm_start
        subroutine sk_lm_step(n, nrs, rstate, istate, x, dx, info)
            use, intrinsic :: iso_c_binding, only: c_double, c_int
            implicit none
            integer(c_int), intent(in) :: n, nrs
            real(c_double), intent(inout) :: rstate(nrs)
            integer(c_int), intent(inout) :: istate(6)
            real(c_double), intent(in) :: x(n)
            real(c_double), intent(out) :: dx(n)
            integer(c_int), intent(out) :: info
        end subroutine sk_lm_step
        subroutine sk_lm_accept(m, n, nrs, rstate, istate, ok, jac, res, accepted, reason, niter, info)
            use, intrinsic :: iso_c_binding, only: c_double, c_int
            implicit none
            integer(c_int), intent(in) :: m, n, nrs, ok
            real(c_double), intent(inout) :: rstate(nrs)
            integer(c_int), intent(inout) :: istate(6)
            real(c_double), intent(in) :: jac(m, n), res(m)
            integer(c_int), intent(out) :: accepted, reason, niter, info
        end subroutine sk_lm_accept
    end interface

    !> the test problems of residuals
    integer, parameter :: rosenbrock = 1, expo = 2, expo_zero_col = 3, wrong_sign = 4, underdetermined = 5, &
        never_ok = 6
    !> how the state travels between calls: kept, flattened, through the entry points
    integer, parameter :: kept = 1, flat = 2, api = 3
    integer, parameter :: nt = 12
    real(dp) :: tt(nt), yexact(nt), ynoisy(nt)
    integer :: i

    do i = 1, nt
        tt(i) = 0.5_dp*(i - 1)
        yexact(i) = 2.0_dp*exp(-0.3_dp*tt(i))
        ynoisy(i) = yexact(i) + 0.02_dp*merge(1.0_dp, -1.0_dp, mod(i, 3) == 0) + 0.005_dp*sin(3.0_dp*i)
    end do

    call test_rosenbrock()
    call test_exponential()
    call test_zero_columns()
    call test_reasons()
    call test_protocol()
    call finish('lm')

contains

    !> Residuals m, Jacobian n columns at x of problem p (y: the data of the
    !> exponential fits).
    subroutine model(p, x, y, res, jac)
        integer, intent(in) :: p
        real(dp), intent(in) :: x(:), y(:)
        real(dp), allocatable, intent(out) :: res(:), jac(:, :)
        real(dp) :: e(nt)
        select case (p)
        case (rosenbrock, wrong_sign, never_ok)
            allocate(res(2), jac(2, 2))
            res = [10.0_dp*(x(2) - x(1)**2), 1.0_dp - x(1)]
            jac = reshape([-20.0_dp*x(1), -1.0_dp, 10.0_dp, 0.0_dp], [2, 2])
            if (p == wrong_sign) jac = -jac
        case (expo, expo_zero_col)
            allocate(res(nt), jac(nt, size(x)))
            e = exp(x(2)*tt)
            res = x(1)*e - y
            jac(:, 1) = e
            jac(:, 2) = x(1)*tt*e
            ! a parameter the model does not depend on
            if (p == expo_zero_col) jac(:, 3) = 0.0_dp
        case (underdetermined)
            allocate(res(1), jac(1, 2))
            res = x(1) + 2.0_dp*x(2) - 3.0_dp
            jac = reshape([1.0_dp, 2.0_dp], [1, 2])
        end select
    end subroutine model

    !> The iteration on problem p from x0, its state passed as `mode` says;
    !> x the last accepted point, cost there, reason, niter, trials (model
    !> evaluations after the start), mono: the cost never rose.
    subroutine run(p, y, x0, maxit, ftol, xtol, gtol, mode, x, cost, reason, niter, trials, mono, info)
        integer, intent(in) :: p, mode
        real(dp), intent(in) :: y(:), x0(:), ftol, xtol, gtol
        integer(ip), intent(in) :: maxit
        real(dp), intent(out) :: x(:), cost
        integer(ip), intent(out) :: reason, niter, info
        integer, intent(out) :: trials
        logical, intent(out) :: mono
        type(lm_state) :: st
        real(dp), allocatable :: res(:), jac(:, :), rs(:), dx(:)
        integer(ip) :: is(lm_nint), acc, n, m, nrs
        logical :: accepted
        real(dp) :: c0
        n = size(x0)
        x = x0
        trials = 0
        allocate(dx(n), rs(lm_state_size(n)))
        call model(p, x, y, res, jac)
        m = size(res)
        nrs = size(rs)
        c0 = 0.5_dp*sum(res**2)
        mono = .true.
        if (mode == api) then
            call sk_lm_start(m, n, nrs, jac, res, maxit, ftol, xtol, gtol, rs, is, reason, info)
            niter = is(4)
        else
            call lm_start(st, jac, res, maxit, ftol, xtol, gtol, info)
            reason = st%reason
            niter = st%niter
        end if
        if (info /= sk_ok) return
        do while (reason == lm_running .and. trials < 10000)
            if (mode == api) then
                call sk_lm_step(n, nrs, rs, is, x, dx, info)
            else
                if (mode == flat) call reload(st)
                call lm_step(st, x, dx, info)
            end if
            if (info /= sk_ok) return
            call model(p, x + dx, y, res, jac)
            trials = trials + 1
            if (mode == api) then
                call sk_lm_accept(m, n, nrs, rs, is, merge(0, 1, p == never_ok), jac, res, acc, reason, niter, info)
                accepted = acc == 1
            else
                if (mode == flat) call reload(st)
                call lm_accept(st, p /= never_ok, jac, res, accepted, info)
                reason = st%reason
                niter = st%niter
            end if
            if (accepted) then
                x = x + dx
                mono = mono .and. 0.5_dp*sum(res**2) < c0
                c0 = 0.5_dp*sum(res**2)
            end if
            if (info /= sk_ok) return
        end do
        call model(p, x, y, res, jac)
        cost = 0.5_dp*sum(res**2)
    end subroutine run

    !> The state through its flat arrays and back.
    subroutine reload(st)
        type(lm_state), intent(inout) :: st
        real(dp), allocatable :: rs(:)
        integer(ip) :: is(lm_nint), info
        allocate(rs(lm_state_size(st%n)))
        call lm_save(st, rs, is, info)
        call expect(info == sk_ok, 'flat state: save')
        call lm_load(st, rs, is, info)
        call expect(info == sk_ok, 'flat state: load')
    end subroutine reload

    subroutine test_rosenbrock()
        real(dp) :: x(2, 3), cost(3)
        integer(ip) :: reason(3), niter(3), info
        integer :: trials(3), mode
        logical :: mono
        character(len=120) :: msg
        do mode = kept, api
            call run(rosenbrock, [0.0_dp], [-1.2_dp, 1.0_dp], 200_ip, 1.0e-15_dp, 1.0e-15_dp, 0.0_dp, mode, &
                x(:, mode), cost(mode), reason(mode), niter(mode), trials(mode), mono, info)
            call expect(info == sk_ok .and. mono, 'rosenbrock: runs, cost decreases')
        end do
        write (msg, '(a, i0, a, i0, a, i0, a, es9.2)') 'rosenbrock: reason ', reason(1), ', iterations ', &
            niter(1), ', trials ', trials(1), ', error ', maxval(abs(x(:, 1) - 1.0_dp))
        print '(a)', trim(msg)
        call expect(maxval(abs(x(:, 1) - 1.0_dp)) < 1.0e-10_dp, 'rosenbrock: minimum (1, 1)')
        call expect(reason(1) == lm_zero .or. reason(1) == lm_xtol, 'rosenbrock: zero residual or step')
        call expect(niter(1) < 60, 'rosenbrock: iterations')
        ! the flat state and the entry points: the same iterates, bit for bit
        call expect(all(x(:, 2) == x(:, 1)) .and. all(x(:, 3) == x(:, 1)) .and. all(reason == reason(1)) &
            .and. all(niter == niter(1)) .and. all(trials == trials(1)), 'rosenbrock: flat state and API identical')
    end subroutine test_rosenbrock

    !> y = a exp(b t): exact data from (1, 0) recover (2, -0.3); noisy data
    !> reach the minimum of an independent search (b by golden section on
    !> the profile cost, a in closed form).
    subroutine test_exponential()
        real(dp) :: x(2), cost, bref, aref, cref
        integer(ip) :: reason, niter, info
        integer :: trials
        logical :: mono
        call run(expo, yexact, [1.0_dp, 0.0_dp], 100_ip, 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, kept, x, cost, reason, &
            niter, trials, mono, info)
        call expect(info == sk_ok .and. mono, 'exponential: runs')
        call expect(abs(x(1) - 2.0_dp) < 1.0e-10_dp .and. abs(x(2) + 0.3_dp) < 1.0e-10_dp, 'exponential: exact data')
        call profile_minimum(ynoisy, aref, bref, cref)
        call run(expo, ynoisy, [1.0_dp, 0.0_dp], 100_ip, 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, kept, x, cost, reason, &
            niter, trials, mono, info)
        print '(a, i0, a, i0, a, 2es10.2)', 'exponential (noisy): reason ', reason, ', iterations ', niter, &
            ', error ', x - [aref, bref]
        call expect(info == sk_ok .and. reason == lm_ftol, 'exponential: noisy data, ftol')
        call expect(abs(x(1) - aref) < 1.0e-7_dp .and. abs(x(2) - bref) < 1.0e-7_dp .and. cost <= cref*(1 + 1.0e-12_dp), &
            'exponential: noisy data at the minimum')
    end subroutine test_exponential

    !> min over b of the cost with a(b) in closed form, by golden section on
    !> [-1, 0.5] (the profile cost is unimodal there).
    subroutine profile_minimum(y, a, b, cost)
        real(dp), intent(in) :: y(:)
        real(dp), intent(out) :: a, b, cost
        real(dp), parameter :: g = 0.5_dp*(sqrt(5.0_dp) - 1.0_dp)
        real(dp) :: lo, hi, b1, b2
        integer :: it
        lo = -1.0_dp
        hi = 0.5_dp
        do it = 1, 200
            b1 = hi - g*(hi - lo)
            b2 = lo + g*(hi - lo)
            if (profile(y, b1, a) < profile(y, b2, a)) then
                hi = b2
            else
                lo = b1
            end if
        end do
        b = 0.5_dp*(lo + hi)
        cost = profile(y, b, a)
    end subroutine profile_minimum

    !> The cost of y = a exp(b t) at b with the best a (returned).
    real(dp) function profile(y, b, a)
        real(dp), intent(in) :: y(:), b
        real(dp), intent(out) :: a
        real(dp) :: e(nt)
        e = exp(b*tt)
        a = sum(y*e)/sum(e*e)
        profile = 0.5_dp*sum((a*e - y)**2)
    end function profile

    !> A parameter the model ignores (a zero column) keeps its value exactly
    !> and costs no iterations; from a = 0 the column of b is zero at the
    !> start (floored scale), and b still converges.
    subroutine test_zero_columns()
        real(dp) :: x3(3), x2(2), cost
        integer(ip) :: reason, niter, niter2, info
        integer :: trials
        logical :: mono
        call run(expo, yexact, [1.0_dp, 0.0_dp], 100_ip, 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, kept, x2, cost, reason, &
            niter2, trials, mono, info)
        call run(expo_zero_col, yexact, [1.0_dp, 0.0_dp, 0.7_dp], 100_ip, 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, kept, x3, &
            cost, reason, niter, trials, mono, info)
        call expect(info == sk_ok .and. x3(3) == 0.7_dp, 'zero column: its parameter does not move')
        call expect(maxval(abs(x3(1:2) - [2.0_dp, -0.3_dp])) < 1.0e-10_dp .and. abs(niter - niter2) <= 1, &
            'zero column: the others converge as without it')
        call run(expo, yexact, [0.0_dp, 0.0_dp], 100_ip, 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, kept, x2, cost, reason, &
            niter, trials, mono, info)
        print '(a, i0, a, i0)', 'zero column at the start: reason ', reason, ', iterations ', niter
        call expect(info == sk_ok .and. maxval(abs(x2 - [2.0_dp, -0.3_dp])) < 1.0e-10_dp .and. niter < 40, &
            'zero column at the start: no stall')
    end subroutine test_zero_columns

    subroutine test_reasons()
        real(dp) :: x(2), cost
        integer(ip) :: reason, niter, info
        integer :: trials
        logical :: mono
        ! at the exact solution: zero cost, nothing to do
        call run(expo, yexact, [2.0_dp, -0.3_dp], 100_ip, 0.0_dp, 0.0_dp, 0.0_dp, kept, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_zero .and. niter == 0 .and. trials == 0, 'reason: zero at the start')
        ! only the gradient test can stop it
        call run(expo, ynoisy, [1.0_dp, 0.0_dp], 100_ip, 0.0_dp, 0.0_dp, 1.0e-9_dp, kept, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_gtol, 'reason: gtol')
        ! only the step test
        call run(expo, ynoisy, [1.0_dp, 0.0_dp], 100_ip, 0.0_dp, 1.0e-6_dp, 0.0_dp, kept, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_xtol, 'reason: xtol')
        ! only the cost test
        call run(expo, ynoisy, [1.0_dp, 0.0_dp], 100_ip, 1.0e-10_dp, 0.0_dp, 0.0_dp, kept, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_ftol, 'reason: ftol')
        ! the iteration limit
        call run(rosenbrock, [0.0_dp], [-1.2_dp, 1.0_dp], 3_ip, 0.0_dp, 0.0_dp, 0.0_dp, kept, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_maxit .and. niter == 3, 'reason: maxit')
        call run(rosenbrock, [0.0_dp], [-1.2_dp, 1.0_dp], 0_ip, 0.0_dp, 0.0_dp, 0.0_dp, kept, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_maxit .and. niter == 0 .and. trials == 0, 'reason: maxit 0')
        ! a Jacobian of the wrong sign: every step raises the cost, lambda
        ! grows past its limit (not an endless loop)
        call run(wrong_sign, [0.0_dp], [-1.2_dp, 1.0_dp], 100_ip, 0.0_dp, 0.0_dp, 0.0_dp, kept, x, cost, reason, &
            niter, trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_lambda .and. niter == 1 .and. all(x == [-1.2_dp, 1.0_dp]), &
            'reason: lambda (wrong Jacobian)')
        ! no trial can be evaluated (outside the model's domain)
        call run(never_ok, [0.0_dp], [-1.2_dp, 1.0_dp], 100_ip, 0.0_dp, 0.0_dp, 0.0_dp, api, x, cost, reason, niter, &
            trials, mono, info)
        call expect(info == sk_ok .and. reason == lm_lambda .and. trials < 20, 'reason: lambda (no trial evaluated)')
        ! fewer residuals than unknowns: a solution of the line
        call run(underdetermined, [0.0_dp], [0.0_dp, 0.0_dp], 100_ip, 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, api, x, cost, &
            reason, niter, trials, mono, info)
        call expect(info == sk_ok .and. cost < 1.0e-20_dp .and. reason /= lm_maxit .and. reason /= lm_lambda, &
            'underdetermined: on the line')
    end subroutine test_reasons

    !> Calls out of order, wrong sizes, bad values and foreign states.
    subroutine test_protocol()
        type(lm_state) :: st
        real(dp) :: jac(3, 2), res(3), dx(2), dx2(2), rs(lm_state_size(2))
        integer(ip) :: is(lm_nint), info, reason
        logical :: accepted
        jac = reshape([1.0_dp, 1.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2.0_dp], [3, 2])
        res = [1.0_dp, -2.0_dp, 0.5_dp]
        call lm_start(st, jac, res(1:2), 10_ip, 0.0_dp, 0.0_dp, 0.0_dp, info)
        call expect(info == sk_err_size, 'protocol: rows of jac and res differ')
        call lm_start(st, jac, res, -1_ip, 0.0_dp, 0.0_dp, 0.0_dp, info)
        call expect(info == sk_err_argument, 'protocol: maxit < 0')
        call lm_start(st, jac, res, 10_ip, -1.0_dp, 0.0_dp, 0.0_dp, info)
        call expect(info == sk_err_argument, 'protocol: negative tolerance')
        res(2) = ieee_value(1.0_dp, ieee_quiet_nan)
        call lm_start(st, jac, res, 10_ip, 0.0_dp, 0.0_dp, 0.0_dp, info)
        call expect(info == sk_err_nonfinite, 'protocol: NaN residual')
        res(2) = -2.0_dp
        call lm_start(st, jac, res, 10_ip, 0.0_dp, 0.0_dp, 0.0_dp, info)
        call expect(info == sk_ok .and. st%reason == lm_running, 'protocol: start')
        call lm_accept(st, .true., jac, res, accepted, info)
        call expect(info == sk_err_argument .and. .not. accepted, 'protocol: a verdict before a step')
        call lm_step(st, [0.0_dp, 0.0_dp, 0.0_dp], dx, info)
        call expect(info == sk_err_size, 'protocol: x of the wrong size')
        call lm_step(st, [0.0_dp, 0.0_dp], dx, info)
        call expect(info == sk_ok, 'protocol: step')
        call lm_step(st, [0.0_dp, 0.0_dp], dx2, info)
        call expect(info == sk_err_argument, 'protocol: two steps without a verdict')
        call lm_accept(st, .true., jac(:, 1:1), res, accepted, info)
        call expect(info == sk_err_size, 'protocol: Jacobian of the wrong width')
        ! a linear model: the trial's residual is exact, the verdict accepts
        call lm_accept(st, .true., jac, res + matmul(jac, dx), accepted, info)
        call expect(info == sk_ok .and. accepted, 'protocol: verdict')
        call lm_save(st, rs, is, info)
        call expect(info == sk_ok .and. is(2) == 2, 'protocol: save')
        is(1) = is(1) + 1
        call lm_load(st, rs, is, info)
        call expect(info == sk_err_argument, 'protocol: foreign state refused')
        is(1) = is(1) - 1
        call lm_load(st, rs(1:size(rs) - 1), is, info)
        call expect(info == sk_err_argument, 'protocol: state of the wrong length refused')
        is(5) = 9
        call lm_load(st, rs, is, info)
        call expect(info == sk_err_argument, 'protocol: unknown reason refused')
        is(5) = lm_xtol
        call lm_load(st, rs, is, info)
        call expect(info == sk_ok .and. st%reason == lm_xtol, 'protocol: load')
        call lm_step(st, [0.0_dp, 0.0_dp], dx2, info)
        call expect(info == sk_err_argument, 'protocol: no step after a stop')
        reason = st%reason
        call expect(reason == lm_xtol, 'protocol: the stopped state stays')
    end subroutine test_protocol

end program test_lm
