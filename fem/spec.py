"""Loading and validating a specimen spec (TOML; units in the key names).

Everything a user can get wrong is checked here, at the entry point, and reported
in one line that names the field, the value, what is allowed and how to fix it.
Inside the tool all quantities are SI.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

from .design_space import parse_design
from .effects import apply_fixed
from .errors import SpecError
from .inputs import InputStd
from .laminates.laminate import Layer
from .laminates.layerwise import GROUPINGS
from .laminates.material import DENSITY_RANGE, LOSS_FACTORS, MAX_LOSS_FACTOR, MODULUS_RANGE, Material
from .model import DIVISIONS_RANGE, MAX_MODES, THEORIES, ModelOptions, SpecimenModel
from .specimen import Configuration, Specimen
from .stock import STOCK, stock_name
from .validation import check_keys, number, suggestion, whole

GPA, MM = 1e9, 1e-3
#: The thinnest layer a spec may give [mm]: 1 um, below any coating that changes a
#: plate's frequencies measurably (a thickness typed in metres lands far below it).
MIN_THICKNESS_MM = 1e-3
MATERIAL_KEYS = {
    "E1_GPa": True,
    "E2_GPa": True,
    "G12_GPa": True,
    "nu12": True,
    "density_kg_m3": True,
    "identify": False,
    "eta_E1": False,
    "eta_E2": False,
    "eta_G12": False,
    "eta": False,
    "identify_damping": False,
    "G13_GPa": False,
    "G23_GPa": False,
    "E3_GPa": False,
    "note": False,
    "bounds": False,
    **{
        f"{key}_std": False
        for key in ("E1_GPa", "E2_GPa", "G12_GPa", "G13_GPa", "G23_GPa", "nu12", "density_kg_m3")
    },
}
#: Plausible ranges that catch unit slips (a modulus in MPa, a density in g/cm^3).
MODULUS_RANGE_GPA = tuple(x / GPA for x in MODULUS_RANGE)
#: Keys of a material's ``bounds`` table and their factor to SI.
BOUND_KEYS = {
    "E1_GPa": ("E1", GPA),
    "E2_GPa": ("E2", GPA),
    "G12_GPa": ("G12", GPA),
    "G13_GPa": ("G13", GPA),
    "G23_GPa": ("G23", GPA),
    "nu12": ("nu12", 1.0),
    "density_kg_m3": ("density", 1.0),
}


def _positive(table: dict, key: str, where: str, **kw) -> float | None:
    return number(table, key, where, low=0.0, **kw)


def _material(name: str, table: dict) -> Material:
    where = f"[materials.{name}]"
    if not isinstance(table, dict):
        raise SpecError(f"{where}: must be a table of properties")
    check_keys(table, MATERIAL_KEYS, where)
    values = {}
    for key in ("E1_GPa", "E2_GPa", "G12_GPa", "G13_GPa", "G23_GPa", "E3_GPa"):
        v = _positive(table, key, where, required=MATERIAL_KEYS[key])
        if v is not None and not MODULUS_RANGE_GPA[0] <= v <= MODULUS_RANGE_GPA[1]:
            raise SpecError(
                f"{where}.{key} = {v:g} GPa is outside {MODULUS_RANGE_GPA[0]:g}..{MODULUS_RANGE_GPA[1]:g} "
                "GPa; "
                "give the modulus in GPa (e.g. 200 for steel, not 200000)"
            )
        values[key[:-4]] = None if v is None else v * GPA
    density = _positive(table, "density_kg_m3", where)
    if not DENSITY_RANGE[0] <= density <= DENSITY_RANGE[1]:
        raise SpecError(
            f"{where}.density_kg_m3 = {density:g} is outside {DENSITY_RANGE[0]:g}..{DENSITY_RANGE[1]:g} "
            "kg/m^3; "
            "give it in kg/m^3 (e.g. 7900 for steel, not 7.9)"
        )
    nu12 = number(table, "nu12", where)
    identify = table.get("identify", False)
    if not isinstance(identify, bool) and not (
        isinstance(identify, list) and identify and all(isinstance(k, str) for k in identify)
    ):
        raise SpecError(
            f'{where}.identify = {identify!r}: need true, false or a list of properties, e.g. ["G13", "G23"]'
        )
    bounds = _bounds(table.get("bounds", {}), where)
    try:
        material = Material(
            name,
            values["E1"],
            values["E2"],
            values["G12"],
            nu12,
            density,
            values["G13"],
            values["G23"],
            identify,
            bounds,
            values["E3"],
        )
        return replace(material, **_damping(table, where, material.isotropic))
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}".replace(f"material '{name}': ", "")) from None


def _damping(table: dict, where: str, isotropic: bool) -> dict:
    """A material's loss factors and what of its damping is identified: ``eta`` sets
    ``eta_E1``, ``eta_E2`` and ``eta_G12`` at once; ``identify_damping = true`` means one
    shared ``eta`` for an isotropic material (or one given by ``eta``), else the three."""
    hint = f"a loss factor 0..{MAX_LOSS_FACTOR:g} (e.g. 0.02)"
    etas = {
        key: number(
            table, key, where, required=False, low=0.0, high=MAX_LOSS_FACTOR, low_inclusive=True, hint=hint
        )
        for key in ("eta",) + LOSS_FACTORS
    }
    if etas["eta"] is not None:
        both = [key for key in LOSS_FACTORS if etas[key] is not None]
        if both:
            raise SpecError(
                f"{where}: eta and {both[0]} are both given; eta sets eta_E1, eta_E2 and eta_G12 at once: "
                "give either eta or the separate loss factors"
            )
        etas.update({key: etas["eta"] for key in LOSS_FACTORS})
    wanted = table.get("identify_damping", False)
    if wanted is True:
        kinds = ("eta",) if isotropic or "eta" in table else LOSS_FACTORS
    elif wanted is False:
        kinds = ()
    elif isinstance(wanted, list) and wanted and all(isinstance(k, str) for k in wanted):
        kinds = tuple(wanted)
    else:
        raise SpecError(
            f"{where}.identify_damping = {wanted!r}: need true, false or a list of loss factors, "
            'e.g. ["eta_E1", "eta_G12"]'
        )
    return {**{key: etas[key] for key in LOSS_FACTORS}, "identify_damping": kinds}


def _bounds(table, where: str) -> tuple[tuple[str, float, float], ...]:
    """A material's ``bounds = { nu12 = [0, 0.6], E1_GPa = [50, 300] }`` in SI."""
    here = f"{where}.bounds"
    if not isinstance(table, dict):
        raise SpecError(f"{here} = {table!r}: need a table like {{ nu12 = [0.0, 0.6], E1_GPa = [50, 300] }}")
    check_keys(table, BOUND_KEYS, here)
    out = []
    for key, pair in table.items():
        ok = (
            isinstance(pair, list)
            and len(pair) == 2
            and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pair
            )
        )
        if not ok or not pair[0] < pair[1]:
            raise SpecError(
                f"{here}.{key} = {pair!r}: need [lower, upper] with lower < upper, e.g. [0.0, 0.6]"
            )
        kind, factor = BOUND_KEYS[key]
        out.append((kind, pair[0] * factor, pair[1] * factor))
    return tuple(out)


