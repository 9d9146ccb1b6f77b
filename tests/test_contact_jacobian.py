"""The contact tangent K_c against central finite differences of the contact residual R_c.

Configurations with partial contact and sliding: the slave body is pushed into
the master and shifted sideways by a non-uniform displacement field, the master
is deformed too; the multipliers λ are nonzero (mid-Uzawa). For random
directions v, (R_c(u + h v) − R_c(u − h v)) / 2h must equal K_c v. Runs
serially and under MPI (the contact data then crosses ranks).
"""

import copy

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_mortar import contact, tangential, uzawa
from dolfinx_mortar.runner import prepare
from dolfinx_mortar.scene import parse_scene

#: the finite-difference checks of the tangent: the exact tangent at every Jacobian (the
#: fixture raises DEEP_PENETRATION_TOL to inf). Per test, never module-wide: the
#: other tests, and any test that runs a scene, see the shipped settings.
exact_tangent = pytest.mark.usefixtures("exact_contact_tangent")
#: the pattern tests compare Jacobians assembled one after the other at one state (or
#: with a direct insertion). With the shipped DEEP_PENETRATION_TOL the first Jacobian of a
#: solve at these pressed states leaves the geometric part out and the next one keeps it,
#: so the values differ by that rule, not by the assembly under test (measured without
#: the fixture: by 0.3 % to 9 % of ‖J‖). They take the exact tangent too.
same_tangent_twice = exact_tangent
#: the library's value
DEEP_PENETRATION_TOL = tangential.DEEP_PENETRATION_TOL

CASES = {
    # name: (generator, params, slave, master, bodies (slave, master), gdim)
    "hertz2d-P1": (
        "hertz2d",
        {"h_contact": 0.4, "h_far": 4.0},
        "cylinder_surface",
        "block_top",
        ("cylinder", "block"),
        2,
    ),
    "hertz2d-P2": (
        "hertz2d",
        {"h_contact": 0.5, "h_far": 4.0, "order": 2},
        "cylinder_surface",
        "block_top",
        ("cylinder", "block"),
        2,
    ),
    "hertz2d-Q1": (
        "hertz2d",
        {"h_contact": 0.4, "h_far": 4.0, "quads": True},
        "cylinder_surface",
        "block_top",
        ("cylinder", "block"),
        2,
    ),
    "hertz3d-P1": (
        "hertz3d",
        {"h_contact": 0.6, "h_far": 6.0, "W": 8.0, "H": 6.0},
        "sphere_surface",
        "block_top",
        ("sphere", "block"),
        3,
    ),
    "hertz3d-P2": (
        "hertz3d",
        {"h_contact": 0.5, "h_far": 8.0, "W": 8.0, "H": 6.0, "order": 2},
        "sphere_surface",
        "block_top",
        ("sphere", "block"),
        3,
    ),
    "patch3d-Q1": (
        "patch3d",
        {"n_lower": 3, "n_upper": 4},
        "upper_bottom",
        "lower_top",
        ("upper", "lower"),
        3,
    ),
}


def _problem(case, integration="element", recovery="lumped", comm=MPI.COMM_WORLD):
    """The contact problem of CASES[case] with the given integration and recovery
    (collective on ``comm``)."""
    gen, params, slave, master, bodies, gdim = CASES[case] if isinstance(case, str) else case
    data = {
        "kinematics": "finite",
        "mesh": {"generator": gen, "params": params},
        "material": [{"region": b, "model": "neo-hookean", "E": 200.0, "nu": 0.3} for b in bodies],
        "contact": [
            {
                "slave": slave,
                "master": master,
                "penalty": 1.0e3,
                "uzawa_tol": 0.0,
                "integration": integration,
                "recovery": recovery,
            }
        ],
        "output": {"dir": "unused"},
    }
    problem, _ = prepare(parse_scene(data, __import__("pathlib").Path(".")), comm)
    return problem


def _set_state(problem, depth, slave_body):
    """Slave body: push down by `depth` (z or y) with a sideways shift and a non-uniform part;
    master body: a smooth non-affine deformation. The pairs count as loaded (a state in a
    step after contact was made, not a first contact: MortarContact.loaded)."""
    md = problem.mesh_data
    gdim = problem.gdim
    u = problem.u
    V = problem.V
    slave_cells = md.cell_tags.find(md.cell_groups[slave_body])

    def master_u(x):
        out = np.zeros((gdim, x.shape[1]))
        out[0] = 0.004 * x[0] + 0.002 * np.sin(2 * x[1])
        out[gdim - 1] = 0.003 * np.sin(1.3 * x[0]) - 0.001 * x[gdim - 1]
        if gdim == 3:
            out[1] = 0.002 * x[1] + 0.001 * np.cos(x[0])
        return out

    def slave_u(x):
        out = np.zeros((gdim, x.shape[1]))
        out[0] = 0.03 + 0.01 * np.sin(x[0]) + 0.002 * x[gdim - 1]
        out[gdim - 1] = -depth - 0.004 * x[0] ** 2
        if gdim == 3:
            out[1] = 0.02 + 0.005 * np.cos(x[1])
        return out

    u.interpolate(master_u)
    w = fem.Function(V)
    w.interpolate(slave_u, slave_cells)
    dofs = fem.locate_dofs_topological(V, problem.mesh.topology.dim, slave_cells)
    bs = V.dofmap.index_map_bs
    idx = (np.repeat(dofs * bs, bs) + np.tile(np.arange(bs), dofs.size)).astype(np.int64)
    u.x.array[idx] = w.x.array[idx]
    u.x.scatter_forward()
    for term in problem.contacts:
        term.loaded = True


def _residual(problem, term, vec_u):
    vec_u.copy(problem.u.vector)
    problem.u.x.scatter_forward()
    term.update(problem.u)
    b = problem.u.vector.copy()
    b.zeroEntries()
    term.add_residual(b)
    b.assemble()
    return b


#: seed of the directions of fd_errors (each call draws its own, reproducibly)
FD_SEED = 20261205


