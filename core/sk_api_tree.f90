!> Entry points of the kinematic-tree core that f2py wraps (bindings/_tree.pyf):
!> plain external subroutines with explicit-shape arrays of iso_c_binding
!> kinds and an integer `info` (sk_errors); the numerics live in sk_tree
!> and sk_tree_solve, whose headers define every symbol below.
!>
!> Every routine takes the same model description (sizes first):
!>   nv virtual joints: vparent[nv] (0 = base, vparent(v) < v), vtype[nv]
!>     (0 fixed, 1 revolute, 2 prismatic), vaxis[3,nv] (unit), vrot[3,3,nv],
!>     vpos[3,nv] (from the parent's frame after motion), qcol[nv] (0: none),
!>     qcoef[nv], qconst[nv];
!>   ng geometric entries gvj[ng], gpar[ng], gcoef[ng] (joint gvj moves by
!>     gcoef * theta(gpar));
!>   nk elastic blocks ktype[nk] (1 linear, 2 cubic, 3 dead zone, 4 6-dof
!>     spring), kvj[6,nk] (joints of the block's coordinates; 1 used for
!>     types 1-3), kpar[21,nk] (theta indices of the law's parameters, 0 =
!>     the value 0), kw0[nk] (dead-zone smoothing, N m or N); ne = number
!>     of elastic coordinates (1 per block of types 1-3, 6 per type 4);
!>   nb bodies bvj[nb] (0 = base), bmass[nb] (kg), bcom[3,nb] (m, in the
!>     body's frame); grav[3] (m/s^2, base axes);
!>   tracker tpar[6] (theta indices of tx, ty, tz, a1, a2, a3), rref[3,3];
!>   nm markers mvj[nm] (frame; 0 = base), mpar[3,nm] (theta indices);
!>   nbp gravity-parameter entries bpar[3,nbp] (body, slot: 1 mass factor,
!>     2-4 centre offset x, y, z; theta index; sk_tree_grav);
!>   npar parameters theta[npar]; ndof joint coordinates.
!> All indices are 1-based. Payloads: lpost[nl] (posture or row), lvj[nl]
!> (frame), lw[6,nl] (force N, moment N m at the frame origin, base axes).
!> Observations: opost[no], omark[no], oxyz[3,no] (m, tracker frame),
!> owt[no] (weights >= 0). Equilibrium: eqit (0 rigid, 1 first order,
!> >= 2 iterated, at most eqit times), etol (m).
!> Every routine returns errloc[2] = [argument code, index] with an argument
!> error (info = size, nonfinite or argument): which argument and which
!> joint, entry, block, parameter, posture, payload, observation or row
!> (the codes and indices of sk_tree_check), 0 otherwise.

!> Frames after motion ra[3,3,nv,np], pa[3,nv,np], generalised gravity
!> forces of every joint wv[nv,np] and joint coordinate tauq[ndof,np],
!> deflections delta[ne,np], iterations nit[np], eqinfo[np]
!> (sk_tree%poses_batch).
subroutine sk_tree_poses(nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl, &
        vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, kpar, kw0, &
        bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, bpar, theta, q, lpost, lvj, lw, eqit, etol, &
        ra, pa, wv, tauq, delta, nit, eqinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, model_body_params, model_setup, poses_batch
    use sk_tree_check, only: inputs_check
    implicit none
    integer(c_int), intent(in) :: nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl
    integer(c_int), intent(in) :: vparent(nv), vtype(nv), qcol(nv), gvj(ng), gpar(ng), ktype(nk), kvj(6, nk), &
        kpar(21, nk), bvj(nb), tpar(6), mvj(nm), mpar(3, nm), bpar(3, nbp)
    real(c_double), intent(in) :: vaxis(3, nv), vrot(3, 3, nv), vpos(3, nv), qcoef(nv), qconst(nv), gcoef(ng), &
        kw0(nk), bmass(nb), bcom(3, nb), grav(3), rref(3, 3)
    real(c_double), intent(in) :: theta(npar), q(ndof, np), lw(6, nl), etol
    integer(c_int), intent(in) :: lpost(nl), lvj(nl), eqit
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
    errloc = 0
    call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, &
        kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, errloc)
    if (info /= sk_ok) return
    call inputs_check(m%nv, m%ndof, m%npar, theta, q, lpost, lvj, lw, etol, info, errloc)
    if (info /= sk_ok) return
    call model_body_params(m, bpar, info)
    if (info /= sk_ok) return
    call poses_batch(m, theta, q, lpost, lvj, lw, eqit, etol, ra, pa, wv, tauq, delta, nit, eqinfo, info)
end subroutine sk_tree_poses

!> Predicted points pred[3,no], weighted residuals res[3*no] and Jacobian
!> jac[3*no,nfree] w.r.t. theta(free), deflections delta[ne,np], nit[np],
!> eqinfo[np] (sk_tree%evaluate).
subroutine sk_tree_evaluate(nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl, no, nfree, &
        vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, kpar, kw0, &
        bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, bpar, theta, q, lpost, lvj, lw, opost, omark, oxyz, owt, &
        free, eqit, etol, pred, res, jac, delta, nit, eqinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, model_body_params, tree_problem, model_setup, problem_setup, evaluate
    use sk_tree_check, only: inputs_check, observations_check
    implicit none
    integer(c_int), intent(in) :: nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl, no, nfree
    integer(c_int), intent(in) :: vparent(nv), vtype(nv), qcol(nv), gvj(ng), gpar(ng), ktype(nk), kvj(6, nk), &
        kpar(21, nk), bvj(nb), tpar(6), mvj(nm), mpar(3, nm), bpar(3, nbp)
    real(c_double), intent(in) :: vaxis(3, nv), vrot(3, 3, nv), vpos(3, nv), qcoef(nv), qconst(nv), gcoef(ng), &
        kw0(nk), bmass(nb), bcom(3, nb), grav(3), rref(3, 3)
    real(c_double), intent(in) :: theta(npar), q(ndof, np), lw(6, nl), oxyz(3, no), owt(no), etol
    integer(c_int), intent(in) :: lpost(nl), lvj(nl), opost(no), omark(no), free(nfree), eqit
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
    errloc = 0
    call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, &
        kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, errloc)
    if (info /= sk_ok) return
    call inputs_check(m%nv, m%ndof, m%npar, theta, q, lpost, lvj, lw, etol, info, errloc)
    if (info /= sk_ok) return
    call observations_check(np, m%nm, m%npar, opost, omark, oxyz, owt, free, info, errloc)
    if (info /= sk_ok) return
    call model_body_params(m, bpar, info)
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
subroutine sk_tree_lm(nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl, no, nfree, &
        vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, kpar, kw0, &
        bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, bpar, theta0, q, lpost, lvj, lw, opost, omark, oxyz, owt, &
        free, npri, ppar, pmu, psw, eqit, etol, maxit, ftol, xtol, gtol, theta, hist, nhist, niter, reason, jac, res, &
        rrefout, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, model_body_params, tree_problem, model_setup, problem_setup
    use sk_tree_check, only: inputs_check, observations_check
    use sk_tree_solve, only: tree_lm
    implicit none
    integer(c_int), intent(in) :: nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl, no, nfree
    integer(c_int), intent(in) :: vparent(nv), vtype(nv), qcol(nv), gvj(ng), gpar(ng), ktype(nk), kvj(6, nk), &
        kpar(21, nk), bvj(nb), tpar(6), mvj(nm), mpar(3, nm), bpar(3, nbp)
    real(c_double), intent(in) :: vaxis(3, nv), vrot(3, 3, nv), vpos(3, nv), qcoef(nv), qconst(nv), gcoef(ng), &
        kw0(nk), bmass(nb), bcom(3, nb), grav(3), rref(3, 3)
    real(c_double), intent(in) :: theta0(npar), q(ndof, np), lw(6, nl), oxyz(3, no), owt(no), etol, ftol, xtol, gtol
    integer(c_int), intent(in) :: lpost(nl), lvj(nl), opost(no), omark(no), free(nfree), eqit, maxit
    integer(c_int), intent(in) :: npri, ppar(npri)
    real(c_double), intent(in) :: pmu(npri), psw(npri)
    real(c_double), intent(out) :: theta(npar), hist(maxit + 1), jac(3*no, nfree), res(3*no), rrefout(3, 3)
    integer(c_int), intent(out) :: nhist, niter, reason, info, errloc(2)
    type(tree_model) :: m
    type(tree_problem) :: pr
    theta = theta0
    rrefout = rref
    hist = 0
    jac = 0
    res = 0
    nhist = 0
    niter = 0
    reason = 0
    errloc = 0
    call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, &
        kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, errloc)
    if (info /= sk_ok) return
    call inputs_check(m%nv, m%ndof, m%npar, theta0, q, lpost, lvj, lw, etol, info, errloc)
    if (info /= sk_ok) return
    call observations_check(np, m%nm, m%npar, opost, omark, oxyz, owt, free, info, errloc)
    if (info /= sk_ok) return
    call model_body_params(m, bpar, info)
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
subroutine sk_tree_frame_jacobian(nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl, &
        vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, kpar, kw0, &
        bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, bpar, theta, frame, q, lpost, lvj, lw, eqit, etol, &
        rf, pf, jq, delta, nit, eqinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, model_body_params, model_setup, frame_jacobian_batch
    use sk_tree_check, only: inputs_check, rows_check
    implicit none
    integer(c_int), intent(in) :: nv, ndof, npar, nk, ne, nb, ng, nm, nbp, np, nl
    integer(c_int), intent(in) :: vparent(nv), vtype(nv), qcol(nv), gvj(ng), gpar(ng), ktype(nk), kvj(6, nk), &
        kpar(21, nk), bvj(nb), tpar(6), mvj(nm), mpar(3, nm), bpar(3, nbp)
    real(c_double), intent(in) :: vaxis(3, nv), vrot(3, 3, nv), vpos(3, nv), qcoef(nv), qconst(nv), gcoef(ng), &
        kw0(nk), bmass(nb), bcom(3, nb), grav(3), rref(3, 3)
    real(c_double), intent(in) :: theta(npar), q(ndof, np), lw(6, nl), etol
    integer(c_int), intent(in) :: frame(np), lpost(nl), lvj(nl), eqit
    real(c_double), intent(out) :: rf(3, 3, np), pf(3, np), jq(6, ndof, np), delta(ne, np)
    integer(c_int), intent(out) :: nit(np), eqinfo(np), info, errloc(2)
    type(tree_model) :: m
    rf = 0
    pf = 0
    jq = 0
    delta = 0
    nit = 0
    eqinfo = 0
    errloc = 0
    call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, &
        kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, errloc)
    if (info /= sk_ok) return
    call inputs_check(m%nv, m%ndof, m%npar, theta, q, lpost, lvj, lw, etol, info, errloc)
    if (info /= sk_ok) return
    call rows_check(m%nv, np, frame, info, errloc)
    if (info /= sk_ok) return
    call model_body_params(m, bpar, info)
    if (info /= sk_ok) return
    call frame_jacobian_batch(m, theta, frame, q, lpost, lvj, lw, eqit, etol, rf, pf, jq, delta, nit, eqinfo, info)
end subroutine sk_tree_frame_jacobian

!> Compensation of nr rows: qout[ndof,nr] puts frame(i) of the model at
!> rtarget[3,3,nr], ptarget[3,nr] (base); full6 1: pose, 0: position;
!> remaining errors resp[nr] (m), resr[nr] (rad), Newton steps nit[nr],
!> rinfo[nr] (sk_tree_solve%compensate_batch). Payload rows lpost; law
!> parameters theta(prow(j)) = trow(j, i) for row i (per-row values).
subroutine sk_tree_compensate(nv, ndof, npar, nk, ne, nb, ng, nm, nbp, nr, nl, npr, &
        vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, kpar, kw0, &
        bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, bpar, theta, frame, qcmd, rtarget, ptarget, lpost, lvj, lw, &
        prow, trow, full6, eqit, etol, maxit, ptol, rtol, qout, resp, resr, nit, rinfo, info, errloc)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    use sk_errors, only: sk_ok
    use sk_tree, only: tree_model, model_body_params, model_setup
    use sk_tree_check, only: inputs_check, rows_check, params_check
    use sk_tree_solve, only: compensate_batch
    implicit none
    integer(c_int), intent(in) :: nv, ndof, npar, nk, ne, nb, ng, nm, nbp, nr, nl, npr
    integer(c_int), intent(in) :: vparent(nv), vtype(nv), qcol(nv), gvj(ng), gpar(ng), ktype(nk), kvj(6, nk), &
        kpar(21, nk), bvj(nb), tpar(6), mvj(nm), mpar(3, nm), bpar(3, nbp)
    real(c_double), intent(in) :: vaxis(3, nv), vrot(3, 3, nv), vpos(3, nv), qcoef(nv), qconst(nv), gcoef(ng), &
        kw0(nk), bmass(nb), bcom(3, nb), grav(3), rref(3, 3)
    real(c_double), intent(in) :: theta(npar), qcmd(ndof, nr), rtarget(3, 3, nr), ptarget(3, nr), lw(6, nl), &
        trow(npr, nr), etol, ptol, rtol
    integer(c_int), intent(in) :: frame(nr), lpost(nl), lvj(nl), prow(npr), full6, eqit, maxit
    real(c_double), intent(out) :: qout(ndof, nr), resp(nr), resr(nr)
    integer(c_int), intent(out) :: nit(nr), rinfo(nr), info, errloc(2)
    type(tree_model) :: m
    qout = qcmd
    resp = 0
    resr = 0
    nit = 0
    rinfo = 0
    errloc = 0
    call model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, &
        kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, errloc)
    if (info /= sk_ok) return
    call inputs_check(m%nv, m%ndof, m%npar, theta, qcmd, lpost, lvj, lw, etol, info, errloc)
    if (info /= sk_ok) return
    call rows_check(m%nv, nr, frame, info, errloc, rtarget, ptarget)
    if (info /= sk_ok) return
    call params_check(m%npar, prow, trow, info, errloc)
    if (info /= sk_ok) return
    call model_body_params(m, bpar, info)
    if (info /= sk_ok) return
    call compensate_batch(m, theta, frame, qcmd, rtarget, ptarget, lpost, lvj, lw, full6, eqit, etol, maxit, &
        ptol, rtol, qout, resp, resr, nit, rinfo, info, prow, trow)
end subroutine sk_tree_compensate
