"""A design written as a spec: the lab's test plan in the form ``check`` and ``fit`` read.

The written spec is the original one (its specimen, materials, ``[[effects]]``,
``[model]`` and ``[design]`` tables as the file has them) with ``[[configurations]]``
replaced by the design's, every material the design bonds defined in ``[materials]``
(built-in stock written out with its values and source), and the command line's
overrides (``--modes``, ``--criterion``, ``--prior-range``) folded in, so that ``check``
of the written file scores exactly the design that was recommended.  A model built in
code (no spec file to start from) is written from the model object itself, unless it
has effects switched on (their tables cannot be rebuilt).  The document is read back
before it is written: a spec that would not give the same laminates and scoring (e.g. a
model whose values were changed in code after loading) is refused.  Written with
tomli-w, atomically.
"""

from __future__ import annotations

import copy
import math
import tomllib
from datetime import date
from pathlib import Path

import tomli_w

from fem.design_space import DesignSpace
from fem.errors import DesignError
from fem.io import write_text
from fem.laminates.laminate import Layer
from fem.laminates.material import ELASTIC_CONSTANTS, Material
from fem.spec import parse_spec
from fem.specimen import Configuration
from fem.stock import STOCK, stock_name

from .problem import Problem
from .scores.design import Design

GPA, MM = 1e9, 1e-3


def _layer(layer: Layer) -> dict:
    out = {"material": layer.material.name, "thickness_mm": round(layer.thickness / MM, 9)}
    if layer.angle:
        out["angle_deg"] = math.degrees(layer.angle)
    return out


def configuration_table(configuration: Configuration) -> dict:
    """A ``[[configurations]]`` entry: additions listed from the specimen outward."""
    out: dict = {"name": configuration.name}
    for face in ("bottom", "top"):
        layers = getattr(configuration, face)
        if layers:
            out[face] = [_layer(l) for l in layers]
    return out


def material_table(material: Material) -> dict:
    """A ``[materials.NAME]`` table of a known material (GPa, kg/m^3)."""
    out = {
        "E1_GPa": material.E1 / GPA,
        "E2_GPa": material.E2 / GPA,
        "G12_GPa": material.G12 / GPA,
        "nu12": material.nu12,
        "density_kg_m3": material.density,
    }
    for key in ("G13", "G23"):
        if getattr(material, key) is not None:
            out[f"{key}_GPa"] = getattr(material, key) / GPA
    bounds = getattr(material, "bounds", ())  # (kind, lower, upper) [SI] a spec may set
    if bounds:
        units = {"nu12": ("nu12", 1.0), "density": ("density_kg_m3", 1.0)}
        out["bounds"] = {
            units.get(kind, (f"{kind}_GPa", GPA))[0]: [
                lo / units.get(kind, (None, GPA))[1],
                hi / units.get(kind, (None, GPA))[1],
            ]
            for kind, lo, hi in bounds
        }
    stock = stock_name(material.name)
    if stock is not None and STOCK[stock].material(material.name) == material:
        out["note"] = f"built-in stock ({stock}): {STOCK[stock].source}"
    return out


def source_document(problem: Problem) -> dict | None:
    """The spec file the problem's model was loaded from, as a TOML document (None when
    there is none to read)."""
    source = Path(problem.model.source)
    try:
        return tomllib.loads(source.read_text())
    except (OSError, tomllib.TOMLDecodeError):
        return None


def _identify(material: Material):
    return True if material.identify == ELASTIC_CONSTANTS else list(material.identify)


def design_table(space: DesignSpace) -> dict:
    """The ``[design]`` table of a design space (limits only where given, not defaulted)."""
    out: dict = {
        "materials": [m.name for m in space.materials],
        "thicknesses_mm": [round(t / MM, 9) for t in space.thicknesses],
        "placements": list(space.placements),
        "adhesive": False
        if space.adhesive is None
        else {
            "material": space.adhesive.material.name,
            "thickness_mm": round(space.adhesive.thickness / MM, 9),
        },
        "configurations": space.size,
        "frequency_std_rel": space.frequency_std_rel,
        "criterion": space.criterion,
    }
    limits = space.limits
    if limits.max_added_mass is not None and "mass" not in limits.defaults:
        out["max_added_mass_g"] = limits.max_added_mass * 1e3
    if limits.max_added_thickness is not None and "thickness" not in limits.defaults:
        out["max_added_thickness_mm"] = limits.max_added_thickness / MM
    if limits.band is not None:
        out["band_hz"] = list(limits.band)
    if limits.min_separation:
        out["min_separation_rel"] = limits.min_separation
    if space.prior_range:
        out.update(prior_range_rel=space.prior_range, prior_samples=space.prior_samples)
    if space.targets_given:
        out["target_std_rel"] = dict(space.targets)
    if space.sensor_mass is not None:
        out["sensor_mass_g"] = space.sensor_mass * 1e3
    return out


def model_document(problem: Problem) -> dict:
    """A spec document rebuilt from the problem's model (built in code, no spec file)."""
    model = problem.model
    if model.effects:
        raise DesignError(
            f"--write-spec: the model has effects switched on ({', '.join(model.effects)}) but no spec "
            "file to copy their tables from; load the model from a spec file (fem.load_spec)"
        )
    specimen = model.specimen
    materials = {}
    for m in list(model.materials) + list(specimen.materials.values()):
        if m.name not in materials:
            table = material_table(m)
            if m.identify:
                table["identify"] = _identify(m)
            materials[m.name] = table
    data = {
        "specimen": {
            "name": specimen.name,
            "length_mm": specimen.length / MM,
            "width_mm": specimen.width / MM,
            "layers": [_layer(l) for l in specimen.layers],
        },
        "materials": materials,
        "model": {"modes": model.options.modes},
    }
    if model.options.divisions is not None:
        data["model"]["divisions"] = model.options.divisions
    data["design"] = design_table(problem.space)
    return data


