"""``sweep``: how the scores of the spec's design change with each design variable.

Each variable is varied alone from the spec's configurations (one at a time):

- ``thickness`` [mm]: the outer added plate of every added configuration;
- ``adhesive_thickness`` [mm]: the bond line (the inner added layer);
- ``material``: the outer added plate's material (spec or stock names);
- ``placement``: the face the additions sit on (top, bottom);
- ``modes``: modes measured per plate.

``CONFIG.KIND`` (e.g. ``brass_top.thickness``) changes one configuration only.
Values: ``0.5,1,2`` or ``START:STOP:COUNT`` (inclusive, evenly spaced); without
values the design space's (or a default set) are used.  The report folder gets
``sweep.csv``, one plot per variable and ``summary.md``, each written atomically.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from fem.errors import DesignError
from fem.io import report_folder, write_text
from fem.laminates.laminate import Layer
from fem.model import MAX_MODES, ModelOptions, SpecimenModel
from fem.plotting import new_figure, save_figure
from fem.solver.sensitivity import GOOD_BELOW, SINGULAR_ABOVE
from fem.specimen import Configuration
from fem.validation import did_you_mean

from .candidates import outer_face, with_plate_thickness
from .problem import Problem, unmeasurable
from .progress import Progress
from .scores.design import Design

KINDS = {
    "thickness": "added plate thickness [mm]",
    "adhesive_thickness": "adhesive thickness [mm]",
    "material": "added plate material",
    "placement": "face of the added plate",
    "modes": "modes measured per plate",
}
NUMERIC = ("thickness", "adhesive_thickness", "modes")
DEFAULT_ADHESIVE_MM = (0.02, 0.05, 0.1, 0.2)
DEFAULT_MODES = (4, 5, 6, 8, 10)
LINE_STYLES = ("-", "--", ":", "-.")


@dataclass(frozen=True)
class Variable:
    """A design variable: ``kind`` (a key of ``KINDS``) of configuration ``target``
    (None = every added configuration) over ``values``."""

    kind: str
    target: str | None
    values: tuple

    @property
    def name(self) -> str:
        return f"{self.target}.{self.kind}" if self.target else self.kind


def _numbers(kind: str, text: str, where: str) -> tuple:
    try:
        if ":" in text:
            start, stop, count = text.split(":")
            if not float(count).is_integer() or int(count) < 1:
                raise ValueError
            values = tuple(float(v) for v in np.linspace(float(start), float(stop), int(count)))
        else:
            values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise DesignError(f"{where}: need numbers '0.5,1,2' or 'START:STOP:COUNT' (e.g. 0.5:3:6)") from None
    if kind == "modes":
        if not all(v.is_integer() and 1 <= v <= MAX_MODES for v in values):
            raise DesignError(f"{where}: modes must be whole numbers from 1 to {MAX_MODES}")
        return tuple(int(v) for v in values)
    if not all(math.isfinite(v) and 0.01 <= v <= 50 for v in values):
        raise DesignError(f"{where}: thicknesses must be 0.01..50 mm (in mm, e.g. 1.0 not 0.001)")
    return values


def parse_variable(text: str, problem: Problem) -> Variable:
    """``KIND[=VALUES]`` or ``CONFIG.KIND[=VALUES]`` -> a validated ``Variable``."""
    where = f"--vary {text!r}"
    name, equals, values = text.partition("=")
    if equals and not values.strip():
        raise DesignError(
            f"{where}: no values after '='; give them (e.g. {name}=0.5,1,2) or leave out '=' for the defaults"
        )
    target, _, kind = name.rpartition(".")
    if kind not in KINDS:
        hint = (did_you_mean(kind, KINDS) + " ").lstrip()
        raise DesignError(
            f"{where}: unknown variable '{kind}'; {hint}allowed: {', '.join(KINDS)} (optionally CONFIG.KIND)"
        )
    added = [c for c in problem.specimen.configurations if not c.is_original]
    if kind != "modes":
        if target:
            names = [c.name for c in added]
            if target not in names:
                raise DesignError(
                    f"{where}: '{target}' is not an added configuration of the spec; "
                    f"known: {', '.join(names) or 'none'}"
                )
        elif not added:
            raise DesignError(
                f"{where}: the spec has no added configuration to vary; add [[configurations]] "
                "with top or bottom layers (or use plan-tests recommend)"
            )
    elif target:
        raise DesignError(f"{where}: modes apply to every plate; use --vary modes")
    space = problem.space
    if not values:
        defaults = {
            "thickness": tuple(t * 1e3 for t in space.thicknesses),
            "adhesive_thickness": DEFAULT_ADHESIVE_MM,
            "material": tuple(m.name for m in space.materials),
            "placement": ("top", "bottom"),
            "modes": DEFAULT_MODES,
        }
        parsed = defaults[kind]
    elif kind in NUMERIC:
        parsed = _numbers(kind, values, where)
    else:
        parsed = tuple(v.strip() for v in values.split(","))
        if kind == "placement" and not set(parsed) <= {"top", "bottom"}:
            raise DesignError(f"{where}: placements are 'top' and 'bottom'")
        if kind == "material":
            for i, v in enumerate(parsed):
                space.material(v, f"{where} value {i + 1}")
    return Variable(kind, target or None, tuple(parsed))


def _relabelled(layers, name: str, face: str) -> tuple[Layer, ...]:
    return tuple(replace(l, label=f"{name}.{face}{j + 1}") for j, l in enumerate(layers))


def vary(problem: Problem, variable: Variable, value) -> tuple[Problem, tuple[Configuration, ...]]:
    """The problem and configurations with ``variable`` set to ``value``."""
    if variable.kind == "modes":
        return problem.with_options(modes=value), problem.specimen.configurations
    out = []
    for c in problem.specimen.configurations:
        if c.is_original or (variable.target and c.name != variable.target):
            out.append(c)
            continue
        face = outer_face(c)
        layers = getattr(c, face)
        if variable.kind == "thickness":
            c = with_plate_thickness(c, value * 1e-3)
        elif variable.kind == "material":
            material = problem.space.material(value, f"--vary {variable.name}")
            c = replace(c, **{face: layers[:-1] + (replace(layers[-1], material=material),)})
        elif variable.kind == "adhesive_thickness":
            if len(layers) > 1:
                c = replace(c, **{face: (replace(layers[0], thickness=value * 1e-3),) + layers[1:]})
        elif variable.kind == "placement":
            if c.top and c.bottom:
                raise DesignError(
                    f"--vary {variable.name}: '{c.name}' has layers on both faces; "
                    "placement moves one-sided additions only"
                )
            c = Configuration(c.name, **{value: _relabelled(layers, c.name, value)})
        out.append(c)
    return problem, tuple(out)


@dataclass(frozen=True)
class SweepPoint:
    """One varied design: the variable's name, its value and the scored design."""

    variable: str
    value: object
    design: Design


