!> Small-displacement algebra of twists and wrenches (6-vectors).
!>
!> Conventions used by the whole core (and by ../shared/spec):
!>   twist  x = (t, phi): translation of a point, then rotation vector;
!>   wrench w = (f, m):   force, then moment about that point.
!> A 6x6 compliance maps a wrench to a twist at the same point and frame.
!> Taghvaeipour et al. 2010 eqs. 8 and 12 (transfer of twists and wrenches
!> between points); Klimchik et al. eq. 2 uses the same transfer inside J.
module sk_spatial
    use sk_kinds, only: dp
    use sk_linalg, only: skew, eye
    implicit none
    private
    public :: twist_transfer, wrench_transfer, rotate6, compliance_move, blockdiag_rot

contains

    !> T with x_B = T x_A for one rigid body, r = B - A:
    !> t_B = t_A + phi x r  =>  T = [[I, -[r]x], [0, I]].
    pure function twist_transfer(r) result(t)
        real(dp), intent(in) :: r(3)
        real(dp) :: t(6, 6)
        t = eye(6)
        t(1:3, 4:6) = -skew(r)
    end function twist_transfer

    !> S with w_A = S w_B (wrench moved from B to A, r = B - A):
    !> m_A = m_B + r x f  =>  S = [[I, 0], [[r]x, I]] = twist_transfer(r)^T.
    pure function wrench_transfer(r) result(s)
        real(dp), intent(in) :: r(3)
        real(dp) :: s(6, 6)
        s = eye(6)
        s(4:6, 1:3) = skew(r)
    end function wrench_transfer

    !> diag(R, R): rotates twists and wrenches from a frame to its parent.
    pure function blockdiag_rot(rot) result(b)
        real(dp), intent(in) :: rot(3, 3)
        real(dp) :: b(6, 6)
        b = 0.0_dp
        b(1:3, 1:3) = rot
        b(4:6, 4:6) = rot
    end function blockdiag_rot

    !> A 6x6 compliance or stiffness expressed in a frame with axes rot
    !> (columns = its axes in the new frame), returned in the new frame:
    !> diag(R,R) c diag(R,R)^T.
    pure function rotate6(rot, c) result(cr)
        real(dp), intent(in) :: rot(3, 3), c(6, 6)
        real(dp) :: cr(6, 6), b(6, 6)
        b = blockdiag_rot(rot)
        cr = matmul(matmul(b, c), transpose(b))
    end function rotate6

    !> Compliance of a spring seen at point B, given it at point A (same
    !> axes), r = B - A: C_B = T C_A T^T with T = twist_transfer(r).
    pure function compliance_move(c, r) result(cb)
        real(dp), intent(in) :: c(6, 6), r(3)
        real(dp) :: cb(6, 6), t(6, 6)
        t = twist_transfer(r)
        cb = matmul(matmul(t, c), transpose(t))
    end function compliance_move

end module sk_spatial
