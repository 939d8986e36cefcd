!> Unit tests of the tree core's solvers (sk_tree_solve): noise-free
!> recovery of the test tree's parameters by Levenberg-Marquardt, and
!> compensation by Newton on chains (pose and position targets). The test
!> tree: tests/core/tree_builder.f90.
program test_tree_solve
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: eye, svd
    use sk_tree
    use sk_tree_solve
    use tree_builder
    implicit none (type, external)

    call test_recovery()
    call test_compensate(7, 1)
    call test_compensate(4, 0)
    call finish('tree_solve')

contains

    !> Noise-free data of the test tree at 40 postures; LM from a perturbed
    !> start recovers tracker, markers, joint offsets, the frame error of L2
    !> and the joint and lateral compliances to 1e-8 (relative to their
    !> scale: 1 for geometry, their value for compliances).
    subroutine test_recovery()
        integer, parameter :: np = 40, maxit = 50
        type(builder) :: b
        type(tree_model) :: m
        type(tree_problem) :: pr
        real(dp) :: q(7, np), theta0(cap), thetaf(cap), hist(maxit + 1), worst, e, rfit(3, 3), rtrue(3, 3), tt(3), &
            tw(3, 3)
        real(dp), allocatable :: lw(:, :), oxyz(:, :), owt(:), pred(:, :), res(:), jac(:, :), delta(:, :)
        integer(ip), allocatable :: lpost(:), lvj(:), opost(:), omark(:), nit(:), eqinfo(:), free(:)
        integer(ip) :: info, nhist, niter, reason, none(0)
        integer :: k, no, nf
        logical :: pick(cap)
        character(len=160) :: msg
        call build_tree(b, 1.0_dp)
        call setup(b, m, info)
        call observations(b, q, np, lpost, lvj, lw, opost, omark, oxyz, owt)
        no = size(opost)
        ! the truth: measurements from the model itself
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, none, info)
        allocate(pred(3, no), res(3*no), delta(b%ne, np), nit(np), eqinfo(np), jac(3*no, 0))
        call evaluate(pr, b%theta(1:b%npar), 100_ip, 1.0e-13_dp, .false., pred, res, jac, delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'recovery: truth')
        oxyz = pred
        ! free: all but the torso's offset-like tracker coupling (none here),
        ! the 6-dof spring, the cubic c3 and the dead zone's law
        pick = .false.
        pick(1:b%npar) = b%pkind(1:b%npar) <= 4
        do k = 1, b%nk
            if (b%ktype(k) == law_linear) pick(b%kpar(1, k)) = .true.
        end do
        nf = count(pick)
        allocate(free(nf))
        free = pack([(k, k = 1, cap)], pick)
        call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
        call expect(info == sk_ok, 'recovery: problem')
        theta0 = b%theta
        do k = 1, nf
            select case (b%pkind(free(k)))
            case (1)
                theta0(free(k)) = theta0(free(k)) + 0.01_dp*(1 + mod(k, 3))
            case (2)
                theta0(free(k)) = theta0(free(k)) + 5.0e-3_dp*merge(1, -1, mod(k, 2) == 0)
            case (3)
                theta0(free(k)) = theta0(free(k)) + 0.01_dp
            case (4)
                theta0(free(k)) = theta0(free(k)) - 1.0e-3_dp
            case default
                theta0(free(k)) = theta0(free(k))*1.3_dp
            end select
        end do
        deallocate(jac)
        allocate(jac(3*no, nf))
        call tree_lm(pr, theta0(1:b%npar), 100_ip, 1.0e-13_dp, int(maxit, ip), 1.0e-14_dp, 1.0e-14_dp, 0.0_dp, &
            thetaf(1:b%npar), hist, nhist, niter, reason, jac, res, rfit, info)
        write (msg, '(a, i0, a, i0, a, i0, a, es9.2, a, es9.2)') 'recovery: ', nf, ' free, info ', info, &
            ', reason ', reason, ', cost ', hist(1), ' -> ', hist(nhist)
        print '(a, a, i0)', trim(msg), ', iterations ', niter
        call expect(info == sk_ok, 'recovery: LM converged')
        ! the fit re-centres the tracker rotation into rfit (its angles 0)
        call tracker_pose(m, b%theta(1:b%npar), rtrue, tt, tw)
        worst = maxval(abs(rfit - rtrue))
        call expect(worst < 1.0e-8_dp .and. all(thetaf(b%tpar(4:6)) == 0.0_dp), 'recovery: tracker rotation')
        do k = 1, nf
            if (any(b%tpar(4:6) == free(k))) cycle
            e = abs(thetaf(free(k)) - b%theta(free(k)))/b%scale(free(k))
            worst = max(worst, e)
            if (e > 1.0e-8_dp) then
                write (msg, '(a, i0, a, i0, a, es9.2)') 'recovery: parameter ', free(k), ' kind ', &
                    b%pkind(free(k)), ' error ', e
                call expect(.false., trim(msg))
            end if
        end do
        print '(a, es9.2)', 'recovery: worst relative parameter error ', worst
        call expect(all(hist(2:nhist) <= hist(1:nhist - 1)), 'recovery: cost history decreases')
    end subroutine test_recovery

    !> Compensation on an n-joint chain with offsets, frame errors, joint and
    !> lateral compliance and masses: targets from the nominal (rigid, no
    !> errors) model; the compensated command puts the identified model's
    !> tool on them to 1e-12 (full6 = 1: pose; 0: position), and the change
    !> of q is least-norm (orthogonal to the Jacobian's null space).
    subroutine test_compensate(nj, full6)
        integer, intent(in) :: nj, full6
        integer, parameter :: nr = 20
        type(builder) :: b
        type(tree_model) :: m
        real(dp) :: q(nj, nr), qout(nj, nr), resp(nr), resr(nr), rt(3, 3, nr), pt(3, nr), jq(6, nj, nr)
        real(dp) :: rf(3, 3, nr), pf(3, nr), delta(3*nj, nr), theta0(cap), axis(3), err, opt
        real(dp), allocatable :: u(:, :), s(:), vt(:, :), ra(:, :, :, :), pa(:, :, :), wv(:, :), tauq(:, :)
        real(dp) :: nol(6, 0)
        integer(ip) :: frame(nr), nit(nr), rinfo(nr), eqinfo(nr), info, none(0)
        integer :: j, v, i, k, nrow
        character(len=160) :: msg
        b%ndof = nj
        b%grav = [0.0_dp, 0.0_dp, -9.81_dp]
        call add_tracker(b, [0.0_dp, 0.0_dp, 0.0_dp], [0.0_dp, 0.0_dp, 0.0_dp], eye(3))
        v = 0
        do j = 1, nj
            axis = merge([0.0_dp, 0.0_dp, 1.0_dp], [0.0_dp, 1.0_dp, 0.0_dp], mod(j, 2) == 1)
            v = add_joint(b, v, rpy(0.1_dp*j, -0.05_dp*j, 0.2_dp), [0.05_dp, 0.02_dp*j, merge(0.3_dp, 0.1_dp, j <= 3)], &
                axis, j, 1.0_dp, 0.0_dp, fr=1.0e-3_dp*[1.0_dp, -0.5_dp, 0.3_dp, 0.8_dp, -0.6_dp, 1.0_dp]*mod(j, 3), &
                clat=[8.0e-6_dp, 5.0e-6_dp], ljoint=law_linear, lpar=[2.0e-5_dp])
            k = add_par(b, 0.01_dp*(-1)**j, 3, 1.0_dp)
            call add_geo(b, v, k, 1.0_dp)
            call add_body(b, v, 12.0_dp - j, [0.1_dp, 0.0_dp, 0.05_dp])
        end do
        v = add_joint(b, v, eye(3), [0.0_dp, 0.0_dp, 0.15_dp], axis, -1, 0.0_dp, 0.0_dp, ljoint=0)
        call setup(b, m, info)
        call expect(info == sk_ok, 'compensate: setup')
        frame = v
        do i = 1, nr
            do j = 1, nj
                q(j, i) = 1.2_dp*sin(0.7_dp*i + 1.9_dp*j) + 0.3_dp
            end do
        end do
        ! nominal targets: no geometric errors, rigid
        theta0 = 0
        call frame_jacobian_batch(m, theta0(1:b%npar), frame, q, none, none, nol, 0_ip, 1.0e-12_dp, rt, pt, jq, &
            delta, nit, eqinfo, info)
        call expect(info == sk_ok, 'compensate: nominal poses')
        call compensate_batch(m, b%theta(1:b%npar), frame, q, rt, pt, none, none, nol, int(full6, ip), 100_ip, &
            1.0e-14_dp, 20_ip, 1.0e-12_dp, 1.0e-12_dp, qout, resp, resr, nit, rinfo, info)
        call expect(info == sk_ok, 'compensate: info')
        write (msg, '(a, i0, a, i0, a, es9.2, a, es9.2, a, i0)') 'compensate: ', nj, ' joints, full6 ', full6, &
            ': max residual ', maxval(resp), ' m, ', maxval(resr), ' rad, Newton steps <= ', maxval(nit)
        print '(a)', trim(msg)
        call expect(all(rinfo == sk_ok), 'compensate: every row converged')
        call expect(maxval(resp) < 1.0e-12_dp, 'compensate: position residual < 1e-12 m')
        if (full6 == 1) call expect(maxval(resr) < 1.0e-12_dp, 'compensate: rotation residual < 1e-12 rad')
        call expect(maxval(abs(qout - q)) > 1.0e-3_dp, 'compensate: the command moved')
        ! independent check of the pose reached, and least-norm optimality
        call frame_jacobian_batch(m, b%theta(1:b%npar), frame, qout, none, none, nol, 100_ip, 1.0e-14_dp, rf, pf, jq, &
            delta, nit, eqinfo, info)
        err = maxval(norm2(pf - pt, dim=1))
        call expect(err < 2.0e-12_dp, 'compensate: the identified model reaches the target')
        ! the same through poses_batch, on the model as given (no folding)
        allocate(ra(3, 3, b%nv, nr), pa(3, b%nv, nr), wv(b%nv, nr), tauq(nj, nr))
        call poses_batch(m, b%theta(1:b%npar), qout, none, none, nol, 100_ip, 1.0e-14_dp, ra, pa, wv, tauq, delta, &
            nit, eqinfo, info)
        err = maxval(norm2(pa(:, v, :) - pt, dim=1))
        call expect(info == sk_ok .and. err < 2.0e-12_dp, 'compensate: target reached (unfolded model)')
        err = 0
        do i = 1, nr
            err = max(err, maxval(abs(ra(:, :, v, i) - rf(:, :, i))))
        end do
        call expect(err < 1.0e-14_dp .and. maxval(abs(pa(:, v, :) - pf)) < 1.0e-14_dp, &
            'compensate: folded and unfolded model agree')
        nrow = merge(6, 3, full6 == 1)
        allocate(u(nrow, nrow), s(nrow), vt(nrow, nj))
        opt = 0
        do i = 1, nr
            call svd(jq(1:nrow, :, i), u, s, vt, info)
            ! (q' - q) has no component in the null space: it lies in the row space
            opt = max(opt, norm2((qout(:, i) - q(:, i)) - matmul(transpose(vt), &
                matmul(vt, qout(:, i) - q(:, i))))/norm2(qout(:, i) - q(:, i)))
        end do
        print '(a, es9.2)', 'compensate: null-space part of the change of q (relative) ', opt
        call expect(opt < 1.0e-6_dp, 'compensate: least-norm change of q')
    end subroutine test_compensate

end program test_tree_solve
