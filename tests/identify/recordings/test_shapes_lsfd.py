"""Mode shapes by least squares in the frequency domain (``identify.recordings.shapes``):
residues recovered exactly from analytic FRFs, standard errors that cover the noise, the
shapes of the project's FE plate from simulated roving-hammer recordings, agreement with
sdypy-EMA's LSFD on the same FRFs, and bad inputs refused with the field named."""

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from fem.errors import MeasurementError
from fem.solver.mode_shapes import deflection_operator
from fem.spec import load_spec
from identify.cli import main as identify_layers
from identify.recordings.shapes import CSV_COLUMNS, estimate_shapes, lsfd, mpc, normalised
from identify.recordings.tap_simulation import Modes, RovingSetup, TapOptions, roving_hits, write_roving

EPS = np.finfo(float).eps

#: Analytic case: real modes (a close pair 4.5 % apart among them) on 150-600 Hz.
FREQUENCIES_HZ = np.array([200.0, 320.0, 335.0, 500.0])
DAMPING = np.array([0.004, 0.006, 0.008, 0.010])
LINES_HZ = np.arange(150.0, 600.0, 0.25)

#: FE case: a 150 x 100 x 1 mm steel plate, its first 7 elastic modes (222-951 Hz, the
#: closest two 6.5 % or 13 half-power half-bandwidths apart), a 5 x 4 grid, the sensor
#: near a corner (off every nodal line of those modes).
PLATE = """
[specimen]
name = "steel plate"
length_mm = 150.0
width_mm = 100.0
layers = [ { material = "steel", thickness_mm = 1.0 } ]

[materials.steel]
E1_GPa = 210.0
E2_GPa = 210.0
G12_GPa = 80.8
nu12 = 0.3
density_kg_m3 = 7850

[[configurations]]
name = "original"

[model]
modes = 8
"""
MODES = 7
SENSOR_MM = (128.0, 77.0)
BAND_HZ = (150.0, 1000.0)  # the 8th mode (1094 Hz) lies above: the upper residual's
#: 8 kHz and 1.5 s keep 60 CSV files small; every mode decays below 1e-3 by the end.
OPTIONS = TapOptions(sample_rate=8000.0, duration_s=1.5)


def mac(a: np.ndarray, b: np.ndarray) -> float:
    return float(abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * np.vdot(b, b).real))


def residue(modes: Modes) -> np.ndarray:
    """Receptance residues of ``Modes`` (accelerance A s^2 / (s^2 + 2 zeta w s + w^2)):
    A / ((s - p)(s - conj p)) has the residue A / (p - conj p) = A / (2 i w_d) at p."""
    w = 2 * np.pi * modes.frequencies_hz
    return modes.residues / (2j * w * np.sqrt(1 - modes.damping_ratios**2))


def poles(frequencies_hz, damping) -> np.ndarray:
    w = 2 * np.pi * np.asarray(frequencies_hz)
    return -np.asarray(damping) * w + 1j * w * np.sqrt(1 - np.asarray(damping) ** 2)


def analytic_case(points: int, seed: int):
    """Accelerances of ``points`` points: the modes (constants of both signs, one point
    near a node of each mode) plus a mass line L and a stiffness term U s^2 of the
    out-of-band modes; the exact residues (modes, points), L and U."""
    rng = np.random.default_rng(seed)
    constants = rng.uniform(0.2, 2.0, (points, len(FREQUENCIES_HZ))) * rng.choice([-1.0, 1.0], (points, 4))
    constants[np.arange(4) % points, np.arange(4)] *= 1e-3
    lower = rng.normal(0.0, 0.3, points) + 1j * rng.normal(0.0, 0.03, points)
    upper = (rng.normal(0.0, 2e-7, points) + 1j * rng.normal(0.0, 2e-8, points)) / (2 * np.pi) ** 2
    s = 2j * np.pi * LINES_HZ
    h = np.array([Modes(FREQUENCIES_HZ, DAMPING, c).accelerance(LINES_HZ) for c in constants])
    h += lower[:, None] + upper[:, None] * s**2
    exact = np.array([residue(Modes(FREQUENCIES_HZ, DAMPING, c)) for c in constants]).T
    return h, exact, lower, upper


