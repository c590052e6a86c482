"""Data that carry effects the baseline model lacks: fitted with the baseline, diagnosed
(forward selection), refitted with what was selected.

Cases (0.05 % Gaussian frequency scatter, std_hz stated, close modes labelled as a lab
would):
- sensor_mass: a 3 g accelerometer at (125, 110) mm on every configuration of the
  paper's plate (8 modes per configuration);
- thick_plate: the paper's stack five times thicker (5.5 mm on 150 mm, a/h = 27, with
  3 mm brass plates), whose frequencies carry transverse shear (first-order shear theory;
  8 modes);
- sensor_on_thick: both at once, on the thick plate with rotary inertia too (a Mindlin
  plate) and a 10 g sensor (1 % of its mass) at (125, 110) mm: two hidden effects;
- thick_laminate_3d: frequencies of an independent 3-D solid model (CalculiX, C3D20R;
  ``tests/data/solid3d/thick_laminate.json``): a 200 x 150 x 6 mm glass/carbon/glass
  laminate (a/h = 33), and the same with 1 mm aluminium bonded under or over it on a
  0.1 mm soft adhesive; the first 10 flexural modes per configuration, ranked by pairing
  their shapes with the plate model's (MAC of w on the reference's 13 x 11 grid).  The fit
  starts from typical handbook values of unidirectional E-glass/epoxy and carbon/epoxy
  plies (``HANDBOOK_START``), not from the truth, and does not know G13 or G23;
- spruce_plate_3d: the same for a 240 x 180 x 8 mm quarter-sawn spruce plate
  (``tests/data/solid3d/spruce_plate.json``, a/h = 30), whose rolling shear modulus G23 =
  G_RT is 17x below G12; starts from handbook spruce values (``SPRUCE_START``), G13 and
  G23 not given;
- laminate_on_adhesive_3d: a 5 mm cross-ply CFRP/GFRP(90)/CFRP with 2 mm aluminium on a
  soft bond line, from ``HANDBOOK_START``;
- thick_homogeneous_3d: the control, a 150 x 100 x 8 mm aluminium plate (a/h = 19), from
  ``ALUMINIUM_START``.

For each: the baseline misfit is far above the noise, the diagnosis selects the effects
the data carry, the refit with them brings the RMS error to within 2x the noise, and the
layer properties come back within their uncertainty.

    python -m studies.hidden_effect [--out DIR]
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from fem.model import SpecimenModel
from fem.solver.attachments import PointMass, point_operators
from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.diagnosis.diagnose import Diagnosis, diagnose
from identify.measurements import Measurements, parse_measurements
from identify.recordings.synthetic import synthetic_measurements
from identify.reporting.plots import plot_before_after

from .common import parse_args, report_folder, start_model, true_model, write_text

NOISE = 5e-4
MODES = 8
#: The 3-D references (see tests/data/solid3d/README.md); ``REFERENCE`` is the default case's.
REFERENCE_FOLDER = Path(__file__).resolve().parent.parent / "tests" / "data" / "solid3d"
DEFAULT_REFERENCE = "thick_laminate"
REFERENCE = REFERENCE_FOLDER / f"{DEFAULT_REFERENCE}.json"
REFERENCE_MODES = 10
GPA = 1e9
#: Start values of the 3-D case: typical unidirectional E-glass/epoxy and carbon/epoxy ply
#: data (fibre volume fraction about 0.6), as a user without a measurement would take them
#: from a handbook.  Against the truth: 2.5-15 % off, the carbon ply's G12 44 % high.
HANDBOOK_START = {
    Parameter("E1", "gfrp_ud"): 41 * GPA,
    Parameter("E2", "gfrp_ud"): 10.4 * GPA,
    Parameter("G12", "gfrp_ud"): 4.3 * GPA,
    Parameter("nu12", "gfrp_ud"): 0.28,
    Parameter("E1", "cfrp_ud"): 142 * GPA,
    Parameter("E2", "cfrp_ud"): 10.3 * GPA,
    Parameter("G12", "cfrp_ud"): 7.2 * GPA,
    Parameter("nu12", "cfrp_ud"): 0.27,
}
#: Start values of the spruce plate (``spruce_plate.json``): "handbook" values for spruce
#: a user would type, G13/G23 not given (so they default to G12).  Against the truth
#: (11.0, 0.90, 0.70 GPa, 0.37): E1 -9 %, E2 -11 %, G12 -11 %, nu12 +8 %.
SPRUCE_START = {
    Parameter("E1", "spruce"): 10.0 * GPA,
    Parameter("E2", "spruce"): 0.80 * GPA,
    Parameter("G12", "spruce"): 0.62 * GPA,
    Parameter("nu12", "spruce"): 0.40,
}
#: Start values of the homogeneous control (``thick_homogeneous.json``): handbook aluminium
#: a user might type (6061-T6-like 68.9 GPa; against the truth E -1.6 %, G -1.6 %).
ALUMINIUM_START = {
    Parameter("E1", "aluminium"): 68.9 * GPA,
    Parameter("E2", "aluminium"): 68.9 * GPA,
    Parameter("G12", "aluminium"): 25.9 * GPA,
    Parameter("nu12", "aluminium"): 0.33,
}
#: 3-D reference case -> the start values of its identified materials (the cross-ply on a
#: soft bond line has the thick laminate's plies).
REFERENCE_STARTS = {
    "thick_laminate": HANDBOOK_START,
    "spruce_plate": SPRUCE_START,
    "laminate_on_adhesive": HANDBOOK_START,
    "thick_homogeneous": ALUMINIUM_START,
}
#: ``run_case`` names of the 3-D references.
REFERENCE_CASES = tuple(f"{name}_3d" for name in REFERENCE_STARTS)


def thick(model: SpecimenModel) -> SpecimenModel:
    """The paper's plate with every layer five times thicker and 3 mm brass plates."""
    values = {
        Parameter("thickness", "layer1"): 1e-3,
        Parameter("thickness", "layer2"): 3.5e-3,
        Parameter("thickness", "layer3"): 1e-3,
    }
    for name, side in (("brass_bottom", "bottom"), ("brass_top", "top")):
        values[Parameter("thickness", f"{name}.{side}1")] = 0.1e-3
        values[Parameter("thickness", f"{name}.{side}2")] = 3e-3
    return model.with_values(values)


