"""LoadStepper's step control on a stand-in problem (no PDE): cutbacks, the predictor
retry and the smallest step, with a Newton solver that fails on demand."""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_mortar import solver as solver_module
from dolfinx_mortar.errors import ConvergenceError, FrozenStatesError
from dolfinx_mortar.solver import LoadStepper, NewtonSolver, SolverSettings


class _Array:
    def __init__(self, n):
        self.array = np.zeros(n)


class _U:
    def __init__(self, n):
        self.x = _Array(n)


class _Problem:
    """Holds u(t) = t (one dof) and the hooks LoadStepper calls."""

    def __init__(self):
        self.u = _U(1)
        self.t = 0.0
        self.timings = {"search": 0.0, "contact_assembly": 0.0, "bulk_assembly": 0.0}
        self.committed = []
        self.carrying_states = False

    def set_time(self, t):
        self.t = t

    def increment_norm(self, u_old):
        return float(abs(self.u.x.array[0] - u_old[0]))

    def begin_step(self):
        pass

    def uzawa_update(self):
        return True, {}

    def commit_step(self):
        self.committed.append(self.t)

    def restore_step(self):
        pass

    def carry_states(self, on):
        self.carrying_states = on


class _Newton:
    """Converges when the step is at most ``limit(t_start)``; records the step sizes."""

    def __init__(self, problem, limit):
        self.problem, self.limit = problem, limit
        self.timings = {"linear_solve": 0.0}
        self.start = 0.0
        self.full_step_solves = 0
        self.full_step_restarts = 0
        self.backtracked_solves = 0
        self.reused_factorizations = 0
        self.failed_reuses = 0
        self.ldlt_fallbacks = 0
        self.limited_steps = 0
        self.state_predictions = 0
        self.linear_iterations = 0
        self.all_iterations = 0

    def solve(self, rtol=None, dtol=None, rescue=True, reuse=False, force=False, full_steps=False):
        p = self.problem
        t0 = p.committed[-1] if p.committed else 0.0
        if p.t - t0 > self.limit(t0):
            raise ConvergenceError("too big a step")
        p.u.x.array[:] = p.t
        self.all_iterations += 1
        return 1, [1.0, 1e-12]


def test_cutbacks_then_success():
    p = _Problem()
    stepper = LoadStepper(p, _Newton(p, lambda t0: 0.1), 1.0, 2, max_cutbacks=3)
    results = stepper.run()
    assert p.committed[-1] == pytest.approx(1.0)
    assert all(b - a <= 0.1 + 1e-12 for a, b in zip([0.0] + p.committed, p.committed, strict=False))
    assert results[0].cutbacks == 3  # 0.5 -> 0.25 -> 0.125 -> 0.0625


def test_steps_never_shorter_than_max_cutbacks_halvings_of_the_load_step():
    """Steps that must shrink without bound towards a target (each converged step makes
    the next harder: no solution beyond t = 0.5) stop once a cutback would make a step
    shorter than 2^-max_cutbacks of the load step, with every converged step committed.
    Each converged cutback reset the count of cutbacks in a row, so the run crept
    towards the target before, one failed attempt of it per converged step, down to the
    minimum step (``bench/scenes/block3d_over_corner.toml``: 49 steps, BENCHMARKS §43)."""
    p = _Problem()
    stepper = LoadStepper(p, _Newton(p, lambda t0: 0.5 * (0.5 - t0)), 1.0, 1, max_cutbacks=6)
    with pytest.raises(
        ConvergenceError,
        match=r"step to t = 0.5 failed after 0 cutbacks from t = 0.484375, and another would "
        r"make the step shorter than 1/2\^6 of the load step \(1; max_cutbacks = 6\)",
    ):
        stepper.run()
    assert p.committed == pytest.approx([0.25, 0.375, 0.4375, 0.46875, 0.484375])
    assert min(np.diff([0.0, *p.committed])) >= 1 / 64


def test_a_large_max_cutbacks_halves_as_any_other():
    """max_cutbacks = 2000 (any integer >= 0 is a valid scene value): the bound of the
    shortest step, 2^-2000 of the load step, underflows to 0 instead of raising
    OverflowError at the first cutback."""
    p = _Problem()
    LoadStepper(p, _Newton(p, lambda t0: 0.1), 1.0, 1, max_cutbacks=2000).run()
    assert p.committed[-1] == pytest.approx(1.0)


def test_shrinking_steps_stop_cleanly_at_the_minimum_step():
    """Cutbacks in a row that reach the minimum step end in ConvergenceError, not in a
    zero-length step (a ZeroDivisionError in the predictor before)."""
    p = _Problem()
    stepper = LoadStepper(p, _Newton(p, lambda t0: 1e-12), 1.0, 1, max_cutbacks=60)
    with pytest.raises(ConvergenceError, match="cannot be halved further"):
        stepper.run()
    assert p.committed == []


@pytest.mark.mpi
def test_a_run_that_stops_with_every_contact_open_says_so(shared_tmp):
    """The coarse hertz2d scene with its load reversed pulls the cylinder off the block:
    the cylinder is held only by contact (and the symmetry plane), Newton cannot reduce
    the load, and every cutback fails. The run stops cleanly, and its error names the
    open pair and the likely cause, the direction of the load."""
    from test_contact_parallel import HERTZ2D

    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    data = {
        **HERTZ2D,
        "traction": [{"boundary": "cylinder_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.625]]}],
        "steps": {"n": 2, "max_cutbacks": 1},
    }
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=shared_tmp)
    assert s["status"] == "failed" and s["steps"] == []
    assert "failed after 1 cutbacks" in s["error"], s["error"]
    assert "no slave node of cylinder_surface:block_top was in contact" in s["error"]
    assert "check the direction of the loads" in s["error"]
    assert "faces its master surface" not in s["error"]


@pytest.mark.mpi
def test_sigterm_on_one_rank_stops_every_rank_at_the_same_iteration(shared_tmp):
    """SIGTERM that reaches rank 0 only (sent from its progress callback after step 1)
    stops the run on every rank at the next Newton iteration (errors.check_stop: one
    allreduce in the SNES monitor; an exception raised in the handler would have left the
    other ranks in a collective): Terminated (SystemExit 143) on every rank, summary.json
    "failed" with step 2 named and step 1 kept, the default handler back afterwards. A
    host's own SIGTERM handler stays in force during a run (it is called; the run ends
    "ok"): the first 2 of the 4 steps (the same steps; session 60, the whole path
    before: steps 3 and 4 asserted nothing more)."""
    import json
    import os
    import signal

    from test_contact_parallel import HERTZ2D

    from dolfinx_mortar.errors import Terminated
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    comm = MPI.COMM_WORLD
    scene = parse_scene({**HERTZ2D, "steps": {"n": 4}}, shared_tmp)

    def progress(step, record):
        if step == 1 and comm.rank == 0:
            os.kill(os.getpid(), signal.SIGTERM)

    previous = signal.signal(signal.SIGTERM, signal.SIG_DFL)  # whatever the test runner set
    try:
        with pytest.raises(Terminated) as info:
            run(scene, comm, out_dir=shared_tmp / "term", progress=progress)
        assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL
        caught = []
        signal.signal(signal.SIGTERM, lambda signum, frame: caught.append(signum))
        half = parse_scene({**HERTZ2D, "steps": {"n": 2, "t_end": 0.5}}, shared_tmp)
        s = run(half, comm, out_dir=shared_tmp / "host", progress=progress)
        assert s["status"] == "ok" and [r["t"] for r in s["steps"]] == [0.25, 0.5]
        assert caught == ([signal.SIGTERM] if comm.rank == 0 else [])
    finally:
        signal.signal(signal.SIGTERM, previous)
    expected = "terminated by SIGTERM during step 2; steps 1..1 kept (to t = 0.25)"
    assert info.value.code == 143 and info.value.message == expected
    summary = json.loads((shared_tmp / "term" / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["error"] == expected
    assert [r["t"] for r in summary["steps"]] == [0.25]
    assert "unfinished" in summary["timings"]


@pytest.mark.mpi
def test_a_run_whose_surfaces_never_face_says_so(shared_tmp):
    """The coarse hertz2d scene with the cylinder 5 (20 facets) above the block: no
    slave point projects onto the master within the search distance, the cylinder falls
    freely, and every cutback fails. The error says the surfaces do not face each other
    (it blamed the direction of the loads, which are right). 1–3 ranks."""
    from test_contact_parallel import HERTZ2D

    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    mesh = {"generator": "hertz2d", "params": {**HERTZ2D["mesh"]["params"], "gap0": 5.0}}
    data = {**HERTZ2D, "mesh": mesh, "steps": {"n": 2, "max_cutbacks": 1}}
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=shared_tmp)
    assert s["status"] == "failed" and s["steps"] == []
    assert "no slave point of cylinder_surface:block_top faces its master surface" in s["error"], s[
        "error"
    ]
    assert "the bodies' positions" in s["error"]
    assert "direction of the loads" not in s["error"]


def _coarse_press_slide(
    integration: str = "segment", margin: float = 0.0, slide: float | None = 0.02
) -> dict:
    """patch2d with 3 × 4 elements (slave facets 0.25 long), one through the thickness,
    linear-elastic, small strain, μ = 0.3: a press of 0.01 in 2 steps, then a slide of
    ``slide`` (None: none) in 2. With the slave's ends on the master's (``margin`` 0) the
    slide takes the slave's right end across the master's edge; with segment integration
    it completes since session 52 (it stalled in its first slide step while the dual
    tangential weights' choice switched at that end: docs/method-notes.md, "Segment
    integration")."""
    path = [[0.0, 0.0, 0.0], [1.0, 0.0, -0.01]] + ([[2.0, slide, -0.01]] if slide else [])
    return {
        "mesh": {
            "generator": "patch2d",
            "params": {"n_lower": 3, "n_upper": 4, "n_y": 1, "margin": margin},
        },
        "kinematics": "small",
        "material": [
            {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3}
            for r in ("lower", "upper")
        ],
        "contact": [
            {
                "slave": "upper_bottom",
                "master": "lower_top",
                "friction": 0.3,
                "integration": integration,
            }
        ],
        "dirichlet": [
            {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
            {"boundary": "upper_top", "path": path},
        ],
        "steps": {"t_end": 2.0 if slide else 1.0, "n": 4 if slide else 2, "max_cutbacks": 1},
    }


@pytest.mark.mpi
def test_a_run_that_stalls_across_the_master_edge_says_so(shared_tmp):
    """A run that stops with a slave facet in contact across the master surface's edge
    (segment integration) says so. The scenario fails by an honest limit: the coarse
    press, then a slide of 0.2 in 2 steps (0.1 a step, 40 % of a slave facet) with
    ``solver.max_it`` = 4 and no cutback. The first slide step needs 13 Newton iterations
    (measured, max_it 25); 4 allow 8 (4 with line search l2, then 4 full steps), so it
    stops there with the slave's right end across the master's edge (its left end slid
    inside). The press steps are kept; the error names the facet and the ways around
    it. (Until session 52 the coarse slide of 0.02 stalled here by itself, a 2-cycle at
    every cutback: the dual tangential weights' choice switched at that end from one
    iterate to the next; it completes now.)"""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    data = _coarse_press_slide(slide=0.2)
    data["steps"]["max_cutbacks"] = 0
    data["solver"] = {"max_it": 4}
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=shared_tmp)
    assert s["status"] == "failed", s.get("error")
    assert [st["t"] for st in s["steps"]] == [0.5, 1.0]
    assert "step to t = 1.5 failed after 0 cutbacks" in s["error"], s["error"]
    assert "DIVERGED_MAX_IT" in s["error"], s["error"]
    assert (
        "; 1 slave facet of upper_bottom:lower_top in contact across the master surface's edge"
        in s["error"]
    ), s["error"]
    assert "has a kink, which may have stopped Newton" in s["error"], s["error"]
    assert 'integration = "element", or a master surface that extends beyond' in s["error"]


def _svk_press_slide(integration: str, penalty: float, press: float, slide: float) -> dict:
    """patch2d (6 | 7 elements, 2 through the thickness, the master 0.2 wider than the
    slave on each side), Saint Venant–Kirchhoff blocks (E = 100), μ = 0.5, lumped
    recovery, pure penalty (uzawa_tol 0): a press of ``press`` at t = 1, then a slide of
    ``slide`` at t = 2, in steps of 0.5 with 4 cutbacks. SVK is finite and stress-free at
    det F = −1 (a mirrored element), so Newton can converge to a folded state."""
    mat = {"model": "saint-venant-kirchhoff", "E": 100.0, "nu": 0.3}
    path = [[0.0, 0.0, 0.0], [1.0, 0.0, -press], [2.0, slide, -press]]
    return {
        "kinematics": "finite",
        "mesh": {
            "generator": "patch2d",
            "params": {"n_lower": 6, "n_upper": 7, "n_y": 2, "margin": 0.2},
        },
        "material": [{"region": r, **mat} for r in ("lower", "upper")],
        "contact": [
            {
                "slave": "upper_bottom",
                "master": "lower_top",
                "friction": 0.5,
                "integration": integration,
                "recovery": "lumped",
                "penalty": penalty,
                "uzawa_tol": 0.0,
            }
        ],
        "dirichlet": [
            {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
            {"boundary": "upper_top", "path": path},
        ],
        "steps": {"t_end": 2.0 if slide else 1.0, "n": 4 if slide else 2, "max_cutbacks": 4},
    }


def _cell_det_F(problem) -> float:
    """The smallest det F at the cell midpoints (DG0 interpolation of det(I + ∇u), over
    all ranks): a check of its own, not ContactProblem.min_det_F."""
    import dolfinx.fem as fem
    import ufl

    Q = fem.FunctionSpace(problem.mesh, ("DG", 0))
    J = fem.Function(Q)
    F = ufl.Identity(problem.gdim) + ufl.grad(problem.u)
    J.interpolate(fem.Expression(ufl.det(F), Q.element.interpolation_points()))
    n = Q.dofmap.index_map.size_local
    return problem.comm.allreduce(float(J.x.array[:n].min(initial=np.inf)), op=MPI.MIN)


@pytest.mark.mpi2
def test_a_converged_state_with_inverted_elements_is_refused(shared_tmp):
    """The SVK press and slide with a stiff penalty (3.85e8): the cutback of the first
    slide step to t = 0.6875 converged (7 + 31 iterations) to a state with a row of the
    lower block mirrored (det F = −1), contact lost (active 0, force 0), and the run went
    on to status "ok" (2 ranks stopped instead). A converged solve with det F <= 0 now
    fails (NewtonSolver._check_inversion): every kept step has det F > 0 (at the cell
    midpoints, checked here independently) and the contact force of the press (8 active
    nodes, 1.3–1.7); the run stops at t = 0.65625 on 1 and 2 ranks, naming the inverted
    elements of its last attempt (3 ranks cut back otherwise). On 2 ranks only (mpi2,
    session 53: 16 s of the 3-rank pass, which asserted the kept steps only)."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    box, dets = {}, []
    data = _svk_press_slide("element", 3.85e8, 0.02, 0.05)
    data["steps"] = {"t_end": 1.0, "n": 2, "max_cutbacks": 4}  # the slide's first step
    s = run(
        parse_scene(data, shared_tmp),
        MPI.COMM_WORLD,
        out_dir=shared_tmp / "inverted",
        setup=lambda problem: box.update(p=problem),
        progress=lambda step, record: dets.append(_cell_det_F(box["p"])),
    )
    box["p"].destroy()
    steps = s["steps"]
    assert len(dets) == len(steps) >= 4 and min(dets) > 0.5, dets
    assert all(st["active_nodes"] == 8 for st in steps), [st["active_nodes"] for st in steps]
    forces = [st["contact_force"]["upper_bottom:lower_top"][1] for st in steps]
    assert min(forces) > 1.0, forces
    assert s["status"] == "failed", [st["t"] for st in steps]
    assert [st["t"] for st in steps] == [0.5, 0.53125, 0.5625, 0.625, 0.65625]
    assert "; the last attempt ended with inverted elements (det F = " in s["error"]


@pytest.mark.mpi2
def test_the_stop_message_of_a_folded_attempt_names_no_master_edge(shared_tmp):
    """The SVK press of the test above with segment integration: every cutback of the
    step to t = 1 fails, the last attempt's iterate folded (det F < 0; on 2 ranks the
    last attempt converged folded, and is refused). The stop message named "6 slave facets ... in contact across the master
    surface's edge" (the master 0.2 wider than the slave on each side, every slave facet
    fully paired at t = 0.5), counted on the folded iterate; it now says that the
    attempt ended with inverted elements, and gives no edge hint. On 2 ranks only (mpi2,
    session 53): a stop on every rank, as serially; 11 s of the 3-rank pass."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    data = _svk_press_slide("segment", 3.85e8, 0.02, 0.05)
    data["steps"] = {"t_end": 1.0, "n": 2, "max_cutbacks": 4}
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=shared_tmp / "folded")
    assert s["status"] == "failed" and [st["t"] for st in s["steps"]] == [0.5], s["steps"]
    assert "across the master surface's edge" not in s["error"], s["error"]
    # the last attempt's iterate folded (serial), or it converged folded (2 ranks)
    assert "inverted elements (det F = -" in s["error"] or s["error"].endswith(
        "Newton converged to a state that is no deformation of the bodies"
    ), s["error"]


