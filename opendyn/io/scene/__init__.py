"""Scene files: a TOML description of one simulation -> a validated, frozen ``Scene``.

A scene names the robot, its initial state, the run settings, the physical effects that exist
and the control. `schema` holds the Scene and its records; `values` the checks of basic values
that every section shares; `sections_robot`, `sections_run`, `sections_effects`,
`sections_constraints` and `sections_control` read one part of the file each; `reader` builds the
Scene from the whole settings tree (its docstring is the file format); `files` loads scene files
and shipped scenes."""
