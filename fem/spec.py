"""Loading and validating a specimen spec (TOML; units in the key names).

Everything a user can get wrong is checked here, at the entry point, and reported
in one line that names the field, the value, what is allowed and how to fix it.
Inside the tool all quantities are SI.
"""
from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .errors import SpecError
from .laminate import Layer
from .material import Material
from .model import ModelOptions
from .specimen import Configuration, Specimen

GPA, MM = 1e9, 1e-3
MATERIAL_KEYS = {
    "E1_GPa": True, "E2_GPa": True, "G12_GPa": True, "nu12": True, "density_kg_m3": True,
    "identify": False, "G13_GPa": False, "G23_GPa": False, "note": False,
}
#: Plausible ranges that catch unit slips (a modulus in MPa, a density in g/cm^3).
MODULUS_RANGE_GPA = (1e-4, 2000.0)   # soft elastomer .. above diamond (~1050 GPa)
DENSITY_RANGE = (10.0, 25000.0)      # foams .. above osmium (22 590 kg/m^3)
MAX_MODES = 60


@dataclass(frozen=True)
class Spec:
    """A loaded spec: the specimen with its configurations, the model options, the
    ``[[effects]]`` tables, the ``[design]`` table (validated by its user) and every
    material defined, including those only a design may use."""

    specimen: Specimen
    model: ModelOptions
    effects: tuple[dict, ...] = ()
    design: dict = field(default_factory=dict)
    source: str = "<spec>"
    materials: dict[str, Material] = field(default_factory=dict)  # every [materials] table, used or not


def _check_keys(table: dict, allowed, where: str) -> None:
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, list(allowed), n=1)
            hint = f"; did you mean '{close[0]}'?" if close else f"; allowed: {', '.join(allowed)}"
            raise SpecError(f"{where}: unknown key '{key}'{hint}")


def number_field(table: dict, key: str, where: str, *, required: bool = True, default=None) -> float | None:
    """A finite number from a TOML table, or a one-line error naming ``where.key``."""
    if key not in table:
        if required:
            raise SpecError(f"{where}: missing field '{key}'")
        return default
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SpecError(f"{where}.{key} = {value!r}: need a finite number")
    return float(value)


def _positive(table: dict, key: str, where: str, **kw) -> float | None:
    value = number_field(table, key, where, **kw)
    if value is not None and value <= 0:
        raise SpecError(f"{where}.{key} = {value:g}: must be positive")
    return value


def _material(name: str, table: dict) -> Material:
    where = f"[materials.{name}]"
    if not isinstance(table, dict):
        raise SpecError(f"{where}: must be a table of properties")
    _check_keys(table, MATERIAL_KEYS, where)
    values = {}
    for key in ("E1_GPa", "E2_GPa", "G12_GPa", "G13_GPa", "G23_GPa"):
        v = _positive(table, key, where, required=MATERIAL_KEYS[key])
        if v is not None and not MODULUS_RANGE_GPA[0] <= v <= MODULUS_RANGE_GPA[1]:
            raise SpecError(
                f"{where}.{key} = {v:g} GPa is outside {MODULUS_RANGE_GPA[0]:g}..{MODULUS_RANGE_GPA[1]:g} GPa; "
                "give the modulus in GPa (e.g. 200 for steel, not 200000)"
            )
        values[key[:-4]] = None if v is None else v * GPA
    density = _positive(table, "density_kg_m3", where)
    if not DENSITY_RANGE[0] <= density <= DENSITY_RANGE[1]:
        raise SpecError(
            f"{where}.density_kg_m3 = {density:g} is outside {DENSITY_RANGE[0]:g}..{DENSITY_RANGE[1]:g} kg/m^3; "
            "give it in kg/m^3 (e.g. 7900 for steel, not 7.9)"
        )
    nu12 = number_field(table, "nu12", where)
    identify = table.get("identify", False)
    if not isinstance(identify, bool):
        raise SpecError(f"{where}.identify = {identify!r}: need true or false")
    try:
        return Material(name, values["E1"], values["E2"], values["G12"], nu12, density,
                        values["G13"], values["G23"], identify)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}".replace(f"material '{name}': ", "")) from None