@pytest.mark.mpi
@pytest.mark.parametrize(
    "integration,margin,expected",
    [("segment", 0.0, 1), ("segment", 0.05, 0), ("element", 0.0, 0)],
    ids=["segment-edge", "segment-margin", "element"],
)
def test_edge_facet_pairs(shared_tmp, integration, margin, expected):
    """``ContactProblem.edge_facet_pairs`` after the coarse press and slide of 0.02 (which
    completes without a cutback in each case): the slave's right end facet lies across
    the master's edge (3 % of its length beyond it, 7.5e-3) with segment integration
    and no margin; none where the master extends beyond the slave, and none with element
    integration (not counted: its kink is another one). The same count on 1–3 ranks.
    (Until session 52 this looked after the press alone and found 2: the end facets' Φ
    weights, chosen when a sliver of 1e-5 uncovered them during the solve, let the
    slave's end nodes stick 1.2e-5 beyond the master's; with the choice made once per
    step attempt they keep Ψ and stick flush, within 3e-11 of a facet, where the count
    is a sign at round-off.) Since session 52 the segment slide, which stalled in its
    first slide step (the right end facet's weights switched between Ψ and Φ from one
    iterate to the next), completes."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    box = {}
    data = _coarse_press_slide(integration, margin)
    s = run(
        parse_scene(data, shared_tmp),
        MPI.COMM_WORLD,
        out_dir=shared_tmp / f"{integration}_{margin}",
        setup=lambda problem: box.update(p=problem),
    )
    assert s["status"] == "ok", s.get("error")
    assert [st["t"] for st in s["steps"]] == [0.5, 1.0, 1.5, 2.0]
    assert all(st["cutbacks"] == 0 for st in s["steps"]), s["steps"]
    found = box["p"].edge_facet_pairs()
    assert found == ({"upper_bottom:lower_top": expected} if expected else {}), found


@pytest.mark.mpi
def test_a_body_that_nothing_holds_stops_the_run(shared_tmp):
    """patch2d without its Dirichlet boundaries: both blocks are free, the Jacobian is
    singular, and Newton's iterates drift (u grew to 1e16 at a "round-off level" that
    made the run count that state, and every later step, as converged: status "ok" with
    garbage). The run now stops cleanly: status "failed", no step kept."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    data = {
        "mesh": {"generator": "patch2d", "params": {"n_lower": 2, "n_upper": 3, "n_y": 1}},
        "kinematics": "small",
        "material": [
            {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3}
            for r in ("lower", "upper")
        ],
        "contact": [{"slave": "upper_bottom", "master": "lower_top"}],
        "traction": [{"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -2.0]]}],
        "steps": {"n": 1, "max_cutbacks": 1},
    }
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=shared_tmp / "free")
    assert s["status"] == "failed" and s["steps"] == [], s["steps"]
    assert "failed after 1 cutbacks" in s["error"], s["error"]


@pytest.mark.parametrize(
    ("pairs", "open_pairs", "free", "hint"),
    [
        (0, [], True, False),
        (2, ["a:b"], True, False),
        (1, ["a:b"], True, True),
        (1, ["a:b"], False, False),
    ],
)
@pytest.mark.parametrize("apart", [False, True])
def test_the_open_contact_hint_needs_every_pair_open(pairs, open_pairs, free, hint, apart):
    """The hint is given only where every contact pair is open (a closed pair may hold
    the body) and an open pair has a body that the Dirichlet conditions leave free
    (``free_body``), and never without contact. It blames the loads where the pair's
    surfaces face each other, and their positions where no slave point projects onto
    the master (``apart``)."""

    class Term:
        name = "a:b"
        free_body = free

    class P:
        contacts = [Term()] * pairs

        def open_pairs(self):
            return open_pairs

        def unpaired_pairs(self):
            return ["a:b"] if apart else []

    text = solver_module._open_contact_hint(P())
    assert bool(text) == hint
    if hint and apart:
        assert "no slave point of a:b faces its master surface" in text
        assert "direction of the loads" not in text
    elif hint:
        assert "no slave node of a:b was in contact" in text
        assert "faces its master surface" not in text


class _NoPredictor(_Newton):
    """Fails every solve started from the predictor (the stepper passes dtol then)."""

    def __init__(self, problem):
        super().__init__(problem, lambda t0: 1.0)
        self.predicted = 0

    def solve(self, rtol=None, dtol=None, rescue=True, reuse=False, force=False, full_steps=False):
        if dtol is not None:
            self.predicted += 1
            raise ConvergenceError("far off")
        return super().solve(rtol, dtol, rescue)


def test_predictor_backs_off_after_failures():
    """After a failure from the predictor the next 1, 2, 4 … (at most
    PREDICTOR_MAX_BACKOFF) steps start from the converged state; each step records its
    failed attempts."""
    p = _Problem()
    newton = _NoPredictor(p)
    results = LoadStepper(p, newton, 1.0, 8).run()
    assert [r.predictor_failures for r in results] == [0, 1, 0, 1, 0, 0, 1, 0]
    assert newton.predicted == 3
    assert p.committed[-1] == pytest.approx(1.0) and len(p.committed) == 8


def _predicted_solves(p, n, newton_type=None):
    """Run ``n`` steps of ``p`` with a Newton (``newton_type``, default _Newton) that
    always converges; returns per solve whether it started from the predictor, and the
    step results."""
    newton = (newton_type or _Newton)(p, lambda t0: 1.0)
    calls = []
    orig = newton.solve
    newton.solve = lambda rtol=None, dtol=None, rescue=True, reuse=False, force=False, **kw: (
        calls.append(dtol) or orig(rtol, dtol, rescue)
    )
    results = LoadStepper(p, newton, 1.0, n).run()
    return [d is not None for d in calls], results


def test_predictor_used_while_it_works():
    predicted, results = _predicted_solves(_Problem(), 5)
    assert predicted == [False, True, True, True, True]
    assert all(r.predictor_failures == 0 for r in results)


def test_uzawa_stall_rule():
    k = solver_module.UZAWA_STALL_ROUNDS
    stalled = solver_module.uzawa_stalled
    assert not stalled([1.0] * (k + 1))  # too few rounds to judge
    assert stalled([1.0] * (k + 2))
    assert not stalled([1.0] * (k + 1) + [0.4, 0.4])
    slow = [0.9**i for i in range(3 * k)]  # 0.9 per round: half within k = 8 rounds
    assert not any(stalled(slow[:n]) for n in range(1, len(slow) + 1))
    zigzag = [0.5**i * (3.0 if i % 2 else 1.0) for i in range(3 * k)]  # converging
    assert not any(stalled(zigzag[:n]) for n in range(1, len(zigzag) + 1))
    # peers problem B, level 3, full tangential step: every other round changes by 0.4
    cycle = [0.14, 0.28, 0.3, 0.33, 0.36, 0.4, 0.11, 0.4, 0.028, 0.4, 0.022, 0.4]
    first = next(n for n in range(1, len(cycle) + 1) if stalled(cycle[:n]))
    assert first == k + 2


class _Ramp(_Problem):
    """Prescribed data ramped up to t = 0.5, then held: the load path has a corner."""

    def load_values(self, t):
        return np.array([min(t, 0.5), 2.0])


def test_no_predictor_across_a_corner_of_the_load_path():
    """The step after the corner starts from the converged state (the extrapolation would
    continue the ramp); the next one, at the new constant rate, uses the predictor."""
    predicted, results = _predicted_solves(_Ramp(), 4)
    assert predicted == [False, True, False, True]
    assert all(r.predictor_failures == 0 for r in results)


class _SnapNewton(_Newton):
    """u(t) = t, plus a jump of 1 from t = 0.6 on (a snap in the third of five steps)."""

    def solve(self, rtol=None, dtol=None, rescue=True, reuse=False, force=False, full_steps=False):
        out = super().solve(rtol, dtol, rescue)
        self.problem.u.x.array[:] += 1.0 if self.problem.t > 0.6 - 1e-12 else 0.0
        return out


def test_no_predictor_after_a_jump():
    """The step after one whose increment rate exceeds PREDICTOR_JUMP_RATIO × the rate
    before starts from the converged state (the jump does not repeat); the one after
    that, at the regular rate again, uses the predictor."""
    predicted, _ = _predicted_solves(_Problem(), 5, _SnapNewton)
    assert predicted == [False, True, True, False, True]
    assert solver_module.PREDICTOR_JUMP_RATIO < 6.0  # the jump's rate ratio here


class _FasterRamp(_Ramp):
    """The load path's corner at t = 0.5, where u's rate grows 4-fold with the load."""

    def increment_norm(self, u_old):
        def g(u):
            return min(u, 0.5) + 4.0 * max(u - 0.5, 0.0)

        return abs(g(self.u.x.array[0]) - g(u_old[0]))


def test_a_rate_change_at_a_corner_of_the_load_path_is_no_jump():
    """The rate that grows with the load at a corner is not a jump: the step after the
    corner's step uses the predictor again (as without the jump rule)."""
    predicted, _ = _predicted_solves(_FasterRamp(), 4)
    assert predicted == [False, True, False, True]


class _FieldRamp(_Problem):
    """A Dirichlet field ramped up to t = 0.5, then held (the scene's paths are constant):
    a corner that only ``field_values`` shows, plus a point that does not move whose
    value is round-off that changes sign every step."""

    comm = MPI.COMM_SELF
    extent = 1.0
    has_dirichlet_fields = True

    def load_values(self, t):
        return np.array([0.0, 2.0])

    def field_values(self, t):
        return np.array([[min(t, 0.5), 0.0], [1e-16 * (-1) ** round(4 * t), 0.0]])


def test_no_predictor_across_a_corner_of_a_dirichlet_field():
    """A corner of an ``add_dirichlet_field`` path counts as one of the scene's paths (the
    session-54 probe: 37 Newton iterations from the extrapolation against 12), and the
    round-off of a point that does not move (below FIELD_ROUND_OFF × the extent) does not
    make every step a corner."""
    predicted, _ = _predicted_solves(_FieldRamp(), 4)
    assert predicted == [False, True, False, True]
    ts = (0.25, 0.5, 0.75)
    jitter = [np.array([0.0, 1e-16 * (-1) ** k]) for k in range(3)]
    assert solver_module._rates_change(*jitter, *ts)  # without the floor: a corner
    assert not solver_module._rates_change(*jitter, *ts, atol=1e-12)


class _Cycling(_Problem):
    """Uzawa rounds whose multiplier change cycles (0.3, 0.4, 0.3, ...) and never settles."""

    def __init__(self):
        super().__init__()
        self.rounds = 0

    def uzawa_update(self):
        self.rounds += 1
        change = 0.3 if self.rounds % 2 else 0.4
        return False, {"pair": {"multiplier_change": 0.01, "tangential_change": change}}


