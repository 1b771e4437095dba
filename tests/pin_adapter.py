"""Pinocchio as an oracle for the tests: a re-export of opendyn.verify's PinocchioOracle, where
every conversion between Pinocchio's conventions and opendyn's is written once (angular/linear
order, cos/sin continuous joints, joint order by name, external-force sign and frame)."""

from __future__ import annotations

from opendyn.verify.oracle import PinocchioOracle as PinOracle
from opendyn.verify.oracle import swap_halves

__all__ = ["PinOracle", "swap_halves"]
