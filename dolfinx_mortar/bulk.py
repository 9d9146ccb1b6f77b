"""Hyperelastic and linear-elastic bulk in UFL (plane strain in 2D).

Laws (Lamé constants λ = Eν/((1+ν)(1−2ν)), μ = E/(2(1+ν)); units of E):

- ``neo-hookean`` (compressible): ψ = μ/2 (I₁ − 3 − 2 ln J) + λ/2 (ln J)²,
  I₁ = tr C (in 2D plane strain tr C + 1, the out-of-plane stretch being 1);
- ``saint-venant-kirchhoff``: ψ = λ/2 (tr E)² + μ tr(E²), E = (C − I)/2 (in 2D
  plane strain E₃₃ = 0, so the 2×2 formulas are exact);
- ``linear-elastic`` (``kinematics = "small"`` only): σ = λ tr ε I + 2μ ε,
  ε = sym ∇u;
- a law a script registered (:func:`dolfinx_mortar.laws.register_law`): its ψ(F, E, ν).

The first Piola stress P = ∂ψ/∂F is obtained with ``ufl.diff``; the residual is
R(u; v) = Σ_regions ∫ P : ∇v dX − Σ_tractions ∫ t̄ · v dA (reference
configuration; t̄ is the prescribed reference traction vector). Contact terms
are added outside UFL and never depend on the law. The built-in laws take λ and μ as
constants of the compiled forms (``fem.Constant``, :func:`region_moduli`), not as
literals: scenes that differ in the moduli alone share one FFCx compilation.

Quadrature degrees are set explicitly: for displacement degree p, linear
elasticity uses 2(p−1) on simplices (2p on quadrilaterals/hexahedra) and the
hyperelastic laws 2p (2p+1 on quadrilaterals/hexahedra) — FFCx's automatic
estimate for ln J would give ~1000 points per hexahedron. P1 on affine simplices
takes one point for every law: ∇u is constant in each cell, so is the integrand
(the hyperelastic laws took 4 points per tetrahedron before session 27; the bulk
assembly of the ironing3d demo's short path 2.09 → 1.69 s).
"""

from __future__ import annotations

import logging

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc
from ufl.algorithms import expand_derivatives

from . import compat
from .errors import SceneError
from .laws import registered_law

log = logging.getLogger(__name__)

#: the laws whose residual is linear in u (a bulk of these alone is assembled once:
#: problem.LinearBulk)
LINEAR_MODELS = ("linear-elastic",)
#: A registered law whose small-strain moduli at F = I (from ∂²ψ/∂F²) differ from the
#: material's E (relative) or ν (absolute) by more than this gets a warning
#: (:func:`check_law`): the contact pairs read E* from the material's values.
MODULI_TOL = 1e-3


def lame(E: float, nu: float) -> tuple[float, float]:
    """Lamé constants (λ, μ) of Young's modulus E and Poisson's ratio ν."""
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


def quadrature_degree(model: str, degree: int, simplex: bool, affine: bool) -> int:
    """The explicit quadrature degree used for ``model`` with displacement degree ``degree``
    on simplices (``simplex``) or not, with affine cells (``affine``: a first-order
    geometry) or curved ones. P1 on affine simplices has a constant ∇u, hence a constant
    integrand P(F) : ∇v for every law: one point (degree 1) is exact."""
    if simplex and affine and degree == 1:
        return 1
    if model == "linear-elastic":
        return max(2 * (degree - 1), 1) if simplex else 2 * degree
    return 2 * degree if simplex else 2 * degree + 1


def inversion_points(model: str, degree: int, cell_name: str, affine: bool) -> np.ndarray:
    """The reference points (n, tdim) at which a state's det F is checked in the cells
    of a region of ``model`` (``solver.NewtonSolver`` refuses a converged state with
    det F <= 0 at one of them: docs/method-notes.md, "Inverted elements"): the points of
    the quadrature rule its bulk forms use (:func:`quadrature_degree`), where the law is
    evaluated, and the cell's vertices, which catch a Q1 cell inverted at a corner
    between its Gauss points. det F is the ratio of the current and the reference
    cell's Jacobian determinants; for a bilinear quadrilateral both are affine in the
    reference coordinates, so a Q1 cell in 2D has det F <= 0 somewhere only if it has at
    a vertex; a P1 simplex has one det F. A trilinear hexahedron or a P2 cell can fold
    between the points checked, unseen."""
    simplex = cell_name in ("triangle", "tetrahedron")
    return compat.reference_points(cell_name, quadrature_degree(model, degree, simplex, affine))


