"""The velocity-level time stepper of the hard model: contacts, joint limits and joint dry
friction as constraints on the velocity at the end of the step (integrator
"semi_implicit_euler" with a hard model in the scene; opendyn.sim.hard reads it).

From (q, v) at t over dt, every effect the scene names evaluated once at (t, q, v):

    v_free = v + dt M(q)^-1 (tau(t, q, v) - c(q, v) - g(q))            (M with the armature)
    rows:  each contact of the step's contact list (opendyn.algorithm.contact_list) within the
           margin: three rows (t1, t2, n) of J, with g_n = J_n v_free + max(d, 0) / dt
           + stabilization min(d, 0) / dt (a gap within the margin may close in one step but
           no further; a penetration is taken out at that rate);
           each joint limit within its margin, or that the free velocity would reach within
           the step (d <= dt |v_free_j| towards it), or the velocity after a solve without it
           (the step then solves again with it): one unilateral row, J = +e_j at the lower limit
           (d = q - lower), -e_j at the upper (d = upper - q), with the same drift rule;
           each joint with dry friction f_c: one box row, J = e_j, |lambda| <= f_c dt;
           each row of the scene's Pfaffian constraints A(q) v = 0 (welds, loops): an equality
           row, J = A_i, g = A_i v_free + stabilization phi_i / dt
    G = J M^-1 J^T + R (the Delassus matrix and the compliance), g = J v_free (+ the drift)
    lambda: the NCP of opendyn.algorithm.ncp (ADMM or PGS), warm-started from the impulses of
           the same contact (pair, feature), limit or joint in the step before
    v+ = v_free + M^-1 J^T lambda,   q+ = q (+) dt v+

With no rows it is symplectic Euler in velocity form. The work w (2,) advances by dt times the
effects' power at the start (as the other Euler steps), and the passive work also by the
impulses' work lambda . J (v_free + v+) / 2, exactly the kinetic energy they add at fixed q
(never positive for contacts and friction that dissipate: an inelastic step gains no energy).
"""

from __future__ import annotations

from collections import namedtuple

from numba import njit

from .._runtime.arrays import copy_into, fill, zero_matrix
from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..algorithm.cholesky import cholesky_factor, cholesky_substitute, largest_diagonal
from ..algorithm.configuration import integrate_kernel
from ..algorithm.constraints.terms import constraint_terms_in
from ..algorithm.contact_list import contact_rows, find_contacts
from ..algorithm.crba import crba_on_poses
from ..algorithm.contact import DEPTH, FORCE, NORMAL_AT, PAIR, POINT
from ..algorithm.ncp import BOX, CONE, EQUALITY, UNILATERAL, solve_ncp
from ..algorithm.rnea import rnea_on_poses
from ..multibody.layout import body_count, tree
from ..multibody.work_views import world_poses
from .step import generalized_forces

# settings (float64): the contacts' margin (m), the limits' margin (rad or m), stabilization,
# compliance (s/kg) and tolerance (m/s); solver (int64): the solver (ncp.ADMM or ncp.PGS) and
# max_iterations
MARGIN, LIMIT_MARGIN, STABILIZATION, COMPLIANCE, TOLERANCE = range(5)
SOLVER, MAX_ITERATIONS = range(2)
# stats (float64 (6,)): the last step's iterations and residual (m/s), the steps whose solve
# did not converge and the worst residual among them (m/s), the last step's rows m and blocks B
ITERATIONS, RESIDUAL, UNCONVERGED, WORST, ROWS, BLOCKS = range(6)

