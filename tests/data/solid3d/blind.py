#!/usr/bin/env python3
"""Blind 3-D reference cases for the diagnosis study: a seeded random family of layered
plates, solved with CalculiX (C3D20R full-plate models, ``generate.py``'s meshes).

Each case draws, from one ``numpy`` generator seeded with ``SEED``:

- a family, in turn: ``hybrid`` (GFRP/CFRP/GFRP or CFRP/GFRP/CFRP, all 0 deg, a/h 15-60),
  ``cross_ply`` (CFRP 0 / GFRP or CFRP 90 / CFRP 0, a/h 15-60) or ``sandwich`` (woven CFRP
  or glass skins 0.3-1.0 mm on a core of G = 10-200 MPa, log-uniform, 4-12 mm);
- the plies' constants: the base materials of ``generate.MATERIALS`` scaled by 0.85-1.15
  per constant, the transversely isotropic plies kept consistent (G13 = G12,
  G23 = E2 / 2(1 + nu23), E3 = E2); the core isotropic (nu = 0.3, density from G);
- misaligned plies: every orthotropic ply turned by +-U(0, d) deg with d = U(0, 8) per
  case (the spec the user writes keeps the nominal 0/90 deg);
- a sensor (half of the cases): 1-10 g on the top surface at a point in the middle 80 %
  of the plate.  On a laminate a ``*MASS`` element on the surface node nearest to the point
  (the point stored is the node's; there a point is a converged model).  On a sandwich,
  where a mass at a point is singular (the skin and the soft core deform without bound
  under it), spread over the sensor's square base of ``SENSOR_BASE_MM`` + 1 mm per gram
  (1-10 g accelerometers stand on 6-15 mm): the top layer's elements under the base made
  denser by the mass, the mesh lines following the base (``FOOTPRINT_3D``);
- the bonded configurations: a soft bond line of 0.05-0.3 mm and an aluminium plate of
  1-2 mm under (``al_bottom``) or over (``al_top``) the specimen.

Full-plate models (misaligned plies and the sensor break the mirror symmetries), the
``coarse`` mesh of ``generate.LEVELS`` (24 elements along the length, one element per
started 2 mm through every layer).  Its error: ``--check-stored`` reads it off the stored
references of ``generate.py`` (same element size and thickness rule, coarse against fine:
at most 0.04 % over the first 10 flexural modes, 0.02 % on the foam sandwich);
``--check`` solves the first hybrid and sandwich (al_bottom) on the ``medium`` mesh too.
Both go to ``blind/mesh_check.json``.  The first
``FLEXURAL_MODES`` flexural
modes of every configuration are stored with their nodal-line label and the rank of the
plate mode (the project's first-order shear plate with rotary inertia at the true values,
sensor and angles) their shape pairs with (MAC of w on a 13 x 11 grid, optimal
assignment), so that the study can rank them without storing shapes.

The split into a development and a held-out half is drawn once from ``SPLIT_SEED`` and
stored in ``index.json`` with both seeds.  That held-out half was run once (run 8, commit
7874d5f) and its failures were then worked on, so it joined the development half; a second
series of ``N_CASES_2`` cases drawn from ``SEED_2`` (blind25-blind36) is the held-out half
since (``halves``).

A third series (``draw_cases_3``, ``SEED_3``, blind37-blind96) draws families the first two
never did, in turn, ``PER_FAMILY_3`` = 12 cases each:

- ``balsa_sandwich``: woven carbon (60 %) or glass skins 0.3-1.0 mm (constants scaled
  0.85-1.15, the glass too) on a 5-20 mm core soft in plane and stiffer through its
  thickness, end-grain balsa or honeycomb type (``_balsa_core``: E1 = E2 = 0.02-0.3 GPa,
  G12 0.005-0.1 GPa and at most E1 / 2, G13 = 2-100 x G12, G23 = 0.5-0.9 x G13,
  E3 = 10-100 x E1, so that the spec states it, nu13, nu23 = 0.01-0.05, 40-250 kg/m^3;
  its 3-D compliance positive definite, ``positive_definite``);
- ``thick_skins``: woven carbon or glass skins 1.0-2.5 mm or aluminium skins 0.5-2 mm
  (half each) on a foam core (``_core``, 4-12 mm) or a balsa-type core (5-20 mm), half each;
- ``coating``: a polymer coating (E = 0.5-5 GPa log-uniform, nu = 0.35-0.45, 1100-1600
  kg/m^3, 0.2-2.0 mm) on one side, top or bottom, of a steel or aluminium sheet of
  0.8-3 mm (E, nu, density 0.97-1.03 x the handbook's): two layers, unsymmetric (the
  specimen's metals are named ``steel``, ``aluminium_sheet``, ``aluminium_skin``: the
  bonded plate is ``aluminium``);
- ``angle_ply``: [+t/-t/+t] or [+t/-t/+t/-t/+t] (equal plies), t = 15-60 deg (whole
  degrees), CFRP or GFRP plies (``_ply``), a/h 15-60: bending-twisting coupling,
  |D16| / D11 = 0.11-0.77 over the draws (an antisymmetric [+t/-t/+t/-t] has D16 = 0);
- ``sensor``: the four stacks above in turn, every one with a sensor.

The plates 200-300 mm long on a sandwich stack, 150-250 mm otherwise; misalignment, sensor
(half of the cases outside the ``sensor`` family) and bonded configurations as above.  Only
plies with axes are turned: a core, a metal and a coating keep 0 deg (a case without such
plies has ``misalignment_max_deg`` 0).  A sensor stands on its base on a sandwich and on a
coating on top; on a metal or a laminate it is a point mass.  The series is split per
family into 6 'dev3' and 6 'heldout3' cases (``split_by_family``, ``SPLIT_SEED_3``).

A fourth series (``SEED_4``, blind97-blind126) draws the third's families again, 6 cases
each, all held out ('heldout4'): after the third series' held-out half had been run (and
failed on sensors), a half that no rule has seen.  A fifth (``SEED_5``, blind127-blind156,
'heldout5') draws them once more, after the fourth had been run once and its misses
worked on, and a sixth (``SEED_6``, blind157-blind186, 'heldout6') after the fifth had.

    python tests/data/solid3d/blind.py [--only NAME ...] [--check]
    python tests/data/solid3d/blind.py --regression [--only NAME ...]
    python tests/data/solid3d/blind.py --shapes-only --only NAME [--only NAME ...]

``--regression`` solves the fixed cases of ``REGRESSION`` into ``regression/<case>.json``
(all of them, or only the ``--only`` ones: the others' records are left as they are).

``--shapes-only`` re-solves stored cases exactly as they were made and writes the top-face
w of their stored flexural modes (``blind_shapes/<case>.json``, the grid of ``generate.GRID``),
refusing a case whose re-solved frequencies differ from its record by more than
``SHAPES_TOLERANCE``.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[2]))

import generate as g  # noqa: E402

OUT = HERE / "blind"
#: The top-face shapes of the stored modes (``--shapes-only``).
SHAPES_OUT = HERE / "blind_shapes"
#: A re-solve for the shapes must give the stored frequencies to this relative difference.
SHAPES_TOLERANCE = 1e-5
SEED = 20_2026
SPLIT_SEED = 20_2027
N_CASES = 24
#: The second series: the held-out half after run 8 (the first series' held-out half had
#: been run and worked on).
SEED_2 = 20_2028
N_CASES_2 = 12
FAMILIES = ("hybrid", "cross_ply", "sandwich")
#: The third series: families the first two never drew, in turn, ``PER_FAMILY_3`` cases
#: each (blind37-blind96), split per family into a development and a held-out half by
#: ``SPLIT_SEED_3`` (``split_by_family``).
SEED_3 = 20_2029
SPLIT_SEED_3 = 20_2030
#: ``sensor``: a stack of the other four families (``STACKS_3`` in turn), always with a sensor.
FAMILIES_3 = ("balsa_sandwich", "thick_skins", "coating", "angle_ply", "sensor")
STACKS_3 = FAMILIES_3[:4]
PER_FAMILY_3 = 12
N_CASES_3 = PER_FAMILY_3 * len(FAMILIES_3)
#: The fourth series: the third's families drawn again from a new seed, ``PER_FAMILY_4``
#: cases each (blind97-blind126), all held out ('heldout4'): no rule was written from them.
SEED_4 = 20_2031
PER_FAMILY_4 = 6
#: The fifth series: the same families from another seed (blind127-blind156), all held out
#: ('heldout5'), drawn after the fourth had been run and its misses worked on.
SEED_5 = 20_2032
PER_FAMILY_5 = 6
#: The sixth series: the same families once more (blind157-blind186), all held out
#: ('heldout6'), drawn after the fifth had been run once and its misses worked on.
SEED_6 = 20_2033
PER_FAMILY_6 = 6
#: A sensor's square base on a sandwich: this side [mm] plus 1 mm per gram of its mass.
SENSOR_BASE_MM = 5.0
#: Elements across each side of a sensor's base in the solid model, per thickness factor of
#: the mesh level (coarse 3, medium 5, fine 7: the bending at the base's edges is the
#: sharpest on the plate).
FOOTPRINT_3D = 2
FLEXURAL_MODES = 10
#: Elastic modes asked of the full model (after its six rigid-body modes).
ELASTIC = 18
LEVEL = g.LEVELS[0]
CHECK_LEVEL = g.LEVELS[1]
SCATTER = (0.85, 1.15)
#: A metal's E, nu and density: this factor range times the handbook value.
METAL_SCATTER = (0.97, 1.03)


def _ply(rng, base: str) -> dict:
    """A transversely isotropic ply: the base constants scaled, G13 = G12, E3 = E2,
    G23 = E2 / 2(1 + nu23)."""
    b = g.MATERIALS[base]
    s = lambda: rng.uniform(*SCATTER)  # noqa: E731
    e1, e2, g12, nu12, rho = b["E1"] * s(), b["E2"] * s(), b["G12"] * s(), b["nu12"] * s(), b["density"] * s()
    nu23 = b["nu23"]
    return dict(
        E1=e1,
        E2=e2,
        E3=e2,
        G12=g12,
        G13=g12,
        G23=e2 / (2 * (1 + nu23)),
        nu12=nu12,
        nu13=nu12,
        nu23=nu23,
        density=rho,
        note=f"{base} scaled 0.85-1.15 per constant",
    )


def _fabric(rng, base: str) -> dict:
    """A woven skin (``cfrp_fabric``, or ``gfrp_fabric`` in the third series): in-plane
    constants scaled; through the thickness as the base."""
    b = FABRICS[base]
    s = lambda: rng.uniform(*SCATTER)  # noqa: E731
    e = b["E1"] * s()
    return dict(
        b,
        E1=e,
        E2=e * b["E2"] / b["E1"] * s(),
        G12=b["G12"] * s(),
        nu12=b["nu12"] * s(),
        density=b["density"] * s(),
        note=f"{base} scaled 0.85-1.15 per in-plane constant",
    )


GLASS_FABRIC = dict(
    E1=24.0,
    E2=23.0,
    E3=10.0,
    G12=4.0,
    G13=3.2,
    G23=3.2,
    nu12=0.12,
    nu13=0.3,
    nu23=0.3,
    density=1900.0,
    note="woven E-glass/epoxy skin",
)
#: The woven skins' base constants (GPa, kg/m^3).
FABRICS = {"cfrp_fabric": g.MATERIALS["cfrp_fabric"], "gfrp_fabric": GLASS_FABRIC}


def _core(rng) -> dict:
    """An isotropic foam core, G = 10-200 MPa log-uniform, nu = 0.3, density growing with G."""
    shear = math.exp(rng.uniform(math.log(0.010), math.log(0.200)))
    nu = 0.3
    return dict(
        E1=2 * shear * (1 + nu),
        E2=2 * shear * (1 + nu),
        E3=2 * shear * (1 + nu),
        G12=shear,
        G13=shear,
        G23=shear,
        nu12=nu,
        nu13=nu,
        nu23=nu,
        density=50.0 + 900.0 * shear,
        note="isotropic foam core, E = 2G(1 + nu)",
    )


STEEL = dict(
    E1=210.0,
    E2=210.0,
    E3=210.0,
    G12=210.0 / 2.58,
    G13=210.0 / 2.58,
    G23=210.0 / 2.58,
    nu12=0.29,
    nu13=0.29,
    nu23=0.29,
    density=7850.0,
    note="structural steel, isotropic (G = E / 2(1 + nu))",
)
#: The third series' metals: the specimen's own (named apart from the bonded ``aluminium``).
METALS = {
    "steel": STEEL,
    "aluminium_sheet": g.MATERIALS["aluminium"],
    "aluminium_skin": g.MATERIALS["aluminium"],
}


def _log_uniform(rng, low: float, high: float) -> float:
    return math.exp(rng.uniform(math.log(low), math.log(high)))


def compliance(c: dict) -> np.ndarray:
    """The 3-D compliance [1/GPa] of a material's engineering constants (``MATERIALS``'
    keys; Voigt order 11, 22, 33, 23, 13, 12; nu_ij = -strain_j / strain_i under stress i,
    as ccx reads them)."""
    s = np.diag([1 / c["E1"], 1 / c["E2"], 1 / c["E3"], 1 / c["G23"], 1 / c["G13"], 1 / c["G12"]])
    s[0, 1] = s[1, 0] = -c["nu12"] / c["E1"]
    s[0, 2] = s[2, 0] = -c["nu13"] / c["E1"]
    s[1, 2] = s[2, 1] = -c["nu23"] / c["E2"]
    return s


def positive_definite(c: dict) -> bool:
    """Whether a material's 3-D compliance is positive definite (a physical solid)."""
    return bool(np.linalg.eigvalsh(compliance(c)).min() > 0)


