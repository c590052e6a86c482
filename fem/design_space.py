"""The design space of a spec's ``[design]`` table, validated at the entry point.

Every key is optional::

    materials = ["brass", "aluminium"]   # spec materials or built-in stock (fem.stock)
    thicknesses_mm = [0.5, 1.0, 2.0]     # the stock thicknesses the lab can get
    placements = ["top", "bottom"]
    adhesive = { material = "adhesive", thickness_mm = 0.05 }
    configurations = 3                   # per test set, the original included
    frequency_std_rel = 0.001            # relative scatter of a measured frequency
    criterion = "condition"              # or "d" (log det) / "e" (smallest eigenvalue)
    max_added_mass_g = 300.0             # per configuration
    max_added_thickness_mm = 3.0         # per configuration, adhesive included
    band_hz = [20.0, 5000.0]             # what the measurement chain covers
    min_separation_rel = 0.005           # closer modes cannot be told apart
    prior_range_rel = 0.3                # score over +-30 % of the identified properties (0: nominal only)
    prior_samples = 16                   # parameter points sampled over that range
    target_std_rel = { E = 0.02, G = 0.02, nu = 0.05 }   # predicted std the lab needs
    sensor_mass_g = 2.0                  # the accelerometer (the test sheet gives its shift)

Without ``max_added_mass_g`` / ``max_added_thickness_mm`` the planner limits an added
configuration to 3 x the specimen's mass and thickness (``fem.limits``).

A spec material takes precedence over a stock one of the same name; ``NAME_stock``
always means the stock one (e.g. ``steel_stock`` next to an identified ``steel``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import DesignError
from .laminates.laminate import Layer
from .laminates.material import Material
from .limits import Limits
from .stock import (
    DEFAULT_ADHESIVE,
    STOCK,
    STOCK_SUFFIX,
    STOCK_THICKNESSES_MM,
    stock_name,
)
from .validation import check_keys, did_you_mean, number, whole

MM = 1e-3
PLACEMENTS = ("top", "bottom")
CRITERIA = {
    "condition": "condition number of the stacked relative sensitivity matrix (smaller is better)",
    "d": "D-optimality: log det of the Fisher information (larger is better)",
    "e": "E-optimality: smallest eigenvalue of the Fisher information (larger is better)",
}
KEYS = (
    "materials",
    "thicknesses_mm",
    "placements",
    "adhesive",
    "configurations",
    "frequency_std_rel",
    "criterion",
    "max_added_mass_g",
    "max_added_thickness_mm",
    "band_hz",
    "min_separation_rel",
    "prior_range_rel",
    "prior_samples",
    "target_std_rel",
    "sensor_mass_g",
    "damping_std_rel",
)
DEFAULT_MATERIALS = ("brass", "aluminium", "steel")
DEFAULT_FREQUENCY_STD_REL = 1e-3
#: Expected relative scatter of a measured damping ratio (repeated tap tests: about 3 %).
DEFAULT_DAMPING_STD_REL = 0.03
#: Added plates thinner than this are foils, not plates; thicker than this are blocks.
THICKNESS_RANGE_MM = (0.01, 50.0)
#: Prior parameter points a robust score uses by default (besides the nominal one).
DEFAULT_PRIOR_SAMPLES = 16
#: Target predicted std per property kind (relative) when [design] gives none: moduli to
#: 2 %, Poisson ratios to 5 % (a Poisson ratio is read from small frequency differences).
DEFAULT_TARGETS = {"E": 0.02, "G": 0.02, "nu": 0.05}
#: Keys of target_std_rel: a kind ("E": E1 and E2, "G": G12, "nu": nu12) or one parameter kind.
TARGET_KEYS = {
    "E": ("E1", "E2"),
    "G": ("G12",),
    "nu": ("nu12",),
    "E1": ("E1",),
    "E2": ("E2",),
    "G12": ("G12",),
    "nu12": ("nu12",),
}


@dataclass(frozen=True)
class DesignSpace:
    """Added plates to choose from and how test sets are scored.

    materials: known plate materials; thicknesses [m]; placements ("top"/"bottom");
    adhesive: the bond layer (material, thickness [m]) or None; size: configurations
    per test set, the original included; frequency_std_rel: relative std of a measured
    frequency; criterion: a key of ``CRITERIA``; limits: the lab's ``Limits``;
    defined: every material the spec defines (for names given later, e.g. in sweeps);
    damping_std_rel: relative std of a measured damping ratio (the loss-factor scores).
    """

    materials: tuple[Material, ...]
    thicknesses: tuple[float, ...] = tuple(t * MM for t in STOCK_THICKNESSES_MM)
    placements: tuple[str, ...] = PLACEMENTS
    adhesive: Layer | None = None
    size: int = 3
    frequency_std_rel: float = DEFAULT_FREQUENCY_STD_REL
    criterion: str = "condition"
    limits: Limits = field(default_factory=Limits)
    defined: tuple[Material, ...] = ()
    prior_range: float = 0.0
    prior_samples: int = DEFAULT_PRIOR_SAMPLES
    targets: tuple[tuple[str, float], ...] = tuple(
        (k, DEFAULT_TARGETS[g]) for g, kinds in TARGET_KEYS.items() if g in DEFAULT_TARGETS for k in kinds
    )
    targets_given: bool = False
    sensor_mass: float | None = None
    damping_std_rel: float = DEFAULT_DAMPING_STD_REL

    def target(self, kind: str) -> float | None:
        """The target relative std of a parameter kind (E1, E2, G12, nu12), or None."""
        return dict(self.targets).get(kind)

    def material(self, name, where: str) -> Material:
        """A known material by name: one the spec defines, else built-in stock."""
        return resolve_material(name, {m.name: m for m in self.defined}, where)


def _number(design: dict, key: str, default, low: float, high: float, what: str, *, zero: bool = False):
    return number(
        design,
        key,
        "[design]",
        required=False,
        default=default,
        low=low,
        high=high,
        low_inclusive=zero,
        hint=what,
        error=DesignError,
    )


def _list(design: dict, key: str, default, example: str) -> list:
    value = design.get(key, default)
    if not isinstance(value, (list, tuple)):
        raise DesignError(f"[design].{key} = {value!r}: need a list, e.g. {key} = {example}")
    if not value:
        raise DesignError(f"[design].{key} is empty: list at least one, e.g. {key} = {example}")
    return list(value)


def resolve_material(name, defined: dict[str, Material], where: str) -> Material:
    """A known plate material by name: the spec's own, else built-in stock."""
    if not isinstance(name, str):
        raise DesignError(f"{where} = {name!r}: need a material name (a string)")
    if name in defined:
        material = defined[name]
        if material.identify:
            hint = (
                f"use '{name}{STOCK_SUFFIX}' for the built-in stock {name}"
                if name in STOCK
                else "bond a known material"
            )
            raise DesignError(
                f"{where} = '{name}' is identified (identify = true) in this spec, "
                f"so it cannot be a known added plate; {hint}"
            )
        return material
    stock = stock_name(name)
    if stock is None:
        known = sorted(defined) + sorted(STOCK)
        hint = (did_you_mean(name, known) + " ").lstrip()
        raise DesignError(
            f"{where} = '{name}' is neither a spec material nor built-in stock; {hint}"
            f"spec: {', '.join(sorted(defined)) or 'none'}; stock: {', '.join(STOCK)}"
        )
    return STOCK[stock].material(name)


