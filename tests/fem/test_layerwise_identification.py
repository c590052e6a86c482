"""Identification and diagnosis with the layerwise model on the 3-D elasticity reference of
the foam-core sandwich (``tests/data/solid3d/foam_sandwich.json``): the frequencies of a
solid model, not of the plate model, with 0.05 % Gaussian noise (seeded)."""

import re
import tomllib

import numpy as np
import pandas as pd
import pytest

from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.diagnosis.diagnose import diagnose
from identify.engine.uncertainty import WEAK_REL_STD
from identify.fitting.driver import fit
from identify.measurements import parse_measurements
from tests.fem import solid3d

pytestmark = pytest.mark.skipif(
    not solid3d.available("foam_sandwich"),
    reason="3-D reference tests/data/solid3d/foam_sandwich.json not generated yet "
    "(python tests/data/solid3d/generate.py --case foam_sandwich)",
)

NOISE = 5e-4
TRUE = {
    Parameter("E1", "cfrp_fabric"): 62e9,
    Parameter("E2", "cfrp_fabric"): 60e9,
    Parameter("G12", "cfrp_fabric"): 4.8e9,
    Parameter("nu12", "cfrp_fabric"): 0.05,
    Parameter("G13", "pvc_foam"): 35e6,
    Parameter("G23", "pvc_foam"): 35e6,
}
#: Handbook starts: a generic woven carbon/epoxy (E 55 GPa, G12 4 GPa, nu12 0.1) and the
#: data-sheet shear modulus of an 80 kg/m^3 PVC foam (27 MPa, e.g. Divinycell H80).
START = {
    Parameter("E1", "cfrp_fabric"): 55e9,
    Parameter("E2", "cfrp_fabric"): 55e9,
    Parameter("G12", "cfrp_fabric"): 4.0e9,
    Parameter("nu12", "cfrp_fabric"): 0.1,
    Parameter("G13", "pvc_foam"): 27e6,
    Parameter("G23", "pvc_foam"): 27e6,
}


def sandwich_spec(foam_identify: str, theory: str = "layerwise"):
    """The reference's spec (true properties) with the foam's ``identify`` replaced."""
    text = solid3d.load("foam_sandwich")["spec_toml"]
    text = re.sub(r"(\[materials\.pvc_foam\][^\[]*?)identify = \w+", rf"\1identify = {foam_identify}", text)
    if theory == "layerwise":
        text = text.replace("[model]", '[model]\ntheory = "layerwise"')
    return parse_spec(tomllib.loads(text), "foam_sandwich")


def measured(model, seed: int = 1):
    """The first 10 flexural modes of every configuration of the 3-D solution, 0.05 % noise,
    with the nodal-line labels read off the 3-D shapes (as a lab reads them off the plate;
    they settle the close pairs, 0.8-1.4 % apart, without refitting their swaps)."""
    rng = np.random.default_rng(seed)
    rows = []
    for conf in solid3d.load("foam_sandwich")["configurations"]:
        f3d, _, labels = solid3d.reference("foam_sandwich", conf["name"])
        noisy = f3d * (1 + NOISE * rng.standard_normal(len(f3d)))
        rows += [
            {
                "configuration": conf["name"],
                "mode": k + 1,
                "frequency_hz": f,
                "std_hz": NOISE * f3d[k],
                "label": labels[k],
            }
            for k, f in enumerate(noisy)
        ]
    return parse_measurements(pd.DataFrame(rows), model, "<3-D foam sandwich>")