def strain_energy(model: str, E: float, nu: float, F, moduli=None):
    """Stored energy density ψ(F) per unit reference volume (UFL expression); ``model``
    a built-in hyperelastic law or a registered one. ``moduli``: the Lamé constants
    (λ, μ) a built-in law uses instead of ``lame(E, nu)`` (UFL constants: see
    :func:`region_moduli`); a registered law always takes the floats E and ν."""
    psi = registered_law(model)
    if psi is not None:
        return psi(F, E, nu)
    lmbda, mu = lame(E, nu) if moduli is None else moduli
    d = F.ufl_shape[0]
    C = F.T * F
    if model == "neo-hookean":
        J = ufl.det(F)
        I1 = ufl.tr(C) + (1 if d == 2 else 0)
        return mu / 2 * (I1 - 3 - 2 * ufl.ln(J)) + lmbda / 2 * ufl.ln(J) ** 2
    if model == "saint-venant-kirchhoff":
        Eg = 0.5 * (C - ufl.Identity(d))
        return lmbda / 2 * ufl.tr(Eg) ** 2 + mu * ufl.tr(Eg * Eg)
    raise ValueError(f"no strain energy for model {model!r}")


def first_piola(model: str, E: float, nu: float, u, moduli=None):
    """First Piola–Kirchhoff stress P(u) (for linear elasticity: the Cauchy stress σ(ε(u)));
    ``moduli`` as :func:`strain_energy`."""
    d = len(u)
    if model == "linear-elastic":
        lmbda, mu = lame(E, nu) if moduli is None else moduli
        eps = ufl.sym(ufl.grad(u))
        return lmbda * ufl.tr(eps) * ufl.Identity(d) + 2 * mu * eps
    F = ufl.variable(ufl.Identity(d) + ufl.grad(u))
    return ufl.diff(strain_energy(model, E, nu, F, moduli), F)


def region_moduli(mesh, model: str, E: float, nu: float):
    """The Lamé constants (λ, μ) of a region of a built-in law as two ``fem.Constant``
    on ``mesh`` (units of E), or None for a registered law (its ψ(F, E, ν) takes the
    floats: it may compute with them as numbers). As constants the moduli are values the
    compiled kernels read at assembly, not literals of the generated C: scenes that
    differ in E or ν alone share one compiled form (FFCx's JIT cache), instead of a
    compilation (seconds; minutes for the 3D P2 laws) for each pair of values.
    Local (no communication)."""
    if registered_law(model) is not None:
        return None
    return tuple(fem.Constant(mesh, PETSc.ScalarType(m)) for m in lame(E, nu))


def check_law(
    model: str, E: float, nu: float, gdim: int, key: str, region: str | None = None
) -> None:
    """Raise SceneError(``key``) unless the registered law ``model`` with the material's
    ``E`` and ``nu`` gives a UFL scalar for a d × d deformation gradient (d = ``gdim``)
    that UFL can differentiate twice, and whose stiffness ∂²ψ/∂F² is not identically
    zero (a ψ at most linear in F left the Jacobian form empty: an IndexError traceback
    from dolfinx's sparsity pattern) (local and deterministic: every rank raises the same
    error); then warns where the law is not stress-free at F = I or its small-strain
    moduli there are not ``E`` and ``nu`` (:func:`_check_reference_state`). Each warning
    names the law and ``region``, the ``[[material]] region`` that uses it (a scene whose
    regions share a law gets one warning per region, each saying which). Built-in laws
    pass unchecked."""
    psi = registered_law(model)
    if psi is None:
        return
    cell = ufl.triangle if gdim == 2 else ufl.tetrahedron
    u = ufl.Coefficient(ufl.VectorElement("P", cell, 1))
    F = ufl.variable(ufl.Identity(gdim) + ufl.grad(u))
    try:
        value = psi(F, E, nu)
        shape = getattr(value, "ufl_shape", None)
        if shape != ():
            what = f"shape {shape}" if shape is not None else type(value).__name__
            raise SceneError(
                key, f"law {model!r}: psi(F, E, nu) must return a UFL scalar, got {what}"
            )
        P = expand_derivatives(ufl.diff(value, F))
        A = expand_derivatives(ufl.diff(P, F))
    except SceneError:
        raise
    except Exception as exc:  # whatever the user's function raises
        raise SceneError(
            key, f"law {model!r}: psi(F, E, nu) failed: {type(exc).__name__}: {exc}"
        ) from None
    if isinstance(A, ufl.constantvalue.Zero):
        raise SceneError(
            key,
            f"law {model!r}: psi(F, E, nu) is at most linear in F (its stiffness "
            "d2psi/dF2 is zero for every F): the bodies of this material resist nothing",
        )
    _check_reference_state(model, P, A, F, u, E, nu, gdim, region)


