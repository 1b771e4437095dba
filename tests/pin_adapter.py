"""Pinocchio as an oracle for the tests, with the conversions between Pinocchio's conventions and
opendyn's written here, apart from opendyn.verify.oracle's: a convention slip there (which
`opendyn verify` uses) must not hide the same slip in opendyn.

PinOracle takes opendyn.verify's PinocchioOracle for which Pinocchio function answers what
(and the compositions for coupled mimic joints), and replaces every conversion it makes:

- q: a continuous joint is one angle in opendyn, (cos, sin) in Pinocchio; a free joint is
  (p, quat (x, y, z, w)) in both.
- velocities, accelerations, generalized forces: matched joint by joint by name; a free joint's
  (omega_b, v_b) in opendyn is (v_b, omega_b) in Pinocchio (both in the body frame).
- spatial rows (Jacobians, centroidal momentum): angular first in opendyn, linear first in
  Pinocchio.
- f_tip[frame] = (m, f), the wrench the frame applies TO THE ENVIRONMENT, in the frame's axes
  (tau = M a + h + J_b^T F); Pinocchio's fext[joint] is the force ON the body, in the joint
  frame (tau = M a + h - J^T fext).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from opendyn.multibody.joints import FREE
from opendyn.verify.oracle import PinocchioOracle


def angular_first(x, axis=0):
    """Pinocchio's linear-first 6-vectors (along `axis`) reordered angular first."""
    x = np.asarray(x)
    angular, linear = np.take(x, [3, 4, 5], axis=axis), np.take(x, [0, 1, 2], axis=axis)
    return np.concatenate([angular, linear], axis=axis)


# kept for the tests that import it
swap_halves = angular_first


def free_bodies_model(od_model):
    """Pinocchio's model of an opendyn model whose bodies are all rigid bodies on free joints
    at the root (a scene's primitive objects, [[objects]], which no URDF describes), built
    joint by joint: per body a JointModelFreeFlyer named as the body's joint, placed at the
    body's home pose, carrying the body's inertia (read from its spatial inertia G), and the
    model's gravity."""
    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(od_model.gravity, float), np.zeros(3))
    for i, name in enumerate(od_model.body_joints):
        if od_model.parent[i] >= 0 or od_model.jtype[i] != FREE:
            raise ValueError(f"body {od_model.body_names[i]!r} is not a free body at the root")
        placement = pin.SE3(np.asarray(od_model.R_home[i]), np.asarray(od_model.p_home[i]))
        joint = model.addJoint(0, pin.JointModelFreeFlyer(), placement, name)
        # G = [[I_c + m [c][c]^T, m [c]], [m [c]^T, m 1]] (opendyn.spatial.algebra)
        G = np.asarray(od_model.G[i])
        mass = G[3, 3]
        c = np.array([G[2, 4], G[0, 5], G[1, 3]]) / mass
        I_c = G[:3, :3] - mass * pin.skew(c) @ pin.skew(c).T
        model.appendBodyToJoint(joint, pin.Inertia(mass, c, I_c), pin.SE3.Identity())
    return model


class PinOracle(PinocchioOracle):
    """PinocchioOracle with the conversions of this module (see its docstring). With no URDF
    (urdf_path empty: the model of a scene's objects alone) its Pinocchio model is
    free_bodies_model's; its conversions are the same."""

    def __init__(self, urdf_path, od_model, mimic=False):
        if urdf_path:
            super().__init__(urdf_path, od_model, mimic)
        else:
            self.pin, self.od, self.coupled = pin, od_model, od_model.coupled
            self.model = free_bodies_model(od_model)
            self.data = self.model.createData()
        model = self.model
        order = np.full(od_model.nv, -1)  # order[k]: Pinocchio's index of opendyn's v_k
        self.free_q = []  # (opendyn q index, Pinocchio q index) of each free joint
        self.angles = []  # (opendyn q index, Pinocchio q index, continuous?) of each named joint
        for b, name in enumerate(od_model.body_joints):
            joint = model.joints[model.getJointId(name)]
            if name in od_model.joint_names or joint.nq != 7:
                continue
            iq, iv = od_model.iq[b], od_model.iv[b]
            self.free_q.append((iq, joint.idx_q))
            order[iv : iv + 3] = joint.idx_v + np.arange(3, 6)  # omega_b
            order[iv + 3 : iv + 6] = joint.idx_v + np.arange(3)  # v_b
        for k, name in enumerate(od_model.joint_names):
            joint = model.joints[model.getJointId(name)]
            assert joint.nv == 1, name
            order[od_model.v_index[k]] = joint.idx_v
            self.angles.append((od_model.q_index[k], joint.idx_q, joint.nq == 2))
        assert sorted(order) == list(range(model.nv)), order
        self.perm_v = order

    # conversions -------------------------------------------------------------------------
    def q(self, q):
        out = pin.neutral(self.model)
        for ours, theirs in self.free_q:
            out[theirs : theirs + 7] = q[ours : ours + 7]
        for ours, theirs, continuous in self.angles:
            if continuous:
                out[theirs], out[theirs + 1] = np.cos(q[ours]), np.sin(q[ours])
            else:
                out[theirs] = q[ours]
        return out

    def v(self, x):
        out = np.zeros(self.model.nv)
        out[self.perm_v] = x
        return out

    def back(self, x):
        return np.asarray(x)[self.perm_v]

    def back_matrix(self, X):
        return np.asarray(X)[self.perm_v][:, self.perm_v]

    def fext(self, q, f_tip):
        fext = [pin.Force.Zero() for _ in range(self.model.njoints)]
        for name, F in (f_tip or {}).items():
            frame = self.model.frames[self.frame_id(name)]
            R, p = frame.placement.rotation, frame.placement.translation  # joint <- frame
            m, f = np.asarray(F[:3], float), np.asarray(F[3:], float)
            f_joint = R @ f
            m_joint = R @ m + np.cross(p, f_joint)  # the moment moved to the joint's origin
            fext[frame.parentJoint] += pin.Force(-f_joint, -m_joint)  # on the body: -F
        return pin.StdVec_Force(fext)

    def jacobian(self, q, frame, expressed_in="space"):
        ref = pin.WORLD if expressed_in == "space" else pin.LOCAL
        J = pin.computeFrameJacobian(self.model, self.data, self.q(q), self.frame_id(frame), ref)
        return angular_first(J)[:, self.perm_v]

    def centroidal_momentum_matrix(self, q):
        A_g = pin.ccrba(self.model, self.data, self.q(q), np.zeros(self.model.nv))
        return angular_first(A_g)[:, self.perm_v]

    def centroidal_momentum(self, q, qd):
        h_g = pin.computeCentroidalMomentum(self.model, self.data, self.q(q), self.v(qd))
        return angular_first(h_g.vector)

    def centroidal_momentum_rate_bias(self, q, qd):
        v = self.v(qd)
        return angular_first(pin.dccrba(self.model, self.data, self.q(q), v) @ v)


__all__ = ["PinOracle", "angular_first", "free_bodies_model", "swap_halves"]
