"""The `opendyn` command (`python -m opendyn.cli` runs it too)."""
