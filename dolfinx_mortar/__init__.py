"""dolfinx_mortar: mortar contact with Coulomb friction for FEniCSx (dolfinx 0.5).

The three-field mixed formulation of Temizer (CMAME 2013): nodal mixed gap and
pressure on the slave surface with unconstrained, lumped or constrained
recovery, penalty regularisation with Uzawa augmentation, consistent
linearisation, 2D and 3D, under MPI.

Public API (imported lazily, so that ``import dolfinx_mortar`` and the scene
checks stay light):

- :func:`load_scene`, :func:`parse_scene` (:mod:`dolfinx_mortar.scene`)
- :func:`run` (:mod:`dolfinx_mortar.runner`): run a scene, write its outputs;
  :func:`prepare`: the mesh and the problem of a scene, for a solver of one's own
- :class:`ContactProblem` (:mod:`dolfinx_mortar.problem`) and
  :class:`MortarContact` (:mod:`dolfinx_mortar.contact`): the problem side
- :class:`NewtonSolver`, :class:`SolverSettings`, :class:`LoadStepper`
  (:mod:`dolfinx_mortar.solver`)
- :func:`register_law` (:mod:`dolfinx_mortar.laws`): a UFL stored-energy law of your
  own, named as ``model`` in a scene
- :class:`SceneError`, :class:`ConvergenceError`
"""

import os as _os

from .errors import ConvergenceError, SceneError

__version__ = "0.1.0"

#: Threads of PT-Scotch (Scotch 7.0, dolfinx 0.5.2's only graph partitioner in Debian
#: bookworm) where the environment does not set ``SCOTCH_PTHREAD_NUMBER``. Scotch 7
#: partitions with one thread per core by default, and the threads' timing decides the
#: partition: on 3 ranks the hertz2d generator's mesh (3 227 cells) loaded three times in
#: one process was cut differently each time in 4 runs of 4, and cattaneo2d's at
#: ``--refine 1`` (39 288 cells) differently in each of 10 runs (on 2 ranks the two parts
#: swapped ranks in 5 runs of 12). Identical runs then differed at round-off, and
#: frictional ones by Newton iterations. One thread: one partition, every time, of the
#: same quality. Set here, on import, so that it holds for meshes that the caller makes
#: with dolfinx after ``import dolfinx_mortar``; an explicit setting is kept.
SCOTCH_THREADS = "1"
_os.environ.setdefault("SCOTCH_PTHREAD_NUMBER", SCOTCH_THREADS)

_LAZY = {
    "load_scene": "scene",
    "parse_scene": "scene",
    "run": "runner",
    "prepare": "runner",
    "ContactProblem": "problem",
    "MortarContact": "contact",
    "NewtonSolver": "solver",
    "LoadStepper": "solver",
    "SolverSettings": "solver",
    "register_law": "laws",
}

__all__ = ["ConvergenceError", "SceneError", "__version__", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
