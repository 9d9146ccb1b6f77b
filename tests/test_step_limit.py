"""Penetration-limited Newton steps (``[solver] step_depth_limit``, and
``solver.FIRST_CONTACT_DEPTH_LIMIT`` in first-contact solves).

``MortarContact.step_limit`` against the closed form on a flat interface (gaps linear in
a rigid translation), and a displacement-driven press from the open state solved with
and without the limit: the same converged state, reached by shortened steps; the
first-contact limit shortens the steps of the solve that starts open only. Serially
and on 2 ranks.
"""

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from test_contact_parallel import HERTZ2D

from dolfinx_mortar import solver
from dolfinx_mortar.runner import prepare, run
from dolfinx_mortar.scene import SceneError, parse_scene

#: serially and on 2 ranks, not on 3 (``mpi_not3``, session 61: the 2-core budget; on 3
#: ranks test_contact_parallel compares such runs with serial ones to 1e-8)
pytestmark = pytest.mark.mpi_not3

GAP0 = 0.05  # initial gap between the blocks of the patch


def _patch_problem():
    data = {
        "kinematics": "finite",
        "mesh": {"generator": "patch2d", "params": {"gap0": GAP0}},
        "material": [
            {"region": r, "model": "neo-hookean", "E": 200.0, "nu": 0.3} for r in ("lower", "upper")
        ],
        "contact": [{"slave": "upper_bottom", "master": "lower_top", "penalty": 1.0e3}],
        "output": {"dir": "unused"},
    }
    problem, _ = prepare(parse_scene(data, __import__("pathlib").Path(".")), MPI.COMM_WORLD)
    return problem


def _translated(problem, dy):
    """A global vector: the upper block translated by dy (y), the lower one at rest."""
    md = problem.mesh_data
    cells = md.cell_tags.find(md.cell_groups["upper"])
    dofs = fem.locate_dofs_topological(problem.V, problem.mesh.topology.dim, cells)
    w = fem.Function(problem.V)
    w.x.array[dofs * problem.V.dofmap.index_map_bs + 1] = dy
    w.x.scatter_forward()
    return w.vector.copy()


@pytest.mark.mpi
def test_step_limit_bounds_the_penetration_of_open_nodes():
    problem = _patch_problem()
    term = problem.contacts[0]
    comm = problem.comm

    def limit(current, trial, depth):
        problem.update_contact(current)
        return comm.allreduce(term.step_limit(trial, depth), op=MPI.MIN)

    h = comm.allreduce(float(term.h_node.max(initial=0.0)), op=MPI.MAX)
    h_min = comm.allreduce(float(term.h_node.min(initial=np.inf)), op=MPI.MIN)
    assert h == pytest.approx(h_min, rel=1e-12)  # uniform slave facets: one closed form
    rest = _translated(problem, 0.0)
    # open (gap GAP0) -> 0.5 h deep: the open nodes may go 0.25 h deep, a fraction
    # (GAP0 + 0.25 h) / (GAP0 + 0.5 h) of the step
    lam = limit(rest, _translated(problem, -(GAP0 + 0.5 * h)), 0.25)
    assert lam == pytest.approx((GAP0 + 0.25 * h) / (GAP0 + 0.5 * h), rel=1e-10)
    # ... and there the deepest node is 0.25 h deep
    problem.update_contact(_translated(problem, -lam * (GAP0 + 0.5 * h)))
    has = term.has_area
    deepest = comm.allreduce(float(np.max(-term.G[has] / term.A[has], initial=0.0)), op=MPI.MAX)
    assert deepest == pytest.approx(0.25 * h, rel=1e-9)
    # a step that stays above -0.25 h, and one that opens the gap: not shortened
    assert limit(rest, _translated(problem, -(GAP0 + 0.2 * h)), 0.25) == 1.0
    assert limit(rest, _translated(problem, 0.3), 0.25) == 1.0
    # nodes in contact (0.01 h deep, pressed) are not limited: the tangent knows them
    pressed = _translated(problem, -(GAP0 + 0.01 * h))
    problem.update_contact(pressed)
    n_active = comm.allreduce(int(np.sum(term.p_hat > 0)))
    assert n_active == comm.allreduce(int(np.sum(term.has_area))) > 0
    assert limit(pressed, _translated(problem, -(GAP0 + 2.0 * h)), 0.25) == 1.0


#: the 2D Hertz scene of the parallel tests, pressed by a displacement of the cylinder's
#: top in one step from the open state, 2.5 h deep: without the limit the first Newton
#: steps plunge the cylinder into the block; with it they are shortened 4 times
PRESS = {
    **{k: v for k, v in HERTZ2D.items() if k != "traction"},
    "mesh": {"generator": "hertz2d", "params": {"h_contact": 0.2, "h_far": 3.0}},
    "dirichlet": HERTZ2D["dirichlet"]
    + [{"boundary": "cylinder_top", "components": [1], "path": [[0.0, 0.0], [1.0, -0.5]]}],
    "steps": {"n": 1, "max_cutbacks": 0},
}


