!> Unit tests of the effect laws (sk_laws): for every law, d delta/dw,
!> d delta/d(slot) and d delta/dv of law_derivs against central
!> differences of law_delta, and law_joint's special cases against the
!> simpler laws (linear, harmonic, cubic, dead zone) and the closed form of
!> a compensated joint, c / (1 + c k_s h).
program test_laws
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp
    use sk_spatial, only: nsym
    use sk_laws
    implicit none (type, external)

    call test_derivatives()
    call test_joint_cases()
    call finish('laws')

contains

    !> A block's 21 slots for law k: small compliances, a compensator.
    function slots(k) result(par)
        integer, intent(in) :: k
        real(dp) :: par(nsym)
        integer :: j
        do j = 1, nsym
            par(j) = 1.0e-4_dp*(1.0_dp + 0.37_dp*j) * merge(-1.0_dp, 1.0_dp, mod(j, 3) == 0)
        end do
        if (k == law_joint) then
            par(js_cubic) = 2.0e-9_dp
            par(js_backlash) = 3.0e-4_dp
            par(js_ks) = 4.0e3_dp
            par(js_geom:js_geom + 3) = [0.3_dp, 0.5_dp, 0.2_dp, 0.25_dp]
        end if
    end function slots

    subroutine test_derivatives()
        real(dp), parameter :: w0 = 40.0_dp, v = 0.7_dp, hw = 1.0e-3_dp, hp = 1.0e-7_dp, hv = 1.0e-6_dp
        real(dp) :: par(nsym), pp(nsym), w(6), wp(6), dmat(6, 6), dpar(6, nsym), dval(6), d1(6), d2(6), fd(6), err
        integer :: k, n, i, j
        character(len=40) :: label
        do k = 1, nlaw
            n = law_ndof(k)
            par = slots(k)
            w(1:n) = [(25.0_dp*(i - 3.2_dp), i = 1, n)]
            call law_derivs(k, par, w0, v, w(1:n), dmat(1:n, 1:n), dpar(1:n, :), dval(1:n))
            err = 0.0_dp
            do i = 1, n
                wp(1:n) = w(1:n)
                wp(i) = w(i) + hw
                call law_delta(k, par, w0, v, wp(1:n), d1(1:n))
                wp(i) = w(i) - hw
                call law_delta(k, par, w0, v, wp(1:n), d2(1:n))
                fd(1:n) = (d1(1:n) - d2(1:n))/(2.0_dp*hw)
                err = max(err, maxval(abs(fd(1:n) - dmat(1:n, i)))/maxval(abs(dmat(1:n, 1:n))))
            end do
            write (label, '(a,i0)') 'd delta/dw of law ', k
            call expect(err < 1.0e-6_dp, trim(label))
            err = 0.0_dp
            ! every slot but law_joint's constant geometry
            do j = 1, merge(js_ks, law_nslot(k), k == law_joint)
                pp = par
                pp(j) = par(j) + hp*max(abs(par(j)), 1.0e-6_dp)
                call law_delta(k, pp, w0, v, w(1:n), d1(1:n))
                pp(j) = par(j) - hp*max(abs(par(j)), 1.0e-6_dp)
                call law_delta(k, pp, w0, v, w(1:n), d2(1:n))
                fd(1:n) = (d1(1:n) - d2(1:n))/(2.0_dp*hp*max(abs(par(j)), 1.0e-6_dp))
                err = max(err, maxval(abs(fd(1:n) - dpar(1:n, j)))/max(maxval(abs(dpar(1:n, j))), 1.0e-30_dp))
            end do
            write (label, '(a,i0)') 'd delta/d(slot) of law ', k
            call expect(err < 1.0e-6_dp, trim(label))
            call law_delta(k, par, w0, v + hv, w(1:n), d1(1:n))
            call law_delta(k, par, w0, v - hv, w(1:n), d2(1:n))
            fd(1:n) = (d1(1:n) - d2(1:n))/(2.0_dp*hv)
            write (label, '(a,i0)') 'd delta/dv of law ', k
            call expect(maxval(abs(fd(1:n) - dval(1:n))) <= 1.0e-6_dp*max(maxval(abs(d1(1:n))), 1.0e-30_dp), &
                trim(label))
        end do
    end subroutine test_derivatives

    subroutine test_joint_cases()
        real(dp), parameter :: w0 = 40.0_dp, v = -1.1_dp, w(1) = [310.0_dp]
        real(dp) :: pj(nsym), pl(nsym), d1(1), d2(1), h, c
        pj = 0.0_dp
        pl = 0.0_dp
        ! linear and harmonic
        pj(js_c) = 2.0e-6_dp
        pj(js_harmonic:js_harmonic + 1) = [3.0e-7_dp, -1.0e-7_dp]
        pl(1:3) = [2.0e-6_dp, 3.0e-7_dp, -1.0e-7_dp]
        call law_delta(law_joint, pj, w0, v, w, d1)
        call law_delta(law_harmonic, pl, w0, v, w, d2)
        call expect(abs(d1(1) - d2(1)) <= 1.0e-15_dp*abs(d2(1)), 'law_joint: the harmonic law')
        ! profile p0 .. p4 on 1, cos v, sin v, cos 2v, sin 2v
        pj = 0.0_dp
        pj(js_profile:js_profile + 4) = [1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp]*1.0e-7_dp
        call law_delta(law_joint, pj, w0, v, w, d1)
        c = 1.0e-7_dp*(1.0_dp + 2.0_dp*cos(v) + 3.0_dp*sin(v) + 4.0_dp*cos(2*v) + 5.0_dp*sin(2*v))
        call expect(abs(d1(1) - c*w(1)) <= 1.0e-15_dp*abs(c*w(1)), 'law_joint: the profile')
        ! cubic and dead zone
        pj = 0.0_dp
        pj(js_c) = 2.0e-6_dp
        pj(js_cubic) = 1.0e-11_dp
        pj(js_backlash) = 2.0e-4_dp
        call law_delta(law_joint, pj, w0, v, w, d1)
        d2(1) = 2.0e-6_dp*w(1) + 1.0e-11_dp*w(1)**3 + 2.0e-4_dp*tanh(w(1)/w0)
        call expect(abs(d1(1) - d2(1)) <= 1.0e-15_dp*abs(d2(1)), 'law_joint: cubic and dead zone')
        ! compensator: 1/c_eff = 1/c + k_s h
        pj = 0.0_dp
        pj(js_c) = 2.0e-6_dp
        pj(js_ks) = 5.0e3_dp
        pj(js_geom:js_geom + 3) = [0.3_dp, 0.5_dp, 0.2_dp, 0.25_dp]
        h = compensator_h(v, 0.3_dp, 0.5_dp, 0.2_dp, 0.25_dp)
        call law_delta(law_joint, pj, w0, v, w, d1)
        c = 1.0_dp/(1.0_dp/2.0e-6_dp + 5.0e3_dp*h)
        call expect(abs(d1(1) - c*w(1)) <= 1.0e-13_dp*abs(c*w(1)), 'law_joint: the compensated joint')
        call expect(law_nslot(law_joint) == js_nslot .and. law_ndof(law_joint) == 1, 'law_joint: slots')
    end subroutine test_joint_cases

end program test_laws
