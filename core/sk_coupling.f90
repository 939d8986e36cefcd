!> Distributing coupling of a reference point to a face.
!>
!> CalculiX's *COUPLING + *DISTRIBUTING spreads a wrench (F, M) given at a
!> reference point p0 over the nodes of an element-face surface with the
!> nodal weights w_i = integral of the face shape function N_i over the face
!> (for quadratic triangles: 0 at the corners, A/3 at each mid-side node),
!> as the forces of a rigid-body-like traction (measured against ccx 2.20):
!>
!>   c = sum w_i x_i / W,  r_i = x_i - c,  I = sum w_i (|r_i|^2 E - r_i r_i^T)
!>   f_i = w_i F / W + w_i (I^-1 M_c) x r_i,   M_c = M + (p0 - c) x F
!>
!> which has resultant F and moment M about p0. The same matrix G maps the
!> node displacements back to the work-conjugate motion of the reference
!> point, x_ref = G^T u (virtual work: w . x_ref = sum f_i . u_i).
module sk_coupling
    use sk_kinds, only: dp, ip
    use sk_errors
    use sk_rotation, only: cross
    use sk_linalg, only: inverse, all_finite, eye
    implicit none
    private
    public :: face_weights, distributing_loads, work_conjugate

contains

    !> Nodal weights w[nn] (integrals of the face shape functions) of the
    !> faces conn[npf,nfaces] (npf = 3: linear triangle; 6: quadratic
    !> triangle, corners then mid-sides 1-2, 2-3, 3-1) over nodes x[3,nn];
    !> area = total area. Six-point Gauss rule (exact to degree 4) on the
    !> isoparametric face, so curved quadratic faces are integrated too.
    !> Quadrilaterals (npf = 4, 8: corners, then mid-sides 1-2, 2-3, 3-4, 4-1):
    !> see quad_weights.
    subroutine face_weights(x, conn, w, area, info)
        real(dp), intent(in) :: x(:, :)
        integer(ip), intent(in) :: conn(:, :)
        real(dp), intent(out) :: w(:), area
        integer(ip), intent(out) :: info
        real(dp), parameter :: a1 = 0.445948490915965_dp, b1 = 0.108103018168070_dp, &
            a2 = 0.091576213509771_dp, b2 = 0.816847572980459_dp, &
            w1 = 0.223381589678011_dp/2, w2 = 0.109951743655322_dp/2
        real(dp), parameter :: qs(6) = [a1, a1, b1, a2, a2, b2], qt(6) = [a1, b1, a1, a2, b2, a2], &
            qw(6) = [w1, w1, w1, w2, w2, w2]
        real(dp) :: nsh(6), ds(6), dt(6), p(3, 6), js(3), jt(3), jac, s, t, l
        integer :: f, q, npf, k

        w = 0.0_dp
        area = 0.0_dp
        npf = size(conn, 1)
        if (npf == 4 .or. npf == 8) then
            call quad_weights(x, conn, w, area, info)
            return
        end if
        call check_faces(x, conn, size(w), .not. (npf /= 3 .and. npf /= 6), info)
        if (info /= sk_ok) return
        do f = 1, size(conn, 2)
            do k = 1, npf
                p(:, k) = x(:, conn(k, f))
            end do
            do q = 1, 6
                s = qs(q)
                t = qt(q)
                l = 1.0_dp - s - t
                if (npf == 3) then
                    nsh(1:3) = [l, s, t]
                    ds(1:3) = [-1.0_dp, 1.0_dp, 0.0_dp]
                    dt(1:3) = [-1.0_dp, 0.0_dp, 1.0_dp]
                else
                    nsh = [l*(2*l - 1), s*(2*s - 1), t*(2*t - 1), 4*l*s, 4*s*t, 4*t*l]
                    ds = [-(4*l - 1), 4*s - 1, 0.0_dp, 4*(l - s), 4*t, -4*t]
                    dt = [-(4*l - 1), 0.0_dp, 4*t - 1, -4*s, 4*s, 4*(l - t)]
                end if
                js = matmul(p(:, 1:npf), ds(1:npf))
                jt = matmul(p(:, 1:npf), dt(1:npf))
                jac = norm2(cross(js, jt))
                do k = 1, npf
                    w(conn(k, f)) = w(conn(k, f)) + qw(q)*jac*nsh(k)
                end do
                area = area + qw(q)*jac
            end do
        end do
        if (.not. area > 0.0_dp) then
            info = sk_err_degenerate
            return
        end if
        ! quadratic corners integrate to zero: drop the round-off (either sign)
        where (abs(w) <= 1.0e-12_dp*maxval(abs(w))) w = 0.0_dp
        info = sk_ok
    end subroutine face_weights

    !> The checks both face rules share: x[3,nn], w[nn], a known face kind
    !> (kind_ok), at least one face, node numbers in 1..nn, finite nodes.
    subroutine check_faces(x, conn, nw, kind_ok, info)
        real(dp), intent(in) :: x(:, :)
        integer(ip), intent(in) :: conn(:, :)
        integer, intent(in) :: nw
        logical, intent(in) :: kind_ok
        integer(ip), intent(out) :: info
        info = sk_err_size
        if (size(x, 1) /= 3 .or. nw /= size(x, 2) .or. .not. kind_ok) return
        info = sk_err_too_few
        if (size(conn, 2) < 1) return
        info = sk_err_argument
        if (any(conn < 1) .or. any(conn > size(x, 2))) return
        info = sk_err_nonfinite
        if (.not. all_finite(x)) return
        info = sk_ok
    end subroutine check_faces

    !> Weights of quadrilateral faces (hexahedra), 3 x 3 Gauss points on the
    !> isoparametric face: the integrals of the shape functions, bilinear
    !> (npf = 4) or serendipity (npf = 8: negative at the corners, -A/12 on
    !> a flat face, and A/3 at the mid-sides: the consistent loads of a
    !> uniform traction; HRZ-lumped positive weights were tried and make the
    !> C3D20R beam's k11 1.9 % too compliant, the corners punched).
    subroutine quad_weights(x, conn, w, area, info)
        real(dp), intent(in) :: x(:, :)
        integer(ip), intent(in) :: conn(:, :)
        real(dp), intent(out) :: w(:), area
        integer(ip), intent(out) :: info
        real(dp), parameter :: g3 = 0.774596669241483_dp
        real(dp), parameter :: gp(3) = [-g3, 0.0_dp, g3], gw(3) = [5.0_dp/9.0_dp, 8.0_dp/9.0_dp, 5.0_dp/9.0_dp]
        real(dp), parameter :: xi(8) = [-1.0_dp, 1.0_dp, 1.0_dp, -1.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, -1.0_dp], &
            eta(8) = [-1.0_dp, -1.0_dp, 1.0_dp, 1.0_dp, -1.0_dp, 0.0_dp, 1.0_dp, 0.0_dp]
        real(dp) :: nsh(8), ds(8), dt(8), p(3, 8), js(3), jt(3), jac, s, t, m(8), af, wq
        integer :: f, a, b, k, npf

        w = 0.0_dp
        area = 0.0_dp
        npf = size(conn, 1)
        call check_faces(x, conn, size(w), .not. (npf /= 4 .and. npf /= 8), info)
        if (info /= sk_ok) return
        do f = 1, size(conn, 2)
            do k = 1, npf
                p(:, k) = x(:, conn(k, f))
            end do
            m = 0.0_dp
            af = 0.0_dp
            do a = 1, 3
                do b = 1, 3
                    s = gp(a)
                    t = gp(b)
                    wq = gw(a)*gw(b)
                    if (npf == 4) then
                        do k = 1, 4
                            nsh(k) = 0.25_dp*(1 + s*xi(k))*(1 + t*eta(k))
                            ds(k) = 0.25_dp*xi(k)*(1 + t*eta(k))
                            dt(k) = 0.25_dp*eta(k)*(1 + s*xi(k))
                        end do
                    else
                        do k = 1, 4
                            nsh(k) = 0.25_dp*(1 + s*xi(k))*(1 + t*eta(k))*(s*xi(k) + t*eta(k) - 1)
                            ds(k) = 0.25_dp*xi(k)*(1 + t*eta(k))*(2*s*xi(k) + t*eta(k))
                            dt(k) = 0.25_dp*eta(k)*(1 + s*xi(k))*(s*xi(k) + 2*t*eta(k))
                        end do
                        do k = 5, 7, 2  ! mid-sides on eta = -1, +1 (xi = 0)
                            nsh(k) = 0.5_dp*(1 - s*s)*(1 + t*eta(k))
                            ds(k) = -s*(1 + t*eta(k))
                            dt(k) = 0.5_dp*(1 - s*s)*eta(k)
                        end do
                        do k = 6, 8, 2  ! mid-sides on xi = +1, -1 (eta = 0)
                            nsh(k) = 0.5_dp*(1 + s*xi(k))*(1 - t*t)
                            ds(k) = 0.5_dp*xi(k)*(1 - t*t)
                            dt(k) = -t*(1 + s*xi(k))
                        end do
                    end if
                    js = matmul(p(:, 1:npf), ds(1:npf))
                    jt = matmul(p(:, 1:npf), dt(1:npf))
                    jac = norm2(cross(js, jt))
                    af = af + wq*jac
                    m(1:npf) = m(1:npf) + wq*jac*nsh(1:npf)
                end do
            end do
            do k = 1, npf
                w(conn(k, f)) = w(conn(k, f)) + m(k)
            end do
            area = area + af
        end do
        if (.not. area > 0.0_dp) then
            info = sk_err_degenerate
            return
        end if
        info = sk_ok
    end subroutine quad_weights

    !> Nodal forces g[3,nf,6] of the six unit wrenches (Fx, Fy, Fz, Mx, My,
    !> Mz at p0) spread over nodes xf[3,nf] with weights w[nf] (see module;
    !> a serendipity face's corners weigh < 0, the sum must be > 0).
    !> Nodes of zero weight get no force. sk_err_degenerate when the weighted
    !> nodes are collinear (the moment cannot be spread).
    subroutine distributing_loads(xf, w, p0, g, info)
        real(dp), intent(in) :: xf(:, :), w(:), p0(3)
        real(dp), intent(out) :: g(:, :, :)
        integer(ip), intent(out) :: info
        real(dp) :: wt, c(3), r(3), inert(3, 3), iinv(3, 3), mc(3), a(3), e(3), f(3), mom(3)
        integer :: i, j, nf

        g = 0.0_dp
        nf = size(xf, 2)
        if (size(xf, 1) /= 3 .or. size(w) /= nf .or. any(shape(g) /= [3, nf, 6])) then
            info = sk_err_size
            return
        end if
        if (.not. (all_finite(xf) .and. all_finite(w) .and. all_finite(p0))) then
            info = sk_err_nonfinite
            return
        end if
        wt = sum(w)
        if (count(w /= 0.0_dp) < 3 .or. .not. wt > 0.0_dp) then
            info = sk_err_too_few
            return
        end if
        c = matmul(xf, w)/wt
        inert = 0.0_dp
        do i = 1, nf
            r = xf(:, i) - c
            inert = inert + w(i)*(dot_product(r, r)*eye(3) - spread(r, 2, 3)*spread(r, 1, 3))
        end do
        call inverse(inert, iinv, info)
        if (info /= sk_ok .or. minval([(inert(i, i), i=1, 3)]) <= 1.0e-12_dp*maxval(abs(inert))) then
            info = sk_err_degenerate
            return
        end if
        do j = 1, 6
            e = 0.0_dp
            f = 0.0_dp
            mom = 0.0_dp
            if (j <= 3) then
                f(j) = 1.0_dp
            else
                mom(j - 3) = 1.0_dp
            end if
            mc = mom + cross(p0 - c, f)
            a = matmul(iinv, mc)
            do i = 1, nf
                r = xf(:, i) - c
                g(:, i, j) = w(i)*f/wt + w(i)*cross(a, r)
            end do
        end do
        info = sk_ok
    end subroutine distributing_loads

    !> Work-conjugate reference motion xref[6,m] = G^T u of m displacement
    !> fields u[3,nf,m] of the coupled nodes, g[3,nf,6] from distributing_loads.
    subroutine work_conjugate(g, u, xref, info)
        real(dp), intent(in) :: g(:, :, :), u(:, :, :)
        real(dp), intent(out) :: xref(:, :)
        integer(ip), intent(out) :: info
        integer :: j, k
        xref = 0.0_dp
        if (size(g, 1) /= 3 .or. size(g, 3) /= 6 .or. size(u, 1) /= 3 .or. size(u, 2) /= size(g, 2) &
            .or. size(xref, 1) /= 6 .or. size(xref, 2) /= size(u, 3)) then
            info = sk_err_size
            return
        end if
        do k = 1, size(u, 3)
            do j = 1, 6
                xref(j, k) = sum(g(:, :, j)*u(:, :, k))
            end do
        end do
        info = sk_ok
    end subroutine work_conjugate

end module sk_coupling
