!> T-optimal design (discrimination between rival models): choose k of
!> ncand candidate blocks of nobs rows so that, with the existing n0 rows,
!> the smallest noncentrality
!>   T(S) = min over ordered pairs a /= b of || (I - P_b) (f_a - f_b) ||^2
!> over the rows R = {1..n0} U rows(S) is largest. f[nrow,nh] holds the
!> whitened predictions of the nh hypotheses (each fitted to the data so far)
!> at all rows, jall[nrow,ptot] their whitened Jacobians side by side
!> (hypothesis h owns the columns hoff(h)+1 .. hoff(h+1)); P_b is the
!> projector on the columns of hypothesis b restricted to R.
!>
!> Search (greedy, then exchange passes as in sk_design): the state of a row
!> set keeps, per hypothesis b, G_b = J_b^T J_b over R (column-scaled by the
!> norms over all rows; plus a tiny ridge while G_b is singular) and its
!> inverse, and per pair g_ab = J_b^T d_ab, e_ab = d_ab^T d_ab
!> (d_ab = f_a - f_b); the noncentrality after adding candidate c follows
!> from the Woodbury identity on the nobs x nobs block
!> K = I + J_c G^-1 J_c^T (no refit):
!>   ncp' = e + d_c.d_c - [g^T h + 2 d_c.y + d_c^T B d_c - z^T K^-1 z],
!> h = G^-1 g, y = J_c h, B = J_c G^-1 J_c^T, z = y + B d_c. The state itself
!> is rebuilt from its rows after each change (exact, no drift). The value
!> and the pair matrix returned are evaluated directly: the residual of d_ab
!> after projection on the column space of J_b over R (thin SVD; singular
!> values with s^2 <= design_singular are a rank deficiency).
module sk_design_disc
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: all_finite, svd
    use sk_design_base, only: chol_small, chol_checked, dpotri, fail, design_singular, design_ridge, design_improve, &
        darg_f, darg_jh, darg_k, darg_n0, darg_nobs, darg_max_passes
    implicit none
    private
    public :: disc_select, disc_pairs, disc_check, disc_evaluate, rows_of, tmin, unit_columns

    !> Per hypothesis: the inverse of its (ridged) scaled G over the rows.
    type hyp_state
        real(dp), allocatable :: gi(:, :)
    end type hyp_state

