!> Deflection rows of a serial chain under known loads (relative data,
!> docs/calibration.md section 3; klimchik eqs. 4-5, 12): the predicted
!> point deflection and tool rotation of every measurement row and their
!> analytic Jacobian with respect to the model's free parameters,
!> including the chain rule through a gravity compensator and a point
!> offset. No evaluator of its own: the terms become the chain's tree
!> model (sk_chain_tree) with one law block per spring (a joint spring's
!> terms are the slots of one law_joint block: linear, profile, harmonic,
!> compensator, cubic, dead zone; a 6-dof spring's elements law_spring6's,
!> sk_laws), a row is a posture under its load with two observations of
!> the tree evaluator (sk_tree_jac evaluate: obs_deflection of the point,
!> obs_rotation of the tool), and the rows and Jacobian are evaluate's;
!> a chain is a tree, a deflection is an observation.
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
    use sk_spatial, only: nsym
    use sk_chain, only: check_chain, spring_joint
    use sk_tree_model, only: tree_model, tree_problem, problem_setup, obs_deflection, obs_rotation
    use sk_tree_jac, only: evaluate
    use sk_chain_tree, only: chain_tree_model
    use sk_laws, only: law_delta, law_derivs, law_linear, law_cubic, law_deadzone, law_spring6, law_joint, joint_ceff, js_c, js_cubic, &
        js_backlash, js_profile, js_harmonic, js_ks, js_geom
    implicit none
    private
    public :: deflection_rows, deflection_setup, deflection_eval, joint_secant

    !> The deflection model of a chain on its rows as the tree problem of
    !> the chain's tree model (deflection_setup): pr, the tree's parameters
    !> th, the entry home(i) that carries value i of par, theta's columns
    !> colof in the tree's free list (0: none), the terms and known values.
    type, public :: deflection_model
        type(tree_problem) :: pr
        real(dp), allocatable :: th(:), par(:)
        integer, allocatable :: home(:), colof(:)
        integer(ip), allocatable :: tint(:, :)
        integer :: nm = 0
    end type deflection_model
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

    !> The deflection model (module header) of a chain with the terms at
    !> npar free columns, on rows q[ndof,nm], w[6,nm] (f, m at the tool
    !> origin, base axes), p[3,nm] (tool coordinates), as the tree problem
    !> dm that deflection_eval evaluates. info: sk_ok, sk_err_argument
    !> (inconsistent chain, springs or terms), sk_err_size, sk_err_nonfinite.
    subroutine deflection_setup(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, npar, &
            q, w, p, dm, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:), tint(:, :), elem(:), npar
        real(dp), intent(in) :: tgeo(:, :), par(:), q(:, :), w(:, :), p(:, :)
        type(deflection_model), intent(out) :: dm
        integer(ip), intent(out) :: info
        real(dp), allocatable :: pv(:), th(:), bkw0(:), opt(:, :)
        integer(ip), allocatable :: bktype(:), bkpar(:, :), free(:), opost(:), okind(:), lpost(:)
        integer, allocatable :: sv(:), colof(:)
        integer(ip) :: tpar(6), mpar(3)
        integer :: m, s, t, k, ns, nm, npall, nth, ig, nfree, c, tool
        integer, allocatable :: home(:)
        type(tree_model) :: tm
        ns = size(stype)
        nm = size(q, 2)
        npall = size(par)
        call check_chain(jaxis, qidx, size(q, 1, kind=ip), stype, sidx, info)
        if (info /= sk_ok) return
        call check_terms(tint, tgeo, elem, int(ns, ip), size(par, kind=ip), npar, size(q, 1, kind=ip), info)
        if (info /= sk_ok) return
        info = sk_err_size
        if (size(w, 2) /= nm .or. size(p, 2) /= nm) return
        info = sk_err_nonfinite
        if (.not. (all_finite(q) .and. all_finite(w) .and. all_finite(p) .and. all_finite(par) &
            .and. all_finite(tgeo))) return
        ! the tree's parameters: every value, the compensators' geometry, the
        ! sums of values that share a slot (a known and a free 6-dof spring
        ! element: home(i) is the entry that carries value i), a zero
        nth = 2*npall + 4*count(tint(1, :) == term_compensator) + 1
        allocate(pv(npall), th(nth), bktype(ns), bkpar(nsym, ns), bkw0(ns), sv(ns), colof(npar), free(npar), &
            home(npall))
        pv = par
        th = 0.0_dp
        th(1:npall) = pv
        home = [(k, k = 1, npall)]
        tpar = int(nth, ip)
        mpar = int(nth, ip)
        bktype = merge(law_linear, law_spring6, stype == spring_joint)
        bkpar = 0
        bkw0 = 1.0_dp
        ig = npall
        do t = 1, size(tint, 2)
            s = tint(2, t)
            select case (tint(1, t))
            case (term_joint)
                call slot(js_c, tint(3, t))
            case (term_profile)
                do k = 0, 4
                    call slot(js_profile + k, tint(3, t) + k)
                end do
            case (term_harmonic)
                call slot(js_harmonic, tint(3, t))
                call slot(js_harmonic + 1, tint(3, t) + 1)
            case (term_compensator)
                call slot(js_ks, tint(3, t))
                do k = 0, 3
                    ig = ig + 1
                    th(ig) = tgeo(k + 1, t)
                    bkpar(js_geom + k, s) = int(ig, ip)
                end do
            case (term_cubic)
                call slot(js_cubic, tint(3, t))
            case (term_deadzone)
                call slot(js_backlash, tint(3, t))
                bkw0(s) = tgeo(5, t)
            case (term_six)
                do k = 0, tint(4, t) - 1
                    call slot(elem(tint(7, t) + k), tint(3, t) + k)
                end do
            case (term_offset)
                mpar = tint(3, t) + [0, 1, 2]
            end select
            if (joint_term(tint(1, t))) bktype(s) = law_joint
        end do
        ! the free values: theta's columns in the tree's free list (two free
        ! values in one sum are not one parameter)
        colof = 0
        nfree = 0
        info = sk_err_argument
        do t = 1, size(tint, 2)
            if (tint(5, t) == 0) cycle
            do k = 0, tint(4, t) - 1
                c = tint(5, t) + k
                if (colof(c) /= 0) return
                if (any(free(1:nfree) == home(tint(3, t) + k))) return
                nfree = nfree + 1
                colof(c) = nfree
                free(nfree) = home(tint(3, t) + k)
            end do
        end do
        if (any(stype /= spring_joint .and. bktype /= law_spring6)) return
        call chain_tree_model(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, size(q, 1, kind=ip), tm, sv, &
            tool, info, bktype, bkpar, bkw0, int(nth, ip), tpar, mpar)
        if (info /= sk_ok) return
        ! row m: posture m under its load at the tool; observations m (the
        ! point's deflection) and nm + m (the tool's rotation)
        allocate(opt(3, 2*nm), opost(2*nm), okind(2*nm), lpost(nm))
        lpost = [(int(m, ip), m = 1, nm)]
        opost = [lpost, lpost]
        okind = [(obs_deflection, m = 1, nm), (obs_rotation, m = 1, nm)]
        opt(:, 1:nm) = p
        opt(:, nm + 1:) = p
        call problem_setup(dm%pr, tm, q, lpost, spread(int(tool, ip), 1, nm), w, opost, spread(1_ip, 1, 2*nm), &
            spread([0.0_dp, 0.0_dp, 0.0_dp], 2, 2*nm), spread(1.0_dp, 1, 2*nm), free(1:nfree), info, okind, opt)
        if (info /= sk_ok) return
        dm%th = th
        dm%home = home
        dm%colof = colof
        dm%tint = tint
        dm%par = par
        dm%nm = nm

    contains

        !> Slot j of spring s's block takes value i (pv); a slot taken
        !> already takes the sum, a new entry of th.
        subroutine slot(j, i)
            integer, intent(in) :: j
            integer(ip), intent(in) :: i
            integer :: old
            old = bkpar(j, s)
            if (old == 0) then
                bkpar(j, s) = i
                return
            end if
            ig = ig + 1
            th(ig) = th(old) + pv(i)
            where (home == old) home = ig
            home(i) = ig
            bkpar(j, s) = int(ig, ip)
        end subroutine slot
    end subroutine deflection_setup

    !> Predicted rows pred[6,nm] of the deflection model dm
    !> (deflection_setup) at theta[npar] and, when want_jac, their Jacobian
    !> jac[6,nm,npar] (module header): the tree evaluator's deflection and
    !> rotation observations (sk_tree_jac evaluate, first order). info:
    !> sk_ok, sk_err_size, sk_err_nonfinite, sk_err_overflow, or evaluate's.
    subroutine deflection_eval(dm, theta, want_jac, pred, jac, info)
        type(deflection_model), intent(inout) :: dm
        real(dp), intent(in) :: theta(:)
        logical, intent(in) :: want_jac
        real(dp), intent(out) :: pred(:, :), jac(:, :, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: pv(:), predt(:, :), res(:), jt(:, :), delta(:, :)
        integer(ip), allocatable :: nit(:), eqinfo(:)
        integer :: nm, i, c, m
        nm = dm%nm
        pred = 0.0_dp
        if (want_jac) jac = 0.0_dp
        info = sk_err_size
        if (size(pred, 1) /= 6 .or. size(pred, 2) /= nm .or. size(theta) /= size(dm%colof)) return
        if (want_jac .and. any(shape(jac) /= [6, nm, size(theta)])) return
        info = sk_err_nonfinite
        if (.not. all_finite(theta)) return
        allocate(pv(size(dm%par)), predt(3, 2*nm), res(6*nm), jt(6*nm, dm%pr%nfree), delta(dm%pr%m%ne, nm), &
            nit(nm), eqinfo(nm))
        ! the tree's parameters: the values, and the sums of those that share a slot
        call values(dm%tint, dm%par, theta, pv)
        dm%th(1:size(pv)) = pv
        do i = 1, size(pv)
            if (dm%home(i) > size(pv)) dm%th(dm%home(i)) = 0.0_dp
        end do
        do i = 1, size(pv)
            if (dm%home(i) > size(pv)) dm%th(dm%home(i)) = dm%th(dm%home(i)) + pv(i)
        end do
        call evaluate(dm%pr, dm%th, 1_ip, 0.0_dp, want_jac, predt, res, jt, delta, nit, eqinfo, info)
        if (info /= sk_ok) return
        pred(1:3, :) = predt(:, 1:nm)
        pred(4:6, :) = predt(:, nm + 1:)
        if (want_jac) then
            do c = 1, size(theta)
                if (dm%colof(c) == 0) cycle
                do m = 1, nm
                    jac(1:3, m, c) = jt(3*m - 2:3*m, dm%colof(c))
                    jac(4:6, m, c) = jt(3*(nm + m) - 2:3*(nm + m), dm%colof(c))
                end do
            end do
        end if
        info = sk_ok
        if (.not. all_finite(pred)) info = sk_err_overflow
    end subroutine deflection_eval

    !> Predicted rows pred[6,nm] at theta and, when want_jac, their Jacobian
    !> jac[6,nm,npar] (module header; deflection_setup, deflection_eval).
    !> q[ndof,nm], w[6,nm] (f, m at the tool origin, base axes), p[3,nm]
    !> (tool coordinates). info: sk_ok, sk_err_argument (inconsistent chain,
    !> springs or terms), sk_err_size, sk_err_nonfinite, sk_err_overflow.
    subroutine deflection_rows(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, &
            theta, q, w, p, want_jac, pred, jac, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:), tint(:, :), elem(:)
        real(dp), intent(in) :: tgeo(:, :), par(:), theta(:), q(:, :), w(:, :), p(:, :)
        logical, intent(in) :: want_jac
        real(dp), intent(out) :: pred(:, :), jac(:, :, :)
        integer(ip), intent(out) :: info
        type(deflection_model) :: dm
        pred = 0.0_dp
        if (want_jac) jac = 0.0_dp
        call deflection_setup(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, tint, tgeo, elem, par, &
            size(theta, kind=ip), q, w, p, dm, info)
        if (info /= sk_ok) return
        call deflection_eval(dm, theta, want_jac, pred, jac, info)
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
