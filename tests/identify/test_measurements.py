"""Measurement CSV validation: bad data gets a clear one-line error naming the line."""

import pandas as pd
import pytest

from fem.errors import MeasurementError
from identify.examples import COATED_PLATE_MEASURED
from identify.measurements import load_measurements, parse_measurements

GOOD = pd.read_csv(COATED_PLATE_MEASURED, comment="#")


def test_bundled_measurements_load(example_spec):
    m = load_measurements(COATED_PLATE_MEASURED, example_spec)
    assert len(m) == 15 and m.has_std
    assert m.configurations == ["original", "brass_bottom", "brass_top"]
    assert m.of("brass_top")["label"].tolist()[3:] == ["(2,1)", "(1,2)"]


def test_without_mode_numbers_a_peak_list(example_spec):
    """No mode column: a peak list, rows unranked (the fit matches them), sorted by
    frequency within each configuration."""
    frame = GOOD.drop(columns=["mode", "std_hz", "label"]).sample(frac=1, random_state=1)
    m = parse_measurements(frame, example_spec)
    assert not m.ranked and m.of("original")["mode"].tolist() == [0] * 5
    assert m.of("original")["frequency_hz"].is_monotonic_increasing
    assert not m.has_std


def set_cell(row, column, value):
    def edit(frame):
        frame.loc[row, column] = value

    return edit


def rename_column(old, new):
    def edit(frame):
        frame.columns = [new if c == old else c for c in frame.columns]

    return edit


def edited(edit):
    frame = GOOD.copy()
    edit(frame)
    return frame


CASES = [
    (
        "unknown configuration",
        lambda f: f.__setitem__("configuration", f["configuration"].replace("brass_top", "brass_tpo")),
        ["line 12", "'brass_tpo'", "did you mean 'brass_top'"],
    ),
    (
        "duplicate row",
        lambda f: f.loc.__setitem__(3, ["original", 3, 238.8, 0.12, ""]),
        ["lines", "original", "mode 3", "more than once"],
    ),
    ("NaN frequency", set_cell(2, "frequency_hz", float("nan")), ["line 4", "not a number"]),
    ("zero frequency", set_cell(0, "frequency_hz", 0.0), ["line 2", "must be positive"]),
    ("negative frequency", set_cell(1, "frequency_hz", -191.5), ["line 3", "must be positive"]),
    ("negative std", set_cell(1, "std_hz", -0.1), ["line 3", "std_hz", "positive"]),
    ("missing std in one row", set_cell(1, "std_hz", float("nan")), ["line 3", "every row or for none"]),
    ("mode not a rank", set_cell(1, "mode", 0), ["line 3", "mode"]),
    (
        "frequencies not rising with mode",
        set_cell(1, "frequency_hz", 100.0),
        ["'original'", "mode 2 (100 Hz) is below mode 1"],
    ),
    (
        "misspelt column",
        rename_column("frequency_hz", "freq_hz"),
        ["unknown column 'freq_hz'", "did you mean 'frequency_hz'"],
    ),
    ("label not a pattern", set_cell(3, "label", "ring"), ["line 5", "label = 'ring'", "(1,2)"]),
    (
        "damping in per cent",
        lambda f: f.insert(3, "damping_ratio", 0.6),
        ["damping_ratio = 0.6", "0.01 for 1 %"],
    ),
]


@pytest.mark.parametrize("edit,expected", [(e, x) for _, e, x in CASES], ids=[c[0] for c in CASES])
def test_bad_measurements(example_spec, edit, expected):
    with pytest.raises(MeasurementError) as info:
        parse_measurements(edited(edit), example_spec)
    message = str(info.value)
    assert "\n" not in message
    for fragment in expected:
        assert fragment in message, message


def test_missing_file(example_spec, tmp_path):
    with pytest.raises(MeasurementError, match="does not exist"):
        load_measurements(tmp_path / "none.csv", example_spec)
