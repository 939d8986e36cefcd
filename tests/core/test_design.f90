!> Unit tests of sk_design, the experiment-design core: the Woodbury
!> updates of M^-1 and of the per-candidate blocks B_c = J_c M^-1 J_c^T,
!> C_c = J_c M^-1 Q M^-1 J_c^T after adding and removing a candidate equal
!> the blocks rebuilt from scratch; the criterion change of adding a
!> candidate (add_cache) equals the difference of direct evaluations; the
!> criterion after every greedy step, and after the exchange passes (the
!> swap formulas of swap_pass), equals the direct evaluation of the
!> selection, and the exchange is never worse than greedy. Discrimination:
!> the noncentrality after adding each candidate by the Woodbury formula
!> (disc_evaluate) equals the direct projection (disc_pairs) of the rows
!> plus that candidate.
program test_design
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_design
    use sk_design_disc, only: disc_evaluate, disc_pairs, rows_of, tmin
    implicit none (type, external)

    integer, parameter :: npar = 7, nobs = 3, ncand = 25, nt = 4
    real(dp) :: jc(npar, nobs, ncand), jt(npar, nt), m0(npar, npar), a(npar, npar)
    integer(ip) :: crit
    integer :: i

    call fill(jc, size(jc))
    call fill(jt, size(jt))
    call fill(a, size(a))
    m0 = 0.05_dp * matmul(transpose(a), a)
    do i = 1, npar
        m0(i, i) = m0(i, i) + 0.1_dp  ! a regular prior (condition ~10)
    end do
    do crit = crit_d, crit_task
        call check_updates(crit)
        call check_select(crit)
    end do
    call check_discrimination()
    call finish('design')

contains

    !> Deterministic pseudo-random numbers x[n] in (-1, 1) (a fixed LCG).
    subroutine fill(x, n)
        integer, intent(in) :: n
        real(dp), intent(out) :: x(n)
        integer(8), save :: state = 12345
        integer :: i
        do i = 1, n
            state = mod(1103515245_8 * state + 12345_8, 2147483648_8)
            x(i) = 2.0_dp * real(state, dp) / 2147483648.0_dp - 1.0_dp
        end do
    end subroutine fill

    real(dp) function rel(x, y)
        real(dp), intent(in) :: x, y
        rel = abs(x - y) / max(abs(y), tiny(1.0_dp))
    end function rel

    real(dp) function direct(chosen, c) result(f)
        integer(ip), intent(in) :: chosen(:), c
        real(dp) :: s(npar)
        integer :: bad
        call criterion_direct(jc, m0, jt, chosen, c, f, bad, s)
    end function direct

    !> Blocks after add/remove equal the blocks of a fresh state.
    subroutine check_updates(c)
        integer(ip), intent(in) :: c
        type(design_state) :: st, fresh
        integer :: bad
        integer(ip) :: info
        real(dp) :: f0, f1
        call state_alloc(st, jc, m0, jt, c)
        st%chosen([2, 5, 9]) = .true.
        call state_init(st, jc, m0, 0.0_dp, bad)
        call expect(bad == 0, 'regular start')
        call expect(rel(st%value, direct([2_ip, 5_ip, 9_ip], c)) < 1e-12_dp, 'state_init value = direct')
        call add_cache(st)
        f0 = st%value
        f1 = direct([2_ip, 5_ip, 9_ip, 14_ip], c)
        call expect(abs(f0 + st%dadd(14) - f1) < 1e-11_dp * abs(f1), 'add delta = difference of direct values')
        call state_update(st, jc, 14, 1.0_dp, info)
        call expect(info == sk_ok, 'add update')
        st%chosen(14) = .true.
        call compare(st, fresh, c, 'after adding')
        call state_update(st, jc, 5, -1.0_dp, info)
        call expect(info == sk_ok, 'remove update')
        st%chosen(5) = .false.
        call compare(st, fresh, c, 'after removing')
    end subroutine check_updates

    subroutine compare(st, fresh, c, what)
        type(design_state), intent(in) :: st
        type(design_state), intent(inout) :: fresh
        integer(ip), intent(in) :: c
        character(*), intent(in) :: what
        integer :: bad
        call state_alloc(fresh, jc, m0, jt, c)
        fresh%chosen = st%chosen
        call state_init(fresh, jc, m0, 0.0_dp, bad)
        call expect(maxval(abs(st%minv - fresh%minv)) < 1e-11_dp * maxval(abs(fresh%minv)), 'M^-1 ' // what)
        call expect(maxval(abs(st%b - fresh%b)) < 1e-11_dp * maxval(abs(fresh%b)), 'B blocks ' // what)
        if (c /= crit_d) call expect(maxval(abs(st%c - fresh%c)) < 1e-11_dp * maxval(abs(fresh%c)), &
            'C blocks ' // what)
    end subroutine compare

    !> Selection: value = direct evaluation, exchange no worse than greedy,
    !> one exchange pass's value change = difference of direct values.
    subroutine check_select(c)
        integer(ip), intent(in) :: c
        integer(ip) :: sel(6), g(6), passes, swaps, singular, ridged, info
        real(dp) :: value, gvalue, path(6), s(npar), gv, gpath(6)
        integer :: i
        call design_select(jc, 6_ip, c, m0, jt, 0_ip, g, gv, gvalue, gpath, passes, swaps, s, singular, ridged, info)
        call expect(info == sk_ok .and. ridged == 0 .and. passes == 0, 'greedy only')
        do i = 1, 6
            call expect(rel(gpath(i), direct(g(1:i), c)) < 1e-11_dp, 'greedy path = direct')
        end do
        call design_select(jc, 6_ip, c, m0, jt, 50_ip, sel, value, gvalue, path, passes, swaps, s, singular, &
            ridged, info)
        call expect(info == sk_ok .and. singular == 0, 'select ok')
        call expect(rel(gvalue, gv) < 1e-14_dp, 'greedy value reported')
        call expect(value <= gvalue, 'exchange no worse than greedy')
        call expect(rel(value, direct(sel, c)) < 1e-11_dp, 'selected value = direct')
        call expect(passes >= 1 .and. passes < 50, 'exchange stopped')
    end subroutine check_select

    !> Woodbury noncentralities of disc_evaluate against disc_pairs.
    subroutine check_discrimination()
        integer(ip), parameter :: n0 = 5, nob = 2, nc = 9, nh = 3
        integer(ip) :: hoff(nh + 1), sel(2)
        real(dp) :: f(n0 + nob * nc, nh), js(n0 + nob * nc, 7), tc(nc), tnow, pairs(nh, nh)
        logical :: skip(nc)
        integer(ip) :: info
        integer :: c
        call fill(f, size(f))
        call fill(js, size(js))
        hoff = [0_ip, 3_ip, 5_ip, 7_ip]
        sel = [4_ip, 7_ip]
        skip = .false.
        skip(sel) = .true.
        call disc_evaluate(f, js, hoff, n0, nob, rows_of(n0, nob, sel), skip, tc, tnow, info)
        call expect(info == sk_ok, 'disc_evaluate')
        call disc_pairs(f, js, hoff, rows_of(n0, nob, sel), pairs, info)
        call expect(rel(tnow, tmin(pairs)) < 1e-10_dp, 'T of the rows = direct')
        do c = 1, nc
            if (skip(c)) cycle
            call disc_pairs(f, js, hoff, rows_of(n0, nob, [sel, int(c, ip)]), pairs, info)
            call expect(rel(tc(c), tmin(pairs)) < 1e-10_dp, 'T after adding a candidate = direct')
        end do
    end subroutine check_discrimination

end program test_design