def test_stalled_uzawa_rounds_stop_before_uzawa_max():
    p = _Cycling()
    p.set_time(0.5)
    with pytest.raises(ConvergenceError, match="stalled"):
        solver_module.solve_step(p, _Newton(p, lambda t0: 1.0), uzawa_max=30)
    assert p.rounds == solver_module.UZAWA_STALL_ROUNDS + 2


class _Unfrozen(_Problem):
    """Uzawa rounds with a growing (or shrinking) change whose solves end with wrong
    frozen stick/slip states in the rounds listed in ``pattern`` (1: wrong); done after
    it."""

    def __init__(self, pattern, growing=True):
        super().__init__()
        self.pattern, self.rounds, self.growing = pattern, 0, growing

    def uzawa_update(self):
        k, self.rounds = self.rounds, self.rounds + 1
        if k == len(self.pattern):
            return True, {"pair": {"multiplier_change": 0.0}}
        change = 2.0**k if self.growing else 0.5**k
        info = {"multiplier_change": change, "unfrozen_states": self.pattern[k]}
        return False, {"pair": info}


@pytest.mark.parametrize("carrying", [False, True])
def test_wrong_frozen_states_in_a_row_fail_the_step(carrying):
    k = solver_module.FROZEN_RETRY_ROUNDS
    if not carrying:  # an attempt with free states gives up sooner (then the carried retry)
        k = solver_module.FROZEN_RETRY_ROUNDS_FREE
    p = _Unfrozen([0] + [1] * k + [0])
    p.carrying_states = carrying
    p.set_time(0.5)
    with pytest.raises(FrozenStatesError, match="frozen"):
        solver_module.solve_step(p, _Newton(p, lambda t0: 1.0), uzawa_max=30)
    assert p.rounds == 1 + k
    # not in a row, or with a shrinking change: the rounds go on to convergence
    for p, n in ((_Unfrozen([1, 0] * k), 2 * k), (_Unfrozen([1] * 2 * k, growing=False), 2 * k)):
        p.set_time(0.5)
        solver_module.solve_step(p, _Newton(p, lambda t0: 1.0), uzawa_max=30)
        assert p.rounds == n + 1


class _FrozenUnlessCarried(_Newton):
    """Fails with wrong frozen states at the steps to the times in ``bad`` unless the
    states are carried (all of them when ``always``); records (t, carrying) per solve."""

    def __init__(self, problem, bad, always=False):
        super().__init__(problem, lambda t0: 1.0)
        self.bad, self.always, self.calls = bad, always, []

    def solve(self, rtol=None, dtol=None, rescue=True, reuse=False, force=False, full_steps=False):
        p = self.problem
        carrying = getattr(p, "carrying_states", False)
        self.calls.append((round(p.t, 12), carrying))
        if round(p.t, 12) in self.bad and (self.always or not carrying):
            self.all_iterations += 3  # the rounds before the failure
            raise FrozenStatesError("wrong frozen states")
        return super().solve(rtol, dtol, rescue, reuse, force)


def test_wrong_frozen_states_retry_the_step_with_carried_states():
    """A step that fails with FrozenStatesError is tried again at the same size with the
    stick/slip states carried between Uzawa rounds, and only then cut back; the retry
    is counted and carrying ends with the step."""
    p = _Problem()
    newton = _FrozenUnlessCarried(p, bad={0.5})
    results = LoadStepper(p, newton, 1.0, 2, max_cutbacks=3).run()
    assert [r.t for r in results] == [0.5, 1.0]
    assert [r.cutbacks for r in results] == [0, 0]
    assert [r.carried_retries for r in results] == [1, 0]
    # the failed attempt's iterations count in all_iterations, not in newton_iterations
    assert [r.all_iterations - sum(r.newton_iterations) for r in results] == [3, 0]
    assert [c for c in newton.calls if c[0] == 0.5] == [(0.5, False), (0.5, True)]
    assert newton.calls[-1] == (1.0, False) and p.carrying_states is False
    # the retry fails too: the step is cut back, the half starts without carrying (t = 0.5
    # always fails here, so the run ends on the cutback limit, the finished steps kept)
    p = _Problem()
    newton = _FrozenUnlessCarried(p, bad={0.5}, always=True)
    stepper = LoadStepper(p, newton, 1.0, 2, max_cutbacks=3)
    with pytest.raises(ConvergenceError, match="wrong frozen states"):
        stepper.run()
    first = stepper.results[0]
    assert first.t == pytest.approx(0.25) and first.cutbacks == 1 and first.carried_retries == 1
    assert newton.calls[:3] == [(0.5, False), (0.5, True), (0.25, False)]


class _Resumable(_Problem):
    """Fails with wrong frozen states from its second Uzawa round on unless the states
    are carried (then the round converges); has round_state / resume_round."""

    def __init__(self):
        super().__init__()
        self.rounds, self.resumed = 0, []

    def begin_step(self):
        self.rounds = 0

    def uzawa_update(self):
        k, self.rounds = self.rounds, self.rounds + 1
        if self.carrying_states:
            return True, {"pair": {"multiplier_change": 0.0}}
        info = {"multiplier_change": 2.0**k, "unfrozen_states": int(k > 0)}
        return False, {"pair": info}

    def round_state(self):
        return {"u": self.u.x.array.copy(), "rounds": self.rounds}

    def resume_round(self, state):
        self.resumed.append(state["rounds"])
        self.rounds = state["rounds"]
        self.u.x.array[:] = state["u"]


def test_the_carried_retry_resumes_after_the_first_round():
    """The FrozenStatesError of an attempt with free states carries the state after its
    first Uzawa round (solve_step's RoundResume); the carried retry starts from there and
    does not solve the first round again, whose iterations count in the accepted step."""
    p = _Resumable()
    p.set_time(1.0)
    newton = _Newton(p, lambda t0: 1.0)
    with pytest.raises(FrozenStatesError) as info:
        solver_module.solve_step(p, newton, uzawa_max=30)
    k = solver_module.FROZEN_RETRY_ROUNDS_FREE
    assert p.rounds == 1 + k
    resume = info.value.resume
    assert resume.its == [1] and resume.state["rounds"] == 1
    assert resume.changes == [1.0] and resume.rtol == pytest.approx(1e-3)
    p = _Resumable()
    newton = _Newton(p, lambda t0: 1.0)
    (result,) = LoadStepper(p, newton, 1.0, 1, uzawa_max=30).run()
    assert p.resumed == [1] and result.carried_retries == 1 and result.cutbacks == 0
    # the first round (1 solve) once, the failed rounds (k), the carried round and the
    # final full-tolerance solve
    assert newton.all_iterations == 1 + k + 2
    assert result.newton_iterations == [1, 1, 1]
    assert result.all_iterations - sum(result.newton_iterations) == k


class _Cubic:
    """R(x) = x³ − 8 per entry (root 2), J = diag(3x²): the NewtonSolver's problem hooks."""

    n = 3
    contacts = ()  # no contact term (so no penetration-limited steps)

    def __init__(self, x0):
        self.comm = MPI.COMM_SELF
        self.timings = {"search": 0.0}
        self.u = type("U", (), {})()
        self.u.vector = PETSc.Vec().createSeq(self.n, comm=self.comm)
        self.u.vector.set(x0)
        self.u.x = type("X", (), {"scatter_forward": lambda self: None})()

    def create_matrix(self):
        A = PETSc.Mat().createAIJ([self.n, self.n], nnz=1, comm=self.comm)
        A.setUp()
        return A

    def residual(self, x, b):
        b.array[:] = x.array**3 - 8.0

    def jacobian(self, x, A):
        A.zeroEntries()
        for i, v in enumerate(x.array):
            A.setValue(i, i, 3.0 * v * v)
        A.assemble()

    def begin_solve(self):
        pass

    def update_contact(self, x):
        pass

    def ensure_contact_at(self, x):
        pass

    def pattern_outdated(self):
        return False


@pytest.fixture
def cubic_vectors(monkeypatch):
    monkeypatch.setattr(
        solver_module, "_create_vector", lambda p: PETSc.Vec().createSeq(p.n, comm=p.comm)
    )


def test_a_stalled_solve_continues_with_full_steps(cubic_vectors):
    """A solve that ends on its iteration limit (here 4; the l2 line search needs about
    7) is continued from its last iterate with at most min(FULL_STEP_ITERATIONS, max_it)
    full Newton steps, to the original tolerance; the line search option and max_it are
    restored afterwards."""
    problem = _Cubic(10.0)
    settings = SolverSettings(rtol=1e-10, atol=1e-14, max_it=4, prefix="test_stall_")
    with NewtonSolver(problem, settings) as newton:
        its, norms = newton.solve()
        assert newton.full_step_solves == 1
        assert newton.options["snes_linesearch_type"] == "l2"
        assert newton.snes.getTolerances()[3] == 4
    assert 4 < its <= 4 + 4
    assert len(norms) == its + 1
    assert norms[-1] <= 1e-10 * norms[0]
    assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


def test_full_steps_are_bounded(cubic_vectors, monkeypatch):
    """The continuation has at most FULL_STEP_ITERATIONS (and max_it) steps: a solve that
    still needs more fails (and the load step would be cut back)."""
    monkeypatch.setattr(solver_module, "FULL_STEP_ITERATIONS", 1)
    settings = SolverSettings(rtol=1e-10, atol=1e-14, max_it=2, prefix="test_budget_")
    with NewtonSolver(_Cubic(10.0), settings) as newton:
        with pytest.raises(ConvergenceError, match="3 iterations"):
            newton.solve()
        assert newton.full_step_solves == 1


class _Term:
    """A contact term's stub for the escape check: in contact while |x| <= 1.5."""

    name = "slave:master"
    first_contact = False

    def __init__(self, free_body, h_mean):
        self.free_body, self.h_mean = free_body, h_mean
        self.touching = True


class _CubicInContact(_Cubic):
    """The cubic from x = 1 to its root 2, with a contact term that loses its contact
    beyond |x| = 1.5: a body held by contact alone (``free``) that escapes."""

    def __init__(self, free, h_mean):
        super().__init__(1.0)
        self.contacts = (_Term(free, h_mean),)

    def update_contact(self, x):
        self.contacts[0].touching = bool(np.abs(x.array).max() <= 1.5)

    ensure_contact_at = update_contact


@pytest.mark.parametrize(
    "free,h_mean,escapes", [(True, 0.1, True), (False, 0.1, False), (True, 10.0, False)]
)
def test_a_solve_whose_free_body_escapes_fails(cubic_vectors, free, h_mean, escapes):
    """A solve that starts in contact and ends with none, moving by more than
    ESCAPE_FACETS facet sizes, fails where the pair's body is held by contact alone: it
    escaped (a 3D stack of three blocks accepted its middle block 1.3 sideways out of the
    stack with every reaction 1e-15); a held body or a move within a facet is accepted."""
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_escape_")
    problem = _CubicInContact(free, h_mean)
    with NewtonSolver(problem, settings) as newton:
        if escapes:
            with pytest.raises(ConvergenceError, match="lost every contact of slave:master"):
                newton.solve()
        else:
            newton.solve()
            assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


class _CubicOpen(_Cubic):
    """The cubic from x = 1 to its root 2, with a contact term open throughout (not in
    contact at the solve's start nor at its end) whose body is held by contact alone:
    the solve moves it ``along`` (the problem's ``free_rigid_motion``) along the motions
    its Dirichlet conditions leave free, and ``floats`` says whether no closed pair
    holds it (``floating``)."""

    def __init__(self, along, floats):
        super().__init__(1.0)
        term = _Term(True, 0.5)
        term.touching = False
        term.frictional = True
        self.contacts = (term,)
        self.along, self.floats = along, floats

    def free_rigid_motion(self, du, tangential=False):
        return np.array([self.along])

    def floating(self, closed):
        assert list(closed) == [False]
        return np.array([self.floats])


@pytest.mark.parametrize(
    "along,floats,fails",
    [(0.6, False, True), (0.1, False, False), (0.1, True, True), (0.0, True, True)],
)
def test_an_open_pair_whose_free_body_nothing_holds_fails_at_any_motion(
    cubic_vectors, along, floats, fails
):
    """A solve that ends with a pair open, not in contact at its start either, whose
    body is held by contact alone: where no closed pair holds the body (``floating``),
    its Jacobian is singular along the free motions and the solve's motion there is the
    linear solver's round-off, so the solve fails whatever that motion (0.1 and 0: below
    the ESCAPE_FACETS facet size 0.5); where a closed pair holds the body, only a motion
    above a facet size fails. stick_only_scene's cut step to t = 0.015625 moved the
    cylinder 0.303 (0.58 facet sizes) once the bulk kernels took λ and μ as constants
    (2.07 before): it was accepted, the predictor carried the drift on, and the run
    ended "ok" with the cylinder 9.26 along x and no node ever in contact."""
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_open_float_")
    problem = _CubicOpen(along, floats)
    with NewtonSolver(problem, settings) as newton:
        if fails:
            with pytest.raises(ConvergenceError) as info:
                newton.solve()
            msg = str(info.value)
            assert msg.startswith("the solve ended with no node of slave:master in contact")
            assert f"moved a body held by contact alone by {along:.3g} " in msg
            assert "the body escaped (a frictional pair holds such motions" in msg
            assert ("linear solver's round-off" in msg) == floats
        else:
            newton.solve()
            assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


def test_a_failed_linear_solve_is_named(cubic_vectors):
    """A singular Jacobian (the cubic at x = 0: J = 0) fails the factorization; the error
    names the SNES reason and the KSP's, so that a user sees the linear solver failed."""
    settings = SolverSettings(prefix="test_singular_")
    with NewtonSolver(_Cubic(0.0), settings) as newton:
        with pytest.raises(
            ConvergenceError,
            match=r"SNES reason -3 DIVERGED_LINEAR_SOLVE \(KSP reason -11 DIVERGED_PCSETUP_FAILED\)",
        ):
            newton.solve()


