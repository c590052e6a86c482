"""Plate finite elements; one element per module."""

from .hermite_plate import HermitePlate
from .layerwise_plate import LayerwisePlate
from .shear_difference_plate import ShearDifferencePlate

__all__ = ["HermitePlate", "LayerwisePlate", "ShearDifferencePlate"]
