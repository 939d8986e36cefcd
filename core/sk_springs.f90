!> Generalised springs (Taghvaeipour et al. 2010 s3) and virtual-joint
!> models (Klimchik et al. eq. 2) as one small algebra, evaluated in batch
!> over postures.
!>
!> A generalised spring between two rigid bodies is held in two dual forms,
!> both always defined, at one reference point with one set of axes:
!>   compliance form (C, Phi):  x = C w + F q,  F^T w = 0
!>       C    6x6 compliance on the wrenches the spring carries (may be
!>            singular: zero compliance = rigid direction),
!>       Phi  projector onto the free twists F (passive joints, mechanisms);
!>   stiffness form (K, Gam):   w = K x + G l,  G^T x = 0
!>       K    6x6 stiffness on the motions the spring allows (may be
!>            singular: zero stiffness = free direction),
!>       Gam  projector onto the rigid (reaction) wrenches G.
!> A serial array adds compliance forms (eqs. 17-22: with every spring
!> moved to one point the Schur complement of eq. 22 becomes a sum of
!> compliances); a parallel array adds stiffness forms (eq. 16). Switching
!> form is a symmetric eigenproblem on the subspace orthogonal to the
!> free/rigid directions, so a singular matrix is never inverted: the
!> directions whose eigenvalue falls below rcond times the largest become
!> free (or rigid) directions and are reported, which is how the rank drop
!> at a singular posture shows up.
!>
!> Units. Rank decisions compare translations with rotations, so the core
!> works in a scaled space: lengths divided by a characteristic length
!> lscale, x~ = D x, w~ = D^-1 w, C~ = D C D, K~ = D^-1 K D^-1 with
!> D = diag(lscale^-1/2 I, lscale^1/2 I). Orthogonality and eigenvalue
!> ratios there do not depend on the unit of length. Inputs and outputs are
!> in the caller's units.
!>
!> Everything is expressed at the tool (output) point in world axes from
!> the start: each leaf is moved there with the transfer matrices of eqs.
!> 8 and 12, so a tree of series/parallel arrays needs no more geometry.
!> Those leaf terms (rotate_blocks, congruence_transfer, revolute_twist)
!> are sk_spatial's, the same code sk_chain sums for a URDF serial chain:
!> one implementation of the virtual-joint terms in the core.
!> A tree is a postfix program: push leaf spring, push joint, combine the
!> top n entries in series, combine them in parallel.
module sk_springs
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_spatial, only: rotate_blocks, congruence_transfer, revolute_twist
    use sk_small_sym, only: jacobi_eig, sym_eigvals_small, spd_inverse_small, psd_defect, psd_tol
    use sk_linalg, only: all_finite
    implicit none
    private
    public :: op_spring, op_joint, op_series, op_parallel
    public :: leaf_compliance, leaf_stiffness, joint_revolute, joint_prismatic
    public :: gspring, c_to_k, k_to_c, spring_tree_batch
    public :: congruence_transfer, rotate_blocks

    integer(ip), parameter :: op_spring = 1     !> push leaf spring arg
    integer(ip), parameter :: op_joint = 2      !> push joint arg
    integer(ip), parameter :: op_series = 3     !> pop arg entries, push their serial array
    integer(ip), parameter :: op_parallel = 4   !> pop arg entries, push their parallel array

    integer(ip), parameter :: leaf_compliance = 0   !> leaf matrix is a compliance
    integer(ip), parameter :: leaf_stiffness = 1    !> leaf matrix is a stiffness
    integer(ip), parameter :: joint_revolute = 1
    integer(ip), parameter :: joint_prismatic = 2

    integer, parameter :: form_c = 1, form_k = 2

    !> One generalised spring in both forms (scaled space, tool point).
    type :: gspring
        real(dp) :: c(6, 6) = 0.0_dp      !> compliance on wrenches orthogonal to the free twists
        real(dp) :: phi(6, 6) = 0.0_dp    !> projector (or sum of projectors) onto free twists
        real(dp) :: k(6, 6) = 0.0_dp      !> stiffness on motions orthogonal to the rigid wrenches
        real(dp) :: gam(6, 6) = 0.0_dp    !> projector (or sum) onto rigid wrenches
        logical :: has_phi = .false., has_gam = .false.
        logical :: phi_r1 = .false.       !> phi is the single rank-1 projector phi_vec phi_vec^T
        real(dp) :: phi_vec(6) = 0.0_dp
        integer :: form = form_c
        integer :: nf = 0, ng = 0         !> numbers of free twists / rigid wrenches (after a switch)
        real(dp) :: ratio = 1.0_dp        !> smallest/largest eigenvalue kept in the last switch
    end type gspring

