!> Kinematic trees of virtual joints ("screws"): forward kinematics (the
!> one implementation of the core; sk_chain's serial chains use it),
!> generalised gravity forces, the elastostatic equilibrium under the
!> robot's own weight and payloads, and analytic total derivatives of
!> marker points and frames through that equilibrium. The calibration on
!> absolute (tracker) data and the compensation built on them are in
!> sk_tree_solve; the entry points f2py wraps in sk_api_tree.
!>
!> Virtual-joint modelling in the style of Klimchik et al. (VJM, eqs. 1-3):
!> every elastic effect is a virtual joint whose deflection is driven by
!> its generalised force; here the forces are the robot's weight, so the
!> deflected pose is a static equilibrium instead of eq. 3's linear map.
!> Units are SI throughout (m, rad, kg, N, N m, m/s^2).
!>
!> Tree. nv virtual joints v = 1..nv in topological order: parent(v) < v,
!> 0 = the root (base_link) frame. Joint v has a fixed transform from its
!> parent's frame after the parent's motion to its own frame before
!> motion, rot[3,3,v] and pos[3,v], a type (0 fixed, 1 revolute, 2
!> prismatic) and a unit axis[3,v] in its own frame:
!>   T_v(after) = T_parent(v)(after) * T(pos_v, rot_v) * Motion(axis_v, val_v)
!> (the URDF convention T_parent * T(origin) * Rot(axis, q)). "Frame v" is
!> the frame after the motion unless said otherwise.
!>
!> Values. val_v = qcoef_v q(qcol_v) + qconst_v          (qcol 0: no joint)
!>                 + sum_k gcoef_k theta(gpar_k)  over the geometric
!>                   entries k of joint v (sparse (gvj, gpar, gcoef) list)
!>                 + delta_e  for the elastic coordinate e on joint v.
!> A <mimic> follower takes its leader's column with multiplier and offset;
!> a joint offset of the leader is a geometric entry of both.
!>
!> Elastic blocks k = 1..nk (ktype): 1 linear 1-dof, delta = c w;
!> 2 cubic, delta = c w + c3 w^3; 3 dead zone, delta = c w + b tanh(w/w0)
!> (w0 = kw0(k) fixed); 4 linear 6-dof spring, delta(6) = C w(6), C
!> symmetric from 21 parameters, upper triangle row by row (sym_index).
!> A block's coordinates ride on kvj(1:n,k) (n = 1 or 6); its parameters
!> are theta(kpar(j,k)) in the order above (kpar = 0: the value 0, e.g.
!> the zeros of a beam template). Elastic coordinates are numbered block
!> after block. Each virtual joint carries at most one, never a fixed one.
!>
!> Gravity. nb bodies: mass bmass(b) at the centre bcom(:,b) (frame
!> bvj(b); 0 = base, no effect) in gravity grav (base axes), and payload
!> wrenches (f, m) at a frame origin, base axes. The generalised force of
!> virtual joint s is w_s = sum over loads i beyond s of F_i . dc_i/dval_s
!> (+ m_i . u_s for payload moments), i.e. minus the derivative of the
!> potential: revolute (unit axis u through o)  w = u . ((c - o) x F),
!> prismatic w = u . F. They are evaluated from per-subtree aggregates
!> accumulated leaf to root: total force F_v, first moment
!> S_v = sum c_i F_i^T and payload moment M_v, so that
!>   w_s = u_s . (vee(S_s) + M_s - o_s x F_s),  vee(S) = sum c_i x F_i.
!>
!> Equilibrium. delta = law(w(delta)) by fixed-point iteration (VJM
!> deflection eq. 3 evaluated at the deflected pose), stopped when the
!> update moves no point by more than etol: sum_e |d delta_e| * L
!> (revolute; L = lscale, a bound on the lever arms) or |d delta_e|
!> (prismatic). For linear laws this is the stationary point of
!> 1/2 delta^T C^-1 delta + potential of the weights. eqit = 0: rigid
!> (delta = 0); 1: first order (w at delta = 0, the points at the
!> deflected pose); >= 2: full equilibrium with at most eqit iterations.
!>
!> Derivatives. With the generalised-force derivatives G = dw/dval
!> (G(s,a) from the aggregates of the distal one's subtree, p the proximal
!> of the two, d the distal; zero unless one is an ancestor of the other):
!>   p, d revolute:  u_p^T S_d u_d - (u_p.o_d)(F_d.u_d) - (u_p.u_d)(tr S_d - F_d.o_d)
!>                   (+ M_d . (u_p x u_d) when the derivative is of w_d)
!>   p revolute, d prismatic:  F_d . (u_p x u_d);   p prismatic: 0,
!> i.e. F . d2c/dval_p dval_d with d2c = u_p x (u_d x (c - o_d)), and
!> D = dlaw/dw (block diagonal), the sensitivity of the deflections to a
!> driver xi (a parameter or a joint coordinate) solves
!>   (I - D G_ee) Z = D G_e,xi + dlaw/dparams
!> (first order: I instead of I - D G_ee, everything at delta = 0), and
!> dx/dxi = dx/dxi|direct + dx/ddelta Z.
!>
!> Gravity parameters (sk_tree_grav). Entries p = 1..nbp, bpar[3,nbp] =
!> (body b, slot s, theta index t): s = 1 a mass factor (mass = bmass(b)
!> times the product of its factors), s = 2..4 an offset of the centre
!> along x, y, z of the body's frame (m; centre = bcom(:,b) + the sum of
!> its offsets). One index on several bodies is a subtree's factor; a body
!> may carry its own factor and its subtrees' (they multiply). They move
!> no point directly: they drive the deflections through dw/dtheta (the
!> right-hand side of the sensitivity). A folded model (model_fold) takes
!> them at theta into its masses and centres.
!>
!> Markers and tracker. Marker j rides on frame mvj(j) at the point
!> theta(mpar(:,j)) of that frame. The tracker pose is
!>   T_tracker = Trans(t) * rref * Rx(a1) Ry(a2) Rz(a3),
!> t = theta(tpar(1:3)), (a1, a2, a3) = theta(tpar(4:6)), rref a reference
!> rotation (the fit re-centres it, so it never meets gimbal lock); a
!> predicted measurement is y = T_tracker * T_frame * p (klimchik's
!> observation equation, eq. 6, with the geometric and elastic model in
!> place of eq. 4's linear map; the fit minimises eq. 7).
!>
!> Parameter roles. theta is one vector; a parameter's role is where its
!> index appears (tpar, mpar, gpar, kpar), so one parameter may act in
!> several places (a mimic leader's offset) and no separate kind code can
!> disagree with the model.
!>
!> 6-dof springs. Their six coordinates are screws (3 prismatic along x, y,
!> z, then revolute about x, y, z of the spring frame); the generalised
!> forces of those screws are the transmitted wrench (f, m about the
!> spring origin, spring axes) at zero deflection, and differ from it at
!> second order in the deflection: delta = C w is the equilibrium of the
!> spring energy 1/2 delta^T C^-1 delta in these coordinates.
!>
!> Cost. Aggregates make the forces O(nv) and G O(pairs) per posture;
!> tree_frames caches the rotation of joints whose value did not change
!> (frame errors); evaluate takes the deflection part of the Jacobian by
!> the adjoint (rows of J_delta (I - D G)^-1: a few rows, many
!> parameters); the frame Jacobian and compensation run on the model with
!> its constant joints folded into their children (model_fold). The fixed
!> point converges when D G is a contraction, as for any real robot
!> (deflections of mm, D G ~ 1e-2); a compliance large enough to approach
!> buckling is reported as not converged (eqinfo), not solved.
module sk_tree
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: eye, cross, rot_exp, all_finite, lu_factor, lu_solve, group_by
    use sk_spatial, only: sym_index, nsym
    use sk_tree_check, only: model_check, is_rotation, vj_fixed, vj_revolute, vj_prismatic, law_linear, &
        law_cubic, law_deadzone, law_spring6
    implicit none
    private
    public :: frame_step, tree_frames
    public :: tree_model, tree_state, tree_problem
    public :: model_setup, problem_setup, state_init, solve_posture
    public :: elastic_sensitivity, tracker_pose, point_jacobian, frame_jacobian
    public :: poses_batch, evaluate, frame_jacobian_batch
    public :: is_rotation, group_by, q_drivers, posture_values, deflected_frames, load_state, apply_laws
    public :: deflection_change, model_fold, fold_for_frames
    public :: model_body_params, body_effective

    public :: vj_fixed, vj_revolute, vj_prismatic, law_linear, law_cubic, law_deadzone, law_spring6

    !> A validated tree model (everything but theta and the postures).
    type :: tree_model
        integer :: nv = 0, ndof = 0, npar = 0, ne = 0, nk = 0, nb = 0, nm = 0
        integer, allocatable :: parent(:), vtype(:), qcol(:)
        real(dp), allocatable :: rot(:, :, :), pos(:, :), axis(:, :), qcoef(:), qconst(:)
        !> geometric entries of joint v: gstart(v) .. gstart(v+1)-1 of gpar, gcoef
        integer, allocatable :: gstart(:), gpar(:)
        real(dp), allocatable :: gcoef(:)
        !> blocks: type, parameter indices [21,nk], first coordinate, dimension
        integer, allocatable :: ktype(:), kpar(:, :), kfirst(:), kdim(:)
        real(dp), allocatable :: kw0(:)
        !> elastic coordinate -> joint; joint -> elastic coordinate (0: none)
        integer, allocatable :: evj(:), vel(:)
        !> the elastic joints in tree order [ne]; the nearest elastic joint at
        !> or above each joint [0:nv] (0: none): the tree the equilibrium's
        !> iterations accumulate the loads on
        integer, allocatable :: elist(:), eanc(:)
        integer, allocatable :: bvj(:)
        real(dp), allocatable :: bmass(:), bcom(:, :)
        !> gravity-parameter entries (body, slot, theta index) [3,nbp] (module header)
        integer :: nbp = 0
        integer, allocatable :: bpar(:, :)
        real(dp) :: grav(3) = 0.0_dp
        !> preorder position and subtree size of joints 0..nv (ancestor tests)
        integer, allocatable :: pre(:), sub(:)
        !> relation of elastic coordinates e (row, its force) and j (column,
        !> its value) for G: 1 j's joint is proximal to or is e's, 2 e's is
        !> strictly proximal to j's, 0 unrelated or the proximal one prismatic
        integer, allocatable :: erel(:, :)
        integer :: tpar(6) = 0
        real(dp) :: rref(3, 3) = 0.0_dp
        integer, allocatable :: mvj(:), mpar(:, :)
        !> bound on lever arms (m) for the equilibrium's stopping test
        real(dp) :: lscale = 1.0_dp
    end type tree_model

    !> One posture: values, frames, loads, deflections.
    type :: tree_state
        real(dp), allocatable :: val(:)                       !< values without deflection [nv]
        real(dp), allocatable :: rb(:, :, :), pb(:, :)        !< frames before motion
        real(dp), allocatable :: ra(:, :, :), pa(:, :)        !< frames after motion
        !> load state (where w and G are taken): axes, origins, aggregates, forces
        real(dp), allocatable :: lu(:, :), lo(:, :), f(:, :), s(:, :, :), mp(:, :), wv(:)
        real(dp), allocatable :: delta(:), par(:, :)          !< deflections [ne], law parameters [21,nk]
        !> per-joint coefficients of G (gprox): gh[3,nv], and ghm[3,nv] with
        !> the payload moments
        real(dp), allocatable :: gh(:, :), ghm(:, :)
        !> motion cache of tree_frames; work arrays of elastic_sensitivity
        real(dp), allocatable :: cval(:), cmot(:, :, :), gee(:, :), amat(:, :), rhs(:, :)
        integer, allocatable :: ipiv(:)
        logical, allocatable :: cok(:)
        !> joints whose generalised force and G coefficients are wanted
        logical, allocatable :: need(:)
        !> bodies' masses and centres at theta (posture_values) [nb], [3,nb];
        !> their centres cb[3,nb] and frames br[3,3,nb] (base) at the load state
        real(dp), allocatable :: bm(:), bc(:, :), cb(:, :), br(:, :, :)
        !> d(mass)/d(factor) of each mass-factor entry at theta [nbp]
        real(dp), allocatable :: bdm(:)
        integer :: nit = 0, eqit = 0
        logical :: conv = .true.
    end type tree_state

    !> A model with its data: postures, payloads and observations grouped
    !> by posture, and the free parameters.
    type :: tree_problem
        type(tree_model) :: m
        integer :: np = 0, nobs = 0, nfree = 0, nz = 0, nent = 0
        real(dp), allocatable :: q(:, :)
        integer, allocatable :: lstart(:), lidx(:), lvj(:)
        real(dp), allocatable :: lw(:, :)
        integer, allocatable :: ostart(:), oidx(:), omark(:)
        real(dp), allocatable :: oxyz(:, :), osw(:)           !< sqrt of the row weights
        integer, allocatable :: free(:), colof(:)             !< free list; theta index -> column
        !> columns whose parameters move joints or laws (deflection drivers):
        !> zcol(1:nz) their Jacobian columns; entries (vj, Z column, coef)
        integer, allocatable :: zcol(:), ent_vj(:), ent_col(:), lawcol(:, :)
        real(dp), allocatable :: ent_coef(:)
        !> Z column of each gravity-parameter entry [nbp] (0: not free)
        integer, allocatable :: bodycol(:)
    end type tree_problem

    interface
        !> Set the gravity-parameter entries bpar[3,nbp] of a model (module
        !> header); info = sk_err_size (shape) or sk_err_argument (a body,
        !> slot or theta index out of range).
        module subroutine model_body_params(m, bpar, info)
            type(tree_model), intent(inout) :: m
            integer(ip), intent(in) :: bpar(:, :)
            integer(ip), intent(out) :: info
        end subroutine model_body_params
        !> Masses bm[nb] and centres bc[3,nb] (body frames) at theta, and
        !> dm[nbp]: d(mass)/d(factor) of each mass-factor entry.
        pure module subroutine body_effective(m, theta, bm, bc, dm)
            type(tree_model), intent(in) :: m
            real(dp), intent(in) :: theta(:)
            real(dp), intent(out) :: bm(:), bc(:, :), dm(:)
        end subroutine body_effective
        !> rhs[ne,:] += dw/dtheta of the gravity-parameter entries with a Z
        !> column bodycol[nbp] (0: none), at the load state of st.
        pure module subroutine body_rhs(m, st, bodycol, rhs)
            type(tree_model), intent(in) :: m
            type(tree_state), intent(in) :: st
            integer, intent(in) :: bodycol(:)
            real(dp), intent(inout) :: rhs(:, :)
        end subroutine body_rhs
    end interface

contains

    ! ---------------------------------------------------------------- kinematics

    !> One virtual joint: from its parent's frame (rp, pp; after motion) to
    !> its own frame before (rb, pb) and after (ra, pa) its motion by val;
    !> mot = rot_exp(axis*val) for a revolute joint (unused otherwise).
    pure subroutine frame_step(rp, pp, rot, pos, vtype, axis, val, mot, rb, pb, ra, pa)
        real(dp), intent(in) :: rp(3, 3), pp(3), rot(3, 3), pos(3), axis(3), val, mot(3, 3)
        integer, intent(in) :: vtype
        real(dp), intent(out) :: rb(3, 3), pb(3), ra(3, 3), pa(3)
        pb = pp + matmul(rp, pos)
        rb = matmul(rp, rot)
        select case (vtype)
        case (vj_revolute)
            ra = matmul(rb, mot)
            pa = pb
        case (vj_prismatic)
            ra = rb
            pa = pb + matmul(rb, axis)*val
        case default
            ra = rb
            pa = pb
        end select
    end subroutine frame_step

    !> Forward kinematics of a tree (parent(v) < v, 0 = base): frames of
    !> every virtual joint before (rb[3,3,nv], pb[3,nv]) and after (ra, pa)
    !> its motion by val[nv], base axes/coordinates. Optional cache of the
    !> revolute motions (all three or none): cmot(:,:,v) = rot_exp(axis*cval(v))
    !> where cok(v); a joint whose value did not change since the last call
    !> (a frame error, a joint of an arm that did not move) reuses it.
    pure subroutine tree_frames(parent, vtype, rot, pos, axis, val, rb, pb, ra, pa, cval, cmot, cok)
        integer, intent(in) :: parent(:), vtype(:)
        real(dp), intent(in) :: rot(:, :, :), pos(:, :), axis(:, :), val(:)
        real(dp), intent(out) :: rb(:, :, :), pb(:, :), ra(:, :, :), pa(:, :)
        real(dp), intent(inout), optional :: cval(:), cmot(:, :, :)
        logical, intent(inout), optional :: cok(:)
        real(dp), parameter :: id(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, &
            0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
        real(dp), parameter :: zero(3) = 0.0_dp
        real(dp) :: mot(3, 3)
        integer :: v, p
        do v = 1, size(parent)
            mot = id
            if (vtype(v) == vj_revolute) then
                if (present(cok)) then
                    if (cok(v) .and. cval(v) == val(v)) then
                        mot = cmot(:, :, v)
                    else
                        mot = rot_exp(axis(:, v)*val(v))
                        cmot(:, :, v) = mot
                        cval(v) = val(v)
                        cok(v) = .true.
                    end if
                else
                    mot = rot_exp(axis(:, v)*val(v))
                end if
            end if
            p = parent(v)
            if (p == 0) then
                call frame_step(id, zero, rot(:, :, v), pos(:, v), vtype(v), axis(:, v), val(v), mot, &
                    rb(:, :, v), pb(:, v), ra(:, :, v), pa(:, v))
            else
                call frame_step(ra(:, :, p), pa(:, p), rot(:, :, v), pos(:, v), vtype(v), axis(:, v), &
                    val(v), mot, rb(:, :, v), pb(:, v), ra(:, :, v), pa(:, v))
            end if
        end do
    end subroutine tree_frames

    ! ---------------------------------------------------------------- set-up

    !> Check a tree description and build the model (see the module header
    !> for every argument); ndof, npar: lengths of q and theta; ne: the
    !> number of elastic coordinates (1 per block of type 1-3, 6 per type
    !> 4). info: sk_err_size (ne or array sizes), sk_err_nonfinite,
    !> sk_err_argument (parent order, type, non-unit axis, non-orthonormal
    !> rotation, index out of range, two coordinates on one joint, ...);
    !> optional errloc: [argument code, index] of the failure
    !> (sk_tree_check%model_check).
    subroutine model_setup(m, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, &
            ktype, kvj, kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, errloc)
        type(tree_model), intent(out) :: m
        integer(ip), intent(in) :: vparent(:), vtype(:), qcol(:), gvj(:), gpar(:), ktype(:), kvj(:, :), &
            kpar(:, :), bvj(:), tpar(:), mvj(:), mpar(:, :), ndof, npar, ne
        real(dp), intent(in) :: vaxis(:, :), vrot(:, :, :), vpos(:, :), qcoef(:), qconst(:), gcoef(:), &
            kw0(:), bmass(:), bcom(:, :), grav(:), rref(:, :)
        integer(ip), intent(out) :: info
        integer(ip), intent(out), optional :: errloc(2)
        integer :: nv, ng, nk, nb, nm, v, k, j, e, p
        integer(ip) :: loc(2)
        integer, allocatable :: nxt(:)
        real(dp), allocatable :: reach(:)
        nv = size(vparent)
        ng = size(gvj)
        nk = size(ktype)
        nb = size(bvj)
        nm = size(mvj)
        call model_check(vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, ktype, kvj, &
            kpar, kw0, bvj, bmass, bcom, grav, tpar, rref, mvj, mpar, ndof, npar, ne, info, loc)
        if (present(errloc)) errloc = loc
        if (info /= sk_ok) return

        m%nv = nv
        m%ndof = ndof
        m%npar = npar
        m%ne = ne
        m%nk = nk
        m%nb = nb
        m%nm = nm
        m%parent = vparent
        m%vtype = vtype
        m%qcol = qcol
        m%rot = vrot
        m%pos = vpos
        m%axis = vaxis
        m%qcoef = qcoef
        m%qconst = qconst
        ! elastic blocks and coordinates
        allocate(m%ktype(nk), m%kpar(nsym, nk), m%kfirst(nk), m%kdim(nk), m%kw0(nk), m%evj(ne), m%vel(nv))
        m%ktype = ktype
        m%kpar = kpar
        m%kw0 = kw0
        m%vel = 0
        e = 0
        do k = 1, nk
            m%kfirst(k) = e + 1
            m%kdim(k) = merge(6, 1, ktype(k) == law_spring6)
            do j = 1, m%kdim(k)
                v = kvj(j, k)
                e = e + 1
                m%evj(e) = v
                m%vel(v) = e
            end do
        end do
        ! geometric entries grouped by joint (counting sort)
        allocate(m%gstart(nv + 1), m%gpar(ng), m%gcoef(ng), nxt(nv + 1))
        m%gstart = 0
        do k = 1, ng
            m%gstart(gvj(k) + 1) = m%gstart(gvj(k) + 1) + 1
        end do
        m%gstart(1) = 1
        do v = 1, nv
            m%gstart(v + 1) = m%gstart(v + 1) + m%gstart(v)
        end do
        nxt = m%gstart
        do k = 1, ng
            v = gvj(k)
            m%gpar(nxt(v)) = gpar(k)
            m%gcoef(nxt(v)) = gcoef(k)
            nxt(v) = nxt(v) + 1
        end do
        ! preorder positions and subtree sizes
        deallocate(nxt)
        allocate(m%pre(0:nv), m%sub(0:nv), nxt(0:nv), reach(0:nv))
        m%sub = 1
        do v = nv, 1, -1
            m%sub(vparent(v)) = m%sub(vparent(v)) + m%sub(v)
        end do
        m%pre(0) = 0
        nxt(0) = 1
        reach(0) = 0.0_dp
        do v = 1, nv
            p = vparent(v)
            m%pre(v) = nxt(p)
            nxt(p) = nxt(p) + m%sub(v)
            nxt(v) = m%pre(v) + 1
            reach(v) = reach(p) + norm2(vpos(:, v))
        end do
        allocate(m%elist(ne), m%eanc(0:nv))
        m%eanc(0) = 0
        e = 0
        do v = 1, nv
            m%eanc(v) = m%eanc(vparent(v))
            if (m%vel(v) == 0) cycle
            m%eanc(v) = v
            e = e + 1
            m%elist(e) = v
        end do
        allocate(m%erel(ne, ne))
        m%erel = 0
        do j = 1, ne
            do e = 1, ne
                if (ancestor(m, m%evj(j), m%evj(e))) then
                    if (vtype(m%evj(j)) == vj_revolute) m%erel(e, j) = 1
                else if (ancestor(m, m%evj(e), m%evj(j))) then
                    if (vtype(m%evj(e)) == vj_revolute) m%erel(e, j) = 2
                end if
            end do
        end do
        m%bvj = bvj
        m%bmass = bmass
        m%bcom = bcom
        allocate(m%bpar(3, 0))
        m%grav = grav
        m%tpar = tpar
        m%rref = rref
        m%mvj = mvj
        m%mpar = mpar
        m%lscale = maxval(reach)
        if (nb > 0) m%lscale = m%lscale + maxval(norm2(bcom, dim=1))
        m%lscale = max(m%lscale, 1.0e-3_dp)
        info = sk_ok
    end subroutine model_setup

    !> The model with every joint of constant value folded away: a joint
    !> with no joint coordinate and no elastic coordinate (fixed, or moved
    !> by parameters only, e.g. a frame error, at theta) and not keep(v)
    !> disappears, its transform (with its motion) merged into its
    !> children's origins and its bodies moved to the nearest kept ancestor.
    !> Poses, forces and derivatives w.r.t. q of the kept joints are those
    !> of m (to rounding), at a fraction of the cost when frame errors are
    !> known (compensation). newidx(v): the kept joint's index in mf (0:
    !> folded, or the base). Markers are dropped (mf%nm = 0).
    subroutine model_fold(m, theta, keep, mf, newidx, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        logical, intent(in) :: keep(:)
        type(tree_model), intent(out) :: mf
        integer, intent(out) :: newidx(0:)
        integer(ip), intent(out) :: info
        logical :: kept(m%nv), direct
        real(dp) :: racc(3, 3, 0:m%nv), pacc(3, 0:m%nv), rb(3, 3), pb(3), val, mot(3, 3)
        integer :: anc(0:m%nv), v, p, n, b, k, j, ng
        integer(ip), allocatable :: vparent(:), vtype(:), qcol(:), gvj(:), gpar(:), kvj(:, :), bvj(:), none(:), &
            nomp(:, :)
        real(dp), allocatable :: vaxis(:, :), vrot(:, :, :), vpos(:, :), qcoef(:), qconst(:), gcoef(:), bcom(:, :), &
            bm(:), bc(:, :), dm(:)
        kept = keep .or. m%qcol > 0 .or. m%vel > 0
        n = count(kept)
        allocate(vparent(n), vtype(n), qcol(n), vaxis(3, n), vrot(3, 3, n), vpos(3, n), qcoef(n), qconst(n))
        newidx = 0
        anc(0) = 0
        racc(:, :, 0) = eye(3)
        pacc(:, 0) = 0.0_dp
        n = 0
        do v = 1, m%nv
            p = m%parent(v)
            ! transform from the nearest kept ancestor (after motion) to v before motion
            direct = p == 0
            if (.not. direct) direct = kept(p)
            if (direct) then
                anc(v) = p
                rb = m%rot(:, :, v)
                pb = m%pos(:, v)
            else
                anc(v) = anc(p)
                rb = matmul(racc(:, :, p), m%rot(:, :, v))
                pb = pacc(:, p) + matmul(racc(:, :, p), m%pos(:, v))
            end if
            if (kept(v)) then
                n = n + 1
                newidx(v) = n
                vparent(n) = newidx(anc(v))
                vtype(n) = m%vtype(v)
                vaxis(:, n) = m%axis(:, v)
                vrot(:, :, n) = rb
                vpos(:, n) = pb
                qcol(n) = m%qcol(v)
                qcoef(n) = m%qcoef(v)
                qconst(n) = m%qconst(v)
                racc(:, :, v) = eye(3)
                pacc(:, v) = 0.0_dp
            else
                val = m%qconst(v)
                do k = m%gstart(v), m%gstart(v + 1) - 1
                    val = val + m%gcoef(k)*theta(m%gpar(k))
                end do
                mot = eye(3)
                if (m%vtype(v) == vj_revolute) mot = rot_exp(m%axis(:, v)*val)
                racc(:, :, v) = matmul(rb, mot)
                pacc(:, v) = pb
                if (m%vtype(v) == vj_prismatic) pacc(:, v) = pb + matmul(rb, m%axis(:, v))*val
            end if
        end do
        ! geometric entries of kept joints (joint offsets)
        ng = 0
        do v = 1, m%nv
            if (kept(v)) ng = ng + m%gstart(v + 1) - m%gstart(v)
        end do
        allocate(gvj(ng), gpar(ng), gcoef(ng))
        ng = 0
        do v = 1, m%nv
            if (.not. kept(v)) cycle
            do k = m%gstart(v), m%gstart(v + 1) - 1
                ng = ng + 1
                gvj(ng) = newidx(v)
                gpar(ng) = m%gpar(k)
                gcoef(ng) = m%gcoef(k)
            end do
        end do
        allocate(kvj(6, m%nk))
        kvj = 0
        do k = 1, m%nk
            do j = 1, m%kdim(k)
                kvj(j, k) = newidx(m%evj(m%kfirst(k) + j - 1))
            end do
        end do
        ! bodies at theta's gravity parameters (the folded model has none)
        allocate(bvj(m%nb), bcom(3, m%nb), none(0), nomp(3, 0), bm(m%nb), bc(3, m%nb), dm(m%nbp))
        call body_effective(m, theta, bm, bc, dm)
        do b = 1, m%nb
            v = m%bvj(b)
            bcom(:, b) = bc(:, b)
            bvj(b) = 0
            if (v == 0) cycle
            if (kept(v)) then
                bvj(b) = newidx(v)
            else
                bvj(b) = newidx(anc(v))
                bcom(:, b) = pacc(:, v) + matmul(racc(:, :, v), bc(:, b))
            end if
        end do
        call model_setup(mf, vparent, vtype, vaxis, vrot, vpos, qcol, qcoef, qconst, gvj, gpar, gcoef, &
            m%ktype, kvj, m%kpar, m%kw0, bvj, bm, bcom, m%grav, m%tpar, m%rref, none, nomp, &
            int(m%ndof, ip), int(m%npar, ip), int(m%ne, ip), info)
        mf%lscale = m%lscale
    end subroutine model_fold

    !> model_fold keeping the frames frame(:) and the payload frames lvj(:)
    !> (0 = base), for the routines that work on those frames only.
    subroutine fold_for_frames(m, theta, frame, lvj, mf, newidx, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        integer(ip), intent(in) :: frame(:), lvj(:)
        type(tree_model), intent(out) :: mf
        integer, intent(out) :: newidx(0:)
        integer(ip), intent(out) :: info
        logical :: keep(m%nv)
        integer :: i
        keep = .false.
        do i = 1, size(frame)
            if (frame(i) > 0) keep(frame(i)) = .true.
        end do
        do i = 1, size(lvj)
            if (lvj(i) > 0) keep(lvj(i)) = .true.
        end do
        call model_fold(m, theta, keep, mf, newidx, info)
    end subroutine fold_for_frames

    !> a is an ancestor of b or b itself (0 is everyone's ancestor).
    pure logical function ancestor(m, a, b)
        type(tree_model), intent(in) :: m
        integer, intent(in) :: a, b
        ancestor = m%pre(a) <= m%pre(b) .and. m%pre(b) < m%pre(a) + m%sub(a)
    end function ancestor

    !> A problem: the model m (model_setup), postures q[ndof,np], payloads
    !> (lpost posture, lvj frame, lw[6] = (f, m) at the frame origin, base
    !> axes), observations (opost posture, omark marker, oxyz[3] measured in
    !> the tracker frame, owt weight >= 0) and the free parameters
    !> free[nfree] (indices into theta, distinct).
    subroutine problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info)
        type(tree_problem), intent(out) :: pr
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: q(:, :), lw(:, :), oxyz(:, :), owt(:)
        integer(ip), intent(in) :: lpost(:), lvj(:), opost(:), omark(:), free(:)
        integer(ip), intent(out) :: info
        integer :: np, nl, no, i, k, c, v, nz, j
        integer, allocatable :: zof(:)
        np = size(q, 2)
        nl = size(lpost)
        no = size(opost)
        info = sk_err_size
        if (size(q, 1) /= m%ndof .or. size(lvj) /= nl .or. any(shape(lw) /= [6, nl]) &
            .or. size(omark) /= no .or. any(shape(oxyz) /= [3, no]) .or. size(owt) /= no) return
        info = sk_err_nonfinite
        if (.not. (all_finite(q) .and. all_finite(lw) .and. all_finite(oxyz) .and. all_finite(owt))) return
        info = sk_err_argument
        if (any(lvj < 0) .or. any(lvj > m%nv) .or. any(omark < 1) .or. any(omark > m%nm)) return
        if (any(owt < 0.0_dp)) return
        if (any(free < 1) .or. any(free > m%npar)) return
        call group_by(lpost, np, pr%lstart, pr%lidx, info)
        if (info /= sk_ok) return
        call group_by(opost, np, pr%ostart, pr%oidx, info)
        if (info /= sk_ok) return
        pr%m = m
        pr%np = np
        pr%nobs = no
        pr%nfree = size(free)
        pr%q = q
        pr%lvj = lvj
        pr%lw = lw
        pr%omark = omark
        pr%oxyz = oxyz
        pr%osw = sqrt(owt)
        pr%free = free
        allocate(pr%colof(m%npar), zof(pr%nfree))
        pr%colof = 0
        info = sk_err_argument
        do c = 1, pr%nfree
            if (pr%colof(free(c)) /= 0) return
            pr%colof(free(c)) = c
        end do
        ! deflection drivers: free geometric and law parameters
        zof = 0
        nz = 0
        pr%nent = 0
        do v = 1, m%nv
            do k = m%gstart(v), m%gstart(v + 1) - 1
                c = pr%colof(m%gpar(k))
                if (c == 0) cycle
                pr%nent = pr%nent + 1
                if (zof(c) == 0) then
                    nz = nz + 1
                    zof(c) = nz
                end if
            end do
        end do
        do k = 1, m%nk
            do j = 1, nsym
                if (m%kpar(j, k) == 0) cycle
                c = pr%colof(m%kpar(j, k))
                if (c == 0) cycle
                if (zof(c) == 0) then
                    nz = nz + 1
                    zof(c) = nz
                end if
            end do
        end do
        ! gravity parameters of the bodies
        allocate(pr%bodycol(m%nbp))
        pr%bodycol = 0
        do k = 1, m%nbp
            c = pr%colof(m%bpar(3, k))
            if (c == 0) cycle
            if (zof(c) == 0) then
                nz = nz + 1
                zof(c) = nz
            end if
            pr%bodycol(k) = zof(c)
        end do
        pr%nz = nz
        allocate(pr%zcol(nz), pr%ent_vj(pr%nent), pr%ent_col(pr%nent), pr%ent_coef(pr%nent), &
            pr%lawcol(nsym, m%nk))
        do c = 1, pr%nfree
            if (zof(c) > 0) pr%zcol(zof(c)) = c
        end do
        i = 0
        do v = 1, m%nv
            do k = m%gstart(v), m%gstart(v + 1) - 1
                c = pr%colof(m%gpar(k))
                if (c == 0) cycle
                i = i + 1
                pr%ent_vj(i) = v
                pr%ent_col(i) = zof(c)
                pr%ent_coef(i) = m%gcoef(k)
            end do
        end do
        pr%lawcol = 0
        do k = 1, m%nk
            do j = 1, nsym
                if (m%kpar(j, k) == 0) cycle
                c = pr%colof(m%kpar(j, k))
                if (c > 0) pr%lawcol(j, k) = zof(c)
            end do
        end do
        info = sk_ok
    end subroutine problem_setup

    !> Allocate the work arrays of one posture. need[nv] (default: all):
    !> the joints whose generalised force and G coefficients load_state
    !> computes (the elastic ones always), i.e. the drivers of the
    !> sensitivities the caller will ask for.
    subroutine state_init(m, st, need)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(out) :: st
        logical, intent(in), optional :: need(:)
        integer :: nv
        nv = m%nv
        allocate(st%val(nv), st%rb(3, 3, nv), st%pb(3, nv), st%ra(3, 3, nv), st%pa(3, nv), &
            st%lu(3, nv), st%lo(3, nv), st%f(3, nv), st%s(3, 3, nv), st%mp(3, nv), st%wv(nv), &
            st%delta(m%ne), st%par(nsym, m%nk), st%gh(3, nv), st%ghm(3, nv), &
            st%cval(nv), st%cmot(3, 3, nv), st%cok(nv), st%gee(m%ne, m%ne), st%amat(m%ne, m%ne), st%ipiv(m%ne), st%need(nv))
        st%delta = 0.0_dp
        st%wv = 0.0_dp
        st%gh = 0.0_dp
        st%ghm = 0.0_dp
        st%cok = .false.
        st%cval = 0.0_dp
        st%need = .true.
        if (present(need)) st%need = need .or. m%vel > 0
        st%bm = m%bmass
        st%bc = m%bcom
        allocate(st%cb(3, m%nb), st%br(3, 3, m%nb), st%bdm(m%nbp))
        st%bdm = 0.0_dp
        st%cb = 0.0_dp
        st%br = 0.0_dp
    end subroutine state_init

    ! ---------------------------------------------------------------- gravity

    !> Loads of the current frames: per-subtree aggregates (force, first
    !> moment, payload moment), and for the joints st%need: axes, origins,
    !> generalised forces wv and the coefficients of G (gpair). Payloads
    !> lvj(lsel(:)), lw(:, lsel(:)). elastic_only: the aggregates and the
    !> per-joint part of the elastic joints only (what an iteration of the
    !> equilibrium reads; the other joints' entries are left as they were).
    pure subroutine load_state(m, st, lsel, lvj, lw, elastic_only)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        integer, intent(in) :: lsel(:)
        integer(ip), intent(in) :: lvj(:)
        real(dp), intent(in) :: lw(:, :)
        logical, intent(in), optional :: elastic_only
        real(dp) :: c(3), fb(3)
        integer :: b, v, p, i, l, a, f
        logical :: only
        only = .false.
        if (present(elastic_only)) only = elastic_only
        ! the aggregates of every joint, or (only) of the elastic ones, each
        ! load entered at the nearest elastic joint above it (m%eanc)
        if (only) then
            do i = 1, m%ne
                v = m%elist(i)
                st%f(:, v) = 0.0_dp
                st%s(:, :, v) = 0.0_dp
                st%mp(:, v) = 0.0_dp
            end do
        else
            st%f = 0.0_dp
            st%s = 0.0_dp
            st%mp = 0.0_dp
        end if
        do b = 1, m%nb
            f = m%bvj(b)
            if (f == 0) cycle
            c = st%pa(:, f) + matmul(st%ra(:, :, f), st%bc(:, b))
            st%cb(:, b) = c
            st%br(:, :, b) = st%ra(:, :, f)
            v = merge(m%eanc(f), f, only)
            if (v == 0) cycle
            fb = st%bm(b)*m%grav
            st%f(:, v) = st%f(:, v) + fb
            do a = 1, 3
                st%s(:, a, v) = st%s(:, a, v) + c*fb(a)
            end do
        end do
        do i = 1, size(lsel)
            l = lsel(i)
            f = lvj(l)
            if (f == 0) cycle
            v = merge(m%eanc(f), f, only)
            if (v == 0) cycle
            st%f(:, v) = st%f(:, v) + lw(1:3, l)
            do a = 1, 3
                st%s(:, a, v) = st%s(:, a, v) + st%pa(:, f)*lw(a, l)
            end do
            st%mp(:, v) = st%mp(:, v) + lw(4:6, l)
        end do
        if (only) then
            do i = m%ne, 1, -1
                v = m%elist(i)
                p = m%eanc(m%parent(v))
                if (p == 0) cycle
                st%f(:, p) = st%f(:, p) + st%f(:, v)
                st%s(:, :, p) = st%s(:, :, p) + st%s(:, :, v)
                st%mp(:, p) = st%mp(:, p) + st%mp(:, v)
            end do
        else
            do v = m%nv, 1, -1
                p = m%parent(v)
                if (p == 0) cycle
                st%f(:, p) = st%f(:, p) + st%f(:, v)
                st%s(:, :, p) = st%s(:, :, p) + st%s(:, :, v)
                st%mp(:, p) = st%mp(:, p) + st%mp(:, v)
            end do
        end if
        call joint_loads(m, st, only)
    end subroutine load_state

    !> The per-joint part of load_state from the aggregates: for the joints
    !> st%need (the elastic ones only when elastic_only), axes, origins,
    !> generalised forces wv and the coefficients of G.
    pure subroutine joint_loads(m, st, elastic_only)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        logical, intent(in) :: elastic_only
        real(dp) :: u(3), mv(3)
        integer :: v
        do v = 1, m%nv
            if (.not. st%need(v)) cycle
            if (elastic_only .and. m%vel(v) == 0) cycle
            u = matmul(st%rb(:, :, v), m%axis(:, v))
            st%lu(:, v) = u
            st%lo(:, v) = st%pb(:, v)
            select case (m%vtype(v))
            case (vj_revolute)
                mv = [st%s(2, 3, v) - st%s(3, 2, v), st%s(3, 1, v) - st%s(1, 3, v), &
                    st%s(1, 2, v) - st%s(2, 1, v)] + st%mp(:, v) - cross(st%pb(:, v), st%f(:, v))
                st%wv(v) = dot_product(u, mv)
                st%gh(:, v) = matmul(st%s(:, :, v), u) - st%pb(:, v)*dot_product(st%f(:, v), u) &
                    - u*(st%s(1, 1, v) + st%s(2, 2, v) + st%s(3, 3, v) - dot_product(st%f(:, v), st%pb(:, v)))
                st%ghm(:, v) = st%gh(:, v) + cross(u, st%mp(:, v))
            case (vj_prismatic)
                st%wv(v) = dot_product(u, st%f(:, v))
                st%gh(:, v) = cross(u, st%f(:, v))
                st%ghm(:, v) = st%gh(:, v)
            case default
                st%wv(v) = 0.0_dp
            end select
        end do
    end subroutine joint_loads

    !> G(s, a) = dw_s/dval_a at the load state (module header), from the
    !> coefficients of the distal joint d (load_state) and the axis of the
    !> proximal one p (gprox).
    pure function gpair(m, st, s, a) result(g)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: s, a
        real(dp) :: g
        g = 0.0_dp
        if (ancestor(m, a, s)) then
            if (m%vtype(a) == vj_revolute) g = gprox(st, a, s, a /= s)
        else if (ancestor(m, s, a)) then
            if (m%vtype(s) == vj_revolute) g = gprox(st, s, a, .false.)
        end if
    end function gpair

    !> G of a revolute proximal joint p and a distal d: G = u_p . h_d with
    !>   h_d = S_d u_d - o_d (F_d . u_d) - u_d (tr S_d - F_d . o_d)
    !> (u_p^T S_d u_d - (u_p . o_d)(F_d . u_d) - (u_p . u_d)(tr S_d - F_d . o_d)),
    !> plus u_p . (u_d x M_d), the payload moments, when the force is d's
    !> and p /= d (moment); a prismatic d has h_d = u_d x F_d.
    pure real(dp) function gprox(st, p, d, moment) result(g)
        type(tree_state), intent(in) :: st
        integer, intent(in) :: p, d
        logical, intent(in) :: moment
        if (moment) then
            g = st%lu(1, p)*st%ghm(1, d) + st%lu(2, p)*st%ghm(2, d) + st%lu(3, p)*st%ghm(3, d)
        else
            g = st%lu(1, p)*st%gh(1, d) + st%lu(2, p)*st%gh(2, d) + st%lu(3, p)*st%gh(3, d)
        end if
    end function gprox

    ! ---------------------------------------------------------------- laws

    !> The symmetric 6x6 compliance of 21 parameters (sym_index order).
    pure function sym6(par) result(c)
        real(dp), intent(in) :: par(nsym)
        real(dp) :: c(6, 6)
        integer :: k, i, j
        do k = 1, nsym
            call sym_index(k, i, j)
            c(i, j) = par(k)
            c(j, i) = par(k)
        end do
    end function sym6

    !> Deflection d(1:n) of a block for its generalised forces w(1:n).
    pure subroutine law_delta(ktype, par, w0, w, d)
        integer, intent(in) :: ktype
        real(dp), intent(in) :: par(nsym), w0, w(:)
        real(dp), intent(out) :: d(:)
        select case (ktype)
        case (law_linear)
            d(1) = par(1)*w(1)
        case (law_cubic)
            d(1) = par(1)*w(1) + par(2)*w(1)**3
        case (law_deadzone)
            d(1) = par(1)*w(1) + par(2)*tanh(w(1)/w0)
        case default
            d(1:6) = matmul(sym6(par), w(1:6))
        end select
    end subroutine law_delta

    !> Number of parameter slots of a law type (1, 2, 2, 21).
    pure integer function law_nslot(ktype)
        integer, intent(in) :: ktype
        select case (ktype)
        case (law_linear)
            law_nslot = 1
        case (law_cubic, law_deadzone)
            law_nslot = 2
        case default
            law_nslot = nsym
        end select
    end function law_nslot

    !> Derivatives of a block's law: dmat[n,n] = d delta/dw, dpar[n,:] =
    !> d delta/d(parameter slot), slots 1..law_nslot(ktype) set.
    pure subroutine law_derivs(ktype, par, w0, w, dmat, dpar)
        integer, intent(in) :: ktype
        real(dp), intent(in) :: par(nsym), w0, w(:)
        real(dp), intent(out) :: dmat(:, :), dpar(:, :)
        real(dp) :: t
        integer :: k, i, j
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
        case default
            dmat(1:6, 1:6) = sym6(par)
            dpar(1:6, 1:nsym) = 0.0_dp
            do k = 1, nsym
                call sym_index(k, i, j)
                dpar(i, k) = w(j)
                if (i /= j) dpar(j, k) = w(i)
            end do
        end select
    end subroutine law_derivs

    ! ---------------------------------------------------------------- equilibrium

    !> Frames at the values st%val plus the deflections st%delta.
    pure subroutine deflected_frames(m, st)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        real(dp) :: vt(m%nv)
        integer :: e
        vt = st%val
        do e = 1, m%ne
            vt(m%evj(e)) = vt(m%evj(e)) + st%delta(e)
        end do
        call tree_frames(m%parent, m%vtype, m%rot, m%pos, m%axis, vt, st%rb, st%pb, st%ra, st%pa, &
            st%cval, st%cmot, st%cok)
    end subroutine deflected_frames

    !> Deflections dn[ne] that the laws give for the current forces st%wv.
    pure subroutine apply_laws(m, st, dn)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        real(dp), intent(out) :: dn(:)
        real(dp) :: w(6)
        integer :: k, e0, n, i
        do k = 1, m%nk
            e0 = m%kfirst(k)
            n = m%kdim(k)
            do i = 1, n
                w(i) = st%wv(m%evj(e0 + i - 1))
            end do
            call law_delta(m%ktype(k), st%par(:, k), m%kw0(k), w(1:n), dn(e0:e0 + n - 1))
        end do
    end subroutine apply_laws

    !> Values of the joints without deflection and the law parameters at
    !> posture q[ndof] (the start of every posture).
    pure subroutine posture_values(m, theta, q, st)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:)
        type(tree_state), intent(inout) :: st
        integer :: v, k, j
        do v = 1, m%nv
            st%val(v) = m%qconst(v)
            if (m%qcol(v) > 0) st%val(v) = st%val(v) + m%qcoef(v)*q(m%qcol(v))
            do k = m%gstart(v), m%gstart(v + 1) - 1
                st%val(v) = st%val(v) + m%gcoef(k)*theta(m%gpar(k))
            end do
        end do
        do k = 1, m%nk
            do j = 1, nsym
                st%par(j, k) = 0.0_dp
                if (m%kpar(j, k) > 0) st%par(j, k) = theta(m%kpar(j, k))
            end do
        end do
        if (m%nbp > 0) call body_effective(m, theta, st%bm, st%bc, st%bdm)
    end subroutine posture_values

    !> How far a change dd[ne] of the deflections moves a point, at most
    !> (first order): sum |dd_e| * lscale (revolute) or |dd_e| (prismatic).
    pure real(dp) function deflection_change(m, dd) result(ch)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: dd(:)
        integer :: e
        ch = 0.0_dp
        do e = 1, m%ne
            ch = ch + abs(dd(e))*merge(m%lscale, 1.0_dp, m%vtype(m%evj(e)) == vj_revolute)
        end do
    end function deflection_change

    !> Solve one posture q[ndof]: values, frames, loads and deflections
    !> (module header; eqit 0 rigid, 1 first order, >= 2 iterated to etol
    !> metres). Payloads lvj(lsel(:)), lw(:, lsel(:)). warm: start the
    !> iteration from st%delta. On return st%conv says whether the
    !> iteration met etol within eqit steps (st%nit frame evaluations); the
    !> state is consistent (frames at st%delta) either way.
    subroutine solve_posture(m, theta, q, lsel, lvj, lw, eqit, etol, warm, st)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:), lw(:, :), etol
        integer, intent(in) :: lsel(:)
        integer(ip), intent(in) :: lvj(:), eqit
        logical, intent(in) :: warm
        type(tree_state), intent(inout) :: st
        real(dp) :: dn(m%ne), ch
        integer :: it
        call posture_values(m, theta, q, st)
        st%eqit = eqit
        st%conv = .true.
        st%nit = 1
        if (.not. warm .or. eqit <= 1) st%delta = 0.0_dp
        if (eqit <= 0 .or. m%ne == 0) then
            st%delta = 0.0_dp
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw)
            return
        end if
        if (eqit == 1) then
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw)
            call apply_laws(m, st, st%delta)
            call deflected_frames(m, st)
            return
        end if
        ! the iterations read the elastic joints' forces only; every load is
        ! taken once more, in full, at the frames the iteration stops at
        do it = 1, eqit
            call deflected_frames(m, st)
            call load_state(m, st, lsel, lvj, lw, elastic_only=.true.)
            call apply_laws(m, st, dn)
            st%nit = it
            ch = deflection_change(m, dn - st%delta)
            st%conv = ch <= etol
            if (st%conv .or. it == eqit .or. .not. ch < huge(1.0_dp)) exit
            st%delta = dn
        end do
        call load_state(m, st, lsel, lvj, lw)
    end subroutine solve_posture

    !> Sensitivity z[ne,ncol] of the deflections to ncol drivers at a solved
    !> posture: driver entries k = 1..size(ent_vj) say that driver
    !> ent_col(k) moves joint ent_vj(k) by ent_coef(k) per unit; lawcol
    !> [21,nk] names the driver of each law-parameter slot (0: none).
    !> Solves (I - D G_ee) z = D G_e,drivers + dlaw/dparams (first order:
    !> z = the right-hand side; rigid: z = 0). With resid[ne] (st%eqit >= 2
    !> only), also y = (I - D G_ee)^-1 resid, the Newton correction of an
    !> equilibrium residual, with the same factors. reuse: keep the factors
    !> of I - D G_ee of the previous call (a chord step of a Newton
    !> iteration whose pose moved little; the right-hand side is current).
    !> adjoint: return the right-hand side in z and leave I - D G_ee
    !> factored in st%amat, st%ipiv (st%eqit >= 2) for a transposed solve
    !> of the caller's few rows (lu_solve).
    !> info = sk_err_singular when I - D G_ee is singular (an unstable
    !> equilibrium).
    subroutine elastic_sensitivity(m, st, ent_vj, ent_col, ent_coef, lawcol, z, info, resid, y, reuse, adjoint, &
            bodycol)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(inout) :: st
        integer, intent(in) :: ent_vj(:), ent_col(:), lawcol(:, :)
        real(dp), intent(in) :: ent_coef(:)
        real(dp), intent(out) :: z(:, :)
        integer(ip), intent(out) :: info
        real(dp), intent(in), optional :: resid(:)
        real(dp), intent(out), optional :: y(:)
        logical, intent(in), optional :: reuse, adjoint
        !> Z columns of the gravity-parameter entries [nbp] (problem_setup)
        integer, intent(in), optional :: bodycol(:)
        real(dp) :: dmat(6, 6), dpar(6, nsym), w(6)
        integer :: ne, ncol, nc, e, k, n, e0, j, a, c, i, d
        logical :: factor
        ne = m%ne
        ncol = size(z, 2)
        nc = ncol + merge(1, 0, present(resid))
        info = sk_ok
        if (ne == 0 .or. st%eqit <= 0 .or. nc == 0) then
            z = 0.0_dp
            if (present(y)) y = 0.0_dp
            return
        end if
        if (present(y) .and. st%eqit < 2) y = 0.0_dp
        factor = st%eqit >= 2
        if (present(reuse)) factor = factor .and. .not. reuse
        if (allocated(st%rhs)) then
            if (size(st%rhs, 2) /= nc) deallocate(st%rhs)
        end if
        if (.not. allocated(st%rhs)) allocate(st%rhs(ne, nc))
        ! G of the drivers, in the columns of the right-hand side
        st%rhs = 0.0_dp
        do k = 1, size(ent_vj)
            a = ent_vj(k)
            c = ent_col(k)
            do e = 1, ne
                st%rhs(e, c) = st%rhs(e, c) + ent_coef(k)*gpair(m, st, m%evj(e), a)
            end do
        end do
        if (present(bodycol)) call body_rhs(m, st, bodycol, st%rhs)
        if (factor) then
            ! G_ee is symmetric but for the payload moments (in the
            ! entries of a force distal to a value)
            do j = 1, ne
                a = m%evj(j)
                do e = j, ne
                    d = m%evj(e)
                    select case (m%erel(e, j))
                    case (1)
                        st%gee(j, e) = gprox(st, a, d, .false.)
                        st%gee(e, j) = st%gee(j, e)
                        if (e /= j) st%gee(e, j) = gprox(st, a, d, .true.)
                    case (2)
                        st%gee(e, j) = gprox(st, d, a, .false.)
                        st%gee(j, e) = gprox(st, d, a, .true.)
                    case default
                        st%gee(e, j) = 0.0_dp
                        st%gee(j, e) = 0.0_dp
                    end select
                end do
            end do
        end if
        do k = 1, m%nk
            e0 = m%kfirst(k)
            n = m%kdim(k)
            do i = 1, n
                w(i) = st%wv(m%evj(e0 + i - 1))
            end do
            call law_derivs(m%ktype(k), st%par(:, k), m%kw0(k), w(1:n), dmat(1:n, 1:n), dpar(1:n, :))
            if (n == 1) then
                z(e0, :) = dmat(1, 1)*st%rhs(e0, 1:ncol)
                if (factor) st%amat(e0, :) = -dmat(1, 1)*st%gee(e0, :)
            else
                z(e0:e0 + n - 1, :) = matmul(dmat(1:n, 1:n), st%rhs(e0:e0 + n - 1, 1:ncol))
                if (factor) st%amat(e0:e0 + n - 1, :) = -matmul(dmat(1:n, 1:n), st%gee(e0:e0 + n - 1, :))
            end if
            do j = 1, law_nslot(m%ktype(k))
                c = lawcol(j, k)
                if (c > 0) z(e0:e0 + n - 1, c) = z(e0:e0 + n - 1, c) + dpar(1:n, j)
            end do
        end do
        if (factor) then
            do e = 1, ne
                st%amat(e, e) = st%amat(e, e) + 1.0_dp
            end do
            call lu_factor(st%amat, st%ipiv, info)
            if (info /= sk_ok) return
        end if
        if (present(adjoint)) then
            if (adjoint) return
        end if
        if (st%eqit >= 2) then
            st%rhs(:, 1:ncol) = z
            if (present(resid)) st%rhs(:, nc) = resid
            call lu_solve(st%amat, st%ipiv, st%rhs)
            z = st%rhs(:, 1:ncol)
            if (present(y)) y = st%rhs(:, nc)
        end if
    end subroutine elastic_sensitivity

    ! ---------------------------------------------------------------- observations

    !> Tracker rotation rt[3,3], translation tt[3] and the axes tw[3,3] (in
    !> the tracker frame) of its three screw angles.
    pure subroutine tracker_pose(m, theta, rt, tt, tw)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:)
        real(dp), intent(out) :: rt(3, 3), tt(3), tw(3, 3)
        real(dp) :: r(3, 3)
        integer :: k
        tt = theta(m%tpar(1:3))
        r = m%rref
        do k = 1, 3
            tw(:, k) = r(:, k)
            r = matmul(r, axis_rot(k, theta(m%tpar(3 + k))))
        end do
        rt = r
    end subroutine tracker_pose

    !> Rotation by angle a about coordinate axis k.
    pure function axis_rot(k, a) result(r)
        integer, intent(in) :: k
        real(dp), intent(in) :: a
        real(dp) :: r(3, 3), c, s
        integer :: i, j
        c = cos(a)
        s = sin(a)
        i = mod(k, 3) + 1
        j = mod(k + 1, 3) + 1
        r = eye(3)
        r(i, i) = c
        r(j, j) = c
        r(j, i) = s
        r(i, j) = -s
    end function axis_rot

    !> Predicted tracker-frame point y[3] of marker mk at a solved posture,
    !> its direct Jacobian jrow[3,nfree] w.r.t. the free parameters (columns
    !> colof(theta index); the deflections held), and jdel[3,ne] = dy/ddelta
    !> (zero off the marker's path). The total Jacobian adds jdel Z, Z the
    !> deflection sensitivity (elastic_sensitivity).
    pure subroutine point_jacobian(m, st, theta, rt, tt, tw, mk, colof, y, jrow, jdel)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        real(dp), intent(in) :: theta(:), rt(3, 3), tt(3), tw(3, 3)
        integer, intent(in) :: mk, colof(:)
        real(dp), intent(out) :: y(3), jrow(:, :), jdel(:, :)
        real(dp) :: x(3), pm(3), rx(3), jx(3), jy(3), rtf(3, 3)
        integer :: f, a, k, c
        f = m%mvj(mk)
        pm = theta(m%mpar(:, mk))
        if (f > 0) then
            x = st%pa(:, f) + matmul(st%ra(:, :, f), pm)
            rtf = matmul(rt, st%ra(:, :, f))
        else
            x = pm
            rtf = rt
        end if
        rx = matmul(rt, x)
        y = rx + tt
        jrow = 0.0_dp
        jdel = 0.0_dp
        do k = 1, 3
            c = colof(m%tpar(k))
            if (c > 0) jrow(k, c) = jrow(k, c) + 1.0_dp
            c = colof(m%tpar(3 + k))
            if (c > 0) jrow(:, c) = jrow(:, c) + cross(tw(:, k), rx)
            c = colof(m%mpar(k, mk))
            if (c > 0) jrow(:, c) = jrow(:, c) + rtf(:, k)
        end do
        a = f
        do while (a > 0)
            if (m%vtype(a) /= vj_fixed) then
                jx = matmul(st%rb(:, :, a), m%axis(:, a))
                if (m%vtype(a) == vj_revolute) jx = cross(jx, x - st%pb(:, a))
                jy = matmul(rt, jx)
                do k = m%gstart(a), m%gstart(a + 1) - 1
                    c = colof(m%gpar(k))
                    if (c > 0) jrow(:, c) = jrow(:, c) + m%gcoef(k)*jy
                end do
                if (m%vel(a) > 0) jdel(:, m%vel(a)) = jy
            end if
            a = m%parent(a)
        end do
    end subroutine point_jacobian

    !> Pose of frame f (rf[3,3], pf[3], base) at a solved posture and its
    !> Jacobian jq[6,ndof] w.r.t. the joint coordinates q: twist (velocity
    !> of the frame origin, angular velocity), base axes; zq[ne,ndof] the
    !> deflection sensitivity to q; a further column of zq (a deflection
    !> change) gives its frame motion in the same column of jq.
    pure subroutine frame_jacobian(m, st, f, zq, rf, pf, jq)
        type(tree_model), intent(in) :: m
        type(tree_state), intent(in) :: st
        integer, intent(in) :: f
        real(dp), intent(in) :: zq(:, :)
        real(dp), intent(out) :: rf(3, 3), pf(3), jq(:, :)
        real(dp) :: u(3), tw(6)
        integer :: a, e, j
        jq = 0.0_dp
        if (f == 0) then
            rf = eye(3)
            pf = 0.0_dp
            return
        end if
        rf = st%ra(:, :, f)
        pf = st%pa(:, f)
        a = f
        do while (a > 0)
            if (m%vtype(a) /= vj_fixed .and. (m%qcol(a) > 0 .or. m%vel(a) > 0)) then
                u = matmul(st%rb(:, :, a), m%axis(:, a))
                if (m%vtype(a) == vj_revolute) then
                    tw(1:3) = cross(u, pf - st%pb(:, a))
                    tw(4:6) = u
                else
                    tw(1:3) = u
                    tw(4:6) = 0.0_dp
                end if
                if (m%qcol(a) > 0) jq(:, m%qcol(a)) = jq(:, m%qcol(a)) + m%qcoef(a)*tw
                e = m%vel(a)
                if (e > 0) then
                    do j = 1, size(jq, 2)
                        jq(:, j) = jq(:, j) + tw*zq(e, j)
                    end do
                end if
            end if
            a = m%parent(a)
        end do
    end subroutine frame_jacobian

    !> Driver entries of the joint coordinates: joint v moves with q(qcol(v)).
    pure subroutine q_drivers(m, ent_vj, ent_col, ent_coef, n)
        type(tree_model), intent(in) :: m
        integer, intent(out) :: ent_vj(:), ent_col(:), n
        real(dp), intent(out) :: ent_coef(:)
        integer :: v
        n = 0
        do v = 1, m%nv
            if (m%qcol(v) == 0 .or. m%vtype(v) == vj_fixed) cycle
            n = n + 1
            ent_vj(n) = v
            ent_col(n) = m%qcol(v)
            ent_coef(n) = m%qcoef(v)
        end do
    end subroutine q_drivers

    ! ---------------------------------------------------------------- batches

    !> Poses and loads at np postures q[ndof,np] (payloads lpost, lvj, lw):
    !> frames after motion ra[3,3,nv,np], pa[3,nv,np]; generalised forces
    !> of every joint wv[nv,np] and of every joint coordinate
    !> tauq[ndof,np] = sum_v qcoef_v wv_v over the joints on column q_j (the
    !> gravity torque of an actuated joint, its mimic followers included),
    !> both at the load state (delta = 0 for eqit <= 1); deflections
    !> delta[ne,np]; iterations nit[np]; eqinfo[np] = sk_err_noconv where
    !> the equilibrium missed etol (then info = sk_err_noconv too, with
    !> every output filled).
    subroutine poses_batch(m, theta, q, lpost, lvj, lw, eqit, etol, ra, pa, wv, tauq, delta, nit, eqinfo, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:, :), lw(:, :), etol
        integer(ip), intent(in) :: lpost(:), lvj(:), eqit
        real(dp), intent(out) :: ra(:, :, :, :), pa(:, :, :), wv(:, :), tauq(:, :), delta(:, :)
        integer(ip), intent(out) :: nit(:), eqinfo(:), info
        type(tree_state) :: st
        integer, allocatable :: lstart(:), lidx(:)
        integer :: ipost, np, v
        np = size(q, 2)
        ra = 0.0_dp
        pa = 0.0_dp
        wv = 0.0_dp
        tauq = 0.0_dp
        delta = 0.0_dp
        nit = 0
        eqinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(q, 1) /= m%ndof .or. size(lvj) /= size(lpost) &
            .or. any(shape(lw) /= [6, size(lpost)]) .or. any(shape(ra) /= [3, 3, m%nv, np]) &
            .or. any(shape(pa) /= [3, m%nv, np]) .or. any(shape(wv) /= [m%nv, np]) &
            .or. any(shape(tauq) /= [m%ndof, np]) .or. any(shape(delta) /= [m%ne, np]) &
            .or. size(nit) /= np .or. size(eqinfo) /= np) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(q) .and. all_finite(lw) .and. etol == etol)) return
        info = sk_err_argument
        if (any(lvj < 0) .or. any(lvj > m%nv)) return
        call group_by(lpost, np, lstart, lidx, info)
        if (info /= sk_ok) return
        call state_init(m, st)
        do ipost = 1, np
            call solve_posture(m, theta, q(:, ipost), lidx(lstart(ipost):lstart(ipost + 1) - 1), lvj, lw, &
                eqit, etol, .false., st)
            ra(:, :, :, ipost) = st%ra
            pa(:, :, ipost) = st%pa
            wv(:, ipost) = st%wv
            do v = 1, m%nv
                if (m%qcol(v) > 0) tauq(m%qcol(v), ipost) = tauq(m%qcol(v), ipost) + m%qcoef(v)*st%wv(v)
            end do
            delta(:, ipost) = st%delta
            nit(ipost) = st%nit
            if (.not. st%conv) eqinfo(ipost) = sk_err_noconv
        end do
        info = merge(sk_ok, sk_err_noconv, all(eqinfo == sk_ok))
    end subroutine poses_batch

    !> Predicted points pred[3,nobs] (tracker frame), weighted residuals
    !> res[3*nobs] = sqrt(w_i) (pred_i - measured_i) (rows 3i-2..3i) and,
    !> when want_jac, their Jacobian jac[3*nobs,nfree] w.r.t. theta(free)
    !> (total derivatives through the equilibrium); deflections
    !> delta[ne,np], iterations nit[np], eqinfo[np] as in poses_batch.
    !> info: sk_ok, sk_err_noconv (some posture missed etol; outputs
    !> filled), sk_err_singular (an unstable equilibrium), size/NaN codes.
    !> Optional warm[ne,np]: deflections to start each posture's iteration
    !> from (eqit >= 2), e.g. those at a nearby theta; the fixed point and
    !> the tolerance are the same, only fewer steps are taken.
    subroutine evaluate(pr, theta, eqit, etol, want_jac, pred, res, jac, delta, nit, eqinfo, info, warm)
        type(tree_problem), intent(in) :: pr
        real(dp), intent(in) :: theta(:), etol
        integer(ip), intent(in) :: eqit
        logical, intent(in) :: want_jac
        real(dp), intent(out) :: pred(:, :), res(:), jac(:, :), delta(:, :)
        integer(ip), intent(out) :: nit(:), eqinfo(:), info
        real(dp), intent(in), optional :: warm(:, :)
        type(tree_state) :: st
        real(dp) :: rt(3, 3), tt(3), tw(3, 3), y(3)
        real(dp), allocatable :: b(:, :), jrow(:, :), lam(:, :), jd(:, :), jz(:, :)
        logical :: need(pr%m%nv)
        integer :: ipost, k, i, r0, nrow, ne, j, maxrow
        integer(ip) :: sinfo
        pred = 0.0_dp
        res = 0.0_dp
        jac = 0.0_dp
        delta = 0.0_dp
        nit = 0
        eqinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= pr%m%npar .or. any(shape(pred) /= [3, pr%nobs]) .or. size(res) /= 3*pr%nobs &
            .or. any(shape(delta) /= [pr%m%ne, pr%np]) .or. size(nit) /= pr%np .or. size(eqinfo) /= pr%np) return
        if (want_jac .and. any(shape(jac) /= [3*pr%nobs, pr%nfree])) return
        if (present(warm)) then
            if (any(shape(warm) /= [pr%m%ne, pr%np])) return
        end if
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. etol == etol)) return
        if (present(warm)) then
            if (.not. all_finite(warm)) return
        end if
        need = .false.
        need(pr%ent_vj) = .true.
        call state_init(pr%m, st, need)
        call tracker_pose(pr%m, theta, rt, tt, tw)
        ne = pr%m%ne
        maxrow = 0
        do ipost = 1, pr%np
            maxrow = max(maxrow, 3*(pr%ostart(ipost + 1) - pr%ostart(ipost)))
        end do
        allocate(b(ne, pr%nz), jrow(3, pr%nfree), lam(ne, maxrow), jd(3, ne), jz(maxrow, pr%nz))
        info = sk_ok
        do ipost = 1, pr%np
            if (present(warm)) st%delta = warm(:, ipost)
            call solve_posture(pr%m, theta, pr%q(:, ipost), pr%lidx(pr%lstart(ipost):pr%lstart(ipost + 1) - 1), &
                pr%lvj, pr%lw, eqit, etol, present(warm), st)
            delta(:, ipost) = st%delta
            nit(ipost) = st%nit
            if (.not. st%conv) eqinfo(ipost) = sk_err_noconv
            if (pr%ostart(ipost + 1) == pr%ostart(ipost)) cycle
            ! deflection part by the adjoint: rows J_delta (I - D G)^-1 B with
            ! B the drivers' right-hand side (few rows, many parameters)
            if (want_jac) then
                call elastic_sensitivity(pr%m, st, pr%ent_vj, pr%ent_col, pr%ent_coef, pr%lawcol, b, sinfo, &
                    adjoint=.true., bodycol=pr%bodycol)
                if (sinfo /= sk_ok) then
                    info = sinfo
                    return
                end if
            end if
            nrow = 0
            do k = pr%ostart(ipost), pr%ostart(ipost + 1) - 1
                i = pr%oidx(k)
                call point_jacobian(pr%m, st, theta, rt, tt, tw, pr%omark(i), pr%colof, y, jrow, jd)
                lam(:, nrow + 1:nrow + 3) = transpose(jd)
                nrow = nrow + 3
                pred(:, i) = y
                r0 = 3*(i - 1)
                res(r0 + 1:r0 + 3) = pr%osw(i)*(y - pr%oxyz(:, i))
                if (want_jac) jac(r0 + 1:r0 + 3, :) = pr%osw(i)*jrow
            end do
            if (.not. want_jac .or. ne == 0 .or. pr%nz == 0) cycle
            ! lam holds J_delta^T; (I - D G)^-T J_delta^T when iterated
            if (st%eqit >= 2) call lu_solve(st%amat, st%ipiv, lam(:, 1:nrow), transposed=.true.)
            ! the posture's rows of the deflection part at once: lam^T B
            jz(1:nrow, :) = matmul(transpose(lam(:, 1:nrow)), b)
            nrow = 0
            do k = pr%ostart(ipost), pr%ostart(ipost + 1) - 1
                i = pr%oidx(k)
                r0 = 3*(i - 1)
                do j = 1, pr%nz
                    jac(r0 + 1:r0 + 3, pr%zcol(j)) = jac(r0 + 1:r0 + 3, pr%zcol(j)) + pr%osw(i)*jz(nrow + 1:nrow + 3, j)
                end do
                nrow = nrow + 3
            end do
        end do
        if (any(eqinfo /= sk_ok)) info = sk_err_noconv
    end subroutine evaluate

    !> Pose of frame frame(i) (rf[3,3,n], pf[3,n], base) at postures
    !> q[ndof,n] at equilibrium, and its Jacobian jq[6,ndof,n] w.r.t. q
    !> (total, through the equilibrium); payloads lpost (1..n), lvj, lw.
    !> nit, eqinfo, info as in poses_batch. Computed on the model with its
    !> constant joints folded (model_fold).
    subroutine frame_jacobian_batch(m, theta, frame, q, lpost, lvj, lw, eqit, etol, rf, pf, jq, delta, &
            nit, eqinfo, info)
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: theta(:), q(:, :), lw(:, :), etol
        integer(ip), intent(in) :: frame(:), lpost(:), lvj(:), eqit
        real(dp), intent(out) :: rf(:, :, :), pf(:, :), jq(:, :, :), delta(:, :)
        integer(ip), intent(out) :: nit(:), eqinfo(:), info
        type(tree_state) :: st
        integer, allocatable :: lstart(:), lidx(:)
        integer :: ent_vj(m%nv), ent_col(m%nv), nent, ipost, n, newidx(0:m%nv)
        integer(ip) :: lvjf(size(lvj))
        type(tree_model) :: mf
        real(dp) :: ent_coef(m%nv), zq(m%ne, m%ndof)
        integer :: lawcol(nsym, m%nk)
        n = size(q, 2)
        rf = 0.0_dp
        pf = 0.0_dp
        jq = 0.0_dp
        delta = 0.0_dp
        nit = 0
        eqinfo = sk_ok
        info = sk_err_size
        if (size(theta) /= m%npar .or. size(q, 1) /= m%ndof .or. size(frame) /= n .or. size(lvj) /= size(lpost) &
            .or. any(shape(lw) /= [6, size(lpost)]) .or. any(shape(rf) /= [3, 3, n]) &
            .or. any(shape(pf) /= [3, n]) .or. any(shape(jq) /= [6, m%ndof, n]) &
            .or. any(shape(delta) /= [m%ne, n]) .or. size(nit) /= n .or. size(eqinfo) /= n) return
        info = sk_err_nonfinite
        if (.not. (all_finite(theta) .and. all_finite(q) .and. all_finite(lw) .and. etol == etol)) return
        info = sk_err_argument
        if (any(frame < 0) .or. any(frame > m%nv) .or. any(lvj < 0) .or. any(lvj > m%nv)) return
        call group_by(lpost, n, lstart, lidx, info)
        if (info /= sk_ok) return
        call fold_for_frames(m, theta, frame, lvj, mf, newidx, info)
        if (info /= sk_ok) return
        lvjf = newidx(lvj)
        call q_drivers(mf, ent_vj, ent_col, ent_coef, nent)
        lawcol = 0
        call state_init(mf, st, mf%qcol > 0)
        do ipost = 1, n
            call solve_posture(mf, theta, q(:, ipost), lidx(lstart(ipost):lstart(ipost + 1) - 1), lvjf, lw, &
                eqit, etol, .false., st)
            call elastic_sensitivity(mf, st, ent_vj(1:nent), ent_col(1:nent), ent_coef(1:nent), lawcol, zq, info)
            if (info /= sk_ok) return
            call frame_jacobian(mf, st, newidx(frame(ipost)), zq, rf(:, :, ipost), pf(:, ipost), jq(:, :, ipost))
            delta(:, ipost) = st%delta
            nit(ipost) = st%nit
            if (.not. st%conv) eqinfo(ipost) = sk_err_noconv
        end do
        info = merge(sk_ok, sk_err_noconv, all(eqinfo == sk_ok))
    end subroutine frame_jacobian_batch

end module sk_tree
