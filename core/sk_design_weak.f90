!> Why a parameter stays weak in a chosen design (the report of stiffkit
!> plan, calib/plan_report.py:weak_parameters). For the information matrix
!> M = m0 + sum over the chosen c of J_c^T J_c (the caller's units):
!>   info[npar]  its diagonal (1/info_j is the variance parameter j would
!>               have if the others were known: uncorrelated),
!>   pool[npar]  the diagonal over ALL candidates, m0 + sum over c of
!>               J_c^T J_c (1/pool_j = s_j^2: the column scales of sk_design,
!>               so that sqrt(info_j / pool_j) is the norm of column j of the
!>               scaled Jacobian over the chosen rows),
!>   task[npar]  the task influence sum over the task rows of jt(j, r)^2,
!>   ev[npar]    the eigenvalues, ascending, of the unit-diagonal information
!>               R = D^-1/2 M D^-1/2 (D = diag M; a column without
!>               information keeps R_jj = 0: its own null direction),
!>   nnull       0 when M is regular by the Cholesky test design_covariance
!>               uses (sk_design_base%chol_checked, relative to the column);
!>               else the eigenvalues of R at or below design_singular, at
!>               least 1,
!>   proj[npar,npar]  the projector V0 V0^T onto the null space of R (V0:
!>               the eigenvectors of the nnull smallest eigenvalues; 0 when
!>               nnull = 0): proj(j, j) > 0 when parameter j is not
!>               identifiable, proj(j, k) its share with parameter k.
module sk_design_weak
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: sym_eig
    use sk_design_base, only: chol_checked, design_singular
    implicit none
    private
    public :: design_weakness

contains

    !> The numbers above for the 1-based chosen[nch] of jc[npar,nobs,ncand],
    !> with prior information m0[npar,npar] and task rows jt[npar,nt];
    !> info = sk_err_lapack if the eigen-decomposition fails.
    subroutine design_weakness(jc, m0, jt, chosen, info_d, pool, task, ev, nnull, proj, info)
        real(dp), intent(in) :: jc(:, :, :), m0(:, :), jt(:, :)
        integer(ip), intent(in) :: chosen(:)
        real(dp), intent(out) :: info_d(:), pool(:), task(:), ev(:), proj(:, :)
        integer(ip), intent(out) :: nnull, info
        real(dp), allocatable :: m(:, :), r(:, :), v(:, :), d(:)
        integer :: i, j, n, bad
        n = size(jc, 1)
        allocate(m(n, n), r(n, n), v(n, n), d(n))
        m = m0
        do i = 1, size(chosen)
            m = m + matmul(jc(:, :, chosen(i)), transpose(jc(:, :, chosen(i))))
        end do
        do j = 1, n
            info_d(j) = m(j, j)
            pool(j) = m0(j, j) + sum(jc(j, :, :)**2)
            task(j) = sum(jt(j, :)**2)
            d(j) = 0.0_dp
            if (m(j, j) > 0.0_dp) d(j) = 1.0_dp / sqrt(m(j, j))
        end do
        do j = 1, n
            r(:, j) = d * m(:, j) * d(j)
        end do
        proj = 0.0_dp
        nnull = 0
        call sym_eig(r, ev, v, info)
        if (info /= sk_ok) return
        m = r
        call chol_checked(m, bad)
        if (bad == 0) return
        nnull = max(1_ip, int(count(ev <= design_singular), ip))
        proj = matmul(v(:, 1:nnull), transpose(v(:, 1:nnull)))
    end subroutine design_weakness

end module sk_design_weak