@dataclass(frozen=True)
class SweepResult:
    """The spec's design (``base``) and every varied design, variable by variable."""

    name: str
    base: Design
    variables: tuple[Variable, ...]
    points: tuple[SweepPoint, ...]

    @cached_property
    def table(self) -> pd.DataFrame:
        """One row per design: variable, value, scores, predicted relative std of every
        parameter, added mass and the frequencies to expect."""
        rows = []
        for point in (SweepPoint("base", "", self.base),) + self.points:
            d = point.design
            sc = d.scores
            row = {
                "variable": point.variable,
                "value": point.value,
                "condition_number": sc.condition_number,
                "verdict": sc.verdict,
                "logdet_fisher": sc.logdet_fisher,
                "min_eigenvalue_fisher": sc.min_eigenvalue_fisher,
                "n_measured": d.n_measured,
                "max_added_mass_g": 1e3 * max(d.added_mass),
            }
            row.update({f"std_rel.{p.name}": s for p, s in zip(d.parameters, sc.std_rel)})
            for s, measured in zip(d.solved, d.measured):
                row.update(
                    {
                        f"{s.configuration.name}.f{i + 1}_hz": f
                        for i, f in enumerate(s.frequencies_hz[: measured.size])
                    }
                )
            rows.append(row)
        return pd.DataFrame(rows)

    def to_dict(self) -> dict:
        table = self.table.astype(object).where(
            np.isfinite(self.table.select_dtypes("number")).reindex(
                columns=self.table.columns, fill_value=True
            ),
            None,
        )  # JSON has no infinities
        return {"base": self.base.to_dict(), "table": table.to_dict("records")}

    def report(self) -> str:
        """The readable summary (Markdown)."""
        b = self.base.scores
        lines = [
            f"# Sweep of the test design of {self.name}",
            "",
            f"Base design (the spec's configurations): {' + '.join(self.base.names)}, condition number "
            f"{b.condition_number:.4g} ({b.verdict}), log det F {b.logdet_fisher:.5g}. Verdicts: good below "
            f"{GOOD_BELOW:g}, ill-conditioned up to {SINGULAR_ABOVE:g}, singular above (paper section 4.6).",
            "",
        ]
        table = self.table
        for variable in self.variables:
            part = table[table.variable == variable.name]
            best = part.loc[part.condition_number.idxmin()]
            worst = part.loc[part.condition_number.idxmax()]
            verdicts = ", ".join(f"{v} ({n})" for v, n in part.verdict.value_counts().items())
            lines += [
                f"## {variable.name}: {KINDS[variable.kind]}",
                "",
                f"Best {best.value}: condition number {best.condition_number:.4g}; worst {worst.value}: "
                f"{worst.condition_number:.4g}. Verdicts: {verdicts}. Plot: `{plot_name(variable)}`.",
                "",
                "| value | condition number | verdict | log det F | largest predicted std |",
                "|---|---|---|---|---|",
            ]
            stds = part.filter(like="std_rel.")
            for (_, row), (_, std) in zip(part.iterrows(), stds.iterrows()):
                worst_p = std.idxmax()[len("std_rel.") :]
                lines.append(
                    f"| {row.value} | {row.condition_number:.4g} | {row.verdict} | {row.logdet_fisher:.5g} | "
                    f"{worst_p} {100 * std.max():.3g} % |"
                )
            lines.append("")
        return "\n".join(lines)

    def write(self, folder: str | Path) -> list[Path]:
        """sweep.csv, a plot per variable and summary.md in a report folder written whole
        or not at all (``fem.io.report_folder``); returns the files' final paths."""
        names = ["sweep.csv"] + [plot_name(v) for v in self.variables] + ["summary.md"]
        with report_folder(folder) as tmp:
            write_text(tmp / "sweep.csv", self.table.to_csv(index=False))
            for variable, name in zip(self.variables, names[1:-1]):
                plot_variable(self.table[self.table.variable == variable.name], variable, tmp / name)
            write_text(tmp / "summary.md", self.report() + "\n")
        return [Path(folder) / name for name in names]