def fd_errors(problem, term, A, u0, n=3, h=1e-6, check=None, fixed=None):
    """Relative errors ‖K v − (R(u0 + h v) − R(u0 − h v))/2h‖ / ‖FD‖ for ``n`` random v
    (collective); ``check(term)`` runs after each perturbed residual; ``fixed``: owned
    local dofs where v is zero (Dirichlet dofs, whose columns K leaves out).

    The n directions are n successive draws of one generator made for this call on
    ``u0``'s communicator and seeded FD_SEED + rank (so they differ from each other, the
    ranks' parts differ from each other, and a run repeats its directions); it is
    destroyed at the end, as are the work vectors."""
    rng = PETSc.Random().create(u0.comm)
    rng.setSeed(FD_SEED + u0.comm.rank)
    errs = []
    try:
        for _ in range(n):
            v = u0.duplicate()
            v.setRandom(rng)
            v.scale(1e-2)
            if fixed is not None:
                v.array[fixed] = 0.0
            up = u0.copy()
            up.axpy(h, v)
            um = u0.copy()
            um.axpy(-h, v)
            fd = _residual(problem, term, up)
            if check is not None:
                check(term)
            rm = _residual(problem, term, um)
            if check is not None:
                check(term)
            fd.axpy(-1.0, rm)
            fd.scale(0.5 / h)
            assert fd.norm() > 0.0
            Jv = u0.duplicate()
            A.mult(v, Jv)
            Jv.axpy(-1.0, fd)
            errs.append(Jv.norm() / max(fd.norm(), 1e-300))
            for w in (v, up, um, fd, rm, Jv):
                w.destroy()
    finally:
        rng.destroy()
    return errs


PARAMS = (
    [(case, "element", "lumped") for case in CASES]
    + [
        ("hertz2d-P1", "node", "lumped"),
        ("hertz2d-Q1", "node", "lumped"),
        ("hertz3d-P1", "node", "lumped"),
        ("patch3d-Q1", "node", "lumped"),
    ]
    + [
        (case, "element", recovery)
        for case in ("hertz2d-P1", "hertz2d-P2", "hertz2d-Q1", "hertz3d-P1", "hertz3d-P2")
        for recovery in ("unconstrained", "constrained")
    ]
    # 2D segment integration with the lumped recovery: the moving segment ends are
    # linearised (contact._add_segment_jacobian); measured 1e-11 … 1e-9
    + [(case, "segment", "lumped") for case in ("hertz2d-P1", "hertz2d-P2", "hertz2d-Q1")]
    # ... and with the mixed recoveries, the variation of M, A and G with them
    + [
        (case, "segment", recovery)
        for case in ("hertz2d-P1", "hertz2d-P2", "hertz2d-Q1")
        for recovery in ("unconstrained", "constrained")
    ]
    # 3D segment integration: the vertices of the clipped polygons move with u
    + [(case, "segment", "lumped") for case in ("hertz3d-P1", "hertz3d-P2", "patch3d-Q1")]
    + [("hertz3d-P1", "segment", recovery) for recovery in ("unconstrained", "constrained")]
)


@exact_tangent
@pytest.mark.mpi
@pytest.mark.parametrize("case, integration, recovery", PARAMS)
def test_contact_tangent_matches_finite_differences(case, integration, recovery):
    problem = _problem(case, integration, recovery)
    term = problem.contacts[0]
    depth = {2: 0.05, 3: 0.04}[problem.gdim]
    _set_state(problem, depth, CASES[case][4][0])
    term.update(problem.u)
    # mid-Uzawa multipliers: some nodes active through λ, others through the penalty
    rng = np.random.default_rng(1 + MPI.COMM_WORLD.rank)
    term.lmbda = np.where(rng.random(term.lmbda.size) < 0.5, 0.2 * rng.random(term.lmbda.size), 0.0)
    u0 = problem.u.vector.copy()
    term.update(problem.u)
    nact = MPI.COMM_WORLD.allreduce(int((term.p > 0).sum()))
    assert nact >= 3, f"configuration should have several active nodes (got {nact})"
    assert term.predictor_nodes == 0
    if recovery != "lumped":
        # the tangent couples nodes through M⁻¹, not only node by node
        rec = term._recovered
        assert rec.tangent_nodes.size >= 3
        assert rec.right.nnz > 3 * rec.tangent_nodes.size
    A = problem.create_matrix()
    problem.contact_jacobian(A)
    errs = fd_errors(problem, term, A, u0)
    assert max(errs) < 1e-5, errs
    # symmetric exactly where the term says so (the solver factorizes LDLᵀ there); the
    # others measured 1e-4 (segment, lumped) to 0.3 (constrained) relative
    if term.symmetric_tangent:
        assert asymmetry(A) <= 1e-13, asymmetry(A)
    else:
        assert asymmetry(A) >= 1e-6, asymmetry(A)


#: tetrahedra whose contact triangles lie on each other's edge lines: the slave grid
#: (4 × 4 over [0, 1]²) is a subset of the master grid (6 × 6 over [-0.25, 1.25]²)
COINCIDENT_TET_PATCH = (
    "patch3d",
    {"n_lower": 6, "n_upper": 4, "margin": 0.25, "quads": False, "n_y": 1},
    "upper_bottom",
    "lower_top",
    ("upper", "lower"),
    3,
)


def _shifted_segment_fd_errors(case, shift):
    """FD errors of the segment tangent (lumped) of the 3D patch ``case`` with the slave
    body translated rigidly by ``shift`` and pressed in by 0.02 (random multipliers)."""
    problem = _problem(case, "segment", "lumped")
    md, V, u = problem.mesh_data, problem.V, problem.u
    cells = md.cell_tags.find(md.cell_groups["upper"])
    w = fem.Function(V)
    w.interpolate(lambda x: np.array([[shift[0]], [shift[1]], [-0.02]]) + 0.0 * x, cells)
    dofs = fem.locate_dofs_topological(V, problem.mesh.topology.dim, cells)
    bs = V.dofmap.index_map_bs
    idx = (np.repeat(dofs * bs, bs) + np.tile(np.arange(bs), dofs.size)).astype(np.int64)
    u.x.array[:] = 0.0
    u.x.array[idx] = w.x.array[idx]
    u.x.scatter_forward()
    term = problem.contacts[0]
    term.loaded = True
    term.update(u)
    rng = np.random.default_rng(1 + MPI.COMM_WORLD.rank)
    term.lmbda = np.where(rng.random(term.lmbda.size) < 0.5, 0.2 * rng.random(term.lmbda.size), 0.0)
    u0 = u.vector.copy()
    term.update(u)
    assert MPI.COMM_WORLD.allreduce(int((term.p > 0).sum())) >= 9
    A = problem.create_matrix()
    problem.contact_jacobian(A)
    return fd_errors(problem, term, A, u0, n=2)


@exact_tangent
@pytest.mark.mpi
@pytest.mark.parametrize("shift", [(0.0, 0.0), (1e-3, 0.0)])
def test_segment_tangent_where_triangle_edges_coincide(shift):
    """3D segment integration with triangle facets whose edges lie on master edges (slave
    translated rigidly by ``shift`` and pressed in: (0, 0) keeps every slave vertex on a
    master vertex, (1e-3, 0) the master vertices on the slave edges y = const). The
    residual is C¹ there (the master surface continues across every edge), so the tangent
    must match central differences; the clipped polygons' vertices at the slave corners
    and on the hypotenuses moved inconsistently before (errors 1.2e-1 and 5.5e-2)."""
    errs = _shifted_segment_fd_errors(COINCIDENT_TET_PATCH, shift)
    assert max(errs) < 1e-6, errs


