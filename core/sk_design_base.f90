!> What the experiment-design core (sk_design, sk_design_disc) shares: the
!> criterion codes, the argument codes of loc(1) of an argument error (named
!> in bindings/design.py, DESIGN_ARGUMENTS), the tolerances, the argument
!> checks of the selection entry points, and the small dense kernels on the
!> nobs x nobs blocks (explicit sizes and plain loops: they run once per
!> candidate and per update, where array temporaries would dominate).
module sk_design_base
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_small_sym, only: chol_small
    use sk_linalg, only: all_finite
    use sk_tree_check, only: fail
    implicit none
    private
    public :: design_check, chol_small, lower_solve, mul_tn, mul, sandwich_trace, chol_checked, fail
    public :: dpotrf, dpotri
    public :: cand_cross, cross_rows, blocks_of

    !> criteria (sk_design)
    integer(ip), parameter, public :: crit_d = 1, crit_a = 2, crit_task = 3
    !> argument codes of loc(1) (named in bindings/design.py, DESIGN_ARGUMENTS)
    integer(ip), parameter, public :: darg_jc = 1, darg_k = 2, darg_criterion = 3, darg_m0 = 4, &
        darg_jt = 5, darg_chosen = 6, darg_max_passes = 7, darg_f = 8, darg_jh = 9, darg_n0 = 10, &
        darg_nobs = 11
    !> ridge (scaled units) added to a singular m0 for the greedy start
    real(dp), parameter, public :: design_ridge = 1.0e-8_dp
    !> the running criterion is replaced by a direct evaluation beyond this relative difference
    real(dp), parameter, public :: design_drift = 1.0e-9_dp
    !> a Cholesky pivot^2 at or below this times its column's diagonal is a
    !> singular direction (1 - R^2 of the column on the ones before it)
    real(dp), parameter, public :: design_singular = 1.0e-12_dp
    !> a swap may not leave less than this fraction of the information of
    !> any direction (the pivots^2 of S2 = I - U_r^T M1^-1 U_r, sk_design)
    real(dp), parameter, public :: design_removal = 1.0e-8_dp
    !> an exchange is made when it improves the criterion by more than this (relative)
    real(dp), parameter, public :: design_improve = 1.0e-10_dp

    interface
        subroutine dpotrf(uplo, n, a, lda, info)
            import :: dp
            character(len=1), intent(in) :: uplo
            integer, intent(in) :: n, lda
            real(dp), intent(inout) :: a(lda, *)
            integer, intent(out) :: info
        end subroutine dpotrf
        subroutine dpotri(uplo, n, a, lda, info)
            import :: dp
            character(len=1), intent(in) :: uplo
            integer, intent(in) :: n, lda
            real(dp), intent(inout) :: a(lda, *)
            integer, intent(out) :: info
        end subroutine dpotri
    end interface

