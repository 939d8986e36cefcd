!> The kinematic-tree model of the core (sk_tree's module header defines
!> every symbol): its types (tree_model: a validated tree, everything but
!> theta and the postures; tree_state: one posture's work arrays;
!> tree_problem: a model with its data), the forward kinematics, and the
!> set-up of a model (model_setup), a problem (problem_setup) and a
!> posture's state (state_init). The gravity parameters' routines are the
!> submodule sk_tree_grav; a model with its constant joints folded away is
!> sk_tree_fold; the laws are sk_laws.
module sk_tree_model
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: all_finite, group_by
    use sk_rotation, only: rot_exp
    use sk_spatial, only: nsym
    use sk_laws, only: law_ndof
    use sk_tree_check, only: model_check, vj_revolute, vj_prismatic
    implicit none
    private
    public :: frame_step, tree_frames
    public :: tree_model, tree_state, tree_problem
    public :: model_setup, problem_setup, state_init, ancestor
    public :: model_body_params, body_effective, body_rhs

    !> observation kinds (tree_problem okind; three rows each): the tracker
    !> position of a marker; the deflection of a marker point under the
    !> posture's known loads (base axes, first order: the point's motion
    !> per unit deflection at the undeflected frames times the first-order
    !> deflections, klimchik eqs. 4-5, docs/calibration.md section 3); the
    !> rotation of the marker's frame under those loads (base axes)
    integer, parameter, public :: obs_position = 1, obs_deflection = 2, obs_rotation = 3

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
        !> observation kinds (obs_*) [nobs]; a deflection's point in the
        !> marker frame, added to the marker's [3,nobs]; postures whose
        !> observations are deflections (solved at first order) [np]
        integer, allocatable :: okind(:)
        real(dp), allocatable :: opt(:, :)
        logical, allocatable :: pdefl(:)
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
            m%kdim(k) = law_ndof(ktype(k))
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
    !> free[nfree] (indices into theta, distinct). Optional okind[no]
    !> (obs_*, default obs_position) and opt[3,no] (the point of a
    !> deflection observation in its marker's frame, added to the
    !> marker's; default 0): a posture observes positions or deflections,
    !> not both, and deflections take no free geometric parameter (the
    !> change of the point's motion per unit deflection with the geometry
    !> is not modelled): sk_err_argument.
    subroutine problem_setup(pr, m, q, lpost, lvj, lw, opost, omark, oxyz, owt, free, info, okind, opt)
        type(tree_problem), intent(out) :: pr
        type(tree_model), intent(in) :: m
        real(dp), intent(in) :: q(:, :), lw(:, :), oxyz(:, :), owt(:)
        integer(ip), intent(in) :: lpost(:), lvj(:), opost(:), omark(:), free(:)
        integer(ip), intent(out) :: info
        integer(ip), intent(in), optional :: okind(:)
        real(dp), intent(in), optional :: opt(:, :)
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
        allocate(pr%okind(no), pr%opt(3, no), pr%pdefl(np))
        pr%okind = obs_position
        pr%opt = 0.0_dp
        info = sk_err_size
        if (present(okind)) then
            if (size(okind) /= no) return
            pr%okind = okind
        end if
        if (present(opt)) then
            if (any(shape(opt) /= [3, no])) return
            pr%opt = opt
        end if
        info = sk_err_nonfinite
        if (.not. all_finite(pr%opt)) return
        info = sk_err_argument
        if (any(pr%okind < obs_position) .or. any(pr%okind > obs_rotation)) return
        pr%pdefl = .false.
        do i = 1, no
            if (pr%okind(i) /= obs_position) pr%pdefl(opost(i)) = .true.
        end do
        do i = 1, no
            if (pr%okind(i) == obs_position .and. pr%pdefl(opost(i))) return
        end do
        allocate(pr%colof(m%npar), zof(pr%nfree))
        pr%colof = 0
        info = sk_err_argument
        do c = 1, pr%nfree
            if (pr%colof(free(c)) /= 0) return
            pr%colof(free(c)) = c
        end do
        if (any(pr%pdefl)) then
            if (any(pr%colof(m%gpar) > 0)) return
        end if
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

end module sk_tree_model