#: the same tetrahedral patch with the bodies' footprints equal (4 × 4 over [0, 1]²)
EQUAL_TET_PATCH = (
    "patch3d",
    {"n_lower": 4, "n_upper": 4, "margin": 0.0, "quads": False, "n_y": 1},
    "upper_bottom",
    "lower_top",
    ("upper", "lower"),
    3,
)


@exact_tangent
@pytest.mark.mpi
def test_segment_tangent_where_master_boundary_vertices_lie_on_slave_edges():
    """Footprints equal, slave translated by (1e-3, -1e-3): the master boundary y = 0 and
    its vertices, the master's corner among them, lie on the slave hypotenuses
    x + y = const, inside the slave surface (the boundaries cross, they do not coincide:
    the residual is C¹). A vertex on a slave edge line used to slide orthogonally to it,
    right only where the master surface continues across the line: along a master
    boundary edge crossing the line obliquely the covered region moved (error 3.1e-2)."""
    errs = _shifted_segment_fd_errors(EQUAL_TET_PATCH, (1e-3, -1e-3))
    assert max(errs) < 1e-6, errs


@pytest.mark.mpi
def test_fd_errors_takes_n_different_directions():
    """fd_errors on a mock residual R(u) = u² (componentwise, K = diag(2 u0)): its n
    directions are different (each call made a fresh generator with PETSc's default seed
    in every pass, so all n were one vector: three equal errors), the ranks' parts of a
    direction differ, and a second call repeats the first's errors (seeded)."""
    from types import SimpleNamespace

    comm = MPI.COMM_WORLD
    u0 = PETSc.Vec().createMPI((5, PETSc.DECIDE), comm=comm)
    u0.array[:] = 1.0 + np.arange(5) + 5 * comm.rank
    seen = []

    def add_residual(b):
        b.array[:] += problem.u.vector.array**2

    problem = SimpleNamespace(
        u=SimpleNamespace(vector=u0.duplicate(), x=SimpleNamespace(scatter_forward=lambda: None))
    )
    term = SimpleNamespace(
        update=lambda u: seen.append(u.vector.array.copy()), add_residual=add_residual
    )
    K = PETSc.Mat().createAIJ(((5, None), (5, None)), nnz=(1, 0), comm=comm)
    lo = K.getOwnershipRange()[0]
    for i, ui in enumerate(u0.array):
        # a wrong entry on rank 0 makes the error depend on the direction
        K.setValue(lo + i, lo + i, 2.0 * ui + (1.0 if lo + i == 0 else 0.0))
    K.assemble()
    h = 1e-6
    errs = fd_errors(problem, term, K, u0, n=3, h=h)
    dirs = [(seen[k] - u0.array) / h for k in (0, 2, 4)]  # u0 + h v_k, then u0 − h v_k
    for k in range(3):
        assert np.allclose((u0.array - seen[2 * k + 1]) / h, dirs[k])
        for j in range(k):
            a = np.array(comm.allgather([dirs[k] @ dirs[j], dirs[k] @ dirs[k], dirs[j] @ dirs[j]]))
            assert a[:, 0].sum() < 0.99 * np.sqrt(a[:, 1].sum() * a[:, 2].sum())
    assert min(abs(errs[k] - errs[j]) for k in range(3) for j in range(k)) > 1e-3 * max(errs)
    parts = comm.allgather(dirs[0])
    assert all(not np.allclose(parts[r], parts[0]) for r in range(1, comm.size))
    assert fd_errors(problem, term, K, u0, n=3, h=h) == errs
    for obj in (u0, problem.u.vector, K):
        obj.destroy()


def asymmetry(A) -> float:
    """max |A − Aᵀ| / max |A| (collective)."""
    d = A.transpose(PETSc.Mat())
    d.axpy(-1.0, A)
    return d.norm(PETSc.NormType.INFINITY) / A.norm(PETSc.NormType.INFINITY)


@pytest.mark.mpi
def test_the_whole_jacobian_is_symmetric_with_conditions_on_slave_dofs():
    """The half hertz2d model of the parallel tests: a symmetry condition fixes u_x of
    the slave node on the axis. Bulk (K₀ with its Dirichlet rows and columns) plus contact is symmetric, so the
    Newton solver factorizes LDLᵀ; with friction it is not, and the solver keeps LU."""
    from test_contact_parallel import HERTZ2D

    from dolfinx_mortar.solver import NewtonSolver

    for mu in (0.0, 0.3):
        pair = {**HERTZ2D["contact"][0], "friction": mu}
        data = {**HERTZ2D, "contact": [pair], "output": {"dir": "unused"}}
        problem, _ = prepare(parse_scene(data, __import__("pathlib").Path(".")), MPI.COMM_WORLD)
        term = problem.contacts[0]
        if mu > 0.0:  # a slip history (u_n = 0.85 u): the nodes closed at t_n take friction
            _set_state(problem, 0.1, "cylinder")
            problem.u.x.array[:] *= 0.85
            problem.u.vector.copy(term._u_n)
            term._u_n_version += 1
        _set_state(problem, 0.1, "cylinder")
        problem.set_time(0.5)
        x = problem.u.vector.copy()
        problem.update_contact(x)
        assert MPI.COMM_WORLD.allreduce(int((term.p > 0).sum())) >= 3
        A = problem.create_matrix()
        problem.jacobian(x, A)
        assert problem.symmetric_jacobian == (mu == 0.0)
        if mu == 0.0:
            assert asymmetry(A) <= 1e-13, asymmetry(A)
        else:
            assert asymmetry(A) >= 1e-6, asymmetry(A)
        with NewtonSolver(problem) as newton:
            want = "cholesky" if mu == 0.0 else "lu"
            assert newton.snes.getKSP().getPC().getType() == want