#: A layer's angle std above this is not a known input (the orientation effect fits it).
MAX_ANGLE_STD_DEG = 15.0


def _input_std(data: dict, specimen: Specimen) -> tuple[InputStd, ...]:
    """The standard uncertainties of known inputs the spec states (``*_std`` keys), in SI.
    A property being identified gets its std from the fit, not from the spec."""
    out = []
    for name, table in data.get("materials", {}).items():
        for key, (kind, factor) in BOUND_KEYS.items():
            std = _positive(table, f"{key}_std", f"[materials.{name}]", required=False)
            if std is None:
                continue
            material = specimen.materials.get(name)
            if material is not None and kind in material.identify:
                raise SpecError(
                    f"[materials.{name}].{key}_std: {kind} of {name} is identified, its std comes from "
                    "the fit; give *_std for known inputs only"
                )
            out.append(InputStd(kind, name, std * factor))
    sp = data["specimen"]
    stacks = [("[specimen].layers", sp["layers"], lambda i: f"layer{i + 1}")]
    for i, c in enumerate(data.get("configurations", [])):
        for side in ("bottom", "top"):
            stacks.append(
                (
                    f"[[configurations]][{i}].{side}",
                    c.get(side, []),
                    lambda j, n=c["name"], s=side: f"{n}.{s}{j + 1}",
                )
            )
    for where, items, label in stacks:
        for i, item in enumerate(items):
            std = _positive(item, "thickness_mm_std", f"{where}[{i}]", required=False)
            if std is not None:
                out.append(InputStd("thickness", label(i), std * MM))
            std = _positive(item, "angle_deg_std", f"{where}[{i}]", required=False)
            if std is not None:
                if std > MAX_ANGLE_STD_DEG:
                    raise SpecError(
                        f"{where}[{i}].angle_deg_std = {std:g}: a layer's axes known to worse than "
                        f"{MAX_ANGLE_STD_DEG:g} deg are not a known input; leave it out and let the "
                        "orientation effect identify the angle"
                    )
                out.append(InputStd("angle", label(i), math.radians(std)))
    for key, kind in (("length_mm_std", "length"), ("width_mm_std", "width"), ("mass_g_std", "mass")):
        std = _positive(sp, key, "[specimen]", required=False)
        if std is not None:
            if kind == "mass" and "mass_g" not in sp:
                raise SpecError(
                    "[specimen].mass_g_std is given without mass_g: weigh the plate and give both"
                )
            out.append(InputStd(kind, "specimen", std * (MM if kind != "mass" else 1e-3)))
    return tuple(out)


