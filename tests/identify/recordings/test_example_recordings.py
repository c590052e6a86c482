"""The example recording of every supported format (identify/examples/recordings) gives
the example plate's two modes, and the files are those the generator writes."""

import numpy as np
import pytest

from identify.examples.recordings import EXAMPLES, MODES_HZ, SAMPLE_RATE
from identify.recordings.peaks import extract_peaks


@pytest.mark.parametrize("kind", EXAMPLES)
def test_example_gives_the_two_modes(kind):
    """One hit (no scatter estimate), 0.3 s at 8 kHz: within 0.1 % of 500 and 1200 Hz
    (the hit's own jitter is 0.03 %)."""
    path = EXAMPLES[kind]
    table = extract_peaks([path], sample_rate=SAMPLE_RATE if "counts" in path.name else None).table
    np.testing.assert_allclose(table["frequency_hz"], MODES_HZ, rtol=1e-3)


def test_examples_are_reproducible(tmp_path, monkeypatch):
    """The generator, seeded, writes the same CSV again."""
    from identify.examples import recordings
    from identify.examples.recordings import make

    monkeypatch.setattr(make, "FOLDER", tmp_path)
    monkeypatch.setattr(make, "EXAMPLES", {k: tmp_path / v.name for k, v in recordings.EXAMPLES.items()})
    make.write_examples()
    assert (tmp_path / "hit.csv").read_text() == EXAMPLES["CSV, time column printed with %.7g"].read_text()
