!> Gravity parameters of the tree model (sk_tree's module header,
!> "Gravity parameters"): body masses scaled by a factor and centres of
!> mass shifted by an offset, both entries of theta, that enter the
!> gravity wrench of every elastic effect above the body.
!>
!> Body b rides on frame v = bvj(b) with mass m_b = bmass(b) alpha_b
!> (alpha_b = theta(bpar(1,b)), 1 when bpar(1,b) = 0) at the point
!> c_b = p_v + R_v (bcom(:,b) + d_b), d_b = theta(bpar(2:4,b)) (0 when the
!> index is 0), base axes, at the load state (where w and G are taken:
!> delta = 0 for the first-order model); its weight is F_b = m_b g. The generalised force
!> of an elastic virtual joint s (axis u_s through o_s, after its parent's
!> motion) holds, for every body beyond s,
!>   revolute:   w_s = u_s . ((c_b - o_s) x F_b),   prismatic: w_s = u_s . F_b,
!> so that
!>   dw_s/dalpha_b = w_s's term of body b / alpha_b
!>                 = u_s . ((c_b - o_s) x bmass_b g)   (prismatic: u_s . bmass_b g),
!>   dw_s/dd_b,k   = u_s . ((R_v e_k) x F_b)           (prismatic: 0).
!> These are the right-hand side of the deflection sensitivity
!> (I - D G_ee) Z = D dw/dtheta (sk_tree%elastic_sensitivity); the
!> parameters move no point directly. One theta index on several bodies
!> (a subtree's factor) sums their columns. Cost: O(depth) per body and
!> parameter slot and posture.
submodule(sk_tree) sk_tree_grav
    implicit none

contains

    module subroutine model_body_params(m, bpar, info)
        type(tree_model), intent(inout) :: m
        integer(ip), intent(in) :: bpar(:, :)
        integer(ip), intent(out) :: info
        info = sk_err_size
        if (any(shape(bpar) /= [4, m%nb])) return
        info = sk_err_argument
        if (any(bpar < 0) .or. any(bpar > m%npar)) return
        m%bpar = bpar
        info = sk_ok
    end subroutine model_body_params

    pure module subroutine body_effective(m, theta, bm, bc)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        real(dp), intent(out) :: bm(:), bc(:, :)
        integer :: b, k
        bm = m%bmass
        bc = m%bcom
        do b = 1, m%nb
            if (m%bpar(1, b) > 0) bm(b) = m%bmass(b)*theta(m%bpar(1, b))
            do k = 1, 3
                if (m%bpar(1 + k, b) > 0) bc(k, b) = bc(k, b) + theta(m%bpar(1 + k, b))
            end do
        end do
    end subroutine body_effective

    pure module subroutine body_rhs(m, st, bodycol, rhs)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: bodycol(:, :)
        real(dp), intent(inout) :: rhs(:, :)
        real(dp) :: c(3), f0(3), fb(3), r(3)
        integer :: b, v, s, e, k, col
        do b = 1, m%nb
            v = m%bvj(b)
            if (v == 0 .or. all(bodycol(:, b) == 0)) cycle
            c = st%cb(:, b)
            f0 = m%bmass(b)*m%grav
            fb = st%bm(b)*m%grav
            s = v
            do while (s > 0)
                e = m%vel(s)
                if (e > 0) then
                    col = bodycol(1, b)
                    if (col > 0) then
                        if (m%vtype(s) == vj_revolute) then
                            rhs(e, col) = rhs(e, col) + dot_product(st%lu(:, s), cross(c - st%lo(:, s), f0))
                        else
                            rhs(e, col) = rhs(e, col) + dot_product(st%lu(:, s), f0)
                        end if
                    end if
                    if (m%vtype(s) == vj_revolute) then
                        do k = 1, 3
                            col = bodycol(1 + k, b)
                            if (col == 0) cycle
                            r = st%br(:, k, b)
                            rhs(e, col) = rhs(e, col) + dot_product(st%lu(:, s), cross(r, fb))
                        end do
                    end if
                end if
                s = m%parent(s)
            end do
        end do
    end subroutine body_rhs

end submodule sk_tree_grav