@same_tangent_twice
@pytest.mark.mpi
@pytest.mark.parametrize("case", ["hertz2d-P1", "hertz3d-P1"])
def test_pattern_grows_before_the_values_go_in(case):
    """problem.jacobian / contact_jacobian (assembly.RecordedValues, MatrixPattern.grow):
    couplings of the unconstrained tangent (through M⁻¹, several node rings apart) that
    the matrix was not made for grow its pattern before any value is inserted, so PETSc
    never reallocates inside MatSetValues (a whole-matrix copy per overflowing row), and
    the values are those of a direct insertion."""
    problem = _problem(case, "element", "unconstrained")
    term = problem.contacts[0]
    _set_state(problem, {2: 0.05, 3: 0.04}[problem.gdim], CASES[case][4][0])
    term.update(problem.u)
    A = problem.create_matrix()  # no learned couplings yet: the mixed ones are new
    before = problem._pattern.key_set.size
    problem.contact_jacobian(A)
    comm = MPI.COMM_WORLD
    assert comm.allreduce(problem._pattern.key_set.size - before) > 0
    assert A.getInfo()["mallocs"] == 0
    direct = problem.create_matrix()
    direct.zeroEntries()
    term.add_jacobian(direct)  # straight into the matrix: PETSc reallocates as needed
    direct.assemble()
    direct.axpy(-1.0, A)
    assert direct.norm() <= 1e-13 * A.norm()
    # the full Jacobian on a matrix made before the couplings were learned: no
    # reallocation either, and the bulk part is there
    term._learned = np.empty(0, np.int64)
    J = problem.create_matrix()
    problem.jacobian(problem.u.vector, J)
    assert J.getInfo()["mallocs"] == 0
    assert J.norm() > A.norm()
    for mat in (A, direct, J):
        mat.destroy()


@same_tangent_twice
@pytest.mark.mpi
@pytest.mark.parametrize("case", ["hertz2d-P1", "hertz3d-P1"])
def test_a_growing_contact_zone_does_not_reallocate_inside_setvalues(case):
    """MatrixPattern.grow / RecordedValues.block_couplings: PETSc squeezes the slots of a
    matrix that its first final assembly did not fill, so a later Jacobian of the same
    matrix whose contact zone has grown (couplings among the candidates, not among the
    slots filled before) must grow the pattern before its values go in, or PETSc copies
    the whole matrix for every overflowing row (hertz3d: 1273 such copies in one matrix
    at 11k dofs, 16 s of contact assembly in an 84 s run at 53k dofs). The values are those of a fresh matrix,
    and a third Jacobian back at the first state adds nothing (the pattern only grows)."""
    problem = _problem(case, "element", "lumped")
    term = problem.contacts[0]
    body = CASES[case][4][0]
    depth = 0.02
    _set_state(problem, 4.0 * depth, body)  # the matrix is made for the wider zone
    term.update(problem.u)
    J = problem.create_matrix()
    _set_state(problem, depth, body)  # its first Jacobian fills a narrower one
    term.update(problem.u)
    problem.jacobian(problem.u.vector, J)
    active0 = MPI.COMM_WORLD.allreduce(int(term.active.sum()))
    _set_state(problem, 4.0 * depth, body)  # a wider contact zone
    term.update(problem.u)
    assert MPI.COMM_WORLD.allreduce(int(term.active.sum())) > active0
    assert not problem.pattern_outdated()  # the candidates the matrix was made for
    problem.jacobian(problem.u.vector, J)
    assert J.getInfo()["mallocs"] == 0
    fresh = problem.create_matrix()
    problem.jacobian(problem.u.vector, fresh)
    fresh.axpy(-1.0, J)
    assert fresh.norm() <= 1e-13 * J.norm()
    nnz = J.getInfo()["nz_used"]
    _set_state(problem, depth, body)
    term.update(problem.u)
    problem.jacobian(problem.u.vector, J)
    assert J.getInfo()["mallocs"] == 0
    assert J.getInfo()["nz_used"] == nnz
    for mat in (J, fresh):
        mat.destroy()


@same_tangent_twice
@pytest.mark.mpi
@pytest.mark.parametrize("case", ["hertz2d-P1", "hertz3d-P1"])
def test_a_jacobian_with_the_last_indices_reuses_their_couplings(case):
    """ContactProblem._recorded_couplings: a Jacobian whose recorded contact indices
    equal the last one's reuses its block couplings (the same array) instead of sorting
    them again, and gives the same matrix; a different contact zone finds its own
    couplings, equal to RecordedValues.block_couplings."""
    from dolfinx_mortar.assembly import RecordedValues

    problem = _problem(case, "element", "lumped")
    term = problem.contacts[0]
    body = CASES[case][4][0]
    _set_state(problem, 0.08, body)
    term.update(problem.u)
    J = problem.create_matrix()
    problem.jacobian(problem.u.vector, J)
    keys = problem._recorded_last[1]
    again = problem.create_matrix()
    problem.jacobian(problem.u.vector, again)
    assert problem._recorded_last[1] is keys
    again.axpy(-1.0, J)
    assert again.norm() <= 1e-14 * J.norm()
    _set_state(problem, 0.02, body)  # a narrower contact zone: other indices
    term.update(problem.u)
    problem.jacobian(problem.u.vector, J)
    values = RecordedValues()
    term.add_jacobian(values)
    fresh = values.block_couplings(problem._pattern.bs, problem._pattern.nblocks)
    assert np.array_equal(problem._recorded_last[1], fresh)
    changed = problem._recorded_last[1] is not keys
    assert MPI.COMM_WORLD.allreduce(int(changed)) > 0  # on the ranks that hold contact
    for mat in (J, again):
        mat.destroy()


@pytest.mark.mpi
def test_a_pair_that_carries_no_load_yet_is_a_first_contact():
    """MortarContact.first_contact, decided at a solve's first Jacobian, on a state with
    active nodes (the FD configuration hertz2d-P1, pressed 0.05): a first contact while
    the pair carries no load (no pressure committed, ``loaded``, and no multiplier), not
    once a multiplier is positive, even on one node of one rank, nor once a step with
    pressure is committed (``commit_step`` sets ``loaded`` on every rank, those without
    an active node included); with no active node, always one. The same on every rank."""
    comm = MPI.COMM_WORLD
    problem = _problem("hertz2d-P1", "element", "lumped")
    term = problem.contacts[0]
    _set_state(problem, 0.05, CASES["hertz2d-P1"][4][0])
    term.loaded = False
    term.update(problem.u)
    assert comm.allreduce(int((term.p_hat > 0.0).sum())) >= 3

    def first_contact() -> bool:
        term.begin_solve()
        problem.contact_jacobian(problem.create_matrix())
        decided = term.first_contact
        assert comm.allgather(decided) == [decided] * comm.size
        return decided

    assert first_contact()
    last = comm.allreduce(comm.rank if term.lmbda.size else -1, op=MPI.MAX)
    if comm.rank == last:
        term.lmbda[0] = 1e-3
    assert not first_contact()
    term.lmbda[:] = 0.0
    assert first_contact()
    term.commit_step()
    assert term.loaded
    assert not first_contact()
    problem.u.x.array[:] = 0.0  # the open reference configuration
    term.update(problem.u)
    assert comm.allreduce(int((term.p_hat > 0.0).sum())) == 0
    assert first_contact()


