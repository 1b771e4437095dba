"""Pinocchio as the oracle, in opendyn's conventions: ``PinocchioOracle`` answers every contract
function for the same URDF, taking and returning opendyn's q, vectors, twists and wrenches.

Pinocchio (the ``pin`` package) is the oracle and a test dependency only: it is imported when
``verify`` or ``PinocchioOracle`` is called, never when opendyn is imported.
``PinocchioOracle`` holds every conversion between Pinocchio's conventions and opendyn's, once:

- Pinocchio's spatial vectors are linear first (v, omega) and forces (f, m); opendyn's are
  angular first (omega, v) and (m, f).
- A continuous joint is (cos, sin) in Pinocchio's q and one angle in opendyn's.
- A free joint (a floating base, Pinocchio's JointModelFreeFlyer) has the same q (p, quat
  (x, y, z, w)); its velocity and force are linear first in Pinocchio, (v_b, omega_b) and
  (f_b, m_b), angular first in opendyn: one permutation of v, `perm_v`, maps both.
- Pinocchio's joint order may differ; joints are matched by name.
- Pinocchio's external forces ``fext[joint]`` act ON the body, in the joint frame, and enter as
  tau = M a + h - J^T fext; opendyn's ``f_tip[frame]`` is the wrench the frame applies TO THE
  ENVIRONMENT, in the frame's coordinates: tau = M a + h + J_b^T F.
- With coupled mimic joints Pinocchio has no ABA, Coriolis matrix or energies; the oracle then
  composes them from Pinocchio's RNEA, CRBA and centre of mass (see each method).
"""

from __future__ import annotations

import numpy as np

from ..io.urdf_model import ROOT_JOINT
from ..multibody.joints import FREE
from ..spatial.algebra import angular, linear

PINOCCHIO_MISSING = "opendyn verify needs Pinocchio: pip install pin"


class PinocchioMissingError(ImportError):
    """Pinocchio is not installed; the message says how to install it."""

    def __init__(self, message=PINOCCHIO_MISSING):
        super().__init__(message)


def import_pinocchio():
    """The ``pinocchio`` module; PinocchioMissingError (an ImportError) when not installed."""
    try:
        import pinocchio
    except ImportError as e:
        raise PinocchioMissingError() from e
    return pinocchio


def swap_halves(x, axis=0):
    """Linear-first <-> angular-first: swap the two 3-blocks of an axis of length 6."""
    x = np.asarray(x)
    return np.concatenate(
        [np.take(x, range(3, 6), axis=axis), np.take(x, range(0, 3), axis=axis)], axis=axis
    )


def symmetric(X):
    """A symmetric matrix of which Pinocchio may have filled only the upper triangle (releases
    differ): the upper one mirrored where the lower one is all zero, else X as it is."""
    X = np.array(X)
    if X[np.tril_indices_from(X, -1)].any():
        return X
    return np.triu(X) + np.triu(X, 1).T


