"""Mode shapes from multi-point universal files (``read_uff_points`` and ``peaks FILE.uff
--shapes-out``): data set 58 FRFs of the project's FE plate on a 5 x 4 grid from an
exact modal sum, with and without noise, in ASCII and binary (58b), the grid's
coordinates in data set 15 or 2411 (metres or mm, with or without data set 164, in one
file or agreeing in two), a vibrometer's and a roving hammer's layout, -Z records, a
point measured twice, and every bad input refused with the record and field named."""

import numpy as np
import pandas as pd
import pytest

from fem.errors import MeasurementError
from fem.solver.mode_shapes import deflection_operator
from fem.spec import load_spec
from identify.cli import main as identify_layers
from identify.recordings.peaks import extract_peaks
from identify.recordings.readers import is_multi_point_uff, read_uff_points
from identify.recordings.shapes import estimate_shapes
from identify.recordings.tap_simulation import Modes

from .test_shapes_lsfd import BAND_HZ, MODES, PLATE, SENSOR_MM, mac

#: 0.25 Hz lines (a quarter of the first mode's half-power half-bandwidth) over the band
#: and 50 Hz beyond it, where the 8th mode (1094 Hz) rises.
LINES_HZ = np.arange(100.0, 1050.0, 0.25)
#: A grid whose coordinates print exactly in E13.5 in metres and in mm.
X_MM, Y_MM = np.linspace(15.0, 135.0, 5), np.array([14.0, 38.0, 62.0, 86.0])
#: Damping ratios of the 8 solved modes ([model] modes = 8).
DAMPING = np.linspace(0.004, 0.007, 8)
# the fixed end (reference of a vibrometer test, sensor of a roving hammer): no coordinates needed
FIXED_NODE = 100
SI = {"units_code": 1, "units_description": "SI", "length": 1.0}
MM = {"units_code": 5, "units_description": "mm (milli newton)", "length": 1000.0}


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    """The FE plate's accelerances at the grid's 20 nodes (numbered 1-20) for a force at
    ``SENSOR_MM``: all 8 solved modes (the 8th above the band), damping ``DAMPING``; the
    folder, points, FRFs by node, the first ``MODES`` shapes at the points (modes,
    points), their frequencies [Hz] and their accelerance constants (modes, points)."""
    folder = tmp_path_factory.mktemp("uff")
    (folder / "plate.toml").write_text(PLATE)
    solution = load_spec(folder / "plate.toml").solve("original")
    field = solution.modes.shapes
    points = pd.DataFrame(
        [(str(i * 4 + j + 1), x, y) for i, x in enumerate(X_MM) for j, y in enumerate(Y_MM)],
        columns=["point", "x_mm", "y_mm"],
    )
    at_points = deflection_operator(solution.units, points["x_mm"] / 1000, points["y_mm"] / 1000) @ field
    at_sensor = deflection_operator(solution.units, SENSOR_MM[0] / 1000, SENSOR_MM[1] / 1000) @ field
    constants = at_points * at_sensor[0]
    frfs = {
        int(p): Modes(solution.frequencies_hz, DAMPING, row).accelerance(LINES_HZ)
        for p, row in zip(points["point"], constants)
    }
    return (
        folder,
        points,
        frfs,
        at_points[:, :MODES].T,
        solution.frequencies_hz[:MODES],
        constants[:, :MODES].T,
    )


def frf_record(node, h, roving="response", direction=3, func_type=4, lines=LINES_HZ):
    """Data set 58: the accelerance ``h`` of ``node`` (the response or the reference end,
    ``roving``) along ``direction``, the other end ``FIXED_NODE`` along +Z."""
    import pyuff

    ends = {"rsp_node": node, "rsp_dir": direction, "ref_node": FIXED_NODE, "ref_dir": 3}
    if roving == "reference":
        ends = {"rsp_node": FIXED_NODE, "rsp_dir": 3, "ref_node": node, "ref_dir": direction}
    return pyuff.prepare_58(
        binary=0,
        func_type=func_type,
        id1=f"H{node}",
        **ends,
        data=np.asarray(h),
        x=lines,
        abscissa_spacing=1,
        abscissa_min=float(lines[0]),
        abscissa_inc=float(lines[1] - lines[0]),
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=12,
        orddenom_spec_data_type=13,
    )


