!> Sparse route of the FEA pipeline: CalculiX matrix files and
!> one CHOLMOD factorisation for several load cases.
!>
!> The C functions live in sk_ccxread.c (the matrix and .dof readers) and
!> sk_cholmod.c (the factorisation); this module holds their bind(C)
!> interfaces (f2py never reads it) and Fortran front ends that turn
!> Fortran strings into C strings and C status codes into sk_errors codes.
module sk_sparse
    use, intrinsic :: iso_c_binding, only: c_char, c_int, c_long, c_double, c_null_char
    use sk_kinds, only: dp, ip
    use sk_errors
    implicit none
    private
    public :: triplet_count, triplet_read, dof_count, dof_read, cholmod_solve, rigid_solve

    interface
        integer(c_int) function c_triplet_count(path, nnz, neq) bind(C, name='sk_c_triplet_count')
            import :: c_char, c_int, c_long
            character(kind=c_char), intent(in) :: path(*)
            integer(c_long), intent(out) :: nnz
            integer(c_int), intent(out) :: neq
        end function c_triplet_count
        integer(c_int) function c_triplet_read(path, nnz, rows, cols, vals) bind(C, name='sk_c_triplet_read')
            import :: c_char, c_int, c_long, c_double
            character(kind=c_char), intent(in) :: path(*)
            integer(c_long), value :: nnz
            integer(c_int), intent(out) :: rows(*), cols(*)
            real(c_double), intent(out) :: vals(*)
        end function c_triplet_read
        integer(c_int) function c_dof_count(path, neq) bind(C, name='sk_c_dof_count')
            import :: c_char, c_int
            character(kind=c_char), intent(in) :: path(*)
            integer(c_int), intent(out) :: neq
        end function c_dof_count
        integer(c_int) function c_dof_read(path, neq, node, dir) bind(C, name='sk_c_dof_read')
            import :: c_char, c_int
            character(kind=c_char), intent(in) :: path(*)
            integer(c_int), value :: neq
            integer(c_int), intent(out) :: node(*), dir(*)
        end function c_dof_read
        integer(c_int) function c_cholmod_solve(n, nnz, rows, cols, vals, nrhs, b, x, times, stats) &
                bind(C, name='sk_c_cholmod_solve')
            import :: c_int, c_long, c_double
            integer(c_int), value :: n, nrhs
            integer(c_long), value :: nnz
            integer(c_int), intent(in) :: rows(*), cols(*)
            real(c_double), intent(in) :: vals(*), b(*)
            real(c_double), intent(out) :: x(*), times(3), stats(1)
        end function c_cholmod_solve
        integer(c_int) function c_cholmod_rigid(n, nnz, rows, cols, vals, nc, ceq, r, b, u, q, times, stats) &
                bind(C, name='sk_c_cholmod_rigid')
            import :: c_int, c_long, c_double
            integer(c_int), value :: n, nc
            integer(c_long), value :: nnz
            integer(c_int), intent(in) :: rows(*), cols(*), ceq(*)
            real(c_double), intent(in) :: vals(*), r(*), b(*)
            real(c_double), intent(out) :: u(*), q(6, 6), times(3), stats(1)
        end function c_cholmod_rigid
    end interface

