"""How a scene is advanced: its effects, the step, the integrators, the driver, the trajectory
and the metrics of a run (on opendyn.algorithm and opendyn.io)."""
