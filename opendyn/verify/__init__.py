"""opendyn against Pinocchio, function by function, as a table.

  oracle    Pinocchio's answers in opendyn's conventions (PinocchioOracle)
  contract  every contract function compared over random states, and the table (verify)
"""
