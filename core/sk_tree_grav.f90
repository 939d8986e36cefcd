!> Gravity parameters of the tree model (sk_tree's module header,
!> "Gravity parameters"): body masses scaled by a factor and centres of
!> mass shifted by an offset, both entries of theta, that enter the
!> gravity wrench of every elastic effect above the body.
!>
!> Entries bpar(:,p) = (b, s, t). Body b rides on frame v = bvj(b) with
!> mass m_b = bmass(b) prod alpha_p over its mass-factor entries (s = 1,
!> alpha_p = theta(t)) at the point c_b = p_v + R_v (bcom(:,b) + d_b),
!> d_b(s-1) = the sum of theta(t) over its offset entries of slot s, base
!> axes, at the load state (where w and G are taken:
!> delta = 0 for the first-order model); its weight is F_b = m_b g. The generalised force
!> of an elastic virtual joint s (axis u_s through o_s, after its parent's
!> motion) holds, for every body beyond s,
!>   revolute:   w_s = u_s . ((c_b - o_s) x F_b),   prismatic: w_s = u_s . F_b,
!> so that
!>   dw_s/dalpha_p = u_s . ((c_b - o_s) x dm_p g)   (prismatic: u_s . dm_p g),
!>   dw_s/dd_b,k   = u_s . ((R_v e_k) x F_b)         (prismatic: 0),
!> dm_p = dm_b/dalpha_p = bmass(b) times the body's other factors.
!> These are the right-hand side of the deflection sensitivity
!> (I - D G_ee) Z = D dw/dtheta (sk_tree_equil%elastic_sensitivity); the
!> parameters move no point directly. One theta index on several bodies
!> (a subtree's factor) sums their columns. Cost: O(depth) per entry and
!> posture.
submodule(sk_tree_model) sk_tree_grav
    use sk_rotation, only: cross
    implicit none

contains

    module subroutine model_body_params(m, bpar, info)
        type(tree_model), intent(inout) :: m
        integer(ip), intent(in) :: bpar(:, :)
        integer(ip), intent(out) :: info
        info = sk_err_size
        if (size(bpar, 1) /= 3) return
        info = sk_err_argument
        if (any(bpar(1, :) < 1) .or. any(bpar(1, :) > m%nb) .or. any(bpar(2, :) < 1) .or. any(bpar(2, :) > 4) &
            .or. any(bpar(3, :) < 1) .or. any(bpar(3, :) > m%npar)) return
        m%nbp = size(bpar, 2)
        m%bpar = bpar
        info = sk_ok
    end subroutine model_body_params

    pure module subroutine body_effective(m, theta, bm, bc, dm)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        real(dp), intent(out) :: bm(:), bc(:, :), dm(:)
        integer :: p, q, b, s
        bm = m%bmass
        bc = m%bcom
        do p = 1, m%nbp
            b = m%bpar(1, p)
            s = m%bpar(2, p)
            if (s == 1) then
                bm(b) = bm(b)*theta(m%bpar(3, p))
                ! the derivative: the body's mass times its other factors
                dm(p) = m%bmass(b)
                do q = 1, m%nbp
                    if (q /= p .and. m%bpar(1, q) == b .and. m%bpar(2, q) == 1) dm(p) = dm(p)*theta(m%bpar(3, q))
                end do
            else
                bc(s - 1, b) = bc(s - 1, b) + theta(m%bpar(3, p))
                dm(p) = 0.0_dp
            end if
        end do
    end subroutine body_effective

    pure module subroutine body_rhs(m, st, bodycol, rhs)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: bodycol(:)
        real(dp), intent(inout) :: rhs(:, :)
        real(dp) :: c(3), f(3), r(3)
        integer :: p, b, v, s, e, slot, col
        do p = 1, m%nbp
            col = bodycol(p)
            b = m%bpar(1, p)
            slot = m%bpar(2, p)
            v = m%bvj(b)
            if (col == 0 .or. v == 0) cycle
            c = st%cb(:, b)
            if (slot == 1) then
                f = st%bdm(p)*m%grav
            else
                f = st%bm(b)*m%grav
                r = st%br(:, slot - 1, b)
            end if
            s = v
            do while (s > 0)
                e = m%vel(s)
                if (e > 0) then
                    if (slot == 1) then
                        if (m%vtype(s) == vj_revolute) then
                            rhs(e, col) = rhs(e, col) + dot_product(st%lu(:, s), cross(c - st%lo(:, s), f))
                        else
                            rhs(e, col) = rhs(e, col) + dot_product(st%lu(:, s), f)
                        end if
                    else if (m%vtype(s) == vj_revolute) then
                        rhs(e, col) = rhs(e, col) + dot_product(st%lu(:, s), cross(r, f))
                    end if
                end if
                s = m%parent(s)
            end do
        end do
    end subroutine body_rhs

end submodule sk_tree_grav
