"""[[objects]] and [[world]]: the free rigid bodies that move with the robot and the static
geometry of the world, added to the robot's Model (opendyn.multibody.assembly.with_world); their
keys are in the file format of opendyn.io.scene.reader.

An object is a primitive shape of uniform density (shape, size, mass) or a URDF (urdf = a file,
relative to the scene's folder) on a floating base of its own; its root link takes the object's
name, its other links and joints "NAME.their name". A scene with objects may leave out [robot]:
the objects and the world are then the whole scene. Names are those of new frames: neither a
frame of the robot nor "ground" (the contact's ground plane) nor another entry's.

Objects and world entries touch only through [effects.contact] with geometry = "collision": a
scene that has them without it runs with a SceneWarning naming them and the key (a free body may
tumble on its own; a box meant to rest on a table falls through it). A world entry's mesh with a
hollow that a thing could enter (opendyn.io.concavity, environment=True) is a SceneWarning too:
it is used as its convex hull. Refused, naming the key: an
[[effects.contact.pairs]] entry that matches no pair the contact checks, and a contact with
nothing to touch because the <collision> meshes of the robot's or the objects' URDFs could not
be read (each one named).
"""

from __future__ import annotations

import dataclasses
import sys
import warnings

import numpy as np

from ...errors import SceneWarning, URDFError
from ...multibody.assembly import object_model, with_world
from ...multibody.geometry import Geometry
from ...sim.effects.geometry_contact import GROUND, GeometryContact, pair_table
from ...sim.values import ValueReader, what_is
from ...spatial.algebra import rpy_matrix
from ..concavity import gross_hollow
from ..meshes import MeshError, hull_vertices, read_mesh
from ..model_cache import cached_world_mesh
from ..urdf import load_urdf

LARGE_MESH = 100_000  # vertices of a world mesh whose hull is announced (655k: 50-60 s)


def _hull(path: str, size) -> tuple[np.ndarray, object]:
    """(the hull's vertices (n, 3) m, the gross hollow or None) of the world mesh `path` scaled
    by `size`; a mesh of over LARGE_MESH vertices says first that it takes a while (its result
    is then kept on disk: opendyn.io.model_cache.cached_world_mesh)."""
    count = len(read_mesh(path)[0])
    if count > LARGE_MESH:
        print(
            f"opendyn: computing the convex hull of the world mesh {path} ({count} vertices: "
            "about a minute per 600,000; kept in the model cache for later runs unless "
            "OPENDYN_MODEL_CACHE=0)",
            file=sys.stderr,
            flush=True,
        )
    return hull_vertices(path, size), gross_hollow(path, size, environment=True)


OBJECT_KEYS = (
    "name", "urdf", "shape", "size", "mass", "position", "rpy", "orientation", "velocity",
    "angular_velocity",
)
WORLD_KEYS = ("name", "shape", "size", "mesh", "position", "rpy")
OBJECT_SHAPES = ("box", "sphere", "cylinder", "capsule")
WORLD_SHAPES = (*OBJECT_SHAPES, "plane", "mesh")
SIZE_COUNTS = {"box": 3, "sphere": 1, "cylinder": 2, "capsule": 2, "mesh": 3}
RESERVED = ("ground",)  # the contact's ground plane, named in [[effects.contact.pairs]]


