"""The outcome of an identification: status, parameters with uncertainties, statistics,
history and residuals.  SI inside; ``report()`` and ``to_dict()`` give the spec's units
(GPa, mm, g)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from fem.model import SpecimenModel
from fem.specimen import Parameter, Specimen

from ..measurements import Measurements
from ..reporting.report import fit_view, report_text, to_dict
from .statistics import FitStatistics
from .stopping import Stop
from .uncertainty import Uncertainty

if TYPE_CHECKING:
    from ..fitting.budget import Budget
    from ..fitting.damping import DampingResult
    from .peak_assignment import PeakAssignment


class FitStatus(str, Enum):  # noqa: UP042 (StrEnum would change str() of a member to its value)
    """How an identification ended.  Only ``CONVERGED`` means the result may be used as
    it stands (exit status 0)."""

    CONVERGED = "converged"  # the misfit is at the level of the stated scatter
    POOR_FIT = "poor_fit"  # converged, on a misfit the scatter cannot explain
    NOT_CONVERGED = "not_converged"  # the iterations stopped before a solution
    NOT_IDENTIFIABLE = "not_identifiable"  # the frequencies fit, the parameters are not determined


@dataclass(frozen=True)
class Iteration:
    """One accepted state of the updating (number 0 is the start)."""

    number: int
    values: np.ndarray
    model_hz: np.ndarray
    rms_rel_error: float
    cost: float
    step: float
    damping: float


@dataclass(frozen=True)
class FitResult:
    """An identification: ``status`` and ``message`` say how it ended; ``values`` (SI) of
    ``parameters`` with their ``uncertainty``; ``statistics`` of the misfit; the
    ``history``; the paired ``model_hz`` per measured row; the fitted ``model``.

    warnings: what the user must know (automatic choices, ambiguities); twins: other
    solutions that fit within the scatter; pairings: configuration -> final
    ``ModePairing``; jacobian: weighted d residual / d z at the result; effect_of:
    parameter -> the effect kind it belongs to; effect_notes: (kind, text) said of an
    effect's estimate; baseline: the fit without the effects, when effects were free;
    peaks: for a peak list, what became of every peak (``measurements`` then holds the
    matched ones, ranked); causes: for a poor fit, what is likely wrong, most likely first;
    budget: each known input's and the measurements' share of the std, when the spec
    states the known inputs' std (``uncertainty`` then includes them); damping: the layers'
    loss factors from the measured damping ratios, when the spec asks for them
    (``identify.fitting.damping``); stop: why the iterations stopped (``stopping.Stop``;
    ``"stop_reason"`` in the JSON).
    """

    status: FitStatus
    message: str
    parameters: tuple[Parameter, ...]
    values: np.ndarray
    uncertainty: Uncertainty
    statistics: FitStatistics
    history: tuple[Iteration, ...]
    measurements: Measurements
    model_hz: np.ndarray
    model: SpecimenModel
    warnings: tuple[str, ...] = ()
    twins: tuple[np.ndarray, ...] = ()
    pairings: dict = field(default_factory=dict)
    jacobian: np.ndarray | None = None
    effect_of: dict = field(default_factory=dict)
    effect_notes: tuple[tuple[str, str], ...] = ()
    baseline: FitResult | None = None
    peaks: PeakAssignment | None = None
    causes: tuple = ()
    budget: Budget | None = None
    damping: DampingResult | None = None
    stop: Stop | None = None

    @property
    def converged(self) -> bool:
        """The fit reached a solution whose misfit the scatter explains."""
        return self.status is FitStatus.CONVERGED

    @property
    def finished(self) -> bool:
        """The iterations reached a solution (converged or a poor fit): its misfit can be
        compared with other fits'."""
        return self.status in (FitStatus.CONVERGED, FitStatus.POOR_FIT)

    @property
    def specimen(self) -> Specimen:
        """The fitted specimen (SI)."""
        return self.model.specimen

    @property
    def iterations(self) -> int:
        return len(self.history) - 1

    @property
    def rel_error(self) -> np.ndarray:
        """(model - measured) / measured per measured mode."""
        return self.model_hz / self.measurements.table["frequency_hz"].to_numpy() - 1

    @property
    def rms_rel_error(self) -> float:
        return self.statistics.rms_rel_error

    def value(self, parameter: Parameter) -> float:
        return float(self.values[self.parameters.index(parameter)])

    def std(self, parameter: Parameter) -> float:
        return float(self.uncertainty.std[self.parameters.index(parameter)])

    def report(self) -> str:
        """Fixed sections: statistics, parameters +- std with flags, correlations,
        residuals, warnings (display units)."""
        return report_text(self)

    def to_dict(self) -> dict:
        """The ``fit --json`` document, display units."""
        return to_dict(self)

    def _repr_html_(self) -> str:
        """The notebook view: the report's status box and tables (``report.fit_view``)."""
        return fit_view(self)


__all__ = ["FitStatus", "FitResult", "Iteration"]
