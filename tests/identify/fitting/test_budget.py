"""The uncertainty budget: known inputs' std propagated to the identified
properties, checked by a refit and by Monte Carlo."""

from dataclasses import replace

import numpy as np
import pytest

from fem.errors import SpecError
from fem.model import SHEAR_THEORY_STD_REL
from fem.spec import load_spec, parse_spec
from fem.specimen import Parameter
from identify.fitting.budget import with_budget
from identify.fitting.driver import HANDBOOK_STD_REL, fit, fit_layers, with_held_scatter
from identify.measurements import Measurements
from identify.recordings.synthetic import synthetic_measurements
from tests.conftest import DATA

SPEC = DATA / "coating_on_aluminium.toml"
#: The coating's true properties (the spec holds start values).
TRUTH = {Parameter("E1", "coating"): 25e9, Parameter("E2", "coating"): 23e9, Parameter("G12", "coating"): 9e9}


@pytest.fixture(scope="module")
def nominal():
    return load_spec(SPEC).with_values(TRUTH)


@pytest.fixture(scope="module")
def data(nominal):
    """Frequencies of the nominal plate, labelled (so the pairing is settled), with a
    stated scatter of 0.001 %: far below what the inputs' uncertainty does."""
    return synthetic_measurements(nominal, modes=6, noise_rel=1e-5, seed=0, labels="all")


@pytest.fixture(scope="module")
def result(nominal, data):
    return fit(load_spec(SPEC), data)


def with_inputs(model, inputs: dict):
    """The model with some known inputs changed (SI): parameters, or 'length'/'width'."""
    geometry = {k: v for k, v in inputs.items() if k in ("length", "width")}
    values = {k: v for k, v in inputs.items() if k not in geometry}
    return model.with_specimen(replace(model.specimen, **geometry)).with_values(values)


def test_budget_table_and_total(result):
    """Every input of the spec appears; the total is the root sum of squares of its
    parts; the reported std is the total."""
    budget = result.budget
    assert result.converged and budget is not None
    assert {u.name for u in budget.inputs} == {
        "aluminium.E1",
        "aluminium.E2",
        "aluminium.G12",
        "aluminium.density",
        "coating.density",
        "layer1.thickness",
        "layer2.thickness",
        "specimen.length",
        "specimen.width",
    }
    np.testing.assert_allclose(
        budget.total_std**2, budget.measurement_std**2 + np.sum(budget.contributions**2, 1)
    )
    np.testing.assert_allclose(result.uncertainty.std, budget.total_std, rtol=1e-9)
    assert budget.total_std[0] > 100 * budget.measurement_std[0], "the inputs dominate the scatter here"
    table = budget.table()
    assert list(table["parameter"]) == ["coating.E1", "coating.E2", "coating.G12"]


@pytest.mark.parametrize(
    "name,kind,target,step",
    [
        ("aluminium.E1", "E1", "aluminium", 0.01),
        ("layer1.thickness", "thickness", "layer1", 0.005),
        ("specimen.length", "length", None, 0.002),
    ],
)
def test_sensitivity_matches_a_refit(nominal, data, result, name, kind, target, step):
    """d theta / d beta against central differences of refits with the input moved by
    +-step (relative): the data are the nominal plate's, so a refit with a changed input
    moves the coating by what the budget's linear sensitivity predicts; 3 % covers the
    second-order terms of steps of 0.2-1 % (measured: below 1 %)."""
    j = [u.name for u in result.budget.inputs].index(name)
    key = kind if kind == "length" else Parameter(kind, target)
    size = nominal.specimen.length if kind == "length" else nominal.value(key)
    moved = [fit_layers(with_inputs(nominal, {key: size * (1 + s * step)}), data).values for s in (1, -1)]
    central = (moved[0] - moved[1]) / (2 * step * size)
    np.testing.assert_allclose(
        result.budget.sensitivity[:, j], central, rtol=0.03, atol=1e-3 * np.abs(central).max()
    )


