!> Serial chains: forward kinematics, Jacobians of the virtual springs, the
!> tool compliance sum_i J_i C_i J_i^T (klimchik eq. 2-3) batched over
!> postures, and the per-spring observation basis of the calibration
!> (klimchik eqs. 4-5, 12).
!>
!> A chain is a list of nj joints from base_link to the tool link; joint k
!> has a fixed origin (rotation jrot[3,3,k], translation jpos[3,k], both in
!> its parent frame), a unit axis jaxis[3,k] (joint frame) and qidx(k), the
!> index of its coordinate in q (0 for a fixed joint). URDF convention:
!>   T_child = T_parent * T(origin) * Rot(axis, q).
!> The tool frame is T_last_child * T(tpos, trot).
!>
!> Frame F_k = T_parent * T(origin_k): the frame of joint k before its
!> rotation. Virtual springs (stype):
!>   1  joint spring of joint k: rotation about its axis, 1 dof
!>   2  6-dof spring at F_k (the distal frame of joint k's parent link)
!>   3  6-dof spring at the base_link origin, base axes
!>   4  6-dof spring at the tool frame
!> Deflections of 6-dof springs (dt, dphi) and their wrenches (f, m) are
!> expressed in the spring frame; the tool twist is in base axes about the
!> tool-frame origin (sk_spatial conventions).
module sk_chain
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: eye, skew, sym_eig, spd_inverse, all_finite, psd_defect, psd_tol
    use sk_tree, only: tree_frames, frame_step, vj_fixed, vj_revolute
    use sk_spatial, only: twist_transfer, blockdiag_rot, revolute_twist, spring_at, add_rank1, &
        rotate_blocks, congruence_transfer, sym_index, nsym
    implicit none
    private
    public :: chain_frames, spring_jacobian, spring_ndof, tool_compliance_batch, check_chain
    public :: spring_basis_batch, sym_index, nsym, spring_jacobians, chain_poses_batch
    !> spring types (the stype codes above; robot/model.py SPRING_* mirrors them,
    !> tests/test_architecture.py checks that the two agree)
    integer(ip), parameter, public :: spring_joint = 1, spring_frame = 2, spring_base = 3, spring_tool = 4

contains

    !> Degrees of freedom of a spring type (1 for a joint spring, else 6).
    pure integer function spring_ndof(stype) result(n)
        integer(ip), intent(in) :: stype
        n = merge(1, 6, stype == spring_joint)
    end function spring_ndof

    !> Frames of the chain at posture q: rf[3,3,nj], pf[3,nj] of every F_k
    !> (base axes/coordinates), and the tool frame rt[3,3], pt[3]. The chain
    !> is a tree with parent(k) = k - 1 (sk_tree's forward kinematics); F_k
    !> is joint k's frame before its motion, the tool a fixed joint after
    !> the last one.
    pure subroutine chain_frames(jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rt, pt)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3), q(:)
        integer(ip), intent(in) :: qidx(:)
        real(dp), intent(out) :: rf(:, :, :), pf(:, :), rt(3, 3), pt(3)
        integer :: parent(size(qidx)), vtype(size(qidx)), k, nj
        real(dp) :: val(size(qidx)), ra(3, 3, size(qidx)), pa(3, size(qidx)), r(3, 3), p(3), ta(3, 3), tp(3)
        nj = size(qidx)
        do k = 1, nj
            parent(k) = k - 1
            vtype(k) = vj_fixed
            val(k) = 0.0_dp
            if (qidx(k) > 0) then
                vtype(k) = vj_revolute
                val(k) = q(qidx(k))
            end if
        end do
        call tree_frames(parent, vtype, jrot, jpos, jaxis, val, rf, pf, ra, pa)
        if (nj > 0) then
            r = ra(:, :, nj)
            p = pa(:, nj)
        else
            r = eye(3)
            p = 0.0_dp
        end if
        call frame_step(r, p, trot, tpos, vj_fixed, tpos, 0.0_dp, trot, rt, pt, ta, tp)
    end subroutine chain_frames

    !> Jacobian j[6,n] (n = spring_ndof) of the tool twist with respect to
    !> the deflection of spring (stype, sidx), given the frames.
    pure subroutine spring_jacobian(stype, sidx, jaxis, rf, pf, rt, pt, j)
        integer(ip), intent(in) :: stype, sidx
        real(dp), intent(in) :: jaxis(:, :), rf(:, :, :), pf(:, :), rt(3, 3), pt(3)
        real(dp), intent(out) :: j(:, :)
        select case (stype)
        case (spring_joint)
            j(:, 1) = revolute_twist(matmul(rf(:, :, sidx), jaxis(:, sidx)), pf(:, sidx), pt)
        case (spring_frame)
            j(:, 1:6) = matmul(twist_transfer(pt - pf(:, sidx)), blockdiag_rot(rf(:, :, sidx)))
        case (spring_base)
            j(:, 1:6) = twist_transfer(pt)
        case default
            j(:, 1:6) = blockdiag_rot(rt)
        end select
    end subroutine spring_jacobian

    !> Check the chain description; info = sk_ok or an sk_errors code.
    pure subroutine check_chain(jaxis, qidx, ndof, stype, sidx, info)
        real(dp), intent(in) :: jaxis(:, :)
        integer(ip), intent(in) :: qidx(:), ndof, stype(:), sidx(:)
        integer(ip), intent(out) :: info
        integer :: k, nj
        nj = size(qidx)
        info = sk_err_argument
        do k = 1, nj
            if (qidx(k) < 0 .or. qidx(k) > ndof) return
            if (qidx(k) > 0 .and. abs(norm2(jaxis(:, k)) - 1.0_dp) > 1.0e-9_dp) return
        end do
        do k = 1, size(stype)
            if (stype(k) < spring_joint .or. stype(k) > spring_tool) return
            if (stype(k) <= spring_frame .and. (sidx(k) < 1 .or. sidx(k) > nj)) return
            if (stype(k) == spring_joint) then
                if (qidx(sidx(k)) == 0) return
            end if
        end do
        info = sk_ok
    end subroutine check_chain

    !> Tool compliance c[6,6,np] = sum_s J_s C_s J_s^T at np postures q[ndof,np].
    !> Joint springs take the per-posture compliance cj(s, ip); 6-dof springs
    !> the constant cs[6,6,s]. Stiffness k = c^-1 where c is positive definite
    !> (Cholesky succeeds and trace(c) trace(k), a bound on the condition
    !> number, stays below 1e13: kinfo = 0, rank 6), else k = 0, kinfo =
    !> sk_err_singular and rank(ip) the numerical rank of c (eigenvalues
    !> above 1e-12 of the largest).
    subroutine tool_compliance_batch(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, cs, cj, &
            q, c, k, rank, kinfo, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:)
        real(dp), intent(in) :: cs(:, :, :), cj(:, :), q(:, :)
        real(dp), intent(out) :: c(:, :, :), k(:, :, :)
        integer(ip), intent(out) :: rank(:), kinfo(:), info
        real(dp), allocatable :: rf(:, :, :), pf(:, :)
        real(dp) :: rt(3, 3), pt(3), ev(6), v(6, 6), cc(6, 6), m(6, 6)
        integer :: ipost, s, nj, ns
        integer(ip) :: linfo
        nj = size(qidx)
        ns = size(stype)
        c = 0.0_dp
        k = 0.0_dp
        rank = 0
        kinfo = 0
        call check_chain(jaxis, qidx, size(q, 1, kind=ip), stype, sidx, info)
        if (info /= sk_ok) return
        if (.not. (all_finite(q) .and. all_finite(cs) .and. all_finite(cj))) then
            info = sk_err_nonfinite
            return
        end if
        ! a negative joint compliance or an indefinite 6x6 spring is no spring:
        ! it would show as a lost rank or a negative tool compliance instead
        do s = 1, ns
            if (stype(s) == 1) then
                if (any(cj(s, :) < 0.0_dp)) info = sk_err_indefinite
            else if (psd_defect(6, cs(:, :, s)) < -psd_tol) then
                info = sk_err_indefinite
            end if
            if (info /= sk_ok) return
        end do
        allocate(rf(3, 3, nj), pf(3, nj))
        do ipost = 1, size(q, 2)
            call chain_frames(jrot, jpos, jaxis, qidx, trot, tpos, q(:, ipost), rf, pf, rt, pt)
            ! J_s C_s J_s^T term by term with the sk_spatial primitives (the
            ! block forms of spring_jacobian's J, shared with sk_springs)
            cc = 0.0_dp
            do s = 1, ns
                select case (stype(s))
                case (1)
                    call add_rank1(cj(s, ipost), revolute_twist(matmul(rf(:, :, sidx(s)), &
                        jaxis(:, sidx(s))), pf(:, sidx(s)), pt), cc)
                    cycle
                case (2)
                    m = cs(:, :, s)
                    call spring_at(rf(:, :, sidx(s)), pt - pf(:, sidx(s)), m)
                case (3)
                    m = cs(:, :, s)
                    call congruence_transfer(pt, m, .false.)
                case default
                    m = cs(:, :, s)
                    call rotate_blocks(rt, m)
                end select
                cc = cc + m
            end do
            cc = 0.5_dp*(cc + transpose(cc))
            c(:, :, ipost) = cc
            ! positive definite: Cholesky inverse; otherwise the rank from the eigenvalues
            call spd_inverse(cc, v, linfo)
            if (linfo == sk_ok) linfo = merge(sk_ok, sk_err_singular, &
                (cc(1,1) + cc(2,2) + cc(3,3) + cc(4,4) + cc(5,5) + cc(6,6)) &
                *(v(1,1) + v(2,2) + v(3,3) + v(4,4) + v(5,5) + v(6,6)) < 1.0e13_dp)
            if (linfo == sk_ok) then
                k(:, :, ipost) = v
                rank(ipost) = 6
                cycle
            end if
            call sym_eig(cc, ev, v, linfo)
            if (linfo /= sk_ok) then
                info = linfo
                return
            end if
            rank(ipost) = count(ev > 1.0e-12_dp*max(maxval(abs(ev)), tiny(1.0_dp)))
            kinfo(ipost) = sk_err_singular
        end do
        info = sk_ok
        if (.not. (all_finite(c) .and. all_finite(k))) info = sk_err_overflow
    end subroutine tool_compliance_batch

    !> Observation basis of nm measurement rows (klimchik eqs. 5, 12): for
    !> row m with posture q[:,m], wrench w[:,m] (f, m at the tool origin,
    !> base axes) and point p[:,m] (tool coordinates), and for every spring
    !> s, the deflection per unit compliance parameter:
    !>   joint spring: one column  J_s J_s^T w
    !>   6-dof spring: 21 columns  J_s E_ab J_s^T w, E_ab the symmetric unit
    !>                 matrix of element (a, b), a <= b (sym_index order).
    !> Each column has 6 rows: the point deflection dt + dphi x (R_tool p)
    !> (base axes), then the tool rotation dphi. Columns of spring s start at
    !> offset(s) + 1; basis[6, nm, nb], nb = sum of 1 or 21 per spring.
    !> rtool[3,3,nm] returns the tool rotations (for point-offset terms).
    subroutine spring_basis_batch(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q, w, p, &
            basis, rtool, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:)
        real(dp), intent(in) :: q(:, :), w(:, :), p(:, :)
        real(dp), intent(out) :: basis(:, :, :), rtool(:, :, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: rf(:, :, :), pf(:, :)
        real(dp) :: rt(3, 3), pt(3), jj(6, 6), g(6, 6), a(6), pm(3, 6)
        integer :: m, s, nj, ns, col, kk, ia, ib, nb
        nj = size(qidx)
        ns = size(stype)
        basis = 0.0_dp
        rtool = 0.0_dp
        call check_chain(jaxis, qidx, size(q, 1, kind=ip), stype, sidx, info)
        if (info /= sk_ok) return
        nb = 0
        do s = 1, ns
            nb = nb + merge(1, nsym, stype(s) == 1)
        end do
        if (size(basis, 1) /= 6 .or. size(basis, 3) /= nb .or. size(basis, 2) /= size(q, 2) &
            .or. size(w, 2) /= size(q, 2) .or. size(p, 2) /= size(q, 2)) then
            info = sk_err_size
            return
        end if
        if (.not. (all_finite(q) .and. all_finite(w) .and. all_finite(p))) then
            info = sk_err_nonfinite
            return
        end if
        allocate(rf(3, 3, nj), pf(3, nj))
        do m = 1, size(q, 2)
            call chain_frames(jrot, jpos, jaxis, qidx, trot, tpos, q(:, m), rf, pf, rt, pt)
            rtool(:, :, m) = rt
            pm = 0.0_dp
            pm(1, 1) = 1.0_dp
            pm(2, 2) = 1.0_dp
            pm(3, 3) = 1.0_dp
            pm(:, 4:6) = -skew(matmul(rt, p(:, m)))
            col = 0
            do s = 1, ns
                call spring_jacobian(stype(s), sidx(s), jaxis, rf, pf, rt, pt, jj)
                if (stype(s) == 1) then
                    a(1) = dot_product(jj(:, 1), w(:, m))
                    basis(1:3, m, col + 1) = matmul(pm, jj(:, 1))*a(1)
                    basis(4:6, m, col + 1) = jj(4:6, 1)*a(1)
                    col = col + 1
                else
                    a = matmul(transpose(jj), w(:, m))
                    g(1:3, :) = matmul(pm, jj)
                    g(4:6, :) = jj(4:6, :)
                    do kk = 1, nsym
                        call sym_index(kk, ia, ib)
                        if (ia == ib) then
                            basis(:, m, col + kk) = g(:, ia)*a(ia)
                        else
                            basis(:, m, col + kk) = g(:, ia)*a(ib) + g(:, ib)*a(ia)
                        end if
                    end do
                    col = col + nsym
                end if
            end do
        end do
        info = sk_ok
    end subroutine spring_basis_batch

    !> Jacobians of every spring at one posture q: jac[6, nd], the columns of
    !> spring s (1 for a joint spring, 6 otherwise) one after the other;
    !> rt[3,3], pt[3] the tool frame.
    subroutine spring_jacobians(jrot, jpos, jaxis, qidx, trot, tpos, stype, sidx, q, jac, rt, pt, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3), q(:)
        integer(ip), intent(in) :: qidx(:), stype(:), sidx(:)
        real(dp), intent(out) :: jac(:, :), rt(3, 3), pt(3)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: rf(:, :, :), pf(:, :)
        real(dp) :: jj(6, 6)
        integer :: s, col, n
        jac = 0.0_dp
        call check_chain(jaxis, qidx, size(q, kind=ip), stype, sidx, info)
        if (info /= sk_ok) return
        n = 0
        do s = 1, size(stype)
            n = n + spring_ndof(stype(s))
        end do
        if (size(jac, 1) /= 6 .or. size(jac, 2) /= n) then
            info = sk_err_size
            return
        end if
        if (.not. all_finite(q)) then
            info = sk_err_nonfinite
            return
        end if
        allocate(rf(3, 3, size(qidx)), pf(3, size(qidx)))
        call chain_frames(jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rt, pt)
        col = 0
        do s = 1, size(stype)
            n = spring_ndof(stype(s))
            call spring_jacobian(stype(s), sidx(s), jaxis, rf, pf, rt, pt, jj)
            jac(:, col + 1:col + n) = jj(:, 1:n)
            col = col + n
        end do
        info = sk_ok
    end subroutine spring_jacobians

    !> Poses of the chain at np postures q[ndof,np] (chain_frames, batched):
    !> rf[3,3,nj,np], pf[3,nj,np] every F_k, rt[3,3,np], pt[3,np] the tool
    !> frame (base axes/coordinates). The one forward kinematics of the
    !> core; the springs evaluator takes these poses for a URDF robot.
    subroutine chain_poses_batch(jrot, jpos, jaxis, qidx, trot, tpos, q, rf, pf, rt, pt, info)
        real(dp), intent(in) :: jrot(:, :, :), jpos(:, :), jaxis(:, :), trot(3, 3), tpos(3), q(:, :)
        integer(ip), intent(in) :: qidx(:)
        real(dp), intent(out) :: rf(:, :, :, :), pf(:, :, :), rt(:, :, :), pt(:, :)
        integer(ip), intent(out) :: info
        integer :: ipost
        integer(ip) :: none(0)
        rf = 0.0_dp
        pf = 0.0_dp
        rt = 0.0_dp
        pt = 0.0_dp
        call check_chain(jaxis, qidx, size(q, 1, kind=ip), none, none, info)
        if (info /= sk_ok) return
        if (.not. all_finite(q)) then
            info = sk_err_nonfinite
            return
        end if
        do ipost = 1, size(q, 2)
            call chain_frames(jrot, jpos, jaxis, qidx, trot, tpos, q(:, ipost), rf(:, :, :, ipost), &
                pf(:, :, ipost), rt(:, :, ipost), pt(:, ipost))
        end do
        info = sk_ok
    end subroutine chain_poses_batch

end module sk_chain