def _layer_material(name, where: str, materials: dict) -> Material:
    """A layer's material: the spec's own, else built-in stock by name (``brass`` or
    ``brass_stock``); a stock material used is added to ``materials``."""
    if not isinstance(name, str):
        raise SpecError(
            f'{where}.material = {name!r}: need a material\'s name (text), e.g. material = "steel"'
        )
    if name in materials:
        return materials[name]
    stock = stock_name(name) if isinstance(name, str) else None
    if stock is None:
        hint = suggestion(name, list(materials) + list(STOCK))
        raise SpecError(
            f"{where}.material = {name!r} is not defined in [materials] nor built-in stock; {hint}"
        )
    materials[name] = STOCK[stock].material(name)
    return materials[name]


def _layers(items, where: str, materials: dict, label, plate_size: float) -> tuple[Layer, ...]:
    if not isinstance(items, list):
        raise SpecError(f"{where}: need a list of {{ material = ..., thickness_mm = ... }} tables")
    out = []
    for i, item in enumerate(items):
        here = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise SpecError(f"{here}: need a table {{ material = ..., thickness_mm = ... }}")
        check_keys(item, ("material", "thickness_mm", "angle_deg", "thickness_mm_std", "angle_deg_std"), here)
        name = item.get("material")
        if name is None:
            raise SpecError(f"{here}: missing field 'material'")
        material = _layer_material(name, here, materials)
        t = _positive(item, "thickness_mm", here)
        if t >= 0.2 * plate_size:
            raise SpecError(
                f"{here}.thickness_mm = {t:g} for a plate {plate_size:g} mm across is not a plate layer; "
                "thicknesses are in mm (e.g. 0.7, not 700 or 0.0007 m)"
            )
        if t < MIN_THICKNESS_MM:
            raise SpecError(
                f"{here}.thickness_mm = {t:g} mm is below {1e3 * MIN_THICKNESS_MM:g} um, thinner than any "
                "layer a vibration test can see: thicknesses are in mm (0.7, not 0.0007 m)"
            )
        angle = number(
            item,
            "angle_deg",
            here,
            required=False,
            default=0.0,
            low=-360.0,
            high=360.0,
            low_inclusive=True,
            hint="degrees from the plate's x axis",
        )
        out.append(Layer(material, t * MM, math.radians(angle), label(i)))
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
                    raise SpecError(
                        f"[specimen].mass_g: material {item['material']!r} is also an added plate; "
                        "give its density explicitly or use another material name for the addition"
                    )
    nominal = sum(layer.material.density * layer.thickness for layer in layers) * area
    factor = mass_g * 1e-3 / nominal
    average = mass_g * 1e-3 / (area * sum(layer.thickness for layer in layers))
    if not DENSITY_RANGE[0] <= average <= DENSITY_RANGE[1]:
        raise SpecError(
            f"[specimen].mass_g = {mass_g:g}: an average density of {average:.4g} kg/m^3 is implausible; "
            "the mass is in grams"
        )
    scaled = {
        n: (m.with_values(density=m.density * factor) if n in names else m) for n, m in materials.items()
    }
    return tuple(replace(layer, material=scaled[layer.material.name]) for layer in layers), scaled