@pytest.mark.mpi
@pytest.mark.parametrize("integration", ["element", "segment"])
def test_deep_penetration_leaves_the_geometric_tangent_out_while_the_active_set_moves(
    monkeypatch, request, integration
):
    """tangential.DEEP_PENETRATION_TOL. The FD configuration hertz2d-P1 presses the cylinder
    more than 0.05 h_I into the block. The first Jacobian of a solve there leaves the
    geometric part out and does NOT match finite differences; the next Jacobian at the
    same active set is exact again (FD to 1e-5), as is the first one with the rule off.
    Element integration: what is left is the penalty part (ε/A) B⊗B alone, symmetric and
    positive semi-definite. Segment integration: the p-proportional terms of the moving
    segment ends are left out too (the first Jacobian differs from one that keeps them)."""
    comm = MPI.COMM_WORLD
    problem = _problem("hertz2d-P1", integration, "lumped")
    term = problem.contacts[0]
    _set_state(problem, 0.05, CASES["hertz2d-P1"][4][0])
    term.update(problem.u)
    u0 = problem.u.vector.copy()
    act = term.p_hat > 0.0
    depth = comm.allreduce(float(np.max(-term.gamma[act] / term.h_node[act], initial=0.0)), MPI.MAX)
    assert depth > DEEP_PENETRATION_TOL, depth

    def jacobian():
        A = problem.create_matrix()
        problem.contact_jacobian(A)
        return A

    term.begin_solve()
    first, second = jacobian(), jacobian()
    assert max(fd_errors(problem, term, first, u0, n=2)) > 1e-3
    assert max(fd_errors(problem, term, second, u0, n=2)) < 1e-5
    if integration == "segment":
        # the same first Jacobian, but with the segment-end terms of p kept
        keep = contact.MortarContact._add_segment_jacobian
        monkeypatch.setattr(
            contact.MortarContact,
            "_add_segment_jacobian",
            lambda self, *args: keep(self, *args[:-1], True),
        )
        term.begin_solve()
        kept = jacobian()
        kept.axpy(-1.0, first)
        assert kept.norm() > 1e-6 * first.norm()
        return
    request.getfixturevalue("exact_contact_tangent")
    term.begin_solve()
    assert max(fd_errors(problem, term, jacobian(), u0, n=2)) < 1e-5
    # the penalty part: symmetric, and v·K v >= 0
    assert first.isSymmetric(tol=1e-10 * first.norm())
    # five successive draws of one generator: five directions (on u0's communicator,
    # seeded per rank like fd_errors's)
    rng = PETSc.Random().create(u0.comm)
    rng.setSeed(FD_SEED + u0.comm.rank)
    for _ in range(5):
        v = u0.duplicate()
        v.setRandom(rng)
        Kv = v.duplicate()
        first.mult(v, Kv)
        assert v.dot(Kv) >= -1e-12 * first.norm() * v.norm() ** 2
        v.destroy()
        Kv.destroy()
    rng.destroy()


def _pin_neighbours(term, max_pins=6):
    """Pin up to ``max_pins`` paired quadrature points to a master facet next to their own
    (sharing a vertex) whose extended projection lies at most PIN_OUTSIDE_TOL outside it;
    returns the pinned (f, q) pairs (local)."""
    from dolfinx_mortar.contact import PIN_OUTSIDE_TOL
    from dolfinx_mortar.kernels import mortar as kmortar

    xm = term.xm
    term.qp_pinned = np.full_like(term.qp_m, -1)
    term._pin_exchange = term._exchanges
    pins = []
    for f, q in zip(*np.nonzero(term.qp_m >= 0), strict=True):
        m = term.qp_m[f, q]
        for m2 in range(xm.shape[0]):
            shared = np.isclose(xm[m][:, None, :], xm[m2][None, :, :]).all(axis=2).any()
            if m2 == m or not shared:
                continue
            qm = np.full_like(term.qp_m, -1)
            qm[f, q] = m2
            zeta, g = np.zeros_like(term.qp_zeta), np.zeros_like(term.qp_g)
            kmortar.forced_points(
                term.ftype,
                term.master.ftype,
                term.xs,
                term.qp_xi,
                qm,
                xm,
                term.master.sign,
                zeta,
                g,
            )
            if 0.0 < kmortar._outside(term.master.ftype, zeta[f, q]) <= PIN_OUTSIDE_TOL:
                term.qp_pinned[f, q] = m2
                pins.append((f, q))
                break
        if len(pins) == max_pins:
            break
    return pins


@exact_tangent
@pytest.mark.mpi
@pytest.mark.parametrize("case", ["hertz2d-P1", "hertz3d-P1"])
def test_pinned_points_keep_their_facet_and_an_exact_tangent(case):
    """Chattering control of the pairing: a quadrature point pinned to a neighbouring
    master facet is paired with it (its projection extended beyond the facet's edge) at
    every update of the solve, and the tangent stays exact with it."""
    problem = _problem(case, "element", "lumped")
    term = problem.contacts[0]
    _set_state(problem, {2: 0.05, 3: 0.04}[problem.gdim], CASES[case][4][0])
    term.update(problem.u)
    u0 = problem.u.vector.copy()
    pins = _pin_neighbours(term)
    assert MPI.COMM_WORLD.allreduce(len(pins)) >= 2
    free = term.qp_m.copy()
    term.update(problem.u)
    for f, q in pins:
        assert term.qp_m[f, q] == term.qp_pinned[f, q] != free[f, q]
    A = problem.create_matrix()
    problem.contact_jacobian(A)
    errs = fd_errors(problem, term, A, u0, check=lambda t: None)
    for f, q in pins:  # still pinned after the perturbed updates
        assert term.qp_m[f, q] == term.qp_pinned[f, q]
    assert max(errs) < 1e-5, errs
    term.begin_solve()
    assert term.qp_pinned is None


def _pinned_at_own_and_neighbour_facets():
    """hertz2d-P1 (element, lumped) pressed by 0.05 with the case's slide, its points
    paired, then pinned: some beyond a neighbour facet's edge (:func:`_pin_neighbours`),
    the rest at their own facet (inside it). Returns (problem, term, own, neighbour): the
    two pinned sets as (nsf, nq) masks (collective)."""
    problem = _problem("hertz2d-P1", "element", "lumped")
    term = problem.contacts[0]
    _set_state(problem, 0.05, CASES["hertz2d-P1"][4][0])
    term.update(problem.u)
    own = term.qp_m >= 0  # at its own facet: inside it
    pins = _pin_neighbours(term)  # beyond a neighbour's edge
    assert problem.comm.allreduce(len(pins)) >= 2
    neighbour = term.qp_pinned >= 0
    own &= ~neighbour
    term.qp_pinned[own] = term.qp_m[own]
    return problem, term, own, neighbour


