"""An independent reference for ground contact on a floating robot: the contact law of
docs/guides/contact.md written here in numpy, the rigid-body dynamics by Pinocchio (its
kinematics and ABA, with opendyn's conventions converted by pin_adapter) and the integration by
scipy's solve_ivp. Nothing of opendyn computes a force, an acceleration or a step here: the scene
is read for its settings only (the robot's URDF, the initial state, the gains and the contact
parameters).

The law, at each contact sphere (centre c welded to a frame, radius r), at its lowest point
x = c - r e_z, world frame: delta = h - x_z; while delta > 0, with v_p the velocity of the body's
material at x, f_n = max(0, k delta - d v_z), f_t = -mu f_n v_t / sqrt(|v_t|^2 + v_s^2), the
force (f_t, f_n) acting on the body at x. A PD controller tau = kp (q_set - q) - kd qd acts at
the joints; gravity is the scene's world-frame vector.

The state integrated is Pinocchio's (q, v): a free-flyer q = (p, quat xyzw, joints), v = (v_b,
omega_b, joints) in the body frame, so dp/dt = R v_b and dquat/dt = quat (x) (omega_b, 0) / 2;
the quaternion is normalised where it is read, never changed in the state.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from pin_adapter import PinOracle
from scipy.integrate import solve_ivp


class ContactReference:
    """The equations of motion of a scene with gravity, ground contact and PD control, in
    Pinocchio's coordinates. Refuses a scene with any other effect."""

    def __init__(self, scene):
        assert set(scene.effects) <= {"gravity", "contact", "control"}, scene.effects
        assert scene.control is None or scene.control.kind == "pd"
        model = scene.model
        self.oracle = oracle = PinOracle(model.source, model)
        self.pmodel, self.pdata = oracle.model, oracle.model.createData()
        self.pmodel.gravity.linear = np.zeros(3) if scene.gravity is None else scene.gravity
        self.nq, self.nv = self.pmodel.nq, self.pmodel.nv
        c = scene.contact
        self.h, self.k, self.d = c.ground_height, c.stiffness, c.damping
        self.mu, self.v_s = c.friction, c.slip_velocity
        self.frames = [oracle.frame_id(p.frame) for p in c.points]
        self.centres = [np.asarray(p.position, float) for p in c.points]
        self.radii = [p.radius for p in c.points]
        # the PD law at the joints, in Pinocchio's order (the free flyer's 6 rows get none)
        self.kp, self.kd = np.zeros(self.nv), np.zeros(self.nv)
        self.q_set = np.zeros(self.nv)
        self.joint_q = np.zeros(self.nv, dtype=int)  # Pinocchio's q index of each v row
        if scene.control is not None:
            ctl = scene.control
            n = len(model.joint_names)
            kp, kd = np.broadcast_to(ctl.kp, n), np.broadcast_to(ctl.kd, n)
            setpoint = np.broadcast_to(ctl.setpoint, n)
            for k, name in enumerate(model.joint_names):
                joint = self.pmodel.joints[self.pmodel.getJointId(name)]
                assert joint.nq == 1 and joint.nv == 1, name
                self.kp[joint.idx_v], self.kd[joint.idx_v] = kp[k], kd[k]
                self.q_set[joint.idx_v] = setpoint[k]
                self.joint_q[joint.idx_v] = joint.idx_q
        self.y0 = np.concatenate([oracle.q(scene.q0), oracle.v(scene.qd0)])

    def config(self, y):
        q = y[: self.nq].copy()
        q[3:7] /= np.linalg.norm(q[3:7])
        return q

    def contacts(self, q, v):
        """(x (P, 3), f (P, 3), delta (P,), fext): each sphere's lowest point, the ground's
        force there and the penetration (0 off the ground), all in the world frame, and the
        forces as Pinocchio's fext (on each joint's body, in its frame, about its origin).
        Needs forwardKinematics(q, v) done."""
        model, data = self.pmodel, self.pdata
        n = len(self.frames)
        x, f, delta = np.empty((n, 3)), np.zeros((n, 3)), np.zeros(n)
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        for p, (fid, c_f, r) in enumerate(zip(self.frames, self.centres, self.radii)):
            frame = model.frames[fid]
            oMi = data.oMi[frame.parentJoint]
            c_i = frame.placement.act(c_f)  # the centre in the joint's frame
            x_i = c_i - oMi.rotation.T @ np.array([0.0, 0.0, r])  # the lowest point, ditto
            x[p] = oMi.act(x_i)
            delta_p = self.h - x[p, 2]
            if delta_p <= 0.0:
                continue
            delta[p] = delta_p
            twist = data.v[frame.parentJoint]  # the body's twist, its frame, about its origin
            v_p = oMi.rotation @ (twist.linear + np.cross(twist.angular, x_i))
            f_n = max(0.0, self.k * delta_p - self.d * v_p[2])
            f_t = -self.mu * f_n * v_p[:2] / np.sqrt(v_p[0] ** 2 + v_p[1] ** 2 + self.v_s**2)
            f[p] = f_t[0], f_t[1], f_n
            f_i = oMi.rotation.T @ f[p]
            fext[frame.parentJoint] += pin.Force(f_i, np.cross(x_i, f_i))
        return x, f, delta, pin.StdVec_Force(fext)

    def rhs(self, t, y):
        q, v = self.config(y), y[self.nq :]
        pin.forwardKinematics(self.pmodel, self.pdata, q, v)
        fext = self.contacts(q, v)[3]
        tau = self.kp * (self.q_set - q[self.joint_q]) - self.kd * v
        tau[:6] = 0.0
        a = pin.aba(self.pmodel, self.pdata, q, v, tau, fext)
        # the free flyer's configuration rates; the joints' q rates are their v
        dq = np.empty(self.nq)
        R = pin.Quaternion(q[3:7]).toRotationMatrix()
        dq[:3] = R @ v[:3]
        qx, qy, qz, qw = y[3:7]
        wx, wy, wz = v[3:6]
        dq[3:7] = 0.5 * np.array(
            [
                qw * wx + qy * wz - qz * wy,
                qw * wy + qz * wx - qx * wz,
                qw * wz + qx * wy - qy * wx,
                -(qx * wx + qy * wy + qz * wz),
            ]
        )
        dq[7:] = v[6:]
        return np.concatenate([dq, a])

    def solve(self, t, rtol, atol, y0=None, method="LSODA"):
        """The motion from y0 (default the scene's initial state) over t[0]..t[-1], sampled at
        t, in opendyn's conventions: (q (K, nq), qd (K, nv), x (K, P, 3), f (K, P, 3), delta
        (K, P)) with the contact points, forces and penetrations of the law at the samples.
        LSODA by default: near zero slip the friction is a stiff damper (mu f_n / v_s over a
        foot's apparent mass, some 1e5 1/s on the Solo12), on which an explicit method crawls
        (RK45 takes about 20 times longer on the Solo12's landing)."""
        y0 = self.y0 if y0 is None else y0
        sol = solve_ivp(
            self.rhs, (t[0], t[-1]), y0, method=method, t_eval=t, rtol=rtol, atol=atol
        )
        assert sol.success, sol.message
        Y = sol.y.T
        qs, qds, xs, fs, deltas = [], [], [], [], []
        for y in Y:
            q, v = self.config(y), y[self.nq :]
            pin.forwardKinematics(self.pmodel, self.pdata, q, v)
            x, f, delta, _ = self.contacts(q, v)
            qs.append(self.od_q(q))
            qds.append(self.oracle.back(v))
            xs.append(x), fs.append(f), deltas.append(delta)
        return np.array(qs), np.array(qds), np.array(xs), np.array(fs), np.array(deltas)

    def od_q(self, q):
        """Pinocchio's q -> opendyn's (free joints as they are, one angle per joint)."""
        out = np.empty(self.oracle.od.nq)
        for ours, theirs in self.oracle.free_q:
            out[ours : ours + 7] = q[theirs : theirs + 7]
        for ours, theirs, continuous in self.oracle.angles:
            out[ours] = np.arctan2(q[theirs + 1], q[theirs]) if continuous else q[theirs]
        return out
