"""When the updating stops, and why: the update loop's constants, named in one place,
and the stop reason kept on every fit result (``FitResult.stop``, ``"stop_reason"`` in
the fit JSON)."""

from __future__ import annotations

from enum import Enum

#: The updating stops once the misfit has stalled (falls by less than this fraction) and
#: no parameter moves by more than STEP_PER_STD of its std.
STALLED = 1e-4
STEP_PER_STD = 0.01
#: Steps the ``FitOptions.stall_chi2`` test looks back over.
STALL_ITERATIONS = 3
#: A parameter whose std in z reaches this is not determined by the data (a modulus
#: +- 100 %, nu12 +- 1): what the stated scatter allows spans every plausible value.
UNDETERMINED_Z = 1.0
#: A parameter this close to a bound in z (relative for log parameters) is on it.
BOUND_TOLERANCE = 1e-9
#: Relative step size below which a step counts as zero (guards a division by it).
TINY_STEP = 1e-300
#: Halvings of a step that leaves the physical bounds (nu12^2 < E1/E2, on the plate)
#: before it is damped instead.
ADMISSIBLE_HALVINGS = 30
#: Levenberg-Marquardt damping: the first one, relative to the largest squared singular
#: value of the Jacobian; the factor it grows by after a rejected step and shrinks by
#: after an accepted one; below ``UNDAMPED`` (relative) it is dropped (back to Gauss-Newton).
FIRST_DAMPING = 1e-6
DAMPING_FACTOR = 10.0
UNDAMPED = 1e-9
#: The model reproduces the measurements exactly below this RMS relative error.
EXACT_RMS = 1e-11
#: The misfit is flat only when the largest step (in z) is below this as well.
FLAT_STEP = 1e-4
#: A decrease of the misfit below this fraction cannot be seen: frequencies are solved to
#: about 1e-12 relative, so with f / std_hz ~ 2000 (0.05 % scatter) each residual carries
#: ~2e-9 of round-off and chi^2 (~ the row count) about 1e-8 of itself.  When no damped
#: step lowers the misfit and Gauss-Newton predicted less than this, the fit is at the
#: minimum (the paper plate with a sensor: 2.7e-10 predicted, a step of 3e-7 in z).
#: Where the solves are less precise it is judged by the step against the std instead
#: (``updating._without_descent``).
ROUNDOFF_COST = 1e-8


class Stop(Enum):
    """Why the iterations stopped; the first five are convergence."""

    GAUSS_NEWTON_SMALL = "the Gauss-Newton step is below the tolerances"
    STEP_SMALL = "the parameter change is below the tolerance"
    WITHIN_STD = f"every change is below {STEP_PER_STD:g} of its parameter's std"
    EXACT = "the model reproduces the measurements exactly"
    MISFIT_FLAT = "the misfit no longer falls"
    MISFIT_STALLED = "the misfit fell by less than the stall limit in each of the last steps"
    NO_DESCENT = "no step lowered the misfit"
    MAX_ITERATIONS = "the iteration limit was reached"

    @property
    def converged(self) -> bool:
        return self not in (Stop.NO_DESCENT, Stop.MAX_ITERATIONS)

    @property
    def code(self) -> str:
        """The reason as the fit JSON gives it (``"stop_reason"``), e.g. ``"max_iterations"``."""
        return self.name.lower()


__all__ = [
    "Stop",
    "STALLED",
    "STEP_PER_STD",
    "STALL_ITERATIONS",
    "BOUND_TOLERANCE",
    "TINY_STEP",
    "ADMISSIBLE_HALVINGS",
    "FIRST_DAMPING",
    "DAMPING_FACTOR",
    "UNDAMPED",
    "EXACT_RMS",
    "FLAT_STEP",
    "UNDETERMINED_Z",
]
