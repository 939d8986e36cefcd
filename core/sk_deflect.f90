!> Deflection rows of a serial chain under known loads (relative data,
!> docs/calibration.md section 3; klimchik eqs. 4-5, 12): the predicted
!> point deflection and tool rotation of every measurement row and their
!> analytic Jacobian with respect to the model's free parameters,
!> including the chain rule through a gravity compensator and a point
!> offset. A joint spring's terms are the slots of one block of the
!> tree's law_joint (sk_laws: linear, profile, harmonic, compensator,
!> cubic, dead zone; law_delta/law_derivs); a 6-dof spring's elements are
!> law_spring6's. The frames, the springs' screws and
!> their generalised forces come from the chain's tree model
!> (sk_chain_tree): a chain is a tree.
!>
!> Model (terms t = 1..nt, tint[7,nt], tgeo[5,nt]):
!>   tint(1,t) kind: 1 joint (c), 2 joint_profile (c0..c4 on 1, cos q,
!>             sin q, cos 2q, sin 2q), 3 gravity_compensator (k_s),
!>             4 joint_cubic (c3), 5 joint_deadzone (b, tau0 = tgeo(5,t)),
!>             6 six-dof spring (elements), 7 point offset (r, tool frame),
!>             8 joint_harmonic (c1, s1 on cos q, sin q)
!>   tint(2,t) the term's spring (1-based into stype/sidx; 0 for kind 7)
!>   tint(3,t) its first value in par, tint(4,t) its number of values
!>   tint(5,t) its first Jacobian column (1-based), 0 when known
!>   tint(6,t) the q column of its joint (joint kinds), tint(7,t) the
!>             first of its elements in elem (kind 6; sym_index order)
!>   tgeo(1:4,t) compensator a, b, beta, s0 (m, m, rad, m)
!> par holds every term's values; those of free terms are taken from theta.
!> A joint spring deflects by delta = law_joint(tau), tau = J_s^T w its
!> torque, with the linear compliance c_eff = c(q) / (1 + c(q) k_s h(q))
!> (c(q) the sum of its joint, profile and harmonic terms, h the
!> compensator's d2V/dq2 per unit k_s, docs/calibration.md section 2;
!> sk_laws joint_ceff); a 6-dof spring by C J_s^T w. A row's
!> six numbers are the point deflection dt + dphi x (R_tool (p + r)) and
!> the tool rotation dphi (base axes).
module sk_deflect
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: all_finite
    use sk_rotation, only: cross
    use sk_spatial, only: sym_index, nsym
    use sk_chain, only: check_chain, spring_joint
    use sk_tree_model, only: tree_model, tree_state, state_init
    use sk_chain_tree, only: chain_tree_model, chain_tree_rows
    use sk_laws, only: law_delta, law_derivs, law_cubic, law_deadzone, law_joint, joint_ceff, js_c, js_cubic, &
        js_backlash, js_profile, js_harmonic, js_ks, js_geom
    implicit none
    private
    public :: deflection_rows, joint_secant
    !> term kinds (robot/model_core.py TERM_* mirrors them)
    integer, parameter, public :: term_joint = 1, term_profile = 2, term_compensator = 3, term_cubic = 4, &
        term_deadzone = 5, term_six = 6, term_offset = 7, term_harmonic = 8
    !> |tau / tau0| below which the dead zone's secant is its tangent at zero
    real(dp), parameter :: secant_small = 1.0e-4_dp

