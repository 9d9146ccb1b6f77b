"""Material laws of the bulk by name: the built-in ones and those a Python script adds.

A script can add a hyperelastic law of its own, written in UFL as a stored-energy
density ψ(F), and then name it as ``model`` in a scene's ``[[material]]``::

    import ufl
    from dolfinx_mortar import register_law

    def mooney_rivlin(F, E, nu):  # ψ per unit reference volume, units of E
        ...
        return c1 * (I1b - 3) + c2 * (I2b - 3) + K / 2 * (J - 1) ** 2

    register_law("mooney-rivlin", mooney_rivlin)   # on every rank, before parse_scene

The bulk then takes P = ∂ψ/∂F with ``ufl.diff`` as for the built-in laws
(:mod:`dolfinx_mortar.bulk`), so the Jacobian stays the exact, symmetric Hessian of
the energy. The registry lives in each process: on the command line, a file that
registers laws is named with ``dolfinx-mortar run --laws FILE`` (every rank runs it
before the scene is read). This module imports neither UFL nor dolfinx, so that scene
checks stay light.
"""

from __future__ import annotations

from collections.abc import Callable

#: The built-in laws (:mod:`dolfinx_mortar.bulk`), the values of ``material.model``
#: that every scene may use.
BUILTIN_MODELS = ("neo-hookean", "saint-venant-kirchhoff", "linear-elastic")

_LAWS: dict[str, Callable] = {}


def register_law(name: str, psi: Callable, replace: bool = False) -> None:
    """Make ``name`` a value of ``material.model`` with stored energy ``psi`` (local).

    ``psi(F, E, nu)`` returns the stored energy density per unit reference volume (a
    UFL scalar, units of E) of the deformation gradient F (a UFL d × d variable; in 2D
    the law is taken in plane strain: F₃₃ = 1 is for ``psi`` to add where it needs the
    third dimension). E and nu are the ``[[material]]``'s values: they must be the law's
    small-strain Young's modulus and Poisson's ratio, since the contact pairs read their
    E* from them (``penalty = "auto"``; a run warns where the law's moduli at F = I
    differ, :func:`dolfinx_mortar.bulk.check_law`). A law is used with
    ``kinematics = "finite"``. E and nu reach ``psi`` as floats, so they are literals of
    the compiled form: each pair of values compiles it once (FFCx's cache keeps it); the
    built-in laws take their moduli as constants and compile once for all values.

    Call it on every rank before the scene is parsed; a scene keeps the ψ it was parsed
    with, and a run refuses a scene whose law was registered again since
    (``Scene.laws``). Raises TypeError for a name that is not a string or a ``psi``
    that is not callable (the two swapped included), ValueError for a name that is empty
    or built in, or already registered with another function (unless ``replace``)."""
    if not isinstance(name, str):
        hint = " (the name comes first: register_law(name, psi))" if callable(name) else ""
        raise TypeError(f"register_law: the name must be a string, got {type(name).__name__}{hint}")
    if not name.strip():
        raise ValueError(f"register_law: the name must be a non-empty string, got {name!r}")
    if name in BUILTIN_MODELS:
        raise ValueError(f"register_law: {name!r} is a built-in law and cannot be replaced")
    if not callable(psi):
        raise TypeError(
            f"register_law: psi for {name!r} must be callable, got {type(psi).__name__} {psi!r}"
        )
    old = _LAWS.get(name)
    if old is not None and old is not psi and not replace:
        raise ValueError(
            f"register_law: {name!r} is already registered with another function "
            "(replace=True replaces it)"
        )
    _LAWS[name] = psi


def registered_law(name: str) -> Callable | None:
    """The ``psi`` registered under ``name``, or None (built-in or unknown names)."""
    return _LAWS.get(name)


def model_names() -> tuple[str, ...]:
    """The values ``material.model`` accepts now: the built-in laws, then the registered
    ones in the order of registration."""
    return BUILTIN_MODELS + tuple(_LAWS)