def geometry(points, dataset=15, scale=1.0):
    """Data set 15 or 2411: the points' nodes at x_mm, y_mm times ``scale`` (file units per mm), z = 0."""
    import pyuff

    n = len(points)
    prepare = pyuff.prepare_15 if dataset == 15 else pyuff.prepare_2411
    return prepare(
        node_nums=points["point"].astype(int).to_numpy(),
        def_cs=np.zeros(n, int),
        disp_cs=np.zeros(n, int),
        color=np.ones(n, int),
        x=points["x_mm"].to_numpy() * scale,
        y=points["y_mm"].to_numpy() * scale,
        z=np.zeros(n),
    )


def units(system):
    import pyuff

    return pyuff.prepare_164(**system, temp_mode=1, force=1.0, temp=1.0, temp_offset=273.15)


def write(path, sets):
    import pyuff

    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


@pytest.fixture(scope="module")
def metres_file(plate):
    """A vibrometer test in one file: data set 164 (SI), the geometry in metres (15) and the 20 FRFs."""
    folder, points, frfs, *_ = plate
    return write(
        folder / "metres.uff",
        [units(SI), geometry(points, 15, 1e-3), *(frf_record(n, h) for n, h in frfs.items())],
    )


@pytest.fixture(scope="module")
def estimate(metres_file):
    measured = read_uff_points(metres_file)
    return measured, estimate_shapes(measured.recordings_by_point, measured.points, band_hz=BAND_HZ)


def test_shapes_from_a_multi_point_uff(plate, estimate):
    """Every mode in the band found at its FE frequency within 1e-6 (noise-free FRFs
    printed to 12 digits; measured 4e-9 at most: a 100-fold margin), its shape against the
    FE shape at the grid: MAC >= 0.99 (measured 0.99999 for the first six modes and 0.9969
    for the seventh, 951 Hz, nearest the band's top, where the upper residual term stands
    in for the 8th mode 1094 Hz away), the points in mm as the grid, the vibrometer's
    layout."""
    _, points, _, exact, frequencies, _ = plate
    measured, result = estimate
    assert measured.roving == "response" and measured.notes == ()
    pd.testing.assert_frame_equal(measured.points, points)
    np.testing.assert_allclose(result.modes["frequency_hz"], frequencies, rtol=1e-6)
    macs = [mac(result.shapes[r], exact[r]) for r in range(MODES)]
    assert min(macs) >= 0.99, macs


def test_roving_hammer_along_minus_z(plate, metres_file, tmp_path):
    """A roving hammer (one response node, the hammer's node the reference), half the
    nodes hit along -Z (their FRFs negated in the file), the geometry in a second file:
    turned back to +Z, exactly the vibrometer file's records (so its shapes); without the
    sign flip the -Z nodes' amplitudes would change sign."""
    _, points, frfs, *_ = plate
    records = [frf_record(n, -h if n % 2 else h, "reference", -3 if n % 2 else 3) for n, h in frfs.items()]
    paths = [
        write(tmp_path / "frfs.uff", records),
        write(tmp_path / "grid.unv", [units(SI), geometry(points, 15, 1e-3)]),
    ]
    measured, reference = read_uff_points(paths), read_uff_points(metres_file)
    assert measured.roving == "reference"
    pd.testing.assert_frame_equal(measured.points, points)
    for name, (record,) in measured.recordings_by_point.items():
        np.testing.assert_array_equal(record.frf, reference.recordings_by_point[name][0].frf)


#: Inches: data set 164's length factor 1 / 0.0254 per metre.
INCH = {"units_code": 7, "units_description": "IN: inch (pound f)", "length": 1 / 0.0254}


@pytest.mark.parametrize(
    "dataset, system, scale, assumed",
    [
        (15, SI, 1e-3, False),
        (2411, MM, 1.0, False),
        (2411, INCH, 1 / 25.4, False),
        (15, None, 1e-3, True),
        (15, None, 1.0, False),
    ],
)
def test_coordinates_in_any_length_unit(plate, dataset, system, scale, assumed, tmp_path):
    """The grid in metres, mm or inches (data set 164), or without 164 (metres when every
    coordinate is below 5, with a note; mm otherwise): the same points in mm.  Data set 15
    prints 6 digits, 2411 17: the grid (0.038 m, 15 / 25.4 in) comes back to the nanometre
    the reader rounds to."""
    _, points, frfs, *_ = plate
    sets = [geometry(points, dataset, scale), frf_record(1, frfs[1]), frf_record(2, frfs[2])]
    measured = read_uff_points(
        write(tmp_path / "grid.uff", sets if system is None else [units(system), *sets])
    )
    pd.testing.assert_frame_equal(measured.points, points.iloc[:2])
    assert len(measured.notes) == assumed


