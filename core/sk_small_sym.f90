!> Small symmetric matrices (6x6 springs, compliances, information
!> blocks) by plain loops, without LAPACK: Cholesky, the SPD inverse with a
!> condition bound, cyclic-Jacobi eigen-decomposition, eigenvalues only, and
!> the PSD defect that tells an indefinite spring from round-off.
module sk_small_sym
    use sk_kinds, only: dp
    implicit none
    private
    !> psd_defect below -psd_tol: the spring is indefinite (not round-off)
    real(dp), parameter, public :: psd_tol = 1.0e-6_dp
    public :: chol_small, spd_inverse_small, jacobi_eig, sym_eigvals_small, psd_defect

contains

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

end module sk_small_sym
