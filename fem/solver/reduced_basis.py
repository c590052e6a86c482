"""Reanalysis: a configuration's modes and exact sensitivities at other parameter values,
on the basis of one full solve (Rayleigh-Ritz), in milliseconds instead of a factorization.

Stiffness and mass are affine in the theory's coefficients (the laminate's A, B, D and
shear stiffnesses, or the layerwise stack's generalised ones) and in an attachment's mass
or spring stiffness: ``K = sum_c X_c K_c + K_a``.  On a basis V (the full solve's rigid-
body fields and elastic modes) the unit matrices are projected once
(``UnitMatrices.projections``), and a new parameter point costs a weighted sum of r x r
matrices, one dense eigenproblem of size r and the attachments' few DOFs.

At the basis point the basis holds the exact modes, so the Ritz frequencies and their
derivatives are the full solve's to round-off; away from it they are upper bounds that
converge with the basis.  The sensitivities are the exact derivatives of the Ritz values
(``RitzSolution.energies``: the same modal energies, from the projected units).  The fit
screens trial steps on it (``identify.engine.objective.TrialScreen``), the peak-list
screen searches moduli on it (``identify.engine.peak_screen``) and the point-mass screen
positions (``identify.fitting.point_mass_screen``); each solves what it accepts in full.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg as sla

from ..errors import ModelError
from ..laminates.layerwise import LayerwiseLaminate
from ..model import LaminateSolution, ModelOptions, SpecimenModel, system_coefficients, system_data
from ..specimen import Specimen
from .attachments import projected_attachments
from .modal import Modes
from .sensitivity import ModalEnergies

#: Basis directions whose mass is below this share of the largest are dropped: they repeat
#: others (the modes of two nearby points) or lie in the mass matrix's null space.
INDEPENDENT = 1e-10


class OutsideBasis(ModelError):
    """The parameter point needs another model structure than the basis was built on (a
    layerwise stack whose shear groups or stretching layers changed)."""


@dataclass(frozen=True)
class RitzModes:
    """Ritz pairs as ``Modes``: omega^2 [rad^2/s^2] and the coordinates (r, m) in the
    ``basis`` (n_dofs, r); the full shapes are expanded only when something reads them
    (pairing by shape, an attachment's sensitivities), not for frequencies and the
    laminate's sensitivities."""

    eigenvalues: np.ndarray
    basis: np.ndarray
    coordinates: np.ndarray

    frequencies_hz = Modes.frequencies_hz

    @cached_property
    def shapes(self) -> np.ndarray:
        return self.basis @ self.coordinates


@dataclass(frozen=True)
class RitzSolution(LaminateSolution):
    """A ``LaminateSolution`` whose modes are Ritz pairs (``RitzModes``: coordinates in
    the basis, expanded to full shapes when read); ``projected``: the basis's unit
    matrices, from which the modal energies (and so the sensitivities) follow."""

    projected: tuple[np.ndarray, np.ndarray] | None = None

    @cached_property
    def energies(self) -> ModalEnergies:
        if self.projected is None:  # an assembled reanalysis: from the expanded shapes
            return super().energies
        y = self.modes.coordinates
        stiffness, mass = self.projected
        return ModalEnergies(
            np.einsum("ri,crs,si->ci", y, stiffness, y, optimize=True),
            np.einsum("ri,crs,si->ci", y, mass, y, optimize=True),
        )


@dataclass(frozen=True)
class Reanalysis:
    """One configuration's Rayleigh-Ritz model on the modes of ``base`` (a full solve)
    and the mesh's six rigid-body fields (their Ritz values, the lowest: zero or a
    suspension's, are dropped): an attachment moved or added mixes rigid-body motion into
    the elastic modes, and without those fields a Ritz value may fall below the true one."""

    configuration: str
    options: ModelOptions
    base: LaminateSolution
    basis: np.ndarray  # (n_dofs, r)
    stiffness: np.ndarray | None  # (n_c, r, r) V^T K_c V; None: assembled
    mass: np.ndarray | None  # (n_i, r, r) V^T M_j V; None: assembled

    @classmethod
    def of(
        cls,
        model: SpecimenModel,
        configuration: str,
        extra: np.ndarray | None = None,
        assembled: bool = False,
    ) -> Reanalysis:
        """The reanalysis of ``configuration`` on ``model``'s full solve (cached), its basis
        enlarged by the ``extra`` fields (n_dofs, k), e.g. the modes at another point on
        the same mesh and theory: the basis then spans the modes between the two too.  The
        basis is made mass-orthonormal at ``model``, and directions that carry no mass
        or repeat others (below ``INDEPENDENT`` of the largest) are dropped.

        ``assembled``: no unit matrix is projected; each point's K and M are assembled and
        projected (V^T K V), and its sensitivities come from the expanded shapes.  For a
        few points: projecting the layerwise element's ~180 unit matrices on a basis of
        26 fields costs one to three full solves (1.0-3.4 s against 0.9-2.0 s for a
        sandwich of 12,672 DOFs, measured under load), an assembled point a fraction of
        one (0.06-0.23 s)."""
        base = model.solve(configuration)
        units = base.units
        fields = [units.rigid_body_modes, base.modes.shapes]
        if extra is not None and extra.shape[0] == units.n_dofs:
            fields.append(extra)
        raw = np.hstack(fields)
        coefficients, inertia = _weights(base, base.laminate, base.layerwise)
        if assembled:
            gram = raw.T @ (
                units.matrix(system_data(units, coefficients, inertia, base.attachments)[1]) @ raw
            )
        else:
            stiffness, mass = units.projections(raw)
            gram = np.tensordot(inertia, mass, 1)
            if base.attachments:
                gram = gram + projected_attachments(units, raw, base.attachments)[1]
        mu, q = np.linalg.eigh(gram)
        kept = mu > INDEPENDENT * mu[-1]
        transform = q[:, kept] / np.sqrt(mu[kept])
        if assembled:
            return cls(configuration, model.options, base, raw @ transform, None, None)
        return cls(
            configuration,
            model.options,
            base,
            raw @ transform,
            np.einsum("ra,crs,sb->cab", transform, stiffness, transform, optimize=True),
            np.einsum("ra,crs,sb->cab", transform, mass, transform, optimize=True),
        )

    @property
    def rigid(self) -> int:
        """Rigid-body fields in the basis: as many of the lowest Ritz values are dropped."""
        return self.base.units.rigid_body_modes.shape[1]

    def _system(self, specimen: Specimen) -> tuple[np.ndarray, np.ndarray, LayerwiseLaminate | None]:
        """The projected stiffness and mass (r, r) of the configuration of ``specimen``,
        its attachments included, and its layerwise stack (None for a single layer)."""
        base, options = self.base, self.options
        laminate = specimen.laminate(self.configuration)
        stack = None
        if base.layerwise is not None:
            stack = options.layerwise_stack(laminate)
            if stack.structure != base.layerwise.structure:
                raise OutsideBasis(f"configuration {self.configuration!r}: the layerwise groups changed")
        coefficients, inertia = _weights(base, laminate, stack)
        if self.stiffness is None:
            units, basis = base.units, self.basis
            stiffness, mass = (
                basis.T @ (units.matrix(data) @ basis)
                for data in system_data(units, coefficients, inertia, specimen.attachments)
            )
            return stiffness, mass, stack
        stiffness = np.tensordot(coefficients, self.stiffness, 1)
        mass = np.tensordot(inertia, self.mass, 1)
        if specimen.attachments:
            extra_stiffness, extra_mass = projected_attachments(base.units, self.basis, specimen.attachments)
            stiffness, mass = stiffness + extra_stiffness, mass + extra_mass
        return stiffness, mass, stack

    def matrices(self, specimen: Specimen) -> tuple[np.ndarray, np.ndarray]:
        """The projected stiffness and mass (r, r) of the configuration of ``specimen``."""
        return self._system(specimen)[:2]

    @property
    def _elastic(self) -> slice:
        """The elastic Ritz values: past the rigid-body ones, as many as the full solve kept."""
        return slice(self.rigid, self.rigid + len(self.base.modes.eigenvalues))

    def frequencies_hz(self, specimen: Specimen) -> np.ndarray:
        """The Ritz frequencies [Hz] alone (no shapes): a screen's thousands of points."""
        stiffness, mass, _ = self._system(specimen)
        eigenvalues = sla.eigh(stiffness, mass, eigvals_only=True, check_finite=False)[self._elastic]
        return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2 * np.pi)

    def solve(self, specimen: Specimen) -> RitzSolution:
        """The Ritz modes of the configuration of ``specimen`` (same mesh and theory as the
        basis), as many as the full solve kept."""
        base = self.base
        stiffness, mass, stack = self._system(specimen)
        eigenvalues, coordinates = sla.eigh(stiffness, mass, check_finite=False)
        eigenvalues, coordinates = eigenvalues[self._elastic], coordinates[:, self._elastic]
        return RitzSolution(
            specimen.laminate(self.configuration),
            base.units,
            RitzModes(eigenvalues, self.basis, coordinates),
            base.inertia_terms,
            base.transverse_shear,
            specimen.attachments,
            stack,
            projected=None if self.stiffness is None else (self.stiffness, self.mass),
        )


def _weights(
    base: LaminateSolution, laminate, stack: LayerwiseLaminate | None
) -> tuple[np.ndarray, np.ndarray]:
    """The weights of the unit stiffness and mass matrices of ``base``'s theory for
    ``laminate``: its layerwise ``stack``'s generalised coefficients, else the single-layer
    theory's (``system_coefficients``)."""
    if stack is not None:
        return stack.stiffness, stack.inertia
    return system_coefficients(laminate, base.transverse_shear, base.inertia_terms)


__all__ = ["OutsideBasis", "Reanalysis", "RitzSolution"]