def _check_reference_state(
    model: str, P, A, F, u, E: float, nu: float, gdim: int, region: str | None = None
) -> None:
    """Warn where a law with first Piola stress ``P`` = ∂ψ/∂F and stiffness ``A`` =
    ∂P/∂F (UFL, of the variable F = I + ∇u) is not stress-free at F = I, or where its small-strain Lamé constants
    λ = ∂²ψ/∂F₁₁∂F₂₂ and μ = ∂²ψ/∂F₁₂∂F₁₂ at F = I give another E or ν than the
    material's (by MODULI_TOL). The warnings name the law and ``region`` (the material's
    region, left out where None). A law whose derivatives UFL cannot evaluate there is not
    checked."""
    what = f"law {model!r}" if region is None else f"law {model!r} (region {region!r})"
    zero = ufl.as_vector([0.0] * gdim)
    try:
        P0 = ufl.replace(P, {u: zero})
        A0 = ufl.replace(A, {u: zero})
        stress = max(abs(float(P0[i, j])) for i in range(gdim) for j in range(gdim))
        lam, mu = float(A0[0, 0, 1, 1]), float(A0[0, 1, 0, 1])
    except Exception as exc:  # a law UFL cannot evaluate at a constant F
        log.debug("%s: reference state not checked (%s)", what, exc)
        return
    if stress > 1e-9 * E:
        log.warning(
            "%s is not stress-free at F = I (largest |P_ij| = %.3g): the unloaded "
            "bodies of this material are prestressed",
            what,
            stress,
        )
    if mu <= 0.0 or lam + mu <= 0.0:
        log.warning(
            "%s: no positive small-strain moduli at F = I (λ = %.4g, μ = %.4g)", what, lam, mu
        )
        return
    E_law, nu_law = mu * (3 * lam + 2 * mu) / (lam + mu), lam / (2 * (lam + mu))
    if abs(E_law / E - 1.0) > MODULI_TOL or abs(nu_law - nu) > MODULI_TOL:
        log.warning(
            "%s: its small-strain moduli at F = I are E = %.6g, nu = %.4g, the "
            "material gives E = %.6g, nu = %.4g; the contact pairs read E* (penalty "
            '"auto") from the material\'s values',
            what,
            E_law,
            nu_law,
            E,
            nu,
        )


def internal_residual(u, v, regions, cell_tags, simplex: bool):
    """Σ_regions ∫ P(u) : ∇v dX.

    ``regions`` is a sequence of ``(tag, model, E, nu)``; ``cell_tags`` the
    dolfinx MeshTags of the cells. Returns a UFL form (rank 1); the moduli of the
    built-in laws enter as constants (:func:`region_moduli`).
    """
    mesh = u.function_space.mesh
    degree = u.function_space.ufl_element().degree()
    affine = mesh.ufl_domain().ufl_coordinate_element().degree() == 1
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    form = 0
    for tag, model, E, nu in regions:
        q = quadrature_degree(model, degree, simplex, affine)
        P = first_piola(model, E, nu, u, region_moduli(mesh, model, E, nu))
        form += ufl.inner(P, ufl.grad(v)) * dx(tag, metadata={"quadrature_degree": q})
    return form