# The hard model as the step takes it: spheres (Spheres) or None, geometry (Geometries) or None
# (opendyn.algorithm.contact_list), limits (iq, iv (n,) int, lower, upper
# (n,)) or None, friction (iv (n,) int, f_c (n,)) or None, constraints (rows, params: the
# scene's Pfaffian constraints as opendyn.algorithm.constraints tables them; A (k, nv),
# Adot_qd (k,), phi (k,), their TermsWork and lambda (k,) of the step before) or None,
# settings, solver, room (HardRoom).
HardTable = namedtuple(
    "HardTable",
    ("spheres", "geometry", "limits", "friction", "constraints", "settings", "solver", "room"),
)
# The contacts' impulses of a step, kept for the next one's warm start: count (1,) int, and
# per contact its pair and feature (C,) int, the id of opendyn.algorithm.contact_list, and
# lambda (C, 3) (t1, t2, n; N s).
Impulses = namedtuple("Impulses", ("count", "pair", "feature", "lam"))
# What the step works in, made once per run: the contact list `found`, the step before's
# Impulses `before`, the geometry pairs' GeometryRoom (or None), the rows J and Y = M^-1 J^T
# (m', nv), G, its factor F and G_s, G preconditioned (m', m') (opendyn.algorithm.ncp),
# vectors (12, m'), blocks (B', 3) int, param (B',), owner (m',) int (a joint row's 3 k + c:
# joint k's lower limit c = 0, upper 1, friction 2; -1 - i: constraint row i), scratch
# (2, 3), J3 (3, nv), S (6,), the joints' previous impulses (n, 3) (lower limit, upper limit,
# friction), the limits that are rows of this step's solve (n, 2) (1: a row; limit_rows) and
# stats (6,).
HardRoom = namedtuple(
    "HardRoom",
    ("found", "before", "pairs", "J", "Y", "G", "F", "G_s", "vectors", "blocks", "param", "owner",
     "scratch", "J3", "S", "joints", "rows", "stats"),
)
# the vectors' rows: g, lambda, then the solver's ten
G_ROW, LAM = 0, 1
LIMIT_PASSES = 4  # solves a step may take, each with the limits the last one's velocity reached
# A run's per-sample record of the hard model (record.Samples): counts (K,) int, rows
# (K, C, opendyn.algorithm.contact.ROW) of the contacts at each sample with their force lambda / dt,
# solver (K, 2) the solve's iterations and residual there.
HardLog = namedtuple("HardLog", ("counts", "rows", "solver"))


@njit(**JIT)
def restart_hard(hard):
    """A fresh start for the HardTable hard, as it is when made (opendyn.sim.hard.hard_table):
    no impulses to warm-start from (the contacts', the joints' and the equality rows'), the
    solver's counts at zero, and the geometry pairs' hulls climbing from their first vertex
    again. Nothing for hard None (numba drops the code)."""
    if hard is None:
        return
    room = hard.room
    room.before.count[0] = 0
    zero_matrix(room.joints)
    fill(room.stats, 0.0)
    forget_equalities(hard.constraints)
    forget_hints(room.pairs)


@njit(**JIT)
def forget_equalities(constraints):
    """The equality rows' impulses of the step before (constraints[6], HardTable) <- 0; nothing
    for constraints None."""
    if constraints is None:
        return
    fill(constraints[6], 0.0)


@njit(**JIT)
def forget_hints(pairs):
    """Each hull's climbing start (the GeometryRoom pairs' hints) <- its first vertex; nothing
    for pairs None (no geometry pairs)."""
    if pairs is None:
        return
    fill(pairs.hints, 0)


@njit(**JIT)
def drift(d, stabilization, dt):
    """The normal row's velocity bias (m/s) of a gap d: max(d, 0) / dt + stabilization
    min(d, 0) / dt."""
    return (max(d, 0.0) + stabilization * min(d, 0.0)) / dt


@njit(**JIT)
def warm_contact(room, k, lam, r):
    """lam[r:r + 3] <- the impulse of contact k's id (pair, feature) in the step before, or 0."""
    found, before = room.found, room.before
    lam[r] = lam[r + 1] = lam[r + 2] = 0.0
    for i in range(before.count[0]):
        if before.pair[i] == found.pair[k] and before.feature[i] == found.feature[k]:
            for c in range(3):
                lam[r + c] = before.lam[i, c]
            return


