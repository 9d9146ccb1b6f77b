"""The Uzawa rounds of a contact pair: the multiplier updates between Newton solves.

METHOD.md §5: after a converged Newton solve at fixed multipliers, each pair updates its
normal (and, with friction, tangential) multipliers towards the nodal law at the
converged state,

    λ^I ← ⟨λ^I − ε^I γ^I⟩ = p̂^I,   λ_T^I ← τ̂^I,

until max_I |p̂^I − λ^I| ≤ uzawa_tol · max_I p̂^I (``uzawa_tol = 0``: pure penalty, no
rounds), a pressed node's change counted max(ε_auto^I/ε^I, 1) times (a stuck node's
tangential one max(ε_T,auto^I/ε_T^I, 1) times: :meth:`UzawaRounds._softness`), so that a
penalty softer than its auto rule stops at the auto rule's penetration. The update is plain, accelerated on the stacked vector [λ, λ_T]
(:class:`UzawaAcceleration`: Aitken or Anderson) or exact (Newton on the rounds'
fixed-point map, :meth:`UzawaRounds._exact_multipliers` and
:meth:`UzawaRounds._exact_multipliers_fd`, one back-substitution with the solver's last
factorization per GMRES product); :func:`resolve_acceleration` picks it per pair. An
exact update in a step whose rounds 2-cycle takes half its step (:func:`_two_cycle`,
:data:`CYCLE_DAMPING`).

:class:`UzawaRounds` holds these methods of :class:`~dolfinx_mortar.contact.MortarContact`
(its base class: it reads the pair's nodal state, p̂, λ, γ, the stick/slip states, and
is not meant to be used on its own). The load-stepping driver calls them through
:meth:`~dolfinx_mortar.problem.ContactProblem.uzawa_update`
(:mod:`dolfinx_mortar.solver`). docs/method-notes.md has the measurements behind the
rules and constants here.
"""

from __future__ import annotations

import copy
import logging
import math

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from . import friction as fr
from .kernels import mortar as kmortar
from .scene import UZAWA_ACCELERATIONS, exact_update_default

log = logging.getLogger(__name__)

#: Upper bound of the Aitken relaxation of the Uzawa update (``uzawa_acceleration = "aitken"``).
OMEGA_MAX = 10.0
#: Anderson acceleration of the Uzawa update: number of previous rounds in the history.
ANDERSON_DEPTH = 5
#: Uzawa update schemes (scene key ``uzawa_acceleration``; the first, "auto", is the
#: default and resolves per pair, :func:`resolve_acceleration`).
ACCELERATIONS = UZAWA_ACCELERATIONS
#: The exact multiplier update (``uzawa_acceleration = "newton"``,
#: :meth:`UzawaRounds._exact_multipliers`): relative tolerance and iteration bound of
#: its GMRES on the scaled Schur complement (about the identity: a handful of products).
EXACT_UPDATE_RTOL = 1e-10
EXACT_UPDATE_MAX_IT = 30
#: The frictional exact update (:meth:`UzawaRounds._exact_multipliers_fd`): GMRES
#: relative tolerance and iteration bound, and the forward-difference step of its
#: products, relative to the larger of max |λ| and max p̂ over the pair. A product's
#: relative error is about this step (round-off of the nodal law is ~1e-16 of it), so
#: GMRES is not asked for more than 1e-6: 1e-9 gave the same rounds on peers problem B
#: level 3 with 50 % more products.
EXACT_FD_RTOL = 1e-6
EXACT_FD_MAX_IT = 40
#: Forcing of the exact updates (inexact Newton on the rounds' map): GMRES's relative
#: tolerance is loosened to EXACT_FORCING × uzawa_tol / c, where c is the round's
#: relative multiplier change (the right-hand side's size in units of max p̂), so that
#: the error the update leaves is about a tenth of the Uzawa tolerance; never tighter
#: than EXACT_UPDATE_RTOL / EXACT_FD_RTOL, never looser than EXACT_FORCING (0: the
#: fixed tolerances). The round after the last update only checks convergence, and with
#: the fixed tolerances it measured 1e-4 to 1e-2 of the Uzawa tolerance (peers problem A
#: level 2: a change of 8.3e-8 updated by 6 products to 2.3e-13, uzawa_tol = 1e-8).
EXACT_FORCING = 0.1
EXACT_FD_STEP = 1e-7
#: The floor of the finite-difference exact update's step (frictional pairs, mixed normal
#: recoveries): a product changes the multipliers by at least this many times the
#: round-off of the nodal law, ε · eps · max|x_s| (the largest penalty, ε_N or ε_T, times
#: the rounding of a gap computed from the slave coordinates x_s = (X − o) + u,
#: :func:`~dolfinx_mortar.surface.pair_origin`), so that the law's rounding stays below
#: 1/EXACT_FD_ROUND_OFF of the differences it enters
#: (:meth:`UzawaRounds._exact_multipliers_fd`).
#: The probe's frictional patch 1e4 from the origin without the pair's origin (steps of
#: 0.7 to 1.6 times the law's round-off) took 7 rounds a step with 10, 4 with 1e2 or 3e2,
#: 4, 3, 3, 3 with 1e3 and 3, 3, 3, 3 with 1e4 (unshifted: 3, 3, 3, 2); near the origin the
#: steps are 1.5e3 (the hard-case sweep's cattaneo2d_reversal) to 1.4e5 times the law's
#: round-off, so 1e3 leaves them alone.
EXACT_FD_ROUND_OFF = 1e3
#: The exact updates' displacement δu is unusable, and the plain update is taken, where
#: it is not finite or its largest component exceeds this many search margins (2 × the
#: largest slave facet; :meth:`UzawaRounds._exact_outcome`). It closes the penetration
#: that the penalty allows, a small fraction of a facet with the auto penalty.
EXACT_DU_MAX = 1.0
#: A pair whose largest nodal pressure p̂ over the Uzawa round is at most this many times
#: the nodal law's round-off, ε · eps · max|x_s| (:meth:`UzawaRounds._law_round_off`),
#: carries no load the law can resolve: the round counts as converged as where max p̂ = 0
#: (:meth:`UzawaRounds.uzawa_update`, :meth:`UzawaRounds._clear_unloaded`). Such a p̂
#: is the penalty times a gap of 1e3 units of round-off of the slave coordinates
#: (2e-13 × max|x_s|): a contact that closes or opens exactly at a step's end, whose
#: relative multiplier change, measured against that p̂, was round-off over round-off
#: (1, 0.5, 2.2, 0.72 …) and never met the tolerance. Measured at such steps: max p̂ =
#: 6e-14 at the touch and 4.4e-11 at the release (0.8 × the round-off) of a 2D patch;
#: the pressures of a loaded contact are many orders above (the same patch: 1.27, 1e10
#: times the floor).
UNLOADED_ROUND_OFF = 1e3
#: A step whose exact updates 2-cycle: where the relative multiplier changes c of the
#: last four rounds repeat two rounds apart, |c_n − c_{n−2}| ≤ CYCLE_TOL c_n and
#: |c_{n−1} − c_{n−3}| ≤ CYCLE_TOL c_{n−1}, the round's exact update is damped,
#: λ ← λ + CYCLE_DAMPING (λ_exact − λ) (λ_T and δu alike; :func:`_two_cycle`). Newton on
#: the rounds' map overshoots across a change of the active set and lands where the next
#: update overshoots back: `block3d_over_corner` (a 3D block dragged in one step until it
#: hangs over the master's corner, finite strain, segment integration) cycled with
#: changes 0.27, 0.082, 0.27, 0.082, … at t = 2 from every start, until the stall rule
#: cut the step back, 6 times (8 steps). One half step breaks the cycle (0.082, then
#: 0.13, 7e-4, converged): the step from t = 1 takes 10 rounds, no cutback (session 63;
#: docs/method-notes.md, "A 2-cycle of the exact updates").
CYCLE_TOL = 0.05
CYCLE_DAMPING = 0.5
#: Element integration: a slave node whose paired weight A^I is below this fraction of its
#: full weight ∫Φ_I dA₀ (its whole slave support paired) is a sliver node
#: (:meth:`UzawaRounds.sliver_nodes`): it takes no augmentation (λ^I = 0, pure penalty)
#: and its multiplier change does not count in the Uzawa stopping test. At the master's
#: edge such a node's A^I comes from one or two Gauss points with Φ_I ≈ 0.005–0.03, and
#: jumps by a factor 10 as a point slides on or off the master; λ^I is a pressure per
#: unit paired area, so the force A^I⟨λ^I − ε g^I⟩ jumped with it and the rounds
#: 2-cycled (patch2d soft slide: paired fraction 0.24 ↔ 0.024, the exact update's λ^I
#: 21 → 451 → 15, multiplier changes 0.43 ↔ 6.9) or left Newton a residual 10 × that of
#: the other rounds (patch3d diagonal slide). 0.25 puts both of these slivers on the
#: penalty side; docs/method-notes.md, "Sliver nodes".
SLIVER_FRACTION = 0.25
#: Segment integration: the same rule below this fraction (session 55). Its A^I is exact
#: and continuous in the slide, but a master edge that lies on a line of slave facet edges
#: (structured meshes: demo_friction_patch 3D deformable, the master's edges y = 0, L on
#: the slave's node rows) pairs the nodes beyond that line over a strip of round-off or
#: discretization-error width, 1e-11 to 1e-6 of their full weight: their λ^I moved by
#: O(1) per round without converging (plain Uzawa contracts there by about 1 − 5 A^I/full
#: with the auto penalty) and the exact update's GMRES stalled at 2e-3 on them, so every
#: sliding step stalled and was cut back. The nodes that a master end sweeps onto are
#: paired over 2e-3 and more of their weight after a step's slide (the same demo, 4
#: steps), which the exact update converges: 1e-3 leaves those augmented
#: (docs/method-notes.md, "Sliver nodes").
SEGMENT_SLIVER_FRACTION = 1e-3
#: A frozen slip direction (the chattering control, contact.FREEZE_AFTER) counts as
#: moved, and the solve as not accepted, where the free law's direction differs from it
#: by more than this (:meth:`UzawaRounds.uzawa_update`).
FROZEN_DIRECTION_TOL = 1e-6
#: A point pinned for switching back (A → B → A) whose converged projection onto its
#: pinned facet lies inside it or at most this far outside (reference coordinates) starts
#: the next Newton solve of the same load step pinned: it sits on the facet's edge and
#: would switch back and forth again. In the twist3d demo's last-but-one step one such
#: point cycled in each of the five Uzawa rounds until its pin at the contact.FREEZE_AFTER-th
#: Jacobian: 4 + 9 + 9 + 9 + 9 + 11 Newton iterations. A point pinned by contact.HOLD_AFTER
#: starts the next solve pinned only where it converged beyond its facet's edge (at most
#: this far outside): it sits on a master vertex that the free pairing crosses back and
#: forth; hertz2d with 128 load steps crawled there for 13 + 15 + 0 Newton iterations
#: (13 + 1 so).
PIN_CARRY_TOL = 1e-3


