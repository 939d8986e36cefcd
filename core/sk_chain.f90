!> Serial chains: their description and its check, and the forward
!> kinematics of the joint frames (sk_tree's). Everything elastic (the
!> springs' Jacobians, the tool compliance, the deflection model) runs on
!> the tree model of the chain (sk_chain_tree): a chain is a tree.
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
    use sk_linalg, only: eye, all_finite
    use sk_tree, only: tree_frames, frame_step, vj_fixed, vj_revolute
    implicit none
    private
    public :: chain_frames, spring_ndof, check_chain, chain_poses_batch
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