contains

    !> Checks shared by every entry point: jc finite (index: candidate),
    !> m0 finite and symmetric, jt finite (index: task row), the criterion
    !> code, task with at least one jt row, chosen[nch] in 1..ncand without
    !> repeats (index: position).
    subroutine design_check(jc, m0, jt, crit, chosen, info, loc)
        real(dp), intent(in) :: jc(:, :, :), m0(:, :), jt(:, :)
        integer(ip), intent(in) :: crit, chosen(:)
        integer(ip), intent(out) :: info, loc(2)
        integer :: c, i, npar, ncand
        logical, allocatable :: seen(:)
        info = sk_ok
        loc = 0
        npar = size(jc, 1)
        ncand = size(jc, 3)
        if (npar < 1 .or. size(jc, 2) < 1) call fail(sk_err_size, darg_jc, 0, info, loc)
        do c = 1, ncand
            if (.not. all_finite(jc(:, :, c))) then
                call fail(sk_err_nonfinite, darg_jc, c, info, loc)
                exit
            end if
        end do
        if (any(shape(m0) /= [npar, npar])) call fail(sk_err_size, darg_m0, 0, info, loc)
        if (info /= sk_ok) return
        if (.not. all_finite(m0)) call fail(sk_err_nonfinite, darg_m0, 0, info, loc)
        if (info == sk_ok) then
            if (maxval(abs(m0 - transpose(m0))) > 1.0e-12_dp * max(maxval(abs(m0)), tiny(1.0_dp))) &
                call fail(sk_err_argument, darg_m0, 0, info, loc)
        end if
        if (crit < crit_d .or. crit > crit_task) call fail(sk_err_argument, darg_criterion, 0, info, loc)
        if (size(jt, 1) /= npar) call fail(sk_err_size, darg_jt, 0, info, loc)
        if (crit == crit_task .and. size(jt, 2) < 1) call fail(sk_err_argument, darg_jt, 0, info, loc)
        do i = 1, size(jt, 2)
            if (.not. all_finite(jt(:, i))) then
                call fail(sk_err_nonfinite, darg_jt, i, info, loc)
                exit
            end if
        end do
        allocate(seen(ncand))
        seen = .false.
        do i = 1, size(chosen)
            if (chosen(i) < 1 .or. chosen(i) > ncand) then
                call fail(sk_err_argument, darg_chosen, i, info, loc)
            else if (seen(chosen(i))) then
                call fail(sk_err_argument, darg_chosen, i, info, loc)
            else
                seen(chosen(i)) = .true.
            end if
        end do
    end subroutine design_check

    !> x = l^-1 b for lower-triangular l[n,n] and b[n,n].
    pure subroutine lower_solve(n, l, b, x)
        integer, intent(in) :: n
        real(dp), intent(in) :: l(n, n), b(n, n)
        real(dp), intent(out) :: x(n, n)
        integer :: i, j, p
        real(dp) :: d
        do j = 1, n
            do i = 1, n
                d = b(i, j)
                do p = 1, i - 1
                    d = d - l(i, p) * x(p, j)
                end do
                x(i, j) = d / l(i, i)
            end do
        end do
    end subroutine lower_solve

    !> c = a^T b for a[n,n], b[n,n].
    pure subroutine mul_tn(n, a, b, c)
        integer, intent(in) :: n
        real(dp), intent(in) :: a(n, n), b(n, n)
        real(dp), intent(out) :: c(n, n)
        integer :: i, j
        do j = 1, n
            do i = 1, n
                c(i, j) = sum(a(:, i) * b(:, j))
            end do
        end do
    end subroutine mul_tn

    !> tr(l^-1 a l^-T) for lower-triangular l[n,n] and symmetric a[n,n].
    pure real(dp) function sandwich_trace(n, l, a) result(tr)
        integer, intent(in) :: n
        real(dp), intent(in) :: l(n, n), a(n, n)
        real(dp) :: x(n, n), y(n, n)
        integer :: i
        call lower_solve(n, l, a, x)
        call lower_solve(n, l, transpose(x), y)
        tr = 0.0_dp
        do i = 1, n
            tr = tr + y(i, i)
        end do
    end function sandwich_trace

    !> In-place Cholesky (lower) of the SPD a[n,n]; bad = first column whose
    !> pivot^2 is <= design_singular times its own diagonal, i.e. a column
    !> that the ones before it explain to 1 - R^2 <= design_singular (0 when
    !> all pass). Relative to the column, so that a design whose information
    !> is small next to all candidates' is not called singular for that.
    !> With absolute, the test is pivot^2 <= design_singular in the scaled
    !> units (all candidates' information has a unit diagonal): the stricter
    !> test the selection uses before it drops its ridge, since its low-rank
    !> updates need a well-conditioned start.
    subroutine chol_checked(a, bad, absolute)
        real(dp), intent(inout) :: a(:, :)
        integer, intent(out) :: bad
        logical, intent(in), optional :: absolute
        integer :: n, linfo, j
        real(dp) :: d(size(a, 1))
        n = size(a, 1)
        bad = 0
        if (n == 0) return
        do j = 1, n
            d(j) = a(j, j)
        end do
        if (present(absolute)) then
            if (absolute) d = 1.0_dp
        end if
        call dpotrf('L', n, a, n, linfo)
        do j = 1, merge(linfo - 1, n, linfo > 0)
            if (.not. a(j, j)**2 > design_singular * d(j)) then
                bad = j
                return
            end if
        end do
        if (linfo > 0) bad = linfo
    end subroutine chol_checked

    !> c = a b (trans = 'n') or a b^T (trans = 't') for a, b [n,n].
    pure subroutine mul(n, trans, a, b, c)
        integer, intent(in) :: n
        character, intent(in) :: trans
        real(dp), intent(in) :: a(n, n), b(n, n)
        real(dp), intent(out) :: c(n, n)
        integer :: j, p
        c = 0.0_dp
        do j = 1, n
            do p = 1, n
                if (trans == 't') then
                    c(:, j) = c(:, j) + a(:, p) * b(j, p)
                else
                    c(:, j) = c(:, j) + a(:, p) * b(p, j)
                end if
            end do
        end do
    end subroutine mul

    !> pr[nv, nobs*ncand] = vz^T J (vz[npar,nv] already scaled by s): the
    !> products of every candidate's rows with nv vectors (four partial sums
    !> per dot product: the loop is bound by memory, not by the add latency).
    subroutine cand_cross(jc, vz, pr)
        real(dp), intent(in) :: jc(:, :, :), vz(:, :)
        real(dp), intent(out) :: pr(:, :)
        call cross_rows(size(jc, 1), size(pr, 2), size(vz, 2), jc, vz, pr)
    end subroutine cand_cross

    subroutine cross_rows(n, ncol, nv, rows, vz, pr)
        integer, intent(in) :: n, ncol, nv
        real(dp), intent(in) :: rows(n, ncol), vz(n, nv)
        real(dp), intent(out) :: pr(nv, ncol)
        integer :: col, j, p, n4
        real(dp) :: s1, s2, s3, s4
        n4 = n - mod(n, 4)
        do col = 1, ncol
            do j = 1, nv
                s1 = 0.0_dp
                s2 = 0.0_dp
                s3 = 0.0_dp
                s4 = 0.0_dp
                do p = 1, n4, 4
                    s1 = s1 + vz(p, j) * rows(p, col)
                    s2 = s2 + vz(p + 1, j) * rows(p + 1, col)
                    s3 = s3 + vz(p + 2, j) * rows(p + 2, col)
                    s4 = s4 + vz(p + 3, j) * rows(p + 3, col)
                end do
                do p = n4 + 1, n
                    s1 = s1 + vz(p, j) * rows(p, col)
                end do
                pr(j, col) = (s1 + s2) + (s3 + s4)
            end do
        end do
    end subroutine cross_rows

    !> Candidate c's blocks P = J_c S V (p) and R = J_c S Z (r) from pr.
    pure subroutine blocks_of(pr, c, n, p, r)
        real(dp), intent(in) :: pr(:, :)
        integer, intent(in) :: c, n
        real(dp), intent(out) :: p(n, n), r(n, n)
        integer :: i, j
        do j = 1, n
            do i = 1, n
                p(i, j) = pr(j, (c - 1) * n + i)
            end do
        end do
        if (size(pr, 1) <= n) return
        do j = 1, n
            do i = 1, n
                r(i, j) = pr(n + j, (c - 1) * n + i)
            end do
        end do
    end subroutine blocks_of

end module sk_design_base
