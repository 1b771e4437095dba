"""How a scene is advanced: its effects, the step, the integrators, the driver, why a run failed
(diagnostics), what its stages cost (profile), the trajectory and the metrics of a run (on
opendyn.algorithm and opendyn.io)."""
