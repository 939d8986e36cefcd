!> Kinematic trees of virtual joints ("screws"): forward kinematics (the
!> one implementation of the core; sk_chain's serial chains use it),
!> generalised gravity forces, the elastostatic equilibrium under the
!> robot's own weight and payloads, and analytic total derivatives of
!> marker points and frames through that equilibrium. The calibration on
!> absolute (tracker) data and the compensation built on them are in
!> sk_tree_solve; the entry points f2py wraps in sk_api_tree.
!>
!> Files (this module re-exports their public names, so a caller says
!> `use sk_tree`): sk_tree_model (types, kinematics, set-up),
!> sk_tree_grav (gravity parameters), sk_tree_fold (folded models),
!> sk_laws (the effect laws), sk_tree_equil (loads, equilibrium,
!> sensitivities), sk_tree_jac (observations, Jacobians, batches),
!> sk_tree_check (argument checks).
!>
!> Virtual-joint modelling in the style of Klimchik et al. (VJM, eqs. 1-3):
!> every elastic effect is a virtual joint whose deflection is driven by
!> its generalised force; here the forces are the robot's weight, so the
!> deflected pose is a static equilibrium instead of eq. 3's linear map.
!> Units are SI throughout (m, rad, kg, N, N m, m/s^2).
!>
!> Tree. nv virtual joints v = 1..nv in topological order: parent(v) < v,
!> 0 = the root (base_link) frame. Joint v has a fixed transform from its
!> parent's frame after the parent's motion to its own frame before
!> motion, rot[3,3,v] and pos[3,v], a type (0 fixed, 1 revolute, 2
!> prismatic) and a unit axis[3,v] in its own frame:
!>   T_v(after) = T_parent(v)(after) * T(pos_v, rot_v) * Motion(axis_v, val_v)
!> (the URDF convention T_parent * T(origin) * Rot(axis, q)). "Frame v" is
!> the frame after the motion unless said otherwise.
!>
!> Values. val_v = qcoef_v q(qcol_v) + qconst_v          (qcol 0: no joint)
!>                 + sum_k gcoef_k theta(gpar_k)  over the geometric
!>                   entries k of joint v (sparse (gvj, gpar, gcoef) list)
!>                 + delta_e  for the elastic coordinate e on joint v.
!> A <mimic> follower takes its leader's column with multiplier and offset;
!> a joint offset of the leader is a geometric entry of both.
!>
!> Elastic blocks k = 1..nk (ktype): 1 linear 1-dof, delta = c w;
!> 2 cubic, delta = c w + c3 w^3; 3 dead zone, delta = c w + b tanh(w/w0)
!> (w0 = kw0(k) fixed); 4 linear 6-dof spring, delta(6) = C w(6), C
!> symmetric from 21 parameters, upper triangle row by row (sym_index).
!> A block's coordinates ride on kvj(1:n,k) (n = 1 or 6); its parameters
!> are theta(kpar(j,k)) in the order above (kpar = 0: the value 0, e.g.
!> the zeros of a beam template). Elastic coordinates are numbered block
!> after block. Each virtual joint carries at most one, never a fixed one.
!>
!> Gravity. nb bodies: mass bmass(b) at the centre bcom(:,b) (frame
!> bvj(b); 0 = base, no effect) in gravity grav (base axes), and payload
!> wrenches (f, m) at a frame origin, base axes. The generalised force of
!> virtual joint s is w_s = sum over loads i beyond s of F_i . dc_i/dval_s
!> (+ m_i . u_s for payload moments), i.e. minus the derivative of the
!> potential: revolute (unit axis u through o)  w = u . ((c - o) x F),
!> prismatic w = u . F. They are evaluated from per-subtree aggregates
!> accumulated leaf to root: total force F_v, first moment
!> S_v = sum c_i F_i^T and payload moment M_v, so that
!>   w_s = u_s . (vee(S_s) + M_s - o_s x F_s),  vee(S) = sum c_i x F_i.
!>
!> Equilibrium. delta = law(w(delta)) by fixed-point iteration (VJM
!> deflection eq. 3 evaluated at the deflected pose), stopped when the
!> update moves no point by more than etol: sum_e |d delta_e| * L
!> (revolute; L = lscale, a bound on the lever arms) or |d delta_e|
!> (prismatic). For linear laws this is the stationary point of
!> 1/2 delta^T C^-1 delta + potential of the weights. eqit = 0: rigid
!> (delta = 0); 1: first order (w at delta = 0, the points at the
!> deflected pose); >= 2: full equilibrium with at most eqit iterations.
!>
!> Derivatives. With the generalised-force derivatives G = dw/dval
!> (G(s,a) from the aggregates of the distal one's subtree, p the proximal
!> of the two, d the distal; zero unless one is an ancestor of the other):
!>   p, d revolute:  u_p^T S_d u_d - (u_p.o_d)(F_d.u_d) - (u_p.u_d)(tr S_d - F_d.o_d)
!>                   (+ M_d . (u_p x u_d) when the derivative is of w_d)
!>   p revolute, d prismatic:  F_d . (u_p x u_d);   p prismatic: 0,
!> i.e. F . d2c/dval_p dval_d with d2c = u_p x (u_d x (c - o_d)), and
!> D = dlaw/dw (block diagonal), the sensitivity of the deflections to a
!> driver xi (a parameter or a joint coordinate) solves
!>   (I - D G_ee) Z = D G_e,xi + dlaw/dparams
!> (first order: I instead of I - D G_ee, everything at delta = 0), and
!> dx/dxi = dx/dxi|direct + dx/ddelta Z.
!>
!> Gravity parameters (sk_tree_grav). Entries p = 1..nbp, bpar[3,nbp] =
!> (body b, slot s, theta index t): s = 1 a mass factor (mass = bmass(b)
!> times the product of its factors), s = 2..4 an offset of the centre
!> along x, y, z of the body's frame (m; centre = bcom(:,b) + the sum of
!> its offsets). One index on several bodies is a subtree's factor; a body
!> may carry its own factor and its subtrees' (they multiply). They move
!> no point directly: they drive the deflections through dw/dtheta (the
!> right-hand side of the sensitivity). A folded model (model_fold) takes
!> them at theta into its masses and centres.
!>
!> Markers and tracker. Marker j rides on frame mvj(j) at the point
!> theta(mpar(:,j)) of that frame. The tracker pose is
!>   T_tracker = Trans(t) * rref * Rx(a1) Ry(a2) Rz(a3),
!> t = theta(tpar(1:3)), (a1, a2, a3) = theta(tpar(4:6)), rref a reference
!> rotation (the fit re-centres it, so it never meets gimbal lock); a
!> predicted measurement is y = T_tracker * T_frame * p (klimchik's
!> observation equation, eq. 6, with the geometric and elastic model in
!> place of eq. 4's linear map; the fit minimises eq. 7).
!>
!> Parameter roles. theta is one vector; a parameter's role is where its
!> index appears (tpar, mpar, gpar, kpar), so one parameter may act in
!> several places (a mimic leader's offset) and no separate kind code can
!> disagree with the model.
!>
!> 6-dof springs. Their six coordinates are screws (3 prismatic along x, y,
!> z, then revolute about x, y, z of the spring frame); the generalised
!> forces of those screws are the transmitted wrench (f, m about the
!> spring origin, spring axes) at zero deflection, and differ from it at
!> second order in the deflection: delta = C w is the equilibrium of the
!> spring energy 1/2 delta^T C^-1 delta in these coordinates.
!>
!> Cost. Aggregates make the forces O(nv) and G O(pairs) per posture;
!> tree_frames caches the rotation of joints whose value did not change
!> (frame errors); evaluate takes the deflection part of the Jacobian by
!> the adjoint (rows of J_delta (I - D G)^-1: a few rows, many
!> parameters); the frame Jacobian and compensation run on the model with
!> its constant joints folded into their children (model_fold). The fixed
!> point converges when D G is a contraction, as for any real robot
!> (deflections of mm, D G ~ 1e-2); a compliance large enough to approach
!> buckling is reported as not converged (eqinfo), not solved.
module sk_tree
    use sk_linalg, only: group_by
    use sk_tree_check, only: is_rotation, vj_fixed, vj_revolute, vj_prismatic
    use sk_laws, only: law_linear, law_cubic, law_deadzone, law_spring6
    use sk_tree_model, only: frame_step, tree_frames, tree_model, tree_state, tree_problem, model_setup, &
        problem_setup, state_init, model_body_params, body_effective, obs_position, obs_deflection, obs_rotation
    use sk_tree_fold, only: model_fold, fold_for_frames
    use sk_tree_equil, only: load_state, deflected_frames, apply_laws, posture_values, deflection_change, &
        solve_posture, elastic_sensitivity
    use sk_tree_jac, only: tracker_pose, point_jacobian, deflection_jacobian, frame_jacobian, q_drivers, &
        poses_batch, evaluate, frame_jacobian_batch
    implicit none
    private
    public :: frame_step, tree_frames
    public :: tree_model, tree_state, tree_problem
    public :: model_setup, problem_setup, state_init, solve_posture
    public :: elastic_sensitivity, tracker_pose, point_jacobian, deflection_jacobian, frame_jacobian
    public :: obs_position, obs_deflection, obs_rotation
    public :: poses_batch, evaluate, frame_jacobian_batch
    public :: is_rotation, group_by, q_drivers, posture_values, deflected_frames, load_state, apply_laws
    public :: deflection_change, model_fold, fold_for_frames
    public :: model_body_params, body_effective

    public :: vj_fixed, vj_revolute, vj_prismatic, law_linear, law_cubic, law_deadzone, law_spring6
end module sk_tree
