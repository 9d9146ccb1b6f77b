"""The "how": Newton (PETSc SNES), Uzawa augmentation rounds and load stepping.

- :class:`NewtonSolver` owns the SNES, its KSP and the Jacobian matrix. Every
  residual evaluation first calls the problem's per-iteration hook
  (``update_contact``: search and pairing), so pairs may change within a load
  step. Options go to PETSc under the solver's prefix (default ``dm_``), so
  ``-dm_snes_monitor`` or ``[solver.petsc] ksp_type = "gmres"`` work; a solver loads
  them into PETSc's global database when it works, so that solvers alive at the same
  time keep their own settings. The matrix is rebuilt between solves when the contact
  couplings outgrow its pattern. Failure raises :class:`~dolfinx_mortar.errors.ConvergenceError`.
- :func:`solve_step` runs the Uzawa rounds around Newton for one load step.
- :class:`LoadStepper` walks the time grid, cuts a failed step in half (up to
  ``max_cutbacks`` times in a row) and calls back after every converged step.
"""

from __future__ import annotations

import bisect
import functools
import logging
import math
import re
import weakref
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from time import perf_counter

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from . import compat
from .errors import (
    ConvergenceError,
    FrozenStatesError,
    InvertedElementsError,
    SceneError,
    SceneTypeError,
    check_stop,
    raise_on_every_rank,
)
from .scene import count_at_least, solver_options, steps_numbers

log = logging.getLogger(__name__)

