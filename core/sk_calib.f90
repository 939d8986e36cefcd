!> Elastostatic calibration and model diagnosis (klimchik et al., s2-3):
!> weighted least squares by a rank-revealing SVD of the column-scaled
!> observation matrix (eqs. 7-9, 15-20) with the partition of the
!> parameters into identifiable (G1), non-identifiable (G2) and
!> semi-identifiable (G3) groups (M4a), greedy selection of an
!> independent subset (M5b), relations between coupled parameters (eq. 21),
!> score (Lagrange-multiplier) tests of candidate columns projected off the
!> model's column space, and the multiplicity-corrected test of the best
!> candidate (the null distribution of the smallest p-value over all
!> candidates, by Monte Carlo on their projected spaces). The tail
!> probabilities are sk_tails'; the neighbour correlation of a residual is
!> sk_neighbours'.
!>
!> The observation matrix and data are weighted by the caller (rows divided
!> by the measurement standard deviation), so unit-variance noise is assumed.
module sk_calib
    use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: svd, all_finite, matmul_tn, sym_eig
    use sk_tails, only: chi2_logsf, f_logsf
    implicit none
    private
    public :: wls_svd, score_tests, select_independent, null_relations, max_score_test

    integer, parameter, public :: group_identifiable = 1
    integer, parameter, public :: group_non_identifiable = 2
    integer, parameter, public :: group_semi_identifiable = 3

