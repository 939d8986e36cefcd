!> Unit tests of sk_sparse (CalculiX matrix files, CHOLMOD) and
!> sk_coupling (distributing coupling) on small known systems.
program test_sparse
    use sk_testing, only: expect, finish
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: cross
    use sk_sparse
    use sk_coupling
    implicit none (type, external)

    !> scratch files live in $TMPDIR (default /tmp), never in the working directory
    character(len=:), allocatable :: scratch

    call init_scratch()
    call test_triplets_and_solve()
    call test_bad_files()
    call test_face_weights()
    call test_distributing()
    call finish('sparse core')

contains

    !> scratch = "$TMPDIR/sk_test_sparse_<random>_": unique per run, so
    !> concurrent runs and the source tree are never touched.
    subroutine init_scratch()
        character(len=4096) :: dir
        integer :: n, stat
        real(dp) :: r
        call get_environment_variable('TMPDIR', dir, n, stat)
        if (stat /= 0 .or. n == 0) dir = '/tmp'
        call random_seed()
        call random_number(r)
        allocate (character(len=len_trim(dir) + 40) :: scratch)
        write (scratch, '(a, a, i0, a)') trim(dir), '/sk_test_sparse_', int(r*1.0e9_dp), '_'
        scratch = trim(scratch)
    end subroutine init_scratch

    !> Delete a scratch file written by a test.
    subroutine remove(path)
        character(len=*), intent(in) :: path
        integer :: u, ios
        open (newunit=u, file=path, status='old', iostat=ios)
        if (ios == 0) close (u, status='delete')
    end subroutine remove

    !> K = tridiag(-1, 4, -1) of order 5 written as CalculiX writes .sti
    !> (upper triangle, 1-based, blank line in between); two right-hand sides.
    subroutine test_triplets_and_solve()
        integer, parameter :: n = 5
        integer :: u, i, j
        integer(ip) :: nnz, neq, info, rows(9), cols(9), node(3), dir(3)
        real(dp) :: vals(9), b(n, 2), x(n, 2), times(3), lnz, k(n, n)
        open(newunit=u, file=scratch//'sparse.sti', status='replace', action='write')
        do i = 1, n
            write(u, '(i0, 1x, i0, 1x, es22.14)') i, i, 4.0_dp
            if (i < n) write(u, '(i0, 1x, i0, 1x, es22.14)') i, i + 1, -1.0_dp
            if (i == 2) write(u, '(a)') ''
        end do
        close(u)
        call triplet_count(scratch//'sparse.sti', nnz, neq, info)
        call expect(info == sk_ok .and. nnz == 9 .and. neq == n, 'count triplets')
        call triplet_read(scratch//'sparse.sti', rows, cols, vals, info)
        call expect(info == sk_ok .and. all(rows <= cols) .and. abs(sum(vals) - 16.0_dp) < 1e-12_dp, 'read triplets')
        k = 0.0_dp
        do j = 1, 9
            k(rows(j), cols(j)) = vals(j)
            k(cols(j), rows(j)) = vals(j)
        end do
        b(:, 1) = [1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp]
        b(:, 2) = [1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, -1.0_dp]
        call cholmod_solve(n, rows, cols, vals, b, x, times, lnz, info)
        call expect(info == sk_ok, 'cholmod solve ok')
        call expect(maxval(abs(matmul(k, x) - b)) < 100*epsilon(1.0_dp), 'K x = b for both columns')
        call expect(lnz >= 9.0_dp, 'factor nonzeros reported')
        ! an indefinite matrix is reported as singular
        vals(1) = -4.0_dp
        call cholmod_solve(n, rows, cols, vals, b, x, times, lnz, info)
        if (info /= sk_err_singular) print *, 'indefinite: info', info
        call expect(info == sk_err_singular, 'not positive definite -> sk_err_singular')
        ! .dof
        open(newunit=u, file=scratch//'sparse.dof', status='replace', action='write')
        write(u, '(a)') '5.1', '5.2', '12.3'
        close(u)
        call dof_count(scratch//'sparse.dof', neq, info)
        call expect(info == sk_ok .and. neq == 3, 'count dofs')
        call dof_read(scratch//'sparse.dof', node, dir, info)
        call expect(info == sk_ok .and. all(node == [5, 5, 12]) .and. all(dir == [1, 2, 3]), 'read dofs')
        call remove(scratch//'sparse.sti')
        call remove(scratch//'sparse.dof')
    end subroutine test_triplets_and_solve

    subroutine test_bad_files()
        integer :: u
        integer(ip) :: nnz, neq, info
        call triplet_count('no_such_file.sti', nnz, neq, info)
        call expect(info == sk_err_io, 'missing file -> sk_err_io')
        open(newunit=u, file=scratch//'bad.sti', status='replace', action='write')
        write(u, '(a)') '1 1 4.0', '1 x 2.0'
        close(u)
        call triplet_count(scratch//'bad.sti', nnz, neq, info)
        call expect(info == sk_err_io, 'malformed line -> sk_err_io')
        open(newunit=u, file=scratch//'bad.dof', status='replace', action='write')
        write(u, '(a)') '5.1', '5.9'
        close(u)
        call dof_count(scratch//'bad.dof', neq, info)
        call expect(info == sk_err_io, 'direction 9 -> sk_err_io')
        call remove(scratch//'bad.sti')
        call remove(scratch//'bad.dof')
    end subroutine test_bad_files

    !> Unit square at x = 1 split into two quadratic triangles: total area 1,
    !> corners weight 0, each mid-side node A/3 per face it belongs to.
    subroutine test_face_weights()
        real(dp) :: x(3, 9), w(9), area
        integer(ip) :: conn(6, 2), conn3(3, 2), info
        ! corners 1..4, mids: 5 (1-2), 6 (2-3), 7 (3-1 diagonal), 8 (3-4), 9 (4-1)
        x(:, 1) = [1.0_dp, 0.0_dp, 0.0_dp]
        x(:, 2) = [1.0_dp, 1.0_dp, 0.0_dp]
        x(:, 3) = [1.0_dp, 1.0_dp, 1.0_dp]
        x(:, 4) = [1.0_dp, 0.0_dp, 1.0_dp]
        x(:, 5) = 0.5_dp*(x(:, 1) + x(:, 2))
        x(:, 6) = 0.5_dp*(x(:, 2) + x(:, 3))
        x(:, 7) = 0.5_dp*(x(:, 3) + x(:, 1))
        x(:, 8) = 0.5_dp*(x(:, 3) + x(:, 4))
        x(:, 9) = 0.5_dp*(x(:, 4) + x(:, 1))
        conn(:, 1) = [1, 2, 3, 5, 6, 7]
        conn(:, 2) = [1, 3, 4, 7, 8, 9]
        call face_weights(x, conn, w, area, info)
        if (info /= sk_ok .or. abs(area - 1.0_dp) > 1e-14_dp) print *, 'T6 info, area, w:', info, area, w
        call expect(info == sk_ok .and. abs(area - 1.0_dp) < 1e-14_dp, 'T6 area')
        call expect(all(w(1:4) == 0.0_dp), 'T6 corner weights exactly 0')
        call expect(abs(w(7) - 1.0_dp/3) < 1e-14_dp .and. abs(w(5) - 1.0_dp/6) < 1e-14_dp, 'T6 mid-side weights A/3')
        conn3(:, 1) = [1, 2, 3]
        conn3(:, 2) = [1, 3, 4]
        call face_weights(x, conn3, w, area, info)
        call expect(abs(w(1) - 1.0_dp/3) < 1e-14_dp .and. abs(w(2) - 1.0_dp/6) < 1e-14_dp, 'T3 weights A/3')
    end subroutine test_face_weights

    !> Forces of every unit wrench sum to it, with its moment about p0;
    !> collinear nodes cannot take a moment.
    subroutine test_distributing()
        real(dp) :: xf(3, 5), w(5), p0(3), g(3, 5, 6), wr(6), res(6), xref(6, 6), u(3, 5, 6)
        integer(ip) :: info
        integer :: i, j
        xf(:, 1) = [1.0_dp, 0.0_dp, 0.0_dp]
        xf(:, 2) = [1.0_dp, 0.3_dp, 0.0_dp]
        xf(:, 3) = [1.0_dp, 0.0_dp, 0.5_dp]
        xf(:, 4) = [1.0_dp, -0.2_dp, -0.1_dp]
        xf(:, 5) = [1.0_dp, 0.4_dp, 0.6_dp]
        w = [1.0_dp, 2.0_dp, 0.5_dp, 1.5_dp, 1.0_dp]
        p0 = [1.2_dp, 0.1_dp, -0.3_dp]
        call distributing_loads(xf, w, p0, g, info)
        call expect(info == sk_ok, 'distributing ok')
        do j = 1, 6
            wr = 0.0_dp
            wr(j) = 1.0_dp
            res = 0.0_dp
            do i = 1, 5
                res(1:3) = res(1:3) + g(:, i, j)
                res(4:6) = res(4:6) + cross(xf(:, i) - p0, g(:, i, j))
            end do
            call expect(maxval(abs(res - wr)) < 1e-12_dp, 'resultant equals the unit wrench')
        end do
        ! work conjugate of a rigid motion (t, phi) about p0 returns it
        do j = 1, 6
            do i = 1, 5
                u(:, i, j) = real(j, dp)*[1.0e-3_dp, -2.0e-3_dp, 0.5e-3_dp] &
                    + cross(real(j, dp)*[1.0e-4_dp, 3.0e-4_dp, -2.0e-4_dp], xf(:, i) - p0)
            end do
        end do
        call work_conjugate(g, u, xref, info)
        call expect(info == sk_ok .and. maxval(abs(xref(:, 2) - 2*[1.0e-3_dp, -2.0e-3_dp, 0.5e-3_dp, &
            1.0e-4_dp, 3.0e-4_dp, -2.0e-4_dp])) < 1e-15_dp, 'work-conjugate motion of a rigid field')
        xf(2:3, :) = 0.0_dp
        xf(1, :) = [1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp]
        call distributing_loads(xf, w, p0, g, info)
        call expect(info == sk_err_degenerate, 'collinear nodes -> sk_err_degenerate')
    end subroutine test_distributing

end program test_sparse
