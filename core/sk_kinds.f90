!> Kinds shared by the whole core.
!>
!> f2py maps `real(dp)` with `dp` a module parameter to C float (see
!> docs/toolchain.md), so every routine that f2py sees uses the
!> iso_c_binding kinds directly; inside the core we use `dp`/`ip`, which are
!> the same kinds.
module sk_kinds
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    implicit none
    private
    public :: dp, ip, pi

    integer, parameter :: dp = c_double
    integer, parameter :: ip = c_int
    real(dp), parameter :: pi = 3.141592653589793238462643383279502884_dp
end module sk_kinds
