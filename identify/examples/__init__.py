"""Bundled examples: the paper's coated plate spec, its measurements and their shapes, and the one
fallback both command-line tools use when no spec is given."""

import sys
from pathlib import Path

FOLDER = Path(__file__).parent
COATED_PLATE = FOLDER / "coated_plate.toml"
COATED_PLATE_MEASURED = FOLDER / "coated_plate_measured.csv"
#: The mode shapes of those peaks on a 5 x 4 roving-hammer grid (``studies.measured_shapes``).
COATED_PLATE_SHAPES = FOLDER / "coated_plate_shapes.csv"


def spec_or_example(path: str | None) -> Path:
    """``path``, or the bundled example's spec (said on stderr) when none is given."""
    if path is not None:
        return Path(path)
    print(f"(no SPEC given: using the bundled example {COATED_PLATE.name})", file=sys.stderr)
    return COATED_PLATE