def resolve_acceleration(
    method: str,
    friction: float,
    recovery: str,
    tangential_recovery: str = "lumped",
) -> str:
    """The Uzawa update of a pair: ``method`` itself, except that "auto" (the default)
    becomes "newton" (the exact update: :meth:`UzawaRounds._exact_multipliers` without
    friction, :meth:`UzawaRounds._exact_multipliers_fd` with it) on a pair with the
    lumped recovery and, with friction, the lumped tangential recovery
    (:func:`~dolfinx_mortar.scene.exact_update_default`); "aitken" on any other, in 2D
    and 3D alike (local). The unconstrained and constrained normal recoveries take
    "newton" on request (the finite-difference update; session 47: docs/method-notes.md,
    "The exact update with the mixed normal recoveries"); with "auto" such a pair (the
    tangential recovery lumped where it has friction: ``scene.exact_update_applies``)
    starts each step with Aitken and switches to the exact update for the rest of the
    step when its rounds are predicted to take too many (sessions 52–53:
    :data:`AUTO_EXACT_BOUND`, ``MortarContact._auto_exact``; the pair reports "aitken").

    Why "newton" by default there: the single serial runs of BENCHMARKS.md §3, §8 and §10
    (sessions 16 and 17): peers problem A 7 / 8 / 9 Newton iterations instead of 11 / 12
    / 13, the hard-case sweep's Hertz cases 24–49 instead of 49–534 with no cutback,
    peers problem B 7 + 4 / 8 + 6 / 9 + 10 (normal + tangential step) instead of 11 + 17
    / 12 + 25 / 13 + 24. With friction in 3D "auto" was Aitken until session 41 (the
    finite-difference products cost a 3D contact search each: the coarse twist3d path
    took 97 s against 71 s in session 17, 48 s against 45 s after session 22's cheaper
    search), switching to the exact update in a step whose rounds contracted slowly.
    Session 41 measured the exact update ahead there (BENCHMARKS §42): ironing3d 262
    Newton iterations and 29.5–31.3 s against 346 and 32.3–33.0 s, a 3D block slid back
    and forth with μ = 2 28 s against 54 s and no cutback against one (every Aitken step
    took 15–19 rounds), the 3D frictional stick patch 5 + 5 iterations against 13 + 13."""
    if method != "auto":
        return method
    if not exact_update_default(friction, recovery, tangential_recovery):
        return "aitken"
    return "newton"


#: "auto" on a pair where the exact update applies but is not the default (the
#: unconstrained and constrained normal recoveries: :func:`~dolfinx_mortar.scene.
#: exact_update_default`) is Aitken, but a step whose Aitken rounds are predicted to take
#: too many switches to the exact update for the rest of the step (attempt): after at
#: least AUTO_EXACT_ROUNDS rounds, with r the change's mean contraction per round over the
#: last AUTO_EXACT_WINDOW rounds, the rounds still needed to reach uzawa_tol are
#: log(uzawa_tol/change)/log(r) (any if r ≥ 1); the switch comes when the rounds so far
#: plus those exceed AUTO_EXACT_BOUND. Session 52 had session 39's rule here (4 rounds, a
#: change above 0.8³ times that of 3 rounds before): a coarse tetrahedral 3D press with
#: μ = 0.3 and the constrained recovery, which Aitken could not finish, switched in rounds
#: 10 and 9 (12 + 11 rounds a press step), but Q1 hexahedra, whose Aitken rounds
#: contract by about 0.5 each, never switched and took 13 + 13 against the exact
#: update's 5 + 5 (session 53, BENCHMARKS §64). Why 10: the exact update takes about 3
#: rounds after the switch, each about 1.7 times an Aitken round's cost, so switching
#: in round 5 costs about 10 Aitken rounds; measured, the press steps predict 11.8–29.8
#: rounds in round 5 (and take 13–34 with Aitken alone), and now 7 or 8 (BENCHMARKS §64).
#: 5 rounds at least: a step that ends in its 5th round never switches, as hertz2d's
#: first constrained step (changes 1, 2.3e-3, 8.6e-2, 2.6e-2, converged in round 5;
#: 12.4 predicted in round 4) and every round of the patch tests, the 2D demos and the
#: quick hard-case sweep with the mixed recoveries (2–5 rounds a step) (docs/
#: method-notes.md, "The exact update with the mixed normal recoveries").
AUTO_EXACT_ROUNDS = 5
AUTO_EXACT_WINDOW = 3
AUTO_EXACT_BOUND = 10


