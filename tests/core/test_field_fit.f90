!> Unit tests of sk_rotation, sk_linalg, sk_field_fit, sk_compliance and sk_beams on
!> small known systems; tolerances scaled by epsilon.
program test_field_fit
    use sk_testing, only: expect, finish
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: rot_exp, rot_log, skew, cross, det3
    use sk_linalg, only: inverse, eye
    use sk_field_fit
    use sk_compliance, only: normal_quantile, compliance_from_experiments
    use sk_beams
    implicit none (type, external)

    call test_rotations()
    call test_fit_exact_field()
    call test_degenerate()
    call test_quantile()
    call test_compliance_diagonal()
    call test_beams()
    call finish('field-fit core')

contains

    subroutine test_rotations()
        real(dp) :: w(3), r(3, 3)
        integer :: i
        real(dp), parameter :: angles(4) = [1.0e-9_dp, 1.0e-3_dp, 0.5_dp, 3.0_dp]
        do i = 1, size(angles)
            w = angles(i)*[0.6_dp, -0.48_dp, 0.64_dp]
            r = rot_exp(w)
            call expect(maxval(abs(matmul(transpose(r), r) - eye(3))) < 10*epsilon(1.0_dp), 'rot_exp orthogonal')
            call expect(abs(det3(r) - 1.0_dp) < 10*epsilon(1.0_dp), 'rot_exp det = 1')
            call expect(norm2(rot_log(r) - w) <= 20*epsilon(1.0_dp)*max(1.0_dp, norm2(w)), 'rot_log(rot_exp(w)) = w')
        end do
        call expect(all(abs(matmul(skew([1.0_dp, 2.0_dp, 3.0_dp]), [4.0_dp, 5.0_dp, 6.0_dp]) &
            - cross([1.0_dp, 2.0_dp, 3.0_dp], [4.0_dp, 5.0_dp, 6.0_dp])) < 1e-14_dp), 'skew * w = v x w')
    end subroutine test_rotations

    !> Noise-free rigid field: LIN is exact for the linear model, the exact
    !> method for the rotation; both return zero residuals.
    subroutine test_fit_exact_field()
        real(dp) :: p(3, 27), d(3, 27), p0(3), t(3), phi(3), cov(6, 6), res(3, 27), ssr, r(3, 3), w(3)
        logical :: used(27)
        integer(ip) :: nused, niter, info, m
        integer :: i, j, k, c
        c = 0
        do k = -1, 1
            do j = -1, 1
                do i = -1, 1
                    c = c + 1
                    p(:, c) = [real(i, dp), real(j, dp), real(k, dp)] + [5.0_dp, 1.0_dp, -2.0_dp]
                end do
            end do
        end do
        p0 = [4.0_dp, 0.0_dp, 0.0_dp]
        ! linear field d = t + phi x (p - p0)
        do c = 1, 27
            d(:, c) = [1e-3_dp, -2e-3_dp, 3e-3_dp] + cross([1e-4_dp, 2e-4_dp, -3e-4_dp], p(:, c) - p0)
        end do
        call fit_field(p, d, p0, method_lin, 0.0_dp, t, phi, cov, res, used, ssr, nused, niter, info)
        call expect(info == sk_ok, 'lin info')
        call expect(maxval(abs(t - [1e-3_dp, -2e-3_dp, 3e-3_dp])) < 1e-15_dp, 'lin t exact')
        call expect(maxval(abs(phi - [1e-4_dp, 2e-4_dp, -3e-4_dp])) < 1e-15_dp, 'lin phi exact')
        call expect(maxval(abs(res)) < 1e-15_dp, 'lin residuals zero')
        ! covariance at p0 with unit sigma: cov_t at centroid = I/n, moved by [c]x
        call expect(abs(cov(4, 4) - 1.0_dp/36.0_dp) < 1e-14_dp, 'cov phi = D^-1 (3x3x3 cube: D = 36 I)')
        ! a large rotation: the exact method recovers the rotation vector
        w = [0.05_dp, -0.08_dp, 0.03_dp]
        r = rot_exp(w)
        do c = 1, 27
            d(:, c) = matmul(r, p(:, c) - p0) - (p(:, c) - p0) + [0.1_dp, 0.2_dp, 0.3_dp]
        end do
        do m = method_svd_plus, method_exact
            call fit_field(p, d, p0, m, 0.0_dp, t, phi, cov, res, used, ssr, nused, niter, info)
            call expect(info == sk_ok, 'svd/exact info')
            call expect(maxval(abs(t - [0.1_dp, 0.2_dp, 0.3_dp])) < 1e-13_dp, 'svd/exact t')
            call expect(maxval(abs(res)) < 1e-13_dp .or. m /= method_exact, 'exact residuals zero')
        end do
        call expect(maxval(abs(phi - w)) < 1e-14_dp, 'exact phi = log R')
        ! trimming 10 % of 27 nodes drops 3
        call fit_field(p, d, p0, method_exact, 0.1_dp, t, phi, cov, res, used, ssr, nused, niter, info)
        call expect(info == sk_ok .and. nused == 24 .and. count(.not. used) == 3, 'trim drops nint(0.1 n) nodes')
    end subroutine test_fit_exact_field

    subroutine test_degenerate()
        real(dp) :: p(3, 5), d(3, 5), t(3), phi(3), cov(6, 6), res(3, 5), ssr
        logical :: used(5)
        integer(ip) :: nused, niter, info
        integer :: i
        do i = 1, 5
            p(:, i) = real(i, dp)*[1.0_dp, 2.0_dp, 3.0_dp]        ! collinear
        end do
        d = 0.0_dp
        call fit_field(p, d, [0.0_dp, 0.0_dp, 0.0_dp], method_lin, 0.0_dp, t, phi, cov, res, used, &
                       ssr, nused, niter, info)
        call expect(info == sk_err_degenerate, 'collinear nodes -> degenerate')
        p = 1.0_dp                                                   ! coincident
        call fit_field(p, d, [0.0_dp, 0.0_dp, 0.0_dp], method_svd_pm, 0.0_dp, t, phi, cov, res, used, &
                       ssr, nused, niter, info)
        call expect(info == sk_err_degenerate, 'coincident nodes -> degenerate')
        call fit_field(p(:, 1:2), d(:, 1:2), [0.0_dp, 0.0_dp, 0.0_dp], method_lin, 0.0_dp, t, phi, cov, &
                       res(:, 1:2), used(1:2), ssr, nused, niter, info)
        call expect(info == sk_err_size, 'two nodes -> size error')
        p(1, 1) = ieee_value(1.0_dp, ieee_positive_inf)
        call fit_field(p, d, [0.0_dp, 0.0_dp, 0.0_dp], method_lin, 0.0_dp, t, phi, cov, res, used, &
                       ssr, nused, niter, info)
        call expect(info == sk_err_nonfinite, 'Inf -> nonfinite')
        ! displacements whose squares overflow: the exact fit reports no
        ! convergence instead of returning NaN
        do i = 1, 5
            p(:, i) = [real(i, dp), real(mod(i*i, 5), dp), real(mod(i*3, 7), dp)]
        end do
        d = 1.0e200_dp*p(:, [2, 3, 4, 5, 1])
        call fit_field(p, d, [0.0_dp, 0.0_dp, 0.0_dp], method_exact, 0.0_dp, t, phi, cov, res, used, &
                       ssr, nused, niter, info)
        call expect(info == sk_err_noconv, 'exact fit of overflowing displacements -> no convergence')
    end subroutine test_degenerate

    subroutine test_quantile()
        call expect(abs(normal_quantile(0.99_dp) - 2.5758293035489004_dp) < 1e-12_dp, 'z(0.99)')
        call expect(abs(normal_quantile(0.95_dp) - 1.959963984540054_dp) < 1e-12_dp, 'z(0.95)')
        call expect(abs(normal_quantile(0.999999_dp) - 4.891638475698373_dp) < 1e-9_dp, 'z(1-1e-6)')
    end subroutine test_quantile

    !> Six axis loads: k is one column per experiment (eq. 3); the std of
    !> k(a,b) is sqrt(cov_b(a,a))/|W_b|.
    subroutine test_compliance_diagonal()
        real(dp) :: w(6, 6), x(6, 6), covx(6, 6, 6), k(6, 6), kstd(6, 6), ci(6, 6), ks(6, 6), asym, z
        logical :: sig(6, 6)
        integer(ip) :: sinfo, info
        integer :: j
        w = 0.0_dp
        covx = 0.0_dp
        do j = 1, 6
            w(j, j) = 10.0_dp**j
            x(:, j) = real(j, dp)*[1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp] + 1e-3_dp
            covx(:, :, j) = 4.0_dp*eye(6)
        end do
        call compliance_from_experiments(w, x, covx, 0.99_dp, .false., k, kstd, ci, sig, ks, asym, z, sinfo, info)
        call expect(info == sk_ok, 'compliance info')
        do j = 1, 6
            call expect(maxval(abs(k(:, j) - x(:, j)/w(j, j))) < 1e-15_dp*maxval(abs(x(:, j))), 'eq. 3 columns')
            call expect(maxval(abs(kstd(:, j) - 2.0_dp/w(j, j))) < 1e-15_dp, 'std = sd/|W|')
        end do
        w(:, 6) = w(:, 5)
        call compliance_from_experiments(w, x, covx, 0.99_dp, .false., k, kstd, ci, sig, ks, asym, z, sinfo, info)
        call expect(info == sk_err_singular, 'wrenches not spanning -> singular')
    end subroutine test_compliance_diagonal

    !> eq. 24 is the inverse of eq. 22 mirrored along x.
    subroutine test_beams()
        real(dp) :: props(6), c(6, 6), k(6, 6), kinv(6, 6)
        integer(ip) :: info
        call section_properties(section_rectangle, [0.01_dp, 0.01_dp], 0.266_dp, props, info)
        call expect(info == sk_ok, 'section info')
        ! square: J = 0.1406 a^4 (Saint-Venant)
        call expect(abs(props(4)/0.01_dp**4 - 0.140577_dp) < 1e-5_dp, 'square torsion constant')
        call cantilever_compliance(1.0_dp, 2e11_dp, 2e11_dp/2.532_dp, props, .false., c, info)
        call beam_stiffness_eq24(1.0_dp, 2e11_dp, 2e11_dp/2.532_dp, props, k, info)
        call inverse(k, kinv, info)
        c(2, 6) = -c(2, 6); c(6, 2) = -c(6, 2); c(3, 5) = -c(3, 5); c(5, 3) = -c(5, 3)
        call expect(maxval(abs(kinv - c))/maxval(abs(c)) < 1e-12_dp, 'inv(eq. 24) = mirrored eq. 22')
    end subroutine test_beams

end program test_field_fit
