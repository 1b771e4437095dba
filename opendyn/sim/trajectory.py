"""A simulated trajectory: samples of (t, q, qd, tau) with the energy balance, saved with its
provenance.

    E(t) = T(q, qd) + U_gravity(q),   T = 1/2 qd^T (M(q) + diag(armature)) qd
    E(t) - E(0) = W_applied(t) + W_passive(t) + (integration error)

W_applied is the work of the control torques and applied wrenches, W_passive that of damping,
friction and the joint-limit spring-dampers, each integrated with the state by the same
integrator; the residual `energy_error` measures how well the integrator keeps the balance.
Ideal constraint forces A^T lambda do no work while A qd = 0; their work through the drift and
the Baumgarte terms is left in `energy_error`, beside the recorded constraint violation.

With ground contact, U also holds the contact springs' energy sum_p 1/2 k delta_p^2 (delta_p the
penetration of point p), and W_passive the work of the rest of the contact forces (the normal
dampers, friction, and the spring energy a clamped normal force lets go), so that the balance
closes as it does for the joint effects.
"""

from __future__ import annotations

import errno
import json
import os
import pathlib
import zipfile
from dataclasses import dataclass, field

import numpy as np

from .._runtime.files import atomic_write, csv_field, kind_of, name_too_long
from .contacts import ContactExtremes, ContactTable

_ARRAYS = ("t", "q", "qd", "tau", "kinetic", "potential", "work_applied", "work_passive")
_VIOLATION = ("violation_position", "violation_velocity")  # empty without constraints
_CONTACT = ("contact_point", "contact_force", "penetration")  # empty without contact
_CENTROIDAL = ("com", "centroidal_momentum")  # empty without a floating base
_SOLVER = ("solver_iterations", "solver_residual")  # empty without a hard model
# their CSV columns: the centre of mass, then h_G = (k_G, l_G)
_CENTROIDAL_COLUMNS = tuple(f"com_{a}" for a in "xyz") + tuple(
    f"{part}_{a}" for part in ("kG", "lG") for a in "xyz"
)


def _check_shapes(traj, path):
    """ValueError naming the file and the array whose shape does not fit the others' (t's
    samples, the coordinates' names): a file changed after it was saved."""
    k, nq, nv = len(traj.t), len(traj.q_names), len(traj.v_names)
    expected = {"t": (k,), "q": (k, nq), "qd": (k, nv), "tau": (k, nv)}
    expected.update({name: (k,) for name in ("kinetic", "potential")})
    expected.update({name: (k,) for name in ("work_applied", "work_passive")})
    for name, shape in expected.items():
        found = np.shape(getattr(traj, name))
        if found != shape:
            raise ValueError(
                f"{path}: its array {name} has shape {found}, where {shape} fits the record ("
                f"{k} samples, {nq} coordinates q, {nv} velocities): the file was changed "
                "after opendyn saved it"
            )


def contacts_csv_path(path) -> pathlib.Path:
    """Where `Trajectory.to_csv(path)` writes the contact table: run.csv -> run.contacts.csv."""
    path = pathlib.Path(path)
    return path.with_name(path.stem + ".contacts.csv")


def _check_writable(paths):
    """OSError naming the first of `paths` (the files one save writes) whose name is longer
    than its file system allows, or that is a folder: raised before any of them is written, so
    that a save writes all of its files or none."""
    for path in paths:
        too_long = name_too_long(path)
        if too_long is not None:
            raise OSError(errno.ENAMETOOLONG, too_long, str(path))
        if path.is_dir():
            raise IsADirectoryError(errno.EISDIR, "is a folder, not a file", str(path))