class WorldSection(ValueReader):
    """Reads [[objects]] and [[world]] into the scene's Model, and the objects' initial state."""

    def world_model(self, objects, world):
        """self.model <- the robot's Model with the objects and the world entries (with_world);
        keeps the object tables for object_states."""
        taken = set(self.model.frame_names) | set(RESERVED)
        object_entries = self._entries(objects, "objects", taken)
        world_entries = self._entries(world, "world", taken)
        named = {name: where for where, _, name, _ in (*object_entries, *world_entries)}
        self._object_tables = []
        report = self.model.report
        self._unread_meshes = [f"{report.source}: {line}" for line in _unread(report)]
        self._hollow_meshes = [f"{report.source}: {line}" for line in _hollow(report)]
        found = []
        for where, table, name, shape in object_entries:
            part = self._object(table, where, name, shape)
            for frame in part.frame_names[1:]:  # a URDF's other links: "NAME.link"
                if (full := f"{name}.{frame}") in named:
                    self.fail(
                        f"{named[full]}.name",
                        f"{full!r} is already a frame of the scene (link {frame!r} of object "
                        f"{name!r}); give the entry a name of its own",
                    )
            found.append((name, part))
            self._object_tables.append((table, where))
        entries = []
        for where, table, name, shape in world_entries:
            T_s = np.eye(4)
            T_s[:3, 3] = self._vec3(table, where, "position")
            T_s[:3, :3] = rpy_matrix(self._vec3(table, where, "rpy"))
            entries.append((self._world_geometry(table, where, name, shape), T_s))
        self.model = with_world(self.model, found, entries)
        return self.model

    def _object(self, table, where, name, shape):
        """The Model of one [[objects]] entry: its URDF with a floating base, or a primitive
        shape of uniform density (object_model)."""
        if "urdf" not in table:
            size = self._size(table, where, shape)
            if "mass" not in table:
                self.fail(f"{where}.mass", "missing: an object needs its mass (kg > 0)")
            mass = self.number(table["mass"], f"{where}.mass", positive=True)
            return object_model(name, shape, size, mass)
        for key in ("shape", "size", "mass"):
            if key in table:
                self.fail(
                    f"{where}.{key}",
                    f"an object from a URDF takes its {key} from the file; remove {key}",
                )
        path = self.existing_file(table["urdf"], f"{where}.urdf", "URDF", self.base_dir)
        try:
            model = load_urdf(str(path), floating_base=True)
        except URDFError as e:
            self.fail(f"{where}.urdf", str(e))
        self._unread_meshes += [f"{where}.urdf {path}: {line}" for line in _unread(model.report)]
        self._hollow_meshes += [f"{where}.urdf {path}: {line}" for line in _hollow(model.report)]
        return model

    def object_states(self, q0, qd0):
        """q0, qd0 of each object's free joint from its table (free_state)."""
        m = self.model
        for table, where in getattr(self, "_object_tables", ()):
            body = m.body_names.index(table["name"])
            self.free_state(table, where, "", body, q0, qd0)

    def _entries(self, value, key, taken) -> list:
        """[(where, table, name, shape)] of the tables [[key]] ("objects" or "world"), each
        checked for its keys, a new name (added to `taken`) and a shape of its kind."""
        if value is None:
            return []
        if not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
            self.fail(key, f"expected tables [[{key}]], found {what_is(value)}")
        objects = key == "objects"
        keys, shapes = (OBJECT_KEYS, OBJECT_SHAPES) if objects else (WORLD_KEYS, WORLD_SHAPES)
        found = []
        for k, table in enumerate(value):
            where = f"{key}[{k}]"
            self.keys(table, where, keys)
            name = self._name(table, where, taken)
            shape = None if "urdf" in table else self._shape(table, where, shapes)
            found.append((where, table, name, shape))
        return found

    def _name(self, table, where, taken) -> str:
        if "name" not in table:
            self.fail(f"{where}.name", "missing: every entry needs a name")
        name = self.string(table["name"], f"{where}.name")
        if not name.strip():
            self.fail(f"{where}.name", f"{name!r} is empty: every entry needs a name")
        if name in taken:
            what = "a reserved name" if name in RESERVED else "already a frame of the scene"
            self.fail(f"{where}.name", f"{name!r} is {what}; give the entry a name of its own")
        taken.add(name)
        return name

    def _shape(self, table, where, shapes) -> str:
        if "shape" not in table:
            also = ", or urdf = a file" if shapes == OBJECT_SHAPES else ""
            self.fail(f"{where}.shape", f"missing: one of {', '.join(shapes)}{also}")
        shape = self.string(table["shape"], f"{where}.shape", shapes)
        if shape not in shapes:
            self.fail(f"{where}.shape", f"expected one of {', '.join(shapes)}, found {shape!r}")
        return shape

    def _size(self, table, where, shape) -> tuple[float, ...]:
        n = SIZE_COUNTS[shape]
        if "size" not in table:
            if shape == "mesh":
                return (1.0, 1.0, 1.0)
            self.fail(f"{where}.size", f"missing: a {shape} needs {n} lengths (m)")
        size = tuple(float(x) for x in self.vector(table["size"], f"{where}.size", n))
        if min(size) <= 0.0:
            self.fail(f"{where}.size", f"expected lengths > 0 (m), found {list(size)}")
        return size

    def _vec3(self, table, where, key) -> np.ndarray:
        value = table.get(key)
        return np.zeros(3) if value is None else self.vector(value, f"{where}.{key}", 3)

    def _world_geometry(self, table, where, name, shape) -> Geometry:
        """The Geometry of a world entry in its own frame."""
        if shape == "plane":
            if "size" in table:
                self.fail(f"{where}.size", "a plane has no size; remove it")
            return Geometry(name, name, "halfspace", (), np.eye(4))
        if "mesh" in table and shape != "mesh":
            self.fail(f"{where}.mesh", f'only shape = "mesh" reads a file; this is a {shape}')
        size = self._size(table, where, shape)
        if shape != "mesh":
            return Geometry(name, name, shape, size, np.eye(4))
        if "mesh" not in table:
            self.fail(f"{where}.mesh", "missing: a mesh entry needs its file (STL, OBJ, DAE)")
        path = self.existing_file(table["mesh"], f"{where}.mesh", "mesh", self.base_dir)
        try:
            vertices, hollow = cached_world_mesh(str(path), size, lambda: _hull(str(path), size))
        except MeshError as e:
            self.fail(f"{where}.mesh", str(e))
        if hollow is not None:
            self.warn(
                f"{where}.mesh",
                f"{str(path)!r} is far from convex: " + hollow.note("one [[world]] entry each"),
            )
        return Geometry(name, name, "mesh", size, np.eye(4), vertices, str(path))

    def warn(self, key, what):
        """A SceneWarning naming the file and `key`: the scene runs, probably not as meant."""
        warnings.warn(f"{self.source}: {key}: {what}", SceneWarning, stacklevel=3)

    def meshes_readable(self, effects):
        """SceneError when [effects.contact] geometry = "collision" would find nothing that
        moves with collision geometry because <collision> meshes could not be read: the
        contact's own check would blame the URDF for having none."""
        contact = effects.get("contact") if isinstance(effects, dict) else None
        if not isinstance(contact, dict) or "geometry" not in contact or not self._unread_meshes:
            return
        if np.any(self.model.geometry_table.body >= 0):
            return
        self.fail(
            "effects.contact",
            'geometry = "collision": nothing can touch: no body that moves has collision '
            "geometry, because these <collision> meshes could not be read:\n  "
            + "\n  ".join(self._unread_meshes),
        )

    def contact_reaches(self, contact):
        """A SceneWarning when the scene's objects and world entries take part in no contact
        (`contact`: the record of [effects.contact], None without it); with the contact between
        collision geometries, a SceneWarning for each mesh of the robot's or an object's URDF
        far from convex, and a SceneError naming each [[effects.contact.pairs]] entry that
        matches no pair the contact checks."""
        m = self.model
        if isinstance(contact, GeometryContact):
            for line in self._hollow_meshes:
                self.warn("effects.contact.geometry", line)
            for k, setting in enumerate(contact.pairs):
                if not _matches_a_pair(m, contact, setting):
                    self.fail(
                        f"effects.contact.pairs[{k}]",
                        f"a = {setting.a!r} and b = {setting.b!r} match no pair of geometries "
                        f"that the contact checks: {_why_no_pair(m, setting)}",
                    )
            return
        parts = [
            f"{what} {', '.join(map(repr, names))}"
            for what, names in (("objects", m.objects), ("world entries", m.world))
            if names
        ]
        if not parts:
            return
        why = (
            "the scene has no [effects.contact]"
            if contact is None
            else "[effects.contact] points are the robot's spheres on the ground alone"
        )
        self.warn(
            "effects.contact.geometry",
            f"the {' and the '.join(parts)} touch nothing ({why}): they pass through each "
            'other, the robot and the ground; add [effects.contact] with geometry = "collision" '
            "(and its stiffness and friction) for them to touch",
        )