def _sensor(grams: float):
    return lambda m: m.with_attachments([PointMass(grams * 1e-3, 0.125, 0.110)])


#: case -> (the effects the data carry, the truth's model from the paper's, the start's).
CASES = {
    "sensor_mass": (("point_mass",), _sensor(3.0), lambda m: m),
    "thick_plate": (("transverse_shear",), lambda m: thick(m).with_options(transverse_shear=True), thick),
    "sensor_on_thick": (
        ("point_mass", "transverse_shear"),
        lambda m: _sensor(10.0)(thick(m)).with_options(transverse_shear=True, rotary_inertia=True),
        thick,
    ),
}
#: The effects that count as "transverse shear" (with or without rotary inertia).
SHEAR = {"transverse_shear", "thick_plate"}


@dataclass(frozen=True)
class HiddenEffect:
    case: str
    true_effects: tuple[str, ...]
    diagnosis: Diagnosis
    max_z: float  # largest |identified - true| / std of the layer properties after the final refit

    @property
    def ranked_first(self) -> str:
        return self.diagnosis.candidates[0].kind

    @property
    def selected(self) -> tuple[str, ...]:
        return tuple(c.kind for c in self.diagnosis.selected)

    @property
    def found_all(self) -> bool:
        """Every true effect selected (shear counted with or without rotary inertia)."""
        chosen = {"transverse_shear" if k in SHEAR else k for k in self.selected}
        return all(("transverse_shear" if k in SHEAR else k) in chosen for k in self.true_effects)

    @property
    def rms_before(self) -> float:
        return self.diagnosis.baseline.rms_rel_error

    @property
    def rms_after(self) -> float:
        return self.diagnosis.final.rms_rel_error if self.diagnosis.final else self.rms_before


def run_case(case: str, kinds: list[str] | None = None, seed: int = 4, workers: int = 1) -> HiddenEffect:
    if case in REFERENCE_CASES:
        return run_reference(kinds, workers=workers, case=case.removesuffix("_3d"))
    true_effects, make_truth, make_start = CASES[case]
    truth = make_truth(true_model().with_options(modes=MODES))
    data = synthetic_measurements(truth, modes=MODES, noise_rel=NOISE, seed=seed, labels="close")
    result = diagnose(make_start(start_model().with_options(modes=MODES)), data, kinds, workers=workers)
    return HiddenEffect(
        case,
        true_effects,
        result,
        _max_z(result, {p: truth.value(p) for p in truth.specimen.material_parameters()}),
    )


def _max_z(result: Diagnosis, truth: dict) -> float:
    fitted = result.final or result.baseline
    return float(max(abs(fitted.value(p) - v) / fitted.std(p) for p, v in truth.items()))


# -- the 3-D reference -----------------------------------------------------------------


def _reference_path(case: str) -> Path:
    return REFERENCE_FOLDER / f"{case}.json"


@cache
def _reference(case: str = DEFAULT_REFERENCE) -> dict:
    return json.loads(_reference_path(case).read_text())


def reference_truth(case: str = DEFAULT_REFERENCE) -> SpecimenModel:
    """The 3-D reference's plate (default the thick laminate) with its true properties
    (G13, G23 included), as the 3-D model has them."""
    return parse_spec(tomllib.loads(_reference(case)["spec_toml"]), str(_reference_path(case)))


def reference_start(case: str = DEFAULT_REFERENCE) -> SpecimenModel:
    """The model a user would write: handbook start values (``REFERENCE_STARTS``), G13 and
    G23 not given."""
    truth = reference_truth(case)
    specimen = truth.specimen
    specimen = specimen.with_materials(
        [replace(m, G13=None, G23=None) for m in specimen.identified_materials]
    )
    return truth.with_specimen(specimen).with_values(REFERENCE_STARTS[case])


