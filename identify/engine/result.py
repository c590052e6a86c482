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
    """How an identification ended.

    Only ``CONVERGED`` means the result may be used as it stands (exit status 0).  The
    member's value is the ``status`` of the ``fit --json`` document.

    Attributes
    ----------
    CONVERGED : str
        ``"converged"``: the misfit is at the level of the stated scatter.
    POOR_FIT : str
        ``"poor_fit"``: converged, on a misfit the scatter cannot explain.
    NOT_CONVERGED : str
        ``"not_converged"``: the iterations stopped before a solution.
    NOT_IDENTIFIABLE : str
        ``"not_identifiable"``: the frequencies fit, the parameters are not determined.

    Examples
    --------
    >>> from identify import FitStatus
    >>> FitStatus("poor_fit") is FitStatus.POOR_FIT
    True
    >>> [status.value for status in FitStatus]
    ['converged', 'poor_fit', 'not_converged', 'not_identifiable']
    """

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
    """An identification: the fitted parameters with their std and how the fit ended.

    Made by ``identify.fit``.  Values are SI inside (Pa); ``report()`` and ``to_dict()``
    give the spec's units (GPa, mm, g).

    Attributes
    ----------
    status : FitStatus
        How the fit ended (with ``message``).
    message : str
        How the fit ended, in words.
    parameters : tuple of Parameter
        The fitted parameters.
    values : numpy.ndarray
        Their values (SI).
    uncertainty : Uncertainty
        Their uncertainty.
    statistics : FitStatistics
        The statistics of the misfit.
    history : tuple of Iteration
        The accepted iterations (number 0 is the start).
    measurements : Measurements
        The measurements fitted; for a peak list, the matched peaks, ranked.
    model_hz : numpy.ndarray
        The paired model frequency [Hz] per measured row.
    model : SpecimenModel
        The fitted model.
    warnings : tuple of str
        What the user must know (automatic choices, ambiguities).
    twins : tuple of numpy.ndarray
        Other solutions that fit within the scatter.
    pairings : dict
        Configuration -> final ``ModePairing``.
    jacobian : numpy.ndarray or None
        Weighted d residual / d z at the result.
    effect_of : dict
        Parameter -> the effect kind it belongs to.
    effect_notes : tuple of (str, str)
        (kind, text) said of an effect's estimate.
    baseline : FitResult or None
        The fit without the effects, when effects were free.
    peaks : PeakAssignment or None
        For a peak list, what became of every peak (``measurements`` then holds the
        matched ones, ranked).
    causes : tuple
        For a poor fit, what is likely wrong, most likely first.
    budget : Budget or None
        Each known input's and the measurements' share of the std, when the spec states
        the known inputs' std (``uncertainty`` then includes them).
    damping : DampingResult or None
        The layers' loss factors from the measured damping ratios, when the spec asks for
        them (``identify.fitting.damping``).
    stop : Stop or None
        Why the iterations stopped (``stopping.Stop``; ``"stop_reason"`` in the JSON).
    images : tuple of (str, numpy.ndarray)
        The plate's images with the same frequencies by symmetry, other states that the
        frequencies cannot tell from this one (``ambiguity.exact_images``): what each
        image is and the parameters' values there (SI, ``parameters``' order).

    Examples
    --------
    >>> import identify
    >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
    >>> model = identify.load_spec(COATED_PLATE)
    >>> result = identify.fit(model, identify.load_measurements(COATED_PLATE_MEASURED, model))
    >>> result.status.value, len(result.parameters)
    ('converged', 12)
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
    images: tuple[tuple[str, np.ndarray], ...] = ()

    @property
    def converged(self) -> bool:
        """The fit reached a solution whose misfit the scatter explains.

        Returns
        -------
        bool
            True when ``status`` is ``FitStatus.CONVERGED``: only then may the result be
            used as it stands.

        Examples
        --------
        >>> import identify
        >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
        >>> model = identify.load_spec(COATED_PLATE)
        >>> identify.fit(model, identify.load_measurements(COATED_PLATE_MEASURED, model)).converged
        True
        """
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
        """The text ``identify-layers fit`` prints.

        Fixed sections: statistics, parameters +- std with flags, correlations, residuals,
        warnings, in display units (the spec's: GPa, mm, g).

        Returns
        -------
        str
            The report.

        Examples
        --------
        >>> import identify
        >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
        >>> model = identify.load_spec(COATED_PLATE)
        >>> result = identify.fit(model, identify.load_measurements(COATED_PLATE_MEASURED, model))
        >>> print(result.report())  # doctest: +ELLIPSIS
        == identification ==
           converged: ...
        statistics
          measured frequencies   15 in 3 configurations
        ...
        """
        return report_text(self)

    def to_dict(self) -> dict:
        """The ``fit --json`` document, in display units (the spec's: GPa, mm, g).

        Returns
        -------
        dict
            The document: ``status``, ``materials`` (values and their ``std``), statistics,
            residuals, warnings and the rest ``docs/json.md`` lists.

        Examples
        --------
        >>> import identify
        >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
        >>> model = identify.load_spec(COATED_PLATE)
        >>> result = identify.fit(model, identify.load_measurements(COATED_PLATE_MEASURED, model))
        >>> steel = result.to_dict()["materials"]["steel"]
        >>> f"E1 = {steel['E1_GPa']:.0f} +- {steel['std']['E1_GPa']:.2f} GPa"
        'E1 = 201 +- 1.55 GPa'
        """
        return to_dict(self)

    def _repr_html_(self) -> str:
        """The notebook view: the report's status box and tables (``report.fit_view``)."""
        return fit_view(self)


__all__ = ["FitStatus", "FitResult", "Iteration"]