def _layers(items, where: str, materials: dict, label, plate_size: float) -> tuple[Layer, ...]:
    if not isinstance(items, list):
        raise SpecError(f"{where}: need a list of {{ material = ..., thickness_mm = ... }} tables")
    out = []
    for i, item in enumerate(items):
        here = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise SpecError(f"{here}: need a table {{ material = ..., thickness_mm = ... }}")
        _check_keys(item, ("material", "thickness_mm", "angle_deg"), here)
        name = item.get("material")
        if name is None:
            raise SpecError(f"{here}: missing field 'material'")
        if name not in materials:
            close = difflib.get_close_matches(str(name), list(materials), n=1)
            hint = f"did you mean '{close[0]}'?" if close else f"known: {', '.join(materials) or 'none'}"
            raise SpecError(f"{here}.material = {name!r} is not defined in [materials]; {hint}")
        t = _positive(item, "thickness_mm", here)
        if t >= 0.2 * plate_size:
            raise SpecError(
                f"{here}.thickness_mm = {t:g} for a plate {plate_size:g} mm across is not a plate layer; "
                "thicknesses are in mm (e.g. 0.7, not 700 or 0.0007 m)"
            )
        if t < 1e-4:
            raise SpecError(f"{here}.thickness_mm = {t:g} mm is below 0.1 um; thicknesses are in mm, not m")
        angle = number_field(item, "angle_deg", here, required=False, default=0.0)
        out.append(Layer(materials[name], t * MM, math.radians(angle), label(i)))
    return tuple(out)


def _with_measured_mass(mass_g: float, layers, materials: dict, area: float, configurations):
    """Densities of the specimen's layers scaled so the plate weighs ``mass_g``.

    When the layer densities are unknown the plate's weight still fixes its mass per
    area, and that is all the Kirchhoff model's frequencies use (paper: the average
    density suffices).  So the densities given are treated as relative guesses.
    """
    names = {layer.material.name for layer in layers}
    for table in configurations:
        for side in ("bottom", "top"):
            for item in table.get(side, []) if isinstance(table, dict) else []:
                if isinstance(item, dict) and item.get("material") in names:
                    raise SpecError(f"[specimen].mass_g: material {item['material']!r} is also an added plate; "
                                    "give its density explicitly or use another material name for the addition")
    nominal = sum(layer.material.density * layer.thickness for layer in layers) * area
    factor = mass_g * 1e-3 / nominal
    average = mass_g * 1e-3 / (area * sum(layer.thickness for layer in layers))
    if not DENSITY_RANGE[0] <= average <= DENSITY_RANGE[1]:
        raise SpecError(f"[specimen].mass_g = {mass_g:g}: an average density of {average:.4g} kg/m^3 is implausible; "
                        "the mass is in grams")
    scaled = {n: (m.with_values(density=m.density * factor) if n in names else m) for n, m in materials.items()}
    return tuple(replace(layer, material=scaled[layer.material.name]) for layer in layers), scaled


