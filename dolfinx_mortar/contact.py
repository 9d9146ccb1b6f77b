"""MortarContact: one slave/master pair of the three-field mixed formulation, with Coulomb friction.

Per Newton iteration (``update``): fetch the current displacements of the
slave facets and master candidates, refresh the master ghost layer when the
bodies moved by more than a quarter of the search margin (with friction the layer
also covers the start-of-step configuration of the t_n pairing), pair the slave
quadrature points with master facets (:mod:`dolfinx_mortar.kernels.mortar`),
and recover the nodal mixed variables. Lumped recovery (METHOD.md §3):

    A^I = ∫ Φ_I dA₀,   γ^I = G^I / A^I,   p^I = ⟨λ^I − ε^I γ^I⟩,

the stationary point of the mixed functional with the mortar mass matrix
lumped. The contact residual and its exact tangent are

    R_c = −Σ_I p^I B^I,
    K_c = Σ_I (ε^I H^I / A^I) B^I ⊗ B^I − Σ_I p^I ∂²G^I/∂u²,   H^I = [λ^I − ε^I γ^I ≥ 0]

for fixed integration points (element and node integration). Segment integration moves
its points with u (2D: the segment ends; 3D: the vertices of the clipped polygons), and
the tangent has those terms too, for every recovery and in the friction integrals
(:meth:`MortarContact._add_segment_jacobian`,
:meth:`~dolfinx_mortar.tangential.TangentialTerms._segment_slip_motion`;
docs/method-notes.md, "Segment integration").

The unconstrained and constrained recoveries keep the consistent mortar matrix M
(:mod:`dolfinx_mortar.recovery`, which also gives their tangent Σ_I d_I a^I ⊗ c^I); the
slave-surface system, one value per node, is gathered on every rank for them.

Uzawa augmentation (METHOD.md §5; the rounds are this class's base
:class:`~dolfinx_mortar.uzawa.UzawaRounds`, in :mod:`dolfinx_mortar.uzawa`): after a
converged Newton solve λ^I ← p^I until max_I |p^I − λ^I| ≤ uzawa_tol · max_I p^I;
``uzawa_tol = 0`` is pure penalty. Each rank computes the nodes it owns (it receives
every slave facet touching them), so nodal sums need no reverse communication and the
results do not depend on the number of ranks.

Integrals are over the reference slave surface: p^I is a nominal pressure
(force per unit reference area), as the CSV output reports it.

Coordinates are relative to the pair's origin o (:attr:`MortarContact.origin`,
:func:`~dolfinx_mortar.surface.pair_origin`: near the slave surface, 0 for a model near
the origin): the kernels see (X − o) + u, whose round-off is that of the surface's size
wherever the model sits (docs/method-notes.md, "A model far from the origin").

Newton aids (docs/method-notes.md): a quadrature point that switches master facet back
and forth is pinned to one facet for the rest of the solve (PIN_OUTSIDE_TOL), and a
solve that starts with no active node leaves the geometric part of the normal tangent
out while its active set moves (GEOMETRIC_TANGENT_AT_FIRST_CONTACT).

With ``friction > 0`` the tangential part (METHOD.md §1, §2, §4; the node-level
formulas in :mod:`dolfinx_mortar.friction`, the point integrals in
:mod:`dolfinx_mortar.kernels.friction`) adds R_T = Σ_I (G^I)ᵀ t^I (G^I the force
weights: the traction acts on the master at the t_n projections ζ_n, G = ∂S/∂u, or with
tangential.FORCE_AT_CURRENT_PROJECTION at the current ones) and its exact non-symmetric tangent,
tangential multipliers to the Uzawa rounds, a slip history (u_n, λ_T = τ_n) committed
per step and the chattering control of FREEZE_AFTER. With ``friction = 0`` none of it is
created. Its slip integrals, recovery, Jacobian blocks and state predictor are the
methods of the base class :class:`~dolfinx_mortar.tangential.TangentialTerms`
(:mod:`dolfinx_mortar.tangential`, with the constants of the friction rules).
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.sparse as sp
from mpi4py import MPI
from petsc4py import PETSc

from . import friction as fr
from . import recovery as rc
from . import tangential as tg
from .analytic import effective_modulus
from .assembly import add_keyed_blocks, add_outer_blocks, padded_rows
from .errors import SceneError, SceneTypeError
from .kernels import mortar as kmortar
from .kernels.shape import (
    INTERVAL1,
    INTERVAL2,
    QUAD1,
    QUAD2,
    REFERENCE_NODES,
    TRIANGLE1,
    TRIANGLE2,
    tdim,
)
from .layout import FacetArrays
from .scene import (
    TANGENTIAL_FRAMES,
    TANGENTIAL_WEIGHTS,
    _show,
    check_facet_group,
    contact_numbers,
    exact_update_applies,
    quadrature_degree_choice,
    uzawa_acceleration_choice,
)
from .search import (
    Fetcher,
    candidates,
    distribute_slave_facets,
    exchange_master_facets,
    points_in_cells,
)
from .surface import (
    CONTACT_DEGREES,
    extract_facets,
    mixed_nodes,
    nodal_rule,
    pair_origin,
    quadrature,
    relative_to,
    shared_nodes,
)
from .tangential import TangentialTerms
from .uzawa import (
    ACCELERATIONS,
    UNLOADED_ROUND_OFF,
    UzawaAcceleration,
    UzawaRounds,
    resolve_acceleration,
)

log = logging.getLogger(__name__)

#: What the warning and the error of an initial overlap beyond the pairing's reach advise
#: (:meth:`MortarContact._find_unseen_overlap`, :meth:`MortarContact.unseen_overlap`)
OVERLAP_ADVICE = (
    "An initial overlap must start within the pairing's reach (a slave facet's box "
    "inflated by half its size, at most 2 slave-facet sizes deep; docs/method-notes.md, "
    '"Pairing"): make the slave facets there coarser, or start from meshes that do not '
    "overlap and prescribe the fit through the load path"
)

RECOVERIES = rc.RECOVERIES
INTEGRATIONS = ("element", "segment", "node")
#: Default slave-facet quadrature degree per facet type (INTERVAL1, INTERVAL2, TRIANGLE1,
#: TRIANGLE2, QUAD1, QUAD2): Gauss rules WITHOUT a point at the facet centre. On structured
#: non-matching meshes a centre point can sit exactly on a master edge, where the
#: closest-point gap has a kink and Newton stalls; degree 7 on P1 lines/quads also keeps
#: the element-integration patch test within 2 % (1.9 % worst in 3D, 0.5 % in 2D). On P1
#: triangles (tetrahedra) degree 4 (6 points) does not: 5–7 % on the structured patch,
#: up to 10.5 % on gmsh ones; degree 6 would (1.2–1.4 % structured), but the hertz3d demo
#: then reads a Newton order ≥ 1.77 in its first step (docs/method-notes.md, "Default
#: quadrature"; BENCHMARKS.md §84): frictionless element integration takes degree 12
#: there (:data:`FRICTIONLESS_ELEMENT_DEGREE`), the other pairs on P1 triangles keep 4. A
#: scene sets another degree per pair: ``[[contact]] quadrature_degree``.
DEFAULT_QUADRATURE_DEGREE = {0: 7, 1: 11, 2: 4, 3: 6, 4: 7, 5: 11}
#: The default degree on P1 triangles (tetrahedral models) with ELEMENT integration and
#: no friction, in place of DEFAULT_QUADRATURE_DEGREE's 4: degree 12 (33 points, no centre
#: point) passes the patch test (0.28 % slave finer, 0.89 % coarser on demo_patch3d's
#: tetrahedra, ≤ 1.6 % on unstructured ones) and keeps the hertz3d demo's Newton order
#: reading ≥ 1.83; since session 66 the tangent's Hessian on affine master facets costs
#: one gap Hessian per facet pair whatever the points (BENCHMARKS.md §92), so contact
#: assembly stays below the bulk's (0.87 × on hertz3d at 94k dofs; 0.54 × at degree 4).
#: With friction the default stays 4: the tangential integrals are still evaluated point
#: by point (demo_cattaneo3d took 2.6 × the wall time at degree 12 in session 66; 1.56 ×
#: since session 68's cheaper pairing, BENCHMARKS.md §99, where the stick patch test on
#: tetrahedra reads 0.28 % at 12 against 6.9 % at 4), and segment integration is exact
#: with any rule (BENCHMARKS.md §94).
FRICTIONLESS_ELEMENT_DEGREE = {2: 12}


def default_quadrature_degree(ftype: int, integration: str, frictional: bool) -> int:
    """The slave rule's degree of a pair that sets no ``quadrature_degree``:
    :data:`FRICTIONLESS_ELEMENT_DEGREE` for element integration without friction where it
    names the facet type, else :data:`DEFAULT_QUADRATURE_DEGREE` of the facet type (local)."""
    if integration == "element" and not frictional and ftype in FRICTIONLESS_ELEMENT_DEGREE:
        return FRICTIONLESS_ELEMENT_DEGREE[ftype]
    return DEFAULT_QUADRATURE_DEGREE[ftype]


#: The centre of each reference facet (INTERVAL1/2: [0, 1]; TRIANGLE1/2: the unit
#: triangle; QUAD1/2: [0, 1]²), where a rule's point is warned about (a chosen
#: ``quadrature_degree``'s rule, element integration).
REFERENCE_CENTRES = {
    0: np.array([0.5]),
    1: np.array([0.5]),
    2: np.array([1 / 3, 1 / 3]),
    3: np.array([1 / 3, 1 / 3]),
    4: np.array([0.5, 0.5]),
    5: np.array([0.5, 0.5]),
}
#: ``penalty = "auto"``: ε_N^I = AUTO_PENALTY_FACTOR · E* / h_I (h_I: mean size of the
#: slave facets around node I, E* the plane-strain effective modulus of the two bodies).
AUTO_PENALTY_FACTOR = 100.0
#: The stiffest penalty taken: max_I ε^I (and max_I ε_T^I) at most MAX_PENALTY_RATIO ×
#: max_I ε_auto^I, i.e. ε h/E* ≤ 1e12, checked at set-up (a SceneError keyed
#: ``<pair>.penalty`` / ``.penalty_tangential``). Far above what the stiff-penalty rules
#: were measured at (ε h/E* = 1e6; docs/method-notes.md, "Stiff penalties"): it refuses
#: nonsense such as penalty = 1e308, whose ε/A overflowed (RuntimeWarnings, then "the
#: first residual is not finite" after 6 cutbacks; `check` said ok).
MAX_PENALTY_RATIO = 1e10
#: The stiffest penalty ratio ε/ε_auto at which the stiff-penalty rules were measured
#: (docs/method-notes.md, "Stiff penalties"): a run that stops with a pair above it says
#: so (:meth:`MortarContact.stiff_penalty_note`; a probe's penalty = 1e10 × auto stopped
#: with DIVERGED_DTOL after 6 cutbacks, a tangential 2.6e4 × auto with "Uzawa
#: augmentation stalled", neither naming the penalty; 1e3 × auto ran).
MEASURED_PENALTY_RATIO = 1e4
#: A penalty more than this many times softer than its auto rule at some node (the
#: ratio ε_auto^I/ε^I, ``MortarContact.softness``) is named in the error of a run that
#: stops with Uzawa rounds (:meth:`MortarContact.stiff_penalty_note`): the rounds move
#: the multipliers by ε γ and crawl (a QA probe of session 65: 3e-7 × auto converged
#: in 8 rounds, 3e-8 × auto stalled).
SOFT_PENALTY_NOTE = 1e3
#: Penalties stiffer than "auto": a pair whose largest ε^I (or ε_T^I) exceeds the largest
#: ε_auto^I = AUTO_PENALTY_FACTOR E*/h_I is stiff (:attr:`MortarContact.soft_start`).
#: Three rules follow (docs/method-notes.md, "Stiff penalties"); pairs at or below the
#: auto penalty are not affected:
#:
#: - the contact predictor (the tangent-only stiffness of the nodes nearest to contact
#:   while none is active; lumped and constrained recoveries) uses ε_soft^I = min(ε^I,
#:   ε_auto^I): with ε = 1e3 ε_auto its springs held the floating body where it stood,
#:   and Newton crawled towards contact;
#: - with Uzawa (uzawa_tol > 0), or as pure penalty where the ratio exceeds
#:   SOFT_START_RATIO, every load step first goes through its Uzawa rounds under ε_soft
#:   (and ε_T,soft = min(ε_T, ε_auto) with friction; :meth:`MortarContact.soft_penalty`,
#:   ``solver.solve_step``), then through them again from that solution with the pair's
#:   own penalties: a penalty continuation. From the open state or an extrapolated
#:   predictor the first iterate penetrates by a fraction of h, where ε = 1e3 ε_auto
#:   gives pressures of 1e4 E* and more, and the l2 line search stalled. With Uzawa the
#:   second pass starts at the augmented-Lagrangian solution, which does not depend on
#:   ε, and takes 0–2 Newton iterations; as pure penalty it starts where the active set
#:   is nearly the stiff one's;
#: - the absolute Newton tolerance is multiplied by
#:   :attr:`MortarContact.round_off_scale`, max ε / max ε_auto or max ε_T / max ε_auto
#:   (≥ 1; the normal auto value in both). The round-off floor of the contact residual
#:   is ε times the round-off of the gaps: on hertz2d about 1e-13 with the auto penalty
#:   and 1.5e-10 with 1e3 × auto, above the default atol of 1e-10, which Newton then
#:   met only by chance.
#:
#: SOFT_START_RATIO (pure penalty): on the hard-case sweep's hertz2d (force control),
#: plain Newton converged at 100 × auto (44 Newton iterations in 4 steps; 55 with the
#: soft pass) and failed at 1e3 × auto and beyond (6 cutbacks in the first step). With
#: Uzawa the soft pass pays at any ratio (100 × auto: 27 iterations against 47).
SOFT_START_RATIO = 100.0
#: A slave facet paired over less than 1 − this of itself lies across the master surface's
#: edge (:meth:`MortarContact.edge_facets_in_contact`; the paired fraction is exact to
#: round-off).
EDGE_FRACTION_TOL = 1e-9
#: The softest contact-predictor springs, as a fraction of the penalty's
#: (:meth:`MortarContact._predictor_scale`).
PREDICTOR_MIN_SCALE = 1e-12
#: Chattering control: after this many Jacobians in one Newton solve, or at the first
#: slip reversal (``_add_tangential_jacobian``; tangential.REVERSAL_RECOVERIES), the
#: stick/slip states and the slip directions are frozen (a frozen slip node keeps
#: τ = μ p_N s with its s);
#: they are re-checked when the solve has converged: another solve follows, with the states
#: free, if a state changed or a slip direction moved by more than uzawa.FROZEN_DIRECTION_TOL.
#: After as many Jacobians the constrained recovery's QP free set can only grow within the
#: solve (re-checked against the plain QP at convergence).
FREEZE_AFTER = 8
#: Chattering control of the lumped contact set: from this Jacobian of a Newton solve on,
#: it can only grow. A node in contact at one of these Jacobians is held in contact for
#: the rest of the solve (p^I = λ^I − εγ^I, tension allowed, so the residual stays smooth
#: along the Newton steps). At convergence a held node whose law pressure ⟨λ^I − εγ^I⟩
#: differs from p^I by more than uzawa_tol × max p (it is in tension) counts as a changed
#: state, and another solve follows, free. A single node entering and leaving contact at
#: every iterate made solves on the ironing2d path 2-cycle until max_it. Later than
#: FREEZE_AFTER: from the 8th Jacobian on, the first solve of peers problem B's level 3
#: (still shrinking its contact zone there) held 2 nodes that then had to be released,
#: 20 Newton iterations instead of 17 (docs/method-notes.md, "The contact set held after
#: the freeze").
HOLD_AFTER = 12
#: Chattering control of the pairing (element and node integration): from the
#: FREEZE_AFTER-th Jacobian of a Newton solve on, a slave quadrature point whose master
#: facet went A → B → A over the last three Jacobians (B may be "none") stays paired with
#: A for the rest of the solve, with the projection onto A extended beyond its edge
#: (``kernels.mortar.forced_points``), unless that projection lies more than this far
#: outside A in reference coordinates (the pin is then ignored). From the HOLD_AFTER-th
#: Jacobian on (when a lumped contact set is held too), every paired point is pinned to its facet
#: so: a point crossing a master vertex turns its normal, hence its contact force, by
#: the kink, and that jump of the residual stopped the l2 line search short of it for 10
#: iterates of the ironing2d snap step (t = 1.36; the largest solve of the path 31 → 22,
#: no solve left to full steps; from the FREEZE_AFTER-th Jacobian the first press step of
#: the short path got worse: 26 iterations and full steps).
PIN_OUTSIDE_TOL = 0.1
#: First contact: in a Newton solve that starts with no active node on the pair, or with
#: a pair that carries no load yet (MortarContact._drop_geometric_tangent), at a
#: Jacobian whose active set (p̂^I > 0) differs from that of the previous Jacobian, the
#: geometric part of the normal contact tangent, −Σ_I p^I ∫ Φ_I ∂²g (the variation of the
#: projection and of the master normal), is left out; the penalty part ε/A B⊗B stays. The
#: first iterate of such a solve penetrates deeply (no contact force holds the body
#: back), p is ε times that depth, and the geometric part then dominates the tangent and
#: is indefinite: Newton cycled through active sets (peers problem A, level 3: 8 to 37
#: active nodes over 25 full steps, then a cutback). Once the active set repeats, the
#: tangent is exact again, so the final iterations keep quadratic convergence. Only
#: first-contact solves: on ironing2d the same rule in every solve gave 7 step halvings
#: instead of 1. The rule also holds in any solve whose iterate has an active node deeper
#: than DEEP_PENETRATION_TOL × h_I, the first Jacobian of the solve included
#: (tangential.DEEP_PENETRATION_TOL).
GEOMETRIC_TANGENT_AT_FIRST_CONTACT = False


def resolve_tangential_weights(
    weights: str, small_strain: bool, tangential_recovery: str = "lumped"
) -> str:
    """The tangential weight functions of a frictional pair: ``weights`` itself, except
    that "auto" (the default) becomes "dual" where every body is linear-elastic (small
    strain, ``small_strain``) and the tangential recovery is lumped, and "standard"
    elsewhere (local). Node integration keeps Φ whatever this says.

    Why (session 25, single serial runs, BENCHMARKS.md §18): with small strain and the
    lumped recovery the dual weights were better or equal everywhere. Peers problem B
    L2(q) 18.1 / 15.4 / 8.0 % → 14.5 / 8.3 / 5.5 % at h = a/4, a/8, a/16 in 0.95 / 0.87
    / 0.83 of the time; the 3D frictional stick patch tests 34 → 13 (hexahedra) and
    42 → 16 (tetrahedra) Newton iterations per step with a smaller traction error;
    twist3d 116 → 103 iterations, torque −0.50 → −0.16 %; the wedge the same slip ratio
    (its second step 13 → 22 iterations, within the 25). Not elsewhere: with finite
    strain the full demo_ironing2d path needs 45 Newton iterations in one step (25 with
    the standard weights), and the coarse Cattaneo scene of
    ``tests/test_contact_parallel.py`` with the constrained tangential recovery one
    cutback."""
    if weights != "auto":
        return weights
    return "dual" if small_strain and tangential_recovery == "lumped" else "standard"


#: The defaults of a pair's tangential keys (:class:`MortarContact`'s arguments).
TANGENTIAL_DEFAULTS = {
    "tangential_weights": TANGENTIAL_WEIGHTS[0],
    "tangential_recovery": "lumped",
    "tangential_frame": TANGENTIAL_FRAMES[0],
    "penalty_tangential": None,
}


def _warn_unused_tangential_keys(key: str, friction: float, integration: str, **given) -> None:
    """Log a warning (local) where a pair's tangential keys ``given`` (name -> value, the
    names of TANGENTIAL_DEFAULTS) differ from their defaults but do nothing: every one of
    them on a frictionless pair (friction = 0: no tangential field is modelled), and
    ``tangential_weights = "dual"`` with node integration (which uses the standard
    weights). They ran without a word (QA, session 65); a warning, not an error, so that
    a sweep over μ that includes 0 runs as written."""
    changed = [
        f"{name} = {value!r}" for name, value in given.items() if value != TANGENTIAL_DEFAULTS[name]
    ]
    if friction == 0.0 and changed:
        log.warning(
            "%s: %s %s no effect with friction = 0 (frictionless: no tangential field is modelled)",
            key,
            ", ".join(changed),
            "has" if len(changed) == 1 else "have",
        )
    elif integration == "node" and given.get("tangential_weights") == "dual":
        log.warning(
            '%s.tangential_weights = "dual" has no effect with integration = "node" '
            "(node integration uses the standard weights)",
            key,
        )


def _max_change(a: tuple, b: tuple) -> float:
    """The largest entry of |a_i − b_i| over the pairs of arrays (a_0, a_1), (b_0, b_1)
    (slave and master facet displacements; local, 0 for empty arrays)."""
    return max(np.abs(x - y).max(initial=0.0) for x, y in zip(a, b, strict=True))


class MortarContact(TangentialTerms, UzawaRounds):
    """Mortar contact (frictionless or Coulomb) between two facet groups (collective construction).

    Parameters
    ----------
    problem: the :class:`~dolfinx_mortar.problem.ContactProblem`.
    slave, master: facet group names: boundary facets, two groups that share no mesh node
        (on two bodies, or on one body: self-contact), otherwise SceneError.
    penalty: ε_N (stress per length) or "auto" (see :data:`AUTO_PENALTY_FACTOR`).
    recovery, integration: see METHOD.md §3 and §7 ("node" = node-to-segment baseline).
    uzawa_tol, uzawa_max: augmentation stop (relative multiplier change) and bound.
    uzawa_acceleration: update of the multipliers between rounds (:class:`UzawaAcceleration`;
        "newton": the exact update of :meth:`_exact_multipliers` (frictionless, lumped)
        or :meth:`_exact_multipliers_fd` (friction, or the unconstrained and constrained
        recoveries), with friction pairs with the lumped tangential recovery only,
        otherwise SceneError; "auto", the default: "newton" on the pairs with the lumped
        recoveries (2D and 3D, with or without friction), "aitken" elsewhere, switching
        to "newton" in a step whose rounds are predicted to take too many where it
        applies, :func:`resolve_acceleration`, :data:`~dolfinx_mortar.uzawa.AUTO_EXACT_BOUND`).
    quadrature_degree: of the slave facet rule (element integration) or of each segment's
        rule (segment integration), an integer in [2,
        :data:`~dolfinx_mortar.scene.MAX_QUADRATURE_DEGREE`], at least 4 on quadratic
        facets (the mortar mass matrix integrated exactly, else SceneError), or None (the
        default, :func:`default_quadrature_degree`: :data:`DEFAULT_QUADRATURE_DEGREE` of
        the facet type, 12 on P1 triangles with element integration and no friction);
        not with node integration.
    key: scene key used in error messages.
    friction: Coulomb coefficient μ; 0 creates no tangential history, fields or blocks.
    penalty_tangential: ε_T (stress per length), "auto" (tangential.AUTO_PENALTY_T_FACTOR E*/h_I,
        10 E*/h_I: a tenth of the normal rule) or None (= ``penalty``).
    tangential_weights: "standard" or "dual" weight functions of the tangential field, or
        "auto" (the default, :func:`resolve_tangential_weights`: "dual" where every
        body of ``problem`` is linear-elastic and the tangential recovery is lumped).
    tangential_recovery: "lumped", "unconstrained" or "constrained" recovery of the
        tangential traction (:func:`dolfinx_mortar.recovery.recover_tangential`).
    tangential_frame: "slave" (:class:`~dolfinx_mortar.friction.NodalFrames`, the
        default) or "master" (:class:`~dolfinx_mortar.friction.MasterFrames`: the
        master's convected covariant basis at each node's t_n master point).

    The options are checked first, on every rank alike, by the scene's rules for
    ``[[contact]]``: an unknown choice raises SceneError, a friction < 0, a penalty or
    penalty_tangential <= 0 (or a string other than "auto"), a uzawa_tol < 0 or a
    uzawa_max < 1 SceneError (a ValueError; :func:`dolfinx_mortar.scene.contact_numbers`),
    so do a uzawa_acceleration "newton" where the exact update does not apply
    (:func:`~dolfinx_mortar.scene.uzawa_acceleration_choice`) and a quadrature_degree
    outside [2, 30] or given with node integration
    (:func:`~dolfinx_mortar.scene.quadrature_degree_choice`), a value of the wrong type
    SceneTypeError (a TypeError), keyed ``KEY.NAME`` (``contact.penalty: must be > 0, got
    -5``). A ``problem`` whose displacement degree is not 1 or 2
    (:data:`~dolfinx_mortar.surface.CONTACT_DEGREES`), or not the mesh's geometry order,
    is a SceneError keyed ``KEY.problem`` (``contact.problem: the displacement degree 3
    (ContactProblem's degree) is not supported: ...``).
    """

    def __init__(
        self,
        problem,
        slave: str,
        master: str,
        penalty="auto",
        recovery="lumped",
        integration="element",
        uzawa_tol=1e-6,
        uzawa_max=20,
        quadrature_degree=None,
        key="contact",
        friction=0.0,
        penalty_tangential=None,
        tangential_weights=TANGENTIAL_WEIGHTS[0],
        tangential_recovery="lumped",
        uzawa_acceleration=ACCELERATIONS[0],
        tangential_frame=TANGENTIAL_FRAMES[0],
    ):
        for name, value, allowed in (
            ("recovery", recovery, RECOVERIES),
            ("integration", integration, INTEGRATIONS),
            ("tangential_weights", tangential_weights, TANGENTIAL_WEIGHTS),
            ("tangential_recovery", tangential_recovery, RECOVERIES),
            ("tangential_frame", tangential_frame, TANGENTIAL_FRAMES),
        ):
            if not isinstance(value, str):  # a list, an array (its `in` was ambiguous)
                raise SceneTypeError(
                    f"{key}.{name}",
                    f"expected a string, one of {', '.join(allowed)}; got "
                    f"{type(value).__name__} {_show(value)}",
                )
            if value not in allowed:
                raise SceneError(f"{key}.{name}", f"{value!r} is not one of {', '.join(allowed)}")
        # the scene's rules for [[contact]]'s numbers (one definition; local, the same
        # arguments on every rank): a penalty <= 0 ran and let the bodies pass through
        # each other, a negative friction ran frictionless
        friction, penalty, penalty_tangential, uzawa_tol, uzawa_max = contact_numbers(
            key, friction, penalty, penalty_tangential, uzawa_tol, uzawa_max
        )
        # the scene's rules too, before any collective (a bad value was a ValueError after
        # the set-up's collectives, a quadrature_degree of 0 the default, -3 a C++ error)
        uzawa_acceleration = uzawa_acceleration_choice(
            key, uzawa_acceleration, friction, recovery, tangential_recovery
        )
        quadrature_degree = quadrature_degree_choice(key, quadrature_degree, integration)
        # the problem's displacement degree: the contact facets are P1/Q1 and P2/Q2 of the
        # mesh's geometry order (ContactProblem's default degree); a degree of 3 was a
        # plain ValueError of surface.facet_type naming no argument (local, before any
        # collective: the same degrees on every rank)
        degree, order = problem.degree, problem.mesh.geometry.cmap.degree
        if degree not in CONTACT_DEGREES or degree != order:
            supported = " and ".join(str(d) for d in CONTACT_DEGREES)
            what = (
                "is not supported"
                if degree not in CONTACT_DEGREES
                else f"differs from the mesh's geometry order {order}"
            )
            raise SceneError(
                f"{key}.problem",
                f"the displacement degree {degree} (ContactProblem's degree) {what}: mortar "
                f"contact takes degrees {supported} (P1/Q1, P2/Q2), equal to the mesh's "
                f"geometry order (here {order}; ContactProblem's default)",
            )
        self.tangential_frame = tangential_frame
        #: as asked ("auto" included), and what it resolved to
        self.tangential_weights_asked = tangential_weights
        self.tangential_weights = resolve_tangential_weights(
            tangential_weights, getattr(problem, "small_strain", False), tangential_recovery
        )
        self.tangential_recovery = tangential_recovery
        self.problem = problem
        self.comm = comm = problem.comm
        self.slave_name, self.master_name = slave, master
        self.name = f"{slave}:{master}"
        self.degenerate = False  # see update()
        self.recovery, self.integration = recovery, integration
        # ζ-distance outside a master facet accepted when none contains a point's projection
        self.outside_tol = float(
            kmortar.NODE_OUTSIDE_TOL if integration == "node" else kmortar.OUTSIDE_TOL
        )
        self.uzawa_tol, self.uzawa_max = float(uzawa_tol), int(uzawa_max)
        self.bs = problem.V.dofmap.index_map_bs
        self.gdim = problem.gdim
        imap = problem.V.dofmap.index_map
        self.ranges = np.asarray(
            comm.allgather(imap.local_range[0]) + [imap.size_global], dtype=np.int64
        )

        md = problem.mesh_data  # a missing or a cell group was a KeyError
        for k, name in (("slave", slave), ("master", master)):
            check_facet_group(f"{key}.{k}", name, md.facet_groups, md.cell_groups)
        slave_local, slave_cells, slave_interior = extract_facets(problem, slave)
        master_local, master_cells, master_interior = extract_facets(problem, master)
        for name, fa, interior, k in (
            (slave, slave_local, slave_interior, "slave"),
            (master, master_local, master_interior, "master"),
        ):
            n_interior = comm.allreduce(interior)
            if n_interior:
                raise SceneError(
                    f"{key}.{k}",
                    f"contact surface {name!r} has {n_interior} facet(s) inside the mesh "
                    "(shared by two cells): contact surfaces must lie on the boundary",
                )
            if comm.allreduce(fa.num_facets) == 0:
                raise SceneError(f"{key}.{k}", f"contact surface {name!r} is empty")
        n_shared = shared_nodes(comm, self.ranges, slave_local.blocks, master_local.blocks)
        if n_shared:
            raise SceneError(
                f"{key}.master",
                f"contact surfaces {slave!r} and {master!r} share {n_shared} mesh node(s): a "
                "slave and its master may be surfaces of one body (self-contact) but must "
                "not share a node; leave the facets at the shared node(s) out of one of the "
                "groups (where two surfaces of one body meet, e.g. at a slit's tip), or give "
                "bodies fused there nodes of their own",
            )
        #: the pair's origin o (gdim,) (:func:`~dolfinx_mortar.surface.pair_origin`; the
        #: same on every rank): every coordinate array of the pair (slave, master_local, the
        #: master ghosts, xs, xm and the histories) is relative to it, X − o and
        #: (X − o) + u, so that the kernels' round-off is that of the surface's size, not
        #: of its distance from the origin; o = 0 for a model near the origin. What leaves
        #: the pair adds o back (:meth:`node_table`, :meth:`master_normals`)
        self.origin = pair_origin(comm, slave_local.X)
        slave_local = relative_to(slave_local, self.origin)
        master_local = relative_to(master_local, self.origin)
        self.ftype = slave_local.ftype
        self.ftype_phi = TRIANGLE1 if self.ftype == TRIANGLE2 else self.ftype
        quadratic = self.ftype in (INTERVAL2, TRIANGLE2, QUAD2)
        if quadrature_degree is not None and quadratic and quadrature_degree < 4:
            # the same facet type on every rank: all raise
            raise SceneError(
                f"{key}.quadrature_degree",
                f"must be >= 4 on quadratic (P2) slave facets, got {quadrature_degree}: the "
                "rule must integrate the mortar mass matrix ∫ N_I N_J dA exactly",
            )
        self.mixed = mixed_nodes(self.ftype)
        self.slave = distribute_slave_facets(comm, slave_local, self.mixed, self.ranges)
        self._midsides = None  # fill_midsides' layout (_midside_layout), made on first use
        #: the global node blocks of the slave facets this rank extracted (its cells'
        #: facets: every node owned or a ghost here), for :meth:`_midside_layout`
        self._own_facet_blocks = slave_local.blocks
        #: slave facets over all ranks (each is extracted by the rank owning its cell)
        self.n_global_facets = comm.allreduce(slave_local.num_facets)
        self.master_local = master_local
        nsf = self.slave.num_facets

        # quadrature: the element rule on every slave facet, or the rule per segment
        qdeg = (
            default_quadrature_degree(self.ftype, integration, friction > 0.0)
            if quadrature_degree is None
            else quadrature_degree
        )
        self.rule = quadrature(self.ftype, qdeg)
        #: the rule's degree (summary.json ``modelled``); None with node integration
        self.quadrature_degree = None if integration == "node" else qdeg
        if integration == "element" and quadrature_degree is not None:
            centre = REFERENCE_CENTRES[self.ftype]
            if np.any(np.all(np.abs(self.rule[0] - centre) < 1e-12, axis=1)):
                log.warning(
                    "%s.quadrature_degree = %d: the rule has a point at the slave facet's "
                    "centre; on structured non-matching meshes a master edge can pass "
                    "through it, where the gap has a kink and Newton can stall (the "
                    "defaults have no centre point: contact.DEFAULT_QUADRATURE_DEGREE)",
                    key,
                    qdeg,
                )
        _warn_unused_tangential_keys(
            key,
            friction,
            integration,
            tangential_weights=tangential_weights,
            tangential_recovery=tangential_recovery,
            tangential_frame=tangential_frame,
            penalty_tangential=penalty_tangential,
        )
        if integration == "node":
            try:
                self.qp_xi, self.qp_w = nodal_rule(self.ftype, self.slave.X)
            except ValueError as exc:
                raise SceneError(f"{key}.integration", str(exc)) from None
        elif integration == "element":
            nq = self.rule[1].size
            self.qp_xi = np.zeros((nsf, nq, self.rule[0].shape[1]))
            self.qp_w = np.zeros((nsf, nq))
            if nsf:
                kmortar.reference_weights(
                    self.ftype, self.slave.X, *self.rule, self.qp_xi, self.qp_w
                )
        else:
            # segments are sub-intervals (2D) or triangles of the clipped polygons (3D)
            self.seg_rule = quadrature(INTERVAL1 if tdim(self.ftype) == 1 else TRIANGLE1, qdeg)
            self.seg_capacity = 8 * self.seg_rule[1].size

        # owned slave nodes (mixed-field nodes) and one facet-local occurrence of each
        lo, hi = self.ranges[comm.rank], self.ranges[comm.rank + 1]
        mb = self.slave.blocks[:, self.mixed]
        owned = (mb >= lo) & (mb < hi)
        self.node_blocks = np.unique(mb[owned])
        self.node_of = np.where(owned, np.searchsorted(self.node_blocks, mb), -1).astype(np.int64)
        n = self.node_blocks.size
        self.n_global_nodes = comm.allreduce(n)
        fidx, iidx = np.nonzero(self.node_of >= 0)
        first = np.full(n, -1, np.int64)
        first[self.node_of[fidx, iidx][::-1]] = np.arange(fidx.size)[::-1]
        self._node_at = (
            (fidx[first], self.mixed[iidx[first]]) if n else (np.empty(0, int), np.empty(0, int))
        )

        # element and segment integration: each node's full weight ∫Φ_I dA₀ over its
        # whole slave support (every point paired; the element rule), against which a
        # sliver of paired area is told (:meth:`sliver_nodes`); None for node integration
        self.full_area = None
        if integration != "node":
            self.full_area = np.zeros(n)
            qp_xi, qp_w = (self.qp_xi, self.qp_w) if integration == "element" else (None, None)
            if integration == "segment":
                qp_xi = np.zeros((nsf, self.rule[1].size, self.rule[0].shape[1]))
                qp_w = np.zeros((nsf, self.rule[1].size))
                if nsf:
                    kmortar.reference_weights(self.ftype, self.slave.X, *self.rule, qp_xi, qp_w)
            if nsf:
                kmortar.nodal_integrals(
                    self.ftype_phi,
                    qp_xi,
                    qp_w,
                    np.zeros(qp_w.shape, np.int64),
                    np.zeros(qp_w.shape),
                    self.node_of,
                    self.full_area,
                    np.zeros(n),
                )

        # sizes: per slave facet (search reach, accepted penetration) and per node (penalty)
        self.h_facet = self._facet_sizes(self.slave.X)
        h_node = np.zeros(n)
        cnt = np.zeros(n)
        for i in range(len(self.mixed)):
            nodes = self.node_of[:, i]
            sel = nodes >= 0
            np.add.at(h_node, nodes[sel], self.h_facet[sel])
            np.add.at(cnt, nodes[sel], 1.0)
        self.h_node = h_node / np.maximum(cnt, 1.0)
        h_all = self._facet_sizes(slave_local.X)
        self.h_mean = comm.allreduce(h_all.sum()) / max(comm.allreduce(h_all.size), 1)
        #: gap window of the contact predictor (rc.near_contact), length
        self.predictor_tol = 1e-3 * self.h_mean
        # the local cells of the pair's two surfaces, and free_body once asked
        self._body_cells = np.concatenate([slave_cells, master_cells])
        self._master_cells = master_cells  # whose bodies mirror a symmetry plane (friction)
        self._free_body = None
        self.h_slave_max = comm.allreduce(h_all.max(initial=0.0), op=MPI.MAX)
        self.margin = 2.0 * self.h_slave_max
        E_s = self._surface_modulus(slave_cells)
        E_m = self._surface_modulus(master_cells)
        # 1/E* = 1/E_s + 1/E_m of the two surfaces' largest plane moduli (ν already in
        # them, and a maximum over the bodies of each surface: not effective_modulus's
        # (E, ν) pairs)
        self.E_star = 1.0 / (1.0 / E_s + 1.0 / E_m)
        #: ε_auto^I = AUTO_PENALTY_FACTOR E*/h_I (n,): the "auto" penalty, and the reference
        #: of the stiff-penalty rules (SOFT_START_RATIO)
        self.eps_auto = AUTO_PENALTY_FACTOR * self.E_star / np.maximum(self.h_node, 1e-300)
        if not comm.allreduce(bool(np.all(np.isfinite(self.eps_auto))), op=MPI.LAND):
            # the predictor and the stiff-penalty rules use ε_auto with any penalty
            raise SceneError(
                key,
                f"the contact stiffness {AUTO_PENALTY_FACTOR:g} E*/h overflows (E* = "
                f"{self.E_star:.3g}): state the moduli and lengths in other units",
            )
        if penalty == "auto":
            self.eps = self.eps_auto
            self.penalty_description = f"auto: {AUTO_PENALTY_FACTOR:g} E*/h_I"
        else:
            self.eps = np.full(n, float(penalty))
            self.penalty_description = float(penalty)
        #: ε_soft^I = min(ε^I, ε_auto^I) (n,): the contact predictor's stiffness and the
        #: penalty of a stiff pair's first solve in a step (SOFT_START_RATIO)
        self.eps_soft = np.minimum(self.eps, self.eps_auto)
        self._eps_own = self.eps  # soft_penalty swaps self.eps
        self.penalty_range = (
            comm.allreduce(float(self.eps.min(initial=np.inf)), op=MPI.MIN),
            comm.allreduce(float(self.eps.max(initial=0.0)), op=MPI.MAX),
        )
        #: the largest auto value max_I ε_auto^I over the ranks
        self._eps_auto_max = max(
            comm.allreduce(float(self.eps_auto.max(initial=0.0)), op=MPI.MAX), 1e-300
        )
        #: max_I ε^I / max_I ε_auto^I (collective at set-up): > 1 for a stiff pair. The
        #: peaks, not the nodewise ratio: a constant ε equal to the auto value in the
        #: contact zone would otherwise be "stiff" at the coarse slave facets far from it
        #: (16.7 on the hard-case sweep's hertz2d mesh)
        self.penalty_ratio = self.penalty_range[1] / self._eps_auto_max
        self._check_penalty_ratio(self.penalty_ratio, self.penalty_range[1], f"{key}.penalty")
        self._penalty_t_ratio = 0.0
        #: max_I ε_auto^I / ε^I over the ranks (and the tangential one, set with
        #: friction): how many times softer than its auto rule the softest node's penalty
        #: is (:meth:`stiff_penalty_note`; collective at set-up)
        self.softness = comm.allreduce(
            float(UzawaRounds._softness(self.eps, self.eps_auto).max(initial=1.0)), op=MPI.MAX
        )
        self.softness_t = 1.0
        self.mu = float(friction)
        self.frictional = self.mu > 0.0
        if self.frictional and recovery == "unconstrained":
            raise SceneError(
                f"{key}.recovery",
                "friction needs non-negative nodal pressures for its Coulomb limit: use "
                'recovery = "lumped" or "constrained" (got "unconstrained")',
            )
        if recovery != "lumped" or (self.frictional and tangential_recovery != "lumped"):
            self._init_mixed_numbering()
        # displacement fetchers: slave facets (fixed), local masters (fixed), candidates (rebuilt)
        self._fetch_slave = Fetcher(problem.u.vector, self._all_dofs(self.slave))
        self._fetch_mlocal = Fetcher(problem.u.vector, self._all_dofs(master_local))
        self._fetch_cand = None
        if self.frictional:
            self._init_friction(penalty if penalty_tangential is None else penalty_tangential, key)
        if uzawa_tol > 0.0 and (soft := self._soft_clause()):
            # said at set-up too: a penalty in the wrong units is caught before the rounds
            # crawl (a QA pass of session 65 ran 3e-9 × auto without a word)
            log.warning("%s: %s", key, soft)

        # multipliers and nodal state
        # checked on entry (uzawa_acceleration_choice)
        requested = uzawa_acceleration
        uzawa_acceleration = resolve_acceleration(
            uzawa_acceleration, self.mu, recovery, tangential_recovery
        )
        self.uzawa_acceleration = UzawaAcceleration(comm, uzawa_acceleration)
        #: "auto" resolved to "aitken" where the exact update applies (the mixed normal
        #: recoveries): a step whose Aitken rounds are predicted to take too many switches
        #: to the exact update (uzawa.AUTO_EXACT_ROUNDS, uzawa.AUTO_EXACT_BOUND; local, the same on
        #: every rank)
        self._auto_exact = (
            requested == "auto"
            and uzawa_acceleration == "aitken"
            and exact_update_applies(self.mu, recovery, tangential_recovery)
        )
        self._round_changes: list[float] = []  # this attempt's max(rel, rel_t) per round
        self.lmbda = np.zeros(n)
        self.lmbda_committed = np.zeros(n)
        self.p = np.zeros(n)
        self.p_hat = np.zeros(n)
        self.active = np.zeros(n, bool)
        self.kcoef = np.zeros(n)
        self.predictor_nodes = 0
        self._no_contact = True
        #: whether some contact update since the last :meth:`begin_step` (the current or
        #: last attempt of a load step) had a slave node in contact, on any rank (the same
        #: on every rank): the stop message tells a failed attempt that lost the contact
        #: it had found from one that never found any
        self.touched_in_attempt = False
        #: (γ_min, spring factor) at the last predictor Jacobian of the solve, or None
        self._predictor_track = None
        self._recovered = None
        self._segment_rows = None  # 2D segments, mixed recoveries: (C_γ, D_p) rows
        self._partial_facets = None
        self._learned = np.empty(0, np.int64)  # couplings of the mixed normal tangent
        self._learned_t = np.empty(0, np.int64)  # ... and of the consistent tangential one
        self.qp_frozen = None  # constrained recovery: the QP free set, once frozen
        self._jacobians = 0
        # lumped recovery: the nodes held in contact (HOLD_AFTER), and the Jacobians of
        # this solve that count towards it
        self.held = None
        self._set_jacobians = 0
        self.hold_after = HOLD_AFTER
        self.freeze_after = FREEZE_AFTER
        # chattering control of the pairing (PIN_OUTSIDE_TOL): pinned master facet per
        # slave quadrature point (−1: free), the pairings of the last two Jacobians, the
        # Jacobians of this solve, and the master exchange they refer to
        self.qp_pinned = None
        self._pair_hist = []
        self._pair_jacobians = 0
        self._pin_exchange = -1
        # the points pinned for switching back (not by HOLD_AFTER), and those of them that
        # the next solve of the same load step starts pinned (uzawa.PIN_CARRY_TOL)
        self.qp_flip = None
        self._carried_pins = None
        self._jac_active = None  # the active set at the previous Jacobian of the solve
        #: the contact states of the Jacobian the Newton solver factorized last
        #: (:meth:`note_factorization`): (contact set (n,) bool, stick/slip states or None)
        self._factored_states = None
        #: whether the current Newton solve is a first contact of the pair (decided at the
        #: solve's first Jacobian, the same on every rank; :meth:`_drop_geometric_tangent`)
        self.first_contact = False
        #: whether some slave node of the pair (on any rank) carried pressure p̂^I > 0 in
        #: the last committed step (False before the first; the same on every rank)
        self.loaded = False
        #: the displacement change (owned dofs) implied by the last exact multiplier update
        #: (``_exact_multipliers``), for the problem to apply; None otherwise
        self.displacement_update = None
        self.gamma = np.zeros(n)
        self.has_area = np.zeros(n, bool)

        self.master = None
        self._u_exchange = None
        self._exchanges = 0
        #: (inputs, results) of the last two pairings of :meth:`_pair_and_integrate`
        self._pairing_memo = []
        #: (inputs, result) of the last :meth:`block_couplings`: its inputs are replaced,
        #: never changed in place, and mostly the same between Newton solves
        self._couplings_memo = None
        self._no_couplings = (np.empty(0, np.int64), np.empty(0, np.int64))
        self._geometric_on = True  # the last Jacobian kept the geometric blocks
        log.info(
            "contact %s: %d slave nodes, penalty %s in [%.4g, %.4g] (E* = %.4g), %s recovery, %s integration",
            self.name,
            self.n_global_nodes,
            self.penalty_description,
            *self.penalty_range,
            self.E_star,
            recovery,
            integration,
        )
        if np.any(self.origin):
            log.info(
                "contact %s: coordinates relative to the pair's origin (%s)",
                self.name,
                ", ".join(f"{c:.17g}" for c in self.origin),
            )
        self._key = key
        self._find_unseen_overlap()

    def _find_unseen_overlap(self) -> None:
        """The owned slave nodes that start (reference configuration, u = 0) inside the
        master's body, away from its cells of which they are nodes
        (:func:`~dolfinx_mortar.search.points_in_cells` over the cells of the bodies that
        hold the master facets), and that the pairing at u = 0 leaves without area
        (A^I = 0: beyond its reach, a slave facet's box inflated by half its size and at
        most 2 facet sizes deep): an overlap the contact does not see. They are kept (:attr:`unseen_start`, local node indices) for
        :meth:`unseen_overlap` after the first step, and a warning names them (collective;
        a contact update at u = 0 only where some node lies inside, then
        :meth:`forget_search`)."""
        comm = self.comm
        #: the owned slave nodes (local indices) that start inside the master's body and
        #: unpaired (:meth:`_find_unseen_overlap`); empty on most pairs
        self.unseen_start = np.empty(0, np.int64)
        self.unseen_report = None
        fi, ii = self._node_at
        X = self.slave.X[fi, ii] + self.origin  # (n, gdim), the reference nodes
        pts = np.zeros((X.shape[0], 3))
        pts[:, : self.gdim] = X
        cells = self.problem.body_cells(self._master_cells)
        inside = points_in_cells(comm, self.problem.mesh, cells, pts)
        if not comm.allreduce(int(np.count_nonzero(inside))):
            return
        from dolfinx import fem

        zero = fem.Function(self.problem.V)
        self.update(zero)
        unseen = inside & ~self.has_area
        depth = self._node_depths(unseen)
        self.forget_search()
        self.unseen_start = np.flatnonzero(unseen)
        report = self._first_node(self.unseen_start, X, depth)
        if report is not None:
            self.unseen_report = report
            count, x, d, h = report
            where = f"more than {self.margin:.3g} deep" if np.isnan(d) else f"{d:.3g} deep"
            log.warning(
                "%s (%s): %d slave node(s) start inside the master's body beyond the "
                "pairing's reach, unseen by the contact: the first at (%s), %s, its slave "
                "facets %.3g in size. The run goes on if its first step pairs them (other "
                "nodes pushing the bodies apart) and stops otherwise. %s",
                self._key,
                self.name,
                count,
                ", ".join(f"{c:.4g}" for c in x),
                where,
                h,
                OVERLAP_ADVICE,
            )

    def _first_node(self, nodes: np.ndarray, X: np.ndarray, depth: np.ndarray | None):
        """(count over the ranks, position, depth, size h_I) of the first node, by
        reference position (smallest x, then y, then z), among the local ``nodes`` of every
        rank, or None where there are none (collective: one allgather). By position, not
        by global block: the blocks follow the partition, and the message named another
        node on 3 ranks than on 1 and 2."""
        first = None
        if nodes.size:
            k = int(nodes[np.lexsort(X[nodes].T[::-1])[0]])
            d = float("nan") if depth is None else float(depth[k])
            first = (X[k].tolist(), d, float(self.h_node[k]))
        found = self.comm.allgather((int(nodes.size), first))
        count = sum(c for c, _ in found)
        if not count:
            return None
        x, d, h = min((f for _, f in found if f is not None), key=lambda f: f[0])
        return count, x, d, h

    def _mixed_node_points(self, nsf: int) -> np.ndarray:
        """The reference coordinates of the mixed nodes on each of ``nsf`` slave facets,
        (nsf, nphi, k), as the pairing kernel's points (local). A writable copy: a
        one-facet broadcast view is read-only, and numba compiles a kernel variant of its
        own for a read-only argument."""
        ref = REFERENCE_NODES[self.ftype][self.mixed]  # (nphi, k)
        return np.broadcast_to(np.asarray(ref, float), (nsf,) + ref.shape).copy()

    def _node_depths(self, sel: np.ndarray) -> np.ndarray:
        """The depth −g of the owned nodes ``sel`` ((n,) bool) below the nearest master
        facet of the current search layer that faces them, the projection extended
        without a depth limit and with the layer's reach (``margin``); NaN where none
        (local; for the warning of :meth:`_find_unseen_overlap`)."""
        n = self.node_blocks.size
        depth = np.full(n, np.nan)
        nsf, nphi = self.node_of.shape
        if not nsf or not sel.any():
            return depth
        xi = self._mixed_node_points(nsf)
        node = self.node_of
        use = (node >= 0) & sel[np.maximum(node, 0)]
        reach = np.full(nsf, self.margin)
        off, idx = candidates(self.xs, self.xm, reach)
        pm = np.full((nsf, nphi), -1, np.int64)
        pz, pg = np.zeros((nsf, nphi, self.gdim - 1)), np.zeros((nsf, nphi))
        kmortar.pair_points(
            self.ftype, self.master.ftype, self.xs, self.slave.sign, xi, use.astype(float),
            self.xm, self.master.sign, self.master_key, off, idx, np.full(nsf, np.inf),
            reach, pm, pz, pg, self.outside_tol, False,
        )  # fmt: skip
        f, i = np.nonzero(use & (pm >= 0))
        np.fmin.at(depth, node[f, i], -pg[f, i])
        return depth

    def unseen_overlap(self) -> str | None:
        """At the first converged step (the load stepper asks after each): the text of
        an error where some slave node that started inside the master's body beyond the
        pairing's reach (:meth:`_find_unseen_overlap`) is still without area (A^I = 0
        at the last update, the converged state), else None, and None from then on: only
        the first step is checked, later the bodies may part (collective where the pair
        had such nodes: one allgather; the same answer on every rank)."""
        if self.unseen_report is None:  # the same on every rank
            return None
        still = self.unseen_start[~self.has_area[self.unseen_start]]
        if not self.comm.allreduce(int(still.size)):
            self.unseen_report = None  # all paired: checked
            return None
        fi, ii = self._node_at
        X = self.slave.X[fi, ii] + self.origin
        report = self._first_node(still, X, None)
        if report is None:
            return None
        count, x, _, h = report
        return (
            f"{self._key} ({self.name}): {count} slave node(s) that started inside the "
            "master's body beyond the pairing's reach are still unpaired after the first "
            "step, the first at (" + ", ".join(f"{c:.4g}" for c in x) + ") (reference "
            f"coordinates; its slave facets {h:.3g} in size): the contact does not see that "
            f"overlap. {OVERLAP_ADVICE}"
        )

    @classmethod
    def from_pair(cls, problem, pair, key="contact"):
        """Build from a :class:`dolfinx_mortar.scene.ContactPair`."""
        return cls(
            problem,
            pair.slave,
            pair.master,
            pair.penalty,
            pair.recovery,
            pair.integration,
            pair.uzawa_tol,
            pair.uzawa_max,
            quadrature_degree=pair.quadrature_degree,
            key=key,
            friction=pair.friction,
            penalty_tangential=pair.penalty_tangential,
            tangential_weights=pair.tangential_weights,
            tangential_recovery=pair.tangential_recovery,
            uzawa_acceleration=pair.uzawa_acceleration,
            tangential_frame=pair.tangential_frame,
        )

    # ------------------------------------------------------------------ friction set-up
    def _held_at_zero(self) -> np.ndarray:
        """Which displacement components of the slave facet nodes lie on a symmetry plane
        or a clamp, (nsf, ns, d) bool, the nodal frames of symmetry planes
        (:class:`~dolfinx_mortar.friction.NodalFrames`) are built from. Collective.

        Component k of a node is marked where a Dirichlet condition holds it at zero for
        the whole load path (``problem.dofs_held_at_zero``; the owners' marks are
        fetched) AND the master is held there too: its body (``problem.mirrored_planes``
        of the master's cells) has a node on the plane x_k = X_k of the node whose
        component k is held at zero. A half model cuts both bodies at its plane; a roller
        wall beside a slave surface over which the master slides holds the slave only,
        and the node keeps its full frame (across the wall the master slides and drags
        it: the wall's reaction holds it). A node with every component held (a clamp)
        keeps its marks (NodalFrames gives it no symmetry frame). None where the problem
        has no ``dofs_held_at_zero``, no plane where it has no ``mirrored_planes``."""
        marks = self.problem.u.vector.duplicate()
        try:
            marks.set(0.0)
            held = getattr(self.problem, "dofs_held_at_zero", None)
            if held is not None:
                marks.array[held()] = 1.0
            held = self._fetch_slave(marks).reshape(self.slave.X.shape) > 0.5
        finally:
            marks.destroy()
        part = held & ~np.all(held, axis=-1, keepdims=True)  # some, not all: planes
        f, i, k = np.nonzero(part)
        c = self.slave.X[f, i, k] + np.asarray(self.origin, float)[k]  # mesh coordinates
        mine = np.unique(np.stack([k, c], axis=1), axis=0)
        planes = np.unique(np.concatenate(self.comm.allgather(mine)), axis=0)  # rows [k, c]
        if not len(planes):
            return held
        mirrored = getattr(self.problem, "mirrored_planes", None)
        ok = np.zeros(len(planes), bool)
        if mirrored is not None:
            ok = mirrored(self._master_cells, planes)
        # each marked component's plane: its row of the sorted list (exact: the same X)
        row = np.empty(k.size, np.int64)
        for comp in np.unique(k):
            j = np.flatnonzero(planes[:, 0] == comp)
            sel = k == comp
            row[sel] = j[np.searchsorted(planes[j, 1], c[sel])]
        drop = ~ok[row]
        held[f[drop], i[drop], k[drop]] = False
        if not np.all(ok):
            log.info(
                "contact %s: slave nodes held at zero on %s, the master's body not: no "
                "symmetry plane there (their frames keep the tangent across it)",
                self.name,
                ", ".join(
                    f"u_{'xyz'[int(a)]} on {'xyz'[int(a)]} = {b:.6g}" for a, b in planes[~ok][:4]
                )
                + (f" and {np.count_nonzero(~ok) - 4} more" if np.count_nonzero(~ok) > 4 else ""),
            )
        return held

    def _check_penalty_ratio(self, ratio: float, eps_max: float, key: str) -> None:
        """SceneError keyed ``key`` where ``ratio`` = max ε / max ε_auto exceeds
        :data:`MAX_PENALTY_RATIO` (the same on every rank: both maxima are reduced)."""
        if ratio <= MAX_PENALTY_RATIO:
            return
        raise SceneError(
            key,
            f"{eps_max:.3g} is {ratio:.3g} times the auto penalty ({AUTO_PENALTY_FACTOR:g} "
            f"E*/h, at most {self._eps_auto_max:.3g} here); at most {MAX_PENALTY_RATIO:g} "
            f"times it is taken (stiff penalties were measured up to {MEASURED_PENALTY_RATIO:g} "
            "times it)",
        )

    # ------------------------------------------------------------------ helpers
    def _all_dofs(self, fa: FacetArrays) -> np.ndarray:
        """Unmasked global dofs (nf·nn·d,) of the facets, node-major."""
        return (fa.blocks[:, :, None] * self.bs + np.arange(self.gdim)).ravel()

    def _facet_sizes(self, X: np.ndarray) -> np.ndarray:
        """Largest vertex distance of each facet (reference), shape (nf,)."""
        if X.shape[0] == 0:
            return np.empty(0)
        nv = 2 if self.gdim == 2 else (4 if self.ftype in (QUAD1, QUAD2) else 3)
        verts = X[:, :nv]
        return np.linalg.norm(verts[:, :, None, :] - verts[:, None, :, :], axis=3).max(axis=(1, 2))

    def _surface_modulus(self, cells) -> float:
        """Largest plane-strain modulus E/(1−ν²) of the bodies owning ``cells`` (collective):
        :func:`~dolfinx_mortar.analytic.effective_modulus` against a rigid body, the same
        in plane strain and in 3D."""
        md = self.problem.mesh_data
        tags = dict(
            zip(np.asarray(md.cell_tags.indices), np.asarray(md.cell_tags.values), strict=True)
        )
        by_tag = {md.cell_groups[r]: (E, nu) for r, _m, E, nu in self.problem.materials}
        vals = [
            effective_modulus(*by_tag[tags[c]], math.inf)
            for c in set(cells.tolist())
            if tags.get(c) in by_tag
        ]
        return self.comm.allreduce(max(vals, default=0.0), op=MPI.MAX)

    @property
    def symmetric_tangent(self) -> bool:
        """Whether this pair's contact tangent is a symmetric matrix (local, fixed at set-up).

        Frictionless normal contact with the lumped or unconstrained recovery and element
        or node integration: the residual is the gradient of an augmented penalty energy
        at fixed multipliers (lumped: Σ_I A_I/(2 ε_I) ⟨λ_I + ε_I ĝ_I⟩²), so the tangent
        is its Hessian, symmetric to round-off in small and finite kinematics, with the
        geometric part or without it. Not symmetric: the Coulomb terms, the constrained
        recovery (its tangent goes through the active-set mortar solve M⁻¹) and segment
        integration (its moving segment ends are linearised in the residual's form, not
        the energy's). ``tests/test_contact_jacobian.py`` measures every combination."""
        return (
            not self.frictional
            and self.recovery in ("lumped", "unconstrained")
            and self.integration in ("element", "node")
        )

    def describe(self) -> dict:
        """What this pair models (summary.json ``modelled``)."""
        return {
            "slave": self.slave_name,
            "master": self.master_name,
            "friction": self.mu,
            "tangential_fields": self.frictional,
            "recovery": self.recovery,
            "integration": self.integration,
            **(
                {}
                if self.quadrature_degree is None
                else {
                    "quadrature": f"degree {self.quadrature_degree}, "
                    + (
                        f"{self.rule[1].size} points per slave facet"
                        if self.integration == "element"
                        else f"{self.seg_rule[1].size} points per segment"
                    )
                }
            ),
            "penalty": self.penalty_description,
            "penalty_range": list(self.penalty_range),
            "uzawa_tol": self.uzawa_tol,
            "uzawa_acceleration": self.uzawa_acceleration.method,
            "slave_nodes": self.n_global_nodes,
            "slave_facets": self.n_global_facets,
            **(
                {
                    "penalty_tangential": self.penalty_t_description,
                    "tangential_weights": "standard (node integration)"
                    if self.integration == "node"
                    else self.tangential_weights
                    + (" (auto)" if self.tangential_weights_asked == "auto" else ""),
                    "tangential_recovery": self.tangential_recovery,
                    "frame": "slave: convected orthonormal slave frame (a_ab = identity)"
                    if self.tangential_frame == "slave"
                    else "master: convected covariant basis at each node's t_n master point "
                    "(orthonormalised; slave frame off the master and at symmetry planes)",
                    "chattering_control": f"stick/slip states frozen after {self.freeze_after} "
                    "Newton iterations, re-checked at convergence",
                }
                if self.frictional
                else {}
            ),
            **(
                {
                    "mortar_matrix": "consistent, gathered on every rank (scipy SuperLU)",
                    "qp": "primal-dual active set; the free set may only grow after "
                    f"{self.freeze_after} Newton iterations, re-checked at convergence",
                }
                if self.recovery == "constrained"
                else {"mortar_matrix": "consistent, gathered on every rank (scipy SuperLU)"}
                if self.recovery == "unconstrained"
                else {
                    "contact_set": f"may only grow after {self.hold_after} Newton iterations, "
                    "re-checked at convergence"
                }
            ),
        }

    # ------------------------------------------------------------------ per iteration
    def update(self, u) -> None:
        """Search, pairing and nodal recovery at the displacement ``u`` (collective)."""
        vec = u.vector
        us = self._fetch_slave(vec).reshape(self.slave.X.shape)
        um = self._fetch_mlocal(vec).reshape(self.master_local.X.shape)
        self.xs = self.slave.X + us
        # the master ghost layer covers the pairings in the configurations it was built
        # for, up to a motion of a quarter of the margin: the current one (u_e) and, with
        # friction, the start of the step's (u_n,e), where the t_n pairing is made
        # (exchange_master_facets with both). It is rebuilt when the current state left
        # u_e, or (friction) when the start of the step is near neither u_e nor u_n,e
        # (a step that started after a slide of more than the allowance)
        cur = (us, um)
        hist = self._history_displacements() if self.frictional else None
        keep = False
        if self._u_exchange is not None:
            allow = 0.25 * self.margin
            moved = self.comm.allreduce(_max_change(cur, self._u_exchange[0]), op=MPI.MAX)
            # (written so that a NaN iterate keeps the layer, as before: its pairing fails;
            # `moved` is the same on every rank, so every rank calls _history_far or none)
            keep = not moved > allow and (hist is None or not self._history_far() > allow)
        if not keep:
            if hist is None:
                xm_ex, xs_ex = self.master_local.X + um, self.xs
            else:
                xm_ex = [self.master_local.X + um, self.master_local.X + hist[1]]
                xs_ex = [self.xs, self.slave.X + hist[0]]
            self.master = exchange_master_facets(
                self.comm, self.master_local, xm_ex, xs_ex, self.margin
            )
            # the pairing's tie-break keys (kernels.mortar.PAIR_TIE_TOL)
            self.master_key = kmortar.facet_keys(self.master.X)
            if self._fetch_cand is not None:
                self._fetch_cand.destroy()
            self._fetch_cand = Fetcher(vec, self._all_dofs(self.master))
            self._u_exchange = ((us.copy(), um.copy()), hist)
            self._exchanges += 1
        self.xm = self.master.X + self._fetch_cand(vec).reshape(self.master.X.shape)
        #: whether this rank's last update met a facet of zero size in the deformed state
        #: (the kernels divide by its Jacobian): the problem's residual is then NaN
        self.degenerate = False
        try:
            self._pair_and_integrate()
        except ZeroDivisionError:
            # a wild Newton iterate (a law without volumetric stiffness: displacements of
            # 1e13, a facet collapsed to round-off) escaped as a ZeroDivisionError from
            # the numba kernels, on this rank only: the pairing is made on the reference
            # geometry instead, so that every rank reaches the collectives below, and the
            # NaN residual fails the solve (its line search, a cutback)
            log.info("%s: a facet has zero size in the deformed state (a NaN residual)", self.name)
            self.degenerate = True
            self.xs, self.xm = self.slave.X.copy(), self.master.X.copy()
            self._pair_and_integrate()
        if self.frictional:
            self._friction_integrals()
        self._recover()

    def _history_far(self) -> float:
        """How far the start-of-step displacements u_n of the local slave and master facets
        lie from the nearer of the last exchange's two configurations (the largest change
        over the ranks; collective). Both change only with a new step or an exchange: it
        is computed once per pair of them, not at every Newton iteration."""
        key = (self._u_n_version, self._exchanges)
        if self._hist_far is None or self._hist_far[0] != key:
            hist, (current, start) = self._history_displacements(), self._u_exchange
            far = np.array([_max_change(hist, current), _max_change(hist, start)])
            self.comm.Allreduce(MPI.IN_PLACE, far, op=MPI.MAX)
            self._hist_far = (key, float(far.min()))
        return self._hist_far[1]

    def _history_displacements(self) -> tuple[np.ndarray, np.ndarray]:
        """The start-of-step displacements u_n of the local slave facets and the local
        master facets (collective: fetched once per t_n, :attr:`_u_n_version`)."""
        memo = self._u_n_local
        if memo is None or memo[0] != self._u_n_version:
            un = self._u_n
            hs = self._fetch_slave(un).reshape(self.slave.X.shape)
            hm = self._fetch_mlocal(un).reshape(self.master_local.X.shape)
            memo = self._u_n_local = (self._u_n_version, (hs, hm))
        return memo[1]

    def _pair_and_integrate(self) -> None:
        """Candidates, pairing and the nodal integrals A^I, G^I at the current ``xs`` and
        ``xm`` (local).

        A function of its inputs (:meth:`_pairing_inputs`): the results for the last two
        sets of inputs are kept (``_pairing_memo``), and inputs equal to one of them, bit
        for bit, take copies of its results. The exact multiplier update
        (``uzawa._exact_multipliers_fd``) pairs at the converged state once per product,
        and the line search and the Jacobian revisit iterates: 135 of the 314 pairings of
        demo_cattaneo3d were repeats. Segment integration, whose points move with the
        pairing, always pairs afresh."""
        memo = self._pairing_memo
        inputs = self._pairing_inputs()
        if inputs is not None:
            for i, (key, result) in enumerate(memo):
                if key == inputs:
                    memo.insert(0, memo.pop(i))
                    self._set_pairing(tuple(a.copy() for a in result))
                    return
        self._pair_and_integrate_afresh()
        if inputs is not None:
            memo.insert(0, (inputs, tuple(a.copy() for a in self._pairing_results())))
            del memo[2:]

    def _pairing_inputs(self) -> tuple | None:
        """What :meth:`_pair_and_integrate` depends on that can change after the term is
        made (local): the coordinates ``xs``, ``xm``, the master layer (its exchange) and
        the pins it applies; None (no memo) with segment integration. The points
        ``qp_xi``, ``qp_w``, the facet sizes and the tolerance are fixed at construction
        with element and node integration (only segment integration sets its points
        again): not copied into the key at every update."""
        if self.integration == "segment":
            return None
        pins = self.qp_pinned is not None and self._pin_exchange == self._exchanges
        return (
            self._exchanges,
            self.xs.shape,
            self.xs.tobytes(),
            self.xm.shape,
            self.xm.tobytes(),
            self.qp_pinned.tobytes() if pins else None,
        )

    def _pairing_results(self) -> tuple:
        """The arrays that :meth:`_pair_and_integrate` makes (local): the candidates' CSR,
        the points' master facets, coordinates and gaps, and A^I, G^I."""
        return (self.cand_off, self.cand, self.qp_m, self.qp_zeta, self.qp_g, self.A, self.G)

    def _set_pairing(self, result: tuple) -> None:
        """Take the arrays of :meth:`_pairing_results` (local)."""
        (self.cand_off, self.cand, self.qp_m, self.qp_zeta, self.qp_g, self.A, self.G) = result

    def _pair_and_integrate_afresh(self) -> None:
        """:meth:`_pair_and_integrate` without its memo (local)."""
        off, idx = candidates(self.xs, self.xm, 0.5 * self.h_facet)
        self.cand_off, self.cand = off, idx
        self._pair()
        n = self.node_blocks.size
        self.A, self.G = np.zeros(n), np.zeros(n)
        if self.slave.num_facets:
            kmortar.nodal_integrals(
                self.ftype_phi,
                self.qp_xi,
                self.qp_w,
                self.qp_m,
                self.qp_g,
                self.node_of,
                self.A,
                self.G,
            )

    def forget_search(self) -> None:
        """Forget what the search and the Jacobians have learned so far (local;
        ``ContactProblem.warm_up``): the next :meth:`update` exchanges the master facets
        afresh, as the first one does, and the couplings learned by the mixed tangents
        are dropped, so the candidates, the sums and the matrix pattern are those of a
        run without the warm-up."""
        self._u_exchange = None
        self._learned = np.empty(0, np.int64)
        self._learned_t = np.empty(0, np.int64)
        self._couplings_memo = None

    def step_limit(self, trial: PETSc.Vec, depth: float) -> float:
        """The largest fraction λ ∈ (0, 1] of the Newton step from the current state to the
        displacement ``trial`` (a global vector, (ndofs,)) along which no slave node that
        is out of contact now (p̂^I = 0) penetrates deeper than ``depth`` h_I (local: the
        caller reduces with MIN over the ranks; collective: the displacements are fetched).

        The nodal gaps g^I = G^I/A^I are taken at the current state (g₀ > 0 for a node out
        of contact, this term's last :meth:`update`) and at the trial (g₁, with the
        current pairing: each paired point's closest-point projection onto its facet,
        extended beyond the facet's edges, so that a point deeper than the pairing's reach
        still counts), linear in between:
        λ = min_I (g₀ + depth h_I)/(g₀ − g₁) over the open nodes with g₁ < −depth h_I.
        Nodes in contact are not limited: the tangent carries their contact stiffness.
        """
        # the fetches are collective (PETSc scatters): every rank, with facets or not
        xs = self.slave.X + self._fetch_slave(trial).reshape(self.slave.X.shape)
        xm = self.master.X + self._fetch_cand(trial).reshape(self.master.X.shape)
        if not self.slave.num_facets:
            return 1.0
        zeta, g = np.zeros_like(self.qp_zeta), np.zeros_like(self.qp_g)
        try:
            kmortar.forced_points(
                self.ftype,
                self.master.ftype,
                xs,
                self.qp_xi,
                self.qp_m,
                xm,
                self.master.sign,
                zeta,
                g,
            )
        except ZeroDivisionError:
            # a facet of zero size at the trial: no limit here, its NaN residual (update)
            # shortens the step
            return 1.0
        n = self.node_blocks.size
        A, G1 = np.zeros(n), np.zeros(n)
        kmortar.nodal_integrals(
            self.ftype_phi, self.qp_xi, self.qp_w, self.qp_m, g, self.node_of, A, G1
        )
        safe = np.where(self.has_area, self.A, 1.0)
        g0, g1 = self.G / safe, G1 / safe
        floor = -depth * self.h_node
        over = self.has_area & (self.p_hat <= 0.0) & (g1 < floor) & (g0 > floor)
        lam = (g0 - floor)[over] / (g0 - g1)[over]
        return float(min(1.0, lam.min(initial=1.0)))

    def _pair(self) -> None:
        nsf = self.slave.num_facets
        km = self.gdim - 1
        if self.integration == "segment":
            self._segment_points()
        nq = self.qp_w.shape[1]
        if self.integration != "segment":
            self.qp_m = np.full((nsf, nq), -1, np.int64)
        self.qp_zeta = np.zeros((nsf, nq, km))
        self.qp_g = np.zeros((nsf, nq))
        if not nsf:
            return
        if self.integration != "segment":
            kmortar.pair_points(
                self.ftype,
                self.master.ftype,
                self.xs,
                self.slave.sign,
                self.qp_xi,
                self.qp_w,
                self.xm,
                self.master.sign,
                self.master_key,
                self.cand_off,
                self.cand,
                2.0 * self.h_facet,
                self.h_facet,
                self.qp_m,
                self.qp_zeta,
                self.qp_g,
                self.outside_tol,
                False,
            )
            if self.qp_pinned is not None and self._pin_exchange == self._exchanges:
                self._apply_pins()
        else:
            kmortar.forced_points(
                self.ftype,
                self.master.ftype,
                self.xs,
                self.qp_xi,
                self.qp_m,
                self.xm,
                self.master.sign,
                self.qp_zeta,
                self.qp_g,
            )

    def _apply_pins(self) -> None:
        """Pair the pinned quadrature points with their pinned master facet (the projection
        extended beyond its edges), unless it lies more than PIN_OUTSIDE_TOL outside."""
        pinned = self.qp_pinned >= 0
        qm = np.where(pinned, self.qp_pinned, -1)
        zeta = np.zeros_like(self.qp_zeta)
        g = np.zeros_like(self.qp_g)
        kmortar.forced_points(
            self.ftype,
            self.master.ftype,
            self.xs,
            self.qp_xi,
            qm,
            self.xm,
            self.master.sign,
            zeta,
            g,
        )
        for f, q in zip(*np.nonzero(pinned), strict=True):
            if kmortar._outside(self.master.ftype, zeta[f, q]) <= PIN_OUTSIDE_TOL:
                self.qp_m[f, q] = qm[f, q]
                self.qp_zeta[f, q] = zeta[f, q]
                self.qp_g[f, q] = g[f, q]

    def _drop_geometric_tangent(self) -> bool:
        """Whether the geometric part of the normal tangent is left out at this Jacobian
        (collective): the active set differs from that of the previous Jacobian of this
        solve (at the first Jacobian of a solve: always), and either the solve is a first
        contact of the pair or an active node is deeper than DEEP_PENETRATION_TOL × h_I.
        See GEOMETRIC_TANGENT_AT_FIRST_CONTACT.

        First contact (:attr:`first_contact`, decided at the solve's first Jacobian): the
        solve starts with no active node on the pair, or the pair carries no load yet: no
        pressure in the last committed step (:attr:`loaded`) and no Uzawa multiplier
        λ^I > 0. The second case is a start with some nodes active but none in
        equilibrium: the reference configuration of a curved P2 slave touching a flat
        master, where the quadratic weights make the mixed gap of the touching vertex
        negative for any convex gap profile (γ = −h²/(20R) for a P2 interval on an arc of
        radius R), or meshes that overlap at t = 0."""
        act = self.p_hat > 0.0
        prev, self._jac_active = self._jac_active, act.copy()
        if prev is None:
            local = np.array([np.count_nonzero(act), np.count_nonzero(self.lmbda > 0.0)])
            n_active, n_lmbda = self.comm.allreduce(local, op=MPI.SUM)
            self.first_contact = n_active == 0 or (not self.loaded and n_lmbda == 0)
        moved = prev is None or (prev.shape == act.shape and bool(np.any(prev != act)))
        depth = float(np.max(-self.gamma[act] / self.h_node[act], initial=0.0))
        flags = self.comm.allreduce(
            int(moved) | int(depth > tg.DEEP_PENETRATION_TOL) << 1, op=MPI.BOR
        )
        return bool(flags & 1) and (self.first_contact or bool(flags & 2))

    def _watch_contact_set(self) -> None:
        """Chattering control of the lumped contact set at a Jacobian (see HOLD_AFTER;
        local: the nodal states are the owned nodes'). ``held`` becomes an array at the
        same Jacobian on every rank (Jacobians are collective), possibly without a node."""
        self._set_jacobians += 1
        if self._set_jacobians >= self.hold_after:
            self.held = self.active.copy() if self.held is None else self.held | self.active

    def _watch_pairing(self) -> None:
        """Chattering control of the pairing at a Jacobian (see PIN_OUTSIDE_TOL): pins the
        points that switched back from the FREEZE_AFTER-th Jacobian of the solve on, and
        every paired point from the HOLD_AFTER-th on."""
        if self.integration == "segment" or not self.slave.num_facets:
            return
        if self._pin_exchange != self._exchanges:  # facet indices refer to another layer
            self._pin_exchange = self._exchanges
            self._pair_hist, self.qp_pinned = [], None
        self._pair_jacobians += 1
        cur = self.qp_m
        if self._pair_jacobians >= self.freeze_after and len(self._pair_hist) == 2:
            h2, h1 = self._pair_hist
            flip = (cur == h2) & (cur != h1) & ((cur >= 0) | (h1 >= 0))
            if self.qp_pinned is None:
                self.qp_pinned = np.full_like(cur, -1)
                self.qp_flip = np.zeros(cur.shape, bool)
            every = self._pair_jacobians >= self.hold_after
            new = (((cur >= 0) & every) | flip) & (self.qp_pinned < 0)
            if new.any():
                self.qp_pinned[new] = np.where(cur >= 0, cur, h1)[new]
                self.qp_flip |= new & flip
                log.debug("%s: %d chattering points pinned", self.name, int(new.sum()))
        self._pair_hist = [*self._pair_hist[-1:], cur.copy()]

    def _segment_points(self) -> None:
        from .kernels.segment import segment_points

        nsf, k = self.slave.num_facets, self.gdim - 1
        while True:
            cap = self.seg_capacity
            self.qp_xi = np.zeros((nsf, cap, k))
            self.qp_w = np.zeros((nsf, cap))
            self.qp_m = np.full((nsf, cap), -1, np.int64)
            if not nsf:
                return
            count = segment_points(
                self.ftype,
                self.xs,
                self.slave.X,
                self.slave.sign,
                self.master.ftype,
                self.xm,
                self.master.sign,
                self.cand_off,
                self.cand,
                *self.seg_rule,
                self.qp_xi,
                self.qp_w,
                self.qp_m,
            )
            if count.min(initial=0) >= 0:
                return
            self.seg_capacity = int(2 * max(-count.min(), cap))

    def _init_mixed_numbering(self) -> None:
        """Global slave-node numbers for the unconstrained and constrained recoveries.

        Node g = (rank offset) + (index among the rank's owned nodes), so that the owned
        arrays of all ranks, concatenated in rank order, are in g order. ``facet_gid``
        (nsf, nphi) numbers every mixed node of the local slave facets (collective)."""
        comm = self.comm
        counts = comm.allgather(self.node_blocks.size)
        self.gid_offset = int(sum(counts[: comm.rank]))
        blocks = np.concatenate(comm.allgather(self.node_blocks))
        order = np.argsort(blocks, kind="stable")
        mb = self.slave.blocks[:, self.mixed]
        self.facet_gid = order[np.searchsorted(blocks[order], mb)].astype(np.int64)

    def _recover(self) -> None:
        """Nodal recovery (:mod:`dolfinx_mortar.recovery`): γ, p̂ = ⟨λ − εγ⟩, p and the
        tangent data (collective)."""
        eps = self.eps
        has = self.A > 1e-12 * self.h_node ** (self.gdim - 1)
        safe_A = np.where(has, self.A, 1.0)
        self.has_area = has
        if self.recovery == "lumped":
            # node-local: γ = G/A, p = ⟨λ − ε γ⟩, tangent coefficient ε H / A
            gamma = np.where(has, self.G / safe_A, 0.0)
            trial = self.lmbda - eps * gamma
            active = has & (trial >= 0.0)
            # the nodes held in contact by the chattering control keep p = trial < 0 too
            closed = active if self.held is None else active | (has & self.held)
            self.gamma = gamma
            self.p_hat = np.where(active, trial, 0.0)
            self.p = self.p_hat if self.held is None else np.where(closed, trial, 0.0)
            self.kcoef = np.where(closed, eps / safe_A, 0.0)
        else:
            self._recover_mixed(has)
            active = self.p_hat > 0.0
            self.kcoef = np.zeros_like(eps)
        self.active = active
        self.predictor_nodes = 0
        self._no_contact = self.comm.allreduce(int(active.sum())) == 0
        self.touched_in_attempt |= not self._no_contact
        if self._no_contact and self._predictor_wanted():
            # Nothing in contact: a body held only by contact would have a singular Jacobian.
            # The nodes closest to contact (rc.near_contact) get the penalty stiffness in the
            # TANGENT only (the residual stays exact), so the first Newton step brings the
            # bodies into contact. Switched off as soon as one node is active, where the
            # tangent is exact again. The unconstrained recovery gets it in its own form
            # (closing γ = M⁻¹G: rc.recover's predictor); the others the lumped one.
            gamma = self.gamma
            gmin = self.comm.allreduce(float(gamma[has].min(initial=np.inf)), op=MPI.MIN)
            near = rc.near_contact(gamma, has, gmin, self.predictor_tol, self.h_node)
            if self.recovery != "unconstrained":
                self.kcoef = np.where(near, self.eps_soft / safe_A, 0.0)
            self.predictor_nodes = int(near.sum())
            self.active = np.zeros_like(active)
        if self.frictional:
            # the pressure below which the slip tolerance fades (_law_slip_tol), collective
            self._p_floor = UNLOADED_ROUND_OFF * self._law_round_off()
            self._recover_tangential()

    @property
    def free_body(self) -> bool:
        """Whether a body of the pair is free in some rigid motion, not held by the
        Dirichlet conditions (ContactProblem.bodies_held; collective at the first use,
        which every rank makes at the same point, then cached). Only then does a state
        with nothing in contact get the contact predictor throughout a solve
        (:meth:`_predictor_wanted`). Where the conditions hold both bodies, the Jacobian is
        regular without it, and its tangent-only stiffness slows Newton down once the
        contact opens (an unloaded press: ‖R‖ fell 0.3 % per iteration until the step was
        cut back without end)."""
        if self._free_body is None:
            self._free_body = not self.problem.bodies_held(self._body_cells)
        return self._free_body

    @property
    def touching(self) -> bool:
        """Whether some slave node of the pair, on any rank, carries pressure (p̂ > 0) at
        the last contact update (the same on every rank)."""
        return not self._no_contact

    def master_normals(self) -> tuple[np.ndarray, np.ndarray]:
        """The reference positions (npts, gdim) of this rank's master facet nodes (mesh
        coordinates: the pair's :attr:`origin` added back), each facet's nodes apart, and
        the facet's unit normal there (npts, gdim), of either sign (local;
        :meth:`~dolfinx_mortar.problem.ContactProblem.unheld_motions`)."""
        from .kernels.gap import unit_normal

        ml = self.master_local
        nf, nn, d = ml.X.shape
        normals = np.zeros((nf, nn, d))
        for f in range(nf):
            xf = np.ascontiguousarray(ml.X[f])
            for i, zeta in enumerate(REFERENCE_NODES[ml.ftype]):
                unit_normal(xf, ml.ftype, 1.0, np.ascontiguousarray(zeta), normals[f, i])
        return ml.X.reshape(-1, d) + self.origin, normals.reshape(-1, d)

    @property
    def body_cells(self) -> np.ndarray:
        """The local cells of the pair's slave and master facets (local indices)."""
        return self._body_cells

    def paired_points(self) -> int:
        """Local count of this rank's slave integration points that project onto a master
        facet at the last pairing (0 before the first)."""
        qp_m = getattr(self, "qp_m", None)
        return 0 if qp_m is None else int(np.count_nonzero(qp_m >= 0))

    def edge_facets_in_contact(self) -> int:
        """Local count of this rank's slave facets that segment integration pairs over part
        of their area only (a facet across the master surface's edge: a paired fraction
        below 1 − EDGE_FRACTION_TOL, :meth:`paired_fraction`) and that touch there (some
        paired point with gap ≤ 0) at the last contact update; 0 for element and node
        integration. Across such an edge the paired area has a kink in the displacement
        (docs/method-notes.md, "Segment integration"); the stop message names such facets.
        Not collective."""
        if self.integration != "segment" or self.slave.num_facets == 0:
            return 0
        fraction = self.paired_fraction(self.qp_m)
        partial = (fraction > 0.0) & (fraction < 1.0 - EDGE_FRACTION_TOL)
        touching = np.any((self.qp_m >= 0) & (self.qp_g <= 0.0), axis=1)
        return int(np.count_nonzero(partial & touching))

    def _predictor_wanted(self) -> bool:
        """Whether a state with nothing in contact gets the contact predictor (local; the
        same on every rank): always in a pair with a free body (:attr:`free_body`); where
        the Dirichlet conditions hold both bodies, only up to the solve's first Jacobian.
        There the springs keep the first iterate of a displacement-driven approach from
        pressing deep without contact forces (without them, ironing2d's first press step
        took a cutback); later in the solve, nothing in contact means the contact opens,
        and the springs would only slow Newton down (a press lifted off stopped after 6
        cutbacks). Collective (:attr:`free_body`, asked only after the solve's first
        Jacobian)."""
        return self._jac_active is None or self.free_body

    def _recover_mixed(self, has) -> None:
        """Unconstrained or constrained recovery on the gathered slave-surface system: the
        mortar mass matrix (rows of the owned nodes from each rank) and the nodal vectors
        are gathered on every rank, which solves the same system (collective)."""
        comm = self.comm
        nsf, nphi = self.node_of.shape
        Mf = np.zeros((nsf, nphi, nphi))
        if nsf:
            kmortar.facet_mass(self.ftype_phi, self.qp_xi, self.qp_w, self.qp_m, Mf)
            # A facet paired over part of its area only (the edge of the paired region, a
            # slave facet beyond the master's edge) enters lumped: with few paired points
            # its consistent block is rank deficient. The row sums, M·1 = A, are kept.
            partial = np.flatnonzero(self.paired_fraction(self.qp_m) < 1.0 - tg.PARTIAL_FACET_TOL)
            sums = Mf[partial].sum(axis=2)
            Mf[partial] = 0.0
            Mf[partial, np.arange(nphi)[:, None], np.arange(nphi)[:, None]] = sums.T
            self._partial_facets = np.zeros(nsf, bool)
            self._partial_facets[partial] = True
        fi, ii = np.nonzero(self.node_of >= 0)
        rows = np.repeat(self.facet_gid[fi, ii], nphi)
        cols = self.facet_gid[fi].ravel()
        vals = Mf[fi, ii].ravel()
        n = self.node_blocks.size
        local = np.concatenate(
            [self.A, self.G, self.lmbda, self.eps, has.astype(float), self.h_node]
        )
        parts = comm.allgather((rows, cols, vals, local.reshape(6, n)))
        rows, cols, vals = (np.concatenate([q[k] for q in parts]) for k in range(3))
        A, G, lam, eps, has_all, h_all = np.concatenate([q[3] for q in parts], axis=1)
        N = A.size
        M = sp.csr_matrix((vals, (rows, cols)), shape=(N, N))
        rec = rc.recover(
            self.recovery,
            M,
            A,
            G,
            lam,
            eps,
            has_all > 0.5,
            self.qp_frozen,
            predictor=(self.predictor_tol, h_all) if self._predictor_wanted() else None,
        )
        own = slice(self.gid_offset, self.gid_offset + n)
        self.gamma, self.p_hat, self.p = rec.gamma[own], rec.p_hat[own], rec.p[own]
        self._recovered = rec

    def paired_fraction(self, qp_m: np.ndarray) -> np.ndarray:
        """(nsf,) the fraction of each local slave facet that the points with
        ``qp_m`` ≥ 0 cover (qp_m (nsf, nq), as :attr:`qp_m`), exact to round-off for
        segment points too (:func:`~dolfinx_mortar.kernels.mortar.paired_fraction`;
        local)."""
        out = np.zeros(self.slave.num_facets)
        if out.size:
            kmortar.paired_fraction(self.ftype, self.slave.X, self.qp_xi, self.qp_w, qp_m, out)
        return out

    # ------------------------------------------------------------------ assembly
    def _terms(self, masked: bool = True):
        """The residual's entries per paired point and the contact force
        (:func:`.kernels.mortar.contact_terms`): (res_idx, res_val, force, sdofs, mdofs)."""
        nsf = self.qp_w.shape[0]
        ns, nm, d = self.slave.nodes_per_facet, self.master.nodes_per_facet, self.gdim
        nloc = (ns + nm) * d
        sdofs = self.slave.dofs if masked else self._all_dofs(self.slave).reshape(nsf, ns * d)
        mdofs = (
            self.master.dofs
            if masked
            else self._all_dofs(self.master).reshape(self.master.num_facets, nm * d)
        )
        npaired = int(np.count_nonzero(self.qp_m >= 0))
        res_idx = np.full((npaired, nloc), -1, np.int64)
        res_val = np.zeros((npaired, nloc))
        force = np.zeros(d)
        if nsf:
            kmortar.contact_terms(
                *self._point_args(sdofs, mdofs),
                self.p,
                res_idx,
                res_val,
                force,
            )
        return res_idx, res_val, force, sdofs, mdofs

    def _point_args(self, sdofs, mdofs) -> tuple:
        """The leading arguments shared by the point kernels (see kernels/mortar.py)."""
        return (
            self.ftype,
            self.master.ftype,
            self.ftype_phi,
            self.xs,
            self.xm,
            self.master.sign,
            self.qp_xi,
            self.qp_w,
            self.qp_m,
            self.qp_zeta,
            sdofs,
            mdofs,
            self.node_of,
        )

    def add_residual(self, b: PETSc.Vec, masked: bool = True) -> None:
        """Add this pair's residual to ``b`` (the global PETSc residual vector of the
        displacement space, force units) with global indices and ADD_VALUES: the normal
        part R_c = −Σ_I p^I B^I and, with friction, the tangential part
        R_T = Σ_I (G^I)ᵀ t^I (t^I the nodal tangential traction vector, G^I its force
        weights: those of the node's mortar slip integral S^I = Σ_k W_k x_k on the slave,
        and on the master at ζ_n, or at the current projection ζ where
        :attr:`force_at_current`). Nodes with t^I = 0 add nothing; the consistent
        recoveries may give t^I ≠ 0 at nodes the nodal law calls open, and those add
        theirs.

        Both are evaluated at the contact state of the last :meth:`update` (current
        coordinates, pairing, p^I, t^I), not at ``b``'s or the problem's ``u`` now. Each
        rank adds the rows of its own slave nodes; rows of other ranks' dofs are sent by
        the caller's ``b.assemble()`` (collective), which must follow. This method is local.

        ``masked``: True (the default) skips the dofs a Dirichlet condition constrains
        (their global index is −1, which PETSc ignores), as the Newton residual wants,
        whose constrained rows hold the condition; False adds to every dof, the
        constrained ones included (``ContactProblem.residual(..., apply_bcs=False)``:
        the reactions, which need the contact force on those dofs too).
        """
        res_idx, res_val, _, _, _ = self._terms(masked)
        keep = res_idx >= 0
        b.setValues(
            res_idx[keep].astype(PETSc.IntType), res_val[keep], addv=PETSc.InsertMode.ADD_VALUES
        )
        if self.frictional:
            # R_T = Σ_I (G^I)ᵀ t^I (the consistent recoveries may give t^I ≠ 0 at nodes
            # the nodal law calls open)
            act = np.any(self.t_vec != 0.0, axis=1)[self.s_node]
            vals = self.t_vec[self.s_node[act]] * self.s_g[act, None]
            if masked:
                idx = self.s_dof[act]
            else:
                idx = self.s_key[act, None] * self.bs + np.arange(self.gdim)
            keep = idx >= 0
            b.setValues(
                idx[keep].astype(PETSc.IntType), vals[keep], addv=PETSc.InsertMode.ADD_VALUES
            )

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """Add K_c to ``A`` with global indices (constrained dofs are −1 and ignored).

        Counts the Jacobians of the Newton solve in ``_jacobians``, once per call: the
        chattering control's freezes of the QP free set (constrained recovery) and of the
        stick/slip states (friction) read it (FREEZE_AFTER). Local."""
        self._jacobians += 1
        self._watch_pairing()
        if self.recovery == "lumped":
            self._watch_contact_set()
        scale = self._predictor_scale()  # collective: called at every Jacobian
        kcoef = self.kcoef
        if scale != 1.0:
            self.kcoef = kcoef * scale
        try:
            self._add_jacobian(A)
        finally:
            self.kcoef = kcoef

    def _predictor_scale(self) -> float:
        """The factor s ≤ 1 of the contact predictor's springs at this Jacobian (a lumped
        pair with nothing in contact; 1 otherwise). Collective.

        The lumped γ^I = G^I/A^I averages the gap over the node's facets, so at a touching
        tip it is still about h²/(12 R) > 0 (a curved slave on a flat master), and springs
        of the penalty's stiffness ε A move a body held by contact alone by only
        δ = F/(ε A) per Newton step: hertz2d with 128 load steps crept at 0.2–1 % of ‖R‖
        per iteration until every cutback of its first step had failed. From the second
        predictor Jacobian of a solve on, the springs are softened so that the next step
        closes the smallest gap: the last step closed c = γ_prev − γ_min with springs s_prev
        ε A, so they carried F = s_prev ε A c, and s = s_prev c / (γ_min + s_prev c) closes
        γ_min and presses the node by δ = s_prev c, the penalty's penetration under F."""
        # _no_contact is the same on every rank, so every rank takes part in the reduction
        if not (
            self.recovery == "lumped"
            and self._no_contact
            and self.comm.allreduce(self.predictor_nodes) > 0
        ):
            self._predictor_track = None
            return 1.0
        has = self.has_area
        gmin = self.comm.allreduce(float(self.gamma[has].min(initial=np.inf)), op=MPI.MIN)
        scale = 1.0
        if self._predictor_track is not None:
            g_prev, scale = self._predictor_track
            closed = g_prev - gmin
            need = gmin + scale * closed
            if closed > 0.0 and need > 0.0:
                scale = min(1.0, max(PREDICTOR_MIN_SCALE, scale * closed / need))
        self._predictor_track = (gmin, scale)
        return scale

    def _add_jacobian(self, A: PETSc.Mat) -> None:
        # the Hessian blocks, summed per (slave facet, master facet) pair, and the rows
        # B^I of the nodes with a tangent coefficient, in one pass over the points
        # (kernels.mortar.jacobian_terms; BENCHMARKS.md §83)
        sdofs, mdofs = self.slave.dofs, self.master.dofs
        h_idx, h_val, c_off, c_idx, c_val = self._jacobian_terms(self.kcoef, sdofs, mdofs, True)
        drop = self._drop_geometric_tangent()  # collective: called at every Jacobian
        geometric = GEOMETRIC_TANGENT_AT_FIRST_CONTACT or not drop
        self._geometric_on = geometric  # the friction's geometric block follows
        if not geometric:
            h_val[:] = 0.0
        rows = np.flatnonzero(h_idx.max(axis=1, initial=-1) >= 0)
        if rows.size:  # every pair's block in one call
            idx = h_idx[rows].astype(PETSc.IntType)
            A.setValuesRCV(idx, idx, h_val[rows], addv=PETSc.InsertMode.ADD_VALUES)
        # B^I ⊗ B^I of the nodes with a tangent coefficient
        self._dp_rows = None
        add_outer_blocks(A, c_off, c_idx, c_val, self.kcoef)
        self._seg_motion = self._seg_c_rows = None
        if self.integration == "segment" and self.slave.num_facets:
            self._seg_motion = self._segment_motion()
            self._add_segment_jacobian(A, sdofs, mdofs, c_off, c_idx, c_val, geometric)
        if self._recovered is not None and self.recovery != "lumped":
            self._add_mixed_jacobian(A, sdofs, mdofs)
            if self.recovery == "constrained":
                # chattering control: after FREEZE_AFTER Jacobians the QP's free set can only
                # grow (no node leaves it within the solve); uzawa_update re-checks it
                # against the plain QP when the solve has converged (_jacobians counts
                # the Jacobians of the solve, this one included: add_jacobian)
                if self._jacobians >= self.freeze_after:
                    self.qp_frozen = self._recovered.free.copy()
        if self.frictional:
            self._add_tangential_jacobian(A, c_off, c_idx, c_val)

    def _segment_motion(self) -> tuple[np.ndarray, np.ndarray]:
        """dξ_q (n_paired, k, nloc) and dw_q (n_paired, nloc) of the segment points with
        respect to their local dofs (:func:`.kernels.segment.segment_derivatives`; local)."""
        from .kernels.segment import segment_derivatives

        ns, nm, d = self.slave.nodes_per_facet, self.master.nodes_per_facet, self.gdim
        nloc = (ns + nm) * d
        n_rows = int(np.count_nonzero(self.qp_m >= 0))
        dxi, dw = np.zeros((n_rows, d - 1, nloc)), np.zeros((n_rows, nloc))
        if n_rows:
            segment_derivatives(
                self.ftype,
                self.xs,
                self.slave.X,
                self.slave.sign,
                self.master.ftype,
                self.xm,
                self.master.sign,
                self.cand_off,
                self.cand,
                *self.seg_rule,
                self.qp_m,
                dxi,
                dw,
            )
        return dxi, dw

    def _add_segment_jacobian(
        self, A, sdofs, mdofs, c_off, c_idx, c_val, geometric: bool = True
    ) -> None:
        """Segment integration: the terms of the moving segment points (local).

        The points ξ_q and weights w_q move with u: in 2D with the segment ends (the
        projections of the master end nodes onto the slave facet), in 3D with the vertices
        of the clipped polygons (:func:`.kernels.segment.segment_derivatives` gives dξ_q
        (k components) and dw_q per paired point). With p held fixed,
        R_c = −Σ_q (Σ_I p^I Φ_I(ξ_q)) w_q b_q varies by

            −b_q ⊗ [(Σ p ∂_β Φ) w_q dξ_q^β + (Σ p Φ) dw_q] − (Σ p Φ) w_q (∂b_q/∂ξ_β) ⊗ dξ_q^β.

        Lumped recovery: p^I = λ^I − ε^I G^I/A^I also varies through G^I and A^I, adding
        (ε^I/A^I) B^I ⊗ C^I with C^I = Σ_q Φ_I (g_q − γ^I) dw_q + w_q [∂_βΦ_I (g_q − γ^I)
        + Φ_I ∂g_q/∂ξ_β] dξ_q^β.

        ``geometric = False`` leaves the first (p-proportional) part out, as
        :meth:`add_jacobian` leaves out the geometric part of the element tangent
        (GEOMETRIC_TANGENT_AT_FIRST_CONTACT, DEEP_PENETRATION_TOL). The rows C^I are kept
        (``self._seg_c_rows``) for the friction tangent, whose ∂p^I they complete.

        Unconstrained and constrained recoveries: M, A and G vary with the points too,
        ∂γ = W(∂G − ∂M γ) and ∂p = Lᵀ(∂F − ∂M p), ∂F = A ∂p̂ + p̂ ∂A. The rows kept for
        :meth:`_add_mixed_jacobian` (``self._segment_rows``) are, per owned node I,

            C_γ^I = Σ_q Φ_I (g_q − γ_h) dw_q + w_q [∂_βΦ_I (g_q − γ_h) + Φ_I (∂_βg_q − ∂_βγ_h)] dξ_q^β,
            D_p^I = Σ_q Φ_I (p̂^I − p_h) dw_q + w_q [∂_βΦ_I (p̂^I − p_h) − Φ_I ∂_βp_h] dξ_q^β,

        with γ_h = Σ_J Φ_J γ^J and p_h = Σ_J Φ_J p^J at ξ_q (the nodal γ^I, p^I and no
        derivative on a partially paired facet, whose block of M is lumped). The motion of
        the points in the slip integrals of friction:
        :meth:`~dolfinx_mortar.tangential.TangentialTerms._segment_slip_motion`."""
        ns, nm, d = self.slave.nodes_per_facet, self.master.nodes_per_facet, self.gdim
        k, nloc = d - 1, (ns + nm) * d
        fr_, qr = np.nonzero(self.qp_m >= 0)
        n_rows = fr_.size
        if not n_rows:
            return
        mr = self.qp_m[fr_, qr]
        nphi = self.node_of.shape[1]
        dxi, dw = self._seg_motion
        b, db = np.zeros((n_rows, nloc)), np.zeros((n_rows, k, nloc))
        g, gxi = np.zeros(n_rows), np.zeros((n_rows, k))
        phi, dphi = np.zeros((n_rows, nphi)), np.zeros((n_rows, nphi, k))
        kmortar.point_xi_terms(*self._point_args(sdofs, mdofs), b, db, g, gxi, phi, dphi)
        w = self.qp_w[fr_, qr]
        nodes = self.node_of[fr_]  # (n_rows, nphi), −1: not an owned node
        idx = np.concatenate([sdofs[fr_], mdofs[mr]], axis=1)
        ADD = PETSc.InsertMode.ADD_VALUES
        if geometric:
            pn = np.where(nodes >= 0, self.p[np.maximum(nodes, 0)], 0.0)
            s0 = np.einsum("ri,ri->r", pn, phi)
            s1 = np.einsum("ri,rib->rb", pn, dphi)
            move = np.einsum("rb,rbj->rj", s1 * w[:, None], dxi) + s0[:, None] * dw
            extra = -np.einsum("ri,rj->rij", b, move)
            extra -= np.einsum("rbi,rbj->rij", (s0 * w)[:, None, None] * db, dxi)
            add_keyed_blocks(A, fr_ * self.master.num_facets + mr, idx, idx, extra)
        if self.recovery != "lumped":
            self._segment_rows = self._mixed_segment_rows(
                fr_, nodes, idx, w, g, gxi, phi, dphi, dxi, dw
            )
            return
        # (ε/A) B^I ⊗ C^I of the lumped nodes with a tangent coefficient
        rr, ii = np.nonzero((nodes >= 0) & (self.kcoef[np.maximum(nodes, 0)] > 0.0))
        if not rr.size:
            return
        node = nodes[rr, ii]
        gg = g[rr] - self.gamma[node]
        xcoef = w[rr, None] * (dphi[rr, ii] * gg[:, None] + phi[rr, ii, None] * gxi[rr])
        cvals = (phi[rr, ii] * gg)[:, None] * dw[rr] + np.einsum("rb,rbj->rj", xcoef, dxi[rr])
        cols = idx[rr]
        keep = cols >= 0
        ndof = int(self.ranges[-1]) * self.bs
        Cm = sp.csr_matrix(
            (cvals[keep], (np.broadcast_to(node[:, None], cols.shape)[keep], cols[keep])),
            shape=(self.node_blocks.size, ndof),
        )
        self._seg_c_rows = Cm  # ∂p^I = −(ε^I/A^I)(B^I + C^I): the friction tangent needs C
        for n_ in np.unique(node):
            s, e = c_off[n_], c_off[n_ + 1]
            cs, ce = Cm.indptr[n_], Cm.indptr[n_ + 1]
            if e > s and ce > cs:
                A.setValues(
                    c_idx[s:e].astype(PETSc.IntType),
                    Cm.indices[cs:ce].astype(PETSc.IntType),
                    self.kcoef[n_] * np.outer(c_val[s:e], Cm.data[cs:ce]),
                    addv=ADD,
                )

    def _mixed_segment_rows(self, fr_, nodes, idx, w, g, gxi, phi, dphi, dxi, dw):
        """The rows C_γ^I and D_p^I of :meth:`_add_segment_jacobian` (its docstring) of the
        owned nodes, as CSR (n, ndof) with global dof columns (local)."""
        rec = self._recovered
        gid = self.facet_gid[fr_]  # (rows, nphi) global node numbers of the facet nodes
        gam, pv = rec.gamma[gid], rec.p[gid]
        partial = self._partial_facets[fr_]
        rr, ii = np.nonzero(nodes >= 0)
        node = nodes[rr, ii]
        ph, dph = phi[rr, ii], dphi[rr, ii]  # (n,), (n, k)
        g_h = np.einsum("ri,ri->r", phi, gam)[rr]
        g_hx = np.einsum("rib,ri->rb", dphi, gam)[rr]
        p_h = np.einsum("ri,ri->r", phi, pv)[rr]
        p_hx = np.einsum("rib,ri->rb", dphi, pv)[rr]
        lump = partial[rr]
        g_h = np.where(lump, gam[rr, ii], g_h)
        p_h = np.where(lump, pv[rr, ii], p_h)
        g_hx = np.where(lump[:, None], 0.0, g_hx)
        p_hx = np.where(lump[:, None], 0.0, p_hx)
        gg, pp = g[rr] - g_h, self.p_hat[node] - p_h
        wr = w[rr, None]
        dx = dxi[rr]
        c_x = wr * (dph * gg[:, None] + ph[:, None] * (gxi[rr] - g_hx))
        d_x = wr * (dph * pp[:, None] - ph[:, None] * p_hx)
        c_vals = (ph * gg)[:, None] * dw[rr] + np.einsum("rb,rbj->rj", c_x, dx)
        d_vals = (ph * pp)[:, None] * dw[rr] + np.einsum("rb,rbj->rj", d_x, dx)
        cols = idx[rr]
        keep = cols >= 0
        ndof = int(self.ranges[-1]) * self.bs
        rows = np.broadcast_to(node[:, None], cols.shape)[keep]
        shape = (self.node_blocks.size, ndof)
        Cg = sp.csr_matrix((c_vals[keep], (rows, cols[keep])), shape=shape)
        Dp = sp.csr_matrix((d_vals[keep], (rows, cols[keep])), shape=shape)
        return Cg, Dp

    def _b_rows(self, mask, sdofs, mdofs):
        """Rows B^I = ∂G^I/∂u of the owned nodes with mask > 0, as CSR (c_off, c_idx, c_val)
        with sorted global dofs (constrained dofs dropped)."""
        return self._jacobian_terms(mask, sdofs, mdofs, False)[2:]

    def _jacobian_terms(self, mask, sdofs, mdofs, want_hess: bool):
        """:func:`.kernels.mortar.jacobian_terms` at the state of the last :meth:`update`:
        (h_idx, h_val, c_off, c_idx, c_val), the Hessian blocks per (slave facet, master
        facet) pair (none unless ``want_hess``) and the compressed rows B^I of the owned
        nodes with mask > 0 (local)."""
        if not self.slave.num_facets:
            nloc = (self.slave.nodes_per_facet + self.master.nodes_per_facet) * self.gdim
            c_off = np.zeros(self.node_blocks.size + 1, np.int64)
            return (
                np.empty((0, nloc), np.int64),
                np.empty((0, nloc, nloc)),
                c_off,
                np.empty(0, np.int64),
                np.empty(0),
            )
        return kmortar.jacobian_terms(
            *self._point_args(sdofs, mdofs), self.p, np.asarray(mask, float), bool(want_hess)
        )

    def _add_mixed_jacobian(self, A, sdofs, mdofs) -> None:
        """Σ_I d_I a^I ⊗ c^I, a^I = Σ_J L_IJ B^J, c^I = Σ_K R_IK B^K
        (:mod:`dolfinx_mortar.recovery`) for the owned tangent nodes I. The rows B^J of
        every node in the supports of L and R are gathered (collective)."""
        rec, comm = self._recovered, self.comm
        n = self.node_blocks.size
        lo = self.gid_offset
        need = np.unique(np.concatenate([rec.left.indices, rec.right.indices]))
        mine = need[(need >= lo) & (need < lo + n)] - lo
        mask = np.zeros(n)
        mask[mine] = 1.0
        c_off, c_idx, c_val = self._b_rows(mask, sdofs, mdofs)
        parts = comm.allgather(
            (
                mine + lo,
                c_off[mine + 1] - c_off[mine],
                np.concatenate([c_idx[c_off[i] : c_off[i + 1]] for i in mine] or [c_idx[:0]]),
                np.concatenate([c_val[c_off[i] : c_off[i + 1]] for i in mine] or [c_val[:0]]),
            )
        )
        # ranks hold consecutive gids and send them sorted: the gather is in gid order
        gids = np.concatenate([q[0] for q in parts])
        lengths = np.zeros(rec.p.size, np.int64)
        lengths[gids] = np.concatenate([q[1] for q in parts])
        indptr = np.zeros(rec.p.size + 1, np.int64)
        np.cumsum(lengths, out=indptr[1:])
        row_idx = np.concatenate([q[2] for q in parts])
        row_val = np.concatenate([q[3] for q in parts])
        ndof = int(self.ranges[-1]) * self.bs
        Bm = sp.csr_matrix((row_val, row_idx, indptr), shape=(rec.p.size, ndof))
        seg = None
        if self.integration == "segment":  # on every rank (collective)
            empty = sp.csr_matrix((n, ndof))
            seg = self._segment_rows or (empty, empty)
        self._segment_rows = None
        Cm = Bm
        if seg is not None:
            # segments: c^I = Σ_K W_IK (B^K + C_γ^K), with the rows C_γ of every node
            Cg = seg[0].tocoo()
            parts = comm.allgather((Cg.row + lo, Cg.col, Cg.data))
            r_, c_, v_ = (np.concatenate([q[k] for q in parts]) for k in range(3))
            Cm = Bm + sp.csr_matrix((v_, (r_, c_)), shape=Bm.shape)
        t = rec.tangent_nodes
        sel = np.flatnonzero((t >= lo) & (t < lo + n))
        Lm = (rec.left[sel] @ Bm).tocsr()
        Rm = (rec.right[sel] @ Cm).tocsr()
        if self.frictional:
            # −∂p^J/∂u = Σ_I L_IJ (d_I c^I − D_p^I) for the owned nodes J (the slip tangent
            # needs it; D_p only with segments)
            own = slice(lo, lo + n)
            LdR = (rec.left.T @ sp.diags(rec.d) @ rec.right).tocsr()[own]
            dp = LdR @ Cm
            if seg is not None:
                Dc = seg[1].tocoo()
                parts = comm.allgather((Dc.row + lo, Dc.col, Dc.data))
                r_, c_, v_ = (np.concatenate([q[k] for q in parts]) for k in range(3))
                Dg = sp.csr_matrix((v_, (r_, c_)), shape=Bm.shape)
                rows_d = np.flatnonzero(np.diff(Dg.indptr) > 0)
                if rows_d.size:
                    dp = dp - rec.left_rows(rows_d).T.tocsr()[own] @ Dg[rows_d]
            self._dp_rows = dp.tocsr()
        keys = []
        rr = np.arange(sel.size)
        self._add_row_products(A, Lm, rr, Rm, rr, rec.d[sel], keys)
        if seg is not None:
            # −Σ_I (Σ_J L_IJ B^J) ⊗ D_p^I over the owned nodes I with a row D_p
            Dp = seg[1].tocsr()
            own_nodes = np.flatnonzero(np.diff(Dp.indptr) > 0)
            if own_nodes.size:
                La = (rec.left_rows(own_nodes + lo) @ Bm).tocsr()
                coef = -np.ones(own_nodes.size)
                self._add_row_products(A, La, np.arange(own_nodes.size), Dp, own_nodes, coef, keys)
        self._learned = np.unique(np.concatenate(keys)) if keys else np.empty(0, np.int64)

    def _add_row_products(self, A, La, li, Ra, ri, coef, keys) -> None:
        """A += Σ_k coef_k L_{li_k} ⊗ R_{ri_k} for rows of the CSR matrices La, Ra (global dof
        columns); appends the block couplings filled to ``keys`` (local).

        Formed as one sparse product K = L_liᵀ diag(coef) R_ri and inserted once, row by
        row (padded batches), on the structure of |L_li|ᵀ|R_ri| (the union of the outer
        products' supports, whatever cancels). One outer product per node inserted every
        entry of the union once per node: the constrained recovery's rows L_I, R_I reach
        the contact zone's part of the free set and the paired region through M⁻¹, so the
        3D Cattaneo–Mindlin hemisphere at h_contact = 0.6 put up to 24 × 2.4 × 10⁵ = 5.8 ×
        10⁶ entries through MatSetValues per Jacobian, 2.4 × 10⁵ distinct (session 53)."""
        if not len(li):
            return
        L, R = La[li], Ra[ri]
        K = (L.T @ sp.diags(np.asarray(coef, float)) @ R).tocsr()
        S = (abs(L).T @ abs(R)).tocsr()
        if not S.nnz:
            return
        S.sort_indices()
        K.sort_indices()
        ncol = np.int64(S.shape[1])
        srow = np.repeat(np.arange(S.shape[0], dtype=np.int64), np.diff(S.indptr))
        skey = srow * ncol + S.indices
        krow = np.repeat(np.arange(K.shape[0], dtype=np.int64), np.diff(K.indptr))
        vals = np.zeros(S.nnz)
        vals[np.searchsorted(skey, krow * ncol + K.indices)] = K.data
        rows = np.flatnonzero(np.diff(S.indptr) > 0)
        off = S.indptr.astype(np.int64)
        width = int(np.diff(off)[rows].max())
        step = max(1, (1 << 22) // width)
        for lo_ in range(0, rows.size, step):
            sel = rows[lo_ : lo_ + step]
            cols, val = padded_rows(off, sel, S.indices.astype(np.int64), vals)
            A.setValuesRCV(
                sel.astype(PETSc.IntType)[:, None],
                cols,
                val[:, None, :],
                addv=PETSc.InsertMode.ADD_VALUES,
            )
        nb = int(self.ranges[-1])
        keys.append(np.unique((srow // self.bs) * nb + S.indices // self.bs))

    # ------------------------------------------------------------------ sparsity
    def learned_couplings(self) -> np.ndarray:
        """Global block couplings (block row × N_blocks + block column, any rows; local)
        of the last assembled tangent that :meth:`block_couplings` does not derive from
        the facets: those of the unconstrained/constrained recoveries (through M⁻¹,
        several node rings apart) and of the mixed tangential tangent."""
        return np.concatenate([self._learned, self._learned_t])

    def block_couplings(self) -> tuple[np.ndarray, np.ndarray]:
        """Global (block row, block col) pairs the contact terms may fill: for every owned
        node, all nodes of its slave facets and of their candidate master facets."""
        if self.master is None:
            self.update(self.problem.u)
        nsf = self.slave.num_facets
        if nsf == 0 or self.node_blocks.size == 0:
            return self._no_couplings
        # blocks seen by each slave facet: its own nodes and its candidates' nodes
        cand_sets = self._candidate_sets()
        inputs = [a for pair in cand_sets for a in pair] + [self._learned, self._learned_t]
        memo = self._couplings_memo
        if (
            memo is not None
            and memo[0][0] == self._exchanges
            and len(memo[0]) == len(inputs) + 1
            and all(np.array_equal(a, b) for a, b in zip(memo[0][1:], inputs, strict=True))
        ):
            return memo[1]
        result = self._block_couplings(nsf, cand_sets)
        self._couplings_memo = ([self._exchanges, *inputs], result)
        return result

    def _candidate_sets(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """(offsets (nsf + 1,), master facets) of the candidates of each slave facet: the
        pairing's and, with friction, the t_n masters of the slip (local)."""
        cand_sets = [(self.cand_off, self.cand)]
        if self.frictional:
            cand_sets.append(self.hist_cand)
        return cand_sets

    def _candidate_blocks(self, nsf: int, cand_sets) -> tuple[np.ndarray, np.ndarray]:
        """(slave facet, master block) of every node of every candidate master facet of
        every slave facet, unsorted, (n,) each (local)."""
        per = self.master.nodes_per_facet
        fac = [np.empty(0, np.int64)] + [
            np.repeat(np.repeat(np.arange(nsf, dtype=np.int64), np.diff(off)), per)
            for off, _ in cand_sets
        ]
        blk = [np.empty(0, np.int64)] + [self.master.blocks[c].ravel() for _, c in cand_sets]
        return np.concatenate(fac), np.concatenate(blk).astype(np.int64)

    def coupling_cover(self) -> tuple[np.ndarray, np.ndarray]:
        """What :meth:`block_couplings` is made of, in a form that is cheap to compare
        (local): the sorted unique keys slave facet × N_blocks + master block, one per
        node of every candidate master facet of every slave facet (the pairing's and,
        with friction, the slip's t_n masters), and the sorted learned couplings
        (:meth:`learned_couplings`). If both are subsets of an earlier cover, so are
        the couplings: a node couples all blocks that its slave facets see, and no
        facet sees a new block. The 3D ironing demo: 2 × 10⁴ keys, where the
        couplings are 1.1 × 10⁵ (from 1.5 × 10⁶ per-node pairs); the master facets'
        numbering, which a new exchange changes, does not enter."""
        if self.master is None:
            self.update(self.problem.u)
        nsf = self.slave.num_facets
        keys = np.empty(0, np.int64)
        if nsf and self.node_blocks.size:
            fac, blk = self._candidate_blocks(nsf, self._candidate_sets())
            keys = fac * int(self.ranges[-1]) + blk
        return np.unique(keys), np.unique(self.learned_couplings())

    def _block_couplings(self, nsf, cand_sets) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`block_couplings` computed (local): each (block row, block col) pair once,
        sorted by row, then column (the learned couplings after them, as they are).

        Node I couples every pair of the blocks its slave facets see (its set S_I): the
        pattern is the union of S_I × S_I, the product Bᵀ B of the (node, block)
        incidence B (scipy's sparse product, counts in int32: no entry cancels). It was
        made as every S_I × S_I, concatenated (7.2 × 10⁶ pairs on demo_cattaneo3d, for
        4.1 × 10⁵ distinct ones), and sorted by the problem (``unique_runs``). The product
        runs over the blocks this rank's facets see (``seen``, sorted), not over all the
        problem's blocks: no array of the global size per rank."""
        cf, cb = self._candidate_blocks(nsf, cand_sets)
        fac = np.concatenate([np.repeat(np.arange(nsf), self.slave.nodes_per_facet), cf])
        seen, blk = np.unique(
            np.concatenate([self.slave.blocks.ravel(), cb]).astype(np.int64), return_inverse=True
        )
        nb, n, m = int(self.ranges[-1]), self.node_blocks.size, seen.size
        # (slave facet, block) and (node, slave facet) incidences: B = N F, (node, block)
        F = sp.csr_matrix((np.ones(fac.size, np.int32), (fac, blk)), shape=(nsf, m))
        fi, ii = np.nonzero(self.node_of >= 0)
        N = sp.csr_matrix((np.ones(fi.size, np.int32), (self.node_of[fi, ii], fi)), shape=(n, nsf))
        B = (N @ F).tocsr()
        B.data[:] = 1
        P = (B.T.tocsr() @ B).tocsr()
        P.sort_indices()  # seen is sorted: the global pairs come sorted too
        rows = [np.repeat(seen, np.diff(P.indptr))]
        cols = [seen[P.indices]]
        for learned in (self._learned, self._learned_t):
            # the unconstrained/constrained tangents couple nodes a few rings apart: the
            # couplings of the last assembled tangent
            rows.append(learned // nb)
            cols.append(learned % nb)
        return np.concatenate(rows), np.concatenate(cols)

    # ------------------------------------------------------------------ Uzawa, steps
    def begin_solve(self) -> None:
        """A Newton solve starts: the constrained recovery's active set and the pairing
        are free again (chattering control), the stick/slip states too unless the last
        Uzawa round carried them (``carry_states``, :meth:`uzawa_update`): then they are
        frozen from the start; the contact predictor's springs start at full stiffness."""
        self._jacobians = 0
        self._predictor_track = None
        self.qp_frozen = None
        self.held, self._set_jacobians = None, 0
        self.qp_pinned, self._pair_hist, self._pair_jacobians = None, [], 0
        self.qp_flip = None
        if self._carried_pins is not None and self._pin_exchange == self._exchanges:
            self.qp_pinned = self._carried_pins.copy()
            self.qp_flip = self.qp_pinned >= 0
        self._jac_active = None
        if self.frictional:
            self.frozen = self._carried if self.carry_states else None
            self._slip_prev = None  # slip reversal (chattering control)
            self._from_predictor = self._solves == 0
            self._solves += 1

    def _max_penetration(self) -> float:
        active = self.p_hat > 0
        return self.comm.allreduce(float(np.max(-self.gamma[active], initial=0.0)), op=MPI.MAX)

    def soft_penalty(self, on: bool) -> None:
        """Use ε_soft and ε_T,soft (``on``) or the pair's own ε and ε_T (local). The nodal
        state follows at the next :meth:`update`; the Uzawa acceleration's history, taken
        with the other penalty, is dropped. See SOFT_START_RATIO."""
        self.uzawa_acceleration.reset()
        self._round_changes = []
        self.eps = self.eps_soft if on else self._eps_own
        if self.frictional:
            self.eps_t = self.eps_t_soft if on else self._eps_t_own
            self._slip_tol = tg.SLIP_TOL * self.eps_t * self.h_node

    @property
    def soft_start(self) -> bool:
        """Whether a load step first goes through its Uzawa rounds under ε_soft: a
        penalty ratio above 1 with Uzawa, above SOFT_START_RATIO as pure penalty (the
        same on every rank)."""
        threshold = 1.0 if self.uzawa_tol > 0.0 else SOFT_START_RATIO
        return max(self.penalty_ratio, self._penalty_t_ratio) > threshold

    def stiff_penalty_note(self) -> str:
        """A clause for the error of a run that stops, where this pair's largest normal or
        tangential penalty exceeds :data:`MEASURED_PENALTY_RATIO` times the largest normal
        auto value ε_auto = AUTO_PENALTY_FACTOR E*/h (the ratios of set-up), or, with
        Uzawa rounds, where a node's penalty is more than SOFT_PENALTY_NOTE times softer
        than its auto rule (``softness``, ``softness_t``); "" otherwise. Local; the same
        on every rank (the ratios are reduced at set-up)."""
        keys = [
            (k, r)
            for k, r in (
                ("penalty", self.penalty_ratio),
                ("penalty_tangential", self._penalty_t_ratio),
            )
            if r > MEASURED_PENALTY_RATIO
        ]
        notes = []
        if keys:
            said = " and the ".join(f"{k} is {r:.3g} times" for k, r in keys)
            notes.append(
                f"on {self.name} the {said} the auto normal penalty ({AUTO_PENALTY_FACTOR:g} "
                f"E*/h), beyond the {MEASURED_PENALTY_RATIO:g} times at which stiff "
                'penalties were measured: with Uzawa a softer penalty ("auto") reaches '
                "the same solution"
            )
        if self.uzawa_tol > 0.0 and (soft := self._soft_clause()):
            notes.append(f"on {self.name} {soft}")
        return "; ".join(notes)

    def _soft_clause(self) -> str:
        """ "the penalty is up to C times softer ... than its auto rule: ..." where a
        node's normal or tangential penalty is more than SOFT_PENALTY_NOTE times softer
        than its auto rule (``softness``, ``softness_t``), else "" (local; the same on
        every rank). Said at set-up (a warning, with Uzawa rounds) and in the error of a
        run that stops (:meth:`stiff_penalty_note`)."""
        soft = [
            (k, r)
            for k, r in (("penalty", self.softness), ("penalty_tangential", self.softness_t))
            if r > SOFT_PENALTY_NOTE
        ]
        if not soft:
            return ""
        said = " and the ".join(f"{k} is up to {r:.3g} times softer" for k, r in soft)
        return (
            f"the {said} than its auto rule: a round moves the multipliers by the penalty "
            "times the penetration (or the elastic slip), so the Uzawa rounds crawl; a "
            'stiffer penalty ("auto") reaches the same solution in fewer rounds'
        )

    @property
    def round_off_scale(self) -> float:
        """The factor ≥ 1 on the absolute Newton tolerance: the ratios of the largest
        penalties to the largest normal auto value, ε/ε_auto and ε_T/ε_auto (1 while
        :meth:`soft_penalty` is on). Local; the same on every rank (the ratios are reduced
        at set-up)."""
        if self.eps is not self._eps_own:  # soft_penalty is on
            return 1.0
        return max(1.0, self.penalty_ratio, self._penalty_t_ratio)

    def begin_step(self) -> None:
        """Reset the Uzawa acceleration's history (multipliers carry over from the last step)
        and :attr:`touched_in_attempt`; with friction, the last committed state becomes the
        slip reference t_n."""
        self._reset_acceleration()
        self._carried = None
        self._carried_pins = None
        self._solves = 0
        self.touched_in_attempt = False
        if self.frictional:
            if self._pending is not None:
                u_n, tau, t_n = self._pending
                if self.tangential_frame == "master":
                    self._hist_vec = t_n
                u_n.copy(self._u_n)
                u_n.destroy()
                self._u_n_version += 1
                self.lmbda_t = tau.copy()
                self.lmbda_t_committed = tau.copy()
                self._pending = None
            self.frozen = None
            self._dual_fixed = None  # the facets' Ψ/Φ choice, segment integration

    def commit_step(self) -> None:
        """Accept the converged step. With friction: accumulate slip and dissipation, and
        keep (u, τ) as the history of the next step (the state itself is still that of
        this step until :meth:`begin_step`, so outputs report this step)."""
        self.lmbda_committed = self.lmbda.copy()
        self.loaded = self.comm.allreduce(int(np.any(self.p_hat > 0.0)), op=MPI.MAX) > 0
        if self.frictional:
            act = self.fstate > 0
            self.slip_length_committed = self.slip_length_committed + np.where(
                act, np.linalg.norm(self.gamma_t, axis=1), 0.0
            )
            slip = self.fstate == fr.SLIP
            # Σ over slipping nodes of τ^I·σ^I (σ = a·S − a_n·S_n = A_T γ when lumped)
            local = float(np.sum(np.einsum("na,na->n", self.tau, self.sigma_t)[slip]))
            self.dissipation = self.comm.allreduce(local)
            touching = self.p_hat > 0.0
            counts = [int(touching.sum()), int(np.count_nonzero(slip & touching))]
            self.committed_slip = tuple(self.comm.allreduce(np.array(counts)).tolist())
            if self._pending is not None:
                self._pending[0].destroy()
            hist = np.where((self.fstate > 0)[:, None], self.tau_law, 0.0)
            # t^n as vectors too: the master frames carry them into the next t_n's frames
            t_n = np.einsum("na,nac->nc", hist, self.frame_a)
            self._pending = (self.problem.u.vector.copy(), hist, t_n)

    def restore_step(self) -> None:
        """Undo a failed attempt at a step (local): the normal multipliers λ go back to
        those of the last :meth:`commit_step` (zero before the first), the Uzawa
        acceleration's history is dropped and no stick/slip states are carried into the
        next attempt; with friction, the tangential multipliers λ_T go back to those the
        step started from (the history t^n of the last commit, set by :meth:`begin_step`
        or, with the master frame, at the step's first search) and no state is frozen.
        The slip history (u_n, t^n), the accumulated slip and the dissipation are those
        of the last commit already (an attempt does not change them). The nodal state
        (p̂, γ, τ, the stick/slip states, the pairing) is not restored: it is the failed
        attempt's until the next :meth:`update`, after the caller has put u back."""
        self.lmbda = self.lmbda_committed.copy()
        self._carried = None
        self._reset_acceleration()
        if self.frictional:
            self.lmbda_t = self.lmbda_t_committed.copy()
            self.frozen = None

    def destroy(self) -> None:
        """Free the PETSc objects this term owns."""
        for obj in (self._fetch_slave, self._fetch_mlocal, self._fetch_cand):
            if obj is not None:
                obj.destroy()
        if self.frictional:
            self._u_n.destroy()
            if self._pending is not None:
                self._pending[0].destroy()

    # ------------------------------------------------------------------ results
    def statistics(self) -> dict:
        """This pair's totals at the state of the last contact update (after a converged
        step: that step's, until the next one starts), summed over all ranks: collective,
        the same dict on every rank. Keys:

        - ``max_penetration``: the largest −γ^I (mixed nodal gap) over the slave nodes
          with pressure (p̂^I > 0), a length ≥ 0; 0 where none penetrates.
        - ``dissipation`` (frictional pairs only): the frictional work of the last
          committed step, Σ over slipping nodes of τ^I·σ^I (σ^I = A_T^I γ_T^I lumped),
          force × length (per unit thickness in 2D); set by :meth:`commit_step`.
        - ``force``: list of ``gdim`` floats, the total force that the master exerts on
          the slave, Σ_I p^I ∫ Φ_I ν dA over the reference slave surface, minus
          Σ_I A_T^I t^I with friction (force units; per unit thickness in 2D); with the
          traction at the current projection (FORCE_AT_CURRENT_PROJECTION) A^I in place
          of A_T^I (its force weights cover every point paired now).
        - ``active_nodes``: the number of slave nodes with p̂^I > 0.
        - ``stick_nodes``, ``slip_nodes``: the numbers of slave nodes in the output
          states 1 and 2 (:meth:`_output_state`: an active frictionless node, and an
          active frictional node without tangential traction yet, counts as slipping).

        The nodes are the mixed-field nodes of the slave surface, each counted on its
        owning rank.
        """
        force = self._terms()[2]
        active = self.p_hat > 0
        out = {"max_penetration": self._max_penetration()}
        if self.frictional:
            # the master pushes the slave with −t^I per unit reference area, over the
            # points of the force weights: those of the S-weights (A_T), or with the
            # traction at ζ every point paired now (A^I: Σ_q w Ψ_I = Σ_q w Φ_I there)
            area = self.A if self.force_at_current else self.AT
            force = force - np.einsum("n,nc->c", area, self.t_vec)
            out["dissipation"] = self.dissipation
        state = self._output_state()
        stick = int(np.count_nonzero(state == fr.STICK))
        slip = int(np.count_nonzero(state == fr.SLIP))
        counts = self.comm.allreduce(np.array([int(active.sum()), stick, slip]))
        out.update(
            force=[float(v) for v in self.comm.allreduce(force)],
            active_nodes=int(counts[0]),
            stick_nodes=int(counts[1]),
            slip_nodes=int(counts[2]),
        )
        return out

    def _output_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """Outward unit normals (n, d) and the SCENES.md output tangents (n, d−1, d)."""
        n = self.node_blocks.size
        if self.frictional:
            nrm = self.frame_n
        else:
            nrm = np.zeros((n, self.gdim))
        if self.gdim == 2:
            return nrm, np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)[:, None, :]
        ax = np.zeros((n, 3))
        near_x = np.abs(nrm[:, 0]) > np.cos(np.radians(10.0))
        ax[~near_x, 0] = 1.0
        ax[near_x, 1] = 1.0
        t0 = ax - np.einsum("nc,nc->n", ax, nrm)[:, None] * nrm
        t0 /= np.maximum(np.linalg.norm(t0, axis=1), 1e-300)[:, None]
        return nrm, np.stack([t0, np.cross(nrm, t0)], axis=1)

    def _output_state(self) -> np.ndarray:
        """The nodal state of the outputs (n,): 0 open, 1 stick, 2 slip.

        A node that carries pressure (p̂^I > 0) but no tangential traction is reported as
        sliding: every active node of a frictionless pair, and a frictional node in the
        step in which it enters contact (it has no slip history at t_n, so the nodal law
        leaves it open: zero traction, free to slide). Only nodes without pressure are
        open (0)."""
        touching = self.p_hat > 0
        if not self.frictional:
            return np.where(touching, fr.SLIP, fr.OPEN)
        # a node without pressure is open whatever its law's state (the initial state of a
        # touching frictional pair had every node at gap 0 "stick" with p_N = 0)
        state = np.where(self.fstate == fr.OPEN, fr.SLIP, self.fstate)
        return np.where(touching, state, fr.OPEN)

    def _tangential_output(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p_T (n, d−1) in the output frame (traction of the master on the slave), the
        accumulated slip length (n,) and the state (n,) of :meth:`_output_state`."""
        n, d = self.node_blocks.size, self.gdim
        if not self.frictional:
            return np.zeros((n, d - 1)), np.zeros(n), self._output_state()
        _, tang = self._output_frame()
        p_t = -np.einsum("nac,nc->na", tang, self.t_vec)
        return p_t, self.slip_length_committed, self._output_state()

    def node_table(self) -> np.ndarray | None:
        """Rows x, y(, z), X, Y(, Z), p_N, p_T0(, p_T1), gap, slip, state of every slave node, on rank 0.

        Nodes in contact without tangential traction are reported as sliding (state 2,
        :meth:`_output_state`); ``gap`` is the mixed
        nodal gap γ^I (NaN where the node sees no master); p_T are the components of the
        tangential traction of the master on the slave in the SCENES.md output frame.
        """
        f, i = self._node_at
        n, d = self.node_blocks.size, self.gdim
        gap = np.where(self.has_area, self.gamma, np.nan)
        p_t, slip, state = self._tangential_output()
        cols = [  # mesh coordinates: the pair's origin added back
            self.slave.X[f, i] + self.origin,
            self.xs[f, i] + self.origin,
            self.p[:, None],
            p_t,
            gap[:, None],
            slip[:, None],
            state[:, None],
        ]
        table = np.hstack(cols) if n else np.empty((0, 3 * d + 3))
        parts = self.comm.gather(table, root=0)
        return np.concatenate(parts) if self.comm.rank == 0 else None

    def fill_fields(self, functions: dict, claimed: np.ndarray | None = None) -> None:
        """Write nodal contact fields into scalar P_k functions (owned slave nodes only;
        local).

        ``claimed`` (float (m, 2), m the length of the functions' arrays, all −inf before
        the first pair of a write; updated): at a node of several pairs' slave surfaces
        (two slave surfaces of one body that meet at a corner) the fields take one pair's
        values, those of the pair ranked first by (in contact, p̂ > 0; sees a master; its
        p_N where in contact), the earlier pair on a tie: ``claimed`` holds the rank of
        the values written so far, and is passed to each pair of the write in turn.
        Without it, the pair overwrites every node of its surface (before session 59 the
        last pair always did: a corner node in contact on the first pair showed the
        second's p_N = 0 and state 0)."""
        local = (self.node_blocks - self.ranges[self.comm.rank]).astype(np.int64)
        p_t, slip, state = self._tangential_output()
        vals = {
            "contact_pressure": self.p,
            "gap": np.where(self.has_area, self.gamma, 0.0),
            "contact_state": state.astype(float),
            "tangential_traction": np.linalg.norm(p_t, axis=1),
            "slip": slip,
        }
        if claimed is not None:
            touching = self.p_hat > 0.0
            rank = np.where(touching, 2.0, np.where(self.has_area, 1.0, 0.0))
            size = np.where(touching, self.p, -np.inf)
            old_rank, old_size = claimed[local, 0], claimed[local, 1]
            take = (rank > old_rank) | ((rank == old_rank) & (size > old_size))
            local = local[take]
            vals = {key: v[take] for key, v in vals.items()}
            claimed[local, 0] = rank[take]
            claimed[local, 1] = size[take]
        for key, v in vals.items():
            if key in functions:
                functions[key].x.array[local] = v

    def fill_midsides(self, functions: dict) -> None:
        """On 6-node triangular slave facets (P2 tetrahedra), whose mixed fields live on the
        facets' vertices (surface.mixed_nodes: ∫N_vertex = 0), give each midside node of
        the slave facets in ``functions`` (the scalar P2 functions of :meth:`fill_fields`,
        filled and with their ghosts updated) the mean of the two vertices of its edge:
        the value of the fields' linear interpolation there, so that a viewer shows the
        P1 field they are. Before session 59 the midside nodes held 0, and the pressure
        seemed to drop to 0 halfway between two contact vertices. Nothing on other
        facets, whose every node carries the fields.

        Collective (a reverse scatter: a midside node's owner need not hold the slave
        facet); the functions' ghosts are updated."""
        if self.ftype != TRIANGLE2 or not functions:
            return
        first = next(iter(functions.values()))
        mid, ends, hit, count = self._midside_layout(first)
        total = first.vector.duplicate()
        for f in functions.values():
            values = f.x.array
            with total.localForm() as t:
                t.set(0.0)
                t.array[mid] = 0.5 * (values[ends[0]] + values[ends[1]])
            total.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            values[hit] = total.array_r[hit] / count[hit]
            f.x.scatter_forward()
        total.destroy()

    def _midside_layout(self, function) -> tuple:
        """(mid, (end_a, end_b), hit, count) of :meth:`fill_midsides`, made once per nodal
        index map (the slave facets do not change during a run; the output writes every
        step with one function space): the local
        indices of the slave facets' midside nodes and of their edges' two vertices, one
        entry per (facet, edge) of the slave facets this rank extracted (its cells':
        every node local), each ``3 ×`` their number long; the owned nodes
        that some rank's slave facet holds as a midside (``hit``); and ``count``, per owned
        node, the number of such entries over all ranks (length ``size_local``).

        Collective when it is made (a reverse scatter: a midside node's owner need not hold
        the slave facet); before session 60 it was made at every write."""
        imap = function.function_space.dofmap.index_map
        if self._midsides is not None and self._midsides[0] is imap:
            return self._midsides[1]
        nodes = REFERENCE_NODES[TRIANGLE2]
        edges = [
            (m, a, b)
            for m in range(3, 6)
            for a in range(3)
            for b in range(a + 1, 3)
            if np.allclose(nodes[m], 0.5 * (nodes[a] + nodes[b]))
        ]
        lo, n_owned = imap.local_range[0], imap.size_local
        ghosts = np.asarray(imap.ghosts, dtype=np.int64)
        order = np.argsort(ghosts)

        def to_local(g):
            """Local indices (owned, then ghosts) of the global nodes g; −1 for a node that
            is neither on this rank."""
            out = g - lo
            off = (out < 0) | (out >= n_owned)
            at = np.minimum(np.searchsorted(ghosts, g[off], sorter=order), ghosts.size - 1)
            at = order[at] if ghosts.size else at
            found = ghosts[at] == g[off] if ghosts.size else np.zeros(at.size, bool)
            out[off] = np.where(found, n_owned + at, -1)
            return out

        # the facets this rank extracted, whose nodes are all local here, each facet on
        # one rank. Before session 64 these were the distributed slave facets
        # (self.slave): a facet received from another rank (it touches a node owned
        # here) can have nodes that are neither owned nor ghosts here, which the search
        # gave another node's index: a 3-rank hertz3d P2 run wrote a midside mean into a
        # vertex, whose gap fields.xdmf showed as 0 where the CSV has 0.54.
        blocks = self._own_facet_blocks
        mid = to_local(np.concatenate([blocks[:, m] for m, _, _ in edges]))
        ends = tuple(to_local(np.concatenate([blocks[:, e[i]] for e in edges])) for i in (1, 2))
        lost = int(np.sum((mid < 0) | (ends[0] < 0) | (ends[1] < 0)))
        lost = self.comm.allreduce(lost)
        if lost:  # on every rank, so that none waits in the scatter below
            raise RuntimeError(f"fill_midsides: {lost} slave facet node(s) not on their rank")
        # every rank that holds a slave facet with the edge gives its midside the mean;
        # the owner takes the mean of those (all equal: the vertices' scattered values)
        counter = function.vector.duplicate()
        with counter.localForm() as c:
            c.set(0.0)
            c.array[mid] = 1.0
        counter.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        count = counter.array_r.copy()
        counter.destroy()
        self._midsides = (imap, (mid, ends, np.flatnonzero(count > 0.0), count))
        return self._midsides[1]
