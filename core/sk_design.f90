!> Optimal design of calibration experiments (stiffkit plan): choose k of
!> ncand candidate postures, each owning nobs whitened observation rows
!> J_c (nobs x npar), so that the information matrix
!>   M = m0 + sum over the chosen c of J_c^T J_c
!> minimises one of three lower-is-better criteria:
!>   D: -log det M,   A: trace M^-1,   task: trace(Jt M^-1 Jt^T).
!> Everything is computed on column-scaled parameters: column j is scaled by
!> s_j = 1/sqrt(diag(m0 + sum over ALL candidates J_c^T J_c)_j) (1 when that
!> diagonal is 0); task is invariant under the scaling, D and A are in the
!> scaled units.
!>
!> Selection: greedy (from m0, plus a tiny ridge when m0 is singular) then a
!> modified Fedorov exchange (for each chosen candidate, the best swap with
!> an unchosen one, made when the criterion strictly improves; passes until
!> none does). No refits: the state keeps M^-1 and, per candidate, the
!> nobs x nobs blocks B_c = J_c M^-1 J_c^T and C_c = J_c M^-1 Q M^-1 J_c^T
!> (Q = I for A, Jt^T Jt for task), updated by the Woodbury identity on the
!> nobs x nobs blocks after every added or removed candidate, in
!> O(ncand nobs^2 npar) (one skinny matrix product over all candidates).
!> Indices are 1-based. Codes, tolerances, argument checks and the small
!> dense kernels are in sk_design_base.
module sk_design
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: inverse, eye
    use sk_design_base
    implicit none
    private
    public :: design_state, design_scales, state_init, state_update, add_cache, swap_pass
    public :: criterion_direct, design_select, design_covariance, state_alloc
    ! the codes and tolerances of sk_design_base, for the entry points
    public :: crit_d, crit_a, crit_task, design_check, darg_k, darg_max_passes


    !> Incremental state: the scaled M^-1 and the per-candidate blocks.
    type design_state
        integer :: npar = 0, nobs = 0, ncand = 0
        integer(ip) :: crit = crit_d
        real(dp), allocatable :: s(:), minv(:, :), q(:, :), b(:, :, :), c(:, :, :)
        !> add_cache: chol(I + B_c), its C_c sandwich and the change of adding c
        real(dp), allocatable :: l(:, :, :), ct(:, :, :), dadd(:)
        logical, allocatable :: chosen(:)
        real(dp) :: value = 0.0_dp
    end type design_state

    interface
        subroutine dgemm(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc)
            import :: dp
            character(len=1), intent(in) :: transa, transb
            integer, intent(in) :: m, n, k, lda, ldb, ldc
            real(dp), intent(in) :: alpha, beta, a(lda, *), b(ldb, *)
            real(dp), intent(inout) :: c(ldc, *)
        end subroutine dgemm
    end interface

