"""Scene files: a TOML description of one simulation -> a validated, frozen ``Scene``
(opendyn.sim.scene, what the simulation runs).

A scene names the robot, its initial state, the run settings, the physical effects that exist
and the control. `sections_robot`, `sections_effects`, `sections_constraints` and
`sections_control` read one part of the file each ([run] is read by opendyn.sim.run, each
effect's settings by its own module, all with the checks of opendyn.sim.values); `reader`
builds the Scene from the whole settings tree (its docstring is the file format); `files` loads
scene files and shipped scenes; `variants` rebuilds a scene with some keys set to other values."""
