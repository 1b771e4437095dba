"""[effects]: the physical effects a scene switches on. Its keys are the names of the effects
that opendyn.sim.effects.registry sets in [effects], and each effect's module reads and checks
its own table into its record (where the generalized force it stands for is written out). A
table that is absent leaves its effect off (None, or () for wrenches)."""

from __future__ import annotations

from ...sim.effects import registry
from ...sim.values import ValueReader


class EffectsSection(ValueReader):
    """Reads the tables of [effects], each by its effect's module."""

    def effects(self, value) -> dict:
        """{name: record} of every effect of [effects], in registry order (None or () when
        its table is absent)."""
        table = self.table(value, "effects")
        in_effects = registry.in_section("effects")
        self.keys(table, "effects", tuple(effect.NAME for effect in in_effects))
        for effect in in_effects:
            if getattr(effect, "JOINTS", False) and effect.NAME in table:
                self.joints_needed(f"effects.{effect.NAME}", f"[effects.{effect.NAME}]")
        records = {}
        for effect in in_effects:  # effects that share a name read the same table: one keeps it
            record = effect.read(self, table.get(effect.NAME))
            if records.get(effect.NAME) is None:
                records[effect.NAME] = record
        return records

    def joints_needed(self, key, what):
        """SceneError naming key when the robot has no joints: `what` would act on nothing."""
        model = self.model
        if not model.joint_names:
            moves = "only its free base moves" if model.floating_base else "nothing in it moves"
            self.fail(
                key,
                f"{model.name!r} has no joints ({moves}), so {what} would act on nothing; "
                "remove it",
            )
