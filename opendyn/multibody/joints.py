"""Joint models: what each kind of joint contributes to a kernel, and nothing else.

    T_{lambda(i), i}(q_i) = M_{lambda(i), i} X_J(q_i),     V_J = S_i v_i,     tau_i = S_i^T F_i

A joint of type jtype has nq_i configuration and nv_i velocity coordinates, q_i = q[iq : iq +
nq_i] and v_i = v[iv : iv + nv_i], and a constant motion subspace S_i (6 x nv_i, angular first)
in its child body's frame {i}, stored as nv_i rows of the model's S field:

  REVOLUTE   nq 1, nv 1, S = (a, 0):  X_J = (Rot(a, q), 0)
  PRISMATIC  nq 1, nv 1, S = (0, a):  X_J = (I, a q)
  FREE       nq 7, nv 6, S = I_6:     X_J = (R(quat), p), q_i = (p, quat) with the quaternion
             in (x, y, z, w) order, v_i = (omega_b, v_b) the body's twist in its own frame {i}

A 1-dof joint may mimic another: its angle is mult * q[iq] + offset, and it adds mult times its
share to the coordinate it follows. S is constant in {i} for all of these, so the joint bias
Sdot v is zero. The kernels walk every joint through `joint_transform` (Featherstone's jcalc),
`joint_motion` and `add_joint_force` over the rows of S; a new kind of joint is a new branch
here and in the configuration functions (`joint_integrate`, `joint_difference`), not an edit
of every algorithm. (Featherstone, Rigid Body Dynamics Algorithms, 2008, Section 4.4; the free
joint as in Pinocchio's JointModelFreeFlyer, twist angular first.)
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.extending import overload
from numba.np.numpy_support import from_dtype

from .._runtime.arrays import all_finite
from .._runtime.kernel_cache import INLINE, JIT
from .._runtime.status import Status
from ..spatial.compiled import se3_log_translation
from .layout import _IQ, _JTYPE, FREE_JOINTS_INT, body_count, config_count, dof_count, field

# joint types, and each type's numbers of configuration and velocity coordinates
REVOLUTE = 0
PRISMATIC = 1
FREE = 2
JOINT_NQ = (1, 1, 7)
JOINT_NV = (1, 1, 6)
JOINT_TYPE_NAMES = ("revolute", "prismatic", "free")
# the names of a free joint's coordinates, after its body's name: q, then v
FREE_Q_NAMES = ("x", "y", "z", "qx", "qy", "qz", "qw")
FREE_V_NAMES = ("wx", "wy", "wz", "vx", "vy", "vz")

def has_free_joints(int_array):
    """At compile time, from the numba type of the model's int buffer (or a view of it): True
    when the model has free joints (its dtype is opendyn.multibody.layout.FREE_JOINTS_INT)."""
    return int_array.dtype == from_dtype(np.dtype(FREE_JOINTS_INT))


def free_joints_only(fn):
    """call(int_array, *args): fn(*args) in compiled code when the model (whose int buffer
    int_array views) has free joints; 0 (Status OK), with fn never compiled, when it has none.
    The choice is made at compile time from int_array's dtype: a fixed-base model's kernels
    compile no free-joint code (transforms, quaternion checks, ABA's multi-dof passes, the
    exponential map). fn is bound here, not passed at the call, so the kernels stay cacheable."""

    def call(int_array, *args):
        """fn(*args) for a model with free joints (compiled code only)."""

    @overload(call)
    def _choose(int_array, *args):
        if has_free_joints(int_array):
            return lambda int_array, *args: fn(*args)
        return lambda int_array, *args: 0

    return call


# A quaternion's norm may differ from 1 by this much: it is used normalised. Further off it is
# refused as a mistake (Euler angles, a zero or a scaled vector), not silently rescaled.
QUATERNION_TOLERANCE = 1e-3


@njit(**INLINE)
def quaternion_rows(x, y, z, w):
    """The rotation of the quaternion (x, y, z, w) / |(x, y, z, w)|, as its three rows (tuples,
    so that no array is made): R = I + 2 w [u] + 2 [u]^2 for the unit quaternion (u, w)."""
    s = 2.0 / (x * x + y * y + z * z + w * w)
    return (
        (1.0 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)),
        (s * (x * y + z * w), 1.0 - s * (x * x + z * z), s * (y * z - x * w)),
        (s * (x * z - y * w), s * (y * z + x * w), 1.0 - s * (x * x + y * y)),
    )


@njit(**INLINE)
def free_transform(R_home, p_home, q, iq, R, p):
    """(R, p) = M X_J for a free joint: X_J = (R(quat), p_J), (p_J, quat) = q[iq : iq + 7]."""
    R_J = quaternion_rows(q[iq + 3], q[iq + 4], q[iq + 5], q[iq + 6])
    for r in range(3):
        h0, h1, h2 = R_home[r, 0], R_home[r, 1], R_home[r, 2]
        for c in range(3):
            R[r, c] = h0 * R_J[0][c] + h1 * R_J[1][c] + h2 * R_J[2][c]
        p[r] = p_home[r] + h0 * q[iq] + h1 * q[iq + 1] + h2 * q[iq + 2]


@njit(**INLINE)
def joint_transform(S_i, R_home, p_home, theta, R, p):
    """(R, p) = T_{lambda(i), i}(theta) = M_{lambda(i), i} X_J(theta) of a 1-dof joint, its
    angle or displacement theta = mult q[iq] + offset: the joint's calc in a kernel's loop
    (a free joint's (R, p) come from prepare_joint_transforms instead).

    X_J = exp([S] theta) for the joint's one row S = (w, v) of S_i, with w = a, v = 0
    (revolute, unit axis a) or w = 0, v = a (prismatic):
      R_J = I + sin theta [w] + (1 - cos theta) [w]^2,   p_J = v theta
    (Lynch & Park, (3.51) and (3.88) with the rotation's or the translation's part zero).
    One formula for both: no branch on the joint type in the kernels' loops, which lets
    numba drop the reference counting of the per-body views there (measured: place_joints
    on a UR5 0.29 -> 0.19 us inside a compiled loop).
    """
    x, y, z = S_i[0, 0], S_i[0, 1], S_i[0, 2]
    s, c = np.sin(theta), np.cos(theta)
    t = 1.0 - c
    # R_J = I + s [w] + t [w]^2, [w]^2 = w w^T - |w|^2 I
    e00, e01, e02 = 1.0 - t * (y * y + z * z), t * x * y - s * z, t * x * z + s * y
    e10, e11, e12 = t * x * y + s * z, 1.0 - t * (x * x + z * z), t * y * z - s * x
    e20, e21, e22 = t * x * z - s * y, t * y * z + s * x, 1.0 - t * (x * x + y * y)
    # p_J = v theta
    vx, vy, vz = S_i[0, 3] * theta, S_i[0, 4] * theta, S_i[0, 5] * theta
    # (R, p) = (R_home R_J, p_home + R_home p_J)
    for r in range(3):
        h0, h1, h2 = R_home[r, 0], R_home[r, 1], R_home[r, 2]
        R[r, 0] = h0 * e00 + h1 * e10 + h2 * e20
        R[r, 1] = h0 * e01 + h1 * e11 + h2 * e21
        R[r, 2] = h0 * e02 + h1 * e12 + h2 * e22
        p[r] = p_home[r] + h0 * vx + h1 * vy + h2 * vz


@njit(**JIT)
def free_joint_transforms(jtype, iq, home, q, R, p):
    """R[i], p[i] <- T_{lambda(i), i}(q_i) = M X_J(q_i) of every free joint i; home = the
    BodyTree's (R_home, p_home). Takes only the arrays it reads: a compiled call updates the
    reference count of each array it takes, twice."""
    R_home, p_home = home
    for i in range(jtype.shape[0]):
        if jtype[i] == FREE:
            free_transform(R_home[i], p_home[i], q, iq[i], R[i], p[i])


transform_free_joints = free_joints_only(free_joint_transforms)


@njit(**INLINE)
def prepare_joint_transforms(body_tree, q, R, p):
    """R[i], p[i] (R (nb, 3, 3), p (nb, 3)) <- the transforms of the free joints, before a
    kernel's loop calls joint_transform for each body. A fixed-base model's kernels compile
    nothing here, and their loops hold only the 1-dof calc (measured: a free-joint branch with
    a call inside RNEA's loop made talos 10-20% slower)."""
    home = (body_tree.R_home, body_tree.p_home)
    # the first jtype picks, by its dtype, whether free-joint code is compiled at all
    transform_free_joints(body_tree.jtype, body_tree.jtype, body_tree.iq, home, q, R, p)


@njit(**INLINE)
def place_joints(body_tree, q, R, p):
    """R[i], p[i] <- T_{lambda(i), i}(q) = M_{lambda(i), i} X_J(q_i) for every body i (R (nb, 3,
    3), p (nb, 3) m): the joint poses every recursion starts from. The kernels call it before
    their passes; the simulation step calls it once per evaluation and runs the kernels' passes
    on its result (their `*_on_poses` forms)."""
    jtype, iq, mult = body_tree.jtype, body_tree.iq, body_tree.mult
    offset, S, R_home, p_home = body_tree.offset, body_tree.S, body_tree.R_home, body_tree.p_home
    prepare_joint_transforms(body_tree, q, R, p)
    for i in range(jtype.shape[0]):
        if jtype[i] != FREE:
            theta = mult[i] * q[iq[i]] + offset[i]
            joint_transform(S[i], R_home[i], p_home[i], theta, R[i], p[i])


@njit(**INLINE)
def joint_motion(nv_i, S_i, mult, x, iv, out):
    """out (6,) <- S_i x_i = sum_k S_i[k] mult x[iv + k]: the joint's twist for x = v, its
    acceleration for x = vdot."""
    for r in range(6):
        out[r] = 0.0
    for k in range(nv_i):
        x_k = mult * x[iv + k]
        for r in range(6):
            out[r] += S_i[k, r] * x_k


@njit(**INLINE)
def add_joint_force(nv_i, S_i, mult, F, iv, tau):
    """tau[iv + k] += mult S_i[k] . F for the joint's rows of S: its share of the generalized
    force of the wrench F (transmitted by the joint, in {i})."""
    for k in range(nv_i):
        s = 0.0
        for r in range(6):
            s += S_i[k, r] * F[r]
        tau[iv + k] += mult * s


@njit(**JIT)
def quaternion_status(ibuf, q):
    """Q_NOT_UNIT_QUATERNION if a free joint's quaternion in q has a norm further than
    QUATERNION_TOLERANCE from 1, else OK."""
    nb = body_count(ibuf)
    jtype, iq = field(ibuf, nb, _JTYPE), field(ibuf, nb, _IQ)
    for i in range(nb):
        if jtype[i] == FREE:
            k = iq[i] + 3
            n = np.sqrt(q[k] ** 2 + q[k + 1] ** 2 + q[k + 2] ** 2 + q[k + 3] ** 2)
            if not abs(n - 1.0) <= QUATERNION_TOLERANCE:
                return Status.Q_NOT_UNIT_QUATERNION.value
    return Status.OK.value


check_quaternions = free_joints_only(quaternion_status)


@njit(**INLINE)
def configuration_status(ibuf, q):
    """Status of a configuration: CONVERT if q is not (nq,), Q_NOT_FINITE if q has NaN or inf,
    Q_NOT_UNIT_QUATERNION if a free joint's quaternion norm is further than
    QUATERNION_TOLERANCE from 1, else OK."""
    if q.shape[0] != config_count(ibuf):
        return Status.CONVERT.value
    if not all_finite(q):
        return Status.Q_NOT_FINITE.value
    return check_quaternions(ibuf, ibuf, q)


@njit(**INLINE)
def state_status(ibuf, q, qd):
    """Status of a state (q, qd): configuration_status(q), then CONVERT if qd is not (nv,),
    QD_NOT_FINITE if qd has NaN or inf, else OK: the checks every kernel taking a state opens
    with."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    return vector_status(ibuf, qd, Status.QD_NOT_FINITE.value)


@njit(**INLINE)
def vector_status(ibuf, x, not_finite):
    """Status of a velocity-like argument x (qd, qdd, tau): CONVERT if it is not (nv,),
    `not_finite` if it has NaN or inf, else OK."""
    if x.shape[0] != dof_count(ibuf):
        return Status.CONVERT.value
    return Status.OK.value if all_finite(x) else not_finite


@njit(**INLINE)
def motion_status(ibuf, q, qd, qdd):
    """Status of a state with accelerations (q, qd, qdd): state_status(q, qd), then
    vector_status(qdd) (CONVERT or QDD_NOT_FINITE), else OK: the checks of every kernel taking
    qdd."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    return vector_status(ibuf, qdd, Status.QDD_NOT_FINITE.value)


# ---- the configuration space: q (+) v and its inverse, per joint ----------------------------


@njit(**INLINE)
def quaternion_multiply(a, b, out):
    """out = a b for quaternions (x, y, z, w): (a_w b_u + b_w a_u + a_u x b_u, a_w b_w - a_u . b_u)."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    out[0] = aw * bx + bw * ax + ay * bz - az * by
    out[1] = aw * by + bw * ay + az * bx - ax * bz
    out[2] = aw * bz + bw * az + ax * by - ay * bx
    out[3] = aw * bw - ax * bx - ay * by - az * bz


@njit(**INLINE)
def normalize_quaternion(u):
    """u <- u / |u| for a quaternion (4,)."""
    n = np.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2 + u[3] ** 2)
    for k in range(4):
        u[k] /= n


@njit(**JIT)
def free_integrate(q, iq, v, iv, dt, q_next):
    """Free joint: T' = T exp([V] dt) with V = v[iv : iv + 6] the body twist (omega, v_b):

      phi = omega dt, rho = v_b dt, theta = |phi|,
      exp([V] dt) = (I + a [phi] + b [phi]^2,  (I + b [phi] + c [phi]^2) rho),
      a = sin(theta)/theta, b = (1 - cos theta)/theta^2, c = (theta - sin theta)/theta^3,
      p' = p + R (position part), quat' = quat (sin(theta/2) phi/theta, cos(theta/2)), normalised.
    (Lynch & Park, Proposition 3.25; series for theta < 1e-2.)"""
    # in registers: phi, rho and the products below are 3-vectors of scalars
    phi0, phi1, phi2 = v[iv] * dt, v[iv + 1] * dt, v[iv + 2] * dt
    rho0, rho1, rho2 = v[iv + 3] * dt, v[iv + 4] * dt, v[iv + 5] * dt
    t2 = phi0**2 + phi1**2 + phi2**2
    theta = np.sqrt(t2)
    if theta < 1e-2:
        b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0
        c = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0
        half = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0  # sin(theta/2)/theta
    else:
        b = 2.0 * np.sin(0.5 * theta) ** 2 / t2
        c = (theta - np.sin(theta)) / (t2 * theta)
        half = np.sin(0.5 * theta) / theta
    # p_e = rho + b phi x rho + c phi x (phi x rho), with x1 = phi x rho and x2 = phi x x1
    x10 = phi1 * rho2 - phi2 * rho1
    x11 = phi2 * rho0 - phi0 * rho2
    x12 = phi0 * rho1 - phi1 * rho0
    x20 = phi1 * x12 - phi2 * x11
    x21 = phi2 * x10 - phi0 * x12
    x22 = phi0 * x11 - phi1 * x10
    e0, e1, e2 = rho0 + b * x10 + c * x20, rho1 + b * x11 + c * x21, rho2 + b * x12 + c * x22
    quat = q[iq + 3 : iq + 7]
    R = quaternion_rows(quat[0], quat[1], quat[2], quat[3])
    for r in range(3):
        q_next[iq + r] = q[iq + r] + (R[r][0] * e0 + R[r][1] * e1 + R[r][2] * e2)
    n = np.sqrt(quat[0] ** 2 + quat[1] ** 2 + quat[2] ** 2 + quat[3] ** 2)
    unit = (quat[0] / n, quat[1] / n, quat[2] / n, quat[3] / n)
    step = (half * phi0, half * phi1, half * phi2, np.cos(0.5 * theta))
    quaternion_multiply(unit, step, q_next[iq + 3 : iq + 7])
    normalize_quaternion(q_next[iq + 3 : iq + 7])


@njit(**JIT)
def free_difference(q0, q1, iq, iv, v):
    """Free joint: v[iv : iv + 6] <- log(T_0^-1 T_1), the body twist that moves T_0 to T_1 in
    unit time (the inverse of free_integrate with dt = 1):

      quat_rel = conj(quat_0) quat_1 = (u, w) with w >= 0, theta = 2 atan2(|u|, w),
      phi = theta u / |u|,  rho = V^-1 R_0^T (p_1 - p_0)
    with V^-1 the SE(3) logarithm's translation map (spatial.compiled.se3_log_translation;
    Lynch & Park, Algorithm 3.2)."""
    a = np.empty(4)
    b = np.empty(4)
    for k in range(4):
        a[k] = q0[iq + 3 + k]
        b[k] = q1[iq + 3 + k]
    normalize_quaternion(a)
    normalize_quaternion(b)
    for k in range(3):
        a[k] = -a[k]
    rel = np.empty(4)
    quaternion_multiply(a, b, rel)
    if rel[3] < 0.0:
        for k in range(4):
            rel[k] = -rel[k]
    s = np.sqrt(rel[0] ** 2 + rel[1] ** 2 + rel[2] ** 2)
    w = rel[3]
    theta = 2.0 * np.arctan2(s, w)
    if s < 1e-3 * w:
        x2 = (s / w) ** 2
        scale = 2.0 / w * (1.0 - x2 / 3.0 + x2 * x2 / 5.0)  # theta / s
    else:
        scale = theta / s
    phi = np.empty(3)
    for k in range(3):
        phi[k] = scale * rel[k]
    R0 = quaternion_rows(q0[iq + 3], q0[iq + 4], q0[iq + 5], q0[iq + 6])
    dp = np.empty(3)
    for c in range(3):
        dp[c] = (
            R0[0][c] * (q1[iq] - q0[iq])
            + R0[1][c] * (q1[iq + 1] - q0[iq + 1])
            + R0[2][c] * (q1[iq + 2] - q0[iq + 2])
        )
    for k in range(3):
        v[iv + k] = phi[k]
    se3_log_translation(phi[0], phi[1], phi[2], theta, dp, v[iv + 3 : iv + 6])


integrate_free_joint = free_joints_only(free_integrate)
difference_free_joint = free_joints_only(free_difference)


@njit(**INLINE)
def joint_integrate(ibuf, jtype, q, iq, v, iv, dt, q_next):
    """q_next's coordinates of one joint <- its q_i (+) v_i dt: the exponential map of SE(3)
    for a free joint, q_i + v_i dt for a 1-dof joint. ibuf: the model's int buffer."""
    if jtype == FREE:
        integrate_free_joint(ibuf, q, iq, v, iv, dt, q_next)
    else:
        q_next[iq] = q[iq] + v[iv] * dt


@njit(**INLINE)
def joint_difference(ibuf, jtype, q0, q1, iq, iv, v):
    """v's coordinates of one joint <- q1_i (-) q0_i, the velocity that integrates q0_i to q1_i
    in unit time: log(T_0^-1 T_1) for a free joint, q1_i - q0_i for a 1-dof joint. ibuf: the
    model's int buffer."""
    if jtype == FREE:
        difference_free_joint(ibuf, q0, q1, iq, iv, v)
    else:
        v[iv] = q1[iq] - q0[iq]