def test_no_continuation_with_the_basic_line_search(cubic_vectors):
    settings = SolverSettings(max_it=2, line_search="basic", prefix="test_basic_")
    with NewtonSolver(_Cubic(10.0), settings) as newton:
        with pytest.raises(ConvergenceError, match="SNES reason -5 DIVERGED_MAX_IT"):
            newton.solve()
        assert newton.full_step_solves == 0


def test_full_steps_at_most_max_it(cubic_vectors):
    """max_it = 3: 3 l2 iterations, then 3 full steps (not 10), not enough here."""
    settings = SolverSettings(rtol=1e-10, atol=1e-14, max_it=3, prefix="test_maxit_")
    with NewtonSolver(_Cubic(10.0), settings) as newton:
        with pytest.raises(ConvergenceError, match="6 iterations"):
            newton.solve()


def test_a_failed_solve_names_the_iterations_of_each_part(cubic_vectors):
    """max_it = 1: 1 l2 iteration, then 1 full step from where it stalled, and the error
    says so (it said "2 iterations" with max_it = 1, as if the limit were not kept); a
    solve in one part says "N iterations" alone."""
    settings = SolverSettings(rtol=1e-10, atol=1e-14, max_it=1, prefix="test_parts_")
    with NewtonSolver(_Cubic(10.0), settings) as newton:
        with pytest.raises(ConvergenceError) as info:
            newton.solve()
    assert (
        "DIVERGED_MAX_IT, 2 iterations: 1 with line search l2, then 1 with full Newton "
        "steps from where it stalled, max_it = 1 each, residual "
    ) in str(info.value)
    settings = SolverSettings(max_it=2, line_search="basic", prefix="test_one_part_")
    with NewtonSolver(_Cubic(10.0), settings) as newton:
        with pytest.raises(ConvergenceError, match=r"DIVERGED_MAX_IT, 2 iterations, residual"):
            newton.solve()


class _Shifted(_Cubic):
    """R(x) = x³ + s x − 8, J = diag(3x² + s): ``s`` (per entry) plays the multipliers that
    an Uzawa round changes between two solves."""

    def __init__(self, x0):
        super().__init__(x0)
        self.s = np.zeros(self.n)

    def residual(self, x, b):
        b.array[:] = x.array**3 + self.s * x.array - 8.0

    def jacobian(self, x, A):
        A.zeroEntries()
        for i, v in enumerate(x.array):
            A.setValue(i, i, 3.0 * v * v + self.s[i])
        A.assemble()


def _two_rounds(prefix, reuse=True, **settings):
    """Solve with s = 0, then with s = (0, 30, 60) from that solution; returns the
    second solve's (iterations, norms, solution) and the solver's reuse counters."""
    problem = _Shifted(3.0)
    opts = SolverSettings(rtol=1e-11, atol=1e-14, prefix=prefix, **settings)
    with NewtonSolver(problem, opts) as newton:
        newton.solve()
        problem.s = np.array([0.0, 30.0, 60.0])
        its, norms = newton.solve(reuse=reuse)
        counts = (newton.reused_factorizations, newton.failed_reuses)
    x = problem.u.vector.array.copy()
    assert np.allclose(x**3 + problem.s * x, 8.0, rtol=1e-10)
    return its, norms, counts


def test_a_round_reuses_the_last_factorization(cubic_vectors):
    """The first iteration of the second solve runs GMRES on the factorization of the
    first solve's last Jacobian (diag(12) against diag(12, 42, 72): 3 GMRES iterations)
    and gives the exact Newton step: the same residual history as with a new
    factorization."""
    its, norms, counts = _two_rounds("test_reuse_")
    assert counts == (1, 0)
    its_ref, norms_ref, counts_ref = _two_rounds("test_noreuse_", reuse=False)
    assert counts_ref == (0, 0)
    assert its == its_ref
    np.testing.assert_allclose(norms, norms_ref, rtol=1e-6, atol=1e-13)


def test_a_failed_reuse_factorizes_again(cubic_vectors, monkeypatch):
    """One GMRES iteration cannot solve the changed system: the solve starts again with a
    new factorization, and converges."""
    monkeypatch.setattr(solver_module, "REUSE_MAX_IT", 1)
    its, norms, counts = _two_rounds("test_reusefail_")
    assert counts == (0, 1)
    assert norms[-1] <= 1e-11 * norms[0]


def test_a_forced_solve_iterates_below_atol(cubic_vectors):
    """A multiplier change whose residual is already below atol: a plain solve keeps the
    state, a forced one (later Uzawa rounds) takes a Newton step towards the new root."""
    for force, moves in ((False, False), (True, True)):
        problem = _Shifted(3.0)
        opts = SolverSettings(rtol=1e-12, atol=1e-6, prefix=f"test_force_{force}_")
        with NewtonSolver(problem, opts) as newton:
            newton.solve()
            x0 = problem.u.vector.array.copy()
            problem.s = np.array([0.0, 0.0, 1e-8])  # residual change 2e-8 < atol
            its, norms = newton.solve(force=force)
        assert norms[0] < 1e-6
        assert (its > 0) == moves
        x = problem.u.vector.array
        assert (abs(x[2] - x0[2]) > 1e-10) == moves
        if moves:  # the step lands on the shifted root: x³ + s x = 8
            assert abs(x[2] ** 3 + 1e-8 * x[2] - 8.0) < 1e-14


def test_later_uzawa_rounds_force_an_iteration():
    """solve_step forces at least one Newton iteration in every round after the first."""
    p = _Unfrozen([0, 0], growing=False)
    p.set_time(0.5)
    newton = _Newton(p, lambda t0: 1.0)
    forced = []
    orig = newton.solve
    newton.solve = lambda rtol=None, dtol=None, rescue=True, reuse=False, force=False, **kw: (
        forced.append(force) or orig(rtol, dtol, rescue)
    )
    solver_module.solve_step(p, newton, uzawa_max=10, inexact=False)
    assert forced == [False, True, True]


class _Pinned(_Unfrozen):
    """Uzawa rounds whose solves end with pinned points (contact.HOLD_AFTER) in the rounds
    listed in ``pinned`` (1: pinned), inexact rounds then a final full-tolerance solve."""

    def __init__(self, pinned, changed=None):
        super().__init__([0] * len(pinned), growing=False)
        self.pinned, self.changed = pinned, changed or {}

    def uzawa_update(self):
        k = self.rounds
        done, info = super().uzawa_update()
        if k < len(self.pinned) and self.pinned[k]:
            info["pair"]["pinned_points"] = 3
        if k in self.changed:  # a state contradicted by the free law at convergence
            info["pair"][self.changed[k]] = 1
        return done, info


@pytest.mark.parametrize(
    "pinned, changed",
    [
        ([1, 0, 1], {}),
        ([0, 1, 0], {}),
        ([0, 0, 1], {}),
        ([1, 1, 1], {0: "unfrozen_states", 1: "released_nodes", 2: "unfrozen_qp_nodes"}),
    ],
)
def test_the_solve_after_released_pins_takes_full_steps(pinned, changed):
    """solve_step asks for full steps (ROUND_FULL_STEPS) in exactly the solves that follow
    a round whose solve ended with pinned points and with no state the free law
    contradicted: the later rounds and the final full-tolerance solve."""
    p = _Pinned(pinned, changed)
    p.set_time(0.5)
    newton = _Newton(p, lambda t0: 1.0)
    asked = []
    orig = newton.solve
    newton.solve = lambda rtol=None, dtol=None, rescue=True, reuse=False, force=False, **kw: (
        asked.append(kw["full_steps"]) or orig(rtol, dtol, rescue)
    )
    solver_module.solve_step(p, newton, uzawa_max=10)
    # rounds 1-3, the round that is done, the final full-tolerance solve
    expected = [bool(k) and i not in changed for i, k in enumerate(pinned)]
    assert asked == [False] + expected + [False]


def _newton_iterations(x0: float, rtol: float) -> int:
    """Full Newton steps on x³ = 8 from x0 until |R| ≤ rtol |R(x0)| (plain Python)."""
    x, r0, k = x0, abs(x0**3 - 8.0), 0
    while abs(x**3 - 8.0) > rtol * r0:
        x, k = x - (x**3 - 8.0) / (3.0 * x * x), k + 1
    return k


def test_full_steps_that_contract_finish_the_solve(cubic_vectors):
    """From x = 10 the full steps contract ‖R‖ at every iterate: the solve takes exactly
    the iterations of plain full-step Newton, with no restart, and the options (line
    search, divergence tolerance, max_it) are the configured ones afterwards."""
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_full_ok_")
    with NewtonSolver(_Cubic(10.0), settings) as newton:
        its, norms = newton.solve(full_steps=True)
        assert newton.full_step_restarts == 0
        assert newton.options["snes_linesearch_type"] == "l2"
        assert float(newton.options["snes_divergence_tolerance"]) == 1e4
        assert newton.snes.getTolerances()[3] == settings.max_it
        assert its == _newton_iterations(10.0, 1e-10) and len(norms) == its + 1
        assert np.allclose(newton.problem.u.vector.array, 2.0, rtol=1e-9)


def test_full_steps_that_raise_the_residual_restart_with_the_line_search(cubic_vectors):
    """From x = 0.5 the first full step lands at 11, where ‖R‖ is 170 times larger: the
    attempt stops there (ROUND_FULL_STEP_GROWTH) and the solve starts again from x = 0.5
    with l2. The returned iterations and norms include the failed step; the solution is
    the l2 solve's."""
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_full_restart_")
    with NewtonSolver(_Cubic(0.5), settings) as newton:
        l2_its, l2_norms = newton.solve()
    with NewtonSolver(_Cubic(0.5), settings) as newton:
        its, norms = newton.solve(full_steps=True)
        assert newton.full_step_restarts == 1
        assert newton.options["snes_linesearch_type"] == "l2"
        assert newton.all_iterations == its
        x = newton.problem.u.vector.array
    assert its == 1 + l2_its and len(norms) == its + 1
    r0 = np.sqrt(3.0) * abs(0.5**3 - 8.0)
    assert norms[0] == pytest.approx(r0) and norms[1] == pytest.approx(np.sqrt(3.0) * 1323.0)
    assert norms[2:] == pytest.approx(l2_norms[1:])
    assert np.allclose(x, 2.0, rtol=1e-9)


def test_no_reuse_with_an_iterative_solver(cubic_vectors):
    _, _, counts = _two_rounds("test_reuse_gmres_", petsc={"ksp_type": "gmres"})
    assert counts == (0, 0)


def test_no_reuse_without_the_lag_setting(cubic_vectors, monkeypatch):
    """Where SNESSetLagPreconditioner cannot be reached (no petsc4py wrapper, no PETSc
    library found), every iteration factorizes: the same solution, no reuse."""
    from dolfinx_mortar import compat

    monkeypatch.setattr(compat, "lag_preconditioner_available", lambda: False)
    _, _, counts = _two_rounds("test_reuse_nolag_")
    assert counts == (0, 0)


class _CubicWithHole(_Cubic):
    """The cubic with a NaN residual for x >= 8 (an inverted element beyond a step)."""

    def residual(self, x, b):
        b.array[:] = np.where(x.array < 8.0, x.array**3 - 8.0, np.nan)


def test_a_nan_residual_restarts_with_backtracking(cubic_vectors):
    """From x = 0.5 the full Newton step lands at 11, where the residual is NaN: the solve
    restarts from its last finite iterate (x0) with the bt line search, which halves the
    step until the residual is finite, and converges; the line search option is restored."""
    problem = _CubicWithHole(0.5)
    settings = SolverSettings(rtol=1e-10, atol=1e-14, line_search="basic", prefix="test_nan_")
    with NewtonSolver(problem, settings) as newton:
        its, norms = newton.solve()
        assert newton.backtracked_solves == 1 and newton.full_step_solves == 0
        assert newton.options["snes_linesearch_type"] == "basic"
    assert len(norms) == its + 1 and np.all(np.isfinite(norms))
    assert norms[0] == pytest.approx(np.sqrt(3.0) * 7.875)
    assert norms[-1] <= 1e-10 * norms[0]
    assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


class _CubicWithNamedHole(_CubicWithHole):
    """... that names what is non-finite, as ContactProblem.nonfinite_cause does."""

    def __init__(self, x0):
        super().__init__(x0)
        self.asked_at = []

    def nonfinite_cause(self, x):
        self.asked_at.append(x.array.copy())
        return "the hole (x >= 8)" if np.any(x.array >= 8.0) else ""


def test_a_failed_restart_after_a_nan_names_the_cause(cubic_vectors):
    """From x = 0.5 the full step lands at 11, in the hole; the bt restart from x = 0.5 is
    cut at max_it = 2. The error names what was non-finite, from the problem's
    ``nonfinite_cause`` asked once, at the NaN iterate (11)."""
    problem = _CubicWithNamedHole(0.5)
    settings = SolverSettings(line_search="basic", max_it=2, prefix="test_nan_named_")
    with NewtonSolver(problem, settings) as newton:
        with pytest.raises(ConvergenceError) as err:
            newton.solve()
        assert newton.backtracked_solves == 1
    assert (
        "0 to the last finite residual (the next one non-finite: the hole (x >= 8)), "
        "then 2 with line search bt from there" in str(err.value)
    )
    assert len(problem.asked_at) == 1 and np.allclose(problem.asked_at[0], 11.0)


def test_no_restart_without_rescue(cubic_vectors):
    """rescue=False (a start from the predictor): the NaN fails the solve at once."""
    problem = _CubicWithHole(0.5)
    settings = SolverSettings(line_search="basic", prefix="test_norescue_")
    with NewtonSolver(problem, settings) as newton:
        with pytest.raises(ConvergenceError, match="SNES reason -4 DIVERGED_FNORM_NAN"):
            newton.solve(rescue=False)
        assert newton.backtracked_solves == 0
    assert np.allclose(problem.u.vector.array, 0.5)