@pytest.mark.mpi
def test_points_that_switched_back_start_the_next_solve_pinned_at_their_edge():
    """uzawa.PIN_CARRY_TOL: at the end of a solve (uzawa_update), a point pinned for
    switching back whose projection lies within PIN_CARRY_TOL of its pinned facet stays
    pinned in the next solve of the load step; a point pinned beyond that, or pinned by
    HOLD_AFTER inside its facet, starts free; a new load step starts with no pin."""
    from dolfinx_mortar.kernels import mortar as kmortar
    from dolfinx_mortar.uzawa import PIN_CARRY_TOL

    comm = MPI.COMM_WORLD
    problem, term, own, neighbour = _pinned_at_own_and_neighbour_facets()
    hold = own & (np.arange(own.size).reshape(own.shape) % 2 == 0)  # pinned by HOLD_AFTER
    term.qp_flip = (term.qp_pinned >= 0) & ~hold
    term.update(problem.u)
    pinned = term.qp_pinned >= 0
    assert np.array_equal(term.qp_m[pinned], term.qp_pinned[pinned])
    outside = np.array([kmortar._outside(term.master.ftype, z) for z in term.qp_zeta[pinned]])
    near = np.zeros_like(pinned)
    near[pinned] = outside <= PIN_CARRY_TOL
    keep = near & term.qp_flip
    assert np.all(keep[own & ~hold]) and not np.any(keep[hold])
    assert comm.allreduce(int((neighbour & ~keep).sum())) >= 1
    _, info = term.uzawa_update()
    assert info["carried_pins"] == comm.allreduce(int(keep.sum())) > 0
    term.begin_solve()
    assert np.array_equal(term.qp_pinned, np.where(keep, term.qp_m, -1))
    term.update(problem.u)
    assert np.array_equal(term.qp_m[keep], term.qp_pinned[keep])
    term.begin_step()
    term.begin_solve()
    assert term.qp_pinned is None


@pytest.mark.mpi
def test_points_held_beyond_their_facets_edge_start_the_next_solve_pinned(monkeypatch):
    """uzawa.PIN_CARRY_TOL for the points pinned by HOLD_AFTER (session 53): one whose
    converged projection lies beyond its pinned facet's edge, at most PIN_CARRY_TOL
    outside, starts the next solve of the load step pinned (it sits on a master vertex
    that the free pairing crosses back and forth: hertz2d with 128 load steps crawled for
    13 + 15 Newton iterations there); one inside its facet, or further outside, starts
    free."""
    from dolfinx_mortar.kernels import mortar as kmortar

    comm = MPI.COMM_WORLD
    problem, term, own, neighbour = _pinned_at_own_and_neighbour_facets()
    term.qp_flip = np.zeros(own.shape, bool)  # every pin from HOLD_AFTER, none switched back
    term.update(problem.u)
    pinned = term.qp_pinned >= 0
    assert np.array_equal(term.qp_m[pinned], term.qp_pinned[pinned])
    outside = np.zeros(own.shape)
    outside[pinned] = [kmortar._outside(term.master.ftype, z) for z in term.qp_zeta[pinned]]
    assert np.all(outside[own] <= 0.0) and np.all(outside[neighbour] > 0.0)
    # a tolerance between the two smallest distances beyond an edge: some carried, some not
    beyond = np.unique(np.concatenate(comm.allgather(outside[neighbour])))
    assert beyond.size >= 2
    tol = 0.5 * (beyond[0] + beyond[1])
    monkeypatch.setattr(uzawa, "PIN_CARRY_TOL", tol)
    keep = neighbour & (outside <= tol)
    assert comm.allreduce(int(keep.sum())) >= 1
    assert comm.allreduce(int((neighbour & ~keep).sum())) >= 1
    assert comm.allreduce(int(own.sum())) >= 1
    _, info = term.uzawa_update()
    assert info["carried_pins"] == comm.allreduce(int(keep.sum()))
    term.begin_solve()
    assert np.array_equal(term.qp_pinned, np.where(keep, term.qp_m, -1))
    term.update(problem.u)
    assert np.array_equal(term.qp_m[keep], term.qp_pinned[keep])


@pytest.mark.mpi
def test_a_rank_without_pins_follows_the_carried_pins():
    """uzawa_update where one rank's term has no pinning state (qp_pinned and qp_flip
    None, as on a rank without slave facets) while the others carry pins: every rank
    takes part in the collectives (no error on any rank, the same counts), the bare rank
    carries nothing, and its next solve starts with no pin. Session 22's review hung the
    2-rank suite here: an in-place ``&=`` with qp_flip None raised on one rank only."""
    comm = MPI.COMM_WORLD
    problem = _problem("hertz2d-P1", "element", "lumped")
    term = problem.contacts[0]
    _set_state(problem, 0.05, CASES["hertz2d-P1"][4][0])
    term.update(problem.u)
    # the bare rank: the one with the fewest paired points (the partition may put them
    # all on one rank), none on one rank
    counts = comm.allgather(int((term.qp_m >= 0).sum()))
    bare = comm.size > 1 and comm.rank == min(range(comm.size), key=lambda r: (counts[r], -r))
    if bare:
        term.qp_pinned = term.qp_flip = None
    else:  # every paired point pinned to its own facet (inside it), as switched back
        term.qp_pinned = term.qp_m.copy()
        term.qp_flip = term.qp_pinned >= 0
        term._pin_exchange = term._exchanges
    term.update(problem.u)
    expected = comm.allreduce(0 if bare else int((term.qp_m >= 0).sum()))
    assert expected > 0
    _, info = term.uzawa_update()
    assert info["carried_pins"] == expected
    assert term._carried_pins.shape == term.qp_m.shape
    term.begin_solve()
    if bare:
        assert term.qp_pinned is None or not np.any(term.qp_pinned >= 0)
    else:
        assert np.array_equal(term.qp_pinned, term.qp_m)


def test_a_point_switching_back_is_pinned():
    """From the FREEZE_AFTER-th Jacobian on, a point whose facet went A → B → A is pinned
    to A (also when B is "none", −1); a point that moved on (A → B → C) is not."""
    from dolfinx_mortar.contact import FREEZE_AFTER

    problem = _problem("hertz2d-P1", "element", "lumped", MPI.COMM_SELF)  # local logic
    term = problem.contacts[0]
    term.update(problem.u)
    shape = term.qp_m.shape
    a = np.zeros(shape, np.int64)
    b, c = a.copy(), a.copy()
    b.flat[0], b.flat[1], b.flat[2] = 5, -1, 7
    c.flat[2] = 9
    term._pin_exchange = term._exchanges
    term._pair_jacobians = FREEZE_AFTER - 3
    for m in (a, b, c):
        term.qp_m = m
        term._watch_pairing()
    assert term.qp_pinned.flat[0] == 0 and term.qp_pinned.flat[1] == 0
    assert term.qp_pinned.flat[2] == -1
    assert np.count_nonzero(term.qp_pinned >= 0) == 2


