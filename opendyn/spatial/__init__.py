"""Spatial algebra of rigid bodies: `algebra`, the readable numpy reference (the user API and the
tests' oracle), and `compiled`, its twin in the 3x3-block forms the kernels inline."""
