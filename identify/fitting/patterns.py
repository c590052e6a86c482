"""Residual signatures that point at missing physics, scored against a fit.

After the layer properties are fitted (or at the spec's values), the relative errors
e = model / measured - 1 of all configurations are tested against the signatures of
the effects a Kirchhoff free-plate model leaves out:

- growing with the mode's wavenumber (q = f / f_1 of its configuration, ~ k^2):
  transverse shear and rotary inertia soften short waves (model too stiff);
- following the squared mode amplitude at one point, e = c phi(x, y)^2 with
  mass-normalised shapes: a point mass there lowers every frequency by
  df/f = -m phi^2 / 2 (a sensor, a glue blob), so c estimates m / 2;
- largest in the lowest modes, e = a + b / q^2: springs in the suspension raise low
  frequencies most (df/f = k w^2 / (2 omega^2));
- only in bonded configurations: the adhesive or the added plates are off.

Each signature is scored by the share of the weighted misfit it explains beyond what
the fitted layer properties can absorb (a score test: its columns are projected on the
complement of the fit's Jacobian).

Measured mode shapes carry a sharper signature of a point mass (``shape_point_map``): a
mass m at s turns mode i towards the others by, to first order,

    d phi_i = m sum_j omega_i^2 phi_j(s) phi_i(s) / (omega_j^2 - omega_i^2) phi_j

(mass-normalised modes), a pattern centred on s.  What of each measured shape its
paired model mode and the modes close to it cannot reproduce is scored against that
pattern at every node; the best node is where the shapes say a mass sits, with an
estimate of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.model import SpecimenModel

from ..engine.pairing import close_modes, shape_at_points
from ..measurements import Measurements

#: A signature explaining more than this share of the misfit is reported as present.
PATTERN_SHARE = 0.5
#: A signature whose part outside the fit's Jacobian is below this fraction of it is
#: absorbed by the layer properties (what is left is round-off).
ABSORBED = 1e-8
#: Distinct start positions the diagnosis tries for a point mass.
POINT_MASS_STARTS = 4
#: Model modes summed in the shape signature of a point mass (the first-order shape
#: change is a sum over the other modes; on the paper's plate 20 and 40 put the mass at
#: the same node, 11 mm from the truth, on a 5 x 4 grid).
SHAPE_SIGNATURE_MODES = 30
#: A position elsewhere whose share of the shapes' residual reaches this fraction of the
#: best one's is reported as a rival: the shapes do not tell the two apart.
RIVAL_SHARE = 0.9


@dataclass(frozen=True)
class ShapePointMap:
    """Per node of the model's mesh (``xy`` [m]): the share of the measured shapes'
    residual a point mass there explains (0 where the mass it would need is negative),
    and that mass [kg]."""

    xy: np.ndarray
    share: np.ndarray
    mass_kg: np.ndarray

    @property
    def best(self) -> int:
        return int(np.argmax(self.share))

    def rivals(self, span: float = 0.2) -> list[np.ndarray]:
        """Nodes [m] at least ``span`` of the plate's size from the best that score
        ``RIVAL_SHARE`` of its share or more: positions the shapes do not tell apart from it
        (on a symmetric plate, often the best one's mirror image, at 1 % shape noise on a
        5 x 4 grid in 2 of 10 seeds)."""
        best = self.xy[self.best]
        size = np.ptp(self.xy, axis=0).max()
        far = np.hypot(*(self.xy - best).T) > span * size
        out = []
        for k in np.argsort(-self.share):
            if self.share[k] < RIVAL_SHARE * self.share[self.best]:
                break
            if far[k] and all(np.hypot(*(self.xy[k] - p)) > span * size for p in out):
                out.append(self.xy[k])
        return out

    def hint(self) -> dict:
        """The best node as a point-mass start (``from_shapes``: ahead of the frequency scan's)."""
        k = self.best
        return {
            "xy": tuple(self.xy[k]),
            "mass_kg": float(self.mass_kg[k]),
            "share": float(self.share[k]),
            "from_shapes": True,
        }


def shape_point_map(model: SpecimenModel, measurements: Measurements, pairings) -> ShapePointMap | None:
    """Where a point mass would explain the measured shapes' residuals (module
    docstring), on ``model`` as the fit solved it with ``SHAPE_SIGNATURE_MODES`` modes;
    None without measured shapes (or when no residual is left)."""
    if measurements.shapes is None:
        return None
    solver = model.with_options(modes=max(SHAPE_SIGNATURE_MODES, model.options.modes))
    explained = weight = residual2 = 0.0
    xy = None
    for name, pairing in pairings.items():
        rows = measurements.of(name)
        solution = solver.solve(name)
        units, lam = solution.units, solution.modes.eigenvalues
        xy = units.mesh.node_xy
        w_index = units.element_type.NODE_DOFS.index("w")
        at_nodes = solution.modes.shapes.reshape(units.mesh.n_nodes, -1, len(lam))[:, w_index, :]
        for shape, i in zip(measurements.shapes_of(rows), pairing.indices):
            if shape is None:
                continue
            at_points = shape_at_points(solution, shape)
            a = shape.amplitude / np.linalg.norm(shape.amplitude)  # every mode weighs alike
            close = np.union1d([i], close_modes(solution, i))
            basis = np.linalg.qr(at_points[:, close])[0]
            r = a - basis @ (basis.T @ a)
            scale = np.vdot(at_points[:, i], a) / np.vdot(at_points[:, i], at_points[:, i])
            others = np.setdiff1d(np.arange(len(lam)), close)
            # (nodes, others) [1/kg]
            coupling = lam[i] * at_nodes[:, others] * at_nodes[:, [i]] / (lam[others] - lam[i])
            pattern = scale * coupling @ (at_points[:, others] - basis @ (basis.T @ at_points[:, others])).T
            explained = explained + (pattern.conj() @ r).real
            weight = weight + np.sum(np.abs(pattern) ** 2, axis=1)
            residual2 += np.vdot(r, r).real
    if xy is None or residual2 <= 0:
        return None
    mass = explained / np.where(weight > 0, weight, np.inf)
    share = np.where(mass > 0, explained**2 / (np.where(weight > 0, weight, np.inf) * residual2), 0.0)
    return ShapePointMap(xy, share, mass)


@dataclass(frozen=True)
class Pattern:
    """A residual signature: the share of the misfit it explains and what it suggests."""

    name: str
    share: float
    detail: str
    suggests: tuple[str, ...]


class ScoreTest:
    """Share of the weighted misfit a signature explains beyond what the fitted layer
    properties can absorb: the signature columns are projected onto the complement of the
    baseline Jacobian before the least-squares fit (a score test for the missing term)."""

    def __init__(self, e: np.ndarray, weight: np.ndarray, jacobian: np.ndarray | None):
        self.weight = weight
        self.r = e * weight
        self.total = float(self.r @ self.r)
        self.q = np.linalg.qr(jacobian)[0] if jacobian is not None and jacobian.size else None

    def __call__(self, columns: np.ndarray) -> tuple[float, np.ndarray]:
        weighted = columns * self.weight[:, None]
        b = weighted
        if self.q is not None:
            b = weighted - self.q @ (self.q.T @ weighted)
            # A signature the layer properties reproduce leaves only round-off: it explains nothing.
            absorbed = np.linalg.norm(b, axis=0) <= ABSORBED * np.linalg.norm(weighted, axis=0)
            b = np.where(absorbed[None, :], 0.0, b)
        coef, *_ = np.linalg.lstsq(b, self.r, rcond=None)
        explained = b @ coef
        return (float(explained @ explained) / self.total if self.total > 0 else 0.0), coef


def residual_patterns(
    model: SpecimenModel,
    measurements: Measurements,
    model_hz: np.ndarray,
    pairings=None,
    jacobian: np.ndarray | None = None,
):
    """Score every signature of the residuals of ``model`` (solved as the fit solved it);
    returns (patterns, per-node share map of the point signature, node coordinates,
    point-mass hints best first, the measured shapes' point-mass map or None)."""
    specimen = model.specimen
    table = measurements.table
    measured = table["frequency_hz"].to_numpy()
    e = model_hz / measured - 1
    sigma_rel = (table["std_hz"].to_numpy() / measured) if measurements.has_std else np.ones_like(e)
    score = ScoreTest(e, 1 / sigma_rel, jacobian)
    configs = table["configuration"].to_numpy()
    q = np.empty_like(e)
    for name in measurements.configurations:
        rows = configs == name
        q[rows] = measured[rows] / measured[rows].min()
    patterns = []
    share, coef = score(q[:, None])
    patterns.append(
        Pattern(
            "grows with wavenumber",
            share if coef[0] > 0 else 0.0,
            f"{coef[0]:+.2e} per unit f/f1 (model stiffer for short waves if > 0)",
            ("transverse_shear", "rotary_inertia"),
        )
    )
    share, coef = score((1 / q**2)[:, None])
    patterns.append(
        Pattern(
            "largest in the lowest modes",
            share if coef[0] < 0 else 0.0,
            f"{coef[0]:+.2e} x (f1/f)^2 (model too soft at low modes if < 0)",
            ("suspension",),
        )
    )
    bonded = np.array([not specimen.configuration(c).is_original for c in configs])
    if bonded.any() and (~bonded).any():
        share, _ = score(bonded[:, None].astype(float))
        ratio = float(np.mean((score.r[bonded]) ** 2) / max(np.mean(score.r[~bonded] ** 2), 1e-300))
        patterns.append(
            Pattern(
                "only in bonded configurations",
                share if ratio > 4 else 0.0,
                f"mean squared error bonded / original = {ratio:.3g}",
                ("adhesive", "thickness"),
            )
        )
    # Point-mass signature: e = (m / 2) phi(x, y)^2, scanned over every node.
    phi2 = []
    for name in measurements.configurations:
        solution = model.solve(name)
        group = table[configs == name]
        units = solution.units
        w_index = units.element_type.NODE_DOFS.index("w")
        shapes = solution.modes.shapes.reshape(units.mesh.n_nodes, -1, solution.modes.shapes.shape[1])[
            :, w_index, :
        ]
        indices = pairings[name].indices if pairings else group["mode"].to_numpy() - 1
        phi2.append(shapes[:, indices].T ** 2)  # (rows, nodes) [1/kg]
    phi2 = np.vstack(phi2)
    fits = [score(phi2[:, k : k + 1]) for k in range(phi2.shape[1])]
    shares = np.array([f[0] if f[1][0] > 0 else 0.0 for f in fits])
    masses = np.array([2 * f[1][0] for f in fits])
    xy = model.mesh.node_xy
    span = max(specimen.length, specimen.width)
    # Distinct start positions: on a plate symmetric about its centre lines, mirrored
    # points are equivalent, so positions are compared folded into one quarter.
    folded = np.abs(xy - np.array([specimen.length, specimen.width]) / 2)
    hints, chosen = [], []
    for k in np.argsort(-shares):
        if shares[k] <= 0 or len(hints) == POINT_MASS_STARTS:
            break
        if all(np.hypot(*(folded[k] - folded[j])) > 0.2 * span for j in chosen):
            chosen.append(k)
            hints.append({"xy": tuple(xy[k]), "mass_kg": float(masses[k]), "share": float(shares[k])})
    by_shapes = shape_point_map(model, measurements, pairings) if pairings else None
    if by_shapes is not None:
        hints.insert(0, by_shapes.hint())
        x, y = 1e3 * by_shapes.xy[by_shapes.best]
        rivals = by_shapes.rivals()
        elsewhere = "; ".join(f"({1e3 * p[0]:.0f}, {1e3 * p[1]:.0f}) mm" for p in rivals)
        patterns.append(
            Pattern(
                "shapes pulled towards one point",
                float(by_shapes.share[by_shapes.best]),
                f"best at x = {x:.0f} mm, y = {y:.0f} mm, about "
                f"{1e3 * by_shapes.mass_kg[by_shapes.best]:.2g} g there (measured shapes)"
                + (f"; about as good at {elsewhere}" if rivals else ""),
                ("point_mass",),
            )
        )
    best = int(np.argmax(shares))
    equivalent = int(np.sum(shares > shares[best] - 0.01))
    patterns.append(
        Pattern(
            "follows one point's mode amplitude",
            float(shares[best]),
            f"best at x = {1e3 * xy[best, 0]:.0f} mm, y = {1e3 * xy[best, 1]:.0f} mm "
            f"({equivalent} points about as good), about {1e3 * masses[best]:.2g} g there",
            ("point_mass",),
        )
    )
    return tuple(patterns), shares, xy, hints, by_shapes


__all__ = [
    "Pattern",
    "ScoreTest",
    "ShapePointMap",
    "residual_patterns",
    "shape_point_map",
    "PATTERN_SHARE",
    "ABSORBED",
    "POINT_MASS_STARTS",
]