contains

    !> Column scales s[npar] from m0 and all candidates.
    subroutine design_scales(jc, m0, s)
        real(dp), intent(in) :: jc(:, :, :), m0(:, :)
        real(dp), intent(out) :: s(:)
        integer :: j
        real(dp) :: d
        do j = 1, size(jc, 1)
            d = m0(j, j) + sum(jc(j, :, :)**2)
            s(j) = 1.0_dp
            if (d > 0.0_dp) s(j) = 1.0_dp / sqrt(d)
        end do
    end subroutine design_scales

    !> Scaled information matrix m = S m0 S + ridge I + sum over chosen of
    !> U_c U_c^T (U_c = S J_c^T).
    subroutine build_m(jc, s, m0, chosen, ridge, m)
        real(dp), intent(in) :: jc(:, :, :), s(:), m0(:, :), ridge
        integer(ip), intent(in) :: chosen(:)
        real(dp), intent(out) :: m(:, :)
        real(dp), allocatable :: u(:, :)
        integer :: i, j, n, nobs
        n = size(s)
        nobs = size(jc, 2)
        do j = 1, n
            m(:, j) = s * m0(:, j) * s(j)
            m(j, j) = m(j, j) + ridge
        end do
        allocate(u(n, nobs))
        do i = 1, size(chosen)
            do j = 1, nobs
                u(:, j) = s * jc(:, j, chosen(i))
            end do
            m = m + matmul(u, transpose(u))
        end do
    end subroutine build_m

    !> Scaled task matrix q = S jt jt^T S (zero-size jt: q = 0).
    subroutine task_matrix(jt, s, q)
        real(dp), intent(in) :: jt(:, :), s(:)
        real(dp), intent(out) :: q(:, :)
        real(dp), allocatable :: js(:, :)
        integer :: i
        allocate(js(size(s), size(jt, 2)))
        do i = 1, size(jt, 2)
            js(:, i) = s * jt(:, i)
        end do
        q = matmul(js, transpose(js))
    end subroutine task_matrix

    !> The criterion of the scaled m (destroyed) from scratch (Cholesky):
    !> f (+huge when singular: bad = first non-identifiable column) and, on
    !> request, minv = m^-1.
    subroutine value_of(m, crit, q, f, bad, minv)
        real(dp), intent(inout) :: m(:, :)
        integer(ip), intent(in) :: crit
        real(dp), intent(in) :: q(:, :)
        real(dp), intent(out) :: f
        integer, intent(out) :: bad
        real(dp), intent(out), optional :: minv(:, :)
        integer :: j, n, linfo
        n = size(m, 1)
        call chol_checked(m, bad)
        f = huge(1.0_dp)
        if (bad > 0) return
        if (crit == crit_d) then
            f = 0.0_dp
            do j = 1, n
                f = f - 2.0_dp * log(m(j, j))
            end do
            if (.not. present(minv)) return
        end if
        call dpotri('L', n, m, n, linfo)
        do j = 1, n
            m(1:j - 1, j) = m(j, 1:j - 1)
        end do
        if (crit == crit_a) f = sum([(m(j, j), j = 1, n)])
        if (crit == crit_task) f = sum(q * m)
        if (present(minv)) minv = m
    end subroutine value_of

    !> Direct criterion of the chosen set (Cholesky from scratch, no ridge):
    !> f = +huge and bad = the first non-identifiable column when M is
    !> singular; s[npar] the scales used.
    subroutine criterion_direct(jc, m0, jt, chosen, crit, f, bad, s)
        real(dp), intent(in) :: jc(:, :, :), m0(:, :), jt(:, :)
        integer(ip), intent(in) :: chosen(:), crit
        real(dp), intent(out) :: f, s(:)
        integer, intent(out) :: bad
        real(dp), allocatable :: m(:, :), q(:, :)
        integer :: n
        n = size(jc, 1)
        allocate(m(n, n), q(n, n))
        call design_scales(jc, m0, s)
        q = 0.0_dp
        if (crit == crit_task) call task_matrix(jt, s, q)
        call build_m(jc, s, m0, chosen, 0.0_dp, m)
        call value_of(m, crit, q, f, bad)
    end subroutine criterion_direct

    !> Fill st from scratch for the chosen flags st%chosen: minv, the blocks
    !> B_c, C_c of every candidate and st%value (+huge, bad > 0 when the
    !> ridged M is singular).
    subroutine state_init(st, jc, m0, ridge, bad)
        type(design_state), intent(inout) :: st
        real(dp), intent(in) :: jc(:, :, :), m0(:, :), ridge
        integer, intent(out) :: bad
        real(dp), allocatable :: m(:, :), x(:, :), h(:, :)
        integer(ip), allocatable :: idx(:)
        integer :: n, nobs, nc, c
        n = st%npar
        nobs = st%nobs
        nc = st%ncand
        idx = pack([(int(c, ip), c = 1, nc)], st%chosen)
        allocate(m(n, n), x(n, nobs * nc))
        call build_m(jc, st%s, m0, idx, ridge, m)
        call value_of(m, st%crit, st%q, st%value, bad, st%minv)
        if (bad > 0) return
        call blocks(st%minv, st%b)
        if (st%crit == crit_d) return
        h = matmul(st%minv, matmul(st%q, st%minv))
        if (st%crit == crit_a) h = matmul(st%minv, st%minv)
        call blocks(h, st%c)
    contains
        !> out_c = U_c^T a U_c for every candidate.
        subroutine blocks(a, out)
            real(dp), intent(in) :: a(:, :)
            real(dp), intent(out) :: out(:, :, :)
            real(dp), allocatable :: as(:, :)
            integer :: j, cc
            allocate(as(n, n))
            do j = 1, n
                as(:, j) = a(:, j) * st%s * st%s(j)
            end do
            call dgemm('N', 'N', n, nobs * nc, n, 1.0_dp, as, n, jc, n, 0.0_dp, x, n)
            do cc = 1, nc
                out(:, :, cc) = matmul(transpose(jc(:, :, cc)), x(:, (cc - 1) * nobs + 1:cc * nobs))
            end do
        end subroutine blocks
    end subroutine state_init

    !> Allocate st for the problem and set its scales and task matrix.
    subroutine state_alloc(st, jc, m0, jt, crit)
        type(design_state), intent(out) :: st
        real(dp), intent(in) :: jc(:, :, :), m0(:, :), jt(:, :)
        integer(ip), intent(in) :: crit
        st%npar = size(jc, 1)
        st%nobs = size(jc, 2)
        st%ncand = size(jc, 3)
        st%crit = crit
        allocate(st%s(st%npar), st%minv(st%npar, st%npar), st%q(st%npar, st%npar))
        allocate(st%b(st%nobs, st%nobs, st%ncand), st%c(st%nobs, st%nobs, st%ncand), st%chosen(st%ncand))
        allocate(st%l(st%nobs, st%nobs, st%ncand), st%ct(st%nobs, st%nobs, st%ncand), st%dadd(st%ncand))
        st%c = 0.0_dp
        st%ct = 0.0_dp
        call design_scales(jc, m0, st%s)
        st%q = 0.0_dp
        if (crit == crit_task) call task_matrix(jt, st%s, st%q)
        if (crit == crit_a) st%q = eye(st%npar)
        st%chosen = .false.
    end subroutine state_alloc

    !> Per candidate, what adding it alone would do: l_c = chol(I + B_c),
    !> ct_c = l_c^-1 C_c l_c^-T and the criterion change dadd_c
    !> (D: -2 log det l_c; A, task: -tr ct_c; +huge if I + B_c is not SPD).
    subroutine add_cache(st)
        type(design_state), intent(inout) :: st
        integer :: c, i, n
        real(dp) :: x(st%nobs, st%nobs), a(st%nobs, st%nobs)
        logical :: ok
        n = st%nobs
        do c = 1, st%ncand
            a = st%b(:, :, c)
            do i = 1, n
                a(i, i) = a(i, i) + 1.0_dp
            end do
            call chol_small(n, a, st%l(:, :, c), 0.0_dp, ok)
            st%dadd(c) = huge(1.0_dp)
            if (.not. ok) cycle
            if (st%crit == crit_d) then
                st%dadd(c) = -2.0_dp * sum([(log(st%l(i, i, c)), i = 1, n)])
            else
                call lower_solve(n, st%l(:, :, c), st%c(:, :, c), x)
                call lower_solve(n, st%l(:, :, c), transpose(x), st%ct(:, :, c))
                st%dadd(c) = -sum([(st%ct(i, i, c), i = 1, n)])
            end if
        end do
    end subroutine add_cache

    !> vz[npar,nv] = s * [M^-1 U_a, M^-1 Q M^-1 U_a] (the second half for A
    !> and task only), U_a = S J_a^T.
    subroutine products(st, jc, a, vz)
        type(design_state), intent(in) :: st
        real(dp), intent(in) :: jc(:, :, :)
        integer, intent(in) :: a
        real(dp), intent(out) :: vz(:, :)
        real(dp) :: u(st%npar, st%nobs)
        integer :: j, n
        n = st%nobs
        do j = 1, n
            u(:, j) = st%s * jc(:, j, a)
        end do
        vz(:, 1:n) = matmul(st%minv, u)
        if (st%crit /= crit_d) vz(:, n + 1:) = matmul(st%minv, matmul(st%q, vz(:, 1:n)))
    end subroutine products

    !> Woodbury update of st after adding (sgn = +1) or removing (sgn = -1)
    !> candidate a: M' = M + sgn U U^T, U = S J_a^T, V = M^-1 U,
    !> E = (sgn I + U^T V)^-1, M'^-1 = M^-1 - V E V^T; per candidate with
    !> P = J_c S V, R = J_c S Z (Z = M^-1 Q V) and W = V^T Q V:
    !>   B_c -= P E P^T,  C_c += -P E R^T - R E P^T + P E W E P^T.
    subroutine state_update(st, jc, a, sgn, info)
        type(design_state), intent(inout) :: st
        real(dp), intent(in) :: jc(:, :, :)
        integer, intent(in) :: a
        real(dp), intent(in) :: sgn
        integer(ip), intent(out) :: info
        integer :: n, j, c, nv
        real(dp), allocatable :: vz(:, :), pr(:, :), e(:, :), w(:, :)
        real(dp), dimension(st%nobs, st%nobs) :: p, r, pe, x, y
        n = st%nobs
        nv = merge(n, 2 * n, st%crit == crit_d)
        allocate(vz(st%npar, nv), pr(nv, n * st%ncand), e(n, n))
        call products(st, jc, a, vz)
        call inverse(sgn * eye(n) + st%b(:, :, a), e, info)
        if (info /= sk_ok) return
        if (st%crit /= crit_d) then
            w = matmul(transpose(vz(:, 1:n)), matmul(st%q, vz(:, 1:n)))
            w = matmul(e, matmul(w, e))
        end if
        st%minv = st%minv - matmul(vz(:, 1:n), matmul(e, transpose(vz(:, 1:n))))
        do j = 1, nv
            vz(:, j) = vz(:, j) * st%s
        end do
        call cand_cross(jc, vz, pr)
        do c = 1, st%ncand
            call blocks_of(pr, c, n, p, r)
            call mul(n, 'n', p, e, pe)
            call mul(n, 't', pe, p, x)
            st%b(:, :, c) = st%b(:, :, c) - x
            if (st%crit /= crit_d) then
                call mul(n, 't', pe, r, x)
                call mul(n, 'n', p, w, y)
                call mul(n, 't', y, p, pe)
                st%c(:, :, c) = st%c(:, :, c) - x - transpose(x) + pe
            end if
        end do
    end subroutine state_update

    !> One exchange pass over the positions of sel[k]: for the chosen r at
    !> each position the best unchosen c (criterion change of the swap from
    !> the blocks and the products P = J_c S M^-1 U_r, R = J_c S M^-1 Q M^-1 U_r,
    !> with L = chol(I + B_c), T = L^-1 P, S2 = I - B_r + T^T T:
    !>   D: -2 log det L - log det S2;
    !>   A/task: -tr(L^-1 C_c L^-T) + tr(S2^-1 C_r1),
    !>   C_r1 = C_r - T^T Rt - Rt^T T + T^T Ct T, Rt = L^-1 R, Ct = L^-1 C_c L^-T);
    !> the swap is made when it lowers the criterion by more than
    !> design_improve (relative) and S2 stays regular (pivots^2 >
    !> design_removal: r does not carry all the information of a direction).
    !> nswap counts the swaps.
    subroutine swap_pass(st, jc, sel, nswap, info)
        type(design_state), intent(inout) :: st
        real(dp), intent(in) :: jc(:, :, :)
        integer(ip), intent(inout) :: sel(:)
        integer, intent(out) :: nswap
        integer(ip), intent(out) :: info
        integer :: n, nv, i, r, c, best
        real(dp), allocatable :: vz(:, :), pr(:, :)
        real(dp) :: d, dbest, tol
        n = st%nobs
        nv = merge(n, 2 * n, st%crit == crit_d)
        allocate(vz(st%npar, nv), pr(nv, n * st%ncand))
        nswap = 0
        info = sk_ok
        call add_cache(st)
        do i = 1, size(sel)
            r = sel(i)
            call products(st, jc, r, vz)
            do c = 1, nv
                vz(:, c) = vz(:, c) * st%s
            end do
            call cand_cross(jc, vz, pr)
            best = 0
            dbest = huge(1.0_dp)
            do c = 1, st%ncand
                if (st%chosen(c)) cycle
                if (st%dadd(c) >= huge(1.0_dp)) cycle
                d = swap_delta(c)
                if (d < dbest) then
                    dbest = d
                    best = c
                end if
            end do
            tol = design_improve * abs(st%value)
            if (st%crit == crit_d) tol = design_improve * max(abs(st%value), 1.0_dp)
            if (best == 0 .or. .not. (dbest < -tol)) cycle
            call state_update(st, jc, best, 1.0_dp, info)
            if (info /= sk_ok) return
            call state_update(st, jc, r, -1.0_dp, info)
            if (info /= sk_ok) return
            st%value = st%value + dbest
            st%chosen(r) = .false.
            st%chosen(best) = .true.
            sel(i) = int(best, ip)
            nswap = nswap + 1
            call add_cache(st)
        end do
    contains
        real(dp) function swap_delta(cc) result(dd)
            integer, intent(in) :: cc
            real(dp), dimension(n, n) :: p, rr, l2, t, rt, tmp, s2, cr1
            logical :: ok
            integer :: ii
            dd = huge(1.0_dp)
            call blocks_of(pr, cc, n, p, rr)
            call lower_solve(n, st%l(:, :, cc), p, t)
            call mul_tn(n, t, t, s2)
            s2 = s2 - st%b(:, :, r)
            do ii = 1, n
                s2(ii, ii) = s2(ii, ii) + 1.0_dp
            end do
            call chol_small(n, s2, l2, design_removal, ok)
            if (.not. ok) return
            if (st%crit == crit_d) then
                dd = st%dadd(cc)
                do ii = 1, n
                    dd = dd - 2.0_dp * log(l2(ii, ii))
                end do
                return
            end if
            call lower_solve(n, st%l(:, :, cc), rr, rt)
            call mul_tn(n, t, rt, tmp)
            cr1 = st%c(:, :, r) - tmp - transpose(tmp)
            call mul(n, 'n', st%ct(:, :, cc), t, rt)
            call mul_tn(n, t, rt, tmp)
            cr1 = cr1 + tmp
            dd = st%dadd(cc) + sandwich_trace(n, l2, cr1)
        end function swap_delta
    end subroutine swap_pass

    !> Greedy selection then exchange (see the module header): sel[k] in
    !> order, value (+huge when M stays singular, singular = 1), the greedy
    !> selection's value gvalue, path[k] the criterion after each greedy step
    !> (with the ridge when m0 is singular: ridged = 1), passes, swaps, scales s[npar].
    !> With start[k] (distinct, checked by the caller) the exchange starts from
    !> that selection instead of the greedy one (added in its order, the same
    !> updates; gvalue and path are then the start's). value and gvalue: the
    !> updates' value, replaced by criterion_direct's beyond design_drift.
    subroutine design_select(jc, k, crit, m0, jt, max_passes, sel, value, gvalue, path, passes, swaps, &
            s, singular, ridged, info, start)
        real(dp), intent(in) :: jc(:, :, :), m0(:, :), jt(:, :)
        integer(ip), intent(in) :: k, crit, max_passes
        integer(ip), intent(in), optional :: start(:)
        integer(ip), intent(out) :: sel(:), passes, swaps, singular, ridged
        real(dp), intent(out) :: value, gvalue, path(:), s(:)
        integer(ip), intent(out) :: info
        type(design_state) :: st
        real(dp) :: ridge, d, dbest
        real(dp), allocatable :: mu(:, :), mt(:, :)
        integer :: bad, step, c, best, nswap, b3
        call state_alloc(st, jc, m0, jt, crit)
        s = st%s
        sel = 0
        path = huge(1.0_dp)
        passes = 0
        swaps = 0
        singular = 0
        value = huge(1.0_dp)
        gvalue = huge(1.0_dp)
        ridge = 0.0_dp
        call state_init(st, jc, m0, ridge, bad)
        ridged = 0
        if (bad > 0) then
            ridged = 1
            ridge = design_ridge
            call state_init(st, jc, m0, ridge, bad)
        end if
        info = sk_err_singular
        if (bad > 0) return
        if (ridge > 0.0_dp) then
            allocate(mu(st%npar, st%npar), mt(st%npar, st%npar))
            call build_m(jc, st%s, m0, sel(1:0), 0.0_dp, mu)
        end if
        do step = 1, k
            call add_cache(st)
            best = 0
            dbest = huge(1.0_dp)
            do c = 1, st%ncand
                if (st%chosen(c)) cycle
                if (st%dadd(c) < dbest) then
                    dbest = st%dadd(c)
                    best = c
                end if
            end do
            if (best == 0) best = findloc(st%chosen, .false., 1)
            if (present(start)) then
                if (size(start) == k) then
                    best = int(start(step))
                    dbest = st%dadd(best)
                end if
            end if
            call state_update(st, jc, best, 1.0_dp, info)
            if (info /= sk_ok) return
            st%value = st%value + dbest
            st%chosen(best) = .true.
            sel(step) = int(best, ip)
            if (ridge > 0.0_dp) call unridge()
            path(step) = st%value
        end do
        if (ridge > 0.0_dp) then
            ! M stayed singular: the exchange runs with the ridge
            call state_init(st, jc, m0, ridge, bad)
            if (bad > 0) return
        end if
        ! the greedy selection's value checked from scratch: the updates lose
        ! digits when M is ill-conditioned (just after it became regular, say)
        call criterion_direct(jc, m0, jt, sel, crit, d, b3, s)
        if (ridge == 0.0_dp) then
            call refresh(d, b3)
            gvalue = st%value
        else
            gvalue = d
        end if
        do while (passes < max_passes)
            passes = passes + 1
            ! fresh blocks and, without the ridge, a fresh value (bounded round-off)
            d = st%value
            call state_init(st, jc, m0, ridge, bad)
            if (bad > 0) exit
            st%value = d
            if (ridge == 0.0_dp) then
                call criterion_direct(jc, m0, jt, sel, crit, d, b3, s)
                call refresh(d, b3)
            end if
            call swap_pass(st, jc, sel, nswap, info)
            if (info /= sk_ok) return
            swaps = swaps + int(nswap, ip)
            if (nswap == 0) exit
        end do
        info = sk_ok
        ! the final M without the ridge: singular -> +huge; when the ridge
        ! stayed, the final criterion is this direct one
        call criterion_direct(jc, m0, jt, sel, crit, d, bad, s)
        if (ridge > 0.0_dp .or. bad > 0) then
            st%value = d
        else
            call refresh(d, bad)
        end if
        value = st%value
        if (value >= huge(1.0_dp)) singular = 1
    contains
        !> The running value replaced by the direct one dv (its Cholesky's
        !> flag b) when they differ beyond design_drift relative.
        subroutine refresh(dv, b)
            real(dp), intent(in) :: dv
            integer, intent(in) :: b
            if (b == 0 .and. abs(st%value - dv) > design_drift * max(abs(dv), tiny(1.0_dp))) st%value = dv
        end subroutine refresh
        !> While the ridge is on: the ridged criterion from scratch (cheap:
        !> npar^3, keeps the huge ridged values from drifting) and, as soon as
        !> M is regular without the ridge, the state rebuilt without it.
        subroutine unridge()
            real(dp) :: u(st%npar, st%nobs), f0
            integer :: j, b2, b3
            do j = 1, st%nobs
                u(:, j) = st%s * jc(:, j, best)
            end do
            mu = mu + matmul(u, transpose(u))
            mt = mu
            do j = 1, st%npar
                mt(j, j) = mt(j, j) + ridge
            end do
            call value_of(mt, crit, st%q, st%value, b2)
            mt = mu
            call chol_checked(mt, b2, absolute=.true.)
            if (b2 > 0) return
            ! the criterion without the ridge, from scratch: the updates carry
            ! it from here on (the ridged value can differ much when M has
            ! only just become regular); while M is singular to the relative
            ! test the ridge stays
            mt = mu
            call value_of(mt, crit, st%q, f0, b3)
            if (b3 > 0) return
            call state_init(st, jc, m0, 0.0_dp, b2)
            if (b2 > 0) then
                call state_init(st, jc, m0, ridge, b2)
                return
            end if
            ridge = 0.0_dp
            st%value = f0
        end subroutine unridge
    end subroutine design_select

    !> Covariance cov[npar,npar] = M^-1 of the chosen set in the caller's
    !> (unscaled) units; bad = the first non-identifiable column (its scaled
    !> Cholesky pivot^2 <= design_singular), 0 when M is regular.
    subroutine design_covariance(jc, m0, chosen, cov, bad)
        real(dp), intent(in) :: jc(:, :, :), m0(:, :)
        integer(ip), intent(in) :: chosen(:)
        real(dp), intent(out) :: cov(:, :)
        integer, intent(out) :: bad
        real(dp), allocatable :: s(:), m(:, :)
        real(dp) :: f, q0(0, 0)
        integer :: n, j
        n = size(jc, 1)
        allocate(s(n), m(n, n))
        call design_scales(jc, m0, s)
        call build_m(jc, s, m0, chosen, 0.0_dp, m)
        cov = 0.0_dp
        call value_of(m, crit_a, q0, f, bad, cov)
        if (bad > 0) return
        do j = 1, n
            cov(:, j) = s * cov(:, j) * s(j)
        end do
    end subroutine design_covariance

end module sk_design
