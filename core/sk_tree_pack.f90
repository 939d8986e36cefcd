!> The packed tree model: the whole model description of sk_tree's module
!> header (virtual joints, geometric entries, law blocks, bodies, tracker,
!> markers, gravity-parameter entries) in one integer array mi and one
!> real array mr, so that an entry point of sk_api_tree takes the model as
!> two arguments plus its own (bindings/tree.py `pack` builds them).
!>
!> mi = [header, integer segments], mr = [real segments]. Header (slots
!> h_*): the layout version pack_version, the counts nv, nk, ne, nb, ng,
!> nm, nbp, then the offsets: mi(h_ioff + s - 1) = first index in mi of
!> integer segment s (s = 1..n_iseg, in the order of the pi_* codes) and
!> mi(h_ioff + n_iseg) = size(mi) + 1; mi(h_roff + s - 1) = first index in
!> mr of real segment s (pr_* order) and mi(h_roff + n_rseg) = size(mr) + 1.
!> A segment is the array in Fortran (column-major) order:
!>   integer: vparent[nv], vtype[nv], qcol[nv], gvj[ng], gpar[ng],
!>            ktype[nk], kvj[6,nk], kpar[21,nk], bvj[nb], tpar[6], mvj[nm],
!>            mpar[3,nm], bpar[3,nbp]
!>   real:    vaxis[3,nv], vrot[3,3,nv], vpos[3,nv], qcoef[nv], qconst[nv],
!>            gcoef[ng], kw0[nk], bmass[nb], bcom[3,nb], grav[3], rref[3,3]
!> ndof and npar are not the model's: they are the sizes of each call's q
!> and theta, as before packing. tests/test_tree_pack.py checks that the
!> Python layout is this one.
module sk_tree_pack
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_spatial, only: nsym
    use sk_tree_check
    use sk_tree_model, only: tree_model, model_setup, model_body_params
    implicit none
    private
    public :: model_unpack, unpack_with_inputs

    !> layout version (mi(h_version)); header slots
    integer, parameter, public :: pack_version = 1
    integer, parameter, public :: h_version = 1, h_nv = 2, h_nk = 3, h_ne = 4, h_nb = 5, h_ng = 6, h_nm = 7, &
        h_nbp = 8, h_ioff = 9
    !> integer segments
    integer, parameter, public :: pi_vparent = 1, pi_vtype = 2, pi_qcol = 3, pi_gvj = 4, pi_gpar = 5, &
        pi_ktype = 6, pi_kvj = 7, pi_kpar = 8, pi_bvj = 9, pi_tpar = 10, pi_mvj = 11, pi_mpar = 12, &
        pi_bpar = 13, n_iseg = 13
    !> real segments
    integer, parameter, public :: pr_vaxis = 1, pr_vrot = 2, pr_vpos = 3, pr_qcoef = 4, pr_qconst = 5, &
        pr_gcoef = 6, pr_kw0 = 7, pr_bmass = 8, pr_bcom = 9, pr_grav = 10, pr_rref = 11, n_rseg = 11
    integer, parameter, public :: h_roff = h_ioff + n_iseg + 1, pack_header = h_roff + n_rseg

