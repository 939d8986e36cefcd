!> Small 3-D geometry shared by the core: cross-product matrices, the
!> vector product, 3x3 determinant and inverse, and rotations (the
!> exponential and logarithm maps of SO(3) and the inverse left Jacobian).
module sk_rotation
    use sk_kinds, only: dp
    implicit none
    private
    public :: skew, cross, det3, inv3, rot_exp, rot_log, left_jacobian_inv

contains

    !> The 3x3 identity (eye(3) of sk_linalg, which uses this module).
    pure function identity3() result(a)
        real(dp) :: a(3, 3)
        a = 0.0_dp
        a(1, 1) = 1.0_dp
        a(2, 2) = 1.0_dp
        a(3, 3) = 1.0_dp
    end function identity3

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
        r = identity3() + a*k + b*matmul(k, k)
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
                bmat = 0.5_dp*(r + identity3())
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
        ji = identity3() - 0.5_dp*k + c*matmul(k, k)
    end function left_jacobian_inv

end module sk_rotation
