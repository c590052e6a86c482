"""The project's exception family: every user-facing error is a ``ValueError``.

Messages name the field, the value, what is allowed and how to fix it.
"""


class LayerIdError(ValueError):
    """Base class of all errors this tool raises on bad input or bad models."""


class SpecError(LayerIdError):
    """A specimen spec (TOML) is invalid."""


class NotApplicableError(SpecError):
    """An effect has nothing to act on in this spec (e.g. a bond line without bonded
    configurations)."""


class MeasurementError(LayerIdError):
    """A measurement table is invalid or does not match the spec."""


class ModelError(LayerIdError):
    """The model cannot be solved as asked (e.g. rigid-body modes not separated)."""


class DesignError(LayerIdError):
    """A test design cannot be built or scored (e.g. no identified material)."""


class OptionsError(LayerIdError):
    """An option of the model or the fit is out of its range (``ModelOptions``,
    ``FitOptions``)."""


class OutputError(LayerIdError):
    """An output file or report folder cannot be written where asked."""