contains

    !> Argument checks: f finite (index: row), jall finite (index: row),
    !> hoff increasing from 0 to ptot with p_h >= 1 (index: hypothesis, as
    !> jh), nh >= 2, 0 <= n0 <= nrow, nobs >= 1 dividing nrow - n0 into
    !> ncand >= 1 blocks, 1 <= k <= ncand, max_passes >= 0.
    subroutine disc_check(f, jall, hoff, n0, nobs, k, max_passes, info, loc)
        real(dp), intent(in) :: f(:, :), jall(:, :)
        integer(ip), intent(in) :: hoff(:), n0, nobs, k, max_passes
        integer(ip), intent(out) :: info, loc(2)
        integer :: i, nrow, nh
        info = sk_ok
        loc = 0
        nrow = size(f, 1)
        nh = size(f, 2)
        if (nh < 2) then
            call fail(sk_err_size, darg_f, 0, info, loc)
            return
        end if
        do i = 1, nrow
            if (.not. all_finite(f(i, :))) then
                call fail(sk_err_nonfinite, darg_f, i, info, loc)
                return
            end if
        end do
        if (size(hoff) /= nh + 1 .or. size(jall, 1) /= nrow) then
            call fail(sk_err_size, darg_jh, 0, info, loc)
            return
        end if
        if (hoff(1) /= 0 .or. hoff(nh + 1) /= size(jall, 2)) call fail(sk_err_size, darg_jh, 0, info, loc)
        do i = 1, nh
            if (hoff(i + 1) <= hoff(i)) call fail(sk_err_size, darg_jh, i, info, loc)
        end do
        if (info /= sk_ok) return
        do i = 1, nrow
            if (.not. all_finite(jall(i, :))) then
                call fail(sk_err_nonfinite, darg_jh, i, info, loc)
                return
            end if
        end do
        if (n0 < 0 .or. n0 > nrow) call fail(sk_err_argument, darg_n0, 0, info, loc)
        if (info /= sk_ok) return
        if (nobs < 1) then
            call fail(sk_err_argument, darg_nobs, 0, info, loc)
        else if (mod(nrow - n0, nobs) /= 0 .or. nrow - n0 < nobs) then
            call fail(sk_err_size, darg_nobs, 0, info, loc)
        else if (k < 1 .or. k > (nrow - n0) / nobs) then
            call fail(sk_err_argument, darg_k, 0, info, loc)
        end if
        if (max_passes < 0) call fail(sk_err_argument, darg_max_passes, 0, info, loc)
    end subroutine disc_check

    !> Row indices of R: 1..n0 and the rows of the candidates in sel.
    pure function rows_of(n0, nobs, sel) result(rows)
        integer(ip), intent(in) :: n0, nobs, sel(:)
        integer, allocatable :: rows(:)
        integer :: i, j
        allocate(rows(n0 + nobs * size(sel)))
        rows(1:n0) = [(i, i = 1, n0)]
        do i = 1, size(sel)
            do j = 1, nobs
                rows(n0 + (i - 1) * nobs + j) = n0 + (sel(i) - 1) * nobs + j
            end do
        end do
    end function rows_of

    !> The pair matrix pairs[nh,nh] (a, b: data of a, fitted by b; 0 on the
    !> diagonal) over the rows R, by thin SVD (see the module header).
    subroutine disc_pairs(f, js, hoff, rows, pairs, info)
        real(dp), intent(in) :: f(:, :), js(:, :)
        integer(ip), intent(in) :: hoff(:)
        integer, intent(in) :: rows(:)
        real(dp), intent(out) :: pairs(:, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: jb(:, :), u(:, :), s(:), vt(:, :), d(:)
        integer :: a, b, m, p, kk, r
        m = size(rows)
        pairs = 0.0_dp
        info = sk_ok
        do b = 1, size(f, 2)
            p = hoff(b + 1) - hoff(b)
            kk = min(m, p)
            jb = js(rows, hoff(b) + 1:hoff(b + 1))
            if (allocated(u)) deallocate(u, s, vt)
            allocate(u(m, kk), s(kk), vt(kk, p))
            r = 0
            if (kk > 0) then
                call svd(jb, u, s, vt, info)
                if (info /= sk_ok) return
                r = count(s**2 > design_singular)
            end if
            do a = 1, size(f, 2)
                if (a == b) cycle
                d = f(rows, a) - f(rows, b)
                if (r > 0) d = d - matmul(u(:, 1:r), matmul(d, u(:, 1:r)))
                pairs(a, b) = sum(d**2)
            end do
        end do
    end subroutine disc_pairs

    !> min over a /= b of pairs(a, b).
    pure real(dp) function tmin(pairs) result(t)
        real(dp), intent(in) :: pairs(:, :)
        integer :: a, b
        t = huge(1.0_dp)
        do b = 1, size(pairs, 2)
            do a = 1, size(pairs, 1)
                if (a /= b) t = min(t, pairs(a, b))
            end do
        end do
    end function tmin

    !> For the rows R: tc[ncand] = T after adding each candidate alone (the
    !> Woodbury formula of the module header; -huge for the candidates in
    !> skip), and tnow = T of R itself, both from the (ridged) normal equations.
    subroutine disc_evaluate(f, js, hoff, n0, nobs, rows, skip, tc, tnow, info)
        real(dp), intent(in) :: f(:, :), js(:, :)
        integer(ip), intent(in) :: hoff(:), n0, nobs
        integer, intent(in) :: rows(:)
        logical, intent(in) :: skip(:)
        real(dp), intent(out) :: tc(:), tnow
        integer(ip), intent(out) :: info
        real(dp), allocatable :: g(:, :), x(:, :), gv(:), h(:), y(:), d(:), dr(:)
        real(dp), allocatable :: bcs(:, :, :), ls(:, :, :)
        real(dp) :: bc(nobs, nobs), z(nobs), e, q, ncp
        integer :: a, b, c, p, j, bad, nc, i0
        logical :: ok
        nc = size(tc)
        allocate(bcs(nobs, nobs, nc), ls(nobs, nobs, nc))
        tc = huge(1.0_dp)
        tnow = huge(1.0_dp)
        info = sk_ok
        do b = 1, size(f, 2)
            p = hoff(b + 1) - hoff(b)
            associate (jb => js(:, hoff(b) + 1:hoff(b + 1)))
                g = matmul(transpose(jb(rows, :)), jb(rows, :))
                call invert(g, bad)
                if (bad > 0) then
                    g = matmul(transpose(jb(rows, :)), jb(rows, :))
                    do j = 1, p
                        g(j, j) = g(j, j) + design_ridge
                    end do
                    call invert(g, bad)
                    if (bad > 0) then
                        info = sk_err_singular
                        return
                    end if
                end if
                ! per candidate: B_c = J_c G^-1 J_c^T and chol(I + B_c)
                x = matmul(jb(n0 + 1:, :), g)
                do c = 1, nc
                    if (skip(c)) cycle
                    i0 = (c - 1) * nobs
                    bcs(:, :, c) = matmul(x(i0 + 1:i0 + nobs, :), transpose(jb(n0 + i0 + 1:n0 + i0 + nobs, :)))
                    bc = bcs(:, :, c)
                    do j = 1, nobs
                        bc(j, j) = bc(j, j) + 1.0_dp
                    end do
                    call chol_small(nobs, bc, ls(:, :, c), 0.0_dp, ok)
                end do
                do a = 1, size(f, 2)
                    if (a == b) cycle
                    dr = f(rows, a) - f(rows, b)
                    gv = matmul(dr, jb(rows, :))
                    h = matmul(g, gv)
                    e = sum(dr**2)
                    q = sum(gv * h)
                    tnow = min(tnow, e - q)
                    y = matmul(jb(n0 + 1:, :), h)
                    d = f(n0 + 1:, a) - f(n0 + 1:, b)
                    do c = 1, nc
                        if (skip(c)) cycle
                        i0 = (c - 1) * nobs
                        associate (dc => d(i0 + 1:i0 + nobs), yc => y(i0 + 1:i0 + nobs))
                            z = yc + matmul(bcs(:, :, c), dc)
                            ncp = e + sum(dc**2) - (q + 2.0_dp * sum(dc * yc) + sum(dc * matmul(bcs(:, :, c), dc)) &
                                - zkz(ls(:, :, c), z))
                        end associate
                        tc(c) = min(tc(c), ncp)
                    end do
                end do
            end associate
        end do
        where (skip) tc = -huge(1.0_dp)
    contains
        !> z^T K^-1 z with K = l l^T.
        real(dp) function zkz(l, zz)
            real(dp), intent(in) :: l(:, :), zz(:)
            real(dp) :: v(nobs)
            integer :: i
            do i = 1, nobs
                v(i) = (zz(i) - sum(l(i, 1:i - 1) * v(1:i - 1))) / l(i, i)
            end do
            zkz = sum(v**2)
        end function zkz
        !> In-place inverse of the SPD a (bad > 0: singular).
        subroutine invert(aa, badc)
            real(dp), intent(inout) :: aa(:, :)
            integer, intent(out) :: badc
            integer :: linfo, jj
            call chol_checked(aa, badc)
            if (badc > 0) return
            call dpotri('L', size(aa, 1), aa, size(aa, 1), linfo)
            do jj = 1, size(aa, 1)
                aa(1:jj - 1, jj) = aa(jj, 1:jj - 1)
            end do
        end subroutine invert
    end subroutine disc_evaluate

    !> The columns of jall scaled to unit norm over all rows (a zero column
    !> kept): the Jacobians the search and its evaluations work on.
    pure function unit_columns(jall) result(js)
        real(dp), intent(in) :: jall(:, :)
        real(dp), allocatable :: js(:, :)
        real(dp) :: nrm
        integer :: j
        allocate(js, source=jall)
        do j = 1, size(js, 2)
            nrm = sqrt(sum(js(:, j)**2))
            if (nrm > 0.0_dp) js(:, j) = js(:, j) / nrm
        end do
    end function unit_columns

    !> Greedy + exchange T-optimal selection: sel[k] (in order, exchanged
    !> positions replaced in place), value = T of the selection and pairs[nh,nh]
    !> (direct, disc_pairs), gvalue = T of the greedy selection, passes, swaps.
    subroutine disc_select(f, jall, hoff, n0, nobs, k, max_passes, sel, value, gvalue, pairs, passes, swaps, info)
        real(dp), intent(in) :: f(:, :), jall(:, :)
        integer(ip), intent(in) :: hoff(:), n0, nobs, k, max_passes
        integer(ip), intent(out) :: sel(:), passes, swaps
        real(dp), intent(out) :: value, gvalue, pairs(:, :)
        integer(ip), intent(out) :: info
        real(dp), allocatable :: js(:, :), tc(:)
        logical, allocatable :: chosen(:), skip(:)
        real(dp) :: tnow, nrm
        integer :: ncand, step, i, j, best, r, nswap
        ncand = (size(f, 1) - n0) / nobs
        js = unit_columns(jall)
        allocate(tc(ncand), chosen(ncand), skip(ncand))
        chosen = .false.
        sel = 0
        passes = 0
        swaps = 0
        value = 0.0_dp
        gvalue = 0.0_dp
        pairs = 0.0_dp
        do step = 1, k
            call disc_evaluate(f, js, hoff, n0, nobs, rows_of(n0, nobs, sel(1:step - 1)), chosen, tc, tnow, info)
            if (info /= sk_ok) return
            best = maxloc(tc, 1)
            chosen(best) = .true.
            sel(step) = int(best, ip)
        end do
        call disc_pairs(f, js, hoff, rows_of(n0, nobs, sel), pairs, info)
        if (info /= sk_ok) return
        gvalue = tmin(pairs)
        do while (passes < max_passes)
            passes = passes + 1
            nswap = 0
            do i = 1, k
                r = sel(i)
                skip = chosen
                skip(r) = .false.
                call disc_evaluate(f, js, hoff, n0, nobs, rows_of(n0, nobs, pack(sel, [(j /= i, j = 1, k)])), skip, &
                    tc, tnow, info)
                if (info /= sk_ok) return
                skip(r) = .true.
                nrm = tc(r)
                tc(r) = -huge(1.0_dp)
                best = maxloc(tc, 1)
                if (.not. (tc(best) > nrm + design_improve * max(abs(nrm), tiny(1.0_dp)))) cycle
                chosen(r) = .false.
                chosen(best) = .true.
                sel(i) = int(best, ip)
                nswap = nswap + 1
            end do
            swaps = swaps + int(nswap, ip)
            if (nswap == 0) exit
        end do
        call disc_pairs(f, js, hoff, rows_of(n0, nobs, sel), pairs, info)
        value = tmin(pairs)
    end subroutine disc_select

end module sk_design_disc