def test_monte_carlo_covers_the_observed_spread(nominal, data, result):
    """Draw every known input from its stated std, compute the true frequencies, fit
    with the nominal inputs: the identified coating scatters as the budget says.  60
    draws: the sample std is itself uncertain by 1/sqrt(2 x 59) = 9 %, so 20 % is about
    2 of those (seed fixed; measured ratios 1.06, 1.12, 1.01)."""
    rng = np.random.default_rng(1)
    values = []
    for _ in range(60):
        draws = {}
        for u in nominal.input_std:
            key = u.kind if u.kind in ("length", "width") else Parameter(u.kind, u.target)
            base = getattr(nominal.specimen, u.kind) if u.kind in ("length", "width") else nominal.value(key)
            draws[key] = base + u.std * rng.standard_normal()
        truth = with_inputs(nominal, draws)
        exact = synthetic_measurements(truth, modes=6).table["frequency_hz"].to_numpy()
        values.append(fit_layers(nominal, Measurements(data.table.assign(frequency_hz=exact), "<mc>")).values)
    observed = np.std(values, axis=0, ddof=1)
    inputs_part = np.sqrt(np.sum(result.budget.contributions**2, axis=1))
    np.testing.assert_allclose(inputs_part / observed, 1.0, atol=0.2)


def test_std_of_an_identified_property_is_refused():
    import tomllib

    data = tomllib.loads(SPEC.read_text())
    data["materials"]["coating"]["E1_GPa_std"] = 1.0
    with pytest.raises(SpecError, match="E1 of coating is identified"):
        parse_spec(data)
    data = tomllib.loads(SPEC.read_text())
    data["specimen"]["mass_g_std"] = 0.1
    with pytest.raises(SpecError, match="mass_g_std is given without mass_g"):
        parse_spec(data)


def test_a_held_property_carries_its_handbook_scatter(nominal, data):
    """A layer property the diagnosis had to hold at the spec's value (here the coating's
    G12, held at its true value so that the misfit is at the 0.001 % noise and does not
    inflate the std) is a "consider" parameter: its handbook scatter
    (``HANDBOOK_STD_REL``) enters the others' std through the budget, whose sensitivity
    to it matches refits with it moved by +-1 % (3 %, as above), and a note names it."""
    g12 = Parameter("G12", "coating")
    free = [Parameter("E1", "coating"), Parameter("E2", "coating")]
    start = nominal
    held = fit_layers(start, data, free)
    widened = with_held_scatter(held, [g12])
    names = [u.name for u in widened.budget.inputs]
    j = names.index("coating.G12")
    assert widened.budget.inputs[j].std == pytest.approx(HANDBOOK_STD_REL * start.value(g12))
    assert "aluminium.E1" in names, "the known inputs are in the same budget"
    assert np.all(widened.uncertainty.std > 2 * held.uncertainty.std), "a 20 % G12 dominates E1 and E2's std"
    assert held.converged
    assert any("coating.G12 held at the spec's values" in w for w in widened.warnings)
    moved = [
        fit_layers(start.with_values({g12: start.value(g12) * (1 + s * 0.01)}), data, free).values
        for s in (1, -1)
    ]
    central = (moved[0] - moved[1]) / (2 * 0.01 * start.value(g12))
    np.testing.assert_allclose(widened.budget.sensitivity[:, j], central, rtol=0.03)
    assert with_held_scatter(held, []) is held
    assert with_budget(widened) is widened, "a result with a budget is not widened twice"


ANGLE_STD_DEG = 3.0


@pytest.fixture(scope="module")
def orthotropic():
    """The coating made a fibre-like ply (E1 = 40, E2 = 10 GPa) whose axes are known to
    ``ANGLE_STD_DEG`` (``angle_deg_std``), nominally along the plate."""
    import tomllib

    spec = tomllib.loads(SPEC.read_text())
    spec["specimen"]["layers"][1]["angle_deg_std"] = ANGLE_STD_DEG
    model = parse_spec(spec)
    values = {
        Parameter("E1", "coating"): 40e9,
        Parameter("E2", "coating"): 10e9,
        Parameter("G12", "coating"): 4e9,
    }
    return model.with_values(values)