def _grid_w(solution, length: float, width: float) -> np.ndarray:
    """w of every plate mode on the reference's grid x_i = L i / 12, y_j = W j / 10 ([j][i])."""
    rows = []
    for y in width * np.arange(11) / 10:
        for x in length * np.arange(13) / 12:
            dofs, operators = point_operators(solution.units, x, y)
            rows.append(operators["w"] @ solution.modes.shapes[dofs])
    return np.array(rows)


def reference_measurements(
    modes: int = REFERENCE_MODES, noise: float = NOISE, seed: int = 1, case: str = DEFAULT_REFERENCE
) -> Measurements:
    """The first ``modes`` flexural modes of every configuration of the 3-D solution with
    ``noise`` relative Gaussian scatter (std_hz = noise x f): each ranked by the plate mode
    its shape pairs with (the plate model at the true values, first-order shear with
    rotary inertia; MAC of w on the 13 x 11 grid, optimal assignment), the nodal-line label
    of that plate mode given for modes within 1 % of a neighbour (as a lab reads them off)."""
    truth = reference_truth(case)
    plate = truth.with_options(modes=modes + 6, transverse_shear=True, rotary_inertia=True)
    rng = np.random.default_rng(seed)
    rows = []
    for conf in _reference(case)["configurations"]:
        flexural = [m for m in conf["modes"] if m["classification"] == "flexural"][:modes]
        f3d = np.array([m["frequency_hz"] for m in flexural])
        w3d = np.array([np.ravel(m["w"]) for m in flexural]).T
        solution = plate.solve(conf["name"])
        w = _grid_w(solution, truth.specimen.length, truth.specimen.width)
        mac = (w3d.T @ w) ** 2 / np.outer(np.sum(w3d**2, axis=0), np.sum(w**2, axis=0))
        ref, index = linear_sum_assignment(-mac)
        rank = index[np.argsort(ref)]
        close = np.zeros(modes, dtype=bool)
        gaps = np.diff(f3d) / f3d[:-1] < 0.01
        close[:-1] |= gaps
        close[1:] |= gaps
        noisy = f3d * (1 + noise * rng.standard_normal(modes))
        rows += [
            {
                "configuration": conf["name"],
                "mode": int(rank[k]) + 1,
                "frequency_hz": noisy[k],
                "std_hz": noise * f3d[k],
                "label": solution.labels[rank[k]] if close[k] else "",
            }
            for k in range(modes)
        ]
    frame = pd.DataFrame(rows).sort_values(["configuration", "mode"], kind="stable")
    return parse_measurements(
        frame, truth, f"<3-D reference {_reference_path(case).name}, {100 * noise:g} % noise>"
    )


def reference_values(case: str = DEFAULT_REFERENCE) -> dict[Parameter, float]:
    """The true layer properties and transverse shear moduli of the 3-D model [SI]."""
    specimen = reference_truth(case).specimen
    out = {}
    for m in specimen.identified_materials:
        for kind in ("E1", "E2", "G12", "nu12", "G13", "G23"):
            out[Parameter(kind, m.name)] = m.value(kind)
    return out


def run_reference(
    kinds: list[str] | None = None, seed: int = 1, workers: int = 1, case: str = DEFAULT_REFERENCE
) -> HiddenEffect:
    """A 3-D reference (default the thick laminate) diagnosed from handbook starts."""
    result = diagnose(
        reference_start(case), reference_measurements(seed=seed, case=case), kinds, workers=workers
    )
    truth = {p: v for p, v in reference_values(case).items() if p.kind in ("E1", "E2", "G12", "nu12")}
    return HiddenEffect(f"{case}_3d", ("transverse_shear",), result, _max_z(result, truth))


def run(out=None, cases=(*CASES, *REFERENCE_CASES), kinds: list[str] | None = None) -> list[HiddenEffect]:
    folder = report_folder("hidden_effect", out)
    outcomes = [run_case(case, kinds) for case in cases]
    lines = ["Hidden effects: baseline fit, diagnosis (forward selection), refit with the selection", ""]
    for o in outcomes:
        lines += [
            f"== {o.case}: data carry {' + '.join(o.true_effects)} ==",
            f"baseline RMS error {100 * o.rms_before:.4f} % (noise {100 * NOISE:.3g} % per mode), reduced "
            "chi^2 "
            f"{o.diagnosis.baseline.statistics.reduced_chi2:.3g}",
            f"selected: {' + '.join(o.selected) or 'nothing'}; RMS error after the refit "
            f"{100 * o.rms_after:.4f} % "
            f"(fall {o.rms_before / o.rms_after:.1f}x)",
            f"layer properties after the refit: largest |error| / std = {o.max_z:.2f}",
            "",
            o.diagnosis.report(),
            "",
        ]
        if o.diagnosis.final is not None:
            plot_before_after(
                o.diagnosis.baseline,
                o.diagnosis.final,
                " + ".join(o.selected),
                folder / f"{o.case}_before_after.png",
            )
    write_text(folder / "summary.txt", "\n".join(lines) + "\n")
    return outcomes


if __name__ == "__main__":
    run(parse_args("hidden_effect", __doc__).out)
    print("report written to reports/hidden_effect (or --out)")