def _slow_rounds(changes: list[float], tol: float) -> bool:
    """Whether the Aitken rounds of a step are predicted to take more than
    AUTO_EXACT_BOUND rounds (AUTO_EXACT_ROUNDS, AUTO_EXACT_WINDOW): with n = len(changes)
    ≥ AUTO_EXACT_ROUNDS, c_k the change of round k (``changes``, the largest relative
    multiplier change, normal or tangential, of each round so far, each above ``tol``;
    dimensionless) and w = AUTO_EXACT_WINDOW, the mean contraction r = (c_n/c_{n−w})^(1/w),
    slow when r ≥ 1 or n + log(tol/c_n)/log(r) > AUTO_EXACT_BOUND. ``tol`` the Uzawa
    tolerance (> 0). Local; the changes are global, so the answer is the same on every
    rank."""
    n, w = len(changes), AUTO_EXACT_WINDOW
    if n < max(AUTO_EXACT_ROUNDS, w + 1) or changes[-1] <= tol:
        return False
    ratio = changes[-1] / changes[-1 - w]  # r^w
    if not ratio < 1.0:
        return True
    return n + w * math.log(tol / changes[-1]) / math.log(ratio) > AUTO_EXACT_BOUND


def _two_cycle(changes: list[float]) -> bool:
    """Whether the last four relative multiplier changes of a step's rounds (``changes``,
    dimensionless, one per round) repeat two rounds apart within :data:`CYCLE_TOL`: the
    rounds 2-cycle (local; the changes are global, so the answer is the same on every
    rank)."""
    if len(changes) < 4:
        return False
    c = changes[-4:]
    return abs(c[3] - c[1]) <= CYCLE_TOL * c[3] and abs(c[2] - c[0]) <= CYCLE_TOL * c[2]


def _gmres(
    comm,
    size: tuple[int, int],
    product,
    rhs: np.ndarray,
    rtol: float,
    max_it: int,
    configure=None,
):
    """Solve A x = rhs by unpreconditioned GMRES from x = 0, A given by its product
    ``product(x, y)`` (y ← A x on PETSc vectors of layout ``size`` = (owned, global);
    collective; the exact multiplier updates). ``configure(ksp)``, where given, is called
    after these settings: the problem's ``configure_uzawa_ksp``, which sets the options
    prefix ``<solver prefix>uzawa_newton_`` and the options given under it. The shell
    matrix, KSP and vectors are created and destroyed here. rhs: (owned,).
    Returns (converged, iterations, x (owned,))."""

    class _Shell:
        def mult(self_, mat, x, y):  # noqa: N805 (petsc4py shell context)
            product(x, y)

    A = PETSc.Mat().createPython((size, size), _Shell(), comm=comm)
    A.setUp()
    ksp = PETSc.KSP().create(comm)
    b = PETSc.Vec().createMPI(size, comm=comm)
    x = b.duplicate()
    try:
        ksp.setOperators(A)
        ksp.setType(PETSc.KSP.Type.GMRES)
        ksp.getPC().setType(PETSc.PC.Type.NONE)
        ksp.setTolerances(rtol=rtol, atol=0.0, max_it=max_it)
        if configure is not None:
            configure(ksp)
        b.array[:] = rhs
        x.set(0.0)
        ksp.solve(b, x)
        return (
            ksp.getConvergedReason() > 0,
            ksp.getIterationNumber(),
            x.getArray(readonly=True).copy(),
        )
    finally:
        for obj in (ksp, A, b, x):
            obj.destroy()


class UzawaAcceleration:
    """The accelerated update x ← x + f of the Uzawa rounds of one contact pair (collective).

    x, f: (n,) local parts of a distributed vector (the stacked multipliers [λ, λ_T] of
    the rank's slave nodes and their plain Uzawa change, stress units). ``method``:

    - "none": plain Uzawa, x + f (also "newton", whose exact update
      ``UzawaRounds._exact_multipliers`` replaces this class's step);
    - "aitken": x + ω f with the Irons–Tuck factor
      ω_k = −ω_{k−1} f_{k−1}·(f_k − f_{k−1}) / |f_k − f_{k−1}|², clamped to [1, OMEGA_MAX];
    - "anderson" (type II, depth m = ANDERSON_DEPTH): with the differences
      ΔX = [x_{i+1} − x_i] and ΔF = [f_{i+1} − f_i] of the last m rounds,
      θ = argmin |f − ΔF θ| and x + f − (ΔX + ΔF) θ. At fixed active and stick/slip sets
      a round x ↦ x + f is affine, and Anderson is then GMRES on its fixed-point
      equation: it damps every slow mode, not just the slowest one. The history restarts
      when a nodal state changes (the map changes) and when |f| grows.
    """

    def __init__(self, comm, method: str = "aitken", depth: int = ANDERSON_DEPTH):
        if method not in ACCELERATIONS or method == "auto":
            raise ValueError(
                f"unknown Uzawa acceleration {method!r}: one of {ACCELERATIONS[1:]} "
                '("auto" is resolved per pair: resolve_acceleration)'
            )
        self.comm, self.method, self.depth = comm, method, depth
        self.reset()

    def reset(self) -> None:
        """Forget the history (a new load step, or a step restored after a cutback)."""
        self._f_prev, self._omega = None, 1.0
        self._hist = None

    def step(self, x: np.ndarray, f: np.ndarray, states: np.ndarray, info: dict) -> np.ndarray:
        """The next x from the current x and its plain change f (collective).

        ``states``: the local nodal states that define the map (any array; a change on
        any rank restarts the Anderson history). ``info`` receives "relaxation" (Aitken)
        or "anderson_depth" (the number of history columns used)."""
        comm = self.comm
        if self.method in ("none", "newton"):  # "newton": UzawaRounds._exact_multipliers
            return x + f
        if self.method == "aitken":
            omega = 1.0
            if self._f_prev is not None:
                df = f - self._f_prev
                num = comm.allreduce(float(self._f_prev @ df))
                den = comm.allreduce(float(df @ df))
                if den > 0.0:
                    omega = float(np.clip(-self._omega * num / den, 1.0, OMEGA_MAX))
            info["relaxation"] = omega
            self._f_prev, self._omega = f, omega
            return x + omega * f
        norm_f = np.sqrt(comm.allreduce(float(f @ f)))
        h = self._hist
        restart = h is None or norm_f > h["norm_f"] or not np.array_equal(states, h["states"])
        restart = bool(comm.allreduce(int(restart), op=MPI.MAX))
        dX, dF = ([], []) if restart else (h["dX"], h["dF"])
        if not restart:
            dX.append(x - h["x"])
            dF.append(f - h["f"])
            del dX[: -self.depth], dF[: -self.depth]
        self._hist = {"x": x, "f": f, "states": states, "norm_f": norm_f, "dX": dX, "dF": dF}
        info["anderson_depth"] = len(dF)
        if not dF:
            return x + f
        F = np.column_stack(dF)
        gram = comm.allreduce(F.T @ F)
        theta = np.linalg.lstsq(gram, comm.allreduce(F.T @ f), rcond=1e-12)[0]
        return x + f - (np.column_stack(dX) + F) @ theta