def test_a_layer_angle_enters_to_second_order(orthotropic):
    """A misaligned layer moves the properties one way (frequencies even in the angle at
    0 deg on this plate): the budget's first-order part of the angle must vanish and its
    second-order part be sqrt(3) x the property change of a refit with the angle at u
    (the module doc), each checked against refits at +-u.  The budget is linear in the
    frequency change and the refits are not: measured 0.5 % (E1), 5.1 % (E2, whose 0.1 %
    change is the difference of larger ones), 0.7 % (G12); 8 % leaves room for that and
    still fails on a missing sqrt(3) (a factor 1.73) or a half-size second difference."""
    data = synthetic_measurements(orthotropic, modes=6, noise_rel=1e-5, seed=0, labels="all")
    nominal = fit_layers(orthotropic, data)
    budget = with_budget(nominal).budget
    names = [u.name for u in budget.inputs]
    first, second = names.index("layer2.angle"), names.index("layer2.angle, second order")
    u = np.radians(ANGLE_STD_DEG)
    angle = Parameter("angle", "layer2")
    moved = [
        fit_layers(orthotropic.with_values({angle: s * u}), data).values - nominal.values for s in (1, -1)
    ]
    odd, even = (moved[0] - moved[1]) / 2, (moved[0] + moved[1]) / 2
    assert np.abs(even).max() > 0 and np.abs(odd).max() < 1e-3 * np.abs(even).max(), (
        "even in the angle at 0 deg"
    )
    np.testing.assert_allclose(budget.contributions[:, second], np.sqrt(3) * np.abs(even), rtol=0.08)
    assert np.all(budget.contributions[:, first] < 1e-3 * budget.contributions[:, second])
    assert np.all(budget.contributions[:, second] > budget.measurement_std), (
        "3 deg matters more than 0.001 % scatter"
    )


@pytest.mark.parametrize("sensor_y", [None, 0.090], ids=["mirror_symmetric", "sensor_off_the_mid_line"])
def test_a_mirror_symmetric_plate_turned_back_is_not_solved_again(orthotropic, monkeypatch, sensor_y):
    """On a plate that is its own mirror image about y = W/2 with its angles negated (every
    ply at 0 or 90 deg, no sensor off the mid-line), the ply turned by -u is the mirror
    image of the ply turned by +u: the budget solves +u only.  Against the same budget
    with -u solved (``maps_onto_itself`` made to say no), the second-order column agrees to
    1e-6 relative (the two solves' frequencies differ by the eigen-solver's round-off,
    about 1e-13 relative, against a second difference of about 1e-4 of each frequency at 3
    deg) and the first-order one is exactly zero, where the solved one is round-off.  With
    a 20 g sensor off the mid-line both are solved, as before: the same budget to the
    last digit."""
    from fem.solver.attachments import PointMass
    from fem.specimen import Specimen
    from identify.fitting.budget import uncertainty_budget

    model = orthotropic
    if sensor_y is not None:
        model = model.with_attachments([PointMass(20e-3, 0.100, sensor_y)])
    data = synthetic_measurements(model, modes=6, noise_rel=1e-5, seed=0, labels="all")
    fitted = fit_layers(model, data)
    shortcut = uncertainty_budget(fitted)
    monkeypatch.setattr(Specimen, "maps_onto_itself", lambda *args, **kwargs: False)
    solved = uncertainty_budget(fitted)
    names = [u.name for u in shortcut.inputs]
    first, second = names.index("layer2.angle"), names.index("layer2.angle, second order")
    if sensor_y is not None:
        np.testing.assert_array_equal(shortcut.sensitivity, solved.sensitivity)
        return
    np.testing.assert_allclose(shortcut.sensitivity[:, second], solved.sensitivity[:, second], rtol=1e-6)
    assert np.all(shortcut.sensitivity[:, first] == 0.0)
    assert np.all(np.abs(solved.sensitivity[:, first]) < 1e-6 * np.abs(solved.sensitivity[:, second]))


def test_an_angle_the_fit_identifies_is_not_an_input(orthotropic):
    """With the orientation effect's angle free, the stated angle std is not used (the fit
    gives the angle's own std)."""
    data = synthetic_measurements(orthotropic, modes=6, noise_rel=1e-5, seed=0, labels="all")
    free = list(orthotropic.specimen.material_parameters()) + [Parameter("angle", "layer2")]
    result = with_budget(
        fit_layers(orthotropic.with_values({Parameter("angle", "layer2"): 0.05}), data, free)
    )
    assert not any("angle" in u.name for u in result.budget.inputs)