def test_cli_mm_file_gives_the_metres_files_shapes(plate, estimate, tmp_path):
    """``peaks FILE.uff --shapes-out --out`` on the grid in mm (data sets 2411 and 164):
    the text SHAPES.csv and the peak list the library writes from the metres file; exit 0."""
    _, points, frfs, *_ = plate
    path = write(
        tmp_path / "mm.uff", [units(MM), geometry(points, 2411), *(frf_record(n, h) for n, h in frfs.items())]
    )
    code = identify_layers(
        [
            "peaks",
            str(path),
            "--band",
            *map(str, BAND_HZ),
            "--shapes-out",
            str(tmp_path / "shapes.csv"),
            "--out",
            str(tmp_path / "peaks.csv"),
        ]
    )
    assert code == 0
    estimate[1].write_csv(tmp_path / "library_shapes.csv")
    estimate[1].write_peaks_csv(tmp_path / "library_peaks.csv")
    assert (tmp_path / "shapes.csv").read_text() == (tmp_path / "library_shapes.csv").read_text()
    assert (tmp_path / "peaks.csv").read_text() == (tmp_path / "library_peaks.csv").read_text()
    assert len(pd.read_csv(tmp_path / "shapes.csv")) == MODES * len(points)


def test_points_csv_replaces_the_geometry(plate, metres_file, tmp_path):
    """A points table (point = node number) beside FRFs without geometry gives the
    vibrometer file's points and records; it also replaces a file's own geometry."""
    _, points, frfs, *_ = plate
    bare = write(tmp_path / "bare.uff", [frf_record(n, h) for n, h in frfs.items()])
    points.to_csv(tmp_path / "points.csv", index=False)
    reference = read_uff_points(metres_file)
    for paths in (bare, metres_file):
        measured = read_uff_points(paths, tmp_path / "points.csv")
        pd.testing.assert_frame_equal(measured.points, points)
        for name, records in measured.recordings_by_point.items():
            np.testing.assert_array_equal(records[0].frf, reference.recordings_by_point[name][0].frf)
    moved = points.assign(x_mm=points["x_mm"] + 1.0)
    np.testing.assert_array_equal(read_uff_points(metres_file, moved).points["x_mm"], moved["x_mm"])


SHORT = np.arange(200.0, 232.0, 0.5)  # 64 lines: bad files need no modes
GRID = pd.DataFrame({"point": ["1", "2", "3"], "x_mm": [10.0, 20.0, 30.0], "y_mm": [5.0, 5.0, 5.0]})
ONES = np.ones(len(SHORT), complex)

BAD_FILES = [
    (
        "one_node",
        [geometry(GRID), frf_record(1, ONES), frf_record(1, 2 * ONES)],
        r"every FRF has response node 1 and reference node 100: one point, not a multi-point test",
    ),
    (
        "no_coordinates",
        [geometry(GRID.iloc[:2]), *(frf_record(n, ONES) for n in (1, 2, 3))],
        r"record 'H3': rsp_node = 3 has no coordinates; export the geometry \(data set 15 or 2411\)",
    ),
    (
        "other_lines",
        [geometry(GRID), frf_record(1, ONES), frf_record(2, ONES, lines=SHORT + 0.25)],
        r"record 'H2' \(node 2\): 64 lines from 200.25 Hz by 0.5 Hz, but .*same frequency lines",
    ),
    (
        "time_record",
        [geometry(GRID), frf_record(1, ONES), frf_record(2, ONES), frf_record(3, ONES, func_type=1)],
        r"record 'H3': func_type = 1 is not an FRF",
    ),
    (
        "in_plane",
        [geometry(GRID), frf_record(1, ONES), frf_record(2, ONES, direction=1)],
        r"record 'H2' \(node 2\): rsp_dir = 1 \(\+X\) is not the plate normal; allowed \+Z \(3\) or -Z "
        r"\(-3\)",
    ),
    (
        "both_ends_rove",
        [
            geometry(GRID),
            frf_record(1, ONES),
            frf_record(2, ONES, "reference"),
            frf_record(3, ONES, "reference"),
        ],
        r"FRFs of 2 response nodes and 3 reference nodes; a shape needs one fixed end",
    ),
    (
        "moved_node",
        [
            geometry(GRID),
            geometry(GRID.assign(x_mm=[10.0, 20.5, 30.0]), 2411),
            frf_record(1, ONES),
            frf_record(2, ONES),
        ],
        r"node 2\b.*\(20, 5\).*data set 15.*\(20\.5, 5\).*data set 2411",
    ),
    (
        "record_twice",
        [geometry(GRID), frf_record(1, ONES), frf_record(2, ONES), frf_record(2, ONES)],
        r"'H2'.*node 2\b.*record_twice\.uff.*'H2'",
    ),
    (
        "repeat_as_velocity",
        [
            geometry(GRID),
            frf_record(1, ONES),
            frf_record(2, ONES),
            {**frf_record(2, 2 * ONES), "ordinate_spec_data_type": 11},
        ],
        r"'H2'.*node 2\b.*velocity.*'H2'.*acceleration",
    ),
    (
        "two_units",
        [units(SI), geometry(GRID), frf_record(1, ONES), frf_record(2, ONES), units(MM)],
        r"data sets 164 give different length units \(1, 1000 per metre\)",
    ),
]


