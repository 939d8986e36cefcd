!> Status codes returned as integer `info` by every entry point of the core.
!>
!> 0 is success. Positive codes are shared by all routines and mapped to
!> Python exceptions (with the routine's name) in stiffkit/_errors.py; keep
!> the two tables in step.
module sk_errors
    use sk_kinds, only: ip
    implicit none
    private

    integer(ip), parameter, public :: sk_ok = 0
    !> array sizes too small or inconsistent (e.g. fewer than 3 nodes)
    integer(ip), parameter, public :: sk_err_size = 1
    !> NaN or Inf in the input
    integer(ip), parameter, public :: sk_err_nonfinite = 2
    !> geometry does not determine the answer (collinear/coincident nodes)
    integer(ip), parameter, public :: sk_err_degenerate = 3
    !> LAPACK reported an illegal argument or a failure to converge
    integer(ip), parameter, public :: sk_err_lapack = 4
    !> a matrix that must be inverted is singular
    integer(ip), parameter, public :: sk_err_singular = 5
    !> an argument value is out of its range (method code, fraction, ...)
    integer(ip), parameter, public :: sk_err_argument = 6
    !> an iteration did not converge
    integer(ip), parameter, public :: sk_err_noconv = 7
    !> too few data left (e.g. after trimming) for the requested estimate
    integer(ip), parameter, public :: sk_err_too_few = 8
    !> a compliance or stiffness has a negative eigenvalue (or a joint a
    !> negative compliance): not a physical spring
    integer(ip), parameter, public :: sk_err_indefinite = 9
    !> a result is not finite although the input was: the input magnitudes
    !> are beyond double precision (usually a unit slip)
    integer(ip), parameter, public :: sk_err_overflow = 10
    !> a file (FEA results, matrices) is missing, unreadable or malformed
    integer(ip), parameter, public :: sk_err_io = 31
    !> out of memory (sparse factorisation)
    integer(ip), parameter, public :: sk_err_nomem = 32
end module sk_errors