def test_identification_of_skins_and_core_shear():
    """The issue's acceptance, from handbook starts (skins 10-17 % off, the core's shear
    moduli 23 % low), the default mesh: the skins' E1 and the core's G13, G23 within 5 %
    and within 3 std of the truth; every other parameter within 3 std or flagged weakly
    identifiable; the RMS error within 2x the noise.  Measured (seed 1): converged in 4
    iterations, RMS 0.042 %; E1 +0.26 % (1.7 std), G13 -0.10 % (1.1 std), G23 +0.05 %
    (0.6 std), E2 -0.11 %, G12 +0.03 %, nu12 0.060 +- 0.006 (truth 0.05, 1.7 std).  The
    core is identified through its shear moduli only (``identify = ["G13", "G23"]``): its
    in-plane constants hardly enter bending (``test_foam_in_plane_constants_...``)."""
    model = sandwich_spec('["G13", "G23"]')
    data = measured(model)
    result = fit(model.with_values(START), data)
    assert result.rms_rel_error < 2 * NOISE, result.report()
    for parameter, flags in zip(result.parameters, result.uncertainty.flags):
        value, std, truth = result.value(parameter), result.std(parameter), TRUE[parameter]
        if parameter.kind in ("E1", "G13", "G23"):
            assert abs(value / truth - 1) < 0.05 and abs(value - truth) < 3 * std, (parameter, value, std)
        else:
            assert abs(value - truth) < 3 * std or "weakly identifiable" in flags, (
                parameter,
                value,
                std,
                flags,
            )


def test_foam_in_plane_constants_are_weakly_identifiable():
    """Identifying the foam like a ply (E1, E2, G12, nu12 with G13, G23), the linearised
    std at the truth for these 30 frequencies and 0.05 % scatter (sigma sqrt(diag (S^T
    S)^-1), the fit's covariance) says which constants the data carry: the foam's E1, E2
    and nu12 have std above the fit's "weakly identifiable" thresholds (10 % of the value;
    0.03 for nu12): measured 83 %, 40 %, 0.72; its shear moduli and the skins' moduli are
    sharp (below 0.5 %: 0.17-0.32 %).  A full fit on these data (13 iterations, 140 s, so
    not run here) flags exactly E1, E2, nu12 of the foam as weakly identifiable and lists
    them as weak combinations (std 78 %, 28 %, 2.7)."""
    model = sandwich_spec('["E1", "E2", "G12", "nu12", "G13", "G23"]')
    parameters = model.specimen.material_parameters()
    sensitivity = model.sensitivity_matrix(parameters)
    std = NOISE * np.sqrt(np.diag(np.linalg.inv(sensitivity.T @ sensitivity)))
    std = dict(zip(parameters, std))
    for kind in ("E1", "E2"):
        assert std[Parameter(kind, "pvc_foam")] > WEAK_REL_STD
    assert (
        std[Parameter("nu12", "pvc_foam")] * model.value(Parameter("nu12", "pvc_foam")) > WEAK_REL_STD * 0.3
    )
    for parameter in (
        Parameter("E1", "cfrp_fabric"),
        Parameter("E2", "cfrp_fabric"),
        Parameter("G13", "pvc_foam"),
        Parameter("G23", "pvc_foam"),
    ):
        assert std[parameter] < 5e-3, (parameter, std[parameter])


def test_diagnosis_selects_the_layerwise_model():
    """A Kirchhoff baseline (the skins identified, the foam known at its handbook 27 MPa)
    misses the sandwich by 18 % RMS; of the candidates that model the section (the FSDT
    with the laminate shear correction, and the layerwise model, which also frees the
    core's shear moduli) the diagnosis ranks the layerwise model first and it brings the
    misfit to the noise level (within 2x; measured 0.042 % at the default mesh, G13 = 34.96,
    G23 = 35.02 MPa; the FSDT 7.4 %).  A 12-element mesh (0.05 % from converged at mode 10)
    keeps the test short."""
    model = (
        sandwich_spec("false", theory="single_layer")
        .with_values({p: v for p, v in START.items() if p.target == "pvc_foam"})
        .with_options(divisions=12)
    )
    data = measured(model)
    diagnosis = diagnose(model, data, ["transverse_shear", "layerwise"])
    best = diagnosis.candidates[0]
    assert best.kind == "layerwise", diagnosis.report()
    assert best.rms_rel_error < 2 * NOISE and diagnosis.baseline.rms_rel_error > 20 * NOISE