def _hollow(report) -> list[str]:
    """The <collision> meshes far from convex that a model's FidelityReport (None: a model not
    read from a URDF) names."""
    return [] if report is None else report.hollow_meshes


def _unread(report) -> list[str]:
    """The <collision> meshes that a model's FidelityReport (None: a model not read from a
    URDF) says could not be read."""
    return [] if report is None else report.unread_meshes


def _matches_a_pair(model, contact, setting) -> bool:
    """Whether the [[effects.contact.pairs]] `setting` matches a pair the contact may check
    (the robot's own pairs too): switched off, it takes one out (pair_table)."""
    every = dataclasses.replace(contact, self_collision=True, pairs=())
    without = dataclasses.replace(every, pairs=(dataclasses.replace(setting, enabled=False),))
    return len(pair_table(model, without)[0]) < len(pair_table(model, every)[0])


def _why_no_pair(model, setting) -> str:
    """Why the geometries of `setting`'s a and b are never a pair."""
    if setting.a == setting.b:
        return "a and b name the same link, object or entry, and a pair is two different ones"

    def moves(name):  # an object, or a link of the robot not welded to the world
        return name != GROUND and model.frames[model.frame_index(name)].body >= 0

    if not moves(setting.a) and not moves(setting.b):
        return (
            "neither moves (world entries, the ground and the links welded to the world never "
            "touch each other)"
        )
    return (
        "their geometries are on one body, or on a body and its parent (which meet at their "
        "joint), or on links the SRDF's <disable_collisions> takes out"
    )