def _metal(rng, name: str) -> dict:
    """An isotropic metal of ``METALS``: E, nu and density scaled by ``METAL_SCATTER``,
    G = E / 2(1 + nu)."""
    b = METALS[name]
    s = lambda: rng.uniform(*METAL_SCATTER)  # noqa: E731
    e, nu, rho = b["E1"] * s(), b["nu12"] * s(), b["density"] * s()
    shear = e / (2 * (1 + nu))
    base = "steel" if name == "steel" else "aluminium"
    return dict(
        E1=e,
        E2=e,
        E3=e,
        G12=shear,
        G13=shear,
        G23=shear,
        nu12=nu,
        nu13=nu,
        nu23=nu,
        density=rho,
        note=f"{base} scaled 0.97-1.03 per constant (E, nu, density), isotropic (G = E / 2(1 + nu))",
    )


def _balsa_core(rng) -> dict:
    """An end-grain balsa or honeycomb-type core: soft in plane (E1 = E2 = 0.02-0.3 GPa,
    G12 = 0.005 GPa to min(0.1 GPa, E1 / 2), both log-uniform, nu12 = 0.2-0.4), stiffer
    through its thickness: G13 = 2-100 x G12 (log-uniform), G23 = 0.5-0.9 x G13,
    E3 = 10-100 x E1 (log-uniform), nu13, nu23 = 0.01-0.05; density 40-250 kg/m^3.  Its
    transverse shear moduli are at most E3 / 2 (both scaled down together where the draw
    gives more): the cell walls or grain that carry the shear carry the crushing load too,
    and no balsa or honeycomb shears more stiffly than it crushes (end-grain balsa: G13
    about 0.05-0.1 E3; a Nomex honeycomb: G13 about 0.3 E3)."""
    e = _log_uniform(rng, 0.02, 0.3)
    g12 = _log_uniform(rng, 0.005, min(0.1, e / 2))
    g13 = g12 * _log_uniform(rng, 2.0, 100.0)
    core = dict(
        E1=e,
        E2=e,
        G12=g12,
        G13=g13,
        G23=g13 * rng.uniform(0.5, 0.9),
        nu12=rng.uniform(0.2, 0.4),
        density=rng.uniform(40.0, 250.0),
        note="end-grain balsa / honeycomb-type core: soft in plane, stiffer through its thickness",
    )
    # Positive definite over these ranges (at the worst corner, nu12 = 0.4, nu13 = nu23 =
    # 0.05, E3 = 100 E1, 1 - nu12^2 - (nu13^2 + nu23^2 + 2 nu12 nu13 nu23) E3/E1 = 0.14):
    # the through-thickness constants are drawn again should a wider range break it.
    while True:
        core.update(
            E3=e * _log_uniform(rng, 10.0, 100.0), nu13=rng.uniform(0.01, 0.05), nu23=rng.uniform(0.01, 0.05)
        )
        if positive_definite(core):
            break
    ceiling = core["E3"] / 2
    if core["G13"] > ceiling:
        core.update(G13=ceiling, G23=core["G23"] * ceiling / core["G13"])
    return core