@pytest.mark.parametrize("name, sets, message", BAD_FILES, ids=[case[0] for case in BAD_FILES])
def test_bad_files_name_the_record_and_field(tmp_path, capsys, name, sets, message):
    """Each bad file: its MeasurementError from the reader, exit 2 from ``peaks --shapes-out``."""
    path = write(tmp_path / f"{name}.uff", [dict(s) for s in sets])
    with pytest.raises(MeasurementError, match=message):
        read_uff_points(path)
    assert identify_layers(["peaks", str(path), "--shapes-out", str(tmp_path / "shapes.csv")]) == 2
    error = capsys.readouterr().err
    assert "--shapes-out needs a multi-point test" in error if name == "one_node" else f"{name}.uff" in error


def test_single_point_uff_stays_one_points_hits(plate, tmp_path):
    """FRFs of one node are averaged as one point's records, as before (exit 0); with
    --shapes-out they are refused (exit 2)."""
    _, _, frfs, *_ = plate
    path = write(tmp_path / "one.uff", [frf_record(1, frfs[1]), frf_record(1, frfs[1])])
    assert (
        identify_layers(["peaks", str(path), "--band", *map(str, BAND_HZ), "--out", str(tmp_path / "p.csv")])
        == 0
    )
    assert len(pd.read_csv(tmp_path / "p.csv")) >= 5
    assert identify_layers(["peaks", str(path), "--shapes-out", str(tmp_path / "s.csv")]) == 2


def test_coherences_beside_the_frfs_are_skipped(plate, metres_file, tmp_path):
    """A lab export with a coherence record per point beside its FRF (function type 6):
    the coherences are skipped, said in a note, and the FRFs read as without them."""
    _, points, frfs, *_ = plate
    records = [units(SI), geometry(points, 15, 1e-3)]
    for n, h in frfs.items():
        records += [frf_record(n, h), frf_record(n, np.ones(len(h)), func_type=6)]
    measured, reference = (
        read_uff_points(write(tmp_path / "with_coherence.uff", records)),
        read_uff_points(metres_file),
    )
    assert len(measured.notes) == 1 and reference.notes == ()
    for name, (record,) in measured.recordings_by_point.items():
        np.testing.assert_array_equal(record.frf, reference.recordings_by_point[name][0].frf)


def test_a_node_placed_alike_by_two_files(plate, tmp_path):
    """The grid in two files, 1/3 mm off the printed digits: in metres in data set 15 (6
    digits: 15.3333 mm) beside the FRFs, and in data set 2411 (17 digits) in a second
    file, which also places the fixed end's node elsewhere: the same points as the first
    file alone (its printing, within 1 um plus 1e-5 of the value of the other's); the
    fixed end is no point, so its place does not matter."""
    _, points, frfs, *_ = plate
    shifted = points.assign(x_mm=points["x_mm"] + 1 / 3, y_mm=points["y_mm"] + 1 / 3)
    fixed = pd.DataFrame({"point": [str(FIXED_NODE)], "x_mm": [0.0], "y_mm": [0.0]})
    frf_file = write(
        tmp_path / "frfs.uff",
        [
            units(SI),
            geometry(pd.concat([shifted, fixed]), 15, 1e-3),
            *(frf_record(n, h) for n, h in frfs.items()),
        ],
    )
    grid = write(
        tmp_path / "grid.unv", [units(SI), geometry(pd.concat([shifted, fixed.assign(x_mm=9.0)]), 2411, 1e-3)]
    )
    alone = read_uff_points(frf_file)
    assert (
        np.abs(alone.points[["x_mm", "y_mm"]].to_numpy() - shifted[["x_mm", "y_mm"]].to_numpy()).max() > 1e-5
    )
    pd.testing.assert_frame_equal(read_uff_points([frf_file, grid]).points, alone.points)


