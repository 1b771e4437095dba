"""opendyn against Pinocchio, function by function, as a table."""
