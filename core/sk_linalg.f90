!> Dense linear algebra shared by the core: thin checked wrappers around
!> LAPACK (dgesv, dgetrf/dgetrs, dgesvd, dsyev, dpotrf/dpotri, dgeqrf,
!> dgels) and BLAS (dgemm), the pseudo-inverse, finiteness checks, the
!> identity and grouping of items by key.
!>
!> Wrappers copy their inputs, check sizes and return an `info` from
!> sk_errors (never the raw LAPACK code).
!>
!> The 3-D geometry (sk_rotation) and the small symmetric kernels
!> (sk_small_sym) live in their own modules: use them from there.
module sk_linalg
    use sk_kinds, only: dp, ip
    use sk_errors
    implicit none
    private
    public :: inverse, svd, sym_eig, spd_inverse, pinv, all_finite
    public :: eye, matmul_tn
    public :: solve_inplace, lu_factor, lu_solve, qr_triangle, lstsq, group_by

    interface all_finite
        module procedure all_finite_1, all_finite_2, all_finite_3
    end interface all_finite

    interface
        subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
            import :: dp
            integer, intent(in) :: n, nrhs, lda, ldb
            real(dp), intent(inout) :: a(lda, *), b(ldb, *)
            integer, intent(out) :: ipiv(*), info
        end subroutine dgesv
        subroutine dgesvd(jobu, jobvt, m, n, a, lda, s, u, ldu, vt, ldvt, work, lwork, info)
            import :: dp
            character, intent(in) :: jobu, jobvt
            integer, intent(in) :: m, n, lda, ldu, ldvt, lwork
            real(dp), intent(inout) :: a(lda, *)
            real(dp), intent(out) :: s(*), u(ldu, *), vt(ldvt, *), work(*)
            integer, intent(out) :: info
        end subroutine dgesvd
        subroutine dsyev(jobz, uplo, n, a, lda, w, work, lwork, info)
            import :: dp
            character, intent(in) :: jobz, uplo
            integer, intent(in) :: n, lda, lwork
            real(dp), intent(inout) :: a(lda, *)
            real(dp), intent(out) :: w(*), work(*)
            integer, intent(out) :: info
        end subroutine dsyev
        subroutine dpotrf(uplo, n, a, lda, info)
            import :: dp
            character, intent(in) :: uplo
            integer, intent(in) :: n, lda
            real(dp), intent(inout) :: a(lda, *)
            integer, intent(out) :: info
        end subroutine dpotrf
        subroutine dpotri(uplo, n, a, lda, info)
            import :: dp
            character, intent(in) :: uplo
            integer, intent(in) :: n, lda
            real(dp), intent(inout) :: a(lda, *)
            integer, intent(out) :: info
        end subroutine dpotri
        subroutine dgemm(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc)
            import :: dp
            character, intent(in) :: transa, transb
            integer, intent(in) :: m, n, k, lda, ldb, ldc
            real(dp), intent(in) :: alpha, beta, a(lda, *), b(ldb, *)
            real(dp), intent(inout) :: c(ldc, *)
        end subroutine dgemm
        subroutine dgetrf(m, n, a, lda, ipiv, info)
            import :: dp
            integer, intent(in) :: m, n, lda
            real(dp), intent(inout) :: a(lda, *)
            integer, intent(out) :: ipiv(*), info
        end subroutine dgetrf
        subroutine dgetrs(trans, n, nrhs, a, lda, ipiv, b, ldb, info)
            import :: dp
            character, intent(in) :: trans
            integer, intent(in) :: n, nrhs, lda, ldb, ipiv(*)
            real(dp), intent(in) :: a(lda, *)
            real(dp), intent(inout) :: b(ldb, *)
            integer, intent(out) :: info
        end subroutine dgetrs
        subroutine dgeqrf(m, n, a, lda, tau, work, lwork, info)
            import :: dp
            integer, intent(in) :: m, n, lda, lwork
            real(dp), intent(inout) :: a(lda, *)
            real(dp), intent(out) :: tau(*), work(*)
            integer, intent(out) :: info
        end subroutine dgeqrf
        subroutine dgels(trans, m, n, nrhs, a, lda, b, ldb, work, lwork, info)
            import :: dp
            character, intent(in) :: trans
            integer, intent(in) :: m, n, nrhs, lda, ldb, lwork
            real(dp), intent(inout) :: a(lda, *), b(ldb, *)
            real(dp), intent(out) :: work(*)
            integer, intent(out) :: info
        end subroutine dgels
    end interface