def _coating(rng) -> dict:
    """A thick polymer coating (paint, a damping layer): isotropic, E = 0.5-5 GPa
    (log-uniform), nu = 0.35-0.45, density 1100-1600 kg/m^3."""
    e, nu = _log_uniform(rng, 0.5, 5.0), rng.uniform(0.35, 0.45)
    shear = e / (2 * (1 + nu))
    return dict(
        E1=e,
        E2=e,
        E3=e,
        G12=shear,
        G13=shear,
        G23=shear,
        nu12=nu,
        nu13=nu,
        nu23=nu,
        density=rng.uniform(1100.0, 1600.0),
        note="polymer coating, isotropic (G = E / 2(1 + nu))",
    )


def _skins(rng, materials: dict, thick: bool) -> tuple[str, float]:
    """A sandwich's skin material (added to ``materials``) and thickness [mm]: woven carbon
    (60 %) or glass 0.3-1.0 mm; ``thick``: woven carbon or glass 1.0-2.5 mm, or aluminium
    0.5-2 mm (half each)."""
    if thick and rng.random() < 0.5:
        materials["aluminium_skin"] = _metal(rng, "aluminium_skin")
        return "aluminium_skin", rng.uniform(0.5, 2.0)
    name = "cfrp_fabric" if rng.random() < 0.6 else "gfrp_fabric"
    materials[name] = _fabric(rng, name)
    return name, rng.uniform(1.0, 2.5) if thick else rng.uniform(0.3, 1.0)


def _stack_3(rng, stack: str, materials: dict) -> tuple[float, list, str | None, bool]:
    """A third-series stack: its length [mm], nominal layers (material, thickness [mm],
    angle [deg]) bottom to top, its core (None without) and whether a sensor on its top
    face stands on its base (on a soft layer or a soft core a point mass is singular).
    Adds the materials drawn to ``materials``."""
    if stack in ("balsa_sandwich", "thick_skins"):
        length = rng.uniform(200.0, 300.0)
        skin, t_skin = _skins(rng, materials, thick=stack == "thick_skins")
        if stack == "balsa_sandwich" or rng.random() < 0.5:
            core, t_core = "balsa_core", rng.uniform(5.0, 20.0)
            materials[core] = _balsa_core(rng)
        else:
            core, t_core = "foam_core", rng.uniform(4.0, 12.0)
            materials[core] = _core(rng)
        return length, [(skin, t_skin, 0.0), (core, t_core, 0.0), (skin, t_skin, 0.0)], core, True
    length = rng.uniform(150.0, 250.0)
    if stack == "coating":
        metal = "steel" if rng.random() < 0.5 else "aluminium_sheet"
        materials[metal] = _metal(rng, metal)
        materials["coating"] = _coating(rng)
        layers = [(metal, rng.uniform(0.8, 3.0), 0.0), ("coating", rng.uniform(0.2, 2.0), 0.0)]
        on_top = rng.random() < 0.5
        return length, layers if on_top else layers[::-1], None, on_top
    # angle_ply: [+t/-t/+t] or [+t/-t/+t/-t/+t], equal plies: D16, D26 != 0
    ply = "cfrp_ud" if rng.random() < 0.5 else "gfrp_ud"
    materials[ply] = _ply(rng, ply)
    h = length / rng.uniform(15.0, 60.0)
    n = 3 if rng.random() < 0.5 else 5
    t = float(round(rng.uniform(15.0, 60.0)))
    return length, [(ply, h / n, t if k % 2 == 0 else -t) for k in range(n)], None, False


def draw_case_3(rng, index: int, family: str, stack: str) -> dict:
    """One case of the third series: ``draw_case``'s choices on a ``STACKS_3`` stack; the
    plies with axes (not a core, a metal or a coating) misaligned by up to 0-8 deg; a
    sensor on half of the cases (on every case of the ``sensor`` family)."""
    materials = {"aluminium": g.MATERIALS["aluminium"], "soft_adhesive": g.MATERIALS["soft_adhesive"]}
    length, nominal, core, on_base = _stack_3(rng, stack, materials)
    description = f"blind {family} case {index + 1}" + (f" ({stack})" if stack != family else "")
    drawn = _Drawn(index, family, length, nominal, materials, on_base, description, family == "sensor")
    return _record(rng, drawn, stack=stack, core=core)


