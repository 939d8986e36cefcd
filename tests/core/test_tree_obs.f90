!> Unit tests of the deflection observation kinds of the tree evaluator
!> (sk_tree_model obs_deflection, obs_rotation; sk_tree_jac evaluate): on
!> the test tree (tests/core/tree_builder.f90) without gravity, a marker's
!> deflection under a payload is the first-order motion of its point and
!> the rotation of its frame (against the positions and frames of the
!> first-order model minus the rigid ones, for deflections small enough
!> that second order is below the tolerance); its Jacobian w.r.t. the law
!> and marker parameters against central differences; the arguments a
!> deflection problem refuses.
program test_tree_obs
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: rot_log
    use sk_tree
    use tree_builder
    implicit none (type, external)

    call test_kinds_are_the_motion()
    call finish('tree_obs')

contains

    subroutine test_kinds_are_the_motion()
        integer, parameter :: np = 2
        type(builder) :: b
        type(tree_model) :: m
        type(tree_problem) :: pr
        real(dp) :: q(7, np), rt(3, 3), tt(3), tw(3, 3), d0(3), dref(3), scale, err, h
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), opt(:, :), pred(:, :), res(:), jac(:, :), delta(:, :)
        real(dp), allocatable :: p0(:, :), p1(:, :), ra0(:, :, :, :), ra1(:, :, :, :), pa(:, :, :), wv(:, :), tq(:, :)
        real(dp), allocatable :: th(:), rp(:), rm(:), d2(:, :)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:), okind(:), nit(:), eqinfo(:), free(:)
        integer(ip) :: info
        integer :: k, no, f, nf, c
        call build_tree(b, 1.0e-3_dp)   ! deflections of um: second order far below the tolerance
        b%grav = 0.0_dp                 ! the payload's deflection alone
        call setup(b, m, info)
        call expect(info == sk_ok, 'obs: setup')
        call observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        no = size(opost)
        ! the rigid and first-order positions (tracker frame) and frames
        allocate(free(0), pred(3, no), res(3*no), jac(3*no, 0), delta(b%ne, np), nit(np), eqinfo(np), p0(3, no), &
            p1(3, no), ra0(3, 3, m%nv, np), ra1(3, 3, m%nv, np), pa(3, m%nv, np), wv(m%nv, np), tq(7, np))
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
        call evaluate(pr, b%theta(1:b%npar), 0_ip, 0.0_dp, .false., p0, res, jac, delta, nit, eqinfo, info)
        call evaluate(pr, b%theta(1:b%npar), 1_ip, 0.0_dp, .false., p1, res, jac, delta, nit, eqinfo, info)
        call poses_batch(m, b%theta(1:b%npar), q, lpost, lvj, lw, 0_ip, 0.0_dp, ra0, pa, wv, tq, delta, nit, eqinfo, &
            info)
        call poses_batch(m, b%theta(1:b%npar), q, lpost, lvj, lw, 1_ip, 0.0_dp, ra1, pa, wv, tq, delta, nit, eqinfo, &
            info)
        call tracker_pose(m, b%theta(1:b%npar), rt, tt, tw)
        ! the same observations as deflections (kind 2) and rotations (kind 3)
        deallocate(jac)
        allocate(okind(2*no), opt(3, 2*no), jac(6*no, 0), d2(3, 2*no))
        okind = [(obs_deflection, k = 1, no), (obs_rotation, k = 1, no)]
        opt = 0.0_dp
        call problem_setup(pr, m, q, lpost, lvj, lw, [opost, opost], [omark, omark], &
            reshape([oxyz, oxyz], [3, 2*no]), [owt, owt], free, info, okind, opt)
        call expect(info == sk_ok, 'obs: deflection problem')
        deallocate(res)
        allocate(res(6*no))
        call evaluate(pr, b%theta(1:b%npar), 100_ip, 0.0_dp, .false., d2, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'obs: deflection evaluation')
        err = 0.0_dp
        scale = 0.0_dp
        do k = 1, no
            dref = matmul(transpose(rt), p1(:, k) - p0(:, k))
            scale = max(scale, norm2(dref))
            err = max(err, norm2(d2(:, k) - dref))
            f = b%mvj(omark(k))
            d0 = rot_log(matmul(ra1(:, :, f, opost(k)), transpose(ra0(:, :, f, opost(k)))))
            err = max(err, norm2(d2(:, no + k) - d0)*m%lscale)
        end do
        print '(a, es9.2, a, es9.2, a)', 'obs: deflections ', scale, ' m, against the motion to ', err, ' m'
        call expect(scale > 1.0e-7_dp, 'obs: the payload deflects the marker')
        call expect(err < 1.0e-5_dp*scale, 'obs: deflection and rotation are the first-order motion')
        ! Jacobian: the law and marker parameters against central differences
        nf = count(b%pkind(1:b%npar) == 5 .or. b%pkind(1:b%npar) == 2)
        deallocate(free, jac)
        allocate(free(nf), jac(6*no, nf), rp(6*no), rm(6*no), th(b%npar))
        free = pack([(int(k, ip), k = 1, b%npar)], b%pkind(1:b%npar) == 5 .or. b%pkind(1:b%npar) == 2)
        call problem_setup(pr, m, q, lpost, lvj, lw, [opost, opost], [omark, omark], &
            reshape([oxyz, oxyz], [3, 2*no]), [owt, owt], free, info, okind, opt + 0.01_dp)
        call evaluate(pr, b%theta(1:b%npar), 1_ip, 0.0_dp, .true., d2, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'obs: the Jacobian')
        err = 0.0_dp
        do c = 1, nf
            k = free(c)
            th = b%theta(1:b%npar)
            h = 1.0e-4_dp*max(abs(th(k)), 1.0e-9_dp)
            th(k) = b%theta(k) + h
            call evaluate(pr, th, 1_ip, 0.0_dp, .false., d2, rp, jac(:, 1:0), delta, nit, eqinfo, info)
            th(k) = b%theta(k) - h
            call evaluate(pr, th, 1_ip, 0.0_dp, .false., d2, rm, jac(:, 1:0), delta, nit, eqinfo, info)
            err = max(err, maxval(abs((rp - rm)/(2.0_dp*h) - jac(:, c)))/max(maxval(abs(jac(:, c))), tiny(1.0_dp)))
        end do
        print '(a, i0, a, es9.2)', 'obs: Jacobian of ', nf, ' law and marker parameters vs central differences ', err
        call expect(err < 1.0e-6_dp, 'obs: the Jacobian is the central differences')
        ! refused: a free geometric parameter, positions and deflections at one posture
        call problem_setup(pr, m, q, lpost, lvj, lw, [opost, opost], [omark, omark], &
            reshape([oxyz, oxyz], [3, 2*no]), [owt, owt], [int(findloc(b%pkind, 3, dim=1), ip)], info, okind, opt)
        call expect(info == sk_err_argument, 'obs: a free geometric parameter is refused')
        okind(1) = obs_position
        call problem_setup(pr, m, q, lpost, lvj, lw, [opost, opost], [omark, omark], &
            reshape([oxyz, oxyz], [3, 2*no]), [owt, owt], free(1:0), info, okind, opt)
        call expect(info == sk_err_argument, 'obs: positions and deflections at one posture are refused')
    end subroutine test_kinds_are_the_motion

end program test_tree_obs
