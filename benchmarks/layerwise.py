"""Layerwise benchmark: the cost of one solve and of one identification with the
layerwise (zig-zag) model against the FSDT model, on the foam-core sandwich of the 3-D
references (250 x 200 mm, 0.5 mm woven CFRP skins, 6 mm PVC foam; 0.1 mm bond line and
1 mm aluminium under or over it), 10 modes per configuration, the default mesh.

Run: ``python -m benchmarks.layerwise``.  Solutions are cached by content, so the cache is
cleared before every timed solve and fit; the unit matrices of the mesh stay assembled
(they are built once per mesh and element type, like in any session).
"""

import time
import tomllib

import numpy as np

from fem.model import solve_laminate
from fem.solver.reduced_basis import Reanalysis
from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.fitting.driver import fit
from identify.recordings.synthetic import synthetic_measurements

from .common import best_time

SANDWICH = """
[specimen]
name = "foam sandwich"
length_mm = 250.0
width_mm = 200.0
layers = [ { material = "cfrp_fabric", thickness_mm = 0.5 }, { material = "pvc_foam", thickness_mm = 6.0 },
           { material = "cfrp_fabric", thickness_mm = 0.5 } ]

[materials.cfrp_fabric]
E1_GPa = 62.0
E2_GPa = 60.0
G12_GPa = 4.8
nu12 = 0.05
density_kg_m3 = 1500.0
G13_GPa = 3.5
G23_GPa = 3.5
identify = true

[materials.pvc_foam]
E1_GPa = 0.1
E2_GPa = 0.1
G12_GPa = 0.035
nu12 = 0.4286
density_kg_m3 = 80.0
G13_GPa = 0.035
G23_GPa = 0.035
identify = ["G13", "G23"]

[materials.soft_adhesive]
E1_GPa = 1.0
E2_GPa = 1.0
G12_GPa = 0.3571
nu12 = 0.4
density_kg_m3 = 1150.0

[materials.aluminium]
E1_GPa = 70.0
E2_GPa = 70.0
G12_GPa = 26.32
nu12 = 0.33
density_kg_m3 = 2700.0

[[configurations]]
name = "original"

[[configurations]]
name = "al_bottom"
bottom = [
  { material = "soft_adhesive", thickness_mm = 0.1 },
  { material = "aluminium", thickness_mm = 1.0 },
]

[[configurations]]
name = "al_top"
top = [ { material = "soft_adhesive", thickness_mm = 0.1 }, { material = "aluminium", thickness_mm = 1.0 } ]

[model]
modes = 10
"""
#: Handbook-like start values: skins 10-20 % off, the foam's shear moduli 20 % low.
START = {
    ("E1", "cfrp_fabric"): 55e9,
    ("E2", "cfrp_fabric"): 52e9,
    ("G12", "cfrp_fabric"): 4.0e9,
    ("nu12", "cfrp_fabric"): 0.06,
    ("G13", "pvc_foam"): 28e6,
    ("G23", "pvc_foam"): 28e6,
}
MODELS = {
    "FSDT": {"transverse_shear": True, "rotary_inertia": True},
    "layerwise": {"theory": "layerwise"},
    "layerwise, one group per layer": {"theory": "layerwise", "layer_groups": "layers"},
}


def sandwich(**options):
    return parse_spec(tomllib.loads(SANDWICH), "<benchmark>").with_options(**options)


def solve_cost(model, configuration: str) -> tuple[int, float]:
    """DOFs and best time of a cold solve (unit matrices assembled once beforehand)."""
    model.solve(configuration)

    def cold():
        solve_laminate.cache_clear()
        model.solve(configuration)

    return model.solve(configuration).units.n_dofs, best_time(cold, repeat=3)


