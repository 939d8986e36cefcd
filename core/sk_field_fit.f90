!> Rigid-body motion of a node field around a reference point
!> (Pashkevich et al. 2009, "Accuracy improvement for stiffness modeling of
!> parallel manipulators", sections 3.1-3.4).
!>
!> Given node positions q_i relative to the reference point p0 and their
!> displacements d_i, find the translation t of p0 and the rotation phi of
!> the field such that  q_i + d_i ~ R(phi) q_i + t  (eq. 4), in the least
!> squares sense (eq. 5). Methods:
!>   lin    linearised model d_i = t + phi x q_i (eqs. 12-17, centred form)
!>   svd*   orthogonal Procrustes (eqs. 6-10), angles from R by Table 1
!>   exact  Gauss-Newton on SO(3) from the LIN start; phi is the rotation
!>          vector log(R), so the answer carries no linearisation error.
!> The noise model is eq. 18 (i.i.d. residuals), the covariance eq. 20 and
!> the noise estimate eq. 21 (3n - 6 degrees of freedom).
module sk_field_fit
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: skew, cross, det3, rot_exp, rot_log, left_jacobian_inv, inv3
    use sk_small_sym, only: jacobi_eig
    use sk_linalg, only: svd, all_finite, eye
    implicit none
    private
    public :: fit_field, fit_rigid, trim_mask
    public :: method_lin, method_svd_plus, method_svd_minus, method_svd_pm, method_exact

    integer(ip), parameter :: method_lin = 0
    integer(ip), parameter :: method_svd_plus = 1
    integer(ip), parameter :: method_svd_minus = 2
    integer(ip), parameter :: method_svd_pm = 3
    integer(ip), parameter :: method_exact = 4

    !> smallest/largest eigenvalue of the field's rotational normal matrix
    !> below which the rotation is declared unobservable (collinear nodes)
    real(dp), parameter :: degenerate_ratio = 1.0e-10_dp

contains

    !> Centroid c of q, the rotational normal matrix and the LIN right-hand
    !> side b = sum_i qh_i x d_i (eq. 17).
    !> D = sum_i [qh_i]x^T [qh_i]x = sum_i (|qh_i|^2 I - qh_i qh_i^T), qh = q - c
    !> (the 3x3 block of eq. 17). info = sk_err_degenerate if D is
    !> (numerically) singular: all nodes on one line or one point.
    subroutine normal_matrix(q, d, c, dmat, b, dbar, info)
        real(dp), intent(in) :: q(:, :)        !> q[3,n]
        real(dp), intent(in) :: d(:, :)        !> d[3,n]
        real(dp), intent(out) :: c(3), dmat(3, 3), b(3), dbar(3)
        integer(ip), intent(out) :: info
        real(dp) :: ev(3), evec(3, 3), s
        c = centroid(q)
        call centred_moments(q, c, d, dmat, b, dbar)  ! S = sum qh qh^T, b = sum qh x d
        s = dmat(1,1) + dmat(2,2) + dmat(3,3)
        dmat = -dmat
        dmat(1,1) = dmat(1,1) + s
        dmat(2,2) = dmat(2,2) + s
        dmat(3,3) = dmat(3,3) + s
        call jacobi_eig(3, dmat, ev, evec)
        info = sk_ok
        if (ev(3) <= 0.0_dp .or. ev(1) <= degenerate_ratio*ev(3)) info = sk_err_degenerate
    end subroutine normal_matrix

    !> One rigid fit of all nodes given (no trimming).
    !> q[3,n]: positions relative to the reference point; d[3,n]: displacements.
    !> On exit t, phi: translation of the reference point and rotation;
    !> covu[6,6]: covariance of (t, phi) per unit noise variance (eq. 20,
    !> moved from the centroid to the reference point); res[3,n]: residuals
    !> q + d - R q - t (LIN: d - t - phi x q); ssr: their sum of squares;
    !> rmat: the fitted rotation (LIN: its linearisation I + [phi]x);
    !> niter: Gauss-Newton iterations (exact method), else 0.
    subroutine fit_rigid(q, d, method, t, phi, rmat, covu, res, ssr, niter, info)
        real(dp), intent(in) :: q(:, :), d(:, :)
        integer(ip), intent(in) :: method
        real(dp), intent(out) :: t(3), phi(3), rmat(3, 3), covu(6, 6), res(:, :), ssr
        integer(ip), intent(out) :: niter, info
        real(dp) :: c(3), dmat(3, 3), dinv(3, 3), b(3), r(3, 3), cx(3, 3), dbar(3)
        real(dp) :: gbar(3), h(3, 3), u(3, 3), s(3), vt(3, 3), fix(3, 3), y(3)
        real(dp) :: delta(3), ji(3, 3), dyinv(3, 3), rc(3), qh(3), e(3)
        integer :: i, n, it
        integer, parameter :: max_iter = 100
        n = size(q, 2)
        niter = 0
        ! LIN, centred form (eq. 17): t_c = mean(d), phi = D^-1 sum qh x d
        call normal_matrix(q, d, c, dmat, b, dbar, info)
        if (info /= sk_ok) return
        dinv = inv3(dmat)          ! D is SPD with a bounded condition number here
        phi = matmul(dinv, b)
        t = dbar - cross(phi, c)
        ! eq. 20 at the centroid, then t(p0) = t_c + [c]x phi
        cx = skew(c)
        covu = 0.0_dp
        covu(1:3, 1:3) = eye(3)/real(n, dp) + matmul(matmul(cx, dinv), transpose(cx))
        covu(1:3, 4:6) = matmul(cx, dinv)
        covu(4:6, 1:3) = transpose(covu(1:3, 4:6))
        covu(4:6, 4:6) = dinv

        select case (method)
        case (method_lin)
            r = eye(3) + skew(phi)
        case (method_svd_plus, method_svd_minus, method_svd_pm)
            ! eqs. 7-10: Procrustes on the centred fields
            gbar = c + dbar                          ! mean of q + d
            call cross_moment(q, c, d, gbar, h)    ! H = sum qh gh^T (eq. 10)
            call svd(h, u, s, vt, info)
            if (info /= sk_ok) return
            ! R = V U^T (eq. 9), a proper rotation (det = +1)
            fix = eye(3)
            if (det3(matmul(transpose(vt), transpose(u))) < 0.0_dp) fix(3, 3) = -1.0_dp
            r = matmul(matmul(transpose(vt), fix), transpose(u))
            ! eq. 6, t = mean(q + d) - R mean(q), written as mean(d) - (R - I) c
            ! so that the round-off of the centroid cancels
            t = dbar - matmul(r - eye(3), c)
            select case (method)                          ! Table 1
            case (method_svd_plus)
                phi = [r(3,2), r(1,3), r(2,1)]
            case (method_svd_minus)
                phi = [-r(2,3), -r(3,1), -r(1,2)]
            case default
                phi = 0.5_dp*[r(3,2) - r(2,3), r(1,3) - r(3,1), r(2,1) - r(1,2)]
            end select
        case (method_exact)
            ! Gauss-Newton on SO(3): R <- exp([delta]x) R, with (delta, t)
            ! the exact least-squares step of the model linearised at R.
            gbar = c + dbar
            r = rot_exp(phi)
            do it = 1, max_iter
                niter = it
                b = 0.0_dp
                do i = 1, n
                    qh = q(:, i) - c
                    y(1) = r(1,1)*qh(1) + r(1,2)*qh(2) + r(1,3)*qh(3)
                    y(2) = r(2,1)*qh(1) + r(2,2)*qh(2) + r(2,3)*qh(3)
                    y(3) = r(3,1)*qh(1) + r(3,2)*qh(2) + r(3,3)*qh(3)
                    e = qh + d(:, i) - (gbar - c) - y
                    b(1) = b(1) + y(2)*e(3) - y(3)*e(2)
                    b(2) = b(2) + y(3)*e(1) - y(1)*e(3)
                    b(3) = b(3) + y(1)*e(2) - y(2)*e(1)
                end do
                ! (R D R^T)^-1 = R D^-1 R^T
                dyinv = matmul(matmul(r, dinv), transpose(r))
                delta = matmul(dyinv, b)
                r = matmul(rot_exp(delta), r)
                if (norm2(delta) <= 1.0e-15_dp + 1.0e-14_dp*norm2(rot_log(r))) exit
            end do
            if (.not. (norm2(delta) <= 1.0e-8_dp)) then   ! NaN too
                info = sk_err_noconv
                return
            end if
            phi = rot_log(r)
            rc = matmul(r, c)
            t = dbar - (rc - c)
            ! covariance: delta ~ D_y^-1 (unit), t = gbar - R c, phi = log R
            dyinv = matmul(matmul(r, dinv), transpose(r))
            ji = left_jacobian_inv(phi)
            cx = skew(rc)
            covu(1:3, 1:3) = eye(3)/real(n, dp) + matmul(matmul(cx, dyinv), transpose(cx))
            covu(1:3, 4:6) = matmul(matmul(cx, dyinv), transpose(ji))
            covu(4:6, 1:3) = transpose(covu(1:3, 4:6))
            covu(4:6, 4:6) = matmul(matmul(ji, dyinv), transpose(ji))
        case default
            info = sk_err_argument
            return
        end select
        rmat = r
        call residuals(q, d, t, rmat, res)
        ssr = sum(res**2)
        info = sk_ok
    end subroutine fit_rigid

    !> s[3,3] = sum_i qh_i qh_i^T, b = sum_i qh_i x d_i (qh = q - c) and the
    !> mean of d by compensated summation, in one pass: nine plain and three
    !> TwoSum accumulators run side by side, without temporaries.
    pure subroutine centred_moments(q, c, d, s, b, dbar)
        real(dp), intent(in) :: q(:, :), c(3), d(:, :)
        real(dp), intent(out) :: s(3, 3), b(3), dbar(3)
        real(dp) :: x, y, z, ds(3), dc(3), tt, zz, v
        integer :: i, k
        s = 0.0_dp
        b = 0.0_dp
        ds = 0.0_dp
        dc = 0.0_dp
        do i = 1, size(q, 2)
            x = q(1, i) - c(1); y = q(2, i) - c(2); z = q(3, i) - c(3)
            s(1,1) = s(1,1) + x*x; s(2,1) = s(2,1) + y*x; s(3,1) = s(3,1) + z*x
            s(2,2) = s(2,2) + y*y; s(3,2) = s(3,2) + z*y; s(3,3) = s(3,3) + z*z
            b(1) = b(1) + (y*d(3, i) - z*d(2, i))
            b(2) = b(2) + (z*d(1, i) - x*d(3, i))
            b(3) = b(3) + (x*d(2, i) - y*d(1, i))
            do k = 1, 3
                v = d(k, i)
                tt = ds(k) + v
                zz = tt - ds(k)
                dc(k) = dc(k) + ((ds(k) - (tt - zz)) + (v - zz))
                ds(k) = tt
            end do
        end do
        s(1,2) = s(2,1); s(1,3) = s(3,1); s(2,3) = s(3,2)
        dbar = (ds + dc)/real(size(q, 2), dp)
    end subroutine centred_moments

    !> h[3,3] = sum_i (q_i - c)(q_i + d_i - g)^T, without temporaries.
    pure subroutine cross_moment(q, c, d, g, h)
        real(dp), intent(in) :: q(:, :), c(3), d(:, :), g(3)
        real(dp), intent(out) :: h(3, 3)
        real(dp) :: a(3), b(3)
        integer :: i, j, k
        h = 0.0_dp
        do i = 1, size(q, 2)
            a = q(:, i) - c
            b = q(:, i) + d(:, i) - g
            do k = 1, 3
                do j = 1, 3
                    h(j, k) = h(j, k) + a(j)*b(k)
                end do
            end do
        end do
    end subroutine cross_moment

    !> Outlier mask (paper s3.4, s4.5): the ntrim nodes whose largest
    !> absolute residual component is largest are dropped (a node goes if
    !> any of its three residuals is among the largest). used[n] in/out.
    subroutine trim_mask(res, ntrim, used)
        real(dp), intent(in) :: res(:, :)
        integer, intent(in) :: ntrim
        logical, intent(inout) :: used(:)
        real(dp), allocatable :: score(:)
        integer, allocatable :: idx(:)
        integer :: i, n
        n = size(res, 2)
        if (ntrim <= 0) return
        allocate(score(n))
        do i = 1, n
            score(i) = maxval(abs(res(:, i)))
            if (.not. used(i)) score(i) = -1.0_dp
        end do
        idx = argsort(score)
        do i = n, max(1, n - ntrim + 1), -1
            used(idx(i)) = .false.
        end do
    end subroutine trim_mask

    !> Fit of the field p[3,n] + d[3,n] about the reference point p0, with
    !> optional trimming of a fraction `trim` of the nodes (refit once).
    !> res[3,n] holds the residuals of every node (trimmed ones included)
    !> against the final fit; used[n] tells which nodes entered it.
    subroutine fit_field(p, d, p0, method, trim, t, phi, covu, res, used, ssr, nused, niter, info)
        real(dp), intent(in) :: p(:, :), d(:, :), p0(3), trim
        integer(ip), intent(in) :: method
        real(dp), intent(out) :: t(3), phi(3), covu(6, 6), res(:, :), ssr
        logical, intent(out) :: used(:)
        integer(ip), intent(out) :: nused, niter, info
        real(dp), allocatable :: q(:, :), qs(:, :), ds(:, :), rs(:, :)
        real(dp) :: rmat(3, 3), acc(3)
        integer :: n, ntrim, i, k
        n = size(p, 2)
        used = .true.
        nused = 0
        niter = 0
        t = 0.0_dp
        phi = 0.0_dp
        covu = 0.0_dp
        ssr = 0.0_dp
        if (size(p, 1) /= 3 .or. any(shape(d) /= [3, n]) .or. any(shape(res) /= [3, n]) &
            .or. size(used) /= n) then
            info = sk_err_size
            return
        end if
        if (n < 3) then
            info = sk_err_size
            return
        end if
        if (.not. (all_finite(p0) .and. all_finite([trim]))) then
            info = sk_err_nonfinite
            return
        end if
        if (method < method_lin .or. method > method_exact .or. trim < 0.0_dp .or. trim >= 0.5_dp) then
            info = sk_err_argument
            return
        end if
        allocate(q(3, n))
        acc = 0.0_dp
        do i = 1, n                      ! positions about p0, and a finiteness check
            q(:, i) = p(:, i) - p0
            acc = acc + ((q(:, i) - q(:, i)) + (d(:, i) - d(:, i)))   ! NaN if any Inf/NaN
        end do
        if (.not. all(acc == 0.0_dp)) then
            info = sk_err_nonfinite
            return
        end if
        call fit_rigid(q, d, method, t, phi, rmat, covu, res, ssr, niter, info)
        if (info /= sk_ok) return
        nused = n
        ntrim = nint(trim*real(n, dp))
        if (ntrim > 0) then
            if (n - ntrim < 3) then
                info = sk_err_too_few
                return
            end if
            call trim_mask(res, ntrim, used)
            nused = count(used)
            allocate(qs(3, nused), ds(3, nused), rs(3, nused))
            k = 0
            do i = 1, n
                if (used(i)) then
                    k = k + 1
                    qs(:, k) = q(:, i)
                    ds(:, k) = d(:, i)
                end if
            end do
            call fit_rigid(qs, ds, method, t, phi, rmat, covu, rs, ssr, niter, info)
            if (info /= sk_ok) return
            call residuals(q, d, t, rmat, res)
            ! the kept residuals are the Gaussian core: undo the shrinkage
            ssr = ssr/trimmed_variance_factor(real(n - nused, dp)/real(n, dp))
        end if
    end subroutine fit_field

    !> Residuals q + d - R q - t of every node against a fit (R, t).
    !> With the LIN fit R = I + [phi]x, this is d - t - phi x q (eq. 15).
    pure subroutine residuals(q, d, t, rmat, res)
        real(dp), intent(in) :: q(:, :), d(:, :), t(3), rmat(3, 3)
        real(dp), intent(out) :: res(:, :)
        real(dp) :: rm(3, 3)
        integer :: i
        rm = rmat - eye(3)    ! small: keeps the residual free of q + d - q cancellation
        do i = 1, size(q, 2)
            res(1, i) = d(1, i) - t(1) - (rm(1,1)*q(1, i) + rm(1,2)*q(2, i) + rm(1,3)*q(3, i))
            res(2, i) = d(2, i) - t(2) - (rm(2,1)*q(1, i) + rm(2,2)*q(2, i) + rm(2,3)*q(3, i))
            res(3, i) = d(3, i) - t(3) - (rm(3,1)*q(1, i) + rm(3,2)*q(2, i) + rm(3,3)*q(3, i))
        end do
    end subroutine residuals

    !> Consistency factor of the noise estimate after trimming a fraction f
    !> of the nodes by their largest |residual| component: for i.i.d.
    !> Gaussian residuals the kept nodes are those with max_k |r_k| < c,
    !> where (2 Phi(c) - 1)^3 = 1 - f, and each kept component has variance
    !> sigma^2 (1 - 2 c phi(c) / (2 Phi(c) - 1)). Dividing the trimmed sum of
    !> squares by this factor keeps eq. 21 unbiased when no node was an
    !> outlier, and conservative (wider intervals) when some were.
    pure function trimmed_variance_factor(f) result(v)
        real(dp), intent(in) :: f
        real(dp) :: v, lo, hi, c, p
        integer :: it
        if (f <= 0.0_dp) then
            v = 1.0_dp
            return
        end if
        lo = 0.0_dp
        hi = 40.0_dp
        do it = 1, 200                       ! bisection on (erf(c/sqrt 2))^3 = 1 - f
            c = 0.5_dp*(lo + hi)
            if (erf(c/sqrt(2.0_dp))**3 < 1.0_dp - f) then
                lo = c
            else
                hi = c
            end if
        end do
        c = 0.5_dp*(lo + hi)
        p = erf(c/sqrt(2.0_dp))
        v = 1.0_dp - 2.0_dp*c*exp(-0.5_dp*c*c)/sqrt(2.0_dp*3.141592653589793_dp)/p
    end function trimmed_variance_factor

    !> Centroid of the columns of a[3,n] (plain sums, two interleaved
    !> chains per row). Its round-off does not reach t: every estimator
    !> writes t = mean(d) - (R - I) c with the compensated mean(d).
    pure function centroid(a) result(m)
        real(dp), intent(in) :: a(:, :)       !> a[3,n]
        real(dp) :: m(3)
        real(dp) :: s1(3), s2(3)
        integer :: j, n
        n = size(a, 2)
        s1 = 0.0_dp
        s2 = 0.0_dp
        do j = 1, n - 1, 2
            s1(1) = s1(1) + a(1, j); s1(2) = s1(2) + a(2, j); s1(3) = s1(3) + a(3, j)
            s2(1) = s2(1) + a(1, j + 1); s2(2) = s2(2) + a(2, j + 1); s2(3) = s2(3) + a(3, j + 1)
        end do
        if (mod(n, 2) == 1) s1 = s1 + a(:, n)
        m = (s1 + s2)/real(n, dp)
    end function centroid

    !> Indices that sort x ascending (heap sort, O(n log n), not stable).
    function argsort(x) result(idx)
        real(dp), intent(in) :: x(:)
        integer, allocatable :: idx(:)
        integer :: n, i, tmp
        n = size(x)
        idx = [(i, i = 1, n)]
        do i = n/2, 1, -1
            call sift(i, n)
        end do
        do i = n, 2, -1
            tmp = idx(1); idx(1) = idx(i); idx(i) = tmp
            call sift(1, i - 1)
        end do
    contains
        subroutine sift(start, last)
            integer, intent(in) :: start, last
            integer :: root, child, t
            root = start
            do
                child = 2*root
                if (child > last) exit
                if (child < last) then
                    if (x(idx(child)) < x(idx(child + 1))) child = child + 1
                end if
                if (x(idx(root)) < x(idx(child))) then
                    t = idx(root); idx(root) = idx(child); idx(child) = t
                    root = child
                else
                    exit
                end if
            end do
        end subroutine sift
    end function argsort

end module sk_field_fit
