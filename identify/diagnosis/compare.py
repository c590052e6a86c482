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
from ..fitting.patterns import PATTERN_SHARE, Pattern, residual_patterns
from ..measurements import Measurements
from ..reporting import html_report as h
from ..reporting.report import shown_residuals
from ..reporting.residuals import residual_table
from ..reporting.rounding import percent


@dataclass(frozen=True)
class Comparison:
    """Measured against model per configuration and mode, with residual patterns."""

    table: pd.DataFrame
    statistics: FitStatistics
    patterns: tuple[Pattern, ...]
    fitted: FitResult | None
    point_map: np.ndarray | None = None     # share explained by a point mass at each node
    node_xy: np.ndarray | None = None
    point_mass_hints: tuple = ()            # best distinct positions with mass estimates

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
        return {"rms_rel_error": self.rms_rel_error,
                "reduced_chi2": chi2 if self.statistics.scatter_known and np.isfinite(chi2) else None,
                "at_noise_level": self.at_noise_level,
                "patterns": [{"pattern": p.name, "share": p.share, "detail": p.detail, "suggests": list(p.suggests)}
                             for p in self.patterns],
                "residuals": self.table.to_dict(orient="records")}

    def sections(self) -> list[tuple[str, str]]:
        """(heading, HTML) sections of the notebook view: the misfit, the residual patterns
        and the residual table, drawn by the HTML report's code."""
        chi2 = self.statistics.reduced_chi2
        summary = (f"RMS relative error {100 * self.rms_rel_error:.4f} %"
                   + (f", reduced chi^2 {chi2:.3g} (1 = the measurement scatter)"
                      if self.statistics.scatter_known and np.isfinite(chi2) else "")
                   + ("; the misfit is at the level of the measurement scatter: nothing is clearly missing"
                      if self.at_noise_level else ""))
        patterns = pd.DataFrame([{"pattern": p.name, "share [%]": 100 * p.share, "detail": p.detail,
                                  "suggests": ", ".join(p.suggests)}
                                 for p in sorted(self.patterns, key=lambda p: -p.share)])
        return [("Misfit", h.paragraph(summary)), ("Residual patterns (share of the misfit each explains)",
                                                    h.table(patterns, "{:.3g}")), ("Residuals", h.table(self.table))]

    def _repr_html_(self) -> str:
        return h.view("Model against measurement", None, self.sections())

    def report(self) -> str:
        chi2 = self.statistics.reduced_chi2
        lines = ["== model against measurement ==", "",
                 f"RMS relative error {percent(self.rms_rel_error, 3)}"
                 + (f", reduced chi^2 {chi2:.3g} (1 = the measurement scatter)"
                    if self.statistics.scatter_known and np.isfinite(chi2) else ""),
                 "", shown_residuals(self.table).to_string(index=False), "",
                 "residual patterns (share of the misfit each explains)"]
        for p in sorted(self.patterns, key=lambda p: -p.share):
            mark = "*" if p.share > PATTERN_SHARE and not self.at_noise_level else " "
            lines.append(f" {mark} {p.name:34s} {100 * p.share:5.1f} %  {p.detail}  -> {', '.join(p.suggests)}")
        if self.at_noise_level:
            lines += ["", "the misfit is at the level of the measurement scatter: nothing is clearly missing"]
        return "\n".join(lines) + "\n"


def compare(model: SpecimenModel, measurements: Measurements, refit: bool = True) -> Comparison:
    """Fit the layer properties (unless ``refit`` is False) and analyse what remains."""
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
    patterns, shares, xy, hints = residual_patterns(solving_model(now, measurements), measurements, model_hz, pairings, jacobian)
    return Comparison(residual_table(measurements, model_hz), statistics, patterns, fitted, shares, xy, tuple(hints))


__all__ = ["Comparison", "compare"]