@pytest.mark.parametrize("quantity, power", [("acceleration", 0), ("velocity", 1), ("displacement", 2)])
def test_exact_residues_from_analytic_frfs(quantity, power):
    """Noise-free FRFs that the model holds exactly (a zero-residual least-squares
    problem): a perturbation of the data by delta relative moves the column-scaled
    solution z by at most kappa delta ||z|| (Golub and Van Loan, Matrix Computations,
    4th ed., 5.3.8; the kappa^2 term multiplies the residual, here zero), kappa the scaled
    basis' condition number.  So each term's contribution, its coefficient's error times
    its column's norm over the lines, is within kappa delta ||H||; delta is the rounding
    of the analytic FRF (a sum of six terms of a few operations each, about 10 eps).
    Asserted: 100 kappa eps ||H|| (a factor 10 of margin); measured 2-17 kappa eps, kappa
    3-4.  The same residues from the velocity (mobility) and displacement (receptance)
    forms, the accelerance divided by s and s^2: the residual terms follow the response
    (mass line L / s^2 and stiffness term U in the receptance)."""
    h, exact, lower, upper = analytic_case(points=6, seed=1)
    s = 2j * np.pi * LINES_HZ
    p = poles(FREQUENCIES_HZ, DAMPING)
    fit = lsfd(LINES_HZ, h / s**power, p, quantity)
    k = 2 - power  # the receptance times s^k
    tolerance = 100 * fit.condition * EPS * np.linalg.norm(h / s**power, axis=1)
    size = np.linalg.norm(s[:, None] ** k / (s[:, None] - p), axis=0)[:, None]
    assert fit.condition < 10
    assert np.all(np.abs(fit.residues - exact) * size <= tolerance)
    assert np.all(np.abs(fit.lower - lower) * np.linalg.norm(s ** (k - 2)) <= tolerance)
    assert np.all(np.abs(fit.upper - upper) * np.linalg.norm(s**k) <= tolerance)
    assert np.all(fit.rms * np.sqrt(len(LINES_HZ)) <= tolerance)


def test_standard_errors_cover_the_noise():
    """Complex white noise of one std on every line: E|R_fit - R|^2 = var Re R + var Im R
    is what ``residue_std``^2 states.  Over 400 points x 4 modes the mean of
    |R_fit - R|^2 / std^2 is 1 within 5 of its standard errors: each ratio has a
    variance of at most 2 (that of chi^2_1, the error all in one direction), so the mean
    of 1600 scatters by at most sqrt(2 / 1600) = 0.035: tolerance 0.18.  A std wrong by
    10 % moves the mean by 0.2."""
    h, exact, _, _ = analytic_case(points=400, seed=2)
    rng = np.random.default_rng(3)
    noise = 1e-3 * np.median(np.abs(h))
    noisy = h + noise * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    fit = lsfd(LINES_HZ, noisy, poles(FREQUENCIES_HZ, DAMPING))
    ratio = np.abs(fit.residues - exact) ** 2 / fit.residue_std**2
    assert abs(ratio.mean() - 1) < 0.18
    assert np.allclose(fit.rms, noise, rtol=0.05)  # the noise per line, from 1800 lines


def test_normalised_shape_and_mpc():
    """A real shape turned by any phase comes back real with its largest amplitude 1
    (MPC 1); a travelling wave (phases spread evenly over the points) has MPC 0."""
    shape = np.array([0.3, -1.2, 0.7, 0.05])
    turned, std = normalised(shape * np.exp(2.1j), np.full(4, 0.12))
    np.testing.assert_allclose(turned[0], -shape / 1.2, atol=1e-15)
    np.testing.assert_allclose(std[0], 0.1, rtol=1e-15)
    assert mpc(shape * np.exp(0.4j))[0] == pytest.approx(1.0, abs=1e-15)
    assert mpc(np.exp(2j * np.pi * np.arange(8) / 8))[0] == pytest.approx(0.0, abs=1e-15)