def parse_spec(data: dict[str, Any], source: str = "<spec>") -> SpecimenModel:
    """The validated model of a parsed TOML document: the specimen with its fixed
    ``[[effects]]`` switched on, the model options and the ``[design]`` table."""
    if not isinstance(data, dict):
        raise SpecError(
            f"spec: need the parsed TOML document (a dict), not {type(data).__name__}; read a file with "
            "load_spec(path)"
        )
    check_keys(data, ("specimen", "materials", "configurations", "model", "effects", "design"), "spec")
    if "specimen" not in data:
        raise SpecError("spec: missing table [specimen]")
    sp = data["specimen"]
    if not isinstance(sp, dict):
        raise SpecError("[specimen]: must be a table")
    if not isinstance(data.get("configurations", []), list):
        raise SpecError(
            f"configurations = {data['configurations']!r}: need a list of [[configurations]] tables, "
            "each with a name"
        )
    check_keys(
        sp,
        ("name", "length_mm", "width_mm", "layers", "mass_g", "length_mm_std", "width_mm_std", "mass_g_std"),
        "[specimen]",
    )
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
        layers, materials = _with_measured_mass(
            _positive(sp, "mass_g", "[specimen]"),
            layers,
            materials,
            length * MM * width * MM,
            data.get("configurations", []),
        )
    configurations = []
    seen_names, seen_stacks = set(), {}
    for i, table in enumerate(data.get("configurations", [{"name": "original"}])):
        here = f"[[configurations]][{i}]"
        if not isinstance(table, dict):
            raise SpecError(f"{here}: need a table with a 'name' (and 'bottom' or 'top' layers)")
        check_keys(table, ("name", "bottom", "top"), here)
        name = table.get("name")
        if not isinstance(name, str) or not name:
            raise SpecError(f"{here}: missing field 'name'")
        if name in seen_names:
            raise SpecError(f"{here}.name = {name!r} is used twice; configuration names must be unique")
        seen_names.add(name)
        bottom = _layers(
            table.get("bottom", []), f"{here}.bottom", materials, lambda j, n=name: f"{n}.bottom{j + 1}", size
        )
        top = _layers(
            table.get("top", []), f"{here}.top", materials, lambda j, n=name: f"{n}.top{j + 1}", size
        )
        key = (
            tuple((l.material.name, l.thickness, l.angle) for l in bottom),
            tuple((l.material.name, l.thickness, l.angle) for l in top),
        )
        if key in seen_stacks:
            what = "adds nothing, like" if not bottom and not top else "adds the same layers as"
            raise SpecError(
                f"{here} ({name!r}) {what} configuration {seen_stacks[key]!r}; remove one of them"
            )
        seen_stacks[key] = name
        configurations.append(Configuration(name, bottom, top))
    if not configurations:
        raise SpecError("spec: [[configurations]] is empty; omit it for the original plate alone")

    model = data.get("model", {})
    if not isinstance(model, dict):
        raise SpecError(f"[model] = {model!r}: must be a table, e.g. [model] then modes = 5 on the next line")
    check_keys(model, ("modes", "divisions", "theory", "layer_groups", "core_stretch"), "[model]")
    modes = whole(model.get("modes", 5), "[model].modes", 1, MAX_MODES, "")
    divisions = model.get("divisions")
    if divisions is not None:
        whole(divisions, "[model].divisions", *DIVISIONS_RANGE, "of elements ")
    for key, allowed in (("theory", THEORIES), ("layer_groups", GROUPINGS)):
        if key in model and model[key] not in allowed:
            raise SpecError(
                f"[model].{key} = {model[key]!r} is unknown; {suggestion(model[key], allowed)} "
                '(e.g. theory = "layerwise" for a soft core or bond line)'
            )
    if not isinstance(model.get("core_stretch", True), bool):
        raise SpecError(f"[model].core_stretch = {model['core_stretch']!r}: need true or false")
    options = ModelOptions(
        modes=modes,
        divisions=divisions,
        theory=model.get("theory", "single_layer"),
        layer_groups=model.get("layer_groups", "auto"),
        core_stretch=model.get("core_stretch", True),
    )

    effects = data.get("effects", [])
    if not isinstance(effects, list) or not all(isinstance(e, dict) for e in effects):
        raise SpecError("[[effects]]: need a list of tables, each with a 'kind'")
    specimen = Specimen(
        sp.get("name", Path(source).stem), length * MM, width * MM, layers, tuple(configurations)
    )
    unused = [name for name, m in materials.items() if m.identify and name not in specimen.materials]
    if unused:
        raise SpecError(
            f"[materials.{unused[0]}] is marked identify = true but no layer uses it: nothing would "
            "find it; use it in [specimen].layers or remove the mark"
        )
    design = parse_design(data.get("design", {}), materials, len(specimen.identified_materials))
    base = SpecimenModel(
        specimen,
        options,
        design=design,
        materials=tuple(materials.values()),
        source=source,
        input_std=_input_std(data, specimen),
    )
    return apply_fixed(base, effects)


