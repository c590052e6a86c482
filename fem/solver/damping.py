"""Modal loss factors to first order: the modal strain energy method.

With complex moduli p (1 + i eta_p) and light damping, each mode's loss factor is the
strain-energy-weighted sum of the moduli's loss factors,

    eta_i = sum_p eta_p d ln(lambda_i) / d ln(p)        (lambda = omega^2),

the weights being the relative eigenvalue sensitivities ``fem.solver.sensitivity`` computes
exactly (Ungar and Kerwin 1962; Johnson and Kienholz 1982, AIAA J. 20:1284).  For moduli
homogeneous of degree one in (E1, E2, G12) the weights of one material sum to that
material's share of the strain energy, so a plate of one material with one eta has
eta_i = eta for every mode.  The error is O(eta^2): ``fem.solver.complex_modes`` solves the
complex eigenproblem to check it.

Which moduli carry which loss factor: ``eta_E1`` E1, ``eta_E2`` E2, ``eta_G12`` G12 and,
in the transverse-shear and layerwise models, the transverse shear moduli G13 and G23
too (a G13 or G23 not given follows G12 already; a given one is added to eta_G12's
weight).  ``eta`` is one loss factor for all of them.  The layerwise model's through-
thickness modulus E3 is taken as elastic.
"""

from __future__ import annotations

import numpy as np

from ..laminates.material import LOSS_FACTORS, SHEAR_MODULI, Material
from ..model import SpecimenModel
from ..specimen import Parameter

#: Modes whose eigenvalues differ (relatively) by less than this times their loss factor
#: are mixed by damping: only their lambda-weighted sum follows the layers' loss factors
#: (``fem.solver.complex_modes``); and never less than ``CLOSE_FLOOR`` (degenerate to rounding).
CLOSE_FACTOR = 2.0
CLOSE_FLOOR = 1e-6
#: The moduli whose loss factor a damping parameter is (transverse shear moduli added
#: where the model has them, ``moduli_of``).
MODULI = {"eta_E1": ("E1",), "eta_E2": ("E2",), "eta_G12": ("G12",), "eta": ("E1", "E2", "G12")}


def moduli_of(model: SpecimenModel, material: Material, kind: str) -> tuple[str, ...]:
    """The moduli of ``material`` whose loss factor the damping parameter ``kind`` is."""
    moduli = MODULI[kind]
    shear_model = model.options.transverse_shear or model.options.theory == "layerwise"
    if shear_model and "G12" in moduli:
        moduli += tuple(g for g in SHEAR_MODULI if g not in material.defaulted_shear_moduli)
    return moduli


def loss_columns(model: SpecimenModel, targets: list[tuple[str, str]]) -> np.ndarray:
    """d eta_i / d eta_p: (modes of every configuration stacked, targets), rows as
    ``SpecimenModel.sensitivity_matrix``.  targets: (material name, damping parameter:
    one of ``fem.laminates.material.DAMPING_PARAMETERS``); a material a configuration lacks gives 0."""
    materials = model.specimen.materials
    parameters, where = [], []
    for name, kind in targets:
        where.append([])
        for modulus in moduli_of(model, materials[name], kind):
            p = Parameter(modulus, name)
            if p not in parameters:
                parameters.append(p)
            where[-1].append(parameters.index(p))
    # (p/f) df/dp = (1/2) d ln(lambda) / d ln(p)
    relative = 2 * model.sensitivity_matrix(parameters) if parameters else np.zeros((0, 0))
    return np.stack([relative[:, w].sum(axis=1) for w in where], axis=1) if targets else relative[:, :0]


def known_targets(model: SpecimenModel) -> list[tuple[str, str]]:
    """(material, loss factor) of every loss factor that is not identified, every material."""
    return [
        (m.name, kind)
        for m in model.specimen.materials.values()
        for kind in LOSS_FACTORS
        if kind not in m.identify_damping and "eta" not in m.identify_damping
    ]


def first_order_loss_factors(model: SpecimenModel) -> dict[str, np.ndarray]:
    """Every configuration's modal loss factors [-] to first order, from the loss
    factors its materials carry (not given = 0)."""
    materials = model.specimen.materials
    targets = [(m.name, kind) for m in materials.values() for kind in LOSS_FACTORS if m.loss_factor(kind)]
    n = model.options.modes
    if not targets:
        return {c.name: np.zeros(n) for c in model.specimen.configurations}
    etas = np.array([materials[name].loss_factor(kind) for name, kind in targets])
    stacked = loss_columns(model, targets) @ etas
    return {c.name: stacked[k * n : (k + 1) * n] for k, c in enumerate(model.specimen.configurations)}


def loss_from_ratio(zeta):
    """The loss factor eta [-] of a pole with damping ratio zeta [-]: a pole of
    lambda* = omega^2 (1 + i eta) has zeta = sin(arctan(eta) / 2), so eta = tan(2 arcsin zeta)
    (2 zeta for light damping; 0.1 % apart at zeta = 0.02)."""
    return np.tan(2 * np.arcsin(zeta))


def ratio_from_loss(eta):
    """The damping ratio zeta [-] of a pole whose loss factor is eta [-]."""
    return np.sin(np.arctan(eta) / 2)


def loss_slope(zeta):
    """d eta / d zeta of ``loss_from_ratio`` [-] (2 for light damping): carries a damping
    ratio's std over to the loss factor."""
    return 2 / (np.cos(2 * np.arcsin(zeta)) * np.sqrt(1 - zeta**2))


def close_groups(eigenvalues: np.ndarray, loss: np.ndarray) -> list[list[int]]:
    """Indices of the modes (ascending eigenvalues) in groups that damping mixes: a chain of
    neighbours closer than ``CLOSE_FACTOR`` x the larger loss factor (``CLOSE_FLOOR`` at least)."""
    groups = [[0]]
    for i in range(1, len(eigenvalues)):
        gap = max(CLOSE_FLOOR, CLOSE_FACTOR * max(loss[i], loss[i - 1])) * eigenvalues[i]
        if eigenvalues[i] - eigenvalues[i - 1] < gap:
            groups[-1].append(i)
        else:
            groups.append([i])
    return groups
