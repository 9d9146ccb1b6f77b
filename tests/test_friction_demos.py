"""The frictional demos, run small, against their exact or analytic solutions.

Like ``test_demos.py``: each demo's ``main(argv)`` runs in-process and returns its
metrics (the same on every rank); the ``mpi`` tests also run under mpirun.

The demos' analytic checks run serially and on 2 ranks, not on 3 (``mpi_not3``, the
2-core budget: the 2D ones since session 60, Cattaneo–Mindlin's loading since session
61): on 3 ranks frictional runs equal the serial ones to 1e-8
(test_contact_parallel.test_parallel_equals_serial: p_N, the tangential traction, slip
and stick/slip states of Cattaneo–Mindlin with the lumped and constrained recoveries and
the master frame, and of a 3D frictional patch, their frictional XDMF fields written; a
frictional slide beyond the ghost margin in
test_a_one_step_slide_beyond_the_ghost_margin_keeps_coulomb_friction), so their 3-rank
runs repeated the serial checks.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

DEMOS = Path(__file__).resolve().parents[1] / "demos"
sys.path.insert(0, str(DEMOS))

import demo_cattaneo2d  # noqa: E402
import demo_cattaneo3d  # noqa: E402
import demo_friction_patch  # noqa: E402
import demo_ironing2d  # noqa: E402
import demo_ironing3d  # noqa: E402
import demo_tiedcurved2d  # noqa: E402
import demo_twist3d  # noqa: E402
import demo_wedge  # noqa: E402

pytestmark = pytest.mark.mpi_not3  # the module docstring

#: the tests whose demo runs write the demo's volume fields (XDMF): the frictional fields
#: (tangential traction, slip, contact state) on 1–3 ranks; the other tests read the
#: metrics, the summary and the contact CSVs only
_WITH_FIELDS = {"test_cattaneo2d"}


@pytest.fixture(autouse=True)
def _no_volume_fields(request, monkeypatch):
    """The demos' runs without their volume fields (``output.fields = []``; the summary
    and the contact CSVs are written as before) but in the tests of ``_WITH_FIELDS``:
    these tests read neither, and in small runs the fields took 25–78 % of a run's time
    (session 60, the summaries' ``timings.output``: the 2D frictional patch runs). The
    field output itself is tested in test_output.py."""
    if request.function.__name__ in _WITH_FIELDS:
        return
    import dataclasses

    from dolfinx_mortar import runner

    run = runner.run

    def run_without_fields(scene, *args, **kwargs):
        output = dataclasses.replace(scene.output, fields=())
        return run(dataclasses.replace(scene, output=output), *args, **kwargs)

    monkeypatch.setattr(runner, "run", run_without_fields)


@pytest.mark.mpi
@pytest.mark.parametrize("mode", ["stick", "slide"])
@pytest.mark.parametrize(
    "integration,tol,frame",
    [("segment", 1e-8, "slave"), ("element", 0.02, "slave"), ("segment", 1e-8, "master")],
)
def test_friction_patch2d(shared_tmp, mode, integration, tol, frame):
    out = str(shared_tmp / f"fpatch2d-{mode}-{integration}-{frame}")
    m = demo_friction_patch.main(
        ["--mode", mode, "--integration", integration, "--frame", frame, "--out", out]
    )
    assert m["modelled"]["frame"].startswith(frame)
    assert m["p_err"] <= tol, m["p_err"]
    assert m["q_err"] <= tol, m["q_err"]
    assert m["wrong_state"] == 0
    assert m["force_normal_err"] <= 1e-8 and m["force_tangential_err"] <= 1e-8
    assert m["modelled"]["tangential_fields"] is True
    if mode == "stick":
        assert max(m["dissipation"]) <= 1e-10
    else:
        # μ p0 L × slip of each step: the top moves 0.025 per step, the upper block's
        # elastic shear μ p(t)/G · H (G = 50) takes 0.005 in step 1 (p0/2) and no more after
        assert m["dissipation"] == pytest.approx([0.5 * 0.02, 1.0 * 0.02], rel=1e-8)
    assert m["max_newton_per_solve"] <= 25 and max(m["newton_iterations"]) <= 25
    # the initial state (step 0): the blocks touch at gap 0 without pressure, so every
    # node is open (state 0); the law's "stick" of a touching node was reported there
    with open(Path(out) / "contact_upper_bottom_0.csv") as fh:
        rows = np.loadtxt(fh, delimiter=",", skiprows=1, ndmin=2)
    assert np.all(rows[:, 4] == 0.0) and np.all(rows[:, -1] == 0), rows[:, [4, -1]]


@pytest.mark.parametrize("frame", ["slave", "master"])
@pytest.mark.parametrize("mode", ["stick", "slide"])
def test_friction_patch3d(shared_tmp, mode, frame):
    """The 3D frictional patch tests, in either tangential frame (``--frame``): the
    master's convected covariant basis passes them as the slave frame does."""
    out = str(shared_tmp / f"fpatch3d-{mode}-{frame}")
    m = demo_friction_patch.main(
        ["--dim", "3", "--mode", mode, "--integration", "segment", "--frame", frame, "--out", out]
    )
    assert m["modelled"]["frame"].startswith(frame)
    assert m["p_err"] <= 1e-8, m["p_err"]
    assert m["q_err"] <= 1e-8, m["q_err"]
    assert m["q_cross"] <= 1e-8, m["q_cross"]
    assert m["wrong_state"] == 0
    assert m["max_newton_per_solve"] <= 25 and max(m["newton_iterations"]) <= 25


def test_friction_patch3d_stick_on_tetrahedra_at_degree_12(shared_tmp):
    """The 3D stick patch test on P1 tetrahedra with element integration and the pair's
    ``quadrature_degree`` 12 (``--quadrature-degree``, session 68): uniform pressure and
    shear within 0.5 % (measured 0.28 % and 0.17 %; the frictional default, degree 4,
    reads 6.9 % and 3.3 %: BENCHMARKS §99), every node sticking."""
    out = str(shared_tmp / "fpatch3d-tri-q12")
    m = demo_friction_patch.main(
        ["--dim", "3", "--tri", "--quadrature-degree", "12", "--out", out]
    )  # fmt: skip
    assert m["modelled"]["quadrature"] == "degree 12, 33 points per slave facet", m["modelled"]
    assert m["p_err"] <= 5e-3, m["p_err"]
    assert m["q_err"] <= 5e-3, m["q_err"]
    assert m["wrong_state"] == 0
    assert m["force_normal_err"] <= 1e-8 and m["force_tangential_err"] <= 1e-8


@pytest.mark.mpi2
def test_friction_patch3d_slide_p2_tetrahedra_needs_no_cutback(shared_tmp):
    """The 3D sliding patch test on P2 tetrahedra (segment integration): every node slips,
    and the upper block is held across the slide (y) only by the contact. Its first solve
    reached the chattering control's freeze (8th Jacobian, ‖R‖ = 8.9e-6); with the slip
    directions fixed the pair had no tangential stiffness, the frozen directions' net
    cross-slip traction nothing to balance it, and the next Newton step moved the block by
    2.3e8 along y: DIVERGED_DTOL and a cutback (12 + 4 + 1 + 0 iterations at t = 0.25).
    Now a pair frozen with no node in stick keeps its slip directions free
    (tangential.FREE_SLIP_DIRECTIONS): 8 + 1 + 1 + 0 at t = 0.5, no cutback, exact. With
    FREE_SLIP_DIRECTIONS = False the same run cuts back once (measured when it landed;
    not re-run here: the suite's 2-core budget). On 2 ranks only (mpi2): 35 s serially."""
    import _common as cm
    from mpi4py import MPI

    sc = demo_friction_patch.scene(3, "slide", "segment", 0, quads=False)
    sc["mesh"]["params"]["order"] = 2
    out = shared_tmp / "fpatch3d-slide-p2tet"
    summary, _ = cm.run_scene(sc, str(out), MPI.COMM_WORLD)
    m = cm.on_root(demo_friction_patch.evaluate, summary, out, 3, "slide", comm=MPI.COMM_WORLD)
    assert m["modelled"]["integration"] == "segment"
    assert summary["modelled"]["cell_type"] == "tetrahedron P2"
    assert m["cutbacks"] == 0, m["newton_iterations"]
    assert [s["t"] for s in summary["steps"]] == [0.5, 1.0]
    assert m["max_newton_per_solve"] <= 12, m["newton_iterations"]
    assert m["p_err"] <= 1e-8 and m["q_err"] <= 1e-8 and m["q_cross"] <= 1e-8, m
    assert m["wrong_state"] == 0


@pytest.mark.mpi
def test_friction_patch2d_deformable_master(shared_tmp):
    """Mode "deformable" (demo_friction_patch's docstring): the upper block, the master,
    slides over the held, deforming lower block (ν = 0.3: both stretch along the
    interface), its interface free. Exact: p_N = p0, |p_T| = μ p0 at every slave node in
    every step. Segment integration: the press step and the normal force of every step
    are exact, the dissipation of the steps after the first sliding one within 1.8 %
    (4 steps; 8: 6e-5) of μ p0 L × the step's slide; the slave nodes
    that the master's ends cover in part miss by a FIRST-ORDER term in the step (the
    current code: 1.79 with 4 sliding steps, 0.89 with 8; a consistent method would meet
    round-off there: tighten this test when it does). The wholly covered nodes: 0.44 %
    and 0.39 %."""
    m = {}
    for n in (4, 8):
        out = str(shared_tmp / f"fpatch2d-deformable-{n}")
        m[n] = demo_friction_patch.main(
            ["--mode", "deformable", "--integration", "segment", "--slide-steps", str(n)]
            + ["--out", out]
        )
        assert m[n]["press_p_err"] <= 1e-8 and m[n]["press_q"] <= 1e-8, m[n]
        assert m[n]["press_nodes_on"] == m[n]["slave_nodes_on"] == 6
        assert m[n]["states"] == [2] and m[n]["q_sign"] in ([-1], [1])
        assert m[n]["force_normal_err"] <= 1e-8, m[n]["force"]
        # the master drags the slave along +x: μ p0 L = 1 (2.0 % low with 4 steps, 3e-6 with
        # 8: whether a segment point falls in the strip swept since t_n, which takes no
        # tangential weight; CHANGELOG, "Fixed (session 55)")
        assert 0.97 <= m[n]["force"][0] <= 1.0 + 1e-8, m[n]["force"]
        # |p_T| = μ p_N at every slipping node: the tangential error is the normal one
        assert m[n]["q_err"] == pytest.approx(m[n]["p_err"], rel=1e-6, abs=1e-9)
        assert m[n]["p_err_inner"] <= 1e-2, m[n]["p_err_inner"]
        assert m[n]["slave_nodes_inner"] == 2
        # μ p0 L × the slide of each step (SLIDE / n), after the first sliding step
        assert m[n]["dissipation"][2:] == pytest.approx([0.05 / n] * (n - 1), rel=2e-2)
        assert m[n]["cutbacks"] == 0 and m[n]["max_newton_per_solve"] <= 8, m[n]
    # first order in the step: halving it halves the error
    ratio = m[8]["p_err"] / m[4]["p_err"]
    assert 0.4 <= ratio <= 0.6, (m[4]["p_err"], m[8]["p_err"])


@pytest.mark.mpi2
def test_friction_patch3d_deformable_master_slides_without_cutback(shared_tmp):
    """Mode "deformable" in 3D (segment integration, 2 sliding steps). The master's edges
    y = 0, L lie on the slave's node rows (and x = 0, L in the press step): the slave nodes
    beyond them are paired over a strip of round-off or discretization-error width, 1e-11
    to 1e-6 of their full weight. Augmented, their multipliers moved by O(1) per round
    without converging, and the exact update's GMRES stalled on them: the press step took
    7 Uzawa rounds, every sliding step stalled and was cut back (session 55). They are now
    sliver nodes (uzawa.SEGMENT_SLIVER_FRACTION = 1e-3): measured 4, 3, 3 rounds, no
    cutback, press exact to 1e-10, the wholly covered nodes 0.73 %; the nodes that the
    master's ends cover in part 0.24 (first order in the step, as in 2D; 0.21 and 0.15 with
    4 and 8 steps). On 2 ranks only (mpi2): 36 s serially."""
    out = str(shared_tmp / "fpatch3d-deformable-2")
    m = demo_friction_patch.main(
        ["--dim", "3", "--mode", "deformable", "--integration", "segment", "--slide-steps", "2"]
        + ["--out", out]
    )
    assert m["press_p_err"] <= 1e-8 and m["press_q"] <= 1e-8, m
    assert m["press_nodes_on"] == 36  # the 6 × 6 slave nodes under the master
    assert m["cutbacks"] == 0 and max(m["uzawa_rounds"]) <= 5, m["uzawa_rounds"]
    assert m["force_normal_err"] <= 1e-8, m["force"]
    assert m["states"] == [2]
    assert m["p_err_inner"] <= 1e-2 and m["q_err_inner"] <= 1e-2, m
    # the master drags the slave along +x: μ p0 L² = 1, first order low (2.35 % here)
    assert 0.95 <= m["force"][0] <= 1.0 + 1e-8, m["force"]
    summary = json.loads((Path(out) / "summary.json").read_text())
    rounds = [r["lower_top:upper_bottom"] for s in summary["steps"] for r in s["uzawa"]]
    assert any(r.get("sliver_nodes", 0) > 0 for r in rounds)


def _assert_cattaneo(m: dict, c_elements: float, l2_q: float, l2_p: float) -> None:
    """The Cattaneo–Mindlin demo's metrics ``m`` against the analytic solution: stick-zone
    half-width within ``c_elements`` slave elements, L2(q) ≤ ``l2_q``, L2(p) ≤ ``l2_p``;
    stick and slip nodes, no negative pressure, at most 25 Newton iterations per solve, no
    cutback and no failed predictor."""
    assert abs(m["c_err_elements"]) <= c_elements, m["c_err_elements"]
    assert m["l2_q"] <= l2_q, m["l2_q"]
    assert m["l2_p"] <= l2_p, m["l2_p"]
    assert m["stick_nodes"] > 0 and m["slip_nodes"] > 0
    assert m["negative"] == 0
    assert m["max_newton_per_solve"] <= 25 and max(m["newton_iterations"]) <= 25
    assert m["cutbacks"] == 0 and m["predictor_failures"] == 0


@pytest.mark.mpi
def test_cattaneo2d(shared_tmp):
    """Default mesh (h = 0.05 ≈ a/13), the library's default (standard) tangential
    weights, profiles over the reference coordinate. Measured: stick half-width −0.29
    elements, L2(q) 11.7 %, L2(p) 3.75 % (dual weights: L2(q) 8.8 %, 30 s instead of
    14 s). The issue's 5 % on q is NOT met here (BENCHMARKS.md §8). The second press step
    (t = 0.5 → 1) converges from the extrapolated predictor, which puts the previous
    contact zone 0.5 h into the block (tangential.DEEP_PENETRATION_TOL; before that rule it
    failed after 35 iterations from the predictor and again from the converged state, and
    was cut back)."""
    out = str(shared_tmp / "cattaneo2d")
    m = demo_cattaneo2d.main(["--tangential-weights", "standard", "--out", out])
    assert 0.4 <= m["Q_ratio"] <= 0.55, m["Q_ratio"]
    _assert_cattaneo(m, c_elements=0.5, l2_q=0.125, l2_p=0.04)
    # SCENES.md states: a node that carries pressure is never "open" (0), also in the
    # press steps, where every node enters contact (frictionless in its first step)
    csvs = sorted(Path(out).glob("contact_*_*.csv"))
    assert len(csvs) == 7, csvs
    entering = 0
    for f in csvs:
        d = np.genfromtxt(f, delimiter=",", names=True)
        assert not np.any((d["p_N"] > 0) & (d["state"] == 0)), f
        entering += int(np.sum((d["p_N"] > 0) & (d["state"] == 2) & (d["p_T0"] == 0.0)))
    assert entering > 0  # the first press step has such nodes (14 of 17 in contact)


def test_cattaneo2d_constrained(shared_tmp):
    """The normal pressure from the constrained recovery (tangential part lumped, dual
    weights). Measured: stick half-width −0.29 elements, L2(q) 6.2 %, L2(p) 2.3 %
    (standard tangential weights: L2(q) 9.8 %); no negative pressure. The interpolation
    error of the exact q at these nodes is already 4.5 %. No cutback and no failed
    predictor (as test_cattaneo2d; at most 21 Newton iterations in one solve)."""
    out = str(shared_tmp / "cattaneo2d-constrained")
    m = demo_cattaneo2d.main(["--recovery", "constrained", "--out", out])
    _assert_cattaneo(m, c_elements=0.5, l2_q=0.07, l2_p=0.03)


@pytest.mark.mpi2
def test_cattaneo2d_meets_the_issue_targets_at_a_over_27(shared_tmp):
    """The issue's Cattaneo–Mindlin figures, on the demo's defaults (lumped normal
    recovery, dual tangential weights) one refinement up, h = 0.025 ≈ a/27 (39654 dofs;
    on 2 ranks only, marker mpi2: 25 s; serially 27 s and the same figures): stick-zone half-width within one slave element of c = a√(1 − Q/(μP))
    (measured −0.06 elements), L2 error of the tangential traction ≤ 5 % (measured
    4.70 %; at h = a/13 the nodal interpolant of the EXACT q already misses by 4.3–5.8 %,
    BENCHMARKS §8), L2(p) 1.20 %, no cutback or failed predictor, at most 17 Newton
    iterations in one solve."""
    out = str(shared_tmp / "cattaneo2d-fine")
    m = demo_cattaneo2d.main(["--refine", "1", "--out", out])
    assert 0.4 <= m["Q_ratio"] <= 0.55, m["Q_ratio"]
    _assert_cattaneo(m, c_elements=1.0, l2_q=0.05, l2_p=0.02)


@pytest.mark.mpi
@pytest.mark.parametrize("mu,integration", [(0.3, "element"), (0.5, "segment")])
def test_wedge_gross_slip_ratio(shared_tmp, mu, integration):
    out = str(shared_tmp / f"wedge-{mu}-{integration}")
    m = demo_wedge.main(["--mu", str(mu), "--integration", integration, "--out", out])
    assert abs(m["ratio_err"]) <= 0.01, m
    assert m["stick_nodes"] == 0 and m["slip_nodes"] > 0
    assert m["gross_slip_step"] is not None
    assert m["max_newton_per_solve"] <= 25 and max(m["newton_iterations"]) <= 25
    assert all(d >= -1e-12 for d in m["dissipation"])


def test_ironing2d_short(shared_tmp):
    """Ironing, short path: press 1.4 in 5 steps, slide 1.4 in 14 steps (0.1 per step,
    one slab element), default mesh, slab as slave, ε_T = E*/h, penetration-limited
    Newton steps (the demo's defaults). Measured (serial, ~14 s): no cutback, no failed
    attempt from the predictor, no solve continued with full steps or restarted after a
    NaN, at most 25 Newton iterations per solve (24, 308 in all, since the blind-spot
    pairing of session 18; 25 and 338 before it; 610 with Aitken), steps shortened by
    the depth limit;
    F_y 1.95–2.0; F_x/F_y 0.085 → 0.31 while the slab shears under a sticking die
    (u_x ≤ 1), then 0.33–0.34 in gross slip. Without the depth limit
    (``--step-depth-limit 0``): 2 cutbacks (the first press step, 0.28 deep, twice the
    demo's; and the slide step to t = 1.786, whose full steps hit NaN residuals and
    whose bt restart ran out of iterations) and 4 failed attempts from the predictor."""
    mu = 0.3
    out = str(shared_tmp / "ironing2d-short")
    argv = ["--press-steps", "5", "--slide-steps", "14", "--slide", "1.4", "--out", out]
    m = demo_ironing2d.main(argv)
    assert m["status"] == "ok" and m["t_reached"] == pytest.approx(2.0)
    assert all(math.isfinite(f) for f in m["F_x"] + m["F_y"])
    assert min(m["F_y"]) > 0.0 and m["F_y_press_end"] == pytest.approx(1.95, rel=0.02)
    assert m["force_balance"] <= 1e-8
    late = [r for r, u in zip(m["ratio"], m["u_x"], strict=True) if u >= 1.0 - 1e-9]
    assert len(late) >= 5 and min(late) >= 0.9 * mu, late
    assert m["slip_nodes"][-1] > 10 * m["stick_nodes"][-1]  # gross slip at the end
    assert m["cutbacks"] == 0 and m["predictor_failures"] == 0, m
    assert m["full_step_solves"] == 0 and m["backtracked_solves"] == 0, m
    assert m["max_newton_per_solve"] <= 25, m["max_newton_per_solve"]
    assert m["limited_steps"] > 0


def test_ironing2d_snap_of_the_dragged_corner(shared_tmp):
    """The demo's path up to u_x = 1.48 (press in 10 steps, slide steps of 0.04): at u_x =
    1.44 the slab's dragged top-left corner (reference x = −2, p ≈ 2.1) springs back 0.3
    along the die and leaves it. The corner opened in the first iterates, re-closed after
    the chattering control's freeze, and as a node frozen open it was imposed stick at its
    t_n material point 3 h away: the round converged back on the vanished pre-snap side
    and the next made the jump, 18 + 31 + 6 + 1 Newton iterations. It now follows the
    free law (tangential.REENTRY_FREE_SLIP): 31 + 4 + 1, and 18 + 10 + 1 with every paired
    point pinned from the 12th Jacobian, 18 + 6 + 1 with full steps in the round after the
    pins (solver.ROUND_FULL_STEPS; measured, serial, ~30 s): no step of the path needs
    more than 25 (issue 4). The step after the snap starts from the converged state
    (solver.PREDICTOR_JUMP_RATIO): at most 20 iterations instead of 27 from the
    extrapolated snap."""
    out = shared_tmp / "ironing2d-snap"
    m = demo_ironing2d.main(["--slide", "1.48", "--slide-steps", "37", "--out", str(out)])
    assert m["status"] == "ok" and m["cutbacks"] == 0 and m["predictor_failures"] == 0, m
    steps = json.loads((out / "summary.json").read_text())["steps"]
    its = {round(s["t"], 3): sum(s["newton_iterations"]) for s in steps}
    snap, after = its[round(1 + 36 / 37, 3)], its[2.0]
    assert snap <= 25 and after <= 22 and max(its.values()) <= 25, (snap, after, its)
    corner = np.genfromtxt(out / "contact_slab_top_46.csv", delimiter=",", names=True)
    corner = corner[np.argmin(corner["x"])]
    assert corner["x"] == pytest.approx(-2.0) and corner["p_N"] < 0.1, corner  # it left


def test_ironing2d_first_press_step_without_cutback(shared_tmp, monkeypatch):
    """The demo's first press step (the die 0.14 into the slab, t = 0.1) in one step. Its
    first Newton iterate moves the die into the slab without contact forces. With the
    exact tangent from there (GEOMETRIC_TANGENT_AT_FIRST_CONTACT = True, the behaviour
    before that rule) the next iterates invert slab elements (NaN residual), where the l2
    line search fails; the solve restarts from its last finite iterate with the bt line
    search and converges (before that restart: a cutback). By default the geometric
    tangent is left out while the active set moves, and the step converges without a NaN
    (20 Newton iterations). F_y agrees with the same press in 4 steps to 0.5 % (measured
    0.0875 and 0.0877; friction makes the press path-dependent). The exact-tangent run
    takes one secant step in its l2 line search, as before session 23, and lets l2 step
    beyond the Newton step, as before session 37: with the two secant steps of
    first-contact solves (solver.FIRST_CONTACT_L2_STEPS), or with l2 capped at the full
    step (solver.L2_MAX_STEP), it also avoids the NaN here."""
    from dolfinx_mortar import contact, solver

    # the rule alone: without the penetration limit of the demo's default, which keeps
    # the first iterates shallower
    common = ["--press", "0.14", "--slide-steps", "1", "--slide", "0.01"]
    common += ["--step-depth-limit", "0"]
    one = demo_ironing2d.main(common + ["--press-steps", "1", "--out", str(shared_tmp / "p1")])
    four = demo_ironing2d.main(common + ["--press-steps", "4", "--out", str(shared_tmp / "p4")])
    monkeypatch.setattr(contact, "GEOMETRIC_TANGENT_AT_FIRST_CONTACT", True)
    monkeypatch.setattr(solver, "FIRST_CONTACT_L2_STEPS", 1)
    monkeypatch.setattr(solver, "L2_MAX_STEP", 1e8)
    exact = demo_ironing2d.main(common + ["--press-steps", "1", "--out", str(shared_tmp / "px")])
    for m in (one, exact):
        assert m["status"] == "ok" and m["cutbacks"] == 0
        assert m["force_balance"] <= 1e-8
        assert m["F_y_press_end"] == pytest.approx(four["F_y_press_end"], rel=5e-3)
    assert one["backtracked_solves"] == 0 and exact["backtracked_solves"] >= 1


@pytest.mark.mpi
def test_tied_curved_converges(shared_tmp):
    """Non-flat patch test: the L2 stress error falls at least like h^1.5 over three
    refinements (measured 1.83, 2.02, 1.83), every interior node sticks on the two finest
    levels, and no Newton solve needs more than 25 iterations."""
    m = demo_tiedcurved2d.main(["--levels", "4", "--out", str(shared_tmp / "tied")])
    errs = [r["stress_err"] for r in m["levels"]]
    assert all(q >= 1.5 for q in m["rates"]["stress_err"]), m["rates"]
    assert errs[-1] <= 0.01, errs
    for r in m["levels"][2:]:
        assert r["states"] == [1], r["states"]
        assert r["q_rms"] <= 0.05, r["q_rms"]
    assert max(r["max_newton_per_solve"] for r in m["levels"]) <= 25


def test_ironing3d_short(shared_tmp):
    """3D ironing, short path: press 0.6 in 2 steps, slide 0.3 in 3 steps (default mesh,
    4866 dofs; ~30 s). Measured: F_x/F_z 0.003, 0.112, 0.214, 0.289 from the end of the
    press on, F_z 2.81–2.84, stick/slip nodes 25/27, 44/8, 18/33, 0/52, no cutback (18 of
    the 27 sliding nodes at the end of the press entered contact in that step: no slip
    history yet, hence no tangential traction, written as sliding). The die sticks, then
    slips, and no solve needs more than 25 Newton iterations (measured 9). Per step, all
    Uzawa rounds together, at most 30: the last step's slide of 0.1 takes 26 (7 + 6 + 4 + 9,
    the last solve with frozen states and a pinned point) since the slip is measured from
    the start of the step (session 45; 25 before). The demo's own path (a press in 5
    steps, slides of 0.095) keeps issue 4's 25 per step: ≤ 18 (BENCHMARKS §48)."""
    argv = ["--press-steps", "2", "--slide-steps", "3", "--slide", "0.3"]
    m = demo_ironing3d.main(argv + ["--out", str(shared_tmp / "ironing3d-short")])
    assert m["status"] == "ok" and m["t_reached"] == pytest.approx(2.0)
    fz, ratio = m["F_z"], m["ratio"]
    assert all(math.isfinite(f) for f in m["F_x"] + fz)
    assert fz[-1] == pytest.approx(2.8, rel=0.05)
    assert all(b > a for a, b in zip(ratio[-4:-1], ratio[-3:], strict=True))  # loading up
    assert 0.25 < ratio[-1] <= 0.3 * 1.05, ratio
    # sticking after the press and in the first slide step
    assert m["stick_nodes"][-4] >= 20 and m["stick_nodes"][-3] > m["slip_nodes"][-3]
    assert m["slip_nodes"][-1] > 10 * m["stick_nodes"][-1]  # slipping at the end
    assert m["max_newton_per_solve"] <= 25 and max(m["newton_iterations"]) <= 30
    # a frictional pair on P1 triangles keeps the 6-point rule of degree 4 by default
    # (contact.default_quadrature_degree; frictionless ones take 12, BENCHMARKS §94)
    summary = json.loads((shared_tmp / "ironing3d-short" / "summary.json").read_text())
    (pair,) = summary["modelled"]["contact_pairs"].values()
    assert pair["quadrature"] == "degree 4, 6 points per slave facet", pair


@pytest.mark.mpi2
def test_twist3d_torque_plateau(shared_tmp):
    """Twisting a Hertz contact to full slip (coarse mesh h = 0.42, 7056 dofs, Uzawa to
    1e-2, the twist in 4 steps instead of the demo's 6; on 2 ranks only: marker mpi2): the
    torque rises monotonically to the plateau (3π/16) μ P a of the measured load, within
    5 % (measured −3.09 %; −3.10 % with 6 twist steps in sessions 45 and 60, −3.76 % in
    earlier sessions; at h = 0.3, −0.48 %), with all contact nodes but at most one
    slipping at the end (1 / 42 with 4 and with 6 steps). The demo's exact multiplier
    update: at most 25 Newton iterations per step, all Uzawa rounds together (measured
    with 4 twist steps: 7, 7, 9, 11 in the press, 10, 8, 7, 5 in the twist, 64 in all
    against 9, 16, 8, 8, 6, 5 and 86 with 6: session 60, the suite's time; Aitken 16 a
    step, in 65 s instead of 97 s on this coarse path, but up to 35 per step on the
    default one)."""
    argv = ["--h-contact", "0.42", "--uzawa-tol", "1e-2", "--twist-steps", "4"]
    m = demo_twist3d.main(argv + ["--out", str(shared_tmp / "twist3d")])
    assert abs(m["M_err"]) <= 0.05, m["M_err"]
    torques = [M for t, M in m["torque_history"] if t > 1.0]
    assert len(torques) == 4, m["torque_history"]
    assert all(b > a for a, b in zip(torques[:-1], torques[1:], strict=True)), torques
    assert m["stick_nodes"] <= 1 and m["slip_nodes"] >= 40
    assert m["P_contact"] == pytest.approx(m["P_measured"], rel=1e-6)
    assert m["max_newton_per_solve"] <= 25 and max(m["newton_iterations"]) <= 25


def test_tied_curved_refine_starts_the_levels(tmp_path):
    """``--refine K`` starts the levels at K (it was ignored: the help of every demo says
    it refines the mesh)."""
    m = demo_tiedcurved2d.main(["--levels", "1", "--refine", "1", "--out", str(tmp_path)])
    (row,) = m["levels"]
    assert row["level"] == 1
    assert row["h"] == pytest.approx(demo_tiedcurved2d.R1 * math.pi / 2 / 12)
    assert (tmp_path / "L1" / "summary.json").is_file()


@pytest.mark.mpi
def test_cattaneo2d_unloading_mindlin_deresiewicz(shared_tmp):
    """History dependence (stick memory, slip reversal, multipliers carried over steps):
    the Cattaneo–Mindlin contact sheared to Q* ≈ 0.47 μP, then unloaded to Q ≈ 0.11 μP
    (t = 2.5) and Q ≈ −0.24 μP (t = 3), against Mindlin–Deresiewicz
    (``analytic.mindlin_deresiewicz2d``, measured P, Q*, Q); demo defaults, h = 0.05 ≈ a/13,
    5 steps (about 4 s serially). Measured (1 and 2 ranks alike, BENCHMARKS §52): the loaded
    state's L2(q) 8.80 % (the loading test's); t = 2.5: new stick half-width +0.27 elements
    from c', L2(q) 34.97 %, the nodal interpolant of the exact q 26.00 % (two cusp pairs,
    c* and c', 2.4 elements apart), the Cattaneo–Mindlin q of the same Q without history
    174 %; t = 3: −0.32 elements, 17.01 %, 10.14 %, 37.2 %. The bounds: the loading test's
    0.5 elements; L2(q) within twice the interpolant's (the loaded state's own ratio at this
    mesh is 1.95; 1.35 and 1.68 here) and under 0.40 / 0.20; at most half the no-history
    distance. The slip nodes slip backwards (reverse slip at the edges): q = −μ p_N there."""
    out = str(shared_tmp / "cattaneo2d-unload")
    m = demo_cattaneo2d.main(["--unload", "--out", out])
    assert 0.4 <= m["loading"]["Q_ratio"] <= 0.55, m["loading"]
    assert m["loading"]["l2_q"] <= 0.09, m["loading"]
    st = {round(s["t"], 6): s for s in m["unloaded"]}
    assert sorted(st) == [2.5, 3.0]
    assert 0.05 <= st[2.5]["Q_ratio"] <= 0.2 and -0.3 <= st[3.0]["Q_ratio"] <= -0.2
    for t, l2_max in ((2.5, 0.40), (3.0, 0.20)):
        s = st[t]
        assert abs(s["c_err_elements"]) <= 0.5, (t, s["c_err_elements"])
        assert s["l2_q"] <= l2_max, (t, s["l2_q"])
        assert s["l2_q"] <= 2.0 * s["l2_interp"], (t, s["l2_q"], s["l2_interp"])
        assert s["l2_q"] <= 0.5 * s["l2_virgin"], (t, s["l2_q"], s["l2_virgin"])
        assert s["stick_nodes"] > 0 and s["slip_nodes"] >= 2
        xs = np.asarray(s["slip_x"])
        assert np.any(xs < 0) and np.any(xs > 0), xs  # both edges
        assert np.allclose(s["slip_q_ratio"], -1.0, atol=1e-6), s["slip_q_ratio"]
    assert m["cutbacks"] == 0 and m["predictor_failures"] == 0
    assert m["max_newton_per_solve"] <= 25


def test_cattaneo2d_unloading_with_the_constrained_tangential_recovery(shared_tmp):
    """``--unload --recovery constrained --tangential-recovery constrained`` (a/13, about
    20 s serially). At the load reversal (t = 2 → 2.5) the two nodes next to the new
    reverse-slip edge nodes (x = ±0.59) went slip − → slip − → slip + from Newton iterate
    to iterate; without the slip-reversal rule (the lumped recovery's only, until session
    48) the states froze at the 8th Jacobian in slip −, wrong at every convergence, and
    the identical rounds failed the step; frozen in stick (the carried retry), the QP
    projected them onto their cone again and Newton 4-cycled at ‖R‖ = 0.18 until max_it:
    8 steps, 3 cutbacks, 131 Newton iterations, 213–232 s. Now 5 steps with no cutback,
    at most 16 Newton iterations in one solve (BENCHMARKS §52), and the constrained-normal
    row's figures: c' within 0.27 / 0.32 elements, L2(q) 29.62 % / 13.71 % (the nodal
    interpolant of the exact q 25.99 % / 10.12 %), q = −μ p_N at every slip node."""
    out = str(shared_tmp / "cattaneo2d-unload-tcon")
    argv = ["--unload", "--recovery", "constrained", "--tangential-recovery", "constrained"]
    m = demo_cattaneo2d.main(argv + ["--out", out])
    assert m["cutbacks"] == 0 and m["predictor_failures"] == 0
    assert len(m["newton_iterations"]) == 5, m["newton_iterations"]
    assert m["max_newton_per_solve"] <= 20 and max(m["newton_iterations"]) <= 30
    assert abs(m["loading"]["l2_q"] - 0.0615) <= 0.002, m["loading"]
    st = {round(s["t"], 6): s for s in m["unloaded"]}
    assert sorted(st) == [2.5, 3.0]
    for t, l2 in ((2.5, 0.2962), (3.0, 0.1371)):
        s = st[t]
        assert abs(s["c_err_elements"]) <= 0.5, (t, s["c_err_elements"])
        assert abs(s["l2_q"] - l2) <= 0.005, (t, s["l2_q"])
        assert s["l2_q"] <= 2.0 * s["l2_interp"], (t, s["l2_q"], s["l2_interp"])
        xs = np.asarray(s["slip_x"])
        assert np.any(xs < 0) and np.any(xs > 0), xs
        assert np.allclose(s["slip_q_ratio"], -1.0, atol=1e-6), s["slip_q_ratio"]


def test_cattaneo3d_quadrature_degree_option_reaches_the_pair(monkeypatch, tmp_path):
    """``demo_cattaneo3d.py --quadrature-degree 12`` (session 68: the degree-12 timings of
    BENCHMARKS §99) sets the pair's ``quadrature_degree``; without it the pair keeps the
    default (no key). The run is stopped where it would start (60 s)."""
    seen = []

    class Stop(Exception):
        pass

    def run_scene(sc, out, comm):
        seen.append(sc)
        raise Stop

    monkeypatch.setattr(demo_cattaneo3d.cm, "run_scene", run_scene)
    for argv in (["--quadrature-degree", "12"], []):
        with pytest.raises(Stop):
            demo_cattaneo3d.main(argv + ["--out", str(tmp_path)])
    assert [sc["contact"][0].get("quadrature_degree") for sc in seen] == [12, None]


def test_cattaneo3d_scene_is_valid(tmp_path):
    """demo_cattaneo3d's scene (not run here: 60 s) parses: the twist demo's hemisphere,
    pressed then shifted, its pair with the default Uzawa settings."""
    from dolfinx_mortar.scene import parse_scene

    sc = parse_scene(demo_cattaneo3d.scene(shift=0.05, n_shift=3, recovery="constrained"), tmp_path)
    assert sc.contacts[0].friction == demo_cattaneo3d.MU
    assert sc.contacts[0].recovery == "constrained"
    assert [d.boundary for d in sc.dirichlet] == ["block_bottom", "sphere_top"]
    # --cycle: +S at t = 2, -S at 4, +S at 6, n_shift steps per S
    raw = demo_cattaneo3d.scene(shift=0.05, n_shift=2, cycle=True)
    assert raw["dirichlet"][1]["path"][1:] == [
        [1, 0, 0, -demo_cattaneo3d.DEPTH],
        *([t, s * 0.05, 0, -demo_cattaneo3d.DEPTH] for t, s in ((2, 1), (4, -1), (6, 1))),
    ]
    assert raw["steps"]["t_end"] == 6.0
    assert raw["steps"]["output_times"] == [0.5, 1.5, 2.5, 3.5, 4.5, 5.5]
    parse_scene(raw, tmp_path)
    t = np.array([1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert np.allclose(demo_cattaneo3d.cycle_shift(t, 0.05), [0, 0.025, 0.05, 0, -0.05, 0, 0.05])
    assert [demo_cattaneo3d.cycle_branch(x) for x in t] == [
        "press", "load", "load", "unload", "unload", "reload", "reload",
    ]  # fmt: skip


def _cap_nodes(seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Nodes of demo_cattaneo3d's sphere's lower cap (a jittered 61 × 61 grid over
    [-2.5, 2.5]², spacing 0.083) and their distances r from the axis."""
    R = demo_cattaneo3d.R
    rng = np.random.default_rng(seed)
    g = np.linspace(-2.5, 2.5, 61)
    xy = np.column_stack([v.ravel() for v in np.meshgrid(g, g)])
    xy += rng.uniform(-0.02, 0.02, xy.shape)
    z = R - np.sqrt(R**2 - np.sum(xy**2, axis=1))
    return np.column_stack([xy, z]), np.hypot(*xy.T)


def _closed_form_csv(x: np.ndarray, p: np.ndarray, q: np.ndarray, c: float) -> dict:
    """A contact CSV (columns of demo_cattaneo3d's) of the nodes x: pressure p, the
    traction q along +x (the force's sign) resisted by the slave (-q along x, in the
    tangent plane, in the CSV's slave frame), stick within the radius c."""
    R = demo_cattaneo3d.R
    t0, t1 = demo_cattaneo3d.slave_frame(x)
    qv = -q[:, None] * np.array([1.0, 0.0, 0.0])
    n = (x - [0.0, 0.0, R]) / R
    qv -= np.sum(qv * n, axis=1)[:, None] * n
    qv *= (np.abs(q) / np.maximum(np.linalg.norm(qv, axis=1), 1e-300))[:, None]
    r = np.hypot(x[:, 0], x[:, 1])
    state = np.where(p > 0.0, np.where(r < c, 1, 2), 0)
    return {
        "x": x[:, 0], "y": x[:, 1], "z": x[:, 2], "p_N": p, "state": state.astype(float),
        "p_T0": np.sum(qv * t0, axis=1), "p_T1": np.sum(qv * t1, axis=1),
    }  # fmt: skip


def test_cattaneo3d_cycle_metrics_read_the_closed_form_as_exact():
    """demo_cattaneo3d --cycle's metrics (the run takes 2 min: BENCHMARKS §67) on data
    written from the closed forms: a loop Q(δ) of Mindlin–Deresiewicz's branches plus a
    body compliance C_b gives C_b back and no loop error; the cycle's dissipation sums
    the steps of 2 < t ≤ 6 only; contact CSVs of the unloading and reloading tractions
    (stick within c') give c' to the grid's spacing and no old-sign slip node, and one
    node's traction turned back to the old sign is counted."""
    A, d = demo_cattaneo3d.analytic, demo_cattaneo3d
    P, mu, C_b = 77.0, d.MU, 1.94e-3
    e_star, lam = A.effective_modulus(d.E, d.NU), A.tangential_compliance(d.E, d.NU)
    Qs = 0.54 * mu * P
    t = np.array([0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0])
    Q = np.array([0.0, 0.0, 0.5, 1.0, 0.5, 0.0, -0.5, -1.0, -0.5, 0.0, 0.5, 1.0]) * Qs
    dc = [0.0, 0.0, *(A.cattaneo_mindlin3d_shift(P, q, mu, d.R, e_star, lam) for q in Q[2:4])]
    dc += [A.mindlin_deresiewicz3d_shift(P, Qs, q, mu, d.R, e_star, lam) for q in Q[4:8]]
    dc += [A.mindlin_deresiewicz3d_shift(P, Qs, q, mu, d.R, e_star, lam, -Qs) for q in Q[8:]]
    delta = np.array(dc) + C_b * Q
    m = d.loop_metrics(t, delta, np.full(len(t), P), Q)
    assert m["C_b"] == pytest.approx(C_b, rel=1e-9)
    assert m["Q_star"] == Qs and m["Q_min"] == -Qs
    assert m["loop_err"] < 1e-8
    assert np.isnan(m["Q_pred"][:2]).all()
    assert m["branch"][2:] == ["load"] * 2 + ["unload"] * 4 + ["reload"] * 4
    # a force 3 % off on the unloading branch is read as such
    Q2 = Q.copy()
    Q2[5] += 0.03 * Qs
    assert d.loop_metrics(t, delta, np.full(len(t), P), Q2)["loop_err"] == pytest.approx(
        0.03, rel=1e-6
    )
    # Masing's rule: each branch's closed-form shift is continuous where it leaves the loop
    for branch, q, qm in (("unload", -Qs, -Qs), ("reload", -1.02 * Qs, -1.02 * Qs)):
        lo, hi = (d.loop_contact_shift(branch, P, q * (1 + s), Qs, qm, lam) for s in (1e-9, -1e-9))
        assert lo == pytest.approx(hi, abs=1e-9)
    diss = np.full(len(t), 0.01)
    w = d.cycle_dissipation(t, diss, P, Qs)
    assert w["dW_fe"] == pytest.approx(0.08)  # the 8 steps of (2, 6]
    assert w["dW"] == pytest.approx(A.mindlin_deresiewicz3d_energy(P, Qs, mu, d.R, e_star, lam))
    assert w["dW_ratio"] == pytest.approx(w["dW_fe"] / w["dW"])

    x, r = _cap_nodes()
    p = A.hertz3d_pressure(r, P, d.R, e_star)
    a = A.hertz3d(P, d.R, e_star)["a"]
    for Qk, Qprev, qmin in ((-0.5 * Qs, 0.0, None), (0.5 * Qs, 0.0, -Qs)):
        branch = "unload" if qmin is None else "reload"
        c1 = a * d.loop_stick_ratio(branch, P, Qk, Qs, qmin)
        assert c1 == pytest.approx(a * A.mindlin_deresiewicz3d_stick(P, Qs, Qk, mu, qmin))
        cur = _closed_form_csv(
            x, p, A.mindlin_deresiewicz3d(r, P, Qs, Qk, mu, d.R, e_star, qmin), c1
        )
        prev = _closed_form_csv(
            x, p, A.mindlin_deresiewicz3d(r, P, Qs, Qprev, mu, d.R, e_star, qmin), a
        )
        c_fit, rr, state = d.stick_fit(cur, a)
        assert abs(c_fit - c1) < 0.083, (branch, c_fit, c1)
        direction = Qk - Qprev
        assert d.old_sign_slip_nodes(cur, prev, direction) == 0
        slip = np.flatnonzero((state == 2) & (prev["state"] > 0))
        assert len(slip) > 20
        cur["p_T0"][slip[0]] *= -1.0
        assert d.old_sign_slip_nodes(cur, prev, direction) == 1
        assert d.old_sign_slip_nodes(cur, prev, -direction) == len(slip) - 1


def test_cattaneo3d_metrics_read_the_closed_form_as_exact():
    """demo_cattaneo3d's metrics (the run itself takes 80 s: BENCHMARKS §63) on a contact
    CSV written from the closed forms: nodes of a sphere's lower cap (a jittered grid),
    p of Hertz, q of Cattaneo–Mindlin against +x in the CSV's slave frame, stick within
    c. The fitted stick radius is c to the grid's spacing, no node is misclassified, the
    slip nodes sit on the cone, and the L2 error of q is the interpolation floor."""
    R, mu = demo_cattaneo3d.R, demo_cattaneo3d.MU
    P, Q = 77.0, 0.5 * mu * 77.0
    e_star = demo_cattaneo3d.analytic.effective_modulus(demo_cattaneo3d.E, demo_cattaneo3d.NU)
    a = demo_cattaneo3d.analytic.hertz3d(P, R, e_star)["a"]
    c = a * demo_cattaneo3d.analytic.cattaneo_mindlin3d(P, Q, mu)
    x, r = _cap_nodes()
    p = demo_cattaneo3d.analytic.hertz3d_pressure(r, P, R, e_star)
    q = demo_cattaneo3d.analytic.cattaneo_mindlin3d_traction(r, P, Q, mu, R, e_star)
    csv = _closed_form_csv(x, p, q, c)
    m = demo_cattaneo3d.evaluate(csv, P, Q, h=0.083)
    assert m["Q_over_muP"] == pytest.approx(0.5)
    assert m["c_over_a"] == pytest.approx(0.5 ** (1 / 3))
    assert abs(m["c_err_elements"]) < 0.5, m
    assert m["misclassified"] == 0
    lo, hi = m["slip_ratio"]
    assert 1 - 1e-12 < lo <= hi < 1 + 1e-12, m["slip_ratio"]
    assert m["stick_ratio_max"] < 1.0
    # to the offset of the pressure centroid from the origin on the jittered grid
    assert m["l2_q"] == pytest.approx(m["l2_q_floor"], rel=1e-2)
    assert m["l2_q"] < 0.08 and m["l2_p"] < 0.03, m  # the floor: 5.9 % at this spacing
    assert abs(m["p_max_err"]) < 0.01
