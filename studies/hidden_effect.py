"""Data that carry an effect the baseline model lacks: fitted with the baseline, diagnosed,
refitted with the effect.

Cases (0.05 % frequency scatter, close modes labelled as a lab would, 8 modes per
configuration):
- sensor_mass: a 3 g accelerometer at (125, 110) mm on every configuration of the
  paper's plate;
- thick_plate: the paper's stack five times thicker (5.5 mm on 150 mm, a/h = 27, with
  3 mm brass plates), whose frequencies carry transverse shear (first-order shear theory).

For each: the baseline misfit is far above the noise, the true effect ranks first, the
RMS error falls at least 5x and to within 2x the noise, and the layer properties come
back within their uncertainty.

    python -m studies.hidden_effect [--out DIR]
"""
from __future__ import annotations

from dataclasses import dataclass

from fem.attachments import PointMass
from fem.model import SpecimenModel
from fem.specimen import Parameter
from identify.diagnose import Diagnosis, diagnose
from identify.plots import plot_before_after
from identify.synthetic import synthetic_measurements

from .common import parse_args, report_folder, start_model, true_model, write_text

NOISE = 5e-4
MODES = 8


def thick(model: SpecimenModel) -> SpecimenModel:
    """The paper's plate with every layer five times thicker and 3 mm brass plates."""
    values = {Parameter("thickness", "layer1"): 1e-3, Parameter("thickness", "layer2"): 3.5e-3,
              Parameter("thickness", "layer3"): 1e-3}
    for name, side in (("brass_bottom", "bottom"), ("brass_top", "top")):
        values[Parameter("thickness", f"{name}.{side}1")] = 0.1e-3
        values[Parameter("thickness", f"{name}.{side}2")] = 3e-3
    return model.with_values(values)


#: case -> (the effect the data carry, the truth's model from the paper's, the start's).
CASES = {
    "sensor_mass": ("point_mass", lambda m: m.with_attachments([PointMass(3e-3, 0.125, 0.110)]), lambda m: m),
    "thick_plate": ("transverse_shear", lambda m: thick(m).with_options(transverse_shear=True), thick),
}


@dataclass(frozen=True)
class HiddenEffect:
    case: str
    true_effect: str
    diagnosis: Diagnosis
    max_z: float          # largest |identified - true| / std of the layer properties after the refit

    @property
    def ranked_first(self) -> str:
        return self.diagnosis.candidates[0].kind

    @property
    def rms_before(self) -> float:
        return self.diagnosis.baseline.rms_rel_error

    @property
    def rms_after(self) -> float:
        return self.diagnosis.candidates[0].rms_rel_error


def run_case(case: str, kinds: list[str] | None = None, seed: int = 4) -> HiddenEffect:
    true_effect, make_truth, make_start = CASES[case]
    truth = make_truth(true_model().with_options(modes=MODES))
    data = synthetic_measurements(truth, modes=MODES, noise_rel=NOISE, seed=seed, labels="close")
    result = diagnose(make_start(start_model().with_options(modes=MODES)), data, kinds)
    best = result.candidates[0].fit
    z = [abs(best.value(p) - truth.value(p)) / best.std(p) for p in truth.specimen.material_parameters()]
    return HiddenEffect(case, true_effect, result, float(max(z)))


def run(out=None, cases=tuple(CASES), kinds: list[str] | None = None) -> list[HiddenEffect]:
    folder = report_folder("hidden_effect", out)
    outcomes = [run_case(case, kinds) for case in cases]
    lines = ["Hidden effects: baseline fit, diagnosis, refit", ""]
    for o in outcomes:
        lines += [f"== {o.case}: data carry {o.true_effect} ==",
                  f"baseline RMS error {100 * o.rms_before:.4f} % (noise {100 * NOISE:.3g} % per mode), reduced chi^2 "
                  f"{o.diagnosis.baseline.statistics.reduced_chi2:.3g}",
                  f"ranked first: {o.ranked_first}; RMS error after refit {100 * o.rms_after:.4f} % "
                  f"(fall {o.rms_before / o.rms_after:.1f}x)",
                  f"layer properties after the refit: largest |error| / std = {o.max_z:.2f}", "",
                  o.diagnosis.report(), ""]
        best = o.diagnosis.candidates[0]
        plot_before_after(o.diagnosis.baseline, best.fit, best.kind, folder / f"{o.case}_before_after.png")
    write_text(folder / "summary.txt", "\n".join(lines) + "\n")
    return outcomes


if __name__ == "__main__":
    run(parse_args("hidden_effect", __doc__).out)
    print("report written to reports/hidden_effect (or --out)")