def draw_case(rng, index: int) -> dict:
    """One random case (a ``generate.CASES``-like dict with its own materials and choices)."""
    family = FAMILIES[index % len(FAMILIES)]
    materials = {"aluminium": g.MATERIALS["aluminium"], "soft_adhesive": g.MATERIALS["soft_adhesive"]}
    if family == "sandwich":
        length = rng.uniform(200.0, 300.0)
        skin_name = "cfrp_fabric" if rng.random() < 0.6 else "gfrp_fabric"
        materials[skin_name] = (
            _fabric(rng, "cfrp_fabric") if skin_name == "cfrp_fabric" else dict(GLASS_FABRIC)
        )
        materials["foam_core"] = _core(rng)
        skin, core = rng.uniform(0.3, 1.0), rng.uniform(4.0, 12.0)
        nominal = [(skin_name, skin, 0.0), ("foam_core", core, 0.0), (skin_name, skin, 0.0)]
    else:
        length = rng.uniform(150.0, 250.0)
        slenderness = rng.uniform(15.0, 60.0)
        h = length / slenderness
        outer = h * rng.uniform(0.15, 0.3)
        if family == "hybrid":
            a, b = ("gfrp_ud", "cfrp_ud") if rng.random() < 0.5 else ("cfrp_ud", "gfrp_ud")
            nominal = [(a, outer, 0.0), (b, h - 2 * outer, 0.0), (a, outer, 0.0)]
        else:
            a, b = "cfrp_ud", ("gfrp_ud" if rng.random() < 0.5 else "cfrp_ud")
            nominal = [(a, outer, 0.0), (b, h - 2 * outer, 90.0), (a, outer, 0.0)]
        # The middle ply's material drawn first (the order a set's iteration happened to take
        # for 14 of the 16 stored laminates; it varied with Python's hash seed).
        for name in dict.fromkeys((b, a)):
            materials[name] = _ply(rng, name)
    on_base = family == "sandwich"
    drawn = _Drawn(index, family, length, nominal, materials, on_base, f"blind {family} case {index + 1}")
    return _record(rng, drawn)


#: The materials whose layers have axes a lay-up can turn (plies); a core, a metal or a
#: coating has none.
WITH_AXES = ("cfrp_ud", "gfrp_ud", "cfrp_fabric", "gfrp_fabric")


@dataclass(frozen=True)
class _Drawn:
    """A case's stack as drawn: its number, family, length [mm], nominal layers (material,
    thickness [mm], angle [deg]) bottom to top, materials, whether a sensor on its top face
    stands on its base, its description, and whether it always carries a sensor."""

    index: int
    family: str
    length: float
    nominal: list
    materials: dict
    on_base: bool
    description: str
    sensor_always: bool = False


def _record(rng, drawn: _Drawn, **choices) -> dict:
    """A drawn stack's case dict, the rest drawn in this order: the width (0.6-0.9 x the
    length), the plies' misalignment (each ply with axes turned by +-U(0, d) deg, d =
    U(0, 8) per case), a 1-10 g sensor (on half of the cases, or always) at a point in the
    middle 80 %, and the bonded configurations' soft bond line (0.05-0.3 mm) and aluminium
    plate (1-2 mm).  ``choices``: the third series' stack and core, after the family."""
    length, nominal = drawn.length, drawn.nominal
    plies = {m for m, _, _ in nominal if m in WITH_AXES}
    width = length * rng.uniform(0.6, 0.9)
    spread = rng.uniform(0.0, 8.0) if plies else 0.0
    layers = []
    for m, t, angle in nominal:
        turn = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.0, spread)) if m in plies else 0.0
        layers.append((m, round(t, 3), round(angle + turn, 2)))
    sensor = None
    if drawn.sensor_always or rng.random() < 0.5:
        sensor = dict(
            mass_g=round(rng.uniform(1.0, 10.0), 2),
            x_mm=rng.uniform(0.1, 0.9) * length,
            y_mm=rng.uniform(0.1, 0.9) * width,
        )
        if drawn.on_base:
            sensor["base_mm"] = round(SENSOR_BASE_MM + sensor["mass_g"], 1)
    bond, plate = round(rng.uniform(0.05, 0.3), 3), round(rng.uniform(1.0, 2.0), 2)
    added = [("soft_adhesive", bond, 0.0), ("aluminium", plate, 0.0)]
    return dict(
        name=f"blind{drawn.index + 1:02d}_{drawn.family}",
        family=drawn.family,
        **choices,
        length_mm=round(length, 1),
        width_mm=round(width, 1),
        layers=layers,
        nominal_layers=[(m, round(t, 3), a) for m, t, a in nominal],
        materials=drawn.materials,
        sensor=sensor,
        misalignment_max_deg=round(spread, 2),
        bond_line_mm=bond,
        aluminium_mm=plate,
        configurations=[
            dict(name="original", bottom=[], top=[]),
            dict(name="al_bottom", bottom=added, top=[]),
            dict(name="al_top", bottom=[], top=added),
        ],
        description=drawn.description,
    )


def _fixed(
    name: str,
    family: str,
    length: float,
    width: float,
    layers,
    materials: dict,
    sensor,
    bond: float,
    plate: float,
    description: str,
) -> dict:
    added = [("soft_adhesive", bond, 0.0), ("aluminium", plate, 0.0)]
    return dict(
        name=name,
        family=family,
        length_mm=length,
        width_mm=width,
        layers=layers,
        nominal_layers=layers,
        materials={
            "aluminium": g.MATERIALS["aluminium"],
            "soft_adhesive": g.MATERIALS["soft_adhesive"],
            **materials,
        },
        sensor=sensor,
        misalignment_max_deg=0.0,
        bond_line_mm=bond,
        aluminium_mm=plate,
        configurations=[
            dict(name="original", bottom=[], top=[]),
            dict(name="al_bottom", bottom=added, top=[]),
            dict(name="al_top", bottom=[], top=added),
        ],
        description=description,
    )


