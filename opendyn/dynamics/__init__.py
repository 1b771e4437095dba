"""Dynamics of open chains on kinematic trees: one algorithm per module, compiled kernels."""
