!> Unit tests of sk_design_weak: the information's diagonal (of the chosen
!> and of all candidates) and the task influence equal their direct sums; a
!> regular design has no null space; a design where column 5 is twice
!> column 4 has one null direction whose projector shares it equally
!> between the two (the unit-diagonal information sees (1, -1)/sqrt(2)) and
!> leaves the other columns out; a column that no chosen row informs is its
!> own null direction.
program test_design_weak
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_design_weak, only: design_weakness
    implicit none (type, external)

    integer, parameter :: npar = 5, nobs = 3, ncand = 12, nt = 4
    real(dp) :: jc(npar, nobs, ncand), jt(npar, nt), m0(npar, npar), direct(npar)
    real(dp) :: info_d(npar), pool(npar), task(npar), ev(npar), proj(npar, npar)
    integer(ip) :: nnull, info, chosen(4)
    integer :: c, j

    call fill(jc, size(jc))
    call fill(jt, size(jt))
    m0 = 0.0_dp
    chosen = [1_ip, 4_ip, 6_ip, 9_ip]
    call design_weakness(jc, m0, jt, chosen, info_d, pool, task, ev, nnull, proj, info)
    call expect(info == sk_ok .and. nnull == 0, 'regular design: no null space')
    call expect(maxval(abs(proj)) == 0.0_dp, 'regular design: zero projector')
    do j = 1, npar
        direct(j) = sum([(sum(jc(j, :, chosen(c))**2), c = 1, size(chosen))])
    end do
    call expect(maxval(abs(info_d - direct)) < 1e-13_dp * maxval(direct), 'info = diagonal of M')
    call expect(maxval(abs(task - sum(jt**2, dim=2))) < 1e-14_dp, 'task influence = column sums of squares')
    call expect(maxval(abs(pool - sum(sum(jc**2, dim=3), dim=2))) < 1e-13_dp * maxval(pool), &
        'pool = diagonal over all candidates')
    call expect(ev(1) > 0.0_dp .and. all(ev(2:) >= ev(:npar - 1)), 'eigenvalues positive, ascending')

    jc(5, :, :) = 2.0_dp * jc(4, :, :)
    call design_weakness(jc, m0, jt, chosen, info_d, pool, task, ev, nnull, proj, info)
    call expect(info == sk_ok .and. nnull == 1, 'collinear pair: one null direction')
    call expect(abs(proj(4, 4) - 0.5_dp) < 1e-10_dp .and. abs(proj(5, 5) - 0.5_dp) < 1e-10_dp, &
        'collinear pair: the null space shared equally')
    call expect(abs(proj(4, 5) + 0.5_dp) < 1e-10_dp, 'collinear pair: opposite signs')
    call expect(maxval(abs(proj(1:3, :))) < 1e-10_dp, 'collinear pair: the others identifiable')

    call fill(jc, size(jc))
    jc(2, :, chosen) = 0.0_dp
    call design_weakness(jc, m0, jt, chosen, info_d, pool, task, ev, nnull, proj, info)
    call expect(info == sk_ok .and. nnull == 1, 'uninformed column: one null direction')
    call expect(info_d(2) == 0.0_dp .and. abs(proj(2, 2) - 1.0_dp) < 1e-12_dp, 'uninformed column: its own')
    call finish('design_weak')

contains

    !> Deterministic pseudo-random numbers x[n] in (-1, 1) (a fixed LCG).
    subroutine fill(x, n)
        integer, intent(in) :: n
        real(dp), intent(out) :: x(n)
        integer(8), save :: state = 4321
        integer :: i
        do i = 1, n
            state = mod(1103515245_8 * state + 12345_8, 2147483648_8)
            x(i) = 2.0_dp * real(state, dp) / 2147483648.0_dp - 1.0_dp
        end do
    end subroutine fill

end program test_design_weak