contains

    !> The model m of the packed arrays mi, mr (module header) for a call
    !> with ndof joint coordinates and npar parameters: the layout is
    !> checked (info = sk_err_size; errloc = [the segment's argument code,
    !> 0] when one segment has the wrong length, [0, 0] for the header),
    !> then the model is set up and checked as by model_setup (errloc names
    !> the argument and the index) and its gravity-parameter entries set
    !> (model_body_params). nv, ne: the sizes the caller dimensioned its
    !> outputs with (sk_err_size unless they are the header's).
    subroutine model_unpack(mi, mr, nv, ne, ndof, npar, m, info, errloc)
        integer(ip), intent(in) :: mi(:), nv, ne, ndof, npar
        real(dp), intent(in) :: mr(:)
        type(tree_model), intent(out) :: m
        integer(ip), intent(out) :: info, errloc(2)
        integer :: nk, nb, ng, nm, nbp
        integer :: io(n_iseg + 1), ro(n_rseg + 1), ilen(n_iseg), rlen(n_rseg)
        integer(ip), parameter :: iarg(n_iseg) = [arg_vparent, arg_vtype, arg_qcol, arg_gvj, arg_gpar, &
            arg_ktype, arg_kvj, arg_kpar, arg_bvj, arg_tpar, arg_mvj, arg_mpar, 0_ip]
        integer(ip), parameter :: rarg(n_rseg) = [arg_vaxis, arg_vrot, arg_vpos, arg_qcoef, arg_qconst, &
            arg_gcoef, arg_kw0, arg_bmass, arg_bcom, arg_grav, arg_rref]
        integer :: s
        info = sk_err_size
        errloc = 0
        if (size(mi) < pack_header) return
        if (mi(h_version) /= pack_version) return
        if (mi(h_nv) /= nv .or. mi(h_ne) /= ne) return
        nk = mi(h_nk)
        nb = mi(h_nb)
        ng = mi(h_ng)
        nm = mi(h_nm)
        nbp = mi(h_nbp)
        if (min(nv, nk, ne, nb, ng, nm, nbp) < 0) return
        io = mi(h_ioff:h_ioff + n_iseg)
        ro = mi(h_roff:h_roff + n_rseg)
        if (io(1) /= pack_header + 1 .or. io(n_iseg + 1) /= size(mi) + 1 .or. ro(1) /= 1 &
            .or. ro(n_rseg + 1) /= size(mr) + 1) return
        if (any(io(2:) < io(:n_iseg)) .or. any(ro(2:) < ro(:n_rseg))) return
        ilen = [nv, nv, nv, ng, ng, nk, 6*nk, nsym*nk, nb, 6, nm, 3*nm, 3*nbp]
        rlen = [3*nv, 9*nv, 3*nv, nv, nv, ng, nk, nb, 3*nb, 3, 9]
        do s = 1, n_iseg
            if (io(s + 1) - io(s) /= ilen(s)) then
                errloc = [iarg(s), 0_ip]
                return
            end if
        end do
        do s = 1, n_rseg
            if (ro(s + 1) - ro(s) /= rlen(s)) then
                errloc = [rarg(s), 0_ip]
                return
            end if
        end do
        call model_setup(m, iseg(pi_vparent), iseg(pi_vtype), reshape(rseg(pr_vaxis), [3, nv]), &
            reshape(rseg(pr_vrot), [3, 3, nv]), reshape(rseg(pr_vpos), [3, nv]), iseg(pi_qcol), rseg(pr_qcoef), &
            rseg(pr_qconst), iseg(pi_gvj), iseg(pi_gpar), rseg(pr_gcoef), iseg(pi_ktype), &
            reshape(iseg(pi_kvj), [6, nk]), reshape(iseg(pi_kpar), [nsym, nk]), rseg(pr_kw0), iseg(pi_bvj), &
            rseg(pr_bmass), reshape(rseg(pr_bcom), [3, nb]), rseg(pr_grav), iseg(pi_tpar), &
            reshape(rseg(pr_rref), [3, 3]), iseg(pi_mvj), reshape(iseg(pi_mpar), [3, nm]), ndof, npar, &
            ne, info, errloc)
        if (info /= sk_ok) return
        call model_body_params(m, reshape(iseg(pi_bpar), [3, nbp]), info)

    contains

        pure function iseg(k) result(a)
            integer, intent(in) :: k
            integer(ip) :: a(io(k + 1) - io(k))
            a = mi(io(k):io(k + 1) - 1)
        end function iseg

        pure function rseg(k) result(a)
            integer, intent(in) :: k
            real(dp) :: a(ro(k + 1) - ro(k))
            a = mr(ro(k):ro(k + 1) - 1)
        end function rseg

    end subroutine model_unpack

    !> The model (model_unpack) and the arguments every entry point takes
    !> with it, checked (sk_tree_check%inputs_check): theta[npar],
    !> postures q[ndof,np] (ndof, npar: their sizes), payloads lpost[nl]
    !> (postures or rows), lvj[nl], lw[6,nl], and etol.
    subroutine unpack_with_inputs(mi, mr, nv, ne, theta, q, lpost, lvj, lw, etol, m, info, errloc)
        integer(ip), intent(in) :: mi(:), nv, ne, lpost(:), lvj(:)
        real(dp), intent(in) :: mr(:), theta(:), q(:, :), lw(:, :), etol
        type(tree_model), intent(out) :: m
        integer(ip), intent(out) :: info, errloc(2)
        call model_unpack(mi, mr, nv, ne, int(size(q, 1), ip), int(size(theta), ip), m, info, errloc)
        if (info /= sk_ok) return
        call inputs_check(m%nv, m%ndof, m%npar, theta, q, lpost, lvj, lw, etol, info, errloc)
    end subroutine unpack_with_inputs

end module sk_tree_pack
