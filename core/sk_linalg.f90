!> Small dense linear algebra shared by the core: cross-product matrices,
!> rotations (exponential and logarithm maps of SO(3)), and thin checked
!> wrappers around LAPACK (dgesv, dgetrf/dgetrs, dgesvd, dsyev,
!> dpotrf/dpotri, dgeqrf, dgels) and BLAS (dgemm).
!>
!> Wrappers copy their inputs, check sizes and return an `info` from
!> sk_errors (never the raw LAPACK code).
module sk_linalg
    use sk_kinds, only: dp, ip, pi
    use sk_errors
    implicit none
    private
    !> psd_defect below -psd_tol: the spring is indefinite (not round-off)
    real(dp), parameter, public :: psd_tol = 1.0e-6_dp
    public :: skew, cross, det3, rot_exp, rot_log, left_jacobian_inv
    public :: inverse, svd, sym_eig, spd_inverse, pinv, all_finite
    public :: eye, jacobi_eig, sym_eigvals_small, inv3, spd_inverse_small, chol_small, matmul_tn, psd_defect
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

    !> Cross-product matrix [v]x, so that matmul(skew(v), w) = v x w.
    pure function skew(v) result(s)
        real(dp), intent(in) :: v(3)
        real(dp) :: s(3, 3)
        s(:, 1) = [0.0_dp, v(3), -v(2)]
        s(:, 2) = [-v(3), 0.0_dp, v(1)]
        s(:, 3) = [v(2), -v(1), 0.0_dp]
    end function skew

    !> Vector product a x b.
    pure function cross(a, b) result(c)
        real(dp), intent(in) :: a(3), b(3)
        real(dp) :: c(3)
        c = [a(2)*b(3) - a(3)*b(2), a(3)*b(1) - a(1)*b(3), a(1)*b(2) - a(2)*b(1)]
    end function cross

    !> Inverse of a 3x3 matrix by its adjugate (for small well-conditioned
    !> systems where a LAPACK call costs more than the arithmetic).
    pure function inv3(a) result(b)
        real(dp), intent(in) :: a(3, 3)
        real(dp) :: b(3, 3)
        b(1,1) = a(2,2)*a(3,3) - a(2,3)*a(3,2)
        b(1,2) = a(1,3)*a(3,2) - a(1,2)*a(3,3)
        b(1,3) = a(1,2)*a(2,3) - a(1,3)*a(2,2)
        b(2,1) = a(2,3)*a(3,1) - a(2,1)*a(3,3)
        b(2,2) = a(1,1)*a(3,3) - a(1,3)*a(3,1)
        b(2,3) = a(1,3)*a(2,1) - a(1,1)*a(2,3)
        b(3,1) = a(2,1)*a(3,2) - a(2,2)*a(3,1)
        b(3,2) = a(1,2)*a(3,1) - a(1,1)*a(3,2)
        b(3,3) = a(1,1)*a(2,2) - a(1,2)*a(2,1)
        b = b/(a(1,1)*b(1,1) + a(1,2)*b(2,1) + a(1,3)*b(3,1))
    end function inv3

    pure function det3(a) result(d)
        real(dp), intent(in) :: a(3, 3)
        real(dp) :: d
        d = a(1,1)*(a(2,2)*a(3,3) - a(2,3)*a(3,2)) &
          - a(1,2)*(a(2,1)*a(3,3) - a(2,3)*a(3,1)) &
          + a(1,3)*(a(2,1)*a(3,2) - a(2,2)*a(3,1))
    end function det3

    !> Rotation matrix exp([w]x) of the rotation vector w (Rodrigues), with a
    !> series for small angles so that it is accurate to round-off.
    pure function rot_exp(w) result(r)
        real(dp), intent(in) :: w(3)
        real(dp) :: r(3, 3)
        real(dp) :: th2, th, a, b, k(3, 3)
        th2 = dot_product(w, w)
        th = sqrt(th2)
        if (th < 1.0e-4_dp) then
            a = 1.0_dp - th2/6.0_dp + th2*th2/120.0_dp
            b = 0.5_dp - th2/24.0_dp + th2*th2/720.0_dp
        else
            a = sin(th)/th
            b = (1.0_dp - cos(th))/th2
        end if
        k = skew(w)
        r = eye(3) + a*k + b*matmul(k, k)
    end function rot_exp

    !> Rotation vector of a proper rotation matrix (logarithm map of SO(3)),
    !> accurate for small angles (uses the skew part with the exact
    !> theta/sin(theta) factor) and well defined up to theta < pi.
    pure function rot_log(r) result(w)
        real(dp), intent(in) :: r(3, 3)
        real(dp) :: w(3)
        real(dp) :: v(3), s, c, th, bmat(3, 3)
        integer :: k
        v = 0.5_dp*[r(3,2) - r(2,3), r(1,3) - r(3,1), r(2,1) - r(1,2)]
        s = norm2(v)                                  ! sin(theta)
        c = 0.5_dp*(r(1,1) + r(2,2) + r(3,3) - 1.0_dp)  ! cos(theta)
        th = atan2(s, c)
        if (s < 1.0e-12_dp) then
            if (c > 0.0_dp) then
                w = v*(1.0_dp + th*th/6.0_dp)
            else
                ! theta close to pi: (R + I)/2 = n n^T, take its largest column
                bmat = 0.5_dp*(r + eye(3))
                k = maxloc([bmat(1,1), bmat(2,2), bmat(3,3)], dim=1)
                w = th*bmat(:, k)/sqrt(max(bmat(k, k), tiny(1.0_dp)))
            end if
        else
            w = v*(th/s)
        end if
    end function rot_log

    !> Inverse of the left Jacobian of SO(3): a left perturbation delta of
    !> exp([w]x) changes the rotation vector by dw = Jl^-1(w) delta.
    pure function left_jacobian_inv(w) result(ji)
        real(dp), intent(in) :: w(3)
        real(dp) :: ji(3, 3)
        real(dp) :: th, th2, k(3, 3), c
        th2 = dot_product(w, w)
        th = sqrt(th2)
        k = skew(w)
        if (th < 1.0e-4_dp) then
            c = 1.0_dp/12.0_dp + th2/720.0_dp
        else
            c = (1.0_dp - th*sin(th)/(2.0_dp*(1.0_dp - cos(th))))/th2
        end if
        ji = eye(3) - 0.5_dp*k + c*matmul(k, k)
    end function left_jacobian_inv

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

    !> Cholesky a = l l^T of a small SPD a[n,n] by plain loops (no LAPACK
    !> call: for blocks of a few rows, called in hot loops); l lower, upper
    !> part zero; ok = .false. when a pivot^2 is <= tol.
    pure subroutine chol_small(n, a, l, tol, ok)
        integer, intent(in) :: n
        real(dp), intent(in) :: a(n, n), tol
        real(dp), intent(out) :: l(n, n)
        logical, intent(out) :: ok
        integer :: i, j, p
        real(dp) :: d
        l = 0.0_dp
        ok = .false.
        do j = 1, n
            d = a(j, j)
            do p = 1, j - 1
                d = d - l(j, p)**2
            end do
            if (.not. (d > tol)) return
            l(j, j) = sqrt(d)
            do i = j + 1, n
                d = a(i, j)
                do p = 1, j - 1
                    d = d - l(i, p) * l(j, p)
                end do
                l(i, j) = d / l(j, j)
            end do
        end do
        ok = .true.
    end subroutine chol_small

    !> Inverse of a small symmetric positive definite a[n,n] by an unrolled
    !> Cholesky (no LAPACK call: for the 6x6 blocks of the spring algebra) and
    !> the lower bound 1/(tr(a) tr(a^-1)) of its smallest/largest eigenvalue
    !> ratio; ok = .false. if a pivot is not positive.
    pure subroutine spd_inverse_small(n, a, ainv, bound, ok)
        integer, intent(in) :: n
        real(dp), intent(in) :: a(n, n)
        real(dp), intent(out) :: ainv(n, n), bound
        logical, intent(out) :: ok
        real(dp) :: l(n, n), li(n, n), s, tra, tri
        integer :: i, j, k
        ok = .false.
        bound = 0.0_dp
        ainv = 0.0_dp
        call chol_small(n, a, l, 0.0_dp, ok)
        if (.not. ok) return
        ok = .false.
        ! li = l^-1 (lower triangular)
        li = 0.0_dp
        do j = 1, n
            li(j, j) = 1.0_dp/l(j, j)
            do i = j + 1, n
                s = 0.0_dp
                do k = j, i - 1
                    s = s - l(i, k)*li(k, j)
                end do
                li(i, j) = s/l(i, i)
            end do
        end do
        ! ainv = li^T li
        do j = 1, n
            do i = j, n
                s = 0.0_dp
                do k = i, n
                    s = s + li(k, i)*li(k, j)
                end do
                ainv(i, j) = s
                ainv(j, i) = s
            end do
        end do
        tra = 0.0_dp
        tri = 0.0_dp
        do i = 1, n
            tra = tra + a(i, i)
            tri = tri + ainv(i, i)
        end do
        bound = 1.0_dp/(tra*tri)
        ok = .true.
    end subroutine spd_inverse_small

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

    !> Eigen-decomposition of a small symmetric a[n,n] by cyclic Jacobi
    !> rotations (relatively accurate for graded matrices, no workspace):
    !> eigenvalues w ascending, eigenvectors in the columns of v.
    pure subroutine jacobi_eig(n, a, w, v)
        integer, intent(in) :: n
        real(dp), intent(in) :: a(n, n)
        real(dp), intent(out) :: w(n), v(n, n)
        real(dp) :: b(n, n), off, tot, theta, t, c, s, x, y, tmpw, tmpv(n)
        integer :: sweep, p, q, k, i, j
        b = a
        v = 0.0_dp
        do k = 1, n
            v(k, k) = 1.0_dp
        end do
        do sweep = 1, 60
            off = 0.0_dp
            tot = 0.0_dp
            do q = 1, n
                do p = 1, q - 1
                    off = off + b(p, q)**2
                end do
                tot = tot + b(q, q)**2
            end do
            if (off <= (1.0e-18_dp)**2*(tot + 2*off) .or. off == 0.0_dp) exit
            do p = 1, n - 1
                do q = p + 1, n
                    if (b(p, q) == 0.0_dp) cycle
                    theta = (b(q, q) - b(p, p))/(2.0_dp*b(p, q))
                    if (abs(theta) > 1.0e150_dp) then
                        t = 0.5_dp/theta
                    else
                        t = sign(1.0_dp, theta)/(abs(theta) + sqrt(theta*theta + 1.0_dp))
                    end if
                    c = 1.0_dp/sqrt(t*t + 1.0_dp)
                    s = t*c
                    do k = 1, n
                        x = b(k, p)
                        y = b(k, q)
                        b(k, p) = c*x - s*y
                        b(k, q) = s*x + c*y
                    end do
                    do k = 1, n
                        x = b(p, k)
                        y = b(q, k)
                        b(p, k) = c*x - s*y
                        b(q, k) = s*x + c*y
                    end do
                    b(p, q) = 0.0_dp
                    b(q, p) = 0.0_dp
                    do k = 1, n
                        x = v(k, p)
                        y = v(k, q)
                        v(k, p) = c*x - s*y
                        v(k, q) = s*x + c*y
                    end do
                end do
            end do
        end do
        do k = 1, n
            w(k) = b(k, k)
        end do
        ! insertion sort, ascending
        do i = 2, n
            tmpw = w(i)
            tmpv = v(:, i)
            j = i - 1
            do while (j >= 1)
                if (w(j) <= tmpw) exit
                w(j + 1) = w(j)
                v(:, j + 1) = v(:, j)
                j = j - 1
            end do
            w(j + 1) = tmpw
            v(:, j + 1) = tmpv
        end do
    end subroutine jacobi_eig

    !> How far a small symmetric a[n,n] (a compliance or stiffness) is from
    !> positive semi-definite, whatever the units of its rows: the smallest
    !> eigenvalue of D sym(a) D with D = diag(a_ii^-1/2) (zero rows left
    !> out), at most 0. A negative diagonal element, or a non-zero coupling
    !> of a row whose diagonal is zero, gives -1. About -1e-16 is round-off;
    !> the callers accept down to -psd_tol.
    pure function psd_defect(n, a) result(dmin)
        integer, intent(in) :: n
        real(dp), intent(in) :: a(n, n)
        real(dp) :: dmin
        real(dp) :: s(n, n), w(n), v(n, n), d(n)
        integer :: i, j
        dmin = -1.0_dp
        d = 0.0_dp
        do i = 1, n
            if (a(i, i) < 0.0_dp) return
            if (a(i, i) > 0.0_dp) d(i) = 1.0_dp/sqrt(a(i, i))
        end do
        do j = 1, n
            do i = 1, n
                if (i /= j .and. (d(i) == 0.0_dp .or. d(j) == 0.0_dp) .and. &
                    (a(i, j) /= 0.0_dp .or. a(j, i) /= 0.0_dp)) return
                s(i, j) = 0.5_dp*(a(i, j) + a(j, i))*d(i)*d(j)
            end do
        end do
        call jacobi_eig(n, s, w, v)
        dmin = min(0.0_dp, w(1))
    end function psd_defect

    !> Eigenvalues only (unsorted) of a small symmetric a[n,n]: Householder
    !> tridiagonalisation and the implicit QL iteration (tred2/tqli without
    !> vectors). ok = .false. if QL needs more than 30 iterations.
    pure subroutine sym_eigvals_small(n, a, d, ok)
        integer, intent(in) :: n
        real(dp), intent(in) :: a(n, n)
        real(dp), intent(out) :: d(n)
        logical, intent(out) :: ok
        real(dp) :: b(n, n), e(n), scale, h, f, g, hh, r, s, c, p, bb, dd
        integer :: i, j, l, m, iter
        logical :: early
        b = a
        ok = .true.
        e = 0.0_dp
        do i = n, 2, -1
            l = i - 1
            h = 0.0_dp
            if (l > 1) then
                scale = sum(abs(b(i, 1:l)))
                if (scale == 0.0_dp) then
                    e(i) = b(i, l)
                else
                    b(i, 1:l) = b(i, 1:l)/scale
                    h = sum(b(i, 1:l)**2)
                    f = b(i, l)
                    g = -sign(sqrt(h), f)
                    e(i) = scale*g
                    h = h - f*g
                    b(i, l) = f - g
                    f = 0.0_dp
                    do j = 1, l
                        g = dot_product(b(j, 1:j), b(i, 1:j)) + dot_product(b(j + 1:l, j), b(i, j + 1:l))
                        e(j) = g/h
                        f = f + e(j)*b(i, j)
                    end do
                    hh = f/(h + h)
                    do j = 1, l
                        f = b(i, j)
                        g = e(j) - hh*f
                        e(j) = g
                        b(j, 1:j) = b(j, 1:j) - (f*e(1:j) + g*b(i, 1:j))
                    end do
                end if
            else
                e(i) = b(i, l)
            end if
        end do
        do i = 1, n
            d(i) = b(i, i)
        end do
        do i = 2, n
            e(i - 1) = e(i)
        end do
        e(n) = 0.0_dp
        do l = 1, n
            iter = 0
            do
                do m = l, n - 1
                    dd = abs(d(m)) + abs(d(m + 1))
                    if (abs(e(m)) + dd == dd) exit
                end do
                if (m == l) exit
                iter = iter + 1
                if (iter > 30) then
                    ok = .false.
                    return
                end if
                g = (d(l + 1) - d(l))/(2.0_dp*e(l))
                r = sqrt(g*g + 1.0_dp)
                g = d(m) - d(l) + e(l)/(g + sign(r, g))
                s = 1.0_dp
                c = 1.0_dp
                p = 0.0_dp
                early = .false.
                do i = m - 1, l, -1
                    f = s*e(i)
                    bb = c*e(i)
                    r = sqrt(f*f + g*g)
                    e(i + 1) = r
                    if (r == 0.0_dp) then
                        d(i + 1) = d(i + 1) - p
                        e(m) = 0.0_dp
                        early = .true.
                        exit
                    end if
                    s = f/r
                    c = g/r
                    g = d(i + 1) - p
                    r = (d(i) - g)*s + 2.0_dp*c*bb
                    p = s*r
                    d(i + 1) = g + p
                    g = c*r - bb
                end do
                if (early) cycle
                d(l) = d(l) - p
                e(l) = g
                e(m) = 0.0_dp
            end do
        end do
    end subroutine sym_eigvals_small

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
