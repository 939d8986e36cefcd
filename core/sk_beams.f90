!> Closed forms for straight prismatic beams, used to check FEA and as
!> link springs: section properties, the cantilever tip compliance of
!> Pashkevich et al. 2009 eq. 22 (Euler-Bernoulli, optional Timoshenko shear
!> terms) and the 6x6 beam stiffness of Taghvaeipour et al. 2010 eq. 24.
!>
!> Axes: the beam runs along x; y and z are the section's principal axes.
!> Iy is the second moment about y (bending in the x-z plane), Iz about z.
module sk_beams
    use sk_kinds, only: dp, ip, pi
    use sk_errors
    implicit none
    private
    public :: section_properties, cantilever_compliance, beam_stiffness_eq24
    public :: section_rectangle, section_tube

    integer(ip), parameter :: section_rectangle = 1   !> dims = [b (along y), h (along z)]
    integer(ip), parameter :: section_tube = 2        !> dims = [outer D, inner d (0: solid)]

contains

    !> props = [A, Iy, Iz, J, kappa_y, kappa_z]: area, second moments,
    !> torsion constant, Timoshenko shear coefficients (Cowper 1966).
    !> Rectangle torsion constant by its exact series (Saint-Venant):
    !> J = a b^3/3 [1 - 192 b/(pi^5 a) sum_{n odd} tanh(n pi a/(2 b))/n^5], a >= b.
    subroutine section_properties(shape, dims, nu, props, info)
        integer(ip), intent(in) :: shape
        real(dp), intent(in) :: dims(2), nu
        real(dp), intent(out) :: props(6)
        integer(ip), intent(out) :: info
        real(dp) :: a, b, s, m, kap
        integer :: n
        props = 0.0_dp
        if (.not. (nu > -1.0_dp .and. nu < 0.5_dp)) then
            info = sk_err_argument
            return
        end if
        select case (shape)
        case (section_rectangle)
            if (.not. (dims(1) > 0.0_dp .and. dims(2) > 0.0_dp)) then
                info = sk_err_argument
                return
            end if
            props(1) = dims(1)*dims(2)
            props(2) = dims(1)*dims(2)**3/12.0_dp
            props(3) = dims(2)*dims(1)**3/12.0_dp
            a = max(dims(1), dims(2))
            b = min(dims(1), dims(2))
            s = 0.0_dp
            do n = 1, 99, 2
                s = s + tanh(n*pi*a/(2.0_dp*b))/real(n, dp)**5
            end do
            props(4) = a*b**3/3.0_dp*(1.0_dp - 192.0_dp*b/(pi**5*a)*s)
            kap = 10.0_dp*(1.0_dp + nu)/(12.0_dp + 11.0_dp*nu)
            props(5:6) = kap
        case (section_tube)
            if (.not. (dims(1) > 0.0_dp .and. dims(2) >= 0.0_dp .and. dims(2) < dims(1))) then
                info = sk_err_argument
                return
            end if
            props(1) = pi/4.0_dp*(dims(1)**2 - dims(2)**2)
            props(2) = pi/64.0_dp*(dims(1)**4 - dims(2)**4)
            props(3) = props(2)
            props(4) = 2.0_dp*props(2)
            m = dims(2)/dims(1)
            kap = 6.0_dp*(1.0_dp + nu)*(1.0_dp + m*m)**2 / &
                ((7.0_dp + 6.0_dp*nu)*(1.0_dp + m*m)**2 + (20.0_dp + 12.0_dp*nu)*m*m)
            props(5:6) = kap
        case default
            info = sk_err_argument
            return
        end select
        info = sk_ok
    end subroutine section_properties

    !> Tip compliance c[6,6] of a cantilever of length l clamped at x = 0 and
    !> loaded at x = l, deflection and wrench at the tip, beam axes
    !> (eq. 22). Non-zero: c11 = L/EA, c22 = L^3/3EIz, c33 = L^3/3EIy,
    !> c44 = L/GJ, c55 = L/EIy, c66 = L/EIz, c26 = L^2/2EIz, c35 = -L^2/2EIy.
    !> (The paper prints c55 = L/3EIy and c66 = L/3EIz; a tip moment M turns
    !> the tip by ML/EI, which is what FEA gives, so we use L/EI.)
    !> timoshenko: add the shear terms L/(kappa G A) to c22 and c33.
    subroutine cantilever_compliance(l, e, g, props, timoshenko, c, info)
        real(dp), intent(in) :: l, e, g, props(6)
        logical, intent(in) :: timoshenko
        real(dp), intent(out) :: c(6, 6)
        integer(ip), intent(out) :: info
        real(dp) :: a, iy, iz, j
        c = 0.0_dp
        a = props(1); iy = props(2); iz = props(3); j = props(4)
        info = beam_args(l, e, g, props)
        if (info /= sk_ok) return
        c(1, 1) = l/(e*a)
        c(2, 2) = l**3/(3.0_dp*e*iz)
        c(3, 3) = l**3/(3.0_dp*e*iy)
        c(4, 4) = l/(g*j)
        c(5, 5) = l/(e*iy)
        c(6, 6) = l/(e*iz)
        c(2, 6) = l**2/(2.0_dp*e*iz)
        c(6, 2) = c(2, 6)
        c(3, 5) = -l**2/(2.0_dp*e*iy)
        c(5, 3) = c(3, 5)
        if (timoshenko) then
            if (.not. all(props(5:6) > 0.0_dp)) then
                info = sk_err_argument
                return
            end if
            c(2, 2) = c(2, 2) + l/(props(5)*g*a)
            c(3, 3) = c(3, 3) + l/(props(6)*g*a)
        end if
        info = sk_ok
    end subroutine cantilever_compliance

    !> 6x6 Euler-Bernoulli beam stiffness of Taghvaeipour et al. eq. 24, as
    !> printed: K = E/L [A, 12Iz/L^2, 12Iy/L^2, GJ/E, 4Iy, 4Iz] on the
    !> diagonal with K26 = 6EIz/L^2 and K35 = -6EIy/L^2. It is the inverse of
    !> eq. 22 for a beam that runs from the loaded point along +x to its
    !> clamp (eq. 22 mirrored x -> -x: the signs of c26, c35 flip).
    subroutine beam_stiffness_eq24(l, e, g, props, k, info)
        real(dp), intent(in) :: l, e, g, props(6)
        real(dp), intent(out) :: k(6, 6)
        integer(ip), intent(out) :: info
        real(dp) :: a, iy, iz, j
        k = 0.0_dp
        a = props(1); iy = props(2); iz = props(3); j = props(4)
        info = beam_args(l, e, g, props)
        if (info /= sk_ok) return
        k(1, 1) = a
        k(2, 2) = 12.0_dp*iz/l**2
        k(3, 3) = 12.0_dp*iy/l**2
        k(4, 4) = j*g/e
        k(5, 5) = 4.0_dp*iy
        k(6, 6) = 4.0_dp*iz
        k(2, 6) = 6.0_dp*iz/l
        k(6, 2) = k(2, 6)
        k(3, 5) = -6.0_dp*iy/l
        k(5, 3) = k(3, 5)
        k = e/l*k
        info = sk_ok
    end subroutine beam_stiffness_eq24

    !> sk_ok when length, moduli and section properties are all positive.
    pure integer(ip) function beam_args(l, e, g, props) result(info)
        real(dp), intent(in) :: l, e, g, props(6)
        info = sk_ok
        if (.not. (l > 0.0_dp .and. e > 0.0_dp .and. g > 0.0_dp .and. all(props(1:4) > 0.0_dp))) &
            info = sk_err_argument
    end function beam_args

end module sk_beams
