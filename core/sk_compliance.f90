!> Compliance matrix from m >= 6 experiments and its statistics
!> (Pashkevich et al. 2009, eqs. 1-3 and section 4.6).
!>
!> Experiment j applies the wrench W_j = (F, M) at the reference point and
!> gives the deflection X_j = (t, phi) with covariance S_j (from the field
!> fit, eq. 20). The compliance k solves k W = X (eq. 2): k = X W^+, which for
!> six axis-aligned loads is one column per experiment (eq. 3).
module sk_compliance
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_linalg, only: pinv, inverse, all_finite
    implicit none
    private
    public :: compliance_from_experiments, normal_quantile

contains

    !> Two-sided standard normal quantile: z with P(|Z| <= z) = level.
    !> Acklam's rational approximation refined by one Halley step on erfc.
    function normal_quantile(level) result(z)
        real(dp), intent(in) :: level
        real(dp) :: z
        real(dp), parameter :: a(6) = [-3.969683028665376e+01_dp, 2.209460984245205e+02_dp, &
            -2.759285104469687e+02_dp, 1.383577518672690e+02_dp, -3.066479806614716e+01_dp, &
            2.506628277459239e+00_dp]
        real(dp), parameter :: b(5) = [-5.447609879822406e+01_dp, 1.615858368580409e+02_dp, &
            -1.556989798598866e+02_dp, 6.680131188771972e+01_dp, -1.328068155288572e+01_dp]
        real(dp), parameter :: c(6) = [-7.784894002430293e-03_dp, -3.223964580411365e-01_dp, &
            -2.400758277161838e+00_dp, -2.549732539343734e+00_dp, 4.374664141464968e+00_dp, &
            2.938163982698783e+00_dp]
        real(dp), parameter :: d(4) = [7.784695709041462e-03_dp, 3.224671290700398e-01_dp, &
            2.445134137142996e+00_dp, 3.754408661907416e+00_dp]
        real(dp) :: p, q, r, e, u
        p = 0.5_dp*(1.0_dp + level)       ! upper quantile of the one-sided law
        if (p < 0.97575_dp) then
            q = p - 0.5_dp
            r = q*q
            z = (((((a(1)*r + a(2))*r + a(3))*r + a(4))*r + a(5))*r + a(6))*q / &
                (((((b(1)*r + b(2))*r + b(3))*r + b(4))*r + b(5))*r + 1.0_dp)
        else
            q = sqrt(-2.0_dp*log(1.0_dp - p))
            z = -(((((c(1)*q + c(2))*q + c(3))*q + c(4))*q + c(5))*q + c(6)) / &
                ((((d(1)*q + d(2))*q + d(3))*q + d(4))*q + 1.0_dp)
        end if
        e = 0.5_dp*erfc(-z/sqrt(2.0_dp)) - p
        u = e*sqrt(2.0_dp*3.141592653589793_dp)*exp(z*z/2.0_dp)
        z = z - u/(1.0_dp + z*u/2.0_dp)
    end function normal_quantile

    !> k[6,6] = X W^+ with element standard deviations kstd[6,6], the
    !> confidence half-widths ci = z kstd at the two-sided `confidence`
    !> level, and the significance mask (element != 0 when |k| > ci).
    !> symmetrize: return (k + k^T)/2 (std combined accordingly);
    !> asym: max over i<j of |k_ij - k_ji| / sqrt(|k_ii k_jj|) of the raw k.
    !> kstiff = k^-1 when it exists (stiff_info = 0), else stiff_info =
    !> sk_err_singular and kstiff = 0.
    subroutine compliance_from_experiments(w, x, covx, confidence, symmetrize, &
            k, kstd, ci, signif, kstiff, asym, z, stiff_info, info)
        real(dp), intent(in) :: w(:, :)        !> wrenches W[6,m]
        real(dp), intent(in) :: x(:, :)        !> deflections X[6,m]
        real(dp), intent(in) :: covx(:, :, :)  !> covariances S[6,6,m]
        real(dp), intent(in) :: confidence     !> in (0, 1)
        logical, intent(in) :: symmetrize
        real(dp), intent(out) :: k(6, 6), kstd(6, 6), ci(6, 6), kstiff(6, 6), asym, z
        logical, intent(out) :: signif(6, 6)
        integer(ip), intent(out) :: stiff_info, info
        real(dp), allocatable :: wp(:, :)
        real(dp) :: var(6, 6), vs(6, 6), scale
        integer(ip) :: rank
        integer :: m, j, a, bb

        k = 0.0_dp; kstd = 0.0_dp; ci = 0.0_dp; kstiff = 0.0_dp
        signif = .false.; asym = 0.0_dp; z = 0.0_dp
        stiff_info = sk_ok
        m = size(w, 2)
        if (size(w, 1) /= 6 .or. any(shape(x) /= [6, m]) .or. any(shape(covx) /= [6, 6, m])) then
            info = sk_err_size
            return
        end if
        if (m < 6) then
            info = sk_err_too_few
            return
        end if
        if (.not. (all_finite(w) .and. all_finite(x) .and. all_finite(covx))) then
            info = sk_err_nonfinite
            return
        end if
        if (.not. (confidence > 0.0_dp .and. confidence < 1.0_dp)) then
            info = sk_err_argument
            return
        end if
        allocate(wp(m, 6))
        call pinv(w, wp, 1.0e-12_dp, rank, info)
        if (info /= sk_ok) return
        if (rank < 6) then
            info = sk_err_singular       ! the wrenches do not span R^6
            return
        end if
        k = matmul(x, wp)                                 ! eq. 2 (eq. 3 if W diagonal)
        var = 0.0_dp
        do j = 1, m                                       ! independent experiments
            do bb = 1, 6
                do a = 1, 6
                    var(a, bb) = var(a, bb) + wp(j, bb)**2*covx(a, a, j)
                end do
            end do
        end do
        do bb = 1, 6
            do a = bb + 1, 6
                scale = sqrt(abs(k(a, a)*k(bb, bb)))
                if (scale > 0.0_dp) asym = max(asym, abs(k(a, bb) - k(bb, a))/scale)
            end do
        end do
        if (symmetrize) then
            k = 0.5_dp*(k + transpose(k))
            ! off-diagonal k_ab and k_ba come from different columns
            ! (independent); the diagonal keeps its own variance
            vs = 0.25_dp*(var + transpose(var))
            do a = 1, 6
                vs(a, a) = var(a, a)
            end do
            var = vs
        end if
        kstd = sqrt(var)
        z = normal_quantile(confidence)
        ci = z*kstd
        signif = abs(k) > ci
        call inverse(k, kstiff, stiff_info)
        if (stiff_info /= sk_ok) kstiff = 0.0_dp
        if (.not. all_finite(kstiff)) then
            kstiff = 0.0_dp
            stiff_info = sk_err_singular
        end if
        info = sk_ok
        if (.not. (all_finite(k) .and. all_finite(kstd))) info = sk_err_overflow
    end subroutine compliance_from_experiments

end module sk_compliance
