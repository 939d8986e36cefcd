!> Minimal check harness shared by the Fortran unit tests: `expect`
!> counts and prints failed checks, `finish` reports and stops with a
!> non-zero status when any failed (meson test reads the exit status).
module sk_testing
    implicit none (type, external)
    private
    public :: expect, finish

    integer, save :: failures = 0

contains

    subroutine expect(ok, what)
        logical, intent(in) :: ok
        character(*), intent(in) :: what
        if (.not. ok) then
            failures = failures + 1
            print '(a, a)', 'FAILED: ', what
        end if
    end subroutine expect

    subroutine finish(suite)
        character(*), intent(in) :: suite
        if (failures > 0) then
            print '(i0, a, a)', failures, ' check(s) failed in ', suite
            error stop 1
        end if
        print '(a, a, a)', 'all ', suite, ' checks passed'
    end subroutine finish

end module sk_testing
