!> The elastostatic equilibrium of a tree model at one posture (sk_tree's
!> module header, "Gravity", "Equilibrium" and "Derivatives"): the
!> generalised gravity forces from per-subtree aggregates (load_state),
!> their derivatives G, the fixed point delta = law(w(delta))
!> (solve_posture) and the sensitivity of the deflections to parameters
!> and joint coordinates, (I - D G_ee) Z = D G_e,xi + dlaw/dparams
!> (elastic_sensitivity). The laws are sk_laws'.
module sk_tree_equil
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: lu_factor, lu_solve
    use sk_rotation, only: cross
    use sk_spatial, only: nsym
    use sk_laws, only: law_delta, law_derivs, law_nslot
    use sk_tree_check, only: vj_revolute, vj_prismatic
    use sk_tree_model, only: tree_model, tree_state, tree_frames, ancestor, body_effective, body_rhs
    implicit none
    private
    public :: load_state, deflected_frames, apply_laws, posture_values, deflection_change
    public :: solve_posture, elastic_sensitivity

contains

    ! ---------------------------------------------------------------- loads

    !> Loads of the current frames: per-subtree aggregates (force, first
    !> moment, payload moment), and for the joints st%need: axes, origins,
    !> generalised forces wv and the coefficients of G (gpair). Payloads
    !> lvj(lsel(:)), lw(:, lsel(:)). elastic_only: the aggregates and the
    !> per-joint part of the elastic joints only (what an iteration of the
    !> equilibrium reads; the other joints' entries are left as they were).
    pure subroutine load_state(m, st, lsel, lvj, lw, elastic_only)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        integer, intent(in) :: lsel(:)
        integer(ip), intent(in) :: lvj(:)
        real(dp), intent(in) :: lw(:, :)
        logical, intent(in), optional :: elastic_only
        real(dp) :: c(3), fb(3)
        integer :: b, v, p, i, l, a, f
        logical :: only
        only = .false.
        if (present(elastic_only)) only = elastic_only
        ! the aggregates of every joint, or (only) of the elastic ones, each
        ! load entered at the nearest elastic joint above it (m%eanc)
        if (only) then
            do i = 1, m%ne
                v = m%elist(i)
                st%f(:, v) = 0.0_dp
                st%s(:, :, v) = 0.0_dp
                st%mp(:, v) = 0.0_dp
            end do
        else
            st%f = 0.0_dp
            st%s = 0.0_dp
            st%mp = 0.0_dp
        end if
        do b = 1, m%nb
            f = m%bvj(b)
            if (f == 0) cycle
            c = st%pa(:, f) + matmul(st%ra(:, :, f), st%bc(:, b))
            st%cb(:, b) = c
            st%br(:, :, b) = st%ra(:, :, f)
            v = merge(m%eanc(f), f, only)
            if (v == 0) cycle
            fb = st%bm(b)*m%grav
            st%f(:, v) = st%f(:, v) + fb
            do a = 1, 3
                st%s(:, a, v) = st%s(:, a, v) + c*fb(a)
            end do
        end do
        do i = 1, size(lsel)
            l = lsel(i)
            f = lvj(l)
            if (f == 0) cycle
            v = merge(m%eanc(f), f, only)
            if (v == 0) cycle
            st%f(:, v) = st%f(:, v) + lw(1:3, l)
            do a = 1, 3
                st%s(:, a, v) = st%s(:, a, v) + st%pa(:, f)*lw(a, l)
            end do
            st%mp(:, v) = st%mp(:, v) + lw(4:6, l)
        end do
        if (only) then
            do i = m%ne, 1, -1
                v = m%elist(i)
                p = m%eanc(m%parent(v))
                if (p == 0) cycle
                st%f(:, p) = st%f(:, p) + st%f(:, v)
                st%s(:, :, p) = st%s(:, :, p) + st%s(:, :, v)
                st%mp(:, p) = st%mp(:, p) + st%mp(:, v)
            end do
        else
            do v = m%nv, 1, -1
                p = m%parent(v)
                if (p == 0) cycle
                st%f(:, p) = st%f(:, p) + st%f(:, v)
                st%s(:, :, p) = st%s(:, :, p) + st%s(:, :, v)
                st%mp(:, p) = st%mp(:, p) + st%mp(:, v)
            end do
        end if
        call joint_loads(m, st, only)
    end subroutine load_state

    !> The per-joint part of load_state from the aggregates: for the joints
    !> st%need (the elastic ones only when elastic_only), axes, origins,
    !> generalised forces wv and the coefficients of G.
    pure subroutine joint_loads(m, st, elastic_only)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        logical, intent(in) :: elastic_only
        real(dp) :: u(3), mv(3)
        integer :: v
        do v = 1, m%nv
            if (.not. st%need(v)) cycle
            if (elastic_only .and. m%vel(v) == 0) cycle
            u = matmul(st%rb(:, :, v), m%axis(:, v))
            st%lu(:, v) = u
            st%lo(:, v) = st%pb(:, v)
            select case (m%vtype(v))
            case (vj_revolute)
                mv = [st%s(2, 3, v) - st%s(3, 2, v), st%s(3, 1, v) - st%s(1, 3, v), &
                    st%s(1, 2, v) - st%s(2, 1, v)] + st%mp(:, v) - cross(st%pb(:, v), st%f(:, v))
                st%wv(v) = dot_product(u, mv)
                st%gh(:, v) = matmul(st%s(:, :, v), u) - st%pb(:, v)*dot_product(st%f(:, v), u) &
                    - u*(st%s(1, 1, v) + st%s(2, 2, v) + st%s(3, 3, v) - dot_product(st%f(:, v), st%pb(:, v)))
                st%ghm(:, v) = st%gh(:, v) + cross(u, st%mp(:, v))
            case (vj_prismatic)
                st%wv(v) = dot_product(u, st%f(:, v))
                st%gh(:, v) = cross(u, st%f(:, v))
                st%ghm(:, v) = st%gh(:, v)
            case default
                st%wv(v) = 0.0_dp
            end select
        end do
    end subroutine joint_loads

    !> G(s, a) = dw_s/dval_a at the load state (module header), from the
    !> coefficients of the distal joint d (load_state) and the axis of the
    !> proximal one p (gprox).
    pure function gpair(m, st, s, a) result(g)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: s, a
        real(dp) :: g
        g = 0.0_dp
        if (ancestor(m, a, s)) then
            if (m%vtype(a) == vj_revolute) g = gprox(st, a, s, a /= s)
        else if (ancestor(m, s, a)) then
            if (m%vtype(s) == vj_revolute) g = gprox(st, s, a, .false.)
        end if
    end function gpair

    !> G of a revolute proximal joint p and a distal d: G = u_p . h_d with
    !>   h_d = S_d u_d - o_d (F_d . u_d) - u_d (tr S_d - F_d . o_d)
    !> (u_p^T S_d u_d - (u_p . o_d)(F_d . u_d) - (u_p . u_d)(tr S_d - F_d . o_d)),
    !> plus u_p . (u_d x M_d), the payload moments, when the force is d's
    !> and p /= d (moment); a prismatic d has h_d = u_d x F_d.
    pure real(dp) function gprox(st, p, d, moment) result(g)
        type(tree_state), intent(in) :: st
        integer, intent(in) :: p, d
        logical, intent(in) :: moment
        if (moment) then
            g = st%lu(1, p)*st%ghm(1, d) + st%lu(2, p)*st%ghm(2, d) + st%lu(3, p)*st%ghm(3, d)
        else
            g = st%lu(1, p)*st%gh(1, d) + st%lu(2, p)*st%gh(2, d) + st%lu(3, p)*st%gh(3, d)
        end if
    end function gprox

    ! ---------------------------------------------------------------- equilibrium

    !> Frames at the values st%val plus the deflections st%delta.
    pure subroutine deflected_frames(m, st)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        real(dp) :: vt(m%nv)
        integer :: e
        vt = st%val
        do e = 1, m%ne
            vt(m%evj(e)) = vt(m%evj(e)) + st%delta(e)
        end do
        call tree_frames(m%parent, m%vtype, m%rot, m%pos, m%axis, vt, st%rb, st%pb, st%ra, st%pa, &
            st%cval, st%cmot, st%cok)
    end subroutine deflected_frames

    !> Deflections dn[ne] that the laws give for the current forces st%wv.
    pure subroutine apply_laws(m, st, dn)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        real(dp), intent(out) :: dn(:)
        real(dp) :: w(6)
        integer :: k, e0, n, i
        do k = 1, m%nk
            e0 = m%kfirst(k)
            n = m%kdim(k)
            do i = 1, n
                w(i) = st%wv(m%evj(e0 + i - 1))
            end do
            call law_delta(m%ktype(k), st%par(:, k), m%kw0(k), st%val(m%evj(e0)), w(1:n), dn(e0:e0 + n - 1))
        end do
    end subroutine apply_laws

    !> Values of the joints without deflection and the law parameters at
    !> posture q[ndof] (the start of every posture).
    pure subroutine posture_values(m, theta, q, st)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:)
        type(tree_state), intent(inout) :: st
        integer :: v, k, j
        do v = 1, m%nv
            st%val(v) = m%qconst(v)
            if (m%qcol(v) > 0) st%val(v) = st%val(v) + m%qcoef(v)*q(m%qcol(v))
            do k = m%gstart(v), m%gstart(v + 1) - 1
                st%val(v) = st%val(v) + m%gcoef(k)*theta(m%gpar(k))
            end do
        end do
        do k = 1, m%nk
            do j = 1, nsym
                st%par(j, k) = 0.0_dp
                if (m%kpar(j, k) > 0) st%par(j, k) = theta(m%kpar(j, k))
            end do
        end do
        if (m%nbp > 0) call body_effective(m, theta, st%bm, st%bc, st%bdm)
    end subroutine posture_values

    !> How far a change dd[ne] of the deflections moves a point, at most
    !> (first order): sum |dd_e| * lscale (revolute) or |dd_e| (prismatic).
    pure real(dp) function deflection_change(m, dd) result(ch)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: dd(:)
        integer :: e
        ch = 0.0_dp
        do e = 1, m%ne
            ch = ch + abs(dd(e))*merge(m%lscale, 1.0_dp, m%vtype(m%evj(e)) == vj_revolute)
        end do
    end function deflection_change

    !> Solve one posture q[ndof]: values, frames, loads and deflections
    !> (module header; eqit 0 rigid, 1 first order, >= 2 iterated to etol
    !> metres). Payloads lvj(lsel(:)), lw(:, lsel(:)). warm: start the
    !> iteration from st%delta. On return st%conv says whether the
    !> iteration met etol within eqit steps (st%nit frame evaluations); the
    !> state is consistent (frames at st%delta) either way.
    subroutine solve_posture(m, theta, q, lsel, lvj, lw, eqit, etol, warm, st)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:), lw(:, :), etol
        integer, intent(in) :: lsel(:)
        integer(ip), intent(in) :: lvj(:), eqit
        logical, intent(in) :: warm
        type(tree_state), intent(inout) :: st
        real(dp) :: dn(m%ne), ch
        integer :: it
        call posture_values(m, theta, q, st)
        st%eqit = eqit
        st%conv = .true.
        st%nit = 1
        if (.not. warm .or. eqit <= 1) st%delta = 0.0_dp
        if (eqit <= 0 .or. m%ne == 0) then
            st%delta = 0.0_dp
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw)
            return
        end if
        if (eqit == 1) then
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw)
            call apply_laws(m, st, st%delta)
            call deflected_frames(m, st)
            return
        end if
        ! the iterations read the elastic joints' forces only; every load is
        ! taken once more, in full, at the frames the iteration stops at
        do it = 1, eqit
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw, elastic_only=.true.)
            call apply_laws(m, st, dn)
            st%nit = it
            ch = deflection_change(m, dn - st%delta)
            st%conv = ch <= etol
            if (st%conv .or. it == eqit .or. .not. ch < huge(1.0_dp)) exit
            st%delta = dn
        end do
        call load_state(m, st, lsel, lvj, lw)
    end subroutine solve_posture

    !> Sensitivity z[ne,ncol] of the deflections to ncol drivers at a solved
    !> posture: driver entries k = 1..size(ent_vj) say that driver
    !> ent_col(k) moves joint ent_vj(k) by ent_coef(k) per unit; lawcol
    !> [21,nk] names the driver of each law-parameter slot (0: none).
    !> Solves (I - D G_ee) z = D G_e,drivers + dlaw/dparams (first order:
    !> z = the right-hand side; rigid: z = 0). With resid[ne] (st%eqit >= 2
    !> only), also y = (I - D G_ee)^-1 resid, the Newton correction of an
    !> equilibrium residual, with the same factors. reuse: keep the factors
    !> of I - D G_ee of the previous call (a chord step of a Newton
    !> iteration whose pose moved little; the right-hand side is current).
    !> adjoint: return the right-hand side in z and leave I - D G_ee
    !> factored in st%amat, st%ipiv (st%eqit >= 2) for a transposed solve
    !> of the caller's few rows (lu_solve).
    !> info = sk_err_singular when I - D G_ee is singular (an unstable
    !> equilibrium).
    subroutine elastic_sensitivity(m, st, ent_vj, ent_col, ent_coef, lawcol, z, info, resid, y, reuse, adjoint, &
            bodycol)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        integer, intent(in) :: ent_vj(:), ent_col(:), lawcol(:, :)
        real(dp), intent(in) :: ent_coef(:)
        real(dp), intent(out) :: z(:, :)
        integer(ip), intent(out) :: info
        real(dp), intent(in), optional :: resid(:)
        real(dp), intent(out), optional :: y(:)
        logical, intent(in), optional :: reuse, adjoint
        !> Z columns of the gravity-parameter entries [nbp] (problem_setup)
        integer, intent(in), optional :: bodycol(:)
        real(dp) :: dmat(6, 6), dpar(6, nsym), dval(6), w(6)
        integer :: ne, ncol, nc, e, k, n, e0, j, a, c, i, d
        logical :: factor
        ne = m%ne
        ncol = size(z, 2)
        nc = ncol + merge(1, 0, present(resid))
        info = sk_ok
        if (ne == 0 .or. st%eqit <= 0 .or. nc == 0) then
            z = 0.0_dp
            if (present(y)) y = 0.0_dp
            return
        end if
        if (present(y) .and. st%eqit < 2) y = 0.0_dp
        factor = st%eqit >= 2
        if (present(reuse)) factor = factor .and. .not. reuse
        if (allocated(st%rhs)) then
            if (size(st%rhs, 2) /= nc) deallocate(st%rhs)
        end if
        if (.not. allocated(st%rhs)) allocate(st%rhs(ne, nc))
        ! G of the drivers, in the columns of the right-hand side
        st%rhs = 0.0_dp
        do k = 1, size(ent_vj)
            a = ent_vj(k)
            c = ent_col(k)
            do e = 1, ne
                st%rhs(e, c) = st%rhs(e, c) + ent_coef(k)*gpair(m, st, m%evj(e), a)
            end do
        end do
        if (present(bodycol)) call body_rhs(m, st, bodycol, st%rhs)
        if (factor) then
            ! G_ee is symmetric but for the payload moments (in the
            ! entries of a force distal to a value)
            do j = 1, ne
                a = m%evj(j)
                do e = j, ne
                    d = m%evj(e)
                    select case (m%erel(e, j))
                    case (1)
                        st%gee(j, e) = gprox(st, a, d, .false.)
                        st%gee(e, j) = st%gee(j, e)
                        if (e /= j) st%gee(e, j) = gprox(st, a, d, .true.)
                    case (2)
                        st%gee(e, j) = gprox(st, d, a, .false.)
                        st%gee(j, e) = gprox(st, d, a, .true.)
                    case default
                        st%gee(e, j) = 0.0_dp
                        st%gee(j, e) = 0.0_dp
                    end select
                end do
            end do
        end if
        do k = 1, m%nk
            e0 = m%kfirst(k)
            n = m%kdim(k)
            do i = 1, n
                w(i) = st%wv(m%evj(e0 + i - 1))
            end do
            call law_derivs(m%ktype(k), st%par(:, k), m%kw0(k), st%val(m%evj(e0)), w(1:n), dmat(1:n, 1:n), &
                dpar(1:n, :), dval(1:n))
            if (n == 1) then
                z(e0, :) = dmat(1, 1)*st%rhs(e0, 1:ncol)
                if (factor) st%amat(e0, :) = -dmat(1, 1)*st%gee(e0, :)
            else
                z(e0:e0 + n - 1, :) = matmul(dmat(1:n, 1:n), st%rhs(e0:e0 + n - 1, 1:ncol))
                if (factor) st%amat(e0:e0 + n - 1, :) = -matmul(dmat(1:n, 1:n), st%gee(e0:e0 + n - 1, :))
            end if
            do j = 1, law_nslot(m%ktype(k))
                c = lawcol(j, k)
                if (c > 0) z(e0:e0 + n - 1, c) = z(e0:e0 + n - 1, c) + dpar(1:n, j)
            end do
            if (any(dval(1:n) /= 0.0_dp)) then
                ! a law that depends on its joint's value: every driver that moves that joint
                do j = 1, size(ent_vj)
                    if (ent_vj(j) == m%evj(e0)) z(e0:e0 + n - 1, ent_col(j)) = z(e0:e0 + n - 1, ent_col(j)) &
                        + ent_coef(j)*dval(1:n)
                end do
            end if
        end do
        if (factor) then
            do e = 1, ne
                st%amat(e, e) = st%amat(e, e) + 1.0_dp
            end do
            call lu_factor(st%amat, st%ipiv, info)
            if (info /= sk_ok) return
        end if
        if (present(adjoint)) then
            if (adjoint) return
        end if
        if (st%eqit >= 2) then
            st%rhs(:, 1:ncol) = z
            if (present(resid)) st%rhs(:, nc) = resid
            call lu_solve(st%amat, st%ipiv, st%rhs)
            z = st%rhs(:, 1:ncol)
            if (present(y)) y = st%rhs(:, nc)
        end if
    end subroutine elastic_sensitivity

end module sk_tree_equil