@pytest.fixture(scope="module")
def roving(tmp_path_factory):
    """The FE plate tapped on a 5 x 4 grid, 3 hits a point, the hammer landing 1 mm (std
    per axis) off each point; SHAPES estimated from the CSV files."""
    folder = tmp_path_factory.mktemp("roving")
    (folder / "plate.toml").write_text(PLATE)
    solution = load_spec(folder / "plate.toml").solve("original")
    field = solution.modes.shapes[:, :MODES]

    def shape(r):
        return lambda x, y: float((deflection_operator(solution.units, x / 1000, y / 1000) @ field[:, r])[0])

    shapes = [shape(r) for r in range(MODES)]
    frequencies = solution.frequencies_hz[:MODES]
    damping = np.linspace(0.004, 0.007, MODES)
    points = pd.DataFrame(
        [
            (f"P{i}{j}", x, y)
            for i, x in enumerate(np.linspace(15.0, 135.0, 5))
            for j, y in enumerate(np.linspace(15.0, 85.0, 4))
        ],
        columns=["point", "x_mm", "y_mm"],
    )
    setup = RovingSetup(SENSOR_MM, hits=3, position_std_mm=1.0, seed=4, options=OPTIONS)
    hits = roving_hits(frequencies, damping, shapes, points, setup)
    paths = write_roving(hits, folder / "recordings")
    exact = deflection_operator(solution.units, points["x_mm"] / 1000, points["y_mm"] / 1000) @ field
    estimate = estimate_shapes(paths, points, "original", band_hz=BAND_HZ)
    return SimpleNamespace(estimate=estimate, exact=exact.T, frequencies=frequencies, folder=folder)


def test_shapes_of_the_fe_plate(roving):
    """Every mode in the band is found, at the truth's frequency within 2e-4 (below one
    hit's scatter, 3e-4: the median over points of 3-hit averages; measured 2-7e-5); its
    shape against the FE shape at the grid points: MAC >= 0.99 (measured 0.996-0.999:
    the hammer's 1 mm scatter, 1/30 of the grid's pitch, and the noise), MPC >= 0.99 for
    these real modes (measured 0.998-0.9995: each hit's poles jitter by 3e-4, a phase
    error of a few hundredths of a radian in each point's H1)."""
    estimate = roving.estimate
    found = estimate.modes["frequency_hz"].to_numpy()
    assert len(found) == MODES
    np.testing.assert_allclose(found, roving.frequencies, rtol=2e-4)
    macs = [mac(estimate.shapes[r], roving.exact[r]) for r in range(MODES)]
    assert min(macs) >= 0.99, macs
    assert estimate.modes["mpc"].min() >= 0.99
    assert (estimate.modes["points_found"] >= 16).all()
    assert np.all(np.abs(estimate.shapes).max(axis=1) == pytest.approx(1.0))
    assert estimate.band_hz[0] >= BAND_HZ[0] and estimate.band_hz[1] <= BAND_HZ[1]
    assert "MPC" in estimate.report()


def test_shapes_csv(roving):
    """SHAPES.csv: the contract's columns, one row per mode and point, frequency_hz printed
    as the peak list beside it prints it, so it names the same peak; the points as given."""
    estimate = roving.estimate
    path = roving.folder / "SHAPES.csv"
    estimate.write_csv(path)
    estimate.write_peaks_csv(roving.folder / "peaks.csv")
    text = pd.read_csv(path, dtype={"frequency_hz": str})
    peaks = pd.read_csv(roving.folder / "peaks.csv", dtype={"frequency_hz": str})
    assert list(text.columns) == CSV_COLUMNS
    assert list(peaks.columns) == ["configuration", "frequency_hz", "std_hz", "damping_ratio", "damping_std"]
    assert len(text) == MODES * 20
    assert set(text["frequency_hz"]) == set(peaks["frequency_hz"]) and len(peaks) == MODES
    back = pd.read_csv(path)
    first = back[back["frequency_hz"] == back["frequency_hz"].iloc[0]]
    np.testing.assert_allclose(
        first["amplitude"] + 1j * first["amplitude_imag"], estimate.shapes[0], atol=1e-6
    )
    np.testing.assert_array_equal(first[["x_mm", "y_mm"]], estimate.points[["x_mm", "y_mm"]])


