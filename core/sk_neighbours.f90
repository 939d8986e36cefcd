!> Structure of a residual (diagnosis, "nothing in the catalogue fits"):
!> the correlation of each point's residual with its nearest neighbour's,
!> with a reproducible permutation test.
module sk_neighbours
    use, intrinsic :: iso_fortran_env, only: int64
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: all_finite, group_by
    implicit none
    private
    public :: neighbour_correlation

contains

    !> Is a residual a function of something (a posture, the time of the
    !> measurement), or noise? For every point i in use (w(i) > 0), its
    !> nearest point nn(i) by x(:, i) (Euclidean over the d coordinates)
    !> among the points in use of the same class cls (e.g. the same marker)
    !> and of another group grp (another configuration);
    !>   rho = sum_i e_i . e_nn(i) / sum_i |e_i|^2
    !> over the points that have one. Noise gives rho near 0 (slightly below:
    !> the fit takes out what neighbours share); an effect that varies
    !> smoothly with x makes neighbours alike. pval: a permutation test, the
    !> share of nperm random pairings (each point with a uniformly drawn
    !> point of its class and another group) whose rho reaches the observed
    !> one, (1 + count) / (1 + nperm); the draws are reproducible (a
    !> xorshift generator seeded by seed). nn(i) = 0 for points without a
    !> neighbour. info: sk_err_size, sk_err_nonfinite, sk_err_argument
    !> (nperm < 1), sk_err_too_few (fewer than 3 points with a neighbour),
    !> sk_ok.
    subroutine neighbour_correlation(x, e, w, grp, cls, nperm, seed, rho, pval, nn, info)
        real(dp), intent(in) :: x(:, :), e(:, :), w(:)
        integer(ip), intent(in) :: grp(:), cls(:), nperm, seed
        real(dp), intent(out) :: rho, pval
        integer(ip), intent(out) :: nn(:), info
        integer, allocatable :: members(:), cstart(:)
        integer :: n, i, j, k, c, ncls, lo, hi, cnt, iperm, tries
        integer(int64) :: st
        real(dp) :: best, d2, num, den, rp
        n = size(x, 2)
        rho = 0.0_dp
        pval = 1.0_dp
        nn = 0
        info = sk_err_size
        if (size(e, 2) /= n .or. size(w) /= n .or. size(grp) /= n .or. size(cls) /= n .or. size(nn) /= n) return
        info = sk_err_nonfinite
        if (.not. (all_finite(x) .and. all_finite(e) .and. all_finite(w))) return
        info = sk_err_argument
        if (nperm < 1 .or. any(cls < 1)) return
        ! the points in use of each class, contiguous (points out of use: class ncls + 1)
        ncls = 0
        if (n > 0) ncls = maxval(cls)
        call group_by(merge(cls, int(ncls + 1, ip), w > 0.0_dp), ncls + 1, cstart, members, info)
        if (info /= sk_ok) return
        ! nearest neighbours
        do c = 1, ncls
            lo = cstart(c)
            hi = cstart(c + 1) - 1
            do k = lo, hi
                i = members(k)
                best = huge(1.0_dp)
                do j = lo, hi
                    if (grp(members(j)) == grp(i)) cycle
                    d2 = sum((x(:, members(j)) - x(:, i))**2)
                    if (d2 < best) then
                        best = d2
                        nn(i) = members(j)
                    end if
                end do
            end do
        end do
        info = sk_err_too_few
        if (count(nn > 0) < 3) return
        num = 0.0_dp
        den = 0.0_dp
        do i = 1, n
            if (nn(i) == 0) cycle
            num = num + dot_product(e(:, i), e(:, nn(i)))
            den = den + dot_product(e(:, i), e(:, i))
        end do
        info = sk_ok
        if (.not. den > 0.0_dp) return
        rho = num/den
        ! permutations: random partners within the class, another group
        st = int(seed, int64)*2654435761_int64 + 88172645463325252_int64
        if (st == 0) st = 88172645463325252_int64
        cnt = 0
        do iperm = 1, nperm
            num = 0.0_dp
            do i = 1, n
                if (nn(i) == 0) cycle
                c = cls(i)
                lo = cstart(c)
                hi = cstart(c + 1) - 1
                do tries = 1, 64
                    j = members(lo + int(modulo(xorshift(st), int(hi - lo + 1, int64))))
                    if (grp(j) /= grp(i)) exit
                end do
                if (grp(j) == grp(i)) j = nn(i)
                num = num + dot_product(e(:, i), e(:, j))
            end do
            rp = num/den
            if (rp >= rho) cnt = cnt + 1
        end do
        pval = real(1 + cnt, dp)/real(1 + nperm, dp)
    end subroutine neighbour_correlation

    !> xorshift64 step: the next state, returned (non-negative part).
    integer(int64) function xorshift(st) result(r)
        integer(int64), intent(inout) :: st
        st = ieor(st, ishft(st, 13))
        st = ieor(st, ishft(st, -7))
        st = ieor(st, ishft(st, 17))
        r = iand(st, huge(st))
    end function xorshift

end module sk_neighbours