def parse_design(design: dict, defined: dict[str, Material], n_identified: int) -> DesignSpace:
    """A validated ``DesignSpace`` from a ``[design]`` table; errors in one line naming
    the key, the value, what is allowed and a fix."""
    if not isinstance(design, dict):
        raise DesignError("[design]: must be a table")
    check_keys(design, KEYS, "[design]", DesignError)
    if "materials" in design:
        names = _list(design, "materials", None, '["brass", "aluminium"]')
        materials = [resolve_material(n, defined, f"[design].materials[{i}]") for i, n in enumerate(names)]
    else:  # spec materials first; stock renamed where the spec's material of that name is identified
        materials = [
            resolve_material(
                n + STOCK_SUFFIX if n in defined and defined[n].identify else n,
                defined,
                "[design].materials (default)",
            )
            for n in DEFAULT_MATERIALS
        ]
    seen = set()
    for i, m in enumerate(materials):
        if m.name in seen:
            raise DesignError(
                f"[design].materials[{i}] = '{m.name}' is listed twice; list each material once"
            )
        seen.add(m.name)

    thicknesses = []
    for i, t in enumerate(_list(design, "thicknesses_mm", STOCK_THICKNESSES_MM, "[0.5, 1.0, 2.0]")):
        here = f"[design].thicknesses_mm[{i}]"
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise DesignError(f"{here} = {t!r}: need a number of mm")
        if not THICKNESS_RANGE_MM[0] <= t <= THICKNESS_RANGE_MM[1]:
            raise DesignError(
                f"{here} = {t:g}: need {THICKNESS_RANGE_MM[0]:g}..{THICKNESS_RANGE_MM[1]:g} mm "
                "(thicknesses are in mm, e.g. 1.0 not 0.001)"
            )
        thicknesses.append(t * MM)
    thicknesses = tuple(sorted(set(thicknesses)))

    placements = _list(design, "placements", PLACEMENTS, '["top", "bottom"]')
    for i, p in enumerate(placements):
        if p not in PLACEMENTS:
            raise DesignError(f"[design].placements[{i}] = {p!r}: allowed: 'top', 'bottom'")
    placements = tuple(dict.fromkeys(placements))

    adhesive = design.get("adhesive", {"material": DEFAULT_ADHESIVE[0], "thickness_mm": DEFAULT_ADHESIVE[1]})
    if adhesive is False:
        bond = None
    else:
        if not isinstance(adhesive, dict) or set(adhesive) != {"material", "thickness_mm"}:
            raise DesignError(
                f"[design].adhesive = {adhesive!r}: need {{ material = NAME, thickness_mm = T }} "
                "or false for none"
            )
        t = adhesive["thickness_mm"]
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0 < t <= 5.0:
            raise DesignError(
                f"[design].adhesive.thickness_mm = {t!r}: need a bond line of 0..5 mm, e.g. 0.05"
            )
        bond = Layer(resolve_material(adhesive["material"], defined, "[design].adhesive.material"), t * MM)

    size = design.get("configurations", max(2, n_identified))
    if isinstance(size, bool) or not isinstance(size, int) or size < 2:
        raise DesignError(
            f"[design].configurations = {size!r}: need a whole number >= 2 (the original plate "
            f"plus at least one added plate; the paper uses one per identified material, here {n_identified})"
        )

    criterion = design.get("criterion", "condition")
    if not isinstance(criterion, str) or criterion not in CRITERIA:
        raise DesignError(f"[design].criterion = {criterion!r}: allowed: {', '.join(map(repr, CRITERIA))}")

    std = _number(
        design, "frequency_std_rel", DEFAULT_FREQUENCY_STD_REL, 0.0, 0.1, "relative, e.g. 0.001 for 0.1 %"
    )
    mass = _number(design, "max_added_mass_g", None, 0.0, 1e6, "grams per configuration")
    thick = _number(design, "max_added_thickness_mm", None, 0.0, 1e3, "mm per configuration")
    separation = _number(
        design, "min_separation_rel", 0.0, 0.0, 0.5, "relative, e.g. 0.005 for 0.5 %", zero=True
    )
    band = design.get("band_hz")
    if band is not None:
        ok = (
            isinstance(band, list)
            and len(band) == 2
            and all(
                isinstance(b, (int, float)) and not isinstance(b, bool) and math.isfinite(b) for b in band
            )
        )
        if not ok or not 0 <= band[0] < band[1]:
            raise DesignError(
                f"[design].band_hz = {band!r}: need [low, high] in Hz with 0 <= low < high, e.g. [20, 5000]"
            )
        band = (float(band[0]), float(band[1]))
    limits = Limits(
        None if mass is None else mass * 1e-3, None if thick is None else thick * MM, band, separation
    )
    prior = _number(
        design,
        "prior_range_rel",
        0.0,
        0.0,
        0.9,
        "relative half-range of the unknown properties, e.g. 0.3 for +-30 %; 0 scores at the "
        "nominal values only",
        zero=True,
    )
    samples = whole(
        design.get("prior_samples", DEFAULT_PRIOR_SAMPLES),
        "[design].prior_samples",
        2,
        256,
        "of parameter points ",
        DesignError,
    )
    sensor = _number(
        design, "sensor_mass_g", None, 0.0, 1000.0, "the accelerometer's mass in grams, e.g. 2.0"
    )
    targets = _targets(design.get("target_std_rel"))
    damping_std = _number(
        design,
        "damping_std_rel",
        DEFAULT_DAMPING_STD_REL,
        0.0,
        1.0,
        "relative scatter of a measured damping ratio, e.g. 0.03 for 3 %",
    )
    return DesignSpace(
        tuple(materials),
        thicknesses,
        placements,
        bond,
        size,
        std,
        criterion,
        limits,
        tuple(defined.values()),
        prior,
        samples,
        targets,
        "target_std_rel" in design,
        None if sensor is None else sensor * 1e-3,
        damping_std,
    )


def _targets(table) -> tuple[tuple[str, float], ...]:
    """(kind, relative std) for E1, E2, G12, nu12 from ``target_std_rel`` (defaults where
    not given; a parameter kind's key overrides its group's)."""
    if table is None:
        table = {}
    elif not isinstance(table, dict) or not table:
        raise DesignError(
            f"[design].target_std_rel = {table!r}: need a table of relative std per property kind, "
            "e.g. { E = 0.02, G = 0.02, nu = 0.05 }"
        )
    check_keys(table, TARGET_KEYS, "[design].target_std_rel", DesignError)
    out = {k: DEFAULT_TARGETS[g] for g, kinds in TARGET_KEYS.items() if g in DEFAULT_TARGETS for k in kinds}
    for key in sorted(table, key=lambda k: k not in DEFAULT_TARGETS):  # groups first, then single kinds
        value = number(
            table,
            key,
            "[design].target_std_rel",
            low=0.0,
            high=1.0,
            hint="relative, e.g. 0.02 for 2 %",
            error=DesignError,
        )
        for kind in TARGET_KEYS[key]:
            out[kind] = value
    return tuple(out.items())