@njit(**JIT)
def add_row(room, rows, j, sign, g, owner):
    """Joint row rows = (m, B) <- J[m] = sign e_j, g[m] = g, lambda's warm start the impulse
    its owner (3 k + c, HardRoom) had in the step before; its block, one row, is left for the
    caller to set."""
    m, B = rows
    J = room.J
    for c in range(J.shape[1]):
        J[m, c] = 0.0
    J[m, j] = sign
    room.vectors[G_ROW, m] = g
    room.vectors[LAM, m] = room.joints[owner // 3, owner % 3]
    room.owner[m] = owner
    room.blocks[B, 0], room.blocks[B, 1], room.blocks[B, 2] = UNILATERAL, m, 1
    room.param[B] = 0.0


@njit(**JIT)
def assemble(hard, model, posed, q, reach, dt):
    """The problem's rows at q (module docstring), in hard.room: J, g, the blocks and their
    params, lambda's warm start; model = (ibuf, fbuf); reach = (v_free, v_probe), the free
    velocity and the one whose reach also makes a limit's row (limit_active). Returns
    (status, m rows, B blocks)."""
    v_free = reach[0]
    body_tree = tree(model[0], model[1])
    room, settings = hard.room, hard.settings
    found = room.found
    find_contacts(posed, (hard.spheres, hard.geometry), settings[MARGIN], room)
    g, lam = room.vectors[G_ROW], room.vectors[LAM]
    m = 0
    for k in range(found.count[0]):
        rows = room.J[m : m + 3]
        contact_rows(body_tree, posed, found, k, room.J3, room.S, rows)
        for r in range(3):
            s = 0.0
            for c in range(v_free.shape[0]):
                s += rows[r, c] * v_free[c]
            g[m + r] = s
        g[m + 2] += drift(found.depth[k], settings[STABILIZATION], dt)
        warm_contact(room, k, lam, m)
        room.blocks[k, 0], room.blocks[k, 1], room.blocks[k, 2] = CONE, m, 3
        room.param[k] = found.mu[k]
        m += 3
    status, at = equality_rows(hard.constraints, model, room, (settings, q, v_free, dt),
                               (m, found.count[0]))
    at = limit_rows(hard.limits, room, (settings, q, reach, dt), at)
    m, B = friction_rows(hard.friction, room, v_free, dt, at)
    return status, m, B


@njit(**JIT)
def equality_rows(constraints, model, room, at_q, at):
    """The scene's Pfaffian constraints A(q) v = 0 as equality rows after the rows and blocks
    at = (m, B): J = A, g = A v_free + stabilization phi / dt (the drift phi taken out at that
    rate), warm-started from the step before; constraints as HardTable's, or None (none: numba
    drops the code); model = (ibuf, fbuf); at_q = (settings, q, v_free, dt). Returns (status,
    (m, B))."""
    m, B = at
    if constraints is None:
        return 0, (m, B)
    rows, params, A, Adot_qd, phi, work, before = constraints
    settings, q, v_free, dt = at_q
    status = constraint_terms_in(model[0], model[1], rows, params, q, v_free, A, Adot_qd, phi, work)
    if status:
        return status, (m, B)
    for i in range(A.shape[0]):
        s = 0.0
        for j in range(A.shape[1]):
            room.J[m, j] = A[i, j]
            s += A[i, j] * v_free[j]
        room.vectors[G_ROW, m] = s + settings[STABILIZATION] * phi[i] / dt
        room.vectors[LAM, m] = before[i]
        room.owner[m] = -1 - i
        room.blocks[B, 0], room.blocks[B, 1], room.blocks[B, 2] = EQUALITY, m, 1
        room.param[B] = 0.0
        B += 1
        m += 1
    return 0, (m, B)


@njit(**JIT)
def limit_active(d, sign, j, settings, reach, dt):
    """Whether a limit of gap d (rad or m) on velocity j, approached at -sign v_j, is a row:
    within the margin, or within one step's reach of the free velocity or of the probe
    (reach = (v_free, v_probe); the probe, the velocity after a solve without the row, catches
    a joint that another row's impulse throws at its limit)."""
    v_free, v_probe = reach
    return d <= max(settings[LIMIT_MARGIN], -sign * v_free[j] * dt, -sign * v_probe[j] * dt)


@njit(**JIT)
def limit_rows(limits, room, at_q, at):
    """The joint limits' rows (module docstring) after the rows and blocks at = (m, B); limits
    = (iq, iv, lower, upper), or None (none: numba drops the code); at_q = (settings, q,
    reach, dt) (limit_active). Returns the new (m, B)."""
    m, B = at
    if limits is None:
        return m, B
    settings, q, reach, dt = at_q
    for k in range(limits[0].shape[0]):
        j = limits[1][k]
        for side in range(2):
            d, sign = limit_gap(limits, k, side, q)
            if room.rows[k, side] == 0.0 and not limit_active(d, sign, j, settings, reach, dt):
                room.joints[k, side] = 0.0
                continue
            room.rows[k, side] = 1.0
            g_j = sign * reach[0][j] + drift(d, settings[STABILIZATION], dt)
            add_row(room, (m, B), j, sign, g_j, 3 * k + side)
            B += 1
            m += 1
    return m, B


@njit(**JIT)
def limits_missed(limits, room, settings, q, reach, dt):
    """Whether a limit that is no row of the last solve (room.rows) would be one at reach =
    (v_free, v_next): the velocity after the solve reaches a limit that none of the solve's
    rows held. False for limits None."""
    if limits is None:
        return False
    for k in range(limits[0].shape[0]):
        for side in range(2):
            d, sign = limit_gap(limits, k, side, q)
            if room.rows[k, side] == 0.0 and limit_active(
                d, sign, limits[1][k], settings, reach, dt
            ):
                return True
    return False


@njit(**JIT)
def limit_gap(limits, k, side, q):
    """(d, sign) of joint k's limit on `side` at q: d = q_i - lower (sign +1, side 0) or
    upper - q_i (sign -1, side 1), rad or m; limits = (iq, iv, lower, upper)."""
    i = limits[0][k]
    if side == 0:
        return q[i] - limits[2][k], 1.0
    return limits[3][k] - q[i], -1.0


@njit(**JIT)
def friction_rows(friction, room, v_free, dt, at):
    """Joint dry friction's box rows (module docstring) after the rows and blocks at = (m, B);
    friction = (iv, f_c), or None (none: numba drops the code). Returns the new (m, B)."""
    m, B = at
    if friction is None:
        return m, B
    iv, f_c = friction
    for k in range(iv.shape[0]):
        add_row(room, (m, B), iv[k], 1.0, v_free[iv[k]], 3 * k + 2)
        room.blocks[B, 0] = BOX
        room.param[B] = f_c[k] * dt
        B += 1
        m += 1
    return m, B


@njit(**JIT)
def delassus(room, M, nv, m, compliance):
    """room.Y[:m] <- (M^-1 J^T)^T, room.G[:m, :m] <- J M^-1 J^T + compliance I, with M's
    Cholesky factor in M."""
    J, Y, G = room.J, room.Y, room.G
    for r in range(m):
        cholesky_substitute(M, nv, J[r], Y[r])
    for r in range(m):
        for c in range(r + 1):
            s = 0.0
            for j in range(nv):
                s += J[r, j] * Y[c, j]
            G[r, c] = s
            G[c, r] = s
        G[r, r] += compliance


@njit(**JIT)
def keep_impulses(hard, m):
    """The step's impulses, kept by id for the next step's warm start (room.before, and the
    joints' rows in room.joints)."""
    room = hard.room
    found, before, lam = room.found, room.before, room.vectors[LAM]
    n = found.count[0]
    before.count[0] = n
    for k in range(n):
        before.pair[k], before.feature[k] = found.pair[k], found.feature[k]
        for c in range(3):
            before.lam[k, c] = lam[3 * k + c]
    for r in range(3 * n, m):
        owner = room.owner[r]
        if owner >= 0:
            room.joints[owner // 3, owner % 3] = lam[r]
    keep_equalities(hard.constraints, room, 3 * n, m)


@njit(**JIT)
def keep_equalities(constraints, room, first, m):
    """The equality rows' impulses (rows first..m whose owner is -1 - i: constraint row i),
    kept for the next step's warm start; nothing for constraints None."""
    if constraints is None:
        return
    before, lam = constraints[6], room.vectors[LAM]
    for r in range(first, m):
        owner = room.owner[r]
        if owner < 0:
            before[-1 - owner] = lam[r]


@njit(**JIT)
def solve_rows(hard, M, size, v_free, v_next):
    """The problem of the m rows and B blocks size = (m, B) that assemble left in hard.room,
    solved: G and Y (delassus, M's Cholesky factor in M), lambda by the scene's solver from its
    warm start, v_next (nv,) <- v_free + M^-1 J^T lambda. Returns (status, iterations,
    residual m/s)."""
    room = hard.room
    m, B = size
    nv = v_free.shape[0]
    delassus(room, M, nv, m, hard.settings[COMPLIANCE])
    vectors = room.vectors
    lam = vectors[LAM]
    problem = (room.G, vectors[G_ROW], room.blocks[:B], room.param[:B], m)
    status, iterations, residual = solve_ncp(
        hard.solver[SOLVER], problem,
        (hard.settings[TOLERANCE], hard.solver[MAX_ITERATIONS]), lam,
        (room.F, room.G_s, vectors[2:12]),
    )
    for j in range(nv):
        s = v_free[j]
        for r in range(m):
            s += room.Y[r, j] * lam[r]
        v_next[j] = s
    return status, iterations, residual


@njit(**JIT)
def hard_velocity_step(hard, scene, t, dt, x, x1, work):
    """One step of the velocity-level stepper (module docstring) from the State x at t to x1,
    in work (the integrator's StepWork: its M, vectors, kv[0] and kw[0]) and hard.room;
    work.tau <- the control torque at its start. Returns a Status."""
    ibuf, fbuf, data = scene.ibuf, scene.fbuf, scene.work
    armature, loads = scene.armature, scene.loads
    q, qd = x.q, x.qd
    nv = qd.shape[0]
    tau, M, power = scene.forces[0], work.M, work.kw[0]
    h, v_free, zero = work.vectors[0], work.vectors[1], work.vectors[2]
    room = hard.room
    status = generalized_forces(scene, t, q, qd, tau, work.tau, power, scene.KD[0], scene.KD[1],
                                False)
    if status:
        return status
    # h = c(q, v) + g(q), M(q) + diag(armature), on the poses generalized_forces placed at q
    fill(zero, 0.0)
    status = rnea_on_poses(ibuf, fbuf, data, qd, zero, loads, h)
    if status:
        return status
    crba_on_poses(ibuf, fbuf, data, M)
    if armature.shape[0]:
        for j in range(nv):
            M[j, j] += armature[j]
    status = cholesky_factor(M, nv, largest_diagonal(M))
    if status:
        return status
    # v_free = v + dt M^-1 (tau - h)
    for j in range(nv):
        h[j] = tau[j] - h[j]
    cholesky_substitute(M, nv, h, v_free)
    for j in range(nv):
        v_free[j] = qd[j] + dt * v_free[j]
    nb = body_count(ibuf)
    posed = world_poses(data, nb)
    # a solve, then again with the limits its velocity reaches, as long as it reaches new ones
    probe = work.vectors[3]
    copy_into(v_free, probe)
    zero_matrix(room.rows)
    iterations = 0
    for _ in range(LIMIT_PASSES):
        status, m, B = assemble(hard, (ibuf, fbuf), posed, q, (v_free, probe), dt)
        if status:
            return status
        status, spent, residual = solve_rows(hard, M, (m, B), v_free, x1.qd)
        iterations += spent
        if status:
            return status
        if not limits_missed(hard.limits, room, hard.settings, q, (v_free, x1.qd), dt):
            break
        copy_into(x1.qd, probe)
    stats = room.stats
    stats[ITERATIONS], stats[RESIDUAL] = iterations, residual
    stats[ROWS], stats[BLOCKS] = m, B
    if not residual <= hard.settings[TOLERANCE]:
        stats[UNCONVERGED] += 1.0
        stats[WORST] = max(stats[WORST], residual)
    lam = room.vectors[LAM]
    impulse_work = 0.0
    for r in range(m):
        s = 0.0
        for j in range(nv):
            s += room.J[r, j] * (v_free[j] + x1.qd[j])
        impulse_work += 0.5 * lam[r] * s
    keep_impulses(hard, m)
    integrate_kernel(ibuf, q, x1.qd, dt, x1.q)
    x1.w[0] = x.w[0] + dt * power[0]
    x1.w[1] = x.w[1] + dt * power[1] + impulse_work
    return Status.OK.value


@njit(**JIT)
def log_sample(log, hard, r, dt):
    """Row r (mod K) of the HardLog log <- the step's contacts (the list found at its start)
    with their forces lambda / dt in {s}, and its solve's iterations and residual. Nothing
    when log is None (numba drops the call)."""
    if log is None:
        return
    r = r % log.counts.shape[0]
    room = hard.room
    found, lam = room.found, room.vectors[LAM]
    n = min(found.count[0], log.rows.shape[1])
    log.counts[r] = n
    log.solver[r, 0], log.solver[r, 1] = room.stats[ITERATIONS], room.stats[RESIDUAL]
    for k in range(n):
        row = log.rows[r, k]
        F = found.frame[k]
        row[PAIR] = found.pair[k]
        for c in range(3):
            row[POINT + c] = found.point[k, c]
            row[NORMAL_AT + c] = F[2, c]
            row[FORCE + c] = (
                lam[3 * k] * F[0, c] + lam[3 * k + 1] * F[1, c] + lam[3 * k + 2] * F[2, c]
            ) / dt
        row[DEPTH] = -found.depth[k]
