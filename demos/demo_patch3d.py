"""Contact patch test in 3D: two stacked blocks under a uniform pressure p0 = 2.

See ``_patch.py`` for the set-up. The interface pressure must equal p0 at every
slave node: to round-off with ``--integration segment``, within the quadrature
error with ``--integration element`` (the default): <= 2 % on these hexahedra (1.2 %
with the finer side as the slave, 1.9 % with ``--swap``), 0.28 % and 0.89 % with
``--tri`` (tetrahedra: a frictionless pair's default rule on a triangle has degree 12, 33
points, since session 66; BENCHMARKS.md §90, §94), 7.0 % and 5.0 % with ``--tri
--quadrature-degree 4`` (6 points, the default of frictional pairs; BENCHMARKS.md §4),
1.3 % and 1.2 % with ``--tri --quadrature-degree 6`` (``[[contact]] quadrature_degree``: 12
points).
``--swap`` makes the coarser side the slave; ``--tri`` uses tetrahedra.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_patch3d.py [--integration segment] [--swap] [--refine K]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import _patch  # noqa: E402


def main(argv=None) -> dict:
    return _patch.main(3, argv)


if __name__ == "__main__":
    cm.script(main, "demo_patch3d")
