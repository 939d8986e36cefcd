!> Levenberg-Marquardt for any least-squares problem min 1/2 |r(x)|^2 whose
!> residual r and Jacobian J the caller evaluates: the damped step, its
!> predicted reduction, the acceptance test with the update of lambda, and
!> the stopping tests, on a state (lm_state) the caller keeps and passes
!> back. One implementation for every fit: the core's one loop around
!> them (sk_lm_solve lm_solve) runs both fits, the tree model's on tracker
!> data (sk_tree_solve tree_lm) and the deflection model's on relative
!> data (sk_deflect_fit deflection_lm); the entry points of sk_api_calib
!> expose them by reverse communication, with the state flattened to two
!> arrays (lm_save, lm_load).
!>
!> Protocol: lm_start(st, J, r) at the start x0; then, while st%reason is
!> lm_running, lm_step(st, x, dx) gives the trial x + dx, the caller
!> evaluates r and J there and calls lm_accept(st, ok, J, r, accepted): on
!> acceptance the caller moves to the trial, else it stays at x (and calls
!> lm_step again). ok = .false. reports a trial outside the model's domain
!> or a failed evaluation: it is rejected like a trial that raised the cost.
!> The caller may change its variables (units, a reparametrisation) only
!> by starting again (lm_start) at the new point.
!>
!> Each step solves the damped problem as an augmented least-squares problem
!>   min | [J; sqrt(lambda) D] dx + [r; 0] |,
!> from the triangular factor R of the QR decomposition of [J r] (kept in
!> the state: the rejected trials at one point cost no factorisation), so
!> the normal equations (and the squared condition number) are never
!> formed. D holds Marquardt's scales: the running maximum of the column
!> norms of J, floored at the start at 1e-6 of the largest, so that a
!> column that is zero or at round-off there is damped like the others
!> instead of taking an unbounded step along it (an exactly zero column
!> gets an exactly zero step). The model's predicted reduction of the cost
!> is pred = 1/2 (|c|^2 - |c + R dx|^2) with c = Q^T r. A trial is accepted
!> when its cost is below the current one; lambda then follows Nielsen's
!> rule: times max(1/10, 1 - (2 rho - 1)^3), rho = actual / predicted
!> reduction, and nu = 2; on rejection lambda is multiplied by nu and nu
!> doubles. lambda starts at 1e-3.
!>
!> Reasons to stop (st%reason; lm_running = 0 while the iteration goes on):
!> lm_ftol (1) the actual and the predicted reduction of an accepted step
!> are both below ftol times the cost, or the predicted reduction of a
!> rejected one is; lm_xtol (2) the scaled step |D dx| is below
!> xtol (|D x| + xtol); lm_gtol (3) every column of J is within gtol of
!> orthogonal to r (the cosine of their angle); lm_zero (4) the cost is
!> zero; lm_maxit (5) maxit iterations (points at which a step was
!> computed: factorisations of [J r]) are used; lm_lambda (6) lambda rose
!> above 1e16: no decrease found. A zero cost overrides ftol and xtol.
module sk_lm
    use, intrinsic :: iso_fortran_env, only: int64
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: qr_triangle, lstsq, all_finite
    implicit none
    private
    public :: lm_state, lm_start, lm_step, lm_accept, lm_save, lm_load, lm_state_size

    integer(ip), parameter, public :: lm_running = 0, lm_ftol = 1, lm_xtol = 2, lm_gtol = 3, lm_zero = 4, &
        lm_maxit = 5, lm_lambda = 6
    !> length of the integer state array of lm_save / lm_load
    integer, parameter, public :: lm_nint = 6

    !> first lambda, the largest before giving up, and the floor of the
    !> Marquardt scales relative to the largest (at the start)
    real(dp), parameter :: lambda0 = 1.0e-3_dp, lambda_max = 1.0e16_dp, scale_floor = 1.0e-6_dp
    !> the number of real scalars in front of the arrays of the flat state
    integer, parameter :: nscal = 9
    !> first element of the integer state: marks an array lm_save wrote
    integer(ip), parameter :: tag = 19533

    !> The iteration's state. n: unknowns; dsc[n]: Marquardt's scales;
    !> r[n,n], c[n]: the triangular factor of [J r] at the current point and
    !> Q^T r; dx[n], predred, dnorm = |D dx|, xnorm = |D x|: the last trial
    !> step; stepped: a trial is out (lm_accept is next).
    type :: lm_state
        integer(ip) :: n = 0, maxit = 0, niter = 0, reason = lm_running
        logical :: stepped = .false.
        real(dp) :: ftol = 0.0_dp, xtol = 0.0_dp, gtol = 0.0_dp, lam = lambda0, nu = 2.0_dp, cost = 0.0_dp, &
            predred = 0.0_dp, dnorm = 0.0_dp, xnorm = 0.0_dp
        real(dp), allocatable :: dsc(:), r(:, :), c(:), dx(:)
    end type lm_state