#: Fixed cases of the same generator (regression tests, not part of the blind family): the
#: diagnosis's two known failures rebuilt on other stacks and masses (a thick
#: carbon/glass/carbon laminate carrying a sensor, and a glass-skinned foam sandwich), and a
#: sandwich family the blind draw lacks: carbon-fabric skins on an end-grain balsa-type core,
#: soft in plane but stiffer through its thickness (E3 = 20 E1; G13, G23 = 3.1, 2.4 G12).
REGRESSION = (
    _fixed(
        "regression_sensor_on_thick",
        "hybrid",
        200.0,
        150.0,
        [("cfrp_ud", 1.2, 0.0), ("gfrp_ud", 3.0, 0.0), ("cfrp_ud", 1.2, 0.0)],
        {"cfrp_ud": g.MATERIALS["cfrp_ud"], "gfrp_ud": g.MATERIALS["gfrp_ud"]},
        dict(mass_g=6.0, x_mm=150.0, y_mm=40.0),
        0.1,
        1.0,
        "5.4 mm CFRP/GFRP/CFRP (a/h = 37) with a 6 g sensor",
    ),
    _fixed(
        "regression_foam_sandwich",
        "sandwich",
        260.0,
        200.0,
        [("gfrp_fabric", 0.6, 0.0), ("foam_core", 8.0, 0.0), ("gfrp_fabric", 0.6, 0.0)],
        {
            "gfrp_fabric": GLASS_FABRIC,
            "foam_core": dict(
                E1=0.13,
                E2=0.13,
                E3=0.13,
                G12=0.05,
                G13=0.05,
                G23=0.05,
                nu12=0.3,
                nu13=0.3,
                nu23=0.3,
                density=95.0,
                note="isotropic foam core, E = 2G(1 + nu)",
            ),
        },
        None,
        0.15,
        1.5,
        "glass-fabric skins 0.6 mm on an 8 mm foam core of G = 50 MPa",
    ),
    _fixed(
        "regression_balsa_sandwich",
        "sandwich",
        240.0,
        160.0,
        [("cfrp_fabric", 0.4, 0.0), ("balsa_core", 6.0, 0.0), ("cfrp_fabric", 0.4, 0.0)],
        {
            "cfrp_fabric": g.MATERIALS["cfrp_fabric"],
            "balsa_core": dict(
                E1=0.18,
                E2=0.18,
                E3=3.6,
                G12=0.07,
                G13=0.22,
                G23=0.17,
                nu12=0.3,
                nu13=0.02,
                nu23=0.02,
                density=150.0,
                note=(
                    "end-grain balsa-type core: soft in plane, stiffer through the thickness "
                    "(E3 = 20 E1, G13, G23 = 3.1, 2.4 G12)"
                ),
            ),
        },
        None,
        0.12,
        1.2,
        (
            "carbon-fabric skins 0.4 mm on a 6 mm end-grain balsa-type core "
            "(G13, G23 = 3.1, 2.4 G12; E3 = 20 E1)"
        ),
    ),
)


def draw_cases(n: int = N_CASES, seed: int = SEED, first: int = 0) -> list[dict]:
    """``n`` cases from one generator seeded with ``seed``, numbered from ``first`` + 1
    (the family follows the number)."""
    rng = np.random.default_rng(seed)
    return [dict(draw_case(rng, first + i), seed=seed) for i in range(n)]