def test_mumps_ordering_by_dimension(cubic_vectors):
    """2D problems factorize with AMD (MUMPS_ORDERING_2D), 3D ones with MUMPS's own choice;
    a [solver.petsc] entry overrides; no MUMPS option without MUMPS."""
    from types import SimpleNamespace

    def ordering(linear, gdim):
        opts = solver_module._linear_options(linear, SimpleNamespace(gdim=gdim))
        return {k: v for k, v in opts.items() if k.startswith("mat_mumps")}

    assert ordering("mumps", 2) == {"mat_mumps_icntl_7": solver_module.MUMPS_ORDERING_2D}
    assert ordering("lu", 2) == {"mat_mumps_icntl_7": solver_module.MUMPS_ORDERING_2D}
    assert ordering("mumps", 3) == {}
    assert ordering("superlu_dist", 2) == {} and ordering("petsc", 2) == {}
    problem = _Cubic(1.0)
    problem.gdim = 2
    for petsc, want in (({}, "0"), ({"mat_mumps_icntl_7": 5}, "5")):
        with NewtonSolver(problem, SolverSettings(prefix="test_ord_", petsc=petsc)) as newton:
            assert str(newton.options["mat_mumps_icntl_7"]) == want


def test_solvers_alive_at_the_same_time_keep_their_own_options(cubic_vectors):
    """Two solvers with the same prefix: each solves with its own settings. The second
    one's options were written over the first one's in PETSc's global database, so the
    first solved with them (a probe's frictional patch factorized with the second
    solver's Cholesky and failed). The database holds the options of the solver that
    worked last, a host program's options of the prefix are set aside while solvers'
    are loaded, and come back when the solvers are destroyed."""
    opts = PETSc.Options()

    def held():
        return {k: opts.getString(k) for k in opts.getAll() if k.startswith("test_two_")}

    opts["test_two_ksp_rtol"] = "0.5"  # a host's option of the prefix
    try:
        first = NewtonSolver(_Cubic(1.0), SolverSettings(prefix="test_two_"))
        second = NewtonSolver(
            _Cubic(1.0),
            SolverSettings(prefix="test_two_", petsc={"ksp_type": "cg", "pc_type": "jacobi"}),
        )
        with first, second:
            assert held()["test_two_ksp_type"] == "cg" and "test_two_ksp_rtol" not in held()
            its, norms = first.solve()
            assert norms[-1] <= 1e-9 * norms[0]
            ksp = first.snes.getKSP()
            assert (ksp.getType(), ksp.getPC().getType()) == ("preonly", "lu")
            assert held()["test_two_ksp_type"] == "preonly"
            second.solve()
            ksp = second.snes.getKSP()
            assert (ksp.getType(), ksp.getPC().getType()) == ("cg", "jacobi")
            first.solve()
            assert first.snes.getKSP().getType() == "preonly"
            assert first.options["ksp_type"] == "preonly" and second.options["ksp_type"] == "cg"
        assert held() == {"test_two_ksp_rtol": "0.5"}
    finally:
        opts.delValue("test_two_ksp_rtol")


def test_solver_options_of_nested_prefixes_and_of_a_collected_solver(cubic_vectors):
    """A solver of prefix ``t_n_`` loading its options set aside every option starting with
    ``t_n_``, the loaded options of a solver of prefix ``t_n_x_`` included: those were
    gone during that solver's solves and came back at the first one's destroy as a host's.
    A solver collected without destroy() left its options in the database and the host's
    set aside for good. An empty prefix (every option the solver's) is refused."""
    import gc

    opts = PETSc.Options()

    def held(prefix):
        return {k for k in opts.getAll() if k.startswith(prefix)}

    inner = NewtonSolver(
        _Cubic(1.0), SolverSettings(prefix="t_n_x_", petsc={"ksp_type": "cg", "pc_type": "none"})
    )
    outer = NewtonSolver(_Cubic(1.0), SolverSettings(prefix="t_n_"))
    with inner, outer:
        assert "t_n_x_ksp_type" in held("t_n_") and "t_n_ksp_type" in held("t_n_")
        inner.solve()
        assert inner.snes.getKSP().getType() == "cg"
    assert held("t_n_") == set()
    opts["t_gc_ksp_rtol"] = "0.5"  # a host's option
    try:
        dropped = NewtonSolver(_Cubic(1.0), SolverSettings(prefix="t_gc_"))
        assert "t_gc_ksp_rtol" not in held("t_gc_")
        del dropped
        gc.collect()
        assert held("t_gc_") == {"t_gc_ksp_rtol"}
    finally:
        opts.delValue("t_gc_ksp_rtol")
    for prefix in ("", "-dm_", "dm x_"):
        with pytest.raises(ValueError, match="SolverSettings.prefix: a PETSc options prefix"):
            SolverSettings(prefix=prefix)


def test_symmetric_jacobians_factorize_ldlt(cubic_vectors, monkeypatch):
    """MUMPS factorizes LDLᵀ (pc_type cholesky) where problem.symmetric_jacobian holds, LU
    otherwise; other solvers keep their LU; [solver.petsc] pc_type overrides; the solve
    reaches the same solution with either factorization (the same line search in each:
    a symmetric problem's would be ENERGY_LINE_SEARCH, whose iterates differ)."""
    from types import SimpleNamespace

    monkeypatch.setattr(solver_module, "ENERGY_LINE_SEARCH", "")

    def pc(linear, symmetric):
        problem = SimpleNamespace(gdim=3, symmetric_jacobian=symmetric)
        return solver_module._linear_options(linear, problem).get("pc_type")

    assert pc("mumps", True) == "cholesky" and pc("lu", True) == "cholesky"
    assert pc("mumps", False) == "lu" and pc("superlu_dist", True) == "lu"
    assert pc("petsc", True) is None
    solutions = {}
    for symmetric, petsc, want in (
        (True, {}, "cholesky"),
        (False, {}, "lu"),
        (True, {"pc_type": "lu"}, "lu"),
    ):
        problem = _Cubic(1.0)
        problem.symmetric_jacobian = symmetric  # _Cubic's Jacobian is diagonal
        with NewtonSolver(problem, SolverSettings(prefix="test_sym_", petsc=petsc)) as newton:
            newton.solve()
            assert newton.snes.getKSP().getPC().getType() == want
        solutions[want, bool(petsc)] = problem.u.vector.array.copy()
    ref = solutions["lu", False]
    for x in solutions.values():
        assert np.allclose(x, ref, rtol=1e-12, atol=1e-14)


class _Swap(_Cubic):
    """R(x) = P x − (1, 2) with P = [[0, 1], [1, 0]]: symmetric, indefinite, with a zero
    diagonal. Its matrix is flagged SPD, so MUMPS's LDLᵀ takes it without pivoting and
    fails on the zero pivot, where LU (with pivoting) solves it."""

    n = 2
    symmetric_jacobian = True

    def create_matrix(self):
        A = PETSc.Mat().createAIJ([self.n, self.n], nnz=2, comm=self.comm)
        A.setUp()
        A.setOption(PETSc.Mat.Option.SPD, True)
        return A

    def residual(self, x, b):
        b.array[:] = x.array[::-1] - np.array([1.0, 2.0])

    def jacobian(self, x, A):
        A.zeroEntries()
        A.setValue(0, 1, 1.0)
        A.setValue(1, 0, 1.0)
        A.assemble()
        A.setOption(PETSc.Mat.Option.SPD, True)


def test_a_failed_ldlt_factorization_falls_back_to_lu(cubic_vectors):
    """An LDLᵀ factorization that fails (here a zero pivot that the SPD flag forbids
    MUMPS to pivot around) makes the solver factorize LU from then on and solve again
    from the start: the solve converges, ldlt_fallbacks counts it, the solver's options
    say lu."""
    problem = _Swap(0.0)
    settings = SolverSettings(prefix="test_fallback_")
    with NewtonSolver(problem, settings) as newton:
        assert newton.snes.getKSP().getPC().getType() == "cholesky"
        its, norms = newton.solve()
        assert newton.ldlt_fallbacks == 1
        assert newton.snes.getKSP().getPC().getType() == "lu"
        assert newton.options["pc_type"] == "lu"
        newton.solve()  # later solves keep LU
        assert newton.ldlt_fallbacks == 1
    assert np.allclose(problem.u.vector.array, [2.0, 1.0])


def _line_search_tolerances(snes) -> tuple[float, int]:
    """The line search's maxstep and max_its (SNESLineSearchGetTolerances through ctypes,
    as compat.set_line_search_max_step and set_line_search_max_it set them)."""
    import ctypes

    from dolfinx_mortar import compat

    lib = compat._petsc_c_library()
    int_t = ctypes.c_int64 if np.dtype(PETSc.IntType).itemsize == 8 else ctypes.c_int32
    ls = ctypes.c_void_p()
    assert lib.SNESGetLineSearch(ctypes.c_void_p(snes.handle), ctypes.byref(ls)) == 0
    reals, n = [ctypes.c_double() for _ in range(5)], int_t()
    get = lib.SNESLineSearchGetTolerances
    get.argtypes = [ctypes.c_void_p] + [ctypes.POINTER(ctypes.c_double)] * 5
    get.argtypes += [ctypes.POINTER(int_t)]
    assert get(ls, *(ctypes.byref(r) for r in reals), ctypes.byref(n)) == 0
    return reals[1].value, n.value


def _line_search_max_it(snes) -> int:
    """The line search's max_its (:func:`_line_search_tolerances`)."""
    return _line_search_tolerances(snes)[1]


@pytest.mark.parametrize(
    "first, scale, expected",
    [(True, 1.0, solver_module.FIRST_CONTACT_L2_STEPS), (False, 1.0, 1), (True, 100.0, 1)],
    ids=["first-contact", "in-contact", "stiff-penalty"],
)
def test_l2_secant_steps_at_first_contact(cubic_vectors, first, scale, expected):
    """FIRST_CONTACT_L2_STEPS secant steps in a solve whose contact term starts with no
    active node (``first_contact``, decided at its first Jacobian), one otherwise and
    where a penalty is stiffer than auto (round_off_scale > 1); the solve converges."""
    from types import SimpleNamespace

    problem = _Cubic(10.0)
    problem.contacts = [SimpleNamespace(first_contact=first, step_limit=lambda trial, d: 1.0)]
    problem.round_off_scale = scale
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_l2steps_")
    with NewtonSolver(problem, settings) as newton:
        newton.solve()
        assert _line_search_max_it(newton.snes) == expected
    assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


def _line_search_type(snes) -> str:
    """The type of the SNES's line search object (SNESLineSearchGetType through ctypes)."""
    import ctypes

    from dolfinx_mortar import compat

    lib = compat._petsc_c_library()
    ls, name = ctypes.c_void_p(), ctypes.c_char_p()
    assert lib.SNESGetLineSearch(ctypes.c_void_p(snes.handle), ctypes.byref(ls)) == 0
    lib.SNESLineSearchGetType.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_char_p)]
    assert lib.SNESLineSearchGetType(ls, ctypes.byref(name)) == 0
    return name.value.decode()


@pytest.mark.parametrize(
    "symmetric, first, scale, expected",
    [
        (True, False, 1.0, solver_module.ENERGY_LINE_SEARCH),
        (False, False, 1.0, "l2"),
        (True, True, 1.0, "l2"),
        (True, False, 100.0, "l2"),
    ],
    ids=["symmetric", "unsymmetric", "first-contact", "stiff-penalty"],
)
def test_energy_line_search_where_the_residual_is_a_gradient(
    cubic_vectors, symmetric, first, scale, expected
):
    """A solve of a problem whose Jacobians are symmetric uses ENERGY_LINE_SEARCH ("cp",
    one secant step), except at first contact and with a penalty stiffer than auto; any
    other solve "l2". The options database keeps "l2", and a later first-contact solve
    of the same solver uses "l2" again; every solve converges."""
    from types import SimpleNamespace

    assert solver_module.ENERGY_LINE_SEARCH == "cp"
    problem = _Cubic(10.0)
    term = SimpleNamespace(first_contact=first, step_limit=lambda trial, d: 1.0)
    problem.contacts = [term]
    problem.round_off_scale = scale
    problem.symmetric_jacobian = symmetric  # _Cubic's Jacobian is diagonal
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_energy_ls_")
    with NewtonSolver(problem, settings) as newton:
        newton.solve()
        assert _line_search_type(newton.snes) == expected
        assert newton._line_search_type() == "l2"
        if expected == "cp":
            assert _line_search_max_it(newton.snes) == 1
        assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)
        problem.u.vector.set(10.0)
        term.first_contact = True
        newton.solve()
        assert _line_search_type(newton.snes) == "l2"
    assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


class _Bump(_Cubic):
    """R(x) = x − 1 + 3.5 b(x) per entry, b the hat of height 1 on [0.2, 0.8] (a kink of
    the residual between the samples of a line search), J = R′: from x = 0 the Newton step
    lands on the root x = 1, and ‖R‖² along it is 3, 27, 0 at λ = 0, 1/2, 1 (three
    entries), a concave fit that "l2" follows to λ = 1 + 35/68 ≈ 1.51."""

    def residual(self, x, b):
        hat = np.maximum(0.0, 1.0 - np.abs(x.array - 0.5) / 0.3)
        b.array[:] = x.array - 1.0 + 3.5 * hat

    def jacobian(self, x, A):
        A.zeroEntries()
        for i, v in enumerate(x.array):
            slope = -np.sign(v - 0.5) / 0.3 if abs(v - 0.5) < 0.3 else 0.0
            A.setValue(i, i, 1.0 + 3.5 * slope)
        A.assemble()


