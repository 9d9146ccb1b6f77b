"""LoadStepper's step control on a stand-in problem (no PDE): cutbacks, the predictor
retry and the smallest step, with a Newton solver that fails on demand."""

import numpy as np
import pytest

from dolfinx_mortar.errors import ConvergenceError
from dolfinx_mortar.solver import MIN_STEP_FRACTION, LoadStepper


class _Array:
    def __init__(self, n):
        self.array = np.zeros(n)


class _U:
    def __init__(self, n):
        self.x = _Array(n)


class _Problem:
    """Holds u(t) = t (one dof) and the hooks LoadStepper calls."""

    def __init__(self):
        self.u = _U(1)
        self.t = 0.0
        self.timings = {"search": 0.0, "contact_assembly": 0.0, "bulk_assembly": 0.0}
        self.committed = []

    def set_time(self, t):
        self.t = t

    def begin_step(self):
        pass

    def uzawa_update(self):
        return True, {}

    def commit_step(self):
        self.committed.append(self.t)

    def restore_step(self):
        pass


class _Newton:
    """Converges when the step is at most ``limit(t_start)``; records the step sizes."""

    def __init__(self, problem, limit):
        self.problem, self.limit = problem, limit
        self.timings = {"linear_solve": 0.0}
        self.start = 0.0

    def solve(self, rtol=None, dtol=None):
        p = self.problem
        t0 = p.committed[-1] if p.committed else 0.0
        if p.t - t0 > self.limit(t0):
            raise ConvergenceError("too big a step")
        p.u.x.array[:] = p.t
        return 1, [1.0, 1e-12]


def test_cutbacks_then_success():
    p = _Problem()
    stepper = LoadStepper(p, _Newton(p, lambda t0: 0.1), 1.0, 2, max_cutbacks=3)
    results = stepper.run()
    assert p.committed[-1] == pytest.approx(1.0)
    assert all(b - a <= 0.1 + 1e-12 for a, b in zip([0.0] + p.committed, p.committed, strict=False))
    assert results[0].cutbacks == 3  # 0.5 -> 0.25 -> 0.125 -> 0.0625


def test_shrinking_steps_stop_cleanly_at_the_minimum_step():
    """Steps that must shrink without bound (each converged step makes the next harder)
    end in ConvergenceError, not in a zero-length step (a ZeroDivisionError in the
    predictor before), with every converged step committed."""
    p = _Problem()
    stepper = LoadStepper(p, _Newton(p, lambda t0: 0.5 * (0.5 - t0)), 1.0, 1, max_cutbacks=6)
    with pytest.raises(ConvergenceError, match="cannot be halved further"):
        stepper.run()
    assert len(p.committed) >= 2
    steps = np.diff([0.0] + p.committed)
    assert steps.min() > MIN_STEP_FRACTION
