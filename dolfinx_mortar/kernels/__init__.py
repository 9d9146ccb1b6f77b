"""Per-point contact kernels (numba): facet shape functions, closest-point projection and
normal gap with exact first and second derivatives.

Conventions (details in :mod:`.shape` and :mod:`.gap`):

* facet types ``INTERVAL1, INTERVAL2, TRIANGLE1, TRIANGLE2, QUAD1, QUAD2`` (codes 0..5),
  basix Lagrange node ordering, reference domains [0,1], unit triangle, [0,1]^2;
* master facet nodes ``xm`` (n_m, d), slave point ``x1`` (d,), d = 2 for interval facets
  and 3 for triangle/quad facets;
* unit normal nu = sign * n/|n| with n = (a1_y, -a1_x) (2D) or a1 x a2 (3D); the caller
  picks ``sign`` so that nu is the master body's OUTWARD normal;
* gap g = (x1 - S(zeta)) . nu(zeta) at the closest-point projection zeta: positive
  outside the master body, negative for penetration;
* derivatives are taken with respect to y = [x1, xm.ravel()] (length d (1 + n_m)).

:mod:`.reference` holds slow NumPy/SciPy reference versions used by the tests (it is not
imported here, so importing the kernels does not import scipy).
"""

from .gap import (
    gap_and_derivatives,
    gap_only,
    project,
    projection_derivative,
    unit_normal,
)
from .shape import (
    FACET_TYPE_NAMES,
    FACET_TYPES,
    INTERVAL1,
    INTERVAL2,
    MAX_NODES,
    QUAD1,
    QUAD2,
    REFERENCE_NODES,
    TRIANGLE1,
    TRIANGLE2,
    clamp_to_reference,
    inside,
    num_nodes,
    reference_centre,
    shape,
    tdim,
)

__all__ = [
    "FACET_TYPES",
    "FACET_TYPE_NAMES",
    "INTERVAL1",
    "INTERVAL2",
    "MAX_NODES",
    "QUAD1",
    "QUAD2",
    "REFERENCE_NODES",
    "TRIANGLE1",
    "TRIANGLE2",
    "clamp_to_reference",
    "gap_and_derivatives",
    "gap_only",
    "inside",
    "num_nodes",
    "project",
    "projection_derivative",
    "reference_centre",
    "shape",
    "tdim",
    "unit_normal",
]
