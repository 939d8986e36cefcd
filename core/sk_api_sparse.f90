!> Entry points of the sparse route that f2py wraps (bindings/_sparse.pyf):
!> CalculiX matrix/dof files, one CHOLMOD factorisation for several load
!> cases, and the distributing coupling of a reference point to a face.
!> Plain external subroutines, explicit shapes, iso_c_binding kinds and an
!> integer `info` (sk_errors; 31 = file missing/unreadable/malformed,
!> 32 = out of memory).

!> Entries nnz and largest equation number neq of a .sti/.mas file.
subroutine sk_triplet_count(path, nnz, neq, info)
    use, intrinsic :: iso_c_binding, only: c_int
    use sk_sparse, only: triplet_count
    implicit none
    character(len=*), intent(in) :: path
    integer(c_int), intent(out) :: nnz, neq, info
    call triplet_count(path, nnz, neq, info)
end subroutine sk_triplet_count

!> The nnz triplets (1-based row <= col, value) of a .sti/.mas file.
subroutine sk_triplet_read(path, nnz, rows, cols, vals, info)
    use, intrinsic :: iso_c_binding, only: c_int, c_double
    use sk_sparse, only: triplet_read
    implicit none
    character(len=*), intent(in) :: path
    integer(c_int), intent(in) :: nnz
    integer(c_int), intent(out) :: rows(nnz), cols(nnz), info
    real(c_double), intent(out) :: vals(nnz)
    call triplet_read(path, rows, cols, vals, info)
end subroutine sk_triplet_read

!> Number of equations in a .dof file.
subroutine sk_dof_count(path, neq, info)
    use, intrinsic :: iso_c_binding, only: c_int
    use sk_sparse, only: dof_count
    implicit none
    character(len=*), intent(in) :: path
    integer(c_int), intent(out) :: neq, info
    call dof_count(path, neq, info)
end subroutine sk_dof_count

!> node(i), direction(i) of every equation i of a .dof file.
subroutine sk_dof_read(path, neq, node, dir, info)
    use, intrinsic :: iso_c_binding, only: c_int
    use sk_sparse, only: dof_read
    implicit none
    character(len=*), intent(in) :: path
    integer(c_int), intent(in) :: neq
    integer(c_int), intent(out) :: node(neq), dir(neq), info
    call dof_read(path, node, dir, info)
end subroutine sk_dof_read

!> x[n,nrhs] = K^-1 b with one CHOLMOD factorisation of K given by nnz
!> upper-triangle triplets; times = [ordering, factorisation, solves] s,
!> lnz = nonzeros of the Cholesky factor.
subroutine sk_sparse_solve(n, nnz, nrhs, rows, cols, vals, b, x, times, lnz, info)
    use, intrinsic :: iso_c_binding, only: c_int, c_double
    use sk_sparse, only: cholmod_solve
    implicit none
    integer(c_int), intent(in) :: n, nnz, nrhs
    integer(c_int), intent(in) :: rows(nnz), cols(nnz)
    real(c_double), intent(in) :: vals(nnz), b(n, nrhs)
    real(c_double), intent(out) :: x(n, nrhs), times(3), lnz
    integer(c_int), intent(out) :: info
    call cholmod_solve(n, rows, cols, vals, b, x, times, lnz, info)
end subroutine sk_sparse_solve

!> Nodal weights w[nn] of faces conn[npf,nf] (npf 3 or 6) over nodes x[3,nn]
!> (integrals of the face shape functions), and the total area.
subroutine sk_face_weights(nn, npf, nf, x, conn, w, area, info)
    use, intrinsic :: iso_c_binding, only: c_int, c_double
    use sk_coupling, only: face_weights
    implicit none
    integer(c_int), intent(in) :: nn, npf, nf
    real(c_double), intent(in) :: x(3, nn)
    integer(c_int), intent(in) :: conn(npf, nf)
    real(c_double), intent(out) :: w(nn), area
    integer(c_int), intent(out) :: info
    call face_weights(x, conn, w, area, info)
end subroutine sk_face_weights

!> Nodal forces g[3,nf,6] of the six unit wrenches at p0 spread over the
!> nodes xf[3,nf] with weights w[nf] (CalculiX *DISTRIBUTING).
subroutine sk_distributing_loads(nf, xf, w, p0, g, info)
    use, intrinsic :: iso_c_binding, only: c_int, c_double
    use sk_coupling, only: distributing_loads
    implicit none
    integer(c_int), intent(in) :: nf
    real(c_double), intent(in) :: xf(3, nf), w(nf), p0(3)
    real(c_double), intent(out) :: g(3, nf, 6)
    integer(c_int), intent(out) :: info
    call distributing_loads(xf, w, p0, g, info)
end subroutine sk_distributing_loads

!> Work-conjugate reference motion xref[6,m] = G^T u of the fields u[3,nf,m].
subroutine sk_work_conjugate(nf, m, g, u, xref, info)
    use, intrinsic :: iso_c_binding, only: c_int, c_double
    use sk_coupling, only: work_conjugate
    implicit none
    integer(c_int), intent(in) :: nf, m
    real(c_double), intent(in) :: g(3, nf, 6), u(3, nf, m)
    real(c_double), intent(out) :: xref(6, m)
    integer(c_int), intent(out) :: info
    call work_conjugate(g, u, xref, info)
end subroutine sk_work_conjugate

!> Rigid coupling on the assembled K: reference-point compliance q[6,6] and
!> displacements u[n,6] of the six unit wrenches, plus the nodal loads b[n,6]
!> of each case (see sk_sparse rigid_solve).
subroutine sk_rigid_solve(n, nnz, nc, rows, cols, vals, ceq, r, b, u, q, times, lnz, info)
    use, intrinsic :: iso_c_binding, only: c_int, c_double
    use sk_sparse, only: rigid_solve
    implicit none
    integer(c_int), intent(in) :: n, nnz, nc
    integer(c_int), intent(in) :: rows(nnz), cols(nnz), ceq(3, nc)
    real(c_double), intent(in) :: vals(nnz), r(3, nc), b(n, 6)
    real(c_double), intent(out) :: u(n, 6), q(6, 6), times(3), lnz
    integer(c_int), intent(out) :: info
    call rigid_solve(n, rows, cols, vals, ceq, r, b, u, q, times, lnz, info)
end subroutine sk_rigid_solve