contains

    !> Length of the real state array for n unknowns.
    pure integer function lm_state_size(n)
        integer, intent(in) :: n
        lm_state_size = nscal + n*(n + 3)
    end function lm_state_size

    !> Start at a point with Jacobian jac[m,n] and residual res[m] (any m:
    !> the factorisation pads [J r] with zero rows when m <= n); maxit, ftol,
    !> xtol, gtol as in the module header. info: sk_err_size (res does not
    !> match jac), sk_err_argument (maxit < 0, a tolerance negative or NaN),
    !> sk_err_nonfinite (NaN or Inf in jac or res), sk_err_overflow (the cost
    !> is not finite), or a failure of the factorisation.
    subroutine lm_start(st, jac, res, maxit, ftol, xtol, gtol, info)
        type(lm_state), intent(out) :: st
        real(dp), intent(in) :: jac(:, :), res(:), ftol, xtol, gtol
        integer(ip), intent(in) :: maxit
        integer(ip), intent(out) :: info
        integer :: n, j
        n = size(jac, 2)
        st%n = n
        allocate(st%dsc(n), st%r(n, n), st%c(n), st%dx(n))
        st%dsc = 1.0_dp
        st%r = 0.0_dp
        st%c = 0.0_dp
        st%dx = 0.0_dp
        info = sk_err_size
        if (size(res) /= size(jac, 1)) return
        info = sk_err_argument
        if (maxit < 0 .or. .not. (ftol >= 0.0_dp .and. xtol >= 0.0_dp .and. gtol >= 0.0_dp)) return
        info = sk_err_nonfinite
        if (.not. (all_finite(jac) .and. all_finite(res))) return
        st%cost = 0.5_dp*sum(res**2)
        info = sk_err_overflow
        if (.not. st%cost <= huge(1.0_dp)) return
        st%maxit = maxit
        st%ftol = ftol
        st%xtol = xtol
        st%gtol = gtol
        do j = 1, n
            st%dsc(j) = norm2(jac(:, j))
        end do
        if (n > 0) then
            if (maxval(st%dsc) > 0.0_dp) then
                where (st%dsc < scale_floor*maxval(st%dsc)) st%dsc = scale_floor*maxval(st%dsc)
            else
                st%dsc = 1.0_dp
            end if
        end if
        if (st%cost == 0.0_dp) st%reason = lm_zero
        if (n == 0) st%reason = lm_ftol
        call begin_point(st, jac, res, info)
    end subroutine lm_start

    !> The trial step dx[n] from the current point x[n] (the caller's
    !> variables, for the xtol test) at the current lambda. info:
    !> sk_err_size, sk_err_argument (the iteration has stopped, or a trial
    !> is already out), sk_err_nonfinite (x), or a failure of the solve.
    subroutine lm_step(st, x, dx, info)
        type(lm_state), intent(inout) :: st
        real(dp), intent(in) :: x(:)
        real(dp), intent(out) :: dx(:)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: stack(:, :), rhs(:)
        integer :: n, j
        n = st%n
        dx = 0.0_dp
        info = sk_err_size
        if (size(x) /= n .or. size(dx) /= n .or. .not. allocated(st%dsc)) return
        info = sk_err_argument
        if (st%reason /= lm_running .or. st%stepped) return
        info = sk_err_nonfinite
        if (.not. all_finite(x)) return
        allocate(stack(2*n, n), rhs(2*n))
        stack = 0.0_dp
        stack(1:n, :) = st%r
        do j = 1, n
            stack(n + j, j) = sqrt(st%lam)*st%dsc(j)
        end do
        rhs = 0.0_dp
        rhs(1:n) = -st%c
        call lstsq(stack, rhs, dx, info)
        if (info /= sk_ok) return
        st%predred = 0.5_dp*(sum(st%c**2) - sum((st%c + matmul(st%r, dx))**2))
        st%dnorm = norm2(st%dsc*dx)
        st%xnorm = norm2(st%dsc*x)
        st%dx = dx
        st%stepped = .true.
    end subroutine lm_step

    !> The verdict on the last trial, evaluated by the caller: jac[m,n] and
    !> res[m] there, ok = .false. when the evaluation failed (or the trial
    !> lies outside the model's domain; jac and res are then not read).
    !> accepted: the caller moves to the trial. The stopping tests, lambda,
    !> the scales and, after an accepted trial, the factorisation at the new
    !> point are updated (module header). info: sk_err_size, sk_err_argument
    !> (no trial is out), or a failure of the factorisation (the trial is
    !> then accepted all the same).
    subroutine lm_accept(st, ok, jac, res, accepted, info)
        type(lm_state), intent(inout) :: st
        logical, intent(in) :: ok
        real(dp), intent(in) :: jac(:, :), res(:)
        logical, intent(out) :: accepted
        integer(ip), intent(out) :: info
        real(dp) :: costt, rho
        integer :: j
        accepted = .false.
        info = sk_err_size
        if (size(jac, 2) /= st%n .or. size(res) /= size(jac, 1)) return
        info = sk_err_argument
        if (.not. st%stepped) return
        info = sk_ok
        st%stepped = .false.
        costt = huge(1.0_dp)
        if (ok) then
            if (all_finite(res) .and. all_finite(jac)) costt = 0.5_dp*sum(res**2)
        end if
        if (costt < st%cost) then
            accepted = .true.
            rho = (st%cost - costt)/max(st%predred, tiny(1.0_dp))
            st%lam = max(st%lam*max(0.1_dp, 1.0_dp - (2.0_dp*rho - 1.0_dp)**3), tiny(1.0_dp))
            st%nu = 2.0_dp
            if (st%cost - costt <= st%ftol*st%cost .and. st%predred <= st%ftol*st%cost) st%reason = lm_ftol
            if (st%dnorm <= st%xtol*(st%xnorm + st%xtol)) st%reason = lm_xtol
            st%cost = costt
            if (st%cost == 0.0_dp) st%reason = lm_zero
            do j = 1, st%n
                st%dsc(j) = max(st%dsc(j), norm2(jac(:, j)))
            end do
            call begin_point(st, jac, res, info)
            return
        end if
        ! no decrease: at the round-off floor, or damp harder
        if (st%predred <= st%ftol*st%cost) then
            st%reason = lm_ftol
        else if (st%dnorm <= st%xtol*(st%xnorm + st%xtol)) then
            st%reason = lm_xtol
        else
            st%lam = st%lam*st%nu
            st%nu = 2.0_dp*st%nu
            if (st%lam > lambda_max) st%reason = lm_lambda
        end if
    end subroutine lm_accept

    !> A new current point (the start or an accepted trial): the iteration
    !> limit, the gtol test, then the triangular factor of [J r].
    subroutine begin_point(st, jac, res, info)
        type(lm_state), intent(inout) :: st
        real(dp), intent(in) :: jac(:, :), res(:)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: aug(:, :), rr(:, :)
        real(dp) :: rnorm, gmax, cn
        integer :: m, n, j
        info = sk_ok
        if (st%reason /= lm_running) return
        if (st%niter >= st%maxit) then
            st%reason = lm_maxit
            return
        end if
        m = size(jac, 1)
        n = st%n
        ! orthogonality of the residual to every column (cost > 0 here)
        rnorm = norm2(res)
        gmax = 0.0_dp
        do j = 1, n
            cn = norm2(jac(:, j))
            if (cn > 0.0_dp) gmax = max(gmax, abs(dot_product(jac(:, j), res))/(cn*rnorm))
        end do
        if (gmax <= st%gtol) then
            st%reason = lm_gtol
            return
        end if
        st%niter = st%niter + 1
        allocate(aug(max(m, n + 1), n + 1), rr(n + 1, n + 1))
        aug = 0.0_dp
        aug(1:m, 1:n) = jac
        aug(1:m, n + 1) = res
        call qr_triangle(aug, rr, info)
        if (info /= sk_ok) return
        st%r = rr(1:n, 1:n)
        st%c = rr(1:n, n + 1)
    end subroutine begin_point

    !> The state as a real array rs[lm_state_size(n)] and an integer array
    !> is[lm_nint] (for a caller that keeps it across calls of the entry
    !> points: reverse communication). info: sk_err_size.
    subroutine lm_save(st, rs, is, info)
        type(lm_state), intent(in) :: st
        real(dp), intent(out) :: rs(:)
        integer(ip), intent(out) :: is(:)
        integer(ip), intent(out) :: info
        integer :: n, k
        n = st%n
        rs = 0.0_dp
        is = 0
        info = sk_err_size
        if (.not. allocated(st%dsc) .or. size(is) /= lm_nint .or. size(rs) /= lm_state_size(n)) return
        is = [tag, st%n, st%maxit, st%niter, st%reason, merge(1_ip, 0_ip, st%stepped)]
        rs(1:nscal) = [st%ftol, st%xtol, st%gtol, st%lam, st%nu, st%cost, st%predred, st%dnorm, st%xnorm]
        k = nscal
        rs(k + 1:k + n) = st%dsc
        k = k + n
        rs(k + 1:k + n) = st%c
        k = k + n
        rs(k + 1:k + n) = st%dx
        k = k + n
        rs(k + 1:k + n*n) = reshape(st%r, [n*n])
        info = sk_ok
    end subroutine lm_save

    !> The state from the arrays lm_save wrote. info: sk_err_argument when
    !> they are not such arrays (mark, sizes, codes).
    subroutine lm_load(st, rs, is, info)
        type(lm_state), intent(out) :: st
        real(dp), intent(in) :: rs(:)
        integer(ip), intent(in) :: is(:)
        integer(ip), intent(out) :: info
        integer :: n, k
        info = sk_err_argument
        if (size(is) /= lm_nint) return
        n = is(2)
        if (is(1) /= tag .or. n < 0 .or. n > size(rs)) return
        if (int(size(rs), int64) /= nscal + int(n, int64)*(n + 3)) return
        if (is(3) < 0 .or. is(4) < 0 .or. is(4) > is(3) .or. is(5) < lm_running .or. is(5) > lm_lambda &
            .or. (is(6) /= 0 .and. is(6) /= 1)) return
        if (.not. all_finite(rs)) return
        st%n = n
        st%maxit = is(3)
        st%niter = is(4)
        st%reason = is(5)
        st%stepped = is(6) == 1
        st%ftol = rs(1)
        st%xtol = rs(2)
        st%gtol = rs(3)
        st%lam = rs(4)
        st%nu = rs(5)
        st%cost = rs(6)
        st%predred = rs(7)
        st%dnorm = rs(8)
        st%xnorm = rs(9)
        k = nscal
        st%dsc = rs(k + 1:k + n)
        k = k + n
        st%c = rs(k + 1:k + n)
        k = k + n
        st%dx = rs(k + 1:k + n)
        k = k + n
        st%r = reshape(rs(k + 1:k + n*n), [n, n])
        info = sk_ok
    end subroutine lm_load

end module sk_lm