def plot_name(variable: Variable) -> str:
    return f"sweep_{variable.name}.png"


def plot_variable(part: pd.DataFrame, variable: Variable, path: Path) -> None:
    """Condition number (verdict zones shaded) and predicted std of every parameter
    against the variable's values."""
    numeric = variable.kind in NUMERIC
    x = part.value.astype(float).to_numpy() if numeric else np.arange(len(part))
    fig, (top, bottom) = new_figure(2, 1, figsize=(9, 7), sharex=True)
    cond = part.condition_number.to_numpy(dtype=float)
    top.semilogy(x, np.where(np.isfinite(cond), cond, np.nan), "o-", color="k")
    high = max(np.nanmax(np.where(np.isfinite(cond), cond, np.nan), initial=1.0) * 3, SINGULAR_ABOVE * 10)
    top.axhspan(1, GOOD_BELOW, color="tab:green", alpha=0.12, label="good")
    top.axhspan(GOOD_BELOW, SINGULAR_ABOVE, color="tab:orange", alpha=0.12, label="ill-conditioned")
    top.axhspan(SINGULAR_ABOVE, high, color="tab:red", alpha=0.12, label="singular")
    top.set_ylim(1, high)
    top.set_ylabel("condition number")
    stds = part.filter(like="std_rel.")
    names = [c[len("std_rel.") :] for c in stds]
    materials = list(dict.fromkeys(n.rsplit(".", 1)[0] for n in names))
    kinds = list(dict.fromkeys(n.rsplit(".", 1)[1] for n in names))
    for column, name in zip(stds, names):  # colour: the property; line style: the material
        material, kind = name.rsplit(".", 1)
        values = 100 * stds[column].to_numpy(dtype=float)
        bottom.semilogy(
            x,
            np.where(np.isfinite(values), values, np.nan),
            marker=".",
            label=name,
            color=f"C{kinds.index(kind)}",
            linestyle=LINE_STYLES[materials.index(material) % 4],
        )
    bottom.set_ylabel("predicted std [% of value]")
    bottom.set_xlabel(KINDS[variable.kind] + (f" ({variable.target})" if variable.target else ""))
    bottom.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    top.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8)
    if not numeric:
        bottom.set_xticks(x, [str(v) for v in part.value])
    top.set_title(f"sweep of {variable.name}")
    save_figure(fig, path)