_LINEAR = {
    "mumps": {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"},
    "lu": {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"},
    "superlu_dist": {
        "ksp_type": "preonly",
        "pc_type": "lu",
        "pc_factor_mat_solver_type": "superlu_dist",
    },
    "petsc": {},
}
#: MUMPS ordering (ICNTL(7)) of 2D problems: AMD. MUMPS's automatic choice (METIS here)
#: factorized the 2D contact Jacobians more slowly: linear solve time of peers problem A
#: level 3 (36.7k dofs) 1.49 s instead of 1.74 s serially, 1.21 s instead of 1.57 s on
#: 2 ranks; demo_hertz2d --refine 2 6.6 s instead of 9.2 s; cattaneo2d 1.40 s instead of
#: 1.61 s (medians, BENCHMARKS §3). In 3D METIS stays: AMD was slower there (hertz3d
#: --refine 1: 4.2 s instead of 3.5 s). A ``[solver.petsc] mat_mumps_icntl_7`` overrides.
MUMPS_ORDERING_2D = 0


def _linear_options(linear: str, problem) -> dict:
    """The PETSc options of a ``linear`` choice for ``problem``: with MUMPS, the ordering
    of its dimension (MUMPS_ORDERING_2D) and an LDLᵀ factorization (``pc_type =
    cholesky``, MUMPS's symmetric indefinite mode) where every Jacobian is symmetric
    (``problem.symmetric_jacobian``): half the factor's storage, and about 30 % less
    time per numeric factorization than LU with the same ordering on the peers'
    frictionless Hertz Jacobians (9.5k and 37k dofs; docs/method-notes.md, "Symmetric
    Jacobians are factorized LDLᵀ")."""
    opts = dict(_LINEAR[linear])
    if opts.get("pc_factor_mat_solver_type") == "mumps":
        if getattr(problem, "gdim", None) == 2:
            opts["mat_mumps_icntl_7"] = MUMPS_ORDERING_2D
        if getattr(problem, "symmetric_jacobian", False):
            opts["pc_type"] = "cholesky"
    return opts


@dataclass
class SolverSettings:
    """Newton settings. ``petsc``: extra PETSc options (without prefix) that override the
    defaults; ``step_depth_limit``: see :meth:`NewtonSolver._limit_step`.

    Checked when made, by the scene's rules for ``[solver]`` (one definition,
    :func:`dolfinx_mortar.scene.solver_options`): rtol in (0, 1), atol >= 0 or "auto",
    max_it in [1, scene.MAX_IT], linear one of scene.LINEAR_SOLVERS, line_search one of
    scene.LINE_SEARCHES, step_depth_limit >= 0, petsc a table of scalars. Raises
    :class:`~dolfinx_mortar.errors.SceneError` (a ValueError) or SceneTypeError (a
    TypeError) keyed ``SolverSettings.NAME`` (``SolverSettings.linear: unknown value
    'cholmod' (choices: ...)``); the numbers become floats and ints, petsc a new dict
    (names without a leading ``-``). They used to fail later: inside PETSc (rtol = 2),
    in a solve (atol = "tight"), or as PETSc's refusal of the options [] (line_search).
    """

    rtol: float = 1e-9
    #: a force, or "auto": AUTO_ATOL, never looser than rtol × the forces
    atol: float | str = "auto"
    max_it: int = 25
    linear: str = "mumps"
    line_search: str = "l2"
    petsc: dict = field(default_factory=dict)
    prefix: str = "dm_"
    #: penetration-limited Newton steps (:meth:`NewtonSolver._limit_step`): the largest
    #: penetration, in units of the nodal facet size h_I, that one Newton step may give a
    #: slave node that is out of contact; 0 = only in first-contact solves, with
    #: FIRST_CONTACT_DEPTH_LIMIT
    step_depth_limit: float = 0.0

    def __post_init__(self):
        checked = solver_options(
            "SolverSettings",
            self.rtol,
            self.atol,
            self.max_it,
            self.linear,
            self.line_search,
            self.petsc,
            self.step_depth_limit,
        )
        for name in ("rtol", "atol", "max_it", "linear", "line_search", "step_depth_limit"):
            setattr(self, name, getattr(checked, name))
        self.petsc = dict(checked.petsc)
        if not isinstance(self.prefix, str):
            raise SceneTypeError(
                "SolverSettings.prefix",
                f"expected a string (a PETSc options prefix), got {type(self.prefix).__name__}",
            )
        # an empty prefix would make every option of the database this solver's (a host
        # program's -log_view set aside with the rest)
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.prefix):
            raise SceneError(
                "SolverSettings.prefix",
                "a PETSc options prefix is a name of letters, digits and '_' not starting "
                f"with a digit (e.g. 'dm_'), got {self.prefix!r}",
            )


#: The penetration limit of the Newton steps of a first-contact solve (a solve that starts
#: with no active node on the pair, or on a pair that has carried no load yet:
#: ``MortarContact.first_contact``) when the settings'
#: ``step_depth_limit`` is 0; in units of h_I; 0 = off. A displacement-driven press from
#: the open state otherwise plunges the slave body into the master at the first Newton
#: step (peers problem B, level 3: 2.6 h deep, 13 → 22 → 35 → 6 → 34 active nodes over
#: the next iterates). Measured on the first Uzawa round of the peers' one-step presses
#: (problem A / B, levels 1 / 2 / 3, single serial runs): 6 / 7 / 10 and 6 / 7 / 12 Newton
#: iterations without the limit, 6 / 7 / 8 and 6 / 7 / 8 with 0.5 (0.4 the same; 0.25:
#: A level 3 9, B level 2 8; 0.75: 11 and 10 at level 3). Later solves are not limited:
#: with 0.5 in every solve the cattaneo2d demo's second press step (from a closed contact
#: zone) took 32 Newton iterations instead of 21 (docs/method-notes.md,
#: "Penetration-limited Newton steps").
FIRST_CONTACT_DEPTH_LIMIT = 0.5

#: Secant steps of the "l2" line search in a first-contact solve (one otherwise, PETSc's
#: default for "l2"). There the residual along a Newton step has the kinks of nodes
#: entering contact, and one secant step from the samples at λ = 1 and 1/2 can land on a
#: worse point than the 1/2 it sampled (peers problem A level 2: ‖R‖ 19.7 at the chosen
#: λ = 0.35 against 16.1 at λ = 1/2). With two, the first Uzawa round of the peers'
#: one-step presses from the open state takes 5 / 5 / 6 Newton iterations instead of
#: 6 / 7 / 8 at levels 1 / 2 / 3 (problem B's normal step the same), for two more
#: residual evaluations per iteration. Not with penalties stiffer than the auto value
#: (``ContactProblem.round_off_scale`` > 1): the hard-case sweep's pure penalty at
#: ε h/E* = 1e4 then diverged in its first step and was cut back (docs/method-notes.md,
#: "The line search at first contact").
FIRST_CONTACT_L2_STEPS = 2
#: Line search of the solves of a problem whose residual is a gradient (every Jacobian
#: symmetric, ``problem.symmetric_jacobian``: a hyperelastic bulk with frictionless
#: contact, R = ∂Π/∂u with Π = Π_bulk + Π_c for fixed multipliers, docs/method-notes.md
#: "The lumped recovery as a potential") where the configured line search is "l2":
#: PETSc's "cp", one secant step on the directional derivative ⟨R(u − λΔu), Δu⟩ =
#: −dΠ/dλ from λ = 0 and 1 (the minimum of the potential along the step), two residuals
#: per Newton step instead of three or four. The potential is C¹ where a step opens or
#: closes nodes (the penalty term ⟨−γ⟩² is), whereas ‖R‖², which "l2" fits with a
#: parabola, has kinks there. The predictor of a force-controlled press puts too much of
#: the surface in contact (hertz3d's second step: twice the final zone), and "l2" crept
#: with λ = 0.06–0.52 while it opened: `demo_hertz3d.py --refine 2` [14, 5, 3, 1] Newton
#: iterations per Uzawa round, with "cp" [12, 3, 1] (62.7 → 48.9 s); the hard-case
#: sweep's ν = 0.49 (P1) 62 → 28 and its large sliding 147 → 133 with no cutback. Not
#: at first contact, where a force-controlled body moves freely up to the contact,
#: ⟨R, Δu⟩ is flat there and the secant step tiny (hertz3d's first round: 31 iterations
#: instead of 5; with ENERGY_MIN_LAMBDA, one more iteration than "l2" in the first step of
#: hertz3d and hertz2d). Nor with penalties stiffer than the auto value
#: (``round_off_scale`` > 1; the sweep's pure penalty at ε h/E* = 1e4 took 64 iterations
#: instead of 44). "" turns it off (docs/method-notes.md, "The energy line search").
ENERGY_LINE_SEARCH = "cp"
#: A step of the energy line search shorter than this (λ) ends it for the rest of the
#: solve ("l2" then): ⟨R, Δu⟩ along a step can be flat up to a kink where a node closes
#: against a stiff penalty, and one secant step from λ = 0 and 1 then lands near 0 at
#: every iteration. In `demo_hertz2d.py --refine 2` the predicted second step crept with
#: λ ≈ 0.003 over 24 iterations until the solve failed and the step was retried from the
#: converged state (with the switch: 22 + 2 + 1 iterations, against 26 + 5 + 1 with "l2"
#: throughout). The steps of hertz3d's predicted round are 0.56–1.04.
ENERGY_MIN_LAMBDA = 0.1
#: The longest step of the "l2" line search, in units of the Newton step (its ``maxstep``
#: tolerance, PETSc's default 1e8; "cp" and "bt" keep the default, and a
#: ``[solver.petsc]`` snes_linesearch_maxstep overrides it). "l2" fits a parabola to ‖R‖²
#: at λ = 0, 1/2 and 1; where the fit is concave (the residual has a kink between the
#: samples: a node that opens or closes, a QP active set that switches) it steps to the
#: right of the samples, uphill of all three. In the constrained recovery's hertz2d
#: step 3 (samples ‖R‖ = 57 at 0, 1231 at 1/2, 822 at 1) it went to λ = 1.43 and
#: ‖R‖ = 1104, and the solve wandered at 500–1700 until max_it (25 iterations, then 8
#: full steps). Capped at the full step the main solve takes 28 iterations instead of 37,
#: and the hard-case sweep 653 instead of 659 (BENCHMARKS.md §33). The energy search
#: "cp" keeps its extrapolation: capping it too cost the sweep's large sliding 134 → 153
#: iterations and a cutback.
L2_MAX_STEP = 1.0
#: PETSc's default ``maxstep`` of a line search, restored for the line searches other
#: than "l2" (for "bt" it bounds the step's norm).
_DEFAULT_MAX_STEP = 1e8
#: The absolute tolerance of the SNES line search (``snes_linesearch_atol``; PETSc's
#: default 1e-15). PETSc's "cp" line search ends the whole solve as converged
#: (SNES_CONVERGED_FNORM_ABS) when |⟨R, Δu⟩| < that tolerance × ‖Δu‖ at the start of a
#: step: an absolute force of 1e-15 that no option of the solver's own tolerances
#: reaches. In units whose forces are small it decided convergence: with hertz2d's E and
#: load times 1e-9 and ``atol`` scaled with them (1e-19), the first round of step 2 stopped
#: at ‖R‖ = 1.5e-12 (3.5e-6 of its first norm), every later Uzawa round took no Newton
#: iteration, and the contact force came out 8e-4 off. 0 leaves convergence to the SNES
#: tolerances (rtol, and ``atol`` no lower than ROUND_OFF_ATOL × the round-off level); the
#: demos' units are unchanged. A ``[solver.petsc]`` value overrides it.
LINE_SEARCH_ATOL = 0.0


#: Smallest step a cutback may produce, as a fraction of t_end: below it the run stops.
MIN_STEP_FRACTION = 1e-9
#: The extrapolated predictor assumes that the prescribed data keep their rate: a step
#: whose rate of the Dirichlet and traction paths, or of a Dirichlet field's displacement
#: at some node, differs from the last step's by more than this (relative) starts from
#: the converged state. At a corner of the load path
#: (peers problem B: the normal approach, then the tangential shift at fixed depth) the
#: extrapolation would press the body in again by a whole normal increment.
PATH_RATE_TOL = 0.1
#: The fields of ``add_dirichlet_field`` count in the check of PATH_RATE_TOL at every
#: owned node they hold (its displacement vector's rate), except where a node's
#: increments over both steps are at most this times the mesh extent: the round-off of
#: a field's value at a point that does not move (a point on the axis of a rotation)
#: would make every step a corner.
FIELD_ROUND_OFF = 1e-12
#: SNES divergence tolerance of a solve started from the extrapolated predictor: the
#: relative growth of the residual norm that aborts it (the step is then retried from
#: the converged state). From a far-off start the contact candidates, hence the Jacobian
#: pattern, grow and every iteration gets expensive. Other solves keep PETSc's 1e4: a
#: first contact can grow the residual 20-fold before converging.
PREDICTOR_DIVERGENCE_TOLERANCE = 1e2
#: The extrapolated predictor repeats the last increment: where that increment's rate
#: ‖Δu‖/Δt exceeds this many times the rate of the increment before, the last step held
#: a jump (a snap: ironing2d's dragged slab corner springs back 0.3 at u_x = 1.44), which
#: does not repeat, and the next step starts from the converged state. Not across a
#: corner of the load path (PATH_RATE_TOL), where the rate changes with the load.
PREDICTOR_JUMP_RATIO = 2.0
#: After a step fails from the predictor, the next steps start from the converged state:
#: 1 step after the first failure, twice as many after each further failure in a row (at
#: most this many); a step that converges from the predictor resets the count. On the
#: ironing2d path the predictor failed in 72 of 110 steps, each failure after up to 45
#: Newton iterations.
PREDICTOR_MAX_BACKOFF = 8
#: A solve that ends on its iteration limit or a failed line search, with a finite
#: residual, continues from its last iterate with up to min(this, max_it) FULL Newton
#: steps (line search "basic") before the step is cut back. The l2 search stalls with
#: ‖R‖ constant where the iterate sits on a kink of the residual (a slave point crossing
#: a master vertex, an active-set or stick/slip switch): it minimises ‖R‖ along the
#: Newton step, and the minimum is the kink. A full step crosses it. (Switching at the
#: first stall, within max_it, was tried: it stops ironing2d at the onset of gross slip.)
FULL_STEP_ITERATIONS = 10
#: The Newton solve of an Uzawa round that follows a round whose solve ended with pinned
#: points (the chattering control of the pairing, contact.PIN_OUTSIDE_TOL) and with
#: states that the free law confirmed (no frozen stick/slip state, held node or QP set
#: contradicted at convergence), and the final full-tolerance solve after such a round,
#: takes full steps (line search "basic"): it starts from that round's solution with the
#: pins released and the multipliers moved. If it has not converged within max_it steps,
#: or its residual grew (ROUND_FULL_STEP_GROWTH) or became non-finite, the solve starts
#: again from the round's start with the configured line search; the step's iteration
#: counts include the failed attempt (summary.json ``full_step_restarts``). The released
#: points cross master vertices as the multipliers shift the contact, each a jump of the
#: residual along the Newton step, and the l2 search stops short of every one: in the
#: second round of ironing2d's snap step (t = 1.36, after 185 pinned points) it crawled
#: for 6 iterates with λ = 0.07 … 0.54 and pairing changes at every Jacobian, 18 + 10 + 1
#: Newton iterations; with full steps 18 + 6 + 1. After a round whose states changed, the
#: next one searches states again, and there full steps cycled longer than l2 (the
#: cattaneo2d demo at h = a/27: 13 + 11 + 1 + 1 instead of 13 + 10 + 1 + 1); in every
#: later round they broke two frictional tests (docs/method-notes.md, "Chattering of the
#: pairing").
ROUND_FULL_STEPS = True
#: ... and they stop (then the solve starts again with the configured line search) as soon
#: as ‖R‖ exceeds this many times its value at the round's start (SNES's divergence
#: tolerance): in hertz2d_nu049_p1 of the hard-case sweep the full steps of the second
#: round went 10 → 65 → 5.3 → 71 … and failed after 10 iterations (a 52-iteration step
#: instead of 43).
ROUND_FULL_STEP_GROWTH = 1.0
#: The absolute tolerance of every solve is at least this many times the residual's
#: measured round-off level f (``ContactProblem.residual_round_off``): ``atol`` is a force,
#: and where the forces are large (E = 2e11 for steel in SI units) no iterate gets below
#: it. With the hertz2d demo's E and load times 1e6, a later Uzawa round went 1.3 →
#: 6.3e-7 and then hovered at 3–4e-7 (about 5 f) until max_it, and the step failed after
#: every cutback. f is measured once a solve converges above ``atol`` (its relative
#: tolerance governed: the forces are large), again after every such solve while
#: ROUND_OFF_ATOL × f exceeds ``atol``, and when a solve fails, whose last iterate is
#: then accepted if its norm is within ROUND_OFF_ATOL × f. Where ROUND_OFF_ATOL × f
#: stays below ``atol`` (the demos' units: f ≈ 1e-13) nothing changes.
ROUND_OFF_ATOL = 20.0
#: ... but a failed solve's last iterate is not accepted where its round-off level
#: exceeds this fraction of the forces (``force_scale``), or where its residual is no
#: smaller than the solve's first: the state has then lost that many digits, and its
#: rounding says nothing of a converged state's. A body that nothing holds against a
#: rigid motion drifts (a singular Jacobian): a scene with a block free along x grew
#: ‖R‖ from 1.05 to 2.6e3 with u ≈ 1e16, at a "round-off level" of 7.6e2 that made
#: that iterate, and every later step, count as converged. Converged states round many
#: orders of magnitude below this fraction, stiff penalties included (the demos' and the
#: hard-case sweep's ``residual_round_off`` against their forces); a drift whose rounding
#: stays below it is caught by MAX_DISPLACEMENT_EXTENTS.
ROUND_OFF_MAX_RELATIVE = 1e-3
#: A solve whose displacement exceeds this many times the mesh's extent (its bounding
#: box's diagonal, ``problem.extent``) fails: no contact problem moves a body a thousand
#: times its own size in one step, and where Newton gets there a body is free to move
#: along a rigid motion that neither a Dirichlet boundary nor contact holds.
MAX_DISPLACEMENT_EXTENTS = 1e3
#: A solve that starts with a pair in contact and ends with none of its nodes in contact,
#: where a body of the pair is free (held by contact alone: ``MortarContact.free_body``),
#: fails when it moved a dof by more than this many of the pair's mean facet sizes: the
#: free body has escaped, and the state, with no force on it, is an equilibrium only
#: because nothing holds it (any rigid motion of it is one too). A 3D stack of three
#: blocks, the middle one held by contact alone, accepted such a step: the middle block
#: moved by 1.3 (6.5 facets) sideways out of the stack, with every reaction 1e-15 while
#: the top was still pressed down; the step halved converges.
ESCAPE_FACETS = 1.0
#: ``atol = "auto"`` (the default): the absolute tolerance is min(AUTO_ATOL, rtol × F),
#: with F the size of the forces, the largest first residual norm of the solves so far
#: (``NewtonSolver.force_scale``). AUTO_ATOL is the fixed 1e-10 of earlier versions, a
#: force in the demos' units; the cap keeps it from being looser than the relative
#: tolerance where the forces are small (E and the load times 1e-9: 1e-10 stopped every
#: solve early and the contact force was 6.5e-4 off; capped, the scaled runs take the
#: unit run's iterations). Where the forces are larger than 0.1 nothing changes.
AUTO_ATOL = 1e-10
#: The Uzawa rounds of a step stop (ConvergenceError, so the step is cut back) when this
#: many rounds in a row have not brought the multiplier change, taken as the larger of
#: two consecutive rounds, below half its smallest value before them. A rate slower than
#: 0.5^(1/8) ≈ 0.92 per round would not reach a useful tolerance within the default 20
#: rounds anyway; cycling rounds (stick/slip states that flip back and forth between
#: rounds: peers problem B, level 3, full tangential step, where every other round
#: changes by 0.4 and the rounds between by 0.1 … 0.002) otherwise run all
#: ``uzawa_max`` rounds before the cutback.
UZAWA_STALL_ROUNDS = 8
#: An attempt at a step fails (FrozenStatesError) when this many Uzawa rounds in a row
#: end with frozen stick/slip states (the chattering control, contact.FREEZE_AFTER) that the free law
#: contradicts (summary.json ``unfrozen_states`` > 0) AND a multiplier change larger
#: than the round before. A solve whose frozen slip directions were wrong converges to a
#: state where those nodes slip the other way, and the multipliers taken from it reverse
#: the tangential traction there: the rounds of peers problem B's full tangential step
#: (level 3) grew (changes 0.14, 0.28, 0.30, 0.33 with 6, 11, 22 wrong states) into a
#: 2-cycle. Rounds whose change shrinks go on: the constrained recovery's Cattaneo test
#: converges through a run of rounds with 1–2 wrong states. The step is then retried at
#: the same size with the states carried between rounds (errors.FrozenStatesError), and
#: only cut back if that attempt fails too. FROZEN_RETRY_ROUNDS counts for the carried
#: attempt; an attempt with free states fails after FROZEN_RETRY_ROUNDS_FREE rounds, so
#: that the carried one starts sooner (B level 3: 7 + 10 + 10 iterations wasted instead of
#: 7 + 10 + 10 + 11; one round was tried: the parallel constrained Cattaneo test then
#: stalled after 6 cutbacks).
FROZEN_RETRY_ROUNDS = 3
FROZEN_RETRY_ROUNDS_FREE = 2
_STALLED = (
    PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT,
    PETSc.SNES.ConvergedReason.DIVERGED_LINE_SEARCH,
)
#: A solve whose residual becomes non-finite (NaN: an element inverted, det F <= 0, at a
#: trial point) restarts from its last iterate with a finite residual with up to max_it
#: steps of the backtracking line search "bt", before the step is cut back. PETSc's l2
#: search halves λ after a NaN at λ = 1 but then fits its secant through λ = 1/2 and may
#: return a λ in (1/2, 1) where the residual is NaN again (the first press step of
#: ironing2d, the full steps at its onset of gross slip); bt only shrinks λ.
_NONFINITE = (PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN,)
# A law finite at det F <= 0 (saint-venant-kirchhoff: ψ(RF) = ψ(F) for a reflection R, so
# a mirrored element is stress-free) gives no NaN there, and Newton can converge to a
# state with inverted elements (patch2d with SVK blocks, a press then a slide: a row of
# the lower block mirrored, det F = −1, contact lost, status "ok"). In finite kinematics
# a converged solve is therefore checked once, at its end (``problem.min_det_F``: the
# bulk forms' quadrature points and the cell vertices), and one with det F <= 0 fails
# (errors.InvertedElementsError): the step is cut back (NewtonSolver._check_inversion;
# docs/method-notes.md, "Inverted elements").
#: NewtonSolver counters that StepResult reports per step
_SOLVE_COUNTERS = (
    "all_iterations",
    "limited_steps",
    "full_step_solves",
    "full_step_restarts",
    "backtracked_solves",
    "reused_factorizations",
    "failed_reuses",
    "ldlt_fallbacks",
    "state_predictions",
    "linear_iterations",
)
#: Direct linear solvers (``linear`` = "mumps", "lu", "superlu_dist", with no
#: ``ksp_type``/``pc_type`` of the user's): the first Newton iteration of an Uzawa round
#: after the first (and of the final full-tolerance solve) does not factorize its
#: Jacobian but solves with GMRES preconditioned by the last factorization, to a relative
#: residual of REUSE_RTOL_FACTOR × the solve's own relative tolerance, within
#: REUSE_MAX_IT iterations. Between rounds only the multipliers have changed, so the
#: Jacobian differs little from the one last factorized: each GMRES iteration (a pair of
#: triangular solves) gains about two digits. If GMRES does not converge, the solve
#: starts again with a new factorization. The later iterations factorize as usual.
REUSE_FACTORIZATION = True
REUSE_RTOL_FACTOR = 0.1
REUSE_MAX_IT = 8


#: Options prefix, after the solver's own (``dm_uzawa_newton_``), of the GMRES of the exact
#: multiplier update (:meth:`NewtonSolver.configure_uzawa_ksp`).
UZAWA_KSP_PREFIX = "uzawa_newton_"

#: Per options prefix, the :class:`NewtonSolver` whose options are in PETSc's global
#: database now (:meth:`NewtonSolver._load_options`), and what the database held under
#: that prefix before the first of them loaded its own: a host program's options, put
#: back when no solver's options are loaded under the prefix any more.
_LOADED: weakref.WeakValueDictionary = weakref.WeakValueDictionary()
_HOST_OPTIONS: dict[str, dict] = {}


def _loaded_keys() -> set[str]:
    """The names (prefix included) of the options the loaded solvers put in PETSc's global
    database: not a host program's, whatever prefix they start with (``dm_x_`` starts
    with ``dm_``)."""
    return {prefix + key for prefix, s in _LOADED.items() for key in s._options}


def _drop_options(prefix: str, options: dict) -> None:
    """A solver collected without :meth:`NewtonSolver.destroy`: if its ``options`` were
    loaded under ``prefix`` (no live solver's are), take them out and put the host
    program's back (the weakref finalizer; local)."""
    if _LOADED.get(prefix) is not None or prefix not in _HOST_OPTIONS:
        return
    opts = PETSc.Options()
    for key in options:
        opts.delValue(prefix + key)
    for key, value in _HOST_OPTIONS.pop(prefix).items():
        opts[key] = "" if value is None else value


def _owning_options(method):
    """Run ``method`` of a :class:`NewtonSolver` with the solver's options in PETSc's
    global database (:meth:`NewtonSolver._load_options`)."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        if self._destroyed:  # its SNES, matrix and vectors are freed: PETSc crashed (SEGV)
            raise RuntimeError(
                f"NewtonSolver.destroy() has freed this solver's PETSc objects: it cannot "
                f"{method.__name__.strip('_').replace('_', ' ')} any more (make a new one)"
            )
        self._load_options()
        return method(self, *args, **kwargs)

    return wrapper


class NewtonSolver:
    """PETSc SNES (newtonls) on a :class:`~dolfinx_mortar.problem.ContactProblem` (collective).

    Owns its SNES, KSP, residual vector and Jacobian matrix; call :meth:`destroy`
    (or use as a context manager) to free them.

    PETSc reads options from one global database, by prefix, when it sets up an object
    and lazily during a solve (the factorization's, the viewers'). This solver's options
    (:attr:`options`: the defaults, ``settings.linear``'s and ``settings.petsc``) are
    written there under ``settings.prefix`` when the solver works (its creation,
    :meth:`solve`, :meth:`solve_with_last_jacobian`) and another solver's options are
    there: those are taken out then. What a host program had put there under the prefix
    is set aside while any solver's options are loaded, and put back by the
    :meth:`destroy` of the solver loaded last. Two solvers alive at the same time with
    the same prefix each solve with their own settings (the first one solved with the
    second one's, a probe's frictional patch with Cholesky).
    """

    def __init__(self, problem, settings: SolverSettings | None = None):
        # the arguments' kinds first (they failed on a missing attribute: "'SolverSettings'
        # object has no attribute 'comm'", "'dict' object has no attribute 'petsc'")
        if isinstance(problem, SolverSettings) or getattr(problem, "comm", None) is None:
            raise TypeError(
                "NewtonSolver(problem, settings): problem must be a ContactProblem, got "
                f"{type(problem).__name__}"
            )
        if settings is not None and not isinstance(settings, SolverSettings):
            hint = (
                " (SolverSettings(**d) builds one from a dict)"
                if isinstance(settings, dict)
                else ""
            )
            raise TypeError(
                "NewtonSolver(problem, settings): settings must be a SolverSettings or None, "
                f"got {type(settings).__name__}{hint}"
            )
        self.problem = problem
        self.settings = settings = settings or SolverSettings()
        #: whether a solve has run (the options were read: _warn_unused_options)
        self._solved = False
        #: whether destroy() has run (a second call does nothing)
        self._destroyed = False
        comm = problem.comm
        # a viewer file that cannot be opened fails on rank 0 only, in setFromOptions or
        # at the end of a solve (-snes_view), and the other ranks went on into a
        # collective: it is checked here, the same decision on every rank
        raise_on_every_rank(comm, next(iter(_viewer_file_errors(settings.petsc)), None))
        self.snes = PETSc.SNES().create(comm)
        self.snes.setOptionsPrefix(settings.prefix)
        defaults = {
            "snes_type": "newtonls",
            "snes_linesearch_type": settings.line_search,
            "snes_linesearch_atol": LINE_SEARCH_ATOL,
            "snes_error_if_not_converged": False,
            "snes_divergence_tolerance": 1e4,
            **_linear_options(settings.linear, problem),
            **settings.petsc,
        }
        # a boolean false of [solver.petsc] leaves the option out (PETSc's default, off
        # for its flags): PETSc reads "false" as the name of a viewer (-snes_monitor)
        defaults = {k: v for k, v in defaults.items() if not (v is False and k in settings.petsc)}
        # Options of the prefix that a host program put in the global database (the
        # scene's and the command line's are settings.petsc) are set aside while a
        # solver's are loaded (_load_options): the solver reads its own options only.
        # They were read where the solver sets no value and overwritten elsewhere, then
        # deleted.
        # A bare flag (-snes_monitor) is "true" as a scene boolean; PETSc wants no value
        # (a viewer option reads "true" as a viewer name), which also means true for its
        # boolean options.
        self._options = {k: "" if v is True else v for k, v in defaults.items()}
        #: the options (without prefix) that PETSc has read in this solver's work, up to
        #: its last unloading (_unload_options), and whether PETSc could tell
        #: (compat.option_used)
        self._used: set[str] = set()
        self._usage_known = True
        # a solver that is collected without destroy() takes its options out and puts
        # the host's back; not at exit, when PETSc may be finalized
        self._drop = weakref.finalize(self, _drop_options, settings.prefix, self._options)
        self._drop.atexit = False
        self._b = _create_vector(problem)
        self._A = problem.create_matrix()
        #: the last iterate with a finite residual norm of the current solve (the
        #: monitor's copy), and whether the solve has had one
        self._finite_x = self._b.duplicate()
        self._trial = self._b.duplicate()  # the end of the full Newton step (_limit_step)
        self._start = self._b.duplicate()  # the start of a solve (full_steps, reuse)
        self._has_finite = False
        self.snes.setFunction(self._F, self._b)
        self.snes.setJacobian(self._J, self._A, self._A)
        self.snes.setTolerances(rtol=settings.rtol, atol=0.0, stol=0.0, max_it=settings.max_it)
        self.snes.setConvergenceHistory(
            length=2 * settings.max_it + FULL_STEP_ITERATIONS + 1, reset=True
        )
        error = refused = None
        try:
            self._load_options()
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()
            refused = self._refused_option()
        except PETSc.Error as exc:
            reason = compat.petsc_error_lines(exc)[-1]
            faulty = _options_named_in(reason, settings.petsc, settings.prefix)
            if len(faulty) == 1:
                (name,) = faulty
                error = f"solver.petsc.{name}", f"PETSc rejected {settings.petsc[name]!r}: {reason}"
            else:
                error = (
                    "solver.petsc",
                    f"PETSc rejected the options {sorted(settings.petsc)}: {reason}",
                )
        # PETSc may fail on some ranks only (rank 0 opens a viewer's file): every rank
        # raises the first failing rank's error
        try:
            raise_on_every_rank(comm, error)
        except SceneError:
            self.destroy()
            raise
        if refused is not None:
            self.destroy()
            raise SceneError(*refused)
        self.timings = {"linear_solve": 0.0}
        #: the effective line search (a ``[solver.petsc]`` snes_linesearch_type overrides)
        self._line_search = str(defaults["snes_linesearch_type"])
        #: solves whose line search stalled and that were continued with full steps
        self.full_step_solves = 0
        #: later-round solves whose full Newton steps failed and that started again with
        #: the configured line search (ROUND_FULL_STEPS)
        self.full_step_restarts = 0
        #: solves whose residual became non-finite and that were restarted with "bt"
        self.backtracked_solves = 0
        self.snes.setMonitor(self._remember_finite)
        #: Newton steps shortened by the penetration limit (settings.step_depth_limit)
        self.limited_steps = 0
        #: load steps' first Jacobians that the state predictor assembled again with slip
        #: tangents (_predict_states)
        self.state_predictions = 0
        #: the limit of first-contact solves (FIRST_CONTACT_DEPTH_LIMIT; 0 = off), used
        #: where ``settings.step_depth_limit`` is 0
        self.first_contact_depth_limit = FIRST_CONTACT_DEPTH_LIMIT
        if problem.contacts:
            self.snes.setLineSearchPreCheck(self._limit_step)
        if hasattr(problem, "linear_inverse"):
            problem.linear_inverse = self.solve_with_last_jacobian
            problem.configure_uzawa_ksp = self.configure_uzawa_ksp
        if hasattr(problem, "factorize_jacobian"):
            problem.factorize_jacobian = self.factorize_current_jacobian
        self._dtol = None
        #: whether the current solve uses ENERGY_LINE_SEARCH (decided at its first Jacobian)
        self._energy = False
        #: factorization reuse (REUSE_FACTORIZATION): possible at all with these options,
        #: a factorization of the current matrix exists, and the KSP is in GMRES mode now
        self._reuse_possible = (
            REUSE_FACTORIZATION
            and settings.linear in ("mumps", "lu", "superlu_dist")
            and not {"ksp_type", "pc_type"} & set(settings.petsc)
            and compat.lag_preconditioner_available()
        )
        self._factored = False
        self._reusing = False
        #: linear solves done with a reused factorization, and those that fell back
        self.reused_factorizations = 0
        self.failed_reuses = 0
        #: LDLᵀ factorizations that failed, after which this solver factorizes LU
        #: (:meth:`_fall_back_to_lu`; 0 or 1)
        self.ldlt_fallbacks = 0
        #: Newton iterations of all solves, failed ones included
        self.all_iterations = 0
        #: Krylov iterations of all linear solves, failed ones included: the Newton
        #: steps' (SNESGetLinearSolveIterations), the state predictor's and those with the
        #: last Jacobian (the exact multiplier update's products); 1 a solve with a
        #: direct solver (KSP preonly), more where GMRES reuses a factorization
        self.linear_iterations = 0
        #: the residual's round-off level f where measured (ROUND_OFF_ATOL; 0: not yet)
        self.round_off = 0.0
        #: the largest first residual norm of the solves so far: the size of the forces
        #: (0: no solve yet), and whether ``atol`` was found to be looser than rtol × it
        self.force_scale = 0.0
        self._warned_atol = False
        # the problem refuses new contact terms while this solver lives (destroy())
        if hasattr(problem, "solvers"):
            problem.solvers.add(self)

    def _refused_option(self) -> tuple[str, str] | None:
        """(key, reason) of a PETSc option, read from the scene's [solver.petsc] or the
        command line's -dm_..., that the solver cannot take, or None (local: the options
        are the same on every rank)."""
        petsc = self.settings.petsc
        if "snes_linesearch_maxstep" in petsc:
            # PETSc takes any number: a cap <= 0 ran "ok", with more Newton iterations
            key = self.settings.prefix + "snes_linesearch_maxstep"
            max_step = PETSc.Options().getReal(key)
            if not max_step > 0.0:
                return "solver.petsc.snes_linesearch_maxstep", f"must be > 0, got {max_step:g}"
        owned = sorted(set(petsc) & set(_TOLERANCE_OPTIONS))
        if owned:
            # NewtonSolver sets these on every solve: PETSc counted them as read, and a
            # scene or command line value was silently ignored
            return (
                f"solver.petsc.{owned[0]}",
                f"set by [solver] {_TOLERANCE_OPTIONS[owned[0]]} (the solver sets it on "
                "every solve): give it there",
            )
        kind = self.snes.getType()
        if kind in _LINEAR_SNES_TYPES:
            # one linear solve, no residual history: every step failed after 6 cutbacks
            return (
                "solver.petsc.snes_type",
                f"{kind!r} solves one linear system and contact is nonlinear: use a "
                "Newton method (the default newtonls)",
            )
        return None

    def _F(self, snes, x, b):
        t0 = perf_counter()
        self.problem.update_contact(x)
        self.problem.timings["search"] += perf_counter() - t0
        self.problem.residual(x, b)

    def _depth_limits(self) -> list[float]:
        """Per contact term, the penetration limit of this Newton step in units of h_I
        (0 = none): ``settings.step_depth_limit`` where set, otherwise
        :attr:`first_contact_depth_limit` in a first-contact solve of the term. The same
        on every rank (``first_contact`` is a collective decision)."""
        depth = self.settings.step_depth_limit
        if depth > 0.0:
            return [depth] * len(self.problem.contacts)
        fc = self.first_contact_depth_limit
        return [fc if term.first_contact else 0.0 for term in self.problem.contacts]

    def _limit_step(self, x, y):
        """Line-search pre-check (collective): shorten the Newton step in place so that no
        slave node out of contact penetrates deeper than the term's limit × h_I
        (:meth:`_depth_limits`, :meth:`~dolfinx_mortar.contact.MortarContact.step_limit`;
        docs/method-notes.md, "Penetration-limited Newton steps"). x (ndofs,) is the
        iterate and x − y the full Newton step's end (PETSc's sign convention); y is
        scaled by λ = min(1, min over the limited contact terms and ranks of their step
        limits)."""
        limits = self._depth_limits()
        if not any(d > 0.0 for d in limits):
            return
        t0 = perf_counter()
        p = self.problem
        p.ensure_contact_at(x)
        x.copy(self._trial)
        self._trial.axpy(-1.0, y)
        lam = min(
            term.step_limit(self._trial, d)
            for term, d in zip(p.contacts, limits, strict=True)
            if d > 0.0
        )
        lam = p.comm.allreduce(lam, op=MPI.MIN)
        p.timings["search"] += perf_counter() - t0  # a search at the step's end
        if lam < 1.0:
            y.scale(lam)
            self.limited_steps += 1
            log.debug("Newton step shortened to %.3g of its length (step_depth_limit)", lam)

    def _remember_finite(self, snes, its, fnorm):
        # a run stopped by SIGTERM: Terminated on every rank here, at the same iteration
        # (collective within errors.stops_on_signals; the exception leaves SNESSolve)
        check_stop(self.problem.comm)
        if np.isfinite(fnorm):
            snes.getSolution().copy(self._finite_x)
            self._has_finite = True
            s = self.settings
            if its == 0 and fnorm > self.force_scale:  # a solve's first norm
                self.force_scale = fnorm
                if s.atol == "auto":  # follows the forces: before the test
                    snes.setTolerances(atol=self._atol())
                elif not self._warned_atol and (atol := self._base_atol()) > s.rtol * fnorm:
                    self._warned_atol = True
                    log.warning(
                        "solver.atol = %.3g (a force) exceeds rtol × the first residual "
                        "norm of this solve (%.3g): Newton may stop before its relative "
                        "tolerance; set [solver] atol for the units of this scene",
                        atol,
                        s.rtol * fnorm,
                    )

    def _J(self, snes, x, A, P):
        # The line search may have evaluated F last at a trial point other than x: the
        # contact pairing and nodal state must be those of x for a consistent tangent;
        # problem.jacobian brings them there (re-computed only when they are not).
        first_iteration = snes.getIterationNumber() == 0
        predict = (
            first_iteration
            and not self._reusing
            and getattr(self.problem, "state_prediction_wanted", lambda: False)()
        )
        watch = self.problem.jacobian_watch() if predict else None
        self.problem.jacobian(x, A)
        if predict:
            self._predict_states(snes, x, A, watch)
        if self._line_search_type() != "l2":  # the scene's, or a continuation's
            self._energy = False
            if first_iteration:
                self._set_max_step(_DEFAULT_MAX_STEP)
        elif first_iteration:
            # first_contact is decided at the solve's first Jacobian (collective)
            p = self.problem
            first = any(term.first_contact for term in p.contacts)
            soft = getattr(p, "round_off_scale", 1.0) <= 1.0
            energy = (
                ENERGY_LINE_SEARCH
                and getattr(p, "symmetric_jacobian", False)
                and not first
                and soft
            )
            # False where the PETSc library cannot be reached (the line search stays)
            self._energy = bool(energy) and compat.set_line_search_type(snes, ENERGY_LINE_SEARCH)
            if self._energy:
                compat.set_line_search_max_it(snes, 1)
                self._set_max_step(_DEFAULT_MAX_STEP)
            else:
                # more secant steps of l2 at first contact, not with penalties stiffer
                # than the auto value (round_off_scale > 1), whose kinks defeat the
                # fitted parabola (FIRST_CONTACT_L2_STEPS)
                self._use_l2(FIRST_CONTACT_L2_STEPS if first and soft else 1)
        elif self._energy and (compat.line_search_lambda(snes) or 0.0) < ENERGY_MIN_LAMBDA:
            # the secant step on a kinked ⟨R, Δu⟩ came out short: "l2" from here on
            log.info("energy line search took a short step; l2 for the rest of the solve")
            self._use_l2(1)
            self._energy = False
        if self._reusing and not first_iteration:
            self._reuse_mode(False)  # only the first iteration of a solve reuses
        if not self._reusing:  # this Jacobian is factorized: its contact states are noted
            note = getattr(self.problem, "note_factorization", None)
            if note is not None:
                note()

    def _predict_states(self, snes, x, A, watch: list) -> None:
        """The state predictor of a load step's first Jacobian (collective; docs/method-
        notes.md, Friction, "Session 49: the state predictor"): the Newton step from x
        with the Jacobian ``A`` just assembled (stick at every node that sticks at the
        step's start) is solved, not taken; where a pair goes into gross slip at its end
        (``MortarContact.guess_slip``), A is assembled at x again with the slip tangent
        there (``problem.predict_states``). Costs one linear solve on the factorization that
        the SNES then reuses for its own first step (the operator is unchanged) or, where
        the tangent changed, one more factorization. ``_b`` holds R(x); ``watch``: the
        contact terms' per-solve state from before A (``problem.jacobian_watch``)."""
        ksp = snes.getKSP()
        ksp.setOperators(A, A)
        dx = self._trial.duplicate()
        try:
            ksp.solve(self._b, dx)
            self.linear_iterations += ksp.getIterationNumber()
            if ksp.getConvergedReason() <= 0 or not np.isfinite(dx.norm()):
                return
            x.copy(self._trial)
            self._trial.axpy(-1.0, dx)
            after = self.problem.jacobian_watch()
            if self.problem.predict_states(x, self._trial, watch, after):
                self.state_predictions += 1
                self.problem.jacobian(x, A)
        finally:
            dx.destroy()

    def _use_l2(self, secant_steps: int) -> None:
        """The SNES's line search becomes "l2" with ``secant_steps`` secant steps and
        steps of at most L2_MAX_STEP (local; inside a solve too)."""
        compat.set_line_search_type(self.snes, "l2")
        compat.set_line_search_max_it(self.snes, secant_steps)
        self._set_max_step(L2_MAX_STEP)

    def _set_max_step(self, max_step: float) -> None:
        """The line search's ``maxstep`` (L2_MAX_STEP), unless ``settings.petsc`` (the
        scene's [solver.petsc] or the command line's -dm_...) sets
        snes_linesearch_maxstep (local)."""
        if "snes_linesearch_maxstep" not in self.settings.petsc:
            compat.set_line_search_max_step(self.snes, max_step)

    def _line_search_type(self) -> str:
        """The line search configured now: the options database's, where the configured
        one and :meth:`_line_search_as` put it; "l2" also while a solve uses
        ENERGY_LINE_SEARCH (local)."""
        return str(self._options.get("snes_linesearch_type", self._line_search))

    def _reuse_mode(self, on: bool, rtol: float = 0.0) -> None:
        """Switch the KSP between GMRES on the last factorization (``on``, to relative
        residual ``rtol``) and the direct solve that factorizes each Jacobian."""
        ksp = self.snes.getKSP()
        if on:
            ksp.setType(PETSc.KSP.Type.GMRES)
            ksp.setPCSide(PETSc.PC.Side.RIGHT)  # the true residual is what converges
            ksp.setTolerances(rtol=rtol, max_it=REUSE_MAX_IT)
        else:
            ksp.setType(PETSc.KSP.Type.PREONLY)
        # SNES decides after each Jacobian whether the PC is rebuilt: by its lag
        compat.set_lag_preconditioner(self.snes, -1 if on else 1)
        self._reusing = on

    @_owning_options
    def solve(
        self,
        rtol: float | None = None,
        dtol: float | None = None,
        rescue: bool = True,
        reuse: bool = False,
        force: bool = False,
        full_steps: bool = False,
    ) -> tuple[int, list[float]]:
        """Solve R(u) = 0 from the problem's current ``u`` (collective).

        ``rtol`` overrides the relative tolerance for this solve only (inexact Uzawa
        rounds); ``dtol`` the divergence tolerance (None: PETSc's default 1e4, or the user's
        ``snes_divergence_tolerance``); ``rescue = False`` skips the "bt" restart after a
        non-finite residual (a solve from the extrapolated predictor: retrying it from the
        converged state is cheaper than up to max_it backtracking steps); ``reuse``: the
        first iteration may use the last factorization (:data:`REUSE_FACTORIZATION`;
        for a solve that starts where the last one converged); ``force``: at least one
        Newton iteration even when the first residual already meets the tolerance (a
        later Uzawa round: its multipliers moved, see :func:`solve_step`); ``full_steps``:
        first try full Newton steps, and start again with the configured line search if
        they fail (:data:`ROUND_FULL_STEPS`; a failed attempt's iterations and norms
        included in the returned ones). Returns
        (iterations, residual norms per iteration, the full-step continuation of a stalled solve and the "bt" restart of a
        solve whose residual became non-finite included: see :data:`FULL_STEP_ITERATIONS`
        and :data:`_NONFINITE`; the iterations after the last finite residual are not
        counted). Raises ConvergenceError.
        """
        s = self.settings
        self._solved = True
        if dtol != self._dtol:
            value = s.petsc.get("snes_divergence_tolerance", 1e4) if dtol is None else dtol
            self._set_option("snes_divergence_tolerance", value)
            self.snes.setFromOptions()
            self._dtol = dtol
        # the residual's round-off floor grows with stiff penalties (the note before
        # contact.SOFT_START_RATIO) and with the size of the forces (ROUND_OFF_ATOL)
        atol = self._atol()
        self.snes.setTolerances(
            rtol=s.rtol if rtol is None else max(rtol, s.rtol), atol=atol, max_it=s.max_it
        )
        self.snes.setForceIteration(force)
        p = self.problem
        p.begin_solve()
        p.update_contact(p.u.vector)
        if p.pattern_outdated():
            self._A.destroy()
            self._A = p.create_matrix()
            self.snes.setJacobian(self._J, self._A, self._A)
            self._factored = False
        x = p.u.vector.copy()
        x.copy(self._start)
        # the pairs in contact at the start (MortarContact.touching: the same on every rank;
        # a term that does not say is taken as not touching, and is not checked)
        touching = [getattr(t, "touching", False) for t in getattr(p, "contacts", ())]
        t_ksp0 = _ksp_time()
        tried = 0, []  # the iterations and norms of a failed full-step attempt
        try:
            if full_steps and self._line_search != "basic":
                with self._line_search_as("basic", s.max_it, dtol=ROUND_FULL_STEP_GROWTH):
                    reason = self._run(x, reuse)
                its, norms = self._history()
                converged = reason > 0 and np.all(np.isfinite(norms))
                inverted = self._inversion(x) if converged else None
                if converged and inverted is None:
                    return self._accept(x, its, norms)
                self.full_step_restarts += 1
                log.info(
                    "Full Newton steps failed (SNES reason %s, %d iterations%s); the solve "
                    "starts again with line search %s",
                    _reason_name(PETSc.SNES.ConvergedReason, reason),
                    its,
                    "" if inverted is None else f", elements inverted: {inverted.describe()}",
                    self._line_search,
                )
                tried = its, norms
                self._back_to_start(x)
                reuse = False
            reason = self._run(x, reuse)
            its, norms = self._history()
            if not norms:
                # the SNES stopped before its first residual norm: a non-finite first
                # residual, or a [solver.petsc] snes_type that keeps no history
                self.all_iterations += tried[0]
                x.destroy()
                why = (
                    "the first residual is not finite"
                    if reason in _NONFINITE
                    else f"SNES type {self.snes.getType()} recorded no residual norm"
                )
                raise ConvergenceError(
                    "Newton did not converge (SNES reason "
                    f"{_reason_name(PETSc.SNES.ConvergedReason, reason)}: {why})"
                )
            target = (s.rtol if rtol is None else max(rtol, s.rtol)) * norms[0]
            budget = min(FULL_STEP_ITERATIONS, s.max_it)
            stalled = reason in _STALLED and self._line_search != "basic"
            # the iterations of each part of the solve, for the error of a failed one
            parts = [(its, f"with line search {self._line_search}")]
            if tried[0]:
                parts.insert(0, (tried[0], "with full Newton steps (then started again)"))
            if stalled and np.all(np.isfinite(norms)):
                self.full_step_solves += 1
                reason, more = self._continue(x, "basic", target / norms[-1], budget)
                its, norms = its + len(more), norms + more
                parts.append((len(more), "with full Newton steps from where it stalled"))
            if reason in _NONFINITE and self._has_finite and self._line_search != "bt" and rescue:
                # restart from the last finite iterate: drop the norms after it
                norms = [r for r in norms if np.isfinite(r)]
                its = len(norms) - 1
                cause = self._nonfinite_cause(x)
                self._finite_x.copy(x)
                self.backtracked_solves += 1
                reason, more = self._continue(x, "bt", target / norms[-1], s.max_it)
                parts = parts[:1] if tried[0] else []
                parts.append((its, f"to the last finite residual{cause}"))
                its, norms = its + len(more), norms + more
                parts.append((len(more), "with line search bt from there"))
            if (
                reason <= 0
                and np.all(np.isfinite(norms))
                and norms[-1] < norms[0]
                and self._at_round_off(x, norms[-1])
            ):
                log.info(
                    "Newton stopped at %.3e, within %g × the residual's round-off level "
                    "(%.3e): converged",
                    norms[-1],
                    ROUND_OFF_ATOL,
                    self.round_off,
                )
                reason = 1
            if reason <= 0 or not np.all(np.isfinite(norms)):
                self.all_iterations += tried[0] + its
                x.destroy()
                why = _reason_name(PETSc.SNES.ConvergedReason, reason)
                if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE:
                    ksp = self.snes.getKSP().getConvergedReason()
                    why += f" (KSP reason {_reason_name(PETSc.KSP.ConvergedReason, ksp)})"
                raise ConvergenceError(
                    f"Newton did not converge (SNES reason {why}, "
                    f"{_iterations_text(parts, s.max_it)}, "
                    f"residual {norms[-1] if norms else float('nan'):.3e})"
                )
            if tried[0]:  # the restart's first norm is the attempt's first
                its, norms = tried[0] + its, tried[1] + norms[1:]
            self._check_drift(x, tried[0] + its)
            self._check_inversion(x, tried[0] + its)
            self._check_escape(x, touching, tried[0] + its)
            out = self._accept(x, its, norms)
            measure = getattr(p, "residual_round_off", None)
            floor_bound = self._atol() > self._base_atol()
            if measure and norms[-1] > atol and (not self.round_off or floor_bound):
                f = measure()
                self.round_off = f if np.isfinite(f) else self.round_off
            return out
        finally:
            self.timings["linear_solve"] += _ksp_time() - t_ksp0

    def _nonfinite_cause(self, x: PETSc.Vec) -> str:
        """The text " (the next one non-finite: <what>)" for the iterate x of a solve
        stopped on a non-finite residual (collective; ``problem.nonfinite_cause``; "" where
        the problem has none or every part is finite at x), also logged. Seen so far: the
        bulk at elements inverted by a line search's trial point (slide_one_step2d.toml
        with the unconstrained tangential recovery: det F <= 0 at each of its 29
        non-finite residuals, the contact part finite at all)."""
        describe = getattr(self.problem, "nonfinite_cause", None)
        what = describe(x) if describe is not None else ""
        if not what:
            return ""
        log.info("Non-finite residual at a Newton iterate: %s", what)
        return f" (the next one non-finite: {what})"

    def _run(self, x: PETSc.Vec, reuse: bool) -> int:
        """One SNES solve from x (the solve's start, ``_start``), in place (collective);
        with ``reuse`` its first linear solve is GMRES on the last factorization
        (:data:`REUSE_FACTORIZATION`), and if that fails the solve starts again from x with
        a new one. Returns the SNES reason."""
        self._has_finite = False
        reusing = reuse and self._reuse_possible and self._factored
        if reusing:
            self._reuse_mode(True, REUSE_RTOL_FACTOR * self.snes.getTolerances()[0])
        reason = self._snes_solve(x)
        if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE and self._ldlt_failed():
            self._fall_back_to_lu()
            self._back_to_start(x)
            reason = self._snes_solve(x)
        if reusing:
            if self._reusing:
                self._reuse_mode(False)
            if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE:
                # GMRES on the old factorization did not converge: start again
                self.failed_reuses += 1
                log.info("GMRES on the last factorization failed; factorizing")
                self._back_to_start(x)
                reason = self._snes_solve(x)
            else:
                self.reused_factorizations += 1
        self._factored = self._factored or self.snes.getIterationNumber() > 0
        return reason

    def _snes_solve(self, x: PETSc.Vec) -> int:
        """``snes.solve(None, x)``, its Krylov iterations counted in
        :attr:`linear_iterations` (collective). Returns the SNES reason."""
        self.snes.solve(None, x)
        self.linear_iterations += self.snes.getLinearSolveIterations()
        return self.snes.getConvergedReason()

    def _ldlt_failed(self) -> bool:
        """Whether the last linear solve failed in an LDLᵀ factorization (collective: the
        KSP's reason is the same on every rank)."""
        ksp = self.snes.getKSP()
        return (
            ksp.getPC().getType() == PETSc.PC.Type.CHOLESKY
            and ksp.getConvergedReason() == PETSc.KSP.ConvergedReason.DIVERGED_PCSETUP_FAILED
        )

    def _fall_back_to_lu(self) -> None:
        """Factorize LU from now on (collective). MUMPS's symmetric indefinite LDLᵀ pivots
        within its fronts only; on 3 ranks it failed once, in one full suite run out of
        several, at the first Newton iteration of hertz2d's first step, where the
        cylinder touches the block at one node (demo_recoveries, unconstrained recovery,
        a run that had passed with LU in every earlier suite run)."""
        log.warning("LDLᵀ factorization failed; factorizing LU from now on")
        self.ldlt_fallbacks += 1
        # the options are where the PC type, solver package and ordering live (a later
        # setFromOptions of this solver reads them again)
        self._set_option("pc_type", "lu")
        self.snes.getKSP().setFromOptions()
        self._factored = False

    def _back_to_start(self, x: PETSc.Vec) -> None:
        """x ← the solve's start (``_start``), for a new SNES solve from there: the
        per-solve chattering control starts afresh (collective; the contact state follows
        at the solve's first residual evaluation)."""
        self._start.copy(x)
        self.problem.begin_solve()
        self._has_finite = False

    def _base_atol(self) -> float:
        """``atol`` (AUTO_ATOL for "auto") scaled with the stiffest penalty
        (contact.SOFT_START_RATIO's note)."""
        s = self.settings
        atol = min(AUTO_ATOL, s.rtol * self.force_scale) if s.atol == "auto" else s.atol
        return atol * getattr(self.problem, "round_off_scale", 1.0)

    def _atol(self) -> float:
        """The absolute tolerance of a solve: :meth:`_base_atol`, or ROUND_OFF_ATOL × the
        measured round-off level if that is larger."""
        return max(self._base_atol(), ROUND_OFF_ATOL * self.round_off)

    def _at_round_off(self, x: PETSc.Vec, norm: float) -> bool:
        """Whether a failed solve's last iterate x, of residual norm ``norm``, sits on the
        residual's round-off floor: f measured there (collective; the problem's state
        becomes x) and ``norm`` ≤ ROUND_OFF_ATOL × f (ROUND_OFF_ATOL), with f at most
        ROUND_OFF_MAX_RELATIVE × the forces; f then becomes the solver's level."""
        measure = getattr(self.problem, "residual_round_off", None)
        if measure is None:
            return False
        self.problem.update_contact(x)
        f = measure()
        # not the floor (or no level: a residual near x is not finite): the f of an
        # iterate far from the root says nothing of the converged states' level, nor does
        # that of a state that lost its digits (ROUND_OFF_MAX_RELATIVE)
        if not np.isfinite(f) or norm > ROUND_OFF_ATOL * f:
            return False
        if f > ROUND_OFF_MAX_RELATIVE * self.force_scale:
            return False
        self.round_off = max(self.round_off, f)
        return True

    def _check_drift(self, x: PETSc.Vec, its: int) -> None:
        """Raise ConvergenceError (x destroyed, ``its`` counted) where the solve's end x
        moved a dof by more than MAX_DISPLACEMENT_EXTENTS × the mesh's extent: a body
        free along a rigid motion (collective)."""
        extent = getattr(self.problem, "extent", 0.0)
        if not extent > 0.0:
            return
        umax = x.norm(PETSc.NormType.NORM_INFINITY)
        if umax <= MAX_DISPLACEMENT_EXTENTS * extent:
            return
        self.all_iterations += its
        x.destroy()
        raise ConvergenceError(
            f"the displacement reached {umax:.3g}, {umax / extent:.3g} times the mesh's "
            "extent: a body is free along a rigid motion that no [[dirichlet]] boundary "
            "and no contact holds (a singular Jacobian)"
        )

    def _inversion(self, x: PETSc.Vec):
        """:func:`_inverted_state` of the problem at the solve's end x (collective; the
        problem's u becomes x)."""
        return _inverted_state(self.problem, x)

    def _check_inversion(self, x: PETSc.Vec, its: int) -> None:
        """Raise InvertedElementsError (x destroyed, ``its`` counted) where the solve's
        end x has inverted elements (:meth:`_inversion`; the note after :data:`_NONFINITE`;
        collective)."""
        det = self._inversion(x)
        if det is None:
            return
        self.all_iterations += its
        x.destroy()
        raise InvertedElementsError(
            f"elements inverted ({det.describe()}): Newton converged to a state that is "
            "no deformation of the bodies",
            det,
        )

    def _check_escape(self, x: PETSc.Vec, touching: list[bool], its: int) -> None:
        """Raise ConvergenceError (x destroyed, ``its`` counted) where a body held by
        contact alone has escaped in the solve (collective), for a pair with a free body:
        in contact at the solve's start (``touching``, per contact term) and with no node
        in contact at its end x, where the solve moved a dof by more than ESCAPE_FACETS of
        the pair's mean facet sizes; not in contact at the start, where the solve moved the
        pair's bodies by more than ESCAPE_FACETS facet sizes along rigid motions that
        nothing holds in the solve (``problem.free_rigid_motion``): those that their
        Dirichlet conditions leave free where the pair is still open at the end, those
        that neither these nor the contact's normal holds where it closed (stick holds
        nothing at nodes that close within a step). A prescribed or force-driven approach
        counts nothing. A pair still open at the end whose free body is in no pair in
        contact there (``problem.floating``) fails whatever that motion: nothing holds
        the body, the Jacobian is singular along those motions, and the solve's motion
        there is the linear solver's round-off (stick_only_scene: 0.303 or 2.07 in one
        step as the bulk kernels' last digits changed)."""
        p = self.problem
        terms = list(getattr(p, "contacts", ()))
        # a term that does not say whether its body is free is not checked
        if not terms or not (any(touching) or any(getattr(t, "free_body", False) for t in terms)):
            return
        p.ensure_contact_at(x)
        lost = [t for t, was in zip(terms, touching, strict=True) if was and not t.touching]
        lost = [t for t in lost if t.free_body]
        fresh = [k for k, (t, was) in enumerate(zip(terms, touching, strict=True)) if not was]
        fresh = [k for k in fresh if getattr(terms[k], "free_body", False)]
        find = getattr(p, "free_rigid_motion", None)
        if not lost and not (fresh and find is not None):
            return
        step = x.copy()
        step.axpy(-1.0, self._start)
        moved = step.norm(PETSc.NormType.NORM_INFINITY)
        along = np.zeros(len(terms))
        open_ = []
        if fresh and find is not None:
            open_ = [k for k in fresh if not terms[k].touching]
            closed = [k for k in fresh if terms[k].touching]
            if open_:
                along[open_] = find(step.array_r)[open_]
            if closed:
                along[closed] = find(step.array_r, tangential=True)[closed]
        step.destroy()
        escaped = [t for t in lost if moved > ESCAPE_FACETS * t.h_mean]
        drifted = [k for k in fresh if along[k] > ESCAPE_FACETS * terms[k].h_mean]
        # an open pair whose free body no closed pair holds: the solve's motion along the
        # free motions is round-off's choice (a singular Jacobian), not a measure of escape
        floats = getattr(p, "floating", None)
        floating = np.zeros(len(terms), bool)
        if open_ and floats is not None:
            floating = floats([getattr(t, "touching", False) for t in terms])
            drifted += [k for k in open_ if floating[k] and k not in drifted]
        if not escaped and not drifted:
            return
        self.all_iterations += its
        x.destroy()
        if escaped:
            names = ", ".join(t.name for t in escaped)
            raise ConvergenceError(
                f"the solve lost every contact of {names}, whose body is held by contact "
                f"alone, and moved a node by {moved:.3g} ({moved / escaped[0].h_mean:.3g} "
                "facet sizes): the body escaped; not an equilibrium of the load path"
            )
        k = max(drifted, key=lambda k: along[k] / terms[k].h_mean)
        names = ", ".join(terms[k].name for k in drifted)
        by = f"{along[k]:.3g} ({along[k] / terms[k].h_mean:.3g} facet sizes)"
        stick = (
            " (a frictional pair holds such motions by stick alone, and stick holds "
            "nothing at the nodes that close within a step)"
            if any(terms[k].frictional for k in drifted)
            else ""
        )
        if terms[k].touching:
            raise ConvergenceError(
                f"the solve closed the contact of {names} and moved a body held by contact "
                f"alone by {by} along rigid motions that neither a [[dirichlet]] condition "
                f"nor the contact's normal holds: the body slid unresisted{stick}; not the "
                "answer of the load path"
            )
        unheld = (
            " (no pair of the body is in contact: nothing holds it along them, and how far "
            "the solve moved it there is the linear solver's round-off)"
            if k in open_ and floating[k]
            else ""
        )
        raise ConvergenceError(
            f"the solve ended with no node of {names} in contact and moved a body held by "
            f"contact alone by {by} along rigid motions that no [[dirichlet]] condition "
            f"holds{unheld}: the body escaped{stick}; not an equilibrium of the load path "
            "that anything selects"
        )

    def _history(self) -> tuple[int, list[float]]:
        """The iterations and residual norms (initial one included) of the last SNES solve."""
        its = self.snes.getIterationNumber()
        return its, [float(r) for r in self.snes.getConvergenceHistory()[0][: its + 1]]

    def _accept(self, x: PETSc.Vec, its: int, norms: list[float]) -> tuple[int, list[float]]:
        """A converged solve: x becomes the problem's u (x is destroyed)."""
        self.all_iterations += its
        p = self.problem
        x.copy(p.u.vector)
        p.u.x.scatter_forward()
        x.destroy()
        return its, norms

    @contextmanager
    def _line_search_as(self, line_search: str, max_it: int, dtol: float | None = None):
        """SNES solves within use ``line_search``, at most ``max_it`` iterations and, if
        given, the divergence tolerance ``dtol``; the configured values are restored
        afterwards (collective)."""
        keys = ["snes_linesearch_type", "snes_divergence_tolerance"]
        saved = [self._options.get(k) for k in keys]
        self._set_option(keys[0], line_search)
        if dtol is not None:
            self._set_option(keys[1], dtol)
        self.snes.setFromOptions()
        self.snes.setTolerances(max_it=max_it)
        try:
            yield
        finally:
            for k, v in zip(keys, saved, strict=True):
                self._set_option(k, v)
            self.snes.setFromOptions()
            self.snes.setTolerances(max_it=self.settings.max_it)

    def _continue(
        self, x: PETSc.Vec, line_search: str, rtol: float, max_it: int
    ) -> tuple[int, list[float]]:
        """Continue a failed solve from x with at most ``max_it`` Newton steps under the
        given line search ("basic": full steps; "bt": backtracking) (collective), to
        ‖R‖ ≤ rtol × ‖R(x)‖ (the original solve's target) or atol. x is updated in place;
        the options are restored afterwards. Returns the SNES reason and the residual
        norms after each step."""
        self.snes.setTolerances(rtol=min(rtol, 0.5))
        with self._line_search_as(line_search, max_it):
            reason = self._snes_solve(x)
        its = self.snes.getIterationNumber()
        log.info(
            "Newton solve continued with %d steps of line search %s: SNES reason %s",
            its,
            line_search,
            _reason_name(PETSc.SNES.ConvergedReason, reason),
        )
        return reason, [float(r) for r in self.snes.getConvergenceHistory()[0][1 : its + 1]]

    @_owning_options
    def solve_with_last_jacobian(self, b: PETSc.Vec, x: PETSc.Vec) -> bool:
        """x = J⁻¹ b with the last Jacobian this solver factorized (collective; the
        KSP as the last Newton iteration left it, nothing assembled or factorized again).
        b, x: global vectors of the problem's layout, b zero on constrained dofs. Returns
        False where no factorization of the current matrix exists (a new sparsity pattern
        since the last iteration; x untouched) or the linear solve failed (x undefined).
        For the exact multiplier update (``contact.MortarContact.uzawa_update``)."""
        if not self._factored:
            return False
        # the wall clock, not PETSc's KSPSolve event: the exact update calls this inside
        # its own GMRES's KSPSolve, and PETSc times a nested event only at its outermost
        # level (the products' solves counted 0.10 of their 0.55 s with GAMG on hertz3d)
        t0 = perf_counter()
        ksp = self.snes.getKSP()
        try:
            ksp.solve(b, x)
            self.linear_iterations += ksp.getIterationNumber()
        finally:
            self.timings["linear_solve"] += perf_counter() - t0
        return ksp.getConvergedReason() > 0

    @_owning_options
    def factorize_current_jacobian(self) -> bool:
        """Assemble the Jacobian at the problem's current u and factorize it, so that
        :meth:`solve_with_last_jacobian` solves with it (collective). For the exact
        multiplier update, where the last factorization belongs to contact states that
        the converged state no longer has (``contact.MortarContact._current_factorization``):
        a round's solve that took one Newton iteration on the last factorization (reuse)
        leaves that of an earlier round. Returns False where the factorization failed
        (then there is none: :meth:`solve_with_last_jacobian` returns False)."""
        p = self.problem
        x = p.u.vector
        t0 = _ksp_time()
        try:
            p.ensure_contact_at(x)
            if p.pattern_outdated():
                self._A.destroy()
                self._A = p.create_matrix()
                self.snes.setJacobian(self._J, self._A, self._A)
            p.jacobian(x, self._A)
            if self._reusing:
                self._reuse_mode(False)
            ksp = self.snes.getKSP()
            ksp.setOperators(self._A, self._A)
            # a solve whose Jacobians all reused the factorization (SNES lag −1) left the
            # PC marked for reuse: it would keep the old factorization
            ksp.getPC().setReusePreconditioner(False)
            # a failed factorization that raises nothing fails the next linear solve:
            # solve_with_last_jacobian returns False then
            self._factored = False
            try:
                ksp.setUp()
            except PETSc.Error:
                return False
        finally:
            self.timings["linear_solve"] += _ksp_time() - t0
        self._factored = True
        note = getattr(p, "note_factorization", None)
        if note is not None:
            note()
        return True

    @_owning_options
    def configure_uzawa_ksp(self, ksp: PETSc.KSP) -> None:
        """Give ``ksp``, the GMRES of the exact multiplier update
        (``contact.MortarContact.uzawa_update``, ``uzawa_acceleration = "newton"``), the
        options prefix ``<settings.prefix>uzawa_newton_`` (:data:`UZAWA_KSP_PREFIX`) and
        the options set under it (KSPSetFromOptions; local to ``ksp``'s communicator, on
        every rank of it). The solver's options are loaded first, so
        ``[solver.petsc] uzawa_newton_ksp_monitor = true`` or ``-dm_uzawa_newton_ksp_max_it
        5`` on the command line take effect; without such options the KSP keeps the
        settings the update gave it (unpreconditioned GMRES, its tolerances)."""
        ksp.setOptionsPrefix(self.settings.prefix + UZAWA_KSP_PREFIX)
        ksp.setFromOptions()

    @property
    def linear_solver(self) -> dict[str, str]:
        """The linear solver that PETSc has set up from :attr:`options` (local; the same
        on every rank): ``{"ksp": KSP type, "pc": PC type}``, plus ``"factor"``, the
        factorization package, where the PC factorizes (lu, cholesky, ilu, icc; "petsc"
        for PETSc's own). summary.json's ``modelled.linear_solver`` is this at the
        solver's creation: an LDLᵀ failure's switch to LU later (:attr:`ldlt_fallbacks`)
        is not in it."""
        ksp = self.snes.getKSP()
        pc = ksp.getPC()
        out = {"ksp": str(ksp.getType()), "pc": str(pc.getType())}
        if out["pc"] in ("lu", "cholesky", "ilu", "icc"):
            out["factor"] = str(pc.getFactorSolverType() or "petsc")
        return out

    @property
    def options(self) -> dict[str, str | int | float]:
        """The PETSc options this solver works with, without its prefix (a copy; a
        flag's value is ""): the defaults, ``settings.linear``'s, ``settings.petsc`` and
        what the solver changes while it works (the line search of a continued solve,
        ``pc_type`` after an LDLᵀ failure). Local."""
        return dict(self._options)

    def _set_option(self, key: str, value) -> None:
        """Set the option ``key`` (without prefix) to ``value``, or remove it (None), for
        this solver, and in PETSc's database if its options are loaded (local)."""
        if value is None:
            self._options.pop(key, None)
        else:
            self._options[key] = value
        if _LOADED.get(self.settings.prefix) is self:
            opts, name = PETSc.Options(), self.settings.prefix + key
            if value is None:
                opts.delValue(name)
            else:
                opts[name] = value

    def _load_options(self) -> None:
        """Put this solver's options into PETSc's global database under its prefix, unless
        they are there (local; cheap then). Another solver's options there are unloaded
        first; where none were, what the database held under the prefix (a host
        program's options) is set aside until :meth:`destroy`."""
        prefix = self.settings.prefix
        loaded = _LOADED.get(prefix)
        if loaded is self:
            return
        opts = PETSc.Options()
        if loaded is not None:
            loaded._unload_options()
        else:
            theirs = _loaded_keys()
            aside = {
                k: v for k, v in opts.getAll().items() if k.startswith(prefix) and k not in theirs
            }
            for key in aside:
                opts.delValue(key)
            _HOST_OPTIONS[prefix] = aside
        for key, value in self._options.items():
            opts[prefix + key] = value
        _LOADED[prefix] = self

    def _unload_options(self) -> None:
        """Note which of this solver's options PETSc has read (:meth:`_warn_unused_options`)
        and take them out of the global database (local; they must be loaded)."""
        opts, prefix = PETSc.Options(), self.settings.prefix
        for key in self._options:
            used = compat.option_used(prefix + key)
            self._usage_known = self._usage_known and used is not None
            if used:
                self._used.add(key)
            opts.delValue(prefix + key)
        del _LOADED[prefix]

    def destroy(self) -> None:
        """Free the solver (collective on the problem's communicator); idempotent: a
        second call, e.g. the ``with`` block's exit after a call by hand, does nothing.

        - Frees the SNES (its KSP and PC), the Jacobian matrix and the residual and work
          vectors it owns; the solver cannot solve afterwards.
        - Gives the problem back: leaves ``problem.solvers`` (the problem takes new contact
          terms again once no solver lives) and sets ``problem.linear_inverse``,
          ``problem.configure_uzawa_ksp`` and ``problem.factorize_jacobian`` to None
          where they are this solver's (another solver's hooks stay).
        - PETSc options: where this solver's options are the ones loaded under its
          prefix (it worked last), takes them out of PETSc's global database and puts
          back what a host program had there under the prefix before a solver loaded
          its own (:meth:`_load_options`); where another solver's are loaded, the
          database is left as it is.
        - After at least one :meth:`solve`, logs one warning (logger
          ``dolfinx_mortar.solver``) naming the options of ``settings.petsc`` (the
          scene's ``[solver.petsc]``, the command line's ``-dm_...``) that PETSc never
          read in this solver's work: a typo, or an option of a solver not in use.
          Nothing is logged where PETSc cannot tell (``compat.option_used``).
        """
        if self._destroyed:
            return
        self._destroyed = True
        self._drop.detach()
        if hasattr(self.problem, "solvers"):
            self.problem.solvers.discard(self)
        if getattr(self.problem, "linear_inverse", None) == self.solve_with_last_jacobian:
            self.problem.linear_inverse = None
            self.problem.configure_uzawa_ksp = None
        if getattr(self.problem, "factorize_jacobian", None) == self.factorize_current_jacobian:
            self.problem.factorize_jacobian = None
        prefix = self.settings.prefix
        if _LOADED.get(prefix) is self:
            self._unload_options()
            opts = PETSc.Options()
            for key, value in _HOST_OPTIONS.pop(prefix, {}).items():
                opts[key] = "" if value is None else value
        if self._solved:
            self._warn_unused_options()
        self.snes.destroy()
        self._A.destroy()
        self._b.destroy()
        self._finite_x.destroy()
        self._trial.destroy()
        self._start.destroy()

    def _warn_unused_options(self) -> None:
        """Log a warning naming the options of ``settings.petsc`` (the scene's
        ``[solver.petsc]`` and the command line's ``-dm_...``) that PETSc never read in
        this solver's solves: a typo, or an option of a solver or type not in use."""
        if not self._usage_known:
            return
        prefix = self.settings.prefix
        unused = [
            k for k, v in self.settings.petsc.items() if v is not False and k not in self._used
        ]
        if unused:
            log.warning(
                "PETSc never read the option(s) %s of [solver.petsc] / the command line: "
                "a typo, or an option of a solver not in use",
                ", ".join(f"-{prefix}{k}" for k in unused),
            )

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()


#: PETSc viewer types that open a file named in the viewer's option value
#: ("TYPE:FILE[:FORMAT[:MODE]]", e.g. ``snes_monitor = "ascii:monitor.txt"``)
_FILE_VIEWERS = ("ascii", "binary", "hdf5", "vtk", "matlab")


def _viewer_file_errors(petsc: dict) -> list[tuple[str, str]]:
    """(key, reason) of each option of ``petsc`` whose value is a file viewer
    (:data:`_FILE_VIEWERS`) whose file cannot be opened: a missing or unwritable
    directory, a directory in the file's place, a missing file to read (local: a check
    of the file system, which creates nothing)."""
    import os
    from pathlib import Path

    errors = []
    for name, value in petsc.items():
        if not isinstance(value, str) or ":" not in value:
            continue
        vtype, fname, *rest = value.split(":", 3)
        mode = rest[1].lower() if len(rest) > 1 else ""
        if (vtype.strip().lower() or "ascii") not in _FILE_VIEWERS:
            continue
        # no file (stdout), ascii's standard streams, a name PETSc expands ($HOSTNAME)
        if not fname or fname in ("stdout", "stderr") or "$" in fname:
            continue
        path = Path(fname)
        if mode in ("read", "update"):
            if not (path.is_file() and os.access(path, os.R_OK)):
                errors.append((f"solver.petsc.{name}", f"cannot read the viewer file {fname}"))
            continue
        parent = path.parent
        if path.is_dir():
            why = "it is a directory"
        elif path.exists():
            why = None if os.access(path, os.W_OK) else "not writable"
        elif not parent.is_dir():
            why = f"no directory {parent}"
        else:
            why = None if os.access(parent, os.W_OK | os.X_OK) else f"{parent} is not writable"
        if why:
            errors.append((f"solver.petsc.{name}", f"cannot open the viewer file {fname}: {why}"))
    return errors


def _options_named_in(reason: str, petsc: dict, prefix: str) -> list[str]:
    """The options of ``petsc`` that PETSc's error message ``reason`` names, by their
    value as a word of it ("Unable to find requested KSP type nonexistent") or by their
    prefixed name; booleans (bare flags) are never matched by value (local)."""
    named = []
    for name, value in petsc.items():
        text = "" if isinstance(value, bool) else str(value)
        by_value = text and re.search(rf"(?<![\w.-]){re.escape(text)}(?![\w.-])", reason)
        if by_value or f"-{prefix}{name}" in reason:
            named.append(name)
    return named


def _create_vector(problem):
    from dolfinx.fem.petsc import create_vector

    return create_vector(problem.F_form)


#: SNES tolerances that NewtonSolver sets from [solver] on every solve, and the [solver]
#: key that sets each. snes_max_it was honoured in a step's first solve only, then the
#: continuations (full steps, "bt") went on to [solver] max_it, and the convergence
#: history is sized from max_it
_TOLERANCE_OPTIONS = {"snes_rtol": "rtol", "snes_atol": "atol", "snes_max_it": "max_it"}
#: SNES types that do one linear solve instead of Newton's method
_LINEAR_SNES_TYPES = ("ksponly", "ksptransposeonly")


def _iterations_text(parts: list[tuple[int, str]], max_it: int) -> str:
    """ "N iterations" of a failed solve, made of ``parts`` ((iterations, how) each); where
    there are several (a full-step attempt started again, a stalled solve continued with
    full steps, a non-finite one with "bt": :meth:`NewtonSolver.solve`), each is named,
    with ``max_it``, the limit of each: a solve with ``max_it = 1`` said "2 iterations"."""
    total = sum(n for n, _ in parts)
    if len(parts) < 2:
        return f"{total} iterations"
    each = ", then ".join(f"{n} {how}" for n, how in parts)
    return f"{total} iterations: {each}, max_it = {max_it} each"


def _reason_name(enum, reason: int) -> str:
    """``reason`` with its PETSc name, e.g. "-3 DIVERGED_LINEAR_SOLVE" (``enum``:
    ``PETSc.SNES.ConvergedReason`` or ``PETSc.KSP.ConvergedReason``; local)."""
    names = [k for k in dir(enum) if k.isupper() and getattr(enum, k) == reason]
    return f"{reason} {min(names, key=len)}" if names else str(reason)


def _ksp_time() -> float:
    """Seconds spent in linear solves so far: PETSc's KSPSolve and PCSetUp events (the LU
    factorisation is logged under PCSetUp, outside KSPSolve). Logging starts on import."""
    return sum(PETSc.Log.Event(e).getPerfInfo()["time"] for e in ("KSPSolve", "PCSetUp"))


PETSc.Log.begin()


@dataclass
class StepResult:
    """What one converged load step did (the ``steps`` entries of summary.json)."""

    t: float
    newton_iterations: list[int]
    residual_norms: list[list[float]]
    uzawa_rounds: int
    cutbacks: int
    wall_time: float
    timings: dict
    uzawa: list[dict] = field(default_factory=list)
    #: Newton solves since the last converged step (failed attempts included) that were
    #: continued with full steps (see FULL_STEP_ITERATIONS)
    full_step_solves: int = 0
    #: later-round solves of this step whose full Newton steps failed and that started
    #: again with the configured line search (see ROUND_FULL_STEPS)
    full_step_restarts: int = 0
    #: the same for solves restarted with the bt line search after a non-finite
    #: residual (see _NONFINITE)
    backtracked_solves: int = 0
    #: attempts of this step from the extrapolated predictor that failed (then retried
    #: from the converged state; see PREDICTOR_MAX_BACKOFF)
    predictor_failures: int = 0
    #: Newton solves of this step whose first linear solve used the last factorization
    #: (GMRES on it; see REUSE_FACTORIZATION), and those where GMRES did not converge
    reused_factorizations: int = 0
    failed_reuses: int = 0
    #: solves of this step whose LDLᵀ factorization failed, after which the solver
    #: factorizes LU (NewtonSolver._fall_back_to_lu)
    ldlt_fallbacks: int = 0
    #: Newton steps of this step shortened by the penetration limit
    #: (SolverSettings.step_depth_limit; failed attempts included)
    limited_steps: int = 0
    #: first Jacobians of this step's solves (failed attempts included) that the state
    #: predictor assembled again with slip tangents (NewtonSolver._predict_states)
    state_predictions: int = 0
    #: attempts of this step that failed with wrong frozen stick/slip states and were
    #: retried with the states carried between Uzawa rounds (see FROZEN_RETRY_ROUNDS)
    carried_retries: int = 0
    #: Newton iterations of all attempts of this step, the failed ones included
    #: (``newton_iterations`` lists those of the accepted attempt)
    all_iterations: int = 0
    #: Krylov iterations of this step's linear solves, failed attempts included
    #: (NewtonSolver.linear_iterations)
    linear_iterations: int = 0


@dataclass
class RoundResume:
    """Where an attempt at a step stood after its first Uzawa round (see
    :func:`solve_step`): the first round's results and the problem's
    ``round_state()`` after its multiplier update."""

    its: list
    norms: list
    info: list
    rtol: float | None
    changes: list
    state: dict


def solve_step(
    problem,
    newton: NewtonSolver,
    uzawa_max: int,
    inexact: bool = True,
    dtol=None,
    resume: RoundResume | None = None,
) -> tuple[list[int], list[list[float]], list[dict]]:
    """Newton solves with fixed multipliers, then Uzawa updates, until the multipliers settle
    (:func:`_rounds`), returning per round its Newton iterations, residual norms and
    update information (collective).

    A problem with a stiff contact pair (``problem.soft_start``: a penalty above "auto"
    with Uzawa, above :data:`dolfinx_mortar.contact.SOFT_START_RATIO` × "auto" as pure
    penalty) goes through the rounds twice: first under the soft penalties ε_soft =
    min(ε, ε_auto) (``problem.soft_penalties``), then from that solution with its own.
    With Uzawa the second pass starts at the augmented-Lagrangian solution, which does
    not depend on ε, so it takes 0–2 Newton iterations; as pure penalty it is one solve
    from the soft state, whose active set is nearly the stiff one's. The soft rounds come
    first in the returned lists; their ``info`` entries of the stiff pairs carry
    ``soft_penalty: True``. Each pass may take ``uzawa_max`` rounds. A FrozenStatesError
    of either pass carries no ``resume``: the retry with carried states starts over, soft
    pass included.
    """
    if resume is not None or not getattr(problem, "soft_start", False):
        return _rounds(problem, newton, uzawa_max, inexact, dtol, resume)
    try:
        with problem.soft_penalties() as stiff:
            soft = _rounds(problem, newton, uzawa_max, inexact, dtol)
        for info in soft[2]:
            for name in stiff:
                info[name]["soft_penalty"] = True
        # the second pass starts from a solution, not from the predictor
        own = _rounds(problem, newton, uzawa_max, inexact)
    except FrozenStatesError as exc:
        exc.resume = None
        raise
    return soft[0] + own[0], soft[1] + own[1], soft[2] + own[2]


def _rounds(problem, newton, uzawa_max, inexact, dtol=None, resume=None) -> tuple:
    """The Uzawa rounds of :func:`solve_step` with the penalties in place (collective;
    the arguments and the returned lists as there).

    With ``inexact`` (default; off where ``problem.exact_multiplier_update``), the rounds
    after the first solve Newton only to
    rtol_k = max(rtol, min(1e-3, 1e-2 · c_{k−1})), c the relative multiplier change of the
    previous round: there is no point in a 1e-9 solve for multipliers that still move by
    1e-4. When the multipliers have settled after an inexact solve, one more solve at the
    full tolerance (same multipliers) makes the accepted state fully converged.
    ``uzawa_max`` bounds the number of Uzawa rounds, and the rounds stop early when they
    stall (:data:`UZAWA_STALL_ROUNDS`). A round after the first takes at least one Newton
    iteration: near the end the residual that a multiplier update leaves can be below the
    absolute tolerance ``atol``, and without an iteration the state, hence the next
    multiplier change, stayed the same round after round (frictional patch test with
    tetrahedra and segments: a stall at 1.7e-9 against uzawa_tol = 1e-9). ``dtol`` goes to
    the first solve
    (see :data:`PREDICTOR_DIVERGENCE_TOLERANCE`), which is then a start from the predictor
    and gets no "bt" restart (:meth:`NewtonSolver.solve`). Raises ConvergenceError.

    A FrozenStatesError raised with free states carries, as ``resume``, a
    :class:`RoundResume` of the attempt after its first round (when the problem has
    ``round_state``). With ``resume`` (the problem already put back into that state with
    ``resume_round``) the rounds go on from the second: the retry with carried states
    does not solve the first round again, whose solve starts free in either attempt.
    """
    # the exact multiplier update reads the gaps of the round's solution: an inexact solve
    # (relative 1e-3) left it as far from closed as before (peers problem A: changes 2e-6
    # after two rounds instead of one)
    inexact = inexact and not getattr(problem, "exact_multiplier_update", False)
    its_all, norms_all, info_all = [], [], []
    rtol = None
    changes = []  # per round: the largest relative multiplier change, normal or tangential
    inconsistent = 0  # rounds in a row whose frozen stick/slip states were wrong
    first = 0
    if resume is not None:
        its_all, norms_all, info_all = list(resume.its), list(resume.norms), list(resume.info)
        rtol, changes, first = resume.rtol, list(resume.changes), 1
    after_first = None  # RoundResume after the first round
    for k in range(first, max(uzawa_max, 1)):
        predicted = k == 0 and dtol is not None
        # a later round iterates at least once, unless the update moved u with the
        # multipliers (the exact update): its state then changes with them anyway
        force = k > 0 and not getattr(problem, "moved_with_multipliers", False)
        its, norms = newton.solve(
            rtol,
            dtol if k == 0 else None,
            rescue=not predicted,
            reuse=k > 0,
            force=force,
            full_steps=ROUND_FULL_STEPS and _released_pins(info_all),
        )
        its_all.append(its)
        norms_all.append(norms)
        done, info = problem.uzawa_update()
        info_all.append(info)
        if done:
            if rtol is not None:
                full_steps = ROUND_FULL_STEPS and _released_pins(info_all)
                its, norms = newton.solve(reuse=True, full_steps=full_steps)
                its_all.append(its)
                norms_all.append(norms)
            return its_all, norms_all, info_all
        change = max((i.get("multiplier_change", 0.0) for i in info.values()), default=0.0)
        exact = getattr(problem, "exact_multiplier_update", False)
        rtol = min(1e-3, 1e-2 * change) if inexact and not exact else None
        # the rounds' test: a penalty softer than its auto rule is tested at the auto
        # rule's change (soft_penalty_change, UzawaRounds._softness)
        changes.append(
            max(
                (
                    max(
                        i.get("multiplier_change", 0.0),
                        i.get("tangential_change", 0.0),
                        i.get("soft_penalty_change", 0.0),
                    )
                    for i in info.values()
                ),
                default=0.0,
            )
        )
        if uzawa_stalled(changes):
            raise ConvergenceError(
                f"Uzawa augmentation stalled: no progress in {UZAWA_STALL_ROUNDS} rounds "
                f"(multiplier changes {', '.join(f'{c:.2g}' for c in changes)}; last round: "
                f"{_round_text(info)})"
            )
        unfrozen = any(i.get("unfrozen_states", 0) > 0 for i in info.values())
        growing = len(changes) >= 2 and changes[-1] >= changes[-2]
        inconsistent = inconsistent + 1 if unfrozen and growing else 0
        carrying = getattr(problem, "carrying_states", False)
        if k == 0 and not carrying and hasattr(problem, "round_state"):
            state = problem.round_state()  # None: nothing could be carried
            if state is not None:
                after_first = RoundResume(
                    its_all[:], norms_all[:], info_all[:], rtol, changes[:], state
                )
        if inconsistent >= (FROZEN_RETRY_ROUNDS if carrying else FROZEN_RETRY_ROUNDS_FREE):
            raise FrozenStatesError(
                f"the stick/slip states frozen by the chattering control were wrong at "
                f"convergence, and the multiplier change grew, in {inconsistent} Uzawa "
                f"rounds in a row ({_round_text(info)})",
                resume=after_first,
            )
    raise ConvergenceError(
        f"Uzawa augmentation did not converge in {uzawa_max} rounds (last round: "
        f"{_round_text(info_all[-1])}); a "
        "change that still falls needs more rounds ([[contact]] uzawa_max) or a looser "
        "uzawa_tol"
    )


#: The keys of a round's ``uzawa_update`` information that :func:`_round_text` reports,
#: in its words.
_ROUND_WORDS = {
    "multiplier_change": "change",
    "tangential_change": "tangential change",
    "soft_penalty_change": "change at the auto penalty",
    "max_penetration": "largest penetration",
}


def _round_text(info: dict) -> str:
    """One Uzawa round's ``uzawa_update`` information (``info``: per pair name, a dict) in
    words for an error message: each pair's relative multiplier changes and largest
    penetration, "a:b: change 2e-12, tangential change 0.0002, largest penetration
    2.6e-19" (local). An error had printed the raw dicts, 17 digits each."""
    return "; ".join(
        f"{name}: " + ", ".join(f"{w} {i[k]:.2g}" for k, w in _ROUND_WORDS.items() if k in i)
        for name, i in info.items()
    )


#: ``uzawa_update`` information of a round whose frozen or held states the free law
#: contradicted at convergence (global counts)
_CHANGED_STATES = ("unfrozen_states", "released_nodes", "unfrozen_qp_nodes")


def _open_contact_hint(problem) -> str:
    """A clause for the error of a run that stops, where no contact pair had a slave
    node in contact at the failed attempt's last contact update ("" where some pair
    touched or the problem has no contact), naming the open pairs with a body that the
    Dirichlet conditions leave free (``free_body``; "" where there is none: the failure
    is not a free body's). Collective; called only when the run stops, so two allreduces
    per run, not per failed attempt. A body that only contact holds is then free, and
    Newton cannot reduce its load: the usual cause is a load pointing away from the
    contact (a pulled cylinder: every cutback failed with ‖R‖ = the load), unless the
    pair had a node in contact at an earlier iterate of the attempt
    (``touched_in_attempt``: Newton lost the contact it had found, and the clause says
    so instead of blaming the loads), or, where no
    slave point of the pair projects onto its master surface at all
    (``problem.unpaired_pairs``), surfaces that are apart or do not face each other (a
    body placed beside the other: the hint had blamed the loads)."""
    if not getattr(problem, "contacts", None):
        return ""
    pairs = problem.open_pairs()
    if len(pairs) < len(problem.contacts):
        return ""
    free = [t.name for t in problem.contacts if t.free_body and t.name in pairs]
    if not free:
        return ""
    apart = [name for name in problem.unpaired_pairs() if name in free]
    # pairs that had a slave node in contact at an earlier iterate of the failed attempt:
    # Newton found the contact and lost it again, which says nothing of the loads (a
    # traction-loaded full 2D Hertz model, whose cylinder turns freely about its centre
    # with frictionless contact, had been told to check them)
    touched = {t.name for t in problem.contacts if getattr(t, "touched_in_attempt", False)}
    lost = [name for name in free if name not in apart and name in touched]
    near = [name for name in free if name not in apart and name not in touched]
    find = getattr(problem, "unheld_motions", None)
    stick = getattr(problem, "stick_only_motions", None)
    movers = list(find()) if find is not None else []
    movers += list(stick()) if stick is not None else []
    drifted = {p for b in movers for p in b.pairs}
    clauses = []
    if apart and set(apart) <= drifted:
        # a free body drifted off: not a question of positions. Named here: a body that
        # only stick holds is named by no other clause unless it started apart or slipped
        # (the clause said "the free body drifted along those motions" and named none)
        said = dict.fromkeys(b.describe(problem.gdim) for b in movers if set(b.pairs) & set(apart))
        clauses.append(
            f"no slave point of {', '.join(apart)} faces its master surface at the last "
            f"attempt: {'; '.join(said)}, held there only by contact, and it drifted off "
            "(check the loads: a body held only by contact follows one that pulls it away)"
        )
    elif apart:
        clauses.append(
            f"no slave point of {', '.join(apart)} faces its master surface (none projects "
            "onto it within the search distance): a body held only by contact is free "
            "there (check the pair's surfaces and the bodies' positions)"
        )
    if near:
        clauses.append(
            f"no slave node of {', '.join(near)} was in contact: a body held only by "
            "contact is free there (check the direction of the loads)"
        )
    if lost:
        clauses.append(
            f"no slave node of {', '.join(lost)} was in contact at the failed attempt's last "
            "iterate, though some were at earlier ones: Newton did not settle the contact "
            "of a body held only by contact there (a rigid motion that contact holds weakly "
            "or not at all, such as a cylinder free to turn about its centre with "
            "frictionless contact, lets the iterates wander: hold it with a [[dirichlet]] "
            "condition)"
        )
    return "; " + "; ".join(clauses)


def _unheld_hint(problem) -> str:
    """A clause for the error of a run that stops, naming each body with rigid motions that
    neither its Dirichlet conditions nor its (frictionless) contact can hold
    (``problem.unheld_motions``; "" where there is none, or the problem cannot tell).
    Collective; cached by the problem (computed when the run set up). A probe's block held
    in z only, its symmetry faces in unnamed physical groups, drifted sideways off the
    sphere above it, and the error blamed the surfaces' positions. Then each group of
    bodies joined by contact that nothing holds against a rigid motion of them all
    together (``problem.unheld_joint_motions``: a shrink fit with no [[dirichlet]] at
    all)."""
    find = getattr(problem, "unheld_motions", None)
    if find is None or not getattr(problem, "contacts", None):
        return ""
    bodies = find()
    joint = getattr(problem, "unheld_joint_motions", None)
    groups = joint() if joint is not None else ()
    stick = getattr(problem, "stick_free_at_start", None) or ()
    return (
        "".join(
            f"; {b.describe(problem.gdim)}, held there by no [[dirichlet]] condition nor by its "
            f"frictionless contact ({', '.join(b.pairs)})"
            for b in bodies
        )
        + "".join(
            f"; {g.describe(problem.gdim)}, held there by no [[dirichlet]] condition, and their "
            f"contact ({', '.join(g.pairs)}) keeps every gap along them"
            for g in groups
        )
        + "".join(
            f"; {b.describe(problem.gdim)} but for stick ({', '.join(b.pairs)}), which holds "
            "nothing at the nodes that close within a step: prescribe these components with "
            "[[dirichlet]], or start the bodies in contact"
            for b in stick
        )
    )


def _friction_hold_hint(problem) -> str:
    """A clause for the error of a run that stops, naming each body that only stick holds
    along some rigid motion (``problem.stick_only_motions``) where at least half of the
    active slave nodes of its frictional pairs slipped in the last converged step (each
    pair's ``committed_slip``): a tangential load beyond μ times the normal load has no
    equilibrium there. A probe's block held by friction alone, pushed by a traction whose
    ratio to the pressure rose past μ = 0.2, stopped at 0.1985 with DIVERGED_DTOL and no
    word of friction (7 of its 8 active nodes slipped in the last converged step; the
    failed attempt's own states were frozen at stick). Bodies named by
    :func:`_unheld_hint`'s stick clause (no contact at t = 0) are left to it. Local after
    the cached ``stick_only_motions``; the same on every rank; "" where there is none."""
    find = getattr(problem, "stick_only_motions", None)
    if find is None or not getattr(problem, "contacts", None):
        return ""
    named = {b.name for b in getattr(problem, "stick_free_at_start", None) or ()}
    counts = {t.name: getattr(t, "committed_slip", (0, 0)) for t in problem.contacts}
    clauses = []
    for b in find():
        active = sum(counts[p][0] for p in b.pairs)
        slip = sum(counts[p][1] for p in b.pairs)
        if b.name not in named and active and 2 * slip >= active:
            clauses.append(
                f"; {b.describe(problem.gdim)} but for friction ({', '.join(b.pairs)}), and "
                f"{slip} of its {active} active slave nodes slipped in the last converged "
                "step: a tangential load above the friction coefficient times the normal "
                "load has no equilibrium (check the loads along these motions, or prescribe "
                "the motion instead of a force)"
            )
    return "".join(clauses)


def _penalty_hint(problem) -> str:
    """A clause for the error of a run that stops, naming the pairs whose penalties exceed
    the band in which stiff penalties were measured (``stiff_penalty_note`` of each
    pair; local, the same on every rank); "" where none does."""
    notes = [
        n
        for t in getattr(problem, "contacts", ())
        if (n := getattr(t, "stiff_penalty_note", lambda: "")())
    ]
    return "".join(f"; {n}" for n in notes)


def _edge_hint(problem) -> str:
    """A clause for the error of a run that stops where slave facets in contact lie
    across the master surface's edge under segment integration (``problem.edge_facet_pairs``;
    "" where none): the paired area has a kink there (one-sided derivatives), which may
    be what stopped Newton. The stalls once put down to it (docs/method-notes.md,
    "Segment integration": a press or a slide with the slave's boundary on the master's,
    with friction) were the dual tangential weights' choice switching from one iterate to
    the next, fixed in session 52; the clause names the place and the ways around it, not
    a known cause. Collective; called only when the run stops."""
    pairs = getattr(problem, "edge_facet_pairs", None)
    found = pairs() if pairs is not None and getattr(problem, "contacts", None) else {}
    if not found:
        return ""
    where = ", ".join(
        f"{n} slave facet{'s' if n > 1 else ''} of {name}" for name, n in found.items()
    )
    return (
        f"; {where} in contact across the master surface's edge, where the paired area of "
        "segment integration has a kink, which may have stopped Newton (docs/method-notes.md, "
        '"Segment integration"): integration = "element", or a master surface that extends '
        "beyond the slave, avoids it"
    )


def _inverted_state(problem, x: PETSc.Vec | None = None):
    """The ``problem.DetF`` of the state x (None: the problem's current u) where it has
    det F <= 0 at a point checked, else None; None without a check: small kinematics
    (``problem.small_strain``, a linear bulk) or a problem without ``min_det_F``
    (collective; with x the problem's u becomes x)."""
    if getattr(problem, "small_strain", True) or not hasattr(problem, "min_det_F"):
        return None
    det = problem.min_det_F(x)
    return det if det.value <= 0.0 else None


def _failed_inversion(problem, exc: ConvergenceError):
    """The ``problem.DetF`` of a failed attempt's last state (the problem's u: the point
    of the last residual evaluation, whose contact state the stop hints read) where it
    has inverted elements, else None (collective): that of an InvertedElementsError
    itself, otherwise :func:`_inverted_state`."""
    if isinstance(exc, InvertedElementsError):
        return exc.det
    return _inverted_state(problem)


def _stop_hints(problem, inverted=None, exc: ConvergenceError | None = None) -> str:
    """The clauses of :func:`_open_contact_hint` and :func:`_edge_hint` (collective), or,
    where the failed attempt's last state had inverted elements (``inverted``, a
    ``problem.DetF`` from :func:`_failed_inversion`), a clause saying so instead: the
    contact state of a folded iterate says nothing of the contact (an SVK slide whose
    collapsed last iterate had 6 slave facets "across the master's edge", the master
    0.2 wider than the slave on each side); "" where ``exc`` (an InvertedElementsError)
    already says so (local then)."""
    if inverted is None:
        return (
            _unheld_hint(problem)
            + _open_contact_hint(problem)
            + _edge_hint(problem)
            + _friction_hold_hint(problem)
            + _penalty_hint(problem)
        )
    if isinstance(exc, InvertedElementsError):
        return ""
    return f"; the last attempt ended with inverted elements ({inverted.describe()})"


def _released_pins(info_all: list[dict]) -> bool:
    """Whether the last Uzawa round's solve (``info_all``: per round, per pair, the
    ``uzawa_update`` information) ended with pinned points on some pair (the chattering
    control of the pairing), and with states that the free law confirmed on every pair:
    the next solve releases the pins and only those (ROUND_FULL_STEPS). The same on every
    rank (the counts are global)."""
    last = info_all[-1].values() if info_all else ()
    pinned = any(i.get("pinned_points", 0) > 0 for i in last)
    return pinned and not any(i.get(k, 0) > 0 for i in last for k in _CHANGED_STATES)


def uzawa_stalled(changes, rounds: int = UZAWA_STALL_ROUNDS) -> bool:
    """True when none of the last ``rounds`` values of m_k = max(c_{k−1}, c_k) (``changes``:
    c_k the relative multiplier change of Uzawa round k) is below half the smallest
    m before them. The pairwise maximum sees through a 2-cycle of large and small
    changes."""
    m = [max(a, b) for a, b in zip(changes[:-1], changes[1:], strict=True)]
    if len(m) <= rounds:
        return False
    return min(m[-rounds:]) > 0.5 * min(m[:-rounds])


def _jumped(problem, rates: list) -> bool:
    """Whether the last converged step held a jump (PREDICTOR_JUMP_RATIO): ``rates`` (t0,
    t1, ‖Δu‖/Δt) of the last two steps, the later one's rate above the ratio times the
    earlier one's, with the load path straight over both (at a corner the rate changes
    with the load: frictionless sliding after a press took 12 iterations instead of 5
    without the predictor in the step after the corner). Collective where the problem
    has Dirichlet fields: the corner check runs whenever there are two rates, whatever
    they are, so that no rank's round-off in the rates decides whether it joins the
    reduction."""
    if len(rates) < 2:
        return False
    (t0, t1, r0), (_, t2, r1) = rates
    bends = _path_bends(problem, t0, t1, t2)
    return r1 > PREDICTOR_JUMP_RATIO * r0 and not bends


def _rates_change(v0, v1, v2, t0: float, t1: float, t2: float, atol: float = 0.0) -> bool:
    """Whether some value's rate on [t1, t2] differs from its rate on [t0, t1] by more than
    PATH_RATE_TOL relative to the larger of the two (``v0, v1, v2``: the values at t0, t1,
    t2, arrays of one shape; where they are 2-D, a row is one vector and its rates compare
    by their Euclidean norms: a node's displacement). Values whose increments over both
    intervals are at most ``atol`` (norms) do not count (round-off: a point that does
    not move)."""
    v0, v1, v2 = (np.asarray(v, float) for v in (v0, v1, v2))
    a, b = (v1 - v0) / (t1 - t0), (v2 - v1) / (t2 - t1)

    def size(w):
        return np.abs(w) if w.ndim == 1 else np.linalg.norm(w, axis=-1)

    change = size(a - b) > PATH_RATE_TOL * np.maximum(size(a), size(b))
    if atol > 0.0:
        change &= np.maximum(size(v1 - v0), size(v2 - v1)) > atol
    return bool(np.any(change))


def _path_bends(problem, t0: float, t1: float, t2: float) -> bool:
    """Whether the prescribed data have a corner at t1 (:func:`_rates_change`): the
    Dirichlet and traction paths (``problem.load_values``, value by value, the same on
    every rank) or the fields of ``add_dirichlet_field`` (``problem.field_values``: each
    rank's own nodes, a node's displacement vector by vector, increments up to
    FIELD_ROUND_OFF × the mesh extent not counted; the ranks' answers combined by a
    logical-or allreduce over the problem's communicator, so that every rank takes the
    same decision). Collective where ``problem.has_dirichlet_fields``, local otherwise.
    A problem without ``load_values`` never bends."""
    if not hasattr(problem, "load_values"):
        return False
    ts = (t0, t1, t2)
    bends = _rates_change(*(problem.load_values(t) for t in ts), *ts)
    if getattr(problem, "has_dirichlet_fields", False):
        atol = FIELD_ROUND_OFF * problem.extent
        local = _rates_change(*(problem.field_values(t) for t in ts), *ts, atol=atol)
        bends = problem.comm.allreduce(local, op=MPI.LOR) or bends
    return bends


def default_uzawa_max(problem) -> int:
    """The Uzawa rounds a load step may take: the largest ``uzawa_max`` of the problem's
    contact terms, 1 without contact (local)."""
    return max([term.uzawa_max for term in getattr(problem, "contacts", ())] or [1])


#: Output times within this fraction of t_end from a step time (or from each other) are
#: that step: ``output_times = [0.5000000000000001]`` with n = 2 added a step of 1e-16
#: after t = 0.5 (no Newton iteration, a second record that printed t = 0.5).
TARGET_MERGE_TOL = 1e-12


def step_targets(t_end: float, n: int, output_times=()) -> list[float]:
    """The times a load stepper works towards (local): the ``n`` equal steps' ends and
    the ``output_times`` in (0, t_end], sorted; an output time within TARGET_MERGE_TOL ×
    t_end of a step's end, or of a smaller output time, is not one more target."""
    targets = np.linspace(0.0, t_end, n + 1)[1:].tolist()
    tol = TARGET_MERGE_TOL * t_end
    for t in sorted(float(t) for t in output_times):
        i = bisect.bisect_left(targets, t)
        near = targets[max(i - 1, 0) : i + 1]
        if 0.0 < t <= t_end + tol and all(abs(t - s) > tol for s in near):
            targets.insert(i, t)
    return targets


class LoadStepper:
    """Walks t = 0 → t_end over ``n`` equal steps plus ``output_times`` (collective; the
    targets: :func:`step_targets`, an output time within round-off of a step's end is
    that step).

    A step that raises FrozenStatesError (wrong frozen stick/slip states, see
    :data:`FROZEN_RETRY_ROUNDS`) is first retried at the same size with the states
    carried between Uzawa rounds (``problem.carry_states``). A step that raises
    ConvergenceError from the extrapolated predictor is retried from the last converged
    state (and the next steps do without the predictor:
    :data:`PREDICTOR_MAX_BACKOFF`); then it is retried with half the time
    increment, at most ``max_cutbacks`` times in a row and never below 2^-max_cutbacks of
    the load step it divides (the step of the ``n`` equal ones or ``output_times`` that
    the stepper works towards); then the ConvergenceError propagates (every finished
    step has been passed to ``on_step`` already). A step's timings include its failed attempts.
    ``on_step(step_index, result)`` is called after each
    converged step, with the problem holding the converged state. Each step starts from
    the extrapolated predictor except at a corner of the load path (``problem.load_values``
    and ``problem.field_values``, :data:`PATH_RATE_TOL`) and after a jump (``problem.increment_norm``,
    :data:`PREDICTOR_JUMP_RATIO`). ``uzawa_max`` bounds the Uzawa rounds per step; None
    (the default) takes the largest ``uzawa_max`` of the problem's contact terms (1
    without contact), as a scene run does.
    """

    def __init__(
        self,
        problem,
        newton: NewtonSolver,
        t_end: float,
        n: int,
        max_cutbacks: int = 6,
        output_times=(),
        uzawa_max: int | None = None,
        on_step: Callable | None = None,
        predictor: bool = True,
    ):
        if isinstance(problem, NewtonSolver) or not callable(getattr(newton, "solve", None)):
            raise TypeError(
                "LoadStepper(problem, newton, t_end, n, ...): newton must be a NewtonSolver, "
                f"got {type(newton).__name__} (the problem comes first)"
            )
        # the scene's rules for [steps] (one definition): t_end = -1 ran backwards, n = 0
        # returned no step, n = -3 was numpy's error, max_cutbacks = -1 was taken
        steps = steps_numbers("LoadStepper", t_end, n, max_cutbacks, output_times)
        if uzawa_max is not None:
            uzawa_max = count_at_least(uzawa_max, "LoadStepper.uzawa_max", 1)
        self.problem = problem
        self.newton = newton
        self.t_end = steps.t_end
        self.targets = step_targets(steps.t_end, steps.n, steps.output_times)
        self.max_cutbacks = steps.max_cutbacks
        if uzawa_max is None:
            # the terms' own bound: a default of 1 round stopped every step of a patch test
            # built through the Python API ("did not converge in 1 rounds")
            uzawa_max = default_uzawa_max(problem)
        self.uzawa_max = uzawa_max
        self.on_step = on_step
        self.predictor = predictor
        self.results: list[StepResult] = []

    def run(self) -> list[StepResult]:
        """Walk the load path from t = 0, starting from the problem's current ``u``, to
        ``t_end`` (collective: every rank calls it, and ``on_step`` runs on every rank).

        Returns :attr:`results` (the list it appends to): one :class:`StepResult` per
        converged step, in order of t. The times are the targets (the ``n`` equal steps
        and ``output_times``) and the midpoints that cutbacks inserted before them, each
        a converged step of its own. A result's ``cutbacks`` counts the halvings made
        since the previous converged step (those that led to it); its ``uzawa_rounds``,
        iterations and norms are those of its accepted attempt; its timings and solve
        counters include its failed attempts.

        Cutbacks: an attempt that raises ConvergenceError is first retried at the same
        size where the class docstring says so (carried stick/slip states once, after a
        FrozenStatesError; from the last converged state, after a failure from the
        extrapolated predictor); otherwise the step is halved (its midpoint becomes the
        next target) at most ``max_cutbacks`` times in a row. The halvings count again
        from 0 after each converged step.

        Raises ConvergenceError (the last attempt's as its cause, the message ending with
        the problem's hints: open pairs, points at a master edge; or, where the last
        attempt's state had inverted elements, a clause saying so instead) where another halving
        would exceed ``max_cutbacks`` in a row, make the step shorter than
        2^-max_cutbacks of the load step it divides, or shorter than
        :data:`MIN_STEP_FRACTION` × ``t_end``. The problem is then back at the last
        converged step: its ``u`` and time, and the contact multipliers of its commit
        (``problem.restore_step``), with no stick/slip states carried; every converged
        step has been passed to ``on_step``. It raises ConvergenceError at once, with
        no cutback, where the first step converged with slave nodes that started inside
        the master's body beyond the pairing's reach still unpaired
        (``problem.unseen_overlaps``), the problem back at t = 0 as above. Other
        exceptions (a PETSc error, or what
        ``on_step`` raises, e.g. an OutputError) propagate at once, the problem left as
        it was then.
        """
        p = self.problem
        t = 0.0
        step = 0
        pending = list(self.targets)
        saved = p.u.x.array.copy()
        previous = None  # (u, t) of the step before the last converged one
        rates = []  # (t0, t1, ‖Δu‖/Δt) of the last two converged steps (_jumped)
        cutbacks = 0
        grid = set(self.targets)
        load_step = {}  # target of the grid -> the length of its load step (from t)
        use_predictor = True
        skip, backoff, predictor_failures = 0, 1, 0  # see PREDICTOR_MAX_BACKOFF
        carried_retries = 0  # see FROZEN_RETRY_ROUNDS
        resume = None  # RoundResume for the carried retry (solve_step)
        marks = {k: getattr(self.newton, k) for k in _SOLVE_COUNTERS}
        wall0 = None
        while pending:
            t_new = pending[0]
            if t_new in grid:
                load_step.setdefault(t_new, t_new - t)
            if wall0 is None:  # the first attempt of this step
                wall0 = perf_counter()
                tim0 = dict(p.timings)
                ls0 = self.newton.timings["linear_solve"]
            predictable = (
                self.predictor
                and previous is not None
                and t > previous[1]
                and not _path_bends(p, previous[1], t, t_new)
                and not _jumped(p, rates)
            )
            predicted = predictable and use_predictor and skip == 0
            if predicted:
                # linear extrapolation of the last increment: u = u_n + (Δt/Δt_n)(u_n − u_{n−1})
                u_prev, t_prev = previous
                p.u.x.array[:] = saved + (t_new - t) / (t - t_prev) * (saved - u_prev)
            p.set_time(t_new)
            p.begin_step()
            if resume is not None:
                p.resume_round(resume.state)
            try:
                its, norms, info = solve_step(
                    p,
                    self.newton,
                    self.uzawa_max,
                    dtol=PREDICTOR_DIVERGENCE_TOLERANCE if predicted else None,
                    resume=resume,
                )
            except ConvergenceError as exc:
                # read before u goes back: the stop hints need it (collective)
                inverted = _failed_inversion(p, exc)
                p.u.x.array[:] = saved
                p.set_time(t)
                p.restore_step()
                # wrong frozen states with free ones: the same step again, the stick/slip
                # states carried between rounds (once; then as any other failure), from
                # the state after the failed attempt's first round (its solve is free in
                # either attempt)
                retry = isinstance(exc, FrozenStatesError) and not p.carrying_states
                p.carry_states(retry)
                resume = exc.resume if retry else None
                if retry:
                    log.warning(
                        "step to t = %g failed (%s); retrying with the stick/slip states "
                        "carried between Uzawa rounds",
                        t_new,
                        exc,
                    )
                    carried_retries += 1
                    continue
                if predicted:
                    # an extrapolated start can be far off (e.g. deep penetration with
                    # friction): retry the same step from the last converged state first
                    log.warning(
                        "step to t = %g failed from the predictor (%s); retrying", t_new, exc
                    )
                    use_predictor = False
                    predictor_failures += 1
                    skip, backoff = backoff, min(2 * backoff, PREDICTOR_MAX_BACKOFF)
                    continue
                # the run stops below: restore_step leaves the failed attempt's contact
                # state (p_hat), which the hint reads (collective, every rank here)
                if cutbacks >= self.max_cutbacks:
                    raise ConvergenceError(
                        f"step to t = {t_new:g} failed after {cutbacks} cutbacks: "
                        f"{exc}{_stop_hints(p, inverted, exc)}"
                    ) from exc
                mid = 0.5 * (t + t_new)
                step_of = load_step[next(s for s in pending if s in grid)]
                if mid - t < math.ldexp(step_of, -self.max_cutbacks) * (1 - 1e-9):
                    # a shorter step than max_cutbacks halvings of the load step: where the
                    # solver reaches no solution beyond some t before the target, every
                    # cutback converged a shorter step towards it and the target failed
                    # again, a run that crept towards it down to MIN_STEP_FRACTION
                    raise ConvergenceError(
                        f"step to t = {t_new:g} failed after {cutbacks} cutbacks from t = "
                        f"{t:g}, and another would make the step shorter than "
                        f"1/2^{self.max_cutbacks} of the load step ({step_of:.3g}; "
                        f"max_cutbacks = {self.max_cutbacks}): {exc}{_stop_hints(p, inverted, exc)}"
                    ) from exc
                cutbacks += 1
                if mid - t <= MIN_STEP_FRACTION * self.t_end:
                    # repeated cutbacks over several steps can shrink the step without bound
                    raise ConvergenceError(
                        f"step to t = {t_new:g} failed and the step size {t_new - t:.3g} "
                        f"cannot be halved further (minimum {MIN_STEP_FRACTION:g} t_end): "
                        f"{exc}{_stop_hints(p, inverted, exc)}"
                    ) from exc
                pending.insert(0, mid)
                log.warning(
                    "step to t = %g failed (%s); cutting back to t = %g", t_new, exc, pending[0]
                )
                continue
            # the first converged step: an initial overlap beyond the pairing's reach that
            # is still unseen makes the converged state no equilibrium, and no cutback helps
            # (the overlap does not depend on t); the terms answer once (then None)
            unseen = p.unseen_overlaps() if hasattr(p, "unseen_overlaps") else None
            if unseen is not None:
                p.u.x.array[:] = saved
                p.set_time(t)
                p.restore_step()
                raise ConvergenceError(f"step to t = {t_new:g} converged, but {unseen}")
            pending.pop(0)
            p.carry_states(False)
            resume = None
            if predicted:
                backoff = 1
            elif predictable and use_predictor and skip > 0:
                skip -= 1
            use_predictor = True
            p.commit_step()
            step += 1
            previous = (saved, t)
            rates = [*rates[-1:], (t, t_new, p.increment_norm(saved) / (t_new - t))]
            t = t_new
            saved = p.u.x.array.copy()
            timings = {k: p.timings[k] - tim0[k] for k in p.timings}
            timings["linear_solve"] = self.newton.timings["linear_solve"] - ls0
            timings["total"] = perf_counter() - wall0
            res = StepResult(t, its, norms, len(info), cutbacks, timings["total"], timings, info)
            for k in _SOLVE_COUNTERS:  # the solves of this step (failed attempts included)
                setattr(res, k, getattr(self.newton, k) - marks[k])
                marks[k] = getattr(self.newton, k)
            res.predictor_failures, predictor_failures = predictor_failures, 0
            res.carried_retries, carried_retries = carried_retries, 0
            self.results.append(res)
            cutbacks = 0
            wall0 = None
            if self.on_step is not None:
                self.on_step(step, res)
        return self.results