def _press(shared_tmp, name, data):
    """Run ``data``; (summary, the slave node table of step ``n``, rank 0's broadcast)."""
    d = shared_tmp / name
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=d)
    assert s["status"] == "ok"
    n = len(s["steps"])
    table = None
    if MPI.COMM_WORLD.rank == 0:
        table = np.genfromtxt(d / f"contact_cylinder_surface_{n}.csv", delimiter=",", names=True)
    return s, MPI.COMM_WORLD.bcast(table, root=0)


@pytest.mark.mpi
@pytest.mark.parametrize("integration", ["element", "segment", "node"])
def test_a_depth_limited_press_reaches_the_same_state(shared_tmp, integration, monkeypatch):
    """The limit changes the path of Newton, not its solution: nodal pressures and the
    contact force agree with the unlimited run to 1e-8 (measured 3e-13 with element
    integration), for each integration, with ``step_depth_limit = 0.25`` and with the
    default (0: the first-contact limit, this press being a first contact); the limited
    runs shortened some of their steps (4 at 0.25), the unlimited one none."""
    out = {}
    for name, depth, first in (("off", 0.0, 0.0), ("first", 0.0, 0.5), ("all", 0.25, 0.5)):
        monkeypatch.setattr(solver, "FIRST_CONTACT_DEPTH_LIMIT", first)
        data = {**PRESS, "solver": {"step_depth_limit": depth}}
        data["contact"] = [{**PRESS["contact"][0], "integration": integration}]
        out[name] = _press(shared_tmp, f"press_{name}", data)
    s0, t0 = out["off"]
    p0 = t0["p_N"]
    assert s0["steps"][0]["limited_steps"] == 0
    assert np.max(p0) > 0.0 and np.count_nonzero(p0) >= 3
    f0 = np.asarray(s0["steps"][0]["contact_force"]["cylinder_surface:block_top"])
    for name in ("first", "all"):
        s1, t1 = out[name]
        assert s1["steps"][0]["limited_steps"] >= 1, name
        assert np.max(np.abs(t1["p_N"] - p0)) <= 1e-8 * np.max(p0), name
        f1 = np.asarray(s1["steps"][0]["contact_force"]["cylinder_surface:block_top"])
        assert np.linalg.norm(f1 - f0) <= 1e-8 * np.linalg.norm(f0), name
    assert s0["modelled"]["first_contact_depth_limit"] == 0.0
    assert out["first"][0]["modelled"]["step_depth_limit"] == 0.0
    assert out["first"][0]["modelled"]["first_contact_depth_limit"] == 0.5
    assert out["all"][0]["modelled"]["step_depth_limit"] == 0.25
    assert out["all"][0]["modelled"]["first_contact_depth_limit"] == 0.0


@pytest.mark.mpi
def test_the_first_contact_limit_leaves_solves_from_a_closed_contact_alone(shared_tmp, monkeypatch):
    """The same press in two steps, default settings: the Newton steps of the first
    solve (the step starts open: a first contact) are checked against the 0.5 h limit,
    those of every later solve (the contact zone is closed when they start) are not,
    and with ``step_depth_limit = 0.25`` every solve's are (``MortarContact.first_contact``,
    ``NewtonSolver._depth_limits``)."""
    seen = []

    def recorded(self):
        limits = depth_limits(self)
        seen.append((self.problem.contacts[0].first_contact, limits))
        return limits

    depth_limits = solver.NewtonSolver._depth_limits
    monkeypatch.setattr(solver.NewtonSolver, "_depth_limits", recorded)
    for depth in (0.0, 0.25):
        seen.clear()
        data = {**PRESS, "steps": {"n": 2, "max_cutbacks": 0}}
        data["solver"] = {"step_depth_limit": depth}
        s, table = _press(shared_tmp, f"press_two_steps_{depth}", data)
        assert [st["converged"] for st in s["steps"]] == [True, True]
        assert np.count_nonzero(table["p_N"]) >= 3
        first = [limits for fc, limits in seen if fc]
        later = [limits for fc, limits in seen if not fc]
        # the first solve's Newton steps, then those of the rounds and of step 2
        assert len(first) >= 3 and len(later) >= 3
        assert seen[0][0] and not seen[-1][0]
        assert first == [[depth or 0.5]] * len(first)
        assert later == [[depth]] * len(later)


def test_step_depth_limit_scene_key(tmp_path):
    base = {**PRESS, "output": {"dir": "x"}}
    assert parse_scene(base, tmp_path).solver.step_depth_limit == 0.0
    ok = parse_scene({**base, "solver": {"step_depth_limit": 0.5}}, tmp_path)
    assert ok.solver.step_depth_limit == 0.5
    for bad in (-0.1, "deep", True):
        with pytest.raises(SceneError, match=r"solver\.step_depth_limit"):
            parse_scene({**base, "solver": {"step_depth_limit": bad}}, tmp_path)