contains

    pure function cstr(s) result(c)
        character(*), intent(in) :: s
        character(len=len_trim(s) + 1, kind=c_char) :: c
        c = trim(s)//c_null_char
    end function cstr

    !> Entries nnz and largest equation number neq of a .sti/.mas file.
    subroutine triplet_count(path, nnz, neq, info)
        character(*), intent(in) :: path
        integer(ip), intent(out) :: nnz, neq, info
        integer(c_long) :: n8
        info = c_triplet_count(cstr(path), n8, neq)
        if (n8 > huge(nnz)) then
            info = sk_err_size
            nnz = 0
        else
            nnz = int(n8, ip)
        end if
    end subroutine triplet_count

    !> Read the nnz triplets (1-based row <= col, value) of a .sti/.mas file.
    subroutine triplet_read(path, rows, cols, vals, info)
        character(*), intent(in) :: path
        integer(ip), intent(out) :: rows(:), cols(:)
        real(dp), intent(out) :: vals(:)
        integer(ip), intent(out) :: info
        if (size(cols) /= size(rows) .or. size(vals) /= size(rows)) then
            info = sk_err_size
            return
        end if
        info = c_triplet_read(cstr(path), int(size(rows), c_long), rows, cols, vals)
    end subroutine triplet_read

    !> Number of equations listed in a .dof file.
    subroutine dof_count(path, neq, info)
        character(*), intent(in) :: path
        integer(ip), intent(out) :: neq, info
        info = c_dof_count(cstr(path), neq)
    end subroutine dof_count

    !> node(i), dir(i) of equation i from a .dof file ("node.direction").
    subroutine dof_read(path, node, dir, info)
        character(*), intent(in) :: path
        integer(ip), intent(out) :: node(:), dir(:)
        integer(ip), intent(out) :: info
        if (size(dir) /= size(node)) then
            info = sk_err_size
            return
        end if
        info = c_dof_read(cstr(path), int(size(node), c_int), node, dir)
    end subroutine dof_read

    !> Solve K x = b for every column of b[n,nrhs] with one CHOLMOD
    !> factorisation of K (upper-triangle triplets, 1-based). times: ordering,
    !> factorisation, solves (s); lnz: nonzeros of the factor.
    subroutine cholmod_solve(n, rows, cols, vals, b, x, times, lnz, info)
        integer(ip), intent(in) :: n, rows(:), cols(:)
        real(dp), intent(in) :: vals(:), b(:, :)
        real(dp), intent(out) :: x(:, :), times(3), lnz
        integer(ip), intent(out) :: info
        real(dp) :: stats(1)
        x = 0.0_dp
        times = 0.0_dp
        lnz = 0.0_dp
        if (size(cols) /= size(rows) .or. size(vals) /= size(rows) .or. size(b, 1) /= n &
            .or. any(shape(x) /= shape(b))) then
            info = sk_err_size
            return
        end if
        if (any(vals /= vals) .or. any(b /= b)) then
            info = sk_err_nonfinite
            return
        end if
        stats = 0.0_dp
        info = c_cholmod_solve(n, int(size(rows), c_long), rows, cols, vals, &
                               int(size(b, 2), c_int), b, x, times, stats)
        lnz = stats(1)
    end subroutine cholmod_solve

    !> Rigid coupling of nc nodes to a reference point on the assembled K
    !> (upper-triangle triplets, n equations): the coupled nodes move as
    !> u_i = t + phi x r_i; ceq[3,nc] their 1-based equations (0: none),
    !> r[3,nc] their offsets from the reference point. Returns the motion q
    !> of the reference point under the six unit wrenches (its compliance)
    !> and the displacements u[n,6] of every equation. b[n,6]: further nodal
    !> loads of each case (equation space; zero for none), e.g. the
    !> reaction of a distributing support.
    subroutine rigid_solve(n, rows, cols, vals, ceq, r, b, u, q, times, lnz, info)
        integer(ip), intent(in) :: n, rows(:), cols(:), ceq(:, :)
        real(dp), intent(in) :: vals(:), r(:, :), b(:, :)
        real(dp), intent(out) :: u(:, :), q(6, 6), times(3), lnz
        integer(ip), intent(out) :: info
        real(dp) :: stats(1)
        u = 0.0_dp
        q = 0.0_dp
        times = 0.0_dp
        lnz = 0.0_dp
        if (size(cols) /= size(rows) .or. size(vals) /= size(rows) .or. size(ceq, 1) /= 3 &
            .or. any(shape(r) /= shape(ceq)) .or. size(u, 1) /= n .or. size(u, 2) /= 6 &
            .or. size(b, 1) /= n .or. size(b, 2) /= 6) then
            info = sk_err_size
            return
        end if
        if (size(ceq, 2) < 3) then
            info = sk_err_too_few
            return
        end if
        if (any(vals /= vals) .or. any(r /= r) .or. any(b /= b)) then
            info = sk_err_nonfinite
            return
        end if
        stats = 0.0_dp
        info = c_cholmod_rigid(n, int(size(rows), c_long), rows, cols, vals, int(size(ceq, 2), c_int), &
                               ceq, r, b, u, q, times, stats)
        lnz = stats(1)
    end subroutine rigid_solve

end module sk_sparse
