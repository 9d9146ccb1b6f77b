"""Parallel runs against serial ones: the same nodal pressures, tangential tractions, slip
and stick/slip states, and contact forces on 1, 2, 3 ranks.

Under ``mpirun -n N`` each test runs the scene on COMM_WORLD (N ranks) and the same
scene on COMM_SELF (serial; test_parallel_equals_serial's serial runs are shared out over
the ranks: ``serial_runs``); the CSV tables (sorted by reference coordinates) and the
summary forces must agree to 1e-8 on rank 0. Serially the two runs coincide, which still
exercises the path.
"""

import pathlib
from time import perf_counter

import numpy as np
import pytest
from mpi4py import MPI

from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import OUTPUT_FIELDS, parse_scene

HERTZ2D = {
    "kinematics": "small",
    "mesh": {"generator": "hertz2d", "params": {"h_contact": 0.25, "h_far": 3.0}},
    "material": [
        {"region": r, "model": "linear-elastic", "E": 200.0, "nu": 0.3}
        for r in ("cylinder", "block")
    ],
    "contact": [{"slave": "cylinder_surface", "master": "block_top", "uzawa_tol": 1e-8}],
    "dirichlet": [
        {"boundary": "block_bottom", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]},
        {"boundary": "symmetry", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
    ],
    "traction": [{"boundary": "cylinder_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.625]]}],
    "steps": {"n": 2},
}
HERTZ3D = {
    "kinematics": "small",
    "mesh": {
        "generator": "hertz3d",
        "params": {"h_contact": 0.5, "h_far": 4.0, "W": 8.0, "H": 6.0},
    },
    "material": [
        {"region": r, "model": "linear-elastic", "E": 200.0, "nu": 0.3} for r in ("sphere", "block")
    ],
    "contact": [
        {
            "slave": "sphere_surface",
            "master": "block_top",
            "uzawa_tol": 1e-8,
            "integration": "segment",
        }
    ],
    "dirichlet": [
        {"boundary": "block_bottom", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]},
        {"boundary": "symmetry_x", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "symmetry_y", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]},
    ],
    "traction": [
        {"boundary": "sphere_top", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -0.0497359]]}
    ],
    "steps": {"n": 1},
}

