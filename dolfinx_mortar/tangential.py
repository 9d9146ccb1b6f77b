"""The tangential terms of a mortar pair: Coulomb friction's slip integrals, recovery,
Jacobian blocks and state predictor.

:class:`TangentialTerms` holds the frictional methods of
:class:`~dolfinx_mortar.contact.MortarContact` (one of its base classes, with
:class:`~dolfinx_mortar.uzawa.UzawaRounds`; it is not meant to be used on its own), in
the order they run:

- set-up (:meth:`~TangentialTerms._init_friction`, only when μ > 0): the tangential
  penalty ε_T, the slip history (u_n, λ_T = τ_n), the nodal frames and the tangential
  weight functions Ψ (docs/method-notes.md, "Dual tangential weights");
- the slip integrals (:meth:`~TangentialTerms._friction_integrals`): the pairing in the
  t_n configuration, A_T^I, the slip weights S^I, S_n^I and the force weights G^I per
  node (:func:`.kernels.friction.slip_integrals`), the nodal frames now and at t_n, and
  the slip since t_n σ^I (:meth:`~TangentialTerms._slip_since_t_n`; METHOD.md §1, §2);
- the tangential recovery and the nodal return mapping
  (:meth:`~TangentialTerms._recover_tangential`: lumped γ = σ/A_T, or the consistent
  recoveries of :func:`.recovery.recover_tangential`; METHOD.md §3, §4), with the
  chattering control's re-entry rule (:meth:`~TangentialTerms._reentry`);
- the Jacobian blocks K_T = Σ_I (G^I)ᵀ ∂t^I/∂u
  (:meth:`~TangentialTerms._add_tangential_jacobian`,
  :meth:`~TangentialTerms._add_mixed_tangential_jacobian`), with the slip-reversal
  freeze, the geometric block of the traction at the current projection
  (:meth:`~TangentialTerms._add_force_geometric`) and, with segment integration, the
  motion of the points (:meth:`~TangentialTerms._segment_slip_motion`;
  docs/method-notes.md, "Segment integration");
- the state predictor of a load step's first Jacobian
  (:meth:`~TangentialTerms.state_prediction_wanted`,
  :meth:`~TangentialTerms.trial_traction`, :meth:`~TangentialTerms.guess_slip`).

The node-level formulas are in :mod:`dolfinx_mortar.friction`, the point integrals in
:mod:`dolfinx_mortar.kernels.friction`. The methods read the host's pair data: the facet
arrays ``slave``, ``master``, ``master_local`` and ``node_of``, ``node_blocks``,
``gdim``, ``bs``, ``comm``, ``h_node``, ``h_facet``; the current pairing of the
quadrature points (``xs``, ``xm``, ``qp_xi``, ``qp_w``, ``qp_m``, ``qp_zeta``); the normal
recovery's state (``p``, ``gamma``, ``active``, ``kcoef``, ``eps_auto``, ``E_star``,
``_dp_rows``, ``_seg_c_rows``, ``_seg_motion``, ``_geometric_on``); the options
(``mu``, ``frictional``, ``integration``, ``tangential_recovery``, ``tangential_frame``,
``tangential_weights``, ``freeze_after``); and a few host methods (``_fetch_slave``,
``_fetch_cand``, ``_held_at_zero``, ``_check_penalty_ratio``, ``_mixed_node_points``,
``paired_fraction``). They set the tangential state that the host's residual, Uzawa
rounds, steps and outputs read (``AT``, ``S``, ``s_*``, ``frame_a``, ``frame_n``,
``tau``, ``t_vec``, ``fstate``, ``frozen``, ``lmbda_t``, ...).

The constants of the friction rules are here; DEEP_PENETRATION_TOL, PARTIAL_FACET_TOL
and SLIP_TOL are shared with the normal stage, which reads them as ``tangential.X`` at
each use (one definition: a test that sets ``tangential.X`` changes both stages).
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from mpi4py import MPI
from petsc4py import PETSc

from . import friction as fr
from . import recovery as rc
from .assembly import add_keyed_blocks, add_row_blocks, add_square_blocks
from .errors import SceneError
from .kernels import friction as kfriction
from .kernels import mortar as kmortar
from .search import candidates
from .surface import dual_coefficients

log = logging.getLogger(__name__)

#: ``penalty_tangential = "auto"``: ε_T^I = AUTO_PENALTY_T_FACTOR · E* / h_I. Ten times softer
#: than the normal rule: with 100 E*/h, Newton cycles between stick and slip at the
#: nodes whose trial traction sits near the Coulomb cone (Cattaneo–Mindlin first
#: contact); the Uzawa rounds remove the elastic stick slip that the softer penalty allows.
AUTO_PENALTY_T_FACTOR = 10.0
#: Unconstrained/constrained recovery: a slave facet whose paired fraction
#: (:meth:`~dolfinx_mortar.contact.MortarContact.paired_fraction`, exact to round-off) is
#: below 1 − this enters the mortar mass matrix lumped. The switch is a jump of the residual, so it must not sit
#: where a solution does: at a symmetry plane the master's end node projects onto the
#: slave's end facet a hair inside it (by the penetration times the facet's slope there),
#: and with 1e-9 hertz2d's coarse P2 half model (segment integration) had that facet
#: cross the threshold between iterates (1 − fraction = 0.98e-9 … 1.0e-9) until the step
#: could not be halved further. A sliver of 1e-4 leaves the consistent block regular.
PARTIAL_FACET_TOL = 1e-4
#: The tangential recoveries whose nodes the chattering control freezes in STICK at a slip
#: reversal (``_add_tangential_jacobian``); the unconstrained one freezes after
#: contact.FREEZE_AFTER Jacobians only.
REVERSAL_RECOVERIES = ("lumped", "constrained")
#: The state predictor of a load step's first Jacobian (:meth:`TangentialTerms.guess_slip`):
#: a node sticking at the step's start gets the slip tangent there where the trial
#: traction at the end of the stick Newton step, |λ_T + ε_T γ|, exceeds (1 + this) × μ p_N
#: (its pressure at the start). Lumped tangential recovery only.
SLIP_GUESS_MARGIN = 0.1
#: The state predictor's load floor: it applies only where the pair's trial pressure
#: Σ A_T p_N at the end of the stick Newton step is at least this times that at its start
SLIP_GUESS_LOAD_FLOOR = 0.5
#: ... and only where the pair's trial shear |Σ A_T τ^tr| exceeds this times μ Σ A_T p_N^tr
#: (measured: 2.07 to 4.97 in the slides it helps, 237 in s16's reversals; 1.18 at the one
#: node of demo_ironing2d where it fired and changed the run's figures)
SLIP_GUESS_PAIR_RATIO = 1.5
#: A node frozen OPEN by the chattering control that closes later is imposed STICK (its
#: multiplier plus ε_T times its slip since t_n), unless that slip, |γ^I| = |σ^I|/A_T^I,
#: exceeds this many h_I: it then follows the free law (stick or slip) for the rest of
#: the solve. It cannot stick to a material point elements away. On the ironing2d path
#: the slab's dragged corner opened in the first iterates of the step where it springs
#: back (u_x = 1.44), re-closed after the freeze 0.3 = 3 h from its t_n point and, held
#: there in stick, pulled the solve back to the vanished pre-snap equilibrium; the next
#: Uzawa round made the jump in 31 iterations (56 in the step; 31 + 4 + 1 with this rule,
#: 18 + 10 + 1 with the pins of contact.PIN_OUTSIDE_TOL as well). The nodes
#: of a press that close after the freeze keep stick: the free law or its state frozen
#: at their entry put transient iterates' slip into the Cattaneo tests (a 35-iteration
#: solve, a 26-iteration step; docs/method-notes.md, "Friction", chattering control).
REENTRY_FREE_SLIP = 0.5
#: ... or whose trial traction |λ_T + ε_T γ^I| exceeds this many μ p^I. On the ironing2d
#: path (t = 1.27) a node at the leading edge of the contact zone re-closed with p = 0.011
#: and stuck with 16 μ p: the round converged with it wrong, and the step took five Uzawa
#: rounds (12 + 11 + 9 + 2 + 1), now 15 + 4 + 2 + 1. Lumped normal recovery only until
#: session 47 (in session 20 the Cattaneo press test then took a 31-iteration solve). With
#: the constrained recovery a node in tension (p < 0, session 46) has no cone, so an
#: imposed stick made τ jump from 0 to the trial traction where p crossed 0: in a 3D slide
#: two such nodes 2-cycled around p = 0 until max_it (docs/method-notes.md, "Friction").
REENTRY_TRIAL_CONE = 3.0
#: At the chattering control's freeze, a pair none of whose active nodes is in stick (in the
#: states being frozen) keeps its states frozen but not its slip directions: they follow the
#: trial traction, with the free law's stiffness μ p ε_T/|τ^tr| (I − s⊗s) across the slip.
#: With the directions fixed, such a pair has no tangential stiffness at all, and a body
#: held across its slip only by the contact has a zero pivot (session 52: the 3D sliding
#: patch test on P2 tetrahedra froze at its 8th Jacobian with ‖R‖ = 8.9e-6; the frozen
#: directions' net cross-slip traction, 1.2e-5, had nothing to balance it, and the next
#: Newton step moved the upper block 2.3e8 across the slide: DIVERGED_DTOL, a cutback).
FREE_SLIP_DIRECTIONS = True
#: Where the tangential traction acts on the master (session 55): True, at the CURRENT
#: projection ζ of each slave point (the force weights G of R_T = Σ_I (G^I)ᵀ t^I, with
#: the geometric tangent block of ζ's motion, :func:`.kernels.friction.force_geometric_blocks`,
#: and with segment integration the master rows at ζ(ξ) of the moving points); False, at
#: ζ_n (G = W, the S-weights of the slip), as before session 55 (docs/method-notes.md,
#: "Where the traction acts on the master"). The slip, its history and the return
#: mapping do not depend on it. The first held step after a gross-slip slide moved the
#: forces by 1.0e-2 |F| (2D) with ζ_n, 4.5e-4 with ζ (BENCHMARKS.md §48, §70).
#: Opt-in (False by default) since the change costs Newton iterations on the ironing
#: path: demo_ironing2d's corner snap (t = 1.36) took 18 + 12 + 1 instead of 18 + 6 + 1 (the
#: full-step round after the pins grew ‖R‖ at its first step, solver.ROUND_FULL_STEP_GROWTH,
#: and restarted with l2), over issue 4's 25 per step (tests/test_friction_demos.py::
#: test_ironing2d_snap_of_the_dragged_corner); with that growth allowed to 3× the snap
#: took 18 + 5 + 1, but the step at t = 1.52 then 12 + 17 + 3 + 1 (BENCHMARKS.md §70).
#: Measured again in session 56 (BENCHMARKS.md §73): seven tests fail with True, among
#: them the deformable-master patches' accuracy (3D, 2 steps: the partly covered nodes
#: 0.9995 instead of 0.24) and the stiff SVK scene of the inversion test; and no rule
#: on the full steps' growth keeps the ironing demo within 25 per step. The patches' loss
#: was a defect, fixed in session 56 (task F, BENCHMARKS.md §75): G dropped the points
#: paired now but not at t_n, so the master's leading end carried no tangential
#: traction; G now takes them (3D deformable patch, 2 steps: 0.9995 → 7.2e-4). The other
#: six failures stand after that fix (§75: the ironing snap, the stiff SVK scene, the
#: unconstrained recovery's slide, an Aitken cutback, the chattering and dissipation tests).
FORCE_AT_CURRENT_PROJECTION = False
#: Deep penetration (in units of the nodal facet size h_I): an active node with mixed gap
#: γ^I < −DEEP_PENETRATION_TOL h_I marks an iterate far from equilibrium, where p = ε|γ|
#: is 5 E* (auto penalty) or more, and the geometric part of the tangent is left out while
#: the active set moves, as at first contact (contact.GEOMETRIC_TANGENT_AT_FIRST_CONTACT).
#: The extrapolated predictor of a displacement-driven press step puts every node of the previous contact zone into the
#: other body by its initial gap (cattaneo2d, t = 0.5 → 1: 0.5 h); with the exact tangent
#: Newton then cycled for 35 iterations, from the predictor and again from the converged
#: state, and the step was cut back. Converged states penetrate by p/ε ≈ 1e-4 h. In a
#: step whose start is that deep (meshes that overlap at t = 0: ``deep_start``), the
#: chattering control's slip-reversal rule does not compare the stick/slip states of such
#: an iterate either (session 52; ``_add_tangential_jacobian``).
DEEP_PENETRATION_TOL = 0.05
#: A node slips only when |τ^tr| − μ p_N > SLIP_TOL ε_T h_I (the traction of a slip of
#: SLIP_TOL h_I): below, the slip direction would be round-off. The lumped law fades it
#: to 0 below the unloaded floor of p_N (:meth:`TangentialTerms._law_slip_tol`), so that a
#: node whose p_N is round-off carries no stick traction beyond round-off.
SLIP_TOL = 1e-10
#: A slave node takes part in the friction of a step only when it touched at t_n: mixed
#: gap γ_n ≤ HISTORY_GAP_TOL h_I (a node closing from farther enters frictionless: its slip
#: from the t_n projection would be spurious, of order γ_n × the rotation of the normal).
HISTORY_GAP_TOL = 1e-2


class TangentialTerms:
    """The tangential (frictional) methods of :class:`~dolfinx_mortar.contact.MortarContact`
    (module docstring): a mixin, not meant to be used on its own."""

    def _init_friction(self, penalty_t, key: str) -> None:
        """Tangential fields, history and frames (only when μ > 0; METHOD.md §1, §4)."""
        n, d = self.node_blocks.size, self.gdim
        self.deep_start = False  # the start of the step penetrates deeply (local)
        #: the tangential auto rule ε_T,auto^I = AUTO_PENALTY_T_FACTOR E*/h_I (n,): the Uzawa
        #: test of a softer ε_T (:meth:`~dolfinx_mortar.uzawa.UzawaRounds._softness`)
        self.eps_t_auto = AUTO_PENALTY_T_FACTOR * self.E_star / np.maximum(self.h_node, 1e-300)
        if penalty_t == "auto":
            self.eps_t = self.eps_t_auto
            self.penalty_t_description = f"auto: {AUTO_PENALTY_T_FACTOR:g} E*/h_I"
        else:
            self.eps_t = np.full(n, float(penalty_t))
            self.penalty_t_description = float(penalty_t)
        # against the NORMAL auto value, as the tolerance was set for it: "auto" and
        # None (= the normal penalty) give ratios ≤ 1
        eps_t_max = self.comm.allreduce(float(self.eps_t.max(initial=0.0)), op=MPI.MAX)
        self._penalty_t_ratio = eps_t_max / self._eps_auto_max
        self._check_penalty_ratio(self._penalty_t_ratio, eps_t_max, f"{key}.penalty_tangential")
        self.softness_t = self.comm.allreduce(
            float(self._softness(self.eps_t, self.eps_t_auto).max(initial=1.0)), op=MPI.MAX
        )
        self._slip_tol = SLIP_TOL * self.eps_t * self.h_node
        self._p_floor = 0.0  # the unloaded floor of p at the last _recover (_law_slip_tol)
        #: ε_T,soft^I = min(ε_T^I, ε_auto^I) (n,), used with ε_soft (SOFT_START_RATIO)
        self.eps_t_soft = np.minimum(self.eps_t, self.eps_auto)
        self._eps_t_own = self.eps_t
        self.frames = fr.NodalFrames(
            self.ftype,
            self.slave.X,
            self.slave.sign,
            self.node_of,
            self.mixed,
            n,
            self.slave.dofs.reshape(self.slave.X.shape),
            held_at_zero=self._held_at_zero(),
        )
        if self.tangential_frame == "master":
            nm = self.master_local.nodes_per_facet
            self.frames = fr.MasterFrames(self.frames, self.master_local.ftype, nm)
        self._hist_vec = None  # t^n vectors of a new t_n, for the master frames (_master_points)
        self._frame_dA = None
        # weight functions of the tangential mixed field, Ψ_i = Σ_j C_ij Φ_j on the facets
        # of finite t_facet_area (docs/method-notes.md, "Dual tangential weights"); node
        # integration keeps Φ (its points are the nodes)
        nsf, nphi = self.node_of.shape
        dual = None
        if self.tangential_weights == "dual" and self.integration != "node":
            error = ""
            try:
                dual = dual_coefficients(self.ftype, self.ftype_phi, self.slave.X, self.rule)
            except ValueError as exc:
                error = str(exc)
            # the same decision on every rank: the first rank's reason, if any
            error = next((e for e in self.comm.allgather(error) if e), "")
            if error and self.tangential_weights_asked != "auto":
                raise SceneError(f"{key}.tangential_weights", error)
            if error:  # "auto" where no dual basis exists
                dual, self.tangential_weights = None, "standard"
        if dual is not None:
            self.t_weights, self.t_facet_area = dual
        else:
            self.t_weights = np.broadcast_to(np.eye(nphi), (nsf, nphi, nphi)).copy()
            self.t_facet_area = np.full(nsf, np.inf)
        self.lmbda_t = np.zeros((n, d - 1))  # tangential multiplier = traction history τ_n
        self.lmbda_t_committed = np.zeros((n, d - 1))
        self.tau = np.zeros((n, d - 1))  # recovered traction components (residual, output)
        self.tau_law = np.zeros((n, d - 1))  # the nodal law's τ̂ (Uzawa, history)
        self.gamma_t = np.zeros((n, d - 1))
        self.sigma_t = np.zeros((n, d - 1))  # weighted slip since t_n, a_α·S − a_α,n·S_n
        self.frame_a_n = np.zeros((n, d - 1, d))  # the nodal frames at t_n
        self.S_n = np.zeros((n, d))  # the S-weights on the t_n coordinates
        self.fstate = np.zeros(n, np.int64)  # the nodal law's states
        self._trec = None  # recovery.TangentialRecovered (consistent recoveries)
        self.slip_length = np.zeros(n)  # accumulated |γ_T| over converged steps
        self.slip_length_committed = np.zeros(n)
        self.dissipation = 0.0
        # (active, slipping) slave nodes of the last committed step, all ranks (the hint of
        # a run that stops: a tangential load beyond μ times the normal load)
        self.committed_slip = (0, 0)
        self.t_vec = np.zeros((n, d))
        self.frozen = None  # imposed stick/slip states (chattering control)
        self._slip_prev, self._reversed = None, None  # slip reversal (chattering control)
        self._dual_fixed = None  # the facets' Ψ/Φ choice of this step (_dual_facets)
        # the Newton solves since begin_step; whether this one starts from the predictor
        self._solves, self._from_predictor = 0, False
        self.carry_states = False  # see the docstring of uzawa_update
        # the states the last Uzawa round hands to the next solve (used with carry_states)
        self._carried = None
        self._jacobians = 0
        #: (mask (n,), D (n, m, m), Pd (n, m)): the slip tangent guessed for the next
        #: Jacobian only (:meth:`guess_slip`), or None
        self._slip_guess = None
        self._u_n = self.problem.u.vector.copy()  # displacements of the last converged step
        self._u_n_version = 0
        self._u_n_local = None  # (version, u_n at the local slave and master facets)
        self._hist_far = None  # ((version, exchanges), _history_far's value)
        self._history_key = None
        self._history_memo = []  # (points, t_n pairing) of _history_pairing
        self._slip_memo = []  # (inputs, results) of the last two _slip_integrals
        self._pending = None  # (u, τ, t^n vectors) of a committed step, for begin_step

    def _friction_integrals(self) -> None:
        """Pairing at t_n, A_T, S, S_n and the S-weights per node, and the nodal frames (now
        and, once per t_n and exchange, in the t_n configuration: ``frame_a_n``).

        The t_n pairing depends only on u_n, the quadrature points and the master ghost
        layer. The t_n configuration and its candidates are computed once per t_n and
        exchange (:attr:`_history_key`); the pairing of the points too, except with
        segment integration, whose points move with u: there it is made at every update
        whose points differ from those of the last two (:meth:`_history_pairing`; the
        exact multiplier update, :meth:`_exact_multipliers_fd`, returns to the converged
        state between its perturbed ones). The rest (:meth:`_slip_integrals`) is kept for
        the last two sets of its inputs with the slave frames (``_slip_memo``), as the
        pairing is (:meth:`_pair_and_integrate`): inputs equal to one of them, bit for bit,
        take copies of its results.
        """
        key = (self._exchanges, self._u_n_version)
        new_key = key != self._history_key
        if new_key:
            un = self._u_n  # (the fetches are collective; the key is the same on every rank)
            xs_n = self.slave.X + self._fetch_slave(un).reshape(self.slave.X.shape)
            xm_n = self.master.X + self._fetch_cand(un).reshape(self.master.X.shape)
            self._x_n = (xs_n, xm_n)
            self.hist_cand = candidates(xs_n, xm_n, 2.0 * self.h_facet)
            self._history_memo = []
        if self.integration == "segment" or new_key:
            self._history_pairing()
            self._history_key = key
            if new_key:  # not per segment update
                xs_n, xm_n = self._x_n
                if self.tangential_frame == "master":
                    self._master_points(xs_n, xm_n, *self.hist_cand)
                # the nodes' frames in the t_n configuration, a_n of σ = a·S − a_n·S_n
                self.frame_a_n = self._frames_at(xs_n, xm_n, False)[0]
                if self._hist_vec is not None:  # master frames, the first search at a new t_n
                    self._carry_history()
        self.dual_on = self._dual_facets()
        self._frame_dA = None  # computed when a Jacobian asks (frame_dA)
        # S-weights and frames: a function of the arrays below (and of the term's fixed
        # layout), kept for the last two sets of them (_slip_memo), like the pairing's
        # (_pair_and_integrate); the master frames carry a state of their own: no memo
        inputs = None
        if self.tangential_frame == "slave":
            arrays = (
                self.xs, self.xm, *self._x_n, self.qp_xi, self.qp_w, self.qp_m, self.qp_mn,
                self.qp_zn, self.qp_zeta, self.node_touching, self.t_weights, self.dual_on,
            )  # fmt: skip
            inputs = (
                self._exchanges,
                self.force_at_current,
                *((a.shape, a.dtype.str, a.tobytes()) for a in arrays),
            )
            for i, (key, result) in enumerate(self._slip_memo):
                if key == inputs:
                    self._slip_memo.insert(0, self._slip_memo.pop(i))
                    self._set_slip(tuple(a.copy() for a in result))
                    return
        self._slip_integrals()
        if inputs is not None:
            self._slip_memo.insert(0, (inputs, tuple(a.copy() for a in self._slip_results())))
            del self._slip_memo[2:]

    def _slip_results(self) -> tuple:
        """The arrays that :meth:`_slip_integrals` makes (local)."""
        return (
            self.AT, self.S, self.S_n, self.s_node, self.s_key, self.s_dof, self.s_w,
            self.s_g, self.s_off, self.frame_a, self.frame_n,
        )  # fmt: skip

    def _set_slip(self, result: tuple) -> None:
        """Take the arrays of :meth:`_slip_results` (local)."""
        (
            self.AT, self.S, self.S_n, self.s_node, self.s_key, self.s_dof, self.s_w,
            self.s_g, self.s_off, self.frame_a, self.frame_n,
        ) = result  # fmt: skip

    def _slip_integrals(self) -> None:
        """A_T, S, S_n and the S-weights per node (``slip_integrals``), and the nodal frames
        now, at the current pairing and t_n pairing (local; :meth:`_friction_integrals`)."""
        nsf, nq = self.qp_w.shape
        n, d = self.node_blocks.size, self.gdim
        ns, nm = self.slave.nodes_per_facet, self.master.nodes_per_facet
        current = self.force_at_current
        cap = nsf * nq * self.node_of.shape[1] * (ns + (2 if current else 1) * nm)
        e_node = np.empty(cap, np.int64)
        e_key = np.empty(cap, np.int64)
        e_dof = np.empty((cap, d), np.int64)
        e_w = np.empty(cap)
        e_g = np.empty(cap)
        self.AT, self.S, self.S_n = np.zeros(n), np.zeros((n, d)), np.zeros((n, d))
        ne = 0
        if nsf:
            ne = kfriction.slip_integrals(
                self.ftype,
                self.master.ftype,
                self.ftype_phi,
                self.xs,
                self.xm,
                *self._x_n,
                self.qp_xi,
                self.qp_w,
                self.qp_m,
                self.qp_mn,
                self.qp_zn,
                self.qp_zeta,
                current,
                self.node_of,
                self.node_touching,
                self.t_weights,
                self.dual_on,
                self.slave.blocks,
                self.slave.dofs,
                self.master.blocks,
                self.master.dofs,
                self.AT,
                self.S,
                self.S_n,
                e_node,
                e_key,
                e_dof,
                e_w,
                e_g,
            )
        # merge the entries of each (node, block): S^I = Σ_k W_k x_k, R_T = Σ_I (G^I)ᵀ t^I
        order = np.lexsort((e_key[:ne], e_node[:ne]))
        en, ek = e_node[order], e_key[order]
        start = np.ones(ne, bool)
        start[1:] = (en[1:] != en[:-1]) | (ek[1:] != ek[:-1])
        first = np.flatnonzero(start)
        self.s_node, self.s_key, self.s_dof = en[first], ek[first], e_dof[order][first]
        self.s_w = np.add.reduceat(e_w[order], first) if ne else np.empty(0)
        self.s_g = np.add.reduceat(e_g[order], first) if ne else np.empty(0)
        self.s_off = np.searchsorted(self.s_node, np.arange(n + 1))
        self.frame_a, self.frame_n, _ = self._frames_at(self.xs, self.xm, False)

    def _history_pairing(self) -> None:
        """The pairing of the quadrature points in the t_n configuration (``_x_n``, its
        candidates ``hist_cand``; local): qp_mn, qp_zn, and what follows from it,
        node_touching, deep_start and dual_area.

        A function of the points (qp_xi, qp_w) at a given t_n and exchange: the results
        for the last two sets of points are kept (``_history_memo``, emptied at a new
        t_n or exchange), and points equal to one of them, bit for bit, take its results.
        """
        memo = self._history_memo
        points = (self.qp_xi.shape, self.qp_xi.tobytes(), self.qp_w.tobytes())
        for i, (pts, result) in enumerate(memo):
            if pts == points:
                memo.insert(0, memo.pop(i))
                (self.qp_mn, self.qp_zn, self.node_touching, self.deep_start, self.dual_area) = (
                    result
                )
                return
        nsf, nq = self.qp_w.shape
        n, km = self.node_blocks.size, self.gdim - 1
        xs_n, xm_n = self._x_n
        off, idx = self.hist_cand
        self.qp_mn = np.full((nsf, nq), -1, np.int64)
        self.qp_zn = np.zeros((nsf, nq, km))
        gn = np.zeros((nsf, nq))
        if nsf:
            kmortar.pair_points(
                self.ftype,
                self.master.ftype,
                xs_n,
                self.slave.sign,
                self.qp_xi,
                self.qp_w,
                xm_n,
                self.master.sign,
                self.master_key,
                off,
                idx,
                2.0 * self.h_facet,
                2.0 * self.h_facet,
                self.qp_mn,
                self.qp_zn,
                gn,
                self.outside_tol,
                True,  # nearest first: 25-36 candidates per facet at 2 h
            )
        # nodes still open at t_n (mixed gap γ_n > 0) have no material point to stick to:
        # their closing motion seen from the t_n projection would be a spurious slip of
        # order γ_n × (normal rotation); they enter frictionless and join the next step
        An, Gn = np.zeros(n), np.zeros(n)
        if nsf:
            kmortar.nodal_integrals(
                self.ftype_phi, self.qp_xi, self.qp_w, self.qp_mn, gn, self.node_of, An, Gn
            )
        has = An > 1e-12 * self.h_node ** (self.gdim - 1)
        gamma_n = np.where(has, Gn / np.where(has, An, 1.0), np.inf)
        self.node_touching = gamma_n <= HISTORY_GAP_TOL * self.h_node
        # a start of step deeper than DEEP_PENETRATION_TOL h_I (meshes that overlap at
        # t = 0; converged states penetrate by p/ε ≈ 1e-4 h): the slip-reversal rule
        # skips the iterates far from equilibrium (_add_tangential_jacobian)
        self.deep_start = bool(np.any(gamma_n < -DEEP_PENETRATION_TOL * self.h_node))
        # facets closed over their whole area at t_n (every point paired with a gap
        # ≤ HISTORY_GAP_TOL h): the dual tangential weights apply only there
        used = self.qp_w != 0.0
        ok = (self.qp_mn >= 0) & (gn <= HISTORY_GAP_TOL * self.h_facet[:, None])
        closed = np.all(ok | ~used, axis=1) & np.any(used, axis=1)
        self.dual_area = np.where(closed, self.t_facet_area, np.inf)
        result = (self.qp_mn, self.qp_zn, self.node_touching, self.deep_start, self.dual_area)
        memo.insert(0, (points, result))
        del memo[2:]

    def _frames_at(self, xs, xm, derivatives: bool):
        """The nodal frames (a, nrm, dA) at slave xs and master xm coordinates (local)."""
        if self.tangential_frame == "master":
            return self.frames.compute(xs, xm, derivatives)
        return self.frames.compute(xs, derivatives)

    def _master_points(self, xs_n, xm_n, off, idx) -> None:
        """The master frames' t_n points (``tangential_frame = "master"``, local): the
        closest-point projection of every owned node in the t_n configuration (the
        occurrence with the smallest |gap| among the facets around it)."""
        nsf, nphi = self.node_of.shape
        n, km = self.node_blocks.size, self.gdim - 1
        mn, zn = np.full(n, -1, np.int64), np.zeros((n, km))
        if nsf:
            xi = self._mixed_node_points(nsf)
            w = (self.node_of >= 0).astype(float)
            pm = np.full((nsf, nphi), -1, np.int64)
            pz, pg = np.zeros((nsf, nphi, km)), np.zeros((nsf, nphi))
            reach = 2.0 * self.h_facet
            kmortar.pair_points(
                self.ftype, self.master.ftype, xs_n, self.slave.sign, xi, w, xm_n,
                self.master.sign, self.master_key, off, idx, reach, reach, pm, pz, pg,
                self.outside_tol, False,
            )  # fmt: skip
            f, i = np.nonzero((self.node_of >= 0) & (pm >= 0))
            order = np.lexsort((np.abs(pg[f, i]), self.node_of[f, i]))
            f, i = f[order], i[order]
            node = self.node_of[f, i]
            first = np.ones(node.size, bool)
            first[1:] = node[1:] != node[:-1]
            mn[node[first]] = pm[f[first], i[first]]
            zn[node[first]] = pz[f[first], i[first]]
        mdofs = self.master.dofs.reshape(self.master.X.shape)
        self.frames.set_points(mn, zn, xs_n, xm_n, mdofs)

    def _carry_history(self) -> None:
        """The master frames at a new t_n (begin_step): the history's traction carried
        into the new frames (local).

        The traction τ^n of the last step was committed as a physical vector t^n =
        τ̂_α ê_α (:meth:`commit_step`): its components in the frames of the new master
        points, λ_T = ê_α·t^n, both evaluated in the t_n configuration (``frame_a_n``), so
        a rigid motion superposed on the coming step leaves them as they are. Where the
        node faces the same affine master facet this is the paper's "covariant components
        carry over"; where the projection moved to another facet, it is the physical-slip
        rule applied to the multiplier (METHOD.md §1)."""
        lam = np.einsum("nac,nc->na", self.frame_a_n, self._hist_vec)
        self.lmbda_t, self.lmbda_t_committed = lam, lam.copy()
        self._hist_vec = None

    def _has_tangential_area(self) -> np.ndarray:
        """(n,) bool: the owned nodes with a tangential area, A_T^I > 1e-12 h_I^(d−1)
        (local): the others take no part in the slip and carry no tangential traction."""
        return self.AT > 1e-12 * self.h_node ** (self.gdim - 1)

    def _slip_since_t_n(self) -> np.ndarray:
        """σ (n, m): the tangential components of the weighted slip since the start of the
        step, in the node's convected frame (local; friction module docstring),

            σ_α^I = a_α^I·S^I − a_{α,n}^I·S_n^I,

        a^I the frame now, a_n^I in the t_n configuration, S_n^I the S-weights applied to
        the t_n coordinates: σ = 0 at u = u_n (S^I = S_n^I there is the weighted t_n gap
        vector, which on a non-matching interface has a tangential part), and a rigid
        motion superposed on the step leaves σ as it is. Zero at the nodes without a
        tangential area A_T. Its derivative: a·∂S + S·∂a, and with segment integration
        − a_n·∂S_n of the moving points too (:meth:`_segment_slip_motion`)."""
        hasT = self._has_tangential_area()
        sigma = np.einsum("nac,nc->na", self.frame_a, self.S) - np.einsum(
            "nac,nc->na", self.frame_a_n, self.S_n
        )
        sigma[~hasT] = 0.0
        return sigma

    @property
    def force_at_current(self) -> bool:
        """Whether the tangential traction acts on the master at the current projection ζ
        (FORCE_AT_CURRENT_PROJECTION), else at ζ_n."""
        return FORCE_AT_CURRENT_PROJECTION

    @property
    def frame_dA(self) -> np.ndarray:
        """∂a_α/∂x of the nodal frames at the current state, (P, nb, m, d, d) in the
        frames' occurrence layout (``frames.off``, ``frames.dofs``): computed on the first
        request after each update, as only Jacobians need it (local)."""
        if self._frame_dA is None:
            self._frame_dA = self._frames_at(self.xs, self.xm, True)[2]
        return self._frame_dA

    def _recover_tangential(self, frozen="current"):
        """Tangential recovery and the nodal return mapping: lumped γ = σ/A_T (local; σ of
        :meth:`_slip_since_t_n`), or the consistent recoveries of
        :func:`.recovery.recover_tangential` (collective).

        With ``frozen = None`` the states of the nodal law are computed free and only
        returned, with the law's traction τ̂ (n, m) for those states.
        """
        hasT = self._has_tangential_area()
        sigma = self._slip_since_t_n()
        gam = sigma / np.where(hasT, self.AT, 1.0)[:, None]  # the lumped slip since t_n
        imposed = self._reentry(self.frozen if frozen == "current" else frozen, gam, hasT)
        if self.tangential_recovery != "lumped":
            rec = self._recover_tangential_mixed(sigma, hasT, imposed)
            own = slice(self.gid_offset, self.gid_offset + self.node_blocks.size)
            if frozen is None:
                return rec.state[own], rec.tau_hat[own]
            self._trec = rec
            self.sigma_t, self.gamma_t = sigma, rec.gamma[own]
            self.tau, self.tau_law = rec.tau[own], rec.tau_hat[own]
            # the states are the nodal law's: M⁻¹F of a slipping zone may stay inside the
            # cone (the QP then leaves it untouched) while the law slips there
            self.fstate = rec.state[own]
            self._D, self._Pd = rec.D[own], rec.Pd[own]
            self.t_vec = np.einsum("na,nac->nc", self.tau, self.frame_a)
            return self.fstate, None
        p = np.where(hasT, self.p, 0.0)
        active = hasT & self.active
        tau, state, D, Pd = fr.return_mapping(
            self.lmbda_t, gam, p, active, self.mu, self.eps_t, imposed, self._law_slip_tol(p)
        )
        if frozen is None:
            return state, tau
        self.sigma_t, self.gamma_t, self.tau, self.tau_law = sigma, gam, tau, tau
        self.fstate = state
        self._D, self._Pd = D, Pd
        self.t_vec = np.einsum("na,nac->nc", tau, self.frame_a)
        return state, None

    def _law_slip_tol(self, p: np.ndarray) -> np.ndarray:
        """The lumped law's slip tolerance at the nodal pressures p (n,): SLIP_TOL ε_T h_I,
        faded linearly to 0 below the unloaded floor p_u = UNLOADED_ROUND_OFF × the law's
        round-off (:meth:`_law_round_off`, taken at the last :meth:`_recover`),

            tol_I = SLIP_TOL ε_T h_I min(1, max(p_I, 0) / p_u),

        so that the stick radius μp + tol_I goes to 0 with p: a node carries at most
        (μ + SLIP_TOL ε_T h_I / p_u) p in τ, continuous where it opens. A node with p ≈ 0
        that stuck with |τ| up to SLIP_TOL ε_T h_I (5.5e-7 on the patch, where μp was
        5e-11) dropped to τ = 0 when it opened, a jump of the residual between iterates
        that stalled Newton at a frictional release exactly at a step's end
        (docs/method-notes.md, "A contact that touches or releases exactly at a step's
        end"). Above p_u (every loaded node)
        nothing changes; at p = 0 a node sticks only where its trial traction is 0
        exactly (the start of a step, σ = 0 at u = u_n). Local."""
        floor = self._p_floor
        if not floor > 0.0:
            return self._slip_tol
        return self._slip_tol * np.clip(p / floor, 0.0, 1.0)

    def _reentry(self, imposed, gamma: np.ndarray, hasT: np.ndarray):
        """The frozen states (chattering control) as they are imposed now (local): a node
        frozen OPEN that is in contact follows the free law (state −1) instead of the
        stick that a frozen open node gets when it closes, where its lumped slip since
        t_n, |γ^I| = |σ^I|/A_T^I (``gamma`` (n, m)), exceeds REENTRY_FREE_SLIP × h_I or
        its trial traction |λ_T + ε_T γ^I| exceeds REENTRY_TRIAL_CONE × μ max(p^I, 0)
        (every normal recovery; at p^I ≤ 0 any nonzero trial traction does: an imposed
        stick would jump from τ = 0 in tension to the trial traction where p^I crosses
        0). ``imposed``: None or (states (n,), directions (n, m) or None); with directions
        None (the exact update's differences) it is returned as is."""
        if imposed is None or imposed[1] is None:
            return imposed
        states, dirs = imposed
        open_ = np.flatnonzero((states == fr.OPEN) & hasT)
        if not open_.size:
            return imposed
        g = gamma[open_]
        far = np.linalg.norm(g, axis=1) > REENTRY_FREE_SLIP * self.h_node[open_]
        trial = np.linalg.norm(self.lmbda_t[open_] + self.eps_t[open_, None] * g, axis=1)
        far |= trial > REENTRY_TRIAL_CONE * self.mu * np.maximum(self.p[open_], 0.0)
        if not far.any():
            return imposed
        states = states.copy()
        states[open_[far]] = -1
        return states, dirs

    def _dual_facets(self) -> np.ndarray:
        """(nsf,) bool: the slave facets whose tangential weights are the dual Ψ, those that
        their points paired now and at t_n cover whole (to FULL_COVER_TOL of their
        ``dual_area``, finite on the facets closed at t_n). With segment integration the
        covered area is a sum of clipped segments that moves with u: a facet whose
        shortfall straddles FULL_COVER_TOL would switch between Ψ and Φ from one iterate
        to the next (Newton cycles) or from one Uzawa round's solve to the next (the rounds
        cycle). There the choice is made at the first evaluation of a step's attempt
        (:meth:`begin_step`) and kept for the attempt; a facet then falls back to Φ only if
        its shortfall grows past DUAL_KEEP_TOL (points lost for real: Ψ's negative lobe at
        a closing facet) or it is no longer closed at t_n (local)."""
        covered = np.zeros(self.node_of.shape[0])
        if covered.size:
            kfriction.covered_area(self.qp_w, self.qp_m, self.qp_mn, covered)
        dual = covered >= (1.0 - kfriction.FULL_COVER_TOL) * self.dual_area
        if self.integration != "segment":
            return dual
        if self._dual_fixed is None or self._dual_fixed.shape != dual.shape:
            self._dual_fixed = dual
        return self._dual_fixed & (covered >= (1.0 - kfriction.DUAL_KEEP_TOL) * self.dual_area)

    def _tangential_mass(self) -> np.ndarray:
        """Facet blocks (nsf, nphi, nphi) of the tangential mortar matrix M_IJ = ∫Ψ_I Φ_J
        dA₀ over the points that enter S^I (paired now and at t_n; Ψ on the facets where
        ``slip_integrals`` uses it). A facet paired over part of its area enters lumped
        (row sums kept), as in the normal recovery (local)."""
        nsf, nphi = self.node_of.shape
        Mf = np.zeros((nsf, nphi, nphi))
        if not nsf:
            return Mf
        qp = np.where((self.qp_m >= 0) & (self.qp_mn >= 0), 0, -1)
        kmortar.facet_mass(self.ftype_phi, self.qp_xi, self.qp_w, qp, Mf)
        dual = self.dual_on
        Mf[dual] = np.einsum("fij,fjk->fik", self.t_weights[dual], Mf[dual])
        partial = np.flatnonzero(self._tangential_partial())
        sums = Mf[partial].sum(axis=2)
        Mf[partial] = 0.0
        Mf[partial, np.arange(nphi)[:, None], np.arange(nphi)[:, None]] = sums.T
        return Mf

    def _tangential_partial(self) -> np.ndarray:
        """(nsf,) bool: the facets whose block of the tangential mortar matrix is lumped,
        paired now and at t_n over less than their whole area (local)."""
        both = np.where((self.qp_m >= 0) & (self.qp_mn >= 0), 0, -1)
        return self.paired_fraction(both) < 1.0 - PARTIAL_FACET_TOL

    def _recover_tangential_mixed(self, sigma, hasT, imposed):
        """The unconstrained or constrained tangential recovery on the gathered slave
        surface (as :meth:`_recover_mixed`): every rank solves the same system
        (collective). Returns the :class:`.recovery.TangentialRecovered` of all nodes."""
        comm, m = self.comm, self.gdim - 1
        n, nphi = self.node_blocks.size, self.node_of.shape[1]
        Mf = self._tangential_mass()
        fi, ii = np.nonzero(self.node_of >= 0)
        rows = np.repeat(self.facet_gid[fi, ii], nphi)
        cols = self.facet_gid[fi].ravel()
        vals = Mf[fi, ii].ravel()
        states, dirs = imposed if imposed is not None else (np.full(n, -1), np.zeros((n, m)))
        local = np.column_stack(
            [
                self.AT,
                sigma,
                self.lmbda_t,
                np.where(hasT, self.p, 0.0),
                hasT,
                hasT & self.active,
                self.eps_t,
                self._slip_tol,
                states,
                dirs,
            ]
        )
        parts = comm.allgather((rows, cols, vals, local))
        rows, cols, vals = (np.concatenate([q[k] for q in parts]) for k in range(3))
        L = np.concatenate([q[3] for q in parts], axis=0)
        N = L.shape[0]
        M = sp.csr_matrix((vals, (rows, cols)), shape=(N, N))
        k = 1 + 2 * m
        AT, sig, lam = L[:, 0], L[:, 1 : 1 + m], L[:, 1 + m : k]
        p, has, act, eps, tol, st = (L[:, k + j] for j in range(6))
        fz = None if imposed is None else (st.astype(np.int64), L[:, k + 6 :])
        return rc.recover_tangential(
            self.tangential_recovery,
            M,
            AT,
            sig,
            lam,
            p,
            has > 0.5,
            act > 0.5,
            self.mu,
            eps,
            fz,
            tol,
        )

    def _add_tangential_jacobian(self, A, c_off, c_idx, c_val) -> None:
        """K_T = Σ_I (G^I)ᵀ ∂t^I/∂u (friction module docstring; G^I the force weights,
        = ∂S^I/∂u where the traction acts at ζ_n) and, with the traction at the current
        projection, the geometric block of ζ's motion (:meth:`_add_force_geometric`);
        non-symmetric. ``_jacobians`` counts this Jacobian already (:meth:`add_jacobian`)."""
        if self.frozen is None:  # the chattering control's freeze is still ahead
            norm = np.linalg.norm(self.tau_law, axis=1)
            dirs = self.tau_law / np.maximum(norm, 1e-300)[:, None]
            slip = self.fstate == fr.SLIP
            # Slip reversal: a node that slipped in opposite directions at two consecutive
            # Jacobians of the solve (s·s_prev < 0) is frozen in STICK (between slip in the
            # old direction and slip in the new one lies stick), and the states freeze at
            # that Jacobian rather than after FREEZE_AFTER. The lumped and, since session
            # 48, the constrained tangential recovery (before, the constrained QP's cone
            # still applied at a node frozen in stick, and the Cattaneo press of the
            # parallel test stopped after 6 cutbacks; recovery.recover_tangential now drops
            # it there). Not the unconstrained one (REVERSAL_RECOVERIES): with the rule, the
            # one-step slide of bench/scenes/slide_one_step2d.toml took a cutback (42 → 91
            # Newton iterations) and friction3d_reversal.toml 574 → 884.
            # docs/method-notes.md, "Chattering control": the hard-case sweep's stick–slip
            # reversal, and why no condition on λ_T since session 25.
            # The first Jacobian of a step's first solve sits at the predictor's state,
            # which carries the last step's slip on: it is not compared (session 41: a
            # press followed by a slide turned half the slave nodes there, which froze
            # them in stick far outside the cone and the solve 2-cycled until max_it).
            # Session 52: in a step that starts deeper than DEEP_PENETRATION_TOL h_I
            # (meshes that overlap at t = 0), an iterate far from equilibrium (an active
            # node that deep, p = ε|γ| of 5 E* or more) is not compared: its states say
            # nothing about the solution's, and the comparisons start afresh at the next
            # Jacobian. A quarter shrink fit (δ = 0.1, μ = 0.3) froze 4 nodes OPEN at the
            # 5th Jacobian on a reversal between the 3rd and the 4th (p ≈ 2600 and 8 at a
            # node), and the re-entry rule let them slip to and fro until max_it. Only
            # such steps: a press's predictor also penetrates that deep (cattaneo2d,
            # ironing2d), where the rule is measured as it was (docs/method-notes.md,
            # "Chattering control").
            reversal = False
            if self.tangential_recovery in REVERSAL_RECOVERIES:
                reversed_ = np.zeros(slip.shape, bool)
                if self._slip_prev is not None:
                    reversed_ |= self._reversed
                    if self._jacobians > 2 or not self._from_predictor:
                        # the slip states and directions of the last Jacobian of this solve
                        was, prev = self._slip_prev
                        reversed_ |= slip & was & (np.einsum("na,na->n", dirs, prev) < 0.0)
                act = self.active
                depth = float(np.max(-self.gamma[act] / self.h_node[act], initial=0.0))
                local = (
                    int(bool(np.any(reversed_ & slip)))
                    | int(depth > DEEP_PENETRATION_TOL) << 1
                    | int(self.deep_start) << 2
                )
                flags = self.comm.allreduce(local, op=MPI.BOR)
                if (flags & 6) == 6:  # far from equilibrium: no comparison, none from here
                    self._slip_prev, self._reversed = None, np.zeros(slip.shape, bool)
                else:
                    self._slip_prev, self._reversed = (slip, dirs), reversed_
                    reversal = bool(flags & 1)
            if self._jacobians >= self.freeze_after or reversal:
                states = self.fstate.copy()
                if reversal:
                    states[self._reversed & slip] = fr.STICK
                if FREE_SLIP_DIRECTIONS and self.gdim == 3:
                    # no node of the pair sticks: fixed directions would leave the pair no
                    # tangential stiffness at all (FREE_SLIP_DIRECTIONS; 3D only)
                    sticks = int(bool(np.any(states[self.active] == fr.STICK)))
                    if not self.comm.allreduce(sticks, op=MPI.BOR):
                        dirs = np.full_like(dirs, np.nan)
                self.frozen = (states, dirs)
        self._learned_t = np.empty(0, np.int64)
        self._add_force_geometric(A)
        mot = None
        mixed = self.tangential_recovery != "lumped" and not self._no_contact
        if self._seg_motion is not None:
            mot = self._segment_slip_motion(A, (self._trec.gamma, self._trec.tau) if mixed else ())
        if mixed:
            self._add_mixed_tangential_jacobian(A, c_off, c_idx, c_val, mot)
            return
        d, m = self.gdim, self.gdim - 1
        fo, fdofs = self.frames.off, self.frames.dofs
        # predictor nodes (nothing in contact yet: tangent-only normal stiffness) get the
        # stick stiffness too, or a body held only by contact would be free tangentially
        hasT = self._has_tangential_area()
        predictor = (
            (self.fstate == fr.OPEN) & (self.kcoef > 0.0) & (self.predictor_nodes > 0) & hasT
        )
        D_stick = self.eps_t[:, None, None] * np.eye(m)
        nodes = np.flatnonzero((self.fstate > 0) | predictor)
        pred = predictor[nodes]
        D0, Pd0 = self._D, self._Pd
        if self._slip_guess is not None:  # the state predictor: this Jacobian only
            guess, Dg, Pdg = self._slip_guess
            self._slip_guess = None
            D0 = np.where(guess[:, None, None], Dg, D0)
            Pd0 = np.where(guess[:, None], Pdg, Pd0)
        D = np.where(pred[:, None, None], D_stick[nodes], D0[nodes])
        Pd = np.where(pred[:, None], 0.0, Pd0[nodes])
        # ∂p_N/∂u = −kN × row: the lumped kcoef B^I, or the row of Lᵀ diag(d) R B of the
        # constrained recovery (kN = 1)
        constrained = ~pred if self._dp_rows is not None else np.zeros(nodes.size, bool)
        kN = np.where(constrained, 1.0, self.kcoef[nodes])
        rows = []
        for node, con in zip(nodes, constrained, strict=True):
            if con:
                r = self._dp_rows
                sl = slice(r.indptr[node], r.indptr[node + 1])
                rows.append((r.indices[sl].astype(np.int64), r.data[sl]))
            elif predictor[node]:
                sl = slice(c_off[node], c_off[node + 1])
                rows.append((c_idx[sl], c_val[sl]))
            else:
                rows.append(self._dp_lumped(node, c_off, c_idx, c_val))
        if mot is None:  # all nodes at once (numba)
            b_off = np.zeros(nodes.size + 1, np.int64)
            b_off[1:] = np.cumsum([r[0].size for r in rows])
            cat = [np.empty(0, np.int64)] + [r[0] for r in rows]
            args = (
                nodes,
                self.frame_a,
                self.S,
                self.AT,
                self.tau,
                D,
                Pd,
                kN,
                self.s_off,
                self.s_dof,
                self.s_w,
                self.s_g,
                fo,
                fdofs,
                self.frame_dA,
                b_off,
                np.concatenate(cat).astype(np.int64),
                np.concatenate([np.empty(0)] + [r[1] for r in rows]),
            )
            # ∂p^I/∂u of the constrained recovery reaches the whole paired region (M⁻¹):
            # the rows of S^I only there, not the square block (session 53)
            rows_only = bool(constrained.any())
            u_off, U, r_off, R, k_off, K = kfriction.node_tangent_blocks(not rows_only, *args)
            if rows_only:
                add_row_blocks(A, u_off, U, r_off, R, k_off, K)
            else:
                add_square_blocks(A, u_off, U, k_off, K)
            return
        for i, node in enumerate(nodes):  # segment integration: the moving points too
            s, e = self.s_off[node], self.s_off[node + 1]
            ps, pe = fo[node], fo[node + 1]
            U, K = fr.node_tangent(
                self.frame_a[node],
                self.S[node],
                self.AT[node],
                self.tau[node],
                D[i],
                Pd[i],
                kN[i],
                self.s_dof[s:e],
                self.s_w[s:e],
                fdofs[ps:pe].reshape(-1, d),
                self.frame_dA[ps:pe].reshape(-1, m, d, d),
                rows[i][0],
                rows[i][1],
                self._moving_rows(mot, node),
                self.s_g[s:e],
            )
            if U.size and constrained.any():
                self._add_slip_rows(A, node, U, K)
            elif U.size:
                idx = U.astype(PETSc.IntType)
                A.setValues(idx, idx, K, addv=PETSc.InsertMode.ADD_VALUES)

    def _add_force_geometric(self, A) -> None:
        """The geometric tangent block of the traction at the current projection (local):
        Σ_q Σ_I (−w_q J₀ Ψ_I) t^I ⊗ ∂_γN^m_b(ζ_q) ∂ζ_q^γ/∂u on the current master facet's
        rows (:func:`.kernels.friction.force_geometric_blocks`; with segment integration
        at fixed ξ_q, the points' own motion is :meth:`_segment_slip_motion`'s). Only where
        :attr:`force_at_current`, and left out with the normal part's geometric block
        (:meth:`_drop_geometric_tangent`, DEEP_PENETRATION_TOL): kept, the second press
        step of demo_cattaneo2d took 13 Newton iterations instead of 9 (study54-S)."""
        if not (self.force_at_current and self._geometric_on) or not self.slave.num_facets:
            return
        rows, cols, K = kfriction.force_geometric_blocks(
            self.ftype,
            self.master.ftype,
            self.ftype_phi,
            self.xs,
            self.xm,
            self.qp_xi,
            self.qp_w,
            self.qp_m,
            self.qp_mn,
            self.qp_zeta,
            self.node_of,
            self.node_touching,
            self.t_weights,
            self.dual_on,
            self.slave.dofs,
            self.master.dofs,
            self.t_vec,
        )
        if rows.shape[0]:
            A.setValuesRCV(
                rows.astype(PETSc.IntType),
                cols.astype(PETSc.IntType),
                K,
                addv=PETSc.InsertMode.ADD_VALUES,
            )

    def _add_slip_rows(self, A, node: int, U: np.ndarray, K: np.ndarray) -> None:
        """A[R, U] += K[R, :] for the friction tangent K = (G^I)ᵀ ∂t^I/∂u (U, U) of one
        node (:func:`.friction.node_tangent`), R the dofs of its S-weights: the only rows
        that can be nonzero (as :func:`.kernels.friction.node_tangent_blocks`; local)."""
        sd = self.s_dof[self.s_off[node] : self.s_off[node + 1]].ravel()
        r = np.flatnonzero(np.isin(U, sd[sd >= 0]))
        if r.size:
            A.setValues(
                U[r].astype(PETSc.IntType),
                U.astype(PETSc.IntType),
                K[r],
                addv=PETSc.InsertMode.ADD_VALUES,
            )

    def _dp_lumped(self, node, c_off, c_idx, c_val) -> tuple[np.ndarray, np.ndarray]:
        """Lumped normal recovery: the row of ∂p^I = −(ε^I/A^I) row as (dofs, values): B^I,
        plus C^I with segment integration (the points move, :meth:`_add_segment_jacobian`)."""
        sl = slice(c_off[node], c_off[node + 1])
        if self._seg_c_rows is None:
            return c_idx[sl], c_val[sl]
        r = self._seg_c_rows
        sc = slice(r.indptr[node], r.indptr[node + 1])
        return np.concatenate([c_idx[sl], r.indices[sc]]), np.concatenate([c_val[sl], r.data[sc]])

    def _segment_slip_motion(self, A, values=()) -> dict:
        """Segment integration: the motion of the points in the slip integrals (local).

        A point q of weight w_q at ξ_q contributes w_q Ψ_I(ξ_q) to A_T^I, w_q Ψ_I Δg(ξ_q) to
        S^I and the residual weights W_Ia = w_q Ψ_I N_a(ξ_q) (slave node a), W_Ib =
        −w_q Ψ_I N^m_b(ζ_n(ξ_q)) (node b of the t_n master facet), :mod:`.kernels.friction`.
        With dξ_q, dw_q of :meth:`_segment_motion` and the point terms of
        :func:`.kernels.friction.slip_point_terms`:

            dA_T^I = Ψ_I dw + w ∂_βΨ_I dξ^β,   dS^I = Δg dA_T^I + w Ψ_I ∂_βΔg dξ^β,
            dS_n^I = d_n dA_T^I + w Ψ_I ∂_βd_n dξ^β   (the t_n gap vector d_n, S_n's weights),
            dW_Ia = N_a dA_T^I + w Ψ_I ∂_βN_a dξ^β,
            dW_Ib = −(N^m_b dA_T^I + w Ψ_I ∂_β[N^m_b(ζ_n)] dξ^β),
            dG_Ib = −(N^m_b(ζ) dA_T^I + w Ψ_I ∂_β[N^m_b(ζ)] dξ^β)   (the current facet's b),

        summed over the points of each (slave facet, master facet) by
        :func:`.kernels.friction.slip_motion_blocks`. Adds Σ_I t^I ⊗ dG_I (the variation of
        the residual's force weights G, R_T = Σ_I Gᵀ t^I, through the moving points: slave
        part dW_Ia, master part dG_Ib at the current projection ζ(ξ) of the moving point,
        ∂ζ/∂ξ at fixed nodes; dW_Ib where the traction acts at ζ_n, :attr:`force_at_current`)
        to ``A``; the part of ζ's motion at fixed ξ is :meth:`_add_force_geometric`'s.
        For nodal ``values`` (each (N, m), all nodes, global numbering), also
        (∂M v)^I = v_h dA_T^I + w Ψ_I ∂_β v_h dξ^β with v_h = Σ_J Φ_J v^J, or v^I on a
        facet whose block of M is lumped
        (:meth:`_tangential_mass`): the consistent tangential recoveries need them.

        Returns the entries e = (facet, master facet, node I): ``node`` (E,), ``cols``
        (E, nloc) global dofs, ``dsig`` (E, m, nloc) the moving points' part of the slip
        since t_n, ∂σ^I = a^I·dS^I − a_n^I·dS_n^I (:meth:`_slip_since_t_n`), ``dAT``
        (E, nloc), ``dMv`` (len(values), E, m, nloc), and the rows of ∂σ^I and ∂A_T^I
        summed per node as CSR ``dsig_rows`` (n·m, ndof), ``dAT_rows`` (n, ndof).
        """
        dxi, dw = self._seg_motion
        current = self.force_at_current
        n_rows = dw.shape[0]
        ns, nm, d = self.slave.nodes_per_facet, self.master.nodes_per_facet, self.gdim
        k, m = d - 1, d - 1
        nphi = self.node_of.shape[1]
        dg, dgxi = np.zeros((n_rows, d)), np.zeros((n_rows, k, d))
        dgn, dgxin = np.zeros((n_rows, d)), np.zeros((n_rows, k, d))
        Ns, dNs = np.zeros((n_rows, ns)), np.zeros((n_rows, ns, k))
        Nm, dNm = np.zeros((n_rows, nm)), np.zeros((n_rows, nm, k))
        Nc, dNc = np.zeros((n_rows, nm)), np.zeros((n_rows, nm, k))
        psi, dpsi = np.zeros((n_rows, nphi)), np.zeros((n_rows, nphi, k))
        phi, dphi = np.zeros((n_rows, nphi)), np.zeros((n_rows, nphi, k))
        if n_rows:
            kfriction.slip_point_terms(
                self.ftype,
                self.master.ftype,
                self.ftype_phi,
                self.xs,
                self.xm,
                *self._x_n,
                self.qp_xi,
                self.qp_w,
                self.qp_m,
                self.qp_mn,
                self.qp_zn,
                self.qp_zeta,
                self.t_weights,
                self.dual_on,
                current,
                dg,
                dgxi,
                dgn,
                dgxin,
                Ns,
                dNs,
                Nm,
                dNm,
                Nc,
                dNc,
                psi,
                dpsi,
                phi,
                dphi,
            )
        fr_, qr = np.nonzero(self.qp_m >= 0)
        mr, mn = self.qp_m[fr_, qr], self.qp_mn[fr_, qr]
        w = self.qp_w[fr_, qr]
        nmf = self.master.num_facets
        k1, g1 = np.unique(fr_ * nmf + mr, return_inverse=True)
        k2, g2 = np.unique((fr_ * nmf + mr) * nmf + np.maximum(mn, 0), return_inverse=True)
        nodes = self.node_of[fr_]
        slot_node = np.where(self.node_touching[np.maximum(nodes, 0)], nodes, -1)
        used = (mn >= 0) & (w != 0.0)  # the points of the slip integrals
        # the force weights' own points (paired now, not at t_n: slip_integrals)
        g_only = (mn < 0) & (w != 0.0) & current
        # the nodal values seen by each slot (lumped facets: the slot's own value)
        nv = len(values)
        vh, dvh = np.zeros((nv, n_rows, nphi, m)), np.zeros((nv, n_rows, nphi, k, m))
        lump = self._tangential_partial()[fr_] if nv else None
        for v, val in enumerate(values):
            vals = val[self.facet_gid[fr_]]  # (n_rows, nphi, m)
            vh[v] = np.where(
                lump[:, None, None], vals, np.einsum("ri,ria->ra", phi, vals)[:, None, :]
            )
            dvh[v] = np.where(
                lump[:, None, None, None], 0.0, np.einsum("rib,ria->rba", dphi, vals)[:, None]
            )
        nloc = (ns + nm) * d
        dS = np.zeros((k1.size, nphi, d, nloc))
        dSn = np.zeros((k1.size, nphi, d, nloc))
        dAT = np.zeros((k1.size, nphi, nloc))
        tw = np.zeros((k2.size, nloc, nloc))
        dMv = np.zeros((nv, k1.size, nphi, m, nloc))
        kfriction.slip_motion_blocks(
            g1,
            g2,
            slot_node,
            used,
            g_only,
            self.t_vec,
            w,
            dxi,
            dw,
            dg,
            dgxi,
            dgn,
            dgxin,
            Ns,
            dNs,
            *((Nc, dNc) if current else (Nm, dNm)),
            psi,
            dpsi,
            vh,
            dvh,
            dS,
            dSn,
            dAT,
            tw,
            dMv,
        )
        # Σ_I t^I ⊗ dG_I: rows [slave facet dofs, master facet dofs: the current one where
        # the traction acts at ζ, else the t_n one], columns the local dofs [slave facet,
        # current master facet]
        f2, rest = np.divmod(k2, nmf * nmf)
        m2, mn2 = np.divmod(rest, nmf)
        add_keyed_blocks(
            A,
            np.arange(k2.size),
            np.concatenate([self.slave.dofs[f2], self.master.dofs[m2 if current else mn2]], axis=1),
            np.concatenate([self.slave.dofs[f2], self.master.dofs[m2]], axis=1),
            tw,
        )
        # the entries (group, slot) of a node taking part
        f1, m1 = np.divmod(k1, nmf)
        moved = np.any(dS != 0.0, axis=(2, 3)) | np.any(dSn != 0.0, axis=(2, 3))
        gg, ii = np.nonzero(np.any(dAT != 0.0, axis=2) | moved)
        node = self.node_of[f1[gg], ii]
        cols = np.concatenate([self.slave.dofs[f1], self.master.dofs[m1]], axis=1)[gg]
        # ∂σ = a·dS − a_n·dS_n of the moving points (σ of _slip_since_t_n)
        dsig = np.einsum("eac,ecj->eaj", self.frame_a[node], dS[gg, ii]) - np.einsum(
            "eac,ecj->eaj", self.frame_a_n[node], dSn[gg, ii]
        )
        dAT, dMv = dAT[gg, ii], dMv[:, gg, ii]
        n, ndof = self.node_blocks.size, int(self.ranges[-1]) * self.bs
        keep = cols >= 0
        en = np.broadcast_to(node[:, None], cols.shape)[keep]
        dsig_rows = sp.csr_matrix(
            (
                dsig.transpose(1, 0, 2)[:, keep].ravel(),
                ((en[None, :] * m + np.arange(m)[:, None]).ravel(), np.tile(cols[keep], m)),
            ),
            shape=(n * m, ndof),
        )
        dAT_rows = sp.csr_matrix((dAT[keep], (en, cols[keep])), shape=(n, ndof))
        order = np.argsort(node, kind="stable")
        return {
            "node": node,
            "cols": cols,
            "dsig": dsig,
            "dAT": dAT,
            "dMv": dMv,
            "dsig_rows": dsig_rows,
            "dAT_rows": dAT_rows,
            "order": order,
            "off": np.searchsorted(node[order], np.arange(n + 1)),
        }

    @staticmethod
    def _entries_of(mot: dict, node: int) -> np.ndarray:
        """The entries of :meth:`_segment_slip_motion` that belong to ``node``."""
        return mot["order"][mot["off"][node] : mot["off"][node + 1]]

    def _moving_rows(self, mot: dict, node: int):
        """``moving`` of :func:`.friction.node_tangent` for one node, or None."""
        m = self.gdim - 1
        rows, at = mot["dsig_rows"][node * m : (node + 1) * m], mot["dAT_rows"][node]
        dofs = np.union1d(rows.indices, at.indices)
        if not dofs.size:
            return None
        return dofs, rows[:, dofs].toarray(), at[:, dofs].toarray()[0], self.sigma_t[node]

    def _add_mixed_tangential_jacobian(self, A, c_off, c_idx, c_val, mot=None) -> None:
        """K_T = Σ_I (G^I)ᵀ [a^Iᵀ ∂τ^I + τ^I_α ∂a^I_α] (G^I the force weights, ∂S^I/∂u
        where the traction acts at ζ_n; :attr:`force_at_current`) for the consistent
        tangential recoveries, ∂τ = Tsig ∂σ + Tp ∂p (:func:`.recovery.recover_tangential`), with
        ∂σ^K_α = a^K_α·∂S^K + S^K·∂a^K_α (:meth:`_slip_since_t_n`: a_n·S_n is constant at
        fixed points) and ∂p^K = −(row of the normal recovery). The rows ∂σ^K and ∂p^K of
        every node are gathered (collective); non-symmetric.

        Segment integration (``mot`` from :meth:`_segment_slip_motion`): ∂σ^K has the
        part of the moving points, a·∂S − a_n·∂S_n, and M and A_T move too, ∂τ = Tsig(∂σ − ∂M γ) + Tp ∂p
        + TF(τ̂ ∂A_T − ∂M τ); the rows τ̂ ∂A_T − ∂M τ are gathered as well."""
        comm, rec = self.comm, self._trec
        d, m, bs = self.gdim, self.gdim - 1, self.bs
        n, lo = self.node_blocks.size, self.gid_offset
        N = rec.tau.shape[0]
        ndof = int(self.ranges[-1]) * bs
        fo, fdofs = self.frames.off, self.frames.dofs
        hasT = self._has_tangential_area()
        trip_s, trip_p, trip_f, local_rows = [], [], [], {}
        if mot is not None:
            dMg, dMt = mot["dMv"]  # (E, m, nloc): ∂M γ and ∂M τ
        for node in np.flatnonzero(hasT):
            s, e = self.s_off[node], self.s_off[node + 1]
            ps, pe = fo[node], fo[node + 1]
            U, pos, Srow, Frow = fr.node_rows(
                self.s_dof[s:e],
                self.s_w[s:e],
                fdofs[ps:pe].reshape(-1, d),
                self.frame_dA[ps:pe].reshape(-1, m, d, d),
            )
            nu = U.size
            Grow = fr.weight_rows(pos, self.s_dof[s:e], self.s_g[s:e], nu)
            local_rows[node] = (U, Grow, Frow[:, :, :nu])
            Gr = self.frame_a[node] @ Srow[:, :nu] + np.einsum(
                "c,acu->au", self.S[node], Frow[:, :, :nu]
            )
            g = lo + node
            for a in range(m):
                trip_s.append((np.full(nu, g * m + a), U, Gr[a]))
            sel = np.empty(0, np.int64) if mot is None else self._entries_of(mot, node)
            if sel.size:
                cols = mot["cols"][sel].ravel()
                keep = cols >= 0
                dsig = mot["dsig"][sel] - dMg[sel]
                dF = self._trec.tau_hat[g][None, :, None] * mot["dAT"][sel][:, None, :] - dMt[sel]
                for a in range(m):
                    rows_a = np.full(int(keep.sum()), g * m + a)
                    trip_s.append((rows_a, cols[keep], dsig[:, a].ravel()[keep]))
                    trip_f.append((rows_a, cols[keep], dF[:, a].ravel()[keep]))
            if self._dp_rows is not None:
                r = self._dp_rows
                sl = slice(r.indptr[node], r.indptr[node + 1])
                trip_p.append((np.full(sl.stop - sl.start, g), r.indices[sl], -r.data[sl]))
            else:
                b_idx, b_val = self._dp_lumped(node, c_off, c_idx, c_val)
                keep = b_idx >= 0
                trip_p.append(
                    (np.full(int(keep.sum()), g), b_idx[keep], -self.kcoef[node] * b_val[keep])
                )

        def gathered(trips, nrows):
            mine = [
                np.concatenate([t[k] for t in trips]) if trips else np.empty(0) for k in range(3)
            ]
            parts = comm.allgather(mine)
            r, c, v = (np.concatenate([q[k] for q in parts]) for k in range(3))
            return sp.csr_matrix((v, (r.astype(np.int64), c.astype(np.int64))), shape=(nrows, ndof))

        Gm = gathered(trip_s, N * m)
        Pm = gathered(trip_p, N)
        own = np.arange(lo * m, (lo + n) * m)
        dtau = sp.csr_matrix(rec.Tsig[own]) @ Gm + sp.csr_matrix(rec.Tp[own]) @ Pm
        if self.integration == "segment":  # on every rank (collective)
            dtau = dtau + sp.csr_matrix(rec.TF[own]) @ gathered(trip_f, N * m)
        dtau = dtau.tocsr()
        keys, nb = [], int(self.ranges[-1])
        for node, (U, Grow, Frow) in local_rows.items():
            rows = dtau[node * m : (node + 1) * m]
            V = np.union1d(rows.indices, U)
            dt = self.frame_a[node].T @ rows[:, V].toarray()
            jU = np.searchsorted(V, U)
            dt[:, jU] += np.einsum("a,acu->cu", self.tau[node], Frow)
            K = Grow.T @ dt
            A.setValues(
                U.astype(PETSc.IntType),
                V.astype(PETSc.IntType),
                K,
                addv=PETSc.InsertMode.ADD_VALUES,
            )
            ub, vb = np.unique(U // bs), np.unique(V // bs)
            keys.append((ub[:, None] * nb + vb[None, :]).ravel())
        self._learned_t = np.unique(np.concatenate(keys)) if keys else np.empty(0, np.int64)

    def state_prediction_wanted(self) -> bool:
        """Whether the next Jacobian is a load step's first (that of its first Newton solve)
        and may get the state predictor (:meth:`guess_slip`; local): friction with the
        lumped tangential recovery, no states frozen, and a node sticking under pressure."""
        if not (self.frictional and self.tangential_recovery == "lumped"):
            return False
        if self._solves != 1 or self._jacobians != 0 or self.frozen is not None:
            return False
        return bool(np.any((self.fstate == fr.STICK) & (self.p > 0.0)))

    def trial_traction(self) -> tuple[np.ndarray, np.ndarray]:
        """The trial traction λ_T + ε_T γ (n, m) and the pressure p_N (n,) of the last
        update (local)."""
        return self.lmbda_t + self.eps_t[:, None] * self.gamma_t, self.p.copy()

    def guess_slip(self, pred: tuple[np.ndarray, np.ndarray]) -> bool:
        """The state predictor of a load step's first Jacobian (collective: every rank
        calls it, with the same answer). ``pred``: the trial tractions λ_T + ε_T γ (n, m)
        and pressures p_N (n,) at the end of the Newton step from this state (u_n) with
        its stick tangent (:meth:`trial_traction`, read there). The pair is judged to go
        into gross slip where, over the nodes that stick under pressure here,

        - every trial traction leaves the cone of its pressure here:
          |τ^tr| > (1 + SLIP_GUESS_MARGIN) μ p_N(u_n);
        - the pair's trial shear leaves the cone of its trial pressure:
          |Σ A_T τ^tr| > SLIP_GUESS_PAIR_RATIO μ Σ A_T p_N^tr (a trial step that
          overshoots the cone by little is a good enough first step);
        - the trial step keeps the load: Σ A_T p_N^tr ≥ SLIP_GUESS_LOAD_FLOOR Σ A_T p_N(u_n)
          (a pair that the trial step unloads, e.g. a node the ironing punch leaves,
          has p_N^tr ≈ 0 and a meaningless ratio).

        Then those nodes get, in the next Jacobian only, the slip tangent of the return
        map at their trial traction, D = μ p_N ε_T/|τ^tr| (I − s⊗s) (m, m) and
        ∂τ/∂p_N = μ s (m,), s = τ^tr/|τ^tr|; the residual and the states stay those of
        this state. Returns whether a node here got it (local).

        At the start of a step that slides every node sticks (its slip since t_n is 0),
        and the stick tangent's Newton step loads the interface with ε_T times the whole
        step's slip: on the 2D block of docs/method-notes.md (Friction, "Session 49:
        the state predictor")
        trial tractions of 17.6 to 24 times μ p_N (median 20.9), whose moment lifts the
        block's trailing nodes."""
        self._slip_guess = None
        trial, p_trial = pred
        norm = np.linalg.norm(trial, axis=1)
        p = np.maximum(self.p, 0.0)
        stick = (self.fstate == fr.STICK) & (p > 0.0)
        if not self.state_prediction_wanted():
            stick[:] = False
        out = stick & (norm > (1.0 + SLIP_GUESS_MARGIN) * self.mu * p)
        At = np.where(stick, self.AT, 0.0)
        loc = np.concatenate(
            [
                [stick.sum(), out.sum(), (At * p).sum(), (At * np.maximum(p_trial, 0.0)).sum()],
                (At[:, None] * trial).sum(axis=0),
            ]
        )
        tot = self.comm.allreduce(loc)
        n_stick, n_out, load, load_trial = tot[:4]
        shear = np.linalg.norm(tot[4:])
        if n_stick == 0 or n_out < n_stick or not load_trial >= SLIP_GUESS_LOAD_FLOOR * load:
            return False
        ratio = shear / (self.mu * load_trial)
        log.debug(
            "state predictor: %d sticking node(s), trial shear %.3g μ F_N^tr, F_N^tr/F_N %.3g",
            n_stick, ratio, load_trial / load,
        )  # fmt: skip
        if not ratio > SLIP_GUESS_PAIR_RATIO:
            return False
        m = trial.shape[1]
        s = trial / np.maximum(norm, 1e-300)[:, None]
        D = (self.mu * p * self.eps_t / np.maximum(norm, 1e-300))[:, None, None] * (
            np.eye(m) - np.einsum("ni,nj->nij", s, s)
        )
        self._slip_guess = (out, D, self.mu * s)
        return bool(out.any())
