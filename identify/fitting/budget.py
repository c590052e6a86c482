"""The uncertainty budget of an identification (GUM, linear propagation): how much each
known input's standard uncertainty (moduli, densities and thicknesses of the known
layers, the plate's size and weighed mass; ``fem.inputs``) and the measurement scatter
contribute to each identified property.

The identified values minimise the weighted misfit r(theta, beta) over theta with the
known inputs beta held at their nominal values.  To first order a change d beta moves
the solution by d theta = G d beta, G = -J_theta^+ J_beta (J: derivatives of the weighted
residuals, ^+ the pseudo-inverse), so the inputs add G diag(u_beta^2) G^T to the
covariance.  J_beta uses the model's exact sensitivities for material properties and
thicknesses, the chain rule for the plate's mass (its layers' densities scale with it),
and central differences of the plate's length and width (a new mesh each way).

A layer's angle is different: where the laminate is symmetric about the plate's axes the
frequencies are even in it (the plate turned by -u is its mirror image turned by +u, and
is not solved again), so the first-order column vanishes and a misalignment only
ever moves the properties one way (a fabric skin 5 deg off: G12 12 std off).  Its part is
taken to second order over a normal angle error theta ~ N(0, u^2): with d1 = (f(+u) -
f(-u)) / 2 and d2 = (f(+u) + f(-u) - 2 f(0)) / 2, df = f' theta + f'' theta^2 / 2 has the
mean square (G d1)^2 + 3 (G d2)^2 in each property (E theta^4 = 3 u^4), entered as two
inputs: the angle (column d1 / u) and its second order (column sqrt(3) d2 / u).

The plate theory itself is an input too: a shear-deformable theory's frequencies carry
its own error against 3-D elasticity (``ModelOptions.theory_std_rel``, a relative std
measured on the 3-D references), taken as independent per mode, so it adds
G diag((u f_i / sigma_i)^2) G^T with G = J_theta^+ (``with_theory_accuracy``, through
``uncertainty.row_scatter_covariance``, as a merged peak's scatter).  It
widens the reported std only: the diagnosis's decisions read the measurements' scatter.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from fem.inputs import ANGLE, ANGLE_SECOND_ORDER, GEOMETRY, MASS, InputStd
from fem.specimen import Parameter

from ..engine.objective import Objective
from ..engine.parameters import UNITS, display
from ..engine.uncertainty import row_scatter_covariance

#: Relative step of the central differences in the plate's length and width: the
#: frequency error is O(step^2) ~ 1e-8, far below any input's effect.
GEOMETRY_STEP = 1e-4


@dataclass(frozen=True)
class Budget:
    """parameters: the identified ones; inputs: the known inputs with their std;
    measurement_std: each parameter's std from the measurement scatter [SI];
    sensitivity: d theta_i / d beta_j [SI per SI] (parameters x inputs)."""

    parameters: tuple[Parameter, ...]
    inputs: tuple[InputStd, ...]
    measurement_std: np.ndarray
    sensitivity: np.ndarray
    # The plate theory's part (``with_theory_accuracy``): its relative frequency std and
    # the covariance it adds [SI^2]; 0 and None for a thin-plate model.
    theory_std_rel: float = 0.0
    theory_covariance: np.ndarray | None = None

    @property
    def contributions(self) -> np.ndarray:
        """|d theta_i / d beta_j| u_j: each input's share of each parameter's std [SI]."""
        return np.abs(self.sensitivity) * np.array([i.std for i in self.inputs])[None, :]

    @property
    def covariance(self) -> np.ndarray:
        """The inputs' part of the parameters' covariance [SI^2]."""
        u2 = np.array([i.std for i in self.inputs]) ** 2
        return (self.sensitivity * u2[None, :]) @ self.sensitivity.T

    @property
    def theory_std(self) -> np.ndarray:
        """The plate theory's share of each parameter's std [SI] (zeros for a thin plate)."""
        if self.theory_covariance is None:
            return np.zeros(len(self.parameters))
        return np.sqrt(np.diag(self.theory_covariance))

    @property
    def total_std(self) -> np.ndarray:
        """Measurement, inputs and the theory together [SI] (independent contributions)."""
        return np.sqrt(self.measurement_std**2 + np.sum(self.contributions**2, axis=1) + self.theory_std**2)

    def table(self) -> pd.DataFrame:
        """One row per parameter in display units: value's std from the measurements,
        from each input, and the total (and the unit)."""
        rows = []
        for i, p in enumerate(self.parameters):
            row = {
                "parameter": p.name,
                "unit": UNITS[p.kind][0],
                "measurement": display(p, self.measurement_std[i]),
            }
            row.update({f"{u.name}": display(p, c) for u, c in zip(self.inputs, self.contributions[i])})
            if self.theory_covariance is not None:
                row["theory vs 3-D"] = display(p, self.theory_std[i])
            row["total"] = display(p, self.total_std[i])
            rows.append(row)
        return pd.DataFrame(rows)

    def to_dict(self) -> dict:
        return {
            "inputs": [{"input": u.name, "std_si": u.std} for u in self.inputs],
            "theory_std_rel": self.theory_std_rel,
            "table": self.table().to_dict(orient="records"),
        }


def _input_columns(objective: Objective, e, inputs) -> np.ndarray:
    """d (model frequency) / d beta_j of the paired rows [Hz per SI unit] (rows x inputs)."""
    model = objective.solved.with_specimen(e.model.specimen)
    out = np.zeros((len(objective.measured_hz), len(inputs)))
    specimen = model.specimen
    # Where the plate's mirror image about y = W/2 with every angle negated is the plate
    # itself (every ply at 0 or 90 deg, a sensor on the mid-line, springs in mirrored
    # pairs), a ply turned by -u is the image of the plate with it turned by +u: the same
    # frequencies, so -u is not solved (the first-order column is then exactly zero).
    mirrored = specimen.maps_onto_itself(flip_x=False, flip_y=True, negate=True)
    for name in objective.configurations:
        rows = objective.rows[name]
        indices = e.pairings[name].indices
        solution = model.solve(name)
        turned = {}  # layer -> the frequencies with its angle at +u and -u (both parts of the angle use them)
        for j, u in enumerate(inputs):
            if u.kind in (ANGLE, ANGLE_SECOND_ORDER):
                if u.target not in turned:
                    plus = _turned(model, u.target, u.std, name)[indices]
                    turned[u.target] = (
                        plus,
                        plus if mirrored else _turned(model, u.target, -u.std, name)[indices],
                    )
                plus, minus = turned[u.target]
                out[rows, j] = (
                    (plus - minus) / 2
                    if u.kind == ANGLE
                    else np.sqrt(3) * (plus + minus - 2 * solution.frequencies_hz[indices]) / 2
                ) / u.std
            elif u.kind in GEOMETRY:
                size = getattr(specimen, u.kind)
                f = [
                    model.with_specimen(replace(specimen, **{u.kind: size * (1 + s * GEOMETRY_STEP)}))
                    .solve(name)
                    .frequencies_hz[indices]
                    for s in (1, -1)
                ]
                out[rows, j] = (f[0] - f[1]) / (2 * GEOMETRY_STEP * size)
            elif u.kind == MASS:
                # Every specimen layer's density scales with the weighed mass: d rho_k / d m = rho_k / m.
                own = {layer.material.name: layer.material.density for layer in specimen.layers}
                mass = (
                    specimen.laminate(specimen.configurations[0].name).inertia[0]
                    * specimen.length
                    * specimen.width
                )
                d = solution.derivatives([Parameter("density", m) for m in own])[indices]
                out[rows, j] = d @ (np.array(list(own.values())) / mass)
            else:
                out[rows, j] = solution.derivatives([Parameter(u.kind, u.target)])[indices, 0]
    return out


def _turned(model, layer: str, turn: float, configuration: str) -> np.ndarray:
    """The frequencies [Hz] of ``configuration`` with ``layer``'s angle turned by ``turn`` [rad]."""
    p = Parameter(ANGLE, layer)
    return model.with_values({p: model.value(p) + turn}).solve(configuration).frequencies_hz


