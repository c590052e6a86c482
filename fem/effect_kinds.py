"""The names of the built-in effect kinds, in their registration order: what a command
line's help lists without importing the effects (and the finite-element code behind them)."""

BUILT_IN = (
    "transverse_shear",
    "rotary_inertia",
    "thick_plate",
    "point_mass",
    "suspension",
    "orientation",
    "adhesive",
    "thickness",
    "layerwise",
)

__all__ = ["BUILT_IN"]