contains

    !> Whether a term kind belongs to a joint spring (its q column is set).
    elemental logical function joint_term(k)
        integer(ip), intent(in) :: k
        joint_term = k <= term_deadzone .or. k == term_harmonic
    end function joint_term

    !> Check the term tables against the springs, the values and the rows.
    pure subroutine check_terms(tint, tgeo, elem, ns, npall, npar, ndof, info)
        integer(ip), intent(in) :: tint(:, :), elem(:), ns, npall, npar, ndof
        real(dp), intent(in) :: tgeo(:, :)
        integer(ip), intent(out) :: info
        integer :: t, k, n
        info = sk_err_argument
        if (size(tint, 1) /= 7 .or. size(tgeo, 1) /= 5 .or. size(tgeo, 2) /= size(tint, 2)) return
        do t = 1, size(tint, 2)
            k = tint(1, t)
            n = tint(4, t)
            if (k < term_joint .or. k > term_harmonic) return
            if (k /= term_offset .and. (tint(2, t) < 1 .or. tint(2, t) > ns)) return
            if (tint(3, t) < 1 .or. tint(3, t) + n - 1 > npall) return
            if (tint(5, t) < 0) return
            if (tint(5, t) > 0 .and. tint(5, t) + n - 1 > npar) return
            select case (k)
            case (term_joint, term_compensator, term_cubic, term_deadzone)
                if (n /= 1) return
            case (term_profile)
                if (n /= 5) return
            case (term_offset)
                if (n /= 3) return
            case (term_harmonic)
                if (n /= 2) return
            case default
                if (tint(7, t) < 1 .or. tint(7, t) + n - 1 > size(elem)) return
                if (any(elem(tint(7, t):tint(7, t) + n - 1) < 1) .or. any(elem(tint(7, t):tint(7, t) + n - 1) > nsym)) &
                    return
            end select
            if (joint_term(k) .and. (tint(6, t) < 1 .or. tint(6, t) > ndof)) return
            if (k == term_deadzone .and. .not. tgeo(5, t) > 0.0_dp) return
            if (k == term_compensator .and. .not. (tgeo(1, t) > 0.0_dp .and. tgeo(2, t) > 0.0_dp)) return
        end do
        info = sk_ok
    end subroutine check_terms

    !> The law_joint block of joint spring s (sk_laws): its slots par[21]
    !> from the values pv of its terms, the dead zone's width w0 (1 when it
    !> has none) and the q column qc of its joint (0: no joint term).
    pure subroutine joint_block(s, tint, tgeo, pv, par, w0, qc)
        integer, intent(in) :: s
        integer(ip), intent(in) :: tint(:, :)
        real(dp), intent(in) :: tgeo(:, :), pv(:)
        real(dp), intent(out) :: par(nsym), w0
        integer, intent(out) :: qc
        integer :: t, p
        par = 0.0_dp
        w0 = 1.0_dp
        qc = 0
        do t = 1, size(tint, 2)
            if (tint(2, t) /= s .or. .not. joint_term(tint(1, t))) cycle
            p = tint(3, t)
            qc = tint(6, t)
            select case (tint(1, t))
            case (term_joint)
                par(js_c) = par(js_c) + pv(p)
            case (term_profile)
                par(js_profile:js_profile + 4) = par(js_profile:js_profile + 4) + pv(p:p + 4)
            case (term_harmonic)
                par(js_harmonic:js_harmonic + 1) = par(js_harmonic:js_harmonic + 1) + pv(p:p + 1)
            case (term_compensator)
                par(js_ks) = pv(p)
                par(js_geom:js_geom + 3) = tgeo(1:4, t)
            case (term_cubic)
                par(js_cubic) = par(js_cubic) + pv(p)
            case (term_deadzone)
                par(js_backlash) = par(js_backlash) + pv(p)
                w0 = tgeo(5, t)
            end select
        end do
    end subroutine joint_block

    !> All values: par with the free slices from theta.
    pure subroutine values(tint, par, theta, pv)
        integer(ip), intent(in) :: tint(:, :)
        real(dp), intent(in) :: par(:), theta(:)
        real(dp), intent(out) :: pv(:)
        integer :: t, n
        pv = par
        do t = 1, size(tint, 2)
            n = tint(4, t)
            if (tint(5, t) > 0) pv(tint(3, t):tint(3, t) + n - 1) = theta(tint(5, t):tint(5, t) + n - 1)
        end do
    end subroutine values

    !> Predicted rows pred[6,nm] at theta and, when want_jac, their Jacobian
    !> jac[6,nm,npar] (module header). q[ndof,nm], w[6,nm] (f, m at the tool
    !> origin, base axes), p[3,nm] (tool coordinates). info: sk_ok,
    !> sk_err_argument (inconsistent chain, springs or terms), sk_err_nonfinite.
    subroutine deflection_rows(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, &
            theta, q, w, p, want_jac, pred, jac, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:), tint(:, :), elem(:)
        real(dp), intent(in) :: tgeo(:, :), par(:), theta(:), q(:, :), w(:, :), p(:, :)
        logical, intent(in) :: want_jac
        real(dp), intent(out) :: pred(:, :), jac(:, :, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: pv(:), g(:, :, :), a(:, :)
        real(dp) :: rt(3, 3), r(3), col(6), jpar(nsym), w0, dl(1), dm(1, 1), dpar(1, nsym), dv(1)
        integer, allocatable :: sv(:)
        integer :: m, s, t, k, kk, ia, ib, ns, jc, qc, toff, tool
        type(tree_model) :: tm
        type(tree_state) :: st
        ns = size(stype)
        pred = 0.0_dp
        if (want_jac) jac = 0.0_dp
        call check_chain(jaxis, qidx, size(q, 1, kind=ip), stype, sidx, info)
        if (info /= sk_ok) return
        call check_terms(tint, tgeo, elem, int(ns, ip), size(par, kind=ip), size(theta, kind=ip), &
            size(q, 1, kind=ip), info)
        if (info /= sk_ok) return
        info = sk_err_size
        if (size(w, 2) /= size(q, 2) .or. size(p, 2) /= size(q, 2) .or. size(pred, 2) /= size(q, 2)) return
        if (want_jac .and. (size(jac, 2) /= size(q, 2) .or. size(jac, 3) /= size(theta))) return
        info = sk_err_nonfinite
        if (.not. (all_finite(q) .and. all_finite(w) .and. all_finite(p) .and. all_finite(par) &
            .and. all_finite(theta) .and. all_finite(tgeo))) return
        allocate(pv(size(par)), g(6, 6, ns), a(6, ns), sv(ns))
        call chain_tree_model(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, size(q, 1, kind=ip), tm, sv, &
            tool, info)
        if (info /= sk_ok) return
        call state_init(tm, st)
        call values(tint, par, theta, pv)
        r = 0.0_dp
        toff = 0
        do t = 1, size(tint, 2)
            if (tint(1, t) == term_offset) then
                toff = t
                r = pv(tint(3, t):tint(3, t) + 2)
            end if
        end do
        do m = 1, size(q, 2)
            ! every spring's unit columns (point, rotation per unit deflection)
            ! and generalised force, on the chain's tree model
            call chain_tree_rows(tm, st, sv, stype, tool, q(:, m), w(:, m), p(:, m) + r, g, a, rt)
            ! 6-dof springs: columns J E_ab J^T w per element (klimchik eq. 12)
            do t = 1, size(tint, 2)
                if (tint(1, t) /= term_six) cycle
                s = tint(2, t)
                jc = tint(5, t)
                do k = 1, tint(4, t)
                    kk = elem(tint(7, t) + k - 1)
                    call sym_index(kk, ia, ib)
                    if (ia == ib) then
                        col = g(:, ia, s)*a(ia, s)
                    else
                        col = g(:, ia, s)*a(ib, s) + g(:, ib, s)*a(ia, s)
                    end if
                    pred(:, m) = pred(:, m) + col*pv(tint(3, t) + k - 1)
                    if (want_jac .and. jc > 0) jac(:, m, jc + k - 1) = col
                end do
            end do
            ! joint springs: delta = law_joint(tau) at the posture
            do s = 1, ns
                if (stype(s) /= spring_joint) cycle
                if (.not. any(tint(2, :) == s .and. joint_term(tint(1, :)))) cycle
                call joint_block(s, tint, tgeo, pv, jpar, w0, qc)
                call law_delta(law_joint, jpar, w0, q(qc, m), a(1:1, s), dl)
                pred(:, m) = pred(:, m) + g(:, 1, s)*dl(1)
                if (.not. want_jac) cycle
                call law_derivs(law_joint, jpar, w0, q(qc, m), a(1:1, s), dm, dpar, dv)
                do t = 1, size(tint, 2)
                    jc = tint(5, t)
                    if (tint(2, t) /= s .or. jc == 0) cycle
                    select case (tint(1, t))
                    case (term_joint)
                        jac(:, m, jc) = g(:, 1, s)*dpar(1, js_c)
                    case (term_profile)
                        do k = 1, 5
                            jac(:, m, jc + k - 1) = g(:, 1, s)*dpar(1, js_profile + k - 1)
                        end do
                    case (term_harmonic)
                        jac(:, m, jc) = g(:, 1, s)*dpar(1, js_harmonic)
                        jac(:, m, jc + 1) = g(:, 1, s)*dpar(1, js_harmonic + 1)
                    case (term_compensator)
                        jac(:, m, jc) = g(:, 1, s)*dpar(1, js_ks)
                    case (term_cubic)
                        jac(:, m, jc) = g(:, 1, s)*dpar(1, js_cubic)
                    case (term_deadzone)
                        jac(:, m, jc) = g(:, 1, s)*dpar(1, js_backlash)
                    end select
                end do
            end do
            ! point offset: d(dt + dphi x R (p + r))/dr = [dphi]x R
            if (want_jac .and. toff > 0) then
                jc = tint(5, toff)
                if (jc > 0) then
                    do k = 1, 3
                        jac(1:3, m, jc + k - 1) = cross(pred(4:6, m), rt(:, k))
                    end do
                end if
            end if
        end do
        info = sk_ok
        if (.not. all_finite(pred)) info = sk_err_overflow
    end subroutine deflection_rows

    !> Compliance cj[ns,np] of every joint spring at postures q[ndof,np]
    !> from the known values par (tint as deflection_rows, no free terms):
    !> c_eff at zero load, or with_load: the secant delta(tau)/tau under the
    !> torques tau[ns,np] (the tangent at zero load where |tau| is below
    !> 1e-4 of a dead zone's tau0). Non-joint springs get 0.
    subroutine joint_secant(stype, tint, tgeo, par, q, tau, with_load, cj, info)
        integer(ip), intent(in) :: stype(:), tint(:, :)
        real(dp), intent(in) :: tgeo(:, :), par(:), q(:, :), tau(:, :)
        logical, intent(in) :: with_load
        real(dp), intent(out) :: cj(:, :)
        integer(ip), intent(out) :: info
        real(dp) :: ceff, dc, dk, dvc, pv(size(par)), none(0), wpar(nsym), dm(1, 1), dp2(1, nsym), dv(1), d(1), &
            jpar(nsym), w0
        integer :: m, s, t, qc
        integer(ip) :: noelem(0)
        cj = 0.0_dp
        call check_terms(tint, tgeo, noelem, size(stype, kind=ip), size(par, kind=ip), 0_ip, &
            size(q, 1, kind=ip), info)
        if (info /= sk_ok) return
        info = sk_err_nonfinite
        if (.not. (all_finite(q) .and. all_finite(par) .and. all_finite(tau) .and. all_finite(tgeo))) return
        call values(tint, par, none, pv)
        do m = 1, size(q, 2)
            do s = 1, size(stype)
                if (stype(s) /= spring_joint) cycle
                call joint_block(s, tint, tgeo, pv, jpar, w0, qc)
                ceff = 0.0_dp
                if (qc > 0) call joint_ceff(jpar, q(qc, m), ceff, dc, dk, dvc)
                cj(s, m) = ceff
                if (.not. with_load) cycle
                ! the secant delta(tau)/tau of each nonlinear term (the tree's laws)
                do t = 1, size(tint, 2)
                    if (tint(2, t) /= s) cycle
                    wpar = 0.0_dp
                    wpar(2) = pv(tint(3, t))
                    select case (tint(1, t))
                    case (term_cubic)
                        if (tau(s, m) == 0.0_dp) cycle
                        call law_delta(law_cubic, wpar, 1.0_dp, 0.0_dp, tau(s:s, m), d)
                        cj(s, m) = cj(s, m) + d(1)/tau(s, m)
                    case (term_deadzone)
                        if (abs(tau(s, m)/tgeo(5, t)) < secant_small) then
                            ! the tangent at zero load
                            call law_derivs(law_deadzone, wpar, tgeo(5, t), 0.0_dp, [0.0_dp], dm, dp2, dv)
                            cj(s, m) = cj(s, m) + dm(1, 1)
                        else
                            call law_delta(law_deadzone, wpar, tgeo(5, t), 0.0_dp, tau(s:s, m), d)
                            cj(s, m) = cj(s, m) + d(1)/tau(s, m)
                        end if
                    end select
                end do
            end do
        end do
        info = sk_ok
    end subroutine joint_secant

end module sk_deflect
