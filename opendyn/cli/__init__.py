"""The `opendyn` command (`python -m opendyn.cli` runs it too).

  main        the arguments, the dispatch, bad input and interruptions answered in one line
  simulate    opendyn simulate (its output files: outputs)
  sweep       opendyn sweep
  robot       opendyn info, verify and demo
  cache       opendyn compile and info --cache
  interrupts  what the command was doing when Ctrl-C or SIGTERM stopped it
"""
