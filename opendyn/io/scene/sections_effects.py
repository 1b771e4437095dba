"""[effects]: the physical effects a scene switches on, each read into its record of
opendyn.io.scene.schema (where the generalized forces they stand for are written out): gravity,
damping, friction, armature, limits, wrenches and ground contact. A table that is absent leaves
its effect off (None, or () for wrenches)."""

from __future__ import annotations

import numpy as np

from ..._runtime.arrays import immutable
from .schema import Contact, ContactPoint, Friction, Limits, Wrench
from .values import ValueReader, _found

EXPRESSED_IN = ("frame", "world")
_EFFECT_KEYS = ("gravity", "damping", "friction", "armature", "limits", "wrench", "contact")
_CONTACT_KEYS = (
    "ground_height", "stiffness", "damping", "friction", "slip_velocity", "points"
)
_CONTACT_POINT_KEYS = ("frame", "position", "radius")


class EffectsSection(ValueReader):
    """Reads the tables of [effects], one method per effect."""

    def gravity(self, value) -> np.ndarray | None:
        if value is None or value is False:
            return None
        if value is True:
            return immutable(self.model.gravity)
        if not isinstance(value, list):
            self.fail(
                "effects.gravity",
                f"expected true, false or a vector [gx, gy, gz] (m/s^2), found {_found(value)}",
            )
        return self.vector(value, "effects.gravity", 3)

    def _coefficients(self, table, key, field, urdf_values, element):
        value = table.get(field, "urdf")
        full = f"{key}.{field}"
        if isinstance(value, str):
            if value != "urdf":
                self.fail(
                    full,
                    f'expected "urdf", a number, a list of {len(self.model.joint_names)} '
                    f"numbers or a table {{joint = number}}, found {_found(value)}",
                )
            if not np.any(urdf_values > 0):
                self.fail(
                    full,
                    f'"urdf" asks for the URDF\'s <dynamics {element}>, but '
                    f"{self.model.source or self.model.name} gives none (all joints 0); give "
                    f"the coefficients: a number, a list of {len(self.model.joint_names)} or a "
                    f"table {{joint = number}}",
                )
            return immutable(urdf_values)
        return self.per_joint(value, full, np.zeros(len(self.model.joint_names)), minimum=0.0)

    def damping(self, table) -> np.ndarray | None:
        if table is None:
            return None
        key = "effects.damping"
        self.keys(table, key, ("coefficients",))
        return self._coefficients(table, key, "coefficients", self.model.damping, "damping")

    def friction(self, table) -> Friction | None:
        if table is None:
            return None
        key = "effects.friction"
        self.keys(table, key, ("coefficients", "smoothing"))
        coulomb = self._coefficients(table, key, "coefficients", self.model.friction, "friction")
        smoothing = self.number(table.get("smoothing", 0.01), f"{key}.smoothing", positive=True)
        return Friction(coulomb=coulomb, smoothing=smoothing)

    def armature(self, table) -> np.ndarray | None:
        if table is None:
            return None
        key = "effects.armature"
        self.keys(table, key, ("values",))
        if "values" not in table:
            self.fail(f"{key}.values", "missing: give a number, a list or a table {joint = kg m^2}")
        return self.per_joint(
            table["values"], f"{key}.values", np.zeros(len(self.model.joint_names)), minimum=0.0
        )

    def limits(self, table) -> Limits | None:
        if table is None:
            return None
        key = "effects.limits"
        self.keys(table, key, ("stiffness", "damping"))
        m = self.model
        finite = np.isfinite(m.lower) | np.isfinite(m.upper)
        if not finite.any():
            self.fail(
                key,
                f"no joint of {m.name!r} has a finite position limit, so limit spring-dampers "
                f"would never act; remove [effects.limits]",
            )
        if "stiffness" not in table:
            self.fail(
                f"{key}.stiffness", "missing: give a number, a list or a table {joint = N m/rad}"
            )
        out = {}
        for field in ("stiffness", "damping"):
            full = f"{key}.{field}"
            value = table.get(field, 0.0)
            arr = self.per_joint(value, full, np.zeros(len(m.joint_names)), minimum=0.0)
            if isinstance(value, (dict, list)):
                for j in np.flatnonzero((arr != 0) & ~finite):
                    name = m.joint_names[j]
                    self.fail(
                        f"{full}.{name}" if isinstance(value, dict) else f"{full}[{j}]",
                        f"joint {name!r} has no finite position limit; limited joints: "
                        f"{', '.join(n for n, f in zip(m.joint_names, finite) if f)}",
                    )
            out[field] = immutable(np.where(finite, arr, 0.0))
        return Limits(
            stiffness=out["stiffness"],
            damping=out["damping"],
            lower=immutable(m.lower),
            upper=immutable(m.upper),
        )

    def wrenches(self, value) -> tuple[Wrench, ...]:
        if value is None:
            return ()
        if isinstance(value, dict):
            return (self.wrench(value, "effects.wrench"),)
        if not isinstance(value, list):
            self.fail(
                "effects.wrench",
                f"expected tables [[effects.wrench]] (frame, value or times/values), "
                f"found {_found(value)}",
            )
        return tuple(self.wrench(w, f"effects.wrench[{i}]") for i, w in enumerate(value))

    def wrench(self, table, key) -> Wrench:
        self.keys(table, key, ("frame", "expressed_in", "value", "times", "values"))
        m = self.model
        if "frame" not in table:
            self.fail(f"{key}.frame", f"missing; frames: {', '.join(m.frame_names)}")
        frame = self.moving_frame(table["frame"], f"{key}.frame", "a wrench on it moves nothing")
        expressed_in = self.string(
            table.get("expressed_in", "frame"), f"{key}.expressed_in", EXPRESSED_IN
        )
        has_value = "value" in table
        has_table = "times" in table or "values" in table
        if has_value == has_table:
            self.fail(
                key,
                ("both value and times/values given" if has_value else "no wrench given")
                + ": give value = [m, f] (6 numbers, constant) or times = [...] with "
                "values = [[6 numbers], ...]",
            )
        if has_value:
            times = immutable([0.0])
            values = immutable(self.vector(table["value"], f"{key}.value", 6)[None, :])
        else:
            for field in ("times", "values"):
                if field not in table:
                    self.fail(f"{key}.{field}", "missing: times and values go together")
            raw_t, raw_v = table["times"], table["values"]
            if not isinstance(raw_t, list) or not raw_t:
                self.fail(
                    f"{key}.times", f"expected a non-empty list of times (s), found {_found(raw_t)}"
                )
            times = self.vector(raw_t, f"{key}.times", len(raw_t))
            bad = np.flatnonzero(np.diff(times) <= 0)
            if bad.size:
                k = int(bad[0]) + 1
                self.fail(
                    f"{key}.times[{k}]",
                    f"times must be strictly increasing; {times[k]:g} follows {times[k - 1]:g}",
                )
            if not isinstance(raw_v, list) or len(raw_v) != len(times):
                found = f"a list of {len(raw_v)}" if isinstance(raw_v, list) else _found(raw_v)
                self.fail(
                    f"{key}.values",
                    f"expected one wrench [m, f] of 6 numbers per time ({len(times)} times), "
                    f"found {found}",
                )
            values = immutable(
                np.array([self.vector(v, f"{key}.values[{i}]", 6) for i, v in enumerate(raw_v)])
            )
        return Wrench(frame=frame, expressed_in=expressed_in, times=times, values=values)

    def contact(self, table) -> Contact | None:
        if table is None:
            return None
        key = "effects.contact"
        self.keys(table, key, _CONTACT_KEYS)
        for field in ("stiffness", "friction", "points"):
            if field not in table:
                self.fail(
                    f"{key}.{field}",
                    'missing: [effects.contact] needs stiffness (N/m), friction (mu) and points '
                    '("urdf" or [[effects.contact.points]] tables)',
                )
        return Contact(
            ground_height=self.number(table.get("ground_height", 0.0), f"{key}.ground_height"),
            stiffness=self.number(table["stiffness"], f"{key}.stiffness", positive=True),
            damping=self.number(table.get("damping", 0.0), f"{key}.damping", minimum=0.0),
            friction=self.number(table["friction"], f"{key}.friction", minimum=0.0),
            slip_velocity=self.number(
                table.get("slip_velocity", 1e-3), f"{key}.slip_velocity", positive=True
            ),
            points=self.contact_points(table["points"], f"{key}.points"),
        )

    def contact_points(self, value, key) -> tuple[ContactPoint, ...]:
        """"urdf" (the model's collision spheres on moving frames) or a list of tables."""
        m = self.model
        if value == "urdf":
            spheres = [s for s in m.collision_spheres if m.frames[m.frame_index(s.link)].body >= 0]
            if not spheres:
                held = " (those there are belong to the fixed world)" if m.collision_spheres else ""
                self.fail(
                    key,
                    f'"urdf": {m.source or m.name} has no <collision> sphere or box on a moving '
                    f"link{held}; give [[effects.contact.points]] tables (frame, position, "
                    "radius)",
                )
            found = [(s.link, s.position, s.radius, s.geometry) for s in spheres]
        else:
            if isinstance(value, dict):
                value = [value]
            if not isinstance(value, list) or not value:
                self.fail(
                    key,
                    f'expected "urdf" or tables [[effects.contact.points]] (frame, position, '
                    f"radius), found {_found(value)}",
                )
            found = []
            for i, point in enumerate(value):
                where = f"{key}[{i}]"
                self.keys(point, where, _CONTACT_POINT_KEYS)
                if "frame" not in point:
                    self.fail(f"{where}.frame", f"missing; frames: {', '.join(m.frame_names)}")
                frame = self.frame(point["frame"], f"{where}.frame")
                if m.frames[m.frame_index(frame)].body < 0:
                    self.fail(
                        f"{where}.frame",
                        f"{frame!r} is welded to the fixed world: a contact sphere there never "
                        "moves and can push nothing; name a frame of a moving link",
                    )
                position = self.vector(point.get("position", [0.0] * 3), f"{where}.position", 3)
                radius = self.number(point.get("radius", 0.0), f"{where}.radius", minimum=0.0)
                found.append((frame, position, radius, "scene"))
        per_frame = {}
        for frame, *_ in found:
            per_frame[frame] = per_frame.get(frame, 0) + 1
        points, seen = [], {}
        for frame, position, radius, source in found:
            k = seen.get(frame, 0)
            seen[frame] = k + 1
            name = frame if per_frame[frame] == 1 else f"{frame}[{k}]"
            points.append(ContactPoint(frame, immutable(position), float(radius), name, source))
        return tuple(points)