@pytest.mark.parametrize("cap", ["L2_MAX_STEP", "none", "scene"])
def test_l2_does_not_step_beyond_the_newton_step(cubic_vectors, monkeypatch, cap):
    """The line search "l2" takes at most the full Newton step (L2_MAX_STEP = 1): where
    its parabola is concave it would step beyond it, uphill of all its samples. On _Bump
    the full step is the root (one iteration); uncapped (L2_MAX_STEP = PETSc's 1e8, or a
    scene's snes_linesearch_maxstep, which overrides the cap) "l2" lands at λ ≈ 1.51 and
    needs a second. A later "bt" solve of the same solver gets PETSc's maxstep back (for
    "bt" a bound on the step's norm)."""
    assert solver_module.L2_MAX_STEP == 1.0
    petsc = {"snes_linesearch_maxstep": 1e8} if cap == "scene" else {}
    if cap == "none":
        monkeypatch.setattr(solver_module, "L2_MAX_STEP", 1e8)
    problem = _Bump(0.0)
    settings = SolverSettings(rtol=1e-10, atol=1e-14, petsc=petsc, prefix="test_l2_cap_")
    with NewtonSolver(problem, settings) as newton:
        its, norms = newton.solve()
        assert _line_search_type(newton.snes) == "l2"
        if cap == "L2_MAX_STEP":
            assert its == 1 and _line_search_tolerances(newton.snes)[0] == 1.0
        else:
            assert its == 2 and norms[1] == pytest.approx(np.sqrt(3) * 35 / 68, rel=1e-9)
        problem.u.vector.set(0.0)
        with newton._line_search_as("bt", 20):
            newton.solve()
        assert _line_search_tolerances(newton.snes)[0] == 1e8
    assert np.allclose(problem.u.vector.array, 1.0, rtol=1e-9)


class _Kink(_Cubic):
    """R(x) = −0.1 + 100 max(x − 1, 0) per entry (root 1.001), the gradient of a potential
    that is linear up to x = 1 and stiff beyond (a node closing against a penalty), with
    a weak spring 0.01 in J before the kink: from x = 0 the energy's directional
    derivative along the Newton step is flat up to the kink, and one secant step of "cp"
    from λ = 0 and 1 lands near 0 (λ ≈ 1e-4)."""

    def residual(self, x, b):
        b.array[:] = -0.1 + 100.0 * np.maximum(x.array - 1.0, 0.0)

    def jacobian(self, x, A):
        A.zeroEntries()
        for i, v in enumerate(x.array):
            A.setValue(i, i, 100.0 if v >= 1.0 else 0.01)
        A.assemble()


def test_a_short_energy_step_ends_the_energy_line_search(cubic_vectors, monkeypatch):
    """A solve of a symmetric problem starts with ENERGY_LINE_SEARCH; its first step is
    shorter than ENERGY_MIN_LAMBDA, so the solve goes on with "l2" and converges. Without
    the switch (ENERGY_MIN_LAMBDA = 0) the steps stay near λ = 1e-4 until max_it, and only
    the full-step continuation of a stalled solve gets it there."""
    from types import SimpleNamespace

    problem = _Kink(0.0)
    problem.contacts = [SimpleNamespace(first_contact=False, step_limit=lambda trial, d: 1.0)]
    problem.round_off_scale = 1.0
    problem.symmetric_jacobian = True
    settings = SolverSettings(rtol=1e-10, atol=1e-12, max_it=40, prefix="test_short_cp_")
    with NewtonSolver(problem, settings) as newton:
        its, _ = newton.solve()
        assert _line_search_type(newton.snes) == "l2"
        assert newton.full_step_solves == 0
    assert np.allclose(problem.u.vector.array, 1.001, rtol=1e-9)
    monkeypatch.setattr(solver_module, "ENERGY_MIN_LAMBDA", 0.0)
    problem.u.vector.set(0.0)
    with NewtonSolver(problem, settings) as newton:
        crept, _ = newton.solve()
        assert newton.full_step_solves == 1  # max_it reached, then full steps
    assert its <= 8 and crept > settings.max_it, (its, crept)  # measured 5 and 42


class _NoisyCubic(_Cubic):
    """_Cubic whose residual carries rounding noise of size ``level`` per entry (its sign
    changes from one evaluation to the next, so no iterate gets below it), and which
    measures it as ContactProblem does."""

    def __init__(self, x0, level):
        super().__init__(x0)
        self.level = level
        self._calls = 0

    def residual(self, x, b):
        self._calls += 1
        sign = np.array([1.0, -1.0, 1.0]) * (-1.0) ** self._calls
        b.array[:] = x.array**3 - 8.0 + self.level * sign

    def residual_round_off(self):
        return self.level


def test_a_solve_on_the_round_off_floor_is_accepted(cubic_vectors):
    """atol below the residual's rounding (a force: large forces put the floor above the
    default 1e-10): the solve cannot meet its tolerances and fails; the solver measures
    the round-off level f there and accepts the iterate when ‖R‖ ≤ ROUND_OFF_ATOL × f.
    From then on every solve's atol is at least ROUND_OFF_ATOL × f, and the next one
    stops there without failing."""
    problem = _NoisyCubic(10.0, 1e-6)
    settings = SolverSettings(rtol=1e-15, atol=1e-14, prefix="test_floor_")
    with NewtonSolver(problem, settings) as newton:
        its, norms = newton.solve()
        assert its > settings.max_it  # ran out of iterations (and full steps), accepted
        assert newton.round_off == 1e-6
        assert norms[-1] <= solver_module.ROUND_OFF_ATOL * 1e-6
        assert np.allclose(problem.u.vector.array, 2.0, atol=1e-6)
        stalled = newton.full_step_solves
        problem.u.vector.set(2.5)
        its, norms = newton.solve()
        assert newton.full_step_solves == stalled and its <= 6, (its, norms)
        assert norms[-1] <= solver_module.ROUND_OFF_ATOL * 1e-6


def test_a_state_that_lost_its_digits_is_not_on_the_round_off_floor(cubic_vectors):
    """The same stall, but with rounding noise above ROUND_OFF_MAX_RELATIVE × the forces
    (the first residual norm, about 1.7e3, times that fraction): a state that lost its
    digits (a body drifting along a rigid motion grew u to 1e16), not a converged one, and
    the solve fails; the round-off level stays unmeasured."""
    level = 10.0 * solver_module.ROUND_OFF_MAX_RELATIVE * 992.0 * np.sqrt(3.0)
    settings = SolverSettings(rtol=1e-15, atol=1e-14, prefix="test_floor_lost_")
    with NewtonSolver(_NoisyCubic(10.0, level), settings) as newton:
        with pytest.raises(ConvergenceError):
            newton.solve()
        assert newton.round_off == 0.0


def test_a_solve_that_drifts_beyond_the_mesh_fails(cubic_vectors):
    """A solve whose end moves a dof by more than MAX_DISPLACEMENT_EXTENTS × the mesh's
    extent fails with an error that names a free rigid motion: the root x = 2 of _Cubic
    with an extent of 1e-3 (limit 1); with an extent of 1 it converges."""
    problem = _Cubic(10.0)
    problem.extent = 1e-3
    settings = SolverSettings(rtol=1e-10, atol=1e-14, prefix="test_drift_")
    with NewtonSolver(problem, settings) as newton:
        with pytest.raises(ConvergenceError, match="free along a rigid motion"):
            newton.solve()
        assert newton.all_iterations > 0
        problem.extent = 1.0
        problem.u.vector.set(10.0)
        newton.solve()
    assert np.allclose(problem.u.vector.array, 2.0, rtol=1e-9)


def test_without_a_round_off_measure_a_stall_still_fails(cubic_vectors):
    """A problem without ``residual_round_off``: the stall is a ConvergenceError."""

    class _Plain(_NoisyCubic):
        residual_round_off = None

    settings = SolverSettings(rtol=1e-15, atol=1e-14, prefix="test_floor_plain_")
    with NewtonSolver(_Plain(10.0, 1e-6), settings) as newton:
        with pytest.raises(ConvergenceError):
            newton.solve()


def test_a_stall_with_no_finite_round_off_level_still_fails(cubic_vectors):
    """A level that is not finite (a residual near the failed iterate was not) accepts
    nothing: the stall is a ConvergenceError, and the solver keeps no level (ironing2d's
    tiny bench had accepted a failed solve at ‖R‖ = 42 this way, once)."""

    class _NaNLevel(_NoisyCubic):
        def residual_round_off(self):
            return float("nan")

    settings = SolverSettings(rtol=1e-15, atol=1e-14, prefix="test_floor_nan_")
    with NewtonSolver(_NaNLevel(10.0, 1e-6), settings) as newton:
        with pytest.raises(ConvergenceError):
            newton.solve()
        assert newton.round_off == 0.0


@pytest.mark.mpi
def test_load_stepper_takes_the_terms_uzawa_rounds():
    """A patch test assembled through the Python API with LoadStepper's defaults: its
    Uzawa rounds per step default to the contact term's ``uzawa_max`` (20), as a scene
    run's do. The default used to be 1 round, and every step failed after 6 cutbacks
    ("Uzawa augmentation did not converge in 1 rounds")."""
    from dolfinx_mortar import ContactProblem, MortarContact
    from dolfinx_mortar.mesh import load_mesh

    md = load_mesh(MPI.COMM_WORLD, generator="patch2d", params={"n_lower": 3, "n_upper": 4})
    mats = [("lower", "linear-elastic", 100.0, 0.3), ("upper", "linear-elastic", 100.0, 0.3)]
    p = ContactProblem(
        md,
        mats,
        [("lower_bottom", None, [[0, 0, 0], [1, 0, 0]]), ("upper_left", (0,), [[0, 0], [1, 0]])],
        [("upper_top", [[0, 0, 0], [1, 0, -1.0]])],
    )
    term = MortarContact(p, "upper_bottom", "lower_top", integration="segment")
    p.add_contact(term)
    with NewtonSolver(p, SolverSettings()) as newton:
        stepper = LoadStepper(p, newton, 1.0, 2)
        assert stepper.uzawa_max == term.uzawa_max == 20
        results = stepper.run()
    assert [r.cutbacks for r in results] == [0, 0]
    assert max(r.uzawa_rounds for r in results) > 1
    force = p.comm.allreduce(float(np.sum(term.p * term.A)))  # Σ p^I A^I = the load
    assert force == pytest.approx(1.0, rel=1e-5)  # to the Uzawa tolerance (1e-6): 2.4e-7
    # one term per slave surface, as a scene's pairs (their output is per slave)
    with pytest.raises(ValueError, match="'upper_bottom' is already the slave surface"):
        p.add_contact(MortarContact(p, "upper_bottom", "lower_top", integration="element"))


_SCENE = {
    "mesh": {"generator": "patch2d"},
    "material": [{"region": "lower", "model": "neo-hookean", "E": 1.0, "nu": 0.3}],
}


@pytest.mark.parametrize(
    "name, value, error",
    [
        ("linear", "cholmod", ValueError),
        ("line_search", "nope", ValueError),
        ("rtol", 2.0, ValueError),
        ("rtol", 0.0, ValueError),
        ("atol", "tight", ValueError),
        ("atol", -1.0, ValueError),
        ("max_it", 0, ValueError),
        ("max_it", 2.5, TypeError),
        ("step_depth_limit", -0.5, ValueError),
        ("petsc", {"snes_monitor": None}, TypeError),
    ],
)
def test_solver_settings_are_checked_as_the_scene_solver_table(name, value, error):
    """SolverSettings follows ``[solver]``'s rules with the scene's reasons (one
    definition, ``scene.solver_options``): a ValueError or TypeError keyed
    ``SolverSettings.NAME`` when made. They failed later: a KeyError (linear =
    "cholmod"), PETSc's error 63 (rtol = 2), a TypeError inside the solve (atol =
    "tight"), "PETSc rejected the options []" (line_search = "nope"), every step failing
    (max_it = 0)."""
    from dolfinx_mortar.errors import SceneError
    from dolfinx_mortar.scene import parse_scene

    with pytest.raises(error) as err:
        SolverSettings(**{name: value})
    assert isinstance(err.value, SceneError)
    assert err.value.key.startswith(f"SolverSettings.{name}")
    with pytest.raises(error) as scene_err:
        parse_scene({**_SCENE, "solver": {name: value}}, ".")
    assert scene_err.value.key == err.value.key.replace("SolverSettings", "solver")
    assert scene_err.value.reason == err.value.reason


def test_solver_settings_normalizes_what_it_accepts():
    """NumPy numbers and a leading "-" of a PETSc option name are taken as the scene takes
    them."""
    s = SolverSettings(rtol=np.float32(0.5), atol=0, max_it=np.int64(5), petsc={"-ksp_view": True})
    assert (s.rtol, s.atol, s.max_it, s.petsc) == (0.5, 0.0, 5, {"ksp_view": True})
    assert type(s.max_it) is int and type(s.atol) is float


