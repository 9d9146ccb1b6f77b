"""dolfinx_mortar: mortar contact with Coulomb friction for FEniCSx (dolfinx 0.5).

The three-field mixed formulation of Temizer (CMAME 2013): nodal mixed gap and
pressure on the slave surface with unconstrained, lumped or constrained
recovery, penalty regularisation with Uzawa augmentation, consistent
linearisation, 2D and 3D, under MPI.

Public API (imported lazily, so that ``import dolfinx_mortar`` and the scene
checks stay light):

- :func:`load_scene`, :func:`parse_scene` (:mod:`dolfinx_mortar.scene`)
- :func:`run` (:mod:`dolfinx_mortar.runner`): run a scene, write its outputs
- :class:`ContactProblem` (:mod:`dolfinx_mortar.problem`) and
  :class:`MortarContact` (:mod:`dolfinx_mortar.contact`): the problem side
- :class:`NewtonSolver`, :class:`LoadStepper` (:mod:`dolfinx_mortar.solver`)
- :class:`SceneError`, :class:`ConvergenceError`
"""

from .errors import ConvergenceError, SceneError

__version__ = "0.1.0"

_LAZY = {
    "load_scene": "scene",
    "parse_scene": "scene",
    "run": "runner",
    "ContactProblem": "problem",
    "MortarContact": "contact",
    "NewtonSolver": "solver",
    "LoadStepper": "solver",
    "SolverSettings": "solver",
}

__all__ = ["ConvergenceError", "SceneError", "__version__", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
