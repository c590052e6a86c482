"""Where does the model fail?  The layer properties fitted (or the spec's values), the
relative errors of every configuration and mode, scored against the signatures of the
effects a Kirchhoff free-plate model leaves out (``patterns``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from fem.model import SpecimenModel

from ..engine.objective import Objective, solving_model
from ..engine.peak_lists import matched_at
from ..engine.result import FitResult
from ..engine.statistics import FitStatistics
from ..fitting.driver import fit_holding_bounds
from ..fitting.patterns import PATTERN_SHARE, Pattern, ShapePointMap, residual_patterns
from ..measurements import Measurements
from ..reporting import html_report as h
from ..reporting.report import shown_residuals
from ..reporting.residuals import residual_table, shape_correlations, with_macs
from ..reporting.rounding import percent
from ..reporting.shape_plots import shape_lines


@dataclass(frozen=True)
class Comparison:
    """Measured against model per configuration and mode, with residual patterns."""

    table: pd.DataFrame
    statistics: FitStatistics
    patterns: tuple[Pattern, ...]
    fitted: FitResult | None
    point_map: np.ndarray | None = None  # share explained by a point mass at each node
    node_xy: np.ndarray | None = None
    point_mass_hints: tuple = ()  # best distinct positions with mass estimates
    shapes: dict | None = None  # configuration -> ShapeCorrelation, with measured shapes
    shape_map: ShapePointMap | None = None  # where a point mass would explain the shapes' residuals
    solver: SpecimenModel | None = None  # the model as compared, solved as the fit solves it

    @property
    def rms_rel_error(self) -> float:
        return self.statistics.rms_rel_error

    @property
    def at_noise_level(self) -> bool:
        """The misfit is consistent with the (stated or assumed) scatter: the one chi^2 test
        a fit's status uses too (``FitStatistics.consistent``), so nothing is clearly missing."""
        return self.statistics.consistent

    def to_dict(self) -> dict:
        """The ``compare --json`` document."""
        chi2 = self.statistics.reduced_chi2
        return {
            "rms_rel_error": self.rms_rel_error,
            "reduced_chi2": chi2 if self.statistics.scatter_known and np.isfinite(chi2) else None,
            "at_noise_level": self.at_noise_level,
            "patterns": [
                {"pattern": p.name, "share": p.share, "detail": p.detail, "suggests": list(p.suggests)}
                for p in self.patterns
            ],
            "residuals": self.table.to_dict(orient="records"),
        } | self._shapes_dict()

    def _shapes_dict(self) -> dict:
        """The measured shapes' keys (empty, or null, without shapes)."""
        shapes = self.shapes or {}
        hint = self.shape_map.hint() if self.shape_map is not None else None
        return {
            "mac_matrix": {name: c.to_dict() for name, c in shapes.items()},
            "worst_point_mm": {
                name: None if c.worst_point is None else (1e3 * c.worst_point).tolist()
                for name, c in shapes.items()
            },
            "point_mass_from_shapes": None
            if hint is None
            else {
                "x_mm": 1e3 * hint["xy"][0],
                "y_mm": 1e3 * hint["xy"][1],
                "mass_g": 1e3 * hint["mass_kg"],
                "share": hint["share"],
            },
        }

    def sections(self) -> list[tuple[str, str]]:
        """(heading, HTML) sections of the notebook view: the misfit, the residual patterns
        and the residual table, drawn by the HTML report's code."""
        chi2 = self.statistics.reduced_chi2
        summary = (
            f"RMS relative error {100 * self.rms_rel_error:.4f} %"
            + (
                f", reduced chi^2 {chi2:.3g} (1 = the measurement scatter)"
                if self.statistics.scatter_known and np.isfinite(chi2)
                else ""
            )
            + (
                "; the misfit is at the level of the measurement scatter: nothing is clearly missing"
                if self.at_noise_level
                else ""
            )
        )
        patterns = pd.DataFrame(
            [
                {
                    "pattern": p.name,
                    "share [%]": 100 * p.share,
                    "detail": p.detail,
                    "suggests": ", ".join(p.suggests),
                }
                for p in sorted(self.patterns, key=lambda p: -p.share)
            ]
        )
        return [
            ("Misfit", h.paragraph(summary)),
            ("Residual patterns (share of the misfit each explains)", h.table(patterns, "{:.3g}")),
            ("Residuals", h.table(self.table)),
        ]

    def _repr_html_(self) -> str:
        return h.view("Model against measurement", None, self.sections())

    def report(self) -> str:
        chi2 = self.statistics.reduced_chi2
        lines = [
            "== model against measurement ==",
            "",
            f"RMS relative error {percent(self.rms_rel_error, 3)}"
            + (
                f", reduced chi^2 {chi2:.3g} (1 = the measurement scatter)"
                if self.statistics.scatter_known and np.isfinite(chi2)
                else ""
            ),
            "",
            shown_residuals(self.table).to_string(index=False),
            "",
            "residual patterns (share of the misfit each explains)",
        ]
        for p in sorted(self.patterns, key=lambda p: -p.share):
            mark = "*" if p.share > PATTERN_SHARE and not self.at_noise_level else " "
            lines.append(
                f" {mark} {p.name:34s} {100 * p.share:5.1f} %  {p.detail}  -> {', '.join(p.suggests)}"
            )
        if self.shapes:
            lines += [
                "",
                "measured mode shapes (MAC at the measured points; residual: what the paired mode and its "
                "close neighbours cannot reproduce)",
                *shape_lines(self.shapes),
            ]
        if self.at_noise_level:
            lines += ["", "the misfit is at the level of the measurement scatter: nothing is clearly missing"]
        return "\n".join(lines) + "\n"