def parse_spec(data: dict[str, Any], source: str = "<spec>") -> Spec:
    """Build a validated ``Spec`` from a parsed TOML document."""
    _check_keys(data, ("specimen", "materials", "configurations", "model", "effects", "design"), "spec")
    if "specimen" not in data:
        raise SpecError("spec: missing table [specimen]")
    sp = data["specimen"]
    _check_keys(sp, ("name", "length_mm", "width_mm", "layers", "mass_g"), "[specimen]")
    length = _positive(sp, "length_mm", "[specimen]")
    width = _positive(sp, "width_mm", "[specimen]")
    for key, v in (("length_mm", length), ("width_mm", width)):
        if not 1.0 <= v <= 20000.0:
            raise SpecError(f"[specimen].{key} = {v:g}: expected 1..20000 mm; lengths are in mm")
    raw_materials = data.get("materials", {})
    if not isinstance(raw_materials, dict) or not raw_materials:
        raise SpecError("spec: missing table [materials.NAME] (one per material)")
    materials = {name: _material(name, table) for name, table in raw_materials.items()}
    if "layers" not in sp:
        raise SpecError("[specimen]: missing field 'layers' (bottom to top)")
    if not sp["layers"]:
        raise SpecError("[specimen].layers is empty: list at least one layer, bottom to top")
    size = min(length, width)
    layers = _layers(sp["layers"], "[specimen].layers", materials, lambda i: f"layer{i + 1}", size)
    total = sum(layer.thickness for layer in layers) / MM
    if total >= 0.2 * size:
        raise SpecError(
            f"[specimen].layers: total thickness {total:g} mm for a plate {size:g} mm across is not a plate; "
            "thicknesses are in mm"
        )

    if "mass_g" in sp:
        layers, materials = _with_measured_mass(_positive(sp, "mass_g", "[specimen]"), layers, materials,
                                                length * MM * width * MM, data.get("configurations", []))
    configurations = []
    seen_names, seen_stacks = set(), {}
    for i, table in enumerate(data.get("configurations", [{"name": "original"}])):
        here = f"[[configurations]][{i}]"
        _check_keys(table, ("name", "bottom", "top"), here)
        name = table.get("name")
        if not isinstance(name, str) or not name:
            raise SpecError(f"{here}: missing field 'name'")
        if name in seen_names:
            raise SpecError(f"{here}.name = {name!r} is used twice; configuration names must be unique")
        seen_names.add(name)
        bottom = _layers(table.get("bottom", []), f"{here}.bottom", materials,
                         lambda j, n=name: f"{n}.bottom{j + 1}", size)
        top = _layers(table.get("top", []), f"{here}.top", materials, lambda j, n=name: f"{n}.top{j + 1}", size)
        key = (tuple((l.material.name, l.thickness, l.angle) for l in bottom),
               tuple((l.material.name, l.thickness, l.angle) for l in top))
        if key in seen_stacks:
            what = "adds nothing, like" if not bottom and not top else "adds the same layers as"
            raise SpecError(f"{here} ({name!r}) {what} configuration {seen_stacks[key]!r}; remove one of them")
        seen_stacks[key] = name
        configurations.append(Configuration(name, bottom, top))
    if not configurations:
        raise SpecError("spec: [[configurations]] is empty; omit it for the original plate alone")

    model = data.get("model", {})
    _check_keys(model, ("modes", "divisions"), "[model]")
    modes = model.get("modes", 5)
    if isinstance(modes, bool) or not isinstance(modes, int) or not 1 <= modes <= MAX_MODES:
        raise SpecError(f"[model].modes = {modes!r}: need a whole number from 1 to {MAX_MODES}")
    divisions = model.get("divisions")
    if divisions is not None and (isinstance(divisions, bool) or not isinstance(divisions, int) or not 2 <= divisions <= 64):
        raise SpecError(f"[model].divisions = {divisions!r}: need a whole number of elements from 2 to 64")
    options = ModelOptions(modes=modes, divisions=divisions)

    effects = data.get("effects", [])
    if not isinstance(effects, list) or not all(isinstance(e, dict) for e in effects):
        raise SpecError("[[effects]]: need a list of tables, each with a 'kind'")
    design = data.get("design", {})
    if not isinstance(design, dict):
        raise SpecError("[design]: must be a table")
    specimen = Specimen(sp.get("name", Path(source).stem), length * MM, width * MM, layers, tuple(configurations))
    from .effects import apply_fixed  # effects build on the model; validate them here, at the entry point

    apply_fixed(specimen, options, effects)
    return Spec(specimen, options, tuple(effects), design, source, materials)


def load_spec(path: str | Path) -> Spec:
    """Read and validate a spec file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SpecError(f"spec file {str(path)!r} cannot be read: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"spec file {str(path)!r} is not valid TOML: {exc}") from None
    return parse_spec(data, str(path))
