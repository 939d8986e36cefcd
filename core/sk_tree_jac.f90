!> Observations of a tree model and their analytic Jacobians through the
!> equilibrium (sk_tree's module header, "Derivatives" and "Markers and
!> tracker"): the tracker pose, a marker's predicted point with its
!> direct Jacobian, a frame's pose with its Jacobian w.r.t. q; and the
!> batches over postures the entry points call: poses and loads
!> (poses_batch), the observation model with its Jacobian (evaluate), the
!> frame Jacobian (frame_jacobian_batch).
module sk_tree_jac
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: eye, all_finite, lu_solve, group_by
    use sk_rotation, only: cross
    use sk_spatial, only: nsym
    use sk_tree_check, only: vj_fixed, vj_revolute
    use sk_tree_model, only: tree_model, tree_state, tree_problem, state_init, obs_position, obs_deflection
    use sk_tree_fold, only: fold_for_frames
    use sk_tree_equil, only: solve_posture, elastic_sensitivity, deflected_frames
    use sk_tree_point, only: point_twists
    implicit none
    private
    public :: tracker_pose, point_jacobian, deflection_jacobian, frame_jacobian, q_drivers
    public :: poses_batch, evaluate, frame_jacobian_batch

contains


    ! ---------------------------------------------------------------- observations

    !> Tracker rotation rt[3,3], translation tt[3] and the axes tw[3,3] (in
    !> the tracker frame) of its three screw angles.
    pure subroutine tracker_pose(m, theta, rt, tt, tw)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        real(dp), intent(out) :: rt(3, 3), tt(3), tw(3, 3)
        real(dp) :: r(3, 3)
        integer :: k
        tt = theta(m%tpar(1:3))
        r = m%rref
        do k = 1, 3
            tw(:, k) = r(:, k)
            r = matmul(r, axis_rot(k, theta(m%tpar(3 + k))))
        end do
        rt = r
    end subroutine tracker_pose

    !> Rotation by angle a about coordinate axis k.
    pure function axis_rot(k, a) result(r)
        integer, intent(in) :: k
        real(dp), intent(in) :: a
        real(dp) :: r(3, 3), c, s
        integer :: i, j
        c = cos(a)
        s = sin(a)
        i = mod(k, 3) + 1
        j = mod(k + 1, 3) + 1
        r = eye(3)
        r(i, i) = c
        r(j, j) = c
        r(j, i) = s
        r(i, j) = -s
    end function axis_rot

    !> Predicted tracker-frame point y[3] of marker mk at a solved posture,
    !> its direct Jacobian jrow[3,nfree] w.r.t. the free parameters (columns
    !> colof(theta index); the deflections held), and jdel[3,ne] = dy/ddelta
    !> (zero off the marker's path). The total Jacobian adds jdel Z, Z the
    !> deflection sensitivity (elastic_sensitivity).
    pure subroutine point_jacobian(m, st, theta, rt, tt, tw, mk, colof, y, jrow, jdel)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        real(dp), intent(in) :: theta(:), rt(3, 3), tt(3), tw(3, 3)
        integer, intent(in) :: mk, colof(:)
        real(dp), intent(out) :: y(3), jrow(:, :), jdel(:, :)
        real(dp) :: x(3), pm(3), rx(3), jx(3), jy(3), rtf(3, 3)
        integer :: f, a, k, c
        f = m%mvj(mk)
        pm = theta(m%mpar(:, mk))
        if (f > 0) then
            x = st%pa(:, f) + matmul(st%ra(:, :, f), pm)
            rtf = matmul(rt, st%ra(:, :, f))
        else
            x = pm
            rtf = rt
        end if
        rx = matmul(rt, x)
        y = rx + tt
        jrow = 0.0_dp
        jdel = 0.0_dp
        do k = 1, 3
            c = colof(m%tpar(k))
            if (c > 0) jrow(k, c) = jrow(k, c) + 1.0_dp
            c = colof(m%tpar(3 + k))
            if (c > 0) jrow(:, c) = jrow(:, c) + cross(tw(:, k), rx)
            c = colof(m%mpar(k, mk))
            if (c > 0) jrow(:, c) = jrow(:, c) + rtf(:, k)
        end do
        a = f
        do while (a > 0)
            if (m%vtype(a) /= vj_fixed) then
                jx = matmul(st%rb(:, :, a), m%axis(:, a))
                if (m%vtype(a) == vj_revolute) jx = cross(jx, x - st%pb(:, a))
                jy = matmul(rt, jx)
                do k = m%gstart(a), m%gstart(a + 1) - 1
                    c = colof(m%gpar(k))
                    if (c > 0) jrow(:, c) = jrow(:, c) + m%gcoef(k)*jy
                end do
                if (m%vel(a) > 0) jdel(:, m%vel(a)) = jy
            end if
            a = m%parent(a)
        end do
    end subroutine point_jacobian

    !> A deflection observation (sk_tree_model obs_deflection, obs_rotation:
    !> kind) of marker mk with the point pt[3] (marker frame, added to the
    !> marker's) at the undeflected frames of st under the deflections
    !> d[ne]: jdel[3,ne] the motion of the point (obs_deflection) or the
    !> rotation of the marker's frame (obs_rotation), base axes, per unit
    !> elastic coordinate (the twists of the elastic joints on its path;
    !> klimchik eqs. 4-5), y = jdel d, and jrow[3,nfree] its direct
    !> Jacobian (the marker's point, [dphi]x R, dphi the rotation).
    pure subroutine deflection_jacobian(m, st, theta, mk, pt, kind, d, colof, y, jrow, jdel)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        real(dp), intent(in) :: theta(:), pt(3), d(:)
        integer, intent(in) :: mk, kind, colof(:)
        real(dp), intent(out) :: y(3), jrow(:, :), jdel(:, :)
        real(dp) :: x(3), dphi(3), rf(3, 3), g(6, m%ne)
        integer :: f, k, c
        f = m%mvj(mk)
        rf = eye(3)
        if (f > 0) rf = st%ra(:, :, f)
        x = matmul(rf, theta(m%mpar(:, mk)) + pt)
        if (f > 0) x = x + st%pa(:, f)
        call point_twists(m, st, f, x, g)
        jdel = g(merge(1, 4, kind == obs_deflection):merge(3, 6, kind == obs_deflection), :)
        y = matmul(jdel, d)
        jrow = 0.0_dp
        if (kind /= obs_deflection) return
        dphi = matmul(g(4:6, :), d)
        do k = 1, 3
            c = colof(m%mpar(k, mk))
            if (c > 0) jrow(:, c) = jrow(:, c) + cross(dphi, rf(:, k))
        end do
    end subroutine deflection_jacobian

    !> Pose of frame f (rf[3,3], pf[3], base) at a solved posture and its
    !> Jacobian jq[6,ndof] w.r.t. the joint coordinates q: twist (velocity
    !> of the frame origin, angular velocity), base axes; zq[ne,ndof] the
    !> deflection sensitivity to q; a further column of zq (a deflection
    !> change) gives its frame motion in the same column of jq.
    pure subroutine frame_jacobian(m, st, f, zq, rf, pf, jq)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: f
        real(dp), intent(in) :: zq(:, :)
        real(dp), intent(out) :: rf(3, 3), pf(3), jq(:, :)
        real(dp) :: u(3), tw(6)
        integer :: a, e, j
        jq = 0.0_dp
        if (f == 0) then
            rf = eye(3)
            pf = 0.0_dp
            return
        end if
        rf = st%ra(:, :, f)
        pf = st%pa(:, f)
        a = f
        do while (a > 0)
            if (m%vtype(a) /= vj_fixed .and. (m%qcol(a) > 0 .or. m%vel(a) > 0)) then
                u = matmul(st%rb(:, :, a), m%axis(:, a))
                if (m%vtype(a) == vj_revolute) then
                    tw(1:3) = cross(u, pf - st%pb(:, a))
                    tw(4:6) = u
                else
                    tw(1:3) = u
                    tw(4:6) = 0.0_dp
                end if
                if (m%qcol(a) > 0) jq(:, m%qcol(a)) = jq(:, m%qcol(a)) + m%qcoef(a)*tw
                e = m%vel(a)
                if (e > 0) then
                    do j = 1, size(jq, 2)
                        jq(:, j) = jq(:, j) + tw*zq(e, j)
                    end do
                end if
            end if
            a = m%parent(a)
        end do
    end subroutine frame_jacobian

    !> Driver entries of the joint coordinates: joint v moves with q(qcol(v)).
    pure subroutine q_drivers(m, ent_vj, ent_col, ent_coef, n)
        type(tree_model), intent(in) :: m
        integer, intent(out) :: ent_vj(:), ent_col(:), n
        real(dp), intent(out) :: ent_coef(:)
        integer :: v
        n = 0
        do v = 1, m%nv
            if (m%qcol(v) == 0 .or. m%vtype(v) == vj_fixed) cycle
            n = n + 1
            ent_vj(n) = v
            ent_col(n) = m%qcol(v)
            ent_coef(n) = m%qcoef(v)
        end do
    end subroutine q_drivers

    ! ---------------------------------------------------------------- batches

    !> Poses and loads at np postures q[ndof,np] (payloads lpost, lvj, lw):
    !> frames after motion ra[3,3,nv,np], pa[3,nv,np]; generalised forces
    !> of every joint wv[nv,np] and of every joint coordinate
    !> tauq[ndof,np] = sum_v qcoef_v wv_v over the joints on column q_j (the
    !> gravity torque of an actuated joint, its mimic followers included),
    !> both at the load state (delta = 0 for eqit <= 1); deflections
    !> delta[ne,np]; iterations nit[np]; eqinfo[np] = sk_err_noconv where
    !> the equilibrium missed etol (then info = sk_err_noconv too, with
    !> every output filled).
    subroutine poses_batch(m, theta, q, lpost, lvj, lw, eqit, etol, ra, pa, wv, tauq, delta, nit, eqinfo, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:, :), lw(:, :), etol
        integer(ip), intent(in) :: lpost(:), lvj(:), eqit
        real(dp), intent(out) :: ra(:, :, :, :), pa(:, :, :), wv(:, :), tauq(:, :), delta(:, :)
        integer(ip), intent(out) :: nit(:), eqinfo(:), info
        type(tree_state) :: st
        integer, allocatable :: lstart(:), lidx(:)
        integer :: ipost, np, v
        np = size(q, 2)
        ra = 0.0_dp
        pa = 0.0_dp
        wv = 0.0_dp
        tauq = 0.0_dp
        delta = 0.0_dp
        nit = 0
        eqinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(q, 1) /= m%ndof .or. size(lvj) /= size(lpost) &
            .or. any(shape(lw) /= [6, size(lpost)]) .or. any(shape(ra) /= [3, 3, m%nv, np]) &
            .or. any(shape(pa) /= [3, m%nv, np]) .or. any(shape(wv) /= [m%nv, np]) &
            .or. any(shape(tauq) /= [m%ndof, np]) .or. any(shape(delta) /= [m%ne, np]) &
            .or. size(nit) /= np .or. size(eqinfo) /= np) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(q) .and. all_finite(lw) .and. etol == etol)) return
        info = sk_err_argument
        if (any(lvj < 0) .or. any(lvj > m%nv)) return
        call group_by(lpost, np, lstart, lidx, info)
        if (info /= sk_ok) return
        call state_init(m, st)
        do ipost = 1, np
            call solve_posture(m, theta, q(:, ipost), lidx(lstart(ipost):lstart(ipost + 1) - 1), lvj, lw, &
                eqit, etol, .false., st)
            ra(:, :, :, ipost) = st%ra
            pa(:, :, ipost) = st%pa
            wv(:, ipost) = st%wv
            do v = 1, m%nv
                if (m%qcol(v) > 0) tauq(m%qcol(v), ipost) = tauq(m%qcol(v), ipost) + m%qcoef(v)*st%wv(v)
            end do
            delta(:, ipost) = st%delta
            nit(ipost) = st%nit
            if (.not. st%conv) eqinfo(ipost) = sk_err_noconv
        end do
        info = merge(sk_ok, sk_err_noconv, all(eqinfo == sk_ok))
    end subroutine poses_batch

    !> Predicted points pred[3,nobs] (tracker frame), weighted residuals
    !> res[3*nobs] = sqrt(w_i) (pred_i - measured_i) (rows 3i-2..3i) and,
    !> when want_jac, their Jacobian jac[3*nobs,nfree] w.r.t. theta(free)
    !> (total derivatives through the equilibrium); deflections
    !> delta[ne,np], iterations nit[np], eqinfo[np] as in poses_batch.
    !> info: sk_ok, sk_err_noconv (some posture missed etol; outputs
    !> filled), sk_err_singular (an unstable equilibrium), size/NaN codes.
    !> Optional warm[ne,np]: deflections to start each posture's iteration
    !> from (eqit >= 2), e.g. those at a nearby theta; the fixed point and
    !> the tolerance are the same, only fewer steps are taken. A posture
    !> whose observations are deflections (pr%pdefl; sk_tree_model obs_*)
    !> is solved at first order whatever eqit, and its rows are
    !> deflection_jacobian's at the undeflected frames (pred: base axes).
    subroutine evaluate(pr, theta, eqit, etol, want_jac, pred, res, jac, delta, nit, eqinfo, info, warm)
        type(tree_problem), intent(in) :: pr
        real(dp), intent(in) :: theta(:), etol
        integer(ip), intent(in) :: eqit
        logical, intent(in) :: want_jac
        real(dp), intent(out) :: pred(:, :), res(:), jac(:, :), delta(:, :)
        integer(ip), intent(out) :: nit(:), eqinfo(:), info
        real(dp), intent(in), optional :: warm(:, :)
        type(tree_state) :: st
        real(dp) :: rt(3, 3), tt(3), tw(3, 3), y(3)
        real(dp), allocatable :: b(:, :), jrow(:, :), lam(:, :), jd(:, :), jz(:, :)
        logical :: need(pr%m%nv)
        integer :: ipost, k, i, r0, nrow, ne, j, maxrow
        integer(ip) :: sinfo
        pred = 0.0_dp
        res = 0.0_dp
        jac = 0.0_dp
        delta = 0.0_dp
        nit = 0
        eqinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= pr%m%npar .or. any(shape(pred) /= [3, pr%nobs]) .or. size(res) /= 3*pr%nobs &
            .or. any(shape(delta) /= [pr%m%ne, pr%np]) .or. size(nit) /= pr%np .or. size(eqinfo) /= pr%np) return
        if (want_jac .and. any(shape(jac) /= [3*pr%nobs, pr%nfree])) return
        if (present(warm)) then
            if (any(shape(warm) /= [pr%m%ne, pr%np])) return
        end if
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. etol == etol)) return
        if (present(warm)) then
            if (.not. all_finite(warm)) return
        end if
        need = .false.
        need(pr%ent_vj) = .true.
        call state_init(pr%m, st, need)
        call tracker_pose(pr%m, theta, rt, tt, tw)
        ne = pr%m%ne
        maxrow = 0
        do ipost = 1, pr%np
            maxrow = max(maxrow, 3*(pr%ostart(ipost + 1) - pr%ostart(ipost)))
        end do
        allocate(b(ne, pr%nz), jrow(3, pr%nfree), lam(ne, maxrow), jd(3, ne), jz(maxrow, pr%nz))
        info = sk_ok
        do ipost = 1, pr%np
            if (present(warm)) st%delta = warm(:, ipost)
            call solve_posture(pr%m, theta, pr%q(:, ipost), pr%lidx(pr%lstart(ipost):pr%lstart(ipost + 1) - 1), &
                pr%lvj, pr%lw, merge(1_ip, eqit, pr%pdefl(ipost)), etol, present(warm), st)
            delta(:, ipost) = st%delta
            if (pr%pdefl(ipost)) then
                ! the undeflected frames (the loads and laws stay at delta = 0)
                st%delta = 0.0_dp
                call deflected_frames(pr%m, st)
            end if
            nit(ipost) = st%nit
            if (.not. st%conv) eqinfo(ipost) = sk_err_noconv
            if (pr%ostart(ipost + 1) == pr%ostart(ipost)) cycle
            ! deflection part by the adjoint: rows J_delta (I - D G)^-1 B with
            ! B the drivers' right-hand side (few rows, many parameters)
            if (want_jac) then
                call elastic_sensitivity(pr%m, st, pr%ent_vj, pr%ent_col, pr%ent_coef, pr%lawcol, b, sinfo, &
                    adjoint=.true., bodycol=pr%bodycol)
                if (sinfo /= sk_ok) then
                    info = sinfo
                    return
                end if
            end if
            nrow = 0
            do k = pr%ostart(ipost), pr%ostart(ipost + 1) - 1
                i = pr%oidx(k)
                if (pr%okind(i) == obs_position) then
                    call point_jacobian(pr%m, st, theta, rt, tt, tw, pr%omark(i), pr%colof, y, jrow, jd)
                else
                    call deflection_jacobian(pr%m, st, theta, pr%omark(i), pr%opt(:, i), pr%okind(i), &
                        delta(:, ipost), pr%colof, y, jrow, jd)
                end if
                lam(:, nrow + 1:nrow + 3) = transpose(jd)
                nrow = nrow + 3
                pred(:, i) = y
                r0 = 3*(i - 1)
                res(r0 + 1:r0 + 3) = pr%osw(i)*(y - pr%oxyz(:, i))
                if (want_jac) jac(r0 + 1:r0 + 3, :) = pr%osw(i)*jrow
            end do
            if (.not. want_jac .or. ne == 0 .or. pr%nz == 0) cycle
            ! lam holds J_delta^T; (I - D G)^-T J_delta^T when iterated
            if (st%eqit >= 2) call lu_solve(st%amat, st%ipiv, lam(:, 1:nrow), transposed=.true.)
            ! the posture's rows of the deflection part at once: lam^T B
            jz(1:nrow, :) = matmul(transpose(lam(:, 1:nrow)), b)
            nrow = 0
            do k = pr%ostart(ipost), pr%ostart(ipost + 1) - 1
                i = pr%oidx(k)
                r0 = 3*(i - 1)
                do j = 1, pr%nz
                    jac(r0 + 1:r0 + 3, pr%zcol(j)) = jac(r0 + 1:r0 + 3, pr%zcol(j)) + pr%osw(i)*jz(nrow + 1:nrow + 3, j)
                end do
                nrow = nrow + 3
            end do
        end do
        if (any(eqinfo /= sk_ok)) info = sk_err_noconv
    end subroutine evaluate

    !> Pose of frame frame(i) (rf[3,3,n], pf[3,n], base) at postures
    !> q[ndof,n] at equilibrium, and its Jacobian jq[6,ndof,n] w.r.t. q
    !> (total, through the equilibrium); payloads lpost (1..n), lvj, lw.
    !> nit, eqinfo, info as in poses_batch. Computed on the model with its
    !> constant joints folded (model_fold).
    subroutine frame_jacobian_batch(m, theta, frame, q, lpost, lvj, lw, eqit, etol, rf, pf, jq, delta, &
            nit, eqinfo, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:, :), lw(:, :), etol
        integer(ip), intent(in) :: frame(:), lpost(:), lvj(:), eqit
        real(dp), intent(out) :: rf(:, :, :), pf(:, :), jq(:, :, :), delta(:, :)
        integer(ip), intent(out) :: nit(:), eqinfo(:), info
        type(tree_state) :: st
        integer, allocatable :: lstart(:), lidx(:)
        integer :: ent_vj(m%nv), ent_col(m%nv), nent, ipost, n, newidx(0:m%nv)
        integer(ip) :: lvjf(size(lvj))
        type(tree_model) :: mf
        real(dp) :: ent_coef(m%nv), zq(m%ne, m%ndof)
        integer :: lawcol(nsym, m%nk)
        n = size(q, 2)
        rf = 0.0_dp
        pf = 0.0_dp
        jq = 0.0_dp
        delta = 0.0_dp
        nit = 0
        eqinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(q, 1) /= m%ndof .or. size(frame) /= n .or. size(lvj) /= size(lpost) &
            .or. any(shape(lw) /= [6, size(lpost)]) .or. any(shape(rf) /= [3, 3, n]) &
            .or. any(shape(pf) /= [3, n]) .or. any(shape(jq) /= [6, m%ndof, n]) &
            .or. any(shape(delta) /= [m%ne, n]) .or. size(nit) /= n .or. size(eqinfo) /= n) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(q) .and. all_finite(lw) .and. etol == etol)) return
        info = sk_err_argument
        if (any(frame < 0) .or. any(frame > m%nv) .or. any(lvj < 0) .or. any(lvj > m%nv)) return
        call group_by(lpost, n, lstart, lidx, info)
        if (info /= sk_ok) return
        call fold_for_frames(m, theta, frame, lvj, mf, newidx, info)
        if (info /= sk_ok) return
        lvjf = newidx(lvj)
        call q_drivers(mf, ent_vj, ent_col, ent_coef, nent)
        lawcol = 0
        call state_init(mf, st, mf%qcol > 0)
        do ipost = 1, n
            call solve_posture(mf, theta, q(:, ipost), lidx(lstart(ipost):lstart(ipost + 1) - 1), lvjf, lw, &
                eqit, etol, .false., st)
            call elastic_sensitivity(mf, st, ent_vj(1:nent), ent_col(1:nent), ent_coef(1:nent), lawcol, zq, info)
            if (info /= sk_ok) return
            call frame_jacobian(mf, st, newidx(frame(ipost)), zq, rf(:, :, ipost), pf(:, ipost), jq(:, :, ipost))
            delta(:, ipost) = st%delta
            nit(ipost) = st%nit
            if (.not. st%conv) eqinfo(ipost) = sk_err_noconv
        end do
        info = merge(sk_ok, sk_err_noconv, all(eqinfo == sk_ok))
    end subroutine frame_jacobian_batch

end module sk_tree_jac
