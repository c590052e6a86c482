"""Shear moduli a shear candidate held because they ran out while a sensor was missing are
freed again by the next effect's refit (``fitting.held_shear_moduli``): a point mass
combines with the shear instead of competing with it.  In a file of its own: one point-mass
refit on a thick shear model is about a minute, run beside the other diagnosis tests."""

from dataclasses import replace

from fem.solver.attachments import PointMass
from fem.specimen import Parameter
from identify import fit
from identify.fitting.driver import (
    AddedEffect,
    Refit,
    add_effect,
    held_shear_moduli,
    point_mass_hints,
    prepare_effect,
)
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model
from studies.hidden_effect import thick


def test_a_point_mass_frees_the_shear_moduli_the_state_holds():
    """A shear fit whose G13/G23 ran out while a sensor was missing holds them
    (``_held_shear``); the point-mass refit on top of it frees them again
    (``held_shear_moduli``, ``prepare_effect(free_again=...)``) and so explains the data
    where the point mass alone must absorb the held moduli's error.  The thick paper plate
    (a/h 27) with a 3 g sensor, the steel core's G13 held at a quarter of its value:
    alone, the refit stays far from the scatter (measured, not repeated here: 80 s;
    reduced chi^2 44, 12.6 g); with the shear moduli free it is consistent with the
    scatter (0.25) and the mass is within 3 of its std of the truth (3.9 +- 0.9 g).  On a
    coarser mesh (12 divisions) the point mass started at a mirrored corner and the freed
    moduli ran out again: freeing is no guarantee, the starts still decide."""
    truth = (
        thick(true_model())
        .with_attachments([PointMass(3e-3, 0.125, 0.110)])
        .with_options(modes=8, transverse_shear=True)
    )
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=8, labels="close")
    g13 = Parameter("G13", "steel")
    model = thick(start_model()).with_options(modes=8, transverse_shear=True)
    model = model.with_values({g13: 0.25 * truth.value(g13)})
    state = fit(model, data)  # the layers free, the shear moduli held
    steel = (g13, Parameter("G23", "steel"))
    held = held_shear_moduli(state, [AddedEffect("transverse_shear", state, held=steel)])
    assert held == steel
    assert held_shear_moduli(state, [AddedEffect("transverse_shear", state)]) == ()  # none ran out: none held
    freed = replace(state, parameters=state.parameters + (g13,))
    # free: not held
    assert held_shear_moduli(freed, [AddedEffect("transverse_shear", state, held=steel)]) == steel[1:]
    hints = point_mass_hints(state)
    prepared = prepare_effect(state, "point_mass", hints, free_again=held)
    assert g13 in prepared.added and any("free again with point_mass" in n for n in prepared.notes)
    combined = add_effect(Refit(state, data, model.specimen), "point_mass", hints, prepared=prepared).result
    assert g13 in combined.parameters and combined.statistics.consistent, combined.statistics.reduced_chi2
    mass = next(p for p in combined.parameters if p.kind == "mass")
    assert abs(combined.value(mass) - 3e-3) < 3 * combined.std(mass)
