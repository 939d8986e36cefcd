!> Solvers on the tree model of sk_tree: calibration on absolute (tracker)
!> measurements by Levenberg-Marquardt, and compensation (the joint command
!> that makes the identified model reach a target pose) by Newton.
!>
!> Calibration minimises cost = 1/2 sum_i w_i |y_i(theta) - y_i^meas|^2
!> (klimchik eq. 7 with eta^T eta = diag(w); y the observation equation of
!> sk_tree) over the free parameters; the others stay at theta0. Each step
!> solves the damped problem as an augmented least-squares problem,
!>   min | [J; sqrt(lambda) D] dx + [r; 0] |,
!> with D the Marquardt scaling (running maximum of the column norms of
!> J), from the triangular factor of the QR decomposition of [J r], so the
!> normal equations (and the squared condition number) are never formed.
!> lambda follows Nielsen's rule (down by max(1/10, 1 - (2 rho - 1)^3) on
!> success, up by 2, 4, 8, ... on failure): sk_lm's, in the core's one
!> loop (sk_lm_solve lm_solve; tree_fit is the problem). Row weights let the caller wrap
!> iteratively reweighted least squares (Huber, Cauchy) around it.
!>
!> Compensation: for each row, Newton on q' with the total Jacobian of the
!> frame (through the equilibrium) so that the frame's position, and its
!> orientation when asked, equal the target: the step is the damped
!> pseudo-inverse solution plus the projection of (q - q') on the Jacobian's
!> null space, so a redundant chain converges to the nearest solution
!> (least-norm change of q); steps longer than dqmax are shortened. Rotation
!> rows are scaled by the model's lever bound so that metres and radians
!> weigh alike. With the full equilibrium (eqit >= 2) the deflections are
!> not iterated to a fixed point at every q: q and delta are Newton's
!> unknowns together, with the equilibrium residual r = delta - law(w):
!>   delta <- delta + Z dq - y,  (I - D G_ee) y = r,
!>   (J_q + J_delta Z) dq = e + J_delta y        (e: pose error),
!> one frame evaluation per step, quadratic convergence of both; a row is
!> done when the pose errors and the point motion of r are within tolerance.
!> After a step shorter than 0.05 (rad or m), the LU factors of
!> I - D G_ee are kept (chord in that matrix only: it moves with q by
!> O(|dq| |D G|), far below what would slow Newton down). Newton starts
!> from the command less the joint offsets, which that cancels exactly.
module sk_tree_solve
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: all_finite, qr_triangle, lstsq
    use sk_rotation, only: rot_log
    use sk_small_sym, only: jacobi_eig, spd_inverse_small
    use sk_spatial, only: nsym
    use sk_tree
    use sk_lm, only: lm_ftol, lm_xtol, lm_gtol, lm_zero, lm_maxit, lm_lambda
    use sk_lm_solve, only: lm_problem, lm_solve
    implicit none
    private
    public :: tree_lm, compensate_batch

    !> tree_lm's problem for the core's one LM loop (sk_lm_solve): the tree
    !> problem and theta at the last accepted step, its deflections (the
    !> trials' warm start) and data rows, the prior rows (pp, pm, pw); the
    !> last trial's theta, deflections and data rows.
    type, extends(lm_problem) :: tree_fit
        type(tree_problem) :: pl
        integer(ip) :: eqit = 0
        real(dp) :: etol = 0.0_dp
        real(dp), allocatable :: theta(:), thetat(:), dacc(:, :), dlast(:, :), jac(:, :), res(:), jlast(:, :), &
            rlast(:), pred(:, :), pm(:), pw(:)
        integer(ip), allocatable :: pp(:), nit(:), eqinfo(:)
    contains
        procedure :: eval => tree_fit_eval
        procedure :: accepted => tree_fit_accepted
        procedure :: augment => tree_fit_augment
    end type tree_fit

    !> joint-space tolerance (rad or m) of the least-norm condition of a
    !> redundant chain: the null-space component of q_cmd - q' (1e-8 rad
    !> moves a 1 m arm by 1e-8 m along the solution manifold, where the pose
    !> error stays below ptol)
    real(dp), parameter :: qtol = 1.0e-8_dp
    !> longest Newton step of the compensation (rad or m): compensations are
    !> small, and near a singular posture the full step would leave the
    !> region where the linearisation holds
    real(dp), parameter :: dqmax = 0.2_dp

    !> reasons the fit stopped (tree_lm reason; sk_lm)
    public :: lm_ftol, lm_xtol, lm_gtol, lm_zero, lm_maxit, lm_lambda

contains

    !> Levenberg-Marquardt fit of theta(free) on problem pr from theta0
    !> (module header; the iteration is sk_lm's: step, acceptance, lambda,
    !> scales and stopping tests). eqit, etol: equilibrium (sk_tree); maxit:
    !> most iterations (Jacobian evaluations); stop when the actual and
    !> predicted relative cost reductions are below ftol (reason 1), the
    !> scaled step |D dx| is below xtol (|D x| + xtol) (2), every column of J
    !> is within gtol of orthogonal to the residual (3), or the cost is zero
    !> (4). Outputs: theta[npar], hist[maxit+1] the cost after each accepted
    !> step (hist(1) at theta0; nhist entries), niter iterations, reason, and
    !> jac[3*nobs,nfree], res[3*nobs] at the returned theta (as evaluate),
    !> rref[3,3]: after every accepted step the tracker rotation is
    !> re-centred (rref <- rref Rx(a1) Ry(a2) Rz(a3), the angles set to 0),
    !> so the returned angles are 0 and the tracker is Trans(t) * rref.
    !> info: sk_ok on reasons 1-4; sk_err_noconv on reason 5 (maxit) and 6
    !> (lambda above 1e16: no decrease found), theta then the best found;
    !> an evaluate error at theta0 is returned as it is.
    !> Optional prior rows (a weak prior toward known values, e.g. the
    !> URDF's masses): psw(i) (theta(ppar(i)) - pmu(i)) joins the residual
    !> of the iteration (and hist's cost); jac and res hold the data rows
    !> only. sk_err_argument when ppar is out of range or psw < 0.
    subroutine tree_lm(pr, theta0, eqit, etol, maxit, ftol, xtol, gtol, theta, hist, nhist, niter, reason, &
            jac, res, rref, info, ppar, pmu, psw)
        type(tree_problem), intent(in) :: pr
        real(dp), intent(in) :: theta0(:), etol, ftol, xtol, gtol
        integer(ip), intent(in), optional :: ppar(:)
        real(dp), intent(in), optional :: pmu(:), psw(:)
        integer(ip), intent(in) :: eqit, maxit
        real(dp), intent(out) :: theta(:), hist(:), jac(:, :), res(:), rref(3, 3)
        integer(ip), intent(out) :: nhist, niter, reason, info
        type(tree_fit) :: tf
        real(dp), allocatable :: delta(:, :), jaug(:, :), raug(:), x(:)
        integer(ip), allocatable :: nit(:), eqinfo(:)
        integer :: n, mrow, npri
        n = pr%nfree
        mrow = 3*pr%nobs
        theta = 0.0_dp
        rref = pr%m%rref
        hist = 0.0_dp
        nhist = 0
        niter = 0
        reason = 0
        jac = 0.0_dp
        res = 0.0_dp
        info = sk_err_size
        if (size(theta0) /= pr%m%npar .or. size(theta) /= pr%m%npar .or. size(hist) < maxit + 1 &
            .or. any(shape(jac) /= [mrow, n]) .or. size(res) /= mrow .or. mrow < n) return
        info = sk_err_argument
        if (maxit < 0 .or. .not. (ftol >= 0.0_dp .and. xtol >= 0.0_dp .and. gtol >= 0.0_dp)) return
        npri = 0
        if (present(ppar)) npri = size(ppar)
        allocate(tf%pp(npri), tf%pm(npri), tf%pw(npri))
        if (npri > 0) then
            info = sk_err_size
            if (.not. (present(pmu) .and. present(psw))) return
            if (size(pmu) /= npri .or. size(psw) /= npri) return
            info = sk_err_argument
            if (any(ppar < 1) .or. any(ppar > pr%m%npar)) return
            if (.not. all(psw >= 0.0_dp)) return
            info = sk_err_nonfinite
            if (.not. (all_finite(pmu) .and. all_finite(psw))) return
            tf%pp = ppar
            tf%pm = pmu
            tf%pw = psw
        end if
        allocate(jaug(mrow + npri, n), raug(mrow + npri), delta(pr%m%ne, pr%np), nit(pr%np), eqinfo(pr%np))
        allocate(tf%pred(3, pr%nobs), tf%dlast(pr%m%ne, pr%np), tf%nit(pr%np), tf%eqinfo(pr%np), &
            tf%jlast(mrow, n), tf%rlast(mrow))
        tf%pl = pr
        tf%eqit = eqit
        tf%etol = etol
        tf%theta = theta0
        call evaluate(tf%pl, tf%theta, eqit, etol, .true., tf%pred, res, jac, delta, nit, eqinfo, info)
        if (info /= sk_ok) return
        call tf%augment(tf%theta, jac, res, jaug, raug)
        ! trials start their equilibria from the deflections at the last
        ! accepted theta (sk_tree%evaluate, warm): the same fixed point to
        ! etol in a few steps instead of a cold start's many
        tf%dacc = delta
        tf%jac = jac
        tf%res = res
        tf%thetat = tf%theta
        x = tf%theta(pr%free)
        call lm_solve(tf, x, jaug, raug, maxit, ftol, xtol, gtol, niter, reason, info, hist, nhist)
        theta = tf%theta
        jac = tf%jac
        res = tf%res
        rref = tf%pl%m%rref
        if (info /= sk_ok) return
        info = merge(sk_err_noconv, sk_ok, reason == lm_maxit .or. reason == lm_lambda)
    end subroutine tree_lm

    !> tree_lm's residual at the free values x: the data rows at theta with
    !> theta(free) = x (equilibria warm from the last accepted ones), then
    !> the prior rows.
    subroutine tree_fit_eval(self, x, jac, res, ok)
        class(tree_fit), intent(inout) :: self
        real(dp), intent(in) :: x(:)
        real(dp), intent(out) :: jac(:, :), res(:)
        logical, intent(out) :: ok
        integer(ip) :: tinfo
        self%thetat = self%theta
        self%thetat(self%pl%free) = x
        call evaluate(self%pl, self%thetat, self%eqit, self%etol, .true., self%pred, self%rlast, self%jlast, &
            self%dlast, self%nit, self%eqinfo, tinfo, warm=self%dacc)
        call self%augment(self%thetat, self%jlast, self%rlast, jac, res)
        ok = tinfo == sk_ok
    end subroutine tree_fit_eval

    !> An accepted trial: its theta, deflections and data rows; then the
    !> tracker rotation re-centred, rref <- rref Rx Ry Rz, angles 0 (the
    !> same poses and Jacobian columns; never near gimbal lock).
    subroutine tree_fit_accepted(self, x)
        class(tree_fit), intent(inout) :: self
        real(dp), intent(inout) :: x(:)
        real(dp) :: rt(3, 3), tt(3), tw(3, 3)
        self%theta = self%thetat
        self%dacc = self%dlast
        self%res = self%rlast
        self%jac = self%jlast
        call tracker_pose(self%pl%m, self%theta, rt, tt, tw)
        self%pl%m%rref = rt
        self%theta(self%pl%m%tpar(4:6)) = 0.0_dp
        x = self%theta(self%pl%free)
    end subroutine tree_fit_accepted

    !> The data rows (j, r) at th followed by the prior rows, in jaug, raug.
    pure subroutine tree_fit_augment(self, th, j, r, jaug, raug)
        class(tree_fit), intent(in) :: self
        real(dp), intent(in) :: th(:), j(:, :), r(:)
        real(dp), intent(out) :: jaug(:, :), raug(:)
        integer :: c, i, mrow
        mrow = size(r)
        jaug(1:mrow, :) = j
        raug(1:mrow) = r
        jaug(mrow + 1:, :) = 0.0_dp
        do i = 1, size(self%pp)
            raug(mrow + i) = self%pw(i)*(th(self%pp(i)) - self%pm(i))
            c = self%pl%colof(self%pp(i))
            if (c > 0) jaug(mrow + i, c) = self%pw(i)
        end do
    end subroutine tree_fit_augment

    !> Compensation of n rows: for row i, the joint command qout(:,i) that
    !> puts frame(i) of the identified model (theta, equilibrium with the
    !> row's payloads lpost = i, lvj, lw) at the target pose rtarget(:,:,i),
    !> ptarget(:,i) (base). full6 = 1: position and orientation, 0: position
    !> only. Newton from qcmd(:,i) (module header); stops when the position
    !> error is below ptol (m) and, for full6, the rotation error below rtol
    !> (rad), or after maxit steps. Outputs: qout[ndof,n], the remaining
    !> errors resp[n] (m) and resr[n] (rad, rotation vector of
    !> R_target R^T), Newton steps nit[n], rinfo[n] = sk_ok or
    !> sk_err_noconv (tolerances or the equilibrium not met). info: input
    !> errors only (size, NaN, out-of-range frame or rotation). eqit >= 2
    !> solves the equilibrium inside the Newton iteration (module header),
    !> to etol; eqit 0 or 1 evaluate the rigid or first-order model at each q.
    !> Optional per-row law parameters: theta(prow(j)) = trow(j, i) for
    !> row i (a compliance that depends on the posture, evaluated by the
    !> caller); prow must name law parameters only (not geometric ones,
    !> which the folding takes at theta): else sk_err_argument.
    subroutine compensate_batch(m, theta, frame, qcmd, rtarget, ptarget, lpost, lvj, lw, full6, eqit, etol, &
            maxit, ptol, rtol, qout, resp, resr, nit, rinfo, info, prow, trow)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), qcmd(:, :), rtarget(:, :, :), ptarget(:, :), lw(:, :), etol, ptol, rtol
        integer(ip), intent(in) :: frame(:), lpost(:), lvj(:), full6, eqit, maxit
        real(dp), intent(out) :: qout(:, :), resp(:), resr(:)
        integer(ip), intent(out) :: nit(:), rinfo(:), info
        integer(ip), intent(in), optional :: prow(:)
        real(dp), intent(in), optional :: trow(:, :)
        type(tree_model) :: mf
        integer, allocatable :: lstart(:), lidx(:), pr(:)
        real(dp), allocatable :: tr(:, :)
        integer :: newidx(0:m%nv), i, n, nd
        n = size(qcmd, 2)
        nd = m%ndof
        qout = 0.0_dp
        resp = 0.0_dp
        resr = 0.0_dp
        nit = 0
        rinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(qcmd, 1) /= nd .or. size(frame) /= n &
            .or. any(shape(rtarget) /= [3, 3, n]) .or. any(shape(ptarget) /= [3, n]) &
            .or. size(lvj) /= size(lpost) .or. any(shape(lw) /= [6, size(lpost)]) &
            .or. any(shape(qout) /= [nd, n]) .or. size(resp) /= n .or. size(resr) /= n &
            .or. size(nit) /= n .or. size(rinfo) /= n) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(qcmd) .and. all_finite(rtarget) .and. all_finite(ptarget) &
            .and. all_finite(lw) .and. etol == etol .and. ptol == ptol .and. rtol == rtol)) return
        info = sk_err_argument
        if (any(frame < 0) .or. any(frame > m%nv) .or. any(lvj < 0) .or. any(lvj > m%nv) .or. maxit < 0 &
            .or. full6 < 0 .or. full6 > 1) return
        do i = 1, n
            if (.not. is_rotation(rtarget(:, :, i))) return
        end do
        allocate(pr(0), tr(0, n))
        if (present(prow) .neqv. present(trow)) return
        if (present(prow)) then
            info = sk_err_size
            if (any(shape(trow) /= [size(prow), n])) return
            info = sk_err_nonfinite
            if (.not. all_finite(trow)) return
            info = sk_err_argument
            if (any(prow < 1) .or. any(prow > m%npar)) return
            do i = 1, size(prow)
                if (any(m%gpar == prow(i)) .or. any(m%tpar == prow(i)) .or. any(m%mpar == prow(i))) return
            end do
            pr = prow
            tr = trow
        end if
        info = sk_err_argument
        call group_by(lpost, n, lstart, lidx, info)
        if (info /= sk_ok) return
        ! the frames of the rows and payloads stay; constant joints fold away
        call fold_for_frames(m, theta, frame, lvj, mf, newidx, info)
        if (info /= sk_ok) return
        call compensate_rows(mf, theta, newidx(frame), qcmd, rtarget, ptarget, lstart, lidx, newidx(lvj), lw, &
            full6, eqit, etol, maxit, ptol, rtol, qout, resp, resr, nit, rinfo, pr, tr)
        info = sk_ok
    end subroutine compensate_batch

    !> The rows of compensate_batch on a validated (folded) model.
    subroutine compensate_rows(m, theta0, frame, qcmd, rtarget, ptarget, lstart, lidx, lvj, lw, full6, eqit, etol, &
            maxit, ptol, rtol, qout, resp, resr, nit, rinfo, prow, trow)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta0(:), qcmd(:, :), rtarget(:, :, :), ptarget(:, :), lw(:, :), etol, ptol, rtol, &
            trow(:, :)
        integer, intent(in) :: frame(:), lstart(:), lidx(:), lvj(:), prow(:)
        integer(ip), intent(in) :: full6, eqit, maxit
        real(dp), intent(inout) :: qout(:, :), resp(:), resr(:)
        integer(ip), intent(inout) :: nit(:), rinfo(:)
        type(tree_state) :: st
        integer :: ent_vj(m%nv), ent_col(m%nv), nent, i, n, nd, nr, it, k, f
        integer :: lawcol(nsym, m%nk)
        integer(ip) :: lvjp(size(lvj))
        real(dp) :: ent_coef(m%nv), zq(m%ne, m%ndof + 1), jq(6, m%ndof + 1), rf(3, 3), pf(3), ep(3), er(3), b(6), &
            re(m%ne), dqlast, qoff(m%ndof)
        real(dp), allocatable :: a(:, :), q(:), dq(:), dqn(:)
        real(dp) :: theta(size(theta0))
        logical :: seen(m%ndof)
        integer :: v, g
        logical :: done, coupled, reuse, factored
        integer(ip) :: sinfo
        integer, allocatable :: lsel(:)
        n = size(qcmd, 2)
        nd = m%ndof
        lvjp = lvj
        theta = theta0
        call q_drivers(m, ent_vj, ent_col, ent_coef, nent)
        lawcol = 0
        nr = merge(6, 3, full6 == 1)
        k = min(nr, nd)
        allocate(a(nr, nd), q(nd), dq(nd), dqn(nd))
        call state_init(m, st, m%qcol > 0)
        coupled = eqit >= 2 .and. m%ne > 0
        ! start: the command less the joint offsets (those of the first
        ! joint each coordinate drives), which it cancels exactly
        qoff = 0.0_dp
        seen = .false.
        do v = 1, m%nv
            if (m%qcol(v) == 0 .or. m%vtype(v) == vj_fixed) cycle
            if (seen(m%qcol(v)) .or. m%qcoef(v) == 0.0_dp) cycle
            seen(m%qcol(v)) = .true.
            do g = m%gstart(v), m%gstart(v + 1) - 1
                qoff(m%qcol(v)) = qoff(m%qcol(v)) + m%gcoef(g)*theta(m%gpar(g))/m%qcoef(v)
            end do
        end do
        do i = 1, n
            f = frame(i)
            q = qcmd(:, i) - qoff
            if (size(prow) > 0) theta(prow) = trow(:, i)
            lsel = lidx(lstart(i):lstart(i + 1) - 1)
            done = .false.
            factored = .false.
            dqlast = huge(1.0_dp)
            st%delta = 0.0_dp
            do it = 0, maxit
                if (coupled) then
                    ! one frame evaluation per step: q and the deflections are
                    ! solved together (re: the equilibrium residual)
                    call posture_values(m, theta, q, st)
                    st%eqit = eqit
                    call deflected_frames(m, st)
                    call load_state(m, st, lsel, lvjp, lw)
                    call apply_laws(m, st, re)
                    re = st%delta - re
                    st%conv = deflection_change(m, re) <= etol
                else
                    call solve_posture(m, theta, q, lsel, lvjp, lw, eqit, etol, .false., st)
                    re = 0.0_dp
                end if
                if (f > 0) then
                    rf = st%ra(:, :, f)
                    pf = st%pa(:, f)
                else
                    rf = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
                    pf = 0.0_dp
                end if
                ep = ptarget(:, i) - pf
                er = rot_log(matmul(rtarget(:, :, i), transpose(rf)))
                resp(i) = norm2(ep)
                resr(i) = norm2(er)
                nit(i) = it
                done = st%conv .and. resp(i) <= ptol .and. (full6 == 0 .or. resr(i) <= rtol)
                if ((done .and. nd <= nr) .or. it == maxit .or. k == 0) exit
                ! total Jacobian J = J_q + J_delta Z; column nd + 1: J_delta y,
                ! the frame motion of the equilibrium correction y. After a step
                ! shorter than 0.05, the factors of I - D G_ee are kept (they
                ! change with q by O(|dq| |D G|), far less than Newton needs)
                reuse = factored .and. dqlast <= 0.05_dp
                call elastic_sensitivity(m, st, ent_vj(1:nent), ent_col(1:nent), ent_coef(1:nent), lawcol, &
                    zq(:, 1:nd), sinfo, re, zq(:, nd + 1), reuse)
                if (sinfo /= sk_ok) exit
                factored = .true.
                call frame_jacobian(m, st, f, zq, rf, pf, jq)
                a(1:3, :) = jq(1:3, 1:nd)
                b(1:3) = ep + jq(1:3, nd + 1)
                if (nr == 6) then
                    a(4:6, :) = m%lscale*jq(4:6, 1:nd)
                    b(4:6) = m%lscale*(er + jq(4:6, nd + 1))
                end if
                call least_norm_step(a, b(1:nr), qcmd(:, i) - q, dq, dqn)
                ! a redundant chain stops when the change of q is least-norm too;
                ! a null-space step below qtol is left out (its round-off would
                ! keep the pose error at its floor)
                if (done .and. norm2(dqn) <= qtol) exit
                if (norm2(dqn) > qtol) dq = dq + dqn
                ! a step near a singular posture is cut to dqmax
                if (norm2(dq) > dqmax) dq = dq*(dqmax/norm2(dq))
                dqlast = norm2(dq)
                q = q + dq
                if (coupled) st%delta = st%delta + matmul(zq(:, 1:nd), dq) - zq(:, nd + 1)
            end do
            qout(:, i) = q
            rinfo(i) = merge(sk_ok, sk_err_noconv, done)
        end do
    end subroutine compensate_rows

    !> Newton step of the compensation for rows a[nr,nd] and errors b[nr]:
    !> dq = A^+ b, the least-norm (least-squares when nd < nr) solution, and
    !> dqn = (I - A^+ A) pull, the part of the pull towards the command in
    !> A's null space. Through the small matrix A A^T (A^T A when nd < nr)
    !> with a ridge of 1e-15 of its trace: Cholesky (spd_inverse_small), or, when
    !> that fails (a singular posture), its eigenvectors by cyclic Jacobi
    !> with the eigenvalues below 1e-14 of the largest dropped.
    subroutine least_norm_step(a, b, pull, dq, dqn)
        real(dp), intent(in) :: a(:, :), b(:), pull(:)
        real(dp), intent(out) :: dq(:), dqn(:)
        integer :: nr, nd
        nr = size(a, 1)
        nd = size(a, 2)
        if (nd >= nr) then
            call row_form(nr)
        else
            call column_form(nd)
        end if
    contains
        subroutine row_form(n)
            integer, intent(in) :: n
            real(dp) :: mi(n, n), t(n)
            mi = gram_inverse(n, matmul(a, transpose(a)))
            t = matmul(mi, b)
            dq = matmul(t, a)
            dqn = 0.0_dp
            if (size(a, 2) == n) return
            t = matmul(mi, matmul(a, pull))
            dqn = pull - matmul(t, a)
        end subroutine row_form
        subroutine column_form(n)
            integer, intent(in) :: n
            dq = matmul(gram_inverse(n, matmul(transpose(a), a)), matmul(b, a))
            dqn = 0.0_dp
        end subroutine column_form
        !> Inverse of a Gram matrix mm[n,n] with a 1e-15 trace ridge; where
        !> that is not positive definite, the pseudo-inverse by eigenvalues
        !> (those below 1e-14 of the largest dropped).
        function gram_inverse(n, mm0) result(mi)
            integer, intent(in) :: n
            real(dp), intent(in) :: mm0(n, n)
            real(dp) :: mi(n, n), mm(n, n), lam(n), u(n, n), lmax, bound
            logical :: ok
            integer :: i
            mm = mm0
            lmax = 0.0_dp
            do i = 1, n
                lmax = lmax + mm(i, i)
            end do
            do i = 1, n
                mm(i, i) = mm(i, i) + 1.0e-15_dp*lmax
            end do
            call spd_inverse_small(n, mm, mi, bound, ok)
            if (ok) return
            call jacobi_eig(n, mm, lam, u)
            lmax = max(lam(n), tiny(1.0_dp))
            mi = 0.0_dp
            do i = 1, n
                if (lam(i) > 1.0e-14_dp*lmax) mi = mi + spread(u(:, i), 2, n)*spread(u(:, i), 1, n)/lam(i)
            end do
        end function gram_inverse
    end subroutine least_norm_step

end module sk_tree_solve
