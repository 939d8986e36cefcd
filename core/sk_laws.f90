!> The effect laws of the core: how an elastic block of the robot model
!> deflects under its generalised forces, delta = law(w; parameters), and
!> the derivatives every Jacobian of the model needs. One block is one
!> effect of the catalogue (a joint compliance, a cubic joint, a dead
!> zone, a 6-dof link or joint spring); the kinematic tree (sk_tree_equil:
!> equilibrium and sensitivities) is the caller, and any new evaluator of
!> the model (serial chains, relative data) calls the same routines, so a
!> law is written once, here.
!>
!> Codes (ktype; bindings and robot/tree_model.py LAW_* use the same
!> numbers, tests/test_architecture.py checks them):
!>   law_linear   1  1 coordinate,  delta = c w                      par = (c)
!>   law_cubic    2  1 coordinate,  delta = c w + c3 w^3             par = (c, c3)
!>   law_deadzone 3  1 coordinate,  delta = c w + b tanh(w / w0)     par = (c, b)
!>                   (w0 > 0 a fixed smoothing width, N m or N: the block's kw0)
!>   law_harmonic 5  1 coordinate,  delta = (c + c1 cos v + s1 sin v) w  par = (c, c1, s1)
!>                   (v the joint's value: cogging, gear eccentricity)
!>   law_joint    6  1 coordinate,  the serial chain's joint (relative data):
!>                   delta = c_eff(v) w + c3 w^3 + b tanh(w / w0),
!>                   c_eff = c(v) / (1 + c(v) k_s h(v)) (a gravity
!>                   compensator of geometry a, b, beta, s0; c_eff = c(v)
!>                   when a = 0), c(v) = c + profile(v) + harmonic(v),
!>                   profile(v) = p0 + p1 cos v + p2 sin v + p3 cos 2v +
!>                   p4 sin 2v, harmonic(v) = c1 cos v + s1 sin v;
!>                   par = (c, c3, b, p0..p4, c1, s1, k_s, a, b, beta, s0)
!>                   (slots js_*; the geometry's four are constants: their
!>                   d delta/d(slot) is returned as 0)
!>   law_spring6  4  6 coordinates, delta(6) = C w(6), C symmetric from 21
!>                   parameters, the upper triangle row by row (sk_spatial
!>                   sym_index order); a 6-dof spring's coordinates are
!>                   screws: 3 prismatic along x, y, z, then revolute about
!>                   x, y, z of the spring frame (VJM, Klimchik et al. eq. 3).
!> Units: w in N m (revolute coordinate) or N (prismatic); delta in rad or
!> m; c in rad/(N m) or m/N. Compliances, not stiffnesses: a rigid effect
!> is c = 0, and every law is linear in its parameters but the dead
!> zone's width w0.
!>
!> Interface shared by every law (par is always the block's 21 slots,
!> only the first law_nslot(ktype) used; w and d hold law_ndof(ktype)
!> entries):
!>   law_ndof(ktype)                          coordinates of a block (1 or 6)
!>   law_nslot(ktype)                         parameter slots (1, 2, 2, 21, 3, 15)
!>   law_delta(ktype, par, w0, v, w, d)       the deflection d = law(w)
!>   law_derivs(ktype, par, w0, v, w, dmat, dpar, dval)  D = d delta/dw
!>                                            [n,n], d delta/d(slot)
!>                                            [n,nslot], d delta/dv [n]
!> v is the value of the block's (first) joint without its deflection (the
!> joint angle, plus any zero offset): a law may depend on it; the callers
!> take dval through every driver that moves that joint.
!>   law_sym6(par)                            the 6x6 compliance of law_spring6
!>   joint_ceff(par, v, ceff, dc, dk, dv)     law_joint's linear compliance
!>   compensator_h(q, a, b, beta, s0)         the compensator's h (elemental)
!>   profile_basis(q)                         1, cos q, sin q, cos 2q, sin 2q
!> Adding a law: a new code here (nlaw the largest; the catalogue of kinds
!> robot/catalogue.py LAWS the same numbers), its cases in law_ndof,
!> law_nslot, law_delta and law_derivs; nothing else of the core changes.
module sk_laws
    use sk_kinds, only: dp
    use sk_spatial, only: sym_index, nsym
    implicit none
    private
    public :: law_ndof, law_nslot, law_delta, law_derivs, law_sym6
    public :: joint_ceff, compensator_h, compensator_dh, profile_basis

    !> law codes (ktype of an elastic block)
    integer, parameter, public :: law_linear = 1, law_cubic = 2, law_deadzone = 3, law_spring6 = 4, &
        law_harmonic = 5, law_joint = 6
    !> the largest law code (sk_tree_check refuses a ktype beyond it)
    integer, parameter, public :: nlaw = 6
    !> law_joint's slots (module header): c, c3, b, the profile's five,
    !> the harmonic's two, k_s, the compensator's geometry a, b, beta, s0
    integer, parameter, public :: js_c = 1, js_cubic = 2, js_backlash = 3, js_profile = 4, js_harmonic = 9, &
        js_ks = 11, js_geom = 12, js_nslot = 15

contains

    !> Number of elastic coordinates of a block of law ktype (6 for a
    !> 6-dof spring, 1 otherwise).
    pure integer function law_ndof(ktype)
        integer, intent(in) :: ktype
        law_ndof = merge(6, 1, ktype == law_spring6)
    end function law_ndof

    !> The symmetric 6x6 compliance of 21 parameters (sym_index order).
    pure function law_sym6(par) result(c)
        real(dp), intent(in) :: par(nsym)
        real(dp) :: c(6, 6)
        integer :: k, i, j
        do k = 1, nsym
            call sym_index(k, i, j)
            c(i, j) = par(k)
            c(j, i) = par(k)
        end do
    end function law_sym6

    !> Deflection d(1:n) of a block for its generalised forces w(1:n)
    !> (n = law_ndof(ktype)); par: the block's 21 parameter slots, w0 the
    !> dead zone's width (unused by the other laws), v the joint's value
    !> (module header; the harmonic law's angle).
    pure subroutine law_delta(ktype, par, w0, v, w, d)
        integer, intent(in) :: ktype
        real(dp), intent(in) :: par(nsym), w0, v, w(:)
        real(dp), intent(out) :: d(:)
        real(dp) :: ceff, dc, dk, dv
        select case (ktype)
        case (law_linear)
            d(1) = par(1)*w(1)
        case (law_cubic)
            d(1) = par(1)*w(1) + par(2)*w(1)**3
        case (law_deadzone)
            d(1) = par(1)*w(1) + par(2)*tanh(w(1)/w0)
        case (law_harmonic)
            d(1) = (par(1) + par(2)*cos(v) + par(3)*sin(v))*w(1)
        case (law_joint)
            call joint_ceff(par, v, ceff, dc, dk, dv)
            d(1) = ceff*w(1) + par(js_cubic)*w(1)**3 + par(js_backlash)*tanh(w(1)/w0)
        case default
            d(1:6) = matmul(law_sym6(par), w(1:6))
        end select
    end subroutine law_delta

    !> Number of parameter slots of a law type (1, 2, 2, 21, 3, 15).
    pure integer function law_nslot(ktype)
        integer, intent(in) :: ktype
        select case (ktype)
        case (law_linear)
            law_nslot = 1
        case (law_cubic, law_deadzone)
            law_nslot = 2
        case (law_harmonic)
            law_nslot = 3
        case (law_joint)
            law_nslot = js_nslot
        case default
            law_nslot = nsym
        end select
    end function law_nslot

    !> Derivatives of a block's law at w(1:n): dmat[n,n] = d delta/dw (the
    !> block of D in the sensitivity (I - D G) Z = ...), dpar[n,:] =
    !> d delta/d(parameter slot), slots 1..law_nslot(ktype) set, dval[n] =
    !> d delta/dv (zero but for the harmonic law).
    pure subroutine law_derivs(ktype, par, w0, v, w, dmat, dpar, dval)
        integer, intent(in) :: ktype
        real(dp), intent(in) :: par(nsym), w0, v, w(:)
        real(dp), intent(out) :: dmat(:, :), dpar(:, :), dval(:)
        real(dp) :: t, ceff, dc, dk, dv
        integer :: k, i, j
        dval = 0.0_dp
        select case (ktype)
        case (law_linear)
            dmat(1, 1) = par(1)
            dpar(1, 1) = w(1)
        case (law_cubic)
            dmat(1, 1) = par(1) + 3.0_dp*par(2)*w(1)**2
            dpar(1, 1) = w(1)
            dpar(1, 2) = w(1)**3
        case (law_deadzone)
            t = tanh(w(1)/w0)
            dmat(1, 1) = par(1) + par(2)*(1.0_dp - t*t)/w0
            dpar(1, 1) = w(1)
            dpar(1, 2) = t
        case (law_harmonic)
            dmat(1, 1) = par(1) + par(2)*cos(v) + par(3)*sin(v)
            dpar(1, 1) = w(1)
            dpar(1, 2) = cos(v)*w(1)
            dpar(1, 3) = sin(v)*w(1)
            dval(1) = (par(3)*cos(v) - par(2)*sin(v))*w(1)
        case (law_joint)
            call joint_ceff(par, v, ceff, dc, dk, dv)
            t = tanh(w(1)/w0)
            dmat(1, 1) = ceff + 3.0_dp*par(js_cubic)*w(1)**2 + par(js_backlash)*(1.0_dp - t*t)/w0
            dpar(1, 1:js_nslot) = 0.0_dp
            dpar(1, js_c) = w(1)*dc
            dpar(1, js_cubic) = w(1)**3
            dpar(1, js_backlash) = t
            dpar(1, js_profile:js_profile + 4) = w(1)*dc*profile_basis(v)
            dpar(1, js_harmonic) = w(1)*dc*cos(v)
            dpar(1, js_harmonic + 1) = w(1)*dc*sin(v)
            dpar(1, js_ks) = w(1)*dk
            dval(1) = dv*w(1)
        case default
            dmat(1:6, 1:6) = law_sym6(par)
            dpar(1:6, 1:nsym) = 0.0_dp
            do k = 1, nsym
                call sym_index(k, i, j)
                dpar(i, k) = w(j)
                if (i /= j) dpar(j, k) = w(i)
            end do
        end select
    end subroutine law_derivs

    !> law_joint's linear compliance at the joint value v (module header):
    !> ceff = c_eff(v), dc = dc_eff/dc (the factor of every term of c(v)),
    !> dk = dc_eff/dk_s, dv = dc_eff/dv.
    pure subroutine joint_ceff(par, v, ceff, dc, dk, dv)
        real(dp), intent(in) :: par(:), v
        real(dp), intent(out) :: ceff, dc, dk, dv
        real(dp) :: c, dcv, ks, h, den
        real(dp) :: slope(5)
        slope = [0.0_dp, -sin(v), cos(v), -2.0_dp*sin(2.0_dp*v), 2.0_dp*cos(2.0_dp*v)]
        c = par(js_c) + dot_product(profile_basis(v), par(js_profile:js_profile + 4)) &
            + par(js_harmonic)*cos(v) + par(js_harmonic + 1)*sin(v)
        dcv = dot_product(slope, par(js_profile:js_profile + 4)) - par(js_harmonic)*sin(v) &
            + par(js_harmonic + 1)*cos(v)
        if (par(js_geom) > 0.0_dp) then
            ks = par(js_ks)
            h = compensator_h(v, par(js_geom), par(js_geom + 1), par(js_geom + 2), par(js_geom + 3))
            den = 1.0_dp + c*ks*h
            ceff = c/den
            dc = 1.0_dp/den**2
            dk = -c*c*h/den**2
            dv = dc*dcv - c*c*ks*compensator_dh(v, par(js_geom), par(js_geom + 1), par(js_geom + 2), &
                par(js_geom + 3))/den**2
        else
            ceff = c
            dc = 1.0_dp
            dk = 0.0_dp
            dv = dcv
        end if
    end subroutine joint_ceff

    !> d2V/dq2 per unit k_s of a gravity compensator (docs/calibration.md
    !> section 2): s = sqrt(a^2 + b^2 - 2ab cos phi), phi = q + beta,
    !> V = k_s (s - s0)^2 / 2 -> h = s'^2 + (s - s0) s''.
    elemental real(dp) function compensator_h(q, a, b, beta, s0) result(h)
        real(dp), intent(in) :: q, a, b, beta, s0
        real(dp) :: phi, s, ds, dds
        phi = q + beta
        s = sqrt(a*a + b*b - 2.0_dp*a*b*cos(phi))
        ds = a*b*sin(phi)/s
        dds = (a*b*cos(phi) - ds*ds)/s
        h = ds*ds + (s - s0)*dds
    end function compensator_h

    !> dh/dq of compensator_h: 3 s' s'' + (s - s0) s''', from
    !> s s' = ab sin phi, s'^2 + s s'' = ab cos phi, 3 s' s'' + s s''' = -ab sin phi.
    elemental real(dp) function compensator_dh(q, a, b, beta, s0) result(dh)
        real(dp), intent(in) :: q, a, b, beta, s0
        real(dp) :: phi, s, ds, dds, ddds
        phi = q + beta
        s = sqrt(a*a + b*b - 2.0_dp*a*b*cos(phi))
        ds = a*b*sin(phi)/s
        dds = (a*b*cos(phi) - ds*ds)/s
        ddds = (-a*b*sin(phi) - 3.0_dp*ds*dds)/s
        dh = 3.0_dp*ds*dds + (s - s0)*ddds
    end function compensator_dh

    !> The joint_profile basis at q: 1, cos q, sin q, cos 2q, sin 2q.
    pure function profile_basis(q) result(f)
        real(dp), intent(in) :: q
        real(dp) :: f(5)
        f = [1.0_dp, cos(q), sin(q), cos(2.0_dp*q), sin(2.0_dp*q)]
    end function profile_basis

end module sk_laws
