"""The measurement CSV's columns in docs/formats.md are the ones the reader accepts."""

import re
from pathlib import Path

from identify.measurements import OPTIONAL, REQUIRED

DOC = Path(__file__).parent.parent / "docs" / "formats.md"


def test_measurement_columns_documented_as_accepted():
    section = DOC.read_text().split("## Measurement CSV", 1)[1].split("\n## ", 1)[0]
    documented = set(re.findall(r"^\| `([a-z_]+)` \|", section, re.M))
    assert documented == set(REQUIRED) | set(OPTIONAL)
    required = set(re.findall(r"^\| `([a-z_]+)` \|[^|]*\| yes \|", section, re.M))
    assert required == set(REQUIRED)