class UzawaRounds:
    """The Uzawa rounds of :class:`~dolfinx_mortar.contact.MortarContact`, its base class
    (the attributes these methods read and set are the pair's: see that class). Entry
    points: :meth:`uzawa_update` after each converged Newton solve (collective),
    :meth:`round_state` / :meth:`resume_round` (the driver's retry of a round),
    :meth:`note_factorization` (the Newton solver's factorizations, which the exact
    updates reuse) and :meth:`sliver_nodes`."""

    def uzawa_update(self) -> tuple[bool, dict]:
        """Augment the multipliers unless converged (collective). Returns (converged, info).

        Plain Uzawa is λ ← p̂ (the nodal penalty pressure ⟨λ − εγ⟩, = p when lumped), i.e.
        λ ← λ + d with d = p̂ − λ; with friction also λ_T ← λ_T + (τ − λ_T). With
        ``uzawa_acceleration = "newton"`` (the default "auto" of the lumped pairs,
        :func:`resolve_acceleration`) the multipliers take the exact update instead
        (:meth:`_exact_multipliers`, :meth:`_exact_multipliers_fd`; the plain one after a
        solve whose frozen or held states the free law contradicts; half of it where the
        step's rounds 2-cycle, :func:`_two_cycle`); otherwise the step
        is accelerated on the stacked vector [λ, λ_T] (:class:`UzawaAcceleration`). λ is
        kept ≥ 0. With friction the change counts max |τ − λ_T| too,
        measured, as max |p̂ − λ|, against the largest p̂ of the pair, at pressed (stuck)
        nodes times their penalty's softness (:meth:`_softness`; summary.json
        ``soft_penalty_change`` where that makes it larger); a pair whose
        largest p̂ is at most :data:`UNLOADED_ROUND_OFF` times the nodal law's round-off
        (0 included: a contact open, or touching exactly, at the step's end) counts as
        converged with λ ← max(p̂, 0), λ_T ← τ̂ (:meth:`_clear_unloaded`; summary.json
        ``unloaded``: that p̂ where it is not 0), and a solve that ended with frozen
        stick/slip states (chattering control) is not accepted when the free states
        differ: another solve follows with the states free.

        With ``carry_states`` (set by the load-stepping driver for the retry of a step that
        failed with :class:`~dolfinx_mortar.errors.FrozenStatesError`) the next solve
        instead starts with the states and slip directions of the free law at this
        converged state (before the multipliers move), frozen for the whole solve and
        re-checked at its convergence: the states then change between rounds only, as in
        a primal-dual active-set iteration (docs/method-notes.md, "Chattering control").
        """
        comm = self.comm
        carry = None
        sliver = self.sliver_nodes()
        # a sliver node's target is λ = 0 (pure penalty): its change is its λ, 0 once there
        d = np.where(sliver, -self.lmbda, self.p_hat - self.lmbda)
        pmax = comm.allreduce(self.p_hat.max(initial=0.0), op=MPI.MAX)
        # the relative changes are measured against the largest p̂ of the augmented nodes
        # (a sliver node's p̂ reached 6935 against 2–3 elsewhere)
        pmax_aug = comm.allreduce(np.where(sliver, 0.0, self.p_hat).max(initial=0.0), op=MPI.MAX)
        pref = pmax_aug if pmax_aug > 0 else pmax
        change = comm.allreduce(np.abs(d).max(initial=0.0), op=MPI.MAX)
        # the test's change: at a pressed node the one the auto penalty would make at the
        # same penetration (_softness; the same as the change for ε ≥ ε_auto)
        # (softness: reduced over the ranks at set-up, so every rank takes the same branch;
        # a pair at or above its auto rule, the default, needs neither array nor allreduce)
        change_test = change
        if self.softness > 1.0:
            soft = np.where(
                (self.p_hat > 0.0) & ~sliver, self._softness(self.eps, self.eps_auto), 1.0
            )
            change_test = comm.allreduce(np.abs(d * soft).max(initial=0.0), op=MPI.MAX)
        # a pair whose pressures are all at the law's round-off carries no load: its
        # relative change would be round-off over round-off (UNLOADED_ROUND_OFF)
        floor = UNLOADED_ROUND_OFF * self._law_round_off() if self.uzawa_tol > 0.0 else 0.0
        unloaded = pmax <= floor
        rel = change / pref if pref > 0 and not unloaded else 0.0
        rel_test = change_test / pref if pref > 0 and not unloaded else 0.0
        info = {"multiplier_change": rel, "max_penetration": self._max_penetration()}
        if unloaded and pmax > 0.0:
            info["unloaded"] = pmax
        n_sliver = comm.allreduce(int(np.count_nonzero(sliver)))
        if n_sliver:
            info["sliver_nodes"] = n_sliver
        rel_t, rel_t_test, changed = 0.0, 0.0, 0
        if self.frictional:
            # the update target: the nodal law's traction at the converged state. After a
            # solve with frozen states that is the law with the states free: a node frozen
            # in stick keeps τ = λ_T + ε_T γ however far outside the Coulomb cone, and
            # taking that as λ_T made the rounds diverge (peers problem B, level 3)
            tau_law, fstate = self.tau_law, self.fstate
            if self.frozen is not None:
                fstate, tau_law = self._recover_tangential(frozen=None)
                s_free = tau_law / np.maximum(np.linalg.norm(tau_law, axis=1), 1e-300)[:, None]
                # (a direction left free, NaN: tangential.FREE_SLIP_DIRECTIONS, never counts
                # as moved)
                moved = (self.fstate == fr.SLIP) & (
                    np.linalg.norm(s_free - self.frozen[1], axis=1) > FROZEN_DIRECTION_TOL
                )
                # a changed state counts where the free law's traction differs from the
                # frozen one by more than the Uzawa tolerance: elsewhere the converged
                # state also satisfies the free law to that tolerance (a node at the edge
                # of the Coulomb cone, where stick and slip give the same traction)
                dtau = np.linalg.norm(tau_law - self.tau_law, axis=1)
                off = dtau > (floor if unloaded else self.uzawa_tol * pmax)
                local = np.count_nonzero(((fstate != self.fstate) | moved) & off)
                changed = comm.allreduce(int(local))
                info["unfrozen_states"] = changed
                info["frozen_traction_error"] = (
                    comm.allreduce(float(dtau.max(initial=0.0)), op=MPI.MAX) / pmax
                    if pmax > 0
                    else 0.0
                )
                self.frozen = None
            # a sliver node's tangential target is pure penalty's too: the step's history
            # λ_T = τ_n (lmbda_t_committed)
            target = np.where(sliver[:, None], self.lmbda_t_committed, tau_law)
            dt = np.linalg.norm(target - self.lmbda_t, axis=1)
            # in stick the change is ε_T times the elastic slip: the test's at ε_T,auto
            dt_max = dt_test = comm.allreduce(dt.max(initial=0.0), op=MPI.MAX)
            if self.softness_t > 1.0:
                stick = (fstate == fr.STICK) & ~sliver
                soft_t = np.where(stick, self._softness(self.eps_t, self.eps_t_auto), 1.0)
                dt_test = comm.allreduce((dt * soft_t).max(initial=0.0), op=MPI.MAX)
            if pref > 0 and not unloaded:
                rel_t, rel_t_test = dt_max / pref, dt_test / pref
            info["tangential_change"] = rel_t
            norm = np.maximum(np.linalg.norm(tau_law, axis=1), 1e-300)
            carry = (fstate.copy(), tau_law / norm[:, None])
        # the pinned points of the solve that ended (chattering control of the pairing), and
        # how far outside their pinned facet they converged (reference coordinates)
        # A rank whose term has no pins (qp_pinned and qp_flip None: no slave facet, whose
        # chattering control never starts) takes part in the collectives with empty masks
        # of the pairing's shape: every array below is a boolean or index array of that
        # shape on every rank
        pinned = np.zeros(self.qp_m.shape, bool)
        if self.qp_pinned is not None:
            pinned = (self.qp_pinned >= 0) & (self.qp_m == self.qp_pinned)
        n_pinned = comm.allreduce(int(pinned.sum()))
        self._carried_pins = None
        if n_pinned:
            outside = np.array(
                [kmortar._outside(self.master.ftype, z) for z in self.qp_zeta[pinned]]
            )
            info["pinned_points"] = n_pinned
            info["pinned_outside"] = comm.allreduce(float(outside.max(initial=0.0)), op=MPI.MAX)
            # points that converged at their pinned facet's edge: those pinned for
            # switching back (inside the facet or just beyond its edge), and those pinned
            # by HOLD_AFTER just beyond its edge (PIN_CARRY_TOL)
            keep = np.zeros_like(pinned)
            if self.qp_pinned is not None:
                keep[pinned] = outside <= PIN_CARRY_TOL
                beyond = np.zeros_like(pinned)
                beyond[pinned] = outside > 0.0
                keep &= self.qp_flip | beyond
            if comm.allreduce(int(keep.any()), op=MPI.MAX):
                carried = np.full(keep.shape, -1, np.int64)
                carried[keep] = self.qp_pinned[keep] if self.qp_pinned is not None else -1
                self._carried_pins = carried
                info["carried_pins"] = comm.allreduce(int(keep.sum()))
        if self.qp_frozen is not None:
            frozen, self.qp_frozen = self.qp_frozen, None
            self._recover()
            changed += int(np.count_nonzero(frozen != self._recovered.free))
            info["unfrozen_qp_nodes"] = changed
        if self.held is not None:
            # held in contact, but in tension beyond the tolerance: the law opens it (held
            # is set at the same Jacobian on every rank, so the count is collective)
            wrong = (
                self.held
                & ~self.active
                & (self.p < -(floor if unloaded else self.uzawa_tol * pmax))
            )
            released = comm.allreduce(int(np.count_nonzero(wrong)))
            if released:
                info["released_nodes"] = released
                changed += released
        if max(rel_test, rel_t_test) > max(rel, rel_t):
            info["soft_penalty_change"] = max(rel_test, rel_t_test)
        rel, rel_t = rel_test, rel_t_test  # the test's changes from here on
        done = self.uzawa_tol == 0.0 or max(rel, rel_t) <= self.uzawa_tol
        # what the next solve starts with when the states are carried (begin_solve), kept
        # for round_state either way; the final full-tolerance solve after converged
        # rounds keeps free states
        self._carried = carry if changed or not done else None
        if done:
            self._clear_unloaded(unloaded, tau_law if self.frictional else None, info, True)
            return changed == 0, info
        self._round_changes.append(max(rel, rel_t))
        if self._auto_exact:
            if self.uzawa_acceleration.method == "aitken" and _slow_rounds(
                self._round_changes, self.uzawa_tol
            ):
                self.uzawa_acceleration.method = "newton"  # until the attempt ends
                info["acceleration_switch"] = "aitken -> newton (slow rounds)"
                log.info("%s: Aitken rounds predicted too many; the exact update", self.name)
        if self.uzawa_acceleration.method == "newton":  # exact_update_applies
            if changed:
                # the solve ended with frozen states, a frozen QP set or a held contact
                # set that the free law contradicts: the round's map at fixed states,
                # which the exact update linearises, is not the next round's. Plain
                # update (on the ironing2d short path's first press step the exact one
                # led to a 30-iteration solve that crawled on a kink; with the plain one
                # 22; hertz2d_nu049_p1's released nodes: the same iterations either way)
                info["exact_update"] = "plain (states changed)"
                lam = np.maximum(self.p_hat, 0.0)
                lam_t = tau_law.copy() if self.frictional else None
            else:
                if self.frictional or self.recovery != "lumped":
                    # the finite-difference update: friction, or the mixed normal
                    # recoveries (p̂ = ⟨λ − ε M⁻¹G⟩ and p from the recovery's own solve)
                    rtol = self._forcing(EXACT_FD_RTOL, max(rel, rel_t))
                    law_now = (fstate, tau_law) if self.frictional else (None, None)
                    lam, lam_t = self._exact_multipliers_fd(*law_now, info, rtol)
                else:
                    rtol = self._forcing(EXACT_UPDATE_RTOL, rel)
                    lam, lam_t = self._exact_multipliers(d, info, rtol), None
                if _two_cycle(self._round_changes):
                    # the exact updates 2-cycle: half the step (CYCLE_DAMPING)
                    lam = self.lmbda + CYCLE_DAMPING * (lam - self.lmbda)
                    if lam_t is not None:
                        lam_t = self.lmbda_t + CYCLE_DAMPING * (lam_t - self.lmbda_t)
                    if self.displacement_update is not None:
                        self.displacement_update = CYCLE_DAMPING * self.displacement_update
                    info["exact_update"] = info.get("exact_update", "") + ", damped (a 2-cycle)"
            self.lmbda = lam
            if lam_t is not None:
                self.lmbda_t = lam_t
            self._clear_unloaded(unloaded, None, info, False)
            return False, info
        # the stacked multipliers x = [λ, λ_T] and their change f = T(x) − x
        x = np.concatenate([self.lmbda, self.lmbda_t.ravel()]) if self.frictional else self.lmbda
        f = np.concatenate([d, (target - self.lmbda_t).ravel()]) if self.frictional else d
        states = (self.p_hat > 0.0) & ~sliver
        if self.frictional:
            states = np.concatenate([states, fstate > 0, fstate == fr.SLIP])
        x = self.uzawa_acceleration.step(x.copy(), f, states, info)
        n = self.lmbda.size
        self.lmbda = np.maximum(x[:n], 0.0)
        if self.frictional:
            self.lmbda_t = x[n:].reshape(self.lmbda_t.shape)
        self._clear_unloaded(unloaded, None, info, False)
        return False, info

    @staticmethod
    def _softness(eps: np.ndarray, eps_auto: np.ndarray) -> np.ndarray:
        """max(ε_auto^I/ε^I, 1) (n,), local: how many times softer than its auto rule a
        node's penalty is. A round moves a pressed node's multiplier by ε^I γ^I (a stuck
        node's tangential one by ε_T^I times its elastic slip), ε/ε_auto times what the
        auto penalty would at the same penetration; the relative change of a soft pair
        then passed uzawa_tol far from the solution (a QA pass of session 65: penalty =
        1e-6 E on a frictional patch stopped after 3 rounds with the bodies 29 % of the
        press into each other, the forces 19 % short and status "ok"). The rounds' test
        takes the change times this factor: the final state the same, whatever the
        penalty, as for penalties at or above the auto rule (factor 1)."""
        return np.maximum(eps_auto / np.maximum(eps, 1e-300), 1.0)

    def sliver_nodes(self) -> np.ndarray:
        """(n_nodes,) bool: the owned slave nodes of element or segment integration whose paired
        weight A^I at the last contact update is positive but below
        :data:`SLIVER_FRACTION` of their full weight ∫Φ_I dA₀ (``full_area``), with
        segment integration below :data:`SEGMENT_SLIVER_FRACTION` of it (local).
        Such a node takes no augmentation: its multiplier target is λ^I = 0 (pure
        penalty, p̂^I = ⟨−ε g^I⟩), it enters neither the exact update nor the scale of
        the relative multiplier change, and its penetration is still reported. All
        False for node integration and for pure penalty (``uzawa_tol = 0``)."""
        if self.full_area is None or self.uzawa_tol == 0.0:
            return np.zeros(self.lmbda.shape, bool)
        fraction = SEGMENT_SLIVER_FRACTION if self.integration == "segment" else SLIVER_FRACTION
        return self.has_area & (self.A < fraction * self.full_area)

    def _clear_unloaded(
        self, unloaded: bool, tau_law: np.ndarray | None, info: dict, converged: bool
    ) -> None:
        """The plain update λ ← p̂, λ_T ← τ̂ where it leaves the converged state as it is
        (local; ``unloaded`` is decided on the largest p̂ of the pair reduced over the
        ranks, so every rank takes the same branch). Not with ``uzawa_tol = 0`` (pure
        penalty: λ stays 0, λ_T is the history τ_n).

        - ``unloaded`` (max p̂ of the pair at most :data:`UNLOADED_ROUND_OFF` times the
          law's round-off, 0 included; the round counts as converged): every node takes
          λ ← max(p̂, 0) and, with friction, λ_T ← τ̂ (``tau_law``: the free law's traction,
          0 where nothing is pressed). With p̂ = ⟨λ − εγ⟩ = 0, λ ≤ εγ at every node with
          paired area, so p̂ stays 0 with λ = 0 and the state (the residual, the tangent)
          does not change: no solve follows; with p̂ at the round-off level it changes by
          that level (p̂ becomes ⟨2p̂ − λ⟩ ∈ [0, 2p̂]). Without it the multipliers of the
          last state in contact survived any number of open steps and pressed at
          re-contact (a ghost pressure p̂ = λ − εγ > 0 at γ > 0).
        - every round (``converged``: the round converged, no update; otherwise after the
          update): a node without paired area (a slave node beyond the master's edge;
          ``has_area``) takes λ = 0, λ_T = 0, its p̂ and τ̂ whatever its multipliers; such
          a node does not enter the residual, so its multipliers only mattered where
          it came back into contact. A sliver node (:meth:`sliver_nodes`) takes λ = 0
          and λ_T = τ_n (the step's history), pure penalty's. Elsewhere a converged
          round keeps its multipliers.

        Where a multiplier changed on a converged round, ``info["cleared_multipliers"]``
        gives the number of nodes (collective count) and the acceleration's history
        (:class:`UzawaAcceleration`) restarts: its last x is no longer the iterate."""
        if self.uzawa_tol == 0.0:
            return
        nodes = np.ones(self.lmbda.shape, bool) if unloaded else ~self.has_area
        sliver = self.sliver_nodes() & ~nodes
        nodes |= sliver
        stale = nodes & (self.lmbda != 0.0)
        if self.frictional:
            stale |= nodes & ~sliver & np.any(self.lmbda_t != 0.0, axis=1)
            stale |= sliver & np.any(self.lmbda_t != self.lmbda_t_committed, axis=1)
        if unloaded:  # a converged round (rel = 0)
            self.lmbda = np.maximum(self.p_hat, 0.0)
            if self.frictional:
                self.lmbda_t = tau_law.copy()
        else:
            self.lmbda = np.where(nodes, 0.0, self.lmbda)
            if self.frictional:
                self.lmbda_t = np.where(nodes[:, None], 0.0, self.lmbda_t)
        if self.frictional:
            self.lmbda_t = np.where(sliver[:, None], self.lmbda_t_committed, self.lmbda_t)
        if not converged:  # after an update: part of the round's change
            return
        cleared = self.comm.allreduce(int(np.count_nonzero(stale)))
        if cleared:
            info["cleared_multipliers"] = cleared
            self._reset_acceleration()

    def _forcing(self, rtol: float, change: float) -> float:
        """GMRES's relative tolerance for an exact update of a round whose relative
        multiplier change is ``change`` (> uzawa_tol): :data:`EXACT_FORCING` × uzawa_tol
        / change, at most EXACT_FORCING, and not below the fixed tolerance ``rtol``
        (which EXACT_FORCING = 0 restores) (local)."""
        return max(rtol, EXACT_FORCING * min(self.uzawa_tol / change, 1.0))

    def note_factorization(self) -> None:
        """The Newton solver factorizes the Jacobian just assembled (local): note its
        contact states, the nodes with a normal tangent (the lumped contact set, held
        nodes included) and the stick/slip states (:meth:`_current_factorization`)."""
        states = getattr(self, "fstate", None) if self.frictional else None
        self._factored_states = (
            self._normal_tangent_set(),
            None if states is None else states.copy(),
        )

    def _normal_tangent_set(self) -> np.ndarray:
        """The nodal states the normal tangent depends on (local): the nodes with a
        lumped tangent coefficient (kcoef > 0: the lumped contact set, held nodes
        included; the contact predictor's); with a mixed recovery also the nodes whose
        law pressure p̂ is positive and the QP's free set 𝒫 (constrained; ``has_area``
        when unconstrained; over all N nodes of the gathered system), stacked (2 n + N,)."""
        kc = np.asarray(self.kcoef) > 0.0
        if self.recovery == "lumped":
            return kc
        rec = self._recovered
        free = np.zeros_like(kc) if rec is None else np.asarray(rec.free, bool)
        return np.concatenate([kc, np.asarray(self.active, bool), free])

    def _current_factorization(self, fstate, info: dict) -> None:
        """Make the solver's last factorization (``problem.linear_inverse``) that of the
        Jacobian at the converged state where its contact states differ (collective;
        the exact updates). A round whose solve took one Newton iteration on a reused
        factorization (the rounds after an exact update) leaves the factorization of an
        earlier round, and where a stick/slip state or the contact set changed since,
        K⁻¹ is not the inverse of this state's Jacobian: du/dx of the update was off by
        up to 30 % and the rounds converged linearly (about 0.5 per round) instead of
        quadratically (docs/method-notes.md, "The exact update's factorization"). Then
        the Jacobian is assembled at u and factorized once more
        (``problem.factorize_jacobian``), with the per-solve chattering control and
        predictor state of every term as it was (the next solve starts afresh anyway).

        fstate: the converged stick/slip states (n,) the update linearises, or None
        (frictionless)."""
        refactor = getattr(self.problem, "factorize_jacobian", None)
        noted = self._factored_states
        if refactor is None or noted is None:
            return
        stale = not np.array_equal(noted[0], self._normal_tangent_set())
        if fstate is not None and noted[1] is not None:
            stale = stale or not np.array_equal(noted[1], fstate)
        if not self.comm.allreduce(bool(stale), op=MPI.LOR):
            return
        # every term's per-solve state, through the problem (ContactProblem.jacobian_watch)
        saved = self.problem.jacobian_watch()
        try:
            ok = refactor()
        finally:
            self.problem.restore_jacobian_watch(saved)
        info["refactorized"] = bool(ok)

    #: the per-solve state that a Jacobian changes (the chattering controls' counters,
    #: pins, holds and freezes, the contact predictor's track): kept across the extra
    #: Jacobian of :meth:`_current_factorization`
    _JACOBIAN_WATCH = (
        "held", "_set_jacobians", "qp_pinned", "qp_flip", "_pair_hist", "_pair_jacobians",
        "_pin_exchange", "_jac_active", "first_contact", "_predictor_track", "_jacobians",
        "qp_frozen", "frozen", "_slip_prev", "_reversed", "_dual_fixed",
    )  # fmt: skip

    def _jacobian_watch(self) -> dict:
        """Copies of :attr:`_JACOBIAN_WATCH` (local)."""
        return {k: copy.copy(getattr(self, k)) for k in self._JACOBIAN_WATCH if hasattr(self, k)}

    def _restore_jacobian_watch(self, watch: dict) -> None:
        """Put back a :meth:`_jacobian_watch` (local)."""
        for k, v in watch.items():
            setattr(self, k, v)

    def _exact_outcome(self, ok: bool, its: int, du, step, info: dict) -> bool:
        """Record how an exact update ended (collective; ``ok`` is the same on every
        rank): with GMRES converged after ``its`` products and a usable update, the
        displacement ``du`` (owned dofs, or None) becomes :attr:`displacement_update` and
        True is returned; otherwise False (the caller takes the plain update). The
        update is unusable where the multiplier change ``step`` (owned entries) or ``du``
        has a value that is not finite, or where some |δu| exceeds EXACT_DU_MAX search
        margins (:data:`EXACT_DU_MAX`): it is added to u before the next solve, and a
        round-off-ridden one had inverted the elements there."""
        if not ok:
            info["exact_update"] = "plain (GMRES failed)"
            return False
        size = np.array([0.0 if du is None else float(np.abs(du).max(initial=0.0)), 0.0])
        finite = np.all(np.isfinite(step)) and (du is None or np.all(np.isfinite(du)))
        size[1] = 0.0 if finite else 1.0
        self.comm.Allreduce(MPI.IN_PLACE, size, op=MPI.MAX)
        if size[1] > 0.0:
            info["exact_update"] = "plain (not finite)"
            return False
        if size[0] > EXACT_DU_MAX * self.margin:
            info["exact_update"] = f"plain (displacement {size[0]:.2g} > {EXACT_DU_MAX:g} margin)"
            return False
        info["exact_update"] = f"newton ({its} products)"
        self.displacement_update = du
        return True

    def _exact_multipliers(self, d: np.ndarray, info: dict, rtol: float) -> np.ndarray:
        """The exact (Newton) update of the multipliers of the active nodes (collective;
        ``uzawa_acceleration = "newton"``, frictionless lumped pairs).

        At the converged state of a round, R(u, λ) = 0, the active nodes A (p̂^I > 0)
        have p^I = λ^I − ε^I G^I/A^I, so ∂R/∂λ^J = −B^J (B^J = ∂G^J/∂u) and a change δλ
        moves u by K⁻¹ Bᵀ δλ (K: the Jacobian, its last factorization) and the weighted
        gaps by B K⁻¹ Bᵀ δλ. The update closes them, G_A + B_A K⁻¹ B_Aᵀ δλ = 0, solved
        by GMRES in the scaled form diag(ε/A) B_A K⁻¹ B_Aᵀ δλ = −ε γ_A = d_A (the plain
        Uzawa step; the operator is about the identity for a stiff penalty), one
        back-substitution per product. λ_A ← max(λ_A + δλ, 0); every other node takes
        the plain update λ ← p̂ = λ + d, and so does every node when the solver has no
        factorization to offer, GMRES fails or the update is unusable
        (:meth:`_exact_outcome`; ``info["exact_update"]`` says which).
        The displacement change this implies, δu = K⁻¹ Bᵀ δλ (one more back-substitution),
        is left in :attr:`displacement_update` for the problem to apply
        (:meth:`~dolfinx_mortar.problem.ContactProblem.uzawa_update`), so that the next
        round starts near its solution. Where the active set and the pairing stay, the
        rounds then stop after two or three instead of five or six. GMRES stops at the
        relative residual ``rtol`` (:meth:`_forcing` of :data:`EXACT_UPDATE_RTOL`).

        d: (n_nodes,) the plain change p̂ − λ of the owned nodes. Returns λ, (n_nodes,).
        """
        comm = self.comm
        self.displacement_update = None
        plain = np.maximum(self.lmbda + d, 0.0)
        solve = getattr(self.problem, "linear_inverse", None)
        act = self.active & self.has_area & ~self.sliver_nodes()
        nodes = np.flatnonzero(act)
        n_loc = int(nodes.size)
        n_glob = comm.allreduce(n_loc)
        if solve is None or n_glob == 0:
            info["exact_update"] = "plain (no factorization)" if n_glob else "plain"
            return plain
        self._current_factorization(None, info)
        first = comm.exscan(n_loc) or 0
        c_off, c_idx, c_val = self._b_rows(act.astype(float), self.slave.dofs, self.master.dofs)
        u = self.problem.u.vector
        lengths = np.maximum((c_off[1:] - c_off[:-1])[nodes], 1).astype(PETSc.IntType)
        B = PETSc.Mat().createAIJ(
            ((n_loc, n_glob), (u.getLocalSize(), u.getSize())), nnz=(lengths, lengths), comm=comm
        )
        B.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        for k, node in enumerate(nodes):
            lo, hi = c_off[node], c_off[node + 1]
            B.setValues([first + k], c_idx[lo:hi].astype(PETSc.IntType), c_val[lo:hi], addv=False)
        B.assemble()
        t = B.createVecRight()  # (ndofs,): Bᵀ δλ, then K⁻¹ Bᵀ δλ in w
        w = t.duplicate()
        dlam = B.createVecLeft()
        scale = (self.eps / np.where(self.has_area, self.A, 1.0))[nodes]
        failed = []

        def schur(x, y):  # y ← diag(ε/A) B K⁻¹ Bᵀ x
            B.multTranspose(x, t)
            if not solve(t, w):
                failed.append(True)
                w.set(0.0)
            B.mult(w, y)
            y.array[:] *= scale  # owned entries (not localForm: no ghosts here)

        du = None
        try:
            ok, its, step = _gmres(
                comm,
                (n_loc, n_glob),
                schur,
                d[nodes],
                rtol,
                EXACT_UPDATE_MAX_IT,
                getattr(self.problem, "configure_uzawa_ksp", None),
            )
            ok = ok and not comm.allreduce(bool(failed), op=MPI.LOR)
            if ok:  # the displacement the new multipliers move u by: δu = K⁻¹ Bᵀ δλ
                dlam.array[:] = step
                B.multTranspose(dlam, t)
                ok = solve(t, w)
                du = w.getArray(readonly=True).copy()
        finally:
            for obj in (B, t, w, dlam):
                obj.destroy()
        if not self._exact_outcome(ok, its, du, step, info):
            return plain
        out = plain.copy()
        out[nodes] = np.maximum(self.lmbda[nodes] + step, 0.0)
        return out

    def _law_round_off(self) -> float:
        """The round-off of the nodal law p̂ = ⟨λ − ε γ⟩ (and τ̂) at the current contact
        state, stress units (collective, the same on every rank): the largest penalty,
        normal or tangential, times eps · max|x_s|, the rounding of a gap computed from the
        slave coordinates x_s = (X − o) + u (:func:`~dolfinx_mortar.surface.pair_origin`)."""
        eps = [float(self.eps.max(initial=0.0))]
        if self.frictional:
            eps.append(float(self.eps_t.max(initial=0.0)))
        local = np.array([max(eps), float(np.abs(self.xs).max(initial=0.0))])
        self.comm.Allreduce(MPI.IN_PLACE, local, op=MPI.MAX)
        return float(local[0] * np.finfo(float).eps * local[1])

    def _exact_multipliers_fd(
        self, fstate: np.ndarray | None, tau_law: np.ndarray | None, info: dict, rtol: float
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The exact (Newton) update of the normal and tangential multipliers of a
        frictional pair, or of the normal ones of a pair with the unconstrained or
        constrained recovery (collective; ``uzawa_acceleration = "newton"``; with friction
        the lumped tangential recovery).

        A round is the fixed-point map x ↦ T(u(x), x) of the stacked multipliers
        x = [λ, λ_T] (n_nodes + n_nodes·(gdim − 1),), T = [p̂, τ̂] the nodal law at the
        solve's converged state, where R(u, x) = 0. The update is Newton on
        F(x) = T(u(x), x) − x:

            (∂T/∂x + ∂T/∂u · du/dx − I) δx = −F,   du/dx = −K⁻¹ ∂R/∂x,

        by GMRES to relative residual ``rtol`` (:meth:`_forcing` of :data:`EXACT_FD_RTOL`)
        with matrix-free products. Each product J v
        takes the contact residual at (u, x + h v) for ∂R/∂x v (forward difference, step
        h from :data:`EXACT_FD_STEP`, no shorter than :data:`EXACT_FD_ROUND_OFF` times
        the nodal law's round-off, :meth:`_law_round_off`; the bulk residual does not
        depend on x), one
        back-substitution w = K⁻¹ ∂R/∂x v with the last factorized Jacobian
        (``problem.linear_inverse``), and the nodal law at (u − h w, x + h v). The
        stick/slip states are those of the free law at the converged state, frozen for
        the differences, so that each is a smooth function; the slip directions follow
        the trial traction (in 3D s depends on λ_T: frozen directions made the update
        inexact there, 10 rounds per step on twist3d). Without
        friction the same equation is :meth:`_exact_multipliers`' diag(ε/A) B K⁻¹ Bᵀ δλ
        = d. Stick nodes get the λ_T that closes their slip, slip nodes μ p̂ s at the new
        state, and the displacement it implies, δu = −K⁻¹ ∂R/∂x δx, is left in
        :attr:`displacement_update`. λ ← max(λ + δλ, 0).

        The mixed normal recoveries (session 47) enter through the recovery's own
        evaluation in each difference: p̂ = ⟨λ − ε γ⟩ with γ = M⁻¹G, and the residual's
        p = M⁻¹F (unconstrained) or the QP's (constrained, F = A p̂), so ∂R/∂λ =
        −Bᵀ W diag(A H) with W = M⁻¹ or M_𝒫𝒫⁻¹ on the QP's free set 𝒫. The map is
        smooth only at a fixed free set, so the constrained recovery keeps the converged
        round's 𝒫 during the differences (``qp_frozen``; a kept node leaves it only
        where its law is open and its p < 0, :func:`.recovery.recover`). Without friction
        x = λ and T = p̂.

        Where no factorization exists, GMRES fails or the update is unusable (not
        finite, or δu beyond :data:`EXACT_DU_MAX` search margins: :meth:`_exact_outcome`),
        the update is the plain one (λ ← p̂, λ_T ← τ̂) and ``info["exact_update"]`` says so.

        fstate: (n_nodes,) the free law's states; tau_law: (n_nodes, gdim − 1) its
        traction τ̂ (both None without friction); rtol: GMRES's relative tolerance.
        Returns (λ (n_nodes,), λ_T (n_nodes, gdim − 1), None without friction).
        """
        comm, prob = self.comm, self.problem
        self.displacement_update = None
        fric = self.frictional
        n, m = self.lmbda_t.shape if fric else (self.lmbda.size, 0)
        plain = (np.maximum(self.p_hat, 0.0), tau_law.copy() if fric else None)
        solve = getattr(prob, "linear_inverse", None)
        if solve is None:
            info["exact_update"] = "plain (no factorization)"
            return plain
        self._current_factorization(fstate, info)
        x0 = prob.u.vector.copy()
        sliver = self.sliver_nodes()  # at the converged state, held during the differences
        lam0 = np.concatenate([self.lmbda, self.lmbda_t.ravel()]) if fric else self.lmbda.copy()
        saved = (
            self.lmbda.copy(),
            self.lmbda_t.copy() if fric else None,
            self.frozen if fric else None,  # set for frictional pairs only
            self.qp_frozen,
        )
        if fric:
            self.frozen = (fstate.copy(), None)  # the states; the slip directions stay free
        if self.recovery == "constrained" and self._recovered is not None:
            self.qp_frozen = self._recovered.free.copy()  # the QP's free set 𝒫, held
        xt, r0, r1, w = (x0.duplicate() for _ in range(4))

        def law(x: PETSc.Vec, lam: np.ndarray) -> np.ndarray:
            self.lmbda = lam[:n].copy()
            if fric:
                self.lmbda_t = lam[n:].reshape(n, m).copy()
            prob.update_contact(x)  # the state at x of every term (u ← x)
            # the sliver nodes' targets are fixed (pure penalty's: λ = 0, λ_T = τ_n)
            p_hat = np.where(sliver, 0.0, self.p_hat)
            if not fric:
                return p_hat
            tau = np.where(sliver[:, None], self.lmbda_t_committed, self.tau_law)
            return np.concatenate([p_hat, tau.ravel()])

        def contact_residual(b: PETSc.Vec) -> None:
            with b.localForm() as bl:
                bl.set(0.0)
            self.add_residual(b)
            b.assemble()

        T0 = law(x0, lam0)
        contact_residual(r0)
        scale = max(
            comm.allreduce(float(np.abs(lam0).max(initial=0.0)), op=MPI.MAX),
            comm.allreduce(float(self.p_hat.max(initial=0.0)), op=MPI.MAX),
            1e-300,
        )
        failed = []
        # the multipliers' change of a product: EXACT_FD_STEP of their scale, and no less
        # than EXACT_FD_ROUND_OFF times the law's round-off at the converged state
        change = EXACT_FD_STEP * scale
        floor = EXACT_FD_ROUND_OFF * self._law_round_off()
        if change < floor:
            log.debug(
                "%s: exact update: a difference step of %.2g is %.2g × the nodal law's "
                "round-off: %.2g taken",
                self.name,
                change,
                change * EXACT_FD_ROUND_OFF / floor,
                floor,
            )
            change = floor

        def dudx(v: np.ndarray) -> float:
            """w ← K⁻¹ ∂R/∂x v (forward difference); returns the step h (0: v = 0)."""
            vmax = comm.allreduce(float(np.abs(v).max(initial=0.0)), op=MPI.MAX)
            if vmax == 0.0:
                w.set(0.0)
                return 0.0
            h = change / vmax
            law(x0, lam0 + h * v)
            contact_residual(r1)
            r1.axpy(-1.0, r0)
            r1.scale(1.0 / h)
            if not solve(r1, w):
                failed.append(True)
                w.set(0.0)
            return h

        def jacobian(xv, yv):  # y ← J x (forward differences)
            v = xv.getArray(readonly=True).copy()
            h = dudx(v)
            if h == 0.0:
                yv.set(0.0)
                return
            x0.copy(xt)
            xt.axpy(-h, w)  # u + h du/dx v
            yv.array[:] = (law(xt, lam0 + h * v) - T0) / h - v

        du = None
        try:
            size = (lam0.size, comm.allreduce(lam0.size))
            ok, its, step = _gmres(  # −F on the right
                comm,
                size,
                jacobian,
                lam0 - T0,
                rtol,
                EXACT_FD_MAX_IT,
                getattr(prob, "configure_uzawa_ksp", None),
            )
            ok = ok and not comm.allreduce(bool(failed), op=MPI.LOR)
            if ok:  # δu = −K⁻¹ ∂R/∂x δx (linear in δx, so one more difference)
                h = dudx(step)
                ok = not comm.allreduce(bool(failed), op=MPI.LOR)
                du = -w.getArray(readonly=True).copy() if h > 0.0 else None
        finally:
            # back to the converged state (u, x and the states of the solve)
            self.lmbda, lam_t, frozen, self.qp_frozen = saved
            if fric:
                self.lmbda_t, self.frozen = lam_t, frozen
            prob.update_contact(x0)
            for vec in (xt, r0, r1, w, x0):
                vec.destroy()
        if not self._exact_outcome(ok, its, du, step, info):
            return plain
        lam = lam0 + step
        return np.maximum(lam[:n], 0.0), lam[n:].reshape(n, m) if fric else None

    def round_state(self) -> dict:
        """What the next Uzawa round starts from, after :meth:`uzawa_update` (local): the
        multipliers, the acceleration's history and the stick/slip states the round would
        carry with ``carry_states`` (copies). :meth:`resume_round` restores it."""
        acc = {k: v for k, v in vars(self.uzawa_acceleration).items() if k != "comm"}
        return {
            "lmbda": self.lmbda.copy(),
            "lmbda_t": self.lmbda_t.copy() if self.frictional else None,
            "acceleration": copy.deepcopy(acc),
            "carry": copy.deepcopy(self._carried),
        }

    def resume_round(self, state: dict) -> None:
        """Go back to a :meth:`round_state` of this step (local; after :meth:`begin_step`):
        the next solve then starts as the round after that state's update did, with the
        states carried if ``carry_states`` is set."""
        self.lmbda = state["lmbda"].copy()
        vars(self.uzawa_acceleration).update(copy.deepcopy(state["acceleration"]))
        if self.frictional:
            self.lmbda_t = state["lmbda_t"].copy()
            self.frozen = None
            self._carried = copy.deepcopy(state["carry"])

    def _reset_acceleration(self) -> None:
        """A step starts (or starts again): the acceleration's history is forgotten, and a
        pair that slow Aitken rounds switched to the exact update (AUTO_EXACT_BOUND) goes
        back to Aitken (local)."""
        self.uzawa_acceleration.reset()
        self._round_changes = []
        if self._auto_exact:
            self.uzawa_acceleration.method = "aitken"