def draw_cases_3(
    seed: int = SEED_3, first: int = N_CASES + N_CASES_2, per_family: int = PER_FAMILY_3
) -> list[dict]:
    """The third series (the fourth with ``SEED_4``, ``PER_FAMILY_4``): ``per_family``
    cases of each of ``FAMILIES_3`` in turn from one generator seeded with ``seed``,
    numbered from ``first`` + 1; the k-th ``sensor`` case on the stack ``STACKS_3[k % 4]``."""
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(per_family * len(FAMILIES_3)):
        family = FAMILIES_3[i % len(FAMILIES_3)]
        stack = STACKS_3[i // len(FAMILIES_3) % len(STACKS_3)] if family == "sensor" else family
        cases.append(dict(draw_case_3(rng, first + i, family, stack), seed=seed))
    return cases


def all_cases() -> list[dict]:
    """The six series: the first (all development now), the second (held-out), the third
    (split per family), the fourth and fifth (held out, each run once) and the sixth (held
    out)."""
    fourth = N_CASES + N_CASES_2 + N_CASES_3
    fifth = fourth + PER_FAMILY_4 * len(FAMILIES_3)
    return (
        draw_cases()
        + draw_cases(N_CASES_2, SEED_2, first=N_CASES)
        + draw_cases_3()
        + draw_cases_3(SEED_4, fourth, PER_FAMILY_4)
        + draw_cases_3(SEED_5, fifth, PER_FAMILY_5)
        + draw_cases_3(SEED_6, fifth + PER_FAMILY_5 * len(FAMILIES_3), PER_FAMILY_6)
    )


def halves(cases: list[dict]) -> dict[str, str]:
    """Every case's half: the first series all development (its held-out half, drawn by
    ``split``, was run once in run 8 and then worked on), the second series held-out, the
    third 'dev3' or 'heldout3' (``split_by_family``), the fourth 'heldout4', the fifth
    'heldout5', the sixth 'heldout6'."""
    first = [c["name"] for c in cases if c["seed"] == SEED]
    return {
        **{name: "dev" for name in split(first)},
        **{c["name"]: "heldout" for c in cases if c["seed"] == SEED_2},
        **split_by_family([c for c in cases if c["seed"] == SEED_3]),
        **{c["name"]: "heldout4" for c in cases if c["seed"] == SEED_4},
        **{c["name"]: "heldout5" for c in cases if c["seed"] == SEED_5},
        **{c["name"]: "heldout6" for c in cases if c["seed"] == SEED_6},
    }


def split(names: list[str], seed: int = SPLIT_SEED) -> dict[str, str]:
    """Half 'dev', half 'heldout', at random, once."""
    order = np.random.default_rng(seed).permutation(len(names))
    return {names[k]: ("dev" if rank < len(names) // 2 else "heldout") for rank, k in enumerate(order)}


def split_by_family(cases: list[dict], seed: int = SPLIT_SEED_3) -> dict[str, str]:
    """The third series' halves: per family (``FAMILIES_3`` in order, one generator
    seeded with ``seed``) half 'dev3', half 'heldout3' at random; in the cases' order."""
    rng = np.random.default_rng(seed)
    half = {}
    for family in FAMILIES_3:
        names = [c["name"] for c in cases if c["family"] == family]
        order = rng.permutation(len(names))
        half.update(
            {names[k]: ("dev3" if rank < len(names) // 2 else "heldout3") for rank, k in enumerate(order)}
        )
    return {c["name"]: half[c["name"]] for c in cases}


# ---------------------------------------------------------------------------------------


def _sensor_lines(mesh: g.Mesh, case: dict, n_elements: int) -> tuple[tuple[str, ...], tuple[float, float]]:
    """A *MASS element on the top-surface corner node nearest to the sensor point; the
    node's (x, y) in mm."""
    s = case["sensor"]
    ids, coords = mesh.lattice()
    i = 2 * int(round(s["x_mm"] / (mesh.lx / mesh.nx)))
    j = 2 * int(round(s["y_mm"] / (mesh.ly / mesh.ny)))
    node = int(ids[i, j, -1])
    x, y, _ = coords[node - 1]
    lines = (
        "*ELEMENT, TYPE=MASS, ELSET=SENSOR",
        f"{n_elements + 1},{node}",
        "*MASS, ELSET=SENSOR",
        f"{s['mass_g'] * 1e-6:.10g}",
    )
    return lines, (float(x), float(y))


def _base_square(case: dict) -> tuple[float, float, float]:
    """A sensor's base: its corner (x0, y0) and side [mm], shifted inside the plate as the
    project's model shifts it (``fem.solver.attachments.base_square``)."""
    from fem.solver.attachments import PointMass, base_square  # noqa: PLC0415

    s = case["sensor"]
    mass = PointMass(1e-3 * s["mass_g"], 1e-3 * s["x_mm"], 1e-3 * s["y_mm"], base=1e-3 * s["base_mm"])
    x0, y0 = base_square(mass, 1e-3 * case["length_mm"], 1e-3 * case["width_mm"])
    return 1e3 * x0, 1e3 * y0, s["base_mm"]


def _on_base(mesh: g.Mesh, case: dict, level: g.Level, layers) -> tuple[g.Mesh, tuple[np.ndarray, float]]:
    """The mesh with its lines following the sensor's base (``FOOTPRINT_3D`` x the level's
    thickness factor + 1 elements a side) and the base's mass as added density of the top
    layer's elements under it: (element indices, kg/m^3)."""
    from fem.solver.mesh import with_footprints  # noqa: PLC0415

    x0, y0, side = _base_square(case)
    per_side = FOOTPRINT_3D * level.thickness_factor + 1
    xs = with_footprints(np.linspace(0.0, mesh.lx, mesh.nx + 1), [(x0, x0 + side)], per_side)
    ys = with_footprints(np.linspace(0.0, mesh.ly, mesh.ny + 1), [(y0, y0 + side)], per_side)
    mesh = g.Mesh(mesh.lx, mesh.ly, len(xs) - 1, len(ys) - 1, mesh.z_levels, mesh.element_layer, xs, ys)
    tol = 1e-6 * side
    in_x = np.nonzero((xs[:-1] >= x0 - tol) & (xs[1:] <= x0 + side + tol))[0]
    in_y = np.nonzero((ys[:-1] >= y0 - tol) & (ys[1:] <= y0 + side + tol))[0]
    top = len(layers) - 1
    rows = np.nonzero(mesh.element_layer == top)[0]
    heavy = np.array([(ez * mesh.ny + ey) * mesh.nx + ex for ez in rows for ey in in_y for ex in in_x])
    thickness_mm = layers[top][1]
    added = 1e-3 * case["sensor"]["mass_g"] / (1e-9 * side**2 * thickness_mm)
    return mesh, (heavy, added)


def solve_full(case: dict, layers, level: g.Level, workdir: Path, tag: str) -> dict:
    """Elastic frequencies, w-shares and mid-plane w grids of the full plate."""
    mesh = g.build_mesh(case, layers, level, quarter=False)
    extra, where, heavier = (), None, None
    if case["sensor"] and case["sensor"].get("base_mm"):
        mesh, heavier = _on_base(mesh, case, level, layers)
        where = (case["sensor"]["x_mm"], case["sensor"]["y_mm"])
    ids, coords = mesh.lattice()
    elements = mesh.elements(ids)
    if case["sensor"] and heavier is None:
        extra, where = _sensor_lines(mesh, case, len(elements))
    job = workdir / tag
    g.write_input(
        job.with_suffix(".inp"),
        mesh,
        layers,
        None,
        6 + ELASTIC,
        materials=case["materials"],
        extra=extra,
        heavier=heavier,
    )
    wall = g.run_ccx(job, 1)
    lam = g.read_eigenvalues(job.with_suffix(".dat"))
    disp = g.read_displacements(job.with_suffix(".frd"), len(coords))
    order = np.argsort(lam)
    lam, disp = lam[order], disp[order]
    if np.abs(lam[:6]).max() > 1e-6 * lam[6]:
        raise RuntimeError(f"{tag}: the 6 lowest modes are not rigid-body modes ({lam[:7]})")
    lam, disp = lam[6:], disp[6:]
    densities = np.repeat([case["materials"][m]["density"] * 1e-12 for m, _, _ in layers], 1)
    density = np.repeat(densities[mesh.element_layer], mesh.nx * mesh.ny)
    if heavier is not None:
        density[heavier[0]] += heavier[1] * 1e-12
    shares = g.kinetic_shares(mesh, elements, density, disp)
    solved = g.Solved(mesh, elements, lam, disp, None, shares, wall)
    z_top = sum(t for _, t, _ in layers)
    z_mid = z_top / 2
    grid = g.sample(solved, case, z_mid, *g.GRID)
    top = g.sample(solved, case, z_top, *g.GRID)
    fine = g.sample(solved, case, z_mid, *g.LABEL_GRID)
    flexural = [k for k in range(len(lam)) if shares[k] > g.FLEXURAL_SHARE][:FLEXURAL_MODES]
    if len(flexural) < FLEXURAL_MODES:
        raise RuntimeError(f"{tag}: only {len(flexural)} flexural modes among {len(lam)}")
    return dict(
        frequency_hz=np.sqrt(lam[flexural]) / (2 * np.pi),
        w=grid[flexural, 2],
        w_top=top[flexural, 2],
        labels=[g.nodal_label(fine[k, 2]) for k in flexural],
        w_share=shares[flexural],
        wall_s=wall,
        dofs=3 * len(coords),
        sensor_xy_mm=where,
        elements=[mesh.nx, mesh.ny, [g.layer_elements(t, level.thickness_factor) for _, t, _ in layers]],
    )


def truth_spec(case: dict, sensor_xy=None) -> str:
    """The project spec with every true value: true angles, G13/G23, the sensor as a fixed
    point mass, first-order shear with rotary inertia left to the options."""
    text = g.spec_toml(case["name"], case, materials=case["materials"])
    if case["sensor"]:
        x, y = sensor_xy
        text += (
            f'\n[[effects]]\nkind = "point_mass"\nmass_g = {case["sensor"]["mass_g"]!r}\n'
            f"x_mm = {x:.6g}\ny_mm = {y:.6g}\n"
        )
        if case["sensor"].get("base_mm"):
            text += f"base_mm = {case['sensor']['base_mm']!r}\n"
    return text


def plate_grid_w(spec_text: str, configuration: str) -> np.ndarray:
    """w of the plate model's modes on ``generate.GRID`` (points, modes): first-order shear
    with rotary inertia, the spec's values."""
    from fem.spec import parse_spec  # noqa: PLC0415
    from studies.hidden_effect import _grid_w  # noqa: PLC0415

    model = parse_spec(tomllib.loads(spec_text), "<blind>").with_options(
        modes=FLEXURAL_MODES + 8, transverse_shear=True, rotary_inertia=True
    )
    solution = model.solve(configuration)
    return _grid_w(solution, model.specimen.length, model.specimen.width)


def pair_with_plate(
    spec_text: str, configuration: str, w3d: np.ndarray, w: np.ndarray | None = None
) -> tuple[list[int], list[float]]:
    """Rank (1-based) of the plate mode each 3-D mode pairs with, and the MAC (``w``: the
    plate's grid shapes, when already at hand)."""
    from scipy.optimize import linear_sum_assignment  # noqa: PLC0415

    w = plate_grid_w(spec_text, configuration) if w is None else w
    a = np.array([np.ravel(x) for x in w3d]).T
    mac = (a.T @ w) ** 2 / np.outer(np.sum(a**2, axis=0), np.sum(w**2, axis=0))
    rows, cols = linear_sum_assignment(-mac)
    rank = cols[np.argsort(rows)]
    return [int(r) + 1 for r in rank], [round(float(mac[k, rank[k]]), 4) for k in range(len(rank))]


def solve_configurations(case: dict, level: g.Level, prefix: str) -> dict:
    """``solve_full`` of every configuration of a case, in a scratch folder removed after."""
    workdir = Path(tempfile.mkdtemp(prefix=f"{prefix}_{case['name']}_"))
    try:
        return {
            c["name"]: solve_full(case, g.stack(case, c), level, workdir, f"{case['name']}_{c['name']}")
            for c in case["configurations"]
        }
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def run_case(case: dict, level: g.Level, half: str) -> dict:
    started = time.perf_counter()
    solved = solve_configurations(case, level, "ccx")
    sensor_xy = next(iter(solved.values()))["sensor_xy_mm"]
    spec = truth_spec(case, sensor_xy)
    g.check_spec(spec)
    configurations = []
    for c in case["configurations"]:
        s = solved[c["name"]]
        rank, mac = pair_with_plate(spec, c["name"], s["w"])
        configurations.append(
            dict(
                name=c["name"],
                total_thickness_mm=g._sig(sum(t for _, t, _ in g.stack(case, c))),
                elements=s["elements"],
                dofs=s["dofs"],
                wall_s=round(s["wall_s"], 1),
                modes=[
                    dict(
                        frequency_hz=g._sig(float(f)),
                        label=lab,
                        w_share=g._sig(float(sh), 4),
                        plate_mode=r,
                        mac=m,
                    )
                    for f, lab, sh, r, m in zip(
                        s["frequency_hz"], s["labels"], s["w_share"], rank, mac, strict=True
                    )
                ],
            )
        )
    return dict(
        case=case["name"],
        family=case["family"],
        half=half,
        seed=case.get("seed"),
        split_seed={SEED_3: SPLIT_SEED_3, SEED_4: None, SEED_5: None, SEED_6: None}.get(
            case.get("seed"), SPLIT_SEED
        ),
        choices=dict(
            length_mm=case["length_mm"],
            width_mm=case["width_mm"],
            nominal_layers=[
                dict(material=m, thickness_mm=t, angle_deg=a) for m, t, a in case["nominal_layers"]
            ],
            true_layers=[dict(material=m, thickness_mm=t, angle_deg=a) for m, t, a in case["layers"]],
            misalignment_max_deg=case["misalignment_max_deg"],
            sensor=None if not case["sensor"] else dict(case["sensor"], x_mm=sensor_xy[0], y_mm=sensor_xy[1]),
            bond_line_mm=case["bond_line_mm"],
            aluminium_mm=case["aluminium_mm"],
            **{k: case[k] for k in ("stack", "core") if k in case},
        ),
        materials={
            m: {k: (g._sig(v) if isinstance(v, float) else v) for k, v in c.items()}
            for m, c in case["materials"].items()
        },
        made_with=dict(
            solver=g.ccx_version(),
            element="C3D20R",
            model="full plate, free-free",
            mesh=dict(
                level=level.name,
                elements_along_length=level.n_length,
                thickness_factor=level.thickness_factor,
            ),
            script="tests/data/solid3d/blind.py",
            wall_time_s=round(time.perf_counter() - started, 1),
        ),
        truth_spec_toml=spec,
        configurations=configurations,
    )


def _unit_max(w: np.ndarray) -> np.ndarray:
    """w scaled to max |w| = 1, its largest value positive (``generate.py``'s convention)."""
    peak = w.flat[np.argmax(np.abs(w))]
    return w / peak


def shapes(case: dict, record: dict, level: g.Level) -> tuple[dict | None, str]:
    """The top-face w of the stored flexural modes, re-solved as the case was made: the
    shapes' record and a summary line, or (None, why) when a re-solved frequency is not
    the stored one (relative difference above ``SHAPES_TOLERANCE``)."""
    started = time.perf_counter()
    solved = solve_configurations(case, level, "ccx_shapes")
    stored = {c["name"]: c for c in record["configurations"]}
    worst, failures, configurations, notes = 0.0, [], [], []
    spec = record["truth_spec_toml"]
    for c in case["configurations"]:
        s, kept = solved[c["name"]], stored[c["name"]]["modes"]
        f_stored = np.array([m["frequency_hz"] for m in kept])
        change = np.abs(s["frequency_hz"] / f_stored - 1)
        worst = max(worst, float(change.max()))
        if change.max() > SHAPES_TOLERANCE:
            k = int(np.argmax(change))
            failures.append(
                f"{c['name']} mode {k + 1}: {s['frequency_hz'][k]:.7g} Hz re-solved, "
                f"{f_stored[k]:.7g} Hz stored ({change[k]:.2e} relative)"
            )
            continue
        mid = np.array([np.ravel(w) for w in s["w"]])
        top = np.array([np.ravel(w) for w in s["w_top"]])
        between = 1 - np.diag(g.mac(mid.T, top.T))
        plate = plate_grid_w(spec, c["name"])
        rank_mid, _ = pair_with_plate(spec, c["name"], s["w"], plate)
        rank_top, _ = pair_with_plate(spec, c["name"], s["w_top"], plate)
        mac_top = [
            g.mac(top[k][:, None], plate[:, m["plate_mode"] - 1 : m["plate_mode"]])[0, 0]
            for k, m in enumerate(kept)
        ]
        if rank_mid != [m["plate_mode"] for m in kept]:  # the plate model may have changed since
            notes.append(
                f"{c['name']}: the re-solved mid-plane shapes pair with plate modes {rank_mid} today, "
                f"the record with {[m['plate_mode'] for m in kept]}"
            )
        if rank_top != rank_mid:
            notes.append(
                f"{c['name']}: the top face pairs with plate modes {rank_top} (mid-plane {rank_mid})"
            )
        thickness = sum(t for _, t, _ in g.stack(case, c))
        configurations.append(
            dict(
                name=c["name"],
                face_z_mm=g._sig(thickness),
                x_mm=[g._sig(x) for x in case["length_mm"] * np.arange(g.GRID[0]) / (g.GRID[0] - 1)],
                y_mm=[g._sig(y) for y in case["width_mm"] * np.arange(g.GRID[1]) / (g.GRID[1] - 1)],
                modes=[
                    dict(
                        frequency_hz=g._sig(float(f)),
                        label=m["label"],
                        plate_mode=m["plate_mode"],
                        mac_plate_mode=round(float(mt), 4),
                        one_minus_mac_mid_plane=g._sig(float(b), 3),
                        w=g._grid_list(_unit_max(w)),
                    )
                    for f, m, mt, b, w in zip(
                        s["frequency_hz"], kept, mac_top, between, s["w_top"], strict=True
                    )
                ],
            )
        )
        notes.append(f"{c['name']}: 1 - MAC(top, mid) max {between.max():.2e}")
    if failures:
        return None, f"{case['name']}: NOT written, re-solve differs from the record: " + "; ".join(failures)
    out = dict(
        case=case["name"],
        family=case["family"],
        face="top (z = the configuration's total thickness)",
        grid=dict(
            points=list(g.GRID),
            x="x_i = L i / 12, from the corner",
            y="y_j = W j / 10",
            layout="w[j][i], row = y",
        ),
        normalisation="max |w| = 1 per mode, its largest value positive; 5 significant digits",
        made_with=dict(
            solver=g.ccx_version(),
            element="C3D20R",
            model="full plate, free-free",
            mesh=dict(
                level=level.name,
                elements_along_length=level.n_length,
                thickness_factor=level.thickness_factor,
            ),
            script="tests/data/solid3d/blind.py",
            command=f"python tests/data/solid3d/blind.py --shapes-only --only {case['name']}",
            wall_time_s=round(time.perf_counter() - started, 1),
            frequency_check=dict(max_relative_difference=g._sig(worst, 3), tolerance=SHAPES_TOLERANCE),
        ),
        configurations=configurations,
    )
    return out, f"{case['name']}: frequencies within {worst:.1e} of the record; " + "; ".join(notes)


def mesh_check(case: dict) -> dict:
    """Relative change of the stored (coarse) frequencies against the medium mesh, on the
    al_bottom configuration (the thin soft bond line and aluminium plate are the layers the
    coarse mesh resolves worst)."""
    workdir = Path(tempfile.mkdtemp(prefix=f"ccx_check_{case['name']}_"))
    out = []
    try:
        for c in case["configurations"][1:2]:  # al_bottom: the thin soft bond line and plate
            layers = g.stack(case, c)
            coarse = solve_full(case, layers, LEVEL, workdir, f"c_{c['name']}")
            medium = solve_full(case, layers, CHECK_LEVEL, workdir, f"m_{c['name']}")
            change = coarse["frequency_hz"] / medium["frequency_hz"] - 1
            out.append(
                dict(
                    configuration=c["name"],
                    max_abs_change=g._sig(float(np.abs(change).max()), 3),
                    per_mode=[g._sig(float(x), 3) for x in change],
                    wall_s=[round(coarse["wall_s"], 1), round(medium["wall_s"], 1)],
                    dofs=[coarse["dofs"], medium["dofs"]],
                )
            )
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    return dict(case=case["name"], levels=[LEVEL.name, CHECK_LEVEL.name], configurations=out)


def stored_convergence() -> list[dict]:
    """The coarse mesh's error on the stored references of ``generate.py`` (the same
    element size and thickness rule, there as quarter models): the largest change coarse
    -> fine over the first 10 flexural modes of each configuration."""
    out = []
    for name in ("thick_laminate", "laminate_on_adhesive", "foam_sandwich", "spruce_plate"):
        data = json.loads((HERE / f"{name}.json").read_text())
        for c in data["configurations"]:
            flexural = [m for m in c["modes"] if m["classification"] == "flexural"][:FLEXURAL_MODES]
            change = [
                m["frequencies_by_level"][LEVEL.name] / m["frequencies_by_level"]["fine"] - 1
                for m in flexural
            ]
            out.append(
                dict(
                    case=name,
                    configuration=c["name"],
                    levels=[LEVEL.name, "fine"],
                    max_abs_change=g._sig(float(np.max(np.abs(change))), 3),
                )
            )
    return out


def index_record(half: dict[str, str]) -> dict:
    """``index.json``: the seeds and every case's half (``halves``)."""
    return dict(
        seed=SEED,
        split_seed=SPLIT_SEED,
        seed_2=SEED_2,
        seed_3=SEED_3,
        split_seed_3=SPLIT_SEED_3,
        seed_4=SEED_4,
        seed_5=SEED_5,
        seed_6=SEED_6,
        cases=half,
        script="tests/data/solid3d/blind.py",
    )


def _write(path: Path, data) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(g.dumps(data) + "\n")
    tmp.replace(path)


def _shapes_only(cases: list[dict], names: list[str] | None, parser) -> int:
    """Every named case re-solved from its draw (the materials of its record, as ``--only``
    re-solves) and its shapes written; 1 when a case's re-solve was refused."""
    known = {c["name"]: c for c in cases}
    if not names or any(n not in known for n in names):
        parser.error(
            f"--shapes-only needs --only NAME for stored cases; unknown: "
            f"{[n for n in names or [] if n not in known] or 'none given'}"
        )
    SHAPES_OUT.mkdir(exist_ok=True)
    status = 0
    for name in names:
        case = known[name]
        record = json.loads((OUT / f"{name}.json").read_text())
        case["materials"] = record["materials"]
        result, line = shapes(case, record, LEVEL)
        if result is None:
            status = 1
        else:
            _write(SHAPES_OUT / f"{name}.json", result)
            line += f" ({result['made_with']['wall_time_s']:.0f} s)"
        print(line, flush=True)
    return status


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", action="extend", nargs="+", help="case name(s) to (re)run")
    parser.add_argument(
        "--check",
        action="store_true",
        help="coarse against medium mesh, the first hybrid and the first sandwich",
    )
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument(
        "--check-stored",
        action="store_true",
        help="the coarse mesh's error on the stored references (no ccx run)",
    )
    parser.add_argument(
        "--regression",
        action="store_true",
        help="the regression cases (or only the --only ones), into regression/",
    )
    parser.add_argument(
        "--shapes-only",
        action="store_true",
        help="re-solve the --only cases and write their top-face shapes into blind_shapes/ "
        "(the case records are not touched)",
    )
    args = parser.parse_args(argv)
    if shutil.which("ccx") is None:
        parser.error("ccx (CalculiX) is not on the PATH; on Debian: apt-get install calculix-ccx")
    cases = all_cases()
    half = halves(cases)
    if args.shapes_only:
        return _shapes_only(cases, args.only, parser)
    if args.regression:
        known = [c["name"] for c in REGRESSION]
        unknown = [n for n in args.only or [] if n not in known]
        if unknown:
            parser.error(f"--regression --only: unknown regression case(s) {unknown}; known: {known}")
        folder = HERE / "regression"
        folder.mkdir(exist_ok=True)
        for case in REGRESSION:
            if args.only and case["name"] not in args.only:
                continue
            result = run_case(case, LEVEL, "regression")
            _write(folder / f"{case['name']}.json", result)
            print(f"{case['name']}: {result['made_with']['wall_time_s']:.0f} s", flush=True)
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    if args.check:
        checks = []
        for family in ("hybrid", "sandwich"):
            case = next(c for c in cases if c["family"] == family)
            checks.append(mesh_check(case))
            print(json.dumps(checks[-1]), flush=True)
        _write(args.out / "mesh_check.json", dict(ccx=checks, stored_references=stored_convergence()))
        return 0
    if args.check_stored:
        _write(args.out / "mesh_check.json", dict(stored_references=stored_convergence()))
        return 0
    _write(args.out / "index.json", index_record(half))
    for case in cases:
        if args.only and case["name"] not in args.only:
            continue
        path = args.out / f"{case['name']}.json"
        if path.exists() and not args.only:
            continue
        # re-solved: the plate its record holds (blind16 and 19 drew the plies the other way)
        if path.exists():
            case["materials"] = json.loads(path.read_text())["materials"]
        result = run_case(case, LEVEL, half[case["name"]])
        _write(path, result)
        print(
            f"{case['name']}: {result['made_with']['wall_time_s']:.0f} s "
            + " | ".join(
                f"{c['name']} {c['modes'][0]['frequency_hz']:.1f} Hz" for c in result["configurations"]
            ),
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