def test_same_shapes_as_sdypy_ema(roving):
    """sdypy-EMA's LSFD (``Model.get_constants``; accelerance, lower and upper residuals)
    on the same H1 of every point and the same lines, given the same poles (a stand-in
    holding ``all_poles`` and ``pole_ind``, as ``whose_poles`` takes another model's):
    the same model, so the same residues to the rounding of two solvers (lstsq there, a
    scaled SVD here; measured 4e-14 of the largest; asserted 1e-9) and MAC >= 0.999."""
    ema = pytest.importorskip("sdypy.EMA", reason="sdypy-EMA (the test extra) is not installed")
    estimate = roving.estimate
    frfs = [pl.frf for pl in estimate.peak_lists.values()]
    assert all(frf.decay_rate == 0 for frf in frfs)  # no window: the poles as they are
    lines = frfs[0].lines(estimate.band_hz)
    first, last = lines[0], lines[-1]
    # sdypy keeps the lines below the one nearest ``upper`` and fits [f_lower, f_upper)
    f = frfs[0].frequency_hz[: last + 3]
    model = ema.Model(
        frf=np.array([frf.h1[: last + 3] for frf in frfs]),
        freq=f,
        lower=f[first],
        upper=f[last + 2],
        pol_order_high=2,
        frf_form="accelerance",
    )
    table = estimate.modes
    given = SimpleNamespace(
        all_poles=[poles(table["frequency_hz"], table["damping_ratio"])],
        pole_ind=np.array([[0, r] for r in range(len(table))]),
    )
    _, constants = model.get_constants(whose_poles=given, f_lower=f[first], f_upper=f[last + 1])
    np.testing.assert_allclose(
        constants.T, estimate.residues, rtol=0, atol=1e-9 * np.abs(estimate.residues).max()
    )
    assert min(mac(estimate.residues[r], constants[:, r]) for r in range(len(table))) >= 0.999


def test_roving_hits_land_off_the_point():
    """A shape linear in x (x / 100 mm; 1 at the sensor) and one mode: each hit's FRF at
    the mode, Y / X of its record (1 s, fully decayed), is the constant where it landed
    times the same factor.  With no scatter, noise or jitter it is the same for every
    hit to the simulation's rounding (measured 2e-10 relative; asserted 1e-8); with 2 mm
    of scatter (std per axis) at x = 50 mm it varies by 2 / 50 = 4 % (measured 3.8 % over
    8 hits, whose sample std is itself uncertain by 27 %: asserted 1.5-8 %)."""
    options = TapOptions(sample_rate=8000.0, duration_s=1.0, jitter_rel=0.0, noise_rel=0.0)
    points = pd.DataFrame({"point": ["A"], "x_mm": [50.0], "y_mm": [20.0]})

    def gains(std_mm):
        hits = roving_hits(
            [300.0],
            [0.01],
            [lambda x, y: x / 100],
            points,
            RovingSetup((100.0, 20.0), hits=8, position_std_mm=std_mm, seed=5, options=options),
        )["A"]
        line = 300  # 300 Hz on the 1 Hz lines of a 1-s record
        return np.array([abs(np.fft.rfft(h.response)[line] / np.fft.rfft(h.force)[line]) for h in hits])

    still = gains(0.0)
    assert np.ptp(still) <= 1e-8 * still.mean()
    assert 0.015 < np.std(gains(2.0) / still.mean(), ddof=1) < 0.08


