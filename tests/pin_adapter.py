"""Pinocchio as an oracle: every conversion between its conventions and opendyn's, written once.

Pinocchio's spatial vectors are linear first (v, w) and forces (f, m); opendyn's are angular
first. A continuous joint is (cos, sin) in Pinocchio's q and one angle in opendyn's. Pinocchio's
joint order may differ; joints are matched by name. Pinocchio's external forces `fext[joint]` act
ON the body, in the joint frame, and enter as tau = M a + h - J^T fext; opendyn's f_tip[frame]
is the wrench the frame applies TO THE ENVIRONMENT, in the frame: tau = M a + h + J_b^T F.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def swap_halves(x, axis=0):
    """Linear-first <-> angular-first along an axis of length 6."""
    x = np.asarray(x)
    return np.concatenate(
        [np.take(x, range(3, 6), axis=axis), np.take(x, range(0, 3), axis=axis)], axis=axis
    )


class PinOracle:
    """A Pinocchio model of the same URDF, with opendyn-ordered inputs and outputs."""

    def __init__(self, urdf_path, od_model, mimic=False):
        self.model = pin.buildModelFromUrdf(str(urdf_path), mimic)
        self.data = self.model.createData()
        self.od = od_model
        nv = od_model.nv
        self.idx_q = np.empty(nv, dtype=int)
        self.idx_v = np.empty(nv, dtype=int)
        self.cos_sin = np.zeros(nv, dtype=bool)
        for k, name in enumerate(od_model.joint_names):
            jid = self.model.getJointId(name)
            if jid >= self.model.njoints:
                raise KeyError(f"Pinocchio model has no joint {name!r}")
            joint = self.model.joints[jid]
            self.idx_q[k], self.idx_v[k] = joint.idx_q, joint.idx_v
            self.cos_sin[k] = joint.nq == 2
        assert self.model.nv == nv, (self.model.nv, nv)

    # conversions -------------------------------------------------------------------------
    def q(self, q):
        out = pin.neutral(self.model)
        for k in range(len(q)):
            if self.cos_sin[k]:
                out[self.idx_q[k] : self.idx_q[k] + 2] = np.cos(q[k]), np.sin(q[k])
            else:
                out[self.idx_q[k]] = q[k]
        return out

    def v(self, x):
        out = np.zeros(self.model.nv)
        out[self.idx_v] = x
        return out

    def back(self, x):
        """A Pinocchio v-ordered vector (or the first axis of an array) in opendyn order."""
        return np.asarray(x)[self.idx_v]

    def back_matrix(self, X):
        return np.asarray(X)[np.ix_(self.idx_v, self.idx_v)]

    def frame_id(self, name):
        fid = self.model.getFrameId(name, pin.BODY)
        if fid >= self.model.nframes:
            fid = self.model.getFrameId(name)
        return fid

    def fext(self, q, f_tip):
        """opendyn f_tip {frame: (m, f) applied to the environment} -> Pinocchio fext."""
        fext = [pin.Force.Zero() for _ in range(self.model.njoints)]
        for name, F in (f_tip or {}).items():
            frame = self.model.frames[self.frame_id(name)]
            F = np.asarray(F, dtype=float)
            on_body = pin.Force(-F[3:], -F[:3])
            fext[frame.parentJoint] += frame.placement.act(on_body)
        return pin.StdVec_Force(fext)

    # dynamics, all in opendyn's conventions ----------------------------------------------
    def set_gravity(self, gravity):
        self.model.gravity.linear = np.array([0, 0, -9.81] if gravity is None else gravity)

    def rnea(self, q, qd, qdd, f_tip=None, gravity=None):
        self.set_gravity(gravity)
        args = (self.model, self.data, self.q(q), self.v(qd), self.v(qdd))
        tau = pin.rnea(*args, self.fext(q, f_tip)) if f_tip else pin.rnea(*args)
        return self.back(tau)

    def mass_matrix(self, q):
        M = pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return self.back_matrix(M)

    def aba(self, q, qd, tau, f_tip=None, gravity=None):
        self.set_gravity(gravity)
        args = (self.model, self.data, self.q(q), self.v(qd), self.v(tau))
        qdd = pin.aba(*args, self.fext(q, f_tip)) if f_tip else pin.aba(*args)
        return self.back(qdd)

    def gravity_forces(self, q, gravity=None):
        self.set_gravity(gravity)
        return self.back(pin.computeGeneralizedGravity(self.model, self.data, self.q(q)))

    def coriolis_matrix(self, q, qd):
        C = pin.computeCoriolisMatrix(self.model, self.data, self.q(q), self.v(qd))
        return self.back_matrix(C)

    def christoffel(self, q):
        """Gamma[i, j, k] from c(qd) = qd^T Gamma qd being quadratic (exact polarisation):
        Gamma[:, j, k] = (c(e_j + e_k) - c(e_j - e_k)) / 4, with c from Pinocchio's RNEA."""
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
        pin.framesForwardKinematics(self.model, self.data, self.q(q))
        return self.data.oMf[self.frame_id(frame)].homogeneous

    def jacobian(self, q, frame, expressed_in="space"):
        ref = pin.WORLD if expressed_in == "space" else pin.LOCAL
        J = pin.computeFrameJacobian(self.model, self.data, self.q(q), self.frame_id(frame), ref)
        return swap_halves(J, axis=0)[:, self.idx_v]

    def kinetic_energy(self, q, qd):
        return pin.computeKineticEnergy(self.model, self.data, self.q(q), self.v(qd))

    def potential_energy(self, q, gravity=None):
        self.set_gravity(gravity)
        return pin.computePotentialEnergy(self.model, self.data, self.q(q))
