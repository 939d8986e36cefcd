!> Unit tests of sk_springs and sk_indices on small known systems;
!> tolerances scaled by epsilon.
program test_springs
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: skew
    use sk_linalg, only: eye
    use sk_spatial, only: twist_transfer, compliance_move
    use sk_springs
    use sk_small_sym, only: jacobi_eig, sym_eigvals_small, psd_defect
    use sk_indices, only: stiffness_indices
    implicit none (type, external)

    call test_jacobi()
    call test_transfer()
    call test_switch_rank()
    call test_tree_series_parallel()
    call test_indices()
    call test_psd_defect()
    call finish('springs core')

contains

    !> A = Q diag(1e-8, 1, 2, 3, 1e4, 5e6) Q^T: eigenpairs to round-off.
    subroutine test_jacobi()
        real(dp) :: q(6, 6), a(6, 6), w(6), v(6, 6), lam(6)
        integer :: i, j
        logical :: ok
        lam = [1.0e-8_dp, 1.0_dp, 2.0_dp, 3.0_dp, 1.0e4_dp, 5.0e6_dp]
        q = eye(6)
        do i = 1, 6
            q(:, i) = q(:, i) + 0.1_dp*[(sin(real(i*j, dp)), j = 1, 6)]
        end do
        call gram_schmidt(q)
        a = matmul(q, matmul(diag(lam), transpose(q)))
        call jacobi_eig(6, a, w, v)
        call expect(all(abs(w - lam) <= 50*epsilon(1.0_dp)*lam(6)), 'jacobi eigenvalues')
        call expect(maxval(abs(matmul(transpose(v), v) - eye(6))) < 50*epsilon(1.0_dp), 'jacobi orthogonal')
        call expect(maxval(abs(matmul(a, v) - matmul(v, diag(w)))) < 100*epsilon(1.0_dp)*lam(6), 'A v = v w')
        call sym_eigvals_small(6, a, w, ok)
        call sort(w)
        call expect(ok .and. all(abs(w - lam) <= 100*epsilon(1.0_dp)*lam(6)), 'tridiagonal QL eigenvalues')
    end subroutine test_jacobi

    !> congruence_transfer = T C T^T (compliance_move) and W^T K W with W = T(-r).
    subroutine test_transfer()
        real(dp) :: c(6, 6), m(6, 6), r(3), t(6, 6)
        integer :: i, j
        do j = 1, 6
            do i = 1, 6
                c(i, j) = 1.0_dp/real(i + j - 1, dp)      ! Hilbert: symmetric
            end do
        end do
        r = [0.3_dp, -1.2_dp, 0.7_dp]
        m = c
        call congruence_transfer(r, m, .false.)
        call expect(maxval(abs(m - compliance_move(c, r))) < 10*epsilon(1.0_dp), 'compliance transfer = T C T^T')
        m = c
        call congruence_transfer(r, m, .true.)
        t = twist_transfer(-r)
        call expect(maxval(abs(m - matmul(transpose(t), matmul(c, t)))) < 10*epsilon(1.0_dp), 'stiffness transfer = W^T K W')
    end subroutine test_transfer

    !> C = diag(1,2,0,4,5,6): one rigid direction (e3), K = C^+ elsewhere.
    subroutine test_switch_rank()
        type(gspring) :: s
        s%c = diag([1.0_dp, 2.0_dp, 0.0_dp, 4.0_dp, 5.0_dp, 6.0_dp])
        call c_to_k(s, 1.0e-9_dp, .true.)
        call expect(s%ng == 1 .and. s%nf == 0, 'one rigid wrench')
        call expect(abs(s%gam(3, 3) - 1.0_dp) < 10*epsilon(1.0_dp), 'rigid wrench is e3')
        call expect(maxval(abs(s%k - diag([1.0_dp, 0.5_dp, 0.0_dp, 0.25_dp, 0.2_dp, 1.0_dp/6]))) < 10*epsilon(1.0_dp), &
                    'K = pseudo-inverse')
        call k_to_c(s, 1.0e-9_dp, .false.)
        call expect(s%nf == 0 .and. s%ng == 1, 'back: e3 stays rigid, not free')
        call expect(maxval(abs(s%c - diag([1.0_dp, 2.0_dp, 0.0_dp, 4.0_dp, 5.0_dp, 6.0_dp]))) < 10*epsilon(1.0_dp), 'C restored')
    end subroutine test_switch_rank

    !> Two co-located springs: series sums compliances, parallel sums stiffnesses.
    subroutine test_tree_series_parallel()
        integer(ip) :: prog(2, 3), lkind(2), jt(1), jp(1), nfree(1), nrigid(1), info
        real(dp) :: lmat(6, 6, 2), lrot(3, 3, 2, 1), lpos(3, 2, 1), jc(1), ja(3, 1, 1), jpt(3, 1, 1)
        real(dp) :: tp(3, 1), tr(3, 3, 1), c(6, 6, 1), k(6, 6, 1), fr(6, 6, 1), rg(6, 6, 1), ratio(1)
        real(dp) :: c0(6, 6)
        c0 = diag([1.0e-6_dp, 2.0e-6_dp, 3.0e-6_dp, 1.0e-3_dp, 2.0e-3_dp, 3.0e-3_dp])
        lmat(:, :, 1) = c0
        lmat(:, :, 2) = 3*c0
        lkind = leaf_compliance
        lrot(:, :, 1, 1) = eye(3)
        lrot(:, :, 2, 1) = eye(3)
        lpos = 0.5_dp
        jt = joint_revolute; jp = 0; jc = 0; ja = 1; jpt = 0
        tp(:, 1) = 0.5_dp
        tr(:, :, 1) = eye(3)
        prog = reshape([op_spring, 1, op_spring, 2, op_series, 2], [2, 3])
        call spring_tree_batch(prog, lkind, lmat, lrot, lpos, jt, jc, jp, ja, jpt, tp, tr, 1.0_dp, &
                               1.0e-9_dp, c, k, fr, nfree, rg, nrigid, ratio, info)
        call expect(info == sk_ok, 'tree info')
        call expect(maxval(abs(c(:, :, 1) - 4*c0)) < 10*epsilon(1.0_dp)*maxval(c0), 'series = summed compliance')
        prog(:, 3) = [op_parallel, 2]
        call spring_tree_batch(prog, lkind, lmat, lrot, lpos, jt, jc, jp, ja, jpt, tp, tr, 1.0_dp, &
                               1.0e-9_dp, c, k, fr, nfree, rg, nrigid, ratio, info)
        call expect(maxval(abs(c(:, :, 1) - 0.75_dp*c0)) < 100*epsilon(1.0_dp)*maxval(c0), 'parallel: 1/(1/c + 1/3c)')
        prog(:, 3) = [op_parallel, 3]
        call spring_tree_batch(prog, lkind, lmat, lrot, lpos, jt, jc, jp, ja, jpt, tp, tr, 1.0_dp, &
                               1.0e-9_dp, c, k, fr, nfree, rg, nrigid, ratio, info)
        call expect(info == sk_err_argument, 'malformed program rejected')
        ! an indefinite leaf is no spring: refused, not turned into a free direction
        prog(:, 3) = [op_series, 2]
        lmat(1, 2, 2) = 10*sqrt(lmat(1, 1, 2)*lmat(2, 2, 2))
        lmat(2, 1, 2) = lmat(1, 2, 2)
        call spring_tree_batch(prog, lkind, lmat, lrot, lpos, jt, jc, jp, ja, jpt, tp, tr, 1.0_dp, &
                               1.0e-9_dp, c, k, fr, nfree, rg, nrigid, ratio, info)
        call expect(info == sk_err_indefinite, 'indefinite leaf rejected')
        lmat(:, :, 2) = 3*c0
        prog = reshape([op_spring, 1, op_joint, 1, op_series, 2], [2, 3])
        jc = -1.0e-6_dp
        call spring_tree_batch(prog, lkind, lmat, lrot, lpos, jt, jc, jp, ja, jpt, tp, tr, 1.0_dp, &
                               1.0e-9_dp, c, k, fr, nfree, rg, nrigid, ratio, info)
        call expect(info == sk_err_indefinite, 'negative joint compliance rejected')
    end subroutine test_tree_series_parallel

    !> psd_defect: 0 for PSD matrices whatever the units of their rows,
    !> negative for indefinite ones, -1 for a negative diagonal.
    subroutine test_psd_defect()
        real(dp) :: a(6, 6), d(6)
        d = [1.0e-9_dp, 1.0e-8_dp, 1.0e-8_dp, 1.0e-4_dp, 1.0e-2_dp, 1.0e2_dp]
        a = diag(d)
        a(2, 6) = 0.8_dp*sqrt(d(2)*d(6)); a(6, 2) = a(2, 6)
        call expect(psd_defect(6, a) == 0.0_dp, 'psd: graded beam-like matrix')
        a(2, 6) = 1.2_dp*sqrt(d(2)*d(6)); a(6, 2) = a(2, 6)
        call expect(abs(psd_defect(6, a) + 0.2_dp) < 1e-12_dp, 'psd: coupling beyond the diagonal')
        a = diag(d)
        a(3, 3) = -d(3)
        call expect(psd_defect(6, a) == -1.0_dp, 'psd: negative diagonal')
        a = 0
        a(1, 2) = 1; a(2, 1) = 1
        call expect(psd_defect(6, a) == -1.0_dp, 'psd: coupling of zero rows')
        call expect(psd_defect(6, eye(6)*0.0_dp) == 0.0_dp, 'psd: zero matrix (rigid)')
    end subroutine test_psd_defect

    subroutine test_indices()
        real(dp) :: k(6, 6), kt, kr, lf(3), ln(3), l
        integer(ip) :: info
        integer :: i, j
        do j = 1, 6
            do i = 1, 6
                k(i, j) = 1.0_dp/real(i + j - 1, dp)
            end do
        end do
        k = k + eye(6)
        l = 0.4_dp
        call stiffness_indices(k, l, kt, kr, lf, ln, info)
        call expect(abs(kt**2 - (l**2*sum(k(1:3, 1:3)**2) + sum(k(1:3, 4:6)**2))/3) < 1e-13_dp*kt**2, 'kappa_t closed form')
        call expect(abs(kr**2 - (sum(k(1:3, 4:6)**2) + sum(k(4:6, 4:6)**2)/l**2)/3) < 1e-13_dp*kr**2, 'kappa_r closed form')
    end subroutine test_indices

    pure function diag(v) result(a)
        real(dp), intent(in) :: v(:)
        real(dp) :: a(size(v), size(v))
        integer :: i
        a = 0.0_dp
        do i = 1, size(v)
            a(i, i) = v(i)
        end do
    end function diag

    subroutine sort(w)
        real(dp), intent(inout) :: w(:)
        integer :: i, j
        real(dp) :: t
        do i = 2, size(w)
            t = w(i)
            j = i - 1
            do while (j >= 1)
                if (w(j) <= t) exit
                w(j + 1) = w(j)
                j = j - 1
            end do
            w(j + 1) = t
        end do
    end subroutine sort

    subroutine gram_schmidt(q)
        real(dp), intent(inout) :: q(:, :)
        integer :: i, j
        do i = 1, size(q, 2)
            do j = 1, i - 1
                q(:, i) = q(:, i) - dot_product(q(:, j), q(:, i))*q(:, j)
            end do
            q(:, i) = q(:, i)/norm2(q(:, i))
        end do
    end subroutine gram_schmidt

end program test_springs