contains

    !> Identity matrix of order n.
    pure function eye(n) result(a)
        integer, intent(in) :: n
        real(dp) :: a(n, n)
        integer :: i
        a = 0.0_dp
        do i = 1, n
            a(i, i) = 1.0_dp
        end do
    end function eye

    !> True when every element is finite (x - x is NaN for Inf and NaN).
    logical function all_finite_1(x) result(ok)
        real(dp), intent(in) :: x(:)
        real(dp) :: acc
        integer :: i
        acc = 0.0_dp
        do i = 1, size(x)
            acc = acc + (x(i) - x(i))
        end do
        ok = acc == 0.0_dp
    end function all_finite_1

    logical function all_finite_2(x) result(ok)
        real(dp), intent(in) :: x(:, :)
        real(dp) :: acc(size(x, 1))
        integer :: j
        acc = 0.0_dp
        do j = 1, size(x, 2)          ! one accumulator per row: short add chains
            acc = acc + (x(:, j) - x(:, j))
        end do
        ok = all(acc == 0.0_dp)
    end function all_finite_2

    logical function all_finite_3(x) result(ok)
        real(dp), intent(in) :: x(:, :, :)
        integer :: k
        ok = .true.
        do k = 1, size(x, 3)
            ok = ok .and. all_finite_2(x(:, :, k))
        end do
    end function all_finite_3

    !> General inverse ainv = a^-1 by LU (dgesv); info = sk_err_singular if
    !> a is exactly singular.
    subroutine inverse(a, ainv, info)
        real(dp), intent(in) :: a(:, :)          !> a[n,n]
        real(dp), intent(out) :: ainv(:, :)      !> a^-1 [n,n]
        integer(ip), intent(out) :: info
        real(dp), allocatable :: lu(:, :)
        integer, allocatable :: ipiv(:)
        integer :: n, linfo
        n = size(a, 1)
        if (size(a, 2) /= n .or. any(shape(ainv) /= [n, n])) then
            info = sk_err_size
            return
        end if
        lu = a
        allocate(ipiv(n))
        ainv = eye(n)
        call dgesv(n, n, lu, n, ipiv, ainv, n, linfo)
        if (linfo > 0) then
            info = sk_err_singular
        else if (linfo < 0) then
            info = sk_err_lapack
        else
            info = sk_ok
        end if
    end subroutine inverse

    !> c = a^T b for a[k,m], b[k,n], c[m,n] (BLAS dgemm); info sk_err_size
    !> when the shapes do not agree.
    subroutine matmul_tn(a, b, c, info)
        real(dp), intent(in) :: a(:, :), b(:, :)
        real(dp), intent(out) :: c(:, :)
        integer(ip), intent(out) :: info
        integer :: k, m, n
        k = size(a, 1)
        m = size(a, 2)
        n = size(b, 2)
        if (size(b, 1) /= k .or. any(shape(c) /= [m, n])) then
            info = sk_err_size
            return
        end if
        info = sk_ok
        if (m == 0 .or. n == 0) return
        if (k == 0) then
            c = 0.0_dp
            return
        end if
        call dgemm('T', 'N', m, n, k, 1.0_dp, a, k, b, k, 0.0_dp, c, m)
    end subroutine matmul_tn
    !> Solve a x = b in place: on return b[n,nrhs] holds x and a[n,n] its LU
    !> factors (lu_factor, lu_solve; for hot loops where the copies of
    !> `inverse` cost more than the solve). info = sk_err_singular if a is
    !> exactly singular.
    subroutine solve_inplace(a, b, info)
        real(dp), intent(inout), contiguous :: a(:, :), b(:, :)
        integer(ip), intent(out) :: info
        integer :: ipiv(size(a, 1))
        if (size(a, 2) /= size(a, 1) .or. size(b, 1) /= size(a, 1)) then
            info = sk_err_size
            return
        end if
        call lu_factor(a, ipiv, info)
        if (info == sk_ok) call lu_solve(a, ipiv, b)
    end subroutine solve_inplace

    !> LU factorisation in place with partial pivoting, LAPACK's layout
    !> (dgetrf: unit L below the diagonal, U on and above, row k swapped
    !> with row ipiv(k)). Up to n = 40 by elimination here (dgetrf's call
    !> overhead dominates there), above by dgetrf. info = sk_err_singular
    !> if a is exactly singular.
    subroutine lu_factor(a, ipiv, info)
        real(dp), intent(inout), contiguous :: a(:, :)
        integer, intent(out) :: ipiv(:)
        integer(ip), intent(out) :: info
        integer :: n, k, p, j, i, linfo
        real(dp) :: t
        n = size(a, 1)
        info = sk_ok
        if (n == 0) return
        if (n > 40) then
            call dgetrf(n, n, a, n, ipiv, linfo)
            if (linfo > 0) then
                info = sk_err_singular
            else if (linfo < 0) then
                info = sk_err_lapack
            end if
            return
        end if
        info = sk_err_singular
        do k = 1, n
            p = k - 1 + maxloc(abs(a(k:n, k)), dim=1)
            ipiv(k) = p
            if (a(p, k) == 0.0_dp) return
            if (p /= k) then
                do j = 1, n
                    t = a(k, j)
                    a(k, j) = a(p, j)
                    a(p, j) = t
                end do
            end if
            t = 1.0_dp/a(k, k)
            do i = k + 1, n
                a(i, k) = a(i, k)*t
            end do
            do j = k + 1, n
                do i = k + 1, n
                    a(i, j) = a(i, j) - a(i, k)*a(k, j)
                end do
            end do
        end do
        info = sk_ok
    end subroutine lu_factor

    !> Solve with the factors of lu_factor: b[n,nrhs] is overwritten by x;
    !> transposed: solve a^T x = b. By substitution here for one or two
    !> right-hand sides up to n = 40 (and any number up to n = 12), else by
    !> dgetrs (its blocked triangular solves win from a few right-hand sides
    !> on: 15 % of a compensation's time at n = 21 with 8 of them).
    subroutine lu_solve(a, ipiv, b, transposed)
        real(dp), intent(in), contiguous :: a(:, :)
        integer, intent(in) :: ipiv(:)
        real(dp), intent(inout), contiguous :: b(:, :)
        logical, intent(in), optional :: transposed
        integer :: n, k, j, i, linfo
        real(dp) :: t
        logical :: tr
        n = size(a, 1)
        tr = .false.
        if (present(transposed)) tr = transposed
        if (n == 0 .or. size(b, 2) == 0) return
        if (n > 40 .or. (size(b, 2) > 2 .and. n > 12)) then
            call dgetrs(merge('T', 'N', tr), n, size(b, 2), a, n, ipiv, b, n, linfo)
            return
        end if
        do j = 1, size(b, 2)
            if (tr) then
                ! U^T z = b, L^T w = z, x = P w
                do k = 1, n
                    t = b(k, j)
                    do i = 1, k - 1
                        t = t - a(i, k)*b(i, j)
                    end do
                    b(k, j) = t/a(k, k)
                end do
                do k = n, 1, -1
                    t = b(k, j)
                    do i = k + 1, n
                        t = t - a(i, k)*b(i, j)
                    end do
                    b(k, j) = t
                end do
                do k = n, 1, -1
                    if (ipiv(k) /= k) then
                        t = b(k, j)
                        b(k, j) = b(ipiv(k), j)
                        b(ipiv(k), j) = t
                    end if
                end do
                cycle
            end if
            do k = 1, n
                if (ipiv(k) /= k) then
                    t = b(k, j)
                    b(k, j) = b(ipiv(k), j)
                    b(ipiv(k), j) = t
                end if
            end do
            do k = 1, n
                do i = k + 1, n
                    b(i, j) = b(i, j) - a(i, k)*b(k, j)
                end do
            end do
            do k = n, 1, -1
                b(k, j) = b(k, j)/a(k, k)
                do i = 1, k - 1
                    b(i, j) = b(i, j) - a(i, k)*b(k, j)
                end do
            end do
        end do
    end subroutine lu_solve

    !> Triangular factor of the QR decomposition a = Q R of a[m,n], m >= n
    !> (dgeqrf): r[n,n] upper triangular (zero below the diagonal). Q is not
    !> formed: append the right-hand side as a last column of a to get Q^T b.
    subroutine qr_triangle(a, r, info)
        real(dp), intent(in) :: a(:, :)
        real(dp), intent(out) :: r(:, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: w(:, :), tau(:), work(:)
        real(dp) :: q(1)
        integer :: m, n, lwork, linfo, j
        m = size(a, 1)
        n = size(a, 2)
        r = 0.0_dp
        if (m < n .or. any(shape(r) /= [n, n])) then
            info = sk_err_size
            return
        end if
        if (n == 0) then
            info = sk_ok
            return
        end if
        w = a
        allocate(tau(n))
        call dgeqrf(m, n, w, m, tau, q, -1, linfo)
        lwork = max(1, int(q(1)))
        allocate(work(lwork))
        call dgeqrf(m, n, w, m, tau, work, lwork, linfo)
        if (linfo /= 0) then
            info = sk_err_lapack
            return
        end if
        do j = 1, n
            r(1:j, j) = w(1:j, j)
        end do
        info = sk_ok
    end subroutine qr_triangle

    !> Least squares min |a x - b| for a[m,n] of full column rank, m >= n,
    !> by QR (dgels); x[n]. info = sk_err_singular when a triangular factor
    !> has an exactly zero diagonal element (a rank-deficient a).
    subroutine lstsq(a, b, x, info)
        real(dp), intent(in) :: a(:, :), b(:)
        real(dp), intent(out) :: x(:)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: w(:, :), rhs(:, :), work(:)
        real(dp) :: q(1)
        integer :: m, n, lwork, linfo
        m = size(a, 1)
        n = size(a, 2)
        x = 0.0_dp
        if (m < n .or. size(b) /= m .or. size(x) /= n) then
            info = sk_err_size
            return
        end if
        if (n == 0) then
            info = sk_ok
            return
        end if
        w = a
        allocate(rhs(m, 1))
        rhs(:, 1) = b
        call dgels('N', m, n, 1, w, m, rhs, m, q, -1, linfo)
        lwork = max(1, int(q(1)))
        allocate(work(lwork))
        call dgels('N', m, n, 1, w, m, rhs, m, work, lwork, linfo)
        if (linfo > 0) then
            info = sk_err_singular
        else if (linfo < 0) then
            info = sk_err_lapack
        else
            x = rhs(1:n, 1)
            info = sk_ok
        end if
    end subroutine lstsq

    !> Thin SVD a = u diag(s) vt of a[m,n], k = min(m,n): u[m,k], s[k], vt[k,n].
    subroutine svd(a, u, s, vt, info)
        real(dp), intent(in) :: a(:, :)
        real(dp), intent(out) :: u(:, :), s(:), vt(:, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: w(:, :), work(:)
        real(dp) :: q(1)
        integer :: m, n, k, lwork, linfo
        m = size(a, 1)
        n = size(a, 2)
        k = min(m, n)
        if (any(shape(u) /= [m, k]) .or. size(s) /= k .or. any(shape(vt) /= [k, n])) then
            info = sk_err_size
            return
        end if
        w = a
        call dgesvd('S', 'S', m, n, w, m, s, u, m, vt, k, q, -1, linfo)
        lwork = max(1, int(q(1)))
        allocate(work(lwork))
        call dgesvd('S', 'S', m, n, w, m, s, u, m, vt, k, work, lwork, linfo)
        if (linfo /= 0) then
            info = sk_err_lapack
        else
            info = sk_ok
        end if
    end subroutine svd

    !> Eigen-decomposition of a symmetric a[n,n]: eigenvalues w ascending,
    !> eigenvectors in the columns of v.
    subroutine sym_eig(a, w, v, info)
        real(dp), intent(in) :: a(:, :)
        real(dp), intent(out) :: w(:), v(:, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: work(:)
        real(dp) :: q(1)
        integer :: n, lwork, linfo
        n = size(a, 1)
        if (size(a, 2) /= n .or. size(w) /= n .or. any(shape(v) /= [n, n])) then
            info = sk_err_size
            return
        end if
        v = a
        call dsyev('V', 'U', n, v, n, w, q, -1, linfo)
        lwork = max(1, int(q(1)))
        allocate(work(lwork))
        call dsyev('V', 'U', n, v, n, w, work, lwork, linfo)
        info = merge(sk_ok, sk_err_lapack, linfo == 0)
    end subroutine sym_eig

    !> Inverse of a symmetric positive definite a[n,n] by Cholesky;
    !> info = sk_err_singular if a is not positive definite.
    subroutine spd_inverse(a, ainv, info)
        real(dp), intent(in) :: a(:, :)
        real(dp), intent(out) :: ainv(:, :)
        integer(ip), intent(out) :: info
        integer :: n, linfo, i, j
        n = size(a, 1)
        if (size(a, 2) /= n .or. any(shape(ainv) /= [n, n])) then
            info = sk_err_size
            return
        end if
        ainv = a
        call dpotrf('U', n, ainv, n, linfo)
        if (linfo /= 0) then
            info = merge(sk_err_singular, sk_err_lapack, linfo > 0)
            return
        end if
        call dpotri('U', n, ainv, n, linfo)
        if (linfo /= 0) then
            info = merge(sk_err_singular, sk_err_lapack, linfo > 0)
            return
        end if
        do j = 1, n
            do i = j + 1, n
                ainv(i, j) = ainv(j, i)
            end do
        end do
        info = sk_ok
    end subroutine spd_inverse

    !> Moore-Penrose pseudo-inverse ap[n,m] of a[m,n]; singular values below
    !> rcond*s_max are treated as zero; rank returned.
    subroutine pinv(a, ap, rcond, rank, info)
        real(dp), intent(in) :: a(:, :)
        real(dp), intent(out) :: ap(:, :)
        real(dp), intent(in) :: rcond
        integer(ip), intent(out) :: rank, info
        real(dp), allocatable :: u(:, :), s(:), vt(:, :)
        integer :: m, n, k, i
        m = size(a, 1)
        n = size(a, 2)
        k = min(m, n)
        if (any(shape(ap) /= [n, m])) then
            info = sk_err_size
            return
        end if
        allocate(u(m, k), s(k), vt(k, n))
        call svd(a, u, s, vt, info)
        if (info /= sk_ok) return
        rank = 0
        ap = 0.0_dp
        do i = 1, k
            if (s(i) > rcond*s(1) .and. s(i) > 0.0_dp) then
                rank = rank + 1
                ap = ap + spread(vt(i, :), 2, m)*spread(u(:, i), 1, n)/s(i)
            end if
        end do
    end subroutine pinv


    !> Group items by their key (1..nkey; e.g. payloads or observations
    !> by posture): item idx(start(k):start(k+1)-1) have key k.
    !> info = sk_err_argument for a key out of range.
    subroutine group_by(key, nkey, start, idx, info)
        integer(ip), intent(in) :: key(:)
        integer, intent(in) :: nkey
        integer, allocatable, intent(out) :: start(:), idx(:)
        integer(ip), intent(out) :: info
        integer :: i, nxt(nkey + 1)
        allocate(start(nkey + 1), idx(size(key)))
        info = sk_err_argument
        if (any(key < 1) .or. any(key > nkey)) return
        start = 0
        do i = 1, size(key)
            start(key(i) + 1) = start(key(i) + 1) + 1
        end do
        start(1) = 1
        do i = 1, nkey
            start(i + 1) = start(i + 1) + start(i)
        end do
        nxt = start
        do i = 1, size(key)
            idx(nxt(key(i))) = i
            nxt(key(i)) = nxt(key(i)) + 1
        end do
        info = sk_ok
    end subroutine group_by

end module sk_linalg