def compare(model: SpecimenModel, measurements: Measurements, refit: bool = True) -> Comparison:
    """Fit the layer properties (unless ``refit`` is False) and analyse what remains.

    The relative error of every configuration and mode is scored against the signatures
    of the effects a Kirchhoff free-plate model leaves out (the residual patterns); a peak
    list's peaks are matched to the model's modes first.

    Parameters
    ----------
    model : SpecimenModel
        The model (``fem.load_spec``).
    measurements : Measurements
        The measured frequencies (``load_measurements``).
    refit : bool, default True
        Fit the layer properties first; False: compare at the spec's values.

    Returns
    -------
    Comparison
        Measured against model per configuration and mode [Hz, %], the misfit statistics,
        the residual patterns and the fit (None without ``refit``).

    Examples
    --------
    >>> import identify
    >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
    >>> model = identify.load_spec(COATED_PLATE)
    >>> comparison = identify.compare(model, identify.load_measurements(COATED_PLATE_MEASURED, model))
    >>> comparison.at_noise_level, round(100 * comparison.rms_rel_error, 3)  # RMS error in %
    (True, 0.024)
    """
    fitted = fit_holding_bounds(model, measurements) if refit else None
    if fitted is not None:
        now, model_hz, statistics = fitted.model, fitted.model_hz, fitted.statistics
        pairings, jacobian = fitted.pairings, fitted.jacobian
        measurements = fitted.measurements  # a peak list: the peaks matched to modes
    else:
        if not measurements.ranked:
            measurements = matched_at(model, measurements)
        objective = Objective(model, measurements, [])
        evaluation = objective.evaluate(np.zeros(0), None)
        now, model_hz, pairings, jacobian = model, evaluation.model_hz, evaluation.pairings, None
        statistics = objective.statistics(evaluation)
    solver = solving_model(now, measurements)
    patterns, shares, xy, hints, shape_map = residual_patterns(
        solver, measurements, model_hz, pairings, jacobian
    )
    table = residual_table(measurements, model_hz)
    paired = table.assign(mode=np.concatenate([pairings[c].indices + 1 for c in measurements.configurations]))
    shapes = shape_correlations(now, measurements, paired, measurements.shapes)
    return Comparison(
        with_macs(table, shapes),
        statistics,
        patterns,
        fitted,
        shares,
        xy,
        tuple(hints),
        shapes,
        shape_map,
        solver,
    )


__all__ = ["Comparison", "compare"]