_MATS = [("lower", "linear-elastic", 100.0, 0.3), ("upper", "linear-elastic", 100.0, 0.3)]
_DBC = [
    ("lower_bottom", None, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
    ("upper_top", None, [[0.0, 0.0, 0.0], [1.0, 0.0, -0.01]]),
]


@pytest.fixture(scope="module")
def patch2d_api():
    from dolfinx_mortar.mesh import load_mesh

    return load_mesh(MPI.COMM_WORLD, generator="patch2d", params={"n_lower": 3, "n_upper": 4})


@pytest.mark.mpi
@pytest.mark.parametrize(
    "args, error, key, phrase",
    [
        # a decreasing t ran "ok" with zero load
        (
            {"dirichlet": [_DBC[0], ("upper_top", None, [[1.0, 0.0, -0.01], [0.0, 0.0, 0.0]])]},
            ValueError,
            "dirichlet[1].path",
            "path not sorted in t",
        ),
        # one value per row was broadcast to both components
        ({"tractions": [("upper_top", [[0.0, 0.0], [1.0, -1.0]])]}, ValueError, "tractions[0].path", "rows must be"),
        ({"dirichlet": [("lower_bottom", None, [[0.0, 0.0], [1.0, 0.0]])]}, ValueError, "dirichlet[0].path", "rows must be"),
        ({"dirichlet": [("lower_bottom", [2], [[0.0, 0.0]])]}, ValueError, "dirichlet[0].components", "out of range [0, 2)"),
        ({"dirichlet": [("nosuch", None, [[0.0, 0.0, 0.0]])]}, ValueError, "dirichlet[0].boundary", "not found among facet groups"),
        ({"materials": [("nosuch", "linear-elastic", 100.0, 0.3)]}, ValueError, "materials[0].region", "not found among cell groups"),
        ({"materials": [_MATS[0]]}, ValueError, "materials", "cell group(s) 'upper' have no material"),
        ({"materials": [("lower", "linear-elastic", -100.0, 0.3), _MATS[1]]}, ValueError, "materials[0].E", "must be > 0"),
        ({"materials": [("lower", "neo-hookean", 100.0, 0.5), _MATS[1]]}, ValueError, "materials[0].nu", "(-1, 0.5)"),
        ({"materials": [("lower", "foo", 100.0, 0.3), _MATS[1]]}, ValueError, "materials[0].model", "unknown value 'foo'"),
        ({"materials": [("lower", 100.0, 0.3), _MATS[1]]}, TypeError, "materials[0]", "expected a tuple (region, model, E, nu)"),
        ({"degree": 0}, ValueError, "degree", "must be >= 1"),
    ],
)  # fmt: skip
def test_contact_problem_checks_its_arguments_as_the_scene_does(
    patch2d_api, args, error, key, phrase
):
    """ContactProblem's materials, Dirichlet conditions, tractions and degree follow the
    rules of ``[[material]]``, ``[[dirichlet]]`` and ``[[traction]]`` (the scene's checks,
    ``scene.problem_inputs``): a ValueError or TypeError naming the argument, on every
    rank, before any collective. They ran with a wrong load, or failed later with a bare
    KeyError, an empty AssertionError inside dolfinx, a UFLException or a
    ZeroDivisionError."""
    from dolfinx_mortar import ContactProblem

    kwargs = {"materials": _MATS, "dirichlet": _DBC, **args}
    with pytest.raises(error) as err:
        ContactProblem(patch2d_api, **kwargs)
    assert err.value.key == key, str(err.value)
    assert phrase in err.value.reason, str(err.value)


def test_contact_problem_takes_what_it_took_before_its_checks(patch2d_api):
    """Inputs the API took before it checked them still work: components as a range,
    materials as a generator, paths as NumPy arrays (a probe of the checks)."""
    from dolfinx_mortar import ContactProblem

    problem = ContactProblem(
        patch2d_api,
        materials=(m for m in _MATS),
        dirichlet=[(name, range(2), np.asarray(path)) for name, _, path in _DBC],
    )
    assert [d.components for d in problem._dirichlet] == [(0, 1), (0, 1)]
    assert len(problem.materials) == 2
    problem.destroy()


@pytest.mark.mpi
def test_api_names_a_bad_surface_boundary_or_component(patch2d_api):
    """MortarContact's slave / master and add_dirichlet_field's name and components are
    checked as the scene's are: one SceneError / SceneTypeError naming the argument, on
    every rank (session 52: KeyError 'nope' for a missing or a cell group, a bare
    AssertionError from UFL for component 7, numpy's ambiguous truth value for a
    recovery given as an array)."""
    from dolfinx_mortar import ContactProblem, MortarContact
    from dolfinx_mortar.errors import SceneError, SceneTypeError

    problem = ContactProblem(patch2d_api, materials=_MATS, dirichlet=[_DBC[0]])

    def field(t, x):
        return np.zeros((2, x.shape[1]))

    def contact(*surfaces, **kw):
        return lambda: MortarContact(problem, *surfaces, **kw)

    def dirichlet(name, components=None):
        return lambda: problem.add_dirichlet_field(name, field, components=components)

    fk, ck = "add_dirichlet_field.name", "add_dirichlet_field.components"
    for call, error, key, phrase in [
        (contact("upper_bottom", "nope"), SceneError, "contact.master", "'nope' not found"),
        (contact("upper", "lower_top"), SceneError, "contact.slave", "'upper' is a cell group"),
        (contact(None, "lower_top"), SceneTypeError, "contact.slave", "expected a string"),
        (
            contact("upper_bottom", "lower_top", recovery=np.array(["lumped", "x"])),
            SceneTypeError,
            "contact.recovery",
            "expected a string, one of unconstrained, lumped, constrained; got ndarray",
        ),
        (dirichlet("nope"), SceneError, fk, "'nope' not found among facet groups"),
        (dirichlet("upper"), SceneError, fk, "'upper' is a cell group"),
        (dirichlet("upper_top", [7]), SceneError, ck, "component 7 out of range [0, 2)"),
        (dirichlet("upper_top", [-1]), SceneError, ck, "component -1 out of range"),
        (dirichlet("upper_top", [1, 1]), SceneError, ck, "a component is named twice"),
        (dirichlet("upper_top", []), SceneError, ck, "empty"),
        (dirichlet("upper_top", ["0"]), SceneTypeError, ck, "expected integers, got str"),
        (dirichlet("upper_top", [True]), SceneTypeError, ck, "expected integers, got bool"),
        (dirichlet("upper_top", 1), SceneTypeError, ck, "expected a sequence of integers"),
        (dirichlet("lower_bottom"), SceneError, ck, "already prescribed"),
    ]:
        with pytest.raises(error) as info:
            call()
        assert info.value.key == key and phrase in info.value.reason, str(info.value)
    problem.add_dirichlet_field("upper_top", field, components=np.array([1]))  # still works
    assert [d.components for d in problem._dirichlet][-1] == (1,)
    problem.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize(
    "degree, what",
    [
        (3, "the displacement degree 3 (ContactProblem's degree) is not supported"),
        (2, "the displacement degree 2 (ContactProblem's degree) differs from the mesh's "),
    ],
)
def test_mortar_contact_names_an_unsupported_degree(patch2d_api, degree, what):
    """A ContactProblem of displacement degree 3 (or one that is not the mesh's geometry
    order) is one SceneError naming ``contact.problem`` and the degrees mortar contact
    takes, before any collective (session 53: a plain ValueError, "no contact facets for
    triangle of degree 3" from surface.facet_type, or "contact needs the displacement
    degree to equal the geometric degree"). The scene cannot ask for it: no key sets the
    degree, and a generator's order 3 or a P3 mesh file is refused by name
    (test_generators, test_mesh)."""
    from dolfinx_mortar import ContactProblem, MortarContact
    from dolfinx_mortar.errors import SceneError

    assert patch2d_api.mesh.geometry.cmap.degree == 1
    problem = ContactProblem(patch2d_api, _MATS, degree=degree)
    with pytest.raises(SceneError) as info:
        MortarContact(problem, "upper_bottom", "lower_top", key="contact[0]")
    assert info.value.key == "contact[0].problem"
    assert info.value.reason.startswith(what), info.value.reason
    assert info.value.reason.endswith(
        "mortar contact takes degrees 1 and 2 (P1/Q1, P2/Q2), equal to the mesh's geometry "
        "order (here 1; ContactProblem's default)"
    ), info.value.reason
    problem.destroy()


def test_run_names_an_out_dir_that_is_not_a_path(tmp_path):
    """run's out_dir is a string or a pathlib.Path (None: the scene's output.dir); else one
    SceneTypeError keyed out_dir, before the mesh is built (session 53: a bare TypeError
    from ``Path(3)``)."""
    from dolfinx_mortar import parse_scene, run
    from dolfinx_mortar.errors import SceneTypeError

    materials = [
        {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3} for r in ("lower", "upper")
    ]
    data = {"kinematics": "small", "mesh": {"generator": "patch2d"}, "material": materials}
    scene = parse_scene(data, tmp_path)
    for bad, shown in ((3, "integer 3"), (b"out", "bytes b'out'")):
        with pytest.raises(SceneTypeError) as info:
            run(scene, MPI.COMM_WORLD, out_dir=bad)
        assert str(info.value) == (
            f"out_dir: expected a path (a string or a pathlib.Path), got {shown}"
        )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.mpi
def test_add_contact_takes_terms_of_this_problem_before_the_solver(patch2d_api):
    """add_contact refuses what is not a term (a str was accepted and failed later), a
    term built on another problem (it ran with that problem's factorization; on another
    communicator the job hung) and a term added while a NewtonSolver of the problem lives
    (a zip ValueError in pattern_outdated); after the solver is destroyed it is taken,
    and the next solver solves with it."""
    from dolfinx_mortar import ContactProblem, MortarContact
    from dolfinx_mortar.mesh import load_mesh

    p = ContactProblem(patch2d_api, _MATS, _DBC)
    q = ContactProblem(patch2d_api, _MATS, _DBC)
    with pytest.raises(TypeError, match="add_contact takes a contact term"):
        p.add_contact("hello")
    other = MortarContact(q, "upper_bottom", "lower_top")
    with pytest.raises(ValueError, match="built on another ContactProblem"):
        p.add_contact(other)
    if MPI.COMM_WORLD.size > 1:  # a problem on another communicator
        md_self = load_mesh(MPI.COMM_SELF, generator="patch2d", params={"n_lower": 3})
        s = ContactProblem(md_self, _MATS, _DBC)
        alone = MortarContact(s, "upper_bottom", "lower_top")
        with pytest.raises(ValueError, match="built on another ContactProblem"):
            p.add_contact(alone)
        alone.destroy()
        s.destroy()
    term = MortarContact(p, "upper_bottom", "lower_top")
    with NewtonSolver(p, SolverSettings(prefix="test_late_term_")):
        with pytest.raises(RuntimeError, match="before creating the NewtonSolver"):
            p.add_contact(term)
    p.add_contact(term)
    with NewtonSolver(p, SolverSettings(prefix="test_late_term_")) as newton:
        results = LoadStepper(p, newton, 1.0, 1).run()
    assert [r.t for r in results] == [1.0]
    assert results[0].uzawa_rounds == 2  # this problem's own exact update (the other's: 8)
    other.destroy()
    q.destroy()
    p.destroy()


def test_destroy_is_idempotent(patch2d_api, caplog):
    """A second destroy() does nothing: it logged the unused-option warning again (a
    solver destroyed by hand inside its ``with`` block). The host's options and the
    problem's hooks (now another solver's) stay as the first call left them."""
    from dolfinx_mortar import ContactProblem, MortarContact

    p = ContactProblem(patch2d_api, _MATS, _DBC)
    p.add_contact(MortarContact(p, "upper_bottom", "lower_top"))
    opts = PETSc.Options()
    opts["test_twice_host_opt"] = "7"
    try:
        with NewtonSolver(
            p, SolverSettings(prefix="test_twice_", petsc={"snes_monitr": True})
        ) as newton:
            LoadStepper(p, newton, 1.0, 1).run()
            assert not opts.hasName("test_twice_host_opt")  # set aside while loaded
            with caplog.at_level("WARNING", logger="dolfinx_mortar.solver"):
                newton.destroy()
                assert opts.getString("test_twice_host_opt") == "7"  # put back
                assert p.linear_inverse is None
                later = NewtonSolver(p, SolverSettings(prefix="test_twice_"))
                newton.destroy()  # again: the later solver keeps its hooks
                assert p.linear_inverse == later.solve_with_last_jacobian
            # and __exit__ a third time
        later.destroy()
        warned = [r for r in caplog.records if "never read the option" in r.getMessage()]
        assert len(warned) == 1, [r.getMessage() for r in warned]
        assert "-test_twice_snes_monitr" in warned[0].getMessage()
    finally:
        opts.delValue("test_twice_host_opt")
        for term in p.contacts:
            term.destroy()
        p.destroy()


def test_the_open_contact_hint_does_not_blame_the_loads_after_contact_was_lost():
    """A pair open at the failed attempt's last iterate that had a node in contact at an
    earlier one (``touched_in_attempt``) is told apart from one that never touched: Newton
    lost the contact it had found, which says nothing of the loads. A traction-loaded full
    2D Hertz model with node integration (its cylinder free to turn about its centre:
    frictionless contact cannot hold that rotation) had been told to check the direction
    of the loads, which were right."""

    class Term:
        name = "a:b"
        free_body = True
        touched_in_attempt = True

    class P:
        contacts = [Term()]

        def open_pairs(self):
            return ["a:b"]

        def unpaired_pairs(self):
            return []

    text = solver_module._open_contact_hint(P())
    assert "no slave node of a:b was in contact at the failed attempt's last iterate" in text
    assert "though some were at earlier ones" in text
    assert "direction of the loads" not in text
    Term.touched_in_attempt = False
    text = solver_module._open_contact_hint(P())
    assert "no slave node of a:b was in contact: a body held only by contact" in text
    assert "check the direction of the loads" in text
    assert "earlier ones" not in text


def test_a_contact_term_records_whether_an_attempt_touched(tmp_path):
    """``touched_in_attempt``: set by a contact update with a node in contact, reset by
    ``begin_step`` (the start of every attempt). The coarse hertz2d scene, one step."""
    from test_contact_parallel import HERTZ2D

    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    held = []
    data = {**HERTZ2D, "steps": {"n": 1}}
    s = run(parse_scene(data, tmp_path), MPI.COMM_SELF, out_dir=tmp_path, setup=held.append)
    problem = held[0]
    try:
        assert s["status"] == "ok", s.get("error")
        (term,) = problem.contacts
        assert term.touching and term.touched_in_attempt
        problem.begin_step()
        assert not term.touched_in_attempt
    finally:
        problem.destroy()


def test_a_stopped_run_names_a_tangential_load_beyond_friction(shared_tmp):
    """A block held along x by friction alone (μ = 0.2), pushed by a traction whose ratio
    to the pressure rises to 0.21: no equilibrium beyond q = μp. The run stops, and its
    error says why (a probe's run stopped at q/p = 0.1985 with DIVERGED_DTOL and no word
    of friction): 7 of the 8 active slave nodes slipped in the last converged step.
    Serial (the counts are reduced in ``commit_step``; the same message on 2 and 3 ranks,
    checked by hand in session 54)."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    data = {
        "mesh": {
            "generator": "patch2d",
            "params": {"margin": 0.25, "n_lower": 12, "n_upper": 7, "n_y": 3},
        },
        "kinematics": "small",
        "material": [
            {"region": r, "model": "linear-elastic", "E": 10.0, "nu": 0.3}
            for r in ("lower", "upper")
        ],
        "contact": [
            {
                "slave": "upper_bottom",
                "master": "lower_top",
                "friction": 0.2,
                "integration": "segment",
            }
        ],
        "dirichlet": [{"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0]]}],
        "traction": [
            {
                "boundary": "upper_top",
                "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.1], [2.0, 0.021, -0.1]],
            }
        ],
        "steps": {"t_end": 2.0, "n": 4},
    }
    out = shared_tmp / f"beyond_mu_{MPI.COMM_WORLD.size}"
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=out)
    assert s["status"] == "failed", s["status"]
    assert s["steps"][-1]["t"] < 2.0 and len(s["steps"]) >= 3  # the press and a slide kept
    last = s["steps"][-1]
    text = (
        f"body 'upper' is free in translation along x but for friction "
        f"(upper_bottom:lower_top), and {last['slip_nodes']} of its {last['active_nodes']} "
        "active slave nodes slipped in the last converged step: a tangential load above "
        "the friction coefficient times the normal load has no equilibrium"
    )
    assert text in s["error"], s["error"]
    assert 2 * last["slip_nodes"] >= last["active_nodes"] > 0, last


@pytest.mark.parametrize(("slip", "hint"), [((8, 7), True), ((8, 4), True), ((8, 3), False)])
def test_the_friction_hint_needs_half_the_nodes_slipping(slip, hint):
    """:func:`solver._friction_hold_hint` names a body that only stick holds where at
    least half of its pairs' active nodes slipped in the last converged step, and leaves
    a body that the stick clause of a run with no contact at t = 0 names to that clause."""
    from types import SimpleNamespace

    from dolfinx_mortar.problem import UnheldBody

    body = UnheldBody("'upper'", np.eye(3)[:1], ["a:b"])
    problem = SimpleNamespace(
        gdim=2,
        contacts=[SimpleNamespace(name="a:b", committed_slip=slip)],
        stick_only_motions=lambda: [body],
        stick_free_at_start=[],
    )
    text = solver_module._friction_hold_hint(problem)
    assert bool(text) == hint, text
    if hint:
        assert f"{slip[1]} of its {slip[0]} active slave nodes slipped" in text
        assert "translation along x but for friction (a:b)" in text
    problem.stick_free_at_start = [body]
    assert solver_module._friction_hold_hint(problem) == ""


def test_the_penalty_hint_names_penalties_beyond_the_measured_band():
    """``MortarContact.stiff_penalty_note`` (read by the error of a run that stops, a
    probe's penalty 1e10 × auto ended in DIVERGED_DTOL, a tangential one in "Uzawa
    augmentation stalled", neither naming the penalty): a clause for each penalty above
    MEASURED_PENALTY_RATIO times the auto normal penalty, none at or below it."""
    from types import SimpleNamespace

    from dolfinx_mortar.contact import MEASURED_PENALTY_RATIO, MortarContact

    def note(normal, tangential, **soft):
        pair = SimpleNamespace(name="a:b", penalty_ratio=normal, _penalty_t_ratio=tangential)
        pair.__dict__.update({"softness": 1.0, "softness_t": 1.0, "uzawa_tol": 1e-6, **soft})
        pair._soft_clause = lambda: MortarContact._soft_clause(pair)
        return MortarContact.stiff_penalty_note(pair)

    assert note(MEASURED_PENALTY_RATIO, 0.1) == ""
    text = note(9.94e9, 0.1)
    assert text.startswith("on a:b the penalty is 9.94e+09 times the auto normal penalty")
    assert "penalty_tangential" not in text
    text = note(1.0, 2.6e5)
    assert text.startswith("on a:b the penalty_tangential is 2.6e+05 times"), text
    # session 65: with Uzawa rounds, a penalty more than SOFT_PENALTY_NOTE times softer
    # than its auto rule (the rounds crawl); not as pure penalty, nor 10 times softer
    text = note(1e-9, 1e-9, softness=2.2e8, softness_t=2.2e7)
    assert text.startswith(
        "on a:b the penalty is up to 2.2e+08 times softer and the penalty_tangential is up "
        "to 2.2e+07 times softer than its auto rule"
    ), text
    assert note(1e-9, 1e-9, softness=2.2e8, uzawa_tol=0.0) == ""
    assert note(0.1, 0.1, softness=10.0) == ""
    problem = SimpleNamespace(
        contacts=[SimpleNamespace(stiff_penalty_note=lambda: "x"), SimpleNamespace()]
    )
    assert solver_module._penalty_hint(problem) == "; x"


def test_round_text_reads_an_uzawa_round():
    """:func:`solver._round_text`: a round's per-pair information in words, two digits
    (an error had printed the raw dicts)."""
    info = {
        "a:b": {
            "multiplier_change": 2.0164425684635276e-12,
            "max_penetration": 2.6e-19,
            "tangential_change": 1.96e-4,
            "exact_update": "newton (2 products)",
        },
        "c:d": {"multiplier_change": 0.5},
    }
    assert solver_module._round_text(info) == (
        "a:b: change 2e-12, tangential change 0.0002, largest penetration 2.6e-19; c:d: change 0.5"
    )


def _turn(theta, x, centre=(0.5, 1.0)):
    """The displacement (2, n) of a rigid rotation by ``theta`` (rad) about ``centre``."""
    dx, dy = x[0] - centre[0], x[1] - centre[1]
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([(c - 1.0) * dx - s * dy, s * dx + (c - 1.0) * dy])


@pytest.mark.mpi
def test_the_corner_check_reads_dirichlet_fields(patch2d_api):
    """``_path_bends`` sees a corner of an add_dirichlet_field path (press, then slide),
    not a straight one (the slide alone; a linearised rotation, as demo_twist3d's); a rigid
    rotation by 22.5° a step is a corner at every step (each node's rate turns by 22.5°:
    a relative change of 2 sin(11.25°) = 0.39 > PATH_RATE_TOL), by 1° a step none (0.017;
    compared dof by dof, the y rate of the node above the centre, quadratic in the angle,
    changed by 0.67 even so). The values are the field's at the owned nodes it holds: one
    row per node of the top over the ranks."""
    from dolfinx_mortar import ContactProblem

    def press_slide(t, x):
        u = np.array([0.1 * max(t - 1.0, 0.0), -0.01 * min(t, 1.0)])
        return np.repeat(u[:, None], x.shape[1], axis=1)

    def linear_twist(t, x):
        return 0.01 * t * np.stack([-(x[1] - 1.0), x[0] - 0.5])

    bends = solver_module._path_bends
    problem = ContactProblem(patch2d_api, materials=_MATS, dirichlet=[_DBC[0]])
    problem.add_dirichlet_field("upper_top", press_slide)
    assert problem.has_dirichlet_fields
    n = problem.comm.allreduce(len(problem.field_values(0.0)))
    assert n == 4 + 1  # patch2d n_upper = 4: 5 nodes on the top
    assert bends(problem, 0.5, 1.0, 1.5)
    assert not bends(problem, 0.0, 0.5, 1.0) and not bends(problem, 1.0, 1.5, 2.0)
    problem.destroy()
    for field, corners in [
        (linear_twist, [False, False]),
        (lambda t, x: _turn(np.radians(22.5) * t, x), [True, True]),
        (lambda t, x: _turn(np.radians(1.0) * t, x), [False, False]),
    ]:
        problem = ContactProblem(patch2d_api, materials=_MATS, dirichlet=[_DBC[0]])
        problem.add_dirichlet_field("upper_top", field)
        assert [bends(problem, t, t + 1.0, t + 2.0) for t in (0.0, 3.0)] == corners
        problem.destroy()


@pytest.mark.mpi
def test_a_field_corner_on_one_rank_is_a_corner_on_every_rank(patch2d_api):
    """Each rank evaluates the field at its own nodes: a field whose path bends only on the
    first rank that holds nodes of it (straight on the others, which hold nodes too: on 2
    ranks upper_bottom is split) makes ``_path_bends`` True on every rank (a logical-or
    allreduce over the problem's communicator); a rank-local answer (True, False here
    without it) would let the ranks start the step from different predictors."""
    from dolfinx_mortar import ContactProblem

    who = {"rank": -1}

    def field(t, x):
        ramp = min(t, 1.0) if MPI.COMM_WORLD.rank == who["rank"] else t
        return np.stack([0.0 * x[0], np.full_like(x[0], -0.01 * ramp)])

    problem = ContactProblem(patch2d_api, materials=_MATS, dirichlet=[_DBC[0]])
    problem.add_dirichlet_field("upper_bottom", field)
    comm = problem.comm
    holders = comm.allgather(len(problem.field_values(0.0)) > 0)
    assert sum(holders) == min(comm.size, 2), holders
    who["rank"] = holders.index(True)
    ts = (0.5, 1.0, 1.5)
    local = solver_module._rates_change(*(problem.field_values(t) for t in ts), *ts)
    assert comm.allgather(local) == [r == who["rank"] for r in range(comm.size)]
    assert comm.allgather(solver_module._path_bends(problem, *ts)) == [True] * comm.size
    assert not solver_module._path_bends(problem, 1.0, 1.5, 2.0)
    problem.destroy()


def test_output_times_within_round_off_of_a_step_are_that_step():
    """An output time within TARGET_MERGE_TOL × t_end of a step's end (or of another
    output time) is no target of its own: ``output_times = [0.5000000000000001]`` with
    n = 2 added a step of 1e-16 (no Newton iteration, a second record printed t = 0.5;
    QA, session 65). t_end stays the last target exactly."""
    from dolfinx_mortar.solver import step_targets

    assert step_targets(1.0, 2, [0.5000000000000001]) == [0.5, 1.0]
    assert step_targets(1.0, 2, [0.9999999999999999, 1.0]) == [0.5, 1.0]
    assert step_targets(1.0, 4, [0.3 + 1e-15, 0.3, 0.6]) == [0.25, 0.3, 0.5, 0.6, 0.75, 1.0]
    assert step_targets(2.0, 1, [0.0, 0.5, 2.5]) == [0.5, 2.0]  # (0, t_end] only
    assert step_targets(1.0, 3, []) == np.linspace(0.0, 1.0, 4)[1:].tolist()


@pytest.mark.parametrize(
    ("kwargs", "key", "reason"),
    [
        ({"t_end": -1.0}, "LoadStepper.t_end", "must be > 0, got -1"),
        ({"t_end": float("nan")}, "LoadStepper.t_end", "must be a finite number"),
        ({"n": 0}, "LoadStepper.n", "must be >= 1, got 0"),
        ({"n": -3}, "LoadStepper.n", "must be >= 1, got -3"),
        ({"n": 2.5}, "LoadStepper.n", "expected an integer, got float 2.5"),
        ({"max_cutbacks": -1}, "LoadStepper.max_cutbacks", "must be >= 0, got -1"),
        ({"output_times": 5}, "LoadStepper.output_times", "expected an array of numbers"),
        ({"output_times": [1.5]}, "LoadStepper.output_times", "1.5 outside (0, t_end]"),
        ({"uzawa_max": 0}, "LoadStepper.uzawa_max", "must be >= 1, got 0"),
    ],
)
def test_load_stepper_arguments_obey_the_scene_rules(kwargs, key, reason):
    """LoadStepper's numbers are checked by the rules of the scene's [steps]
    (``scene.steps_numbers``): t_end = -1 ran backwards, n = 0 returned no step, n = -3
    was numpy's error, max_cutbacks = -1 and uzawa_max = 0 were taken (QA, session 65)."""
    from dolfinx_mortar.errors import SceneError

    p = _Problem()
    args = {"t_end": 1.0, "n": 2, **kwargs}
    with pytest.raises(SceneError) as info:  # SceneTypeError is one
        LoadStepper(p, _Newton(p, lambda t0: 1.0), **args)
    assert info.value.key == key and reason in info.value.reason, str(info.value)


def test_load_stepper_and_newton_solver_refuse_misplaced_arguments(cubic_vectors):
    """Arguments of the wrong kind or in the wrong order are a TypeError that says so
    (they failed on a missing attribute), NumPy numbers are taken, and a destroyed
    NewtonSolver refuses to solve (PETSc crashed with SEGV; QA, session 65)."""
    p = _Problem()
    newton = _Newton(p, lambda t0: 1.0)
    with pytest.raises(TypeError, match="newton must be a NewtonSolver, got _Problem"):
        LoadStepper(newton, p, 1.0, 2)
    stepper = LoadStepper(p, newton, np.float64(1.0), np.int64(2), output_times=np.array([0.3]))
    assert stepper.targets == [0.3, 0.5, 1.0]
    cubic = _Cubic(1.0)
    with pytest.raises(TypeError, match="problem must be a ContactProblem, got SolverSettings"):
        NewtonSolver(SolverSettings(), cubic)
    with pytest.raises(TypeError, match=r"settings must be .* got dict \(SolverSettings\(\*\*d\)"):
        NewtonSolver(cubic, {"rtol": 1e-8})
    newton = NewtonSolver(cubic, SolverSettings(prefix="test_destroyed_"))
    newton.destroy()
    with pytest.raises(RuntimeError, match=r"destroy\(\) has freed .* cannot solve any more"):
        newton.solve()


def test_the_drifted_body_is_named():
    """A body that only stick held (no clause of _unheld_hint or _friction_hold_hint named
    it: it started in contact and did not slip) and that drifted off its master is named
    with its motions and the loads blamed; the clause said "the free body drifted along
    those motions" and named none (QA, session 65: a block pulled off by its traction)."""

    class Body:
        pairs = ("a:b",)

        def describe(self, gdim):
            return "body 'upper' is free in translation along x"

    class Term:
        name = "a:b"
        free_body = True

    class P:
        contacts = [Term()]
        gdim = 2

        def open_pairs(self):
            return ["a:b"]

        def unpaired_pairs(self):
            return ["a:b"]

        def unheld_motions(self):
            return []

        def stick_only_motions(self):
            return [Body()]

    text = solver_module._open_contact_hint(P())
    assert (
        "no slave point of a:b faces its master surface at the last attempt: body 'upper' is "
        "free in translation along x, held there only by contact, and it drifted off (check "
        "the loads"
    ) in text, text