def test_every_paired_point_is_pinned_from_hold_after():
    """From the HOLD_AFTER-th Jacobian on (when the contact set is held too) every paired
    point keeps its facet; unpaired points (−1) stay free."""
    from dolfinx_mortar.contact import HOLD_AFTER

    problem = _problem("hertz2d-P1", "element", "lumped", MPI.COMM_SELF)  # local logic
    term = problem.contacts[0]
    term.update(problem.u)
    m = np.arange(term.qp_m.size, dtype=np.int64).reshape(term.qp_m.shape) % 5
    m.flat[3] = -1
    term._pin_exchange = term._exchanges
    term._pair_jacobians = HOLD_AFTER - 3
    for _k in range(2):  # the (HOLD_AFTER − 2)-th and (HOLD_AFTER − 1)-th Jacobian
        term.qp_m = m.copy()
        term._watch_pairing()
        assert term.qp_pinned is None or not np.any(term.qp_pinned >= 0)
    term.qp_m = m.copy()
    term._watch_pairing()
    assert np.array_equal(term.qp_pinned, np.where(m >= 0, m, -1))


@pytest.mark.mpi
def test_the_held_contact_set_keeps_nodes_in_tension_until_the_recheck(request):
    """Chattering control of the lumped contact set (contact.HOLD_AFTER): a node in
    contact at a Jacobian from the HOLD_AFTER-th of a solve on stays in contact when a
    later iterate opens it, with p = λ − εγ < 0 and an exact tangent, while the law's
    pressure p̂ stays ⟨λ − εγ⟩ = 0; a node in contact at an earlier Jacobian only is not
    held. uzawa_update counts a held node in tension as a changed state
    (``released_nodes``) and does not accept the round; the next solve starts free."""
    request.getfixturevalue("exact_contact_tangent")  # exact tangents only
    comm = MPI.COMM_WORLD
    problem = _problem("hertz2d-P1", "element", "lumped")
    term = problem.contacts[0]
    body = CASES["hertz2d-P1"][4][0]

    def jacobian_at(depth):
        _set_state(problem, depth, body)
        term.update(problem.u)
        problem.contact_jacobian(problem.create_matrix())
        return term.p_hat > 0.0

    def held_set():
        return term.held if term.held is not None else np.zeros_like(term.active)

    term.begin_solve()
    term.hold_after = 2
    deep = jacobian_at(0.05)
    assert term.held is None
    shallow = jacobian_at(0.035)  # from the 2nd Jacobian on, the contact set is held
    assert comm.allreduce(int((deep & ~shallow).sum())) >= 1  # in contact at the 1st only
    assert np.array_equal(held_set(), shallow)
    jacobian_at(0.05)
    assert np.array_equal(held_set(), deep)
    _set_state(problem, 0.035, body)  # shallower: the free law opens held nodes
    term.update(problem.u)
    opened = held_set() & (term.p_hat == 0.0)
    n_opened = comm.allreduce(int(opened.sum()))
    assert n_opened >= 1
    assert np.all(term.p[opened] < 0.0) and np.all(term.kcoef[opened] > 0.0)
    assert np.array_equal(term.p[~opened], term.p_hat[~opened])
    u0 = problem.u.vector.copy()
    A = problem.create_matrix()
    problem.contact_jacobian(A)
    errs = fd_errors(problem, term, A, u0, n=2)
    assert max(errs) < 1e-5, errs
    term.update(problem.u)
    term.uzawa_tol = 1e-12
    done, info = term.uzawa_update()
    assert not done and info["released_nodes"] == n_opened
    term.begin_solve()
    term.update(problem.u)
    assert np.all(term.p[opened] == 0.0) and np.all(term.kcoef[opened] == 0.0)


@pytest.mark.mpi
def test_block_couplings_are_remembered_until_their_inputs_change():
    """``MortarContact.block_couplings`` returns its last result, the same object, while
    the candidates, the master layer and the learned couplings are those it was computed
    from (every Newton solve asks, to check the matrix pattern), and computes afresh, the
    same as without the memo, once they change; ``pattern_outdated`` is then False for the
    matrix made from them without comparing keys (1–3 ranks)."""
    comm = MPI.COMM_WORLD

    def everywhere(flag):  # local checks decided together: no rank leaves a collective
        return comm.allreduce(int(bool(flag)), op=MPI.MIN) == 1

    problem = _problem("hertz2d-P1")
    term = problem.contacts[0]
    _set_state(problem, 0.05, "cylinder")
    term.update(problem.u)
    first = term.block_couplings()
    assert everywhere(term.block_couplings() is first)
    term.update(problem.u)  # new candidate arrays, the same values
    assert everywhere(term.block_couplings() is first)
    A = problem.create_matrix()
    assert not problem.pattern_outdated()
    _set_state(problem, 0.4, "cylinder")  # deeper: other candidates
    term.update(problem.u)
    now = term.block_couplings()
    has = term.slave.num_facets > 0 and term.node_blocks.size > 0
    assert comm.allreduce(int(now is not first), op=MPI.MAX) == 1
    if has:
        fresh = term._block_couplings(term.slave.num_facets, [(term.cand_off, term.cand)])
    same = not has or all(np.array_equal(a, b) for a, b in zip(now, fresh, strict=True))
    assert everywhere(same)
    keys = problem._contact_couplings()
    missing = comm.allreduce(int(not np.isin(keys, problem._pattern_keys).all()), op=MPI.MAX)
    assert missing == 1 and problem.pattern_outdated()
    A.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("case", ["hertz2d-P1", "hertz3d-P1"])
