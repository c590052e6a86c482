"""Plate finite elements; one element per module."""
from .hermite_plate import HermitePlate
from .shear_difference_plate import ShearDifferencePlate

__all__ = ["HermitePlate", "ShearDifferencePlate"]
