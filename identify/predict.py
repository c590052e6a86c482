"""``predict``: the elastic frequencies of every configuration of a model."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from fem.model import MAX_MODES, SpecimenModel
from fem.validation import whole

from .reporting import html_report as h

if TYPE_CHECKING:
    import pandas as pd


@dataclass(frozen=True)
class Prediction:
    """Per configuration the first elastic frequencies [Hz] and the modes' nodal-line
    labels, computed with ``model`` (its options: mesh, plate theory, effects)."""

    model: SpecimenModel
    frequencies_hz: dict[str, np.ndarray]
    labels: dict[str, tuple[str, ...]]

    def to_dict(self) -> dict:
        """The ``predict --json`` document."""
        return {
            "configurations": [
                {"name": name, "frequencies_hz": f.round(4), "labels": list(self.labels[name])}
                for name, f in self.frequencies_hz.items()
            ]
        }

    def report(self) -> str:
        model, mesh = self.model, self.model.mesh
        options = model.options
        if options.theory == "layerwise":
            theory = "layerwise (zig-zag) plate"
        else:
            theory = (
                ("first-order shear deformation" if options.transverse_shear else "Kirchhoff")
                + " plate"
                + (" with rotary inertia" if options.rotary_inertia else "")
            )
        lines = [
            f"{model.name}: first {model.options.modes} elastic modes ({theory}, {mesh.nx} x {mesh.ny} "
            "elements"
            f"{', graded towards the edges' if mesh.x_nodes else ''})"
        ]
        if model.effects:
            lines.append(f"with the spec's effects: {', '.join(model.effects)}")
        lines += [f"note: {n}" for n in model.notes]
        lines.append("mode  " + "".join(f"{name:>24s}" for name in self.frequencies_hz))
        for i in range(model.options.modes):
            cells = "".join(
                f"{f[i]:>14.3f} Hz {self.labels[n][i]:>6s}" for n, f in self.frequencies_hz.items()
            )
            lines.append(f"{i + 1:>4d}  {cells}")
        return "\n".join(lines)

    def table(self) -> pd.DataFrame:
        """One row per mode: per configuration its frequency [Hz] and nodal-line label."""
        import pandas as pd  # here: ``predict`` on the command line needs no pandas

        columns = {"mode": np.arange(1, self.model.options.modes + 1)}
        for name, f in self.frequencies_hz.items():
            columns[f"{name} [Hz]"] = f
            columns[f"{name} label"] = self.labels[name]
        return pd.DataFrame(columns)

    def _repr_html_(self) -> str:
        """The notebook view: the frequency table, drawn by the HTML report's code."""
        title = self.report().splitlines()[0]
        return h.view(self.model.name, None, [(title, h.table(self.table(), "{:.3f}"))])


def predict(model: SpecimenModel, modes: int | None = None) -> Prediction:
    """The first ``modes`` elastic frequencies of every configuration.

    The frequencies are computed with the model's options (mesh, plate theory) and the
    spec's fixed effects.

    Parameters
    ----------
    model : SpecimenModel
        The model (``fem.load_spec``).
    modes : int, optional
        How many elastic modes, from 1 to ``MAX_MODES`` (60); default (None): the model's
        ``[model] modes``.

    Returns
    -------
    Prediction
        Per configuration the frequencies [Hz] and the modes' nodal-line labels.

    Raises
    ------
    SpecError
        ``modes`` is not a whole number from 1 to 60.

    Examples
    --------
    >>> import identify
    >>> from identify.examples import COATED_PLATE
    >>> prediction = identify.predict(identify.load_spec(COATED_PLATE), modes=2)
    >>> prediction.frequencies_hz["original"].round(0)  # Hz
    array([148., 234.])
    >>> prediction.labels["original"]
    ('(1,1)', '(0,2)-(2,0)')
    """
    if modes is not None:
        model = model.with_options(modes=whole(modes, "--modes", 1, MAX_MODES, ""))
    solutions = {c.name: model.solve(c.name) for c in model.specimen.configurations}
    return Prediction(
        model,
        {n: s.frequencies_hz for n, s in solutions.items()},
        {n: s.labels for n, s in solutions.items()},
    )


__all__ = ["Prediction", "predict"]
