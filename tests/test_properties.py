"""Property tests (hypothesis): whatever a user hands the spec parser, the measurement
parser, the recording readers or the peak-list matcher, the answer is a result or a
one-line error of the project's family (``LayerIdError``, a ``ValueError``), never another
exception.  Inputs are the bundled spec and measurements with one value replaced by any
TOML-like value, tables of arbitrary cells, and arbitrary bytes as recording files."""

import copy
import math
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fem.errors import LayerIdError
from fem.spec import load_spec, parse_spec
from identify.engine.matching import align, match
from identify.examples import COATED_PLATE
from identify.measurements import parse_measurements
from identify.recordings.readers import read_csv, read_uff, read_wav

BASE = tomllib.loads(COATED_PLATE.read_text())
MODEL = load_spec(COATED_PLATE)
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

#: Any value a TOML document can hold (TOML has no null; numbers include the awkward ones).
scalars = st.one_of(
    st.booleans(),
    st.integers(-(10**12), 10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
toml_values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=8), inner, max_size=3)
    ),
    max_leaves=6,
)


def paths(node, prefix=()):
    """Every key path into a parsed TOML document."""
    yield prefix
    if isinstance(node, dict):
        for key, value in node.items():
            yield from paths(value, prefix + (key,))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from paths(value, prefix + (i,))


PATHS = [p for p in paths(BASE) if p]


def replaced(document, path, value):
    out = copy.deepcopy(document)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


def one_line(exc: LayerIdError) -> None:
    assert str(exc) and "\n" not in str(exc), str(exc)


@SETTINGS
@given(st.sampled_from(PATHS), toml_values)
def test_spec_with_any_value_anywhere(path, value):
    try:
        parse_spec(replaced(BASE, path, value))
    except LayerIdError as exc:
        one_line(exc)


@SETTINGS
@given(st.sampled_from(PATHS))
def test_spec_with_a_key_left_out(path):
    document = copy.deepcopy(BASE)
    node = document
    for key in path[:-1]:
        node = node[key]
    del node[path[-1]]
    try:
        parse_spec(document)
    except LayerIdError as exc:
        one_line(exc)


@SETTINGS
@given(toml_values)
def test_spec_of_any_document(value):
    try:
        parse_spec(value)
    except LayerIdError as exc:
        one_line(exc)


cells = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-10, 10**6),
    st.sampled_from(["original", "brass_top", "brass_bottom", "(1,2)", "", " ", "nan", "1e3"]),
    st.text(max_size=6),
)
COLUMNS = ["configuration", "mode", "frequency_hz", "std_hz", "label", "damping_ratio"]


@SETTINGS
@given(st.lists(st.fixed_dictionaries({}, optional={c: cells for c in COLUMNS}), max_size=8))
def test_measurements_of_any_rows(rows):
    try:
        parse_measurements(pd.DataFrame(rows), MODEL)
    except LayerIdError as exc:
        one_line(exc)


@SETTINGS
@given(
    st.binary(max_size=400),
    st.sampled_from([read_csv, read_wav, read_uff]),
    st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True)),
)
def test_recording_readers_on_any_bytes(content, reader, sample_rate):
    suffix = {read_csv: ".csv", read_wav: ".wav", read_uff: ".uff"}[reader]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"hit{suffix}"
        path.write_bytes(content)
        try:
            reader(path, sample_rate)
        except LayerIdError as exc:
            one_line(exc)


numbers = st.floats(-1e3, 1e6, allow_nan=False)


@SETTINGS
@given(st.text(alphabet="time_s,forceaclrnp0123456789.-e\n ", max_size=300))
def test_recording_csv_of_any_text(text):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "hit.csv"
        path.write_text(text)
        try:
            read_csv(path, 48000.0)
        except LayerIdError as exc:
            one_line(exc)


frequencies = st.lists(st.floats(1.0, 1e4), min_size=1, max_size=12).map(lambda f: np.sort(np.array(f)))


@SETTINGS
@given(frequencies, frequencies, st.floats(1e-4, 0.5), st.booleans())
def test_matcher_assigns_each_mode_once(peaks, modes, tolerance, with_std):
    """Any peaks and modes: each peak gets one mode or none, no mode two peaks; a peak
    within the tolerance of a mode alone is not left out (it costs less than the gate)."""
    std = 1e-3 * peaks if with_std else None
    result = match(peaks, std, modes, tolerance)
    assert result.modes.shape == peaks.shape and math.isfinite(result.cost)
    taken = result.modes[result.matched]
    assert len(set(taken.tolist())) == len(taken) and ((taken >= 0) & (taken < len(modes))).all()
    aligned = align(peaks, std, modes)
    assert aligned.modes.shape == peaks.shape and 1 / 3 - 1e-9 <= aligned.scale <= 3 + 1e-9


@pytest.mark.parametrize("frame", [None, 5, "configuration,frequency_hz", [1, 2], {"a": 1}])
def test_measurements_of_what_is_not_a_table(frame):
    with pytest.raises(LayerIdError) as info:
        parse_measurements(frame, MODEL)
    one_line(info.value)