@pytest.mark.parametrize("moved_mm", [0.01, -5.0])
def test_a_node_placed_apart_by_two_files_is_refused(plate, metres_file, tmp_path, moved_mm):
    """A second file placing node 7 (45, 62 mm) 0.01 mm (above 1 um plus 1e-5 of the
    value, data set 15's printing) or 5 mm away: refused, naming the node, both files and
    both places in mm, in either order; a points table replaces both geometries."""
    _, points, *_ = plate
    moved = points.assign(x_mm=np.where(points["point"] == "7", points["x_mm"] + moved_mm, points["x_mm"]))
    grid = write(tmp_path / "grid.unv", [units(SI), geometry(moved, 2411, 1e-3)])
    place = rf"\({45 + moved_mm:g}, 62\)"
    with pytest.raises(MeasurementError, match=rf"node 7\b.*\(45, 62\).*metres\.uff.*{place}.*grid\.unv"):
        read_uff_points([metres_file, grid])
    with pytest.raises(MeasurementError, match=rf"node 7\b.*{place}.*grid\.unv.*\(45, 62\).*metres\.uff"):
        read_uff_points([grid, metres_file])
    pd.testing.assert_frame_equal(read_uff_points([metres_file, grid], points).points, points)


def test_a_point_measured_twice_is_averaged(plate, tmp_path):
    """Node 7 measured again in a second file along -Z (its FRF negated), 10 % weaker where
    the first file's record is 10 % stronger: both records kept, turned to +Z, and said in
    a note; the point's peak list, as ``estimate_shapes`` makes it, averages them to the
    plate's FRF (each printed to 12 digits: within 7.1e-12 of it) as two hits.  The first
    file given twice is refused: copies would pass for repeats."""
    _, points, frfs, *_ = plate
    first = write(
        tmp_path / "first.uff",
        [
            units(SI),
            geometry(points, 15, 1e-3),
            *(frf_record(n, 1.1 * h if n == 7 else h) for n, h in frfs.items()),
        ],
    )
    again = write(tmp_path / "again.uff", [frf_record(7, -0.9 * frfs[7], direction=-3)])
    measured = read_uff_points([first, again])
    assert len(measured.notes) == 1
    assert {n: len(r) for n, r in measured.recordings_by_point.items()} == {
        n: 1 + (n == "7") for n in points["point"]
    }
    pd.testing.assert_frame_equal(measured.points, points)
    twice = extract_peaks(measured.recordings_by_point["7"], band_hz=BAND_HZ).frf
    assert twice.n_hits == 2
    np.testing.assert_allclose(twice.h1, frfs[7], rtol=1e-11)
    with pytest.raises(MeasurementError, match=r"'H1'.*node 1\b.*first\.uff.*'H1'"):
        read_uff_points([first, first])


#: Noise of the noisy file: white and Gaussian, its std ``NOISE_REL`` times the grid's
#: largest |FRF| on the real and on the imaginary part of every line: the first mode's
#: largest peak stands 60 dB above it, the seventh's 24 dB.
NOISE_REL = 1e-3


def shape_angle(a, b) -> float:
    """The angle [rad] between two shapes, arccos sqrt(MAC): a distance (it obeys the
    triangle inequality), where 1 - MAC is not."""
    return float(np.arccos(np.sqrt(min(mac(a, b), 1.0))))


