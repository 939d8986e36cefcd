!> Unit tests of sk_calib, sk_tails and sk_neighbours: least squares with a
!> duplicated and a zero column (groups, null-space relations), score tests,
!> greedy selection, the chi-square / F tail probabilities in log space, and
!> the neighbour correlation test of a residual's structure.
program test_calib
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_calib
    use sk_tails, only: chi2_logsf, f_logsf
    use sk_neighbours, only: neighbour_correlation
    implicit none (type, external)

    call test_wls_groups()
    call test_score()
    call test_tails()
    call test_select()
    call test_max_score()
    call test_neighbours()
    call finish('calib')

contains

    subroutine test_wls_groups()
        real(dp) :: a(8, 4), y(8), theta(4), stdu(4), s(4), v(4, 4), res(8), tt(4)
        integer(ip) :: rank, group(4), info
        integer :: i
        do i = 1, 8
            a(i, 1) = 1.0_dp
            a(i, 2) = real(i, dp)
            a(i, 3) = 2.0_dp*real(i, dp)           ! coupled with column 2
            a(i, 4) = 0.0_dp                       ! no influence
        end do
        tt = [1.5_dp, 0.25_dp, 0.0_dp, 0.0_dp]
        y = matmul(a, tt)
        call wls_svd(a, y, 1.0e-10_dp, 1.0e-6_dp, theta, stdu, s, v, rank, group, res, info)
        call expect(info == sk_ok .and. rank == 2, 'wls: rank 2')
        call expect(group(1) == group_identifiable, 'wls: intercept identifiable')
        call expect(group(2) == group_semi_identifiable .and. group(3) == group_semi_identifiable, 'wls: coupled pair semi')
        call expect(group(4) == group_non_identifiable, 'wls: zero column non-identifiable')
        call expect(abs(theta(1) - 1.5_dp) < 1e-12_dp, 'wls: identifiable value exact')
        call expect(abs(theta(2) + 2*theta(3) - 0.25_dp) < 1e-12_dp, 'wls: coupled combination exact')
        call expect(maxval(abs(res)) < 1e-12_dp, 'wls: zero residual')
        block
            real(dp) :: rel(2, 4)
            call null_relations(v, rank, 1.0e-9_dp, rel, info)
            ! scaled columns: col 3 / |col 3| = col 2 / |col 2| -> relation (0, 1, -1, 0) and (0, 0, 0, 1)
            call expect(info == sk_ok .and. maxval(abs(rel(1, :) - [0.0_dp, 1.0_dp, -1.0_dp, 0.0_dp])) < 1e-9_dp &
                .and. maxval(abs(rel(2, :) - [0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp])) < 1e-9_dp, 'null relations: sparse rows')
        end block
        call wls_svd(a(1:3, :), y(1:3), 1.0e-10_dp, 1.0e-6_dp, theta, stdu, s, v, rank, group, res(1:3), info)
        call expect(info == sk_err_too_few, 'wls: fewer rows than parameters')
    end subroutine test_wls_groups

    subroutine test_score()
        real(dp) :: a(6, 1), r(6), z(6, 2), stat(2), pr(6, 2)
        integer(ip) :: dof(2), info
        a(:, 1) = [1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp]
        r = [1.0_dp, -1.0_dp, 2.0_dp, -2.0_dp, 0.5_dp, -0.5_dp]
        z(:, 1) = 3*a(:, 1)                         ! spanned by the model
        z(:, 2) = [1.0_dp, -1.0_dp, 2.0_dp, -2.0_dp, 0.5_dp, -0.5_dp] + a(:, 1)
        call score_tests(a, r, z, [1, 2, 3], 1.0e-10_dp, 1.0e-6_dp, stat, dof, pr, info)
        call expect(info == sk_ok, 'score: info')
        call expect(dof(1) == 0 .and. stat(1) == 0, 'score: spanned candidate adds nothing')
        call expect(dof(2) == 1 .and. abs(stat(2) - dot_product(r, r)) < 1e-12_dp, 'score: candidate explains r')
    end subroutine test_score

    subroutine test_tails()
        ! chi2 sf(10, 3) = 0.0185661354..., F sf(3; 2, 10) = 1.6^-5
        call expect(abs(chi2_logsf(10.0_dp, 3.0_dp) - log(0.018566135463043_dp)) < 1e-9_dp, 'chi2 tail')
        call expect(abs(chi2_logsf(2.0_dp, 2.0_dp) + 1.0_dp) < 1e-12_dp, 'chi2 tail k=2 is exp(-x/2)')
        call expect(abs(chi2_logsf(4000.0_dp, 2.0_dp) + 2000.0_dp) < 1e-9_dp, 'chi2 tail in log space, no underflow')
        call expect(abs(f_logsf(3.0_dp, 2.0_dp, 10.0_dp) + 5*log(1.6_dp)) < 1e-10_dp, 'F tail')
    end subroutine test_tails

    subroutine test_select()
        real(dp) :: a(4, 3)
        integer(ip) :: sel(3), info
        a = 0
        a(1, 1) = 1; a(1, 2) = 2; a(2, 3) = 1       ! column 2 = 2 x column 1
        call select_independent(a, [2, 1, 3], 1.0e-8_dp, sel, info)
        call expect(info == sk_ok .and. all(sel == [0, 1, 1]), 'select: the preferred of a dependent pair')
        call select_independent(a, [1, 2, 3], 1.0e-8_dp, sel, info)
        call expect(all(sel == [1, 0, 1]), 'select: order decides')
    end subroutine test_select

    !> The max-score test against closed forms: one candidate (its own
    !> chi-square p-value), a duplicated candidate (no penalty for looking
    !> twice at the same column), two orthogonal ones (Sidak, 1-(1-p)^2), a
    !> candidate spanned by the model (ignored), and the F variant.
    subroutine test_max_score()
        integer, parameter :: n = 12, nsim = 40000
        real(dp) :: a(n, 1), z(n, 3), p, lobs, se
        integer(ip) :: info
        integer :: i
        a(:, 1) = 1.0_dp
        z = 0.0_dp
        do i = 1, n
            z(i, 1) = real(i, dp)                 ! a trend
            z(i, 2) = real(mod(i, 2), dp)         ! an alternation
        end do
        z(:, 3) = 2.0_dp
        lobs = log(0.05_dp)
        se = 3*sqrt(0.05_dp*0.95_dp/nsim)
        call max_score_test(a, z, [1, 2], 1.0e-10_dp, 1.0e-6_dp, lobs, 0, nsim, 7, p, info)
        call expect(info == sk_ok .and. abs(p - 0.05_dp) < se, 'max score: one candidate is its own test')
        call max_score_test(a, reshape([z(:, 1), z(:, 1)], [n, 2]), [1, 2, 3], 1.0e-10_dp, 1.0e-6_dp, lobs, 0, &
            nsim, 7, p, info)
        call expect(info == sk_ok .and. abs(p - 0.05_dp) < se, 'max score: a duplicate costs nothing')
        ! the alternation projected off the mean is not orthogonal to the trend:
        ! use the first half / second half contrast instead, orthogonal to both
        z(:, 2) = [(merge(1.0_dp, -1.0_dp, i <= n/2), i=1, n)]
        z(:, 1) = [(merge(real(i, dp) - 3.5_dp, -(real(i - n/2, dp) - 3.5_dp), i <= n/2), i=1, n)]
        call max_score_test(a, z(:, 1:2), [1, 2, 3], 1.0e-10_dp, 1.0e-6_dp, lobs, 0, nsim, 11, p, info)
        call expect(info == sk_ok .and. abs(dot_product(z(:, 1), z(:, 2))) < 1e-12_dp, 'max score: orthogonal pair')
        call expect(abs(p - (1.0_dp - 0.95_dp**2)) < 3*sqrt(0.0975_dp*0.9025_dp/nsim), 'max score: Sidak for two')
        call max_score_test(a, z, [1, 2, 3, 4], 1.0e-10_dp, 1.0e-6_dp, lobs, 0, nsim, 11, p, info)
        call expect(abs(p - (1.0_dp - 0.95_dp**2)) < 3*sqrt(0.0975_dp*0.9025_dp/nsim), 'max score: spanned ignored')
        call max_score_test(a, z(:, 1:1), [1, 2], 1.0e-10_dp, 1.0e-6_dp, lobs, 5, nsim, 3, p, info)
        call expect(info == sk_ok .and. abs(p - 0.05_dp) < se, 'max score: F against pure error')
        call max_score_test(a, z(:, 1:1), [1, 2], 1.0e-10_dp, 1.0e-6_dp, 0.0_dp, 0, nsim, 3, p, info)
        call expect(p == 1.0_dp, 'max score: log p = 0 is p = 1')
        call max_score_test(a, z(:, 1:1), [1, 2], 1.0e-10_dp, 1.0e-6_dp, lobs, 0, 0, 3, p, info)
        call expect(info == sk_err_argument, 'max score: nsim >= 1')
    end subroutine test_max_score

    !> Neighbour correlation: the nearest point of another group and the
    !> same class on a line; noise gives rho ~ 0 and a large p, a smooth
    !> function of x rho near 1 and the smallest p; bad input codes.
    subroutine test_neighbours()
        integer, parameter :: n = 400, nperm = 199
        real(dp) :: x(1, n), e(3, n), w(n), rho, pval, u(3, n), xs(1, 5), es(1, 5), ws(5)
        integer(ip) :: grp(n), cls(n), nn(n), info, g5(5), c5(5), nn5(5)
        integer :: i
        ! five points on a line: 0, 1, 1.2, 3 (class 1) and 5 (class 2); points 2 and 3 share a group
        xs(1, :) = [0.0_dp, 1.0_dp, 1.2_dp, 3.0_dp, 5.0_dp]
        es(1, :) = [1.0_dp, -1.0_dp, 2.0_dp, 0.5_dp, 1.0_dp]
        ws = 1.0_dp
        g5 = [1, 2, 2, 3, 4]
        c5 = [1, 1, 1, 1, 2]
        call neighbour_correlation(xs, es, ws, g5, c5, 9_ip, 1_ip, rho, pval, nn5, info)
        call expect(info == sk_ok, 'neighbours: small case runs')
        call expect(all(nn5 == [2, 1, 1, 3, 0]), 'neighbours: nearest of another group, same class')
        call expect(abs(rho - (-1.0_dp - 1.0_dp + 2.0_dp + 1.0_dp)/(1.0_dp + 1.0_dp + 4.0_dp + 0.25_dp)) < 1e-14_dp, &
            'neighbours: rho of the small case')
        ! noise, then a smooth function of x plus a little noise
        call random_seed(put=[(12345 + 7*i, i=1, 64)])
        do i = 1, n
            x(1, i) = real(i, dp)/real(n, dp)*6.0_dp
            grp(i) = (i + 1)/2
            cls(i) = 1 + mod(i, 2)
        end do
        call random_number(u)
        e = u - 0.5_dp
        w = 1.0_dp
        call neighbour_correlation(x, e, w, grp, cls, int(nperm, ip), 7_ip, rho, pval, nn, info)
        call expect(info == sk_ok .and. abs(rho) < 0.2_dp .and. pval > 0.01_dp, 'neighbours: noise is not structure')
        e(1, :) = e(1, :)*0.1_dp + sin(x(1, :))
        call neighbour_correlation(x, e, w, grp, cls, int(nperm, ip), 7_ip, rho, pval, nn, info)
        call expect(info == sk_ok .and. rho > 0.3_dp .and. abs(pval - 1.0_dp/(nperm + 1)) < 1e-15_dp, &
            'neighbours: a smooth function of x is structure')
        ! the same seed, the same p
        block
            real(dp) :: p2, r2
            call neighbour_correlation(x, e*0.0_dp + u - 0.5_dp, w, grp, cls, int(nperm, ip), 7_ip, rho, pval, nn, info)
            call neighbour_correlation(x, e*0.0_dp + u - 0.5_dp, w, grp, cls, int(nperm, ip), 7_ip, r2, p2, nn, info)
            call expect(p2 == pval .and. r2 == rho, 'neighbours: reproducible')
        end block
        call neighbour_correlation(x, e, w, grp, cls, 0_ip, 7_ip, rho, pval, nn, info)
        call expect(info == sk_err_argument, 'neighbours: nperm 0 refused')
        call neighbour_correlation(x, e(:, 1:n - 1), w, grp, cls, 9_ip, 7_ip, rho, pval, nn, info)
        call expect(info == sk_err_size, 'neighbours: sizes checked')
        w = 0.0_dp
        w(1:2) = 1.0_dp
        call neighbour_correlation(x, e, w, grp, cls, 9_ip, 7_ip, rho, pval, nn, info)
        call expect(info == sk_err_too_few, 'neighbours: too few points in use')
    end subroutine test_neighbours

end program test_calib
