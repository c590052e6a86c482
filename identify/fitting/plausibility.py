"""Is an effect's estimate physically plausible?

A missing effect can be imitated by another one: the error pattern of transverse shear
on a thick plate is matched in part by a heavy mass near the centre, a suspension as
stiff as the plate, or a layer turned by tens of degrees.  Such estimates are marked, and
the diagnosis does not prefer them over a plausible rival that fits about as well.  The
limits (each judged on the estimate, not on its std):

- a point mass heavier than ``MAX_MASS_SHARE`` of the plate (the original configuration)
  and than ``SENSOR_MASS_MAX``: accelerometers and glue blobs are grams on plates of
  hundreds of grams, but a light plate can carry a sensor of a larger share (miniature
  accelerometers weigh 0.2-2 g, general-purpose ones with cable and wax up to about 10 g;
  the blind study's foam sandwich of 123 g carried a true 6.3 g sensor, 5.2 %, and a
  share alone called it implausible);
- suspension springs whose rigid-body frequency (the plate bouncing on them, sqrt(k_total
  / m)) exceeds ``MAX_SUSPENSION_RATIO`` of the first measured frequency: a support that
  stiff is not a free suspension (test practice keeps it below 10-20 %);
- a layer's material axes turned from the spec's ``angle_deg`` more than ``MAX_TURN_DEG``
  or, where the spec states the lay-up tolerance (``angle_deg_std``), more than
  ``TURN_STDS`` times it (a spec that means a turned layer says so with its angle; a
  hand lay-up known to 3 deg may be 6 deg off: the blind hybrid's plies were 5.6 deg);
- specimen layer thicknesses more than ``MAX_THICKNESS_CHANGE`` off the spec (callipers
  do better), bond lines outside ``BOND_LINE_RANGE`` times their nominal thickness;
- transverse shear moduli above ``MAX_SHEAR_RATIO`` x the material's G12 (isotropic: G13 =
  G23 = G12; fibre plies and wood: G13 about G12, G23 below it; the fitted G12 of a thick
  ply carries the model's error too, so the limit leaves room: at 1.5 a blind hybrid's
  glass G23 at 1.55 x its fitted G12 made the right shear model "implausible" and left
  nothing selected, while the runaway values it is there for are 10-300 x) or below G12 /
  ``MIN_SHEAR_FRACTION`` (wood's rolling shear G_RT is about G_LR / 10-20).  That is a
  solid's rule: a core whose cells or grain run through its thickness (end-grain balsa,
  a honeycomb), known by a spec's through-thickness modulus E3 at least
  ``THROUGH_THICKNESS_CORE`` times its in-plane moduli, carries transverse shear through
  its cell walls or fibres and may exceed its in-plane G12 up to ``CORE_MAX_SHEAR_RATIO``
  times (end-grain balsa 2-4 x, a honeycomb 10-100 x its in-plane shear modulus, which
  its bending cell walls make tiny).
"""

from __future__ import annotations

import math

from fem.inputs import ANGLE
from fem.solver.attachments import PointMass, Suspension
from fem.specimen import Parameter, Specimen

from ..engine.ambiguity import axis_turn

MAX_MASS_SHARE = 0.05
SENSOR_MASS_MAX = 0.010  # kg
MAX_SUSPENSION_RATIO = 0.2
MAX_TURN_DEG = 5.0
TURN_STDS = 3.0
MAX_THICKNESS_CHANGE = 0.1
BOND_LINE_RANGE = (1 / 3, 3.0)
MAX_SHEAR_RATIO = 2.5
MIN_SHEAR_FRACTION = 100.0
THROUGH_THICKNESS_CORE = 5.0
CORE_MAX_SHEAR_RATIO = 100.0


def plate_mass(specimen: Specimen) -> float:
    """Mass of the specimen alone [kg]: the original plate."""
    return float(
        sum(layer.material.density * layer.thickness for layer in specimen.layers)
        * specimen.length
        * specimen.width
    )


