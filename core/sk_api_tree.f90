!> Entry points of the kinematic-tree core that f2py wraps (bindings/_tree.pyf):
!> plain external subroutines with explicit-shape arrays of iso_c_binding
!> kinds and an integer `info` (sk_errors); the numerics live in sk_tree
!> and sk_tree_solve, whose headers define every symbol below.
!>
!> Every routine takes the model packed (sk_tree_pack): mi[nmi], mr[nmr]
!> (bindings/tree.py `pack`), with nv and ne of its header as the sizes of
!> the outputs. The model's arrays (all indices 1-based):
!>   nv virtual joints: vparent[nv] (0 = base, vparent(v) < v), vtype[nv]
!>     (0 fixed, 1 revolute, 2 prismatic), vaxis[3,nv] (unit), vrot[3,3,nv],
!>     vpos[3,nv] (from the parent's frame after motion), qcol[nv] (0: none),
!>     qcoef[nv], qconst[nv];
!>   ng geometric entries gvj[ng], gpar[ng], gcoef[ng] (joint gvj moves by
!>     gcoef * theta(gpar));
!>   nk elastic blocks ktype[nk] (sk_laws: 1 linear, 2 cubic, 3 dead zone,
!>     4 6-dof spring), kvj[6,nk] (joints of the block's coordinates; 1
!>     used for types 1-3), kpar[21,nk] (theta indices of the law's
!>     parameters, 0 = the value 0), kw0[nk] (dead-zone smoothing, N m or
!>     N); ne = number of elastic coordinates (1 per block of types 1-3, 6
!>     per type 4);
!>   nb bodies bvj[nb] (0 = base), bmass[nb] (kg), bcom[3,nb] (m, in the
!>     body's frame); grav[3] (m/s^2, base axes);
!>   tracker tpar[6] (theta indices of tx, ty, tz, a1, a2, a3), rref[3,3];
!>   nm markers mvj[nm] (frame; 0 = base), mpar[3,nm] (theta indices);
!>   nbp gravity-parameter entries bpar[3,nbp] (body, slot: 1 mass factor,
!>     2-4 centre offset x, y, z; theta index; sk_tree_grav).
!> Each call's own arguments: parameters theta[npar], postures q[ndof,np];
!> payloads lpost[nl] (posture or row), lvj[nl] (frame), lw[6,nl] (force
!> N, moment N m at the frame origin, base axes); observations opost[no],
!> omark[no], oxyz[3,no] (m, tracker frame), owt[no] (weights >= 0);
!> equilibrium eqit (0 rigid, 1 first order, >= 2 iterated, at most eqit
!> times), etol (m).
!> Every routine returns errloc[2] = [argument code, index] with an argument
!> error of the model, the postures, payloads, observations or rows (info =
!> size, nonfinite or argument): which argument and which joint, entry,
!> block, parameter, posture, payload, observation or row (the codes and
!> indices of sk_tree_check), 0 otherwise.

!> Frames after motion ra[3,3,nv,np], pa[3,nv,np], generalised gravity
!> forces of every joint wv[nv,np] and joint coordinate tauq[ndof,np],
!> deflections delta[ne,np], iterations nit[np], eqinfo[np]
!> (sk_tree%poses_batch).
subroutine sk_tree_poses(nmi, nmr, nv, ne, ndof, npar, np, nl, mi, mr, theta, q, lpost, lvj, lw, eqit, etol, &
        ra, pa, wv, tauq, delta, nit, eqinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, poses_batch
    use sk_tree_pack, only: unpack_with_inputs
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, np, nl, mi(nmi), lpost(nl), lvj(nl), eqit
    real(c_double), intent(in) :: mr(nmr), theta(npar), q(ndof, np), lw(6, nl), etol
    real(c_double), intent(out) :: ra(3, 3, nv, np), pa(3, nv, np), wv(nv, np), tauq(ndof, np), delta(ne, np)
    integer(c_int), intent(out) :: nit(np), eqinfo(np), info, errloc(2)
    type(tree_model) :: m
    ra = 0
    pa = 0
    wv = 0
    tauq = 0
    delta = 0
    nit = 0
    eqinfo = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta, q, lpost, lvj, lw, etol, m, info, errloc)
    if (info /= sk_ok) return
    call poses_batch(m, theta, q, lpost, lvj, lw, eqit, etol, ra, pa, wv, tauq, delta, nit, eqinfo, info)
end subroutine sk_tree_poses

!> Compliance c[6,6,np] of the frame of joint frame (base axes, about its
!> origin) at postures q[ndof,np] with the parameters theta[npar], those of
!> vidx[nvar] taking each posture's values vval[nvar,np], at the undeflected
!> frames with every law's tangent at zero load; its stiffness k, rank and
!> kinfo (sk_tree_point%compliance_batch).
subroutine sk_tree_compliance(nmi, nmr, nv, ne, ndof, npar, np, nvar, mi, mr, theta, vidx, vval, frame, q, &
        c, k, rank, kinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model
    use sk_tree_pack, only: unpack_with_inputs
    use sk_tree_point, only: compliance_batch
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, np, nvar, mi(nmi), vidx(nvar), frame
    real(c_double), intent(in) :: mr(nmr), theta(npar), vval(nvar, np), q(ndof, np)
    real(c_double), intent(out) :: c(6, 6, np), k(6, 6, np)
    integer(c_int), intent(out) :: rank(np), kinfo(np), info, errloc(2)
    type(tree_model) :: m
    integer(c_int) :: none(0)
    real(c_double) :: nonew(6, 0)
    c = 0
    k = 0
    rank = 0
    kinfo = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta, q, none, none, nonew, 0.0_c_double, m, info, errloc)
    if (info /= sk_ok) return
    call compliance_batch(m, theta, vidx, vval, int(frame), q, c, k, rank, kinfo, info)
end subroutine sk_tree_compliance

!> Twists g[6,ne] of the frame of joint frame (about its origin, base axes)
!> per unit elastic coordinate at posture q[ndof], undeflected
!> (sk_tree_point%twists_at): every spring's Jacobian.
subroutine sk_tree_twists(nmi, nmr, nv, ne, ndof, npar, mi, mr, theta, frame, q, g, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model
    use sk_tree_pack, only: unpack_with_inputs
    use sk_tree_point, only: twists_at
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, mi(nmi), frame
    real(c_double), intent(in) :: mr(nmr), theta(npar), q(ndof)
    real(c_double), intent(out) :: g(6, ne)
    integer(c_int), intent(out) :: info, errloc(2)
    type(tree_model) :: m
    integer(c_int) :: none(0)
    real(c_double) :: nonew(6, 0)
    g = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta, reshape(q, [ndof, 1]), none, none, nonew, 0.0_c_double, m, &
        info, errloc)
    if (info /= sk_ok) return
    call twists_at(m, theta, int(frame), q, g, info)
end subroutine sk_tree_twists

!> Predicted points pred[3,no], weighted residuals res[3*no] and Jacobian
!> jac[3*no,nfree] w.r.t. theta(free), deflections delta[ne,np], nit[np],
!> eqinfo[np] (sk_tree%evaluate).
subroutine sk_tree_evaluate(nmi, nmr, nv, ne, ndof, npar, np, nl, no, nfree, mi, mr, theta, q, lpost, lvj, lw, &
        opost, omark, oxyz, owt, free, eqit, etol, pred, res, jac, delta, nit, eqinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, tree_problem, problem_setup, evaluate
    use sk_tree_pack, only: unpack_with_inputs
    use sk_tree_check, only: observations_check
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, np, nl, no, nfree, mi(nmi)
    integer(c_int), intent(in) :: lpost(nl), lvj(nl), opost(no), omark(no), free(nfree), eqit
    real(c_double), intent(in) :: mr(nmr), theta(npar), q(ndof, np), lw(6, nl), oxyz(3, no), owt(no), etol
    real(c_double), intent(out) :: pred(3, no), res(3*no), jac(3*no, nfree), delta(ne, np)
    integer(c_int), intent(out) :: nit(np), eqinfo(np), info, errloc(2)
    type(tree_model) :: m
    type(tree_problem) :: pr
    pred = 0
    res = 0
    jac = 0
    delta = 0
    nit = 0
    eqinfo = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta, q, lpost, lvj, lw, etol, m, info, errloc)
    if (info /= sk_ok) return
    call observations_check(np, m%nm, m%npar, opost, omark, oxyz, owt, free, info, errloc)
    if (info /= sk_ok) return
    call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
    if (info /= sk_ok) return
    call evaluate(pr, theta, eqit, etol, .true., pred, res, jac, delta, nit, eqinfo, info)
end subroutine sk_tree_evaluate

!> Levenberg-Marquardt fit of theta(free) from theta0: theta[npar],
!> hist[maxit+1] (cost after each accepted step; nhist of them), niter,
!> reason, jac[3*no,nfree], res[3*no] at theta, and the re-centred tracker
!> rotation rrefout[3,3] (theta's tracker angles are then 0); prior rows
!> psw(i) (theta(ppar(i)) - pmu(i)), npri of them (sk_tree_solve%tree_lm).
subroutine sk_tree_lm(nmi, nmr, nv, ne, ndof, npar, np, nl, no, nfree, npri, mi, mr, theta0, q, lpost, lvj, lw, &
        opost, omark, oxyz, owt, free, ppar, pmu, psw, eqit, etol, maxit, ftol, xtol, gtol, theta, hist, nhist, &
        niter, reason, jac, res, rrefout, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, tree_problem, problem_setup
    use sk_tree_pack, only: unpack_with_inputs
    use sk_tree_check, only: observations_check
    use sk_tree_solve, only: tree_lm
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, np, nl, no, nfree, npri, mi(nmi)
    integer(c_int), intent(in) :: lpost(nl), lvj(nl), opost(no), omark(no), free(nfree), ppar(npri), eqit, maxit
    real(c_double), intent(in) :: mr(nmr), theta0(npar), q(ndof, np), lw(6, nl), oxyz(3, no), owt(no), &
        pmu(npri), psw(npri), etol, ftol, xtol, gtol
    real(c_double), intent(out) :: theta(npar), hist(maxit + 1), jac(3*no, nfree), res(3*no), rrefout(3, 3)
    integer(c_int), intent(out) :: nhist, niter, reason, info, errloc(2)
    type(tree_model) :: m
    type(tree_problem) :: pr
    theta = theta0
    hist = 0
    jac = 0
    res = 0
    nhist = 0
    niter = 0
    reason = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta0, q, lpost, lvj, lw, etol, m, info, errloc)
    rrefout = m%rref
    if (info /= sk_ok) return
    call observations_check(np, m%nm, m%npar, opost, omark, oxyz, owt, free, info, errloc)
    if (info /= sk_ok) return
    call problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
    if (info /= sk_ok) return
    call tree_lm(pr, theta0, eqit, etol, maxit, ftol, xtol, gtol, theta, hist, nhist, niter, reason, jac, res, &
        rrefout, info, ppar, pmu, psw)
end subroutine sk_tree_lm

!> Pose rf[3,3,np], pf[3,np] (base) of frame(i) at q[ndof,np] at
!> equilibrium and its total Jacobian jq[6,ndof,np] w.r.t. q (twist:
!> origin velocity, angular velocity, base axes); delta[ne,np], nit[np],
!> eqinfo[np] (sk_tree%frame_jacobian_batch). Payload postures lpost are
!> columns of q.
subroutine sk_tree_frame_jacobian(nmi, nmr, nv, ne, ndof, npar, np, nl, mi, mr, theta, frame, q, lpost, lvj, lw, &
        eqit, etol, rf, pf, jq, delta, nit, eqinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, frame_jacobian_batch
    use sk_tree_pack, only: unpack_with_inputs
    use sk_tree_check, only: rows_check
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, np, nl, mi(nmi), frame(np), lpost(nl), lvj(nl), eqit
    real(c_double), intent(in) :: mr(nmr), theta(npar), q(ndof, np), lw(6, nl), etol
    real(c_double), intent(out) :: rf(3, 3, np), pf(3, np), jq(6, ndof, np), delta(ne, np)
    integer(c_int), intent(out) :: nit(np), eqinfo(np), info, errloc(2)
    type(tree_model) :: m
    rf = 0
    pf = 0
    jq = 0
    delta = 0
    nit = 0
    eqinfo = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta, q, lpost, lvj, lw, etol, m, info, errloc)
    if (info /= sk_ok) return
    call rows_check(m%nv, np, frame, info, errloc)
    if (info /= sk_ok) return
    call frame_jacobian_batch(m, theta, frame, q, lpost, lvj, lw, eqit, etol, rf, pf, jq, delta, nit, eqinfo, info)
end subroutine sk_tree_frame_jacobian

!> Compensation of nr rows: qout[ndof,nr] puts frame(i) of the model at
!> rtarget[3,3,nr], ptarget[3,nr] (base); full6 1: pose, 0: position;
!> remaining errors resp[nr] (m), resr[nr] (rad), Newton steps nit[nr],
!> rinfo[nr] (sk_tree_solve%compensate_batch). Payload rows lpost; law
!> parameters theta(prow(j)) = trow(j, i) for row i (per-row values).
subroutine sk_tree_compensate(nmi, nmr, nv, ne, ndof, npar, nr, nl, npr, mi, mr, theta, frame, qcmd, rtarget, &
        ptarget, lpost, lvj, lw, prow, trow, full6, eqit, etol, maxit, ptol, rtol, qout, resp, resr, nit, rinfo, &
        info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model
    use sk_tree_pack, only: unpack_with_inputs
    use sk_tree_check, only: rows_check, params_check
    use sk_tree_solve, only: compensate_batch
    implicit none
    integer(c_int), intent(in) :: nmi, nmr, nv, ne, ndof, npar, nr, nl, npr, mi(nmi)
    integer(c_int), intent(in) :: frame(nr), lpost(nl), lvj(nl), prow(npr), full6, eqit, maxit
    real(c_double), intent(in) :: mr(nmr), theta(npar), qcmd(ndof, nr), rtarget(3, 3, nr), ptarget(3, nr), &
        lw(6, nl), trow(npr, nr), etol, ptol, rtol
    real(c_double), intent(out) :: qout(ndof, nr), resp(nr), resr(nr)
    integer(c_int), intent(out) :: nit(nr), rinfo(nr), info, errloc(2)
    type(tree_model) :: m
    qout = qcmd
    resp = 0
    resr = 0
    nit = 0
    rinfo = 0
    call unpack_with_inputs(mi, mr, nv, ne, theta, qcmd, lpost, lvj, lw, etol, m, info, errloc)
    if (info /= sk_ok) return
    call rows_check(m%nv, nr, frame, info, errloc, rtarget, ptarget)
    if (info /= sk_ok) return
    call params_check(m%npar, prow, trow, info, errloc)
    if (info /= sk_ok) return
    call compensate_batch(m, theta, frame, qcmd, rtarget, ptarget, lpost, lvj, lw, full6, eqit, etol, maxit, &
        ptol, rtol, qout, resp, resr, nit, rinfo, info, prow, trow)
end subroutine sk_tree_compensate