contains

    !> Column norms of a[n,p]; zero (or negligible) columns get norm 1 and
    !> zero(k) = .true.
    pure subroutine column_scales(a, d, zero)
        real(dp), intent(in) :: a(:, :)
        real(dp), intent(out) :: d(:)
        logical, intent(out) :: zero(:)
        integer :: k
        do k = 1, size(a, 2)
            d(k) = norm2(a(:, k))
        end do
        zero = d <= 1.0e-14_dp*max(maxval(d, mask=d == d), tiny(1.0_dp))
        where (zero) d = 1.0_dp
    end subroutine column_scales

    !> SVD of a[n,p] with its columns scaled to unit norm (zero columns kept
    !> at zero): as = a diag(d)^-1 = u diag(s) vt; rank counts the singular
    !> values above rcond * s(1). Shared by the fit and the score tests.
    subroutine scaled_svd(a, rcond, d, zero, as, u, s, vt, rank, info)
        real(dp), intent(in) :: a(:, :), rcond
        real(dp), intent(out) :: d(:), as(:, :), u(:, :), s(:), vt(:, :)
        logical, intent(out) :: zero(:)
        integer(ip), intent(out) :: rank, info
        integer :: k
        call column_scales(a, d, zero)
        do k = 1, size(a, 2)
            as(:, k) = merge(0.0_dp, a(:, k)/d(k), zero(k))
        end do
        rank = 0
        call svd(as, u, s, vt, info)
        if (info /= sk_ok) return
        rank = count(s > rcond*s(1) .and. s > 0.0_dp)
    end subroutine scaled_svd

    !> Weighted least squares a theta ~ y (a[n,p], n >= p, rows already
    !> weighted). The columns are scaled to unit norm, a = U S V^T; singular
    !> values below rcond*s(1) count as zero (rank r). theta is the
    !> minimum-norm solution in the scaled parameters (eq. 19); stdu(k) the
    !> standard deviation of theta(k) for unit noise (eqs. 8; restricted to
    !> the identifiable subspace for G3); s[p] and v[p,p] the singular
    !> values and right vectors of the scaled problem; group(k) by M4a with
    !> tolerance gtol on the rows of V: 1 identifiable (row of the null part
    !> zero), 2 non-identifiable (row of the range part zero), 3 semi.
    !> res = y - a theta.
    subroutine wls_svd(a, y, rcond, gtol, theta, stdu, s, v, rank, group, res, info)
        real(dp), intent(in) :: a(:, :), y(:), rcond, gtol
        real(dp), intent(out) :: theta(:), stdu(:), s(:), v(:, :), res(:)
        integer(ip), intent(out) :: rank, group(:), info
        real(dp), allocatable :: as(:, :), u(:, :), vt(:, :), d(:), uty(:)
        logical, allocatable :: zero(:)
        integer :: n, p, k, i
        n = size(a, 1)
        p = size(a, 2)
        theta = 0.0_dp
        stdu = 0.0_dp
        s = 0.0_dp
        v = 0.0_dp
        res = 0.0_dp
        group = 0
        rank = 0
        if (p < 1 .or. size(y) /= n .or. size(theta) /= p .or. size(s) /= p) then
            info = sk_err_size
            return
        end if
        if (n < p) then
            info = sk_err_too_few
            return
        end if
        if (.not. (all_finite(a) .and. all_finite(y))) then
            info = sk_err_nonfinite
            return
        end if
        allocate(d(p), zero(p), as(n, p), u(n, p), vt(p, p), uty(p))
        call scaled_svd(a, rcond, d, zero, as, u, s, vt, rank, info)
        if (info /= sk_ok) return
        v = transpose(vt)
        uty = matmul(transpose(u(:, 1:rank)), y)
        do i = 1, rank
            theta = theta + v(:, i)*(uty(i)/s(i))                 ! eq. 19
        end do
        do k = 1, p
            stdu(k) = sqrt(sum((v(k, 1:rank)/s(1:rank))**2))
            if (norm2(v(k, rank + 1:p)) < gtol .and. .not. zero(k)) then
                group(k) = group_identifiable
            else if (norm2(v(k, 1:rank)) < gtol .or. zero(k)) then
                group(k) = group_non_identifiable
            else
                group(k) = group_semi_identifiable
            end if
        end do
        res = y - matmul(as, theta)
        theta = theta/d
        stdu = stdu/d
        info = sk_ok
    end subroutine wls_svd

    !> Checks shared by the score tests: sizes, candidate blocks, finite
    !> values. info sk_ok when the inputs are consistent.
    subroutine check_candidates(a, z, cstart, info)
        real(dp), intent(in) :: a(:, :), z(:, :)
        integer(ip), intent(in) :: cstart(:)
        integer(ip), intent(out) :: info
        integer :: c
        info = sk_ok
        if (size(z, 1) /= size(a, 1) .or. size(a, 1) < size(a, 2) .or. size(cstart) < 1) then
            info = sk_err_size
            return
        end if
        do c = 1, size(cstart) - 1
            if (cstart(c) < 1 .or. cstart(c + 1) < cstart(c) .or. cstart(c + 1) - 1 > size(z, 2)) then
                info = sk_err_argument
                return
            end if
        end do
        if (.not. (all_finite(a) .and. all_finite(z))) info = sk_err_nonfinite
    end subroutine check_candidates

    !> The model's column space for the score tests: u(:, 1:rank) from the
    !> scaled SVD of a (rank by rcond as in wls_svd), and zref, the norm
    !> below which a candidate column is round-off (1e-13 of the largest
    !> column of a and z).
    subroutine model_space(a, z, rcond, u, rank, zref, info)
        real(dp), intent(in) :: a(:, :), z(:, :), rcond
        real(dp), allocatable, intent(out) :: u(:, :)
        integer(ip), intent(out) :: rank, info
        real(dp), intent(out) :: zref
        real(dp), allocatable :: as(:, :), s(:), vt(:, :), d(:)
        logical, allocatable :: zero(:)
        integer :: n, p, k
        n = size(a, 1)
        p = size(a, 2)
        allocate(d(p), zero(p), as(n, p), u(n, p), s(p), vt(p, p))
        zref = 0.0_dp
        do k = 1, size(z, 2)
            zref = max(zref, norm2(z(:, k)))
        end do
        do k = 1, p
            zref = max(zref, norm2(a(:, k)))
        end do
        zref = 1.0e-13_dp*zref
        call scaled_svd(a, rcond, d, zero, as, u, s, vt, rank, info)
    end subroutine model_space

    !> Orthonormal basis q(:, 1:dof) of the space that the candidate columns
    !> zblock[n,nc] (each scaled to unit norm; those not longer than zref are
    !> round-off and count as zero) span off the model's column space
    !> u(:, 1:rank); dof counts the singular values above ztol.
    subroutine candidate_space(u, rank, zblock, zref, ztol, q, dof, info)
        real(dp), intent(in) :: u(:, :), zblock(:, :), zref, ztol
        integer(ip), intent(in) :: rank
        real(dp), allocatable, intent(out) :: q(:, :)
        integer(ip), intent(out) :: dof, info
        real(dp), allocatable :: zc(:, :), uz(:, :), sz(:), vz(:, :)
        integer :: n, nc, k
        n = size(zblock, 1)
        nc = size(zblock, 2)
        allocate(zc(n, nc), uz(n, min(n, nc)), sz(min(n, nc)), vz(min(n, nc), nc))
        do k = 1, nc
            ! a column at round-off level (relative to the largest column of
            ! the model and the candidates) carries no information: zero
            if (norm2(zblock(:, k)) > zref) then
                zc(:, k) = zblock(:, k)/norm2(zblock(:, k))
            else
                zc(:, k) = 0.0_dp
            end if
        end do
        if (rank > 0) zc = zc - matmul(u(:, 1:rank), matmul(transpose(u(:, 1:rank)), zc))
        call svd(zc, uz, sz, vz, info)
        dof = 0
        if (info /= sk_ok) return
        dof = count(sz > ztol)
        q = uz(:, 1:dof)
    end subroutine candidate_space

    !> Score (Lagrange-multiplier) tests of ncand candidates against the
    !> model a[n,p] (weighted) and its weighted residual r[n]. Candidate c
    !> owns the columns z(:, cstart(c):cstart(c+1)-1). Its columns, scaled
    !> to unit norm (those below 1e-13 of the largest column of a and z are
    !> round-off and count as zero), are projected off the column space of a (rank by rcond
    !> as in wls_svd); dof(c) is the rank of what is left (singular values
    !> above ztol), stat(c) = |P r|^2 with P the projector on that space,
    !> chi-square with dof(c) degrees of freedom under the model for unit
    !> noise; pr(:, c) = P r, the part of the residual the candidate explains.
    subroutine score_tests(a, r, z, cstart, rcond, ztol, stat, dof, pr, info)
        real(dp), intent(in) :: a(:, :), r(:), z(:, :), rcond, ztol
        integer(ip), intent(in) :: cstart(:)
        real(dp), intent(out) :: stat(:), pr(:, :)
        integer(ip), intent(out) :: dof(:), info
        real(dp), allocatable :: u(:, :), q(:, :), coef(:)
        real(dp) :: zref
        integer(ip) :: rank
        integer :: n, ncand, c, k0, nc
        n = size(a, 1)
        ncand = size(cstart) - 1
        stat = 0.0_dp
        pr = 0.0_dp
        dof = 0
        if (size(r) /= n .or. size(stat) /= ncand .or. size(dof) /= ncand .or. any(shape(pr) /= [n, ncand])) then
            info = sk_err_size
            return
        end if
        call check_candidates(a, z, cstart, info)
        if (info /= sk_ok) return
        if (.not. all_finite(r)) then
            info = sk_err_nonfinite
            return
        end if
        call model_space(a, z, rcond, u, rank, zref, info)
        if (info /= sk_ok) return
        do c = 1, ncand
            k0 = cstart(c)
            nc = cstart(c + 1) - k0
            if (nc < 1) cycle
            call candidate_space(u, rank, z(:, k0:k0 + nc - 1), zref, ztol, q, dof(c), info)
            if (info /= sk_ok) return
            if (dof(c) > 0) then
                coef = matmul(transpose(q), r)
                pr(:, c) = matmul(q, coef)
                stat(c) = sum(coef**2)
            end if
        end do
        info = sk_ok
    end subroutine score_tests

    !> Multiplicity-corrected test of the best candidate (max-score test).
    !> lobs is the smallest log p-value over the candidates of score_tests
    !> (same a, z, cstart, rcond, ztol); p is the probability, under the
    !> model with unit Gaussian noise, that some candidate reaches a log
    !> p-value <= lobs, i.e. the p-value of the best candidate corrected for
    !> having looked at all of them, with their correlations (nested
    !> templates, coupled springs) taken into account. Without pure error
    !> (dpe = 0) each candidate's p-value is chi-square(dof_c); with dpe > 0
    !> it is F(dof_c, dpe) against an independent pure-error variance.
    !>
    !> Under the model the residual's part in candidate c's projected space
    !> Q_c is Q_c^T e with e ~ N(0, I_n): the stacked s = Q^T e is Gaussian
    !> with covariance G = Q^T Q (identity blocks, the correlations between
    !> candidates off the diagonal), drawn as s = V sqrt(Lambda) g from the
    !> eigen-decomposition of G (a cost per draw independent of n). nsim
    !> draws give the null distribution of min_c log p_c exactly up to Monte
    !> Carlo error; each candidate's statistic is compared with its critical
    !> value at lobs (found once by bisection). p = (1 + #hits) / (1 + nsim).
    !> The draws are reproducible (seed); the caller's random state is kept.
    subroutine max_score_test(a, z, cstart, rcond, ztol, lobs, dpe, nsim, seed, p, info)
        real(dp), intent(in) :: a(:, :), z(:, :), rcond, ztol, lobs
        integer(ip), intent(in) :: cstart(:), dpe, nsim, seed
        real(dp), intent(out) :: p
        integer(ip), intent(out) :: info
        integer, parameter :: nblk = 64
        real(dp), allocatable :: u(:, :), q(:, :), qall(:, :), crit(:), e(:, :), sb(:, :), g(:), gram(:, :), &
            lam(:), vec(:, :), lt(:, :)
        integer(ip), allocatable :: dof(:), off(:)
        integer, allocatable :: state(:), myseed(:)
        real(dp) :: zref, s2, st
        integer(ip) :: rank, dtot
        integer :: n, ncand, c, k0, nc, hits, done, nb, j, ns, i
        logical :: hit
        p = 1.0_dp
        n = size(a, 1)
        ncand = size(cstart) - 1
        if (nsim < 1 .or. dpe < 0) then
            info = sk_err_argument
            return
        end if
        call check_candidates(a, z, cstart, info)
        if (info /= sk_ok) return
        if (ieee_is_nan(lobs)) then
            info = sk_err_nonfinite
            return
        end if
        call model_space(a, z, rcond, u, rank, zref, info)
        if (info /= sk_ok) return
        allocate(dof(ncand), off(ncand), crit(ncand), qall(n, size(z, 2)))
        dtot = 0
        dof = 0
        do c = 1, ncand
            off(c) = dtot
            k0 = cstart(c)
            nc = cstart(c + 1) - k0
            if (nc < 1) cycle
            call candidate_space(u, rank, z(:, k0:k0 + nc - 1), zref, ztol, q, dof(c), info)
            if (info /= sk_ok) return
            if (dof(c) > 0) then
                qall(:, dtot + 1:dtot + dof(c)) = q
                dtot = dtot + dof(c)
            end if
        end do
        info = sk_ok
        if (dtot == 0 .or. lobs >= 0.0_dp) return
        ! critical value of each candidate's statistic (chi-square, or F times dof)
        do c = 1, ncand
            if (dof(c) > 0) crit(c) = critical_value(real(dof(c), dp), real(dpe, dp), lobs)
        end do
        ! s = Q^T e ~ N(0, G): the square root L = V sqrt(max(Lambda, 0)) of G
        allocate(gram(dtot, dtot), lam(dtot), vec(dtot, dtot), lt(dtot, dtot))
        call matmul_tn(qall(:, 1:dtot), qall(:, 1:dtot), gram, info)
        if (info /= sk_ok) return
        call sym_eig(gram, lam, vec, info)
        if (info /= sk_ok) return
        do i = 1, dtot
            vec(:, i) = vec(:, i)*sqrt(max(lam(i), 0.0_dp))
        end do
        lt = transpose(vec)
        call random_seed(size=ns)
        allocate(state(ns), myseed(ns))
        call random_seed(get=state)
        myseed = [(seed + 7919*i, i=1, ns)]
        call random_seed(put=myseed)
        allocate(e(dtot, nblk), sb(dtot, nblk), g(max(dpe, 1)))
        hits = 0
        done = 0
        do while (done < nsim)
            nb = min(nblk, nsim - done)
            call gaussian(e(:, 1:nb))
            call matmul_tn(lt, e(:, 1:nb), sb(:, 1:nb), info)
            if (info /= sk_ok) exit
            do j = 1, nb
                s2 = 1.0_dp
                if (dpe > 0) then
                    call gaussian_1(g)
                    s2 = sum(g**2)/dpe
                end if
                hit = .false.
                do c = 1, ncand
                    if (dof(c) == 0) cycle
                    st = sum(sb(off(c) + 1:off(c) + dof(c), j)**2)
                    if (st >= crit(c)*s2) then
                        hit = .true.
                        exit
                    end if
                end do
                if (hit) hits = hits + 1
            end do
            done = done + nb
        end do
        call random_seed(put=state)
        if (info /= sk_ok) return
        p = real(hits + 1, dp)/real(nsim + 1, dp)
    end subroutine max_score_test

    !> The statistic x of a candidate with k degrees of freedom whose log
    !> p-value is lobs < 0: chi-square(k) when d2 = 0, else k * F(k, d2)
    !> (so that x / s2 is compared, s2 the pure-error variance). Bisection
    !> on the monotone tail.
    pure function critical_value(k, d2, lobs) result(x)
        real(dp), intent(in) :: k, d2, lobs
        real(dp) :: x, lo, hi
        integer :: it
        lo = 0.0_dp
        hi = max(1.0_dp, 2.0_dp*k)
        do it = 1, 200
            if (tail(hi) <= lobs) exit
            lo = hi
            hi = 2.0_dp*hi
        end do
        do it = 1, 200
            x = 0.5_dp*(lo + hi)
            if (tail(x) > lobs) then
                lo = x
            else
                hi = x
            end if
            if (hi - lo <= 1.0e-12_dp*hi) exit
        end do
        x = hi
    contains
        pure function tail(t) result(l)
            real(dp), intent(in) :: t
            real(dp) :: l
            if (d2 > 0.0_dp) then
                l = f_logsf(t/k, k, d2)
            else
                l = chi2_logsf(t, k)
            end if
        end function tail
    end function critical_value

    !> Standard normal draws (Box-Muller on the intrinsic generator).
    subroutine gaussian(x)
        real(dp), intent(out) :: x(:, :)
        integer :: j
        do j = 1, size(x, 2)
            call gaussian_1(x(:, j))
        end do
    end subroutine gaussian

    subroutine gaussian_1(x)
        real(dp), intent(out) :: x(:)
        real(dp), parameter :: twopi = 6.283185307179586_dp
        real(dp) :: u1(size(x)), u2(size(x))
        call random_number(u1)
        call random_number(u2)
        x = sqrt(-2.0_dp*log(1.0_dp - u1))*cos(twopi*u2)
    end subroutine gaussian_1

    !> Greedy choice of independent columns of a[n,p] taken in the order
    !> order(1..p) (1-based column numbers): a column, scaled to unit norm,
    !> is selected (selected(k) = 1) when its part orthogonal to the columns
    !> already selected is longer than tol (M5b: an identifiable subset).
    subroutine select_independent(a, order, tol, selected, info)
        real(dp), intent(in) :: a(:, :), tol
        integer(ip), intent(in) :: order(:)
        integer(ip), intent(out) :: selected(:), info
        real(dp), allocatable :: qb(:, :), x(:)
        integer :: n, p, k, c, nq, pass
        n = size(a, 1)
        p = size(a, 2)
        selected = 0
        if (size(order) /= p .or. size(selected) /= p) then
            info = sk_err_size
            return
        end if
        if (any(order < 1) .or. any(order > p)) then
            info = sk_err_argument
            return
        end if
        allocate(qb(n, p), x(n))
        nq = 0
        do k = 1, p
            c = order(k)
            x = a(:, c)
            if (norm2(x) <= 0.0_dp) cycle
            x = x/norm2(x)
            do pass = 1, 2                          ! re-orthogonalise once
                if (nq > 0) x = x - matmul(qb(:, 1:nq), matmul(x, qb(:, 1:nq)))  ! Q (Q^T x), no transposed copy
            end do
            if (norm2(x) > tol .and. nq < n) then
                nq = nq + 1
                qb(:, nq) = x/norm2(x)
                selected(c) = 1
            end if
        end do
        info = sk_ok
    end subroutine select_independent

    !> Sparse relations between coupled parameters (klimchik eq. 21): the
    !> reduced row echelon form of the null part of V (v[p,p] from wls_svd,
    !> columns rank+1..p span the null space), by Gauss-Jordan elimination
    !> with partial pivoting; rel[p-rank, p], each row a null vector with 1 at
    !> its pivot and zeros at the other pivots, entries below tol set to 0.
    !> The parameters with a non-zero entry in a row are coupled: only their
    !> combination is identifiable.
    subroutine null_relations(v, rank, tol, rel, info)
        real(dp), intent(in) :: v(:, :), tol
        integer(ip), intent(in) :: rank
        real(dp), intent(out) :: rel(:, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: m(:, :), row(:)
        integer :: p, k, i, col, r, piv
        p = size(v, 1)
        k = p - rank
        rel = 0.0_dp
        if (size(v, 2) /= p .or. rank < 0 .or. rank > p .or. any(shape(rel) /= [k, p])) then
            info = sk_err_size
            return
        end if
        if (k == 0) then
            info = sk_ok
            return
        end if
        m = transpose(v(:, rank + 1:p))
        r = 1
        do col = 1, p
            if (r > k) exit
            piv = r - 1 + maxloc(abs(m(r:k, col)), dim=1)
            if (abs(m(piv, col)) <= tol) cycle
            if (piv /= r) then
                row = m(r, :)
                m(r, :) = m(piv, :)
                m(piv, :) = row
            end if
            m(r, :) = m(r, :)/m(r, col)
            do i = 1, k
                if (i /= r) m(i, :) = m(i, :) - m(i, col)*m(r, :)
            end do
            r = r + 1
        end do
        where (abs(m) <= tol) m = 0.0_dp
        rel = m
        info = sk_ok
    end subroutine null_relations

end module sk_calib