def test_an_angle_std_beyond_15_deg_is_refused():
    import tomllib

    spec = tomllib.loads(SPEC.read_text())
    spec["specimen"]["layers"][1]["angle_deg_std"] = 20.0
    with pytest.raises(SpecError, match="angle_deg_std = 20: .* orientation effect"):
        parse_spec(spec)


@pytest.fixture(scope="module")
def shear_plate():
    """The coating plate in first-order shear with rotary inertia, its frequencies with a
    stated 0.01 % scatter: the shear theory's own error (0.049 %) is then most of the std."""
    model = load_spec(SPEC).with_options(transverse_shear=True, rotary_inertia=True)
    data = synthetic_measurements(model.with_values(TRUTH), modes=4, noise_rel=1e-4, seed=0, labels="all")
    return model, data, fit(model, data)


def test_a_shear_theorys_own_error_is_in_the_std(shear_plate):
    """A shear-deformable model's std carries the theory's error against 3-D elasticity
    (``SHEAR_THEORY_STD_REL`` per frequency): a column of the budget, in the total, and
    in the reported std.  The theory's error and the scatter are both independent and
    relative per mode here, through the same fit, so their parts of each property's std
    stand as u / noise_rel = 4.9: to 1e-3, as the theory's u f_i takes the measured f_i, which
    lie 0.01 % from the exact ones the stated std_hz scale (measured 3e-5; the measurement
    part comes from the uncertainty's own SVD, the theory's from a pseudo-inverse)."""
    _, _, result = shear_plate
    budget = result.budget
    assert result.converged and budget.theory_std_rel == SHEAR_THEORY_STD_REL
    np.testing.assert_allclose(
        budget.theory_std / budget.measurement_std, SHEAR_THEORY_STD_REL / 1e-4, rtol=1e-3
    )
    np.testing.assert_allclose(
        budget.total_std**2,
        budget.measurement_std**2 + np.sum(budget.contributions**2, 1) + budget.theory_std**2,
    )
    np.testing.assert_allclose(result.uncertainty.std, budget.total_std, rtol=1e-9)
    assert "theory vs 3-D" in budget.table().columns
    assert budget.to_dict()["theory_std_rel"] == SHEAR_THEORY_STD_REL


def test_the_theorys_part_is_what_refits_move(shear_plate):
    """Against refits: each frequency moved alone by the theory's error (u f_i) moves the
    coating by a column c_i; independent errors give the covariance sum c_i c_i^T.  Its
    std matches the budget's theory part to 1 % (measured 0.02-0.07 %: the refits are
    nonlinear in a 0.049 % step only to second order)."""
    model, data, result = shear_plate
    nominal = model.with_values(TRUTH)
    exact = synthetic_measurements(nominal, modes=4, labels="all").table["frequency_hz"].to_numpy()
    base = fit_layers(nominal, Measurements(data.table.assign(frequency_hz=exact), "<exact>")).values
    columns = []
    for i in range(len(exact)):
        moved = exact.copy()
        moved[i] *= 1 + SHEAR_THEORY_STD_REL
        refit = fit_layers(nominal, Measurements(data.table.assign(frequency_hz=moved), "<moved>"))
        columns.append(refit.values - base)
    c = np.array(columns).T
    np.testing.assert_allclose(np.sqrt(np.diag(c @ c.T)), result.budget.theory_std, rtol=0.01)


def test_a_thin_plate_has_no_theory_part(result):
    """The thin plate's missing shear is what the diagnosis tests; its std is the
    measurements' and the inputs' alone."""
    assert result.model.options.theory_std_rel == 0.0
    assert result.budget.theory_covariance is None
    assert "theory vs 3-D" not in result.budget.table().columns


def test_a_misfit_that_sets_the_scatter_holds_the_theory_already():
    """Without std_hz the scatter is estimated from the residuals, which carry the theory's
    error already: no theory part is added."""
    model = load_spec(SPEC).with_options(transverse_shear=True, rotary_inertia=True)
    data = synthetic_measurements(model.with_values(TRUTH), modes=4, seed=0, labels="all")
    result = fit(model, data)
    assert not result.statistics.scatter_known
    assert result.budget.theory_covariance is None