BAD_INPUTS = [
    (
        {"A": ["a.csv"], "B": []},
        {"point": ["A", "B"], "x_mm": [0.0, 10.0], "y_mm": [0.0, 0.0]},
        "point 'B' .* has no recordings",
    ),
    (
        {"A": ["a.csv"], "C": ["c.csv"]},
        {"point": ["A", "B"], "x_mm": [0.0, 10.0], "y_mm": [0.0, 0.0]},
        "point 'C' has recordings but no row in points",
    ),
    (
        {"A": ["a.csv"], "B": ["b.csv"]},
        {"point": ["A", "B"], "x_mm": [0.0, np.nan], "y_mm": [0.0, 0.0]},
        "x_mm of point 'B' is nan",
    ),
    (
        {"A": ["a.csv"], "B": ["b.csv"]},
        {"point": ["A", "B"], "x_mm": [0.0, 10.0], "y_mm": [0.0, "ten"]},
        "y_mm of point 'B' is 'ten'",
    ),
    (
        {"A": ["a.csv"]},
        {"point": ["A", "A"], "x_mm": [0.0, 10.0], "y_mm": [0.0, 0.0]},
        r"point 'A' is listed 2 times \(rows \[1, 2\]\)",
    ),
    (
        {"A": ["a.csv"], "B": ["b.csv"]},
        {"point": ["A", "B"], "x_mm": [5.0, 5.0], "y_mm": [0.0, 0.0]},
        "'A', 'B' share x_mm, y_mm = \\(5, 0\\)",
    ),
    (
        {"A": ["a.csv"], "B": ["b.csv"]},
        {"point": ["A", "B"], "x": [0.0, 1.0], "y_mm": [0.0, 0.0]},
        "column 'x_mm' is missing",
    ),
    ({"A": ["a.csv"]}, {"point": ["A"], "x_mm": [0.0], "y_mm": [0.0]}, "needs at least 2 points"),
]


@pytest.mark.parametrize("recordings, points, message", BAD_INPUTS)
def test_bad_inputs_name_the_field(recordings, points, message):
    with pytest.raises(MeasurementError, match=message):
        estimate_shapes(recordings, pd.DataFrame(points))


def test_response_only_recordings_are_refused():
    """Without the force, a point's response scales with how hard it was hit: no shape."""
    points = pd.DataFrame({"point": ["A", "B"], "x_mm": [20.0, 60.0], "y_mm": [20.0, 20.0]})
    hits = roving_hits(
        [300.0],
        [0.01],
        [lambda x, y: x / 100],
        points,
        RovingSetup((100.0, 20.0), hits=2, options=TapOptions(sample_rate=8000.0, duration_s=0.5)),
    )
    silent = {p: [replace(h, force=None) for h in hs] for p, hs in hits.items()}
    with pytest.raises(MeasurementError, match="point 'A': its recordings have no force channel"):
        estimate_shapes(silent, points, band_hz=(100.0, 1000.0))


def test_a_points_recording_error_names_the_point(tmp_path):
    """An error reading a point's recordings says which point."""
    with pytest.raises(MeasurementError, match="point 'B': .*no such file"):
        estimate_shapes(
            {"A": [tmp_path / "a.csv"], "B": [tmp_path / "b.csv"]},
            pd.DataFrame({"point": ["B", "A"], "x_mm": [0.0, 10.0], "y_mm": [0.0, 0.0]}),
        )


def test_peaks_points_command(roving, capsys):
    """``peaks --points``: the points table beside a folder per point, the peak list and
    SHAPES.csv written, the same modes as the library call, a report with the shapes
    drawn, exit 0."""
    folder = roving.folder / "recordings"
    roving.estimate.points.to_csv(folder / "points.csv", index=False)
    code = identify_layers(
        [
            "peaks",
            "--points",
            str(folder / "points.csv"),
            "--band",
            *map(str, BAND_HZ),
            "--out",
            str(roving.folder / "cli_peaks.csv"),
            "--shapes-out",
            str(roving.folder / "cli_shapes.csv"),
            "--json",
            "--report",
            str(roving.folder / "cli_report"),
        ]
    )
    document = json.loads(capsys.readouterr().out)
    assert code == 0
    np.testing.assert_allclose(
        [p["frequency_hz"] for p in document["peaks"]], roving.estimate.modes["frequency_hz"], rtol=1e-12
    )
    assert len(pd.read_csv(roving.folder / "cli_shapes.csv")) == MODES * 20
    assert len(pd.read_csv(roving.folder / "cli_peaks.csv")) == MODES
    assert (roving.folder / "cli_report" / "shapes.png").stat().st_size > 0


def test_peaks_points_without_a_point_folder_is_exit_2(tmp_path, capsys):
    pd.DataFrame({"point": ["A", "B"], "x_mm": [10.0, 20.0], "y_mm": [5.0, 5.0]}).to_csv(
        tmp_path / "points.csv", index=False
    )
    assert identify_layers(["peaks", "--points", str(tmp_path / "points.csv")]) == 2
    assert "point 'A': no recordings" in capsys.readouterr().err
