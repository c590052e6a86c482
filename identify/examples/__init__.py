"""Bundled examples: the paper's coated plate spec and its measurements."""
from pathlib import Path

FOLDER = Path(__file__).parent
COATED_PLATE = FOLDER / "coated_plate.toml"
COATED_PLATE_MEASURED = FOLDER / "coated_plate_measured.csv"
