"""A Python controller shipped beside the scenes (robots/NAME.py), imported as a module, as the
tests that step its scene by hand or read its constants need it."""

import importlib.util

from opendyn.io.urdf import shipped_robots_dir


def shipped_controller(name):
    """robots/NAME.py as a module."""
    spec = importlib.util.spec_from_file_location(name, shipped_robots_dir() / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
