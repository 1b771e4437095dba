"""Pinocchio 4.1's own constraint solvers as an independent oracle for frictional contact.

The problem: given a Delassus matrix G (m, m), a drift g (m,) and a list of blocks, find the
impulses lam (m,) such that, with the constraint velocities c = (G + diag(compliance)) lam + g,
every block satisfies its law:

- ("cone", first_row, mu): 3 rows (t1, t2, n), Coulomb's law with maximum dissipation written as
  de Saxce's NCP: lam in K = {|lam_t| <= mu lam_n}, c + s in K* = {mu |u_t| <= u_n} with the
  shift s = (0, 0, mu |c_t|), and <lam, c + s> = 0;
- ("unilateral", row, _): lam >= 0, c >= 0, lam c = 0 (a joint limit);
- ("box", row, b): |lam| <= b, and c >= 0 where lam = -b, c <= 0 where lam = b, c = 0 strictly
  inside (dry joint friction);
- ("equality", row, _): c = 0, lam free (a bilateral row).

`solve_with_pinocchio` hands exactly this problem to pin.ADMMConstraintSolver or
pin.PGSConstraintSolver; `ncp_residuals` measures, in numpy alone, how far any lam is from
solving it. `point_contact_jacobian` and `relative_point_contact_jacobian` build contact
jacobians with Pinocchio's kinematics.

How the problem reaches Pinocchio (4.1's Python API):

- G goes in as ``pin.DelassusOperatorDense(G)``; the compliance as
  ``delassus.updateCompliance(vector)``: the operator applies G + diag(compliance) to a vector
  and keeps the solver's own proximal damping apart. The solvers write that damping into the
  operator, so it is built afresh for every solve (a PGS solve reads the damped matrix).
- The sets come from constraint models, stacked in a ``pin.StdVec_ConstraintModel`` with their
  datas in a ``pin.StdVec_ConstraintData`` (``models[i].createData()``). The solvers use the
  models only for their sizes and sets, never their kinematics, so the models are built on a
  throwaway one-joint model:
  a cone is a ``pin.PointContactConstraintModel(model, joint)`` with ``setFriction(mu)`` (set
  ``CoulombFrictionCone(mu)``, rows x, y, z with z the normal: our t1, t2, n);
  a unilateral row is a ``pin.JointLimitConstraintModel(model, [joint], [0], [inf])`` (one
  lower limit: set ``NonNegativeOrthantCone`` of size 1);
  a box row is a ``pin.JointFrictionConstraintModel(model, [joint], [-b], [b])`` (set
  ``BoxSet(-b*dt, b*dt)`` with the model's time step dt = 1, read into its data at createData);
  equality rows go three at a time into a ``pin.PointAnchorConstraintModel(model, joint)``
  (set ``FullSpaceCone`` of size 3), the last group padded with decoupled rows (G = the mean
  diagonal of G, g = 0) whose impulses are zero and dropped.
- ``solver.solve(delassus, g, models, datas, settings, result)`` returns the converged flag;
  the impulses are ``result.retrieveConstraintImpulses()`` (ADMM: its projected iterate y,
  inside the sets exactly).

What Pinocchio 4.1 cannot express, or handles differently:

- An equality row alone: the only unbounded sets are the 3-row (point anchor) and 6-row (frame
  anchor) full-space cones, hence the padding. A box with infinite bounds solves it too, but
  Pinocchio's box complementarity (max(c+ (lam - lb), c- (ub - lam))) is then inf, so ADMM stops
  on its relative test alone (small successive steps) and reports an infinite complementarity.
- ADMM solves the NCP (settings.solve_ncp = True, the default: de Saxce's shift is updated at
  each iteration from the previous dual iterate) or, with solve_ncp = False, the convex
  relaxation (CCP: c in K*, no shift, so a sliding contact also separates). PGS always iterates
  on the NCP (a projected Gauss-Seidel step per block: the normal impulse, then the tangential
  one projected onto the disk of radius mu lam_n); its solve_ncp only changes its statistics.
- A cone's friction must be >= 0 and its axes are fixed (x, y tangent, z normal): an
  anisotropic (elliptic) or a pyramidal cone is not available; nor is a negative compliance.
- With a singular G (more contact rows than the bodies' degrees of freedom) the impulses are
  not unique: ADMM and PGS may return different lam; compare the velocities c, the generalized
  impulses J^T lam or the residuals instead (the NCP being nonconvex, even c need not be
  unique, although it agreed to 1e-11 on a box resting on four corners).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin

KINDS = ("cone", "unilateral", "box", "equality")
_SIZE = {"cone": 3, "unilateral": 1, "box": 1, "equality": 1}


# ---------------------------------------------------------------------------------------------
# the problem


def _sorted_blocks(blocks, m):
    """The blocks sorted by first row, checked to cover rows 0..m-1 exactly once."""
    out = sorted(((str(k), int(r), p) for k, r, p in blocks), key=lambda b: b[1])
    row = 0
    for kind, first, param in out:
        if kind not in _SIZE:
            raise ValueError(f"unknown block kind {kind!r} (expected one of {KINDS})")
        if first != row:
            raise ValueError(f"blocks leave a gap or overlap at row {row} (block at {first})")
        if kind == "cone" and not float(param) >= 0.0:
            raise ValueError(f"a cone's friction coefficient must be >= 0, got {param}")
        if kind == "box" and not float(param) >= 0.0:
            raise ValueError(f"a box's bound must be >= 0, got {param}")
        row += _SIZE[kind]
    if row != m:
        raise ValueError(f"blocks cover {row} rows, the problem has {m}")
    return out


def _compliance_vector(compliance, m):
    comp = np.array(np.broadcast_to(np.asarray(compliance, float), (m,)))
    if np.any(comp < 0.0):
        raise ValueError("the compliance must be >= 0")
    return comp


def _problem_arrays(G, g, m):
    G = np.asarray(G, float)
    g = np.asarray(g, float).reshape(-1)
    if G.shape != (m, m) or g.shape != (m,):
        raise ValueError(f"G must be ({m}, {m}) and g ({m},), got {G.shape} and {g.shape}")
    return G, g


def _pinocchio_problem(blocks, m):
    """Pinocchio's constraint models for the blocks, in Pinocchio's stacking order.

    Returns (models, datas, rows, n_pad): models a pin.StdVec_ConstraintModel, datas the
    matching pin.StdVec_ConstraintData, rows the index array such that Pinocchio's row k is our
    row rows[k] (k < m), and n_pad the decoupled rows appended after them.
    """
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "carrier")
    model.appendBodyToJoint(joint, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    models = pin.StdVec_ConstraintModel()
    rows = []
    equality_rows = []
    for kind, first, param in _sorted_blocks(blocks, m):
        if kind == "cone":
            cmodel = pin.PointContactConstraintModel(model, joint)
            cmodel.setFriction(float(param))
            models.append(cmodel)
            rows.extend((first, first + 1, first + 2))
        elif kind == "unilateral":
            lower, upper = np.zeros(1), np.full(1, np.inf)
            models.append(pin.JointLimitConstraintModel(model, [joint], lower, upper))
            rows.append(first)
        elif kind == "box":
            b = float(param)
            models.append(
                pin.JointFrictionConstraintModel(model, [joint], np.full(1, -b), np.full(1, b))
            )
            rows.append(first)
        else:
            equality_rows.append(first)
    n_groups = -(-len(equality_rows) // 3)
    for _ in range(n_groups):
        models.append(pin.PointAnchorConstraintModel(model, joint))
    rows.extend(equality_rows)
    datas = pin.StdVec_ConstraintData()
    for cmodel in models:
        datas.append(cmodel.createData())
    n_pad = 3 * n_groups - len(equality_rows)
    return models, datas, np.asarray(rows, dtype=int), n_pad


def solve_with_pinocchio(
    G,
    g,
    blocks,
    solver="admm",
    tolerance=1e-12,
    max_iterations=10000,
    compliance=0.0,
    return_info=False,
):
    """Solve the contact problem of this module with Pinocchio's ADMM or PGS solver.

    G: (m, m) symmetric positive semi-definite Delassus matrix; g: (m,) drift; blocks: a list of
    (kind, first_row, parameter) covering the m rows once, kind "cone" (3 rows t1, t2, n,
    parameter mu), "unilateral", "box" (parameter the bound b) or "equality" (1 row each); see
    the module docstring for the laws. compliance: a float or an (m,) array added to G's
    diagonal (Pinocchio's DelassusOperatorDense.updateCompliance). solver: "admm"
    (pin.ADMMConstraintSolver, NCP mode) or "pgs" (pin.PGSConstraintSolver). tolerance: the
    solver's absolute and relative feasibility and complementarity tolerances (Pinocchio's own
    measures, not those of `ncp_residuals`); max_iterations: its iteration cap.

    Returns lam, the (m,) impulses, in our row order; with return_info=True, (lam, info), info
    a dict with "converged", "iterations" and Pinocchio's "primal_feasibility",
    "dual_feasibility" and "complementarity". Warns (RuntimeWarning) when the solver stops
    without converging.
    """
    G, g = _problem_arrays(G, g, len(np.asarray(g).reshape(-1)))
    m = g.size
    scale = float(np.abs(G).max()) if m else 0.0
    if np.abs(G - G.T).max(initial=0.0) > 1e-10 * scale:
        raise ValueError("G must be symmetric")
    comp = _compliance_vector(compliance, m)
    models, datas, rows, n_pad = _pinocchio_problem(blocks, m)
    size = m + n_pad
    G_pin = np.zeros((size, size))
    G_pin[:m, :m] = G[np.ix_(rows, rows)]
    pad_value = float(np.mean(np.diag(G))) if m else 1.0
    G_pin[m:, m:] = np.eye(n_pad) * (pad_value if pad_value > 0.0 else 1.0)
    G_pin = 0.5 * (G_pin + G_pin.T)  # within rounding of G_pin, checked above
    g_pin = np.zeros(size)
    g_pin[:m] = g[rows]
    comp_pin = np.zeros(size)
    comp_pin[:m] = comp[rows]

    if solver == "admm":
        settings = pin.ADMMSolverSettings()
        settings.solve_ncp = True
        make_solver, make_result = pin.ADMMConstraintSolver, pin.ADMMSolverResult
    elif solver == "pgs":
        settings = pin.PGSSolverSettings()
        make_solver, make_result = pin.PGSConstraintSolver, pin.PGSSolverResult
    else:
        raise ValueError(f"solver must be 'admm' or 'pgs', got {solver!r}")
    settings.absolute_feasibility_tol = tolerance
    settings.relative_feasibility_tol = tolerance
    settings.absolute_complementarity_tol = tolerance
    settings.relative_complementarity_tol = tolerance
    settings.max_iterations = int(max_iterations)

    delassus = pin.DelassusOperatorDense(G_pin)
    delassus.updateCompliance(comp_pin)
    result = make_result()
    converged = make_solver(size).solve(delassus, g_pin, models, datas, settings, result)
    lam_pin = np.asarray(result.retrieveConstraintImpulses(), float)
    lam = np.zeros(m)
    lam[rows] = lam_pin[:m]
    info = {
        "converged": converged,
        "iterations": int(result.iterations),
        "primal_feasibility": float(result.primal_feasibility),
        "dual_feasibility": float(result.dual_feasibility),
        "complementarity": float(result.complementarity),
    }
    if not converged:
        warnings.warn(
            f"pinocchio's {solver} solver stopped after {info['iterations']} iterations "
            f"without converging (primal {info['primal_feasibility']:.3g}, dual "
            f"{info['dual_feasibility']:.3g}, complementarity {info['complementarity']:.3g})",
            RuntimeWarning,
            stacklevel=2,
        )
    return (lam, info) if return_info else lam


# ---------------------------------------------------------------------------------------------
# residuals, in numpy alone


def _cone_distance(t, n, k):
    """Euclidean distance of (t, n) (t in R^2, n a scalar) from the cone {|t| <= k n}, k >= 0
    (k = inf: the half-space n >= 0)."""
    r = float(np.hypot(t[0], t[1]))
    if np.isinf(k):
        return max(0.0, -n)
    if r <= k * n:
        return 0.0
    if k * r <= -n:  # in the polar cone: the projection is the apex
        return float(np.hypot(r, n))
    return (r - k * n) / np.sqrt(1.0 + k * k)


def ncp_residuals(G, g, blocks, lam, compliance=0.0, box_tol=1e-9):
    """How far lam is from solving the contact problem of this module, in numpy alone.

    With c = (G + diag(compliance)) lam + g, per block:

    - cone (mu), s = (0, 0, mu |c_t|): "primal" the distance of lam_i from K = {|lam_t| <=
      mu lam_n}; "dual" the distance of c_i + s from K* = {mu |u_t| <= u_n}; "complementarity"
      |<lam_i, c_i + s>| / max(|lam_i|, 1e-12);
    - unilateral: primal max(0, -lam), dual max(0, -c), complementarity |lam c| / max(|lam|,
      1e-12);
    - box (b): primal max(0, |lam| - b); dual the velocity breaking the normal-cone condition:
      max(0, -c) where lam is at -b, max(0, c) at +b, |c| strictly inside, lam counting as at
      a bound within box_tol * max(b, 1) of it (so that rounding does not put it inside);
      complementarity max(c+ (lam + b), c- (b - lam)) / (2 b) with c+, c- the positive and
      negative parts of c: |c| at the wrong bound, c weighed by the distance from the right
      bound in between (0 when b = 0);
    - equality: primal 0, dual |c|, complementarity |lam c| / max(|lam|, 1e-12).

    Returns a dict: "primal" (impulse units), "dual" and "complementarity" (velocity units), the
    largest over the blocks, and "velocity" the vector c.
    """
    G, g = _problem_arrays(G, g, len(np.asarray(g).reshape(-1)))
    m = g.size
    lam = np.asarray(lam, float).reshape(-1)
    if lam.shape != (m,):
        raise ValueError(f"lam must be ({m},), got {lam.shape}")
    comp = _compliance_vector(compliance, m)
    c = G @ lam + comp * lam + g
    primal = dual = compl = 0.0
    for kind, first, param in _sorted_blocks(blocks, m):
        if kind == "cone":
            mu = float(param)
            li, ci = lam[first : first + 3], c[first : first + 3]
            u = ci + np.array([0.0, 0.0, mu * np.hypot(ci[0], ci[1])])
            primal = max(primal, _cone_distance(li[:2], li[2], mu))
            dual = max(dual, _cone_distance(u[:2], u[2], np.inf if mu == 0.0 else 1.0 / mu))
            compl = max(compl, abs(li @ u) / max(np.linalg.norm(li), 1e-12))
            continue
        li, ci = lam[first], c[first]
        if kind == "unilateral":
            p, d = max(0.0, -li), max(0.0, -ci)
            k = abs(li * ci) / max(abs(li), 1e-12)
        elif kind == "box":
            b = float(param)
            p = max(0.0, abs(li) - b)
            at = box_tol * max(b, 1.0)
            at_lower, at_upper = li <= -b + at, li >= b - at
            if at_lower and at_upper:  # b within tolerance of 0: any velocity is allowed
                d = 0.0
            elif at_lower:
                d = max(0.0, -ci)
            elif at_upper:
                d = max(0.0, ci)
            else:
                d = abs(ci)
            cp, cm = max(0.0, ci), max(0.0, -ci)
            k = max(cp * (li + b), cm * (b - li)) / (2.0 * b) if b > 0.0 else 0.0
            k = max(k, 0.0)
        else:
            p, d = 0.0, abs(ci)
            k = abs(li * ci) / max(abs(li), 1e-12)
        primal, dual, compl = max(primal, p), max(dual, d), max(compl, k)
    return {"primal": primal, "dual": dual, "complementarity": compl, "velocity": c}


# ---------------------------------------------------------------------------------------------
# contact jacobians with Pinocchio's kinematics


def point_contact_jacobian(model, data, q, joint_id, placement):
    """The (3, nv) jacobian of the velocity of a point rigidly attached to joint joint_id.

    placement: a pin.SE3 in the joint's frame (body-fixed): its translation is the point, its
    rotation's columns are the contact axes t1, t2, n expressed in the joint's frame. The rows
    are the point's velocity (in the world) expressed along t1, t2, n; joint 0 (the world)
    gives zeros. Computed with pin.computeJointJacobians (which also runs the forward
    kinematics of q into data) and the joint's LOCAL jacobian moved to the placement.

    This is minus the jacobian of pin.PointContactConstraintModel(model, joint_id, placement,
    0, oMc) with oMc the placement in the world, whose rows are the velocity of its second
    point (the world's) relative to its first.
    """
    pin.computeJointJacobians(model, data, np.asarray(q, float))
    if joint_id == 0:
        return np.zeros((3, model.nv))
    J_joint = pin.getJointJacobian(model, data, joint_id, pin.ReferenceFrame.LOCAL)
    return (placement.inverse().toActionMatrix() @ J_joint)[:3].copy()


def _world_point_jacobian(model, data, joint_id, point_world):
    """The (3, nv) jacobian, world axes, of the velocity of the material point of joint
    joint_id's body at point_world (data holds the joint jacobians)."""
    if joint_id == 0:
        return np.zeros((3, model.nv))
    J = pin.getJointJacobian(model, data, joint_id, pin.ReferenceFrame.WORLD)
    return J[:3] - pin.skew(np.asarray(point_world, float)) @ J[3:]


def relative_point_contact_jacobian(model, data, q, joint_a, joint_b, point_world, R_world_contact):
    """The (3, nv) jacobian J_b(x) - J_a(x) of the velocity of body b's material at the world
    point x relative to body a's material at x, rows along the columns (t1, t2, n) of
    R_world_contact (the contact frame's rotation in the world). Joint 0 is the world (zero
    jacobian). Runs pin.computeJointJacobians(model, data, q).

    Pinocchio's pin.PointContactConstraintModel(model, joint_a, aMc, joint_b, bMc), with aMc and
    bMc the contact frame (R_world_contact, x) seen from each joint, has this jacobian.
    """
    pin.computeJointJacobians(model, data, np.asarray(q, float))
    J = _world_point_jacobian(model, data, joint_b, point_world)
    J = J - _world_point_jacobian(model, data, joint_a, point_world)
    return np.asarray(R_world_contact, float).T @ J


# ---------------------------------------------------------------------------------------------
# self-check


def _random_spd(rng, n, cond=1e3):
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return Q @ np.diag(np.logspace(0.0, -np.log10(cond), n)) @ Q.T


def _sliding(mu, lam_n, c_t):
    """A sliding cone's (lam, c): lam_t opposes c_t at the cone's edge, c_n = 0."""
    c_t = np.asarray(c_t, float)
    lam_t = -mu * lam_n * c_t / np.linalg.norm(c_t)
    return np.r_[lam_t, lam_n], np.r_[c_t, 0.0]


def _cases(compliance):
    """The self-check's problems: name -> (G, g, blocks, the expected lam or None)."""
    rng = np.random.default_rng(7)
    k = 1.0 + compliance
    cases = {
        "(a) sliding": (
            np.eye(3),
            np.array([0.5, 0.0, -1.0]),
            [("cone", 0, 0.3)],
            np.array([-0.3, 0.0, 1.0]) / k,
        ),
        "(b) sticking": (
            np.eye(3),
            np.array([0.1, 0.0, -1.0]),
            [("cone", 0, 1.0)],
            np.array([-0.1, 0.0, 1.0]) / k,
        ),
    }
    G = _random_spd(rng, 12)
    g = rng.standard_normal(12)
    g[2::3] -= 1.0  # mostly pressing
    blocks = [("cone", 3 * i, rng.uniform(0.2, 1.0)) for i in range(4)]
    cases["(c) 4 contacts"] = (G, g, blocks, None)
    # mixed problems built from a known solution (lam, c): g = c - (G + compliance I) lam
    blocks = [
        ("unilateral", 0, None),
        ("cone", 1, 0.5),
        ("box", 4, 0.2),
        ("equality", 5, None),
        ("cone", 6, 0.8),
    ]
    G = _random_spd(rng, 9)
    # limit pushing, contact sliding, friction at its upper bound, a contact sliding
    lam1, c1 = _sliding(0.5, 1.3, [0.3, -0.4])
    lam2, c2 = _sliding(0.8, 0.6, [-0.2, 0.1])
    lam = np.r_[0.4, lam1, 0.2, -0.7, lam2]
    c = np.r_[0.0, c1, -0.25, 0.0, c2]
    cases["(d) mixed, active"] = (G, c - (G + compliance * np.eye(9)) @ lam, blocks, lam)
    # limit leaving, contact sticking, friction holding inside its box, a contact leaving
    lam = np.r_[0.0, 0.1, -0.05, 1.0, 0.05, 0.7, 0.0, 0.0, 0.0]
    c = np.r_[0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.2, -0.1, 0.4]
    cases["(d) mixed, idle"] = (G, c - (G + compliance * np.eye(9)) @ lam, blocks, lam)
    # blocks given out of row order, three equality rows sharing one anchor
    blocks = [("equality", 4, None), ("cone", 0, 0.6), ("equality", 3, None), ("box", 5, 0.1)]
    blocks.append(("equality", 6, None))
    G = _random_spd(rng, 7)
    lam0, c0 = _sliding(0.6, 0.9, [0.05, 0.02])
    lam = np.r_[lam0, 0.3, -0.2, -0.1, 0.5]
    c = np.r_[c0, 0.0, 0.0, 0.6, 0.0]
    cases["(d) unordered"] = (G, c - (G + compliance * np.eye(7)) @ lam, blocks, lam)
    cases["(e) box alone"] = (np.eye(1) * 2.0, np.array([5.0]), [("box", 0, 1.0)], np.array([-1.0]))
    return cases


def _check_jacobians(fd_bound=1e-7, pin_bound=1e-12):
    """Check both jacobians on a random humanoid (free flyer) against central finite
    differences of world positions (through pin.integrate) and against the jacobian of
    pin.PointContactConstraintModel; print the errors and fail when one exceeds its bound."""
    model = pin.buildSampleModelHumanoidRandom()
    data = model.createData()
    rng = np.random.default_rng(3)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    eps = 1e-6

    def central_difference(position):
        """The (3, nv) derivative of position(q) along each velocity direction."""
        out = np.zeros((3, model.nv))
        for k in range(model.nv):
            dv = np.zeros(model.nv)
            dv[k] = eps
            plus = position(pin.integrate(model, q, dv))
            minus = position(pin.integrate(model, q, -dv))
            out[:, k] = (plus - minus) / (2.0 * eps)
        pin.forwardKinematics(model, data, q)
        return out

    def pinocchio_jacobian(cmodel):
        cdata = cmodel.createData()
        pin.computeJointJacobians(model, data, q)
        cmodel.calc(model, data, cdata)
        return cmodel.jacobian(model, data, cdata)

    def on_body(joint, local_point):
        def position(qq):
            pin.forwardKinematics(model, data, qq)
            return data.oMi[joint].act(local_point)

        return position

    # a point on the last body, its contact frame fixed to the body
    joint = model.njoints - 1
    pl = pin.SE3(pin.exp3(rng.standard_normal(3)), rng.standard_normal(3) * 0.1)
    J = point_contact_jacobian(model, data, q, joint, pl)
    oMc = data.oMi[joint] * pl
    errors = {
        "point_contact_jacobian vs finite differences": np.abs(
            J - oMc.rotation.T @ central_difference(on_body(joint, pl.translation))
        ).max(),
        "point_contact_jacobian vs -PointContactConstraintModel": np.abs(
            J + pinocchio_jacobian(pin.PointContactConstraintModel(model, joint, pl, 0, oMc))
        ).max(),
    }
    # a world point on two bodies
    a, b = 2, model.njoints - 3
    x = rng.standard_normal(3) * 0.3
    Rc = pin.exp3(rng.standard_normal(3))
    Jr = relative_point_contact_jacobian(model, data, q, a, b, x, Rc)
    xa, xb = data.oMi[a].actInv(x), data.oMi[b].actInv(x)
    J_fd = central_difference(on_body(b, xb)) - central_difference(on_body(a, xa))
    wMc = pin.SE3(Rc, x)
    cmodel = pin.PointContactConstraintModel(
        model, a, data.oMi[a].actInv(wMc), b, data.oMi[b].actInv(wMc)
    )
    errors["relative_point_contact_jacobian vs finite differences"] = np.abs(Jr - Rc.T @ J_fd).max()
    errors["relative_point_contact_jacobian vs PointContactConstraintModel"] = np.abs(
        Jr - pinocchio_jacobian(cmodel)
    ).max()
    Jw = relative_point_contact_jacobian(model, data, q, 0, joint, oMc.translation, oMc.rotation)
    errors["relative (world, body) vs point_contact_jacobian"] = np.abs(Jw - J).max()
    for name, error in errors.items():
        print(f"{name}: {error:.1e}")
        assert error < (fd_bound if "finite" in name else pin_bound), (name, error)


def _self_check(bound=1e-9):
    """Solve every case with both solvers, with and without compliance; print the residuals
    of Pinocchio's answers and fail when one exceeds bound."""
    worst = 0.0
    for compliance in (0.0, 1e-3):
        for name, (G, g, blocks, expected) in _cases(compliance).items():
            answers = {}
            for solver in ("admm", "pgs"):
                lam, info = solve_with_pinocchio(
                    G, g, blocks, solver=solver, compliance=compliance, return_info=True
                )
                r = ncp_residuals(G, g, blocks, lam, compliance=compliance)
                error = np.abs(lam - expected).max() if expected is not None else np.nan
                print(
                    f"{name:18s} {solver:4s} compliance {compliance:g}: primal "
                    f"{r['primal']:.1e} dual {r['dual']:.1e} complementarity "
                    f"{r['complementarity']:.1e} |lam - expected| {error:.1e} "
                    f"({info['iterations']} iterations)"
                )
                worst = max(worst, r["primal"], r["dual"], r["complementarity"])
                if expected is not None:
                    worst = max(worst, error)
                answers[solver] = lam
            worst = max(worst, np.abs(answers["admm"] - answers["pgs"]).max())
            if compliance == 0.0 and name.startswith(("(a)", "(b)")):
                print(f"{'':18s} lam = {answers['admm']}")
    print(f"largest residual or error: {worst:.1e}")
    assert worst < bound, worst
    _check_jacobians()


if __name__ == "__main__":
    np.set_printoptions(precision=6, suppress=True)
    _self_check()
