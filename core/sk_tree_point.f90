!> The elastostatic compliance of a point of the tree model (sk_tree's
!> module header): how the point moves per unit elastic coordinate at a
!> state without deflection (point_twists: the columns of G, twists about
!> the point in base axes), its compliance sum over the elastic blocks of
!> G_k D_k G_k^T with D_k the tangent of block k's law at zero load
!> (point_compliance; the laws are sk_laws'), and the stiffness, the
!> inverse of a compliance where it exists (compliance_stiffness). A serial
!> chain's tool compliance (klimchik eq. 2-3, sk_chain_tree) is this, on
!> the tree model of the chain.
module sk_tree_point
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: sym_eig, spd_inverse, all_finite
    use sk_small_sym, only: psd_defect, psd_tol
    use sk_rotation, only: cross
    use sk_laws, only: law_derivs, law_nslot
    use sk_spatial, only: nsym
    use sk_tree_check, only: vj_revolute
    use sk_tree_model, only: tree_model, tree_state, ancestor, state_init
    use sk_tree_equil, only: posture_values, deflected_frames
    implicit none
    private
    public :: point_twists, point_compliance, compliance_stiffness, compliance_batch, twists_at

contains

    !> g[6,ne]: the motion of the point x (base coordinates) riding on
    !> joint vj per unit elastic coordinate e at the frames of st: (the
    !> point's translation, the rotation), base axes; zero for a coordinate
    !> whose joint is not at or above vj. A revolute coordinate turns about
    !> its joint's axis, a prismatic one slides along it.
    pure subroutine point_twists(m, st, vj, x, g)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: vj
        real(dp), intent(in) :: x(3)
        real(dp), intent(out) :: g(:, :)
        real(dp) :: u(3)
        integer :: e, v
        do e = 1, m%ne
            v = m%evj(e)
            g(:, e) = 0.0_dp
            if (.not. ancestor(m, v, vj)) cycle
            u = matmul(st%rb(:, :, v), m%axis(:, v))
            if (m%vtype(v) == vj_revolute) then
                g(1:3, e) = cross(u, x - st%pb(:, v))
                g(4:6, e) = u
            else
                g(1:3, e) = u
            end if
        end do
    end subroutine point_twists

    !> Compliance c[6,6] of the frame of joint vj (about its origin, base
    !> axes) at the state st (frames without deflection, law parameters
    !> st%par): sum over the blocks k of G_k D_k G_k^T, D_k = d delta/dw of
    !> block k's law at zero load (sk_laws%law_derivs), G = point_twists;
    !> symmetrised. Optional ok: every block's D is positive semi-definite
    !> (a negative compliance is no spring); the 6-dof blocks' only when
    !> check6 (default true: an eigenvalue problem per block).
    pure subroutine point_compliance(m, st, vj, c, ok, check6)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: vj
        real(dp), intent(out) :: c(6, 6)
        logical, intent(out), optional :: ok
        logical, intent(in), optional :: check6
        logical :: six
        real(dp) :: g(6, m%ne), d(6, 6), dpar(6, nsym), dval(6), w(6), gk(6, 6)
        integer :: k, e0, n, a, b
        call point_twists(m, st, vj, st%pa(:, vj), g)
        c = 0.0_dp
        w = 0.0_dp
        if (present(ok)) ok = .true.
        six = .true.
        if (present(check6)) six = check6
        do k = 1, m%nk
            e0 = m%kfirst(k)
            n = m%kdim(k)
            call law_derivs(m%ktype(k), st%par(:, k), m%kw0(k), st%val(m%evj(e0)), w(1:n), d(1:n, 1:n), &
                dpar(1:n, 1:law_nslot(m%ktype(k))), dval(1:n))
            if (present(ok)) then
                if (n == 1) then
                    if (d(1, 1) < 0.0_dp) ok = .false.
                else if (six) then
                    if (psd_defect(6, d) < -psd_tol) ok = .false.
                end if
            end if
            if (n == 1) then
                do b = 1, 6
                    do a = 1, 6
                        c(a, b) = c(a, b) + d(1, 1)*g(a, e0)*g(b, e0)
                    end do
                end do
            else
                ! fixed 6x6 shapes: the compiler inlines these products
                gk = g(:, e0:e0 + 5)
                c = c + matmul(matmul(gk, d), transpose(gk))
            end if
        end do
        c = 0.5_dp*(c + transpose(c))
    end subroutine point_compliance

    !> Stiffness k[6,6] = c^-1 of a compliance c[6,6] where c is positive
    !> definite (Cholesky succeeds and trace(c) trace(k), a bound on the
    !> condition number, stays below 1e13: kinfo = sk_ok, rank 6), else k =
    !> 0, kinfo = sk_err_singular and rank the numerical rank of c
    !> (eigenvalues above 1e-12 of the largest). info: sk_ok or the
    !> eigensolver's failure.
    subroutine compliance_stiffness(c, k, rank, kinfo, info)
        real(dp), intent(in) :: c(6, 6)
        real(dp), intent(out) :: k(6, 6)
        integer(ip), intent(out) :: rank, kinfo, info
        real(dp) :: v(6, 6), ev(6)
        integer :: i
        k = 0.0_dp
        rank = 0
        kinfo = sk_ok
        call spd_inverse(c, v, info)
        if (info == sk_ok) then
            if (sum([(c(i, i), i = 1, 6)])*sum([(v(i, i), i = 1, 6)]) >= 1.0e13_dp) info = sk_err_singular
        end if
        if (info == sk_ok) then
            k = v
            rank = 6
            return
        end if
        call sym_eig(c, ev, v, info)
        if (info /= sk_ok) return
        rank = count(ev > 1.0e-12_dp*max(maxval(abs(ev)), tiny(1.0_dp)))
        kinfo = sk_err_singular
    end subroutine compliance_stiffness

    !> Compliance c[6,6,np] of the frame of joint frame (1..nv; base axes,
    !> about its origin) at np postures q[ndof,np] with the parameters
    !> theta[npar], those of the list vidx[nvar] taking each posture's
    !> values vval[nvar,np] (a law's value that varies from posture to
    !> posture): point_compliance at the undeflected frames, every law's
    !> tangent at zero load; the stiffness k, rank and kinfo of each
    !> posture (compliance_stiffness). info: sk_ok, sk_err_size,
    !> sk_err_argument (frame, vidx), sk_err_nonfinite, sk_err_indefinite
    !> (a block's compliance with a negative eigenvalue: no spring),
    !> sk_err_overflow.
    subroutine compliance_batch(m, theta, vidx, vval, frame, q, c, k, rank, kinfo, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), vval(:, :), q(:, :)
        integer(ip), intent(in) :: vidx(:)
        integer, intent(in) :: frame
        real(dp), intent(out) :: c(:, :, :), k(:, :, :)
        integer(ip), intent(out) :: rank(:), kinfo(:), info
        type(tree_state) :: st
        real(dp) :: th(size(theta))
        integer :: ipost, kb
        logical :: ok, vary6
        c = 0.0_dp
        k = 0.0_dp
        rank = 0
        kinfo = 0
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(q, 1) /= m%ndof .or. size(vval, 1) /= size(vidx) &
            .or. size(vval, 2) /= size(q, 2)) return
        info = sk_err_argument
        if (frame < 1 .or. frame > m%nv .or. any(vidx < 1) .or. any(vidx > m%npar)) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(vval) .and. all_finite(q))) return
        ! a 6-dof block's compliance is the same at every posture unless one
        ! of its parameters varies: its check once
        vary6 = .false.
        do kb = 1, m%nk
            if (m%kdim(kb) == 6) vary6 = vary6 .or. any([(any(m%kpar(:, kb) == vidx(ipost)), ipost = 1, size(vidx))])
        end do
        call state_init(m, st)
        th = theta
        do ipost = 1, size(q, 2)
            th(vidx) = vval(:, ipost)
            call posture_values(m, th, q(:, ipost), st)
            st%delta = 0.0_dp
            call deflected_frames(m, st)
            call point_compliance(m, st, frame, c(:, :, ipost), ok, ipost == 1 .or. vary6)
            if (.not. ok) then
                info = sk_err_indefinite
                return
            end if
            call compliance_stiffness(c(:, :, ipost), k(:, :, ipost), rank(ipost), kinfo(ipost), info)
            if (info /= sk_ok) return
        end do
        info = sk_ok
        if (.not. (all_finite(c) .and. all_finite(k))) info = sk_err_overflow
    end subroutine compliance_batch

    !> g[6,ne]: the twists of the frame of joint frame (about its origin,
    !> base axes) per unit elastic coordinate (point_twists) at posture
    !> q[ndof] with the parameters theta[npar], undeflected: the columns of
    !> every spring's Jacobian. info: sk_ok, sk_err_size, sk_err_argument
    !> (frame), sk_err_nonfinite.
    subroutine twists_at(m, theta, frame, q, g, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:)
        integer, intent(in) :: frame
        real(dp), intent(out) :: g(:, :)
        integer(ip), intent(out) :: info
        type(tree_state) :: st
        g = 0.0_dp
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(q) /= m%ndof .or. size(g, 1) /= 6 .or. size(g, 2) /= m%ne) return
        info = sk_err_argument
        if (frame < 1 .or. frame > m%nv) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(q))) return
        call state_init(m, st)
        call posture_values(m, theta, q, st)
        st%delta = 0.0_dp
        call deflected_frames(m, st)
        call point_twists(m, st, frame, st%pa(:, frame), g)
        info = sk_ok
    end subroutine twists_at

end module sk_tree_point
