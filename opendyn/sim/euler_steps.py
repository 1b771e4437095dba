"""The two Euler steps that solve with the mass matrix, for the fixed-step loop of
opendyn.sim.integrators (whose docstring derives them), each from a State x = (q, qd, w) at t to
x1 over dt:

  implicit_euler       linearly implicit in velocity, with the effects' stiffness K = -dtau/dq
                       and damping D = -dtau/dqd (nv, nv) at the end of the step:
                         (M + diag(armature) + dt D + dt^2 K) (qd' - qd) = dt (tau - h - dt K qd),
                         q' = q (+) qd' dt
                       K and D are the effects' exact derivatives (contact's are not symmetric:
                       its friction turns with the normal force and the contact's geometry), the
                       rigid body's own left out; the matrix is solved by LU
  semi_implicit_euler  symplectic Euler in momentum form, p = (M(q) + diag(armature)) qd:
                         p' = p + dt (dK/dq(q, v) - g(q) + tau(t, q, qd)),  v = (M(q) + ..)^-1 p',
                         q' = q (+) v dt,   qd' = (M(q') + diag(armature))^-1 p'
                       (v by fixed-point iteration at fixed q, to FIXED_POINT_RTOL)

The work w (2,) (applied, passive; J) advances by dt times the power at the start, and the
contact's extremes at the start are the step's (contact_extremes.keep_step).
"""

from __future__ import annotations

from numba import njit

from .._runtime.arrays import copy_into, fill
from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..algorithm.cholesky import (
    cholesky_factor,
    cholesky_solve,
    cholesky_substitute,
    largest_diagonal,
)
from ..algorithm.configuration import integrate_kernel
from ..algorithm.constraints import general_constrained_solve_at
from ..algorithm.contact_extremes import keep_step
from ..algorithm.crba import crba_kernel, crba_on_poses
from ..algorithm.energy import kinetic_gradient_kernel
from ..algorithm.lu import lu_solve
from ..algorithm.rnea import rnea_on_poses
from .step import generalized_forces

FIXED_POINT_RTOL = 1e-14  # the momentum update's iteration stops when v changes less than this
FIXED_POINT_MAX = 50


@njit(**JIT)
def velocity_solve(scene, con, q, qd, M, piv, rhs, qdd):
    """qdd <- M^-1 rhs, or with constraints con (scene.constraints, not None) the constrained
    solve of M qdd + A^T lambda = rhs (M overwritten; lambda in scene.con_work.lam, its row
    swaps in scene.con_work's own), both by LU with partial pivoting (piv (nv,) int64: its row
    swaps): M here is M + diag(armature) + dt D + dt^2 K, not symmetric once contact's exact
    derivatives are in K and D. A function of its own so that the test on None is decided when
    it compiles. Returns a Status (SINGULAR + k: M singular at joint k)."""
    if con is None:
        return lu_solve(M, piv, rhs, qdd)
    return general_constrained_solve_at(
        scene.ibuf, scene.fbuf, con, q, qd, M, rhs, qdd, scene.con_work
    )


