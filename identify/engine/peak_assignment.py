"""What became of every peak of a peak list fitted: the model mode it matched, or left out."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..measurements import Measurements
from .matching import Match


@dataclass(frozen=True)
class PeakAssignment:
    """Every measured peak and what became of it: ``modes`` the model mode (1-based) it
    is matched to, 0 when left out as spurious; ``model_hz`` that mode's frequency, or
    the nearest mode's for a peak left out; ``nearest`` that mode (1-based); ``unseen``
    configuration -> model modes (1-based) inside the measured band no peak matched."""

    measurements: Measurements
    modes: np.ndarray
    model_hz: np.ndarray
    nearest: np.ndarray
    unseen: dict
    by_configuration: dict  # configuration -> its ``Match``

    @property
    def matched(self) -> np.ndarray:
        return self.modes > 0

    def matches(self) -> dict[str, Match]:
        return dict(self.by_configuration)

    def notes(self) -> list[str]:
        table = self.measurements.table
        out = []
        left = np.flatnonzero(~self.matched)
        if left.size:
            listed = "; ".join(
                f"{table['configuration'].iloc[i]} {table['frequency_hz'].iloc[i]:.2f} Hz (nearest mode "
                f"{self.nearest[i]} at {self.model_hz[i]:.2f} Hz, "
                f"{100 * (table['frequency_hz'].iloc[i] / self.model_hz[i] - 1):+.2f} %)"
                for i in left
            )
            out.append(f"left out {left.size} peak(s) that match no model mode (spurious?): {listed}")
        unseen = "; ".join(
            f"{name} mode(s) {', '.join(map(str, modes))}" for name, modes in self.unseen.items() if modes
        )
        if unseen:
            out.append(
                f"model modes inside the measured band with no peak (a node near the sensor?): {unseen}"
            )
        return out


def peak_table(assignment: PeakAssignment) -> pd.DataFrame:
    """Per measured peak: configuration, model mode, measured and model frequency,
    relative error, matched, and why a peak was left out (``note``).  A left-out peak has
    no model mode, so its mode, model frequency and error are None (JSON null, a blank CSV
    cell), never NaN; its note names the nearest mode and how far off it lies."""
    table = assignment.measurements.table
    measured = table["frequency_hz"].to_numpy()
    matched = assignment.matched
    nearest_error = assignment.model_hz / measured - 1

    def where_matched(values):
        return pd.Series(
            [v.item() if m else None for v, m in zip(values, matched, strict=True)], dtype=object
        )

    return pd.DataFrame(
        {
            "configuration": table["configuration"].to_numpy(),
            "mode": where_matched(assignment.modes),
            "measured_hz": measured,
            "model_hz": where_matched(assignment.model_hz),
            "rel_error": where_matched(nearest_error),
            "matched": matched,
            "note": [
                ""
                if m
                else f"left out: matches no model mode (nearest: mode {n} at {f:.2f} Hz, {100 * e:+.2f} %)"
                for m, n, f, e in zip(
                    matched, assignment.nearest, assignment.model_hz, nearest_error, strict=True
                )
            ],
        }
    )


__all__ = ["PeakAssignment", "peak_table"]