def fit_cost(model) -> tuple[float, int, float]:
    """Time, iterations and RMS error of a fit of the model's own (noise-free) frequencies
    from the handbook start (every mode labelled, as the lab reads the nodal lines, so no
    close-pair refits): the same work per iteration as a fit of measured data."""
    data = synthetic_measurements(model, modes=10, labels="all")
    start = model.with_values({Parameter(kind, target): value for (kind, target), value in START.items()})
    if model.options.theory != "layerwise":  # the FSDT cannot read the core's shear apart: fit the skins only
        start = start.with_values({Parameter(k, "pvc_foam"): 35e6 for k in ("G13", "G23")})
    parameters = [
        p
        for p in start.specimen.material_parameters()
        if model.options.theory == "layerwise" or p.target != "pvc_foam"
    ]
    solve_laminate.cache_clear()
    t0 = time.perf_counter()
    result = fit(start, data, parameters=parameters)
    return time.perf_counter() - t0, result.iterations, result.rms_rel_error


def reanalysis_cost(model) -> tuple[float, float, float, float]:
    """The reduced-basis model of every configuration (``fem.solver.reduced_basis``) on the
    handbook start's modes: time to build it (projections; the full solves cached), time
    of one evaluation of every configuration (frequencies and the sensitivities of the
    fit's parameters), its largest relative difference from the full solve at the basis
    point (frequencies, sensitivities) and at the truth (frequencies)."""
    start = model.with_values({Parameter(kind, target): value for (kind, target), value in START.items()})
    parameters = start.specimen.material_parameters()
    names = [c.name for c in start.specimen.configurations]
    for name in names:
        start.solve(name)
    built = time.perf_counter()
    reanalyses = [Reanalysis.of(start, name) for name in names]
    built = time.perf_counter() - built

    seconds = best_time(
        lambda: [r.solve(start.specimen).derivatives(parameters) for r in reanalyses], repeat=5
    )
    at_basis = 0.0
    for r, name in zip(reanalyses, names):
        ritz, full = r.solve(start.specimen), start.solve(name)
        exact = full.derivatives(parameters)
        scale = np.maximum(np.abs(exact).max(axis=0), 1e-300)
        at_basis = max(
            at_basis,
            float(np.max(np.abs(ritz.frequencies_hz / full.frequencies_hz - 1))),
            float(np.max(np.abs(ritz.derivatives(parameters) - exact) / scale)),
        )
    at_truth = max(
        float(np.max(r.solve(model.specimen).frequencies_hz / model.solve(n).frequencies_hz - 1))
        for r, n in zip(reanalyses, names)
    )
    return built, seconds, at_basis, at_truth


def main() -> None:
    print("== layerwise: foam-core sandwich 250 x 200 mm, 10 modes, default mesh ==")
    for name, options in MODELS.items():
        model = sandwich(**options)
        mesh = model.mesh
        for configuration in ("original", "al_bottom"):
            dofs, seconds = solve_cost(model, configuration)
            stack = model.solve(configuration).layerwise
            extra = f", {stack.n_groups} shear groups, {len(stack.stretch)} stretching core" if stack else ""
            print(
                f"one solve, {name:32s} {configuration:9s}: {1e3 * seconds:7.0f} ms, {dofs} DOFs "
                f"({mesh.nx} x {mesh.ny} elements{extra})"
            )
    for name in ("FSDT", "layerwise"):
        built, seconds, at_basis, at_truth = reanalysis_cost(sandwich(**MODELS[name]))
        print(
            f"reduced basis, {name:9s}: built in {1e3 * built:.0f} ms; one evaluation of the 3 "
            "configurations "
            f"(frequencies and 6 sensitivities) {1e3 * seconds:.1f} ms (target 5 ms); off the full solve by "
            f"{at_basis:.1e} at its basis point (target 1e-6), {100 * at_truth:.2f} % at the truth (10-20 % "
            "away)"
        )
    for name in ("FSDT", "layerwise"):
        what = "skins' E1, E2, G12, nu12" + (" + foam G13, G23" if name == "layerwise" else "")
        seconds, iterations, rms = fit_cost(sandwich(**MODELS[name]))
        print(
            f"identification, {name:9s} ({what}), 3 configurations x 10 modes from the handbook start: "
            f"{seconds:.1f} s, {iterations} iterations, RMS {100 * rms:.2g} %"
        )


if __name__ == "__main__":
    main()