CATTANEO2D = {
    "kinematics": "small",
    "mesh": {
        "generator": "cattaneo2d",
        "params": {"h_contact": 0.1, "c_zone": 1.0, "h_far": 3.0},
    },
    "material": [
        {"region": r, "model": "linear-elastic", "E": 200.0, "nu": 0.3} for r in ("upper", "lower")
    ],
    "contact": [
        {
            "slave": "upper_surface",
            "master": "lower_surface",
            "friction": 0.2,
            "uzawa_tol": 1e-9,
            "uzawa_max": 60,
        }
    ],
    "dirichlet": [
        {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
        {
            "boundary": "upper_top",
            "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.15], [2.0, 0.025, -0.15]],
        },
    ],
    "steps": {"t_end": 2.0, "n": 4},
}


# Frictionless large sliding: the upper half-cylinder pressed in four steps, then dragged
# by 1.0 (10 contact facets, 2.5 per step) over the lower one, 3 nodes still in contact at
# the end. The master ghost layer is exchanged again whenever the surfaces have moved by
# a quarter of its margin since the last exchange: twice on this path
# (MortarContact._exchanges = 3 with the first).
SLIDE2D = dict(
    CATTANEO2D,
    mesh={"generator": "cattaneo2d", "params": {"h_contact": 0.1, "c_zone": 1.5, "h_far": 3.0}},
    contact=[{"slave": "upper_surface", "master": "lower_surface", "uzawa_tol": 1e-8}],
    dirichlet=[
        {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
        {"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.05], [2.0, 1.0, -0.05]]},
    ],
    steps={"t_end": 2.0, "n": 8},
)


# 3D friction (session 61): the flat tetrahedral patch (non-matching, 3 × 3 lower and
# 4 × 4 upper cells in x, 2 in y) pressed by 0.01, then the upper block shifted by 0.008:
# the centre sticks, the edges slip (20 stick and 5 slip nodes), segment integration;
# "auto" resolves to the exact Uzawa update (3D frictional, lumped), so its distributed
# finite-difference products run here too. 4 s serially.
PATCH3D_FRICTION = {
    "kinematics": "small",
    "mesh": {
        "generator": "patch3d",
        "params": {"n_lower": 3, "n_upper": 4, "n_y": 2, "quads": False},
    },
    "material": [
        {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3} for r in ("lower", "upper")
    ],
    "contact": [
        {
            "slave": "upper_bottom",
            "master": "lower_top",
            "friction": 0.3,
            "integration": "segment",
            "uzawa_tol": 1e-9,
        }
    ],
    "dirichlet": [
        {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]]},
        {
            "boundary": "upper_top",
            "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -0.01], [2.0, 0.008, 0.0, -0.01]],
        },
    ],
    "steps": {"t_end": 2.0, "n": 2},
}


def _with_recovery(data, recovery, **more):
    return dict(data, contact=[dict(data["contact"][0], recovery=recovery, **more)])


def _run(data, out, comm, box=None):
    """Run ``data`` on ``comm``; ``box["problem"]`` receives the problem (if given). A
    frictional scene writes every field (the tangential traction, slip and contact state
    too: their XDMF output on 1–3 ranks), a frictionless one the displacement and the
    pressure."""
    fields = ["displacement", "contact_pressure"]
    if any(pair.get("friction") for pair in data["contact"]):
        fields = list(OUTPUT_FIELDS)
    d = dict(data, output={"dir": str(out), "fields": fields})
    setup = None if box is None else (lambda problem: box.update(problem=problem))
    return run(parse_scene(d, pathlib.Path(".")), comm, setup=setup)


#: test_parallel_equals_serial's scenes: (name, scene, slave surface)
PARALLEL_CASES = [
    ("hertz2d", HERTZ2D, "cylinder_surface"),
    ("hertz3d", HERTZ3D, "sphere_surface"),
    ("cattaneo2d-friction", CATTANEO2D, "upper_surface"),
    ("hertz2d-unconstrained", _with_recovery(HERTZ2D, "unconstrained"), "cylinder_surface"),
    ("hertz2d-constrained", _with_recovery(HERTZ2D, "constrained"), "cylinder_surface"),
    ("hertz3d-constrained", _with_recovery(HERTZ3D, "constrained"), "sphere_surface"),
    (
        # the gathered systems of both consistent recoveries: the normal QP and the
        # tangential Coulomb-cone QP
        "cattaneo2d-friction-constrained",
        _with_recovery(CATTANEO2D, "constrained", tangential_recovery="constrained"),
        "upper_surface",
    ),
    (
        # the master's covariant basis: the nodes' t_n master points, ghost master facets
        "cattaneo2d-friction-master",
        _with_recovery(CATTANEO2D, "lumped", tangential_frame="master"),
        "upper_surface",
    ),
    ("slide2d", SLIDE2D, "upper_surface"),
    ("patch3d-friction", PATCH3D_FRICTION, "upper_bottom"),
]


@pytest.fixture(scope="module")
def serial_runs(request, tmp_path_factory):
    """The serial runs (COMM_SELF, the default direct solver) of PARALLEL_CASES that
    test_parallel_equals_serial compares with, and
    test_an_iterative_linear_solver_gives_the_direct_solvers_answer too (the same scenes,
    run a second time before), under mpirun: of the cases that the session runs, each
    rank runs every size-th (case i on rank i mod size), all of them before the first
    case, instead of rank 0 running each after its parallel run while the other ranks
    waited (on 3 ranks, 2 of them busy-waiting on the 2 cores). Rank 0 gets {name:
    (summary, output directory)}, or (None, the error) for a run that raised
    (collective; an empty dict serially, where the tests run what they compare)."""
    comm = MPI.COMM_WORLD
    if comm.size == 1:
        return {}
    path = str(tmp_path_factory.mktemp("serial_runs")) if comm.rank == 0 else None
    root = pathlib.Path(comm.bcast(path, root=0))
    users = (
        "test_parallel_equals_serial",
        "test_an_iterative_linear_solver_gives_the_direct_solvers_answer",
    )
    wanted = {
        item.callspec.params["name"]
        for item in request.session.items
        if item.module is request.module and item.originalname in users
    }
    mine = {}
    cases = [case for case in PARALLEL_CASES if case[0] in wanted]
    for name, data, _ in cases[comm.rank :: comm.size]:
        out = root / f"{name}_ser"
        try:
            mine[name] = (_run(data, out, MPI.COMM_SELF), out)
        except Exception as exc:  # on rank 0 in the test: the other ranks go on
            mine[name] = (None, f"{type(exc).__name__}: {exc}")
    gathered = comm.gather(mine, root=0)
    return {k: v for part in gathered for k, v in part.items()} if comm.rank == 0 else {}


@pytest.mark.mpi
@pytest.mark.mpi_not1
@pytest.mark.parametrize("name, data, slave", PARALLEL_CASES)
def test_parallel_equals_serial(shared_tmp, serial_runs, name, data, slave):
    """Each of PARALLEL_CASES on COMM_WORLD against its serial run: the slave table of the
    last step (p_N to 1e-8 of its maximum, coordinates to 1e-10, tangential traction,
    gap, slip and state to 1e-8), the contact force and the reactions to 1e-8. On 3 ranks
    these comparisons stand for the scenario tests that run serially and on 2 ranks only
    (``mpi_not3``): 2D and 3D, frictionless and frictional, each normal recovery, the
    master frame, large sliding, and the 3D frictional exact Uzawa update. Not in the
    serial pass of scripts/test.sh (``mpi_not1``, session 66): serially the parallel run
    is the serial one, and the MPI passes run each serial reference (``serial_runs``)
    and check it as the serial pass did (status, surface counts, pressures, states)."""
    comm = MPI.COMM_WORLD
    box = {}
    par = _run(data, shared_tmp / f"{name}_par", comm, box)
    assert par["status"] == "ok" and par["ranks"] == comm.size
    if name == "slide2d":  # the ghost layer was exchanged again as the surfaces slid
        assert box["problem"].contacts[0]._exchanges >= 3
    (pair,) = par["modelled"]["contact_pairs"].values()
    assert pair["recovery"] == data["contact"][0].get("recovery", "lumped")
    if name == "patch3d-friction":  # "auto" is the exact update on a 3D frictional pair
        assert pair["uzawa_acceleration"] == "newton"
    if pair["tangential_fields"]:
        assert pair["tangential_recovery"] == data["contact"][0].get(
            "tangential_recovery", "lumped"
        )
        assert pair["frame"].startswith(data["contact"][0].get("tangential_frame", "slave"))
    if comm.rank == 0:
        # serially the "parallel" run IS the serial one: the checks below then only test
        # the run itself (states, pressures), without running it a second time
        if comm.size > 1:
            ser, ser_dir = serial_runs[name]
            assert ser is not None, f"the serial run raised {ser_dir}"
        else:
            ser, ser_dir = par, shared_tmp / f"{name}_par"
        assert ser["status"] == "ok"
        # the surface's size, counted over the ranks
        (ser_pair,) = ser["modelled"]["contact_pairs"].values()
        for key in ("slave_nodes", "slave_facets"):
            assert pair[key] == ser_pair[key] > 0
        k = len(par["steps"])
        assert k == len(ser["steps"]) and k >= 1
        tp = np.loadtxt(
            shared_tmp / f"{name}_par" / f"contact_{slave}_{k}.csv", delimiter=",", skiprows=1
        )
        ts = np.loadtxt(ser_dir / f"contact_{slave}_{k}.csv", delimiter=",", skiprows=1)
        assert tp.shape == ts.shape and tp.shape[0] > 10
        pcol = 4 if "2d" in name else 6  # p_N column
        assert np.count_nonzero(ts[:, pcol] > 0) >= 3
        scale = ts[:, pcol].max()
        np.testing.assert_allclose(tp[:, pcol], ts[:, pcol], rtol=0, atol=1e-8 * scale)
        np.testing.assert_allclose(tp[:, :pcol], ts[:, :pcol], rtol=0, atol=1e-10)
        # tangential traction, gap, slip and state (friction: stick and slip both present)
        np.testing.assert_allclose(tp[:, pcol + 1 :], ts[:, pcol + 1 :], rtol=0, atol=1e-8 * scale)
        if "friction" in name:
            assert set(np.unique(ts[:, -1])) >= {1.0, 2.0}
        fp = np.array(
            par["steps"][-1]["contact_force"][next(iter(par["steps"][-1]["contact_force"]))]
        )
        fs = np.array(
            ser["steps"][-1]["contact_force"][next(iter(ser["steps"][-1]["contact_force"]))]
        )
        np.testing.assert_allclose(fp, fs, rtol=1e-8, atol=1e-10 * np.abs(fs).max())
        rp, rs = par["steps"][-1]["reactions"], ser["steps"][-1]["reactions"]
        for b in rs:
            np.testing.assert_allclose(
                rp[b], rs[b], rtol=1e-8, atol=1e-9 * max(np.abs(rs[b]).max(), 1.0)
            )
    comm.barrier()


#: GMRES with PETSc's algebraic multigrid, as docs/scenes.md's ``[solver.petsc]`` example
#: has it; the Krylov tolerance below Newton's (rtol 1e-9) so that both solvers reach the
#: same converged state
ITERATIVE = {"ksp_type": "gmres", "pc_type": "gamg", "ksp_rtol": 1e-10}


@pytest.mark.mpi
@pytest.mark.parametrize(
    "name, data, slave",
    [
        ("hertz3d", HERTZ3D, "sphere_surface"),
        # non-symmetric Jacobians (friction): MUMPS factorizes LU
        ("cattaneo2d-friction", CATTANEO2D, "upper_surface"),
    ],
)
def test_an_iterative_linear_solver_gives_the_direct_solvers_answer(
    shared_tmp, serial_runs, name, data, slave
):
    """The scene with GMRES + GAMG on COMM_WORLD against the default direct solver
    (MUMPS) serially: the same nodal pressures, tangential tractions, gaps, slip and
    states and the same contact force, to 1e-8; summary.json names the solver that ran
    (``modelled.linear_solver``) and counts its Krylov iterations per step
    (``linear_iterations``): several per Newton iteration with GMRES; with MUMPS one per
    Newton iteration, plus those of the solves with the last factorization (the exact
    multiplier update's products, GMRES on a reused factorization). On 1 rank the two
    runs are both serial."""
    comm = MPI.COMM_WORLD
    it = _run(dict(data, solver={"petsc": ITERATIVE}), shared_tmp / f"{name}_gamg", comm)
    assert it["status"] == "ok"
    assert it["modelled"]["linear_solver"] == {"ksp": "gmres", "pc": "gamg"}
    newton = sum(sum(st["newton_iterations"]) for st in it["steps"])
    assert sum(st["linear_iterations"] for st in it["steps"]) > 3 * newton > 0
    if comm.rank == 0:
        if comm.size > 1:  # test_parallel_equals_serial's serial run of the scene
            assert dict((c[0], c[1]) for c in PARALLEL_CASES)[name] == data
            direct, direct_dir = serial_runs[name]
            assert direct is not None, f"the serial run raised {direct_dir}"
        else:
            direct_dir = shared_tmp / f"{name}_mumps"
            direct = _run(data, direct_dir, MPI.COMM_SELF)
        assert direct["status"] == "ok"
        assert direct["modelled"]["linear_solver"]["ksp"] == "preonly"
        assert direct["modelled"]["linear_solver"]["factor"] == "mumps"
        for st in direct["steps"]:  # one a Newton iteration, more for the exact update
            assert sum(st["newton_iterations"]) <= st["linear_iterations"]
        lin = sum(st["linear_iterations"] for st in direct["steps"])
        assert lin < sum(st["linear_iterations"] for st in it["steps"])
        k = len(direct["steps"])
        assert len(it["steps"]) == k >= 1
        ti, td = (
            np.loadtxt(d / f"contact_{slave}_{k}.csv", delimiter=",", skiprows=1)
            for d in (shared_tmp / f"{name}_gamg", direct_dir)
        )
        assert ti.shape == td.shape and td.shape[0] > 10
        pcol = 4 if "2d" in name else 6  # p_N column
        assert np.count_nonzero(td[:, pcol] > 0) >= 3
        scale = td[:, pcol].max()
        np.testing.assert_allclose(ti[:, :pcol], td[:, :pcol], rtol=0, atol=1e-10)
        np.testing.assert_allclose(ti[:, pcol:], td[:, pcol:], rtol=0, atol=1e-8 * scale)
        (fi,), (fd,) = (s["steps"][-1]["contact_force"].values() for s in (it, direct))
        np.testing.assert_allclose(fi, fd, rtol=1e-8, atol=1e-10 * np.abs(fd).max())
    comm.barrier()


def test_the_exact_updates_linear_solves_count_in_the_linear_solve_time(shared_tmp, monkeypatch):
    """summary.json's ``timings.linear_solve`` holds the solves with the last Jacobian
    that the exact multiplier update's GMRES products take
    (``NewtonSolver.solve_with_last_jacobian``): they run inside that GMRES's own
    KSPSolve, and PETSc's KSPSolve event, which timed them, does not time a nested
    solve. Each call adds at least 0.9 of its wall time to the solver's linear-solve
    time (it added 0.18 of it with GAMG on hertz3d: 0.10 of 0.55 s)."""
    from dolfinx_mortar.solver import NewtonSolver

    wall, counted = [], []
    solve = NewtonSolver.solve_with_last_jacobian

    def timed(self, b, x):
        t0, c0 = perf_counter(), self.timings["linear_solve"]
        try:
            return solve(self, b, x)
        finally:
            wall.append(perf_counter() - t0)
            counted.append(self.timings["linear_solve"] - c0)

    monkeypatch.setattr(NewtonSolver, "solve_with_last_jacobian", timed)
    data = dict(HERTZ3D, contact=[dict(HERTZ3D["contact"][0], uzawa_acceleration="newton")])
    s = _run(dict(data, solver={"petsc": ITERATIVE}), shared_tmp / "exact_gamg", MPI.COMM_SELF)
    assert s["status"] == "ok" and len(wall) >= 4
    assert sum(wall) >= sum(counted) >= 0.9 * sum(wall) > 0.0
    assert s["timings"]["linear_solve"] <= s["timings"]["total"]


@pytest.mark.mpi
def test_a_mesh_is_partitioned_alike_every_time():
    """PT-Scotch's threads decided the partition (``dolfinx_mortar.SCOTCH_THREADS``): the
    same mesh loaded three times gave the ranks different cells, so identical runs differed
    at round-off. Every load must give each rank the same cells. (Serially the partition is
    trivial; the test means something on 2 and 3 ranks, where without the setting it failed
    in 4 runs of 4 on 3 ranks and 5 of 6 on 2.)"""
    from dolfinx_mortar.mesh import load_mesh

    comm = MPI.COMM_WORLD
    cells = []
    for _ in range(3):
        mesh = load_mesh(comm, generator="hertz2d").mesh
        n = mesh.topology.index_map(mesh.topology.dim).size_local
        cells.append(np.sort(np.asarray(mesh.topology.original_cell_index)[:n]))
    assert comm.allreduce(sum(c.size for c in cells[:1])) == 3227  # every cell, once
    same = all(np.array_equal(cells[0], c) for c in cells[1:])
    assert comm.allreduce(same, op=MPI.LAND)


@pytest.mark.parametrize("preset, expected", [(None, "1"), ("3", "3")])
def test_scotch_threads_set_on_import_unless_set(preset, expected):
    """``import dolfinx_mortar`` sets SCOTCH_PTHREAD_NUMBER to SCOTCH_THREADS where the
    environment does not set it, and keeps an explicit setting (README, "Parallel jobs on
    a cluster")."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "SCOTCH_PTHREAD_NUMBER"}
    if preset is not None:
        env["SCOTCH_PTHREAD_NUMBER"] = preset
    code = "import os, dolfinx_mortar; print(os.environ['SCOTCH_PTHREAD_NUMBER'])"
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == expected


@pytest.mark.mpi
@pytest.mark.parametrize(
    "name, data",
    [
        ("hertz2d", HERTZ2D),
        ("cattaneo2d-friction", CATTANEO2D),
        (
            "cattaneo2d-friction-master",
            _with_recovery(CATTANEO2D, "lumped", tangential_frame="master"),
        ),
    ],
)
def test_residual_round_off_is_collective_and_leaves_the_state(shared_tmp, name, data):
    """``ContactProblem.residual_round_off`` at the converged states of a run: one value
    on every rank, at the level of the residual's rounding; the state it evaluated around
    (u, the contact state, hence the residual) as before (bitwise serially; on several
    ranks two assemblies of the same state differ at round-off anyway); and a run that measures
    it after every step (``run(..., round_off=True)``) ends where one that does not ends,
    frictional history included (bitwise serially; to 1e-8 on several ranks, where two
    equal runs differ at round-off too)."""
    from dolfinx.fem.petsc import create_vector

    comm = MPI.COMM_WORLD
    box = {}
    runs = {}
    for measured in (False, True):
        runs[measured] = run(
            parse_scene(data, pathlib.Path(".")),
            comm,
            shared_tmp / f"round_off_{name}_{measured}",
            setup=lambda p: box.__setitem__("p", p),
            round_off=measured,
        )
    for a, b in zip(runs[False]["steps"], runs[True]["steps"], strict=True):
        if comm.size == 1:
            assert a["contact_force"] == b["contact_force"]
            assert a["residual_norms"] == b["residual_norms"]
        else:  # MUMPS on several ranks is not bitwise repeatable: two equal runs differ too
            for key, fa in a["contact_force"].items():
                fa, fb = np.asarray(fa), np.asarray(b["contact_force"][key])
                assert np.linalg.norm(fa - fb) <= 1e-8 * np.linalg.norm(fa), (fa, fb)
    p = box["p"]
    recorded = [st["residual_round_off"] for st in runs[True]["steps"]]
    assert all(1e-16 < f < 1e-10 for f in recorded), recorded
    u0 = p.u.x.array.copy()
    b0, b1 = create_vector(p.F_form), create_vector(p.F_form)
    p.update_contact(p.u.vector)
    p.residual(p.u.vector, b0)
    f = p.residual_round_off()
    p.residual(p.u.vector, b1)
    # every assertion on a value every rank shares: one rank failing alone would leave the
    # others waiting in the next collective call
    assert comm.allreduce(int(np.array_equal(p.u.x.array, u0)), op=MPI.MIN) == 1
    b1.axpy(-1.0, b0)
    change = b1.norm()
    if comm.size == 1:
        assert change == 0.0
    else:  # the off-rank sums of an assembly arrive in any order: equal to round-off
        assert change <= 10.0 * f, (change, f)
    assert len(set(comm.allgather(f))) == 1
    assert f == pytest.approx(recorded[-1], rel=1e-6)


@pytest.mark.mpi
def test_shared_nodes_counts_across_ranks():
    """surface.shared_nodes: rank r owns the global nodes 3r, 3r + 1, 3r + 2 and holds
    a = {3r, 3r + 1} and b = {3r + 1, 3(r + 1) mod 3p}: the sets share 3r + 1 on every
    rank and 3(r + 1) of the next rank's a, 2p nodes (p ranks; 2 serially), each counted
    once however many ranks hold it."""
    from dolfinx_mortar.surface import shared_nodes

    comm = MPI.COMM_WORLD
    r, p = comm.rank, comm.size
    ranges = np.arange(p + 1) * 3
    a = np.array([[3 * r, 3 * r + 1], [3 * r, 3 * r]])  # a repeat, 2D like blocks
    b = np.array([3 * r + 1, (3 * (r + 1)) % (3 * p), 3 * r + 1])
    assert shared_nodes(comm, ranges, a, b) == 2 * p
    assert shared_nodes(comm, ranges, a, np.array([3 * r + 2])) == 0


@pytest.mark.mpi
@pytest.mark.parametrize("recovery", ["unconstrained", "constrained"])
def test_p2_half_model_with_segments_passes_the_symmetry_sliver(shared_tmp, recovery):
    """hertz2d's coarse half model with P2 triangles and segment integration: the master's
    end node on the symmetry plane projects onto the slave's end facet a hair inside it
    (the penetration times the P2 facet's slope there), so that facet is paired over
    1 − 1e-9 of itself. With a 1e-9 threshold its block of the mortar matrix switched
    between consistent and lumped from one iterate to the next, a jump of the residual:
    the run stopped near t = 0.1012 when the step could not be halved further. Now it
    completes without a cutback, the load carried, and every facet that is paired at all
    is paired whole or beyond the threshold (tangential.PARTIAL_FACET_TOL)."""
    from dolfinx_mortar import tangential

    data = {
        **HERTZ2D,
        "mesh": {
            "generator": "hertz2d",
            "params": {"h_contact": 0.2, "h_far": 3.0, "quads": False, "order": 2},
        },
        "contact": [
            {
                "slave": "cylinder_surface",
                "master": "block_top",
                "recovery": recovery,
                "integration": "segment",
                "uzawa_tol": 1e-6,
            }
        ],
        "steps": {"n": 3},
    }
    box = {}
    s = run(
        parse_scene(data, shared_tmp),
        MPI.COMM_WORLD,
        out_dir=shared_tmp / f"p2_sliver_{recovery}",
        setup=lambda problem: box.update(p=problem),
    )
    assert s["status"] == "ok", s["error"]
    assert [st["cutbacks"] for st in s["steps"]] == [0, 0, 0], s["steps"]
    (force,) = [st["contact_force"] for st in s["steps"][-1:]]
    assert abs(force["cylinder_surface:block_top"][1] - 5.0) <= 1e-6, force
    term = box["p"].contacts[0]
    fraction = term.paired_fraction(term.qp_m)
    paired = fraction[fraction > 0.0]
    sliver = (paired > 1.0 - tangential.PARTIAL_FACET_TOL) & (paired < 1.0 - 1e-13)
    assert np.all(paired <= 1.0 + 1e-12), paired.max()
    assert MPI.COMM_WORLD.allreduce(int(np.count_nonzero(sliver))) >= 1  # the end facet


# Two cells (one per body) with friction: on 3 ranks one rank holds no cell. It crashed
# in surface.extract_facets (compat.cell_geometry_nodes reshaped an empty dofmap with
# reshape(0, -1): "cannot reshape array of size 0").
TINY2D = {
    "kinematics": "small",
    "mesh": {"generator": "patch2d", "params": {"n_lower": 1, "n_upper": 1, "n_y": 1}},
    "material": [
        {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3} for r in ("lower", "upper")
    ],
    "contact": [
        {"slave": "upper_bottom", "master": "lower_top", "friction": 0.3, "uzawa_tol": 1e-9}
    ],
    "dirichlet": [
        {"boundary": "lower_bottom", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "lower_left", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "upper_left", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
    ],
    "traction": [{"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.2, -2.0]]}],
    "steps": {"n": 2},
}


@pytest.mark.mpi
def test_a_rank_without_cells(shared_tmp):
    """A mesh with fewer cells than ranks (dolfinx leaves a rank empty) runs, and its
    contact table, contact force and reactions are the serial ones."""
    comm = MPI.COMM_WORLD
    box = {}
    par = _run(TINY2D, shared_tmp / "tiny_par", comm, box)
    assert par["status"] == "ok"
    tdim = box["problem"].mesh.topology.dim
    cells = box["problem"].mesh.topology.index_map(tdim).size_local
    assert comm.allreduce(cells) == 2
    if comm.size >= 3:
        assert comm.allreduce(int(cells == 0)) >= 1
    if comm.rank == 0:
        ser = _run(TINY2D, shared_tmp / "tiny_ser", MPI.COMM_SELF) if comm.size > 1 else par
        ser_dir = "tiny_ser" if comm.size > 1 else "tiny_par"
        assert ser["status"] == "ok" and len(ser["steps"]) == len(par["steps"]) == 2
        tp, ts = (
            np.loadtxt(shared_tmp / d / "contact_upper_bottom_2.csv", delimiter=",", skiprows=1)
            for d in ("tiny_par", ser_dir)
        )
        assert tp.shape == ts.shape == (2, 9) and np.all(ts[:, 4] > 1.0)
        np.testing.assert_allclose(tp, ts, rtol=0, atol=1e-9)
        fp, fs = (s["steps"][-1]["contact_force"]["upper_bottom:lower_top"] for s in (par, ser))
        np.testing.assert_allclose(fp, fs, rtol=0, atol=1e-9)
        for b, r in ser["steps"][-1]["reactions"].items():
            np.testing.assert_allclose(par["steps"][-1]["reactions"][b], r, rtol=0, atol=1e-9)


# Coulomb friction after a slide far beyond the master ghost layer's margin in ONE step:
# a soft block (E = 100, 12 slave facets) pressed by 0.02 onto a stiff, longer one
# (E = 1e6, 28 master facets over [-3, 4]), then one of them dragged by 1.3 (about 8
# margins of 2 h_slave) in one step. The t_n pairing (slip since the start of the step)
# needs the master facets under the slave's START-of-step position: they were not in the
# ghost layer (exchanged around the current slave box only), the points lost their t_n
# master, and the step ended frictionless (F_x ≈ 0) while every node reported "slip"; on
# several ranks, a partition-dependent part of them. The stiff master stays flat and the
# master frame is its direction, so in gross slip F_T = μ F_N up to the master's strain.
COULOMB_MU = 0.3


def _coulomb_slide(mover):
    drag = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, -1.3, 0.0]]
    press = [[0.0, 0.0, 0.0], [1.0, 0.0, -0.02], [2.0, 1.3 if mover == "slave" else 0.0, -0.02]]
    return {
        "kinematics": "small",
        "mesh": {
            "generator": "patch2d",
            "params": {"n_lower": 28, "n_upper": 12, "n_y": 2, "margin": 3.0, "quads": True},
        },
        "material": [
            {"region": r, "model": "linear-elastic", "E": e, "nu": 0.3}
            for r, e in (("lower", 1e6), ("upper", 100.0))
        ],
        "contact": [
            {
                "slave": "upper_bottom",
                "master": "lower_top",
                "friction": COULOMB_MU,
                "tangential_frame": "master",
                # the comparison with a serial run needs multipliers converged beyond its
                # tolerance: at the default 1e-6 the press's second round ends at a change
                # of 1.4e-6 serially and 6.4e-7 on 3 ranks (the exact update's GMRES
                # stops at a forcing tolerance), one round apart, 3e-8 apart in p_N
                "uzawa_tol": 1e-9,
            }
        ],
        "dirichlet": [
            {
                "boundary": "lower_bottom",
                "path": drag if mover == "master" else [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            },
            {"boundary": "upper_top", "path": press},
        ],
        "steps": {"t_end": 2.0, "n": 2},
    }


@pytest.mark.mpi
@pytest.mark.parametrize("mover", ["slave", "master"])
def test_a_one_step_slide_beyond_the_ghost_margin_keeps_coulomb_friction(shared_tmp, mover):
    comm = MPI.COMM_WORLD
    data = _coulomb_slide(mover)
    name = f"coulomb_{mover}"
    box = {}
    par = _run(data, shared_tmp / f"{name}_par", comm, box)
    assert par["status"] == "ok", par.get("error")
    term = box["problem"].contacts[0]
    assert 1.3 > 7 * term.margin
    # the layer holds the masters near the two positions, not the whole master surface
    n_master = comm.allreduce(term.master_local.num_facets)
    assert comm.allreduce(term.master.num_facets, op=MPI.MAX) < 0.8 * n_master
    fx, fy = par["steps"][-1]["contact_force"]["upper_bottom:lower_top"]
    assert fy > 1.0
    # gross slip: the Coulomb force (frictionless before the fix: fx/fy ≈ 0)
    assert abs(fx / (-COULOMB_MU * fy) - 1.0) < 1e-5
    if comm.rank == 0:
        k = len(par["steps"])
        tp = np.loadtxt(
            shared_tmp / f"{name}_par" / f"contact_upper_bottom_{k}.csv",
            delimiter=",",
            skiprows=1,
        )
        loaded = tp[:, 4] > 0
        assert np.count_nonzero(loaded) >= 10 and np.all(tp[loaded, -1] == 2.0)  # slip
        np.testing.assert_allclose(tp[:, 5], -COULOMB_MU * tp[:, 4], rtol=1e-4, atol=1e-12)
        if comm.size > 1:  # the same result as a serial run
            ser = _run(data, shared_tmp / f"{name}_ser", MPI.COMM_SELF)
            assert ser["status"] == "ok" and len(ser["steps"]) == k
            ts = np.loadtxt(
                shared_tmp / f"{name}_ser" / f"contact_upper_bottom_{k}.csv",
                delimiter=",",
                skiprows=1,
            )
            assert tp.shape == ts.shape
            # 1e-7: the dragged master's slide ends in a solve of 35 Newton iterations
            # (the pairing's chattering control) that lands, from round-off-level
            # differences of the linear solves, on one of three results: 3e-11, 4.3e-9
            # or 3.1e-8 of max p_N from the serial run on 3 ranks. MUMPS's parallel
            # factorization is not repeatable there (the same Jacobian and residual give
            # a different Newton step from run to run; not the hash seed), and serial
            # SuperLU_DIST already ends 4.3e-9 from serial MUMPS (BENCHMARKS §48)
            np.testing.assert_allclose(tp, ts, rtol=0, atol=1e-7 * ts[:, 4].max())
            fs = ser["steps"][-1]["contact_force"]["upper_bottom:lower_top"]
            np.testing.assert_allclose([fx, fy], fs, rtol=1e-7, atol=1e-10 * abs(fs[1]))
            for st_p, st_s in zip(par["steps"], ser["steps"], strict=True):
                assert st_p["newton_iterations"] == st_s["newton_iterations"]
    comm.barrier()


# Node integration on a matching structured interface: every slave node of patch3d's
# 4 x 4 hexahedral faces lies over a master vertex or edge, where its projections onto
# the 2 or 4 master facets around it have gaps equal to round-off (60 of the 64 node
# points). The closest facet was decided by that round-off and by the facets' local order,
# so the pairing, and with it the Newton path, depended on the partition: the first step
# took 12, 9 and 8 Newton iterations on 1, 2 and 3 ranks (kernels.mortar.PAIR_TIE_TOL).
PATCH3D_NODE = {
    "mesh": {"generator": "patch3d", "params": {"n_lower": 4, "n_upper": 4, "n_y": 2}},
    "material": [
        {"region": r, "model": "neo-hookean", "E": 100.0, "nu": 0.3} for r in ("lower", "upper")
    ],
    "contact": [
        {
            "slave": "upper_bottom",
            "master": "lower_top",
            "integration": "node",
            "penalty": "auto",
            "uzawa_tol": 1e-8,
        }
    ],
    "dirichlet": [
        {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]},
        {"boundary": "upper_top", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -0.02]]},
    ],
    "steps": {"n": 2},
}


@pytest.mark.mpi
def test_node_integration_over_master_vertices_takes_the_same_newton_path(shared_tmp):
    """Ties of the pairing are broken by the master facets' reference centroids, the same
    on every partition: the same Newton iterations on 1, 2 and 3 ranks, and few of them
    (the interface is flat; before: 12 + 1 and 9 + 1 serially, 9 + 1 and 10 + 1 on 2 ranks)."""
    comm = MPI.COMM_WORLD
    par = _run(PATCH3D_NODE, shared_tmp / "patch3d_node_par", comm)
    assert par["status"] == "ok" and len(par["steps"]) == 2
    its = [s["newton_iterations"] for s in par["steps"]]
    assert max(its[0][0], its[1][0]) <= 4, its
    if comm.rank == 0:
        if comm.size > 1:
            ser = _run(PATCH3D_NODE, shared_tmp / "patch3d_node_ser", MPI.COMM_SELF)
            assert ser["status"] == "ok"
        else:
            ser = par
        assert its == [s["newton_iterations"] for s in ser["steps"]]
        fp = par["steps"][-1]["contact_force"]["upper_bottom:lower_top"]
        fs = ser["steps"][-1]["contact_force"]["upper_bottom:lower_top"]
        assert fs[2] > 2.0  # the press, in the master's +z direction
        np.testing.assert_allclose(fp, fs, rtol=0, atol=1e-9 * fs[2])
    comm.barrier()
