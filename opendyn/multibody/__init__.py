"""What the robot is: the frozen Model, its buffer layout, the joint models and the constraint
objects (on opendyn.spatial; used by opendyn.algorithm)."""
