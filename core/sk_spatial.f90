!> Small-displacement algebra of twists and wrenches (6-vectors).
!>
!> Conventions used by the whole core (and by the file formats in docs/):
!>   twist  x = (t, phi): translation of a point, then rotation vector;
!>   wrench w = (f, m):   force, then moment about that point.
!> A 6x6 compliance maps a wrench to a twist at the same point and frame.
!> Taghvaeipour et al. 2010 eqs. 8 and 12 (transfer of twists and wrenches
!> between points); Klimchik et al. eq. 2 uses the same transfer inside J.
module sk_spatial
    use sk_kinds, only: dp
    use sk_rotation, only: skew
    use sk_linalg, only: eye
    implicit none
    private
    public :: twist_transfer, wrench_transfer, rotate6, compliance_move, blockdiag_rot
    public :: rotate_blocks, congruence_transfer, revolute_twist, spring_at, add_rank1
    public :: sym_index, nsym

    !> number of independent elements of a symmetric 6x6 matrix
    integer, parameter :: nsym = 21

contains

    !> Element (i, j), i <= j, of the upper triangle, row by row:
    !> (1,1) (1,2) ... (1,6) (2,2) ... (6,6) -> 1 .. 21.
    pure subroutine sym_index(k, i, j)
        integer, intent(in) :: k
        integer, intent(out) :: i, j
        integer :: kk
        kk = k
        do i = 1, 6
            if (kk <= 7 - i) then
                j = i + kk - 1
                return
            end if
            kk = kk - (7 - i)
        end do
        i = 6
        j = 6
    end subroutine sym_index

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

    !> Rotate a 6x6 (compliance or stiffness) from local axes to world axes:
    !> diag(R,R) m diag(R,R)^T, block by block.
    pure subroutine rotate_blocks(rot, m)
        real(dp), intent(in) :: rot(3, 3)
        real(dp), intent(inout) :: m(6, 6)
        real(dp) :: rt(3, 3), a(3, 3), b(3, 3), d(3, 3)
        rt = transpose(rot)
        a = m(1:3, 1:3)
        b = m(1:3, 4:6)
        d = m(4:6, 4:6)
        a = matmul(rot, matmul(a, rt))
        b = matmul(rot, matmul(b, rt))
        d = matmul(rot, matmul(d, rt))
        m(1:3, 1:3) = a
        m(1:3, 4:6) = b
        m(4:6, 4:6) = d
        m(4:6, 1:3) = transpose(b)
    end subroutine rotate_blocks

    !> m <- T m T^T with T = twist_transfer(r) = [[I, -[r]x], [0, I]]
    !> (a compliance moved by r, eq. 8), or, with r -> -r and the transpose,
    !> a stiffness (eq. 16: W^T K W with W = T(-r)); block form:
    !> A' = A - S B^T + (B - S D) S, B' = B - S D, D' = D, S = [r]x.
    pure subroutine congruence_transfer(r, m, stiffness)
        real(dp), intent(in) :: r(3)
        real(dp), intent(inout) :: m(6, 6)
        logical, intent(in) :: stiffness
        real(dp) :: s(3, 3), a(3, 3), b(3, 3), d(3, 3), sd(3, 3), bb(3, 3)
        if (stiffness) then
            ! W^T K W, W = [[I, S],[0, I]] (S = [r]x, r = tool - spring):
            ! A' = A, B' = A S + B, D' = S^T A S + S^T B + B^T S + D
            s = skew(r)
            a = m(1:3, 1:3)
            b = m(1:3, 4:6)
            d = m(4:6, 4:6)
            bb = matmul(a, s) + b
            m(1:3, 4:6) = bb
            m(4:6, 1:3) = transpose(bb)
            m(4:6, 4:6) = d + matmul(transpose(s), bb) + matmul(transpose(b), s)
        else
            s = skew(r)
            a = m(1:3, 1:3)
            b = m(1:3, 4:6)
            d = m(4:6, 4:6)
            sd = matmul(s, d)
            bb = b - sd
            m(1:3, 1:3) = a - matmul(s, transpose(b)) + matmul(bb, s)
            m(1:3, 4:6) = bb
            m(4:6, 1:3) = transpose(bb)
        end if
    end subroutine congruence_transfer



    !> Unit twist at point ``tool`` of a rotation about the unit axis u
    !> through ``point``: (u x (tool - point), u) (the column of a revolute
    !> joint in the Jacobian of klimchik eq. 2).
    pure function revolute_twist(u, point, tool) result(xi)
        real(dp), intent(in) :: u(3), point(3), tool(3)
        real(dp) :: xi(6), r(3)
        r = tool - point
        xi(1:3) = [u(2)*r(3) - u(3)*r(2), u(3)*r(1) - u(1)*r(3), u(1)*r(2) - u(2)*r(1)]
        xi(4:6) = u
    end function revolute_twist

    !> A 6x6 compliance given in local axes ``rot`` (columns in world) at a
    !> point, seen at the tool: m <- T diag(R,R) m diag(R,R)^T T^T with
    !> T = twist_transfer(r), r = tool - point. Equals J m J^T with the
    !> 6-dof spring Jacobian J = twist_transfer(r) blockdiag_rot(rot).
    pure subroutine spring_at(rot, r, m)
        real(dp), intent(in) :: rot(3, 3), r(3)
        real(dp), intent(inout) :: m(6, 6)
        call rotate_blocks(rot, m)
        call congruence_transfer(r, m, .false.)
    end subroutine spring_at

    !> acc <- acc + c xi xi^T (a joint spring of compliance c, twist xi).
    pure subroutine add_rank1(c, xi, acc)
        real(dp), intent(in) :: c, xi(6)
        real(dp), intent(inout) :: acc(6, 6)
        integer :: a, b
        do b = 1, 6
            do a = 1, 6
                acc(a, b) = acc(a, b) + c*xi(a)*xi(b)
            end do
        end do
    end subroutine add_rank1

end module sk_spatial