def _same(a: tuple, b: tuple) -> bool:
    return len(a) == len(b) and all(
        x == y if not isinstance(x, float) or not isinstance(y, float) else math.isclose(x, y, rel_tol=1e-12)
        for x, y in zip(a, b)
    )


def _stack(problem: Problem, configuration: Configuration) -> list[tuple]:
    m = [
        (
            l.material.E1,
            l.material.E2,
            l.material.G12,
            l.material.nu12,
            l.material.density,
            l.thickness,
            l.angle,
            l.material.identify,
        )
        for l in problem.specimen.laminate(configuration).layers
    ]
    return m


def verify(problem: Problem, design: Design, data: dict) -> None:
    """Read ``data`` back: the same laminates, measured modes and scoring as ``problem``
    (else a one-line ``DesignError`` naming what differs)."""
    back = Problem.of(parse_spec(copy.deepcopy(data)))
    for s in design.solved:
        mine = _stack(problem, s.configuration)
        theirs = _stack(back, back.specimen.configuration(s.configuration.name))
        if len(mine) != len(theirs) or not all(_same(a, b) for a, b in zip(mine, theirs)):
            raise DesignError(
                f"--write-spec: configuration '{s.configuration.name}' would not read back as the same "
                "laminate (was the model changed in code after loading its spec?); write the design "
                "from the model as loaded"
            )
    a, b = problem.space, back.space
    checks = {
        "[model] modes": (problem.modes, back.modes),
        "[design] frequency_std_rel": (a.frequency_std_rel, b.frequency_std_rel),
        "[design] criterion": (a.criterion, b.criterion),
        "[design] prior_range_rel": (a.prior_range, b.prior_range),
        "[design] limits": (a.limits, b.limits),
        "model options": (problem.options, back.options),
        "attachments": (problem.specimen.attachments, back.specimen.attachments),
    }
    for what, (x, y) in checks.items():
        if x != y:
            raise DesignError(
                f"--write-spec: {what} would read back as {y!r}, not {x!r}; write the design from the "
                "model as loaded from its spec"
            )


def design_document(problem: Problem, design: Design) -> dict:
    """The spec of ``design``: the source spec (or the model) with its configurations
    replaced, the bonded materials defined and the problem's options (modes, criterion,
    prior range); checked by reading it back."""
    source = source_document(problem)
    data = copy.deepcopy(source) if source is not None else model_document(problem)
    materials = data.setdefault("materials", {})
    configurations = [s.configuration for s in design.solved]
    for c in configurations:
        for layer in c.bottom + c.top:
            name = layer.material.name
            if name not in materials and not layer.material.identify:
                materials[name] = material_table(layer.material)
    data["configurations"] = [configuration_table(c) for c in configurations]
    model = data.setdefault("model", {})
    model["modes"] = problem.modes
    space = data.setdefault("design", {})
    if space.get("criterion", "condition") != problem.space.criterion:
        space["criterion"] = problem.space.criterion
    if space.get("prior_range_rel", 0.0) != problem.space.prior_range:
        space["prior_range_rel"] = problem.space.prior_range
    verify(problem, design, data)
    return data


def write_spec(problem: Problem, design: Design, path: str | Path) -> Path:
    """Write ``design`` as a complete spec at ``path`` (atomically).

    The spec is the source spec (or the model) with its configurations replaced by the
    design's, the bonded materials defined and the problem's options; it is checked by
    reading it back, and a header comment gives its scores and how to check it.

    Parameters
    ----------
    problem : Problem
        The planning problem the design was scored in (``Problem.of(model)``).
    design : Design
        The design to write, e.g. ``recommend(...).best``.
    path : str or pathlib.Path
        The spec file to write.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    DesignError
        The design would not read back as written (the model was changed in code after
        loading), or a model with effects has no spec file to copy their tables from.
    OutputError
        ``path`` is a folder or its folder is not writable.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import designer
    >>> from identify.examples import COATED_PLATE
    >>> from fem import load_spec
    >>> problem = designer.Problem.of(load_spec(COATED_PLATE))
    >>> best = designer.recommend(problem, top=1).best
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = designer.write_spec(problem, best, Path(folder) / "plan.toml")
    ...     [c.name for c in load_spec(path).specimen.configurations]
    ['original', 'steel_stock_1mm_top', 'steel_stock_1mm_bottom']
    """
    data = design_document(problem, design)
    sc = design.scores
    robust = ""
    if design.robust is not None:
        robust = (
            f"; over the prior (+-{100 * design.robust.range_rel:g} %): worst "
            f"{design.robust.worst(problem.space.criterion):.5g} ({problem.space.criterion})"
        )
    header = (
        f"# Test plan written by plan-tests recommend on {date.today().isoformat()} from "
        f"{problem.model.source}\n"
        f"# configurations: {' + '.join(design.names)}\n"
        f"# condition number {sc.condition_number:.4g} ({sc.verdict}), log det F "
        f"{sc.logdet_fisher:.5g}{robust}\n"
        "# check it with: plan-tests check THIS_FILE; after the test: identify-layers fit THIS_FILE "
        "DATA.csv\n\n"
    )
    path = Path(path)
    write_text(path, header + tomli_w.dumps(data))
    return path
