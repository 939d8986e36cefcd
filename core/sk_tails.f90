!> Tail probabilities the calibration tests need (chi-square and F
!> survival functions through the regularised incomplete gamma and beta
!> functions), in log space so that strong effects do not underflow to 0.
module sk_tails
    use sk_kinds, only: dp
    implicit none
    private
    public :: chi2_logsf, f_logsf, log_gammq, log_betai

contains

    !> log Q(a, x), Q the regularised upper incomplete gamma function:
    !> series for P when x < a + 1, Lentz continued fraction otherwise.
    pure function log_gammq(a, x) result(lq)
        real(dp), intent(in) :: a, x
        real(dp) :: lq, ap, del, ssum, b, c, dd, h, an, lpre
        integer :: n
        if (x <= 0.0_dp) then
            lq = 0.0_dp
            return
        end if
        lpre = -x + a*log(x) - log_gamma(a)
        if (x < a + 1.0_dp) then
            ap = a
            ssum = 1.0_dp/a
            del = ssum
            do n = 1, 100000
                ap = ap + 1.0_dp
                del = del*x/ap
                ssum = ssum + del
                if (abs(del) < abs(ssum)*1.0e-16_dp) exit
            end do
            lq = log(max(1.0_dp - exp(lpre + log(ssum)), tiny(1.0_dp)))
        else
            b = x + 1.0_dp - a
            c = 1.0_dp/tiny(1.0_dp)
            dd = 1.0_dp/b
            h = dd
            do n = 1, 100000
                an = -n*(n - a)
                b = b + 2.0_dp
                dd = an*dd + b
                if (abs(dd) < tiny(1.0_dp)) dd = tiny(1.0_dp)
                c = b + an/c
                if (abs(c) < tiny(1.0_dp)) c = tiny(1.0_dp)
                dd = 1.0_dp/dd
                del = dd*c
                h = h*del
                if (abs(del - 1.0_dp) < 1.0e-16_dp) exit
            end do
            lq = lpre + log(h)
        end if
    end function log_gammq

    !> log of the chi-square survival function, k degrees of freedom.
    pure function chi2_logsf(x, k) result(l)
        real(dp), intent(in) :: x, k
        real(dp) :: l
        l = log_gammq(0.5_dp*k, 0.5_dp*x)
    end function chi2_logsf

    !> Continued fraction of the incomplete beta function (modified Lentz).
    pure function betacf(a, b, x) result(h)
        real(dp), intent(in) :: a, b, x
        real(dp) :: h, aa, c, d, del, qab, qap, qam
        integer :: m, m2
        qab = a + b
        qap = a + 1.0_dp
        qam = a - 1.0_dp
        c = 1.0_dp
        d = 1.0_dp - qab*x/qap
        if (abs(d) < tiny(1.0_dp)) d = tiny(1.0_dp)
        d = 1.0_dp/d
        h = d
        do m = 1, 100000
            m2 = 2*m
            aa = m*(b - m)*x/((qam + m2)*(a + m2))
            d = 1.0_dp + aa*d
            if (abs(d) < tiny(1.0_dp)) d = tiny(1.0_dp)
            c = 1.0_dp + aa/c
            if (abs(c) < tiny(1.0_dp)) c = tiny(1.0_dp)
            d = 1.0_dp/d
            h = h*d*c
            aa = -(a + m)*(qab + m)*x/((a + m2)*(qap + m2))
            d = 1.0_dp + aa*d
            if (abs(d) < tiny(1.0_dp)) d = tiny(1.0_dp)
            c = 1.0_dp + aa/c
            if (abs(c) < tiny(1.0_dp)) c = tiny(1.0_dp)
            d = 1.0_dp/d
            del = d*c
            h = h*del
            if (abs(del - 1.0_dp) < 1.0e-16_dp) exit
        end do
    end function betacf

    !> log I_x(a, b), the regularised incomplete beta function.
    pure recursive function log_betai(a, b, x) result(l)
        real(dp), intent(in) :: a, b, x
        real(dp) :: l, lbt
        if (x <= 0.0_dp) then
            l = -huge(1.0_dp)
            return
        else if (x >= 1.0_dp) then
            l = 0.0_dp
            return
        end if
        lbt = log_gamma(a + b) - log_gamma(a) - log_gamma(b) + a*log(x) + b*log(1.0_dp - x)
        if (x < (a + 1.0_dp)/(a + b + 2.0_dp)) then
            l = lbt + log(betacf(a, b, x)) - log(a)
        else
            l = log(max(1.0_dp - exp(lbt + log(betacf(b, a, 1.0_dp - x)) - log(b)), tiny(1.0_dp)))
        end if
    end function log_betai

    !> log of the F(d1, d2) survival function at f.
    pure function f_logsf(f, d1, d2) result(l)
        real(dp), intent(in) :: f, d1, d2
        real(dp) :: l
        if (f <= 0.0_dp) then
            l = 0.0_dp
        else
            l = log_betai(0.5_dp*d2, 0.5_dp*d1, d2/(d2 + d1*f))
        end if
    end function f_logsf

end module sk_tails