def load_spec(path: str | Path) -> SpecimenModel:
    """Read and validate a spec file: the model every command and API function takes.

    The spec (TOML, UTF-8) gives the specimen, its materials and configurations in the
    spec's units (GPa, mm, kg/m^3); the model holds them in SI (Pa, m, kg) with the spec's
    fixed ``[[effects]]`` switched on, the ``[model]`` options and the validated
    ``[design]`` table.

    Parameters
    ----------
    path : str or pathlib.Path
        The spec file.

    Returns
    -------
    SpecimenModel
        The specimen, its effects, model options and design space (SI inside).

    Raises
    ------
    SpecError
        The file cannot be read, is not UTF-8 text or not valid TOML, or a table or key
        is invalid (the message names the field, the value and what is allowed).
    DesignError
        The ``[design]`` table is invalid.

    Examples
    --------
    >>> from fem.spec import load_spec
    >>> from identify.examples import COATED_PLATE
    >>> model = load_spec(COATED_PLATE)
    >>> [c.name for c in model.specimen.configurations]
    ['original', 'brass_bottom', 'brass_top']
    >>> round(model.specimen.length, 3)  # 150 mm in the spec, metres inside
    0.15
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SpecError(f"spec file {str(path)!r} cannot be read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise SpecError(
            f"spec file {str(path)!r} is not UTF-8 text (a binary file, or saved as UTF-16?): save it "
            "as UTF-8 TOML"
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"spec file {str(path)!r} is not valid TOML: {exc}") from None
    return parse_spec(data, str(path))
