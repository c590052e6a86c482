"""Plate finite elements; one element per module."""
from .hermite_plate import HermitePlate

__all__ = ["HermitePlate"]
