!> The one Levenberg-Marquardt loop of the core: every nonlinear fit (the
!> tree model's on tracker data, sk_tree_solve tree_lm; the deflection
!> model's on relative data, sk_deflect_fit deflection_lm) is a problem
!> (a type extending lm_problem) that this loop drives with sk_lm's step,
!> acceptance, damping and stopping tests. A problem evaluates its
!> residual and Jacobian in its own variables x (eval), may move x after an
!> accepted step without changing the point (accepted: a re-centred
!> tracker rotation, variables recomputed from the model's values), and
!> may ask for new variables at the current point (stale, then restart:
!> the loop starts sk_lm again there with the iterations left; the
!> restart's first factorisation is not counted twice).
module sk_lm_solve
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_lm, only: lm_state, lm_start, lm_step, lm_accept, lm_running
    implicit none
    private
    public :: lm_problem, lm_solve

    !> A least-squares problem min 1/2 |r(x)|^2 for lm_solve (module header).
    type, abstract :: lm_problem
    contains
        procedure(lm_eval), deferred :: eval
        procedure :: accepted => no_change
        procedure :: stale => never_stale
        procedure :: restart => no_restart
    end type lm_problem

    abstract interface
        !> Residual res[m] and Jacobian jac[m,n] at x[n]; ok = .false.: x
        !> lies outside the model's domain or the evaluation failed (the
        !> trial is rejected; jac and res are not read).
        subroutine lm_eval(self, x, jac, res, ok)
            import :: lm_problem, dp
            class(lm_problem), intent(inout) :: self
            real(dp), intent(in) :: x(:)
            real(dp), intent(out) :: jac(:, :), res(:)
            logical, intent(out) :: ok
        end subroutine lm_eval
    end interface

contains

    !> Fit from x[n] (in: the start; out: the end), with jac[m,n] and res[m]
    !> evaluated there by the caller (out: at the end); maxit, ftol, xtol,
    !> gtol: sk_lm's. niter: the iterations used; reason: sk_lm's (never
    !> lm_running); optional hist[maxit+1]: the cost at the start and after
    !> each accepted step, nhist of them. info: sk_lm's failures (an input
    !> of lm_start, a failed factorisation or solve), else sk_ok.
    subroutine lm_solve(p, x, jac, res, maxit, ftol, xtol, gtol, niter, reason, info, hist, nhist)
        class(lm_problem), intent(inout) :: p
        real(dp), intent(inout) :: x(:), jac(:, :), res(:)
        integer(ip), intent(in) :: maxit
        real(dp), intent(in) :: ftol, xtol, gtol
        integer(ip), intent(out) :: niter, reason, info
        real(dp), intent(inout), optional :: hist(:)
        integer(ip), intent(out), optional :: nhist
        type(lm_state) :: st
        real(dp) :: dx(size(x)), xt(size(x)), jt(size(jac, 1), size(jac, 2)), rt(size(res))
        logical :: ok, accepted, stale
        integer :: nh
        niter = 0
        reason = lm_running
        nh = 0
        if (present(nhist)) nhist = 0
        do
            call lm_start(st, jac, res, maxit - niter, ftol, xtol, gtol, info)
            if (info /= sk_ok) return
            if (nh == 0) call record()
            stale = .false.
            do while (st%reason == lm_running .and. .not. stale)
                call lm_step(st, x, dx, info)
                if (info /= sk_ok) return
                xt = x + dx
                call p%eval(xt, jt, rt, ok)
                call lm_accept(st, ok, jt, rt, accepted, info)
                if (accepted) then
                    x = xt
                    jac = jt
                    res = rt
                    call p%accepted(x)
                    call record()
                    stale = st%reason == lm_running .and. p%stale()
                end if
                if (info /= sk_ok) return
            end do
            niter = niter + st%niter - merge(1, 0, stale)
            if (.not. stale) exit
            call p%restart(x, jac)
        end do
        reason = st%reason

    contains

        subroutine record()
            nh = nh + 1
            if (present(hist)) then
                if (nh <= size(hist)) hist(nh) = st%cost
            end if
            if (present(nhist)) nhist = nh
        end subroutine record
    end subroutine lm_solve

    !> Default hook after an accepted step: the variables stay.
    subroutine no_change(self, x)
        class(lm_problem), intent(inout) :: self
        real(dp), intent(inout) :: x(:)
        associate (a => self, b => x)
        end associate
    end subroutine no_change

    !> Default: the variables never go stale.
    logical function never_stale(self)
        class(lm_problem), intent(inout) :: self
        associate (a => self)
        end associate
        never_stale = .false.
    end function never_stale

    !> Default restart: nothing changes (never called: never_stale).
    subroutine no_restart(self, x, jac)
        class(lm_problem), intent(inout) :: self
        real(dp), intent(inout) :: x(:), jac(:, :)
        associate (a => self, b => x, c => jac)
        end associate
    end subroutine no_restart

end module sk_lm_solve
