"""What you compute on a Model, one algorithm per module: kinematics, rnea, crba, aba, forward,
energy, christoffel, task_space, contact, configuration, cholesky, constraints/ (frames, terms,
solve, arguments, table, api) (on opendyn.multibody; used by opendyn.sim and the layers above)."""
