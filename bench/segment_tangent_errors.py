"""FD errors of the contact tangent with segment integration (docs/method-notes.md,
"Segment integration"): the configurations of ``tests/test_contact_jacobian.py``
(frictionless) and ``tests/test_friction.py`` (stick and slip nodes), the relative error
‖K v − (R(u + h v) − R(u − h v))/2h‖ / ‖…‖ for two random directions v at h = 1e-5 and
1e-6 (the deep-penetration rule off, as in the tests). The tests assert < 1e-5; this
prints the values.

Run (serial, from the checkout)::

    /usr/bin/python3 bench/segment_tangent_errors.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_contact_jacobian as tc  # noqa: E402
import test_friction as tf  # noqa: E402

from dolfinx_mortar import tangential  # noqa: E402

NORMAL = [
    ("hertz2d-P1", "lumped"),
    ("hertz3d-P1", "lumped"),
    ("hertz3d-P2", "lumped"),
    ("patch3d-Q1", "lumped"),
    ("hertz3d-P1", "unconstrained"),
    ("hertz3d-P1", "constrained"),
]
FRICTION = [  # (case, normal recovery, tangential weights, tangential recovery)
    ("hertz2d-P1", "lumped", "standard", "lumped"),
    ("hertz2d-Q1", "lumped", "dual", "lumped"),
    ("hertz3d-P1", "lumped", "standard", "lumped"),
    ("patch3d-Q1", "lumped", "standard", "lumped"),
    ("hertz3d-P1", "constrained", "standard", "lumped"),
    ("hertz2d-P1", "lumped", "standard", "unconstrained"),
    ("hertz3d-P1", "constrained", "standard", "constrained"),
]


def _errors(problem, term):
    u0 = problem.u.vector.copy()
    A = problem.create_matrix()
    problem.contact_jacobian(A)
    return {h: max(tc.fd_errors(problem, term, A, u0, n=2, h=h)) for h in (1e-5, 1e-6)}


def main() -> None:
    tangential.DEEP_PENETRATION_TOL = np.inf
    rows = []
    for case, rec in NORMAL:
        problem = tc._problem(case, "segment", rec)
        term = problem.contacts[0]
        tc._set_state(problem, {2: 0.05, 3: 0.04}[problem.gdim], tc.CASES[case][4][0])
        rng = np.random.default_rng(1 + MPI.COMM_WORLD.rank)
        n = term.lmbda.size
        term.lmbda = np.where(rng.random(n) < 0.5, 0.2 * rng.random(n), 0.0)
        term.update(problem.u)
        rows.append((f"normal   {case} {rec}", _errors(problem, term)))
    for case, rec, weights, trec in FRICTION:
        problem = tf._problem(case, "segment", recovery=rec, weights=weights, t_recovery=trec)
        term = tf._frictional_state(problem, case)
        rows.append((f"friction {case} {rec} {weights} {trec}", _errors(problem, term)))
    if MPI.COMM_WORLD.rank == 0:
        print("segment integration: FD error of the tangent   h = 1e-5   h = 1e-6")
        for name, e in rows:
            print(f"  {name:52s} {e[1e-5]:.2e}   {e[1e-6]:.2e}")


if __name__ == "__main__":
    import argparse

    # no options: --help says what the script does instead of running it
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()
    main()