def test_the_coupling_cover_decides_the_pattern_check(case, monkeypatch):
    """``ContactProblem.pattern_outdated`` first compares the terms' coupling covers
    (slave facet × master block of the candidates, and the learned couplings): a cover
    that is a subset of the matrix's proves its couplings are held, without building and
    comparing the couplings. Checked on five pressed states (1–3 ranks): wherever one
    cover is a subset of another's, so are the couplings, and then the covers alone
    settle the check; a cover that proves nothing falls back to the keys and is then
    replaced by one that does; couplings the matrix lacks make it outdated."""
    comm = MPI.COMM_WORLD
    problem = _problem(case)
    term = problem.contacts[0]

    def state(depth):
        _set_state(problem, depth, CASES[case][4][0])
        term.update(problem.u)
        return term.coupling_cover(), problem._contact_couplings()

    def subset(small, big):  # on every rank
        ok = np.isin(small, big).all()
        return comm.allreduce(int(ok), op=MPI.MIN) == 1

    depths = (0.05, 0.25, 0.02, 0.4, 0.1)
    seen = [state(d) for d in depths]
    covered = []  # (i, j): the cover at depths[i] is a subset of the one at depths[j]
    for i, (cov_a, keys_a) in enumerate(seen):
        for j, (cov_b, keys_b) in enumerate(seen):
            if i != j and subset(cov_a[0], cov_b[0]) and subset(cov_a[1], cov_b[1]):
                covered.append((i, j))
                assert subset(keys_a, keys_b)
    assert covered

    full = []
    original = problem._contact_couplings
    monkeypatch.setattr(problem, "_contact_couplings", lambda: full.append(1) or original())
    i, j = covered[0]
    state(depths[j])
    A = problem.create_matrix()
    held = problem._pattern_keys
    full.clear()
    _, keys = state(depths[i])
    assert not problem.pattern_outdated() and subset(keys, held)
    assert comm.allreduce(len(full), op=MPI.MAX) == 1  # only state()'s own call
    full.clear()
    problem._pattern_cover = [(np.empty(0, np.int64), np.empty(0, np.int64))]
    assert not problem.pattern_outdated()  # the keys decide (where the cover is not empty)
    assert comm.allreduce(len(full), op=MPI.MAX) == 1
    assert np.array_equal(problem._pattern_cover[0][0], term.coupling_cover()[0])
    outdated = [k for k, (_, keys) in enumerate(seen) if not subset(keys, held)]
    assert outdated
    state(depths[outdated[0]])  # new couplings
    assert problem.pattern_outdated()
    A.destroy()


def test_unique_runs_equals_np_unique():
    """``assembly.unique_runs`` (a stable sort that merges sorted runs, then the repeats
    dropped) gives ``np.unique``'s result: runs with repeats across them, one run, empty."""
    from dolfinx_mortar.assembly import unique_runs

    rng = np.random.default_rng(3)
    runs = np.concatenate([np.sort(rng.integers(0, 500, 40)) for _ in range(30)])
    for keys in (runs, np.sort(rng.integers(0, 50, 100)), np.empty(0, np.int64)):
        assert np.array_equal(unique_runs(keys.copy()), np.unique(keys))


#: a small frictional press of the patch2d generator (quads, segment integration)
FRICTIONAL_PATCH = {
    "kinematics": "finite",
    "mesh": {
        "generator": "patch2d",
        "params": {"L": 1.0, "H": 0.5, "n_lower": 8, "n_upper": 5, "n_y": 2, "quads": True},
    },
    "material": [
        {"region": r, "model": "neo-hookean", "E": 100.0, "nu": 0.3} for r in ("lower", "upper")
    ],
    "contact": [
        {
            "slave": "upper_bottom",
            "master": "lower_top",
            "integration": "segment",
            "friction": 0.3,
        }
    ],
    "dirichlet": [
        {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
        # pressed at t = 1, then slid by SHIFT at t = 2
        {"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.02, -0.02]]},
    ],
    "steps": {"t_end": 1.0, "n": 1},
}


def test_residual_and_jacobian_are_evaluated_at_x(tmp_path, request):
    """ContactProblem.residual(x) and jacobian(x) evaluate at x, whatever state the
    contact terms were last updated at (they were evaluated at the last update: the
    Jacobian differed by 41 % from J(x) on a slide), and the Jacobian is the derivative
    of the residual, through the public API alone: a press step solved by the runner,
    then a state of the next step, the slave body slid by SHIFT with stick and slip
    nodes, and a perturbation of the free dofs."""
    from dolfinx_mortar.runner import run

    shift = 4e-3
    data = copy.deepcopy(FRICTIONAL_PATCH)
    data["dirichlet"][1]["path"].append([2.0, 0.02 + shift, -0.02])
    data["output"] = {"dir": str(tmp_path)}
    held = []
    summary = run(parse_scene(data, tmp_path), MPI.COMM_SELF, setup=held.append)
    assert summary["status"] == "ok", summary["error"]
    problem = held[0]
    # the press above ran with the shipped settings; the comparisons below take the
    # exact tangent (the fixture exact_contact_tangent, from here on)
    request.getfixturevalue("exact_contact_tangent")
    try:
        term = problem.contacts[0]
        md, V = problem.mesh_data, problem.V
        upper = md.cell_tags.find(md.cell_groups["upper"])
        blocks = fem.locate_dofs_topological(V, problem.mesh.topology.dim, upper)
        n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        fixed = problem.dirichlet_scale()[0]
        problem.begin_step()
        problem.set_time(2.0)
        rng = np.random.default_rng(3)
        x1 = problem.u.vector.copy()
        x = x1.array
        x[blocks[blocks * 2 < n] * 2] += shift  # the slave body slid along x (bs = 2)
        pert = 1e-3 * rng.standard_normal(n)
        pert[fixed] = 0.0  # the constrained dofs at their values (x_c = ū_c)
        x += pert
        x0 = x1.duplicate()
        x0.set(0.0)
        A_at, A_ref = problem.create_matrix(), problem.create_matrix()
        b_at, b_ref = x1.duplicate(), x1.duplicate()
        # evaluated at x1 after an update at x0, against an explicit update at x1
        problem.begin_solve()
        problem.update_contact(x0)
        problem.jacobian(x1, A_at)
        problem.update_contact(x0)
        problem.residual(x1, b_at)
        states = term.fstate.copy()
        problem.begin_solve()
        problem.update_contact(x1)
        problem.jacobian(x1, A_ref)
        problem.residual(x1, b_ref)
        assert np.count_nonzero(states == 1) and np.count_nonzero(states == 2), states
        A_at.axpy(-1.0, A_ref)
        assert A_at.norm() == 0.0
        b_at.axpy(-1.0, b_ref)
        assert b_at.norm() == 0.0
        # central differences of residual(x) along free directions against J v
        h = 1e-7
        xp, rp, rm, Jv, v = (x1.duplicate() for _ in range(5))
        for _ in range(3):
            v.array[:] = rng.standard_normal(n)
            v.array[fixed] = 0.0
            for sign, r in ((1.0, rp), (-1.0, rm)):
                x1.copy(xp)
                xp.axpy(sign * h, v)
                problem.residual(xp, r)
            rp.axpy(-1.0, rm)
            rp.scale(0.5 / h)
            A_ref.mult(v, Jv)
            rp.axpy(-1.0, Jv)
            assert rp.norm() <= 1e-8 * Jv.norm(), rp.norm() / Jv.norm()
        for obj in (A_at, A_ref, b_at, b_ref, x0, x1, xp, rp, rm, Jv, v):
            obj.destroy()
    finally:
        problem.destroy()