def implausible(
    parameters, fitted: Specimen, nominal: Specimen, first_hz: float | None = None, input_std=()
) -> tuple[str, ...]:
    """Why the effect estimates ``parameters`` in the ``fitted`` specimen are physically
    unlikely, judged against the ``nominal`` one (the spec's); empty when plausible.
    ``first_hz``: the lowest measured frequency (for the suspension); ``input_std``: the
    spec's known inputs' std (a layer's lay-up tolerance widens its turn limit)."""
    tolerance = {u.target: u.std for u in input_std if u.kind == ANGLE}
    reasons = []
    done = set()
    layer_labels = {layer.label for layer in nominal.layers}
    for p in parameters:
        p = Parameter(p.kind, p.target)
        if (p.kind, p.target) in done:
            continue
        done.add((p.kind, p.target))
        if p.kind == "mass":
            mass, plate = fitted.value(p), plate_mass(fitted)
            if mass > max(MAX_MASS_SHARE * plate, SENSOR_MASS_MAX):
                reasons.append(
                    f"a point mass of {1e3 * mass:.3g} g is {100 * mass / plate:.2g} % of the plate's "
                    f"{1e3 * plate:.4g} g (more than {100 * MAX_MASS_SHARE:.0f} % and "
                    f"{1e3 * SENSOR_MASS_MAX:.0f} g: heavier than a sensor or glue blob)"
                )
        elif p.kind == "stiffness":
            springs = fitted.attachment(p.target)
            if isinstance(springs, Suspension) and first_hz:
                total = springs.stiffness * len(springs.points)
                bounce = math.sqrt(total / _total_mass(fitted)) / (2 * math.pi)
                if bounce > MAX_SUSPENSION_RATIO * first_hz:
                    reasons.append(
                        f"suspension springs of {springs.stiffness:.3g} N/m hold the plate at "
                        f"{bounce:.3g} Hz, {100 * bounce / first_hz:.2g} % of the first mode (more than "
                        f"{100 * MAX_SUSPENSION_RATIO:.0f} %: stiffer than a free suspension)"
                    )
        elif p.kind == "angle":
            turn = math.degrees(axis_turn(fitted.value(p) - nominal.value(p)))
            limit = max(MAX_TURN_DEG, TURN_STDS * math.degrees(tolerance.get(p.target, 0.0)))
            if abs(turn) > limit:
                reasons.append(
                    f"layer {p.target} turned {turn:+.3g} deg from the spec's angle (more than "
                    f"{limit:.3g} deg; give angle_deg in the spec if it is meant)"
                )
        elif p.kind == "thickness":
            ratio = fitted.value(p) / nominal.value(p)
            if p.target in layer_labels and abs(ratio - 1) > MAX_THICKNESS_CHANGE:
                reasons.append(
                    f"layer {p.target} {100 * (ratio - 1):+.3g} % off its nominal thickness (more than "
                    f"{100 * MAX_THICKNESS_CHANGE:.0f} %)"
                )
            elif p.target not in layer_labels and not BOND_LINE_RANGE[0] <= ratio <= BOND_LINE_RANGE[1]:
                reasons.append(
                    f"bond line {p.target} at {ratio:.3g} x its nominal thickness (outside "
                    f"{BOND_LINE_RANGE[0]:.2g}-{BOND_LINE_RANGE[1]:g} x)"
                )
        elif p.kind in ("G13", "G23") and ("shear", p.target) not in done:
            done.add(("shear", p.target))
            material = fitted.materials[p.target]
            given = nominal.materials.get(p.target, material)
            highest = CORE_MAX_SHEAR_RATIO if through_thickness_core(given) else MAX_SHEAR_RATIO
            for kind, value in zip(("G13", "G23"), material.transverse_shear_moduli):
                ratio = value / material.G12
                if ratio > highest or ratio < 1 / MIN_SHEAR_FRACTION:
                    reasons.append(
                        f"{p.target} {kind} = {value / 1e9:.3g} GPa is {ratio:.3g} x its G12 (outside "
                        f"1/{MIN_SHEAR_FRACTION:g}-{highest:g} x)"
                    )
    return tuple(reasons)


def through_thickness_core(material) -> bool:
    """A core whose cells or grain run through its thickness: the spec gives an E3 at least
    ``THROUGH_THICKNESS_CORE`` times its larger in-plane modulus."""
    return material.E3 is not None and material.E3 >= THROUGH_THICKNESS_CORE * max(material.E1, material.E2)


def _total_mass(specimen: Specimen) -> float:
    return plate_mass(specimen) + sum(a.mass for a in specimen.attachments if isinstance(a, PointMass))


__all__ = [
    "implausible",
    "plate_mass",
    "through_thickness_core",
    "MAX_MASS_SHARE",
    "SENSOR_MASS_MAX",
]
