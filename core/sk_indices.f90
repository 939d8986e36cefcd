!> Stiffness performance indices kappa_t, kappa_r of Taghvaeipour et al.
!> 2010 s5 (eqs. 31-39), made independent of the unit of length.
!>
!> K = [[K11, K12], [K12^T, K22]] (eq. 31). The paper splits
!> f = K11 s + K12 theta and n = K12^T s + K22 theta (eqs. 32-33), maps
!> s and theta through the eigenvectors S_s, S_theta (of K11^T K11,
!> K12^T K12) and H_s, H_theta (of K12 K12^T, K22^T K22) (eqs. 34-36),
!> builds G_f = [K11 S_s, K12 S_theta] and G_n = [K12^T H_s, K22 H_theta]
!> (eq. 38) and takes kappa = sqrt(mean of the three non-zero eigenvalues
!> of G^T G) (eq. 39).
!>
!> As printed, G_f mixes N/m with N and G_n N with N m, so the numbers
!> change with the unit of length. With a characteristic length l
!> (lscale, in the same unit as K) we nondimensionalise the translation,
!> s = l s~, and divide the moment equation by l, which gives
!>   G_f = [l K11 S_s, K12 S_theta],  G_n = [K12^T H_s, (K22/l) H_theta],
!> both in N, and kappa_t, kappa_r in N for any unit of length.
!> lscale = 1 (in the caller's unit) is the paper's literal formula.
module sk_indices
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_small_sym, only: jacobi_eig
    implicit none
    private
    public :: stiffness_indices

contains

    !> kappa_t, kappa_r and the three eigenvalues each (ascending) of
    !> G_f^T G_f and G_n^T G_n for one 6x6 stiffness k.
    pure subroutine stiffness_indices(k, lscale, kt, kr, lamf, lamn, info)
        real(dp), intent(in) :: k(6, 6), lscale
        real(dp), intent(out) :: kt, kr, lamf(3), lamn(3)
        integer(ip), intent(out) :: info
        real(dp) :: k11(3, 3), k12(3, 3), k22(3, 3), ss(3, 3), st(3, 3), hs(3, 3), ht(3, 3)
        real(dp) :: gf(3, 6), gn(3, 6), w(3), v(3, 3)
        kt = 0.0_dp; kr = 0.0_dp; lamf = 0.0_dp; lamn = 0.0_dp
        if (.not. (lscale > 0.0_dp)) then
            info = sk_err_argument
            return
        end if
        if (.not. all(abs(k) <= huge(1.0_dp))) then
            info = sk_err_nonfinite
            return
        end if
        k11 = lscale*k(1:3, 1:3)
        k12 = k(1:3, 4:6)
        k22 = k(4:6, 4:6)/lscale
        ! eq. 34: orthogonal matrices of eigenvectors of K_beta^T K_beta
        call jacobi_eig(3, matmul(transpose(k11), k11), w, ss)
        call jacobi_eig(3, matmul(transpose(k12), k12), w, st)
        call jacobi_eig(3, matmul(k12, transpose(k12)), w, hs)
        call jacobi_eig(3, matmul(transpose(k22), k22), w, ht)
        ! eq. 38
        gf(:, 1:3) = matmul(k11, ss)
        gf(:, 4:6) = matmul(k12, st)
        gn(:, 1:3) = matmul(transpose(k12), hs)
        gn(:, 4:6) = matmul(k22, ht)
        ! eq. 39: the non-zero eigenvalues of G^T G are those of G G^T (3x3)
        call jacobi_eig(3, matmul(gf, transpose(gf)), lamf, v)
        call jacobi_eig(3, matmul(gn, transpose(gn)), lamn, v)
        lamf = max(lamf, 0.0_dp)
        lamn = max(lamn, 0.0_dp)
        kt = sqrt(sum(lamf)/3.0_dp)
        kr = sqrt(sum(lamn)/3.0_dp)
        info = sk_ok
        if (.not. (abs(kt) <= huge(1.0_dp) .and. abs(kr) <= huge(1.0_dp))) info = sk_err_overflow
    end subroutine stiffness_indices

end module sk_indices