class PinocchioOracle:
    """A Pinocchio model of the same URDF, with opendyn-ordered inputs and outputs.

    Every method takes and returns opendyn's conventions: q (nv,) with one angle per continuous
    joint, vectors in ``od_model.joint_names`` order, twists and wrenches angular first, f_tip
    as the wrenches frames apply to the environment, gravity a world-frame (3,) vector (m/s^2,
    None = (0, 0, -9.81)).
    """

    def __init__(self, urdf_path, od_model, mimic=False):
        """urdf_path: the URDF file ``od_model`` was loaded from; mimic: couple mimic joints,
        as ``od_model`` was loaded; a floating base (a free joint named "root_joint") is given
        to Pinocchio as a JointModelFreeFlyer root. Raises PinocchioMissingError without
        Pinocchio, KeyError naming a joint Pinocchio lacks, ValueError when the two models
        disagree on nv."""
        pin = self.pin = import_pinocchio()
        added_root = od_model.floating_base and ROOT_JOINT in od_model.body_joints
        if added_root:
            self.model = pin.buildModelFromUrdf(str(urdf_path), pin.JointModelFreeFlyer(), mimic)
        else:
            self.model = pin.buildModelFromUrdf(str(urdf_path), mimic)
        self.data = self.model.createData()
        self.od = od_model
        # coupled mimic joints: Pinocchio's ABA, Coriolis matrix and energies refuse them
        self.coupled = od_model.coupled
        if self.model.nv != od_model.nv:
            raise ValueError(
                f"Pinocchio's model of {urdf_path} has nv={self.model.nv}, opendyn's "
                f"{od_model.nv} (mimic={mimic}: load both with the same mimic choice)"
            )
        # perm_v[k]: Pinocchio's index of opendyn's velocity coordinate k
        self.perm_v = np.empty(od_model.nv, dtype=int)
        self.free = []  # (opendyn q index, Pinocchio q index) of each free joint
        for i in range(od_model.nb):
            if od_model.jtype[i] != FREE:
                continue
            joint = self.model.joints[self._joint_id(od_model.body_joints[i], urdf_path)]
            iv = od_model.iv[i]
            self.perm_v[iv : iv + 3] = joint.idx_v + np.arange(3, 6)
            self.perm_v[iv + 3 : iv + 6] = joint.idx_v + np.arange(3)
            self.free.append((od_model.iq[i], joint.idx_q))
        nj = len(od_model.joint_names)
        self.idx_q = np.empty(nj, dtype=int)
        self.cos_sin = np.zeros(nj, dtype=bool)
        for k, name in enumerate(od_model.joint_names):
            joint = self.model.joints[self._joint_id(name, urdf_path)]
            self.idx_q[k] = joint.idx_q
            self.perm_v[od_model.v_index[k]] = joint.idx_v
            self.cos_sin[k] = joint.nq == 2

    def _joint_id(self, name, urdf_path):
        jid = self.model.getJointId(name)
        if jid >= self.model.njoints:
            raise KeyError(f"Pinocchio model of {urdf_path} has no joint {name!r}")
        return jid

    # conversions -------------------------------------------------------------------------
    def q(self, q):
        """opendyn q (nq,) -> Pinocchio q: (cos, sin) for continuous joints, free joints'
        (p, quat) as they are."""
        out = self.pin.neutral(self.model)
        for ours, theirs in self.free:
            out[theirs : theirs + 7] = q[ours : ours + 7]
        for k, iq in enumerate(self.od.q_index):
            if self.cos_sin[k]:
                out[self.idx_q[k] : self.idx_q[k] + 2] = np.cos(q[iq]), np.sin(q[iq])
            else:
                out[self.idx_q[k]] = q[iq]
        return out

    def v(self, x):
        """An opendyn-ordered (nv,) velocity, acceleration or generalized force in Pinocchio's
        order (and a free joint's halves linear first)."""
        out = np.zeros(self.model.nv)
        out[self.perm_v] = x
        return out

    def back(self, x):
        """A Pinocchio v-ordered vector (or the first axis of an array) in opendyn order."""
        return np.asarray(x)[self.perm_v]

    def back_matrix(self, X):
        """A Pinocchio (nv, nv) matrix in opendyn order (rows and columns)."""
        return np.asarray(X)[np.ix_(self.perm_v, self.perm_v)]

    def frame_id(self, name):
        """Pinocchio's frame id of a link (BODY frame) or, failing that, any frame so named;
        KeyError naming the frame when Pinocchio has none."""
        fid = self.model.getFrameId(name, self.pin.BODY)
        if fid >= self.model.nframes:
            fid = self.model.getFrameId(name)
        if fid >= self.model.nframes:
            raise KeyError(f"Pinocchio's model has no frame {name!r}")
        return fid

    def fext(self, q, f_tip):
        """opendyn f_tip {frame: (m, f) applied to the environment} -> Pinocchio fext."""
        pin = self.pin
        fext = [pin.Force.Zero() for _ in range(self.model.njoints)]
        for name, F in (f_tip or {}).items():
            frame = self.model.frames[self.frame_id(name)]
            F = np.asarray(F, dtype=float)
            on_body = pin.Force(-linear(F), -angular(F))
            fext[frame.parentJoint] += frame.placement.act(on_body)
        return pin.StdVec_Force(fext)

    # dynamics, all in opendyn's conventions ----------------------------------------------
    def set_gravity(self, gravity):
        """Set Pinocchio's gravity to a world-frame (3,) vector, None = (0, 0, -9.81)."""
        self.model.gravity.linear = np.array([0, 0, -9.81] if gravity is None else gravity)

    def rnea(self, q, qd, qdd, f_tip=None, gravity=None):
        """tau (nv,) = M qdd + h + sum J_b^T F_tip, by Pinocchio's RNEA."""
        pin = self.pin
        self.set_gravity(gravity)
        args = (self.model, self.data, self.q(q), self.v(qd), self.v(qdd))
        tau = pin.rnea(*args, self.fext(q, f_tip)) if f_tip else pin.rnea(*args)
        return self.back(tau)

    def mass_matrix(self, q):
        """M (nv, nv), by Pinocchio's CRBA (upper triangle mirrored)."""
        M = self.pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return self.back_matrix(M)

    def aba(self, q, qd, tau, f_tip=None, gravity=None):
        """qdd (nv,) by Pinocchio's ABA; with coupled mimic joints (no ABA in Pinocchio),
        M^-1 (tau - rnea(q, qd, 0, f_tip)) from Pinocchio's CRBA and RNEA."""
        pin = self.pin
        if self.coupled:
            rhs = tau - self.rnea(q, qd, np.zeros(self.od.nv), f_tip, gravity)
            return np.linalg.solve(self.mass_matrix(q), rhs)
        self.set_gravity(gravity)
        args = (self.model, self.data, self.q(q), self.v(qd), self.v(tau))
        qdd = pin.aba(*args, self.fext(q, f_tip)) if f_tip else pin.aba(*args)
        return self.back(qdd)

    def rnea_derivatives(self, q, qd, qdd, f_tip=None, gravity=None):
        """(dtau_dq, dtau_dqd, M) (nv, nv) each by computeRNEADerivatives (M's lower triangle
        mirrored where Pinocchio leaves it zero); q-derivatives in the tangent space, as
        opendyn's. With coupled mimic joints (which it refuses), central differences of
        Pinocchio's RNEA, Richardson-extrapolated (error about 1e-10 relative)."""
        pin = self.pin
        if self.coupled:
            return self._rnea_differences(q, qd, qdd, f_tip, gravity)
        self.set_gravity(gravity)
        args = (self.model, self.data, self.q(q), self.v(qd), self.v(qdd))
        if f_tip:
            dq, dv, da = pin.computeRNEADerivatives(*args, self.fext(q, f_tip))
        else:
            dq, dv, da = pin.computeRNEADerivatives(*args)
        return self.back_matrix(dq), self.back_matrix(dv), self.back_matrix(symmetric(da))

    def aba_derivatives(self, q, qd, tau, f_tip=None, gravity=None):
        """(dqdd_dq, dqdd_dqd, M^-1) (nv, nv) each by computeABADerivatives (M^-1's lower
        triangle mirrored where Pinocchio leaves it zero). With coupled mimic joints (no ABA
        in Pinocchio), -M^-1 (dtau_dq, dtau_dqd) at qdd = M^-1 (tau - rnea(q, qd, 0)), all from
        rnea_derivatives (differences of Pinocchio's RNEA: its CRBA does not always agree with
        its RNEA on coupled joints)."""
        pin = self.pin
        if self.coupled:
            zero = np.zeros(self.od.nv)
            M = self.rnea_derivatives(q, qd, zero, f_tip, gravity)[2]
            qdd = np.linalg.solve(M, tau - self.rnea(q, qd, zero, f_tip, gravity))
            dq, dv, _ = self.rnea_derivatives(q, qd, qdd, f_tip, gravity)
            Minv = np.linalg.inv(M)
            return -Minv @ dq, -Minv @ dv, Minv
        self.set_gravity(gravity)
        args = (self.model, self.data, self.q(q), self.v(qd), self.v(tau))
        if f_tip:
            dq, dv, Minv = pin.computeABADerivatives(*args, self.fext(q, f_tip))
        else:
            dq, dv, Minv = pin.computeABADerivatives(*args)
        return self.back_matrix(dq), self.back_matrix(dv), self.back_matrix(symmetric(Minv))

    def _rnea_differences(self, q, qd, qdd, f_tip, gravity):
        """Central differences of Pinocchio's RNEA in q (along opendyn's integrate), qd and
        qdd, each Richardson-extrapolated from steps h and h/2."""
        from ..algorithm.configuration import integrate

        n = self.od.nv
        E = np.eye(n)

        def central(f, h):
            return np.stack([(f(h * E[k]) - f(-h * E[k])) / (2 * h) for k in range(n)], 1)

        def richardson(f, h=1e-3):
            return (4 * central(f, h / 2) - central(f, h)) / 3

        def tau(q_, qd_, qdd_):
            return self.rnea(q_, qd_, qdd_, f_tip, gravity)

        return (
            richardson(lambda e: tau(integrate(self.od, q, e, 1.0), qd, qdd)),
            richardson(lambda e: tau(q, qd + e, qdd)),
            richardson(lambda e: tau(q, qd, qdd + e)),
        )

    def gravity_forces(self, q, gravity=None):
        """g (nv,), by Pinocchio's computeGeneralizedGravity."""
        self.set_gravity(gravity)
        return self.back(self.pin.computeGeneralizedGravity(self.model, self.data, self.q(q)))

    def coriolis_matrix(self, q, qd):
        """C (nv, nv) by Pinocchio's computeCoriolisMatrix; with coupled mimic joints (which
        it does not project consistently), C[i, j] = sum_k Gamma[i, j, k] qd_k from
        ``christoffel``, which is the Coriolis matrix only when every velocity coordinate is
        the rate of a coordinate (a fixed base): ValueError on a floating base then."""
        if self.coupled and self.od.floating_base:
            raise ValueError(
                "no Coriolis matrix reference for coupled mimic joints on a floating base"
            )
        if self.coupled:
            return np.einsum("ijk,k->ij", self.christoffel(q), qd)
        C = self.pin.computeCoriolisMatrix(self.model, self.data, self.q(q), self.v(qd))
        return self.back_matrix(C)

    def christoffel(self, q):
        """Gamma[i, j, k] from c(qd) = qd^T Gamma qd being quadratic (exact polarisation):
        Gamma[:, j, k] = (c(e_j + e_k) - c(e_j - e_k)) / 4, with c from Pinocchio's RNEA."""
        pin = self.pin
        n = self.od.nv
        self.set_gravity((0.0, 0.0, 0.0))
        qp, zero = self.q(q), np.zeros(self.model.nv)

        def c(qd):
            return self.back(pin.rnea(self.model, self.data, qp, self.v(qd), zero))

        E = np.eye(n)
        Gamma = np.empty((n, n, n))
        for j in range(n):
            for k in range(j, n):
                Gamma[:, j, k] = Gamma[:, k, j] = (c(E[j] + E[k]) - c(E[j] - E[k])) / 4.0
        self.set_gravity(None)
        return Gamma

    def frame_pose(self, q, frame):
        """T_sf (4, 4) of a frame, by Pinocchio's framesForwardKinematics."""
        self.pin.framesForwardKinematics(self.model, self.data, self.q(q))
        return self.data.oMf[self.frame_id(frame)].homogeneous

    def jacobian(self, q, frame, expressed_in="space"):
        """J_s (WORLD) or J_b (LOCAL) (6, nv), angular rows first, by computeFrameJacobian."""
        pin = self.pin
        ref = pin.WORLD if expressed_in == "space" else pin.LOCAL
        J = pin.computeFrameJacobian(self.model, self.data, self.q(q), self.frame_id(frame), ref)
        return swap_halves(J, axis=0)[:, self.perm_v]

    def kinetic_energy(self, q, qd):
        """K = qd^T M qd / 2 by computeKineticEnergy; with coupled mimic joints (which it
        refuses), from Pinocchio's CRBA."""
        if self.coupled:
            return 0.5 * float(qd @ self.mass_matrix(q) @ qd)
        return self.pin.computeKineticEnergy(self.model, self.data, self.q(q), self.v(qd))

    def potential_energy(self, q, gravity=None):
        """U = -sum_i m_i g . c_i by computePotentialEnergy; with coupled mimic joints (which
        it refuses), -m g . c from Pinocchio's centre of mass c and total mass m."""
        pin = self.pin
        self.set_gravity(gravity)
        if self.coupled:
            com = pin.centerOfMass(self.model, self.data, self.q(q))
            return -float(self.data.mass[0]) * float(np.dot(self.model.gravity.linear, com))
        return pin.computePotentialEnergy(self.model, self.data, self.q(q))

    def task_space_mass_matrix(self, q, frame, max_condition=np.inf):
        """Lambda = (J_b M^-1 J_b^T)^-1 (6, 6), angular first, from Pinocchio's LOCAL frame
        Jacobian and CRBA, and the condition number of J_b M^-1 J_b^T; Lambda is None where
        that exceeds max_condition (inf where singular)."""
        J_b = self.jacobian(q, frame, "body")
        Lambda_inv = J_b @ np.linalg.solve(self.mass_matrix(q), J_b.T)
        sv = np.linalg.svd(Lambda_inv, compute_uv=False)
        condition = float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf
        if not condition <= max_condition:
            return None, condition
        return np.linalg.inv(Lambda_inv), condition

    # centroidal dynamics and the inertial-parameter regressor ----------------------------
    def center_of_mass(self, q):
        """c (3,), world frame, by Pinocchio's centerOfMass."""
        return np.array(self.pin.centerOfMass(self.model, self.data, self.q(q)))

    def center_of_mass_jacobian(self, q):
        """J_c (3, nv), by Pinocchio's jacobianCenterOfMass (columns in opendyn's order)."""
        J_c = self.pin.jacobianCenterOfMass(self.model, self.data, self.q(q))
        return np.asarray(J_c)[:, self.perm_v]

    def centroidal_momentum_matrix(self, q):
        """A_G (6, nv), angular rows first, by Pinocchio's ccrba (rows linear first there)."""
        A_g = self.pin.ccrba(self.model, self.data, self.q(q), np.zeros(self.model.nv))
        return swap_halves(A_g, axis=0)[:, self.perm_v]

    def centroidal_momentum(self, q, qd):
        """h_G (6,), angular first, by Pinocchio's computeCentroidalMomentum."""
        h_g = self.pin.computeCentroidalMomentum(self.model, self.data, self.q(q), self.v(qd))
        return swap_halves(h_g.vector)

    def centroidal_momentum_rate_bias(self, q, qd):
        """Adot_G qd (6,), angular first, from Pinocchio's dccrba (the time derivative of A_G)."""
        v = self.v(qd)
        dA_g = self.pin.dccrba(self.model, self.data, self.q(q), v)
        return swap_halves(dA_g @ v)

    def torque_regressor(self, q, qd, qdd, gravity=None):
        """Y (nv, 10 nb), by Pinocchio's computeJointTorqueRegressor: rows in opendyn's order,
        columns by opendyn's bodies (each body's joint), 10 per body in Pinocchio's order
        (m, m c, I about the joint frame's origin: xx, xy, yy, xz, yz, zz)."""
        self.set_gravity(gravity)
        Y = self.pin.computeJointTorqueRegressor(
            self.model, self.data, self.q(q), self.v(qd), self.v(qdd)
        )
        self.set_gravity(None)
        ids = [self.model.getJointId(name) for name in self.od.body_joints]
        columns = np.array([10 * (j - 1) + k for j in ids for k in range(10)], dtype=int)
        return np.asarray(Y)[np.ix_(self.perm_v, columns)]