@njit(**JIT)
def implicit_velocity_step(scene, t, dt, x, x1, work):
    """One linearly implicit Euler step (module docstring) from the State x at t to x1, in
    work (the integrator's StepWork: its M, piv, vectors, kv[0] and kw[0]); work.tau <- the
    control torque at its start. Returns a Status."""
    ibuf, fbuf, data = scene.ibuf, scene.fbuf, scene.work
    armature, loads = scene.armature, scene.loads
    q, qd = x.q, x.qd
    nv = qd.shape[0]
    tau, K, D = scene.forces[0], scene.KD[0], scene.KD[1]
    M, h, rhs, zero = work.M, work.vectors[0], work.vectors[1], work.vectors[2]
    qdd, power = work.kv[0], work.kw[0]
    status = generalized_forces(scene, t, q, qd, tau, work.tau, power, K, D, True)
    if status:
        return status
    keep_step(scene.touch)
    # h(q, qd) and M(q) on the poses generalized_forces placed at q
    fill(zero, 0.0)
    status = rnea_on_poses(ibuf, fbuf, data, qd, zero, loads, h)
    if status:
        return status
    crba_on_poses(ibuf, fbuf, data, M)
    for j in range(nv):
        rhs[j] = tau[j] - h[j]
        for k in range(nv):
            M[j, k] += dt * D[j, k] + dt * dt * K[j, k]
            rhs[j] -= dt * K[j, k] * qd[k]
        if armature.shape[0]:
            M[j, j] += armature[j]
    status = velocity_solve(scene, scene.constraints, q, qd, M, work.piv, rhs, qdd)
    if status:
        return status
    for j in range(nv):
        x1.qd[j] = qd[j] + dt * qdd[j]
    integrate_kernel(ibuf, q, x1.qd, dt, x1.q)
    x1.w[0] = x.w[0] + dt * power[0]
    x1.w[1] = x.w[1] + dt * power[1]
    return Status.OK.value


@njit(**JIT)
def symplectic_euler_step(scene, t, dt, x, x1, work):
    """One step of symplectic Euler in momentum form (module docstring) from the State x at t to
    x1, in work (the integrator's StepWork: its M, vectors, v and kw[0]); work.tau <- the
    control torque at its start. Returns a Status."""
    ibuf, fbuf, data = scene.ibuf, scene.fbuf, scene.work
    armature, loads, KD = scene.armature, scene.loads, scene.KD
    q, qd = x.q, x.qd
    nv = qd.shape[0]
    tau = scene.forces[0]
    M, v, power = work.M, work.v, work.kw[0]
    rows = work.vectors
    zero, g, p, p1, dK_dq, v_next = rows[0], rows[1], rows[2], rows[3], rows[4], rows[5]
    status = generalized_forces(scene, t, q, qd, tau, work.tau, power, KD[0], KD[1], False)
    if status:
        return status
    keep_step(scene.touch)
    # g(q): RNEA at qd = qdd = 0 under the base acceleration, on the poses generalized_forces
    # placed at q
    fill(zero, 0.0)
    status = rnea_on_poses(ibuf, fbuf, data, zero, zero, loads, g)
    if status:
        return status
    # p = (M(q) + diag(armature)) qd
    crba_on_poses(ibuf, fbuf, data, M)
    fill(p, 0.0)
    for r in range(nv):
        if armature.shape[0]:
            M[r, r] += armature[r]
        for c in range(nv):
            p[r] += M[r, c] * qd[c]
    status = cholesky_factor(M, nv, largest_diagonal(M))
    if status:
        return status
    # p' = p + dt (dK/dq(q, v) - g + tau), v = M^-1 p': fixed-point iteration from v = qd
    copy_into(qd, v)
    converged = False
    for _ in range(FIXED_POINT_MAX):
        status = kinetic_gradient_kernel(ibuf, fbuf, data, q, v, dK_dq)
        if status:
            return status
        for j in range(nv):
            p1[j] = p[j] + dt * (dK_dq[j] - g[j] + tau[j])
        cholesky_substitute(M, nv, p1, v_next)
        change = 0.0
        size = 0.0
        for j in range(nv):
            change = max(change, abs(v_next[j] - v[j]))
            size = max(size, abs(v_next[j]))
            v[j] = v_next[j]
        if change <= FIXED_POINT_RTOL * (1.0 + size):
            converged = True
            break
    if not converged:
        return Status.NO_CONVERGENCE.value
    # q' = q (+) v dt, qd' = (M(q') + diag(armature))^-1 p'
    integrate_kernel(ibuf, q, v, dt, x1.q)
    crba_kernel(ibuf, fbuf, data, x1.q, M)
    if armature.shape[0]:
        for r in range(nv):
            M[r, r] += armature[r]
    status = cholesky_solve(M, p1, x1.qd)
    if status:
        return status
    x1.w[0] = x.w[0] + dt * power[0]
    x1.w[1] = x.w[1] + dt * power[1]
    return Status.OK.value