contains

    !> Orthonormal bases of range(p) (eigenvalue > tol*max) and of its
    !> orthogonal complement, for a symmetric PSD p[6,6].
    pure subroutine split_range(p, has, tol, rng, nr, cmp, nc)
        real(dp), intent(in) :: p(6, 6), tol
        logical, intent(in) :: has
        real(dp), intent(out) :: rng(6, 6), cmp(6, 6)
        integer, intent(out) :: nr, nc
        real(dp) :: w(6), v(6, 6), wmax
        integer :: i
        rng = 0.0_dp
        cmp = 0.0_dp
        nr = 0
        nc = 0
        if (.not. has) then
            do i = 1, 6
                cmp(i, i) = 1.0_dp
            end do
            nc = 6
            return
        end if
        call jacobi_eig(6, p, w, v)
        wmax = w(6)
        do i = 1, 6
            if (wmax > 0.0_dp .and. w(i) > tol*wmax) then
                nr = nr + 1
                rng(:, nr) = v(:, i)
            else
                nc = nc + 1
                cmp(:, nc) = v(:, i)
            end if
        end do
    end subroutine split_range

    !> Shared body of the two switches: given the dual projector (free
    !> twists for C -> K, rigid wrenches for K -> C) and the matrix m
    !> (C or K), return its inverse on the complement (minv), the new
    !> degenerate projector (pnew: rigid for C -> K, free for K -> C) with
    !> its rank, the rank of the old one (made an exact projector) and the
    !> eigenvalue ratio. A projector known to be the rank-1 vec vec^T
    !> (r1) is complemented by a Householder reflection. Unless exact, a
    !> reduced matrix whose Cholesky factor proves every eigenvalue above
    !> rcond times the largest (1/(tr M tr M^-1) > rcond) is inverted
    !> directly, with the same rank decision as the eigen-decomposition;
    !> ratio is then that lower bound, or, if exact, the eigenvalue ratio
    !> (eigenvalues by tridiagonal QL). Otherwise the Jacobi eigenvectors
    !> decide the rank.
    pure subroutine switch_form(m, pold, has_old, r1, vec, rcond, exact, minv, pnew, nnew, nold, ratio)
        real(dp), intent(in) :: m(6, 6), rcond, vec(6)
        real(dp), intent(inout) :: pold(6, 6)
        logical, intent(in) :: has_old, r1, exact
        real(dp), intent(out) :: minv(6, 6), pnew(6, 6), ratio
        integer, intent(out) :: nnew, nold
        real(dp) :: rng(6, 6), cmp(6, 6), mr(6, 6), mri(6, 6), w(6), u(6, 6), z(6), smax, smin
        real(dp) :: hv(6), bound
        logical :: ok
        integer :: nc, i, a, b, kept
        if (has_old .and. r1) then
            hv = vec/norm2(vec)
            rng = 0.0_dp
            cmp = 0.0_dp
            rng(:, 1) = hv
            nold = 1
            hv(1) = hv(1) + sign(1.0_dp, hv(1))
            do b = 2, 6
                do a = 1, 6
                    cmp(a, b - 1) = -2.0_dp*hv(a)*hv(b)/dot_product(hv, hv)
                end do
                cmp(b, b - 1) = cmp(b, b - 1) + 1.0_dp
            end do
            nc = 5
        else
            call split_range(pold, has_old, rcond, rng, nold, cmp, nc)
        end if
        ! full 6x6 products (unused columns of rng, cmp are zero): fixed-size
        ! matmuls the compiler inlines
        if (has_old) pold = matmul(rng, transpose(rng))
        minv = 0.0_dp
        pnew = 0.0_dp
        nnew = 0
        ratio = 0.0_dp
        if (nc == 0) return
        mr = matmul(transpose(cmp), matmul(m, cmp))
        mri = 0.0_dp
        call spd_inverse_small(nc, mr(1:nc, 1:nc), mri(1:nc, 1:nc), bound, ok)
        if (ok .and. bound > rcond) then
            ! every eigenvalue is above rcond times the largest: full rank
            minv = matmul(cmp, matmul(mri, transpose(cmp)))
            ratio = bound
            if (exact) then
                call sym_eigvals_small(nc, mr(1:nc, 1:nc), w(1:nc), ok)
                if (ok) then
                    ratio = minval(w(1:nc))/maxval(w(1:nc))
                    return
                end if
            else
                return
            end if
        end if
        call jacobi_eig(nc, mr(1:nc, 1:nc), w(1:nc), u(1:nc, 1:nc))
        smax = w(nc)
        smin = smax
        kept = 0
        do i = 1, nc
            z = matmul(cmp(:, 1:nc), u(1:nc, i))
            if (smax > tiny(1.0_dp) .and. w(i) > rcond*smax) then
                kept = kept + 1
                smin = min(smin, w(i))
                do b = 1, 6
                    do a = 1, 6
                        minv(a, b) = minv(a, b) + z(a)*z(b)/w(i)
                    end do
                end do
            else
                nnew = nnew + 1
                do b = 1, 6
                    do a = 1, 6
                        pnew(a, b) = pnew(a, b) + z(a)*z(b)
                    end do
                end do
            end if
        end do
        if (kept > 0) ratio = smin/smax
    end subroutine switch_form

    !> Compliance form -> stiffness form (scaled space).
    pure subroutine c_to_k(s, rcond, exact)
        type(gspring), intent(inout) :: s
        real(dp), intent(in) :: rcond
        logical, intent(in) :: exact
        call switch_form(s%c, s%phi, s%has_phi, s%phi_r1, s%phi_vec, rcond, exact, s%k, s%gam, &
                         s%ng, s%nf, s%ratio)
        s%has_gam = s%ng > 0
        s%has_phi = s%nf > 0
    end subroutine c_to_k

    !> Stiffness form -> compliance form (scaled space).
    pure subroutine k_to_c(s, rcond, exact)
        type(gspring), intent(inout) :: s
        real(dp), intent(in) :: rcond
        logical, intent(in) :: exact
        call switch_form(s%k, s%gam, s%has_gam, .false., s%phi_vec, rcond, exact, s%c, s%phi, &
                         s%nf, s%ng, s%ratio)
        s%has_phi = s%nf > 0
        s%has_gam = s%ng > 0
        s%phi_r1 = .false.
    end subroutine k_to_c

    !> Unit twist of a joint seen at the tool point, scaled: (t/lscale, phi);
    !> the revolute twist is sk_spatial's (the one sk_chain uses too).
    pure function joint_twist(jtype, axis, point, tool, lscale) result(xi)
        integer(ip), intent(in) :: jtype
        real(dp), intent(in) :: axis(3), point(3), tool(3), lscale
        real(dp) :: xi(6), u(3)
        u = axis/norm2(axis)
        if (jtype == joint_revolute) then
            xi = revolute_twist(u, point, tool)
            xi(1:3) = xi(1:3)/lscale
        else
            xi(1:3) = u/lscale
            xi(4:6) = 0.0_dp
        end if
    end function joint_twist

    !> Check a postfix program once: leaf and joint indices, joint types,
    !> operand counts, one result on the stack; info = sk_ok or
    !> sk_err_argument (a negative joint compliance: sk_err_indefinite).
    pure subroutine check_program(prog, lkind, jtype, jcomp, info)
        integer(ip), intent(in) :: prog(:, :), lkind(:), jtype(:)
        real(dp), intent(in) :: jcomp(:)
        integer(ip), intent(out) :: info
        integer :: i, op, arg, depth
        info = sk_err_argument
        depth = 0
        do i = 1, size(prog, 2)
            op = prog(1, i)
            arg = prog(2, i)
            select case (op)
            case (op_spring)
                if (arg < 1 .or. arg > size(lkind)) return
                depth = depth + 1
            case (op_joint)
                if (arg < 1 .or. arg > size(jtype)) return
                if (jtype(arg) /= joint_revolute .and. jtype(arg) /= joint_prismatic) return
                if (jcomp(arg) < 0.0_dp) then
                    info = sk_err_indefinite
                    return
                end if
                depth = depth + 1
            case (op_series, op_parallel)
                if (arg < 1 .or. arg > depth) return
                depth = depth - arg + 1
            case default
                return
            end select
        end do
        if (depth /= 1 .or. size(prog, 2) < 1) return
        if (any(lkind /= leaf_compliance .and. lkind /= leaf_stiffness)) return
        info = sk_ok
    end subroutine check_program

    !> A leaf spring (scaled matrix m in its local axes) posed by rot, pos
    !> and moved to the tool point (eqs. 8, 12): compliance or stiffness form.
    pure function leaf_spring(m0, kind, rot, pos, tool, lscale) result(s)
        real(dp), intent(in) :: m0(6, 6), rot(3, 3), pos(3), tool(3), lscale
        integer(ip), intent(in) :: kind
        type(gspring) :: s
        real(dp) :: m(6, 6)
        m = m0
        call rotate_blocks(rot, m)
        if (kind == leaf_compliance) then
            call congruence_transfer((tool - pos)/lscale, m, .false.)
            s%c = m
            s%form = form_c
        else
            call congruence_transfer((tool - pos)/lscale, m, .true.)
            s%k = m
            s%form = form_k
        end if
    end function leaf_spring

    !> A joint seen at the tool point: a rank-1 compliance c xi xi^T along its
    !> unit twist, or, when passive, the rank-1 projector onto that free twist.
    pure function joint_spring(jtype, comp, passive, axis, point, tool, lscale) result(s)
        integer(ip), intent(in) :: jtype
        real(dp), intent(in) :: comp, axis(3), point(3), tool(3), lscale
        logical, intent(in) :: passive
        type(gspring) :: s
        real(dp) :: xi(6), cs
        integer :: a, b
        xi = joint_twist(jtype, axis, point, tool, lscale)
        s%form = form_c
        cs = merge(1.0_dp/dot_product(xi, xi), comp*lscale, passive)
        do b = 1, 6
            do a = 1, 6
                if (passive) then
                    s%phi(a, b) = cs*xi(a)*xi(b)
                else
                    s%c(a, b) = cs*xi(a)*xi(b)
                end if
            end do
        end do
        if (passive) then
            s%has_phi = .true.
            s%phi_r1 = .true.
            s%phi_vec = xi
        end if
    end function joint_spring

    !> Serial array of the springs st (eqs. 17-22): compliance forms add,
    !> free-twist projectors add; the result replaces st(1).
    pure subroutine combine_series(st, rcond)
        type(gspring), intent(inout) :: st(:)
        real(dp), intent(in) :: rcond
        integer :: j
        if (st(1)%form == form_k) call k_to_c(st(1), rcond, .false.)
        do j = 2, size(st)
            if (st(j)%form == form_k) call k_to_c(st(j), rcond, .false.)
            st(1)%c = st(1)%c + st(j)%c
            if (st(j)%has_phi) then
                if (st(1)%has_phi) then
                    st(1)%phi_r1 = .false.
                else
                    st(1)%phi_r1 = st(j)%phi_r1
                    st(1)%phi_vec = st(j)%phi_vec
                end if
                st(1)%phi = st(1)%phi + st(j)%phi
                st(1)%has_phi = .true.
            end if
        end do
        st(1)%form = form_c
        st(1)%has_gam = .false.
    end subroutine combine_series

    !> Parallel array of the springs st (eq. 16): stiffness forms add,
    !> rigid-wrench projectors add; the result replaces st(1).
    pure subroutine combine_parallel(st, rcond)
        type(gspring), intent(inout) :: st(:)
        real(dp), intent(in) :: rcond
        integer :: j
        if (st(1)%form == form_c) call c_to_k(st(1), rcond, .false.)
        do j = 2, size(st)
            if (st(j)%form == form_c) call c_to_k(st(j), rcond, .false.)
            st(1)%k = st(1)%k + st(j)%k
            if (st(j)%has_gam) then
                st(1)%gam = st(1)%gam + st(j)%gam
                st(1)%has_gam = .true.
            end if
        end do
        st(1)%form = form_k
        st(1)%has_phi = .false.
        st(1)%phi_r1 = .false.
    end subroutine combine_parallel

    !> Unit basis of the range of projector p (nb columns, largest first),
    !> unscaled (translation rows times tscale, rotation rows times rscale)
    !> and rotated into the result axes trot.
    pure function projector_basis(p, nb, tscale, rscale, trot) result(bas)
        real(dp), intent(in) :: p(6, 6), tscale, rscale, trot(3, 3)
        integer, intent(in) :: nb
        real(dp) :: bas(6, 6), w(6), v(6, 6)
        integer :: j
        call jacobi_eig(6, p, w, v)
        bas = 0.0_dp
        do j = 1, nb
            bas(1:3, j) = matmul(transpose(trot), v(1:3, 7 - j)*tscale)
            bas(4:6, j) = matmul(transpose(trot), v(4:6, 7 - j)*rscale)
        end do
    end function projector_basis

    !> The root spring in both forms, each on its own subspace (C on the
    !> wrenches orthogonal to the free twists, K on the motions orthogonal to
    !> the rigid wrenches), back in the caller's units and the tool axes.
    pure subroutine root_results(s, rcond, dsc, trot, lscale, c, k, free, nfree, rigid, nrigid, ratio)
        type(gspring), intent(inout) :: s
        real(dp), intent(in) :: rcond, dsc(6), trot(3, 3), lscale
        real(dp), intent(out) :: c(6, 6), k(6, 6), free(6, 6), rigid(6, 6), ratio
        integer(ip), intent(out) :: nfree, nrigid
        real(dp) :: m(6, 6)
        integer :: a, b
        if (s%form == form_c) then
            call c_to_k(s, rcond, .true.)
        else
            call k_to_c(s, rcond, .true.)
        end if
        if (s%nf > 0) then
            m = -s%phi
            do a = 1, 6
                m(a, a) = m(a, a) + 1.0_dp
            end do
            s%c = matmul(m, matmul(s%c, m))
        end if
        if (s%ng > 0) then
            m = -s%gam
            do a = 1, 6
                m(a, a) = m(a, a) + 1.0_dp
            end do
            s%k = matmul(m, matmul(s%k, m))
        end if
        ratio = s%ratio
        nfree = s%nf
        nrigid = s%ng
        do b = 1, 6
            do a = 1, 6
                c(a, b) = s%c(a, b)/(dsc(a)*dsc(b))
                k(a, b) = s%k(a, b)*dsc(a)*dsc(b)
            end do
        end do
        call rotate_blocks(transpose(trot), c)
        call rotate_blocks(transpose(trot), k)
        free = 0.0_dp
        rigid = 0.0_dp
        if (s%nf > 0) free = projector_basis(s%phi, s%nf, lscale, 1.0_dp, trot)
        if (s%ng > 0) rigid = projector_basis(s%gam, s%ng, 1.0_dp, lscale, trot)
    end subroutine root_results

    !> Evaluate a spring tree at np postures.
    !>
    !> prog[2,nops]: postfix program, (op, arg) per step (op_* codes).
    !> lkind[ns], lmat[6,6,ns]: leaf springs, compliance or stiffness in
    !>   their local axes at their own point; lrot[3,3,ns,np], lpos[3,ns,np]:
    !>   pose of each leaf (columns of lrot = local axes in world) per posture.
    !> jtype[nj], jcomp[nj], jpassive[nj], jaxis[3,nj,np], jpoint[3,nj,np]:
    !>   joints, revolute or prismatic, compliance (rad/(N m) or m/N, rank-1
    !>   spring about/along the axis) or passive (free) if jpassive /= 0.
    !> tpos[3,np], trot[3,3,np]: tool point and the axes of the results.
    !> Results per posture: compliance c and stiffness k (each on the
    !> complement of the free twists / rigid wrenches), free twists
    !> free[:, 1:nfree] (columns (t, phi), |t/lscale|^2 + |phi|^2 = 1),
    !> rigid wrenches rigid[:, 1:nrigid] (|f|^2 + |m/lscale|^2 = 1) and the
    !> smallest/largest stiffness eigenvalue ratio (scaled) of the rest.
    subroutine spring_tree_batch(prog, lkind, lmat, lrot, lpos, jtype, jcomp, jpassive, &
            jaxis, jpoint, tpos, trot, lscale, rcond, c, k, free, nfree, rigid, nrigid, ratio, info)
        integer(ip), intent(in) :: prog(:, :), lkind(:), jtype(:), jpassive(:)
        real(dp), intent(in) :: lmat(:, :, :), lrot(:, :, :, :), lpos(:, :, :)
        real(dp), intent(in) :: jcomp(:), jaxis(:, :, :), jpoint(:, :, :)
        real(dp), intent(in) :: tpos(:, :), trot(:, :, :), lscale, rcond
        real(dp), intent(out) :: c(:, :, :), k(:, :, :), free(:, :, :), rigid(:, :, :), ratio(:)
        integer(ip), intent(out) :: nfree(:), nrigid(:), info
        type(gspring), allocatable :: stack(:)
        real(dp), allocatable :: lloc(:, :, :)
        real(dp) :: dsc(6)
        integer :: nops, ns, ip_, top, op, arg, i, a, b, n
        nops = size(prog, 2)
        ns = size(lkind)
        c = 0.0_dp; k = 0.0_dp; free = 0.0_dp; rigid = 0.0_dp; ratio = 0.0_dp
        nfree = 0; nrigid = 0
        if (.not. (lscale > 0.0_dp) .or. .not. (rcond >= 0.0_dp .and. rcond < 1.0_dp)) then
            info = sk_err_argument
            return
        end if
        if (.not. (all(abs(lmat) <= huge(1.0_dp)) .and. all(abs(jcomp) <= huge(1.0_dp)))) then
            info = sk_err_nonfinite
            return
        end if
        call check_program(prog, lkind, jtype, jcomp, info)
        if (info /= sk_ok) return
        ! a leaf with a negative eigenvalue is no spring: it would turn into a
        ! "rigid" or "free" direction below instead of an error
        do i = 1, ns
            if (psd_defect(6, lmat(:, :, i)) < -psd_tol) then
                info = sk_err_indefinite
                return
            end if
        end do
        ! leaves in the scaled space, local axes (posture independent)
        dsc = [(lscale**(-0.5_dp), i = 1, 3), (lscale**0.5_dp, i = 1, 3)]
        allocate(lloc(6, 6, max(ns, 1)))
        do i = 1, ns
            do b = 1, 6
                do a = 1, 6
                    if (lkind(i) == leaf_compliance) then
                        lloc(a, b, i) = dsc(a)*lmat(a, b, i)*dsc(b)
                    else
                        lloc(a, b, i) = lmat(a, b, i)/(dsc(a)*dsc(b))
                    end if
                end do
            end do
            lloc(:, :, i) = 0.5_dp*(lloc(:, :, i) + transpose(lloc(:, :, i)))
        end do
        allocate(stack(nops))
        do ip_ = 1, size(tpos, 2)
            top = 0
            do i = 1, nops
                op = prog(1, i)
                arg = prog(2, i)
                select case (op)
                case (op_spring)
                    top = top + 1
                    stack(top) = leaf_spring(lloc(:, :, arg), lkind(arg), lrot(:, :, arg, ip_), &
                                             lpos(:, arg, ip_), tpos(:, ip_), lscale)
                case (op_joint)
                    top = top + 1
                    stack(top) = joint_spring(jtype(arg), jcomp(arg), jpassive(arg) /= 0, &
                                              jaxis(:, arg, ip_), jpoint(:, arg, ip_), tpos(:, ip_), lscale)
                case (op_series)
                    n = top - arg + 1
                    call combine_series(stack(n:top), rcond)
                    top = n
                case (op_parallel)
                    n = top - arg + 1
                    call combine_parallel(stack(n:top), rcond)
                    top = n
                end select
            end do
            call root_results(stack(1), rcond, dsc, trot(:, :, ip_), lscale, c(:, :, ip_), k(:, :, ip_), &
                              free(:, :, ip_), nfree(ip_), rigid(:, :, ip_), nrigid(ip_), ratio(ip_))
        end do
        info = sk_ok
        if (.not. (all_finite(c) .and. all_finite(k) .and. all_finite(ratio))) info = sk_err_overflow
    end subroutine spring_tree_batch

end module sk_springs