def sweep(
    problem: Problem | SpecimenModel,
    variables: list[Variable | str],
    pool=None,
    progress: Progress | None = None,
) -> SweepResult:
    """Score the spec's design and every one-at-a-time variation of it.

    Parameters
    ----------
    problem : Problem or SpecimenModel
        A planning problem, or a model (its ``[design]`` table makes the problem).
    variables : list of Variable or str
        What to vary, as ``Variable`` or as the command line gives them
        (``KIND[=VALUES]`` or ``CONFIG.KIND[=VALUES]``, e.g. ``"thickness=0.5:3:6"``; KIND:
        thickness, adhesive_thickness [mm], material, placement, modes).
    pool : concurrent.futures.Executor, optional
        Where to solve the configurations not cached (None: in this process).
    progress : Progress, optional
        Where a progress bar goes for long runs (None: nowhere).

    Returns
    -------
    SweepResult
        The spec's design (``base``) and every varied design, variable by variable.

    Raises
    ------
    DesignError
        A variable is unknown or its values invalid, or a configuration of the spec's
        design has no mode that would be measured.

    Examples
    --------
    >>> import designer
    >>> from identify.examples import COATED_PLATE
    >>> from fem import load_spec
    >>> result = designer.sweep(load_spec(COATED_PLATE), ["thickness=0.5,1"])  # mm
    >>> [(p.value, round(p.design.scores.condition_number, 1)) for p in result.points]
    [(0.5, 54.7), (1.0, 25.6)]
    """
    problem = Problem.of(problem)
    variables = [v if isinstance(v, Variable) else parse_variable(v, problem) for v in variables]
    plan = [("base", "", problem, problem.specimen.configurations)]
    for variable in variables:
        plan += [(variable.name, value, *vary(problem, variable, value)) for value in variable.values]
    by_options: dict[ModelOptions, list] = {}
    for _, _, p, configurations in plan:  # one parallel batch per model (modes change the model)
        by_options.setdefault(p.options, []).extend(configurations)
    for options, configurations in by_options.items():
        replace(problem, model=replace(problem.model, options=options)).solve(
            configurations, pool=pool, progress=progress
        )
    for solved in problem.solve(problem.specimen.configurations):  # the base design must be measurable
        if not problem.measured(solved).any():
            raise unmeasurable(problem, solved)
    designs = [Design.of(p, p.solve(configurations)) for _, _, p, configurations in plan]
    points = tuple(SweepPoint(name, value, d) for (name, value, _, _), d in zip(plan[1:], designs[1:]))
    return SweepResult(problem.specimen.name, designs[0], tuple(variables), points)