def test_noisy_frfs_give_shapes_within_the_noise(plate, estimate, tmp_path):
    """The grid's FRFs plus noise (``NOISE_REL``) through the file, ``read_uff_points`` and
    ``estimate_shapes`` as in the first test: the 7 modes found, each within a half-power
    half-bandwidth of its FE frequency, and each shape's angle to the exact one within the
    noise-free estimate's angle plus 3 times the angle the noise is expected to add.

    The expected angle.  With the poles held, LSFD's residue R_jr of mode r at point j
    from lines df apart has var(Re R) = var(Im R) = s^2 / sum_k |s_k^2 / (s_k - p_r)|^2 =
    2 s^2 zeta_r df / w_r^3 (the sum taken as the integral over the resonance; the other
    modes' and the residual terms' columns neglected), s the noise's std.  The plate's
    receptance residue is |R_jr| = A_jr / (2 w_r), A the accelerance constant.  The noise
    across the exact shape has 2 (N - 1) real components over the N points, so the squared
    angle it adds, |noise across|^2 / |R|^2, has a mean below 2 N var / sum_j |R_jr|^2 =
    16 N s^2 zeta_r df / (w_r sum_j A_jr^2) and is that mean times a chi-square of 38
    degrees of freedom over 38.  Its 1e-4 quantiles are 0.36 and 2.08: the angle lies
    within 0.6 and 1.44 times its expected value; 3 (and 1/3) allow twice that for the
    approximations and for the poles, which come from the noisy FRFs too (an error of a
    pole scales a mode's residues alike at every point to first order, leaving its MAC).
    The triangle inequality adds the noise-free estimate's own angle (the 951 Hz mode's
    0.056 rad, its upper residual standing in for the 8th mode).  Measured: the noise's
    angle 0.88-1.12 times the expected one; MAC 0.9954 for the seventh mode and 0.9999 or
    more for the others."""
    _, points, frfs, exact, frequencies, constants = plate
    rng = np.random.default_rng(1)
    noise = NOISE_REL * max(np.abs(h).max() for h in frfs.values())
    noisy = {
        n: h + noise * (rng.standard_normal(len(h)) + 1j * rng.standard_normal(len(h)))
        for n, h in frfs.items()
    }
    measured = read_uff_points(
        write(
            tmp_path / "noisy.uff",
            [units(SI), geometry(points, 15, 1e-3), *(frf_record(n, h) for n, h in noisy.items())],
        )
    )
    result = estimate_shapes(measured.recordings_by_point, measured.points, band_hz=BAND_HZ)
    found = result.modes["frequency_hz"].to_numpy()
    assert len(found) == MODES and np.all(np.abs(found - frequencies) < DAMPING[:MODES] * frequencies), found
    w = 2 * np.pi * frequencies
    expected = np.sqrt(
        16
        * len(points)
        * noise**2
        * DAMPING[:MODES]
        * (LINES_HZ[1] - LINES_HZ[0])
        / (w * np.sum(constants**2, axis=1))
    )
    clean = estimate[1].shapes
    to_exact = np.array([shape_angle(result.shapes[r], exact[r]) for r in range(MODES)])
    clean_to_exact = np.array([shape_angle(clean[r], exact[r]) for r in range(MODES)])
    to_clean = np.array([shape_angle(result.shapes[r], clean[r]) for r in range(MODES)])
    assert np.all(to_exact <= clean_to_exact + 3 * expected), (
        np.cos(to_exact) ** 2,
        clean_to_exact,
        expected,
    )
    assert np.all((to_clean >= expected / 3) & (to_clean <= 3 * expected)), to_clean / expected


def test_binary_58b_reads_as_the_ascii_file(plate, metres_file, tmp_path):
    """The vibrometer file with its FRFs in pyuff's binary form of data set 58 (58b: the
    header in ASCII, the values as doubles; 'binary': 1 in the record, written after the
    ASCII data sets, as pyuff's overwrite mode truncates a file whose first set is
    binary): recognised as a multi-point test from its headers, the same points, layout
    and notes as the ASCII file, the FRFs the written doubles exactly and the ASCII file's
    within rtol 1e-11 (those print each part to 12 digits, %20.11e: within 5e-12 of it,
    so within 7.1e-12 of |H|)."""
    import pyuff

    _, points, frfs, *_ = plate
    binary = write(
        tmp_path / "binary.uff",
        [
            units(SI),
            geometry(points, 15, 1e-3),
            *({**frf_record(n, h), "binary": 1} for n, h in frfs.items()),
        ],
    )
    if b"\n    58b" not in binary.read_bytes():
        pytest.skip(
            f"pyuff {pyuff.__version__} wrote data set 58 in ASCII despite 'binary': 1: no 58b to read"
        )
    assert is_multi_point_uff(binary)
    measured, reference = read_uff_points(binary), read_uff_points(metres_file)
    assert (measured.roving, measured.notes) == (reference.roving, reference.notes)
    pd.testing.assert_frame_equal(measured.points, reference.points)
    for name, (record,) in measured.recordings_by_point.items():
        np.testing.assert_array_equal(
            record.frequency_hz, reference.recordings_by_point[name][0].frequency_hz
        )
        np.testing.assert_array_equal(record.frf, frfs[int(name)])
        np.testing.assert_allclose(record.frf, reference.recordings_by_point[name][0].frf, rtol=1e-11, atol=0)