def _with_second_orders(inputs: tuple[InputStd, ...]) -> tuple[InputStd, ...]:
    """Each layer angle followed by its second-order part (the module doc)."""
    out = []
    for u in inputs:
        out.append(u)
        if u.kind == ANGLE:
            out.append(InputStd(ANGLE_SECOND_ORDER, u.target, u.std))
    return tuple(out)


def uncertainty_budget(result, consider: tuple[InputStd, ...] = ()) -> Budget | None:
    """The budget of a finished fit whose model states known inputs' std, or that holds
    properties at uncertain values (``consider``: "consider" parameters, e.g. a layer
    property held at a handbook value); None when there are none.  An input the fit
    identifies (a thickness or an angle an effect freed) is not an input."""
    identified = {(p.kind, p.target) for p in result.parameters}
    inputs = _with_second_orders(
        tuple(
            u for u in tuple(result.model.input_std) + tuple(consider) if (u.kind, u.target) not in identified
        )
    )
    if not inputs or not result.finished or not np.all(np.isfinite(result.uncertainty.std)):
        return None
    objective = Objective(result.model, result.measurements, result.parameters)
    e = objective.evaluate(result.values, result.pairings, track=False)
    weighted_theta = e.derivatives / objective.sigma[:, None]
    weighted_beta = _input_columns(objective, e, inputs) / objective.sigma[:, None]
    sensitivity = -np.linalg.pinv(weighted_theta) @ weighted_beta
    return Budget(result.parameters, inputs, result.uncertainty.std.copy(), sensitivity)


def with_budget(result, consider: tuple[InputStd, ...] = ()):
    """The result with its budget (the known inputs and the ``consider`` ones), and its
    uncertainty widened by the inputs' part; as it is when it already has one (a held
    property's scatter is added where it is held, before ``fit`` adds the known inputs)."""
    budget = None if result.budget is not None else uncertainty_budget(result, consider)
    if budget is None:
        return result
    return replace(result, budget=budget, uncertainty=result.uncertainty.with_covariance(budget.covariance))


def with_theory_accuracy(result):
    """The result with its plate theory's own error in the std (the module doc), added to
    its budget (one is made when it has none); as it is for a thin-plate model, an
    unfinished fit, undefined std or a budget that already holds the theory's part, and
    where the scatter is the misfit's own (estimated from the residuals, or the stated one
    inflated by them): the theory's error is then in it already."""
    u = result.model.options.theory_std_rel
    budget = result.budget
    statistics = result.statistics
    if (
        u == 0
        or not statistics.scatter_known
        or statistics.inflated
        or (budget is not None and budget.theory_covariance is not None)
        or not result.finished
        or not np.all(np.isfinite(result.uncertainty.std))
    ):
        return result
    objective = Objective(result.model, result.measurements, result.parameters)
    e = objective.evaluate(result.values, result.pairings, track=False)
    covariance = row_scatter_covariance(objective, e, (u * objective.measured_hz / objective.sigma) ** 2)
    if budget is None:
        p = len(result.parameters)
        budget = Budget(result.parameters, (), result.uncertainty.std.copy(), np.zeros((p, 0)))
    budget = replace(budget, theory_std_rel=u, theory_covariance=covariance)
    return replace(result, budget=budget, uncertainty=result.uncertainty.with_covariance(covariance))


__all__ = ["Budget", "uncertainty_budget", "with_budget", "with_theory_accuracy"]
