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
    use sk_linalg, only: jacobi_eig, sym_eigvals_small, spd_inverse_small
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
        real(dp) :: dsc(6), m(6, 6), xi(6), cs, r(3), w(6), v(6, 6), bas(6, 6)
        integer :: nops, ns, nj, np, ip_, top, depth, op, arg, i, j, a, b, n
        nops = size(prog, 2)
        ns = size(lkind)
        nj = size(jtype)
        np = size(tpos, 2)
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
        ! validate the program once: indices, stack depth, one result
        depth = 0
        do i = 1, nops
            op = prog(1, i)
            arg = prog(2, i)
            select case (op)
            case (op_spring)
                if (arg < 1 .or. arg > ns) then
                    info = sk_err_argument
                    return
                end if
                depth = depth + 1
            case (op_joint)
                if (arg < 1 .or. arg > nj) then
                    info = sk_err_argument
                    return
                end if
                if (jtype(arg) /= joint_revolute .and. jtype(arg) /= joint_prismatic) then
                    info = sk_err_argument
                    return
                end if
                if (jcomp(arg) < 0.0_dp) then
                    info = sk_err_argument
                    return
                end if
                depth = depth + 1
            case (op_series, op_parallel)
                if (arg < 1 .or. arg > depth) then
                    info = sk_err_argument
                    return
                end if
                depth = depth - arg + 1
            case default
                info = sk_err_argument
                return
            end select
        end do
        if (depth /= 1 .or. nops < 1) then
            info = sk_err_argument
            return
        end if
        do i = 1, ns
            if (lkind(i) /= leaf_compliance .and. lkind(i) /= leaf_stiffness) then
                info = sk_err_argument
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
        do ip_ = 1, np
            top = 0
            do i = 1, nops
                op = prog(1, i)
                arg = prog(2, i)
                select case (op)
                case (op_spring)
                    top = top + 1
                    stack(top) = gspring()
                    m = lloc(:, :, arg)
                    call rotate_blocks(lrot(:, :, arg, ip_), m)
                    r = (tpos(:, ip_) - lpos(:, arg, ip_))/lscale
                    if (lkind(arg) == leaf_compliance) then
                        call congruence_transfer(r, m, .false.)
                        stack(top)%c = m
                        stack(top)%form = form_c
                    else
                        call congruence_transfer(r, m, .true.)
                        stack(top)%k = m
                        stack(top)%form = form_k
                    end if
                case (op_joint)
                    top = top + 1
                    stack(top) = gspring()
                    xi = joint_twist(jtype(arg), jaxis(:, arg, ip_), jpoint(:, arg, ip_), &
                                     tpos(:, ip_), lscale)
                    stack(top)%form = form_c
                    if (jpassive(arg) /= 0) then
                        cs = 1.0_dp/dot_product(xi, xi)
                        stack(top)%has_phi = .true.
                    else
                        cs = jcomp(arg)*lscale
                    end if
                    do b = 1, 6
                        do a = 1, 6
                            m(a, b) = cs*xi(a)*xi(b)
                        end do
                    end do
                    if (jpassive(arg) /= 0) then
                        stack(top)%phi = m
                        stack(top)%phi_r1 = .true.
                        stack(top)%phi_vec = xi
                    else
                        stack(top)%c = m
                    end if
                case (op_series)
                    n = top - arg + 1
                    if (stack(n)%form == form_k) call k_to_c(stack(n), rcond, .false.)
                    do j = n + 1, top
                        if (stack(j)%form == form_k) call k_to_c(stack(j), rcond, .false.)
                        stack(n)%c = stack(n)%c + stack(j)%c
                        if (stack(j)%has_phi) then
                            if (stack(n)%has_phi) then
                                stack(n)%phi_r1 = .false.
                            else
                                stack(n)%phi_r1 = stack(j)%phi_r1
                                stack(n)%phi_vec = stack(j)%phi_vec
                            end if
                            stack(n)%phi = stack(n)%phi + stack(j)%phi
                            stack(n)%has_phi = .true.
                        end if
                    end do
                    stack(n)%form = form_c
                    stack(n)%has_gam = .false.
                    top = n
                case (op_parallel)
                    n = top - arg + 1
                    if (stack(n)%form == form_c) call c_to_k(stack(n), rcond, .false.)
                    do j = n + 1, top
                        if (stack(j)%form == form_c) call c_to_k(stack(j), rcond, .false.)
                        stack(n)%k = stack(n)%k + stack(j)%k
                        if (stack(j)%has_gam) then
                            stack(n)%gam = stack(n)%gam + stack(j)%gam
                            stack(n)%has_gam = .true.
                        end if
                    end do
                    stack(n)%form = form_k
                    stack(n)%has_phi = .false.
                    stack(n)%phi_r1 = .false.
                    top = n
                end select
            end do
            ! the root in both forms
            if (stack(1)%form == form_c) then
                call c_to_k(stack(1), rcond, .true.)
            else
                call k_to_c(stack(1), rcond, .true.)
            end if
            ! report each matrix on its own subspace: C on the wrenches orthogonal
            ! to the free twists, K on the motions orthogonal to the rigid wrenches
            if (stack(1)%nf > 0) then
                m = -stack(1)%phi
                do a = 1, 6
                    m(a, a) = m(a, a) + 1.0_dp
                end do
                stack(1)%c = matmul(m, matmul(stack(1)%c, m))
            end if
            if (stack(1)%ng > 0) then
                m = -stack(1)%gam
                do a = 1, 6
                    m(a, a) = m(a, a) + 1.0_dp
                end do
                stack(1)%k = matmul(m, matmul(stack(1)%k, m))
            end if
            ratio(ip_) = stack(1)%ratio
            nfree(ip_) = stack(1)%nf
            nrigid(ip_) = stack(1)%ng
            ! back to the caller's units, then to the tool axes
            do b = 1, 6
                do a = 1, 6
                    c(a, b, ip_) = stack(1)%c(a, b)/(dsc(a)*dsc(b))
                    k(a, b, ip_) = stack(1)%k(a, b)*dsc(a)*dsc(b)
                end do
            end do
            call rotate_blocks(transpose(trot(:, :, ip_)), c(:, :, ip_))
            call rotate_blocks(transpose(trot(:, :, ip_)), k(:, :, ip_))
            if (stack(1)%nf > 0) then
                call jacobi_eig(6, stack(1)%phi, w, v)
                bas = 0.0_dp
                do j = 1, stack(1)%nf
                    bas(1:3, j) = v(1:3, 7 - j)*lscale
                    bas(4:6, j) = v(4:6, 7 - j)
                    bas(1:3, j) = matmul(transpose(trot(:, :, ip_)), bas(1:3, j))
                    bas(4:6, j) = matmul(transpose(trot(:, :, ip_)), bas(4:6, j))
                end do
                free(:, :, ip_) = bas
            end if
            if (stack(1)%ng > 0) then
                call jacobi_eig(6, stack(1)%gam, w, v)
                bas = 0.0_dp
                do j = 1, stack(1)%ng
                    bas(1:3, j) = v(1:3, 7 - j)
                    bas(4:6, j) = v(4:6, 7 - j)*lscale
                    bas(1:3, j) = matmul(transpose(trot(:, :, ip_)), bas(1:3, j))
                    bas(4:6, j) = matmul(transpose(trot(:, :, ip_)), bas(4:6, j))
                end do
                rigid(:, :, ip_) = bas
            end if
        end do
        info = sk_ok
    end subroutine spring_tree_batch

end module sk_springs