def _file_name(path, what) -> pathlib.Path:
    """`path` as a Path, or a TypeError (not a file name) or ValueError (an empty one) naming
    `what` (the method) and the argument."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"{what}: path must be a file name (str or pathlib.Path), got {type(path).__name__}"
        )
    if not str(path).strip():
        raise ValueError(f"{what}: path is empty; name the file to write")
    return pathlib.Path(path)


def saved_paths(path) -> tuple[pathlib.Path, pathlib.Path]:
    """The two files `Trajectory.save(path)` writes: `path` as a .npz (its suffix replaced by
    .npz, or .npz added), and the JSON record beside it (the same name, .json)."""
    path = pathlib.Path(path)
    if path.suffix != ".npz":
        path = path.with_suffix(".npz")
    return path, path.with_suffix(".json")


@dataclass
class Trajectory:
    """Samples of a simulation.

    t (K,) s; q (K, nq) rad or m; qd (K, nv) rad/s or m/s; tau (K, nv) the control torque
    (N m or N; zero without control). With a floating base q = (p, quat (x, y, z, w),
    q_joints) and qd = (omega_b, v_b, qd_joints), the base twist in its own frame.
    joint_names: the model's joint names; q_names (nq,), v_names (nv,): the name of every
    column of q and of qd and tau (model.q_names, model.v_names: base_x ... base_qw,
    base_wx ... base_vz, then the joints; the joint names alone for a fixed base);
    kinetic, potential (K,) J; work_applied, work_passive (K,) J,
    the work done since t = 0 by control and applied wrenches, and by damping, friction and limits.
    complete: False when the run stopped early (failure or interrupt); message says why.
    stats: steps, rejected steps, dynamics evaluations, wall time (s: wall_s, a Python
      controller's calls included, controller_s of it theirs), kernel load time (s);
      with a floating base quaternion_norm_error, the largest | |quat| - 1 | of the samples.
    violation_position, violation_velocity: (K,) max_i |phi_i(q)| (m or rad) and max_i |(A qd)_i|
    (m/s or rad/s) over the scene's constraints at each sample; empty (0,) without constraints.
    contact_names (P,): the scene's contact points (the frame's name, with [k] when a frame has
    several); contact_point (K, P, 3) m: each point's lowest point of its sphere, world frame;
    contact_force (K, P, 3) N: the force the ground applies to the robot there, world frame;
    penetration (K, P) m: delta = max(0, ground_height - (z - r)); ground_height (m) the plane
    z = ground_height, None without contact. Empty (K, 0, ...) without contact.
    com (K, 3) m: the centre of mass in the world frame; centroidal_momentum (K, 6): h_G =
    (k_G, l_G), the angular momentum about the centre of mass (kg m^2/s) and the linear
    momentum (kg m/s) in world-aligned axes, angular first (opendyn.algorithm.centroidal);
    recorded for a floating base, empty (0, 3), (0, 6) otherwise.
    contacts: with contact between collision geometries ([effects.contact] geometry =
    "collision"), its ContactTable (opendyn.sim.contacts): one row per contact point per
    sample, with its pair, point, normal, force and depth; None otherwise.
    contact_extremes: with contact of either kind, its ContactExtremes (opendyn.sim.contacts):
    the deepest penetration, the largest force, each with its pair and time, the most points
    at once and each pair's deepest, over every step of the run and not only the samples
    (which can miss a bounce between two of them); None without contact.
    solver_iterations, solver_residual: (K,) with a hard model (opendyn.sim.hard), the
    iterations and the residual (m/s, opendyn.algorithm.ncp) of the contact solve of the step
    from each sample; empty (0,) otherwise. With a hard model the contact forces (contact_force,
    contacts.force) are those of the step from each sample, lambda / dt, at the contacts found
    at the sample; a contacts row's depth is then -d, negative for a gap within the margin.
    provenance: the scene, integrator, versions and timing, as plain JSON types.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    work_applied: np.ndarray
    work_passive: np.ndarray
    joint_names: tuple[str, ...]
    q_names: tuple[str, ...] = ()
    v_names: tuple[str, ...] = ()
    complete: bool = True
    message: str = ""
    stats: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)
    violation_position: np.ndarray = field(default_factory=lambda: np.zeros(0))
    violation_velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    contact_names: tuple[str, ...] = ()
    contact_point: np.ndarray | None = None
    contact_force: np.ndarray | None = None
    penetration: np.ndarray | None = None
    ground_height: float | None = None
    com: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    centroidal_momentum: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    contacts: ContactTable | None = None
    contact_extremes: ContactExtremes | None = None
    solver_iterations: np.ndarray = field(default_factory=lambda: np.zeros(0))
    solver_residual: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self):
        # a fixed-base record (nq = nv = the joints) names its columns by the joints
        if not self.q_names:
            self.q_names = tuple(self.joint_names)
        if not self.v_names:
            self.v_names = tuple(self.joint_names)
        k, p = len(self.t), len(self.contact_names)
        if self.contact_point is None:
            self.contact_point = np.zeros((k, p, 3))
        if self.contact_force is None:
            self.contact_force = np.zeros((k, p, 3))
        if self.penetration is None:
            self.penetration = np.zeros((k, p))

    @property
    def has_contact(self) -> bool:
        """Whether the scene named ground contact (its points are recorded)."""
        return self.ground_height is not None

    @property
    def energy(self) -> np.ndarray:
        """(K,) mechanical energy T + U_gravity (J)."""
        return self.kinetic + self.potential

    @property
    def energy_error(self) -> np.ndarray:
        """(K,) E(t) - E(0) - W_applied(t) - W_passive(t) (J): zero for exact integration."""
        return self.energy - self.energy[0] - self.work_applied - self.work_passive

    def _check_outputs(self, paths, what):
        """Refuse, before any is written, the files `paths` that one write makes where one
        cannot be written (_check_writable) or is a file the run read, as its provenance names
        them (Scene.inputs): ValueError naming `what` and the file."""
        _check_writable(paths)
        read = self.provenance.get("scene", {}).get("inputs", ())
        inputs = {os.path.realpath(f) for f in read if os.path.isfile(f)}
        for path in paths:
            if os.path.realpath(path) in inputs:
                raise ValueError(
                    f"{what}: {path} is a file this run read (its scene, its robot or a file "
                    "the scene names); writing there would replace it: name another file"
                )

    def save(self, path) -> pathlib.Path:
        """Write the arrays to `path` (.npz) with the provenance record as JSON, both inside the
        .npz (key "provenance") and beside it (same name, .json; see `saved_paths`). Each file
        is written atomically (`atomic_write`): an error or Ctrl-C during the save leaves the
        file as it was, or absent, never truncated. A file the run read (its scene, its
        robot's URDF, a file the scene names) is refused. Returns the .npz path."""
        path = _file_name(path, "Trajectory.save")
        if os.path.isdir(path):
            raise IsADirectoryError(
                errno.EISDIR, "is a folder; name the .npz to write in it (FOLDER/run.npz)",
                str(path),
            )
        path, json_path = saved_paths(path)
        self._check_outputs((path, json_path), "Trajectory.save")
        record = self.record()
        arrays = {name: getattr(self, name) for name in _ARRAYS + _VIOLATION}
        if self.has_contact:
            arrays.update({name: getattr(self, name) for name in _CONTACT})
            arrays["contact_names"] = np.array(self.contact_names, dtype=str)
            arrays["ground_height"] = np.array(self.ground_height)
        if len(self.com):
            arrays.update({name: getattr(self, name) for name in _CENTROIDAL})
        if len(self.solver_iterations):
            arrays.update({name: getattr(self, name) for name in _SOLVER})
        if self.contacts is not None:
            arrays.update(self.contacts.arrays())
        if self.contact_extremes is not None:
            arrays.update(self.contact_extremes.arrays())
        with atomic_write(path) as f:
            np.savez_compressed(
                f,
                **arrays,
                joint_names=np.array(self.joint_names, dtype=str),
                q_names=np.array(self.q_names, dtype=str),
                v_names=np.array(self.v_names, dtype=str),
                provenance=np.array(json.dumps(record)),
            )
        with atomic_write(json_path) as f:
            f.write((json.dumps(record, indent=2) + "\n").encode())
        return path

    def record(self) -> dict:
        """The provenance record: run status, statistics and the scene's provenance."""
        return {
            "complete": self.complete,
            "message": self.message,
            "samples": len(self.t),
            "stats": self.stats,
            **self.provenance,
        }

    @classmethod
    def load(cls, path) -> "Trajectory":
        """Read a trajectory written by `save(path)`: `path`, or the .npz that `save` made of
        it (`saved_paths`: "run" was saved as run.npz). A file of another kind (an image, an
        .npz of other arrays) is a ValueError naming it and what it is."""
        if not os.path.exists(path) and os.path.exists(saved_paths(path)[0]):
            path = saved_paths(path)[0]
        try:
            data = np.load(path, allow_pickle=False)
        except (ValueError, EOFError, zipfile.BadZipFile) as e:
            kind = kind_of(path)
            what = f"is {kind}" if kind != "a ZIP archive" else f"cannot be read ({e})"
            raise ValueError(f"{path}: {what}, not a trajectory saved by opendyn (.npz)") from None
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise ValueError(f"{path}: is a numpy array (.npy), not a trajectory saved by opendyn")
        missing = [name for name in ("provenance", "joint_names", *_ARRAYS) if name not in data]
        if missing:
            data.close()
            raise ValueError(
                f"{path}: an .npz archive without the arrays of a trajectory saved by opendyn "
                f"(no {', '.join(missing)})"
            )
        with data:
            record = json.loads(str(data["provenance"]))
            arrays = {name: data[name] for name in _ARRAYS}
            arrays.update({name: data[name] for name in _VIOLATION if name in data})
            if "ground_height" in data:
                arrays.update({name: data[name] for name in _CONTACT})
                arrays["contact_names"] = tuple(str(n) for n in data["contact_names"])
                arrays["ground_height"] = float(data["ground_height"])
            arrays.update({name: data[name] for name in _CENTROIDAL if name in data})
            arrays.update({name: data[name] for name in _SOLVER if name in data})
            if "contacts_sample" in data:
                arrays["contacts"] = ContactTable.from_arrays(data)
            if "extremes_head" in data:
                arrays["contact_extremes"] = ContactExtremes.from_arrays(data)
            names = tuple(str(n) for n in data["joint_names"])
            columns = {
                key: tuple(str(n) for n in data[key])
                for key in ("q_names", "v_names")
                if key in data
            }
        stats = record.pop("stats", {})
        complete = record.pop("complete", True)
        message = record.pop("message", "")
        record.pop("samples", None)
        traj = cls(
            **arrays,
            joint_names=names,
            **columns,
            complete=complete,
            message=message,
            stats=stats,
            provenance=record,
        )
        _check_shapes(traj, path)
        return traj

    def to_csv(self, path) -> pathlib.Path:
        """One row per sample: t, q_<name> for each of q_names, qd_<name> and tau_<name> for
        each of v_names (a floating base's q_base_x ... q_base_qw, qd_base_wx ... qd_base_vz
        first), kinetic, potential, work_applied, work_passive (SI units), with constraints
        violation_position, violation_velocity, with a floating base com_x, com_y, com_z (m)
        and the centroidal momentum kG_x, kG_y, kG_z (kg m^2/s), lG_x, lG_y, lG_z (kg m/s),
        world frame, and with contact, for each contact point, fx_<point>, fy_<point>,
        fz_<point> (N, world frame) and penetration_<point> (m). With contacts between
        collision geometries, their table beside it, one row per contact point
        (ContactTable.to_csv, at contacts_csv_path(path)). A column name that holds a comma, a
        double quote or a line break (a joint's, a point's) is quoted (csv_field).
        Written atomically, like `save`; a name too long or a folder in the place of either
        file is refused before either is written, and so is a file the run read (`save`).
        Returns the path."""
        path = _file_name(path, "Trajectory.to_csv")
        paths = [path] if self.contacts is None else [path, contacts_csv_path(path)]
        self._check_outputs(paths, "Trajectory.to_csv")
        header = ["t", *(f"q_{n}" for n in self.q_names), *(f"qd_{n}" for n in self.v_names)]
        header += [*(f"tau_{n}" for n in self.v_names), "kinetic", "potential"]
        header += ["work_applied", "work_passive"]
        columns = [self.t, self.q, self.qd, self.tau, self.kinetic, self.potential]
        columns += [self.work_applied, self.work_passive]
        if len(self.violation_position):
            header += list(_VIOLATION)
            columns += [self.violation_position, self.violation_velocity]
        if len(self.com):
            header += list(_CENTROIDAL_COLUMNS)
            columns += [self.com, self.centroidal_momentum]
        for p, name in enumerate(self.contact_names):
            header += [f"fx_{name}", f"fy_{name}", f"fz_{name}", f"penetration_{name}"]
            columns += [self.contact_force[:, p], self.penetration[:, p]]
        table = np.column_stack(columns)
        line = ",".join(csv_field(name) for name in header)
        with atomic_write(path) as f:
            np.savetxt(f, table, delimiter=",", header=line, comments="", fmt="%.17g")
        if self.contacts is not None:
            self.contacts.to_csv(contacts_csv_path(path), self.t)
        return path

    def plot(self, path) -> pathlib.Path:
        """A PNG with three panels over time: positions, velocities (a floating base's position,
        quaternion and body twist among them), and the energy
        (E - E(0), the work of the non-conservative forces, and the integration error); with
        constraints a fourth, their violation; with contact one more, the normal force (the z
        component of contact_force, N) at each contact point and their sum; with a floating
        base one more, the centroidal momentum h_G = (k_G, l_G) (kg m^2/s, kg m/s). The format
        is the suffix's (any matplotlib writes: .png, .pdf, .svg ...; PNG without one). Written
        atomically, like `save`. Returns the path."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        path = pathlib.Path(path)
        constrained = len(self.violation_position) > 0
        centroidal = len(self.com) > 0
        panels = 3 + constrained + self.has_contact + centroidal
        fig, axes = plt.subplots(
            panels, 1, figsize=(9, 3 * panels), sharex=True, constrained_layout=True
        )
        for k, name in enumerate(self.q_names):
            axes[0].plot(self.t, self.q[:, k], label=name)
        for k, name in enumerate(self.v_names):
            axes[1].plot(self.t, self.qd[:, k], label=name)
        axes[0].set_ylabel("q (rad or m; quaternion)")
        axes[1].set_ylabel("qd (rad/s or m/s)")
        if len(self.q_names) <= 12:
            axes[0].legend(loc="upper right", fontsize="small", ncol=2)
        if self.v_names != self.q_names and len(self.v_names) <= 12:  # a floating base's twist
            axes[1].legend(loc="upper right", fontsize="small", ncol=2)
        energy = self.energy - self.energy[0]
        axes[2].plot(self.t, energy, label="E - E(0)")
        if np.any(self.work_applied):
            axes[2].plot(self.t, self.work_applied, label="work applied")
        if np.any(self.work_passive):
            axes[2].plot(self.t, self.work_passive, label="work passive")
        axes[2].plot(self.t, self.energy_error, label="balance error", linestyle="--")
        axes[2].set_ylabel("energy (J)")
        axes[2].legend(loc="best", fontsize="small")
        if constrained:
            axes[3].semilogy(self.t, self.violation_position, label="max |phi| (m or rad)")
            axes[3].semilogy(self.t, self.violation_velocity, label="max |A qd| (m/s or rad/s)")
            axes[3].set_ylabel("constraint violation")
            axes[3].legend(loc="best", fontsize="small")
        if self.has_contact:
            ax = axes[3 + constrained]
            normal = self.contact_force[:, :, 2]
            for p, name in enumerate(self.contact_names):
                ax.plot(self.t, normal[:, p], label=name)
            ax.plot(self.t, normal.sum(axis=1), label="sum", color="black", linewidth=2)
            ax.set_ylabel("contact normal force f_z (N)")
            if len(self.contact_names) <= 12:
                ax.legend(loc="upper right", fontsize="small", ncol=2)
        if centroidal:
            for k, name in enumerate(_CENTROIDAL_COLUMNS[3:]):
                axes[-1].plot(self.t, self.centroidal_momentum[:, k], label=name)
            axes[-1].set_ylabel("h_G (kg m^2/s, kg m/s)")
            axes[-1].legend(loc="upper right", fontsize="small", ncol=2)
        axes[-1].set_xlabel("t (s)")
        title = self.provenance.get("scene", {}).get("name", "")
        if not self.complete:
            title += " (partial: " + self.message.split("\n")[0] + ")"
        fig.suptitle(title)
        try:
            with atomic_write(path) as f:
                fig.savefig(f, format=path.suffix[1:] or "png", dpi=100)
        finally:
            plt.close(fig)
        return path
